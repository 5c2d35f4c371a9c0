//! Long-run drift: 10 simulated minutes at 5 kHz (3 million steps) of the f32 real-time code
//! against an f64 reference of the same discretisation.
//!
//! Two systems, each driven by a sum of sines plus deterministic noise:
//! 1. the 2-DOF substructure (Tustin, computed by model-core) vs the same Tustin system
//!    computed independently in f64 by `mil-discretise` and run with nalgebra;
//! 2. a command-filter cascade with a 1 Hz, ζ = 0.05 resonance and a 30 Hz section, designed
//!    by `mil-discretise` (ZOH), run in model-core's f32 delta form vs the f64 state space.
//!
//! Bound (stated and asserted): the RMS error over every minute stays below 1e-5 of the RMS
//! output, and the last minute's error is no more than 2x the first minute's (no drift).

use mil_discretise::{tustin_ss, zoh_ss, StateSpace, Zpk};
use mil_integration_tests::ReferenceSystem;
use model_core::{Causality, Model, ModelInput, SubstructureModel, SubstructureParams};
use nalgebra::{DMatrix, DVector};

const FS: f64 = 5000.0;
const MINUTES: usize = 10;
const PER_MINUTE: usize = 60 * 5000;

/// Deterministic excitation: three sines (0.7, 3.1 and 13 Hz) plus uniform noise.
struct Excitation {
    k: u64,
    seed: u64,
}

impl Excitation {
    fn next(&mut self) -> f64 {
        let t = self.k as f64 / FS;
        self.k += 1;
        self.seed = self
            .seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        let noise = ((self.seed >> 11) as f64 / (1u64 << 53) as f64) - 0.5;
        let tau = 2.0 * std::f64::consts::PI;
        0.6 * (tau * 0.7 * t).sin()
            + 0.3 * (tau * 3.1 * t).sin()
            + 0.1 * (tau * 13.0 * t).sin()
            + 0.2 * noise
    }
}

struct MinuteStats {
    err2: f64,
    ref2: f64,
    n: usize,
}

/// Runs `MINUTES` minutes of samples; `sample` returns `(f32 output - f64 reference, f64
/// reference)` per output value, summed into per-minute statistics.
fn run_minutes(mut sample: impl FnMut(&mut MinuteStats)) -> Vec<MinuteStats> {
    (0..MINUTES)
        .map(|_| {
            let mut s = MinuteStats {
                err2: 0.0,
                ref2: 0.0,
                n: PER_MINUTE,
            };
            for _ in 0..PER_MINUTE {
                sample(&mut s);
            }
            s
        })
        .collect()
}

impl MinuteStats {
    fn add(&mut self, err: f64, reference: f64) {
        self.err2 += err * err;
        self.ref2 += reference * reference;
    }
}

fn check(label: &str, minutes: &[MinuteStats]) {
    let rel: Vec<f64> = minutes
        .iter()
        .map(|m| (m.err2 / m.n as f64).sqrt() / (m.ref2 / m.n as f64).sqrt())
        .collect();
    println!(
        "{label}: relative RMS error per minute: {:?}",
        rel.iter().map(|r| format!("{r:.2e}")).collect::<Vec<_>>()
    );
    for (i, r) in rel.iter().enumerate() {
        assert!(
            *r < 1e-5,
            "{label}: minute {i}: relative RMS error {r:e} >= 1e-5"
        );
    }
    let (first, last) = (rel[0], rel[rel.len() - 1]);
    assert!(
        last <= 2.0 * first + 1e-7,
        "{label}: drift: first minute {first:e}, last {last:e}"
    );
}

