//! The simulated rig: what the MiL controller meets before it meets hardware.
//!
//! - [`actuator`]: the nonlinear force-controlled servo-hydraulic actuator (servovalve with
//!   spool saturation, orifice flow, chamber compressibility, friction, load cell and its
//!   analogue force loop, supply pressure), which linearises to
//!   [`mil_params::ServoHydraulicActuator`]'s `p_f(s)`, `r_f(s)`.
//! - [`specimen`]: mass-spring-damper specimens (the paper's quarter car and half car, or
//!   any other) made of DOFs and force elements, with the actuators' attachment points. An
//!   element's law and effects are `mil-structure`'s ([`mil_structure::Element`]), the
//!   vocabulary and laws diagnosis fits.
//! - [`plant`]: a specimen driven by the actuators (the MiL rig) or by an ideal interface
//!   (the emulated system), integrated by fixed-step RK4.
//! - [`sensors`] and [`link`]: measurement noise, quantisation and bandwidth; the CAN link
//!   as a per-sample delay with fixed-point scaling and optional dropped or corrupted frames.
//! - [`harness`]: model-core's controller step against the rig and the emulated system.
//! - [`experiment`]: the whole MiL experiment (board, rig, emulated system) in one call.
//! - [`rigs`]: the paper's rigs assembled: the tyre and aero examples (the aero speed
//!   constant or following a speed input), and any mass-spring-damper specimen coupled to
//!   model-core's general substructure model.
//! - [`metrics`]: MiL-vs-emulated error figures (J1–J3 of the real-time hybrid simulation
//!   benchmark).
//!
//! SI units throughout; positions and forces up positive.

/// The default RK4 step of the plants (s): 100 µs, checked against a 2 µs reference
/// integration in `tests/tyre_rig.rs` (load-cell force within 1e-4 of its variation).
pub const DEFAULT_INTERNAL_STEP_S: f64 = 100e-6;

pub mod actuator;
pub mod actuator_test;
pub mod experiment;
pub mod harness;
pub mod link;
pub mod metrics;
pub mod plant;
pub mod rigs;
pub mod sensors;
pub mod specimen;
