//! Real measured records (nonlinearbenchmark.org, see `host-tools/diagnose/data/README.md`):
//! records the diagnosis' simulator did not make.

use mil_diagnose::simulate::{prepare_inputs, simulate};
use mil_diagnose::{diagnose, EffectKind, Model, Options, Record};
use std::path::PathBuf;

/// `rel` in the diagnosis crate's folder (its example models and benchmark records).
fn path(rel: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../host-tools/diagnose")
        .join(rel)
}

fn options() -> Options {
    Options {
        progress: std::env::var_os("DIAGNOSE_PROGRESS").is_some(),
        ..Options::default()
    }
}

/// Asserts README.md's paragraph on the real records (the one naming the Silverbox, EMPS
/// and Bouc-Wen results) states `figure` (as formatted).
fn in_readme(figure: String) {
    mil_integration_tests::readme::assert_paragraph_states(
        "On the Silverbox record",
        "It writes `updated.toml`",
        &figure,
    );
}

fn names(d: &mil_diagnose::Diagnosis) -> Vec<EffectKind> {
    d.named.iter().map(|n| n.named.effect).collect()
}

#[test]
fn emps_coulomb_friction_of_about_20_n() {
    let model = Model::read(&path("examples/emps.toml")).unwrap();
    let record = Record::read(&path("data/emps_estimation.csv")).unwrap();
    let t = std::time::Instant::now();
    let d = diagnose(&model, &record, &options()).unwrap();
    println!(
        "EMPS diagnosed in {:.2} s\n{}",
        t.elapsed().as_secs_f64(),
        d.summary()
    );
    assert_eq!(
        names(&d).first(),
        Some(&EffectKind::CoulombFriction),
        "{:?}",
        names(&d)
    );
    let fc = d.named[0].named.parameters["force_n"];
    println!("EMPS: F_c = {fc:.2} N (published about 20 N)");
    assert!((15.0..25.0).contains(&fc), "F_c {fc}");
    assert!(d.gap_after.nrmse < d.gap_recalibrated.nrmse);
    let sd = d.named[0].std["force_n"];
    in_readme(format!("`coulomb_friction` of {fc:.1} ± {sd:.1} N first"));
}

#[test]
fn silverbox_cubic_hardening_cuts_the_arrow_error() {
    let model = Model::read(&path("examples/silverbox.toml")).unwrap();
    let record = Record::read(&path("data/silverbox_multisine.csv")).unwrap();
    let t = std::time::Instant::now();
    let d = diagnose(&model, &record, &options()).unwrap();
    println!(
        "Silverbox diagnosed in {:.2} s\n{}",
        t.elapsed().as_secs_f64(),
        d.summary()
    );
    assert_eq!(
        names(&d).first(),
        Some(&EffectKind::CubicStiffness),
        "{:?}",
        names(&d)
    );
    let k3 = d.named[0].named.parameters["stiffness_n_per_m3"];
    assert!(k3 > 0.0, "hardening expected, k3 = {k3}");
    in_readme(format!(
        "names `cubic_stiffness` (hardening) and the gap goes from {:.2} (model as given) and \
         {:.3} (recalibrated) to {:.3}",
        d.gap_before.nrmse, d.gap_recalibrated.nrmse, d.gap_after.nrmse
    ));
    // The growing-amplitude "arrow" test section, simulated from rest.
    let arrow = Record::read(&path("data/silverbox_arrow.csv")).unwrap();
    let y = arrow.column("y").unwrap();
    let err = |m: &Model| {
        let inputs = prepare_inputs(m, &arrow).unwrap();
        let sim = simulate(m, &arrow, &inputs, 0..arrow.len(), None).unwrap();
        let e: Vec<f64> = sim.outputs[0].iter().zip(y).map(|(s, y)| s - y).collect();
        mil_diagnose::signal::rms(&e)
    };
    let (linear, updated) = (err(&d.recalibrated_model), err(&d.updated));
    println!(
        "Silverbox arrow: RMS simulation error {:.3} mV (recalibrated linear) -> {:.3} mV (with cubic stiffness), {:.1}x",
        linear * 1e3,
        updated * 1e3,
        linear / updated
    );
    assert!(updated < linear / 3.0, "{linear} -> {updated}");
}

#[test]
fn boucwen_hysteresis() {
    let model = Model::read(&path("examples/boucwen.toml")).unwrap();
    let record = Record::read(&path("data/boucwen_multisine.csv")).unwrap();
    let t = std::time::Instant::now();
    let d = diagnose(&model, &record, &options()).unwrap();
    println!(
        "Bouc-Wen diagnosed in {:.2} s\n{}",
        t.elapsed().as_secs_f64(),
        d.summary()
    );
    assert_eq!(
        names(&d).first(),
        Some(&EffectKind::Hysteresis),
        "{:?}",
        names(&d)
    );
    assert!(d.gap_after.nrmse < d.gap_recalibrated.nrmse);
    in_readme(format!(
        "names `hysteresis` and the gap goes from {:.2} and {:.3} to {:.3}",
        d.gap_before.nrmse, d.gap_recalibrated.nrmse, d.gap_after.nrmse
    ));
}
