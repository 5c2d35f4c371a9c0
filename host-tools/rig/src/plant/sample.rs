//! The plant's signals at an instant ([`Plant::sample`]): the attachment positions and
//! velocities and the interface forces, from the exact model in the linear regime or from
//! the state derivative otherwise, and [`PlantOutputs`] collecting them with the DOFs and
//! the actuators' states.

use super::drive::Drive;
use super::linear::{with_linear, Linear};
use super::Plant;
use crate::actuator::{ForceActuator, ACTUATOR_STATES};
use mil_numerics::dense::copy;

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

impl Plant {
    /// Evaluates the plant's signals now, for demands `demand` (N; they set the load-cell
    /// force through the accelerations) and road `road` with rate `road_rate` (m/s); read
    /// them with [`Plant::position`], [`Plant::velocity`] and [`Plant::force`]. Allocates
    /// nothing.
    pub fn sample(&mut self, demand: &[f64], road: &[f64], road_rate: &[f64]) {
        if self.exact_steps {
            if let Some(linear) = self.linear.as_mut() {
                let actuators: &[ForceActuator] = match &self.drive {
                    Drive::Actuators(a) => a,
                    Drive::Ideal(_) => &[],
                };
                let (state, outputs) = (&self.state, &mut self.linear_out);
                let inside = with_linear!(linear, m => {
                    let inside = m.sample(state, actuators, (demand, road, road_rate));
                    copy(outputs, m.outputs());
                    inside
                });
                if inside {
                    self.first_stage_ready = false;
                    self.linear_outputs = true;
                    return;
                }
            }
        }
        self.linear_outputs = false;
        copy(&mut self.road, road);
        copy(&mut self.road_rate, road_rate);
        self.derivative(0, false, demand);
        copy(&mut self.sampled_demand, demand);
        copy(&mut self.sampled_road, road);
        copy(&mut self.sampled_road_rate, road_rate);
        self.first_stage_ready = true;
    }

    /// Output `k` (0: position, 1: velocity, 2: force) of the last [`Plant::sample`].
    fn sampled_output(&self, k: usize) -> &[f64] {
        if self.linear_outputs {
            let ch = self.channels;
            return self.linear_out.get(k * ch..(k + 1) * ch).unwrap_or(&[]);
        }
        match k {
            0 => &self.y,
            1 => &self.y_dot,
            _ => &self.forces,
        }
    }

    /// Attachment position per channel (m) at the last [`Plant::sample`].
    pub fn position(&self) -> &[f64] {
        self.sampled_output(0)
    }

    /// Attachment velocity per channel (m/s) at the last [`Plant::sample`].
    pub fn velocity(&self) -> &[f64] {
        self.sampled_output(1)
    }

    /// Interface force on the specimen per channel (N) at the last [`Plant::sample`]: the
    /// load-cell force, or the ideal interface's force.
    pub fn force(&self) -> &[f64] {
        self.sampled_output(2)
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
            position: self.position().to_vec(),
            velocity: self.velocity().to_vec(),
            force: self.force().to_vec(),
            dofs: self.state[..self.n].to_vec(),
            load_pressure: pick(crate::actuator::state::LOAD_PRESSURE),
            spool: pick(crate::actuator::state::SPOOL),
        }
    }
}
