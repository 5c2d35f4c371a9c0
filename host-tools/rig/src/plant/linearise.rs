//! The affine model of a piecewise-linear plant, built once at construction: the plant's
//! equations in the linear regime (elements linear or with lift-off, the actuators' linear
//! regime, an ideal interface's affine form) evaluated at the unit vectors of
//! `ξ = [x; demand; road; road rate; 1]`, giving the generator, the outputs `[y; ẏ; F]` and
//! the regime quantities with their tests that [`super::linear`] discretises.

use super::drive::{AffineInterface, Drive};
use super::linear::{Linear, LinearParts, RegimeTest, Shape};
use super::Plant;
use crate::actuator::{ForceActuator, ACTUATOR_STATES};
use mil_numerics::dense::{balance, copy, dot, row};

impl Plant {
    /// The affine model of a piecewise-linear plant (`None` otherwise).
    pub(super) fn linear_model(&self) -> Option<Linear> {
        if self.element_states > 0
            || !self
                .specimen
                .elements
                .iter()
                .all(|e| e.element.is_piecewise_linear())
        {
            return None;
        }
        let ch = self.channels;
        let inputs = self.road.len();
        let affine = match &self.drive {
            Drive::Actuators(acts) => {
                if !acts.iter().all(ForceActuator::has_linear_regime) {
                    return None;
                }
                None
            }
            Drive::Ideal(law) => {
                let a = law.affine()?;
                let square = |m: &[Vec<f64>], cols: usize| {
                    m.len() == ch
                        && m.iter()
                            .all(|r| r.len() == cols && r.iter().all(|v| v.is_finite()))
                };
                let ok = a.offset_n.len() == ch
                    && a.offset_n.iter().all(|v| v.is_finite())
                    && square(&a.position_n_per_m, ch)
                    && square(&a.velocity_n_s_per_m, ch)
                    && square(&a.road_n_per_m, inputs)
                    && square(&a.road_rate_n_s_per_m, inputs)
                    && a.lower_bound_n.len() == ch
                    && a.lower_bound_n
                        .iter()
                        .all(|b| !b.is_nan() && *b < f64::INFINITY);
                if !ok {
                    return None;
                }
                Some(a)
            }
        };
        let states = self.state.len();
        let cols = states + ch + 2 * inputs + 1;
        let mut generator = vec![0.0; cols * cols];
        let mut outputs = vec![0.0; 3 * ch * cols];
        let mut regime: Vec<Vec<f64>> = Vec::new();
        let mut tests = Vec::new();
        let mut xi = vec![0.0; cols];
        for col in 0..cols {
            xi.iter_mut().for_each(|v| *v = 0.0);
            // The constant column: ξ = 0 with the constants; any other: a unit ξ without.
            let constants = if col + 1 == cols {
                1.0
            } else {
                xi[col] = 1.0;
                0.0
            };
            let (dx, obs, quantities, t) = self.affine_eval(affine.as_ref(), &xi, constants);
            for (i, v) in dx.iter().enumerate() {
                generator[i * cols + col] = *v;
            }
            for (i, v) in obs.iter().enumerate() {
                outputs[i * cols + col] = *v;
            }
            if regime.is_empty() {
                regime = vec![vec![0.0; cols]; quantities.len()];
                tests = t;
            }
            for (r, v) in regime.iter_mut().zip(&quantities) {
                r[col] = *v;
            }
        }
        // The road ramps at its rate: d(road_i)/dt = road_rate_i.
        for i in 0..inputs {
            generator[(states + ch + i) * cols + states + ch + inputs + i] = 1.0;
        }
        let balance = balance(&mut generator, cols);
        let parts = LinearParts {
            shape: Shape {
                states,
                cols,
                channels: ch,
                inputs,
            },
            generator,
            balance,
            outputs,
            regime,
            tests,
        };
        // Room for one internal step per control period; `advance` widens it when the
        // period takes more.
        let rows = parts.fused_rows(1);
        Linear::with_rows(parts, rows)
    }

