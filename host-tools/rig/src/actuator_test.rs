//! The blocked-rod force test of one actuator: the test a rig engineer runs before a MiL
//! experiment to measure the actuator's force-tracking response.
//!
//! The rod is clamped to the reaction mass (it does not move, `ẏ = ÿ = 0`), the servo
//! controller's force loop follows a command (a sine sweep, random noise), and the load
//! cell is recorded with the command at the controller's sample rate. The response from the
//! command to the load cell is then the tracking response `p_f` of the analysis (the
//! reference actuator's "rod held still"), sampled as a digital servo controller samples
//! it: the command is held over each sample period (zero-order hold) and the load cell is
//! read at the sample instants, through the set-up's transducer (bandwidth, noise,
//! quantisation).
//!
//! The actuator's nonlinear effects ([`crate::actuator::ActuatorEffects`]) and its supply
//! pressure limit act as on the MiL rig, so a test driven too hard shows them (the
//! coherence falls) as it would on the real rig.

use crate::actuator::{ForceActuator, ACTUATOR_STATES};
use crate::sensors::{Sensor, SensorError, SensorSpec};

/// Errors of a blocked-rod test.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ActuatorTestError {
    /// The load cell's specification or the sample rate.
    #[error(transparent)]
    Sensor(#[from] SensorError),
    /// The integration step.
    #[error(
        "actuator test: the internal step must be > 0 s and at most the sample period (is {0} s)"
    )]
    Step(f64),
    /// A command sample that is not finite.
    #[error("actuator test: command sample {index} is not finite ({value})")]
    Command {
        /// Sample index.
        index: usize,
        /// Its value (N).
        value: f64,
    },
    /// The actuator's state left the finite numbers (a command far beyond the supply
    /// pressure limit with an unstable force loop).
    #[error("actuator test: the simulation diverged at sample {0}")]
    Diverged(usize),
}

/// A blocked-rod test: the actuator, the load cell and the sampling.
#[derive(Clone, Debug)]
pub struct BlockedRodTest {
    /// The actuator with its force loop and effects.
    pub actuator: ForceActuator,
    /// The load cell (N).
    pub load_cell: SensorSpec,
    /// The servo controller's sample rate (Hz): command updates and load-cell samples.
    pub sample_rate_hz: f64,
    /// RK4 step (s), at most the sample period.
    pub internal_step_s: f64,
    /// Seed of the load cell's noise.
    pub seed: u64,
}

impl BlockedRodTest {
    /// Runs the test: `command[i]` (N) is held from sample `i` to sample `i + 1`; the
    /// result's element `i` is the load cell read at sample `i` (N), before `command[i]`
    /// acts. The actuator starts at rest holding `command[0]`. `progress` is called with
    /// the fraction done, now and then.
    ///
    /// # Errors
    /// An invalid load cell, sample rate or step, a non-finite command, a diverged state.
    pub fn run(
        &self,
        command: &[f64],
        mut progress: impl FnMut(f64),
    ) -> Result<Vec<f64>, ActuatorTestError> {
        let mut sensor = Sensor::new(&self.load_cell, self.sample_rate_hz, self.seed)?;
        let period = 1.0 / self.sample_rate_hz;
        if !(self.internal_step_s > 0.0 && self.internal_step_s <= period * (1.0 + 1e-9)) {
            return Err(ActuatorTestError::Step(self.internal_step_s));
        }
        if let Some((index, &value)) = command.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(ActuatorTestError::Command { index, value });
        }
        let steps = (period / self.internal_step_s - 1e-9).ceil().max(1.0) as usize;
        let h = period / steps as f64;
        let a = &self.actuator;
        let first = command.first().copied().unwrap_or(0.0);
        let mut x = a.equilibrium(first);
        sensor.reset(a.piston_force(&x, 0.0));
        let every = (command.len() / 100).max(1);
        let mut measured = Vec::with_capacity(command.len());
        // The rod is still: the load cell reads the piston force, and the actuator's state is
        // its own ODE (4 states), integrated by the classical RK4.
        let f = |x: &[f64; ACTUATOR_STATES], demand: f64| {
            a.derivative(x, demand, a.piston_force(x, 0.0), 0.0)
        };
        for (i, &demand) in command.iter().enumerate() {
            measured.push(sensor.measure(a.piston_force(&x, 0.0)));
            for _ in 0..steps {
                let k1 = f(&x, demand);
                let k2 = f(&axpy(&x, 0.5 * h, &k1), demand);
                let k3 = f(&axpy(&x, 0.5 * h, &k2), demand);
                let k4 = f(&axpy(&x, h, &k3), demand);
                for j in 0..ACTUATOR_STATES {
                    x[j] += h / 6.0 * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j]);
                }
            }
            if x.iter().any(|v| !v.is_finite()) {
                return Err(ActuatorTestError::Diverged(i));
            }
            if i % every == 0 {
                progress(i as f64 / command.len() as f64);
            }
        }
        progress(1.0);
        Ok(measured)
    }
}

/// `x + h k`.
fn axpy(x: &[f64; ACTUATOR_STATES], h: f64, k: &[f64; ACTUATOR_STATES]) -> [f64; ACTUATOR_STATES] {
    core::array::from_fn(|j| x[j] + h * k[j])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::actuator::ActuatorEffects;
    use mil_params::ServoHydraulicActuator;

    fn test(rate: f64) -> BlockedRodTest {
        BlockedRodTest {
            actuator: ForceActuator::new(
                ServoHydraulicActuator::REFERENCE,
                ActuatorEffects::default(),
            )
            .unwrap(),
            load_cell: SensorSpec::default(),
            sample_rate_hz: rate,
            internal_step_s: 50e-6,
            seed: 1,
        }
    }

    #[test]
    fn a_steady_command_is_held_and_a_step_is_followed() {
        let mut command = vec![1500.0; 2000];
        command[1000..].fill(2500.0);
        let y = test(2000.0).run(&command, |_| {}).unwrap();
        // At rest from the start, the force loop's integrator then removes the step's error.
        assert!((y[999] - 1500.0).abs() < 1e-6, "{}", y[999]);
        assert!((y[1999] - 2500.0).abs() < 1.0, "{}", y[1999]);
        // The step is not seen before the sample after it is applied.
        assert!((y[1000] - 1500.0).abs() < 1e-6, "{}", y[1000]);
        assert!(y[1001] > 1500.1, "{}", y[1001]);
        assert!(y[1040] > 2000.0, "{}", y[1040]);
    }

    #[test]
    fn bad_inputs_are_refused() {
        let t = test(2000.0);
        assert!(matches!(
            t.run(&[0.0, f64::NAN], |_| {}),
            Err(ActuatorTestError::Command { index: 1, .. })
        ));
        assert!(matches!(
            t.run(&[0.0, f64::INFINITY], |_| {}),
            Err(ActuatorTestError::Command { index: 1, .. })
        ));
        let slow = BlockedRodTest {
            internal_step_s: 1e-3,
            ..test(2000.0)
        };
        assert!(matches!(
            slow.run(&[0.0; 4], |_| {}),
            Err(ActuatorTestError::Step(_))
        ));
    }
}
