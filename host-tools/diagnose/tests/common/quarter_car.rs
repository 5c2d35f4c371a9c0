//! The quarter car of the tyre example (`examples/quarter-car.toml`) on a track-like road, made by
//! the simulated rig (`mil-rig`), with two effects the model file lacks: the tyre lifts off
//! (it can only push) and the suspension damper is asymmetric (1.5 kN·s/m in bump,
//! 3.5 kN·s/m in rebound). The rig's linear parameters are 8–12 % away from the model
//! file's. Shared by the benchmark (`examples/tyre_benchmark.rs`) and the tyre test
//! (`tests/tyre_example.rs`).

// Each user takes its own part of this module.
#![allow(dead_code)]

use mil_diagnose::Record;
use mil_numerics::rng::SplitMix64;
use mil_rig::plant::{AffineInterface, IdealInterface, Plant};
use mil_rig::specimen::{PlacedElement, Specimen, GRAVITY_M_PER_S2};
use mil_structure::{EffectKind, Element};

/// Record sample rate (Hz).
pub const FS: f64 = 1000.0;
/// The rig's quarter car (true values; `quarter-car.toml` has 150 kg, 20 kg, 120 kN/m, 2.5 kN·s/m,
/// 250 kN/m, 500 N·s/m).
pub const M_S: f64 = 150.0;
/// Unsprung mass (kg).
pub const M_U: f64 = 20.0;
/// Suspension stiffness (N/m), −10 % vs the model file.
pub const K_C: f64 = 108.0e3;
/// Suspension damping in bump (N·s/m).
pub const C_BUMP: f64 = 1.5e3;
/// Suspension damping in rebound (N·s/m).
pub const C_REBOUND: f64 = 3.5e3;
/// Tyre stiffness (N/m), +10 %.
pub const K_T: f64 = 275.0e3;
/// Tyre damping (N·s/m), −10 %.
pub const C_T: f64 = 450.0;

/// Measurement noise on the road column (fraction of its clean RMS).
pub const INPUT_NOISE: f64 = 0.005;
/// Measurement noise on the output columns (fraction of their clean RMS).
pub const OUTPUT_NOISE: f64 = 0.007;

/// No actuator force: the quarter car is driven by the road only.
pub struct NoForce;

impl IdealInterface for NoForce {
    fn forces(&self, _y: &[f64], _yd: &[f64], _road: &[f64], _rr: &[f64], forces: &mut [f64]) {
        forces[0] = 0.0;
    }
    fn affine(&self) -> Option<AffineInterface> {
        Some(AffineInterface {
            offset_n: vec![0.0],
            position_n_per_m: vec![vec![0.0, 0.0]],
            velocity_n_s_per_m: vec![vec![0.0, 0.0]],
            road_n_per_m: vec![vec![0.0]],
            road_rate_n_s_per_m: vec![vec![0.0]],
            lower_bound_n: vec![f64::NEG_INFINITY],
        })
    }
}

/// The track-like road (m), see the module documentation.
pub fn track_road(duration_s: f64, seed: u64) -> Vec<f64> {
    let mut w = mil_identify::band_limited_noise(0.5, 20.0, duration_s, FS, 3e-3, true, seed);
    let (height, len) = (30e-3, (0.08 * FS) as usize);
    let every = (1.7 * FS) as usize;
    let mut start = (0.5 * FS) as usize;
    while start + len < w.len() {
        for k in 0..len {
            let s = k as f64 / len as f64;
            w[start + k] += height * (std::f64::consts::PI * s).sin();
        }
        start += every;
    }
    w
}

/// Adds white noise of `fraction` × the signal's RMS.
pub fn noisy(clean: &[f64], fraction: f64, rng: &mut SplitMix64) -> Vec<f64> {
    let rms = (clean.iter().map(|v| v * v).sum::<f64>() / clean.len() as f64).sqrt();
    clean
        .iter()
        .map(|v| v + fraction * rms * rng.normal())
        .collect()
}

/// Simulates the quarter car over `road` and returns the record with `quarter-car.toml`'s columns.
pub fn quarter_car_record(road: &[f64], seed: u64) -> Record {
    let g = GRAVITY_M_PER_S2;
    let suspension = Element::linear(K_C, 0.5 * (C_BUMP + C_REBOUND))
        .with_preload(M_S * g)
        .with(
            EffectKind::AsymmetricDamping,
            &[("bump_n_s_per_m", C_BUMP), ("rebound_n_s_per_m", C_REBOUND)],
        );
    let tyre_preload = (M_S + M_U) * g;
    let tyre = Element::linear(K_T, C_T)
        .with_preload(tyre_preload)
        .with(EffectKind::LiftOff, &[]);
    // The tyre's law relative to its preload, unpacked once for the loop below.
    let tyre_law = tyre.compile().expect("tyre law");
    let specimen = Specimen {
        dofs: vec!["x_s".into(), "x_u".into()],
        mass: vec![vec![M_S, 0.0], vec![0.0, M_U]],
        static_force: vec![-M_S * g, -M_U * g],
        elements: vec![
            PlacedElement {
                name: "suspension".into(),
                element: suspension,
                // Compression: the hub rising towards the body.
                dof_coefficients: vec![-1.0, 1.0],
                input_coefficients: vec![0.0],
            },
            PlacedElement {
                name: "tyre".into(),
                element: tyre.clone(),
                // Compression: the road rising towards the hub.
                dof_coefficients: vec![0.0, -1.0],
                input_coefficients: vec![1.0],
            },
        ],
        inputs: vec!["road".into()],
        // The (forceless) interface channel sits on the hub.
        attachments: vec![vec![0.0, 1.0]],
    };
    let mut plant = Plant::with_ideal_interface(specimen, Box::new(NoForce), 1e-4).expect("plant");
    let dt = 1.0 / FS;
    let n = road.len();
    let (mut body, mut hub, mut force) = (
        Vec::with_capacity(n),
        Vec::with_capacity(n),
        Vec::with_capacity(n),
    );
    let mut airborne = 0usize;
    for i in 0..n {
        let s = plant.state();
        let (xs, xu, vu) = (s[0], s[1], s[3]);
        let road_rate = if i + 1 < n {
            (road[i + 1] - road[i]) * FS
        } else {
            0.0
        };
        let f = tyre.preload_n + tyre_law.force(road[i] - xu, road_rate - vu, 0.0);
        if f <= 0.0 {
            airborne += 1;
        }
        body.push(xs);
        hub.push(xu);
        force.push(f - tyre_preload);
        let next = road[(i + 1).min(n - 1)];
        plant.advance(dt, &[0.0], &[road[i]], &[next]);
    }
    println!(
        "record: the tyre is off the road in {:.2} % of the samples",
        100.0 * airborne as f64 / n as f64
    );
    let mut rng = SplitMix64::new(seed ^ 0xABCD);
    let t: Vec<f64> = (0..n).map(|i| i as f64 * dt).collect();
    Record::new(
        &t,
        vec![
            "road".into(),
            "body".into(),
            "hub".into(),
            "tyre_force".into(),
        ],
        vec![
            noisy(road, INPUT_NOISE, &mut rng),
            noisy(&body, OUTPUT_NOISE, &mut rng),
            noisy(&hub, OUTPUT_NOISE, &mut rng),
            noisy(&force, OUTPUT_NOISE, &mut rng),
        ],
    )
    .expect("record")
}
