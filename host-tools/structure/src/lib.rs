//! # mil-structure
//!
//! The specimen's structure as every host tool sees it, low in the crate graph: the effect
//! vocabulary and the force laws of spring-damper elements, shared by the simulated rig
//! (`mil-rig`) and diagnosis (`mil-diagnose`), so that what diagnosis names and fits is
//! what the rig simulates.
//!
//! - [`effects`]: the effect identifiers ([`EffectKind`]), their parameters (SI names) and
//!   laws: [`ElementLaw`] for an element's force (and [`CompiledLaw`], the same law unpacked
//!   for inner loops), [`InputLaw`] for an input's delay, rate limit, saturation and play.
//! - [`element`]: an element's law as written in files ([`Element`]: stiffness, damping,
//!   static preload and effects by name).
//! - [`model`]: the structure file (TOML: DOFs, points, elements between them, inputs and
//!   measured outputs mapped to record columns, effects) and the validated [`Model`].
//! - [`plausible`]: the physical plausibility every structure must pass (static
//!   compressions, natural frequencies), which catches unit mistakes.
//!
//! Sign convention: an element's compression `x` (m) is positive when its ends approach,
//! `v = dx/dt`, and its force `F` (N) pushes the ends apart (positive in compression).
//! Positions are deviations from the static equilibrium; an element carrying a static load
//! there has it as its preload.

pub mod effects;
pub mod element;
pub mod model;
pub mod plausible;

pub use effects::{CompiledLaw, EffectKind, ElementLaw, InputLaw};
pub use element::{Element, Parameters};
pub use model::{Model, ModelFile};

/// A structure file, element, effect or parameter is malformed or out of its physical
/// range; the message names it.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The message names the item: DOF, element, effect and parameter, or field.
    #[error("{0}")]
    Model(String),
    /// Reading a file failed.
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