    /// The linear regime's model at `xi` with the constant terms (static forces, preloads,
    /// interface offsets) times `constants`: the state derivative, the outputs `[y; ẏ; F]`,
    /// the regime quantities and their tests. Construction only (allocates).
    fn affine_eval(
        &self,
        affine: Option<&AffineInterface>,
        xi: &[f64],
        constants: f64,
    ) -> (Vec<f64>, Vec<f64>, Vec<f64>, Vec<RegimeTest>) {
        let (n, ch, inputs) = (self.n, self.channels, self.road.len());
        let states = self.state.len();
        let x = &xi[..states];
        let demand = &xi[states..states + ch];
        let w = &xi[states + ch..states + ch + inputs];
        let w_dot = &xi[states + ch + inputs..states + ch + 2 * inputs];
        let (q, qd) = (&x[..n], &x[n..2 * n]);
        let y: Vec<f64> = self
            .specimen
            .attachments
            .iter()
            .map(|t| dot(t, q))
            .collect();
        let y_dot: Vec<f64> = self
            .specimen
            .attachments
            .iter()
            .map(|t| dot(t, qd))
            .collect();
        let mut generalised: Vec<f64> = self
            .specimen
            .static_force
            .iter()
            .map(|g| constants * g)
            .collect();
        let mut quantities = Vec::new();
        let mut tests = Vec::new();
        for e in &self.specimen.elements {
            let el = &e.element;
            let xe = dot(&e.dof_coefficients, q) + dot(&e.input_coefficients, w);
            let ve = dot(&e.dof_coefficients, qd) + dot(&e.input_coefficients, w_dot);
            let f =
                el.stiffness_n_per_m * xe + el.damping_n_s_per_m * ve + constants * el.preload_n;
            if el.lifts_off() {
                quantities.push(f);
                tests.push(RegimeTest::NonNegative);
            }
            for (g, a) in generalised.iter_mut().zip(&e.dof_coefficients) {
                *g -= a * f;
            }
        }
        let act_states = &x[2 * n..];
        let state_of = |j: usize| -> [f64; ACTUATOR_STATES] {
            let mut s = [0.0; ACTUATOR_STATES];
            copy(
                &mut s,
                &act_states[j * ACTUATOR_STATES..(j + 1) * ACTUATOR_STATES],
            );
            s
        };
        let mut forces = vec![0.0; ch];
        match (&self.drive, affine) {
            (Drive::Actuators(acts), _) => {
                for (j, a) in acts.iter().enumerate() {
                    forces[j] = a.piston_force(&state_of(j), y_dot[j]);
                }
            }
            (Drive::Ideal(_), Some(a)) => {
                for (j, f) in forces.iter_mut().enumerate() {
                    *f = constants * a.offset_n[j]
                        + dot(&a.position_n_per_m[j], &y)
                        + dot(&a.velocity_n_s_per_m[j], &y_dot)
                        + dot(&a.road_n_per_m[j], w)
                        + dot(&a.road_rate_n_s_per_m[j], w_dot);
                    if a.lower_bound_n[j] > f64::NEG_INFINITY {
                        quantities.push(*f);
                        tests.push(RegimeTest::Above(a.lower_bound_n[j]));
                    }
                }
            }
            (Drive::Ideal(_), None) => {}
        }
        for (t, f) in self.specimen.attachments.iter().zip(&forces) {
            for (g, ti) in generalised.iter_mut().zip(t) {
                *g += ti * f;
            }
        }
        let accel: Vec<f64> = (0..n)
            .map(|i| dot(row(&self.inv_mass, i, n), &generalised))
            .collect();
        let mut dx = vec![0.0; states];
        dx[..n].copy_from_slice(qd);
        dx[n..2 * n].copy_from_slice(&accel);
        if let Drive::Actuators(acts) = &self.drive {
            for (j, a) in acts.iter().enumerate() {
                let s = state_of(j);
                forces[j] -= a.moving_mass_kg() * dot(&self.specimen.attachments[j], &accel);
                let (u, demanded) = a.valve_signals(&s, demand[j], forces[j], y_dot[j]);
                quantities.extend([u, demanded, s[crate::actuator::state::LOAD_PRESSURE]]);
                tests.push(RegimeTest::Actuator(j));
                let start = 2 * n + j * ACTUATOR_STATES;
                dx[start..start + ACTUATOR_STATES].copy_from_slice(
                    &a.linear_regime_derivative(&s, demand[j], forces[j], y_dot[j]),
                );
            }
        }
        let outputs = y.into_iter().chain(y_dot).chain(forces).collect();
        (dx, outputs, quantities, tests)
    }
}
