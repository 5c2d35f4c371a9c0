//! The engineer's path from a measured actuator to a command filter: `mil actuator-test` on
//! the simulated rig (the nonlinear actuator, integrated in time, with the load cell's
//! noise) -> `mil identify` -> `mil analyze` and `mil design-filter` on a set-up whose
//! tracking response is the identified table, at 1, 2 and 5 kHz sampling, with a sweep,
//! with noise, and with a coherence gap (a two-band excitation made here, independently of
//! `mil actuator-test`).
//!
//! The yardstick is independent of the identification: the analysis of the same set-up
//! with the reference actuator's linear model (`reference_actuator.rs`, derived from the
//! physics), its loop delay increased by the half sample of the zero-order hold that a
//! sampled test contains. The figures: stability decided and equal, gain margin within
//! 5 %, phase margin within 3°, the fitted bandwidth and equivalent delay within 10 % of
//! the model's, and the filter designed from the table as good as the one designed from
//! the model.
//!
//! Seeds 1 (the tools' default, used while building the extension) are the development
//! set; the noise seeds in `HELD_OUT` were run only once the method was fixed, and are
//! reported apart.

use mil::actuator_test::{Args, Signal};
use mil::analyze::run_analyze;
use mil::design_filter::{run_design_filter, DesignRequest, Method};
use mil::identify::{run_identify, IdentifyOptions};
use mil::setup::SetUp;
use mil_analysis::{LinearActuator, Stability};
use mil_params::ServoHydraulicActuator;
use mil_rig::actuator::{ActuatorEffects, ForceActuator};
use mil_rig::actuator_test::BlockedRodTest;
use std::f64::consts::TAU;
use std::io::Write;
use std::path::{Path, PathBuf};

mod common;

const HELD_OUT: [u64; 2] = [907, 4441];

