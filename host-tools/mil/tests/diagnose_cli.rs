//! `mil diagnose` run as a program: the JSON object on synthetic oscillator data, the named
//! effect on a shipped measured record, the files it writes, and clear errors.

use mil_diagnose::simulate::{prepare_inputs, simulate};
use mil_diagnose::{Model, Record};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn diagnose_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../diagnose")
}

fn mil(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_mil"))
        .args(args)
        .output()
        .expect("run mil")
}

fn text(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

/// The shipped oscillator with a hidden cubic hardening spring (the model as given is the
/// linear example), driven by band-limited noise, displacement noise added: 10 s at 1 kHz.
fn oscillator_record(path: &Path) {
    let linear = std::fs::read_to_string(diagnose_dir().join("examples/oscillator.toml")).unwrap();
    let truth = Model::from_toml(&format!(
        "{linear}\n[[effect]]\neffect = \"cubic_stiffness\"\nelement = \"spring\"\nparameters = {{ stiffness_n_per_m3 = 2.0e9 }}\n"
    ))
    .unwrap();
    let fs = 1000.0;
    let force = mil_identify::band_limited_noise(0.5, 60.0, 10.0, fs, 20.0, false, 11);
    let time: Vec<f64> = (0..force.len()).map(|i| i as f64 / fs).collect();
    let zeros = vec![0.0; force.len()];
    let rec = Record::new(
        &time,
        vec!["force".into(), "x".into()],
        vec![force.clone(), zeros],
    )
    .unwrap();
    let inputs = prepare_inputs(&truth, &rec).unwrap();
    let sim = simulate(&truth, &rec, &inputs, 0..rec.len(), None).unwrap();
    // Deterministic small measurement noise (about 1 % of the displacement's spread).
    let sd = mil_diagnose::signal::std(&sim.outputs[0]);
    let mut state = 0x2545_f491_4f6c_dd1d_u64;
    let x: Vec<f64> = sim.outputs[0]
        .iter()
        .map(|v| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            let u = (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
            v + 0.02 * sd * u
        })
        .collect();
    Record::new(&time, vec!["force".into(), "x".into()], vec![force, x])
        .unwrap()
        .write(path)
        .unwrap();
}

#[test]
fn json_on_synthetic_oscillator_data_has_the_issue_keys() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("osc.csv");
    oscillator_record(&data);
    let out = dir.path().join("out");
    let model = diagnose_dir().join("examples/oscillator.toml");
    let run = mil(&[
        "diagnose",
        "--model",
        text(&model),
        "--data",
        text(&data),
        "--out",
        text(&out),
        "--json",
    ]);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{stderr}");
    let stdout = String::from_utf8(run.stdout).unwrap();
    // Exactly one JSON object on stdout.
    let v: serde_json::Value = serde_json::from_str(stdout.trim()).expect(&stdout);
    assert_eq!(stdout.trim().lines().count(), 1, "{stdout}");
    let obj = v.as_object().unwrap();
    let mut keys: Vec<&str> = obj.keys().map(String::as_str).collect();
    keys.sort_unstable();
    assert_eq!(
        keys,
        [
            "gap_after",
            "gap_before",
            "named_effects",
            "recalibrated",
            "updated_model"
        ]
    );
    let effects = v["named_effects"].as_array().unwrap();
    for e in effects {
        assert!(e["effect"].is_string() && e["element"].is_string(), "{e}");
        assert!(e["parameters"]
            .as_object()
            .unwrap()
            .values()
            .all(|p| p.is_number()));
    }
    assert!(v["recalibrated"]
        .as_object()
        .unwrap()
        .values()
        .all(|p| p.is_number()));
    let (before, after) = (
        v["gap_before"]["nrmse"].as_f64().unwrap(),
        v["gap_after"]["nrmse"].as_f64().unwrap(),
    );
    assert!(after < before, "{before} -> {after}");
    // The hidden effect is the one named first.
    assert_eq!(
        effects.first().map(|e| &e["effect"]),
        Some(&"cubic_stiffness".into()),
        "{stdout}"
    );
    // The files: the updated model (a valid model file with the effect), the report, plots.
    let updated = PathBuf::from(v["updated_model"].as_str().unwrap());
    let m = Model::read(&updated).unwrap();
    assert!(m.elements[0].law.k3.is_some());
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(report["named_effects"], v["named_effects"]);
    for plot in [
        "residual.svg",
        "restoring_force_x.svg",
        "restoring_force_v.svg",
        "frf.svg",
        "coherence.svg",
    ] {
        let svg = std::fs::read_to_string(out.join(plot)).unwrap();
        assert!(svg.contains("<svg"), "{plot}");
    }
}

