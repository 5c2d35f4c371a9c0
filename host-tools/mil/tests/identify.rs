//! `mil identify` recovers the reference actuator's tracking response from simulated test
//! records (a sine sweep and pink noise, as the paper's responses were measured), and the
//! table it writes gives `mil analyze` the same figures as the model it came from.

use mil::analyze::run_analyze;
use mil::identify::{run_identify, IdentifyOptions};
use mil::setup::SetUp;
use mil_analysis::LinearActuator;
use mil_discretise::{simulate_cascade, zoh_tf, TransferFunction};
use mil_identify::{band_limited_noise, log_sine_sweep};
use mil_params::ServoHydraulicActuator;
use std::io::Write;
use std::path::Path;

const FS: f64 = 2000.0;

/// Writes a record CSV: time, command, force.
fn write_record(path: &Path, command: &[f64], force: &[f32]) {
    let mut f = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    writeln!(f, "time,force_command,force").unwrap();
    for (i, (u, y)) in command.iter().zip(force).enumerate() {
        writeln!(f, "{:.6},{u:.9e},{y:.9e}", i as f64 / FS).unwrap();
    }
}

/// The reference actuator's tracking response sampled with a zero-order hold at `FS`, and
/// its cascade (what the simulated test records run through).
fn reference_tracking() -> (mil_discretise::DiscreteZpk, model_core::CascadeCoefficients) {
    let p = ServoHydraulicActuator::REFERENCE.tracking().unwrap();
    let tf = TransferFunction::new(p.numerator.clone(), p.denominator.clone()).unwrap();
    let discrete = zoh_tf(&tf, 1.0 / FS).unwrap();
    let cascade = discrete.to_cascade().unwrap();
    (discrete, cascade)
}

#[test]
fn identified_table_matches_the_reference_actuator_and_feeds_the_analysis() {
    let (discrete, cascade) = reference_tracking();
    let dir = tempfile::tempdir().unwrap();
    let sweep = log_sine_sweep(0.5, 150.0, 60.0, FS, 1000.0);
    let noise = band_limited_noise(0.5, 140.0, 60.0, FS, 1000.0, true, 7);
    let mut records = Vec::new();
    for (name, u) in [("sweep.csv", &sweep), ("noise.csv", &noise)] {
        let y = simulate_cascade(&cascade, &u.iter().map(|v| *v as f32).collect::<Vec<_>>());
        let path = dir.path().join(name);
        write_record(&path, u, &y);
        records.push(path);
    }
    let table_path = dir.path().join("tracking.csv");
    let (table, summary) = run_identify(&IdentifyOptions {
        records,
        input: "force_command".into(),
        output: "force".into(),
        segment_length: Some(8192),
        band_hz: (1.0, 140.0),
        min_coherence: 0.95,
        out: table_path.clone(),
    })
    .unwrap();
    assert!(summary.points > 400, "{summary:?}");
    // Against the exact response of the simulated (zero-order-hold) system: 0.3 dB, 2°.
    let mut worst = (0.0_f64, 0.0_f64);
    for point in table.points() {
        let exact = discrete.response(point.frequency_hz);
        let got = point.complex();
        let ratio = got / exact;
        worst.0 = worst.0.max((20.0 * ratio.norm().log10()).abs());
        worst.1 = worst.1.max(ratio.arg().to_degrees().abs());
    }
    eprintln!(
        "identified vs exact over {} points: worst {:.3} dB, {:.2} deg",
        summary.points, worst.0, worst.1
    );
    assert!(worst.0 < 0.3 && worst.1 < 2.0, "worst {worst:?}");

    // The analysis with the measured table instead of the model: same gain margin within 0.01.
    let tyre =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/tyre.toml"))
            .unwrap();
    let setup_text = tyre
        .replace(
            "control = \"force\"",
            "control = \"force\"\ntracking = { table = \"tracking.csv\" }",
        )
        .replace("f_min_hz = 0.5", "f_min_hz = 1.5")
        .replace("[analysis]", "[analysis]\nf_max_hz = 139.0");
    for edit in ["control = \"force\"", "f_min_hz = 0.5", "[analysis]"] {
        assert_eq!(tyre.matches(edit).count(), 1, "tyre.toml: {edit}");
    }
    let setup = dir.path().join("tyre-measured.toml");
    std::fs::write(&setup, setup_text).unwrap();
    std::fs::copy(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/tyre-physical.toml"),
        dir.path().join("tyre-physical.toml"),
    )
    .unwrap();
    let measured = run_analyze(&SetUp::read(&setup).unwrap(), &dir.path().join("out"))
        .unwrap()
        .report;
    // The identified table contains the simulation's zero-order hold (half a sample of
    // delay); the model run gets the same extra delay so that the two describe one system.
    let model_text = tyre.replace(
        "sample_rate_hz = 2000.0",
        "sample_rate_hz = 2000.0\nloop_delay_s = 0.001",
    );
    assert_ne!(model_text, tyre);
    let model_setup = dir.path().join("tyre-model.toml");
    std::fs::write(&model_setup, model_text).unwrap();
    let model = run_analyze(
        &SetUp::read(&model_setup).unwrap(),
        &dir.path().join("out-model"),
    )
    .unwrap()
    .report;
    let (a, b) = (
        measured.mil.gain_margin.unwrap(),
        model.mil.gain_margin.unwrap(),
    );
    eprintln!("gain margin with the identified table {a:.3}, with the model {b:.3}");
    assert!(
        (a - b).abs() < 0.05,
        "measured-table GM {a} vs model GM {b}"
    );
}

