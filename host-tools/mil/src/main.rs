//! `mil`: the model-in-the-loop rig tool.

use anyhow::Result;
use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use mil::setup::SetUp;
use mil::xcp::BoardArgs;
use std::path::{Path, PathBuf};

/// `print!` through [`mil::cli::print`] (a closed stdout ends the program quietly), its
/// error returned with `?`.
macro_rules! out {
    ($($arg:tt)*) => {
        mil::cli::print(format_args!($($arg)*))?
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

/// The controller `mil sim` runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum SimBoard {
    /// model-core's controller in this process.
    Host,
    /// The firmware image in QEMU.
    Qemu,
}

#[derive(Subcommand)]
enum Command {
    /// Run the board's controller step in closed loop with the simulated rig, the emulated
    /// system (the real vehicle) alongside, and report how close they are, and how close to
    /// the set-up's analysis. Without SETUP the built-in tyre example runs.
    Sim {
        /// MiL set-up (TOML); examples in host-tools/mil/examples/.
        setup: Option<PathBuf>,
        /// Command filter (JSON) in place of the set-up's; `none`: without a filter.
        #[arg(long)]
        filter: Option<PathBuf>,
        /// Output folder (CSV and SVG plots).
        #[arg(long, default_value = "out/sim")]
        out: PathBuf,
        /// Print the summary as one JSON object.
        #[arg(long)]
        json: bool,
        /// The controller: `host` (model-core's, in this process) or `qemu` (the firmware
        /// image in QEMU, configured over XCP for the set-up, every demand frame compared
        /// with the host mirror: the summary adds the mismatch count).
        #[arg(long, value_enum, default_value_t = SimBoard::Host)]
        board: SimBoard,
        /// The firmware image for `--board qemu` (its QEMU build); default: the one under
        /// the build folder (`cargo build -p mil-firmware --target thumbv7em-none-eabihf
        /// --release --features qemu`).
        #[arg(long)]
        elf: Option<PathBuf>,
        /// Run this many seconds instead of the set-up's `[excitation] duration_s` (QEMU
        /// steps a few hundred samples a second).
        #[arg(long)]
        duration: Option<f64>,
        /// With `--board qemu`: serve the board's XCP port at this address (e.g.
        /// 127.0.0.1:5555) for your own XCP tools (`mil param set --setup`, `mil filter
        /// upload`, `mil daq record`, one at a time, `--port tcp:ADDRESS`) instead of
        /// configuring the board itself; the rig holds still until a DAQ measurement starts
        /// on the board, then runs the road, the recording beginning with the run.
        #[arg(long)]
        xcp: Option<std::net::SocketAddr>,
        /// With --xcp: how long to wait for the measurement (s).
        #[arg(long, default_value_t = 600.0, requires = "xcp")]
        wait: f64,
    },
    /// Run the real-time controller step over a road input, open-loop on a rigid rig (the
    /// hubs or body held still). Without SETUP the built-in tyre example runs.
    Run {
        /// MiL set-up (TOML); examples in host-tools/mil/examples/.
        setup: Option<PathBuf>,
        /// Command filter (JSON) in place of the set-up's; `none`: without a filter.
        #[arg(long)]
        filter: Option<PathBuf>,
        /// Output folder for run.csv, run.svg (demand) and run-road.svg.
        #[arg(long, default_value = "out")]
        out: PathBuf,
        /// Print one JSON object with the summary instead of the table.
        #[arg(long)]
        json: bool,
    },
    /// Frequency-domain analysis of a MiL set-up: MiL vs emulated responses, open-loop
    /// margins, resonances, band errors and noise sensitivity. Examples:
    /// host-tools/mil/examples/.
    Analyze {
        /// MiL set-up (TOML).
        setup: PathBuf,
        /// Command filter (JSON) in place of the set-up's; `none`: without a filter.
        #[arg(long)]
        filter: Option<PathBuf>,
        /// Output folder for the plots (SVG) and traces (CSV).
        #[arg(long, default_value = "out/analyze")]
        out: PathBuf,
        /// Print one JSON object with the figures instead of the table.
        #[arg(long)]
        json: bool,
    },
    /// Design the actuator command filter for a set-up (the paper's least-squares fit, or
    /// the optimised accuracy/noise trade-off) and write the filter file the firmware and
    /// `[controller] filter` load, with plots next to it.
    DesignFilter {
        /// MiL set-up (TOML), as for `mil analyze` (its own filter is left out).
        setup: PathBuf,
        /// `ls`: least-squares fit; `optimal`: trade-off front, exports the most accurate
        /// design meeting the target.
        #[arg(long, value_enum, default_value = "ls")]
        method: mil::design_filter::Method,
        /// Filter file to write (JSON); the plots go to the same folder.
        #[arg(long, default_value = "out/design-filter/filter.json")]
        out: PathBuf,
        /// Roll-off frequency of the filter's poles (Hz).
        #[arg(long)]
        rolloff_hz: Option<f64>,
        /// Damping ratio of the roll-off pole pairs.
        #[arg(long)]
        rolloff_damping: Option<f64>,
        /// Number of poles (1-8).
        #[arg(long)]
        poles: Option<usize>,
        /// Number of zeros (< poles).
        #[arg(long)]
        zeros: Option<usize>,
        /// Trade-off weights for `optimal` (comma-separated, 0-1).
        #[arg(long, value_delimiter = ',')]
        weights: Option<Vec<f64>>,
        /// Print one JSON object with the figures instead of the table.
        #[arg(long)]
        json: bool,
    },
    /// Test the set-up's actuator on the simulated rig as a rig engineer tests the real one
    /// before a MiL experiment: its rod blocked, a sine sweep or noise force command, the
    /// load cell recorded; the record `mil identify` reads.
    ActuatorTest(mil::actuator_test::Args),
    /// Compare a MiL recording with the emulated system (`mil sim`'s `sim.csv`: every
    /// `mil_*` column against its `emulated_*`) or with another run (`--against`): J1 delay,
    /// J2 normalised RMS error, J3 normalised peak error, the responses to `--input`, plots.
    Compare(mil::compare::Args),
    /// Identify an actuator's frequency response from test records (sine sweep and/or random
    /// noise; H1 estimate, Welch averaging, coherence) and write the table `mil analyze`
    /// reads (`[actuator] tracking = { table = "..." }`).
    Identify {
        /// Record file (CSV with a header, `time` first, uniform); repeat to average several.
        #[arg(long = "data", required = true)]
        data: Vec<PathBuf>,
        /// Input column (e.g. the force command).
        #[arg(long)]
        input: String,
        /// Output column (e.g. the measured force).
        #[arg(long)]
        output: String,
        /// Welch segment length (samples); resolution = sample rate / length. Default: the
        /// longest power of two that fits 8 times into the shortest record, 16 to 4096.
        #[arg(long)]
        segment: Option<usize>,
        /// Band kept in the table, LOW:HIGH in Hz (the excited band).
        #[arg(long, default_value = "0.5:140")]
        band: String,
        /// Points with lower coherence are dropped.
        #[arg(long, default_value_t = 0.9)]
        min_coherence: f64,
        /// Table file to write.
        #[arg(long, default_value = "out/actuator-frf.csv")]
        out: PathBuf,
        /// Print one JSON object with the summary.
        #[arg(long)]
        json: bool,
    },
    /// Find where a lumped model and a measured record disagree: recalibrate the model's
    /// linear parameters, name the missing physical effect(s), fit them, and write the
    /// updated model, a report (JSON) and plots (residual before/after, restoring force,
    /// FRF overlay). Examples: host-tools/diagnose/examples/ with host-tools/diagnose/data/.
    Diagnose {
        /// Model file (TOML): DOFs, elements, inputs and outputs mapped to CSV columns.
        #[arg(long)]
        model: PathBuf,
        /// Measured record (CSV with a header, `time` first, uniform, SI units).
        #[arg(long)]
        data: PathBuf,
        /// Output folder for the updated model, the report and the plots.
        #[arg(long, default_value = "out/diagnose")]
        out: PathBuf,
        /// Print one JSON object (named_effects, recalibrated, gap_before, gap_after,
        /// updated_model) instead of the summary.
        #[arg(long)]
        json: bool,
        /// Also write the updated model's element ELEMENT as model-core's real-time tyre
        /// (numerical-tyre.toml: the [numerical.tyre] table of a MiL set-up; stiffness, damping,
        /// static load and lift-off).
        #[arg(long, value_name = "ELEMENT")]
        tyre: Option<String>,
        /// Static wheel load (N) for --tyre when the updated model has no lift-off.
        #[arg(long, requires = "tyre")]
        tyre_static_load_n: Option<f64>,
    },
    /// Write the board's A2L file (calibration parameters and measurements for CANape,
    /// INCA or pyxcp) with the addresses of the firmware ELF FILE (built with symbols, as
    /// the release profile does).
    A2l {
        /// The linked firmware; default: the image under the build folder
        /// (target/thumbv7em-none-eabihf/release/mil-firmware, the one `mil sim --board qemu`
        /// runs).
        #[arg(long)]
        elf: Option<PathBuf>,
        /// The A2L file to write.
        #[arg(long, default_value = "out/mil.a2l")]
        out: PathBuf,
    },
    /// Validate any of the project's files exactly as the commands that read it do, and
    /// report the first problem: a MiL set-up (TOML with [controller]), a structure (TOML
    /// with [[dof]]), a filter file (JSON) or a record (CSV).
    Check {
        /// The file.
        file: PathBuf,
        /// For a record: the structure whose input and output columns it must hold.
        #[arg(long, value_name = "STRUCTURE")]
        against: Option<PathBuf>,
    },
    /// The board's calibration parameters over XCP on CAN, by their A2L names: list them
    /// (A2L only), read them, write them.
    Param {
        #[command(subcommand)]
        command: ParamCommand,
    },
    /// Measurement over XCP on CAN: record the board's signals with its timestamps.
    Daq {
        #[command(subcommand)]
        command: DaqCommand,
    },
    /// The board's command filter over XCP on CAN.
    Filter {
        #[command(subcommand)]
        command: FilterCommand,
    },
}

#[derive(Subcommand)]
enum ParamCommand {
    /// List the calibration parameters and the measurements of an A2L file: name, unit,
    /// limits, address, description (no board needed).
    List {
        /// The board's A2L file (`mil a2l` writes it).
        #[arg(long)]
        a2l: PathBuf,
    },
    /// Read parameters (or measurements) from the board.
    Get {
        /// A2L names.
        #[arg(required = true)]
        names: Vec<String>,
        #[command(flatten)]
        board: BoardArgs,
    },
    /// Write parameters: each value is checked against the A2L limits before anything is
    /// sent; contiguous parameters go to the board as one change it validates as a whole,
    /// the others one after another; prints old → new as read back.
    Set {
        /// NAME=VALUE pairs (SI units as in the A2L); with --setup, they replace the set-up's
        /// values.
        #[arg(required_unless_present = "setup")]
        assignments: Vec<String>,
        /// Configure the board for this MiL set-up (TOML): its model, parameters, limits,
        /// command filter and sample rate, as `mil sim --board qemu` configures the board
        /// in QEMU; only the parameters that differ are written, and printed old → new.
        #[arg(long)]
        setup: Option<PathBuf>,
        #[command(flatten)]
        board: BoardArgs,
    },
    /// Store the board's working page in its flash (XCP SET_REQUEST STORE_CAL_REQ): the board
    /// boots with it from then on (its status frame and the measurement `calibration_source`
    /// say so). Only while the controller does not run: a flash erase stalls the board.
    Store {
        #[command(flatten)]
        board: BoardArgs,
    },
}

#[derive(Subcommand)]
enum DaqCommand {
    /// Record signals by DAQ on the board's control step into a CSV or MDF4 file: `time` (s, from
    /// the board's timestamps, 0 at the first sample), then the signals in the A2L's SI
    /// units. Without --duration or --samples: 10 s.
    Record {
        /// Measurement (or parameter) names, comma-separated.
        #[arg(long, value_delimiter = ',', required = true)]
        signals: Vec<String>,
        /// File to write: ASAM MDF 4 for `*.mf4` or `*.mdf`, else CSV.
        #[arg(long)]
        out: PathBuf,
        /// Board time to record (s).
        #[arg(long, conflicts_with = "samples")]
        duration: Option<f64>,
        /// Samples to record.
        #[arg(long)]
        samples: Option<u64>,
        /// Keep every N-th control step (on the board where it can, else on the host).
        #[arg(long, default_value_t = 1)]
        prescaler: u16,
        #[command(flatten)]
        board: BoardArgs,
    },
}

#[derive(Subcommand)]
enum FilterCommand {
    /// Write a filter file (`mil design-filter`) to the board: every channel's
    /// filter_sections and section coefficients (delta form) as ONE block download, so the
    /// board validates the whole filter at once; prints the coefficients written.
    Upload {
        /// Filter file (JSON, `mil-command-filter`).
        filter: PathBuf,
        #[command(flatten)]
        board: BoardArgs,
    },
}

/// Runs the command; an error is printed as one line of causes (no backtrace, whatever
/// `RUST_BACKTRACE` says: the message names what to fix) and the exit status is 1.
fn main() -> std::process::ExitCode {
    match run(Cli::parse()) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("Error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

/// The set-up at `path` (none: the built-in tyre example), its command filter replaced by
/// `filter` if given (`none`: no filter; relative to the working folder).
fn set_up(path: Option<&Path>, filter: Option<&Path>) -> Result<SetUp> {
    let mut s = match path {
        Some(path) => SetUp::read(path)?,
        None => SetUp::builtin()?,
    };
    if let Some(f) = filter {
        s.controller.filter = if f == Path::new("none") {
            None
        } else {
            Some(std::env::current_dir()?.join(f))
        };
    }
    Ok(s)
}

/// The firmware image `elf`, or the one under the build folder.
fn firmware_elf(elf: Option<PathBuf>) -> Result<PathBuf> {
    match elf {
        Some(e) => Ok(e),
        None => anyhow::Context::with_context(mil_can::find_firmware_elf(), || {
            format!(
                "no firmware image found: build it with `{}` or give --elf",
                mil_can::FIRMWARE_BUILD_COMMAND
            )
        }),
    }
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Run {
            setup,
            filter,
            out,
            json,
        } => {
            let config = set_up(setup.as_deref(), filter.as_deref())?.run()?;
            mil::cli::check_output_folder(&out)?;
            let bar = mil::cli::progress_bar(json, 1000, "running controller");
            let result = mil::run(&config, |f| bar.set_position((f * 1000.0) as u64))?;
            bar.finish_and_clear();
            std::fs::create_dir_all(&out)?;
            let csv = out.join("run.csv");
            result.write_csv(&csv)?;
            let plots = mil::plot::plot_run(&result, &out)?;
            if json {
                outln!("{}", serde_json::to_string(&result.summary)?);
            } else {
                out!("{}", result.table());
                outln!("time histories: {}", csv.display());
                for p in &plots {
                    outln!("plot:           {}", p.display());
                }
            }
            // A faulted run is a failed one: the files are complete, the status says so.
            if let Some(t) = result.summary.fault_at_s {
                anyhow::bail!(
                    "the controller faulted at {t:.4} s: {} ({} holds the whole run)",
                    mil::run::fault_causes(result.summary.fault_flags),
                    csv.display()
                );
            }
            Ok(())
        }
        Command::DesignFilter {
            setup,
            method,
            out,
            rolloff_hz,
            rolloff_damping,
            poles,
            zeros,
            weights,
            json,
        } => {
            if let Some(folder) = out.parent().filter(|p| !p.as_os_str().is_empty()) {
                mil::cli::check_output_folder(folder)?;
            }
            let paper = mil_analysis::design::FilterStructure::PAPER;
            let structure = mil_analysis::design::FilterStructure {
                rolloff_hz: rolloff_hz.unwrap_or(paper.rolloff_hz),
                rolloff_damping: rolloff_damping.unwrap_or(paper.rolloff_damping),
                poles: poles.unwrap_or(paper.poles),
                zeros: zeros.unwrap_or(paper.zeros),
            };
            let request = mil::design_filter::DesignRequest {
                method,
                out,
                structure: Some(structure),
                weights,
            };
            let bar = if json || method == mil::design_filter::Method::Ls {
                ProgressBar::hidden()
            } else {
                ProgressBar::new(1).with_style(
                    ProgressStyle::with_template("{msg} [{bar:40}] {pos}/{len} {elapsed}")
                        .unwrap_or_else(|_| ProgressStyle::default_bar()),
                )
            };
            bar.set_message("optimising over the weights");
            let setup = SetUp::read(&setup)?;
            let result = mil::design_filter::run_design_filter(&setup, &request, |i, n| {
                bar.set_length(n as u64);
                bar.set_position(i as u64);
            })?;
            bar.finish_and_clear();
            if json {
                outln!("{}", serde_json::to_string(&result.summary)?);
            } else {
                out!("{}", result.table());
            }
            Ok(())
        }
        Command::Analyze {
            setup,
            filter,
            out,
            json,
        } => {
            mil::cli::check_output_folder(&out)?;
            let result =
                mil::analyze::run_analyze(&set_up(Some(&setup), filter.as_deref())?, &out)?;
            if json {
                outln!("{}", serde_json::to_string(&result.summary())?);
            } else {
                out!("{}", result.table());
            }
            Ok(())
        }
        Command::Compare(args) => {
            let summary = mil::compare::run(&args)?;
            if args.json {
                outln!("{}", serde_json::to_string(&summary)?);
            } else {
                outln!("{}", summary.text());
            }
            Ok(())
        }
        Command::ActuatorTest(args) => {
            let summary = mil::actuator_test::run(&args)?;
            if args.json {
                outln!("{}", serde_json::to_string(&summary)?);
            } else {
                outln!("{}", summary.text());
            }
            Ok(())
        }
        Command::Identify {
            data,
            input,
            output,
            segment,
            band,
            min_coherence,
            out,
            json,
        } => {
            let bar = mil::cli::spinner(json, "reading the records and estimating the response");
            let (_, summary) = mil::identify::run_identify(&mil::identify::IdentifyOptions {
                records: data,
                input,
                output,
                segment_length: segment,
                band_hz: mil::identify::parse_band(&band)?,
                min_coherence,
                out,
            })?;
            bar.finish_and_clear();
            if json {
                outln!("{}", serde_json::to_string(&summary)?);
            } else {
                outln!("{}", summary.text());
            }
            Ok(())
        }
        Command::Sim {
            setup,
            filter,
            out,
            json,
            board,
            elf,
            duration,
            xcp,
            wait,
        } => {
            if xcp.is_some() && board != SimBoard::Qemu {
                anyhow::bail!("--xcp serves the XCP port of the board in QEMU: add --board qemu");
            }
            if !(wait.is_finite() && wait > 0.0) {
                anyhow::bail!("--wait: a time in seconds above 0, got {wait}");
            }
            let mut config = set_up(setup.as_deref(), filter.as_deref())?.sim()?;
            mil::cli::check_output_folder(&out)?;
            if let Some(d) = duration {
                config.run.duration_s = d;
            }
            let bar = mil::cli::progress_bar(json, 1000, "simulating the rig");
            let progress = |f: f64| bar.set_position((f * 1000.0) as u64);
            let elf_given = elf.is_some();
            let (result, qemu) = match board {
                SimBoard::Host => (mil::sim::simulate(&config, progress)?, None),
                SimBoard::Qemu => {
                    let elf = firmware_elf(elf)?;
                    bar.set_message("the firmware in QEMU on the simulated rig");
                    let serve = xcp.map(|listen| mil::sim::ServeXcp {
                        listen,
                        wait: std::time::Duration::from_secs_f64(wait),
                    });
                    let ready = |at: std::net::SocketAddr| {
                        bar.suspend(|| {
                            eprintln!(
                                "the board's XCP port: tcp:{at} (mil param, mil filter upload, mil \
                                 daq record --port tcp:{at}); the rig runs its road once a DAQ \
                                 measurement starts"
                            );
                        });
                        bar.set_message("waiting for a DAQ measurement on the board");
                    };
                    let (r, q) = mil::sim::simulate_on_qemu(&config, &elf, serve, ready, progress)?;
                    (r, Some(q))
                }
            };
            // The main job (the built-in example, no filter asked for) also runs with the
            // paper's command filter: the problem and its answer side by side.
            let paper = if setup.is_none() && filter.is_none() && board == SimBoard::Host {
                let mut file = tempfile::NamedTempFile::new()?;
                std::io::Write::write_all(&mut file, mil::setup::DEFAULT_FILTER.as_bytes())?;
                let mut with = set_up(None, Some(file.path()))?.sim()?;
                if let Some(d) = duration {
                    with.run.duration_s = d;
                }
                bar.set_message("the same with the paper's command filter");
                bar.set_position(0);
                Some(mil::sim::simulate(&with, |f: f64| {
                    bar.set_position((f * 1000.0) as u64)
                })?)
            } else {
                None
            };
            bar.finish_and_clear();
            std::fs::create_dir_all(&out)?;
            let csv = out.join("sim.csv");
            result.write_csv(&csv)?;
            let plots = result.write_plots(&out)?;
            // The filtered run with its files: (run, CSV, plots).
            let paper = match paper {
                Some(p) => {
                    let folder = out.join("with-filter");
                    std::fs::create_dir_all(&folder)?;
                    let csv = folder.join("sim.csv");
                    p.write_csv(&csv)?;
                    let plots = p.write_plots(&folder)?;
                    Some((p, csv, plots))
                }
                None => None,
            };
            if json {
                let mut value = serde_json::to_value(&result.summary)?;
                if let (Some(q), Some(map)) = (&qemu, value.as_object_mut()) {
                    map.insert("qemu".into(), serde_json::to_value(q)?);
                }
                if let (Some((p, _, _)), Some(map)) = (&paper, value.as_object_mut()) {
                    map.insert(
                        "with_paper_filter".into(),
                        serde_json::to_value(&p.summary)?,
                    );
                }
                outln!("{}", value);
            } else {
                out!("{}", result.table());
                if let Some(q) = &qemu {
                    // The default image by its name only: where the build folder is differs
                    // between machines.
                    let image = if elf_given {
                        q.elf.clone()
                    } else {
                        format!(
                            "{} (the QEMU build; --elf to choose)",
                            Path::new(&q.elf)
                                .file_name()
                                .map_or(q.elf.clone(), |n| n.to_string_lossy().to_string())
                        )
                    };
                    match &q.xcp_served_at {
                        Some(at) => outln!(
                            "firmware in QEMU: {image} (configured by {} XCP client(s) at tcp:{at})",
                            q.xcp_clients
                        ),
                        None => outln!(
                            "firmware in QEMU: {image} ({} parameter slots written over XCP)",
                            q.slots_written
                        ),
                    }
                    outln!(
                        "demand frames:  {} compared with the host mirror{}, {} mismatches",
                        q.demand_frames,
                        if q.xcp_served_at.is_some() {
                            " of the set-up"
                        } else {
                            ""
                        },
                        q.mismatches
                    );
                }
                outln!("time histories: {}", csv.display());
                for p in &plots {
                    outln!("plot:           {}", p.display());
                }
                if let Some((p, paper_csv, paper_plots)) = &paper {
                    out!(
                        "{}",
                        result.side_by_side(
                            &p.summary,
                            "the paper's least-squares command filter \
                             (host-tools/mil/examples/tyre-filter.json)"
                        )
                    );
                    outln!("with the filter: {}", paper_csv.display());
                    for p in paper_plots {
                        outln!("plot:            {}", p.display());
                    }
                }
            }
            if let Some(t) = result.summary.fault_at_s {
                anyhow::bail!(
                    "the controller faulted at {t:.4} s: {} ({} holds the whole run)",
                    mil::run::fault_causes(result.summary.fault_flags),
                    csv.display()
                );
            }
            // The image must do what the host code does: a differing frame fails the run.
            if let Some(q) = qemu.as_ref().filter(|q| q.mismatches > 0) {
                anyhow::bail!(
                    "{} of {} demand frames of the firmware differ from the host mirror's{}",
                    q.mismatches,
                    q.demand_frames,
                    if q.xcp_served_at.is_some() {
                        ": the board was not configured as the set-up says (`mil param set \
                         --setup`, and the filter with `mil filter upload`)"
                    } else {
                        ""
                    }
                );
            }
            Ok(())
        }
        Command::Diagnose {
            model,
            data,
            out,
            json,
            tyre,
            tyre_static_load_n,
        } => {
            let bar = if json {
                ProgressBar::hidden()
            } else {
                ProgressBar::new(1000).with_style(
                    ProgressStyle::with_template("[{bar:30}] {percent:>3}% {elapsed} {wide_msg}")
                        .unwrap_or_else(|_| ProgressStyle::default_bar()),
                )
            };
            bar.set_message("estimating states");
            let request = mil::diagnose::DiagnoseRequest {
                model,
                data,
                out,
                tyre: tyre.map(|element| mil::diagnose::TyreExport {
                    element,
                    static_load_n: tyre_static_load_n,
                }),
            };
            let result = mil::diagnose::run_diagnose(&request, &|f, m| {
                bar.set_position((f * 1000.0) as u64);
                bar.set_message(m.to_string());
            });
            bar.finish_and_clear();
            let result = result?;
            if json {
                outln!("{}", serde_json::to_string(&result.json_report())?);
            } else {
                out!("{}", result.table());
            }
            // After the diagnosis, which stands without it.
            if let Some(Err(why)) = &result.tyre {
                anyhow::bail!("--tyre: {why}");
            }
            Ok(())
        }
        Command::A2l { elf, out } => {
            let elf = firmware_elf(elf)?;
            let bytes =
                std::fs::read(&elf).map_err(|e| anyhow::anyhow!("{}: {e}", elf.display()))?;
            let layout =
                mil_a2l::layout(&bytes).map_err(|e| anyhow::anyhow!("{}: {e}", elf.display()))?;
            let version = format!(
                "{} (ELF {})",
                env!("CARGO_PKG_VERSION"),
                elf.file_name().map_or("?".into(), |n| n.to_string_lossy())
            );
            if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
                std::fs::create_dir_all(dir)?;
            }
            let text = mil_a2l::generate(&layout, &version);
            mil::cli::write_atomic(&out, |w| Ok(std::io::Write::write_all(w, text.as_bytes())?))?;
            outln!(
                "{}: calibration page at 0x{:08X} ({} bytes), measurements at 0x{:08X} ({} bytes)",
                out.display(),
                layout.calibration.address,
                layout.calibration.size,
                layout.measurement.address,
                layout.measurement.size
            );
            Ok(())
        }
        Command::Check { file, against } => {
            outln!("{}", mil::check::check(&file, against.as_deref())?);
            Ok(())
        }
        Command::Param { command } => run_param(command),
        Command::Daq { command } => run_daq(command),
        Command::Filter { command } => run_filter(command),
    }
}

fn run_param(command: ParamCommand) -> Result<()> {
    match command {
        ParamCommand::List { a2l } => {
            let a2l = mil::xcp::load_a2l(&a2l)?;
            out!("{}", mil::param::list_table(&a2l));
        }
        ParamCommand::Get { names, board } => {
            let a2l = mil::xcp::load_a2l(&board.a2l)?;
            mil::param::resolve(&a2l, &names)?;
            let table = mil::xcp::session(&board, &a2l, |m| mil::param::get(m, &a2l, &names))?;
            out!("{table}");
        }
        ParamCommand::Set {
            assignments,
            setup,
            board,
        } => {
            let a2l = mil::xcp::load_a2l(&board.a2l)?;
            let given = mil::param::parse_assignments(&assignments)?;
            let assignments = match &setup {
                Some(path) => {
                    let config = set_up(Some(path), None)?.sim()?;
                    let mut all = mil::param::page_assignments(&mil::sim::board_page(&config)?);
                    for (name, v) in given {
                        match all.iter_mut().find(|(n, _)| *n == name) {
                            Some(slot) => slot.1 = v,
                            None => all.push((name, v)),
                        }
                    }
                    all
                }
                None => given,
            };
            // Everything the host can check, before the board is contacted.
            mil::param::check_assignments(&a2l, &assignments)?;
            let secret = mil::xcp::secret(&board)?;
            let changes = mil::xcp::session(&board, &a2l, |m| match &setup {
                Some(_) => mil::param::set_all(m, &a2l, &assignments, &secret),
                None => mil::param::set(m, &a2l, &assignments, &secret),
            })?;
            out!("{}", mil::param::changes_table(&a2l, &changes));
            if let Some(path) = &setup {
                outln!(
                    "the board is configured for {} ({} of {} parameters changed)",
                    path.display(),
                    changes.len(),
                    assignments.len()
                );
            }
        }
        ParamCommand::Store { board } => {
            let a2l = mil::xcp::load_a2l(&board.a2l)?;
            let secret = mil::xcp::secret(&board)?;
            let line = mil::xcp::session(&board, &a2l, |m| mil::param::store(m, &a2l, &secret))?;
            out!("{line}");
        }
    }
    Ok(())
}

fn run_daq(command: DaqCommand) -> Result<()> {
    let DaqCommand::Record {
        signals,
        out,
        duration,
        samples,
        prescaler,
        board,
    } = command;
    let a2l = mil::xcp::load_a2l(&board.a2l)?;
    let items = mil::daq_record::resolve_signals(&a2l, &signals)?;
    let length = match (duration, samples) {
        (_, Some(n)) => mil::daq_record::Length::Samples(n),
        (Some(d), None) => mil::daq_record::Length::Duration(d),
        (None, None) => mil::daq_record::Length::Duration(10.0),
    };
    let secret = mil::xcp::secret(&board)?;
    let bar = ProgressBar::new(1000).with_style(
        ProgressStyle::with_template("{msg} [{bar:40}] {percent:>3}% {elapsed}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar.set_message("recording");
    // Ctrl-C ends the recording early and cleanly: the list is stopped and freed on the
    // board (else it would keep sampling, and loading the bus, until the next CONNECT).
    let interrupt = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    {
        let interrupt = std::sync::Arc::clone(&interrupt);
        ctrlc::set_handler(move || interrupt.store(true, std::sync::atomic::Ordering::Relaxed))
            .map_err(|e| anyhow::anyhow!("cannot install the Ctrl-C handler: {e}"))?;
    }
    let request = mil::daq_record::Request {
        prescaler,
        length,
        out: out.clone(),
    };
    let recorded = mil::xcp::session(&board, &a2l, |m| {
        mil::daq_record::record(
            m,
            &items,
            &secret,
            &request,
            |f| bar.set_position((f.clamp(0.0, 1.0) * 1000.0) as u64),
            || interrupt.load(std::sync::atomic::Ordering::Relaxed),
        )
    });
    bar.finish_and_clear();
    let recorded = recorded?;
    let rate = recorded
        .event_cycle_s
        .map(|c| format!(" at {} Hz", 1.0 / c))
        .unwrap_or_default();
    let steps = if prescaler == 1 {
        format!("every control step{rate}")
    } else {
        format!(
            "1 in {prescaler} control steps{rate}{}",
            if recorded.host_prescaler == 1 {
                String::new()
            } else {
                format!(
                    ": 1 in {} on the board, 1 in {} of those kept by the host",
                    recorded.board_prescaler, recorded.host_prescaler
                )
            }
        )
    };
    outln!(
        "{}: {} samples over {:.3} s ({steps}; {} CAN frames per sample){}",
        out.display(),
        recorded.samples,
        recorded.span_s,
        recorded.dtos_per_sample,
        if recorded.interrupted {
            ", stopped by Ctrl-C"
        } else {
            ""
        }
    );
    let units: Vec<String> = items
        .iter()
        .map(|i| format!("{} [{}]", i.name, i.unit_or_dash()))
        .collect();
    outln!("columns: time [s], {}", units.join(", "));
    if recorded.stats.incomplete > 0 {
        outln!(
            "incomplete cycles dropped (lost DTOs): {}",
            recorded.stats.incomplete
        );
    }
    Ok(())
}

fn run_filter(command: FilterCommand) -> Result<()> {
    let FilterCommand::Upload { filter, board } = command;
    let a2l = mil::xcp::load_a2l(&board.a2l)?;
    let plan = mil::filter_upload::plan(&a2l, &filter)?;
    let secret = mil::xcp::secret(&board)?;
    let changes = mil::xcp::session(&board, &a2l, |m| {
        mil::filter_upload::upload(m, &plan, &secret)
    })?;
    out!("{}", mil::filter_upload::table(&plan, &changes));
    Ok(())
}
