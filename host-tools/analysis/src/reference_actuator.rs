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
//! [`ServoHydraulicActuator::REFERENCE`] is a hub actuator of a motorsport tyre rig,
//! calibrated so that the paper's tyre example reproduces the published figures: see the
//! constant's documentation and the tests in `host-tools/mil/tests/analyze.rs`.

use crate::error::{setup_error, Result};
use crate::poly::{add, mul, scale, Rational};
use serde::{Deserialize, Serialize};
use std::f64::consts::TAU;

/// Physical parameters of a force-controlled servo-hydraulic actuator (SI units).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ServoHydraulicActuator {
    /// Piston annulus area `A` (m²).
    pub piston_area_m2: f64,
    /// Total oil volume of both chambers and the lines to the valve `V` (m³).
    pub oil_volume_m3: f64,
    /// Effective bulk modulus of the oil `β` (Pa), including hose and air compliance.
    pub bulk_modulus_pa: f64,
    /// Servovalve flow at full opening at the operating pressure drop `K_q` (m³/s).
    pub flow_gain_m3_per_s: f64,
    /// Flow-pressure coefficient plus cross-piston leakage `K_c` (m³/(s·Pa)).
    pub flow_pressure_coefficient: f64,
    /// Servovalve natural frequency `ω_v / 2π` (Hz).
    pub valve_frequency_hz: f64,
    /// Servovalve damping ratio `ζ_v`.
    pub valve_damping_ratio: f64,
    /// Moving mass between the piston and the load cell `m_a` (kg).
    pub moving_mass_kg: f64,
    /// Viscous seal friction `c_a` (N·s/m).
    pub seal_damping_n_s_per_m: f64,
    /// Proportional force gain `K_p` (valve opening per newton of force error, 1/N).
    pub proportional_gain_per_n: f64,
    /// Integral force gain `K_i` (valve opening per newton-second, 1/(N·s)).
    pub integral_gain_per_n_s: f64,
    /// Fraction `κ` of the piston's flow demand fed forward from its velocity (0…1).
    pub velocity_feedforward: f64,
    /// Supply pressure (Pa). Not used by the linear model; the simulated rig uses it for the
    /// pressure and flow limits.
    pub supply_pressure_pa: f64,
}

impl ServoHydraulicActuator {
    /// The reference actuator: a hub actuator of a motorsport tyre rig.
    ///
    /// Values and why:
    /// - `A = 1.2e-3 m²`: 25 kN at 210 bar, enough for a racing car's corner load with margin.
    /// - `V = 3.0e-4 m³`, `β = 1.0e9 Pa`: a 0.1 m stroke cylinder plus manifold and hose
    ///   volume; effective (not pure-oil) bulk modulus. Hydraulic stiffness `k_h ≈ 19 kN/mm`.
    /// - `K_q = 1.0e-3 m³/s` (60 l/min), `K_c = 1e-13 m³/(s·Pa)`: a two-stage servovalve
    ///   sized for 0.8 m/s; small leakage.
    /// - Valve 100 Hz, `ζ_v = 0.7`: a high-response two-stage valve (its −90° frequency),
    ///   as motorsport rigs use.
    /// - `m_a = 6 kg`, `c_a = 600 N·s/m`: piston, rod and load-cell adaptor; seal friction.
    /// - `K_p`, `K_i`, `κ`: tuned so that the tyre example gives the paper's figures (body
    ///   bounce captured, a lightly damped MiL resonance near 17 Hz, open-loop phase lag beyond
    ///   180° with gain margin about 1.4; see `host-tools/mil/tests/analyze.rs`).
    pub const REFERENCE: Self = Self {
        piston_area_m2: 1.2e-3,
        oil_volume_m3: 3.0e-4,
        bulk_modulus_pa: 1.0e9,
        flow_gain_m3_per_s: 1.0e-3,
        flow_pressure_coefficient: 1.0e-13,
        valve_frequency_hz: 100.0,
        valve_damping_ratio: 0.7,
        moving_mass_kg: 6.0,
        seal_damping_n_s_per_m: 600.0,
        proportional_gain_per_n: 8.3e-6,
        integral_gain_per_n_s: 3.0e-4,
        velocity_feedforward: 1.0,
        supply_pressure_pa: 210e5,
    };

