//! The reference force-controlled servo-hydraulic actuator and its linear responses.
//!
//! ## Model (linearised about mid-stroke, zero load pressure)
//! - Servovalve: spool opening `x_v` (fraction of full opening, −1…1) follows the valve
//!   command through a second-order lag `G_v(s) = ω_v² / (s² + 2 ζ_v ω_v s + ω_v²)`.
//! - Orifice flow: `Q = K_q x_v − K_c P_L` (`K_q`: flow at full opening at the operating
//!   pressure drop, m³/s; `K_c`: total flow-pressure coefficient including leakage, m³/(s Pa)).
//! - Chamber compressibility (symmetric piston, total oil volume `V`, bulk modulus `β`):
//!   `Q − A ẏ = V/(4β) Ṗ_L`, so the hydraulic stiffness is `k_h = 4 β A² / V`.
//! - Load cell between the piston rod and the specimen: `F = A P_L − m_a ÿ − c_a ẏ`
//!   (`m_a`: moving mass in front of the load cell side; `c_a`: seal friction, viscous).
//! - Force controller (the servo controller's "servovalve loop"): proportional-integral on
//!   the force error, `u = (K_p + K_i/s)(F_c − F)`, plus velocity feed-forward that supplies
//!   the fraction `κ` of the flow `A ẏ` the piston motion draws. The feed-forward is taken
//!   as compensated for the valve dynamics (it adds `κ A ẏ` to the flow directly), as
//!   servo controllers do with a valve-inverse lead on the velocity signal.
//!
//! With `y` (rod displacement, imposed by the specimen) an independent input:
//! `F = p_f(s) F_c + r_f(s) y` where, with `H_d = V s/(4β) + K_c`, `G_v = V_n/V_d` and
//! `C = C_n/C_d` (`C_n = K_p s + K_i`, `C_d = s`),
//!
//! ```text
//! D(s)   = H_d V_d C_d + A K_q V_n C_n
//! p_f(s) = A K_q V_n C_n / D(s)
//! r_f(s) = −[(1 − κ) A² s V_d C_d + (m_a s² + c_a s) H_d V_d C_d] / D(s)
//! ```
//!
//! `p_f` is the tracking response (dimensionless) and `r_f` the disturbance response (N/m),
//! the `P_f`, `R_f` of the paper's framework. Without feed-forward (`κ = 0`) the actuator
//! behaves towards a moving specimen like a damper `A/(K_q K_p)` (a very large one); this is
//! why force-controlled rigs use velocity feed-forward, and why `r_f` is small in the paper.
//!
//! ## Calibration
//! [`ServoHydraulicActuator::REFERENCE`] (in `mil-params`) is a hub actuator of a motorsport tyre rig,
//! calibrated so that the paper's tyre example reproduces the published figures: see the
//! constant's documentation and the tests in `host-tools/mil/tests/analyze.rs`.

use crate::error::Result;
use crate::poly::{add, mul, scale, Rational};
use crate::response::LinearActuator;
use mil_params::ServoHydraulicActuator;
use std::f64::consts::TAU;

/// The polynomials `(A K_q V_n C_n, D, r_f numerator)` of the module documentation.
fn polynomials(a: &ServoHydraulicActuator) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let area = a.piston_area_m2;
    let kq = a.flow_gain_m3_per_s;
    let wv = TAU * a.valve_frequency_hz;
    let vn = vec![wv * wv];
    let vd = vec![1.0, 2.0 * a.valve_damping_ratio * wv, wv * wv];
    let hd = vec![
        a.oil_volume_m3 / (4.0 * a.bulk_modulus_pa),
        a.flow_pressure_coefficient,
    ];
    let cn = vec![a.proportional_gain_per_n, a.integral_gain_per_n_s];
    let cd = vec![1.0, 0.0];
    let tracking_num = scale(&mul(&vn, &cn), area * kq);
    let den = add(&mul(&mul(&hd, &vd), &cd), &tracking_num);
    let velocity_path = mul(
        &scale(&[1.0, 0.0], area * area * (1.0 - a.velocity_feedforward)),
        &mul(&vd, &cd),
    );
    let inertia_path = mul(
        &[a.moving_mass_kg, a.seal_damping_n_s_per_m, 0.0],
        &mul(&mul(&hd, &vd), &cd),
    );
    let disturbance_num = scale(&add(&velocity_path, &inertia_path), -1.0);
    (tracking_num, den, disturbance_num)
}

impl LinearActuator for ServoHydraulicActuator {
    /// Tracking response `p_f(s)`: load-cell force per force command (dimensionless), with the
    /// rod held still.
    ///
    /// # Errors
    /// Invalid parameters.
    fn tracking(&self) -> Result<Rational> {
        self.validate()?;
        let (num, den, _) = polynomials(self);
        Rational::new(num, den)
    }

    /// Disturbance response `r_f(s)`: load-cell force per rod displacement imposed by the
    /// specimen (N/m), with the force command held at zero.
    ///
    /// Improper (it grows as `−m_a s²` at high frequency: the moving mass).
    ///
    /// # Errors
    /// Invalid parameters.
    fn disturbance(&self) -> Result<Rational> {
        self.validate()?;
        let (_, den, num) = polynomials(self);
        Rational::new(num, den)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reference_is_valid_and_tracks_at_low_frequency() {
        let act = ServoHydraulicActuator::REFERENCE;
        act.validate().unwrap();
        // Integral action: unit static gain despite leakage; no disturbance at rest.
        let p = act.tracking().unwrap().response(1e-4);
        assert!((p - 1.0).norm() < 1e-6, "{p}");
        let r = act.disturbance().unwrap().response(1e-4);
        assert!(r.norm() < 1e-6, "{r}");
    }

    #[test]
    fn proportional_only_with_leakage_has_the_static_gain_of_its_loop() {
        let act = ServoHydraulicActuator {
            integral_gain_per_n_s: 0.0,
            flow_pressure_coefficient: 1e-12,
            ..ServoHydraulicActuator::REFERENCE
        };
        let g = act.piston_area_m2 * act.flow_gain_m3_per_s * act.proportional_gain_per_n;
        let expected = g / (g + act.flow_pressure_coefficient);
        let p = act.tracking().unwrap().response(1e-4);
        assert!((p.norm() - expected).abs() < 1e-6, "{p} vs {expected}");
    }

    #[test]
    fn without_feedforward_a_moving_rod_sees_the_flow_damper() {
        // κ = 0, K_i = 0, K_c = 0: r_f(jω) → −j ω A/(K_q K_p) at low frequency.
        let act = ServoHydraulicActuator {
            velocity_feedforward: 0.0,
            integral_gain_per_n_s: 0.0,
            flow_pressure_coefficient: 0.0,
            seal_damping_n_s_per_m: 0.0,
            moving_mass_kg: 0.0,
            ..ServoHydraulicActuator::REFERENCE
        };
        let r = act.disturbance().unwrap();
        let f = 0.01;
        let c = act.piston_area_m2 / (act.flow_gain_m3_per_s * act.proportional_gain_per_n);
        let h = r.response(f);
        let expected = -c * TAU * f;
        assert!(
            (h.im - expected).abs() < 1e-3 * expected.abs(),
            "{h} vs {expected}"
        );
        assert!(h.re.abs() < 1e-2 * expected.abs());
    }

    #[test]
    fn invalid_parameters_are_named() {
        let act = ServoHydraulicActuator {
            piston_area_m2: f64::NAN,
            ..ServoHydraulicActuator::REFERENCE
        };
        let e = act.tracking().unwrap_err().to_string();
        assert!(e.contains("piston_area_m2"), "{e}");
    }
}
