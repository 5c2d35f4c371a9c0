//! `mil identify`: an actuator's frequency response from test records (sine sweep, random
//! noise), as the paper's responses were obtained, written as the frequency-response table
//! that `mil analyze` reads.

use anyhow::{bail, Context, Result};
use mil_identify::{h1_estimate, read_record_csv, FrfTable, Record, WelchOptions};
use serde::Serialize;
use std::path::PathBuf;

/// Options of `mil identify`.
#[derive(Clone, Debug)]
pub struct IdentifyOptions {
    /// Record files (CSV, `time` first); all are averaged together.
    pub records: Vec<PathBuf>,
    /// Input column (e.g. the force command).
    pub input: String,
    /// Output column (e.g. the measured force).
    pub output: String,
    /// Welch segment length (samples); none: the workspace's rule for the shortest record
    /// ([`WelchOptions::for_record`]).
    pub segment_length: Option<usize>,
    /// Band kept in the table (Hz).
    pub band_hz: (f64, f64),
    /// Points with lower coherence are dropped.
    pub min_coherence: f64,
    /// Table file to write.
    pub out: PathBuf,
}

/// Summary of an identification.
#[derive(Clone, Debug, Serialize)]
pub struct IdentifySummary {
    /// Sample rate of the records (Hz).
    pub sample_rate_hz: f64,
    /// Welch segment length used (samples).
    pub segment_length: usize,
    /// Welch segments averaged.
    pub segments: usize,
    /// Points written.
    pub points: usize,
    /// Lowest and highest frequency written (Hz).
    pub frequency_range_hz: (f64, f64),
    /// Lowest coherence among the written points.
    pub min_coherence: f64,
    /// The table file.
    pub table: String,
}

/// Runs the identification and writes the table.
///
/// # Errors
/// Unreadable records, different sample rates, too little coherent data.
pub fn run_identify(o: &IdentifyOptions) -> Result<(FrfTable, IdentifySummary)> {
    if o.records.is_empty() {
        bail!("give at least one record (--data FILE)");
    }
    let mut data = Vec::new();
    let mut rate: Option<f64> = None;
    for path in &o.records {
        let (fs, u, y) = read_record_csv(path, &o.input, &o.output)
            .with_context(|| format!("reading {}", path.display()))?;
        if let Some(r) = rate {
            if (r - fs).abs() > 1e-6 * r {
                bail!(
                    "{} is sampled at {fs} Hz, the first record at {r} Hz",
                    path.display()
                );
            }
        }
        rate = Some(fs);
        data.push((u, y));
    }
    let fs = rate.unwrap_or(1.0);
    let records: Vec<Record<'_>> = data
        .iter()
        .map(|(u, y)| Record {
            input: u,
            output: y,
        })
        .collect();
    let shortest = data.iter().map(|(u, _)| u.len()).min().unwrap_or(0);
    let options = match o.segment_length {
        Some(segment_length) => WelchOptions {
            segment_length,
            ..WelchOptions::default()
        },
        None => WelchOptions::for_record(shortest),
    };
    let estimate = h1_estimate(&records, fs, &options)?;
    let table = estimate.to_table(o.band_hz.0, o.band_hz.1, o.min_coherence)?;
    table.write_csv(&o.out)?;
    let points = table.points();
    let summary = IdentifySummary {
        sample_rate_hz: fs,
        segment_length: options.segment_length,
        segments: estimate.segments,
        points: points.len(),
        frequency_range_hz: table.frequency_range(),
        min_coherence: points
            .iter()
            .filter_map(|p| p.coherence)
            .fold(1.0, f64::min),
        table: o.out.display().to_string(),
    };
    Ok((table, summary))
}

/// Parses `LOW:HIGH` (Hz).
///
/// # Errors
/// Not two increasing positive numbers.
pub fn parse_band(text: &str) -> Result<(f64, f64)> {
    let (a, b) = text
        .split_once(':')
        .context("band must be LOW:HIGH in Hz, e.g. 0.5:140")?;
    let (a, b): (f64, f64) = (a.trim().parse()?, b.trim().parse()?);
    if !(a > 0.0 && b > a) {
        bail!("band {text}: need 0 < LOW < HIGH");
    }
    Ok((a, b))
}
