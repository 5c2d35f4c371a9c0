//! `mil sim`: the board's controller in closed loop with the simulated rig, the emulated
//! system alongside (the main job), on the host or the firmware in QEMU.

use anyhow::Result;
use std::path::{Path, PathBuf};

/// The controller `mil sim` runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum SimBoard {
    /// model-core's controller in this process.
    Host,
    /// The firmware image in QEMU.
    Qemu,
}

/// The arguments of `mil sim`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The set-up and its command filter.
    #[command(flatten)]
    pub set_up: crate::cli::SetUpArgs,
    /// Output folder (CSV and SVG plots).
    #[arg(long, default_value = "out/sim")]
    pub out: PathBuf,
    /// Print the summary as one JSON object.
    #[arg(long)]
    pub json: bool,
    /// The controller: `host` (model-core's, in this process) or `qemu` (the firmware
    /// image in QEMU, configured over XCP for the set-up, every demand frame compared
    /// with the host mirror: the summary adds the mismatch count).
    #[arg(long, value_enum, default_value_t = SimBoard::Host)]
    pub board: SimBoard,
    /// The firmware image for `--board qemu` (its QEMU build); default: the one under
    /// the build folder (`cargo build -p mil-firmware --target thumbv7em-none-eabihf
    /// --release --features qemu`).
    #[arg(long)]
    pub elf: Option<PathBuf>,
    /// Run this many seconds instead of the set-up's `[excitation] duration_s` (QEMU
    /// steps a few hundred samples a second).
    #[arg(long)]
    pub duration: Option<f64>,
    /// With `--board qemu`: serve the board's XCP port at this address (e.g.
    /// 127.0.0.1:5555) for your own XCP tools (`mil param set --setup`, `mil filter
    /// upload`, `mil daq record`, one at a time, `--port tcp:ADDRESS`) instead of
    /// configuring the board itself; the rig holds still until a DAQ measurement starts
    /// on the board, then runs the road, the recording beginning with the run (record
    /// at most --duration: the board's port closes when the run ends, and a longer
    /// recording keeps the run's samples and fails, saying so).
    #[arg(long)]
    pub xcp: Option<std::net::SocketAddr>,
    /// With --xcp: how long to wait for the measurement (s).
    #[arg(long, default_value_t = 600.0, requires = "xcp")]
    pub wait: f64,
}

/// Runs `mil sim`.
///
/// # Errors
/// What the command refuses or fails on, one line naming it.
pub fn run(args: Args) -> Result<()> {
    let Args {
        set_up,
        out,
        json,
        board,
        elf,
        duration,
        xcp,
        wait,
    } = args;
    if xcp.is_some() && board != SimBoard::Qemu {
        anyhow::bail!("--xcp serves the XCP port of the board in QEMU: add --board qemu");
    }
    if !(wait.is_finite() && wait > 0.0) {
        anyhow::bail!("--wait: a time in seconds above 0, got {wait}");
    }
    let mut config = set_up.read()?.sim()?;
    crate::cli::check_output_folder(&out)?;
    if let Some(d) = duration {
        config.run.duration_s = d;
    }
    let bar = crate::cli::progress_bar(json, 1000, "simulating the rig");
    let progress = |f: f64| bar.set_position((f * 1000.0) as u64);
    let elf_given = elf.is_some();
    let (result, qemu) = match board {
        SimBoard::Host => (crate::sim::simulate(&config, progress)?, None),
        SimBoard::Qemu => {
            let elf = crate::cli::firmware_elf(elf)?;
            bar.set_message("the firmware in QEMU on the simulated rig");
            let serve = xcp.map(|listen| crate::sim::ServeXcp {
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
            let (r, q) = crate::sim::simulate_on_qemu(&config, &elf, serve, ready, progress)?;
            (r, Some(q))
        }
    };
    // The main job (the built-in example, no filter asked for) also runs with the
    // paper's command filter: the problem and its answer side by side.
    let paper = if set_up.is_builtin() && board == SimBoard::Host {
        let mut file = tempfile::NamedTempFile::new()?;
        std::io::Write::write_all(&mut file, crate::setup::DEFAULT_FILTER.as_bytes())?;
        let mut with = crate::cli::set_up(None, Some(file.path()))?.sim()?;
        if let Some(d) = duration {
            with.run.duration_s = d;
        }
        bar.set_message("the same with the paper's command filter");
        bar.set_position(0);
        Some(crate::sim::simulate(&with, |f: f64| {
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
                "demand frames:  {} compared with the host mirror{}{}, {} mismatches",
                q.demand_frames,
                if q.xcp_served_at.is_some() {
                    " of the set-up"
                } else {
                    ""
                },
                if q.idle_frames > 0 {
                    format!(" (and {} idle before the run)", q.idle_frames)
                } else {
                    String::new()
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
            crate::run::fault_causes(result.summary.fault_flags),
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
