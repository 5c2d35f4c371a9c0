//! Drawing helpers shared by the Bode and x-y plots: SVG rendering, colours, curves, legend,
//! text boxes.

use std::path::Path;

use anyhow::{anyhow, Result};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use crate::axis::Axis;

/// A drawing area of the SVG backend in pixel coordinates.
pub(crate) type Area<'a> = DrawingArea<SVGBackend<'a>, Shift>;
/// A chart with our axes.
pub(crate) type Chart<'a, 'b> = ChartContext<'a, SVGBackend<'b>, Cartesian2d<Axis, Axis>>;

// Font sizes are nominal: plotters' SVG backend writes `font-size` as the nominal size / 1.24.
/// Tick label font size.
pub(crate) const TICK_FONT: u32 = 15;
/// Axis description font size.
pub(crate) const DESC_FONT: u32 = 16;
/// Title font size.
pub(crate) const TITLE_FONT: u32 = 22;
/// Legend and marker label font size.
pub(crate) const LABEL_FONT: u32 = 15;

/// Width of the area left of a chart for the tick labels of `axes` and the axis description.
pub(crate) fn y_label_area(axes: &[&Axis]) -> u32 {
    let widest = axes
        .iter()
        .flat_map(|axis| axis.labels())
        .map(|label| text_width(&label, TICK_FONT))
        .max()
        .unwrap_or(0);
    (widest + 40).clamp(64, 240) as u32
}

/// Distinct colours (matplotlib's "tab10"), cycled beyond ten series.
const PALETTE: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

/// The colour of series number `index`.
pub(crate) fn series_colour(index: usize) -> RGBColor {
    PALETTE[index % PALETTE.len()]
}

/// Colour of markers, annotations and reference lines.
pub(crate) const INK: RGBColor = RGBColor(40, 40, 40);

/// Converts plotters' errors (which carry the backend's error type) into anyhow errors.
pub(crate) trait DrawResult<T> {
    /// The result with a plotting error converted.
    fn drawing(self) -> Result<T>;
}

impl<T, E: std::fmt::Debug> DrawResult<T> for std::result::Result<T, E> {
    fn drawing(self) -> Result<T> {
        self.map_err(|e| anyhow!("drawing the plot failed: {e:?}"))
    }
}

/// Renders an SVG of `size` pixels with `draw` into memory, then writes it to `path`.
pub(crate) fn render_svg(
    path: &Path,
    size: (u32, u32),
    draw: impl FnOnce(&Area<'_>) -> Result<()>,
) -> Result<()> {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
        root.fill(&WHITE).drawing()?;
        draw(&root)?;
        root.present().drawing()?;
    }
    // Whole or not at all: an interrupted run leaves no half-drawn plot.
    Ok(mil_numerics::files::write_atomic(path, svg.as_bytes())?)
}

/// How a curve is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum LineKind {
    /// Solid line.
    Solid,
    /// Dashed line.
    Dashed,
    /// Filled circles.
    Points,
}

/// A curve ready to draw: data split into segments of drawable points.
#[derive(Clone, Debug)]
pub(crate) struct Curve {
    pub(crate) colour: RGBColor,
    pub(crate) kind: LineKind,
    /// Runs of consecutive drawable points; a line is interrupted between runs.
    pub(crate) segments: Vec<Vec<(f64, f64)>>,
}

impl Curve {
    /// Splits `points` into runs of points accepted by both axes.
    pub(crate) fn new(
        colour: RGBColor,
        kind: LineKind,
        points: impl IntoIterator<Item = (f64, f64)>,
        x_axis: &Axis,
        y_axis: &Axis,
    ) -> Curve {
        let mut segments = Vec::new();
        let mut current = Vec::new();
        for (x, y) in points {
            if x_axis.accepts(x) && y_axis.accepts(y) {
                current.push((x, y));
            } else if !current.is_empty() {
                segments.push(std::mem::take(&mut current));
            }
        }
        if !current.is_empty() {
            segments.push(current);
        }
        Curve {
            colour,
            kind,
            segments,
        }
    }
}

/// Line style of the curves.
fn curve_style(colour: RGBColor) -> ShapeStyle {
    colour.stroke_width(2)
}

/// Draws a curve on a chart.
pub(crate) fn draw_curve(chart: &mut Chart<'_, '_>, curve: &Curve) -> Result<()> {
    let style = curve_style(curve.colour);
    for segment in &curve.segments {
        if curve.kind == LineKind::Points || segment.len() == 1 {
            chart
                .draw_series(
                    segment
                        .iter()
                        .map(|&p| Circle::new(p, 3, curve.colour.filled())),
                )
                .drawing()?;
        } else if curve.kind == LineKind::Dashed {
            chart
                .draw_series(DashedLineSeries::new(segment.iter().copied(), 9, 5, style))
                .drawing()?;
        } else {
            chart
                .draw_series(LineSeries::new(segment.iter().copied(), style))
                .drawing()?;
        }
    }
    Ok(())
}

