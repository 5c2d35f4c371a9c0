//! # model-core
//!
//! The real-time part of the model-in-the-loop (MiL) rig controller: fixed-step numerical
//! models (tyre, aerodynamic, general mass-spring-damper substructure), the actuator command
//! filter, demand limits and one [`Controller::step`] that the firmware's interrupt task and
//! every host test call unchanged.
//!
//! Rules this crate keeps:
//! - `no_std`, no heap, no `unsafe`; `f32` at run time.
//! - No panics in the step path: no `unwrap`, no indexing that can fail, no division that can
//!   produce a non-finite value reaching the output. Any non-finite input or internal value
//!   puts the controller into a latched fault and the demand ramps to the configured safe value.
//! - Coefficients live apart from state ([`BiquadCoefficients`] vs [`BiquadState`], parameter
//!   sets vs model state) so a validated parameter set can be swapped in between two steps.
//! - Units are SI unless a doc comment says otherwise.
//!
//! The recursions use the *delta operator* form (see [`biquad`]): coefficients are stored as
//! deviations from the `z = 1` point, so a 1 Hz mode sampled at 5 kHz keeps full `f32`
//! relative precision instead of losing it in `a1 ≈ -2`.
#![no_std]
#![forbid(unsafe_code)]
#![deny(missing_docs)]
#![cfg_attr(
    not(test),
    deny(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing)
)]

pub mod aero;
pub mod biquad;
pub mod board;
pub mod controller;
pub mod element;
pub mod limits;
pub mod linalg;
pub mod page;
pub mod params;
pub mod state_space;
pub mod substructure;
pub mod tyre;
pub mod velocity;

pub use aero::{AeroModel, AeroParams, AeroPrepared, RideHeightMap};
pub use biquad::{
    BiquadCoefficients, BiquadState, Cascade, CascadeCoefficients, CascadeState, POLE_MARGIN,
};
pub use board::{BoardController, BoardParams, BoardPrepared, ModelKind, BOARD_CHANNELS};
pub use controller::{
    fault, Controller, ControllerParams, Mode, Model, ModelInput, PreparedParams, Status,
    BUMPLESS_FADE_S,
};
pub use element::ElementLaw;
pub use limits::{DemandLimits, RateLimiter};
pub use params::{ParamError, Range};
pub use state_space::{DeltaStateSpace, DeltaStateSpaceCoefficients};
pub use substructure::{
    Causality, InterfaceParams, SubstructureElement, SubstructureModel, SubstructureParams,
    MAX_DOF, MAX_ELEMENTS,
};
pub use tyre::{TyreModel, TyreModelParams, TyreParams};
pub use velocity::{VelocityEstimator, VelocityFilterCoefficients};

/// Largest number of second-order sections in one channel's command filter cascade.
pub const MAX_SECTIONS: usize = 4;

/// Largest number of actuator channels one controller serves (status bit masks are `u8`).
pub const MAX_CHANNELS: usize = 8;
