//! `mil design-filter`: command-filter design for a MiL set-up (the paper's least-squares
//! method or the optimised trade-off), exported as a filter file with plots and figures.

use anyhow::{bail, Context, Result};
use mil_analysis::design::{
    command_path, design_ls, design_optimal, with_filter, DesignOptions, DesignTarget,
    FilterDesign, FilterFigures, FilterStructure, DEFAULT_WEIGHTS,
};
use mil_analysis::filter_file::FilterFile;
use mil_analysis::metrics::log_grid;
use mil_analysis::setup::Setup;
use mil_analysis::{Loop, LoopPoint, MilSystem};
use mil_plots::{
    bode_page_svg, bode_svg, xy_svg, Annotation, BodePlot, BodeSeries, MagnitudeScale, Marker,
    SeriesStyle, XyPlot, XySeries,
};
use num_complex::Complex64;
use serde::Serialize;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Design method.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// The paper's least-squares fit (fixed roll-off poles).
    Ls,
    /// The optimised trade-off between MiL-vs-emulated error and noise sensitivity.
    Optimal,
}

impl std::fmt::Display for Method {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Method::Ls => "least squares",
            Method::Optimal => "optimal",
        })
    }
}

/// Options of the command beyond the set-up file.
#[derive(Clone, Debug)]
pub struct DesignRequest {
    /// Method.
    pub method: Method,
    /// Filter file to write.
    pub out: PathBuf,
    /// Pole structure (`None`: the paper's).
    pub structure: Option<FilterStructure>,
    /// Trade-off weights of the optimised method (`None`: the default sweep).
    pub weights: Option<Vec<f64>>,
}

/// One point of the trade-off front in the JSON summary.
#[derive(Serialize)]
pub struct FrontSummary {
    /// Weight of the noise term.
    pub weight: f64,
    /// Whether the point meets the target.
    pub meets_target: bool,
    /// Its figures.
    pub figures: FilterFigures,
}

/// The JSON summary: the chosen filter's figures at top level.
#[derive(Serialize)]
pub struct DesignSummary {
    /// Set-up name.
    pub name: String,
    /// Method.
    pub method: Method,
    /// Filter file written.
    pub file: String,
    /// Sample rate of the cascade (Hz).
    pub sample_rate_hz: f64,
    /// Number of second-order sections.
    pub sections: usize,
    /// Roll-off frequency of the design (Hz).
    pub rolloff_hz: f64,
    /// Phase-lag reduction over 0.5–30 Hz (%).
    pub phase_lag_reduction_pct: f64,
    /// Worst command-path magnitude error over 0.5–30 Hz (dB).
    pub magnitude_error_db: f64,
    /// Noise-sensitivity peak (60 Hz to Nyquist) with / without filter.
    pub noise_sensitivity_ratio: f64,
    /// With / without noise sensitivity at the filtered peak's frequency.
    pub noise_ratio_at_peak: f64,
    /// Frequency of the filtered noise-sensitivity peak (Hz).
    pub noise_peak_hz: f64,
    /// MiL gain margin with the filter (null: no phase crossover).
    pub gain_margin_with_filter: Option<f64>,
    /// MiL gain margin without filter.
    pub gain_margin_without: Option<f64>,
    /// Closed-loop stability with the filter.
    pub stability_with_filter: mil_analysis::Stability,
    /// All figures of the chosen filter.
    pub figures: FilterFigures,
    /// Optimised method: the target.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub target: Option<DesignTarget>,
    /// Optimised method: whether the chosen filter meets the target.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub target_met: Option<bool>,
    /// Optimised method: the weight of the chosen filter (null: the least-squares design).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub chosen_weight: Option<Option<f64>>,
    /// Optimised method: the trade-off front.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub front: Option<Vec<FrontSummary>>,
    /// Files written.
    pub files: Vec<String>,
}

/// Result of the command.
pub struct DesignOutput {
    /// The set-up.
    pub setup: Setup,
    /// The exported design.
    pub design: FilterDesign,
    /// The summary.
    pub summary: DesignSummary,
}

