//! The reference position-controlled servo-hydraulic actuator and its linear responses.
//!
//! ## Model (linearised about mid-stroke, zero load pressure)
//! - Servovalve: a first-order lag `1/(τ_v s + 1)` from the valve command to the flow (a
//!   small two-stage valve near 200 Hz, `ζ_v` 0.7, has the low-frequency lag
//!   `τ_v = 2 ζ_v/ω_v` ≈ 1.1 ms).
//! - Flow into the chambers: `Q = K_q K_p (x_c − x)/(τ_v s + 1) − K_ce p` with the load
//!   pressure `p`; `K_ce` lumps the valve's flow-pressure coefficient, leakage and the servo
//!   controller's pressure (ΔP) feedback.
//! - Compressibility: `(V/4β) s p = Q − A s x`, hydraulic stiffness `k_h = 4 β A²/V`.
//! - Rod: `m_a s² x = A p + F_load` (`F_load`: force the specimen applies to the rod).
//! - Position controller: proportional, loop (velocity) gain `K_v = K_q K_p / A` (1/s); no
//!   integral action (the flow-controlling valve already integrates).
//!
//! Eliminating `p` (with `ω_h² = k_h/m_a` and `K_ce = 2 ζ_h A²/(m_a ω_h)`, i.e. `K_ce` set
//! by the hydraulic damping ratio `ζ_h`):
//!
//! ```text
//! D(s)   = (s³/ω_h² + (m_a K_ce/A²) s² + s)(τ_v s + 1) + K_v
//! p_d(s) = K_v / D(s)                                   tracking (dimensionless)
//! r_d(s) = (s/k_h + K_ce/A²)(τ_v s + 1) / D(s)          compliance (m/N)
//! ```
//!
//! so that `x = p_d(s) x_c + r_d(s) F_load`: the `P_d`, `R_d` of the paper's framework.
//! `r_d(0) = K_ce/(A² K_v)` is the position loop's static compliance against a steady load;
//! above the loop bandwidth it falls to the order of the oil column `1/k_h`, and above `ω_h`
//! to the rod inertia `1/(m_a ω²)`.

use crate::error::{setup_error, Result};
use crate::poly::{add, mul, Rational};
use serde::{Deserialize, Serialize};
use std::f64::consts::TAU;

/// Physical parameters of a position-controlled servo-hydraulic actuator (SI units).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PositionServoActuator {
    /// Piston annulus area `A` (m²).
    pub piston_area_m2: f64,
    /// Total oil volume of both chambers and the lines to the valve `V` (m³).
    pub oil_volume_m3: f64,
    /// Effective bulk modulus of the oil `β` (Pa), including hose and air compliance.
    pub bulk_modulus_pa: f64,
    /// Moving mass of piston, rod and load-cell adaptor `m_a` (kg).
    pub moving_mass_kg: f64,
    /// Hydraulic damping ratio `ζ_h` of the oil column that sets `K_ce` (dimensionless).
    pub hydraulic_damping_ratio: f64,
    /// Servovalve first-order time constant `τ_v` (s).
    pub valve_time_constant_s: f64,
    /// Proportional position-loop (velocity) gain `K_v = K_q K_p / A` (1/s).
    pub loop_gain_per_s: f64,
}

impl PositionServoActuator {
    /// The reference position servo: a small actuator for a bench specimen (the paper's
    /// 2-DOF example), `A = 5e-4 m²` (10 kN at 210 bar), `V = 1e-4 m³`, `β = 1 GPa`
    /// (`k_h = 1e7 N/m`), `m_a = 2 kg` (oil column at 356 Hz), `ζ_h = 0.2`, `τ_v = 1.1 ms`,
    /// `K_v = 2π·30 1/s`. Closed-loop poles at 45 Hz and 100 Hz (real) and 350 Hz (ζ 0.2):
    /// −3 dB at 40 Hz, −90° at 62 Hz, no overshoot; static compliance 4.7e-7 m/N.
    pub const REFERENCE: Self = Self {
        piston_area_m2: 5.0e-4,
        oil_volume_m3: 1.0e-4,
        bulk_modulus_pa: 1.0e9,
        moving_mass_kg: 2.0,
        hydraulic_damping_ratio: 0.2,
        valve_time_constant_s: 1.1e-3,
        loop_gain_per_s: TAU * 30.0,
    };