/// Without `--segment`, the segment follows the workspace's rule for the shortest record: a
/// 2 s noise record (4000 samples, shorter than the long records' 4096-sample segment) is
/// cut into 256-sample segments and still identified within 1 dB over 10-100 Hz, and a
/// second, longer record does not change the rule's choice.
#[test]
fn the_default_segment_follows_the_shortest_record() {
    let (discrete, cascade) = reference_tracking();
    let dir = tempfile::tempdir().unwrap();
    let mut records = Vec::new();
    for (name, seconds, seed) in [("short.csv", 2.0, 3), ("long.csv", 30.0, 4)] {
        let u = band_limited_noise(0.5, 140.0, seconds, FS, 1000.0, true, seed);
        let y = simulate_cascade(&cascade, &u.iter().map(|v| *v as f32).collect::<Vec<_>>());
        let path = dir.path().join(name);
        write_record(&path, &u, &y);
        records.push(path);
    }
    let identify = |records: Vec<std::path::PathBuf>| {
        run_identify(&IdentifyOptions {
            records,
            input: "force_command".into(),
            output: "force".into(),
            segment_length: None,
            band_hz: (10.0, 100.0),
            min_coherence: 0.9,
            out: dir.path().join("table.csv"),
        })
        .unwrap()
    };
    for set in [records[..1].to_vec(), records.clone()] {
        let (table, summary) = identify(set);
        assert_eq!(summary.segment_length, 256, "{summary:?}");
        for point in table.points() {
            let ratio = point.complex() / discrete.response(point.frequency_hz);
            assert!(
                (20.0 * ratio.norm().log10()).abs() < 1.0,
                "{} Hz: {ratio}",
                point.frequency_hz
            );
        }
    }
}

/// A record too short for the segment asked for is named by its file, not by its index in
/// the estimator ("record 0"), with the option that helps.
#[test]
fn a_record_too_short_is_named_by_its_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("short-sweep.csv");
    let command: Vec<f64> = (0..1000).map(|i| (i as f64 * 0.1).sin()).collect();
    let force: Vec<f32> = command.iter().map(|&u| u as f32).collect();
    write_record(&path, &command, &force);
    let e = run_identify(&IdentifyOptions {
        records: vec![path.clone()],
        input: "force_command".into(),
        output: "force".into(),
        segment_length: Some(4096),
        band_hz: (0.5, 200.0),
        min_coherence: 0.9,
        out: dir.path().join("t.csv"),
    })
    .unwrap_err()
    .to_string();
    assert!(e.starts_with(&path.display().to_string()), "{e}");
    assert!(!e.contains("record 0"), "{e}");
    assert!(e.contains("--segment"), "{e}");
}
