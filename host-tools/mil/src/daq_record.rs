//! `mil daq record`: signals of the board recorded by XCP DAQ on its control-step event, with
//! the board's own timestamps, into a CSV file (`time` in s from the first sample, then the
//! signals in the A2L's SI units) or, for a file named `*.mf4` or `*.mdf`, into ASAM MDF 4
//! (one channel group: the master channel `time` in s, then one f64 channel per signal,
//! named as the signal, with the A2L's unit).

use std::io::Write as _;
use std::path::Path;
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
    /// The file: MDF 4 for `*.mf4` or `*.mdf` ([`is_mdf`]), else CSV.
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
    /// Why the board's samples stopped before the length asked for (the board stopped
    /// stepping, its port closed: e.g. a served run that ended), after at least one sample;
    /// the file holds the samples recorded up to then.
    pub ended_early: Option<String>,
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

/// Whether `path` is written as MDF 4: its extension is `mf4` or `mdf` (any case).
#[must_use]
pub fn is_mdf(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("mf4") || e.eq_ignore_ascii_case("mdf"))
}

/// Where the samples go.
enum Sink {
    /// Written whole at the end (a recording that fails before its first sample leaves no
    /// file).
    Csv(mil_numerics::files::AtomicFile),
    Mdf {
        writer: Box<mdf4_rs::MdfWriter<mdf4_rs::writer::FileWriter>>,
        group: String,
        record: Vec<mdf4_rs::DecodedValue>,
    },
}

impl Sink {
    /// Creates `out` and writes the header: the CSV's first line, or the MDF 4 blocks down to
    /// the channels, with the data block opened.
    fn create(out: &Path, signals: &[&Item]) -> Result<Self> {
        if !is_mdf(out) {
            let mut w = mil_numerics::files::AtomicFile::create(out)?;
            // Each column with its unit (the A2L's; `-` is none).
            let mut header = vec!["time [s]".to_string()];
            header.extend(signals.iter().map(|s| match s.unit.as_str() {
                "-" | "" => s.name.clone(),
                unit => format!("{} [{unit}]", s.name),
            }));
            writeln!(w, "{}", header.join(","))?;
            return Ok(Self::Csv(w));
        }
        let path = out
            .to_str()
            .with_context(|| format!("{}: an MDF file name must be UTF-8", out.display()))?;
        let context = || format!("cannot create {}", out.display());
        let mut writer = Box::new(mdf4_rs::MdfWriter::new(path).with_context(context)?);
        let group = (|| -> mdf4_rs::Result<String> {
            use mdf4_rs::DataType;
            writer.init_mdf_file()?;
            let group = writer.add_channel_group(None, |_| {})?;
            writer.set_channel_group_name(&group, "daq")?;
            let channel = |name: &str| {
                let name = name.to_string();
                move |ch: &mut mdf4_rs::blocks::ChannelBlock| {
                    ch.data_type = DataType::FloatLE;
                    ch.bit_count = 64;
                    ch.name = Some(name);
                }
            };
            let time = writer.add_channel(&group, None, channel("time"))?;
            writer.set_time_channel(&time)?;
            writer.set_channel_unit(&time, "s")?;
            let mut prev = time;
            for s in signals {
                let cn = writer.add_channel(&group, Some(&prev), channel(&s.name))?;
                // The A2L's `-` (or nothing) is no unit.
                if s.unit != "-" {
                    writer.set_channel_unit(&cn, &s.unit)?;
                }
                if !s.description.is_empty() {
                    writer.set_channel_comment(&cn, &s.description)?;
                }
                prev = cn;
            }
            writer.start_data_block_for_cg(&group, 0)?;
            Ok(group)
        })()
        .with_context(context)?;
        Ok(Self::Mdf {
            writer,
            group,
            record: Vec::with_capacity(signals.len() + 1),
        })
    }

    /// Writes one sample: the time (s) and the signals' physical values.
    fn write(&mut self, signals: &[&Item], time_s: f64, values: &[f64]) -> Result<()> {
        match self {
            Self::Csv(w) => {
                write!(w, "{time_s:.6}")?;
                for (item, v) in signals.iter().zip(values) {
                    write!(w, ",{}", format_value(item, *v))?;
                }
                writeln!(w)?;
            }
            Self::Mdf {
                writer,
                group,
                record,
            } => {
                use mdf4_rs::DecodedValue::Float;
                record.clear();
                record.push(Float(time_s));
                record.extend(values.iter().map(|v| Float(*v)));
                writer.write_record(group, record)?;
            }
        }
        Ok(())
    }

    /// Flushes the file; for MDF 4, closes the data block so that the file is complete.
    fn finish(self) -> Result<()> {
        match self {
            Self::Csv(w) => w.commit()?,
            Self::Mdf {
                mut writer, group, ..
            } => {
                writer.finish_data_block(&group)?;
                writer.finalize()?;
            }
        }
        Ok(())
    }
}

/// Unlocks DAQ with `secret`, records `signals` as `request` says (or until `stop()` says
/// so), writes the CSV (or MDF 4, [`is_mdf`]) and stops and frees the DAQ list. `progress(done)` is called with
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
    let mut sink = Sink::create(out, signals)?;

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
    let mut ended_early = None;
    let mut samples = 0u64;
    let mut span_s = 0.0;
    let result: Result<()> = (|| {
        loop {
            if stop() {
                interrupted = true;
                break;
            }
            let s = match session.next_sample(timeout) {
                Ok(s) => s,
                // The board's samples stopped after some came: what came is the recording.
                Err(e) if samples > 0 => {
                    ended_early = Some(e.to_string());
                    break;
                }
                Err(e) => return Err(e.into()),
            };
            if let Length::Duration(d) = length {
                if s.time_s >= d {
                    break;
                }
            }
            sink.write(signals, s.time_s, &s.values)?;
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
    // Stop and free the list whatever happened; complete the file with what was recorded
    // (a CSV with no sample is not left behind).
    let session_stats = session.stats();
    let stopped = session.stop();
    if let Err(e) = result {
        if let Sink::Mdf { .. } = sink {
            // Already on disk: closed whole.
            let _ = sink.finish();
        }
        return Err(e);
    }
    let finished = sink
        .finish()
        .with_context(|| format!("cannot write {}", out.display()));
    // A board whose samples stopped may no longer answer the stop: its counts are the
    // session's own.
    let stats = match (stopped, &ended_early) {
        (Ok(stats), _) => stats,
        (Err(_), Some(_)) => session_stats,
        (Err(e), None) => return Err(e.into()),
    };
    finished?;
    Ok(Recorded {
        samples,
        span_s,
        event_cycle_s,
        board_prescaler,
        host_prescaler,
        stats,
        dtos_per_sample,
        interrupted,
        ended_early,
    })
}
