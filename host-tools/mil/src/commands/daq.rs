//! `mil daq record`: the board's signals recorded by XCP DAQ into CSV or MDF 4.

use crate::xcp::BoardArgs;
use anyhow::Result;
use std::path::PathBuf;

/// The subcommands of `mil daq`.
#[derive(clap::Subcommand, Debug)]
pub enum DaqCommand {
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
        /// The board: its A2L file and how to reach it.
        #[command(flatten)]
        board: BoardArgs,
    },
}

/// Runs `mil daq ...`.
///
/// # Errors
/// What the board or the tool refuses, one line naming it.
pub fn run(command: DaqCommand) -> Result<()> {
    let DaqCommand::Record {
        signals,
        out,
        duration,
        samples,
        prescaler,
        board,
    } = command;
    let a2l = crate::xcp::load_a2l(&board.a2l)?;
    let items = crate::daq_record::resolve_signals(&a2l, &signals)?;
    let length = match (duration, samples) {
        (_, Some(n)) => crate::daq_record::Length::Samples(n),
        (Some(d), None) => crate::daq_record::Length::Duration(d),
        (None, None) => crate::daq_record::Length::Duration(10.0),
    };
    let secret = crate::xcp::secret(&board)?;
    let bar = crate::cli::progress_bar(false, 1000, "recording");
    // Ctrl-C ends the recording early and cleanly: the list is stopped and freed on the
    // board (else it would keep sampling, and loading the bus, until the next CONNECT).
    let interrupt = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    {
        let interrupt = std::sync::Arc::clone(&interrupt);
        ctrlc::set_handler(move || interrupt.store(true, std::sync::atomic::Ordering::Relaxed))
            .map_err(|e| anyhow::anyhow!("cannot install the Ctrl-C handler: {e}"))?;
    }
    let request = crate::daq_record::Request {
        prescaler,
        length,
        out: out.clone(),
    };
    let recorded = crate::xcp::session(&board, &a2l, |m| {
        crate::daq_record::record(
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
    if let Some(why) = &recorded.ended_early {
        // The samples that came are the file; the shortfall is the command's failure.
        let asked = match length {
            crate::daq_record::Length::Duration(d) => format!("{d} s asked for"),
            crate::daq_record::Length::Samples(n) => format!("{n} samples asked for"),
        };
        anyhow::bail!(
            "the board's samples stopped after {:.3} s ({asked}): {why}; {} holds the {} \
             samples recorded (did the run on the board end, e.g. a `mil sim --xcp` run \
             shorter than the recording?)",
            recorded.span_s,
            out.display(),
            recorded.samples
        );
    }
    Ok(())
}
