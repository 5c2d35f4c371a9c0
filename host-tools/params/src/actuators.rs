//! The reference servo-hydraulic actuators' physical parameters. Their linear responses
//! (tracking and disturbance, the paper's `P`, `R`) are derived in `mil-analysis`
//! (`reference_actuator`, `position_servo`); the simulated rig integrates the force
//! actuator's nonlinear equations (`mil-rig`'s `actuator`).

use crate::ParamError;
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
    pub fn validate(&self) -> Result<(), ParamError> {
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
                return Err(ParamError(format!("actuator {name} must be > 0 (is {v})")));
            }
        }
        for (name, v) in non_negative {
            if !(v.is_finite() && v >= 0.0) {
                return Err(ParamError(format!("actuator {name} must be >= 0 (is {v})")));
            }
        }
        if !(0.0..=1.0).contains(&self.velocity_feedforward) {
            return Err(ParamError(format!(
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
}

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
    pub fn validate(&self) -> Result<(), ParamError> {
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
                return Err(ParamError(format!(
                    "position servo {name} must be > 0 (is {v})"
                )));
            }
        }
        let tau = self.valve_time_constant_s;
        if !(tau.is_finite() && tau >= 0.0) {
            return Err(ParamError(format!(
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
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_references_are_valid() {
        ServoHydraulicActuator::REFERENCE.validate().unwrap();
        PositionServoActuator::REFERENCE.validate().unwrap();
    }

    #[test]
    fn an_invalid_parameter_is_named_with_its_value() {
        let e = ServoHydraulicActuator {
            piston_area_m2: f64::NAN,
            ..ServoHydraulicActuator::REFERENCE
        }
        .validate()
        .unwrap_err();
        assert!(e.0.contains("piston_area_m2") && e.0.contains("NaN"), "{e}");
        let e = ServoHydraulicActuator {
            velocity_feedforward: 1.5,
            ..ServoHydraulicActuator::REFERENCE
        }
        .validate()
        .unwrap_err();
        assert!(e.0.contains("velocity_feedforward"), "{e}");
        let e = PositionServoActuator {
            valve_time_constant_s: -1e-3,
            ..PositionServoActuator::REFERENCE
        }
        .validate()
        .unwrap_err();
        assert!(e.0.contains("valve_time_constant_s"), "{e}");
    }

    /// The documented figures of the references: `k_h ≈ 19 kN/mm` for the force actuator,
    /// `k_h = 1e7 N/m`, oil column at 356 Hz and static compliance 4.7e-7 m/N for the
    /// position servo.
    #[test]
    fn the_derived_quantities_match_the_documentation() {
        let k = ServoHydraulicActuator::REFERENCE.hydraulic_stiffness();
        assert!((k - 19.2e6).abs() < 0.1e6, "{k}");
        let p = PositionServoActuator::REFERENCE;
        assert!((p.hydraulic_stiffness() - 1e7).abs() < 1.0);
        let f = p.hydraulic_frequency() / TAU;
        assert!((f - 356.0).abs() < 1.0, "{f}");
        let c = p.static_compliance();
        assert!((c - 4.7e-7).abs() < 0.05e-7, "{c}");
    }
}
