//! SVG plots of run results (plotters, SVG backend).

use crate::run::RunOutput;
use anyhow::{anyhow, Result};
use plotters::prelude::*;
use std::path::Path;

/// Plots road input (mm) and demand (N) of channel 0 (and channel 1 when present) against
/// time, one panel each.
pub fn plot_run(out: &RunOutput, path: &Path) -> Result<()> {
    let root = SVGBackend::new(path, (1200, 700)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| anyhow!("{e}"))?;
    let (upper, lower) = root.split_vertically(350);
    let channels = out.summary.channels.min(2);
    let road: Vec<Vec<f64>> = out
        .road
        .iter()
        .map(|r| r.iter().map(|v| v * 1e3).collect())
        .collect();
    panel(
        &upper,
        "Road input",
        "road [mm]",
        &out.time,
        &road,
        channels,
    )?;
    panel(
        &lower,
        "Actuator demand",
        "demand [N]",
        &out.time,
        &out.demand,
        channels,
    )?;
    root.present().map_err(|e| anyhow!("{e}"))?;
    Ok(())
}

/// One time-history panel of the first `channels` columns of `values` (`[sample][channel]`),
/// decimated to at most about 4000 points per line.
fn panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    title: &str,
    y_label: &str,
    time: &[f64],
    values: &[Vec<f64>],
    channels: usize,
) -> Result<()> {
    let colours = [&BLUE, &RED];
    let t_end = time.last().copied().unwrap_or(1.0);
    let step = (time.len() / 4000).max(1);
    let (lo, hi) = values
        .iter()
        .flat_map(|v| v.iter().take(channels))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
            (a.min(*x), b.max(*x))
        });
    let pad = ((hi - lo) * 0.05).max(1e-9);
    let mut chart = ChartBuilder::on(area)
        .caption(title, ("sans-serif", 20))
        .margin(10)
        .x_label_area_size(35)
        .y_label_area_size(70)
        .build_cartesian_2d(0.0..t_end, (lo - pad)..(hi + pad))
        .map_err(|e| anyhow!("{e}"))?;
    chart
        .configure_mesh()
        .x_desc("time [s]")
        .y_desc(y_label)
        .draw()
        .map_err(|e| anyhow!("{e}"))?;
    for (ch, colour) in colours.iter().enumerate().take(channels) {
        chart
            .draw_series(LineSeries::new(
                time.iter()
                    .zip(values)
                    .step_by(step)
                    .map(|(t, v)| (*t, v.get(ch).copied().unwrap_or(0.0))),
                *colour,
            ))
            .map_err(|e| anyhow!("{e}"))?
            .label(format!("channel {ch}"))
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], *colour));
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(|e| anyhow!("{e}"))?;
    Ok(())
}
