//! # mil-params
//!
//! Parameter sets as plain data, low in the crate graph so that every tool reads the same
//! values from one place: the paper's examples ([`TyreExample`], [`AeroExample`],
//! [`TwoDofExample`]) and the reference servo-hydraulic actuators
//! ([`ServoHydraulicActuator`], [`PositionServoActuator`]).
//!
//! What the sets mean is built elsewhere: their linear structures and actuator responses in
//! `mil-analysis`, their simulated specimens and actuators in `mil-rig`. Here they are
//! values, their physical ranges ([`ServoHydraulicActuator::validate`]) and the few
//! quantities derived from the values alone.
//!
//! Units: SI; frequencies in Hz.

pub mod actuators;
pub mod examples;

pub use actuators::{PositionServoActuator, ServoHydraulicActuator};
pub use examples::{AeroExample, TwoDofExample, TyreExample, TyreVelocity};

/// A parameter outside its physical range; the message names the field and its value.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{0}")]
pub struct ParamError(pub String);
