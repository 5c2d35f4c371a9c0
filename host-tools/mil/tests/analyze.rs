//! `mil analyze` on the shipped set-ups reproduces the paper's figures (A. R. Plummer,
//! "Model-in-the-loop testing", 2006) with the reference actuator, and writes its outputs.

use mil::analyze::{run_analyze, AnalyzeOutput};
use mil::setup::SetUp;
use mil_analysis::Stability;
use std::path::{Path, PathBuf};

fn setup(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("examples")
        .join(name)
}

/// `mil analyze` on the set-up file at `path`.
fn analyze_file(path: &Path, out: &Path) -> anyhow::Result<AnalyzeOutput> {
    run_analyze(&SetUp::read(path)?, out)
}

/// Paper section 4: body bounce near 4 Hz captured; a very lightly damped MiL resonance at
/// 17 Hz that the emulated system does not have; open-loop phase lag beyond 180° with gain
/// margin 1.4 (emulated: passive, no phase crossover). Tolerances: gain margin ±0.1, the
/// resonance ±1 Hz with damping ratio below 0.12, the bounce within 5 % of the emulated one.
#[test]
fn tyre_example_reproduces_the_paper() {
    let out = tempfile::tempdir().unwrap();
    let r = analyze_file(&setup("tyre.toml"), out.path())
        .unwrap()
        .report;
    assert_eq!(r.configuration, 4);
    assert_eq!(r.mil_loop.filter, None);
    assert!(
        r.mil_loop.velocity.contains("low-pass 500 Hz"),
        "{}",
        r.mil_loop.velocity
    );
    assert_eq!(r.mil.stability, Stability::Stable);
    assert_eq!(r.emulated.stability, Stability::Stable);
    let gm = r.mil.gain_margin.unwrap();
    assert!((gm - 1.4).abs() < 0.1, "gain margin {gm}");
    let gm_hz = r.mil.gain_margin_hz.unwrap();
    assert!(
        (15.0..22.0).contains(&gm_hz),
        "phase crossover at {gm_hz} Hz"
    );
    assert_eq!(r.emulated.gain_margin, None, "the emulated loop is passive");

    let tyre = &r.responses[0];
    let bounce_emulated = tyre
        .emulated_resonances
        .iter()
        .find(|x| (3.0..5.0).contains(&x.hz))
        .expect("emulated bounce");
    let bounce_mil = tyre
        .mil_resonances
        .iter()
        .find(|x| (3.0..5.0).contains(&x.hz))
        .expect("MiL bounce");
    assert!((bounce_mil.hz / bounce_emulated.hz - 1.0).abs() < 0.05);
    let actuator_mode = tyre
        .mil_resonances
        .iter()
        .find(|x| (16.0..18.0).contains(&x.hz))
        .expect("MiL resonance near 17 Hz");
    assert!(actuator_mode.damping_ratio < 0.12, "{actuator_mode:?}");
    assert!(
        !tyre.emulated_resonances.iter().any(|x| x.hz > 10.0),
        "the emulated system has no resonance above 10 Hz"
    );
    // Good agreement below 5 Hz, strong deviation above 10 Hz.
    let band = |from: f64| {
        tyre.band_errors
            .iter()
            .find(|b| b.from_hz == from)
            .unwrap()
            .max_magnitude_db
    };
    assert!(band(0.5) < 2.0 && band(10.0) > 10.0);
    // Figures a person reads: a resonance's magnitude with its unit to three digits, no
    // five-digit mantissas ("3.3912e2").
    let table = analyze_file(&setup("tyre.toml"), out.path())
        .unwrap()
        .table();
    let peak = format!("{:.0} N/mm", bounce_emulated.magnitude);
    assert!(table.contains(&peak), "{peak}: {table}");
    let long_mantissa = table.split_whitespace().find(|w| {
        let w = w.trim_matches(|c: char| !c.is_ascii_alphanumeric());
        w.split_once('e').is_some_and(|(m, e)| {
            m.split_once('.').is_some_and(|(_, d)| d.len() > 2) && e.parse::<i32>().is_ok()
        })
    });
    assert_eq!(long_mantissa, None, "{table}");
    for f in [
        "responses.svg",
        "open-loop.svg",
        "noise-sensitivity.svg",
        "responses.csv",
    ] {
        assert!(out.path().join(f).exists(), "{f}");
    }
}

