//! The discrepancy workflow (`mil diagnose`, issue 6): take a lumped mass-spring-damper
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
//! - [`signal`]: filters, differentiation, spectra, error figures.
//!
//! What a record must hold: every input's column, and displacement outputs that determine
//! every DOF's position (one per DOF, or combinations such as points that together fix
//! them), because recalibration and candidate selection estimate each DOF's position,
//! velocity and acceleration from them ([`equation`]). That is what a rig measures (the
//! actuators' LVDTs, laser or string-pot displacements); a DOF seen only by an
//! accelerometer or a load cell is refused with an error that names it. Velocity,
//! acceleration and force outputs are compared too, in the gap and the output-error
//! refinement.
//!
//! SI units throughout. Sign convention of an element (as in `mil-rig`): its compression
//! `x = pos(lower) − pos(upper)` (m) is positive when its ends approach, `v = dx/dt`, and its
//! force `F` (N) pushes the ends apart (positive in compression).

pub mod diagnose;
pub mod effects;
pub mod equation;
pub mod evidence;
pub mod model;
pub mod parallel;
pub mod record;
pub mod signal;
pub mod simulate;
pub mod split;

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
    /// Reading or writing a file failed.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The cause.
        source: std::io::Error,
    },
}

/// Result with the crate's [`Error`].
pub type Result<T> = std::result::Result<T, Error>;
