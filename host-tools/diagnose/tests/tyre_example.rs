//! The tyre example's model file (`examples/quarter-car.toml`) against 60 s of the simulated rig's
//! quarter car on a track-like road (see `tests/common/quarter_car.rs`): the rig's linear
//! parameters 8–12 % off the file's, the tyre lifting off and the suspension damper
//! asymmetric. The workflow must recalibrate the linear parameters, name exactly those two
//! effects on the right elements with their parameters, and shrink the gap.

#[path = "common/quarter_car.rs"]
mod quarter_car;

use mil_diagnose::{diagnose, EffectKind, Model, Options};
use mil_rig::specimen::GRAVITY_M_PER_S2;
use quarter_car::*;

#[test]
fn tyre_example_names_lift_off_and_asymmetric_damping() {
    let text = include_str!("../examples/quarter-car.toml");
    let model = Model::from_toml(text).expect("quarter-car.toml");
    let record = quarter_car_record(&track_road(60.0, 21), 21);
    let d = diagnose(&model, &record, &Options::default()).expect("diagnose");
    println!("{}", d.summary());
    let mut named: Vec<(EffectKind, &str)> = d
        .named
        .iter()
        .map(|n| (n.named.effect, n.named.element.as_str()))
        .collect();
    named.sort();
    assert_eq!(
        named,
        [
            (EffectKind::LiftOff, "tyre"),
            (EffectKind::AsymmetricDamping, "suspension")
        ]
    );
    let param = |kind: EffectKind, key: &str| -> f64 {
        d.named
            .iter()
            .find(|n| n.named.effect == kind)
            .and_then(|n| n.named.parameters.get(key).copied())
            .expect("parameter")
    };
    let within = |what: &str, got: f64, truth: f64, tol: f64| {
        println!(
            "{what}: {got:.6e} vs {truth:.6e} (tolerance {:.1} %)",
            100.0 * tol
        );
        assert!(
            (got - truth).abs() <= tol * truth.abs(),
            "{what}: {got} vs {truth}"
        );
    };
    // The tyre's static load is the car's weight.
    within(
        "preload",
        param(EffectKind::LiftOff, "preload_n"),
        (M_S + M_U) * GRAVITY_M_PER_S2,
        0.01,
    );
    within(
        "bump",
        param(EffectKind::AsymmetricDamping, "bump_n_s_per_m"),
        C_BUMP,
        0.03,
    );
    within(
        "rebound",
        param(EffectKind::AsymmetricDamping, "rebound_n_s_per_m"),
        C_REBOUND,
        0.03,
    );
    // The linear parameters the model file had 10 % off.
    let rec = |key: &str| d.recalibrated.get(key).copied().expect("recalibrated");
    within("k_c", rec("suspension.stiffness_n_per_m"), K_C, 0.03);
    within("k_t", rec("tyre.stiffness_n_per_m"), K_T, 0.03);
    // The gap: the updated model is an order of magnitude closer than the recalibrated
    // linear one.
    println!(
        "gap: {:.4} as given, {:.4} recalibrated, {:.4} updated",
        d.gap_before.nrmse, d.gap_recalibrated.nrmse, d.gap_after.nrmse
    );
    assert!(d.gap_after.nrmse < 0.1 * d.gap_recalibrated.nrmse);
    assert!(d.gap_recalibrated.nrmse < d.gap_before.nrmse);
}
