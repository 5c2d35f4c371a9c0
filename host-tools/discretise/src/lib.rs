//! # mil-discretise
//!
//! Host-side (`std`, `f64`) discretisation of continuous linear models into the `f32`
//! coefficients that the `no_std` [`model_core`] crate runs: delta-form second-order
//! sections ([`model_core::BiquadCoefficients`], [`model_core::CascadeCoefficients`]) and
//! delta-form state space ([`model_core::DeltaStateSpaceCoefficients`]).
//!
//! Units: SI; frequencies in Hz unless stated (the Laplace variable `s` and roots in `s` are
//! in rad/s); the sample period `dt` in s.
//!
//! ## Why everything goes through `1 - z`
//! model-core stores `α1 = (1-p1) + (1-p2)`, `α2 = (1-p1)(1-p2)` instead of `a1`, `a2`.
//! These numbers are tiny for slow modes (a 1 Hz mode at 5 kHz: `α2 ≈ 1.6e-6`) and would be
//! ruined by forming `p ≈ 1` first and subtracting. This crate therefore computes `1 - z`
//! for every discrete root directly from the continuous root (`-expm1(p dt)` for
//! zero-order hold, `-s dt/(1 - s dt/2)` for Tustin), `Φ - I` directly from a scaling and
//! squaring of `e^{A dt} - I`, and evaluates discrete responses at `q = e^{jωT} - 1`.
//!
//! ## Overview
//! - Continuous models: [`TransferFunction`], [`Zpk`], [`StateSpace`].
//! - Discretisation: [`tustin`], [`tustin_tf`], [`tustin_ss`], [`zoh`], [`zoh_tf`], [`zoh_ss`].
//! - Discrete models: [`DiscreteZpk`] (→ [`DiscreteZpk::to_sections`],
//!   [`DiscreteZpk::to_cascade`]), [`DiscreteStateSpace`] (→ [`to_delta_state_space`]).
//! - Checking: [`cascade_response`], [`simulate_cascade`], the `response` methods.

pub mod continuous;
pub mod discrete;
pub mod error;
pub mod methods;
mod pairing;
pub mod poly;

pub use continuous::{StateSpace, TransferFunction, Zpk};
pub use discrete::{
    cascade_response, delta_operator_point, simulate_cascade, to_delta_state_space, DiscreteRoot,
    DiscreteStateSpace, DiscreteZpk,
};
pub use error::{DiscretiseError, Result};
pub use methods::{expm_minus_identity, tustin, tustin_ss, tustin_tf, zoh, zoh_ss, zoh_tf};
pub use poly::{polynomial_roots, polyval};