    /// Checks that every parameter is finite and positive (`τ_v` may be zero: an ideal
    /// valve).
    ///
    /// # Errors
    /// Names the first offending field.
    pub fn validate(&self) -> Result<()> {
        let positive = [
            ("piston_area_m2", self.piston_area_m2),
            ("oil_volume_m3", self.oil_volume_m3),
            ("bulk_modulus_pa", self.bulk_modulus_pa),
            ("moving_mass_kg", self.moving_mass_kg),
            ("hydraulic_damping_ratio", self.hydraulic_damping_ratio),
            ("loop_gain_per_s", self.loop_gain_per_s),
        ];
        for (name, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return Err(setup_error(format!(
                    "position servo {name} must be > 0 (is {v})"
                )));
            }
        }
        let tau = self.valve_time_constant_s;
        if !(tau.is_finite() && tau >= 0.0) {
            return Err(setup_error(format!(
                "position servo valve_time_constant_s must be >= 0 (is {tau})"
            )));
        }
        Ok(())
    }

    /// Hydraulic (oil-column) stiffness `k_h = 4 β A²/V` (N/m).
    pub fn hydraulic_stiffness(&self) -> f64 {
        4.0 * self.bulk_modulus_pa * self.piston_area_m2.powi(2) / self.oil_volume_m3
    }

    /// Unloaded oil-column natural frequency `ω_h = √(k_h/m_a)` (rad/s).
    pub fn hydraulic_frequency(&self) -> f64 {
        (self.hydraulic_stiffness() / self.moving_mass_kg).sqrt()
    }

    /// Total flow-pressure coefficient `K_ce = 2 ζ_h A²/(m_a ω_h)` (m³/(s·Pa)).
    pub fn flow_pressure_coefficient(&self) -> f64 {
        2.0 * self.hydraulic_damping_ratio * self.piston_area_m2.powi(2)
            / (self.moving_mass_kg * self.hydraulic_frequency())
    }

    /// Static compliance of the position loop against a steady load, `K_ce/(A² K_v)` (m/N).
    pub fn static_compliance(&self) -> f64 {
        self.flow_pressure_coefficient() / (self.piston_area_m2.powi(2) * self.loop_gain_per_s)
    }

    /// `(D, tracking numerator, disturbance numerator)`, descending powers of `s`.
    fn polynomials(&self) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let wh = self.hydraulic_frequency();
        let a2 = self.piston_area_m2.powi(2);
        let kce = self.flow_pressure_coefficient();
        let valve = [self.valve_time_constant_s, 1.0];
        let hydraulic = [1.0 / (wh * wh), self.moving_mass_kg * kce / a2, 1.0, 0.0];
        let den = add(&mul(&hydraulic, &valve), &[self.loop_gain_per_s]);
        let disturbance = mul(&[1.0 / self.hydraulic_stiffness(), kce / a2], &valve);
        (den, vec![self.loop_gain_per_s], disturbance)
    }

    /// Tracking response `p_d(s)`: rod position per position command (dimensionless), with
    /// no load.
    ///
    /// # Errors
    /// Invalid parameters.
    pub fn tracking(&self) -> Result<Rational> {
        self.validate()?;
        let (den, num, _) = self.polynomials();
        Rational::new(num, den)
    }

    /// Disturbance response `r_d(s)`: rod position per force the specimen applies to the
    /// rod (m/N), with the command held at zero.
    ///
    /// # Errors
    /// Invalid parameters.
    pub fn disturbance(&self) -> Result<Rational> {
        self.validate()?;
        let (den, _, num) = self.polynomials();
        Rational::new(num, den)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reference_tracks_statically_with_the_loop_compliance() {
        let act = PositionServoActuator::REFERENCE;
        // At 1e-4 Hz the loop's lag is ω/K_v ≈ 3e-6 rad.
        let p = act.tracking().unwrap().response(1e-4);
        assert!((p - 1.0).norm() < 1e-5, "{p}");
        let r = act.disturbance().unwrap().response(1e-4);
        assert!(
            (r - act.static_compliance()).norm() < 1e-5 * act.static_compliance(),
            "{r}"
        );
        // The documented figures: k_h 1e7 N/m, static compliance 4.7e-7 m/N.
        assert!((act.hydraulic_stiffness() - 1.0e7).abs() < 1e-3);
        assert!((act.static_compliance() - 4.7e-7).abs() < 0.05e-7);
    }

    #[test]
    fn ideal_valve_lowers_the_order() {
        let act = PositionServoActuator {
            valve_time_constant_s: 0.0,
            ..PositionServoActuator::REFERENCE
        };
        let p = act.tracking().unwrap();
        assert_eq!(p.denominator.len(), 4, "{:?}", p.denominator);
    }

    #[test]
    fn invalid_parameters_are_named() {
        let act = PositionServoActuator {
            loop_gain_per_s: -1.0,
            ..PositionServoActuator::REFERENCE
        };
        let e = act.tracking().unwrap_err().to_string();
        assert!(e.contains("loop_gain_per_s"), "{e}");
    }
}
