//! `mil analyze`: the frequency-domain analysis of a MiL set-up, written as a summary table,
//! one JSON object, SVG plots and a CSV of the traces.

use crate::cli::number;
use anyhow::{Context, Result};
use mil_analysis::analyze::{analyze, AnalysisReport};
use mil_analysis::setup::Setup;
use mil_plots::{
    bode_page_svg, bode_svg, xy_svg, BodePlot, BodeSeries, Marker, SeriesStyle, XyPlot, XySeries,
};
use num_complex::Complex64;
use serde::Serialize;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The JSON summary: the MiL loop's figures at top level, the emulated loop's under
/// `emulated`.
#[derive(Serialize)]
pub struct AnalyzeSummary<'a> {
    /// Set-up name.
    pub name: &'a str,
    /// Configuration number (1–4).
    pub configuration: u8,
    /// The MiL loop's elements: actuator, loop delay, velocity estimate, command filter.
    pub mil_loop: &'a mil_analysis::LoopDescription,
    /// MiL gain margin (null: no phase crossover).
    pub gain_margin: Option<f64>,
    /// MiL phase-crossover frequency (Hz).
    pub gain_margin_hz: Option<f64>,
    /// MiL phase margin (degrees).
    pub phase_margin_deg: Option<f64>,
    /// MiL gain-crossover frequency (Hz).
    pub phase_margin_hz: Option<f64>,
    /// Closed-loop stability of the MiL loop.
    pub stability: mil_analysis::Stability,
    /// Resonances of the first response, MiL.
    pub resonances: &'a [mil_analysis::metrics::Resonance],
    /// The emulated loop's figures.
    pub emulated: &'a mil_analysis::analyze::LoopFigures,
    /// Every response with its band errors.
    pub responses: &'a [mil_analysis::analyze::ResponseFigures],
    /// Control sensitivity figures.
    pub noise: &'a mil_analysis::analyze::NoiseFigures,
    /// Files written.
    pub files: Vec<String>,
}

/// Result of the command.
pub struct AnalyzeOutput {
    /// The set-up.
    pub setup: Setup,
    /// The report.
    pub report: AnalysisReport,
    /// Files written.
    pub files: Vec<PathBuf>,
}

