//! Integration tests: write plots into a temporary directory and check the SVG text.
//!
//! Set `MIL_PLOTS_KEEP=<dir>` to also keep the sample plots of `sample_plots_for_viewing` in
//! that directory (convert with `rsvg-convert -o plot.png plot.svg` to look at them).

use std::f64::consts::PI;
use std::path::{Path, PathBuf};

use mil_plots::{
    bode_page_svg, bode_svg, xy_svg, Annotation, BodePlot, BodeSeries, MagnitudeScale, Marker,
    SeriesStyle, XyPlot, XySeries,
};
use num_complex::Complex64;

/// Log-spaced frequencies from `from` to `to` Hz.
fn log_frequencies(from: f64, to: f64, count: usize) -> Vec<f64> {
    (0..count)
        .map(|k| from * (to / from).powf(k as f64 / (count - 1) as f64))
        .collect()
}

/// A second-order resonance `w0^2 / (s^2 + 2 zeta w0 s + w0^2)` times a delay, times `gain`.
fn resonance(frequency: &[f64], f0: f64, zeta: f64, delay: f64, gain: f64) -> Vec<Complex64> {
    let w0 = 2.0 * PI * f0;
    frequency
        .iter()
        .map(|f| {
            let s = Complex64::new(0.0, 2.0 * PI * f);
            gain * w0 * w0 / (s * s + 2.0 * zeta * w0 * s + w0 * w0) * (-s * delay).exp()
        })
        .collect()
}

/// A two-series Bode diagram with markers and reference lines.
fn sample_bode() -> BodePlot {
    let frequency = log_frequencies(0.1, 200.0, 400);
    let mut plot = BodePlot::new("Tyre force response", "tyre force / road [N/mm]");
    plot.magnitude_factor = 1e-3;
    plot.series.push(BodeSeries::new(
        "MiL",
        frequency.clone(),
        resonance(&frequency, 12.0, 0.15, 0.004, 2.0e5),
    ));
    let mut emulated = BodeSeries::new(
        "emulated",
        frequency.clone(),
        resonance(&frequency, 11.0, 0.2, 0.006, 1.8e5),
    );
    emulated.dashed = true;
    plot.series.push(emulated);
    plot.markers.push(Marker::new(12.0, "resonance 12.0 Hz"));
    plot.markers.push(Marker::new(21.3, "GM 1.4 at 21.3 Hz"));
    plot.phase_lines.push(-180.0);
    plot.magnitude_lines.push(1.0);
    plot
}

/// Reads an SVG file and checks that it looks like an SVG document.
fn read_svg(path: &Path) -> String {
    let text = std::fs::read_to_string(path).expect("plot file is readable");
    let trimmed = text.trim();
    assert!(
        trimmed.starts_with("<svg") || trimmed.starts_with("<?xml"),
        "not an SVG start: {}",
        &trimmed[..trimmed.len().min(80)]
    );
    assert!(trimmed.ends_with("</svg>"), "SVG does not end with </svg>");
    text
}

/// Number of `<polyline` elements drawn in the given colour (`#RRGGBB`).
fn polylines_in(svg: &str, colour: &str) -> usize {
    svg.lines()
        .filter(|l| l.contains("<polyline") && l.contains(&format!("stroke=\"{colour}\"")))
        .count()
}

/// The text lines inside `<text>` elements.
fn texts(svg: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut rest = svg;
    while let Some(start) = rest.find("<text") {
        rest = &rest[start..];
        let Some(open_end) = rest.find('>') else {
            break;
        };
        let Some(close) = rest.find("</text>") else {
            break;
        };
        out.push(rest[open_end + 1..close].trim().to_string());
        rest = &rest[close..];
    }
    out
}

fn temp_dir() -> tempfile::TempDir {
    tempfile::tempdir().expect("temporary directory")
}