/// EMPS (measured, a free mass in closed loop): Coulomb friction on the guide, of about
/// 20 N as published. The first 12 s of the record keep the test short.
#[test]
fn emps_record_names_coulomb_friction() {
    let dir = tempfile::tempdir().unwrap();
    let full = Record::read(&diagnose_dir().join("data/emps_estimation.csv")).unwrap();
    let data = dir.path().join("emps.csv");
    full.slice(0..full.len().min(12_000)).write(&data).unwrap();
    let out = dir.path().join("out");
    let model = diagnose_dir().join("examples/emps.toml");
    let run = mil(&[
        "diagnose",
        "--model",
        text(&model),
        "--data",
        text(&data),
        "--out",
        text(&out),
    ]);
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    println!("{stdout}");
    assert!(
        stdout.contains("named: coulomb_friction on \"guide\""),
        "{stdout}"
    );
    assert!(
        stdout.contains("gap (NRMSE, validation blocks):"),
        "{stdout}"
    );
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    let fc = report["named_effects"][0]["parameters"]["force_n"]
        .as_f64()
        .unwrap();
    assert!((10.0..30.0).contains(&fc), "F_c {fc}");
    assert!(out.join("updated.toml").is_file());
    assert!(out.join("restoring_force_v.svg").is_file());
}

/// Silverbox (measured, an electronic mass-spring-damper with a hardening spring): the JSON
/// names `cubic_stiffness` with a positive coefficient and the gap shrinks several-fold.
#[test]
fn silverbox_record_names_cubic_hardening() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let model = diagnose_dir().join("examples/silverbox.toml");
    let data = diagnose_dir().join("data/silverbox_multisine.csv");
    let run = mil(&[
        "diagnose",
        "--model",
        text(&model),
        "--data",
        text(&data),
        "--out",
        text(&out),
        "--json",
    ]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&run.stdout).unwrap();
    println!("{v}");
    let first = &v["named_effects"][0];
    assert_eq!(first["effect"], "cubic_stiffness", "{v}");
    assert_eq!(first["element"], "spring", "{v}");
    assert!(first["parameters"]["stiffness_n_per_m3"].as_f64().unwrap() > 0.0);
    let (before, after) = (
        v["gap_before"]["nrmse"].as_f64().unwrap(),
        v["gap_after"]["nrmse"].as_f64().unwrap(),
    );
    assert!(after < before / 3.0, "{before} -> {after}");
    assert!(out.join("frf.svg").is_file());
}

#[test]
fn clear_errors_and_non_zero_exit() {
    let dir = tempfile::tempdir().unwrap();
    let model = diagnose_dir().join("examples/oscillator.toml");
    let missing = dir.path().join("missing.csv");
    let run = mil(&[
        "diagnose",
        "--model",
        text(&model),
        "--data",
        text(&missing),
    ]);
    assert!(!run.status.success());
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(err.contains("missing.csv"), "{err}");
    assert!(run.stdout.is_empty());

    let bad = dir.path().join("bad.toml");
    std::fs::write(&bad, "name = \"x\"\n[[dof]]\nname = \"x\"\nmass = -1.0\n").unwrap();
    let data = diagnose_dir().join("data/silverbox_multisine.csv");
    let run = mil(&["diagnose", "--model", text(&bad), "--data", text(&data)]);
    assert!(!run.status.success());
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(err.contains("model"), "{err}");

    // The oscillator names columns `force` and `x`; the Silverbox record has `u` and `y`.
    let run = mil(&["diagnose", "--model", text(&model), "--data", text(&data)]);
    assert!(!run.status.success());
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(
        err.contains("does not fit the model") && err.contains("\"force\""),
        "{err}"
    );
}

#[path = "../../diagnose/tests/common/quarter_car.rs"]
mod quarter_car;

