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
//!
//! Between samples the road ramps linearly; at a sample the plants are sampled with the
//! mean of the two ramps' rates (central difference: a forward difference would put the
//! road rate half a sample early, 0.5° at 30 Hz in the emulated tyre force). A plant whose
//! specimen takes no road input (the hub-coupled MiL rig) reuses the sampled derivative as
//! the first stage of the integration step that follows.
//!
//! Signals are stored per channel (column-major): `histories.mil_force[c][k]` is channel
//! `c`'s load-cell force at sample `k`. The run allocates nothing per sample beyond the
//! growth of those columns.

use crate::link::{CanLink, LinkSpec, Received};
use crate::plant::Plant;
use crate::sensors::{Sensor, SensorSpec};
use model_core::{Controller, Model, ModelInput, Status};

/// What the harness steps every sample: model-core's [`Controller`] on the host, or the
/// board itself behind a transport (the firmware in QEMU, a rig board on a CAN adapter).
pub trait Board<const CH: usize> {
    /// Starts the model (the harness calls it once, with the rig at rest).
    ///
    /// # Errors
    /// The board did not start (a transport error, a refused command).
    fn start(&mut self) -> Result<(), String>;

    /// One control sample: the measured input in, the actuator demand per channel (N) out.
    ///
    /// # Errors
    /// No demand came back (a transport error or timeout).
    fn step(&mut self, input: &ModelInput<CH>) -> Result<[f32; CH], String>;

    /// The board's status after the last step.
    fn status(&self) -> Status;
}

/// The host's own controller: a controller that cannot start (a latched fault) stays in its
/// mode, which the run's status history shows; it never fails.
impl<M: Model<CH>, const CH: usize> Board<CH> for Controller<M, CH> {
    fn start(&mut self) -> Result<(), String> {
        Controller::start(self);
        Ok(())
    }

    fn step(&mut self, input: &ModelInput<CH>) -> Result<[f32; CH], String> {
        Ok(Controller::step(self, input))
    }

    fn status(&self) -> Status {
        Controller::status(self)
    }
}

/// The board's run-time controller ([`model_core::BoardController`]) on its first `CH`
/// channels (`CH` up to [`model_core::BOARD_CHANNELS`], the running configuration's count):
/// what the firmware runs, on the host.
impl<const CH: usize> Board<CH> for model_core::BoardController {
    fn start(&mut self) -> Result<(), String> {
        model_core::BoardController::start(self);
        Ok(())
    }

    fn step(&mut self, input: &ModelInput<CH>) -> Result<[f32; CH], String> {
        if CH != self.channels() {
            return Err(format!(
                "the board runs {} channel(s), the rig has {CH}",
                self.channels()
            ));
        }
        use model_core::board::fit;
        let wide = ModelInput {
            position: fit(&input.position, 0.0),
            force: fit(&input.force, 0.0),
            road: fit(&input.road, 0.0),
            speed: input.speed,
        };
        Ok(fit(&model_core::BoardController::step(self, &wide), 0.0))
    }

    fn status(&self) -> Status {
        model_core::BoardController::status(self)
    }
}

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

/// Time histories of a run (SI units), per channel (or road input) one column with a value
/// per control sample.
#[derive(Clone, Debug, Default)]
pub struct Histories {
    /// Sample times (s).
    pub time: Vec<f64>,
    /// Road inputs: per input, its samples (m).
    pub road: Vec<Vec<f64>>,
    /// Demand computed by the controller: per channel, its samples (N).
    pub demand: Vec<Vec<f64>>,
    /// MiL rig: attachment position per channel, its samples (m).
    pub mil_position: Vec<Vec<f64>>,
    /// MiL rig: load-cell force per channel, its samples (N).
    pub mil_force: Vec<Vec<f64>>,
    /// Emulated system: attachment position per channel, its samples (m).
    pub emulated_position: Vec<Vec<f64>>,
    /// Emulated system: interface force per channel, its samples (N).
    pub emulated_force: Vec<Vec<f64>>,
    /// MiL rig: every specimen DOF's displacement (m, or rad for a rotation; from the static
    /// equilibrium), what transducers beyond the actuators' would measure: per part and
    /// DOF, named `<dof>_<the part's first channel>`, its samples.
    pub mil_dofs: Vec<(String, Vec<f64>)>,
    /// Controller status per sample.
    pub status: Vec<Status>,
}

impl Histories {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.time.len()
    }

    /// Whether the run has no samples.
    pub fn is_empty(&self) -> bool {
        self.time.is_empty()
    }
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
    /// The board failed (a remote board's transport).
    #[error("board: {0}")]
    Board(String),
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

/// The road inputs' columns picked for one plant, and their rates.
struct PlantRoad {
    map: Vec<usize>,
    now: Vec<f64>,
    next: Vec<f64>,
    rate: Vec<f64>,
}

impl PlantRoad {
    fn new(map: &[usize]) -> Self {
        Self {
            map: map.to_vec(),
            now: vec![0.0; map.len()],
            next: vec![0.0; map.len()],
            rate: vec![0.0; map.len()],
        }
    }

