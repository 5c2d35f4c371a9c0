//! Shared by the synthetic-record tests: the one-DOF oscillator made by the simulated rig
//! (2 kg on a 20 kN/m, 20 N·s/m spring-damper to ground, driven by a prescribed force), the
//! engineer's linear model of it with every parameter 10–15 % off, and the diagnosis run
//! that prints what a reader of the test output needs.

// Each test file uses its own part of this module.
#![allow(dead_code)]

use mil_diagnose::{diagnose, Diagnosis, EffectKind, Model, Options, Record};
use mil_numerics::rng::SplitMix64;
use mil_rig::plant::{AffineInterface, IdealInterface, Plant};
use mil_rig::specimen::{PlacedElement, Specimen, GRAVITY_M_PER_S2};
use mil_structure::{Element, Parameters};
use std::collections::BTreeMap;

/// The effects switched on in a simulated element: parameters (SI names) by effect, as in
/// [`mil_structure::Element::effects`].
pub type Effects = BTreeMap<EffectKind, Parameters>;

/// The effects `list` (each effect with its parameters by SI name, see [`EffectKind`]); an
/// empty list is the linear element.
pub fn effects(list: &[(EffectKind, &[(&str, f64)])]) -> Effects {
    list.iter()
        .map(|(kind, parameters)| {
            let parameters = parameters
                .iter()
                .map(|(name, value)| (name.to_string(), *value))
                .collect();
            (*kind, parameters)
        })
        .collect()
}

/// Oscillator mass (kg).
pub const MASS: f64 = 2.0;
/// Oscillator stiffness (N/m).
pub const K: f64 = 2.0e4;
/// Oscillator damping (N·s/m).
pub const C: f64 = 20.0;
/// Record sample rate (Hz).
pub const FS: f64 = 1000.0;
/// Record length (s).
pub const DURATION_S: f64 = 16.0;
/// RMS of the random force (N).
pub const FORCE_RMS: f64 = 20.0;

/// Measurement noise on the excitation column (fraction of its clean RMS).
pub const INPUT_NOISE: f64 = 0.005;
/// Measurement noise on the displacement column (fraction of its clean RMS).
pub const OUTPUT_NOISE: f64 = 0.007;

/// The prescribed force is the specimen's pseudo road input 0 (N), passed through.
pub struct ForceFromInput;

impl IdealInterface for ForceFromInput {
    fn forces(&self, _y: &[f64], _yd: &[f64], road: &[f64], _rr: &[f64], forces: &mut [f64]) {
        forces[0] = road[0];
    }
    fn affine(&self) -> Option<AffineInterface> {
        Some(AffineInterface {
            offset_n: vec![0.0],
            position_n_per_m: vec![vec![0.0]],
            velocity_n_s_per_m: vec![vec![0.0]],
            road_n_per_m: vec![vec![1.0]],
            road_rate_n_s_per_m: vec![vec![0.0]],
            lower_bound_n: vec![f64::NEG_INFINITY],
        })
    }
}

/// The oscillator on the simulated rig with `effects` on its spring-damper, driven by the
/// force on its input 0 (N), at rest; RK4 or exact steps of 0.1 ms.
pub fn oscillator_plant(effects: Effects) -> Plant {
    oscillator_plant_of(MASS, K, C, effects)
}

/// [`oscillator_plant`] with mass `mass` (kg), stiffness `k` (N/m) and damping `c`
/// (N·s/m).
pub fn oscillator_plant_of(mass: f64, k: f64, c: f64, effects: Effects) -> Plant {
    let specimen = Specimen {
        dofs: vec!["x".into()],
        mass: vec![vec![mass]],
        static_force: vec![0.0],
        elements: vec![PlacedElement {
            name: "spring".into(),
            element: Element {
                effects,
                ..Element::linear(k, c)
            },
            // Compression: the mass moving down towards the ground.
            dof_coefficients: vec![-1.0],
            input_coefficients: vec![0.0],
        }],
        inputs: vec!["force".into()],
        attachments: vec![vec![1.0]],
    };
    Plant::with_ideal_interface(specimen, Box::new(ForceFromInput), 1e-4).expect("plant")
}

/// The engineer's oscillator model: linear, every parameter off (mass +10 %, stiffness
/// −12 %, damping +15 %).
pub fn oscillator_model() -> Model {
    oscillator_model_of(MASS * 1.10, K * 0.88, C * 1.15)
}