#[test]
fn bode_svg_contains_series_and_marker_labels() {
    let dir = temp_dir();
    let path = dir.path().join("bode.svg");
    bode_svg(&path, &sample_bode()).unwrap();
    let svg = read_svg(&path);
    let texts = texts(&svg);
    for label in [
        "Tyre force response",
        "MiL",
        "emulated",
        "resonance 12.0 Hz",
        "GM 1.4 at 21.3 Hz",
        "tyre force / road [N/mm]",
        "phase [deg]",
        "frequency [Hz]",
    ] {
        assert!(texts.iter().any(|t| t == label), "missing text {label:?}");
    }
    // Decade labels on the frequency axis (0.1 .. 200 Hz).
    for decade in ["0.1", "1", "10", "100"] {
        assert!(texts.iter().any(|t| t == decade), "missing tick {decade}");
    }
    // Phase ticks at multiples of 45 degrees including the -180 reference.
    assert!(texts.iter().any(|t| t == "-180"));
}

#[test]
fn the_frequency_axis_covers_the_span_asked_for() {
    // A series over 5-20 Hz only, in a diagram that claims 0.5-30 Hz.
    let frequency = log_frequencies(5.0, 20.0, 50);
    let mut plot = BodePlot::new("coherent part of a band", "force / road [N/mm]");
    plot.series.push(BodeSeries::new(
        "estimate",
        frequency.clone(),
        resonance(&frequency, 12.0, 0.15, 0.0, 1.0),
    ));
    let dir = temp_dir();
    // The frequency axis' tick labels: the numbers drawn lowest on the page.
    let ticks = |plot: &BodePlot, name: &str| {
        let path = dir.path().join(name);
        bode_svg(&path, plot).unwrap();
        let svg = read_svg(&path);
        let numbers: Vec<(u32, String)> = svg
            .split("<text")
            .skip(1)
            .filter_map(|t| {
                let y = t.split("y=\"").nth(1)?.split('"').next()?.parse().ok()?;
                let text = t.split('>').nth(1)?.split('<').next()?.trim().to_string();
                text.parse::<f64>().is_ok().then_some((y, text))
            })
            .collect();
        let bottom = numbers.iter().map(|n| n.0).max().unwrap();
        numbers
            .into_iter()
            .filter(|n| n.0 == bottom)
            .map(|n| n.1)
            .collect::<Vec<_>>()
    };
    let without = ticks(&plot, "without.svg");
    assert!(!without.iter().any(|t| t == "1"), "{without:?}");
    plot.frequency_span = Some([0.5, 30.0]);
    let with = ticks(&plot, "with.svg");
    for tick in ["1", "10"] {
        assert!(
            with.iter().any(|t| t == tick),
            "missing tick {tick}: {with:?}"
        );
    }
    // A span that is not a band of positive frequencies is ignored, not drawn.
    plot.frequency_span = Some([0.0, f64::NAN]);
    assert_eq!(ticks(&plot, "bad.svg"), without);
}

#[test]
fn dashed_series_is_drawn_as_separate_segments() {
    let dir = temp_dir();
    let path = dir.path().join("bode.svg");
    bode_svg(&path, &sample_bode()).unwrap();
    let svg = read_svg(&path);
    // Series 0 (solid, first palette colour): one polyline per panel plus the legend sample.
    let solid = polylines_in(&svg, "#1F77B4");
    // Series 1 (dashed, second palette colour): many short dashes.
    let dashed = polylines_in(&svg, "#FF7F0E");
    assert_eq!(solid, 3, "solid series polylines");
    assert!(dashed > 40, "dashed series has only {dashed} polylines");
}

#[test]
fn log_magnitude_with_zero_and_non_finite_values_is_drawn() {
    let dir = temp_dir();
    let frequency = log_frequencies(1.0, 100.0, 50);
    let mut response = resonance(&frequency, 10.0, 0.3, 0.0, 1.0);
    response[0] = Complex64::new(0.0, 0.0);
    response[10] = Complex64::new(f64::NAN, 0.0);
    response[20] = Complex64::new(f64::INFINITY, 1.0);
    let mut frequency_with_nan = frequency.clone();
    frequency_with_nan[30] = f64::NAN;
    for scale in [
        MagnitudeScale::Log,
        MagnitudeScale::Decibel,
        MagnitudeScale::Linear,
    ] {
        let mut plot = BodePlot::new("zeros", "gain [-]");
        plot.magnitude_scale = scale;
        plot.series.push(BodeSeries::new(
            "with zeros",
            frequency_with_nan.clone(),
            response.clone(),
        ));
        // A series that is zero everywhere: nothing to draw on a log or dB axis.
        plot.series.push(BodeSeries::new(
            "all zero",
            frequency.clone(),
            vec![Complex64::new(0.0, 0.0); frequency.len()],
        ));
        let path = dir.path().join(format!("zeros-{scale:?}.svg"));
        bode_svg(&path, &plot).unwrap();
        let svg = read_svg(&path);
        assert!(svg.contains("with zeros") && svg.contains("all zero"));
    }
}

