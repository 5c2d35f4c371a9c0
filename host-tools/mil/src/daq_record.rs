//! `mil daq record`: signals of the board recorded by XCP DAQ on its control-step event, with
//! the board's own timestamps, into a CSV file (`time` in s from the first sample, then the
//! signals in the A2L's SI units).

use std::io::Write as _;
use std::time::Duration;

use anyhow::{bail, Context, Result};
use mil_can::Transport;
use mil_xcp_master::{resource, A2l, DaqOptions, DaqStats, Item, Master};

use crate::xcp::format_value;

/// When a recording ends.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Length {
    /// After this many seconds of board time.
    Duration(f64),
    /// After this many samples.
    Samples(u64),
}

/// What to record into which file.
#[derive(Clone, Debug, PartialEq)]
pub struct Request {
    /// Keep every N-th control step (≥ 1).
    pub prescaler: u16,
    /// When to end.
    pub length: Length,
    /// The CSV file.
    pub out: std::path::PathBuf,
}

/// What a recording did.
#[derive(Clone, Debug, PartialEq)]
pub struct Recorded {
    /// Samples written.
    pub samples: u64,
    /// Board time covered (s, first to last sample).
    pub span_s: f64,
    /// The event's cycle as the board reports it (s).
    pub event_cycle_s: Option<f64>,
    /// The prescaler the board applied.
    pub board_prescaler: u8,
    /// The part of the prescaler applied on the host (every n-th of the board's samples).
    pub host_prescaler: u16,
    /// The session's counts.
    pub stats: DaqStats,
    /// DTOs (CAN frames) per sample on the bus.
    pub dtos_per_sample: usize,
    /// Ended early by `stop`.
    pub interrupted: bool,
}

/// The signals `names`: measurements first, then characteristics (the board samples both).
///
/// # Errors
/// A name the A2L does not have, or none given.
pub fn resolve_signals<'a>(a2l: &'a A2l, names: &[String]) -> Result<Vec<&'a Item>> {
    if names.is_empty() {
        bail!("no signals: give --signals a,b,c");
    }
    let mut out: Vec<&Item> = Vec::new();
    for n in names {
        let item = a2l
            .measurement(n)
            .or_else(|e| a2l.characteristic(n).map_err(|_| e))?;
        if out.iter().any(|i| i.name == item.name) {
            bail!("signal {n} is given twice");
        }
        out.push(item);
    }
    Ok(out)
}

/// Unlocks DAQ with `secret`, records `signals` as `request` says (or until `stop()` says
/// so), writes the CSV and stops and frees the DAQ list. `progress(done)` is called with
/// the fraction done.
///
/// # Errors
/// A wrong secret, the board's errors, no DAQ data (controller not stepping), I/O.
pub fn record<T: Transport>(
    master: &mut Master<T>,
    signals: &[&Item],
    secret: &[u8],
    request: &Request,
    mut progress: impl FnMut(f64),
    stop: impl Fn() -> bool,
) -> Result<Recorded> {
    let (prescaler, length, out) = (request.prescaler, request.length, request.out.as_path());
    if prescaler == 0 {
        bail!("--prescaler must be at least 1");
    }
    match length {
        Length::Duration(d) if !(d.is_finite() && d > 0.0) => bail!("--duration must be > 0 s"),
        Length::Samples(0) => bail!("--samples must be at least 1"),
        _ => {}
    }
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    }
    let file =
        std::fs::File::create(out).with_context(|| format!("cannot create {}", out.display()))?;
    let mut w = std::io::BufWriter::new(file);
    let mut header = vec!["time".to_string()];
    header.extend(signals.iter().map(|s| s.name.clone()));
    writeln!(w, "{}", header.join(","))?;

    master.unlock(resource::DAQ, secret)?;
    let timeout = master.timeout().max(Duration::from_millis(500));
    let options = DaqOptions {
        prescaler,
        ..DaqOptions::default()
    };
    let mut session = master.start_daq(signals, options)?;
    let event_cycle_s = session.event_cycle_s();
    let (board_prescaler, host_prescaler) = (session.board_prescaler(), session.host_prescaler());
    let dtos_per_sample = session.plan().odts.len();
    let mut interrupted = false;
    let mut samples = 0u64;
    let mut span_s = 0.0;
    let result: Result<()> = (|| {
        loop {
            if stop() {
                interrupted = true;
                break;
            }
            let s = session.next_sample(timeout)?;
            if let Length::Duration(d) = length {
                if s.time_s >= d {
                    break;
                }
            }
            write!(w, "{:.6}", s.time_s)?;
            for (item, v) in signals.iter().zip(&s.values) {
                write!(w, ",{}", format_value(item, *v))?;
            }
            writeln!(w)?;
            samples += 1;
            span_s = s.time_s;
            match length {
                Length::Samples(n) => {
                    progress(samples as f64 / n as f64);
                    if samples >= n {
                        break;
                    }
                }
                Length::Duration(d) => progress(s.time_s / d),
            }
        }
        Ok(())
    })();
    // Stop and free the list whatever happened.
    let stopped = session.stop();
    result?;
    let stats = stopped?;
    w.flush()?;
    Ok(Recorded {
        samples,
        span_s,
        event_cycle_s,
        board_prescaler,
        host_prescaler,
        stats,
        dtos_per_sample,
        interrupted,
    })
}
