//! Real-time factor of the simulated rig: the tyre example (one quarter car on the hub
//! actuator, model-core's tyre controller step, the emulated system alongside) at a 5 kHz
//! control rate, simulated seconds per wall-clock second. Target: at least 1000 on one core.
//!
//! `cargo run --release -p mil-rig --example realtime_factor [-- <rate_hz> <seconds> <internal_step_s>]`

use mil_rig::harness::{run, Instrumentation};
use mil_rig::rigs::{paper_tyre_part, tyre_controller, tyre_input};
use model_core::{DemandLimits, TyreParams};

fn main() {
    let mut args = std::env::args().skip(1);
    let fs: f64 = args.next().and_then(|a| a.parse().ok()).unwrap_or(5000.0);
    let seconds: f64 = args.next().and_then(|a| a.parse().ok()).unwrap_or(20.0);
    let internal_step_s: f64 = args
        .next()
        .and_then(|a| a.parse().ok())
        .unwrap_or(mil_rig::DEFAULT_INTERNAL_STEP_S);
    let mut parts = vec![paper_tyre_part(internal_step_s).expect("rig")];
    let n = (fs * seconds) as usize;
    let road: Vec<Vec<f64>> = vec![(0..n)
        .map(|k| {
            let t = k as f64 / fs;
            1e-3 * (std::f64::consts::TAU * (1.0 + 0.5 * t) * t).sin()
        })
        .collect()];
    let limits = DemandLimits {
        min: -20_000.0,
        max: 20_000.0,
        rate: 1.0e9,
    };
    let mut controller = tyre_controller(TyreParams::PAPER, limits, fs).expect("controller");
    let started = std::time::Instant::now();
    let (h, _) = run(
        &mut controller,
        &mut parts,
        &Instrumentation::default(),
        fs,
        &road,
        &[f64::from(TyreParams::PAPER.static_load)],
        tyre_input,
        |_| {},
    )
    .expect("run");
    let wall = started.elapsed().as_secs_f64();
    assert_eq!(h.len(), n);
    println!(
        "tyre example, {fs:.0} Hz control, internal step {:.0} us, {seconds:.0} s simulated in {wall:.3} s: real-time factor {:.0}x ({:.0} ns per control step)",
        internal_step_s * 1e6,
        seconds / wall,
        wall / n as f64 * 1e9
    );
}