/// Paper section 3: the vertical response of the MiL system matches the emulated one well,
/// pitch less well, but the pitch resonance near 8 Hz appears in both.
#[test]
fn aero_example_captures_the_pitch_resonance() {
    let out = tempfile::tempdir().unwrap();
    let r = analyze_file(&setup("aero.toml"), out.path())
        .unwrap()
        .report;
    assert_eq!(r.channels, 2);
    assert_eq!(r.mil.stability, Stability::Stable);
    let vertical = &r.responses[0];
    let pitch = &r.responses[1];
    for list in [&pitch.mil_resonances, &pitch.emulated_resonances] {
        assert!(
            list.iter().any(|x| (7.0..9.5).contains(&x.hz)),
            "pitch resonance near 8 Hz: {list:?}"
        );
    }
    let worst = |resp: &mil_analysis::analyze::ResponseFigures| {
        resp.band_errors
            .iter()
            .map(|b| b.max_magnitude_db)
            .fold(0.0, f64::max)
    };
    assert!(
        worst(vertical) < 1.5,
        "vertical within 1.5 dB: {}",
        worst(vertical)
    );
}

/// The 2-DOF example with the reference (tyre-rig) actuator is unstable in MiL (two modes at
/// 10 and 13 Hz right where the actuator lags): the analysis must say so rather than show a
/// response.
#[test]
fn two_dof_example_with_the_hub_actuator_is_reported_unstable() {
    let out = tempfile::tempdir().unwrap();
    let r = analyze_file(&setup("two-dof-hub-actuator.toml"), out.path()).unwrap();
    assert_eq!(r.report.mil.stability, Stability::Unstable(2));
    assert_eq!(r.report.emulated.stability, Stability::Stable);
    assert!(r.table().contains("WARNING"));
    let json = serde_json::to_value(r.summary()).unwrap();
    assert_eq!(json["stability"]["unstable"], 2);
    assert!(json["gain_margin"].as_f64().unwrap() < 1.0);
    // The plots say so too; responses in dB with their unit; the control sensitivity (a
    // magnitude) without a phase panel.
    let svg = |name: &str| std::fs::read_to_string(out.path().join(name)).unwrap();
    for name in ["responses.svg", "open-loop.svg"] {
        assert!(
            svg(name).contains("MiL loop UNSTABLE: 2 closed-loop pole(s)"),
            "{name}"
        );
    }
    assert!(svg("responses.svg").contains("dB re 1 "));
    assert!(!svg("noise-sensitivity.svg").contains("phase [deg]"));
}

/// The JSON summary carries the fields the issue names, for MiL and emulated.
#[test]
fn json_summary_has_the_documented_fields() {
    let out = tempfile::tempdir().unwrap();
    let r = analyze_file(&setup("tyre.toml"), out.path()).unwrap();
    let json = serde_json::to_value(r.summary()).unwrap();
    for key in [
        "gain_margin",
        "gain_margin_hz",
        "phase_margin_deg",
        "phase_margin_hz",
    ] {
        assert!(json[key].is_number(), "{key}");
        assert!(json["emulated"].get(key).is_some(), "emulated {key}");
    }
    let res = json["resonances"].as_array().unwrap();
    assert!(res.iter().all(|x| x["hz"].is_number()
        && x["magnitude"].is_number()
        && x["damping_ratio"].is_number()));
    assert!(json["emulated"]["resonances"].is_array());
}

/// A set-up with a mistake is refused with the field named.
#[test]
fn bad_setups_name_the_problem() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(setup("tyre.toml")).unwrap();
    std::fs::copy(
        setup("tyre-physical.toml"),
        dir.path().join("tyre-physical.toml"),
    )
    .unwrap();
    let cases = [
        (
            text.replace("output = \"interface_force\"", "output = \"physical:x_q\""),
            "x_q",
        ),
        (
            text.replace("configuration = 4", "configuration = 3"),
            "configuration",
        ),
        (
            text.replace("control = \"force\"", "control = \"torque\""),
            "torque",
        ),
        (
            text.replace("sample_rate_hz = 2000.0", "sample_rate_hz = -1.0"),
            "sample_rate_hz",
        ),
    ];
    for (body, needle) in cases {
        assert_ne!(body, text, "{needle}: the edit applies to tyre.toml");
        let path = dir.path().join("bad.toml");
        std::fs::write(&path, body).unwrap();
        let e = match analyze_file(&path, dir.path()) {
            Ok(_) => panic!("{needle}: accepted"),
            Err(e) => format!("{e:#}"),
        };
        assert!(e.contains(needle), "{needle}: {e}");
    }
}

/// The 2-DOF set-up on the hub actuator (its numerical and physical parts structure files)
/// describes the same system as the analysis library's built-in 2-DOF example
/// (`TwoDofExample` defaults) on the reference actuator with the set-up's loop delay
/// (1.5 samples at 2 kHz): identical MiL and emulated responses to 1e-12 relative.
#[test]
fn custom_two_dof_equals_the_built_in_example() {
    use mil_analysis::examples::{force_actuators, two_dof_structure};
    use mil_analysis::Loop;
    use mil_params::{ServoHydraulicActuator, TwoDofExample};
    let a = SetUp::read(&setup("two-dof-hub-actuator.toml"))
        .unwrap()
        .analysis()
        .unwrap()
        .system;
    let b = two_dof_structure(&TwoDofExample::default())
        .unwrap()
        .with_actuators(force_actuators(&ServoHydraulicActuator::REFERENCE, 1.5 / 2000.0).unwrap());
    assert_eq!((a.configuration(), b.configuration()), (4, 4));
    assert!(a.filter.is_none());
    for f in [1.0, 10.07, 13.3, 50.0] {
        for which in [Loop::Mil, Loop::Emulated] {
            let (pa, pb) = (a.point(f, which).unwrap(), b.point(f, which).unwrap());
            assert_eq!(pa.physical.shape(), pb.physical.shape(), "{f} Hz");
            let d = (&pa.physical - &pb.physical).norm() / pb.physical.norm();
            assert!(d < 1e-12, "{f} Hz: {d}");
        }
    }
}

