//! The plant's fast paths against plain RK4: the exact linear steps (see the `plant` module
//! documentation) on the linear tyre rig, through lift-off of an emulated tyre that declares
//! its affine form, and through spool saturation of the actuator; and the integration
//! accuracy of plain RK4 at 100 µs and 200 µs internal steps at a 5 kHz control rate.
//!
//! Errors are RMS differences of the interface force against a plain RK4 reference at 2 µs,
//! relative to the force's RMS variation. Speed is not asserted here: see the
//! `realtime_factor` example.

use mil_identify::band_limited_noise;
use mil_params::{ServoHydraulicActuator, TyreExample};
use mil_rig::actuator::{ActuatorEffects, ForceActuator};
use mil_rig::harness::{run, Histories, Instrumentation};
use mil_rig::plant::Plant;
use mil_rig::rigs::{ideal_tyre, paper_tyre_part, tyre_controller, tyre_input, IdealTyre};
use mil_rig::specimen::Specimen;
use mil_structure::{EffectKind, Element};
use model_core::{DemandLimits, TyreParams};

const REFERENCE_STEP_S: f64 = 2e-6;

fn rms(v: impl Iterator<Item = f64>) -> f64 {
    let (s, n) = v.fold((0.0, 0usize), |(s, n), x| (s + x * x, n + 1));
    (s / n.max(1) as f64).sqrt()
}

/// RMS of `a − b` relative to the RMS variation of `b`.
fn relative_error(a: &[f64], b: &[f64]) -> f64 {
    let mean = b.iter().sum::<f64>() / b.len() as f64;
    let variation = rms(b.iter().map(|x| x - mean));
    assert!(variation > 0.0);
    rms(a.iter().zip(b).map(|(x, y)| x - y)) / variation
}

/// The closed-loop tyre rig at `fs` (Hz) on `road` (m) with the given internal step (s),
/// exact steps on or off.
fn tyre_rig(road: &[f64], fs: f64, internal_step_s: f64, exact: bool) -> Histories {
    let mut parts = vec![paper_tyre_part(internal_step_s).unwrap()];
    parts[0].mil.set_exact_steps(exact);
    parts[0].emulated.set_exact_steps(exact);
    let limits = DemandLimits {
        min: -20_000.0,
        max: 20_000.0,
        rate: 1.0e9,
    };
    let mut controller = tyre_controller(TyreParams::PAPER, limits, fs).unwrap();
    let (h, _) = run(
        &mut controller,
        &mut parts,
        &Instrumentation::default(),
        fs,
        &[road.to_vec()],
        &[f64::from(TyreParams::PAPER.static_load)],
        tyre_input,
        |_| {},
    )
    .unwrap();
    if exact {
        // The hub-coupled MiL rig is linear in its regime; the rigs' `IdealTyre` declares no
        // affine form, so the emulated plant integrates by RK4.
        let counts = parts[0].mil.step_counts();
        assert!(parts[0].mil.has_exact_steps());
        assert_eq!(counts.rk4, 0, "{counts:?}");
    }
    h
}

/// Plain RK4 at 100 µs and 200 µs, and the exact steps, against plain RK4 at 2 µs on the
/// tyre rig at 5 kHz (2 s of road noise, 1 mm RMS, 0.5–50 Hz): MiL load-cell force and
/// emulated tyre force.
#[test]
fn tyre_rig_at_5_khz_against_a_2_us_reference() {
    let fs = 5000.0;
    let road = band_limited_noise(0.5, 50.0, 2.0, fs, 1e-3, true, 7);
    let reference = tyre_rig(&road, fs, REFERENCE_STEP_S, false);
    for (step, exact, bound_mil, bound_emulated) in [
        (100e-6, false, 1e-4, 1e-4),
        (200e-6, false, 1e-3, 1e-4),
        (100e-6, true, 1e-6, 1e-4),
        (200e-6, true, 1e-6, 1e-4),
    ] {
        let h = tyre_rig(&road, fs, step, exact);
        let mil = relative_error(&h.mil_force[0], &reference.mil_force[0]);
        let emulated = relative_error(&h.emulated_force[0], &reference.emulated_force[0]);
        eprintln!(
            "5 kHz, {:.0} us {}: force error / RMS variation: MiL {mil:.2e}, emulated {emulated:.2e}",
            step * 1e6,
            if exact { "exact steps" } else { "plain RK4" }
        );
        assert!(mil < bound_mil, "MiL {mil} at {step} s, exact {exact}");
        assert!(
            emulated < bound_emulated,
            "emulated {emulated} at {step} s, exact {exact}"
        );
    }
}