#[test]
fn odd_but_valid_data_is_drawn() {
    let dir = temp_dir();
    // A single point.
    let mut plot = BodePlot::new("one point", "gain [-]");
    plot.series.push(BodeSeries::new(
        "single",
        vec![5.0],
        vec![Complex64::new(0.0, 2.0)],
    ));
    bode_svg(&dir.path().join("single.svg"), &plot).unwrap();
    // Equal magnitudes and unsorted frequencies, marker at an invalid frequency.
    let mut plot = BodePlot::new("flat", "gain [dB]");
    plot.magnitude_scale = MagnitudeScale::Decibel;
    plot.series.push(BodeSeries::new(
        "flat",
        vec![10.0, 1.0, 100.0, 3.0],
        vec![Complex64::new(1.0, 0.0); 4],
    ));
    plot.markers.push(Marker::new(f64::NAN, "nowhere"));
    plot.markers.push(Marker::new(-1.0, "negative"));
    plot.magnitude_lines.push(f64::INFINITY);
    plot.phase_lines.push(f64::NAN);
    let path = dir.path().join("flat.svg");
    bode_svg(&path, &plot).unwrap();
    let svg = read_svg(&path);
    assert!(!svg.contains("nowhere") && !svg.contains("negative"));
    // Special characters in labels are escaped.
    let mut plot = BodePlot::new("a < b & c", "|G| [-]");
    plot.series.push(BodeSeries::new(
        "<tag>",
        vec![1.0, 2.0],
        vec![Complex64::new(1.0, 0.0); 2],
    ));
    let path = dir.path().join("escape.svg");
    bode_svg(&path, &plot).unwrap();
    let svg = read_svg(&path);
    assert!(svg.contains("a &lt; b &amp; c") && svg.contains("&lt;tag&gt;"));
}

#[test]
fn bode_errors() {
    let dir = temp_dir();
    let path = dir.path().join("error.svg");
    let empty = BodePlot::new("empty", "gain [-]");
    let err = bode_svg(&path, &empty).unwrap_err().to_string();
    assert!(err.contains("no series"), "{err}");

    let mut plot = BodePlot::new("empty series", "gain [-]");
    plot.series.push(BodeSeries::new("nothing", vec![], vec![]));
    let err = bode_svg(&path, &plot).unwrap_err().to_string();
    assert!(err.contains("empty"), "{err}");

    let mut plot = BodePlot::new("mismatch", "gain [-]");
    plot.series.push(BodeSeries::new(
        "short",
        vec![1.0, 2.0],
        vec![Complex64::new(1.0, 0.0)],
    ));
    let err = bode_svg(&path, &plot).unwrap_err().to_string();
    assert!(err.contains("2 frequencies but 1"), "{err}");

    let mut plot = BodePlot::new("dc", "gain [-]");
    plot.series.push(BodeSeries::new(
        "with dc",
        vec![0.0, 1.0],
        vec![Complex64::new(1.0, 0.0); 2],
    ));
    let err = bode_svg(&path, &plot).unwrap_err().to_string();
    assert!(err.contains("non-positive frequency"), "{err}");

    let mut plot = BodePlot::new("nan", "gain [-]");
    plot.series.push(BodeSeries::new(
        "all nan",
        vec![1.0, 2.0],
        vec![Complex64::new(f64::NAN, 0.0); 2],
    ));
    let err = bode_svg(&path, &plot).unwrap_err().to_string();
    assert!(err.contains("no finite data"), "{err}");

    let mut plot = sample_bode();
    plot.magnitude_factor = 0.0;
    assert!(bode_svg(&path, &plot).is_err());

    assert!(!path.exists(), "no file is written on errors");

    // A missing folder is made; one that cannot be (a file in its way) is named.
    std::fs::write(dir.path().join("a-file"), "x").unwrap();
    let unwritable = dir.path().join("a-file").join("bode.svg");
    let err = bode_svg(&unwritable, &sample_bode())
        .unwrap_err()
        .to_string();
    assert!(err.contains("cannot create the folder"), "{err}");
    assert!(err.contains("a-file"), "{err}");
    let made = dir.path().join("missing-folder").join("bode.svg");
    bode_svg(&made, &sample_bode()).unwrap();
    assert!(made.is_file());
}

