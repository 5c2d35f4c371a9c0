//! The plant: a specimen driven at its attachment points either by the nonlinear actuators
//! (the MiL rig) or by an ideal interface law (the emulated system), integrated with the
//! classical fourth-order Runge–Kutta method at a fixed internal step.
//!
//! State vector: `q` (n), `q̇` (n), the elements' internal states (Bouc-Wen), then per
//! actuator `[x_v, ẋ_v, P_L, q_int]` ([`crate::actuator::state`]). Within one call of
//! [`Plant::advance`] the actuator demands are held (zero-order hold, as the rig's servo
//! controller applies each received demand) and the road inputs ramp linearly between their
//! samples.
//!
//! With actuators, each actuator's rod mass `m_a` joins the specimen's mass matrix at its
//! attachment (`M + m_a t_j t_jᵀ`), the piston force `F_p` acts on the specimen, and the
//! load cell measures `F_j = F_p,j − m_a ÿ_j` (the force on the specimen).

use crate::actuator::{ForceActuator, ACTUATOR_STATES};
use crate::specimen::{Specimen, SpecimenError};

/// The forces an ideal interface (the emulated system's numerical part, coupled without
/// actuators, delay or sampling) applies at the attachment points.
pub trait IdealInterface {
    /// Writes the force per channel (N) into `forces`, given per channel the attachment
    /// position `y` (m) and velocity `y_dot` (m/s), and per road input its value `road` (m)
    /// and rate `road_rate` (m/s).
    fn forces(&self, y: &[f64], y_dot: &[f64], road: &[f64], road_rate: &[f64], forces: &mut [f64]);
}

/// What drives the specimen.
enum Drive {
    Actuators(Vec<ForceActuator>),
    Ideal(Box<dyn IdealInterface + Send + Sync>),
}

/// Signals of the plant at one instant.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PlantOutputs {
    /// Attachment (actuator rod) position per channel `y_j` (m).
    pub position: Vec<f64>,
    /// Attachment velocity per channel (m/s).
    pub velocity: Vec<f64>,
    /// Interface force on the specimen per channel (N): the load-cell force, or the ideal
    /// interface's force.
    pub force: Vec<f64>,
    /// Generalised positions `q` (m, rad).
    pub dofs: Vec<f64>,
    /// Load pressure per actuator (Pa); empty for the ideal interface.
    pub load_pressure: Vec<f64>,
    /// Spool opening per actuator (fraction of full opening).
    pub spool: Vec<f64>,
}

/// The specimen with its drive, state and scratch space (no allocation while stepping).
pub struct Plant {
    specimen: Specimen,
    drive: Drive,
    n: usize,
    channels: usize,
    element_states: usize,
    /// Inverse of the total mass matrix, row-major.
    inv_mass: Vec<f64>,
    state: Vec<f64>,
    time_s: f64,
    internal_step_s: f64,
    // Scratch.
    k: [Vec<f64>; 4],
    tmp: Vec<f64>,
    generalised: Vec<f64>,
    accel: Vec<f64>,
    y: Vec<f64>,
    y_dot: Vec<f64>,
    forces: Vec<f64>,
    road: Vec<f64>,
    road_rate: Vec<f64>,
    /// Attachments `t_j`, row-major (channels × n).
    attachments: Vec<f64>,
    /// Elements' DOF coefficients `a_e`, row-major (elements × n).
    element_dofs: Vec<f64>,
    /// Elements' input coefficients `b_e`, row-major (elements × inputs).
    element_inputs: Vec<f64>,
    /// The first RK4 stage `k[0]` holds the derivative at the current state for the
    /// demand and road in `sampled_*` (set by [`Plant::sample`], cleared by any change of
    /// state).
    first_stage_ready: bool,
    sampled_demand: Vec<f64>,
    sampled_road: Vec<f64>,
    sampled_road_rate: Vec<f64>,
}

