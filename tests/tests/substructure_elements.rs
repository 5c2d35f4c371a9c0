//! The board's nonlinear substructure against the structure it was exported from.
//!
//! The numerical part `host-tools/mil/examples/two-dof-nonlinear-numerical.toml` (the 2-DOF
//! example's mass on a road spring-damper with bump and rebound stops, a cubic spring,
//! asymmetric damping and dry friction) goes through the set-up's export
//! (`two-dof.toml` with that numerical part) into model-core's `f32` substructure with one
//! nonlinear element, configuration 4: the measured position `x_p` and the road `z_n` in,
//! the interface force `F_i = k_i (x_n − x_p) + c_i (ẋ_n − ẋ̂_p)` out. The reference is the
//! same structure file with `B_i` added as an element to a displacement input `x_p`,
//! simulated in `f64` by the structure simulation diagnosis and the rig use (RK4 with
//! sub-steps, inputs interpolated linearly), its interface force `−F_(B_i)`.
//!
//! The inputs are random-phase multisines (the workspace's SplitMix64, seeded) and a swept
//! sine, written here, large enough that the stops engage most of the time. Bounds: RMS difference
//! within 2 % of the force's RMS and the worst sample within 5 % of the force's peak, for
//! the nonlinear part and for its linear counterpart (the same file without its effects),
//! and the effects adding at most 0.5 percentage points of RMS difference to the linear
//! scheme's. The linear scheme's difference (0.6–0.8 %) is mostly the board's causal
//! backward-difference road rate against the reference's interpolated one (`c ż` lags half
//! a sample); the effects change the force by about 100 % RMS, so they are active.
//!
//! The structure is damped as a car's (damping ratio 0.2): a lightly damped structure with
//! stops is sensitive to its initial conditions, and any two integrations of it (f32 or
//! f64, any scheme) drift apart sample by sample; with the 2-DOF example's 0.016 they
//! differed by 50 % RMS after a few seconds while agreeing to 0.1 % on a plain sine.
//!
//! Seeds 1–3 were used while writing the scheme; seeds 11 and 12 (other amplitudes) and
//! the sweep were run once the bounds were set (seed 11 once before, on the lightly damped
//! structure, which showed the drift above) and are reported apart.

use mil::setup::SetUp;
use mil_diagnose::simulate::{prepare_inputs, simulate};
use mil_diagnose::{Model, Record};
use mil_numerics::rng::SplitMix64;
use model_core::{Model as _, ModelInput, SubstructureModel, SubstructureParams};
use std::path::PathBuf;

const FS: f64 = 2000.0;
const SECONDS: f64 = 8.0;

fn examples() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../host-tools/mil/examples")
}

fn read(name: &str) -> String {
    std::fs::read_to_string(examples().join(name)).expect("example readable")
}

const NONLINEAR: &str = "two-dof-nonlinear-numerical.toml";

/// The numerical part's text: the example with its effects, or (`effects` false) its
/// linear counterpart, the same file without its `[[effect]]` tables.
fn numerical_text(effects: bool) -> String {
    let text = read(NONLINEAR);
    if effects {
        text
    } else {
        text.split("[[effect]]")
            .next()
            .unwrap_or_default()
            .to_string()
    }
}

/// The board's parameters for the 2-DOF set-up with numerical part file `numerical`,
/// through the set-up's export.
fn board(numerical: &std::path::Path) -> SubstructureParams<1> {
    let numerical = numerical.to_string_lossy();
    let text =
        read("two-dof.toml").replace("\"two-dof-numerical.toml\"", &format!("{numerical:?}"));
    assert!(
        text.contains(&*numerical),
        "the set-up names its numerical part"
    );
    let config = SetUp::from_toml(&text, &examples())
        .and_then(|s| s.run())
        .expect("set-up valid");
    config
        .substructure
        .expect("a substructure set-up")
        .params::<1>()
        .expect("one channel")
}

