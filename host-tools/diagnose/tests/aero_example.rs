//! The aero example's model file (`examples/half-car.toml`: the paper's half car on a
//! four-poster, heave and pitch, front and rear suspensions from the posts to the axle
//! points, down-force actuators at the axle points) against 60 s of the simulated rig's
//! half car: the rig's mass, inertia, stiffnesses and dampings 8–12 % off the file's, and a
//! bump stop in the front suspension that the file lacks (engaging at 4 mm of compression,
//! as a bump rubber under aero load). Road: independent random profiles under the front
//! and rear posts (0.5–20 Hz, 3 mm RMS each); down force: a random load (0.2–8 Hz, 1 kN RMS
//! front, 1.2 kN rear). Measurement noise: 0.5 % of each input's RMS, 0.7 % of each output's.
//! The workflow must recalibrate, name the bump stop on the front suspension with its gap
//! and stiffness, and shrink the gap.

mod common;

use common::noisy;
use mil_diagnose::{diagnose, EffectKind, Model, Options, Record};
use mil_numerics::rng::SplitMix64;
use mil_rig::plant::{AffineInterface, IdealInterface, Plant};
use mil_rig::specimen::{PlacedElement, Specimen};
use mil_structure::Element;

/// Record sample rate (Hz) and length (s).
const FS: f64 = 1000.0;
const DURATION_S: f64 = 60.0;
/// Axle positions ahead of (front) and behind (rear) the centroid (m), as in the file.
const L_F: f64 = 1.8;
const L_R: f64 = 1.4;
/// The rig's half car (the file has 550 kg, 350 kg·m², 300 kN/m, 2 kN·s/m, 240 kN/m,
/// 4 kN·s/m).
const M_B: f64 = 600.0;
const I_B: f64 = 320.0;
const K_F: f64 = 330.0e3;
const C_F: f64 = 1.8e3;
const K_R: f64 = 216.0e3;
const C_R: f64 = 4.4e3;
/// The hidden front bump stop: gap (m) and stiffness (N/m).
const BUMP_GAP: f64 = 4.0e-3;
const BUMP_K: f64 = 600.0e3;

/// The down forces are the specimen's pseudo inputs 2 and 3 (N, up positive), applied at
/// the axle points (interface channels 0 and 1).
struct DownForce;

impl IdealInterface for DownForce {
    fn forces(&self, _y: &[f64], _yd: &[f64], road: &[f64], _rr: &[f64], forces: &mut [f64]) {
        forces[0] = road[2];
        forces[1] = road[3];
    }
    fn affine(&self) -> Option<AffineInterface> {
        Some(AffineInterface {
            offset_n: vec![0.0, 0.0],
            position_n_per_m: vec![vec![0.0, 0.0]; 2],
            velocity_n_s_per_m: vec![vec![0.0, 0.0]; 2],
            road_n_per_m: vec![vec![0.0, 0.0, 1.0, 0.0], vec![0.0, 0.0, 0.0, 1.0]],
            road_rate_n_s_per_m: vec![vec![0.0; 4]; 2],
            lower_bound_n: vec![f64::NEG_INFINITY; 2],
        })
    }
}