/// Draws a thin dashed reference line through the data points `from` and `to`.
pub(crate) fn draw_reference_line(
    chart: &mut Chart<'_, '_>,
    from: (f64, f64),
    to: (f64, f64),
) -> Result<()> {
    chart
        .draw_series(DashedLineSeries::new(
            [from, to],
            6,
            4,
            INK.mix(0.75).stroke_width(1),
        ))
        .drawing()?;
    Ok(())
}

/// Draws the mesh (grid, tick labels, axis descriptions) of a chart.
pub(crate) fn draw_mesh(
    chart: &mut Chart<'_, '_>,
    x_axis: &Axis,
    y_axis: &Axis,
    x_desc: Option<&str>,
    y_desc: &str,
) -> Result<()> {
    let x_format = |v: &f64| x_axis.label(*v);
    let y_format = |v: &f64| y_axis.label(*v);
    let no_label = |_: &f64| String::new();
    let mut mesh = chart.configure_mesh();
    mesh.y_label_formatter(&y_format)
        .y_desc(y_desc)
        .label_style(("sans-serif", TICK_FONT))
        .axis_desc_style(("sans-serif", DESC_FONT))
        .bold_line_style(BLACK.mix(0.22))
        .light_line_style(BLACK.mix(0.08));
    match x_desc {
        Some(desc) => mesh.x_label_formatter(&x_format).x_desc(desc),
        None => mesh.x_label_formatter(&no_label),
    };
    mesh.draw().drawing()?;
    // Close the frame at the top and right.
    chart
        .plotting_area()
        .draw(&Rectangle::new(
            [(x_axis.lo(), y_axis.hi()), (x_axis.hi(), y_axis.lo())],
            BLACK.stroke_width(1),
        ))
        .drawing()?;
    Ok(())
}

/// An axis-aligned rectangle in pixels, local to a chart's plotting area.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct PixelRect {
    pub(crate) x0: i32,
    pub(crate) y0: i32,
    pub(crate) x1: i32,
    pub(crate) y1: i32,
}

impl PixelRect {
    fn contains(&self, (x, y): (i32, i32)) -> bool {
        x >= self.x0 && x <= self.x1 && y >= self.y0 && y <= self.y1
    }

    pub(crate) fn overlaps(&self, other: &PixelRect) -> bool {
        self.x0 < other.x1 && other.x0 < self.x1 && self.y0 < other.y1 && other.y0 < self.y1
    }
}

/// Estimated width in pixels of `text` in a sans-serif font of nominal `size` (an average
/// character is about 0.56 of the rendered size, which is `size / 1.24`).
pub(crate) fn text_width(text: &str, size: u32) -> i32 {
    (text.chars().count() as f64 * f64::from(size) * 0.45).ceil() as i32
}

/// The pixel position of a data point local to the chart's plotting area.
pub(crate) fn local_pixel(chart: &Chart<'_, '_>, point: (f64, f64)) -> (i32, i32) {
    let (x, y) = chart.backend_coord(&point);
    let (x0, y0) = chart.plotting_area().get_base_pixel();
    (x - x0, y - y0)
}

/// The size in pixels of a chart's plotting area.
pub(crate) fn plot_size(chart: &Chart<'_, '_>) -> (i32, i32) {
    let (w, h) = chart.plotting_area().dim_in_pixel();
    (w as i32, h as i32)
}

/// Draws `text` with a translucent white box behind it, the box's top-left corner at `at`
/// (pixels local to `area`). Returns the box.
pub(crate) fn draw_text_box(
    area: &Area<'_>,
    text: &str,
    at: (i32, i32),
    colour: &RGBColor,
) -> Result<PixelRect> {
    let rect = text_box(text, at);
    area.draw(&Rectangle::new(
        [(rect.x0, rect.y0), (rect.x1, rect.y1)],
        WHITE.mix(0.85).filled(),
    ))
    .drawing()?;
    let style = ("sans-serif", LABEL_FONT)
        .into_font()
        .color(colour)
        .pos(Pos::new(HPos::Left, VPos::Center));
    area.draw(&Text::new(
        text.to_string(),
        (rect.x0 + 3, (rect.y0 + rect.y1) / 2),
        style,
    ))
    .drawing()?;
    Ok(rect)
}

/// The box [`draw_text_box`] draws for `text` at `at`.
pub(crate) fn text_box(text: &str, at: (i32, i32)) -> PixelRect {
    PixelRect {
        x0: at.0,
        y0: at.1,
        x1: at.0 + text_width(text, LABEL_FONT) + 6,
        y1: at.1 + LABEL_FONT as i32 + 3,
    }
}

/// One legend entry.
#[derive(Clone, Debug)]
pub(crate) struct LegendEntry {
    pub(crate) label: String,
    pub(crate) colour: RGBColor,
    pub(crate) kind: LineKind,
}