    /// Picks samples `k` and `k + 1` (held at the ends) and the rate at sample `k`
    /// (central difference over `2 dt`).
    fn pick(&mut self, road: &[Vec<f64>], k: usize, dt: f64) {
        for (i, &input) in self.map.iter().enumerate() {
            let column = road.get(input).map_or(&[][..], Vec::as_slice);
            let now = column.get(k).copied().unwrap_or(0.0);
            let next = column.get(k + 1).copied().unwrap_or(now);
            let previous = k
                .checked_sub(1)
                .and_then(|j| column.get(j))
                .copied()
                .unwrap_or(now);
            self.now[i] = now;
            self.next[i] = next;
            self.rate[i] = (next - previous) / (2.0 * dt);
        }
    }
}

/// Runs `controller` (started by the harness) against `parts` for every sample of `road`
/// (per road input its samples, m; all inputs equally long). `input` builds the
/// controller's input from the received measurements (position and force per channel),
/// the road inputs at the sample and the sample index; `initial_demand` (N per channel) is
/// the static demand the rig starts at rest with (the model's static output). `progress`
/// gets the fraction done now and then.
///
/// # Errors
/// Invalid sensors or links, parts that do not cover the controller's channels, or road
/// inputs of unequal length.
#[allow(clippy::too_many_arguments)]
pub fn run<B: Board<CH>, const CH: usize>(
    controller: &mut B,
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
    if !(sample_rate_hz.is_finite() && sample_rate_hz > 0.0) {
        return Err(HarnessError::Layout(format!(
            "sample rate must be > 0 Hz (is {sample_rate_hz})"
        )));
    }
    let dt = 1.0 / sample_rate_hz;
    let inputs = road.len();
    let n = road.first().map_or(0, Vec::len);
    if road.iter().any(|c| c.len() != n) {
        return Err(HarnessError::Layout("road inputs of unequal length".into()));
    }
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
    controller.start().map_err(HarnessError::Board)?;

    let column = || vec![Vec::with_capacity(n); CH];
    let mut h = Histories {
        time: Vec::with_capacity(n),
        road: road.to_vec(),
        demand: column(),
        mil_position: column(),
        mil_force: column(),
        emulated_position: column(),
        emulated_force: column(),
        mil_dofs: parts
            .iter()
            .flat_map(|p| {
                p.mil
                    .specimen()
                    .dofs
                    .iter()
                    .map(|d| (format!("{d}_{}", p.first_channel), Vec::with_capacity(n)))
                    .collect::<Vec<_>>()
            })
            .collect(),
        status: Vec::with_capacity(n),
    };
    let mut roads: Vec<(PlantRoad, PlantRoad)> = parts
        .iter()
        .map(|p| {
            (
                PlantRoad::new(&p.mil_inputs),
                PlantRoad::new(&p.emulated_inputs),
            )
        })
        .collect();
    let mut sample_road = vec![0.0; inputs];
    let mut applied: [f64; CH] = *initial_demand;
    let mut mil_pos = [0.0; CH];
    let mut mil_force = [0.0; CH];
    for k in 0..n {
        for (w, column) in sample_road.iter_mut().zip(road) {
            *w = column.get(k).copied().unwrap_or(0.0);
        }
        // 1. Sample the plants.
        let mut dof_histories = h.mil_dofs.iter_mut();
        for (p, (mil_road, emu_road)) in parts.iter_mut().zip(roads.iter_mut()) {
            let range = p.first_channel..p.first_channel + p.mil.channels();
            mil_road.pick(road, k, dt);
            emu_road.pick(road, k, dt);
            p.mil
                .sample(&applied[range.clone()], &mil_road.now, &mil_road.rate);
            p.emulated
                .sample(&applied[range.clone()], &emu_road.now, &emu_road.rate);
            let dofs = p.mil.specimen().len();
            // `take` first: zip stops before drawing the next part's history.
            for (q, (_, history)) in p.mil.state().iter().take(dofs).zip(dof_histories.by_ref()) {
                history.push(*q);
            }
            mil_pos[range.clone()].copy_from_slice(p.mil.position());
            mil_force[range.clone()].copy_from_slice(p.mil.force());
            for (c, (y, f)) in range.zip(p.emulated.position().iter().zip(p.emulated.force())) {
                h.emulated_position[c].push(*y);
                h.emulated_force[c].push(*f);
            }
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
        let demand = controller
            .step(&input(&position, &force, &sample_road, k))
            .map_err(HarnessError::Board)?;
        h.status.push(controller.status());
        // 4. The demand back to the rig, applied from the next sample.
        let mut next_applied = applied;
        for (c, ch) in channels.iter_mut().enumerate() {
            receive(
                ch.demand_link.transfer(f64::from(demand[c])),
                &mut ch.received_demand,
            );
            next_applied[c] = ch.received_demand;
        }
        // 5. Advance both plants over [t_k, t_{k+1}] with the demand received before.
        for (p, (mil_road, emu_road)) in parts.iter_mut().zip(roads.iter()) {
            let range = p.first_channel..p.first_channel + p.mil.channels();
            p.mil
                .advance(dt, &applied[range.clone()], &mil_road.now, &mil_road.next);
            p.emulated
                .advance(dt, &applied[range], &emu_road.now, &emu_road.next);
        }
        applied = next_applied;

        h.time.push(k as f64 * dt);
        for c in 0..CH {
            h.demand[c].push(f64::from(demand[c]));
            h.mil_position[c].push(mil_pos[c]);
            h.mil_force[c].push(mil_force[c]);
        }
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
