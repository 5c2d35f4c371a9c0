//! `mil`: the model-in-the-loop rig tool.

use anyhow::Result;
use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(
    name = "mil",
    version,
    about = "Model-in-the-loop control for servo-hydraulic test rigs"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run the MiL controller with the simulated rig, the real vehicle alongside (the main job).
    ///
    /// Run the board's controller step in closed loop with the simulated rig, the emulated
    /// system (the real vehicle) alongside, and report how close they are, and how close to
    /// the set-up's analysis. Without SETUP the built-in tyre example runs.
    Sim(mil::commands::sim::Args),
    /// Run the controller open-loop on a rigid rig over a road input.
    ///
    /// Run the real-time controller step over a road input, open-loop on a rigid rig (the
    /// hubs or body held still). Without SETUP the built-in tyre example runs.
    Run(mil::commands::run::Args),
    /// Analyse a MiL set-up in the frequency domain.
    ///
    /// Frequency-domain analysis of a MiL set-up: MiL vs emulated responses, open-loop
    /// margins, resonances, band errors and noise sensitivity. Examples:
    /// host-tools/mil/examples/.
    Analyze(mil::commands::analyze::Args),
    /// Design the actuator command filter for a set-up.
    ///
    /// Design the actuator command filter for a set-up (the paper's least-squares fit, or
    /// the optimised accuracy/noise trade-off) and write the filter file the firmware and
    /// `[controller] filter` load, with plots next to it.
    DesignFilter(mil::commands::design_filter::Args),
    /// Test the set-up's actuator on the simulated rig, its rod blocked.
    ///
    /// Test the set-up's actuator on the simulated rig as a rig engineer tests the real one
    /// before a MiL experiment: its rod blocked, a sine sweep or noise force command, the
    /// load cell recorded; the record `mil identify` reads.
    ActuatorTest(mil::commands::actuator_test::Args),
    /// Compare a MiL recording with the emulated system or with another run.
    ///
    /// Compare a MiL recording with the emulated system (`mil sim`'s `sim.csv`: every
    /// `mil_*` column against its `emulated_*`) or with another run (`--against`): J1 delay,
    /// J2 normalised RMS error, J3 normalised peak error, the responses to `--input`, plots.
    Compare(mil::commands::compare::Args),
    /// Identify an actuator's frequency response from test records.
    ///
    /// Identify an actuator's frequency response from test records (sine sweep and/or random
    /// noise; H1 estimate, Welch averaging, coherence) and write the table `mil analyze`
    /// reads (`[actuator] tracking = { table = "..." }`).
    Identify(mil::commands::identify::Args),
    /// Name the physical effect a model misses in a measured record, and fix the model.
    ///
    /// Find where a lumped model and a measured record disagree: recalibrate the model's
    /// linear parameters, name the missing physical effect(s), fit them, and write the
    /// updated model, a report (JSON) and plots (residual before/after, restoring force,
    /// FRF overlay). Examples: host-tools/diagnose/examples/ with host-tools/diagnose/data/.
    Diagnose(mil::commands::diagnose::Args),
    /// Write the board's A2L file from the firmware image.
    ///
    /// Write the board's A2L file (calibration parameters and measurements for CANape,
    /// INCA or pyxcp) with the addresses of the firmware ELF FILE (built with symbols, as
    /// the release profile does).
    A2l(mil::commands::a2l::Args),
    /// Validate a set-up, structure, filter file or record as the commands read it.
    ///
    /// Validate any of the project's files exactly as the commands that read it do, and
    /// report the first problem: a MiL set-up (TOML with [controller]), a structure (TOML
    /// with [[dof]]), a filter file (JSON) or a record (CSV).
    Check(mil::commands::check::Args),
    /// The board's calibration parameters over XCP: list, get, set, store.
    ///
    /// The board's calibration parameters over XCP on CAN, by their A2L names: list them
    /// (A2L only), read them, write them.
    Param {
        #[command(subcommand)]
        command: mil::commands::param::ParamCommand,
    },
    /// Record the board's signals over XCP DAQ.
    ///
    /// Measurement over XCP on CAN: record the board's signals with its timestamps.
    Daq {
        #[command(subcommand)]
        command: mil::commands::daq::DaqCommand,
    },
    /// Upload a command filter to the board over XCP.
    ///
    /// The board's command filter over XCP on CAN.
    Filter {
        #[command(subcommand)]
        command: mil::commands::filter::FilterCommand,
    },
}

/// Runs the command; an error is printed as one line of causes (no backtrace, whatever
/// `RUST_BACKTRACE` says: the message names what to fix) and the exit status is 1.
fn main() -> std::process::ExitCode {
    match run(Cli::parse()) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("Error: {}", mil::cli::error_message(&e));
            std::process::ExitCode::FAILURE
        }
    }
}

fn run(cli: Cli) -> Result<()> {
    use mil::commands as c;
    match cli.command {
        Command::Sim(args) => c::sim::run(args),
        Command::Run(args) => c::run::run(args),
        Command::Analyze(args) => c::analyze::run(args),
        Command::DesignFilter(args) => c::design_filter::run(args),
        Command::ActuatorTest(args) => c::actuator_test::run(args),
        Command::Compare(args) => c::compare::run(args),
        Command::Identify(args) => c::identify::run(args),
        Command::Diagnose(args) => c::diagnose::run(args),
        Command::A2l(args) => c::a2l::run(args),
        Command::Check(args) => c::check::run(args),
        Command::Param { command } => c::param::run(command),
        Command::Daq { command } => c::daq::run(command),
        Command::Filter { command } => c::filter::run(command),
    }
}