impl AnalyzeOutput {
    /// The JSON summary.
    pub fn summary(&self) -> AnalyzeSummary<'_> {
        let r = &self.report;
        AnalyzeSummary {
            name: &self.setup.name,
            configuration: r.configuration,
            mil_loop: &r.mil_loop,
            gain_margin: r.mil.gain_margin,
            gain_margin_hz: r.mil.gain_margin_hz,
            phase_margin_deg: r.mil.phase_margin_deg,
            phase_margin_hz: r.mil.phase_margin_hz,
            stability: r.mil.stability,
            resonances: &r.mil.resonances,
            emulated: &r.emulated,
            responses: &r.responses,
            noise: &r.noise,
            files: self.files.iter().map(|p| p.display().to_string()).collect(),
        }
    }

    /// The human summary table.
    pub fn table(&self) -> String {
        let r = &self.report;
        let mut s = String::new();
        let opt = |v: Option<f64>, d: usize| v.map_or("none".to_string(), |x| format!("{x:.d$}"));
        let _ = writeln!(
            s,
            "set-up {:?}: configuration {}, {} channel(s)",
            self.setup.name, r.configuration, r.channels
        );
        let l = &r.mil_loop;
        let _ = writeln!(s, "MiL loop elements:");
        let _ = writeln!(s, "  actuator control      {}", l.control);
        let _ = writeln!(s, "  tracking response     {}", l.tracking);
        let _ = writeln!(s, "  disturbance response  {}", l.disturbance);
        let _ = writeln!(s, "  loop delay            {:.3} ms", l.loop_delay_s * 1e3);
        let _ = writeln!(s, "  interface velocity    {}", l.velocity);
        let _ = writeln!(
            s,
            "  command filter        {}",
            l.filter.as_deref().unwrap_or("none")
        );
        let _ = writeln!(s, "{:<28} {:>14} {:>14}", "", "MiL", "emulated");
        // Short for the column: the count of right half-plane poles in brackets.
        let stability = |s: mil_analysis::Stability| match s {
            mil_analysis::Stability::Stable => "stable".to_string(),
            mil_analysis::Stability::Unstable(n) => format!("unstable ({n})"),
            mil_analysis::Stability::Unknown => "not determined".to_string(),
        };
        let rows = [
            (
                "closed loop",
                stability(r.mil.stability),
                stability(r.emulated.stability),
            ),
            (
                "gain margin",
                opt(r.mil.gain_margin, 2),
                opt(r.emulated.gain_margin, 2),
            ),
            (
                "  at (Hz)",
                opt(r.mil.gain_margin_hz, 2),
                opt(r.emulated.gain_margin_hz, 2),
            ),
            (
                "phase margin (deg)",
                opt(r.mil.phase_margin_deg, 1),
                opt(r.emulated.phase_margin_deg, 1),
            ),
            (
                "  at (Hz)",
                opt(r.mil.phase_margin_hz, 2),
                opt(r.emulated.phase_margin_hz, 2),
            ),
        ];
        for (name, a, b) in rows {
            let _ = writeln!(s, "{name:<28} {a:>14} {b:>14}");
        }
        if r.mil.stability != mil_analysis::Stability::Stable {
            let _ = writeln!(
                s,
                "WARNING: the MiL loop is not shown stable; its responses below describe no \
                 physical run"
            );
        }
        for resp in &r.responses {
            let _ = writeln!(s, "\nresponse {:?} [{}]", resp.name, resp.unit);
            let fmt = |v: &[mil_analysis::metrics::Resonance]| {
                v.iter()
                    .map(|x| {
                        format!(
                            "{:.2} Hz ({} {}, ζ {:.3})",
                            x.hz,
                            number(x.magnitude, 3),
                            resp.unit,
                            x.damping_ratio
                        )
                    })
                    .collect::<Vec<_>>()
                    .join(", ")
            };
            let _ = writeln!(s, "  resonances MiL:      {}", fmt(&resp.mil_resonances));
            let _ = writeln!(
                s,
                "  resonances emulated: {}",
                fmt(&resp.emulated_resonances)
            );
            let _ = writeln!(
                s,
                "  {:<14} {:>12} {:>12} {:>12} {:>12}",
                "band (Hz)", "max dB", "rms dB", "max deg", "rms deg"
            );
            for b in &resp.band_errors {
                let _ = writeln!(
                    s,
                    "  {:<14} {:>12.2} {:>12.2} {:>12.1} {:>12.1}",
                    format!("{}-{}", b.from_hz, b.to_hz),
                    b.max_magnitude_db,
                    b.rms_magnitude_db,
                    b.max_phase_deg,
                    b.rms_phase_deg
                );
            }
        }
        let n = &r.noise;
        let _ = writeln!(
            s,
            "\ncontrol sensitivity (command per unit measurement noise, SI): peak {} at {:.1} Hz; \
             above 60 Hz {} at {:.1} Hz; command RMS {} for the stated noise",
            number(n.peak, 3),
            n.peak_hz,
            number(n.peak_above_60hz, 3),
            n.peak_above_60hz_hz,
            number(n.command_rms, 3)
        );
        for f in &self.files {
            let _ = writeln!(s, "wrote {}", f.display());
        }
        s
    }
}

fn series(label: &str, f: &[f64], h: &[Complex64], dashed: bool) -> BodeSeries {
    BodeSeries {
        label: label.to_string(),
        frequency_hz: f.to_vec(),
        response: h.to_vec(),
        dashed,
    }
}

