//! `mil identify`: an actuator's frequency response from test records (sine sweep, random
//! noise), as the paper's responses were obtained, written as the frequency-response table
//! that `mil analyze` reads.

use anyhow::{bail, Context, Result};
use mil_analysis::measured::MeasuredResponse;
use mil_identify::{h1_estimate, read_record_csv, FrfTable, Record, WelchOptions};
use mil_plots::{
    bode_svg, xy_svg, BodePlot, BodeSeries, MagnitudeScale, Marker, SeriesStyle, XyPlot, XySeries,
};
use serde::Serialize;
use std::path::{Path, PathBuf};

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
    /// Read as an actuator's tracking response (what `[actuator] tracking = { table = .. }`
    /// does with it): its bandwidth, equivalent delay and fitted model, or why `mil analyze`
    /// would refuse it.
    pub tracking: Tracking,
    /// Plots written: the Bode diagram of the table with the fitted model, and the
    /// coherence.
    pub plots: Vec<String>,
}

/// The table read as a tracking response.
#[derive(Clone, Debug, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Tracking {
    /// `mil analyze` and `mil design-filter` can use it, extended by its fitted model.
    Usable {
        /// −3 dB bandwidth from the measurement (Hz).
        bandwidth_hz: f64,
        /// Phase lag at the bandwidth as a delay (ms).
        equivalent_delay_ms: f64,
        /// The fitted model, in words.
        model: String,
        /// RMS magnitude difference between the model and the table (dB).
        fit_rms_db: f64,
        /// RMS phase difference (degrees).
        fit_rms_deg: f64,
    },
    /// Why the analysis would refuse it (e.g. it stops short of the bandwidth).
    Refused(String),
}

/// An identification error naming the record's file and columns (the estimator numbers
/// records and calls them input and output).
fn named(e: mil_identify::IdentifyError, o: &IdentifyOptions) -> anyhow::Error {
    use mil_identify::IdentifyError as E;
    let file = |i: usize| {
        o.records
            .get(i)
            .map_or_else(|| format!("record {i}"), |p| p.display().to_string())
    };
    let column = |signal: &str| {
        if signal == "input" {
            o.input.clone()
        } else {
            o.output.clone()
        }
    };
    match e {
        E::LengthMismatch {
            record,
            input,
            output,
        } => anyhow::anyhow!(
            "{}: {} has {input} samples but {} has {output}",
            file(record),
            o.input,
            o.output
        ),
        E::RecordTooShort {
            record,
            samples,
            segment_length,
        } => anyhow::anyhow!(
            "{}: {samples} samples is shorter than one segment of {segment_length} samples: \
             record longer, or give a shorter --segment",
            file(record)
        ),
        E::NonFinite {
            record,
            signal,
            index,
            value,
        } => anyhow::anyhow!(
            "{}: {} sample {index} is not finite ({value})",
            file(record),
            column(signal)
        ),
        other => other.into(),
    }
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
        // Its errors name the file.
        let (fs, u, y) = read_record_csv(path, &o.input, &o.output)?;
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
    let estimate = h1_estimate(&records, fs, &options).map_err(|e| named(e, o))?;
    let table = estimate.to_table(o.band_hz.0, o.band_hz.1, o.min_coherence)?;
    crate::cli::write_atomic(&o.out, |w| Ok(table.to_writer(w)?))?;
    let measured = MeasuredResponse::new(table.clone(), &o.out.display().to_string());
    let plots = write_plots(&table, measured.as_ref().ok(), &o.out, &o.input, &o.output)?;
    let tracking = match &measured {
        Ok(m) => {
            let (bandwidth_hz, delay_s) = m.bandwidth();
            Tracking::Usable {
                bandwidth_hz,
                equivalent_delay_ms: delay_s * 1e3,
                model: m.fit().describe(),
                fit_rms_db: m.fit().rms_db,
                fit_rms_deg: m.fit().rms_deg,
            }
        }
        Err(mil_analysis::AnalysisError::Setup(why)) => Tracking::Refused(why.clone()),
        Err(e) => Tracking::Refused(e.to_string()),
    };
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
        tracking,
        plots: plots.iter().map(|p| p.display().to_string()).collect(),
    };
    Ok((table, summary))
}

