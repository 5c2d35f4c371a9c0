//! The plant's state derivative `ẋ = f(x, demand, road, road rate)`, evaluated for the RK4
//! stages and [`Plant::sample`]: the elements' force laws specialised
//! once, the attachment kinematics, the accelerations through `M⁻¹`, the interface forces,
//! the load cells and the actuators' own dynamics. Specimens of up to [`FIXED`] DOFs and road
//! inputs go through a fixed-size kernel; larger ones through the general one.

use super::drive::{actuator_state, interface_forces, Drive};
use super::Plant;
use crate::actuator::ACTUATOR_STATES;
use mil_numerics::dense::{copy, dot, row};
use mil_structure::CompiledLaw;

/// An element's force law, specialised once.
#[derive(Clone, Copy, Debug)]
pub(super) enum ElementLaw {
    /// `preload + k x + c v` (no effects).
    Linear { k: f64, c: f64, preload: f64 },
    /// `preload` plus the element's law (`mil-structure`'s, unpacked), with `states`
    /// internal states (the hysteretic deflection).
    General {
        law: CompiledLaw,
        preload: f64,
        states: usize,
    },
}

/// Size of the fixed-size derivative kernel: specimens of up to this many DOFs and road
/// inputs (every built-in one) are evaluated with their vectors padded with zeros to it, so
/// that every dot product is one unrolled expression.
pub(super) const FIXED: usize = 4;

/// A vector of the fixed-size kernel.
pub(super) type Fixed4 = [f64; FIXED];

/// The specimen's coefficients for the fixed-size kernel (zero-padded).
pub(super) struct Fixed {
    /// `t_j` per channel.
    pub(super) attachments: Vec<Fixed4>,
    /// `M⁻¹ t_j` per channel.
    pub(super) inv_mass_attachments: Vec<Fixed4>,
    /// `a_e` per element.
    pub(super) element_dofs: Vec<Fixed4>,
    /// `b_e` per element.
    pub(super) element_inputs: Vec<Fixed4>,
    /// `M⁻¹ a_e` per element.
    pub(super) inv_mass_elements: Vec<Fixed4>,
    /// `M⁻¹ g`.
    pub(super) inv_mass_static: Fixed4,
}

/// `v` zero-padded (or cut) to [`FIXED`].
#[inline]
pub(super) fn pad(v: &[f64]) -> Fixed4 {
    let mut a = [0.0; FIXED];
    copy(&mut a, v);
    a
}

/// The fixed-size dot product (pairwise; exact zeros in the padding).
#[inline]
fn dot4(a: &Fixed4, b: &Fixed4) -> f64 {
    (a[0] * b[0] + a[1] * b[1]) + (a[2] * b[2] + a[3] * b[3])
}

impl Plant {
    /// Evaluates the derivative of `state` (or of the RK4 trial state `tmp`) into
    /// `k[which]` with demands `demand` (N) and the road in `self.road`, `self.road_rate`;
    /// also leaves the attachment kinematics in `self.y`, `self.y_dot`, the accelerations in
    /// `self.accel` and the interface forces in `self.forces`.
    pub(super) fn derivative(&mut self, which: usize, from_tmp: bool, demand: &[f64]) {
        if self.fixed.is_some() {
            self.derivative_fixed(which, from_tmp, demand);
        } else {
            self.derivative_general(which, from_tmp, demand);
        }
    }