/// Writes `responses.svg`, `open-loop.svg`, `noise-sensitivity.svg` and `responses.csv`.
fn write_outputs(report: &AnalysisReport, out: &Path) -> Result<Vec<PathBuf>> {
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let t = &report.traces;
    let f = &t.frequency_hz;
    let mut files = Vec::new();

    // An unstable MiL loop is said on every plot of it: its responses describe no steady
    // state.
    let unstable = match report.mil.stability {
        mil_analysis::Stability::Stable => String::new(),
        mil_analysis::Stability::Unstable(n) => {
            format!(" (MiL loop UNSTABLE: {n} closed-loop pole(s) in the right half-plane)")
        }
        mil_analysis::Stability::Unknown => " (MiL loop stability not determined)".into(),
    };
    let mut pages = Vec::new();
    for (k, resp) in report.responses.iter().enumerate() {
        // In dB, the physical unit alongside (as every response plot of the tools).
        let mut plot = BodePlot::new(
            format!("{}: MiL vs emulated{}", resp.name, unstable),
            format!("{} [dB re 1 {}]", resp.name, resp.unit),
        );
        plot.magnitude_scale = mil_plots::MagnitudeScale::Decibel;
        plot.series = vec![
            series("MiL", f, &t.mil[k], false),
            series("emulated", f, &t.emulated[k], true),
        ];
        plot.markers = resp
            .mil_resonances
            .iter()
            .map(|r| Marker {
                frequency_hz: r.hz,
                label: format!("MiL {:.1} Hz ζ {:.2}", r.hz, r.damping_ratio),
            })
            .collect();
        pages.push(plot);
    }
    let path = out.join("responses.svg");
    bode_page_svg(&path, &pages)?;
    files.push(path);

    let mut open = BodePlot::new(
        format!("Open loop broken at the numerical model's summing junction{unstable}"),
        "|L|",
    );
    for (k, locus) in t.mil_open_loop.iter().enumerate() {
        open.series
            .push(series(&format!("MiL locus {}", k + 1), f, locus, false));
    }
    for (k, locus) in t.emulated_open_loop.iter().enumerate() {
        open.series
            .push(series(&format!("emulated locus {}", k + 1), f, locus, true));
    }
    open.phase_lines = vec![-180.0];
    open.magnitude_lines = vec![1.0];
    if let (Some(gm), Some(hz)) = (report.mil.gain_margin, report.mil.gain_margin_hz) {
        open.markers.push(Marker {
            frequency_hz: hz,
            label: format!("GM {gm:.2} at {hz:.1} Hz"),
        });
    }
    // A configuration without a loop (L ≡ 0, e.g. B_i physical and a massless numerical
    // part) has nothing to draw.
    let has_loop = t
        .mil_open_loop
        .iter()
        .chain(&t.emulated_open_loop)
        .flatten()
        .any(|v| v.norm() > 0.0 && v.is_finite());
    if has_loop {
        let path = out.join("open-loop.svg");
        bode_svg(&path, &open)?;
        files.push(path);
    }

    // A magnitude only (a singular value has no phase): no phase panel.
    let mut noise = XyPlot::new(
        "Control sensitivity: actuator command per unit measurement noise",
        "frequency [Hz]",
        "command / noise (SI)",
    );
    noise.log_x = true;
    noise.log_y = true;
    noise.series = vec![XySeries::new(
        "MiL",
        f.iter()
            .copied()
            .zip(t.noise_sensitivity.iter().copied())
            .collect(),
        SeriesStyle::Line,
    )];
    let path = out.join("noise-sensitivity.svg");
    xy_svg(&path, &noise)?;
    files.push(path);

    let path = out.join("responses.csv");
    // Whole or not at all.
    let mut file = mil_numerics::files::AtomicFile::create(&path)?;
    let mut w = csv::Writer::from_writer(file.writer());
    let mut header = vec!["frequency_hz".to_string()];
    for resp in &report.responses {
        for which in ["mil", "emulated"] {
            header.push(format!("{} {which} magnitude [{}]", resp.name, resp.unit));
            header.push(format!("{} {which} phase [deg]", resp.name));
        }
    }
    header.push("open loop |L| (MiL locus 1)".into());
    header.push("open loop phase [deg] (MiL locus 1)".into());
    header.push("control sensitivity (SI)".into());
    w.write_record(&header)?;
    let mil_phase: Vec<Vec<f64>> = t
        .mil
        .iter()
        .map(|h| mil_analysis::metrics::unwrapped_phase_deg(h))
        .collect();
    let emu_phase: Vec<Vec<f64>> = t
        .emulated
        .iter()
        .map(|h| mil_analysis::metrics::unwrapped_phase_deg(h))
        .collect();
    let open_phase = t
        .mil_open_loop
        .first()
        .map(|l| mil_analysis::metrics::unwrapped_phase_deg(l))
        .unwrap_or_default();
    for i in 0..f.len() {
        let mut row = vec![format!("{:.6}", f[i])];
        for k in 0..report.responses.len() {
            row.push(format!("{:.6e}", t.mil[k][i].norm()));
            row.push(format!("{:.3}", mil_phase[k][i]));
            row.push(format!("{:.6e}", t.emulated[k][i].norm()));
            row.push(format!("{:.3}", emu_phase[k][i]));
        }
        let l = t
            .mil_open_loop
            .first()
            .map_or(Complex64::new(0.0, 0.0), |l| l[i]);
        row.push(format!("{:.6e}", l.norm()));
        row.push(format!("{:.3}", open_phase.get(i).copied().unwrap_or(0.0)));
        row.push(format!("{:.6e}", t.noise_sensitivity[i]));
        w.write_record(&row)?;
    }
    w.flush()?;
    drop(w);
    file.commit()?;
    files.push(path);
    Ok(files)
}

/// Runs `mil analyze` on a MiL set-up.
///
/// # Errors
/// Invalid set-up, analysis failure, or unwritable output folder.
pub fn run_analyze(setup: &crate::setup::SetUp, out: &Path) -> Result<AnalyzeOutput> {
    let setup = setup.analysis()?;
    let report = analyze(&setup.system, &setup.options)?;
    let files = write_outputs(&report, out)?;
    Ok(AnalyzeOutput {
        setup,
        report,
        files,
    })
}
