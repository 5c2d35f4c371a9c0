//! The frequency-response table: validation, CSV round trip, unwrapping, interpolation.

use mil_identify::{Complex64, FrfPoint, FrfTable, IdentifyError};

use crate::common::temp_path;

fn point(f: f64, m: f64, p: f64, c: Option<f64>) -> FrfPoint {
    FrfPoint {
        frequency_hz: f,
        magnitude: m,
        phase_deg: p,
        coherence: c,
    }
}

/// First-order low-pass `1 / (1 + j f/fc)`, corner 10 Hz, followed by a delay (s).
fn low_pass(f: f64, delay_s: f64) -> Complex64 {
    let delay = Complex64::from_polar(1.0, -2.0 * std::f64::consts::PI * f * delay_s);
    delay / Complex64::new(1.0, f / 10.0)
}

/// The delay of the delayed low-pass: 2 ms turns the phase to -810° at 1 kHz, so a wrapped
/// phase differs from the unwrapped one by up to 720°.
const DELAY: f64 = 0.002;

/// 20 points per decade from 0.1 Hz to 1 kHz (81 points).
fn log_grid() -> Vec<f64> {
    (0..=80)
        .map(|i| 0.1 * 10f64.powf(i as f64 / 20.0))
        .collect()
}

fn low_pass_table(delay_s: f64) -> FrfTable {
    let f = log_grid();
    let h: Vec<Complex64> = f.iter().map(|&f| low_pass(f, delay_s)).collect();
    FrfTable::from_response(&f, &h, None).unwrap()
}

fn parse(text: &str) -> Result<FrfTable, IdentifyError> {
    FrfTable::from_reader(text.as_bytes())
}

#[test]
fn csv_round_trip_is_exact() {
    // Awkward values: long decimals, tiny and huge numbers, exponent notation, negative
    // phases beyond -360°, coherence present.
    let points = vec![
        point(0.1, 1.0 / 3.0, -0.123_456_789_012_345_67, Some(0.999_999)),
        point(1.0 / 7.0, 2.5e-9, -190.0, Some(0.5)),
        point(10.0, 123_456_789.123_456_78, -370.25, Some(1.0)),
        point(2e4, 0.0, -400.0, Some(0.0)),
    ];
    let table = FrfTable::new(points).unwrap();
    let mut buf = Vec::new();
    table.to_writer(&mut buf).unwrap();
    let text = String::from_utf8(buf.clone()).unwrap();
    assert!(
        text.starts_with("frequency_hz,magnitude,phase_deg,coherence\n"),
        "{text}"
    );
    let back = FrfTable::from_reader(buf.as_slice()).unwrap();
    // The format writes shortest round-trip representations: equal to 1e-12 relative is
    // the requirement, and in fact bit-equal.
    for (a, b) in table.points().iter().zip(back.points()) {
        for (x, y) in [
            (a.frequency_hz, b.frequency_hz),
            (a.magnitude, b.magnitude),
            (a.phase_deg, b.phase_deg),
            (a.coherence.unwrap(), b.coherence.unwrap()),
        ] {
            assert!((x - y).abs() <= 1e-12 * x.abs(), "{x} vs {y}");
        }
    }
    assert_eq!(table, back);

    // Through a file, and without the coherence column.
    let table = low_pass_table(DELAY);
    assert!(!table.has_coherence());
    let path = temp_path("round-trip.csv");
    table.write_csv(&path).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(text.starts_with("frequency_hz,magnitude,phase_deg\n"));
    let back = FrfTable::read_csv(&path).unwrap();
    std::fs::remove_file(&path).unwrap();
    assert_eq!(table, back);
}

#[test]
fn from_response_unwraps_phase() {
    let table = low_pass_table(DELAY);
    // The exact phase is continuous: -atan(f/10) - 360·f·0.002 degrees, reaching
    // -90 - 720 = -810° at 1 kHz. The unwrapped table must match it (not just modulo 360).
    for p in table.points() {
        let exact = -(p.frequency_hz / 10.0).atan().to_degrees() - 360.0 * p.frequency_hz * 0.002;
        assert!(
            (p.phase_deg - exact).abs() < 1e-9,
            "{} Hz: {} vs {exact}",
            p.frequency_hz,
            p.phase_deg
        );
    }
}

