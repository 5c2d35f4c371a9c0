//! # mil-plots
//!
//! SVG plots for the mil tools, drawn with `plotters`' SVG backend (no system fonts or
//! libraries needed):
//!
//! - [`bode_svg`]: a Bode diagram (magnitude panel above, unwrapped phase panel below, shared
//!   logarithmic frequency axis) comparing several responses, with labelled vertical
//!   [`Marker`]s and horizontal reference lines;
//! - [`bode_page_svg`]: several Bode diagrams stacked in one file;
//! - [`xy_svg`]: an x-y plot (lines, dashed lines or points, optional log axes) with labelled
//!   [`Annotation`] crosses, e.g. a Pareto front with its target point.
//!
//! Axis ranges come from the data with some padding. Non-finite values are skipped (a line is
//! interrupted there) and so are non-positive values on logarithmic axes; odd data never
//! panics. Empty plots, empty series, mismatched lengths, non-positive frequencies and
//! unwritable paths are errors.
//!
//! ```no_run
//! use mil_plots::{bode_svg, BodePlot, BodeSeries, MagnitudeScale, Marker};
//! use num_complex::Complex64;
//!
//! let frequency: Vec<f64> = (1..=200).map(|k| 0.1 * f64::from(k)).collect();
//! let response = frequency
//!     .iter()
//!     .map(|f| Complex64::new(1.0, 0.0) / Complex64::new(1.0, f / 5.0))
//!     .collect();
//! let mut plot = BodePlot::new("Loop gain", "loop gain [dB]");
//! plot.magnitude_scale = MagnitudeScale::Decibel;
//! plot.series.push(BodeSeries::new("MiL", frequency, response));
//! plot.markers.push(Marker::new(5.0, "corner 5 Hz"));
//! plot.phase_lines.push(-180.0);
//! bode_svg(std::path::Path::new("loop_gain.svg"), &plot)?;
//! # Ok::<(), anyhow::Error>(())
//! ```

mod axis;
mod bode;
mod draw;
mod phase;
mod xy;

use num_complex::Complex64;

pub use bode::{bode_page_svg, bode_svg};
pub use phase::{bode_phase_deg, unwrap_phase_deg};
pub use xy::xy_svg;

/// How the magnitude axis of a Bode diagram is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum MagnitudeScale {
    /// `20 log10(factor * |response|)` on a linear axis; zero responses are skipped.
    Decibel,
    /// `factor * |response|` on a linear axis that includes zero.
    Linear,
    /// `factor * |response|` on a logarithmic axis; zero responses are skipped.
    #[default]
    Log,
}

/// One response to draw on a Bode diagram.
#[derive(Clone, Debug, PartialEq)]
pub struct BodeSeries {
    /// Legend text (an empty label leaves the series out of the legend).
    pub label: String,
    /// Frequencies in Hz, in any order (they are sorted for drawing); must be positive.
    /// Non-finite entries are skipped.
    pub frequency_hz: Vec<f64>,
    /// The complex response at each frequency (same length as `frequency_hz`). Non-finite
    /// entries are skipped.
    pub response: Vec<Complex64>,
    /// Draw the series with a dashed line.
    pub dashed: bool,
}

impl BodeSeries {
    /// A solid series.
    pub fn new(label: impl Into<String>, frequency_hz: Vec<f64>, response: Vec<Complex64>) -> Self {
        BodeSeries {
            label: label.into(),
            frequency_hz,
            response,
            dashed: false,
        }
    }
}

/// A vertical marker at a frequency across both panels of a Bode diagram, labelled at the top
/// of the magnitude panel (e.g. "GM 1.4 at 21.3 Hz").
///
/// Markers at non-finite or non-positive frequencies are not drawn.
#[derive(Clone, Debug, PartialEq)]
pub struct Marker {
    /// Where the marker is, in Hz.
    pub frequency_hz: f64,
    /// The text next to the marker.
    pub label: String,
}

impl Marker {
    /// A marker at `frequency_hz` with `label`.
    pub fn new(frequency_hz: f64, label: impl Into<String>) -> Self {
        Marker {
            frequency_hz,
            label: label.into(),
        }
    }
}

