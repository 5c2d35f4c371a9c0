//! SVG plots of run results (plotters, SVG backend).

use crate::run::RunOutput;
use anyhow::{anyhow, Result};
use plotters::prelude::*;
use std::path::Path;

/// Plots road input and demand of channel 0 (and channel 1 when present) against time.
pub fn plot_run(out: &RunOutput, path: &Path) -> Result<()> {
    let root = SVGBackend::new(path, (1200, 700)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| anyhow!("{e}"))?;
    let (upper, lower) = root.split_vertically(350);
    let t_end = out.time.last().copied().unwrap_or(1.0);
    let step = (out.time.len() / 4000).max(1);
    let range = |v: &mut dyn Iterator<Item = f64>| {
        let (lo, hi) = v.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
            (a.min(x), b.max(x))
        });
        let pad = ((hi - lo) * 0.05).max(1e-9);
        (lo - pad)..(hi + pad)
    };
    let channels = out.summary.channels.min(2);
    let colours = [&BLUE, &RED];

    let yr = range(
        &mut out
            .road
            .iter()
            .flat_map(|r| r.iter().take(channels).map(|v| v * 1e3)),
    );
    let mut chart = ChartBuilder::on(&upper)
        .caption("Road input", ("sans-serif", 20))
        .margin(10)
        .x_label_area_size(35)
        .y_label_area_size(70)
        .build_cartesian_2d(0.0..t_end, yr)
        .map_err(|e| anyhow!("{e}"))?;
    chart
        .configure_mesh()
        .x_desc("time [s]")
        .y_desc("road [mm]")
        .draw()
        .map_err(|e| anyhow!("{e}"))?;
    for (ch, colour) in colours.iter().enumerate().take(channels) {
        chart
            .draw_series(LineSeries::new(
                out.time
                    .iter()
                    .zip(&out.road)
                    .step_by(step)
                    .map(|(t, r)| (*t, r[ch] * 1e3)),
                *colour,
            ))
            .map_err(|e| anyhow!("{e}"))?
            .label(format!("channel {ch}"))
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], *colour));
    }
    chart
        .configure_series_labels()
        .border_style(BLACK)
        .draw()
        .map_err(|e| anyhow!("{e}"))?;

    let yd = range(
        &mut out
            .demand
            .iter()
            .flat_map(|d| d.iter().take(channels).copied()),
    );
    let mut chart = ChartBuilder::on(&lower)
        .caption("Actuator demand", ("sans-serif", 20))
        .margin(10)
        .x_label_area_size(35)
        .y_label_area_size(70)
        .build_cartesian_2d(0.0..t_end, yd)
        .map_err(|e| anyhow!("{e}"))?;
    chart
        .configure_mesh()
        .x_desc("time [s]")
        .y_desc("demand [N]")
        .draw()
        .map_err(|e| anyhow!("{e}"))?;
    for (ch, colour) in colours.iter().enumerate().take(channels) {
        chart
            .draw_series(LineSeries::new(
                out.time
                    .iter()
                    .zip(&out.demand)
                    .step_by(step)
                    .map(|(t, d)| (*t, d[ch])),
                *colour,
            ))
            .map_err(|e| anyhow!("{e}"))?
            .label(format!("channel {ch}"))
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], *colour));
    }
    chart
        .configure_series_labels()
        .border_style(BLACK)
        .draw()
        .map_err(|e| anyhow!("{e}"))?;
    root.present().map_err(|e| anyhow!("{e}"))?;
    Ok(())
}