/// Pixel positions sampled along the curves (every few pixels along lines), local to the
/// chart's plotting area, to find where a legend covers the least data.
pub(crate) fn curve_samples(chart: &Chart<'_, '_>, curves: &[Curve]) -> Vec<(i32, i32)> {
    let mut samples = Vec::new();
    for curve in curves {
        for segment in &curve.segments {
            let pixels: Vec<(i32, i32)> = segment.iter().map(|&p| local_pixel(chart, p)).collect();
            if let Some(&first) = pixels.first() {
                samples.push(first);
            }
            if curve.kind == LineKind::Points {
                samples.extend(pixels.iter().skip(1));
                continue;
            }
            for pair in pixels.windows(2) {
                let (a, b) = (pair[0], pair[1]);
                let length = f64::from(b.0 - a.0).hypot(f64::from(b.1 - a.1));
                let steps = (length / 4.0).ceil().clamp(1.0, 400.0) as i32;
                for k in 1..=steps {
                    let t = f64::from(k) / f64::from(steps);
                    samples.push((
                        a.0 + (t * f64::from(b.0 - a.0)).round() as i32,
                        a.1 + (t * f64::from(b.1 - a.1)).round() as i32,
                    ));
                }
            }
        }
    }
    samples
}

/// How many of `samples` lie in `rect`.
pub(crate) fn covered(samples: &[(i32, i32)], rect: &PixelRect) -> usize {
    samples.iter().filter(|&&p| rect.contains(p)).count()
}

/// Draws a legend inside the chart's plotting area, in the corner (or top or bottom middle)
/// where it covers the fewest `samples` and no `obstacles`.
pub(crate) fn draw_legend(
    chart: &Chart<'_, '_>,
    entries: &[LegendEntry],
    samples: &[(i32, i32)],
    obstacles: &[PixelRect],
) -> Result<()> {
    if entries.is_empty() {
        return Ok(());
    }
    const ROW: i32 = LABEL_FONT as i32 + 5;
    const SAMPLE: i32 = 30;
    const PAD: i32 = 7;
    const INSET: i32 = 8;
    let text = entries
        .iter()
        .map(|e| text_width(&e.label, LABEL_FONT))
        .max()
        .unwrap_or(0);
    let width = PAD + SAMPLE + PAD + text + PAD;
    let height = entries.len() as i32 * ROW + PAD;
    let (w, h) = plot_size(chart);
    let left = INSET;
    let right = (w - INSET - width).max(INSET);
    let centre = ((w - width) / 2).max(INSET);
    let top = INSET;
    let bottom = (h - INSET - height).max(INSET);
    let candidates = [
        (right, top),
        (left, top),
        (right, bottom),
        (left, bottom),
        (centre, top),
        (centre, bottom),
    ];
    let score = |&(x, y): &(i32, i32)| -> usize {
        let rect = PixelRect {
            x0: x - 3,
            y0: y - 3,
            x1: x + width + 3,
            y1: y + height + 3,
        };
        let covered = covered(samples, &rect);
        let blocked = obstacles.iter().filter(|o| o.overlaps(&rect)).count();
        covered + 100_000 * blocked
    };
    let mut best = candidates[0];
    let mut best_score = score(&best);
    for candidate in &candidates[1..] {
        let s = score(candidate);
        if s < best_score {
            best = *candidate;
            best_score = s;
        }
    }
    let (x0, y0) = best;
    let area = chart.plotting_area().strip_coord_spec();
    area.draw(&Rectangle::new(
        [(x0, y0), (x0 + width, y0 + height)],
        WHITE.mix(0.9).filled(),
    ))
    .drawing()?;
    area.draw(&Rectangle::new(
        [(x0, y0), (x0 + width, y0 + height)],
        BLACK.mix(0.4).stroke_width(1),
    ))
    .drawing()?;
    for (i, entry) in entries.iter().enumerate() {
        let y = y0 + PAD / 2 + ROW / 2 + i as i32 * ROW + 1;
        let xs = x0 + PAD;
        let style = curve_style(entry.colour);
        match entry.kind {
            LineKind::Solid => area
                .draw(&PathElement::new(vec![(xs, y), (xs + SAMPLE, y)], style))
                .drawing()?,
            LineKind::Dashed => {
                for (a, b) in [(0, 8), (12, 20), (24, SAMPLE)] {
                    area.draw(&PathElement::new(vec![(xs + a, y), (xs + b, y)], style))
                        .drawing()?;
                }
            }
            LineKind::Points => {
                for dx in [6, SAMPLE - 6] {
                    area.draw(&Circle::new((xs + dx, y), 3, entry.colour.filled()))
                        .drawing()?;
                }
            }
        }
        let text_style = ("sans-serif", LABEL_FONT)
            .into_font()
            .color(&BLACK)
            .pos(Pos::new(HPos::Left, VPos::Center));
        area.draw(&Text::new(
            entry.label.clone(),
            (xs + SAMPLE + PAD, y),
            text_style,
        ))
        .drawing()?;
    }
    Ok(())
}
