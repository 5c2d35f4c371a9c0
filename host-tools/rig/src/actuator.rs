//! The nonlinear force-controlled servo-hydraulic actuator of the simulated rig.
//!
//! The physics of [`mil_params::ServoHydraulicActuator`] (see `reference_actuator` in the
//! analysis library) without its linearisation:
//!
//! ```text
//! force loop     u = K_p (F_c − F) + K_i q,   q̇ = F_c − F     (analogue PI, the rig's own
//!                                                             "servovalve loop")
//! servovalve     ẍ_v = ω_v² (sat(u) − x_v) − 2 ζ_v ω_v ẋ_v     (sat: ±spool_limit)
//! feed-forward   x_ff = κ A ẏ / K_q                           (valve-compensated, so it
//!                                                             bypasses the spool dynamics)
//! ΔP compensation x = clamp(x_d / √((P_s − sgn(x_d) P_L)⁺ / P_s), ±spool_limit),
//!                x_d = x_v + x_ff                             (the servo controller's flow
//!                                                             linearisation)
//! orifice flow   Q = K_q x √((P_s − sgn(x) P_L)⁺ / P_s)         (critically centred
//!                                                             four-way valve, return at 0)
//! chambers       V/(4β) Ṗ_L = Q − A ẏ − K_c P_L
//! piston force   F_p = A P_L − c_a ẏ − F_coulomb tanh(ẏ / v_ε)   (seals)
//! load cell      F = F_p − m_a ÿ                               (rod mass in front of it)
//! ```
//!
//! `K_q` is the flow at full opening with no load (`P_L = 0`), the pressure drop across the
//! two metering lands then being the supply pressure `P_s`; the flow falls to zero as `P_L`
//! approaches `±P_s` (the supply pressure limit: the actuator cannot push harder than
//! `A P_s`). The servo controller linearises the valve with the measured load pressure (ΔP
//! compensation), so that below saturation `Q = K_q x_d` at any static load: without it the
//! flow gain differs by several per cent between the two flow directions at the tyre rig's
//! static load, and the velocity feed-forward (which must cancel `A ẏ` to within about 2 %
//! for the loop to keep its gain margin) leaves a direction-dependent residual that makes
//! the loop strongly nonlinear ([`ActuatorEffects::uncompensated_orifice`] switches it off
//! as a hidden effect). Near the supply pressure the compensation runs into the spool limit:
//! the flow capacity, and so the force rate, falls. About `x = 0`, `P_L = 0`, `ẏ = 0` every nonlinearity is smooth or inactive and
//! the equations are exactly the reference actuator's, so the linearised plant has its
//! `p_f(s)` and `r_f(s)` (tested in `tests/linearisation.rs`).
//!
//! Switchable effects (off by default, [`ActuatorEffects`]): a lower spool saturation, a
//! spool rate limit, and Coulomb seal friction. The PI integrator stops integrating while
//! the valve command is saturated and the error would drive it further (conditional
//! integration: a real servo controller's anti-windup).
//!
//! The rod weight is not modelled (rig actuators carry it by a static offset of their
//! controller or a counterbalance).

use mil_params::ServoHydraulicActuator;
use serde::{Deserialize, Serialize};
use std::f64::consts::TAU;

/// Switchable nonlinear effects of the actuator, all off by default.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ActuatorEffects {
    /// Servovalve saturation: the largest spool opening (fraction of full opening, 0…1];
    /// `None`: 1 (the spool's end stops).
    pub spool_limit: Option<f64>,
    /// Servovalve rate limit: the largest spool speed (full openings per second, 1/s), e.g.
    /// a pilot stage that runs out of flow; `None`: no limit.
    pub spool_rate_limit_per_s: Option<f64>,
    /// Coulomb friction of the piston and rod seals (N), smoothed over ±1 mm/s.
    pub coulomb_friction_n: Option<f64>,
    /// Switch off the servo controller's ΔP compensation: the flow gain then falls by
    /// `√(1 − P_L/P_s)` when the load pressure opposes the flow (3 % at the tyre rig's
    /// static load) and rises when it assists it, a kink at zero flow that the velocity
    /// feed-forward, tuned at `P_L = 0`, no longer cancels.
    pub uncompensated_orifice: bool,
}