/// Inverse of a small square matrix given as rows (Gauss–Jordan with partial pivoting),
/// row-major; `None` when singular.
pub fn invert(rows: &[Vec<f64>]) -> Option<Vec<f64>> {
    let n = rows.len();
    let mut a: Vec<f64> = rows.iter().flat_map(|r| r.iter().copied()).collect();
    if a.len() != n * n {
        return None;
    }
    let mut inv = vec![0.0; n * n];
    for i in 0..n {
        inv[i * n + i] = 1.0;
    }
    let scale = a.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    for col in 0..n {
        let pivot =
            (col..n).max_by(|&i, &j| a[i * n + col].abs().total_cmp(&a[j * n + col].abs()))?;
        if a[pivot * n + col].abs() <= 1e-12 * scale {
            return None;
        }
        for j in 0..n {
            a.swap(col * n + j, pivot * n + j);
            inv.swap(col * n + j, pivot * n + j);
        }
        let d = a[col * n + col];
        for j in 0..n {
            a[col * n + j] /= d;
            inv[col * n + j] /= d;
        }
        for i in 0..n {
            if i != col {
                let f = a[i * n + col];
                if f != 0.0 {
                    for j in 0..n {
                        a[i * n + j] -= f * a[col * n + j];
                        inv[i * n + j] -= f * inv[col * n + j];
                    }
                }
            }
        }
    }
    Some(inv)
}

#[inline]
fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Row `i` of a row-major matrix with rows of `n` (empty beyond the end). Multiplies where
/// `chunks_exact` would divide: this is the integration's inner loop.
#[inline]
fn row(m: &[f64], i: usize, n: usize) -> &[f64] {
    m.get(i * n..i * n + n).unwrap_or(&[])
}

/// `dst = src` element by element (no `memmove` call for a handful of values).
#[inline]
fn copy(dst: &mut [f64], src: &[f64]) {
    for (d, s) in dst.iter_mut().zip(src) {
        *d = *s;
    }
}

impl Plant {
    /// The MiL rig: `actuators[j]` drives attachment `j`; `internal_step_s` is the RK4 step
    /// (s).
    ///
    /// # Errors
    /// An invalid specimen, a count of actuators other than the attachments', or a
    /// non-positive step.
    pub fn with_actuators(
        specimen: Specimen,
        actuators: Vec<ForceActuator>,
        internal_step_s: f64,
    ) -> Result<Self, SpecimenError> {
        if actuators.len() != specimen.attachments.len() {
            return Err(SpecimenError(format!(
                "{} actuators for {} attachments",
                actuators.len(),
                specimen.attachments.len()
            )));
        }
        Self::new(specimen, Drive::Actuators(actuators), internal_step_s)
    }

    /// The emulated system: the specimen coupled to `interface` ideally.
    ///
    /// # Errors
    /// An invalid specimen or a non-positive step.
    pub fn with_ideal_interface(
        specimen: Specimen,
        interface: Box<dyn IdealInterface + Send + Sync>,
        internal_step_s: f64,
    ) -> Result<Self, SpecimenError> {
        Self::new(specimen, Drive::Ideal(interface), internal_step_s)
    }