/// A Bode diagram: magnitude panel above, phase panel (degrees, each series unwrapped) below,
/// shared log-frequency axis.
///
/// The phase of each series is unwrapped along ascending frequency and shifted by a multiple of
/// 360 degrees so that it lies in (-180, 180] at the series' lowest frequency (see
/// [`bode_phase_deg`]). Reference lines and markers are included in the axis ranges.
#[derive(Clone, Debug, PartialEq)]
pub struct BodePlot {
    /// Title above the diagram.
    pub title: String,
    /// Magnitude axis label including units, e.g. "tyre force / road [N/mm]". It is drawn as
    /// given, so say `[dB]` in it when `magnitude_scale` is [`MagnitudeScale::Decibel`].
    pub magnitude_label: String,
    /// How the magnitude axis is drawn.
    pub magnitude_scale: MagnitudeScale,
    /// Factor applied to |response| before plotting (e.g. 1e-3 to show N/m as N/mm); must be
    /// positive and finite.
    pub magnitude_factor: f64,
    /// The responses, drawn in distinct colours in this order.
    pub series: Vec<BodeSeries>,
    /// Labelled vertical markers.
    pub markers: Vec<Marker>,
    /// Horizontal reference lines on the phase panel, degrees (e.g. vec![-180.0]).
    pub phase_lines: Vec<f64>,
    /// Horizontal reference lines on the magnitude panel, in plotted units (e.g. vec![1.0] or
    /// vec![0.0] dB).
    pub magnitude_lines: Vec<f64>,
    /// A band (Hz, low and high) the frequency axis covers whatever the series cover, e.g. the
    /// band a comparison claims when its estimate is coherent over part of it only.
    pub frequency_span: Option<[f64; 2]>,
}

impl BodePlot {
    /// An empty diagram: logarithmic magnitude axis, factor 1, no series, markers or lines.
    pub fn new(title: impl Into<String>, magnitude_label: impl Into<String>) -> Self {
        BodePlot {
            title: title.into(),
            magnitude_label: magnitude_label.into(),
            magnitude_scale: MagnitudeScale::Log,
            magnitude_factor: 1.0,
            series: Vec::new(),
            markers: Vec::new(),
            phase_lines: Vec::new(),
            magnitude_lines: Vec::new(),
            frequency_span: None,
        }
    }
}

/// How an x-y series is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum SeriesStyle {
    /// A solid line through the points in the given order.
    #[default]
    Line,
    /// A dashed line through the points in the given order.
    Dashed,
    /// A filled circle at each point, no line.
    Points,
}

/// One series of an x-y plot.
#[derive(Clone, Debug, PartialEq)]
pub struct XySeries {
    /// Legend text (an empty label leaves the series out of the legend).
    pub label: String,
    /// The points `(x, y)`, joined in this order for the line styles. Non-finite points (and
    /// non-positive ones on log axes) are skipped, interrupting the line.
    pub points: Vec<(f64, f64)>,
    /// How the series is drawn.
    pub style: SeriesStyle,
}

impl XySeries {
    /// A series with the given label, points and style.
    pub fn new(label: impl Into<String>, points: Vec<(f64, f64)>, style: SeriesStyle) -> Self {
        XySeries {
            label: label.into(),
            points,
            style,
        }
    }
}

/// A labelled point on an x-y plot, drawn as a black cross with its text next to it (e.g. the
/// target of a trade-off).
#[derive(Clone, Debug, PartialEq)]
pub struct Annotation {
    /// x coordinate.
    pub x: f64,
    /// y coordinate.
    pub y: f64,
    /// The text next to the cross.
    pub label: String,
}

impl Annotation {
    /// An annotation at `(x, y)`.
    pub fn new(x: f64, y: f64, label: impl Into<String>) -> Self {
        Annotation {
            x,
            y,
            label: label.into(),
        }
    }
}

/// An x-y plot with optional logarithmic axes.
#[derive(Clone, Debug, PartialEq)]
pub struct XyPlot {
    /// Title above the plot.
    pub title: String,
    /// x axis label including units.
    pub x_label: String,
    /// y axis label including units.
    pub y_label: String,
    /// Logarithmic x axis (non-positive x values are skipped).
    pub log_x: bool,
    /// Logarithmic y axis (non-positive y values are skipped).
    pub log_y: bool,
    /// The series, drawn in distinct colours in this order.
    pub series: Vec<XySeries>,
    /// Labelled crosses drawn over the series.
    pub annotations: Vec<Annotation>,
}

impl XyPlot {
    /// An empty plot with linear axes.
    pub fn new(
        title: impl Into<String>,
        x_label: impl Into<String>,
        y_label: impl Into<String>,
    ) -> Self {
        XyPlot {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            log_x: false,
            log_y: false,
            series: Vec::new(),
            annotations: Vec::new(),
        }
    }
}
