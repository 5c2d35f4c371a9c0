//! `mil compare`: how close a MiL recording is to the emulated system, or to another run,
//! in the figures `mil sim` reports (J1 delay, J2 normalised RMS error, J3 normalised peak
//! error: `mil_rig::metrics`) and, given the recording's input, in its frequency response.
//!
//! - One record: every `mil_<x>` column against its `emulated_<x>` column (`mil sim`'s
//!   `sim.csv`, or a recording with the emulated system's response beside it).
//! - `--against OTHER`: every column the two records share (but `time`, `mode`, `fault`),
//!   the record against OTHER (e.g. the board in QEMU against the host's controller, a rig
//!   recording against a `mil sim` run of the same road). A `mil daq record` recording's
//!   board signals `position`, `road`, `demand` (channel 0) are compared with a run's
//!   `mil_position_0`, `road_0`, `demand_0`. Same sample rate, same inputs (the road
//!   columns equal to 1 % RMS: a board recording holds the road as quantised on CAN); the
//!   shorter length is compared.
//! - `--input COLUMN`: the responses of both sides to that column (H1, Welch), their
//!   magnitude and phase differences over `--band`, and a Bode diagram.

use crate::sim::{coherent_bins, Deviation};
use anyhow::{bail, Context, Result};
use mil_identify::{h1_estimate, Record, WelchOptions};
use mil_numerics::record::{read, Table};
use mil_plots::{
    bode_svg, xy_svg, BodePlot, BodeSeries, MagnitudeScale, SeriesStyle, XyPlot, XySeries,
};
use mil_rig::metrics::{compare, Comparison};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// `mil compare`'s arguments.
#[derive(Clone, Debug, clap::Args)]
pub struct Args {
    /// The recording (CSV, `time` first): `mil sim`'s `sim.csv`, a `mil daq record` CSV or
    /// a rig's record.
    pub record: PathBuf,
    /// The reference run (CSV): compare the columns both have; without it, every `mil_*`
    /// column against its `emulated_*` column.
    #[arg(long)]
    pub against: Option<PathBuf>,
    /// The input column (e.g. `road_0`): also compare the responses to it.
    #[arg(long)]
    pub input: Option<String>,
    /// Band of the response comparison, LOW:HIGH in Hz.
    #[arg(long, default_value = "1:30")]
    pub band: String,
    /// Skip this many seconds at the start (the settling of the run).
    #[arg(long, default_value_t = 0.5)]
    pub skip: f64,
    /// Output folder (plots).
    #[arg(long, default_value = "out/compare")]
    pub out: PathBuf,
    /// Print one JSON object with the summary.
    #[arg(long)]
    pub json: bool,
}

/// One compared pair of columns.
#[derive(Clone, Debug, Serialize)]
pub struct Pair {
    /// The recording's column.
    pub column: String,
    /// The reference column it is compared with.
    pub reference: String,
    /// Its unit, where a header gives one.
    pub unit: Option<String>,
    /// J1-J3 and the errors.
    pub figures: Comparison,
    /// Response comparison to `--input`: worst magnitude (dB) and phase (degrees)
    /// difference over the band, among points of coherence ≥ 0.9 on both sides.
    pub response: Option<Deviation>,
}

/// What `mil compare` found.
#[derive(Clone, Debug, Serialize)]
pub struct Summary {
    /// The recording.
    pub record: String,
    /// The reference: the other file, or "emulated" columns of the same file.
    pub reference: String,
    /// Sample rate (Hz).
    pub sample_rate_hz: f64,
    /// Seconds compared.
    pub duration_s: f64,
    /// The pairs.
    pub pairs: Vec<Pair>,
    /// Columns equal in both records, sample for sample (not tabled).
    pub identical: Vec<String>,
    /// Plots written.
    pub plots: Vec<String>,
}

fn load(path: &Path) -> Result<(Table, f64)> {
    let table = read(path)?;
    table
        .require_time_first()
        .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    let base = table
        .time_base()
        .map_err(|(line, e)| anyhow::anyhow!("{}: line {line}: {e}", path.display()))?;
    Ok((table, 1.0 / base.dt))
}

