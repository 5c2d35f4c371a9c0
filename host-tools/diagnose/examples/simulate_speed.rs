//! Speed of the workflow's simulation (the inner loop of the output-error refinement):
//! the tyre example (`examples/quarter-car.toml`, lift-off and asymmetric damping on) over
//! 420 000 samples of a random road at 1 kHz, outputs only, fastest of 5 runs.
//!
//! ```text
//! cargo run --release -p mil-diagnose --example simulate_speed [-- SAMPLES]
//! ```

use mil_diagnose::simulate::{prepare_inputs, simulate_outputs};
use mil_diagnose::{Model, Record};
use std::time::Instant;

fn main() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/quarter-car.toml");
    let mut model = Model::from_toml(&std::fs::read_to_string(path).expect("quarter-car.toml"))
        .expect("quarter-car.toml");
    model.elements[1].law.lift_off = Some(1667.0);
    model.elements[0].law.c_abs = Some(-1000.0);
    let n = std::env::args()
        .nth(1)
        .map_or(420_000, |a| a.parse().expect("SAMPLES: a number"));
    let dt = 1e-3;
    let mut s = 0x1234_5678u64;
    let mut road = Vec::with_capacity(n);
    let mut y = 0.0;
    for _ in 0..n {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        y = 0.995 * y + 1e-4 * ((s >> 11) as f64 / (1u64 << 53) as f64 - 0.5);
        road.push(y);
    }
    let t: Vec<f64> = (0..n).map(|i| i as f64 * dt).collect();
    let zeros = vec![0.0; n];
    let record = Record::new(
        &t,
        vec![
            "road".into(),
            "body".into(),
            "hub".into(),
            "tyre_force".into(),
        ],
        vec![road, zeros.clone(), zeros.clone(), zeros],
    )
    .expect("record");
    let inputs = prepare_inputs(&model, &record).expect("inputs");
    let mut best = f64::INFINITY;
    let mut check = 0.0;
    for _ in 0..5 {
        let t0 = Instant::now();
        let sim = simulate_outputs(&model, &record, &inputs, 0..n, None).expect("simulate");
        best = best.min(t0.elapsed().as_secs_f64());
        check = sim.outputs[2].iter().map(|v| v.abs()).sum::<f64>();
    }
    println!(
        "simulate: {n} samples in {:.1} ms (fastest of 5): {:.1} ns per sample (checksum {check:.6e})",
        best * 1e3,
        best * 1e9 / n as f64
    );
}
