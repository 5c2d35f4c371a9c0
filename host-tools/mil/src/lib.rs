//! The `mil` tool's library: the MiL set-up file ([`setup`]: one description of an
//! experiment, turned into the linear analysis and into the run, validated once into
//! model-core's parameter set), generated and recorded road inputs, and the run of the
//! real-time controller step with its CSV, SVG and summary outputs.
//!
//! `mil sim` ([`sim`]) runs the controller in closed loop with the simulated rig
//! (`mil-rig`) and the emulated system alongside; `mil run` ([`mod@run`]) drives it open-loop
//! on a rigid rig (measured positions zero), so its demand is the force the numerical model
//! asks of the actuators for the given road and speed.
//!
//! `mil diagnose` ([`mod@diagnose`]) runs the discrepancy workflow of `mil-diagnose` on a model
//! file and a measured record and writes the updated model, the report and the plots.
//!
//! `mil param` ([`param`]), `mil daq record` ([`daq_record`]) and `mil filter upload`
//! ([`filter_upload`]) calibrate and measure the board over XCP on CAN (`mil-xcp-master`),
//! by the names of its A2L file; [`xcp`] holds what they share (port, CAN IDs, secret).

/// `print!` through [`cli::print`] (a closed stdout ends the program quietly), its error
/// returned with `?`: what every subcommand prints with.
macro_rules! out {
    ($($arg:tt)*) => {
        $crate::cli::print(format_args!($($arg)*))?
    };
}

/// `println!` as [`out!`].
macro_rules! outln {
    () => {
        out!("\n")
    };
    ($($arg:tt)*) => {
        out!("{}\n", format_args!($($arg)*))
    };
}

pub mod actuator_test;
pub mod analyze;
pub mod check;
pub mod cli;
pub mod commands;
pub mod compare;
pub mod config;
pub mod daq_record;
pub mod design_filter;
pub mod diagnose;
pub mod filter_upload;
pub mod identify;
pub mod param;
pub mod plot;
pub mod run;
pub mod setup;
pub mod signals;
pub mod sim;
pub mod xcp;

pub use config::{Config, ModelKind};
pub use run::{run, RunOutput, Summary};