/// A compared pair: the record's column, the reference's.
type Columns = (usize, usize);

/// Columns never compared.
const SKIPPED: [&str; 3] = ["time", "mode", "fault"];

/// The board's own signals (A2L measurements, as `mil daq record` names its columns) and the
/// `mil sim` columns of the same quantity: the board measures channel 0.
const BOARD_SIGNALS: [(&str, &str); 3] = [
    ("position", "mil_position_0"),
    ("road", "road_0"),
    ("demand", "demand_0"),
];

/// The column of `table` holding the quantity `name` names: `name` itself, or its
/// counterpart between a board recording and a `mil sim` run ([`BOARD_SIGNALS`]).
fn column_for(table: &Table, name: &str) -> Option<usize> {
    table.index(name).or_else(|| {
        BOARD_SIGNALS.iter().find_map(|&(board, sim)| {
            if name == board {
                table.index(sim)
            } else if name == sim {
                table.index(board)
            } else {
                None
            }
        })
    })
}

/// Two records' input columns are the same input when they differ by less than this
/// fraction of the reference's RMS (RMS of the difference), or by no more than rounding to
/// the coarser record's resolution ([`resolution`]): a board recording holds the road as it
/// came over CAN (quantised, e.g. to 1 µm), a `mil sim` run as it was generated, and a road
/// of a few µm differs from its frames by far more than 1 % of its RMS.
const SAME_INPUT: f64 = 0.01;

/// The step between a column's values when they are quantised: the smallest gap between two
/// of its distinct values (gaps below 1e-9 of its largest value, the text's rounding, are
/// none); 0 for fewer than two distinct values.
fn resolution(x: &[f64]) -> f64 {
    let mut v: Vec<f64> = x.iter().copied().filter(|v| v.is_finite()).collect();
    v.sort_by(f64::total_cmp);
    let floor = 1e-9 * v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let gap = v
        .windows(2)
        .map(|w| w[1] - w[0])
        .filter(|gap| *gap > floor)
        .fold(f64::INFINITY, f64::min);
    if gap.is_finite() {
        gap
    } else {
        0.0
    }
}

/// `a` and `b` are the same input within [`SAME_INPUT`] or their resolution.
fn same_input(a: &[f64], b: &[f64]) -> bool {
    let rms = |x: &mut dyn Iterator<Item = f64>, n: usize| {
        (x.map(|v| v * v).sum::<f64>() / n.max(1) as f64).sqrt()
    };
    let n = a.len().min(b.len());
    let diff = rms(&mut a.iter().zip(b).map(|(x, y)| x - y), n);
    let scale = rms(&mut b.iter().copied(), n);
    // Rounding to the nearest step moves a value by half a step at most.
    let step = resolution(&a[..n]).max(resolution(&b[..n]));
    let worst = a
        .iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max);
    diff <= SAME_INPUT * scale || a[..n] == b[..n] || worst <= 0.5 * step * (1.0 + 1e-6)
}

/// The factor and unit a response `output / input` is plotted in, from the columns' units
/// ([`crate::plot::response_unit`]); none where a column has no unit.
fn response_unit(output: Option<&str>, input: Option<&str>) -> (f64, Option<String>) {
    match (output, input) {
        (Some(a), Some(b)) => {
            let (factor, unit) = crate::plot::response_unit(&format!("{a}/{b}"));
            (factor, Some(unit))
        }
        _ => (1.0, None),
    }
}

/// `dB re 1 UNIT`, or `dB` without a unit.
fn decibel_label(unit: &(f64, Option<String>)) -> String {
    unit.1
        .as_ref()
        .map_or_else(|| "dB".to_string(), |u| format!("dB re 1 {u}"))
}