    fn new(specimen: Specimen, drive: Drive, internal_step_s: f64) -> Result<Self, SpecimenError> {
        specimen.validate()?;
        if !(internal_step_s.is_finite() && internal_step_s > 0.0) {
            return Err(SpecimenError(format!(
                "internal step must be > 0 s (is {internal_step_s})"
            )));
        }
        let n = specimen.len();
        let channels = specimen.attachments.len();
        let mut total = specimen.mass.clone();
        if let Drive::Actuators(acts) = &drive {
            for (t, a) in specimen.attachments.iter().zip(acts) {
                for i in 0..n {
                    for j in 0..n {
                        total[i][j] += a.moving_mass_kg() * t[i] * t[j];
                    }
                }
            }
        }
        let inv_mass =
            invert(&total).ok_or_else(|| SpecimenError("singular total mass matrix".into()))?;
        let element_states = specimen.elements.iter().map(|e| e.element.states()).sum();
        let actuator_states = match &drive {
            Drive::Actuators(a) => a.len() * ACTUATOR_STATES,
            Drive::Ideal(_) => 0,
        };
        let len = 2 * n + element_states + actuator_states;
        let inputs = specimen.inputs.len();
        Ok(Self {
            n,
            channels,
            element_states,
            inv_mass,
            state: vec![0.0; len],
            time_s: 0.0,
            internal_step_s,
            k: [
                vec![0.0; len],
                vec![0.0; len],
                vec![0.0; len],
                vec![0.0; len],
            ],
            tmp: vec![0.0; len],
            generalised: vec![0.0; n],
            accel: vec![0.0; n],
            y: vec![0.0; channels],
            y_dot: vec![0.0; channels],
            forces: vec![0.0; channels],
            road: vec![0.0; inputs],
            road_rate: vec![0.0; inputs],
            attachments: specimen.attachments.iter().flatten().copied().collect(),
            element_dofs: specimen
                .elements
                .iter()
                .flat_map(|e| e.dof_coefficients.iter().copied())
                .collect(),
            element_inputs: specimen
                .elements
                .iter()
                .flat_map(|e| e.input_coefficients.iter().copied())
                .collect(),
            first_stage_ready: false,
            sampled_demand: vec![0.0; channels],
            sampled_road: vec![0.0; inputs],
            sampled_road_rate: vec![0.0; inputs],
            specimen,
            drive,
        })
    }

    /// The specimen.
    pub fn specimen(&self) -> &Specimen {
        &self.specimen
    }

    /// Interface channels.
    pub fn channels(&self) -> usize {
        self.channels
    }

    /// Simulated time (s).
    pub fn time_s(&self) -> f64 {
        self.time_s
    }

    /// The RK4 step (s).
    pub fn internal_step_s(&self) -> f64 {
        self.internal_step_s
    }

    /// The full state vector (see the module documentation).
    pub fn state(&self) -> &[f64] {
        &self.state
    }

    /// Puts the plant at rest at `q = 0` with every actuator holding `demand[j]` (N): the
    /// static equilibrium of the specimen description (see [`Specimen`]).
    pub fn rest(&mut self, demand: &[f64]) {
        self.state.iter_mut().for_each(|x| *x = 0.0);
        self.time_s = 0.0;
        self.first_stage_ready = false;
        let offset = 2 * self.n + self.element_states;
        if let Drive::Actuators(acts) = &self.drive {
            for (j, (a, f)) in acts.iter().zip(demand).enumerate() {
                let s = a.equilibrium(*f);
                self.state[offset + j * ACTUATOR_STATES..offset + (j + 1) * ACTUATOR_STATES]
                    .copy_from_slice(&s);
            }
        }
    }