#[test]
fn bode_page_stacks_diagrams() {
    let dir = temp_dir();
    let path = dir.path().join("page.svg");
    let mut second = sample_bode();
    second.title = "Second diagram".into();
    second.magnitude_scale = MagnitudeScale::Decibel;
    second.magnitude_label = "loop gain [dB]".into();
    let mut third = sample_bode();
    third.title = "Third diagram".into();
    third.magnitude_scale = MagnitudeScale::Linear;
    bode_page_svg(&path, &[sample_bode(), second, third.clone()]).unwrap();
    let svg = read_svg(&path);
    let texts = texts(&svg);
    for title in ["Tyre force response", "Second diagram", "Third diagram"] {
        assert!(texts.iter().any(|t| t == title), "missing {title}");
    }
    assert_eq!(texts.iter().filter(|t| *t == "frequency [Hz]").count(), 3);
    assert!(svg.contains("height=\"1800\""), "three 600-pixel diagrams");

    assert!(bode_page_svg(&path, &[]).is_err());
    third.series.clear();
    let err = format!(
        "{:#}",
        bode_page_svg(&path, &[sample_bode(), third]).unwrap_err()
    );
    assert!(err.contains("Bode diagram 2"), "{err}");
}

/// A Pareto front of two criteria with a target point.
fn sample_xy() -> XyPlot {
    let front: Vec<(f64, f64)> = (0..=20)
        .map(|k| {
            let t = f64::from(k) / 20.0;
            (0.5 + 2.0 * t, 4.0 / (0.5 + 2.0 * t) + 0.3)
        })
        .collect();
    let candidates: Vec<(f64, f64)> = (0..40)
        .map(|k| {
            let t = f64::from(k) / 40.0;
            (
                0.6 + 2.0 * t,
                4.0 / (0.5 + 2.0 * t) + 0.8 + (f64::from(k) * 1.7).sin().abs(),
            )
        })
        .collect();
    let mut plot = XyPlot::new(
        "Design trade-off",
        "tracking error [mm RMS]",
        "force noise [N RMS]",
    );
    plot.series
        .push(XySeries::new("candidates", candidates, SeriesStyle::Points));
    plot.series.push(XySeries::new(
        "Pareto front",
        front.clone(),
        SeriesStyle::Line,
    ));
    plot.series.push(XySeries::new(
        "previous front",
        front.iter().map(|&(x, y)| (x * 1.1, y * 1.15)).collect(),
        SeriesStyle::Dashed,
    ));
    plot.annotations
        .push(Annotation::new(1.2, 3.7, "target (1.2, 3.7)"));
    plot
}

#[test]
fn xy_svg_contains_labels_and_annotation() {
    let dir = temp_dir();
    let path = dir.path().join("pareto.svg");
    xy_svg(&path, &sample_xy()).unwrap();
    let svg = read_svg(&path);
    let texts = texts(&svg);
    for label in [
        "Design trade-off",
        "tracking error [mm RMS]",
        "force noise [N RMS]",
        "candidates",
        "Pareto front",
        "previous front",
        "target (1.2, 3.7)",
    ] {
        assert!(texts.iter().any(|t| t == label), "missing text {label:?}");
    }
    // 40 candidate points as circles of the first colour (plus two in the legend).
    let circles = svg
        .lines()
        .filter(|l| l.contains("<circle") && l.contains("#1F77B4"))
        .count();
    assert_eq!(circles, 42);
    // The dashed series (third colour) is drawn in many pieces, the solid one (second) in one
    // plus its legend sample.
    assert_eq!(polylines_in(&svg, "#FF7F0E"), 2);
    assert!(polylines_in(&svg, "#2CA02C") > 10);
}

