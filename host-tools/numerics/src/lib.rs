//! # mil-numerics
//!
//! The numerics the host tools share, one implementation each, low in the crate graph (it
//! depends on nothing of the project): the analysis, the simulated rig, identification and
//! diagnosis all call these instead of keeping their own.
//!
//! - [`rng`]: SplitMix64, the seeded generator of every reproducible noise (the rig's sensor
//!   and link noise, identification's excitations, the tests' synthetic records).
//! - [`filter`]: Butterworth low-pass sections (bilinear, pre-warped), causal or zero-phase:
//!   the rig's in-band comparisons, the generated road noise, diagnosis' differentiation
//!   filters.
//! - [`record`]: the CSV reader of every record and table (comma, semicolon or tab; units in
//!   the header; decimal commas; comment lines) and the one time-base rule.

pub mod filter;
pub mod record;
pub mod rng;