/// Runs the comparison and writes the plots.
///
/// # Errors
/// Unreadable records, different sample rates, nothing to compare, a missing input column.
pub fn run(args: &Args) -> Result<Summary> {
    let band = crate::identify::parse_band(&args.band)?;
    crate::cli::check_output_folder(&args.out)?;
    if let Some(other) = &args.against {
        let same = |p: &Path| std::fs::canonicalize(p).ok();
        if same(other).is_some() && same(other) == same(&args.record) {
            bail!(
                "{} is compared with itself: give the reference run with --against",
                args.record.display()
            );
        }
    }
    let (record, fs) = load(&args.record)?;
    // The reference: the other run, or the record itself (its emulated_* columns).
    let other = match &args.against {
        Some(path) => Some(load(path)?),
        None => None,
    };
    let reference: &Table = other.as_ref().map_or(&record, |(table, _)| table);
    let (reference_name, pairs): (String, Vec<Columns>) = match (&args.against, &other) {
        (Some(path), Some((table, fs_other))) => {
            let fs_other = *fs_other;
            if (fs_other - fs).abs() > 1e-6 * fs {
                bail!(
                    "{} is sampled at {fs_other:.6} Hz, {} at {fs:.6} Hz: compare runs at one \
                         rate",
                    path.display(),
                    args.record.display()
                );
            }
            let pairs = record
                .names
                .iter()
                .enumerate()
                .filter(|(_, n)| !SKIPPED.contains(&n.as_str()))
                .filter_map(|(i, n)| column_for(table, n).map(|j| (i, j)))
                .collect();
            (path.display().to_string(), pairs)
        }
        _ => {
            let pairs = record
                .names
                .iter()
                .enumerate()
                .filter_map(|(i, n)| {
                    let rest = n.strip_prefix("mil_")?;
                    record.index(&format!("emulated_{rest}")).map(|j| (i, j))
                })
                .collect();
            ("emulated".to_string(), pairs)
        }
    };
    if pairs.is_empty() {
        bail!(
            "{}: nothing to compare: {} (columns: {})",
            args.record.display(),
            if args.against.is_some() {
                "the two records share no column but time"
            } else {
                "no mil_<x> column with an emulated_<x> beside it; give the reference run with \
                 --against"
            },
            record.names.join(",")
        );
    }
    let n = record.rows().min(reference.rows());
    let skip = ((args.skip * fs).round() as usize).min(n.saturating_sub(2));
    if n - skip < 16 {
        bail!(
            "{}: fewer than 16 samples to compare",
            args.record.display()
        );
    }
    let input = match &args.input {
        Some(name) => Some(record.index(name).with_context(|| {
            format!(
                "--input {name}: no such column in {} (columns: {})",
                args.record.display(),
                record.names.join(",")
            )
        })?),
        None => None,
    };
    let input_reference = match &args.input {
        Some(name) => Some(column_for(reference, name).with_context(|| {
            format!(
                "--input {name}: no such column in {reference_name} (columns: {})",
                reference.names.join(",")
            )
        })?),
        None => None,
    };
    // Two runs are comparable only on the same inputs: the road (and speed) columns, and
    // --input, must be equal where both records have them.
    if args.against.is_some() {
        for &(i, j) in &pairs {
            let name = &record.names[i];
            let is_input =
                name.starts_with("road") || name == "speed" || Some(name) == args.input.as_ref();
            if is_input && !same_input(&record.columns[i][..n], &reference.columns[j][..n]) {
                bail!(
                    "{} and {reference_name} were run on different inputs (column `{name}` \
                     differs): compare runs of the same road and length (a generated road \
                     depends on the run's length: give both the same --duration)",
                    args.record.display()
                );
            }
        }
    }
    // Columns equal sample for sample (the same road, the emulated system of the same run)
    // are named once, not tabled.
    let (pairs, identical): (Vec<Columns>, Vec<Columns>) =
        pairs.into_iter().partition(|&(i, j)| {
            args.against.is_none() || record.columns[i][skip..n] != reference.columns[j][skip..n]
        });
    let identical: Vec<String> = identical
        .iter()
        .map(|&(i, _)| record.names[i].clone())
        .collect();
    if pairs.is_empty() {
        // Two runs equal sample for sample: the finding itself (e.g. the board in QEMU and
        // the host's controller on the same road).
        return Ok(Summary {
            record: args.record.display().to_string(),
            reference: reference_name,
            sample_rate_hz: fs,
            duration_s: (n - skip) as f64 / fs,
            pairs: Vec::new(),
            identical,
            plots: Vec::new(),
        });
    }
    let welch = WelchOptions::for_band(n - skip, fs, band.0);
    let mut out = Vec::new();
    let mut bode = Vec::new();
    for &(i, j) in &pairs {
        let (m, d) = (&record.columns[i][skip..n], &reference.columns[j][skip..n]);
        let figures = compare(m, d, fs, 0.1);
        let response = match (input, input_reference) {
            (Some(u), Some(v)) => {
                let mine = h1_estimate(
                    &[Record {
                        input: &record.columns[u][skip..n],
                        output: m,
                    }],
                    fs,
                    &welch,
                )?;
                let theirs = h1_estimate(
                    &[Record {
                        input: &reference.columns[v][skip..n],
                        output: d,
                    }],
                    fs,
                    &welch,
                )?;
                let bins = coherent_bins(&mine, &theirs, band);
                let at = |e: &mil_identify::FrfEstimate| -> Vec<_> {
                    bins.iter().map(|&k| e.response[k]).collect()
                };
                let worst = Deviation::worst(&at(&mine), &at(&theirs));
                let keep =
                    |e: &mil_identify::FrfEstimate| -> (Vec<f64>, Vec<num_complex::Complex64>) {
                        e.frequency_hz
                            .iter()
                            .zip(&e.response)
                            .filter(|(f, _)| **f >= 0.5 * band.0 && **f <= 2.0 * band.1)
                            .map(|(f, r)| (*f, *r))
                            .unzip()
                    };
                let (fa, ra) = keep(&mine);
                let (fb, rb) = keep(&theirs);
                // The response's unit from the headers, force per road in N/mm as every
                // command shows it.
                let response_unit =
                    response_unit(record.units[i].as_deref(), record.units[u].as_deref());
                let mut plot = BodePlot::new(
                    format!(
                        "{} / {}: {} against {reference_name}",
                        record.names[i],
                        record.names[u],
                        args.record.display()
                    ),
                    format!(
                        "{} / {} [{}]",
                        record.names[i],
                        record.names[u],
                        decibel_label(&response_unit)
                    ),
                );
                plot.magnitude_scale = MagnitudeScale::Decibel;
                plot.magnitude_factor = response_unit.0;
                plot.frequency_span = Some([band.0, band.1]);
                let mut theirs_series = BodeSeries::new(reference.names[j].clone(), fb, rb);
                theirs_series.dashed = true;
                plot.series = vec![
                    BodeSeries::new(record.names[i].clone(), fa, ra),
                    theirs_series,
                ];
                bode.push(plot);
                worst
            }
            _ => None,
        };
        out.push(Pair {
            column: record.names[i].clone(),
            reference: reference.names[j].clone(),
            unit: record.units[i].clone(),
            figures,
            response,
        });
    }
    let mut plots = Vec::new();
    // The pair with the largest J2 over the second around its largest error.
    if let Some((k, &(i, j))) = pairs.iter().enumerate().max_by(|a, b| {
        let j2 = |p: &Pair| p.figures.nrms_error_pct.unwrap_or(0.0);
        j2(&out[a.0]).total_cmp(&j2(&out[b.0]))
    }) {
        let (m, d) = (&record.columns[i][skip..n], &reference.columns[j][skip..n]);
        let worst = (0..m.len())
            .max_by(|&a, &b| (m[a] - d[a]).abs().total_cmp(&(m[b] - d[b]).abs()))
            .unwrap_or(0);
        let half = (0.5 * fs) as usize;
        let (a, b) = (worst.saturating_sub(half), (worst + half).min(m.len()));
        let t = |s: usize| (s + skip) as f64 / fs;
        let unit = out[k]
            .unit
            .as_deref()
            .map_or(String::new(), |u| format!(" [{u}]"));
        let mut plot = XyPlot::new(
            format!(
                "{}: {} against {} (J2 {:.1} %), around the largest error",
                args.record.display(),
                out[k].column,
                out[k].reference,
                out[k].figures.nrms_error_pct.unwrap_or(f64::NAN)
            ),
            "time [s]",
            format!("{}{unit}", out[k].column),
        );
        plot.series = vec![
            XySeries::new(
                format!("{} (reference)", out[k].reference),
                (a..b).map(|s| (t(s), d[s])).collect(),
                SeriesStyle::Dashed,
            ),
            XySeries::new(
                out[k].column.clone(),
                (a..b).map(|s| (t(s), m[s])).collect(),
                SeriesStyle::Line,
            ),
        ];
        let path = args.out.join("time.svg");
        xy_svg(&path, &plot)?;
        plots.push(path);
    }
    for (k, plot) in bode.iter().enumerate() {
        let path = args.out.join(format!("response-{}.svg", out[k].column));
        bode_svg(&path, plot)?;
        plots.push(path);
    }
    Ok(Summary {
        record: args.record.display().to_string(),
        reference: reference_name,
        sample_rate_hz: fs,
        duration_s: (n - skip) as f64 / fs,
        pairs: out,
        identical,
        plots: plots.iter().map(|p| p.display().to_string()).collect(),
    })
}

