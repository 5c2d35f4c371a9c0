//! # mil-numerics
//!
//! The numerics the host tools share, one implementation each, low in the crate graph (it
//! depends on nothing of the project): the analysis, the simulated rig, identification and
//! diagnosis all call these instead of keeping their own.
//!
//! - [`rng`]: SplitMix64, the seeded generator of every reproducible noise (the rig's sensor
//!   and link noise, identification's excitations, the tests' synthetic records).
//! - [`dense`]: small dense linear algebra on row-major slices (inverse, product, balancing,
//!   dot product): the rig's plant and the matrix exponential.
//! - [`expm`]: the matrix exponential (`e^{sM} − I`, scaling and squaring): the rig's exact
//!   linear steps and the zero-order-hold discretisation.
//! - [`filter`]: Butterworth low-pass sections (bilinear, pre-warped), causal or zero-phase:
//!   the rig's in-band comparisons, the generated road noise, diagnosis' differentiation
//!   filters.
//! - [`interpolate`]: a uniformly sampled signal at a fractional sample index (input delays of
//!   the effect laws and of diagnosis).
//! - [`files`]: every output file written whole or not at all (temporary file, then renamed).
//! - [`record`]: the CSV reader of every record and table (comma, semicolon or tab; units in
//!   the header; decimal commas; comment lines) and the one time-base rule.
//! - [`format`]: figures as a person reads them: significant digits, a value with its
//!   uncertainty.

pub mod dense;
pub mod expm;
pub mod files;
pub mod filter;
pub mod format;
pub mod interpolate;
pub mod optimise;
pub mod record;
pub mod rng;