impl DesignOutput {
    /// The human summary table.
    pub fn table(&self) -> String {
        let s = &self.summary;
        let f = &s.figures;
        let opt = |v: Option<f64>| v.map_or("none".to_string(), |g| format!("{g:.2}"));
        let mut t = String::new();
        let _ = writeln!(
            t,
            "command filter for {} ({}, {} sections at {} Hz, roll-off {:.1} Hz)",
            s.name, s.method, s.sections, s.sample_rate_hz, s.rolloff_hz
        );
        let _ = writeln!(t, "{:<44} {:>12} {:>12}", "", "without", "with filter");
        let _ = writeln!(
            t,
            "{:<44} {:>12.1} {:>12.1}",
            "mean phase lag 0.5-30 Hz [deg]",
            f.mean_phase_lag_without_deg,
            f.mean_phase_lag_with_deg
        );
        let _ = writeln!(
            t,
            "{:<44} {:>12.2} {:>12.2}",
            "worst magnitude error 0.5-30 Hz [dB]",
            f.magnitude_error_without_db,
            f.magnitude_error_db
        );
        let _ = writeln!(
            t,
            "{:<44} {:>12.1} {:>12.1}",
            "MiL vs emulated response error (RMS) [%]",
            f.response_error_without_pct,
            f.response_error_with_pct
        );
        let _ = writeln!(
            t,
            "{:<44} {:>12} {:>12}",
            "noise sensitivity peak 60 Hz-Nyquist",
            crate::cli::number(f.noise_peak_without, 3),
            crate::cli::number(f.noise_peak_with, 3)
        );
        let _ = writeln!(
            t,
            "{:<44} {:>12.1} {:>12.1}",
            "  at [Hz]", f.noise_peak_without_hz, f.noise_peak_with_hz
        );
        let _ = writeln!(
            t,
            "{:<44} {:>12} {:>12.2}",
            format!(
                "worst MiL/emulated above the band (at {:.0} Hz)",
                f.out_of_band_amplification_hz
            ),
            "",
            f.out_of_band_amplification
        );
        let _ = writeln!(
            t,
            "{:<44} {:>12} {:>12}",
            "gain margin of the MiL loop",
            opt(f.gain_margin_without),
            opt(f.gain_margin_with_filter)
        );
        let _ = writeln!(
            t,
            "phase-lag reduction {:.1} %, noise-sensitivity ratio {:.2} ({:.1}x at {:.0} Hz), \
             closed loop with filter: {}",
            f.phase_lag_reduction_pct,
            f.noise_sensitivity_ratio,
            f.noise_ratio_at_peak,
            f.noise_peak_with_hz,
            f.stability_with_filter
        );
        if let (Some(target), Some(met)) = (&s.target, s.target_met) {
            let _ = writeln!(
                t,
                "target (lag reduction >= {} % with <= {} dB, ratio <= {}, GM >= {}): {}",
                target.min_phase_lag_reduction_pct,
                target.max_magnitude_error_db,
                target.max_noise_sensitivity_ratio,
                target.min_gain_margin,
                if met {
                    "met"
                } else {
                    "NOT reachable on this front (see the pareto plot)"
                }
            );
            if let Some(front) = s.front.as_ref().filter(|f| !f.is_empty()) {
                let _ = writeln!(
                    t,
                    "front:  weight  lag red [%]  mag [dB]  noise ratio    GM  error [%]  above band  target"
                );
                for p in front {
                    let f = &p.figures;
                    let _ = writeln!(
                        t,
                        "        {:>6.2}  {:>11.1}  {:>8.2}  {:>11.2}  {:>4}  {:>9.1}  {:>10.2}  {}",
                        p.weight,
                        f.phase_lag_reduction_pct,
                        f.magnitude_error_db,
                        f.noise_sensitivity_ratio,
                        f.gain_margin_with_filter
                            .map_or("none".to_string(), |g| format!("{g:.2}")),
                        f.response_error_with_pct,
                        f.out_of_band_amplification,
                        if p.meets_target { "met" } else { "-" }
                    );
                }
            }
            let _ = writeln!(
                t,
                "chosen: {}",
                match s.chosen_weight.flatten() {
                    Some(w) => format!("front point at weight {w}"),
                    None => "the least-squares design".into(),
                }
            );
        }
        let _ = writeln!(t, "files:");
        for file in &s.files {
            let _ = writeln!(t, "  {file}");
        }
        t
    }
}