    /// [`Plant::derivative`] with the fixed-size kernel.
    fn derivative_fixed(&mut self, which: usize, from_tmp: bool, demand: &[f64]) {
        let Some(fx) = &self.fixed else {
            return;
        };
        let n = self.n;
        let x: &[f64] = if from_tmp { &self.tmp } else { &self.state };
        let (q, rest) = x.split_at(n.min(x.len()));
        let (qd, rest) = rest.split_at(n.min(rest.len()));
        let (zs, act_states) = rest.split_at(self.element_states.min(rest.len()));
        let Some(out) = self.k.get_mut(which) else {
            return;
        };
        let (q4, qd4) = (pad(q), pad(qd));
        let (road, road_rate) = (pad(&self.road), pad(&self.road_rate));
        // Attachment kinematics.
        for ((y, y_dot), t) in self
            .y
            .iter_mut()
            .zip(self.y_dot.iter_mut())
            .zip(&fx.attachments)
        {
            *y = dot4(t, &q4);
            *y_dot = dot4(t, &qd4);
        }
        // Accelerations: static forces, elements.
        let mut accel = fx.inv_mass_static;
        let mut zi = 0;
        for (((law, a), b), m) in self
            .laws
            .iter()
            .zip(&fx.element_dofs)
            .zip(&fx.element_inputs)
            .zip(&fx.inv_mass_elements)
        {
            let xe = dot4(a, &q4) + dot4(b, &road);
            let ve = dot4(a, &qd4) + dot4(b, &road_rate);
            let f = element_force(law, xe, ve, zs, &mut zi, out, 2 * n);
            for (acc, mi) in accel.iter_mut().zip(m) {
                *acc -= mi * f;
            }
        }
        // Interface forces: piston forces (actuators) or the ideal law.
        interface_forces(
            &self.drive,
            act_states,
            &self.y,
            &self.y_dot,
            &self.road,
            &self.road_rate,
            &mut self.forces,
        );
        for (f, m) in self.forces.iter().zip(&fx.inv_mass_attachments) {
            for (acc, mi) in accel.iter_mut().zip(m) {
                *acc += mi * f;
            }
        }
        copy(&mut self.accel, &accel);
        let len = out.len();
        let (velocities, rest) = out.split_at_mut(n.min(len));
        copy(velocities, qd);
        copy(rest, accel.get(..n).unwrap_or(&[]));
        // Actuators: load cell (F_p − m_a ÿ) and their own dynamics.
        if let Drive::Actuators(acts) = &self.drive {
            let offset = 2 * n + self.element_states;
            for (j, ((a, t), ((f, y_dot), demand))) in acts
                .iter()
                .zip(&fx.attachments)
                .zip(self.forces.iter_mut().zip(&self.y_dot).zip(demand))
                .enumerate()
            {
                *f -= a.moving_mass_kg() * dot4(t, &accel);
                let d = a.derivative(actuator_state(act_states, j), *demand, *f, *y_dot);
                let start = offset + j * ACTUATOR_STATES;
                if let Some(o) = out.get_mut(start..start + ACTUATOR_STATES) {
                    copy(o, &d);
                }
            }
        }
    }

    /// [`Plant::derivative`] for any size.
    fn derivative_general(&mut self, which: usize, from_tmp: bool, demand: &[f64]) {
        let n = self.n;
        let inputs = self.road.len();
        let x: &[f64] = if from_tmp { &self.tmp } else { &self.state };
        let (q, rest) = x.split_at(n.min(x.len()));
        let (qd, rest) = rest.split_at(n.min(rest.len()));
        let (zs, act_states) = rest.split_at(self.element_states.min(rest.len()));
        let Some(out) = self.k.get_mut(which) else {
            return;
        };
        // Attachment kinematics.
        for (j, (y, y_dot)) in self.y.iter_mut().zip(self.y_dot.iter_mut()).enumerate() {
            let t = row(&self.attachments, j, n);
            *y = dot(t, q);
            *y_dot = dot(t, qd);
        }
        // Accelerations: static forces, elements (`M⁻¹ a_e` precomputed).
        copy(&mut self.accel, &self.inv_mass_static);
        let mut zi = 0;
        for (i, law) in self.laws.iter().enumerate() {
            let a = row(&self.element_dofs, i, n);
            let (mut xe, mut ve) = (dot(a, q), dot(a, qd));
            if inputs > 0 {
                let b = row(&self.element_inputs, i, inputs);
                xe += dot(b, &self.road);
                ve += dot(b, &self.road_rate);
            }
            let f = element_force(law, xe, ve, zs, &mut zi, out, 2 * n);
            for (acc, m) in self
                .accel
                .iter_mut()
                .zip(row(&self.inv_mass_elements, i, n))
            {
                *acc -= m * f;
            }
        }
        // Interface forces: piston forces (actuators) or the ideal law.
        interface_forces(
            &self.drive,
            act_states,
            &self.y,
            &self.y_dot,
            &self.road,
            &self.road_rate,
            &mut self.forces,
        );
        for (j, f) in self.forces.iter().enumerate() {
            for (acc, m) in self
                .accel
                .iter_mut()
                .zip(row(&self.inv_mass_attachments, j, n))
            {
                *acc += m * f;
            }
        }
        let len = out.len();
        let (velocities, rest) = out.split_at_mut(n.min(len));
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
}

/// Force (N) of one element at compression `xe` (m) and rate `ve` (m/s) by its law; an
/// element with an internal state takes it from `zs[*zi]`, writes its rate into
/// `out[states_at + *zi]` and advances `*zi`.
#[inline]
fn element_force(
    law: &ElementLaw,
    xe: f64,
    ve: f64,
    zs: &[f64],
    zi: &mut usize,
    out: &mut [f64],
    states_at: usize,
) -> f64 {
    match law {
        // The order of `Element::force`: k x, + c v, + preload.
        ElementLaw::Linear { k, c, preload } => k * xe + c * ve + preload,
        ElementLaw::General {
            law,
            preload,
            states,
        } => {
            if *states > 0 {
                let z = zs.get(*zi).copied().unwrap_or(0.0);
                if let Some(rate) = out.get_mut(states_at + *zi) {
                    *rate = law.state_rate(xe, ve, z);
                }
                *zi += states;
                preload + law.force(xe, ve, z)
            } else {
                preload + law.force(xe, ve, 0.0)
            }
        }
    }
}
