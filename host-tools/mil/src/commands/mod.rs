//! One module per `mil` subcommand: its arguments (`Args`, clap) and `run`; `main.rs` only
//! dispatches.

pub mod a2l;
pub mod actuator_test;
pub mod analyze;
pub mod check;
pub mod compare;
pub mod daq;
pub mod design_filter;
pub mod diagnose;
pub mod filter;
pub mod identify;
pub mod param;
pub mod run;
pub mod sim;