#[test]
fn substructure_f32_does_not_drift_from_f64_over_10_minutes() {
    // Lim et al. style 2-DOF: masses 10 and 5 kg, ground springs 4e4 and 2e4 N/m to two road
    // inputs, coupling spring 1e4 N/m and damper 5 N s/m, dampers 20 and 10 N s/m from each
    // mass to fixed ground (modes at 10.1 and 13.3 Hz, ζ ≈ 1-2 %). Every mode must be damped:
    // an undamped mode has |z| = 1, and f32 rounding of its coefficients moves it by ~1e-11,
    // so f32 and f64 runs of an undamped model separate in phase without bound.
    let (m1, m2, k1, k2, ki, c1, c2, ci) = (10.0, 5.0, 4.0e4, 2.0e4, 1.0e4, 20.0, 10.0, 5.0);
    let mut p = SubstructureParams::<2>::zeroed(2, Causality::Admittance);
    p.mass[0][0] = m1 as f32;
    p.mass[1][1] = m2 as f32;
    p.stiffness[0][0] = ki as f32;
    p.stiffness[1][1] = ki as f32;
    p.stiffness[0][1] = -ki as f32;
    p.stiffness[1][0] = -ki as f32;
    p.damping[0][0] = (ci + c1) as f32;
    p.damping[1][1] = (ci + c2) as f32;
    p.damping[0][1] = -ci as f32;
    p.damping[1][0] = -ci as f32;
    p.ground_stiffness[0][0] = k1 as f32;
    p.ground_stiffness[1][1] = k2 as f32;
    p.interface[1].dof = 1;
    // The dampers go to fixed ground, not to the road, so the road enters through stiffness
    // only and the f64 reference needs no road-velocity estimator.
    let dt = 1.0 / FS;
    let prepared = SubstructureModel::<2>::prepare(&p, dt as f32).expect("valid");
    let mut model = SubstructureModel::<2>::new();

    // Continuous model for the reference: states [x1 x2 v1 v2], inputs [F1 F2 z1 z2]
    // (admittance: measured interface forces act with a minus sign), outputs [x1 x2].
    let mut a = DMatrix::<f64>::zeros(4, 4);
    a[(0, 2)] = 1.0;
    a[(1, 3)] = 1.0;
    let kk = [[k1 + ki, -ki], [-ki, k2 + ki]];
    let cc = [[ci + c1, -ci], [-ci, ci + c2]];
    let mm = [m1, m2];
    for i in 0..2 {
        for j in 0..2 {
            a[(2 + i, j)] = -kk[i][j] / mm[i];
            a[(2 + i, 2 + j)] = -cc[i][j] / mm[i];
        }
    }
    let mut b = DMatrix::<f64>::zeros(4, 4);
    b[(2, 0)] = -1.0 / m1;
    b[(3, 1)] = -1.0 / m2;
    b[(2, 2)] = k1 / m1;
    b[(3, 3)] = k2 / m2;
    let mut c = DMatrix::<f64>::zeros(2, 4);
    c[(0, 0)] = 1.0;
    c[(1, 1)] = 1.0;
    let ss = StateSpace::new(a, b, c, DMatrix::zeros(2, 4)).expect("state space");
    let d = tustin_ss(&ss, dt, None).expect("tustin");
    let mut reference = ReferenceSystem {
        phi: d.phi(),
        gamma: d.gamma.clone(),
        c: d.c.clone(),
        d: d.d.clone(),
        x: DVector::zeros(4),
    };

    let mut road = Excitation { k: 0, seed: 1 };
    let mut force = Excitation { k: 17, seed: 2 };
    let minutes = run_minutes(|s| {
        let z = 0.01 * road.next(); // m
        let f = 200.0 * force.next(); // N
                                      // Inputs are rounded to f32 once, as they would arrive over the bus; the reference
                                      // uses the same rounded values so only the arithmetic differs.
        let (zf, ff) = (z as f32, f as f32);
        let input = ModelInput {
            force: [ff, 0.0],
            road: [zf, 0.0],
            ..ModelInput::default()
        };
        let y = model.step(&prepared, &input);
        let u = DVector::from_vec(vec![f64::from(ff), 0.0, f64::from(zf), 0.0]);
        let y_ref = reference.step(&u);
        for (y, r) in y.iter().zip(y_ref.iter()) {
            s.add(f64::from(*y) - r, *r);
        }
    });
    check("2-DOF substructure", &minutes);
}

#[test]
fn command_filter_f32_does_not_drift_from_f64_over_10_minutes() {
    let dt = 1.0 / FS;
    // 1 Hz resonance (ζ = 0.05) times a 30 Hz, ζ = 0.7 low-pass: a slow pole pair at
    // 1 - 1.3e-5 from z = 1 (the hard case for f32) plus an ordinary one.
    let slow = Zpk::second_order_lowpass(1.0, 0.05).expect("zpk");
    let fast = Zpk::second_order_lowpass(30.0, 0.7).expect("zpk");
    let both = Zpk::new(
        vec![],
        slow.poles.iter().chain(&fast.poles).copied().collect(),
        slow.gain * fast.gain,
    )
    .expect("zpk");
    let cascade = mil_discretise::zoh(&both, dt)
        .expect("zoh")
        .to_cascade()
        .expect("cascade");
    let mut filter = model_core::Cascade::new(cascade);
    let dss = zoh_ss(&both.to_state_space().expect("ss"), dt).expect("zoh ss");
    let n = dss.delta.nrows();
    let mut reference = ReferenceSystem {
        phi: dss.phi(),
        gamma: dss.gamma.clone(),
        c: dss.c.clone(),
        d: dss.d.clone(),
        x: DVector::zeros(n),
    };
    let mut input = Excitation { k: 0, seed: 3 };
    let minutes = run_minutes(|s| {
        let u = input.next() as f32;
        let y = f64::from(filter.step(u));
        let y_ref = reference.step(&DVector::from_vec(vec![f64::from(u)]))[0];
        s.add(y - y_ref, y_ref);
    });
    check("1 Hz + 30 Hz command filter", &minutes);
}