/// The tyre example with its tracking response from `table` and the rate `fs`, in `dir`;
/// `loop_delay_s` overrides the set-up's loop delay.
fn tyre_setup(
    dir: &Path,
    name: &str,
    fs: f64,
    table: Option<&Path>,
    loop_delay_s: Option<f64>,
) -> PathBuf {
    let examples = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples");
    let text = std::fs::read_to_string(examples.join("tyre.toml")).unwrap();
    for edit in ["control = \"force\"", "sample_rate_hz = 2000.0"] {
        assert_eq!(text.matches(edit).count(), 1, "tyre.toml: {edit}");
    }
    let mut controller = format!("sample_rate_hz = {fs:.1}");
    if let Some(d) = loop_delay_s {
        controller.push_str(&format!("\nloop_delay_s = {d}"));
    }
    let mut text = text.replace("sample_rate_hz = 2000.0", &controller);
    if let Some(t) = table {
        text = text.replace(
            "control = \"force\"",
            &format!(
                "control = \"force\"\ntracking = {{ table = {:?} }}",
                t.display().to_string()
            ),
        );
    }
    std::fs::copy(
        examples.join("tyre-physical.toml"),
        dir.join("tyre-physical.toml"),
    )
    .unwrap();
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

/// The −3 dB bandwidth (Hz) of the reference actuator's tracking response, from its
/// rational function, and its phase lag there as a delay (s), with the half sample of a
/// zero-order hold at `fs`.
fn reference_figures(fs: f64) -> (f64, f64) {
    let p = ServoHydraulicActuator::REFERENCE.tracking().unwrap();
    let g0 = p.response(1e-3).norm();
    let mut f = 1.0;
    while p.response(f).norm() > g0 / 2f64.sqrt() {
        f *= 1.001;
    }
    let mut phase = p.response(f).arg();
    if phase > 0.0 {
        phase -= TAU;
    }
    (f, -phase / (TAU * f) + 0.5 / fs)
}

struct Figures {
    gain_margin: f64,
    phase_margin: f64,
    bandwidth: f64,
    delay: f64,
    lag_reduction: f64,
}

/// identify -> analyze -> design-filter on `records` at `fs`; the figures, checked against
/// the model's.
fn path(dir: &Path, fs: f64, records: Vec<PathBuf>, label: &str) -> Figures {
    let table = dir.join(format!("{label}.csv"));
    let (identified, _) = run_identify(&IdentifyOptions {
        records,
        input: "force_command".into(),
        output: "force".into(),
        segment_length: None,
        band_hz: (0.5, 0.4 * fs),
        min_coherence: 0.9,
        out: table.clone(),
    })
    .unwrap();
    let setup = tyre_setup(dir, &format!("{label}.toml"), fs, Some(&table), None);
    let setup = SetUp::read(&setup).unwrap();
    let measured = run_analyze(&setup, &dir.join(format!("{label}-analyze"))).unwrap();
    let model_setup = tyre_setup(
        dir,
        &format!("{label}-model.toml"),
        fs,
        None,
        Some(2.0 / fs),
    );
    let model_setup = SetUp::read(&model_setup).unwrap();
    let model = run_analyze(&model_setup, &dir.join(format!("{label}-model-analyze"))).unwrap();
    let (a, b) = (&measured.report.mil, &model.report.mil);
    assert_eq!(a.stability, b.stability, "{label}: stability");
    assert_ne!(a.stability, Stability::Unknown, "{label}");
    let (bandwidth_hz, delay_s) = match &measured.setup.system.actuators.tracking {
        mil_analysis::ResponseSource::Measured(m) => m.bandwidth(),
        other => panic!("{label}: tracking {other:?}"),
    };
    let design = |s: &SetUp, name: &str| {
        run_design_filter(
            s,
            &DesignRequest {
                method: Method::Ls,
                out: dir.join(name),
                structure: None,
                weights: None,
            },
            |_, _| {},
        )
        .unwrap()
        .summary
    };
    let with_table = design(&setup, &format!("{label}-filter.json"));
    let with_model = design(&model_setup, &format!("{label}-model-filter.json"));
    assert_eq!(
        with_table.stability_with_filter,
        Stability::Stable,
        "{label}"
    );
    let figures = Figures {
        gain_margin: a.gain_margin.unwrap() / b.gain_margin.unwrap(),
        phase_margin: a.phase_margin_deg.unwrap() - b.phase_margin_deg.unwrap(),
        bandwidth: bandwidth_hz,
        delay: delay_s,
        lag_reduction: with_table.phase_lag_reduction_pct - with_model.phase_lag_reduction_pct,
    };
    let (bandwidth, delay) = reference_figures(fs);
    eprintln!(
        "{label}: {} points {:.2}-{:.1} Hz; gain margin {:.3} vs model {:.3}, phase margin \
         {:+.2} deg; bandwidth {:.1} Hz (model {bandwidth:.1}), equivalent delay {:.2} ms \
         (model {:.2}); phase-lag reduction {:.1} % ({:+.1} vs the model's filter)",
        identified.points().len(),
        identified.frequency_range().0,
        identified.frequency_range().1,
        a.gain_margin.unwrap(),
        b.gain_margin.unwrap(),
        figures.phase_margin,
        figures.bandwidth,
        figures.delay * 1e3,
        delay * 1e3,
        with_table.phase_lag_reduction_pct,
        figures.lag_reduction
    );
    assert!(
        (figures.gain_margin - 1.0).abs() < 0.05,
        "{label}: gain margin ratio {}",
        figures.gain_margin
    );
    assert!(
        figures.phase_margin.abs() < 3.0,
        "{label}: phase margin {}",
        figures.phase_margin
    );
    assert!(
        (figures.bandwidth / bandwidth - 1.0).abs() < 0.1,
        "{label}: bandwidth {}",
        figures.bandwidth
    );
    assert!(
        (figures.delay / delay - 1.0).abs() < 0.1,
        "{label}: delay {}",
        figures.delay
    );
    // As good as the model's, within 3 points of phase-lag reduction either way.
    assert!(
        figures.lag_reduction.abs() < 3.0,
        "{label}: lag reduction {}",
        figures.lag_reduction
    );
    figures
}

fn actuator_test(dir: &Path, fs: f64, signal: Signal, seed: u64) -> PathBuf {
    let out = dir.join(format!("{signal:?}-{fs}-{seed}.csv"));
    mil::actuator_test::run(&Args {
        setup: None,
        signal,
        band: None,
        amplitude: None,
        offset: None,
        duration: 60.0,
        rate: Some(fs),
        seed,
        out: Some(out.clone()),
        json: true,
    })
    .unwrap();
    out
}

#[test]
fn sweep_and_noise_records_at_1_2_and_5_khz_give_the_models_figures() {
    let dir = tempfile::tempdir().unwrap();
    for fs in [1000.0, 2000.0, 5000.0] {
        let sweep = actuator_test(dir.path(), fs, Signal::Sweep, 1);
        path(dir.path(), fs, vec![sweep.clone()], &format!("sweep-{fs}"));
        let noise = actuator_test(dir.path(), fs, Signal::Noise, 1);
        path(
            dir.path(),
            fs,
            vec![sweep, noise],
            &format!("sweep+noise-{fs}"),
        );
    }
}

#[test]
fn held_out_noise_seeds_give_the_models_figures() {
    let dir = tempfile::tempdir().unwrap();
    for (fs, seed) in [
        (2000.0, HELD_OUT[0]),
        (5000.0, HELD_OUT[1]),
        (1000.0, HELD_OUT[1]),
    ] {
        let noise = actuator_test(dir.path(), fs, Signal::Noise, seed);
        path(
            dir.path(),
            fs,
            vec![noise],
            &format!("held-out-noise-{fs}-{seed}"),
        );
    }
}

/// A two-band noise command (0.5-20 Hz and 60 Hz up, nothing between), through the blocked actuator with a noisy load cell: the
/// table has a coherence gap over the unexcited band.
#[test]
fn a_table_with_a_coherence_gap_gives_the_models_figures() {
    let dir = tempfile::tempdir().unwrap();
    for fs in [1000.0, 2000.0, 5000.0] {
        // Two bands of white noise from independent seeds, summed.
        let low = mil_identify::band_limited_noise(0.5, 20.0, 60.0, fs, 300.0, false, 5);
        let high = mil_identify::band_limited_noise(60.0, 0.4 * fs, 60.0, fs, 300.0, false, 6);
        let command: Vec<f64> = low.iter().zip(&high).map(|(a, b)| 1667.7 + a + b).collect();
        let test = BlockedRodTest {
            actuator: ForceActuator::new(
                ServoHydraulicActuator::REFERENCE,
                ActuatorEffects::default(),
            )
            .unwrap(),
            load_cell: mil_rig::sensors::SensorSpec {
                noise_rms: 20.0,
                ..Default::default()
            },
            sample_rate_hz: fs,
            internal_step_s: 50e-6_f64.min(1.0 / fs),
            seed: 3,
        };
        let force = test.run(&command, |_| {}).unwrap();
        let record = dir.path().join(format!("gap-{fs}.csv"));
        let mut w = std::io::BufWriter::new(std::fs::File::create(&record).unwrap());
        writeln!(w, "time,force_command,force").unwrap();
        for (i, (u, y)) in command.iter().zip(&force).enumerate() {
            writeln!(w, "{},{u},{y}", i as f64 / fs).unwrap();
        }
        drop(w);
        let label = format!("gap-{fs}");
        path(dir.path(), fs, vec![record], &label);
        let table =
            mil_identify::FrfTable::read_csv(&dir.path().join(format!("{label}.csv"))).unwrap();
        let in_gap = table
            .points()
            .iter()
            .filter(|p| (25.0..55.0).contains(&p.frequency_hz))
            .count();
        let excited = table
            .points()
            .iter()
            .filter(|p| (65.0..95.0).contains(&p.frequency_hz))
            .count();
        assert!(
            in_gap * 4 < excited,
            "{label}: {in_gap} points in the gap, {excited} beside it"
        );
    }
}

/// A table that stops below the actuator's bandwidth cannot be extended: the analysis
/// refuses it, naming the band it needs and the commands that measure it; so does one whose
/// lowest frequency is above a tenth of the bandwidth.
#[test]
fn a_table_short_of_the_bandwidth_is_refused_with_the_band_it_needs() {
    let dir = tempfile::tempdir().unwrap();
    let record = actuator_test(dir.path(), 2000.0, Signal::Sweep, 1);
    for (band, expected) in [
        (
            (0.5, 25.0),
            [
                "below its low-frequency gain",
                "--band 0.5:100",
                "mil actuator-test",
            ],
        ),
        (
            (8.0, 300.0),
            ["starts at", "static gain is not measured", "--band"],
        ),
    ] {
        let table = dir.path().join(format!("short-{}.csv", band.1));
        run_identify(&IdentifyOptions {
            records: vec![record.clone()],
            input: "force_command".into(),
            output: "force".into(),
            segment_length: None,
            band_hz: band,
            min_coherence: 0.9,
            out: table.clone(),
        })
        .unwrap();
        let setup = tyre_setup(dir.path(), "short.toml", 2000.0, Some(&table), None);
        let err = run_analyze(&SetUp::read(&setup).unwrap(), &dir.path().join("out"))
            .err()
            .map(|e| format!("{e:#}"))
            .unwrap_or_default();
        for part in expected {
            assert!(err.contains(part), "{band:?}: {part:?} not in {err:?}");
        }
    }
}

/// The two commands as the tutorial gives them: `mil actuator-test` then `mil identify`,
/// whose output names the actuator's bandwidth and delay and the files; a test command
/// beyond the actuator's force capacity (a force in kN given in N) is refused naming it.
#[test]
fn the_commands_print_the_next_step_and_the_actuators_figures() {
    let dir = tempfile::tempdir().unwrap();
    let mil = |args: &[&str]| common::mil_in(dir.path(), args);
    let (code, stdout, stderr) = mil(&["actuator-test", "--duration", "30"]);
    assert_eq!(code, Some(0), "{stderr}");
    assert!(stdout.contains("wrote out/actuator/sweep.csv"), "{stdout}");
    let next = stdout
        .lines()
        .find_map(|l| l.strip_prefix("next: mil "))
        .unwrap_or_else(|| panic!("{stdout}"));
    let args: Vec<&str> = next.split_whitespace().collect();
    let (code, stdout, stderr) = mil(&args);
    assert_eq!(code, Some(0), "{stderr}");
    assert!(stdout.contains("bandwidth (-3 dB)"), "{stdout}");
    assert!(stdout.contains("equivalent delay"), "{stdout}");
    for file in [
        "out/actuator-frf.csv",
        "out/actuator-frf.svg",
        "out/actuator-frf-coherence.svg",
    ] {
        assert!(dir.path().join(file).is_file(), "{file}: {stdout}");
    }
    let (code, _, stderr) = mil(&["actuator-test", "--amplitude", "30000"]);
    assert_eq!(code, Some(1));
    assert!(
        stderr.contains("--amplitude 30000 N") && stderr.contains("capacity"),
        "{stderr}"
    );
}
