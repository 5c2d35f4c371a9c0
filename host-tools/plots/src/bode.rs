//! Bode diagrams.

use std::path::Path;

use anyhow::{bail, Context, Result};
use num_complex::Complex64;
use plotters::prelude::*;

use crate::axis::Axis;
use crate::draw::{
    curve_samples, draw_curve, draw_legend, draw_mesh, draw_reference_line, draw_text_box,
    render_svg, series_colour, text_box, y_label_area, Area, Chart, Curve, DrawResult, LegendEntry,
    LineKind, PixelRect, INK, LABEL_FONT, TITLE_FONT,
};
use crate::phase::bode_phase_deg;
use crate::{BodePlot, MagnitudeScale};

/// Size of a single Bode diagram in pixels.
const BODE_SIZE: (u32, u32) = (960, 680);
/// Height of each diagram on a page of several.
const PAGE_PLOT_HEIGHT: u32 = 600;
/// Share of a diagram's height (below the title) for the magnitude panel.
const MAGNITUDE_SHARE: f64 = 0.55;

/// Writes a Bode diagram as an SVG file.
///
/// Errors if the plot has no series, a series is empty or its frequency and response lengths
/// differ, a frequency is zero or negative, `magnitude_factor` is not positive and finite, no
/// point at all can be drawn, or the file cannot be written.
pub fn bode_svg(path: &Path, plot: &BodePlot) -> Result<()> {
    let prepared = Prepared::new(plot)?;
    render_svg(path, BODE_SIZE, |root| draw_bode(root, plot, &prepared))
}

/// Writes several Bode diagrams stacked in one SVG file (each a magnitude and phase pair with
/// its own title and axes), for a one-page report.
///
/// Errors if `plots` is empty or as [`bode_svg`] for any of the plots.
pub fn bode_page_svg(path: &Path, plots: &[BodePlot]) -> Result<()> {
    if plots.is_empty() {
        bail!("no Bode diagrams to write to {}", path.display());
    }
    let prepared = plots
        .iter()
        .enumerate()
        .map(|(i, plot)| {
            Prepared::new(plot)
                .with_context(|| format!("Bode diagram {} (\"{}\")", i + 1, plot.title))
        })
        .collect::<Result<Vec<_>>>()?;
    let height = PAGE_PLOT_HEIGHT.saturating_mul(plots.len() as u32);
    render_svg(path, (BODE_SIZE.0, height), |root| {
        let areas = root.split_evenly((plots.len(), 1));
        for ((area, plot), prepared) in areas.iter().zip(plots).zip(&prepared) {
            draw_bode(area, plot, prepared)?;
        }
        Ok(())
    })
}

/// A Bode diagram's axes and curves, computed from the data.
struct Prepared {
    frequency: Axis,
    magnitude: Axis,
    phase: Axis,
    magnitude_curves: Vec<Curve>,
    phase_curves: Vec<Curve>,
    legend: Vec<LegendEntry>,
    /// Drawable markers: (frequency, label).
    markers: Vec<(f64, String)>,
}

/// One series' points sorted by frequency: (frequency, plotted magnitude, phase in degrees).
type SeriesPoints = Vec<(f64, f64, f64)>;