/// A linear oscillator model of mass `m` (kg), stiffness `k` (N/m), damping `c` (N·s/m),
/// laid out as [`oscillator_plant`] (force `force` in, displacement `x` out).
pub fn oscillator_model_of(m: f64, k: f64, c: f64) -> Model {
    Model::from_toml(&format!(
        r#"
name = "oscillator"
[[dof]]
name = "x"
mass = {m}
[[element]]
name = "spring"
upper = "x"
lower = "ground"
stiffness_n_per_m = {k}
damping_n_s_per_m = {c}
[[input]]
name = "force"
kind = "force"
column = "force"
at = "x"
[[output]]
column = "x"
kind = "displacement"
of = "x"
"#
    ))
    .expect("model")
}

/// Diagnoses `record` against `model`, printing the summary, the first round's candidate
/// scores and the gaps.
pub fn run(name: &str, model: &Model, record: &Record) -> Diagnosis {
    let options = Options {
        progress: std::env::var_os("DIAGNOSE_PROGRESS").is_some(),
        ..Options::default()
    };
    let t = std::time::Instant::now();
    let d = diagnose(model, record, &options).expect("diagnose");
    println!("{name}: diagnosed in {:.2} s", t.elapsed().as_secs_f64());
    println!("--- {name} ---\n{}", d.summary());
    for c in d.candidates.iter().filter(|c| c.round == 0) {
        println!(
            "  candidate {} on {}: criterion {:.1}, SSE x{:.4}",
            c.effect, c.element, c.criterion, c.sse_ratio
        );
    }
    println!(
        "named: {:?}; gap {:.4} (as given) -> {:.4} (recalibrated) -> {:.4} (updated): {:.2}x vs as given, {:.2}x vs recalibrated",
        names(&d),
        d.gap_before.nrmse,
        d.gap_recalibrated.nrmse,
        d.gap_after.nrmse,
        d.gap_before.nrmse / d.gap_after.nrmse,
        d.gap_recalibrated.nrmse / d.gap_after.nrmse
    );
    d
}

/// The named effects, in order.
pub fn names(d: &Diagnosis) -> Vec<EffectKind> {
    d.named.iter().map(|n| n.named.effect).collect()
}

/// A record at [`FS`] of the excitation `input` (column `input_name`) and the displacement
/// `x` (column `x`), with measurement noise ([`INPUT_NOISE`], [`OUTPUT_NOISE`]) drawn from
/// `seed`.
pub fn noisy_record(input_name: &str, input: &[f64], x: &[f64], seed: u64) -> Record {
    let mut rng = SplitMix64::new(seed ^ 0xABCD);
    let t: Vec<f64> = (0..input.len()).map(|i| i as f64 / FS).collect();
    let u = noisy(input, INPUT_NOISE, &mut rng);
    let x = noisy(x, OUTPUT_NOISE, &mut rng);
    Record::new(&t, vec![input_name.into(), "x".into()], vec![u, x]).expect("record")
}

/// Adds white noise of `fraction` × the signal's RMS.
pub fn noisy(clean: &[f64], fraction: f64, rng: &mut SplitMix64) -> Vec<f64> {
    let rms = (clean.iter().map(|v| v * v).sum::<f64>() / clean.len() as f64).sqrt();
    clean
        .iter()
        .map(|v| v + fraction * rms * rng.normal())
        .collect()
}

/// Displacement (m) of the oscillator with `effects`, driven by the force `f` (N), from
/// rest; the force is linearly interpolated between samples.
pub fn oscillator_response(effects: Effects, f: &[f64]) -> Vec<f64> {
    plant_response(oscillator_plant(effects), f)
}

/// Displacement (m) of DOF 0 of `plant` driven on its input 0 by the force `f` (N), from
/// rest; the force is linearly interpolated between samples.
pub fn plant_response(mut plant: Plant, f: &[f64]) -> Vec<f64> {
    let dt = 1.0 / FS;
    let mut x = Vec::with_capacity(f.len());
    for i in 0..f.len() {
        x.push(plant.state()[0]);
        let next = f[(i + 1).min(f.len() - 1)];
        plant.advance(dt, &[0.0], &[f[i]], &[next]);
    }
    x
}

/// `f` as it arrives `delay_s` (s) later, linearly interpolated (held at `f[0]` before).
pub fn delayed(f: &[f64], delay_s: f64) -> Vec<f64> {
    let shift = delay_s * FS;
    (0..f.len())
        .map(|i| {
            let s = i as f64 - shift;
            if s <= 0.0 {
                f[0]
            } else {
                let j = s.floor() as usize;
                let w = s - j as f64;
                f[j] * (1.0 - w) + f[(j + 1).min(f.len() - 1)] * w
            }
        })
        .collect()
}