/// The emulated quarter car on the rigs' ideal tyre (affine while on the road).
fn emulated_quarter_car(tyre: &Element, internal_step_s: f64) -> Plant {
    let car = TyreExample::default();
    let mut specimen = Specimen::quarter_car(&car, Specimen::quarter_car_suspension(&car));
    specimen.inputs = vec!["road".into()];
    for e in &mut specimen.elements {
        e.input_coefficients = vec![0.0];
    }
    Plant::with_ideal_interface(
        specimen,
        Box::new(IdealTyre::new(vec![tyre.clone()]).unwrap()),
        internal_step_s,
    )
    .unwrap()
}

/// Drives `plant` open loop at `fs` (Hz) as the harness does (sample, then advance over
/// the sample period) with `demand(k)` (N) and `road` (m, empty for none); returns the
/// interface force per sample (N).
fn drive(
    plant: &mut Plant,
    fs: f64,
    samples: usize,
    demand: impl Fn(usize) -> f64,
    road: &[f64],
) -> Vec<f64> {
    let dt = 1.0 / fs;
    plant.rest(&[demand(0)]);
    let mut out = Vec::with_capacity(samples);
    for k in 0..samples {
        let d = [demand(k)];
        if road.is_empty() {
            plant.sample(&d, &[], &[]);
            out.push(plant.force()[0]);
            plant.advance(dt, &d, &[], &[]);
        } else {
            let now = road[k.min(road.len() - 1)];
            let next = road[(k + 1).min(road.len() - 1)];
            let previous = road[k.saturating_sub(1)];
            plant.sample(&d, &[now], &[(next - previous) / (2.0 * dt)]);
            out.push(plant.force()[0]);
            plant.advance(dt, &d, &[now], &[next]);
        }
    }
    out
}

/// Through lift-off: the emulated quarter car on a 12 mm, 15 Hz road (the wheel leaves the
/// road every cycle) with the exact steps falls back to RK4 around every lift-off and
/// touch-down, and stays as close to the 2 µs reference as plain RK4 at the same step.
#[test]
fn exact_steps_through_lift_off_match_rk4() {
    let fs = 5000.0;
    let samples = 5000;
    let road: Vec<f64> = (0..samples)
        .map(|k| 12e-3 * (std::f64::consts::TAU * 15.0 * k as f64 / fs).sin())
        .collect();
    let tyre = ideal_tyre(&TyreParams::PAPER);
    assert!(tyre.lifts_off());
    let no_demand = |_| 0.0;
    let reference = drive(
        &mut {
            let mut p = emulated_quarter_car(&tyre, REFERENCE_STEP_S);
            p.set_exact_steps(false);
            p
        },
        fs,
        samples,
        no_demand,
        &road,
    );
    assert!(
        reference.iter().filter(|f| **f == 0.0).count() > 100,
        "the road must lift the wheel off"
    );
    for step in [100e-6, 200e-6] {
        let mut plain = emulated_quarter_car(&tyre, step);
        plain.set_exact_steps(false);
        let plain_force = drive(&mut plain, fs, samples, no_demand, &road);
        let mut exact = emulated_quarter_car(&tyre, step);
        assert!(exact.has_exact_steps());
        let exact_force = drive(&mut exact, fs, samples, no_demand, &road);
        let counts = exact.step_counts();
        assert!(counts.exact > 0 && counts.rk4 > 0, "{counts:?}");
        let (e_plain, e_exact) = (
            relative_error(&plain_force, &reference),
            relative_error(&exact_force, &reference),
        );
        eprintln!(
            "lift-off, {:.0} us: plain RK4 {e_plain:.2e}, exact steps {e_exact:.2e} ({} exact, {} RK4 steps)",
            step * 1e6,
            counts.exact,
            counts.rk4
        );
        assert!(e_exact <= 1.5 * e_plain + 1e-9, "{e_exact} vs {e_plain}");
        assert!(e_exact < 1e-3);
    }
    // Without lift-off the same tyre is linear everywhere: every step exact, and equal to
    // the reference to well below RK4's error.
    let linear = Element {
        effects: Default::default(),
        ..tyre
    };
    let mut plain = emulated_quarter_car(&linear, REFERENCE_STEP_S);
    plain.set_exact_steps(false);
    let reference = drive(&mut plain, fs, samples, no_demand, &road);
    let mut exact = emulated_quarter_car(&linear, 200e-6);
    let exact_force = drive(&mut exact, fs, samples, no_demand, &road);
    assert_eq!(exact.step_counts().rk4, 0);
    let e = relative_error(&exact_force, &reference);
    eprintln!("linear tyre, 200 us exact steps: {e:.2e}");
    assert!(e < 1e-7, "{e}");
}