#[test]
fn xy_log_axes_skip_non_positive_values() {
    let dir = temp_dir();
    let path = dir.path().join("coherence.svg");
    let frequency = log_frequencies(0.5, 500.0, 200);
    let coherence: Vec<(f64, f64)> = frequency
        .iter()
        .map(|&f| (f, 1.0 / (1.0 + (f / 100.0).powi(4))))
        .chain([(0.0, 0.5), (-1.0, 0.5), (10.0, 0.0), (f64::NAN, 1.0)])
        .collect();
    let mut plot = XyPlot::new("Coherence", "frequency [Hz]", "coherence [-]");
    plot.log_x = true;
    plot.log_y = true;
    plot.series
        .push(XySeries::new("coherence", coherence, SeriesStyle::Line));
    xy_svg(&path, &plot).unwrap();
    let svg = read_svg(&path);
    let texts = texts(&svg);
    assert!(
        texts.iter().any(|t| t == "100"),
        "decade label on the x axis"
    );
    assert!(texts.iter().any(|t| t == "coherence"));
}

#[test]
fn xy_errors() {
    let dir = temp_dir();
    let path = dir.path().join("error.svg");
    let plot = XyPlot::new("empty", "x", "y");
    assert!(xy_svg(&path, &plot).is_err());
    let mut plot = XyPlot::new("empty series", "x", "y");
    plot.series
        .push(XySeries::new("nothing", vec![], SeriesStyle::Line));
    let err = xy_svg(&path, &plot).unwrap_err().to_string();
    assert!(err.contains("no points"), "{err}");
    let mut plot = XyPlot::new("all negative on log axes", "x", "y");
    plot.log_y = true;
    plot.series.push(XySeries::new(
        "negative",
        vec![(1.0, -1.0), (2.0, 0.0), (f64::NAN, 1.0)],
        SeriesStyle::Points,
    ));
    let err = xy_svg(&path, &plot).unwrap_err().to_string();
    assert!(err.contains("no finite data"), "{err}");
    assert!(!path.exists());
    std::fs::write(dir.path().join("a-file"), "x").unwrap();
    let unwritable = dir.path().join("a-file").join("xy.svg");
    assert!(xy_svg(&unwritable, &sample_xy()).is_err());
}

#[test]
fn xy_single_point_and_annotation_only() {
    let dir = temp_dir();
    let mut plot = XyPlot::new("one point", "x [-]", "y [-]");
    plot.series
        .push(XySeries::new("one", vec![(2.0, 2.0)], SeriesStyle::Line));
    xy_svg(&dir.path().join("one.svg"), &plot).unwrap();
    let mut plot = XyPlot::new("target only", "x [-]", "y [-]");
    plot.annotations.push(Annotation::new(0.0, 0.0, "origin"));
    let path = dir.path().join("target.svg");
    xy_svg(&path, &plot).unwrap();
    assert!(read_svg(&path).contains("origin"));
}

/// Writes the sample plots; with `MIL_PLOTS_KEEP` set they are kept for viewing.
#[test]
fn sample_plots_for_viewing() {
    let dir = temp_dir();
    let out: PathBuf = std::env::var_os("MIL_PLOTS_KEEP")
        .map(PathBuf::from)
        .unwrap_or_else(|| dir.path().to_path_buf());
    bode_svg(&out.join("sample-bode.svg"), &sample_bode()).unwrap();
    let mut decibel = sample_bode();
    decibel.title = "Loop gain".into();
    decibel.magnitude_label = "loop gain [dB]".into();
    decibel.magnitude_scale = MagnitudeScale::Decibel;
    decibel.magnitude_factor = 1.0 / 2.0e5;
    decibel.magnitude_lines = vec![0.0];
    bode_page_svg(
        &out.join("sample-page.svg"),
        &[sample_bode(), decibel.clone()],
    )
    .unwrap();
    xy_svg(&out.join("sample-pareto.svg"), &sample_xy()).unwrap();
    for name in ["sample-bode.svg", "sample-page.svg", "sample-pareto.svg"] {
        read_svg(&out.join(name));
    }
}
