//! Shared by the synthetic-record tests: the one-DOF oscillator made by the simulated rig
//! (2 kg on a 20 kN/m, 20 N·s/m spring-damper to ground, driven by a prescribed force), the
//! engineer's linear model of it with every parameter 10–15 % off, and the diagnosis run
//! that prints what a reader of the test output needs.

// Each test file uses its own part of this module.
#![allow(dead_code)]

use mil_diagnose::{diagnose, Diagnosis, EffectKind, Model, Options, Record};
use mil_rig::effects::{Effects, Element};
use mil_rig::plant::{AffineInterface, IdealInterface, Plant};
use mil_rig::rng::SplitMix64;
use mil_rig::specimen::{PlacedElement, Specimen};

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
    let specimen = Specimen {
        dofs: vec!["x".into()],
        mass: vec![vec![MASS]],
        static_force: vec![0.0],
        elements: vec![PlacedElement {
            name: "spring".into(),
            element: Element::linear(K, C).with_effects(effects),
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
"#,
        m = MASS * 1.10,
        k = K * 0.88,
        c = C * 1.15
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

/// Adds white noise of `fraction` × the signal's RMS.
pub fn noisy(clean: &[f64], fraction: f64, rng: &mut SplitMix64) -> Vec<f64> {
    let rms = (clean.iter().map(|v| v * v).sum::<f64>() / clean.len() as f64).sqrt();
    clean
        .iter()
        .map(|v| v + fraction * rms * rng.normal())
        .collect()
}