#[test]
fn wrapped_phase_column_is_unwrapped_on_reading() {
    // Write the low-pass table by hand with the phase wrapped to (-180, 180].
    let table = low_pass_table(DELAY);
    let mut text = String::from("frequency_hz , magnitude, phase_deg\n");
    for p in table.points() {
        let wrapped = low_pass(p.frequency_hz, DELAY).arg().to_degrees();
        assert!(wrapped > -180.0 && wrapped <= 180.0);
        text += &format!("{},{},{}\n", p.frequency_hz, p.magnitude, wrapped);
    }
    let back = parse(&text).unwrap();
    let mut jumps = 0;
    for (a, b) in table.points().iter().zip(back.points()) {
        // Unwrapping adds exact multiples of 360 to the wrapped value: equal to rounding.
        assert!(
            (a.phase_deg - b.phase_deg).abs() < 1e-9,
            "{} vs {}",
            a.phase_deg,
            b.phase_deg
        );
        if (a.phase_deg - low_pass(a.frequency_hz, DELAY).arg().to_degrees()).abs() > 1.0 {
            jumps += 1;
        }
    }
    // The check is not vacuous: many rows needed a shift of 360° or 720°.
    assert!(jumps > 10, "{jumps}");
}

#[test]
fn invalid_files_are_errors_naming_the_problem() {
    let cases: &[(&str, &str, &[&str])] = &[
        (
            "wrong header",
            "freq,mag,phase\n1,1,0\n2,1,0\n",
            &["line 1", "header"],
        ),
        (
            "dB header",
            "frequency_hz,magnitude_db,phase_deg\n1,1,0\n2,1,0\n",
            &["line 1"],
        ),
        (
            "five columns",
            "frequency_hz,magnitude,phase_deg,coherence,x\n1,1,0,1,1\n2,1,0,1,1\n",
            &["line 1"],
        ),
        ("empty", "", &["line 1"]),
        (
            "header only",
            "frequency_hz,magnitude,phase_deg\n",
            &["at least 2"],
        ),
        (
            "one row",
            "frequency_hz,magnitude,phase_deg\n1,1,0\n",
            &["line 2", "at least 2"],
        ),
        (
            "unsorted",
            "frequency_hz,magnitude,phase_deg\n1,1,0\n3,1,0\n2,1,0\n",
            &["line 4", "line 3", "increasing"],
        ),
        (
            "duplicate",
            "frequency_hz,magnitude,phase_deg\n1,1,0\n2,1,0\n2,1,0\n",
            &["line 4", "duplicates"],
        ),
        (
            "zero frequency",
            "frequency_hz,magnitude,phase_deg\n0,1,0\n2,1,0\n",
            &["line 2", "not positive"],
        ),
        (
            "negative magnitude",
            "frequency_hz,magnitude,phase_deg\n1,1,0\n2,-0.5,0\n",
            &["line 3", "negative"],
        ),
        (
            "NaN",
            "frequency_hz,magnitude,phase_deg\n1,1,0\n2,NaN,0\n",
            &["line 3", "magnitude", "not finite"],
        ),
        (
            "infinite phase",
            "frequency_hz,magnitude,phase_deg\n1,1,0\n2,1,-inf\n",
            &["line 3", "phase_deg", "not finite"],
        ),
        (
            "not a number",
            "frequency_hz,magnitude,phase_deg\n1,1,0\n2,1,abc\n",
            &["line 3", "`abc`"],
        ),
        (
            "missing field",
            "frequency_hz,magnitude,phase_deg\n1,1,0\n2,1\n",
            &["line 3", "2 fields"],
        ),
        (
            "coherence > 1",
            "frequency_hz,magnitude,phase_deg,coherence\n1,1,0,1\n2,1,0,1.5\n",
            &["line 3", "coherence"],
        ),
        (
            "blank field",
            "frequency_hz,magnitude,phase_deg\n1,1,0\n2,,0\n",
            &["line 3", "magnitude"],
        ),
    ];
    for (name, text, needles) in cases {
        let e = parse(text).expect_err(name);
        let msg = e.to_string();
        for needle in *needles {
            assert!(msg.contains(needle), "{name}: `{msg}` lacks `{needle}`");
        }
    }
    // A missing file names the file.
    let path = temp_path("does-not-exist.csv");
    let e = FrfTable::read_csv(&path).unwrap_err();
    assert!(e.to_string().contains("does-not-exist.csv"), "{e}");
}