/// Through spool saturation: the quarter car on an actuator whose spool opens to 5 % at
/// most, driven by ±3 kN demand steps, with the exact steps falls back to RK4 while the
/// valve saturates, and stays as close to the 2 µs reference as plain RK4 at the same step.
#[test]
fn exact_steps_through_spool_saturation_match_rk4() {
    let fs = 5000.0;
    let samples = 5000;
    let car = TyreExample::default();
    let weight = (car.sprung_mass_kg + car.unsprung_mass_kg) * mil_rig::specimen::GRAVITY_M_PER_S2;
    let demand = |k: usize| weight + if (k / 500) % 2 == 0 { 3000.0 } else { -3000.0 };
    let plant = |step: f64, exact: bool| {
        let actuator = ForceActuator::new(
            ServoHydraulicActuator::REFERENCE,
            ActuatorEffects {
                spool_limit: Some(0.05),
                ..ActuatorEffects::default()
            },
        )
        .unwrap();
        let mut p = Plant::with_actuators(
            Specimen::quarter_car(&car, Specimen::quarter_car_suspension(&car)),
            vec![actuator],
            step,
        )
        .unwrap();
        p.set_exact_steps(exact);
        p
    };
    let reference = drive(
        &mut plant(REFERENCE_STEP_S, false),
        fs,
        samples,
        demand,
        &[],
    );
    for step in [100e-6, 200e-6] {
        let plain = drive(&mut plant(step, false), fs, samples, demand, &[]);
        let mut exact = plant(step, true);
        assert!(exact.has_exact_steps());
        let exact_force = drive(&mut exact, fs, samples, demand, &[]);
        let counts = exact.step_counts();
        assert!(counts.exact > 0 && counts.rk4 > 0, "{counts:?}");
        let (e_plain, e_exact) = (
            relative_error(&plain, &reference),
            relative_error(&exact_force, &reference),
        );
        eprintln!(
            "spool saturation, {:.0} us: plain RK4 {e_plain:.2e}, exact steps {e_exact:.2e} ({} exact, {} RK4 steps)",
            step * 1e6,
            counts.exact,
            counts.rk4
        );
        assert!(e_exact <= 1.5 * e_plain + 1e-9, "{e_exact} vs {e_plain}");
        // The valve's kinks cost plain RK4 too: 3e-3 at 100 µs.
        assert!(e_exact < 1e-2);
    }
}