fn series(label: &str, f: &[f64], h: Vec<Complex64>, dashed: bool) -> BodeSeries {
    BodeSeries {
        label: label.into(),
        frequency_hz: f.to_vec(),
        response: h,
        dashed,
    }
}

/// Writes the plots of a design into `folder`, named after the filter file (`stem`): two
/// designs in one folder keep their own plots; returns the files.
fn write_plots(
    setup: &Setup,
    design: &FilterDesign,
    folder: &Path,
    stem: &str,
    pick: &(dyn Fn(&LoopPoint) -> Complex64 + Sync),
) -> Result<Vec<PathBuf>> {
    let fs = setup.sample_rate_hz;
    let filter = design.command_filter(fs);
    let bare = with_filter(&setup.system, None);
    let filtered = with_filter(&setup.system, Some(filter.clone()));
    // Up to 0.9 × Nyquist: the Tustin zeros at z = −1 would stretch the dB axis otherwise.
    let grid = log_grid(0.1, 0.45 * fs, 200);
    let mut files = Vec::new();

    // Filter and actuator-with-filter tracking response.
    let path_without: Vec<Complex64> = grid
        .iter()
        .map(|&f| command_path(&setup.system, f))
        .collect::<mil_analysis::Result<_>>()?;
    let f_resp: Vec<Complex64> = grid.iter().map(|&f| filter.response(f)).collect();
    let path_with: Vec<Complex64> = f_resp
        .iter()
        .zip(&path_without)
        .map(|(a, b)| a * b)
        .collect();
    let mut filt = BodePlot::new("Command filter F (discrete cascade)", "|F| [dB]");
    filt.magnitude_scale = MagnitudeScale::Decibel;
    filt.series = vec![series("F", &grid, f_resp, false)];
    filt.magnitude_lines = vec![0.0];
    let mut tracking = BodePlot::new(
        "Actuator tracking response with the command filter (incl. loop delay)",
        "|F P e^-sT| [dB]",
    );
    tracking.magnitude_scale = MagnitudeScale::Decibel;
    tracking.series = vec![
        series("actuator alone", &grid, path_without, true),
        series("with filter", &grid, path_with, false),
    ];
    tracking.magnitude_lines = vec![0.0];
    tracking.phase_lines = vec![0.0];
    tracking.markers = vec![Marker::new(30.0, "fit band ends 30 Hz")];
    let path = folder.join(format!("{stem}.svg"));
    bode_page_svg(&path, &[filt, tracking])?;
    files.push(path);

    // The first response: emulated, MiL without and with the filter.
    let spec = setup
        .options
        .responses
        .first()
        .context("the set-up has no responses")?;
    let resp_grid = log_grid(
        setup.options.f_min_hz.max(0.1),
        100.0_f64.min(0.5 * fs),
        200,
    );
    let trace = |s: &MilSystem, which: Loop| -> Result<Vec<Complex64>> {
        resp_grid
            .iter()
            .map(|&f| Ok(pick(&s.point(f, which)?) * spec.display_scale))
            .collect()
    };
    let mut resp = BodePlot::new(
        format!("{}: MiL with the command filter", spec.name),
        format!("{} [{}]", spec.name, spec.display_unit),
    );
    resp.series = vec![
        series("emulated", &resp_grid, trace(&bare, Loop::Emulated)?, true),
        series(
            "MiL, no filter",
            &resp_grid,
            trace(&bare, Loop::Mil)?,
            false,
        ),
        series(
            "MiL with filter",
            &resp_grid,
            trace(&filtered, Loop::Mil)?,
            false,
        ),
    ];
    let path = folder.join(format!("{stem}-response.svg"));
    bode_svg(&path, &resp)?;
    files.push(path);

    // Control sensitivity with and without the filter: a magnitude only (no phase panel).
    let noise = |s: &MilSystem| -> Result<Vec<(f64, f64)>> {
        grid.iter()
            .map(|&f| {
                let p = s.point(f, Loop::Mil)?;
                Ok((
                    f,
                    mil_analysis::metrics::max_singular_value(&p.noise_to_command),
                ))
            })
            .collect()
    };
    let mut plot = XyPlot::new(
        "Control sensitivity: actuator command per unit measurement noise",
        "frequency [Hz]",
        "command / noise (SI)",
    );
    plot.log_x = true;
    plot.log_y = true;
    let with = noise(&filtered)?;
    let fig = &design.figures;
    // The filtered peak, where the ratio is read.
    if let Some(&(f, v)) = with.iter().min_by(|a, b| {
        (a.0 - fig.noise_peak_with_hz)
            .abs()
            .total_cmp(&(b.0 - fig.noise_peak_with_hz).abs())
    }) {
        plot.annotations = vec![Annotation::new(
            f,
            v,
            format!(
                "{:.1}x at {:.0} Hz",
                fig.noise_ratio_at_peak, fig.noise_peak_with_hz
            ),
        )];
    }
    plot.series = vec![
        XySeries::new("no filter", noise(&bare)?, SeriesStyle::Dashed),
        XySeries::new("with filter", with, SeriesStyle::Line),
    ];
    let path = folder.join(format!("{stem}-noise-sensitivity.svg"));
    xy_svg(&path, &plot)?;
    files.push(path);
    Ok(files)
}

