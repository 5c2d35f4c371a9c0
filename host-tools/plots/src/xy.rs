//! x-y plots.

use std::path::Path;

use anyhow::{bail, Result};
use plotters::prelude::*;

use crate::axis::Axis;
use crate::draw::{
    covered, curve_samples, draw_curve, draw_legend, draw_mesh, draw_text_box, local_pixel,
    plot_size, render_svg, series_colour, text_box, y_label_area, Curve, DrawResult, LegendEntry,
    LineKind, PixelRect, INK, TITLE_FONT,
};
use crate::{SeriesStyle, XyPlot};

/// Size of an x-y plot in pixels.
const XY_SIZE: (u32, u32) = (900, 600);

/// Writes an x-y plot as an SVG file.
///
/// Errors if the plot has neither series nor annotations, a series has no points, no point at
/// all can be drawn, or the file cannot be written.
pub fn xy_svg(path: &Path, plot: &XyPlot) -> Result<()> {
    if plot.series.is_empty() && plot.annotations.is_empty() {
        bail!("x-y plot \"{}\" has no series", plot.title);
    }
    if let Some(empty) = plot.series.iter().find(|s| s.points.is_empty()) {
        bail!("series \"{}\" has no points", empty.label);
    }
    let drawable = |v: f64, log: bool| v.is_finite() && (!log || v > 0.0);
    let points: Vec<(f64, f64)> = plot
        .series
        .iter()
        .flat_map(|s| s.points.iter().copied())
        .chain(plot.annotations.iter().map(|a| (a.x, a.y)))
        .filter(|&(x, y)| drawable(x, plot.log_x) && drawable(y, plot.log_y))
        .collect();
    let axis = |values: Vec<f64>, log: bool| {
        if log {
            Axis::log(values, 1.1)
        } else {
            Axis::linear(values)
        }
    };
    let x_axis = axis(points.iter().map(|p| p.0).collect(), plot.log_x);
    let y_axis = axis(points.iter().map(|p| p.1).collect(), plot.log_y);
    let (Some(x_axis), Some(y_axis)) = (x_axis, y_axis) else {
        bail!("x-y plot \"{}\" has no finite data to plot", plot.title);
    };

    let mut curves = Vec::new();
    let mut legend = Vec::new();
    for (i, series) in plot.series.iter().enumerate() {
        let colour = series_colour(i);
        let kind = match series.style {
            SeriesStyle::Line => LineKind::Solid,
            SeriesStyle::Dashed => LineKind::Dashed,
            SeriesStyle::Points => LineKind::Points,
        };
        curves.push(Curve::new(
            colour,
            kind,
            series.points.iter().copied(),
            &x_axis,
            &y_axis,
        ));
        if !series.label.is_empty() {
            legend.push(LegendEntry {
                label: series.label.clone(),
                colour,
                kind,
            });
        }
    }

    render_svg(path, XY_SIZE, |root| {
        let title_style = ("sans-serif", TITLE_FONT)
            .into_font()
            .style(FontStyle::Bold);
        let inner = root.titled(&plot.title, title_style).drawing()?;
        let mut chart = ChartBuilder::on(&inner)
            .margin_left(10)
            .margin_right(28)
            .margin_top(6)
            .margin_bottom(8)
            .y_label_area_size(y_label_area(&[&y_axis]))
            .x_label_area_size(46)
            .build_cartesian_2d(x_axis.clone(), y_axis.clone())
            .drawing()?;
        draw_mesh(
            &mut chart,
            &x_axis,
            &y_axis,
            Some(&plot.x_label),
            &plot.y_label,
        )?;
        for curve in &curves {
            draw_curve(&mut chart, curve)?;
        }
        let samples = curve_samples(&chart, &curves);
        let local = chart.plotting_area().strip_coord_spec();
        let mut obstacles: Vec<PixelRect> = Vec::new();
        for annotation in &plot.annotations {
            let point = (annotation.x, annotation.y);
            if !(x_axis.accepts(point.0) && y_axis.accepts(point.1)) {
                continue;
            }
            chart
                .draw_series(std::iter::once(Cross::new(point, 7, INK.stroke_width(2))))
                .drawing()?;
            // The cross itself should not be covered by the legend or other labels.
            let (x, y) = local_pixel(&chart, point);
            obstacles.push(PixelRect {
                x0: x - 8,
                y0: y - 8,
                x1: x + 8,
                y1: y + 8,
            });
            if annotation.label.is_empty() {
                continue;
            }
            let rect = annotation_box(&chart, point, &annotation.label, &samples, &obstacles);
            obstacles.push(draw_text_box(
                &local,
                &annotation.label,
                (rect.x0, rect.y0),
                &INK,
            )?);
        }
        draw_legend(&chart, &legend, &samples, &obstacles)
    })
}

/// Where an annotation's label goes: beside the cross (above or below, right or left), inside
/// the plotting area, where it covers the fewest curve `samples` and no `obstacles`.
fn annotation_box(
    chart: &crate::draw::Chart<'_, '_>,
    point: (f64, f64),
    label: &str,
    samples: &[(i32, i32)],
    obstacles: &[PixelRect],
) -> PixelRect {
    const GAP: i32 = 9;
    let (x, y) = local_pixel(chart, point);
    let (width, height) = plot_size(chart);
    let size = text_box(label, (0, 0));
    let right = (x + GAP).min(width - size.x1).max(0);
    let left = (x - GAP - size.x1).max(0);
    let above = (y - GAP - size.y1).max(0);
    let below = (y + GAP).min(height - size.y1).max(0);
    let candidates = [(right, above), (right, below), (left, above), (left, below)];
    let score = |&(cx, cy): &(i32, i32)| {
        let rect = text_box(label, (cx, cy));
        covered(samples, &rect) + 100_000 * obstacles.iter().filter(|o| o.overlaps(&rect)).count()
    };
    let best = candidates
        .iter()
        .min_by_key(|c| score(c))
        .copied()
        .unwrap_or((right, above));
    text_box(label, best)
}
