//! Time-series record CSV: reading, checks, and an end-to-end identification from files.

use std::fmt::Write as _;

use mil_identify::{
    h1_estimate, log_sine_sweep, read_record_csv, read_record_from_reader, IdentifyError, Record,
    WelchOptions,
};

use crate::common::{errors, temp_path, TestSystem, FS};

#[test]
fn record_round_trip_through_a_file_identifies_the_system() {
    // A sweep through the test system, written as `mil run` writes its time histories
    // (`time` with 6 decimals first, values in exponent notation, an extra column), read back
    // by name and identified.
    let system = TestSystem::standard();
    let u = log_sine_sweep(10.0, 200.0, 32.0, FS, 1.0);
    let y = system.simulate(&u);
    let mut text = String::from("time,road_0,command,force,mode\n");
    for (i, (a, b)) in u.iter().zip(&y).enumerate() {
        writeln!(text, "{:.6},0,{a:.9e},{b:.9e},1", i as f64 / FS).unwrap();
    }
    let path = temp_path("record.csv");
    std::fs::write(&path, text).unwrap();
    let read = read_record_csv(&path, "command", "force");
    std::fs::remove_file(&path).unwrap();
    let (fs, input, output) = read.unwrap();
    assert!((fs / FS - 1.0).abs() < 1e-9, "{fs}");
    assert_eq!(input.len(), u.len());
    // 10 significant digits written: values back to 1e-9 relative.
    for (a, b) in input.iter().zip(&u) {
        assert!((a - b).abs() <= 1e-9 * b.abs().max(1e-300), "{a} vs {b}");
    }
    let est = h1_estimate(
        &[Record {
            input: &input,
            output: &output,
        }],
        fs,
        &WelchOptions {
            segment_length: 2048,
            // 75 % overlap: even time weighting of the sweep (see the h1 tests).
            overlap: 0.75,
            ..WelchOptions::default()
        },
    )
    .unwrap();
    let table = est.to_table(15.0, 180.0, 0.95).unwrap();
    for p in table.points() {
        let (db, deg) = errors(p.complex(), system.response(p.frequency_hz));
        assert!(
            db.abs() < 0.5 && deg.abs() < 3.0,
            "{} Hz: {db} dB {deg} deg",
            p.frequency_hz
        );
    }
}

fn read(text: &str) -> Result<(f64, Vec<f64>, Vec<f64>), IdentifyError> {
    read_record_from_reader(text.as_bytes(), "u", "y")
}

#[test]
fn rounded_time_at_an_awkward_rate_is_uniform() {
    // 3 kHz written with 6 decimals: each time is off by up to 5e-7 s (0.15 % of a sample);
    // accepted, and the fitted rate is within 1e-6 relative.
    let mut text = String::from("time,y,u\n");
    for i in 0..30_000 {
        writeln!(text, "{:.6},{},{}", i as f64 / 3000.0, i % 7, i % 5).unwrap();
    }
    let (fs, u, y) = read(&text).unwrap();
    assert!((fs / 3000.0 - 1.0).abs() < 1e-6, "{fs}");
    assert_eq!((u[6], y[6]), (1.0, 6.0));
}

#[test]
fn record_errors_name_the_problem() {
    let e = read("time,u,x\n0,1,2\n0.001,1,2\n").unwrap_err();
    assert!(matches!(e, IdentifyError::MissingColumn { .. }));
    let msg = e.to_string();
    assert!(msg.contains("`y`") && msg.contains("time, u, x"), "{msg}");

    let e = read("t,u,y\n0,1,2\n0.001,1,2\n").unwrap_err();
    assert!(
        e.to_string().contains("line 1") && e.to_string().contains("time"),
        "{e}"
    );

    // A dropped sample (0.003 missing): line 5 holds 0.004.
    let e = read("time,u,y\n0,1,2\n0.001,1,2\n0.002,1,2\n0.004,1,2\n0.005,1,2\n0.006,1,2\n")
        .unwrap_err();
    assert!(
        matches!(e, IdentifyError::NonUniformTime { line: 5, .. }),
        "{e}"
    );
    assert!(e.to_string().contains("uniform"), "{e}");

    // Timing jitter of a fraction of a sample passes (the workspace's one time-base rule);
    // a repeated sample does not, on its own line.
    let (fs, _, _) = read("time,u,y\n0,1,2\n0.00111,1,2\n0.002,1,2\n0.0029,1,2\n").unwrap();
    assert!((fs - 1000.0 / 0.9667).abs() < 2.0, "{fs}");
    let e = read("time,u,y\n0,1,2\n0.001,1,2\n0.00101,1,2\n0.002,1,2\n").unwrap_err();
    assert!(
        matches!(e, IdentifyError::NonUniformTime { line: 4, .. }),
        "{e}"
    );

    // Time going backwards.
    assert!(read("time,u,y\n0.002,1,2\n0.001,1,2\n0,1,2\n").is_err());

    let e = read("time,u,y\n0,1,2\n0.001,nan,2\n").unwrap_err();
    assert!(
        e.to_string().contains("line 3") && e.to_string().contains("`u`"),
        "{e}"
    );
    let e = read("time,u,y\n0,1,2\n0.001,1\n").unwrap_err();
    assert!(e.to_string().contains("line 3"), "{e}");
    let e = read("time,u,y\n0,1,2\n").unwrap_err();
    assert!(e.to_string().contains("at least 2"), "{e}");

    let e = read_record_csv(&temp_path("missing-record.csv"), "u", "y").unwrap_err();
    assert!(matches!(e, IdentifyError::Io { .. }), "{e}");
}