    /// Evaluates the derivative of `state` (or of the RK4 trial state `tmp`) into
    /// `k[which]` with demands `demand` (N) and the road in `self.road`, `self.road_rate`;
    /// also leaves the attachment kinematics in `self.y`, `self.y_dot`, the accelerations in
    /// `self.accel` and the interface forces in `self.forces`.
    fn derivative(&mut self, which: usize, from_tmp: bool, demand: &[f64]) {
        let n = self.n;
        let inputs = self.road.len();
        let x: &[f64] = if from_tmp { &self.tmp } else { &self.state };
        let (q, rest) = x.split_at(n);
        let (qd, rest) = rest.split_at(n);
        let (zs, act_states) = rest.split_at(self.element_states);
        let out = &mut self.k[which];
        // Attachment kinematics.
        for (j, (y, y_dot)) in self.y.iter_mut().zip(self.y_dot.iter_mut()).enumerate() {
            let t = row(&self.attachments, j, n);
            *y = dot(t, q);
            *y_dot = dot(t, qd);
        }
        // Generalised forces: static, elements.
        copy(&mut self.generalised, &self.specimen.static_force);
        let mut zi = 0;
        for (i, e) in self.specimen.elements.iter().enumerate() {
            let a = row(&self.element_dofs, i, n);
            let (mut xe, mut ve) = (dot(a, q), dot(a, qd));
            if inputs > 0 {
                let b = row(&self.element_inputs, i, inputs);
                xe += dot(b, &self.road);
                ve += dot(b, &self.road_rate);
            }
            let element = &e.element;
            let f = if element.states() > 0 {
                let z = zs.get(zi).copied().unwrap_or(0.0);
                if let Some(rate) = out.get_mut(2 * n + zi) {
                    *rate = element.state_rate(xe, ve, z);
                }
                zi += element.states();
                element.force(xe, ve, z)
            } else {
                element.force(xe, ve, 0.0)
            };
            for (g, ai) in self.generalised.iter_mut().zip(a) {
                *g -= ai * f;
            }
        }
        // Interface forces: piston forces (actuators) or the ideal law.
        match &self.drive {
            Drive::Actuators(acts) => {
                for (j, (a, (f, y_dot))) in acts
                    .iter()
                    .zip(self.forces.iter_mut().zip(&self.y_dot))
                    .enumerate()
                {
                    *f = a.piston_force(actuator_state(act_states, j), *y_dot);
                }
            }
            Drive::Ideal(law) => {
                law.forces(
                    &self.y,
                    &self.y_dot,
                    &self.road,
                    &self.road_rate,
                    &mut self.forces,
                );
            }
        }
        for (j, f) in self.forces.iter().enumerate() {
            let t = row(&self.attachments, j, n);
            for (g, ti) in self.generalised.iter_mut().zip(t) {
                *g += ti * f;
            }
        }
        // Accelerations.
        for (i, a) in self.accel.iter_mut().enumerate() {
            *a = dot(row(&self.inv_mass, i, n), &self.generalised);
        }
        let (velocities, rest) = out.split_at_mut(n);
        copy(velocities, qd);
        copy(rest, &self.accel);
        // Actuators: load cell (F_p − m_a ÿ) and their own dynamics.
        if let Drive::Actuators(acts) = &self.drive {
            let offset = 2 * n + self.element_states;
            for (j, (a, ((f, y_dot), demand))) in acts
                .iter()
                .zip(self.forces.iter_mut().zip(&self.y_dot).zip(demand))
                .enumerate()
            {
                *f -= a.moving_mass_kg() * dot(row(&self.attachments, j, n), &self.accel);
                let d = a.derivative(actuator_state(act_states, j), *demand, *f, *y_dot);
                let start = offset + j * ACTUATOR_STATES;
                if let Some(o) = out.get_mut(start..start + ACTUATOR_STATES) {
                    copy(o, &d);
                }
            }
        }
    }

    fn set_road(&mut self, from: &[f64], to: &[f64], fraction: f64, duration_s: f64) {
        for ((r, rr), (a, b)) in self
            .road
            .iter_mut()
            .zip(self.road_rate.iter_mut())
            .zip(from.iter().zip(to))
        {
            *r = a + fraction * (b - a);
            *rr = (b - a) / duration_s;
        }
    }