/// A structure file is a set-up's physical part: the 2-DOF set-up on the small actuator
/// (without its command filter), whose `[physical] structure = "two-dof-physical.toml"` is
/// what `mil sim` runs on the rig (and what `mil diagnose` reads and writes), gives the same
/// analysis as the part's matrices written out in code (`TwoDofExample`'s, its post input
/// `z_p` left out: the mass stands on the rig's bed), to rounding; and a structure with a
/// hidden cubic spring analyses as its linear part.
#[test]
fn a_structure_file_is_the_physical_part() {
    use mil_analysis::analyze::analyze;
    use mil_analysis::examples::two_dof_structure;
    use mil_params::TwoDofExample;
    let mut shipped = SetUp::read(&setup("two-dof.toml")).unwrap();
    assert_eq!(
        shipped.physical.structure.as_deref(),
        Some(Path::new("two-dof-physical.toml"))
    );
    assert!(shipped.controller.filter.is_some());
    shipped.controller.filter = None;
    let out = tempfile::tempdir().unwrap();
    let a = run_analyze(&shipped, out.path()).unwrap();
    // The same parts as matrices: x_n (m_n, c_n, k_n to z_n), x_p (m_p, c_p, k_p to the bed),
    // B_i numerical; the set-up's own actuator and analysis options.
    let mut structure = two_dof_structure(&TwoDofExample::default()).unwrap();
    assert_eq!(structure.inputs[1].name, "z_p");
    structure.inputs.truncate(1);
    let matrices = structure.with_actuators(a.setup.system.actuators.clone());
    let b = analyze(&matrices, &a.setup.options).unwrap();
    // The physical part with a hidden cubic spring, in a folder of its own.
    let linear = std::fs::read_to_string(setup("two-dof-physical.toml")).unwrap();
    let cubic = out.path().join("cubic.toml");
    std::fs::write(
        &cubic,
        linear + "\n[[effect]]\neffect = \"cubic_stiffness\"\nelement = \"k_p, c_p to the bed\"\nparameters = { stiffness_n_per_m3 = 1e9 }\n",
    )
    .unwrap();
    let mut with_cubic = shipped.clone();
    with_cubic.physical.structure = Some(cubic);
    let c = run_analyze(&with_cubic, out.path()).unwrap().report;
    let (ja, jb) = (
        serde_json::to_value(&a.report).unwrap(),
        serde_json::to_value(&b).unwrap(),
    );
    fn same(a: &serde_json::Value, b: &serde_json::Value, at: &str) {
        use serde_json::Value::*;
        match (a, b) {
            (Number(x), Number(y)) => {
                let (x, y) = (x.as_f64().unwrap(), y.as_f64().unwrap());
                assert!((x - y).abs() <= 1e-9 * x.abs().max(1.0), "{at}: {x} vs {y}");
            }
            (Array(x), Array(y)) => {
                assert_eq!(x.len(), y.len(), "{at}");
                for (i, (x, y)) in x.iter().zip(y).enumerate() {
                    same(x, y, &format!("{at}[{i}]"));
                }
            }
            (Object(x), Object(y)) => {
                for (k, v) in x {
                    if k == "name" || k == "setup" {
                        continue;
                    }
                    same(v, &y[k], &format!("{at}.{k}"));
                }
            }
            (x, y) => assert_eq!(x, y, "{at}"),
        }
    }
    same(&ja, &jb, "report");
    same(
        &ja,
        &serde_json::to_value(&c).unwrap(),
        "report with the cubic spring",
    );
    assert!(ja.to_string().len() > 1000, "a report with figures");
}

/// `mil analyze` takes its set-up as `mil sim` and `mil run` do: without one, the built-in
/// tyre example (the one the main job runs), the same as its shipped file.
#[test]
fn without_a_set_up_the_built_in_example_is_analysed() {
    let dir = tempfile::tempdir().unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_mil"))
        .args(["analyze", "--json", "--out", "out"])
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let shipped = analyze_file(&setup("tyre.toml"), &dir.path().join("shipped")).unwrap();
    let shipped = serde_json::to_value(shipped.summary()).unwrap();
    assert_eq!(json["name"], "tyre");
    assert_eq!(json["gain_margin"], shipped["gain_margin"]);
}