impl IdentifySummary {
    /// The summary as lines of text.
    pub fn text(&self) -> String {
        let mut out = format!(
            "{} points, {:.2}-{:.1} Hz, {} segments of {} samples at {} Hz, lowest coherence \
             {:.3}\n",
            self.points,
            self.frequency_range_hz.0,
            self.frequency_range_hz.1,
            self.segments,
            self.segment_length,
            self.sample_rate_hz,
            self.min_coherence,
        );
        match &self.tracking {
            Tracking::Usable {
                bandwidth_hz,
                equivalent_delay_ms,
                model,
                fit_rms_db,
                fit_rms_deg,
            } => out.push_str(&format!(
                "as a tracking response: bandwidth (-3 dB) {bandwidth_hz:.1} Hz, equivalent \
                 delay {equivalent_delay_ms:.2} ms (the phase lag there)\nfitted model: \
                 {model} ({fit_rms_db:.2} dB / {fit_rms_deg:.1} deg RMS); `mil analyze` \
                 extends the table with it beyond {:.1}-{:.1} Hz\n",
                self.frequency_range_hz.0, self.frequency_range_hz.1
            )),
            Tracking::Refused(why) => out.push_str(&format!(
                "as a tracking response it cannot be used yet: {why}\n"
            )),
        }
        out.push_str(&format!("wrote {}", self.table));
        for p in &self.plots {
            out.push_str(&format!("\nwrote {p}"));
        }
        out
    }
}

/// Writes `<table stem>.svg` (Bode diagram: the table, and the fitted model with the
/// extension `mil analyze` uses, from a tenth of its lowest to four times its highest
/// frequency, the bandwidth marked) and `<table stem>-coherence.svg`.
fn write_plots(
    table: &FrfTable,
    measured: Option<&MeasuredResponse>,
    out: &Path,
    input: &str,
    output: &str,
) -> Result<Vec<PathBuf>> {
    let stem = out.with_extension("");
    let bode_path = stem.with_extension("svg");
    let coherence_path = PathBuf::from(format!("{}-coherence.svg", stem.display()));
    let points = table.points();
    let f: Vec<f64> = points.iter().map(|p| p.frequency_hz).collect();
    let mut plot = BodePlot::new(
        format!("{output} / {input}: measured frequency response"),
        format!("{output} / {input} [dB]"),
    );
    plot.magnitude_scale = MagnitudeScale::Decibel;
    plot.series.push(BodeSeries::new(
        "measured",
        f.clone(),
        points.iter().map(|p| p.complex()).collect(),
    ));
    plot.magnitude_lines = vec![0.0, -3.0];
    if let Some(m) = measured {
        let (lo, hi) = table.frequency_range();
        let grid: Vec<f64> = (0..=400)
            .map(|i| 0.1 * lo * (40.0 * hi / lo).powf(f64::from(i) / 400.0))
            .collect();
        let mut extended = BodeSeries::new(
            "as the analysis extends it",
            grid.clone(),
            grid.iter().map(|&x| m.response(x)).collect(),
        );
        extended.dashed = true;
        plot.series.push(extended);
        let mut model = BodeSeries::new(
            format!("fitted model ({})", m.fit().describe()),
            grid.clone(),
            grid.iter().map(|&x| m.fit().response(x)).collect(),
        );
        model.dashed = true;
        plot.series.push(model);
        let (bandwidth, delay) = m.bandwidth();
        plot.markers.push(Marker::new(
            bandwidth,
            format!("bandwidth {bandwidth:.1} Hz, {:.2} ms", delay * 1e3),
        ));
    }
    bode_svg(&bode_path, &plot)?;
    if table.has_coherence() {
        let mut coherence = XyPlot::new(
            format!("{output} / {input}: coherence of the kept points"),
            "frequency [Hz]",
            "coherence [-]",
        );
        coherence.log_x = true;
        coherence.series.push(XySeries::new(
            "coherence",
            points
                .iter()
                .map(|p| (p.frequency_hz, p.coherence.unwrap_or(f64::NAN)))
                .collect(),
            SeriesStyle::Points,
        ));
        xy_svg(&coherence_path, &coherence)?;
        return Ok(vec![bode_path, coherence_path]);
    }
    Ok(vec![bode_path])
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