/// Velocity (m/s) over which the Coulomb seal friction is smoothed (`tanh(ẏ/v_ε)`).
pub const FRICTION_SMOOTHING_M_PER_S: f64 = 1e-3;

/// Errors of the actuator parameters.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("actuator: {0}")]
pub struct ActuatorError(pub String);

/// Number of states of one actuator (`x_v`, `ẋ_v`, `P_L`, `q`).
pub const ACTUATOR_STATES: usize = 4;

/// State indices of one actuator.
pub mod state {
    /// Spool opening `x_v` (fraction of full opening).
    pub const SPOOL: usize = 0;
    /// Spool velocity `ẋ_v` (1/s).
    pub const SPOOL_RATE: usize = 1;
    /// Load pressure `P_L` (Pa).
    pub const LOAD_PRESSURE: usize = 2;
    /// Integral of the force error `q` (N·s).
    pub const FORCE_ERROR_INTEGRAL: usize = 3;
}

/// The nonlinear actuator: physical parameters, effects and the coefficients derived from
/// them once.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ForceActuator {
    /// Physical parameters and the force loop (the reference actuator's).
    pub params: ServoHydraulicActuator,
    /// Switchable effects.
    pub effects: ActuatorEffects,
    wv2: f64,
    two_zeta_wv: f64,
    spool_limit: f64,
    rate_limit: f64,
    friction: f64,
    compressibility_gain: f64,
    feedforward_gain: f64,
    inverse_supply_pressure: f64,
}

impl ForceActuator {
    /// Validates the parameters and derives the coefficients.
    ///
    /// # Errors
    /// Invalid physical parameters or effects (named).
    pub fn new(
        params: ServoHydraulicActuator,
        effects: ActuatorEffects,
    ) -> Result<Self, ActuatorError> {
        params
            .validate()
            .map_err(|e| ActuatorError(e.to_string()))?;
        let spool_limit = effects.spool_limit.unwrap_or(1.0);
        if !(spool_limit > 0.0 && spool_limit <= 1.0) {
            return Err(ActuatorError(format!(
                "spool_limit must be in (0, 1] (is {spool_limit})"
            )));
        }
        let rate_limit = effects.spool_rate_limit_per_s.unwrap_or(f64::INFINITY);
        if rate_limit.is_nan() || rate_limit <= 0.0 {
            return Err(ActuatorError(format!(
                "spool_rate_limit_per_s must be > 0 (is {rate_limit})"
            )));
        }
        let friction = effects.coulomb_friction_n.unwrap_or(0.0);
        if !(friction.is_finite() && friction >= 0.0) {
            return Err(ActuatorError(format!(
                "coulomb_friction_n must be >= 0 (is {friction})"
            )));
        }
        let wv = TAU * params.valve_frequency_hz;
        Ok(Self {
            params,
            effects,
            wv2: wv * wv,
            two_zeta_wv: 2.0 * params.valve_damping_ratio * wv,
            spool_limit,
            rate_limit,
            friction,
            compressibility_gain: 4.0 * params.bulk_modulus_pa / params.oil_volume_m3,
            feedforward_gain: params.velocity_feedforward * params.piston_area_m2
                / params.flow_gain_m3_per_s,
            inverse_supply_pressure: 1.0 / params.supply_pressure_pa,
        })
    }

    /// Moving mass in front of the load cell `m_a` (kg), added to the specimen's mass at
    /// the attachment.
    pub fn moving_mass_kg(&self) -> f64 {
        self.params.moving_mass_kg
    }

    /// Piston force on the rod (N) at actuator state `x` and rod velocity `rod_velocity`
    /// (m/s).
    #[inline]
    pub fn piston_force(&self, x: &[f64; ACTUATOR_STATES], rod_velocity: f64) -> f64 {
        let p = &self.params;
        let mut f =
            p.piston_area_m2 * x[state::LOAD_PRESSURE] - p.seal_damping_n_s_per_m * rod_velocity;
        if self.friction > 0.0 {
            f -= self.friction * (rod_velocity / FRICTION_SMOOTHING_M_PER_S).tanh();
        }
        f
    }

