//! The closed-loop harness: model-core's controller step against the simulated rig, and the
//! emulated system (the ideal coupling) on the same road input.
//!
//! Timing of one control sample `k` (period `T`):
//!
//! 1. the rig's transducers sample the plant at `t_k` (sensors: noise, quantisation,
//!    bandwidth), and the values cross the CAN link to the board (fixed-point scaling, link
//!    delay, dropped or corrupted frames);
//! 2. the board runs [`model_core::Controller::step`] (the code that runs on the board);
//! 3. the demand crosses the link back, and the rig's servo controller applies it from
//!    `t_{k+1}` and holds it for one period.
//!
//! With ideal sensors and no link delay the demand computed from the sample at `t_k` acts
//! over `[t_{k+1}, t_{k+2})`: a loop delay of 1.5 samples (one sample of transport and
//! computation plus half a sample of hold), the analysis' default. Each link delay sample
//! adds one. A dropped frame leaves the receiver with the last value it received (and is
//! counted); a corrupted frame delivers its wrong value, which the board's input validation
//! must catch.

use crate::link::{CanLink, LinkSpec, Received};
use crate::plant::{Plant, PlantOutputs};
use crate::sensors::{Sensor, SensorSpec};
use model_core::{Controller, Model, ModelInput, Status};

/// Sensors and links of every channel (the same spec on every channel).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Instrumentation {
    /// Displacement transducer at each attachment (m).
    pub position_sensor: SensorSpec,
    /// Load cell (N).
    pub force_sensor: SensorSpec,
    /// Link carrying the measured position to the board (m).
    pub position_link: LinkSpec,
    /// Link carrying the measured force to the board (N).
    pub force_link: LinkSpec,
    /// Link carrying the demand to the rig (N).
    pub demand_link: LinkSpec,
}

/// One plant of the rig and the controller channels it serves: channels
/// `first_channel .. first_channel + plant.channels()`.
pub struct RigPart {
    /// The MiL plant (actuators on the specimen).
    pub mil: Plant,
    /// The emulated plant (the same specimen with the ideal interface).
    pub emulated: Plant,
    /// First controller channel of this plant.
    pub first_channel: usize,
    /// Which of the run's road inputs drive the MiL plant's specimen inputs (indices).
    pub mil_inputs: Vec<usize>,
    /// Which of the run's road inputs drive the emulated plant's inputs (indices): its
    /// specimen's, plus those the numerical model takes (e.g. the road under the tyre).
    pub emulated_inputs: Vec<usize>,
}

/// Time histories of a run (SI units), one row per control sample.
#[derive(Clone, Debug, Default)]
pub struct Histories {
    /// Sample times (s).
    pub time: Vec<f64>,
    /// Road inputs per sample (m).
    pub road: Vec<Vec<f64>>,
    /// Demand computed by the controller per sample and channel (N).
    pub demand: Vec<Vec<f64>>,
    /// MiL rig per sample: attachment position per channel (m).
    pub mil_position: Vec<Vec<f64>>,
    /// MiL rig per sample: load-cell force per channel (N).
    pub mil_force: Vec<Vec<f64>>,
    /// Emulated system per sample: attachment position per channel (m).
    pub emulated_position: Vec<Vec<f64>>,
    /// Emulated system per sample: interface force per channel (N).
    pub emulated_force: Vec<Vec<f64>>,
    /// Controller status per sample.
    pub status: Vec<Status>,
}

/// Link statistics of a run.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct LinkStatistics {
    /// Frames sent (all links, all channels).
    pub frames: u64,
    /// Frames dropped.
    pub dropped: u64,
    /// Frames corrupted.
    pub corrupted: u64,
}

/// Errors of the harness set-up.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum HarnessError {
    /// A sensor spec is invalid.
    #[error("sensor: {0}")]
    Sensor(String),
    /// A link spec is invalid.
    #[error("link: {0}")]
    Link(String),
    /// Inconsistent channels or inputs.
    #[error("{0}")]
    Layout(String),
}