/// The reference: the numerical structure with `B_i` (k_i, c_i from `two-dof.toml`) from
/// `x_n` to the measured position, its force as output.
fn reference(numerical: &str) -> Model {
    let text = format!(
        "{}\n[[element]]\nname = \"B_i\"\nupper = \"x_n\"\nlower = \"x_p\"\n\
         stiffness_n_per_m = 1.0e4\ndamping_n_s_per_m = 5.0\n\n\
         [[input]]\nname = \"x_p\"\nkind = \"displacement\"\ncolumn = \"x_p\"\n\n\
         [[output]]\ncolumn = \"f_b\"\nkind = \"force\"\nof = \"B_i\"\n",
        numerical
    );
    Model::from_toml(&text).expect("reference structure valid")
}

/// Inputs `(x_p, z_n)` (m) per sample.
enum Excitation {
    /// Random-phase multisines, 0.5–25 Hz, with RMS `x_p`, `z_n` (m).
    Multisine { seed: u64, rms: (f64, f64) },
    /// A sine sweep 0.5 → 20 Hz on `z_n` of amplitude `a` (m), `x_p` at rest.
    Sweep { a: f64 },
}

impl Excitation {
    fn signals(&self, n: usize) -> (Vec<f64>, Vec<f64>) {
        let t = |k: usize| k as f64 / FS;
        match *self {
            Excitation::Multisine { seed, rms } => {
                let mut rng = SplitMix64::new(seed);
                let mut multisine = |rms: f64| {
                    let tones: Vec<(f64, f64)> = (0..40)
                        .map(|_| {
                            (
                                0.5 + 24.5 * rng.uniform(),
                                std::f64::consts::TAU * rng.uniform(),
                            )
                        })
                        .collect();
                    let a = rms * (2.0 / tones.len() as f64).sqrt();
                    (0..n)
                        .map(|k| {
                            tones
                                .iter()
                                .map(|(f, p)| a * (std::f64::consts::TAU * f * t(k) + p).sin())
                                .sum::<f64>()
                        })
                        .collect::<Vec<f64>>()
                };
                (multisine(rms.0), multisine(rms.1))
            }
            Excitation::Sweep { a } => {
                let (f0, f1, span) = (0.5, 20.0, n as f64 / FS);
                let z = (0..n)
                    .map(|k| {
                        let tk = t(k);
                        let phase =
                            std::f64::consts::TAU * (f0 * tk + 0.5 * (f1 - f0) / span * tk * tk);
                        a * phase.sin()
                    })
                    .collect();
                (vec![0.0; n], z)
            }
        }
    }
}

/// The board's interface force per sample.
fn run_board(p: &SubstructureParams<1>, x_p: &[f64], z_n: &[f64]) -> Vec<f64> {
    let prepared = SubstructureModel::<1>::prepare(p, (1.0 / FS) as f32).expect("valid");
    let mut m = SubstructureModel::<1>::new();
    x_p.iter()
        .zip(z_n)
        .map(|(&x, &z)| {
            let input = ModelInput {
                position: [x as f32],
                road: [z as f32],
                ..ModelInput::default()
            };
            f64::from(m.step(&prepared, &input)[0])
        })
        .collect()
}

/// The reference's interface force per sample.
fn run_reference(model: &Model, x_p: &[f64], z_n: &[f64]) -> Vec<f64> {
    let time: Vec<f64> = (0..x_p.len()).map(|k| k as f64 / FS).collect();
    let record = Record::new(
        &time,
        vec!["road_0".into(), "x_p".into()],
        vec![z_n.to_vec(), x_p.to_vec()],
    )
    .expect("record");
    let inputs = prepare_inputs(model, &record).expect("inputs");
    let sim = simulate(model, &record, &inputs, 0..record.len(), None).expect("stable");
    sim.outputs[0].iter().map(|f| -f).collect()
}