    /// Checks that every parameter is finite and in its physical range.
    ///
    /// # Errors
    /// Names the first offending field.
    pub fn validate(&self) -> Result<()> {
        let positive = [
            ("piston_area_m2", self.piston_area_m2),
            ("oil_volume_m3", self.oil_volume_m3),
            ("bulk_modulus_pa", self.bulk_modulus_pa),
            ("flow_gain_m3_per_s", self.flow_gain_m3_per_s),
            ("valve_frequency_hz", self.valve_frequency_hz),
            ("valve_damping_ratio", self.valve_damping_ratio),
            ("proportional_gain_per_n", self.proportional_gain_per_n),
            ("supply_pressure_pa", self.supply_pressure_pa),
        ];
        let non_negative = [
            ("flow_pressure_coefficient", self.flow_pressure_coefficient),
            ("moving_mass_kg", self.moving_mass_kg),
            ("seal_damping_n_s_per_m", self.seal_damping_n_s_per_m),
            ("integral_gain_per_n_s", self.integral_gain_per_n_s),
        ];
        for (name, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return Err(setup_error(format!("actuator {name} must be > 0 (is {v})")));
            }
        }
        for (name, v) in non_negative {
            if !(v.is_finite() && v >= 0.0) {
                return Err(setup_error(format!(
                    "actuator {name} must be >= 0 (is {v})"
                )));
            }
        }
        if !(0.0..=1.0).contains(&self.velocity_feedforward) {
            return Err(setup_error(format!(
                "actuator velocity_feedforward must be in 0..=1 (is {})",
                self.velocity_feedforward
            )));
        }
        Ok(())
    }

    /// Hydraulic stiffness `4 β A² / V` (N/m) of the oil columns with the valve closed.
    pub fn hydraulic_stiffness(&self) -> f64 {
        4.0 * self.bulk_modulus_pa * self.piston_area_m2.powi(2) / self.oil_volume_m3
    }

    /// The polynomials `(A K_q V_n C_n, D, r_f numerator)` of the module documentation.
    fn polynomials(&self) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let a = self.piston_area_m2;
        let kq = self.flow_gain_m3_per_s;
        let wv = TAU * self.valve_frequency_hz;
        let vn = vec![wv * wv];
        let vd = vec![1.0, 2.0 * self.valve_damping_ratio * wv, wv * wv];
        let hd = vec![
            self.oil_volume_m3 / (4.0 * self.bulk_modulus_pa),
            self.flow_pressure_coefficient,
        ];
        let cn = vec![self.proportional_gain_per_n, self.integral_gain_per_n_s];
        let cd = vec![1.0, 0.0];
        let tracking_num = scale(&mul(&vn, &cn), a * kq);
        let den = add(&mul(&mul(&hd, &vd), &cd), &tracking_num);
        let velocity_path = mul(
            &scale(&[1.0, 0.0], a * a * (1.0 - self.velocity_feedforward)),
            &mul(&vd, &cd),
        );
        let inertia_path = mul(
            &[self.moving_mass_kg, self.seal_damping_n_s_per_m, 0.0],
            &mul(&mul(&hd, &vd), &cd),
        );
        let disturbance_num = scale(&add(&velocity_path, &inertia_path), -1.0);
        (tracking_num, den, disturbance_num)
    }

    /// Tracking response `p_f(s)`: load-cell force per force command (dimensionless), with the
    /// rod held still.
    ///
    /// # Errors
    /// Invalid parameters.
    pub fn tracking(&self) -> Result<Rational> {
        self.validate()?;
        let (num, den, _) = self.polynomials();
        Rational::new(num, den)
    }

    /// Disturbance response `r_f(s)`: load-cell force per rod displacement imposed by the
    /// specimen (N/m), with the force command held at zero.
    ///
    /// Improper (it grows as `−m_a s²` at high frequency: the moving mass).
    ///
    /// # Errors
    /// Invalid parameters.
    pub fn disturbance(&self) -> Result<Rational> {
        self.validate()?;
        let (_, den, num) = self.polynomials();
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
