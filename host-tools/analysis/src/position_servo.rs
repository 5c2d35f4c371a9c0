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

use crate::error::Result;
use crate::poly::{add, mul, Rational};
use crate::response::LinearActuator;
use mil_params::PositionServoActuator;

/// `(D, tracking numerator, disturbance numerator)`, descending powers of `s`.
fn polynomials(a: &PositionServoActuator) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let wh = a.hydraulic_frequency();
    let a2 = a.piston_area_m2.powi(2);
    let kce = a.flow_pressure_coefficient();
    let valve = [a.valve_time_constant_s, 1.0];
    let hydraulic = [1.0 / (wh * wh), a.moving_mass_kg * kce / a2, 1.0, 0.0];
    let den = add(&mul(&hydraulic, &valve), &[a.loop_gain_per_s]);
    let disturbance = mul(&[1.0 / a.hydraulic_stiffness(), kce / a2], &valve);
    (den, vec![a.loop_gain_per_s], disturbance)
}

impl LinearActuator for PositionServoActuator {
    /// Tracking response `p_d(s)`: rod position per position command (dimensionless), with
    /// no load.
    ///
    /// # Errors
    /// Invalid parameters.
    fn tracking(&self) -> Result<Rational> {
        self.validate()?;
        let (den, num, _) = polynomials(self);
        Rational::new(num, den)
    }

    /// Disturbance response `r_d(s)`: rod position per force the specimen applies to the
    /// rod (m/N), with the command held at zero.
    ///
    /// # Errors
    /// Invalid parameters.
    fn disturbance(&self) -> Result<Rational> {
        self.validate()?;
        let (den, _, num) = polynomials(self);
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