struct Channel {
    position_sensor: Sensor,
    force_sensor: Sensor,
    position_link: CanLink,
    force_link: CanLink,
    demand_link: CanLink,
    received_position: f64,
    received_force: f64,
    received_demand: f64,
}

fn receive(r: Received, last: &mut f64) {
    match r {
        Received::Value(v) | Received::Corrupted(v) => *last = v,
        Received::Dropped => {}
    }
}

/// Runs `controller` (started by the harness) against `parts` for every road sample.
/// `input` builds the controller's input from the received measurements (position and force
/// per channel), the road sample and the sample index; `initial_demand` (N per channel) is
/// the static demand the rig starts at rest with (the model's static output). `progress`
/// gets the fraction done now and then.
///
/// # Errors
/// Invalid sensors or links, or parts that do not cover the controller's channels.
#[allow(clippy::too_many_arguments)]
pub fn run<M: Model<CH>, const CH: usize>(
    controller: &mut Controller<M, CH>,
    parts: &mut [RigPart],
    instrumentation: &Instrumentation,
    sample_rate_hz: f64,
    road: &[Vec<f64>],
    initial_demand: &[f64; CH],
    input: impl Fn(&[f64; CH], &[f64; CH], &[f64], usize) -> ModelInput<CH>,
    mut progress: impl FnMut(f64),
) -> Result<(Histories, LinkStatistics), HarnessError> {
    let covered: usize = parts.iter().map(|p| p.mil.channels()).sum();
    if covered != CH {
        return Err(HarnessError::Layout(format!(
            "the rig's plants serve {covered} channels, the controller has {CH}"
        )));
    }
    let dt = 1.0 / sample_rate_hz;
    let inputs = road.first().map_or(0, Vec::len);
    for p in parts.iter() {
        let bad = |plant: &Plant, map: &[usize]| {
            map.len() != plant.specimen().inputs.len() || map.iter().any(|&i| i >= inputs)
        };
        if bad(&p.mil, &p.mil_inputs) || bad(&p.emulated, &p.emulated_inputs) {
            return Err(HarnessError::Layout(
                "specimen inputs do not match the road inputs".into(),
            ));
        }
    }
    let mut channels = Vec::with_capacity(CH);
    for (c, &static_demand) in initial_demand.iter().enumerate() {
        let seed = 1000 * c as u64;
        let sensor = |spec: &SensorSpec, s: u64| {
            Sensor::new(spec, sample_rate_hz, s).map_err(|e| HarnessError::Sensor(e.to_string()))
        };
        let link = |spec: &LinkSpec, s: u64| {
            CanLink::new(&LinkSpec {
                seed: spec.seed.wrapping_add(s),
                ..spec.clone()
            })
            .map_err(|e| HarnessError::Link(e.to_string()))
        };
        channels.push(Channel {
            position_sensor: sensor(&instrumentation.position_sensor, seed + 1)?,
            force_sensor: sensor(&instrumentation.force_sensor, seed + 2)?,
            position_link: link(&instrumentation.position_link, seed + 3)?,
            force_link: link(&instrumentation.force_link, seed + 4)?,
            demand_link: link(&instrumentation.demand_link, seed + 5)?,
            received_position: 0.0,
            received_force: static_demand,
            received_demand: static_demand,
        });
    }
    // At rest: plants at equilibrium, sensors and links settled on the static values.
    let pick = |map: &[usize], w: &[f64]| -> Vec<f64> { map.iter().map(|&i| w[i]).collect() };
    for p in parts.iter_mut() {
        let range = p.first_channel..p.first_channel + p.mil.channels();
        p.mil.rest(&initial_demand[range.clone()]);
        p.emulated.rest(&initial_demand[range]);
    }
    for (c, ch) in channels.iter_mut().enumerate() {
        ch.position_sensor.reset(0.0);
        ch.force_sensor.reset(initial_demand[c]);
        ch.position_link.prime(0.0);
        ch.force_link.prime(initial_demand[c]);
        ch.demand_link.prime(initial_demand[c]);
    }
    controller.start();

    let n = road.len();
    let mut h = Histories {
        time: Vec::with_capacity(n),
        road: road.to_vec(),
        demand: Vec::with_capacity(n),
        mil_position: Vec::with_capacity(n),
        mil_force: Vec::with_capacity(n),
        emulated_position: Vec::with_capacity(n),
        emulated_force: Vec::with_capacity(n),
        status: Vec::with_capacity(n),
    };
    let mut applied: Vec<f64> = initial_demand.to_vec();
    for (k, w) in road.iter().enumerate() {
        let next = road.get(k + 1).unwrap_or(w);
        let previous = k.checked_sub(1).and_then(|i| road.get(i)).unwrap_or(w);
        // The road ramps linearly between samples, so its rate jumps at a sample; the
        // sampled signals take the mean of the two slopes (central difference).
        let rate: Vec<f64> = previous
            .iter()
            .zip(next)
            .map(|(a, b)| (b - a) / (2.0 * dt))
            .collect();
        // 1. Sample the plants.
        let mut mil_pos = vec![0.0; CH];
        let mut mil_force = vec![0.0; CH];
        let mut emu_pos = vec![0.0; CH];
        let mut emu_force = vec![0.0; CH];
        for p in parts.iter_mut() {
            let range = p.first_channel..p.first_channel + p.mil.channels();
            let out: PlantOutputs = p.mil.outputs(
                &applied[range.clone()],
                &pick(&p.mil_inputs, w),
                &pick(&p.mil_inputs, &rate),
            );
            mil_pos[range.clone()].copy_from_slice(&out.position);
            mil_force[range.clone()].copy_from_slice(&out.force);
            let out = p.emulated.outputs(
                &applied[range.clone()],
                &pick(&p.emulated_inputs, w),
                &pick(&p.emulated_inputs, &rate),
            );
            emu_pos[range.clone()].copy_from_slice(&out.position);
            emu_force[range].copy_from_slice(&out.force);
        }
        // 2. Transducers and the link to the board.
        let mut position = [0.0; CH];
        let mut force = [0.0; CH];
        for (c, ch) in channels.iter_mut().enumerate() {
            let p = ch.position_sensor.measure(mil_pos[c]);
            let f = ch.force_sensor.measure(mil_force[c]);
            receive(ch.position_link.transfer(p), &mut ch.received_position);
            receive(ch.force_link.transfer(f), &mut ch.received_force);
            position[c] = ch.received_position;
            force[c] = ch.received_force;
        }
        // 3. The board's step.
        let demand = controller.step(&input(&position, &force, w, k));
        let status = controller.status();
        // 4. The demand back to the rig, applied from the next sample.
        let mut next_applied = applied.clone();
        for (c, ch) in channels.iter_mut().enumerate() {
            receive(
                ch.demand_link.transfer(f64::from(demand[c])),
                &mut ch.received_demand,
            );
            next_applied[c] = ch.received_demand;
        }
        // 5. Advance both plants over [t_k, t_{k+1}] with the demand received before.
        for p in parts.iter_mut() {
            let range = p.first_channel..p.first_channel + p.mil.channels();
            p.mil.advance(
                dt,
                &applied[range.clone()],
                &pick(&p.mil_inputs, w),
                &pick(&p.mil_inputs, next),
            );
            p.emulated.advance(
                dt,
                &applied[range],
                &pick(&p.emulated_inputs, w),
                &pick(&p.emulated_inputs, next),
            );
        }
        applied = next_applied;

        h.time.push(k as f64 * dt);
        h.demand
            .push(demand.iter().map(|v| f64::from(*v)).collect());
        h.mil_position.push(mil_pos);
        h.mil_force.push(mil_force);
        h.emulated_position.push(emu_pos);
        h.emulated_force.push(emu_force);
        h.status.push(status);
        if k % 8192 == 0 {
            progress(k as f64 / n.max(1) as f64);
        }
    }
    progress(1.0);
    let mut stats = LinkStatistics::default();
    for ch in &channels {
        for l in [&ch.position_link, &ch.force_link, &ch.demand_link] {
            let c = l.counts();
            stats.frames += c.sent;
            stats.dropped += c.dropped;
            stats.corrupted += c.corrupted;
        }
    }
    Ok((h, stats))
}
