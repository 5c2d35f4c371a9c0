//! What drives the specimen at its attachment points: the nonlinear actuators (the MiL rig)
//! or an ideal interface law (the emulated system), with the interface forces each applies
//! and, for an ideal interface, its affine form in the linear regime.

use crate::actuator::{ForceActuator, ACTUATOR_STATES};

/// The forces an ideal interface (the emulated system's numerical part, coupled without
/// actuators, delay or sampling) applies at the attachment points.
pub trait IdealInterface {
    /// Writes the force per channel (N) into `forces`, given per channel the attachment
    /// position `y` (m) and velocity `y_dot` (m/s), and per road input its value `road` (m)
    /// and rate `road_rate` (m/s).
    fn forces(&self, y: &[f64], y_dot: &[f64], road: &[f64], road_rate: &[f64], forces: &mut [f64]);

    /// The law's affine form, if it has one: [`IdealInterface::forces`] must return exactly
    /// (to rounding) the [`AffineInterface`] force on every channel wherever that exceeds the
    /// channel's lower bound, and a force not above the bound elsewhere (e.g. lift-off). With
    /// it, the plant takes exact linear steps (see the [`plant`](super) module
    /// documentation). `None` (the default): the law is treated as nonlinear.
    fn affine(&self) -> Option<AffineInterface> {
        None
    }
}

/// The affine form of an ideal interface law (see [`IdealInterface::affine`]): per channel
/// `j`,
///
/// ```text
/// F_j = offset_j + Σ_k (position_jk y_k + velocity_jk ẏ_k) + Σ_i (road_ji w_i + road_rate_ji ẇ_i)
/// ```
///
/// valid where `F_j > lower_bound_j`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AffineInterface {
    /// Force at rest `offset_j` per channel (N).
    pub offset_n: Vec<f64>,
    /// Stiffness per channel and attachment `position_jk` (N/m).
    pub position_n_per_m: Vec<Vec<f64>>,
    /// Damping per channel and attachment `velocity_jk` (N·s/m).
    pub velocity_n_s_per_m: Vec<Vec<f64>>,
    /// Gain per channel and road input `road_ji` (N/m).
    pub road_n_per_m: Vec<Vec<f64>>,
    /// Gain per channel and road rate `road_rate_ji` (N·s/m).
    pub road_rate_n_s_per_m: Vec<Vec<f64>>,
    /// Per channel the force (N) the affine form must exceed to hold (`f64::NEG_INFINITY`:
    /// everywhere; 0 for lift-off).
    pub lower_bound_n: Vec<f64>,
}

/// What drives the specimen.
pub(super) enum Drive {
    Actuators(Vec<ForceActuator>),
    Ideal(Box<dyn IdealInterface + Send + Sync>),
}

/// The actuators of a drive (none for an ideal interface).
pub(super) fn drive_actuators(drive: &Drive) -> &[ForceActuator] {
    match drive {
        Drive::Actuators(a) => a,
        Drive::Ideal(_) => &[],
    }
}

/// The interface forces (N) into `forces`: the actuators' piston forces from their states
/// `act_states` and rod velocities, or the ideal interface's law.
#[inline]
pub(super) fn interface_forces(
    drive: &Drive,
    act_states: &[f64],
    y: &[f64],
    y_dot: &[f64],
    road: &[f64],
    road_rate: &[f64],
    forces: &mut [f64],
) {
    match drive {
        Drive::Actuators(acts) => {
            for (j, (a, (f, v))) in acts.iter().zip(forces.iter_mut().zip(y_dot)).enumerate() {
                *f = a.piston_force(actuator_state(act_states, j), *v);
            }
        }
        Drive::Ideal(law) => law.forces(y, y_dot, road, road_rate, forces),
    }
}

/// Actuator `j`'s states in the actuators' part of the state vector.
#[inline]
pub(super) fn actuator_state(states: &[f64], j: usize) -> &[f64; ACTUATOR_STATES] {
    states
        .get(j * ACTUATOR_STATES..(j + 1) * ACTUATOR_STATES)
        .and_then(|s| s.try_into().ok())
        .unwrap_or(&[0.0; ACTUATOR_STATES])
}