impl Prepared {
    fn new(plot: &BodePlot) -> Result<Prepared> {
        if plot.series.is_empty() {
            bail!("Bode diagram \"{}\" has no series", plot.title);
        }
        let factor = plot.magnitude_factor;
        if !(factor.is_finite() && factor > 0.0) {
            bail!(
                "Bode diagram \"{}\": magnitude factor {factor} is not positive and finite",
                plot.title
            );
        }
        let mut all_points: Vec<SeriesPoints> = Vec::with_capacity(plot.series.len());
        for series in &plot.series {
            let (f, h) = (&series.frequency_hz, &series.response);
            if f.len() != h.len() {
                bail!(
                    "series \"{}\" has {} frequencies but {} response values",
                    series.label,
                    f.len(),
                    h.len()
                );
            }
            if f.is_empty() {
                bail!("series \"{}\" is empty", series.label);
            }
            if let Some(bad) = f.iter().find(|v| v.is_finite() && **v <= 0.0) {
                bail!(
                    "series \"{}\" has a non-positive frequency {bad} Hz",
                    series.label
                );
            }
            let mut order: Vec<usize> = (0..f.len()).filter(|&i| f[i].is_finite()).collect();
            order.sort_by(|&a, &b| f[a].total_cmp(&f[b]));
            let sorted_response: Vec<Complex64> = order.iter().map(|&i| h[i]).collect();
            let phase = bode_phase_deg(&sorted_response);
            all_points.push(
                order
                    .iter()
                    .zip(&sorted_response)
                    .zip(phase)
                    .map(|((&i, h), p)| (f[i], magnitude(*h, factor, plot.magnitude_scale), p))
                    .collect(),
            );
        }

        let frequencies = all_points.iter().flatten().map(|p| p.0);
        let markers: Vec<(f64, String)> = plot
            .markers
            .iter()
            .filter(|m| m.frequency_hz.is_finite() && m.frequency_hz > 0.0)
            .map(|m| (m.frequency_hz, m.label.clone()))
            .collect();
        let span = plot
            .frequency_span
            .into_iter()
            .flatten()
            .filter(|f| f.is_finite() && *f > 0.0);
        let frequency = Axis::log(
            frequencies.chain(markers.iter().map(|m| m.0)).chain(span),
            1.0,
        );

        let magnitudes = all_points
            .iter()
            .flatten()
            .map(|p| p.1)
            .chain(plot.magnitude_lines.iter().copied());
        let magnitude = match plot.magnitude_scale {
            MagnitudeScale::Decibel => Axis::linear(magnitudes),
            MagnitudeScale::Linear => Axis::linear(magnitudes.chain([0.0])),
            MagnitudeScale::Log => Axis::log(magnitudes, 1.25),
        };
        let phases = all_points
            .iter()
            .flatten()
            .map(|p| p.2)
            .chain(plot.phase_lines.iter().copied());
        let phase = Axis::phase(phases);

        let any_magnitude = magnitude
            .as_ref()
            .is_some_and(|axis| all_points.iter().flatten().any(|p| axis.accepts(p.1)));
        let any_phase = all_points.iter().flatten().any(|p| p.2.is_finite());
        let Some(frequency) = frequency else {
            bail!("Bode diagram \"{}\" has no finite frequencies", plot.title);
        };
        if !any_magnitude && !any_phase {
            bail!("Bode diagram \"{}\" has no finite data to plot", plot.title);
        }
        let magnitude = match magnitude {
            Some(axis) => axis,
            None => match plot.magnitude_scale {
                MagnitudeScale::Log => Axis::log([0.1, 10.0], 1.0),
                _ => Axis::linear([0.0, 1.0]),
            }
            .context("default magnitude axis")?,
        };
        let phase = match phase {
            Some(axis) => axis,
            None => Axis::phase([-180.0, 0.0]).context("default phase axis")?,
        };

        let mut magnitude_curves = Vec::new();
        let mut phase_curves = Vec::new();
        let mut legend = Vec::new();
        for (i, (series, points)) in plot.series.iter().zip(&all_points).enumerate() {
            let colour = series_colour(i);
            let kind = if series.dashed {
                LineKind::Dashed
            } else {
                LineKind::Solid
            };
            magnitude_curves.push(Curve::new(
                colour,
                kind,
                points.iter().map(|p| (p.0, p.1)),
                &frequency,
                &magnitude,
            ));
            phase_curves.push(Curve::new(
                colour,
                kind,
                points.iter().map(|p| (p.0, p.2)),
                &frequency,
                &phase,
            ));
            if !series.label.is_empty() {
                legend.push(LegendEntry {
                    label: series.label.clone(),
                    colour,
                    kind,
                });
            }
        }
        Ok(Prepared {
            frequency,
            magnitude,
            phase,
            magnitude_curves,
            phase_curves,
            legend,
            markers,
        })
    }
}

/// The plotted magnitude of a response value (NaN or -inf where it cannot be drawn).
fn magnitude(h: Complex64, factor: f64, scale: MagnitudeScale) -> f64 {
    if !(h.re.is_finite() && h.im.is_finite()) {
        return f64::NAN;
    }
    let m = h.norm() * factor;
    match scale {
        MagnitudeScale::Decibel => 20.0 * m.log10(),
        MagnitudeScale::Linear | MagnitudeScale::Log => m,
    }
}

/// Builds one panel of a Bode diagram: `top` pixels of margin above it, `left` pixels for the
/// magnitude or phase tick labels, `x_label_area` pixels below it for the frequency tick labels
/// (0 for the magnitude panel).
fn build_panel<'a, 'b>(
    area: &'a Area<'b>,
    frequency: &Axis,
    y_axis: &Axis,
    (top, left, x_label_area): (u32, u32, u32),
) -> Result<Chart<'a, 'b>> {
    ChartBuilder::on(area)
        .margin_left(10)
        .margin_right(28)
        .margin_top(top)
        .margin_bottom(6)
        .y_label_area_size(left)
        .x_label_area_size(x_label_area)
        .build_cartesian_2d(frequency.clone(), y_axis.clone())
        .drawing()
}