#[test]
fn new_validates_points() {
    let ok = point(1.0, 1.0, 0.0, None);
    let bad: Vec<(&str, Vec<FrfPoint>)> = vec![
        ("one point", vec![ok]),
        ("decreasing", vec![ok, point(0.5, 1.0, 0.0, None)]),
        ("negative magnitude", vec![ok, point(2.0, -1.0, 0.0, None)]),
        ("NaN phase", vec![ok, point(2.0, 1.0, f64::NAN, None)]),
        (
            "infinite frequency",
            vec![ok, point(f64::INFINITY, 1.0, 0.0, None)],
        ),
        ("negative frequency", vec![point(-1.0, 1.0, 0.0, None), ok]),
        ("mixed coherence", vec![ok, point(2.0, 1.0, 0.0, Some(0.9))]),
        (
            "coherence < 0",
            vec![
                point(1.0, 1.0, 0.0, Some(-0.1)),
                point(2.0, 1.0, 0.0, Some(0.9)),
            ],
        ),
    ];
    for (name, points) in bad {
        assert!(FrfTable::new(points).is_err(), "{name}");
    }
    assert!(FrfTable::from_response(&[1.0, 2.0], &[Complex64::new(1.0, 0.0)], None).is_err());
    assert!(FrfTable::from_response(
        &[1.0, 2.0],
        &[Complex64::new(1.0, 0.0), Complex64::new(f64::NAN, 0.0)],
        None
    )
    .is_err());
}

#[test]
fn interpolation_is_exact_at_nodes_and_accurate_between() {
    let table = low_pass_table(0.0);
    // At the nodes: the node's own value, i.e. the exact response to rounding.
    for p in table.points() {
        let h = table.response(p.frequency_hz).unwrap();
        assert_eq!(h, p.complex());
        let exact = low_pass(p.frequency_hz, 0.0);
        assert!(
            (h - exact).norm() <= 1e-12 * exact.norm(),
            "{} Hz",
            p.frequency_hz
        );
    }
    // Between the nodes: at 9 points inside each of the 80 intervals. The curvature of
    // ln|H| and of the phase in u = log10(f) bounds the error of the linear interpolation at
    // h²/8 · max|d²/du²| with h = 0.05 decade: ln(10)²/2 for ln|H| → ≈ 0.08 % in magnitude
    // (at the corner), ≈ 1 rad → ≈ 0.02° in phase. The limits (0.5 %, 0.5°) are the brief's.
    let grid = log_grid();
    let mut worst_mag = 0.0f64;
    let mut worst_deg = 0.0f64;
    for w in grid.windows(2) {
        for j in 1..10 {
            let f = w[0] * (w[1] / w[0]).powf(j as f64 / 10.0);
            let h = table.response(f).unwrap();
            let exact = low_pass(f, 0.0);
            worst_mag = worst_mag.max((h.norm() / exact.norm() - 1.0).abs());
            worst_deg = worst_deg.max((h / exact).arg().to_degrees().abs());
        }
    }
    println!(
        "interpolation, 20 points/decade: worst magnitude error {:.4} %, phase {:.4} deg",
        100.0 * worst_mag,
        worst_deg
    );
    assert!(worst_mag < 0.005, "magnitude error {worst_mag}");
    assert!(worst_deg < 0.5, "phase error {worst_deg}");
}

#[test]
fn interpolation_is_log_linear() {
    // Two nodes a decade pair apart: the geometric midpoint gets the geometric mean magnitude
    // and the arithmetic mean phase (linear-in-frequency interpolation would give
    // 0.505 and -44.5° at 50.5 Hz instead, and 0.09 / -9.1° at 10 Hz).
    let t = FrfTable::new(vec![
        point(1.0, 1.0, 0.0, None),
        point(100.0, 0.01, -90.0, None),
    ])
    .unwrap();
    let h = t.response(10.0).unwrap();
    assert!((h.norm() - 0.1).abs() < 1e-12, "{}", h.norm());
    assert!((h.arg().to_degrees() + 45.0).abs() < 1e-9);
    // A zero magnitude node: linear in magnitude instead of ln (no NaN).
    let t = FrfTable::new(vec![
        point(1.0, 0.0, 0.0, None),
        point(100.0, 2.0, 0.0, None),
    ])
    .unwrap();
    assert!((t.response(10.0).unwrap().norm() - 1.0).abs() < 1e-12);
}

#[test]
fn out_of_range_queries_are_errors() {
    let table = low_pass_table(DELAY);
    let (lo, hi) = table.frequency_range();
    assert!((lo - 0.1).abs() < 1e-15 && (hi - 1000.0).abs() < 1e-9);
    for f in [0.0, 0.099_999, 1000.001, -1.0, f64::NAN, f64::INFINITY] {
        match table.response(f) {
            Err(IdentifyError::OutOfRange { min, max, .. }) => {
                assert_eq!((min, max), (lo, hi));
            }
            other => panic!("{f} Hz: {other:?}"),
        }
    }
    let e = table.response(2000.0).unwrap_err();
    assert!(e.to_string().contains("2000 Hz"), "{e}");
    // The ends themselves are inside.
    assert!(table.response(lo).is_ok() && table.response(hi).is_ok());
}
