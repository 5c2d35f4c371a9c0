//! # mil-analysis
//!
//! Frequency-domain analysis of model-in-the-loop (MiL) set-ups in `f64`, following
//! A. R. Plummer, "Model-in-the-loop testing" (2006), section 2: the emulated system (the
//! ideal coupling of numerical and physical part) against the MiL system (actuator tracking
//! and disturbance responses, loop delay, command filter, measurement noise), for all four
//! configurations (interface impedance `B_i` in the physical or numerical part × position
//! or force control).
//!
//! - [`system`]: the framework at one frequency ([`MilSystem::point`]).
//! - [`metrics`]: grids, margins, resonances, band errors.
//! - [`reference_actuator`]: the force-controlled servo-hydraulic actuator's responses.
//! - [`position_servo`]: the position-controlled servo-hydraulic actuator's responses.
//! - [`examples`]: the paper's tyre, aero and 2-DOF set-ups as linear structures.
//!
//! The parameter sets themselves (the examples', the actuators') live in `mil-params`.
//! - [`response`]: responses from models or measured tables; the command filter.
//!
//! Units: SI; frequencies in Hz; phases in degrees; the Laplace variable in rad/s.

pub mod analyze;
pub mod design;
pub mod error;
pub mod examples;
pub mod filter_file;
pub mod measured;
pub mod metrics;
pub mod poly;
pub mod position_servo;
pub mod reference_actuator;
pub mod response;
pub mod setup;
pub mod system;

pub use error::{AnalysisError, Result};
pub use metrics::Stability;
pub use response::{CommandFilter, LinearActuator, ResponseSource};
pub use system::{
    ActuatorControl, Actuators, ImpedanceLocation, Interface, Loop, LoopDescription, LoopPoint,
    MechanicalPart, MilSystem, VelocityEstimate,
};