fn pareto_plot(
    path: &Path,
    front: &[mil_analysis::design::FrontPoint],
    least_squares: &FilterDesign,
    chosen: &FilterDesign,
    target: &DesignTarget,
) -> Result<()> {
    let point = |d: &FilterDesign| {
        (
            d.figures.noise_sensitivity_ratio,
            d.figures.response_error_with_pct,
        )
    };
    let pts: Vec<(f64, f64)> = front.iter().map(|p| point(&p.design)).collect();
    let (y_lo, y_hi) = pts
        .iter()
        .chain(std::iter::once(&point(least_squares)))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p.1), hi.max(p.1))
        });
    let mut plot = XyPlot::new(
        "Command-filter trade-off: MiL accuracy vs noise sensitivity",
        "noise-sensitivity ratio (peak 60 Hz-Nyquist, with / without filter)",
        "MiL vs emulated response error, RMS 0.5-30 Hz [%]",
    );
    plot.series = vec![
        XySeries::new("optimised front (over the weight)", pts, SeriesStyle::Line),
        XySeries::new(
            "least-squares design",
            vec![point(least_squares)],
            SeriesStyle::Points,
        ),
        XySeries::new(
            format!("target: ratio <= {}", target.max_noise_sensitivity_ratio),
            vec![
                (target.max_noise_sensitivity_ratio, y_lo),
                (target.max_noise_sensitivity_ratio, y_hi),
            ],
            SeriesStyle::Dashed,
        ),
    ];
    // The front's designs as points, those meeting the target apart; one label only, the
    // chosen design's (a label per point collided).
    let meets: Vec<(f64, f64)> = front
        .iter()
        .filter(|p| p.meets_target)
        .map(|p| point(&p.design))
        .collect();
    if !meets.is_empty() {
        plot.series.push(XySeries::new(
            "designs meeting the target",
            meets,
            SeriesStyle::Points,
        ));
    }
    let (x, y) = point(chosen);
    plot.annotations = vec![Annotation::new(
        x,
        y,
        format!(
            "chosen: {:.1} % error, ratio {:.2}, lag -{:.0} %",
            chosen.figures.response_error_with_pct,
            chosen.figures.noise_sensitivity_ratio,
            chosen.figures.phase_lag_reduction_pct
        ),
    )];
    xy_svg(path, &plot)?;
    Ok(())
}