/// `--tyre`: the quarter car diagnosed from 40 s of the simulated rig (tyre lift-off and an
/// asymmetric damper hidden) gives model-core's real-time tyre, and the `[tyre]` table it
/// writes makes the tyre example's `mil sim` configuration a valid run with the diagnosed
/// tyre.
#[test]
fn the_diagnosed_tyre_goes_into_a_sim_configuration() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("quarter_car.csv");
    quarter_car::quarter_car_record(&quarter_car::track_road(40.0, 5), 5)
        .write(&csv)
        .unwrap();
    let out = dir.path().join("out");
    let model = diagnose_dir().join("examples/quarter-car.toml");
    let o = mil(&[
        "diagnose",
        "--model",
        text(&model),
        "--data",
        text(&csv),
        "--out",
        text(&out),
        "--tyre",
        "tyre",
    ]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(stdout.contains("tyre (model-core):"), "{stdout}");
    let tyre = std::fs::read_to_string(out.join("numerical-tyre.toml")).unwrap();
    println!("{tyre}");
    let table: toml::Table = toml::from_str(&tyre).unwrap();
    let t = &table["numerical"]["tyre"];
    let num = |k: &str| t[k].as_float().unwrap();
    let weight = (quarter_car::M_S + quarter_car::M_U) * 9.81;
    assert!((num("static_load_n") - weight).abs() < 0.01 * weight);
    assert!((num("stiffness_n_per_m") - quarter_car::K_T).abs() < 0.03 * quarter_car::K_T);
    assert_eq!(t["lift_off"].as_bool(), Some(true));
    // The tyre example's set-up with its [numerical.tyre] table replaced.
    let examples = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("examples");
    let example = std::fs::read_to_string(examples.join("tyre.toml")).unwrap();
    let (head, rest) = example.split_once("[numerical.tyre]").unwrap();
    let (_, tail) = rest.split_once("[physical]").unwrap();
    let set_up = format!("{head}{tyre}\n[physical]{tail}");
    let c = mil::setup::SetUp::from_toml(&set_up, &examples)
        .unwrap()
        .run()
        .unwrap();
    c.validate_sim().unwrap();
    assert_eq!(c.tyre.as_ref().map(|t| t.lift_off), Some(true));
}

/// A `--tyre` element the updated model does not have: the diagnosis is still printed and
/// written, the refusal follows it, and the exit status says it failed.
#[test]
fn a_tyre_that_cannot_be_exported_does_not_hide_the_diagnosis() {
    let dir = tempfile::tempdir().unwrap();
    let model = diagnose_dir().join("examples/silverbox.toml");
    let data = diagnose_dir().join("data/silverbox_multisine.csv");
    let out = dir.path().join("out");
    let o = Command::new(env!("CARGO_BIN_EXE_mil"))
        .args(["diagnose", "--model", text(&model), "--data", text(&data)])
        .args(["--out", text(&out), "--tyre", "no_such_element"])
        .output()
        .expect("run mil");
    let stdout = String::from_utf8_lossy(&o.stdout);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{stdout}{stderr}");
    assert!(stdout.contains("named effect(s):"), "{stdout}");
    assert!(out.join("updated.toml").is_file());
    assert!(stderr.starts_with("Error: --tyre: "), "{stderr}");
    assert!(stderr.contains("no_such_element"), "{stderr}");
    assert!(!out.join("numerical-tyre.toml").exists());
}

#[test]
fn a_bad_model_file_is_one_clear_line_without_a_backtrace() {
    let dir = std::env::temp_dir().join(format!("mil-diagnose-bad-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let model = dir.join("bad.toml");
    std::fs::write(&model, "name = \"x\"\n[[dof]]\nname = \"a\"\nmass = -1\n").unwrap();
    let data = diagnose_dir().join("data/silverbox_multisine.csv");
    let out = Command::new(env!("CARGO_BIN_EXE_mil"))
        .args(["diagnose", "--model", text(&model), "--data", text(&data)])
        .args(["--out", text(&dir.join("out"))])
        .env("RUST_BACKTRACE", "1")
        .output()
        .expect("run mil");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert_eq!(err.matches("model:").count(), 1, "{err}");
    assert!(
        err.contains("bad.toml") && err.contains("mass must be > 0"),
        "{err}"
    );
    std::fs::remove_dir_all(&dir).ok();
}
