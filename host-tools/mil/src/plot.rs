//! `mil run`'s plots, drawn by `mil-plots` like every other plot of the tools, and the
//! tools' one rule for a response's plotted unit.

use crate::run::RunOutput;
use anyhow::Result;
use mil_plots::{xy_svg, SeriesStyle, XyPlot, XySeries};
use std::path::{Path, PathBuf};

/// How the tools plot a response whose SI unit is `unit`: force per displacement (N/m) in
/// N/mm, as `mil analyze` shows it, every other unit as it is; the factor multiplies the SI
/// magnitude.
pub fn response_unit(unit: &str) -> (f64, String) {
    if unit == "N/m" {
        (1e-3, "N/mm".into())
    } else {
        (1.0, unit.into())
    }
}

/// At most about this many points per line (a long run is decimated for the plot only).
const MAX_POINTS: usize = 4000;

/// Writes `run.svg` (every channel's demand, kN) and `run-road.svg` (every channel's road,
/// mm) into `dir`; returns their paths.
///
/// # Errors
/// A plot cannot be written.
pub fn plot_run(out: &RunOutput, dir: &Path) -> Result<Vec<PathBuf>> {
    let step = (out.time.len() / MAX_POINTS).max(1);
    let channels = out.summary.channels;
    let series = |values: &[Vec<f64>], scale: f64| -> Vec<XySeries> {
        (0..channels)
            .map(|c| {
                XySeries::new(
                    format!("channel {c}"),
                    out.time
                        .iter()
                        .zip(values)
                        .step_by(step)
                        .map(|(t, v)| (*t, v.get(c).copied().unwrap_or(f64::NAN) * scale))
                        .collect(),
                    SeriesStyle::Line,
                )
            })
            .collect()
    };
    let mut files = Vec::new();
    let mut demand = XyPlot::new(
        format!(
            "Actuator demand, {} model, open loop on a rigid rig",
            out.summary.model
        ),
        "time [s]",
        "demand [kN]",
    );
    demand.series = series(&out.demand, 1e-3);
    let path = dir.join("run.svg");
    xy_svg(&path, &demand)?;
    files.push(path);
    let mut road = XyPlot::new("Road input", "time [s]", "road [mm]");
    road.series = series(&out.road, 1e3);
    let path = dir.join("run-road.svg");
    xy_svg(&path, &road)?;
    files.push(path);
    Ok(files)
}