/// Runs `mil design-filter` on a MiL set-up (designed for it without its own filter).
///
/// # Errors
/// Invalid set-up, a failed design, a design that may not be exported (unstable loop), or
/// unwritable outputs.
pub fn run_design_filter(
    setup: &crate::setup::SetUp,
    request: &DesignRequest,
    progress: impl FnMut(usize, usize),
) -> Result<DesignOutput> {
    let mut setup = setup.clone();
    setup.controller.filter = None;
    let setup = setup.analysis()?;
    let spec = setup
        .options
        .responses
        .first()
        .context("the set-up has no [[analysis.responses]]")?
        .clone();
    let pick = move |p: &LoopPoint| spec.output.pick(p, spec.input);
    let mut options = DesignOptions::paper(setup.sample_rate_hz);
    if let Some(structure) = request.structure {
        options.structure = structure;
    }
    let target = DesignTarget::DEFAULT;
    let (design, target_met, chosen_weight, front, extra_plot) = match request.method {
        Method::Ls => (
            design_ls(&setup.system, &options, &pick)?,
            None,
            None,
            None,
            None,
        ),
        Method::Optimal => {
            let weights = request
                .weights
                .clone()
                .unwrap_or_else(|| DEFAULT_WEIGHTS.to_vec());
            let result =
                design_optimal(&setup.system, &options, &weights, &target, &pick, progress)?;
            let front: Vec<FrontSummary> = result
                .front
                .iter()
                .map(|p| FrontSummary {
                    weight: p.weight,
                    meets_target: p.meets_target,
                    figures: p.design.figures.clone(),
                })
                .collect();
            let plot = (result.front, result.least_squares);
            (
                result.chosen,
                Some(result.target_met),
                Some(result.chosen_weight),
                Some(front),
                Some(plot),
            )
        }
    };
    if let Err(e) = design.check_exportable() {
        let f = &design.figures;
        bail!(
            "{e}; nothing written (design figures: phase-lag reduction {:.1} %, gain margin \
             {}, noise-sensitivity ratio {:.2}; the loop without filter is {})",
            f.phase_lag_reduction_pct,
            f.gain_margin_with_filter
                .map_or("none".into(), |g| format!("{g:.2}")),
            f.noise_sensitivity_ratio,
            match mil_analysis::MilSystem::stability(&with_filter(&setup.system, None), Loop::Mil) {
                mil_analysis::Stability::Stable => "stable".to_string(),
                mil_analysis::Stability::Unstable(n) => format!("unstable too ({n} poles)"),
                mil_analysis::Stability::Unknown => "of unknown stability".to_string(),
            }
        );
    }
    let folder = request
        .out
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .map_or_else(PathBuf::new, Path::to_path_buf);
    if !folder.as_os_str().is_empty() {
        std::fs::create_dir_all(&folder)
            .with_context(|| format!("creating {}", folder.display()))?;
    }
    let mut file = FilterFile::new(&design.cascade, setup.sample_rate_hz);
    file.figures = Some(serde_json::to_value(&design.figures)?);
    file.write(&request.out)?;
    // Read back through the loader the host tool and the firmware configuration use.
    let (_, reread) = FilterFile::read(&request.out)?;
    if reread != design.cascade {
        bail!("the filter file does not read back to the designed cascade");
    }
    let mut files = vec![request.out.clone()];
    // The plots are named after the filter file.
    let stem = request
        .out
        .file_stem()
        .map_or_else(|| "filter".into(), |s| s.to_string_lossy().into_owned());
    files.extend(write_plots(&setup, &design, &folder, &stem, &pick)?);
    if let Some((front_points, least_squares)) = &extra_plot {
        let path = folder.join(format!("{stem}-pareto.svg"));
        pareto_plot(&path, front_points, least_squares, &design, &target)?;
        files.push(path);
    }
    let f = &design.figures;
    let summary = DesignSummary {
        name: setup.name.clone(),
        method: request.method,
        file: request.out.display().to_string(),
        sample_rate_hz: setup.sample_rate_hz,
        sections: design.cascade.active().len(),
        rolloff_hz: design.continuous.structure.rolloff_hz,
        phase_lag_reduction_pct: f.phase_lag_reduction_pct,
        magnitude_error_db: f.magnitude_error_db,
        noise_sensitivity_ratio: f.noise_sensitivity_ratio,
        noise_ratio_at_peak: f.noise_ratio_at_peak,
        noise_peak_hz: f.noise_peak_with_hz,
        gain_margin_with_filter: f.gain_margin_with_filter,
        gain_margin_without: f.gain_margin_without,
        stability_with_filter: f.stability_with_filter,
        figures: f.clone(),
        target: target_met.map(|_| target),
        target_met,
        chosen_weight,
        front,
        files: files.iter().map(|p| p.display().to_string()).collect(),
    };
    Ok(DesignOutput {
        setup,
        design,
        summary,
    })
}
