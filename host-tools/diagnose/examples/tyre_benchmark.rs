//! Benchmark of issue 6: time to diagnose 10 minutes of 1 kHz data for the tyre example
//! (`examples/quarter-car.toml`) with the full candidate library and default options (target:
//! under 30 s on 2 cores).
//!
//! ```text
//! cargo run --release -p mil-diagnose --example tyre_benchmark [-- SECONDS]
//! ```
//!
//! The record is made by the simulated rig (`mil-rig`): the paper's whole quarter car on
//! the road (body 150 kg on the suspension, hub 20 kg on the tyre, the road a prescribed
//! displacement under the tyre; gravity, the suspension preloaded by the body's weight, the
//! tyre by the car's), with the rig's true linear parameters 8–12 % away from the model
//! file's (so the workflow has to recalibrate) and two effects the model file lacks: the
//! tyre lifts off (it can only push) and the suspension damper is asymmetric (1.5 kN·s/m in
//! bump, 3.5 kN·s/m in rebound). The road is track-like: a pink random profile (0.5–20 Hz,
//! 3 mm RMS) with a 30 mm half-sine kerb of 80 ms every 1.7 s. The record holds the columns
//! of `quarter-car.toml`: `road`, `body`, `hub` (m, deviations from the static equilibrium) and
//! `tyre_force` (N, positive in compression, deviation from the static wheel load, as a
//! load cell zeroed at rest reads it), each with white measurement noise of 0.5 % (road)
//! or 0.7 % (outputs) of its clean RMS.
//!
//! Printed: the record length, the wall time and the process CPU time of `diagnose` (the
//! simulation that makes the record is not timed), the named effects with their
//! parameters, the recalibrated parameters, the gap before → after, and the target.

use cpu_time::{ProcessTime, ThreadTime};
use mil_diagnose::{diagnose, Model, Options};
use std::time::Instant;

#[path = "../tests/common/quarter_car.rs"]
mod quarter_car;
use mil_rig::specimen::GRAVITY_M_PER_S2;
use quarter_car::*;

/// Record length by default (s): 10 minutes.
const DURATION_S: f64 = 600.0;
/// Target of the issue (s).
const TARGET_S: f64 = 30.0;

fn main() {
    let duration_s = std::env::args()
        .nth(1)
        .map(|a| a.parse::<f64>().expect("SECONDS: a number"))
        .unwrap_or(DURATION_S);
    let model_path = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/quarter-car.toml");
    let model = Model::from_toml(&std::fs::read_to_string(model_path).expect("quarter-car.toml"))
        .expect("quarter-car.toml");

    let t = Instant::now();
    let record = quarter_car_record(&track_road(duration_s, 6), 6);
    println!(
        "record: {} samples ({:.0} s at {:.0} Hz), made in {:.1} s (not timed below)",
        record.len(),
        duration_s,
        FS,
        t.elapsed().as_secs_f64()
    );

    let options = Options {
        progress: std::env::var_os("DIAGNOSE_PROGRESS").is_some(),
        ..Options::default()
    };
    let (wall, cpu, process) = (Instant::now(), ThreadTime::now(), ProcessTime::now());
    let d = diagnose(&model, &record, &options).expect("diagnose");
    let (wall, cpu, process) = (
        wall.elapsed().as_secs_f64(),
        cpu.elapsed().as_secs_f64(),
        process.elapsed().as_secs_f64(),
    );

    println!("--- summary ---\n{}", d.summary());
    println!("--- figures ---");
    println!(
        "record length: {} samples, {:.0} s at {:.0} Hz",
        record.len(),
        duration_s,
        FS
    );
    println!(
        "candidates: {} effects (full library), default options",
        options.candidates.len()
    );
    println!("diagnose wall time: {wall:.2} s");
    println!(
        "diagnose process CPU time: {process:.2} s on {} worker threads (calling thread alone: {cpu:.2} s)",
        mil_diagnose::parallel::threads(options.threads)
    );
    for n in &d.named {
        println!(
            "named: {} on {}: {:?}",
            n.named.effect, n.named.element, n.named.parameters
        );
    }
    if d.named.is_empty() {
        println!("named: none");
    }
    println!(
        "truth: lift_off on tyre (preload {:.1} N), asymmetric_damping on suspension (bump {C_BUMP}, rebound {C_REBOUND} N·s/m)",
        (M_S + M_U) * GRAVITY_M_PER_S2
    );
    println!("recalibrated: {:?}", d.recalibrated);
    println!(
        "gap (NRMSE, validation part): {:.4} as given -> {:.4} recalibrated -> {:.4} updated",
        d.gap_before.nrmse, d.gap_recalibrated.nrmse, d.gap_after.nrmse
    );
    println!(
        "target: under {TARGET_S:.0} s for 600 s of data on 2 cores: {}",
        if wall < TARGET_S { "met" } else { "NOT met" }
    );
}