/// `f` clipped to ±`limit`.
pub fn clipped(f: &[f64], limit: f64) -> Vec<f64> {
    f.iter().map(|v| v.max(-limit).min(limit)).collect()
}

/// `f` with its rate limited to ±`rate_per_s` (units of `f` per second), sample by sample.
pub fn rate_limited(f: &[f64], rate_per_s: f64) -> Vec<f64> {
    let step = rate_per_s / FS;
    let mut out = f.to_vec();
    for i in 1..out.len() {
        let prev = out[i - 1];
        out[i] = out[i].max(prev - step).min(prev + step);
    }
    out
}

/// Root mean square of `x`.
pub fn rms(x: &[f64]) -> f64 {
    (x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64).sqrt()
}

/// The lift-off records' wheel: mass (kg) on a preloaded tyre spring.
pub const WHEEL_MASS: f64 = 250.0;
/// Tyre stiffness (N/m).
pub const TYRE_K: f64 = 1.5e5;
/// Tyre damping (N·s/m).
pub const TYRE_C: f64 = 1500.0;

/// No actuator force (the specimen is driven by its road input only).
pub struct NoForce;

impl IdealInterface for NoForce {
    fn forces(&self, _y: &[f64], _yd: &[f64], _road: &[f64], _rr: &[f64], forces: &mut [f64]) {
        forces[0] = 0.0;
    }
    fn affine(&self) -> Option<AffineInterface> {
        Some(AffineInterface {
            offset_n: vec![0.0],
            position_n_per_m: vec![vec![0.0]],
            velocity_n_s_per_m: vec![vec![0.0]],
            road_n_per_m: vec![vec![0.0]],
            road_rate_n_s_per_m: vec![vec![0.0]],
            lower_bound_n: vec![f64::NEG_INFINITY],
        })
    }
}

/// The wheel ([`WHEEL_MASS`] on the tyre, static load `m g`) driven by `road` (m) through a
/// displacement input, from rest: its displacement (m) and the fraction of the samples in
/// which the tyre would pull (the linear tyre force below zero). With `lift_off` the tyre
/// can only push (`mil_structure`'s `lift_off`), without it the tyre is linear.
pub fn wheel_response(road: &[f64], lift_off: bool) -> (Vec<f64>, f64) {
    let g = GRAVITY_M_PER_S2;
    let mut tyre = Element::linear(TYRE_K, TYRE_C).with_preload(WHEEL_MASS * g);
    if lift_off {
        tyre = tyre.with(EffectKind::LiftOff, &[]);
    }
    let specimen = Specimen {
        dofs: vec!["x".into()],
        mass: vec![vec![WHEEL_MASS]],
        static_force: vec![-WHEEL_MASS * g],
        elements: vec![PlacedElement {
            name: "tyre".into(),
            element: tyre,
            // Compression: the road rising towards the mass.
            dof_coefficients: vec![-1.0],
            input_coefficients: vec![1.0],
        }],
        inputs: vec!["road".into()],
        attachments: vec![vec![1.0]],
    };
    let mut plant = Plant::with_ideal_interface(specimen, Box::new(NoForce), 1e-4).expect("plant");
    let dt = 1.0 / FS;
    let mut x = Vec::with_capacity(road.len());
    for i in 0..road.len() {
        x.push(plant.state()[0]);
        let next = road[(i + 1).min(road.len() - 1)];
        plant.advance(dt, &[0.0], &[road[i]], &[next]);
    }
    let pulling = (1..x.len())
        .filter(|&i| {
            let (xe, ve) = (
                road[i] - x[i],
                (road[i] - x[i] - road[i - 1] + x[i - 1]) * FS,
            );
            WHEEL_MASS * g + TYRE_K * xe + TYRE_C * ve < 0.0
        })
        .count();
    let fraction = pulling as f64 / x.len() as f64;
    (x, fraction)
}

/// The engineer's wheel model: the mass right (a displacement-driven record fixes only k/m
/// and c/m), the tyre's stiffness −12 % and damping +15 % off, no lift-off.
pub fn wheel_model() -> Model {
    Model::from_toml(&format!(
        r#"
name = "wheel on tyre"
[[dof]]
name = "x"
mass = {m}
[[input]]
name = "road"
kind = "displacement"
column = "road"
[[element]]
name = "tyre"
upper = "x"
lower = "road"
stiffness_n_per_m = {k}
damping_n_s_per_m = {c}
[[output]]
column = "x"
kind = "displacement"
of = "x"
"#,
        m = WHEEL_MASS,
        k = TYRE_K * 0.88,
        c = TYRE_C * 1.15
    ))
    .expect("model")
}