fn rms(v: &[f64]) -> f64 {
    (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt()
}

struct Outcome {
    rms_error: f64,
    worst_error: f64,
    engaged: f64,
    effect_size: f64,
}

/// Board against reference for one excitation; also the share of samples with a stop
/// engaged and the RMS difference the effects make (nonlinear against linear reference),
/// each relative to the force's RMS (errors) or peak (worst).
fn compare(excitation: &Excitation) -> (Outcome, Outcome) {
    let n = (SECONDS * FS) as usize;
    let (x_p, z_n) = excitation.signals(n);
    let folder = tempfile::tempdir().expect("temporary folder");
    let linear_reference = run_reference(&reference(&numerical_text(false)), &x_p, &z_n);
    let outcome = |effects: bool| {
        let file = folder.path().join(format!("numerical-{effects}.toml"));
        std::fs::write(&file, numerical_text(effects)).expect("written");
        let board = run_board(&board(&file), &x_p, &z_n);
        let model = reference(&numerical_text(effects));
        let f = run_reference(&model, &x_p, &z_n);
        let err: Vec<f64> = board.iter().zip(&f).map(|(a, b)| a - b).collect();
        let peak = f.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let worst = err.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        // The road element's compression z_n − x_n, from the reference's interface force:
        // x_n = x_p + (F_i − c_i (ẋ_n − ẋ_p)) / k_i, the damper's share neglected here
        // (it only decides what counts as engaged).
        let engaged = f
            .iter()
            .zip(&x_p)
            .zip(&z_n)
            .filter(|((fi, xp), z)| (*z - (*xp + *fi / 1.0e4)).abs() > 1.5e-3)
            .count() as f64
            / n as f64;
        let diff: Vec<f64> = f
            .iter()
            .zip(&linear_reference)
            .map(|(a, b)| a - b)
            .collect();
        Outcome {
            rms_error: rms(&err) / rms(&f),
            worst_error: worst / peak,
            engaged,
            effect_size: rms(&diff) / rms(&f),
        }
    };
    (outcome(true), outcome(false))
}

fn check(label: &str, excitation: &Excitation) {
    let (nonlinear, linear) = compare(excitation);
    println!(
        "{label}: nonlinear: RMS error {:.3} %, worst {:.3} % of peak, stops engaged {:.0} % \
         of samples, effects change the force by {:.1} % RMS; linear: RMS error {:.3} %, \
         worst {:.3} %",
        100.0 * nonlinear.rms_error,
        100.0 * nonlinear.worst_error,
        100.0 * nonlinear.engaged,
        100.0 * nonlinear.effect_size,
        100.0 * linear.rms_error,
        100.0 * linear.worst_error,
    );
    for (part, o) in [("nonlinear", &nonlinear), ("linear", &linear)] {
        assert!(
            o.rms_error < 0.02,
            "{label} {part}: RMS error {:.3} % >= 2 %",
            100.0 * o.rms_error
        );
        assert!(
            o.worst_error < 0.05,
            "{label} {part}: worst error {:.3} % of peak >= 5 %",
            100.0 * o.worst_error
        );
    }
    assert!(
        nonlinear.rms_error < linear.rms_error + 0.005,
        "{label}: the effects add {:.3} % RMS error to the linear scheme's {:.3} %",
        100.0 * (nonlinear.rms_error - linear.rms_error),
        100.0 * linear.rms_error
    );
    assert!(
        nonlinear.engaged > 0.05,
        "{label}: stops engaged in {:.1} % of samples only",
        100.0 * nonlinear.engaged
    );
    assert!(
        nonlinear.effect_size > 10.0 * nonlinear.rms_error.max(0.005),
        "{label}: the effects change the force by {:.2} % only",
        100.0 * nonlinear.effect_size
    );
}

/// The excitations used while writing the scheme.
#[test]
fn the_board_matches_the_structure_on_the_development_inputs() {
    for seed in 1..=3 {
        check(
            &format!("multisine seed {seed}"),
            &Excitation::Multisine {
                seed,
                rms: (2.0e-3, 2.0e-3),
            },
        );
    }
}

/// Inputs kept back until the scheme was done.
#[test]
fn the_board_matches_the_structure_on_held_back_inputs() {
    for seed in [11, 12] {
        check(
            &format!("held-back multisine seed {seed}"),
            &Excitation::Multisine {
                seed,
                rms: (1.0e-3, 3.0e-3),
            },
        );
    }
    check("held-back sweep", &Excitation::Sweep { a: 4.0e-3 });
}