/// Plants that are not piecewise linear take no exact steps: Coulomb seal friction, and an
/// ideal interface that declares no affine form.
#[test]
fn nonlinear_plants_take_rk4_steps() {
    let car = TyreExample::default();
    let actuator = ForceActuator::new(
        ServoHydraulicActuator::REFERENCE,
        ActuatorEffects {
            coulomb_friction_n: Some(50.0),
            ..ActuatorEffects::default()
        },
    )
    .unwrap();
    let p = Plant::with_actuators(
        Specimen::quarter_car(&car, Specimen::quarter_car_suspension(&car)),
        vec![actuator],
        100e-6,
    )
    .unwrap();
    assert!(!p.has_exact_steps());
    // The paper's tyre (lift-off only) is piecewise affine; a progressive tyre is not.
    let part = paper_tyre_part(100e-6).unwrap();
    assert!(part.mil.has_exact_steps());
    assert!(part.emulated.has_exact_steps());
    let tyre = mil_rig::rigs::ideal_tyre(&model_core::TyreParams::PAPER)
        .with(EffectKind::CubicStiffness, &[("stiffness_n_per_m3", 1e9)]);
    let reference = ForceActuator::new(
        ServoHydraulicActuator::REFERENCE,
        ActuatorEffects::default(),
    )
    .unwrap();
    let progressive = mil_rig::rigs::quarter_car_part(
        Specimen::quarter_car(&car, Specimen::quarter_car_suspension(&car)),
        reference,
        tyre,
        0,
        0,
        100e-6,
    )
    .unwrap();
    assert!(progressive.mil.has_exact_steps());
    assert!(!progressive.emulated.has_exact_steps());
}

/// The whole control period in one product (after a sample in the regime) equals the same
/// period in separate exact internal steps (without a sample), whatever the number of
/// internal steps: 2 (the fused matrix as built), 8 (widened to more rows) and 40 (too
/// many rows for a fused matrix: step by step only). The MiL quarter car on the reference
/// actuator at 5 kHz, ±200 N demand steps and a 1 kN sine (inside the linear regime); states compared after every
/// period, relative to each state's largest magnitude.
#[test]
fn a_fused_period_equals_its_exact_internal_steps() {
    let fs = 5000.0;
    let dt = 1.0 / fs;
    let samples = 2000;
    let car = TyreExample::default();
    let weight = (car.sprung_mass_kg + car.unsprung_mass_kg) * mil_rig::specimen::GRAVITY_M_PER_S2;
    let demand = |k: usize| {
        let t = k as f64 * dt;
        weight
            + if (k / 250) % 2 == 0 { 200.0 } else { -200.0 }
            + 1000.0 * (std::f64::consts::TAU * 7.0 * t).sin()
    };
    let plant = |step: f64| {
        let actuator = ForceActuator::new(
            ServoHydraulicActuator::REFERENCE,
            ActuatorEffects::default(),
        )
        .unwrap();
        Plant::with_actuators(
            Specimen::quarter_car(&car, Specimen::quarter_car_suspension(&car)),
            vec![actuator],
            step,
        )
        .unwrap()
    };
    for (step, steps) in [(100e-6, 2), (25e-6, 8), (5e-6, 40)] {
        let (mut fused, mut stepped) = (plant(step), plant(step));
        assert!(fused.has_exact_steps());
        fused.rest(&[demand(0)]);
        stepped.rest(&[demand(0)]);
        let mut worst = 0.0_f64;
        let mut scale = vec![0.0_f64; fused.state().len()];
        let mut differences = vec![0.0_f64; fused.state().len()];
        for k in 0..samples {
            let d = [demand(k)];
            fused.sample(&d, &[], &[]);
            fused.advance(dt, &d, &[], &[]);
            stepped.advance(dt, &d, &[], &[]);
            for (i, (a, b)) in fused.state().iter().zip(stepped.state()).enumerate() {
                scale[i] = scale[i].max(b.abs());
                differences[i] = differences[i].max((a - b).abs());
            }
        }
        for (d, s) in differences.iter().zip(&scale) {
            if *s > 0.0 {
                worst = worst.max(d / s);
            }
        }
        let (a, b) = (fused.step_counts(), stepped.step_counts());
        eprintln!(
            "{steps} internal steps per period: largest state difference / state range {worst:.1e} ({a:?}, {b:?})"
        );
        assert_eq!(a.rk4 + b.rk4, 0, "{a:?} {b:?}");
        assert_eq!(a.exact, (steps * samples) as u64);
        assert_eq!(b.exact, (steps * samples) as u64);
        assert!(worst < 1e-9, "{worst} at {steps} internal steps");
    }
}