    /// State derivatives given the force demand `demand_n`, the load-cell force
    /// `load_cell_n` and the rod velocity (m/s).
    #[inline]
    pub fn derivative(
        &self,
        x: &[f64; ACTUATOR_STATES],
        demand_n: f64,
        load_cell_n: f64,
        rod_velocity: f64,
    ) -> [f64; ACTUATOR_STATES] {
        let p = &self.params;
        let error = demand_n - load_cell_n;
        let u = p.proportional_gain_per_n * error
            + p.integral_gain_per_n_s * x[state::FORCE_ERROR_INTEGRAL];
        let command = u.clamp(-self.spool_limit, self.spool_limit);
        // Conditional integration: hold the integral while saturated further outwards.
        let integrating = u == command || (u > command) != (error > 0.0);
        let spool_rate = x[state::SPOOL_RATE].clamp(-self.rate_limit, self.rate_limit);
        let mut spool_acceleration =
            self.wv2 * (command - x[state::SPOOL]) - self.two_zeta_wv * x[state::SPOOL_RATE];
        if x[state::SPOOL_RATE].abs() >= self.rate_limit
            && (spool_acceleration > 0.0) == (x[state::SPOOL_RATE] > 0.0)
        {
            spool_acceleration = 0.0;
        }
        // Flow demand as a fraction of K_q: the spool's and the feed-forward's.
        let demanded = x[state::SPOOL] + self.feedforward_gain * rod_velocity;
        let pl = x[state::LOAD_PRESSURE];
        let drop = (p.supply_pressure_pa - demanded.signum() * pl).max(0.0);
        let root = (drop * self.inverse_supply_pressure).sqrt();
        let flow_fraction = if self.effects.uncompensated_orifice {
            demanded.clamp(-self.spool_limit, self.spool_limit) * root
        } else if root >= 1e-3 && demanded.abs() <= self.spool_limit * root {
            // ΔP compensation: the spool opens to demanded / root and the flow is the
            // demanded one (the common case, computed without the division).
            demanded
        } else {
            // Compensation up to the spool limit: the flow capacity falls with the drop.
            (demanded / root.max(1e-3)).clamp(-self.spool_limit, self.spool_limit) * root
        };
        let flow = p.flow_gain_m3_per_s * flow_fraction;
        let pressure_rate = self.compressibility_gain
            * (flow - p.piston_area_m2 * rod_velocity - p.flow_pressure_coefficient * pl);
        [
            spool_rate,
            spool_acceleration,
            pressure_rate,
            if integrating { error } else { 0.0 },
        ]
    }

    /// Whether the actuator has a linear regime: no Coulomb seal friction, no spool rate
    /// limit and the ΔP compensation on. Inside that regime (see
    /// [`ForceActuator::in_linear_regime`]) [`ForceActuator::derivative`] equals the affine
    /// [`ForceActuator::linear_regime_derivative`] and [`ForceActuator::piston_force`] is
    /// `A P_L − c_a ẏ`.
    pub fn has_linear_regime(&self) -> bool {
        self.friction == 0.0
            && self.rate_limit == f64::INFINITY
            && !self.effects.uncompensated_orifice
    }

    /// The valve command `u = K_p (F_c − F) + K_i q` (fraction of full opening) and the
    /// flow demand `x_v + κ A ẏ / K_q` (fraction of `K_q`) at actuator state `x`, force
    /// demand `demand_n` (N), load-cell force `load_cell_n` (N) and rod velocity (m/s): the
    /// two signals [`ForceActuator::in_linear_regime`] tests, as
    /// [`ForceActuator::derivative`] computes them.
    #[inline]
    pub fn valve_signals(
        &self,
        x: &[f64; ACTUATOR_STATES],
        demand_n: f64,
        load_cell_n: f64,
        rod_velocity: f64,
    ) -> (f64, f64) {
        let p = &self.params;
        let u = p.proportional_gain_per_n * (demand_n - load_cell_n)
            + p.integral_gain_per_n_s * x[state::FORCE_ERROR_INTEGRAL];
        (u, x[state::SPOOL] + self.feedforward_gain * rod_velocity)
    }

