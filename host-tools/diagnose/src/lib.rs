//! The discrepancy workflow (`mil diagnose`): take a lumped mass-spring-damper
//! model and a measured record, recalibrate the model's linear parameters, find which
//! physical effect is missing, fit its parameters, and show how much the gap shrinks.
//!
//! - [`model`]: the model file (TOML) — DOFs (masses, kg or kg·m²), points, spring-damper
//!   elements between DOFs, points, displacement inputs or `ground`, displacement and force
//!   inputs and measured outputs mapped to CSV columns, and effects attached to elements or
//!   inputs ([`effects::EffectKind`]); validated once into a [`Model`], written back with
//!   [`Model::to_toml`].
//! - [`record`]: the measured record (CSV, `time` first, uniform, SI units).
//! - [`simulate`]: fixed-step RK4 simulation of a model driven by a record's inputs.
//! - [`equation`]: the equation-error (inverse-dynamics) formulation on measured states,
//!   linear in the linear parameters and in most effects' parameters.
//! - [`diagnose()`]: recalibration, candidate effects, selection by a validation criterion,
//!   output-error refinement, the evidence and the report ([`Diagnosis`], [`JsonReport`]).
//! - [`accelerometer`]: DOF positions from accelerometers where displacements leave them
//!   open.
//! - [`signal`]: filters, differentiation, spectra, error figures.
//!
//! What a record must hold: every input's column, and motion outputs that determine every
//! DOF's position, because recalibration and candidate selection estimate each DOF's
//! position, velocity and acceleration from them ([`equation`]). Displacement outputs (one
//! per DOF, or combinations such as points that together fix them) are what a rig measures
//! (the actuators' LVDTs, laser or string-pot displacements). A DOF they leave open may be
//! seen by an accelerometer instead (the body of a quarter car on a hub-driven rig): its
//! motion above the accelerometer's low band edge comes from the acceleration, below it
//! from the model's balance with the measured DOFs and inputs ([`accelerometer`]); a DOF no
//! spring holds (its static position unfixed), or seen by nothing, is refused with an error
//! that names it and says what to measure. Velocity, acceleration and force outputs are
//! compared too, in the gap and the output-error refinement, and a measured element force
//! adds its own equations (it fixes the masses' scale). Records longer than
//! [`diagnose::MAX_SAMPLES`] are averaged down in blocks when their band allows, refused
//! with one line otherwise ([`diagnose::within_budget`]).
//!
//! SI units throughout. Sign convention of an element (as in `mil-rig`): its compression
//! `x = pos(lower) − pos(upper)` (m) is positive when its ends approach, `v = dx/dt`, and its
//! force `F` (N) pushes the ends apart (positive in compression).

pub mod accelerometer;
pub mod diagnose;
/// The effect vocabulary and laws (`mil-structure`'s, shared with the simulated rig).
pub use mil_structure::effects;
/// The structure file and the validated model (`mil-structure`'s).
pub use mil_structure::model;
pub mod equation;
pub mod evidence;
pub mod parallel;
pub mod record;
pub mod signal;
pub mod simulate;
pub mod split;
pub mod uncertainty;

pub use diagnose::{
    diagnose, diagnose_with_progress, Diagnosis, Gap, JsonReport, NamedEffect, Options,
};
pub use effects::EffectKind;
pub use model::{Model, ModelFile};
pub use record::Record;

/// Errors of the workflow, with a message that names the offending item.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The model file is malformed or inconsistent.
    #[error("model: {0}")]
    Model(String),
    /// The record is malformed or does not fit the model.
    #[error("record: {0}")]
    Record(String),
    /// The simulation diverged or could not run.
    #[error("simulation: {0}")]
    Simulation(String),
    /// The workflow cannot proceed (e.g. too little data, nothing measured).
    #[error("diagnose: {0}")]
    Diagnose(String),
    /// Writing a file failed (the message names it).
    #[error(transparent)]
    Write(std::io::Error),
    /// Reading or writing a file failed.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The cause.
        source: std::io::Error,
    },
}

impl From<mil_structure::Error> for Error {
    fn from(e: mil_structure::Error) -> Self {
        match e {
            mil_structure::Error::Model(m) => Error::Model(m),
            mil_structure::Error::Io { path, source } => Error::Io { path, source },
        }
    }
}

/// Result with the crate's [`Error`].
pub type Result<T> = std::result::Result<T, Error>;