impl Summary {
    /// The summary as a table.
    pub fn text(&self) -> String {
        let mut out = format!(
            "{} against {}: {:.2} s at {} Hz\n",
            self.record, self.reference, self.duration_s, self.sample_rate_hz
        );
        if !self.pairs.is_empty() {
            out.push_str(
                "J1 delay at the cross-correlation peak (ms, > 0: the record lags), J2 \
                 normalised RMS error (%), J3 normalised peak error (%)\n",
            );
        }
        if self.pairs.is_empty() {
            out.push_str(&format!(
                "equal in every shared column, sample for sample: {}",
                self.identical.join(", ")
            ));
            return out;
        }
        out.push_str(&format!(
            "{:<24} {:<24} {:>9} {:>9} {:>9} {:>12}",
            "column", "reference", "J1 ms", "J2 %", "J3 %", "RMS error"
        ));
        let with_response = self.pairs.iter().any(|p| p.response.is_some());
        if with_response {
            out.push_str(&format!(" {:>9} {:>9}", "resp. dB", "resp. deg"));
        }
        out.push('\n');
        // Rounded first, so that a value that rounds to zero prints as 0, not -0.
        let opt = |v: Option<f64>, digits: usize| {
            v.map_or("-".to_string(), |v| {
                let scale = 10f64.powi(digits as i32);
                format!("{:.digits$}", (v * scale).round() / scale + 0.0)
            })
        };
        for p in &self.pairs {
            out.push_str(&format!(
                "{:<24} {:<24} {:>9} {:>9} {:>9} {:>12}",
                p.column,
                p.reference,
                opt(p.figures.delay_ms, 2),
                opt(p.figures.nrms_error_pct, 1),
                opt(p.figures.peak_error_pct, 1),
                format!(
                    "{}{}",
                    crate::cli::number(p.figures.rms_error, 3),
                    p.unit.as_deref().map_or(String::new(), |u| format!(" {u}"))
                ),
            ));
            if with_response {
                out.push_str(&format!(
                    " {:>9} {:>9}",
                    opt(p.response.map(|r| r.db), 2),
                    opt(p.response.map(|r| r.deg), 1)
                ));
            }
            out.push('\n');
        }
        if !self.identical.is_empty() {
            out.push_str(&format!("equal in both: {}\n", self.identical.join(", ")));
        }
        for p in &self.plots {
            out.push_str(&format!("wrote {p}\n"));
        }
        out.pop();
        out
    }
}
