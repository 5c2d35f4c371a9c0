//! The `mil` tool's library: typed run configuration (TOML, validated once into model-core's
//! parameter set), generated and recorded road inputs, and the run of the real-time
//! controller step with its CSV, SVG and summary outputs.
//!
//! Until the simulated rig exists, a run drives the controller open-loop on a rigid rig:
//! measured positions are zero (or come from a recorded CSV), so the demand is the force the
//! numerical model asks of the actuators for the given road and speed.

pub mod analyze;
pub mod config;
pub mod design_filter;
pub mod identify;
pub mod plot;
pub mod run;
pub mod signals;

pub use config::{Config, ModelKind};
pub use run::{run, RunOutput, Summary};