    /// Advances by `duration_s` (s) in RK4 steps of at most the internal step, with the
    /// actuator demands `demand` (N per channel; ignored by an ideal interface) held and the
    /// road ramping from `road_from` to `road_to` (m per input).
    ///
    /// When [`Plant::sample`] was called last with the same demand, `road_from` and the
    /// ramp's rate `(road_to − road_from) / duration_s` (m/s), the first RK4 stage is the
    /// derivative it evaluated and is not evaluated again.
    pub fn advance(&mut self, duration_s: f64, demand: &[f64], road_from: &[f64], road_to: &[f64]) {
        let steps = (duration_s / self.internal_step_s - 1e-9).ceil().max(1.0) as usize;
        let h = duration_s / steps as f64;
        for s in 0..steps {
            let f0 = s as f64 / steps as f64;
            let fm = (s as f64 + 0.5) / steps as f64;
            let f1 = (s as f64 + 1.0) / steps as f64;
            self.set_road(road_from, road_to, f0, duration_s);
            let reuse = s == 0
                && self.first_stage_ready
                && self.sampled_demand == demand
                && self.sampled_road == self.road
                && self.sampled_road_rate == self.road_rate;
            if !reuse {
                self.derivative(0, false, demand);
            }
            self.set_road(road_from, road_to, fm, duration_s);
            let half = 0.5 * h;
            stage(&mut self.tmp, &self.state, &self.k[0], half);
            self.derivative(1, true, demand);
            stage(&mut self.tmp, &self.state, &self.k[1], half);
            self.derivative(2, true, demand);
            self.set_road(road_from, road_to, f1, duration_s);
            stage(&mut self.tmp, &self.state, &self.k[2], h);
            self.derivative(3, true, demand);
            let sixth = h / 6.0;
            let [k0, k1, k2, k3] = &self.k;
            for ((x, a), ((b, c), d)) in
                self.state.iter_mut().zip(k0).zip(k1.iter().zip(k2).zip(k3))
            {
                *x += sixth * (a + 2.0 * b + 2.0 * c + d);
            }
        }
        self.first_stage_ready = false;
        self.time_s += duration_s;
    }

    /// Evaluates the plant's signals now, for demands `demand` (N; they set the load-cell
    /// force through the accelerations) and road `road` with rate `road_rate` (m/s); read
    /// them with [`Plant::position`], [`Plant::velocity`] and [`Plant::force`]. Allocates
    /// nothing.
    pub fn sample(&mut self, demand: &[f64], road: &[f64], road_rate: &[f64]) {
        copy(&mut self.road, road);
        copy(&mut self.road_rate, road_rate);
        self.derivative(0, false, demand);
        copy(&mut self.sampled_demand, demand);
        copy(&mut self.sampled_road, road);
        copy(&mut self.sampled_road_rate, road_rate);
        self.first_stage_ready = true;
    }

    /// Attachment position per channel (m) at the last [`Plant::sample`].
    pub fn position(&self) -> &[f64] {
        &self.y
    }

    /// Attachment velocity per channel (m/s) at the last [`Plant::sample`].
    pub fn velocity(&self) -> &[f64] {
        &self.y_dot
    }

    /// Interface force on the specimen per channel (N) at the last [`Plant::sample`]: the
    /// load-cell force, or the ideal interface's force.
    pub fn force(&self) -> &[f64] {
        &self.forces
    }

    /// The plant's signals now (see [`Plant::sample`]), collected.
    pub fn outputs(&mut self, demand: &[f64], road: &[f64], road_rate: &[f64]) -> PlantOutputs {
        self.sample(demand, road, road_rate);
        let offset = 2 * self.n + self.element_states;
        let actuators = match &self.drive {
            Drive::Actuators(a) => a.len(),
            Drive::Ideal(_) => 0,
        };
        let pick = |k: usize| {
            (0..actuators)
                .map(|j| self.state[offset + j * ACTUATOR_STATES + k])
                .collect()
        };
        PlantOutputs {
            position: self.y.clone(),
            velocity: self.y_dot.clone(),
            force: self.forces.clone(),
            dofs: self.state[..self.n].to_vec(),
            load_pressure: pick(crate::actuator::state::LOAD_PRESSURE),
            spool: pick(crate::actuator::state::SPOOL),
        }
    }
}

/// Actuator `j`'s states in the actuators' part of the state vector.
#[inline]
fn actuator_state(states: &[f64], j: usize) -> &[f64; ACTUATOR_STATES] {
    states
        .get(j * ACTUATOR_STATES..(j + 1) * ACTUATOR_STATES)
        .and_then(|s| s.try_into().ok())
        .unwrap_or(&[0.0; ACTUATOR_STATES])
}

/// `tmp = x + h k` (an RK4 trial state).
#[inline]
fn stage(tmp: &mut [f64], x: &[f64], k: &[f64], h: f64) {
    for ((t, a), b) in tmp.iter_mut().zip(x).zip(k) {
        *t = a + h * b;
    }
}