    /// Whether the valve command `u` (fraction of full opening), the flow demand `demanded`
    /// (fraction of `K_q`) and the load pressure `load_pressure_pa` (Pa) lie in the linear
    /// regime, in which [`ForceActuator::derivative`] takes exactly its affine branches: the
    /// command within the spool limit (so the integrator integrates), and the ΔP-compensated
    /// spool opening within it too. `false` for NaN, and always `false` without
    /// [`ForceActuator::has_linear_regime`].
    #[inline]
    pub fn in_linear_regime(&self, u: f64, demanded: f64, load_pressure_pa: f64) -> bool {
        self.has_linear_regime() && self.linear_regime_holds(u, demanded, load_pressure_pa)
    }

    /// [`ForceActuator::in_linear_regime`] for an actuator known to have a linear regime
    /// (the plant's exact steps test it every internal step).
    #[inline]
    pub(crate) fn linear_regime_holds(&self, u: f64, demanded: f64, load_pressure_pa: f64) -> bool {
        // `signum(demanded) · P_L` (NaN `demanded` fails the last test anyway).
        let signed = if demanded.is_sign_negative() {
            -load_pressure_pa
        } else {
            load_pressure_pa
        };
        let drop = (self.params.supply_pressure_pa - signed).max(0.0);
        // `root ≥ 1e-3 ∧ |demanded| ≤ limit·root` with `root = √(drop/P_s)`, squared: the
        // same set without a square root.
        let ratio = drop * self.inverse_supply_pressure;
        u.abs() <= self.spool_limit
            && ratio >= 1e-6
            && demanded * demanded <= self.spool_limit * self.spool_limit * ratio
    }

    /// State derivatives in the linear regime (the affine branches of
    /// [`ForceActuator::derivative`]: unsaturated command, integrating, compensated flow
    /// `K_q x_d`), for any state; arguments as there. Equal to
    /// [`ForceActuator::derivative`] wherever [`ForceActuator::in_linear_regime`] holds.
    #[inline]
    pub fn linear_regime_derivative(
        &self,
        x: &[f64; ACTUATOR_STATES],
        demand_n: f64,
        load_cell_n: f64,
        rod_velocity: f64,
    ) -> [f64; ACTUATOR_STATES] {
        let p = &self.params;
        let error = demand_n - load_cell_n;
        let (u, demanded) = self.valve_signals(x, demand_n, load_cell_n, rod_velocity);
        let spool_acceleration =
            self.wv2 * (u - x[state::SPOOL]) - self.two_zeta_wv * x[state::SPOOL_RATE];
        let flow = p.flow_gain_m3_per_s * demanded;
        let pressure_rate = self.compressibility_gain
            * (flow
                - p.piston_area_m2 * rod_velocity
                - p.flow_pressure_coefficient * x[state::LOAD_PRESSURE]);
        [
            x[state::SPOOL_RATE],
            spool_acceleration,
            pressure_rate,
            error,
        ]
    }

    /// The state at rest holding the force `force_n` (N) with the rod still: `P_L = F/A`, and
    /// the spool opened just enough to feed the leakage at that pressure, held there by the
    /// integrator.
    pub fn equilibrium(&self, force_n: f64) -> [f64; ACTUATOR_STATES] {
        let p = &self.params;
        let pl = force_n / p.piston_area_m2;
        let leakage = p.flow_pressure_coefficient * pl;
        // The flow equals the leakage: Q = K_q x_v with ΔP compensation, else
        // K_q x_v √((P_s − sgn(x_v) P_L)/P_s).
        let sign = if leakage >= 0.0 { 1.0 } else { -1.0 };
        let drop = ((p.supply_pressure_pa - sign * pl) / p.supply_pressure_pa).max(1e-6);
        let gain = if self.effects.uncompensated_orifice {
            drop.sqrt()
        } else {
            1.0
        };
        let x = leakage / (p.flow_gain_m3_per_s * gain);
        let q = if p.integral_gain_per_n_s > 0.0 {
            x / p.integral_gain_per_n_s
        } else {
            0.0
        };
        let mut out = [0.0; ACTUATOR_STATES];
        out[state::SPOOL] = x;
        out[state::LOAD_PRESSURE] = pl;
        out[state::FORCE_ERROR_INTEGRAL] = q;
        out
    }
}