/// Draws one Bode diagram into `area`.
fn draw_bode(area: &Area<'_>, plot: &BodePlot, prepared: &Prepared) -> Result<()> {
    let title_style = ("sans-serif", TITLE_FONT)
        .into_font()
        .style(FontStyle::Bold);
    let inner = area.titled(&plot.title, title_style).drawing()?;
    let (_, height) = inner.dim_in_pixel();
    let (upper, lower) = inner.split_vertically((f64::from(height) * MAGNITUDE_SHARE) as i32);
    let frequency = &prepared.frequency;

    // The marker labels go in rows above the magnitude panel; the horizontal layout does not
    // depend on the panel's top margin, so lay them out on a probe chart first.
    let left = y_label_area(&[&prepared.magnitude, &prepared.phase]);
    let probe = build_panel(&upper, frequency, &prepared.magnitude, (4, left, 0))?;
    let (labels, rows) = layout_marker_labels(&probe, &upper, &prepared.markers);
    drop(probe);
    let strip = rows as i32 * MARKER_ROW;
    let mut magnitude_chart = build_panel(
        &upper,
        frequency,
        &prepared.magnitude,
        (4 + strip as u32, left, 0),
    )?;
    draw_mesh(
        &mut magnitude_chart,
        frequency,
        &prepared.magnitude,
        None,
        &plot.magnitude_label,
    )?;
    let mut phase_chart = build_panel(&lower, frequency, &prepared.phase, (6, left, 46))?;
    draw_mesh(
        &mut phase_chart,
        frequency,
        &prepared.phase,
        Some("frequency [Hz]"),
        "phase [deg]",
    )?;

    let panels = [
        (
            &mut magnitude_chart,
            &prepared.magnitude,
            &plot.magnitude_lines,
            &prepared.magnitude_curves,
        ),
        (
            &mut phase_chart,
            &prepared.phase,
            &plot.phase_lines,
            &prepared.phase_curves,
        ),
    ];
    for (chart, y_axis, lines, curves) in panels {
        for &y in lines.iter().filter(|&&y| y_axis.accepts(y)) {
            draw_reference_line(chart, (frequency.lo(), y), (frequency.hi(), y))?;
        }
        for curve in curves {
            draw_curve(chart, curve)?;
        }
        for &(f, _) in &prepared.markers {
            chart
                .draw_series(DashedLineSeries::new(
                    [(f, y_axis.lo()), (f, y_axis.hi())],
                    5,
                    3,
                    marker_style(),
                ))
                .drawing()?;
        }
    }

    // Marker labels: extend each marker line up to its label, then draw the label.
    let plot_top = magnitude_chart.plotting_area().get_base_pixel().1 - upper.get_base_pixel().1;
    for (x, rect, _) in &labels {
        let mid = (rect.y0 + rect.y1) / 2;
        upper
            .draw(&plotters::element::DashedPathElement::new(
                [(*x, mid), (*x, plot_top)],
                5,
                3,
                marker_style(),
            ))
            .drawing()?;
    }
    for (_, rect, label) in &labels {
        draw_text_box(&upper, label, (rect.x0, rect.y0), &INK)?;
    }

    let samples = curve_samples(&magnitude_chart, &prepared.magnitude_curves);
    draw_legend(&magnitude_chart, &prepared.legend, &samples, &[])?;
    Ok(())
}

/// Line style of the markers.
fn marker_style() -> ShapeStyle {
    INK.stroke_width(1)
}

/// Height of a row of marker labels.
const MARKER_ROW: i32 = LABEL_FONT as i32 + 6;
/// At most this many rows of marker labels (further labels may overlap).
const MARKER_ROWS: usize = 4;

/// Lays the marker labels out in rows above the magnitude panel, each next to its marker's
/// line, without overlaps where possible. Returns (line x, label box, label) in pixels local to
/// `area`, and the number of rows used.
fn layout_marker_labels<'m>(
    chart: &Chart<'_, '_>,
    area: &Area<'_>,
    markers: &'m [(f64, String)],
) -> (Vec<(i32, PixelRect, &'m str)>, usize) {
    const GAP: i32 = 4;
    let (width, _) = area.dim_in_pixel();
    let width = width as i32;
    let base_x = area.get_base_pixel().0;
    let mut order: Vec<(i32, &str)> = markers
        .iter()
        .filter(|m| !m.1.is_empty())
        .map(|(f, label)| (chart.backend_coord(&(*f, 1.0)).0 - base_x, label.as_str()))
        .collect();
    order.sort_by_key(|m| m.0);
    let mut placed: Vec<(i32, PixelRect, &str)> = Vec::new();
    let mut rows = 0;
    for (x, label) in order {
        let label_width = text_box(label, (0, 0)).x1;
        let left = if x + GAP + label_width <= width {
            x + GAP
        } else {
            (x - GAP - label_width).max(0)
        };
        let row = (0..MARKER_ROWS)
            .find(|&row| {
                let rect = text_box(label, (left, 2 + row as i32 * MARKER_ROW));
                !placed.iter().any(|p| p.1.overlaps(&rect))
            })
            .unwrap_or(MARKER_ROWS - 1);
        rows = rows.max(row + 1);
        placed.push((
            x,
            text_box(label, (left, 2 + row as i32 * MARKER_ROW)),
            label,
        ));
    }
    (placed, rows)
}