fn half_car_record(seed: u64) -> Record {
    let front = Element::linear(K_F, C_F).with(
        EffectKind::BumpStop,
        &[("gap_m", BUMP_GAP), ("stiffness_n_per_m", BUMP_K)],
    );
    let specimen = Specimen {
        dofs: vec!["z_b".into(), "theta_b".into()],
        mass: vec![vec![M_B, 0.0], vec![0.0, I_B]],
        static_force: vec![0.0, 0.0],
        elements: vec![
            PlacedElement {
                name: "front_suspension".into(),
                element: front,
                // Compression: the front post rising towards the front axle point
                // (z_b − l_f θ).
                dof_coefficients: vec![-1.0, L_F],
                input_coefficients: vec![1.0, 0.0, 0.0, 0.0],
            },
            PlacedElement {
                name: "rear_suspension".into(),
                element: Element::linear(K_R, C_R),
                // The rear axle point is z_b + l_r θ.
                dof_coefficients: vec![-1.0, -L_R],
                input_coefficients: vec![0.0, 1.0, 0.0, 0.0],
            },
        ],
        inputs: vec![
            "road_front".into(),
            "road_rear".into(),
            "downforce_front".into(),
            "downforce_rear".into(),
        ],
        attachments: vec![vec![1.0, -L_F], vec![1.0, L_R]],
    };
    let mut plant =
        Plant::with_ideal_interface(specimen, Box::new(DownForce), 1e-4).expect("plant");
    let noise = |lo, hi, rms, s| {
        mil_identify::band_limited_noise(lo, hi, DURATION_S, FS, rms, true, seed ^ s)
    };
    let inputs = [
        noise(0.5, 20.0, 3e-3, 1),
        noise(0.5, 20.0, 3e-3, 2),
        noise(0.2, 8.0, 1.0e3, 3),
        noise(0.2, 8.0, 1.2e3, 4),
    ];
    let n = inputs[0].len();
    let dt = 1.0 / FS;
    let (mut front_axle, mut rear_axle) = (Vec::with_capacity(n), Vec::with_capacity(n));
    let mut engaged = 0usize;
    for i in 0..n {
        let s = plant.state();
        let (z, th) = (s[0], s[1]);
        front_axle.push(z - L_F * th);
        rear_axle.push(z + L_R * th);
        if inputs[0][i] - (z - L_F * th) > BUMP_GAP {
            engaged += 1;
        }
        let now: Vec<f64> = inputs.iter().map(|u| u[i]).collect();
        let next: Vec<f64> = inputs.iter().map(|u| u[(i + 1).min(n - 1)]).collect();
        plant.advance(dt, &[0.0, 0.0], &now, &next);
    }
    println!(
        "record: the front bump stop is engaged in {:.1} % of the samples",
        100.0 * engaged as f64 / n as f64
    );
    let mut rng = SplitMix64::new(seed ^ 0xABCD);
    let t: Vec<f64> = (0..n).map(|i| i as f64 * dt).collect();
    let mut columns: Vec<Vec<f64>> = inputs.iter().map(|u| noisy(u, 0.005, &mut rng)).collect();
    columns.push(noisy(&front_axle, 0.007, &mut rng));
    columns.push(noisy(&rear_axle, 0.007, &mut rng));
    Record::new(
        &t,
        [
            "road_front",
            "road_rear",
            "downforce_front",
            "downforce_rear",
            "front_axle",
            "rear_axle",
        ]
        .map(String::from)
        .to_vec(),
        columns,
    )
    .expect("record")
}

#[test]
fn aero_example_names_the_front_bump_stop() {
    let model = Model::from_toml(include_str!("../examples/half-car.toml")).expect("half-car.toml");
    let record = half_car_record(31);
    let d = diagnose(&model, &record, &Options::default()).expect("diagnose");
    println!("{}", d.summary());
    let named: Vec<(EffectKind, &str)> = d
        .named
        .iter()
        .map(|n| (n.named.effect, n.named.element.as_str()))
        .collect();
    assert_eq!(named, [(EffectKind::BumpStop, "front_suspension")]);
    let p = &d.named[0].named.parameters;
    let within = |what: &str, got: f64, truth: f64, tol: f64| {
        println!(
            "{what}: {got:.6e} vs {truth:.6e} (tolerance {:.0} %)",
            100.0 * tol
        );
        assert!(
            (got - truth).abs() <= tol * truth.abs(),
            "{what}: {got} vs {truth}"
        );
    };
    within("gap", p["gap_m"], BUMP_GAP, 0.10);
    within("stop stiffness", p["stiffness_n_per_m"], BUMP_K, 0.15);
    let rec = |key: &str| d.recalibrated[key];
    within("body mass", rec("z_b.mass"), M_B, 0.03);
    within("pitch inertia", rec("theta_b.mass"), I_B, 0.03);
    within(
        "front stiffness",
        rec("front_suspension.stiffness_n_per_m"),
        K_F,
        0.03,
    );
    within(
        "rear stiffness",
        rec("rear_suspension.stiffness_n_per_m"),
        K_R,
        0.03,
    );
    println!(
        "gap: {:.4} as given, {:.4} recalibrated, {:.4} updated",
        d.gap_before.nrmse, d.gap_recalibrated.nrmse, d.gap_after.nrmse
    );
    assert!(d.gap_after.nrmse < 0.5 * d.gap_recalibrated.nrmse);
    assert!(d.gap_recalibrated.nrmse < d.gap_before.nrmse);
}
