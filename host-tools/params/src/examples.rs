//! The paper's examples (brief tables), in SI units: the tyre on a hub-coupled rig (section
//! 4), the aerodynamic model on a four-poster (section 3) and the 2-DOF example (Lim et al.).
//! The tyre's damping velocity is by default what the board's tyre computes (model-core's
//! velocity estimator at the controller's sample period and the model-core tyre's 500 Hz
//! cut-off).

use model_core::TyreParams;
use serde::{Deserialize, Serialize};

/// How the tyre example's analysis obtains the tyre's deflection velocity.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TyreVelocity {
    /// As the board's tyre model computes it: model-core's velocity estimator at the
    /// controller's sample period with [`TyreExample::velocity_cutoff_hz`]
    /// (`mil_analysis::system::VelocityEstimate::Board`).
    #[default]
    Board,
    /// The ideal continuous derivative `c_t s`
    /// (`mil_analysis::system::VelocityEstimate::Continuous`), e.g. to see what the
    /// estimator costs.
    Continuous,
}

/// Quarter car on a hub-coupled rig with a numerical tyre (paper section 4, Table 2).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TyreExample {
    /// Sprung mass `m_s` (kg).
    pub sprung_mass_kg: f64,
    /// Suspension stiffness `k_c` (N/m).
    pub suspension_stiffness: f64,
    /// Suspension damping `c_c` (N·s/m).
    pub suspension_damping: f64,
    /// Unsprung mass `m_u` (kg).
    pub unsprung_mass_kg: f64,
    /// Tyre stiffness `k_t` (N/m).
    pub tyre_stiffness: f64,
    /// Tyre damping `c_t` (N·s/m).
    pub tyre_damping: f64,
    /// Cut-off (Hz) of the low-pass of the board's tyre deflection-velocity estimator
    /// (`model_core::TyreParams::velocity_cutoff_hz`; 0: plain backward difference, at most
    /// 20 kHz). Default: the model-core tyre's, [`TyreParams::PAPER`] (500 Hz).
    pub velocity_cutoff_hz: f64,
    /// Whether the analysis uses the board's velocity estimator (default) or `c_t s`.
    pub velocity_estimate: TyreVelocity,
}

impl Default for TyreExample {
    fn default() -> Self {
        Self {
            sprung_mass_kg: 150.0,
            suspension_stiffness: 120e3,
            suspension_damping: 2.5e3,
            unsprung_mass_kg: 20.0,
            tyre_stiffness: 250e3,
            tyre_damping: 500.0,
            velocity_cutoff_hz: f64::from(TyreParams::PAPER.velocity_cutoff_hz),
            velocity_estimate: TyreVelocity::Board,
        }
    }
}

/// Half car (heave and pitch) on a four-poster with a numerical aerodynamic model driving
/// front and rear down-force actuators (paper section 3, Table 1).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct AeroExample {
    /// Body mass `m_b` (kg).
    pub body_mass_kg: f64,
    /// Pitch inertia `i_b` (kg·m²).
    pub pitch_inertia_kg_m2: f64,
    /// Front suspension stiffness `k_f` (N/m, both wheels).
    pub front_stiffness: f64,
    /// Front suspension damping `c_f` (N·s/m).
    pub front_damping: f64,
    /// Rear suspension stiffness `k_r` (N/m).
    pub rear_stiffness: f64,
    /// Rear suspension damping `c_r` (N·s/m).
    pub rear_damping: f64,
    /// Centroid to front axle `l_f` (m).
    pub front_axle_m: f64,
    /// Centroid to rear axle `l_r` (m).
    pub rear_axle_m: f64,
    /// Aerodynamic stiffness `K_i`, rows `[F_z; M_θ]`, columns `[z; θ]` (N/m, N/rad,
    /// N·m/m, N·m/rad), at the example's speed.
    pub aero_stiffness: [[f64; 2]; 2],
}

impl Default for AeroExample {
    fn default() -> Self {
        Self {
            body_mass_kg: 550.0,
            pitch_inertia_kg_m2: 350.0,
            front_stiffness: 300e3,
            front_damping: 2e3,
            rear_stiffness: 240e3,
            rear_damping: 4e3,
            front_axle_m: 1.8,
            rear_axle_m: 1.4,
            aero_stiffness: [[-83.9e3, 45.3e3], [-51.9e3, 231.6e3]],
        }
    }
}

impl AeroExample {
    /// Axle transform `L = [1 −l_f; 1 l_r]`: axle displacements `[front; rear]` (m) from the
    /// body's `[z; θ]` (m, rad).
    pub fn axle_transform(&self) -> [[f64; 2]; 2] {
        [[1.0, -self.front_axle_m], [1.0, self.rear_axle_m]]
    }
}

/// The 2-DOF example (Lim et al.): numerical mass `m_n` on `(k_n, c_n)` from ground input
/// `z_n`, physical mass `m_p` on `(k_p, c_p)` from `z_p`, joined by `(k_i, c_i)`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TwoDofExample {
    /// Numerical mass (kg).
    pub numerical_mass_kg: f64,
    /// Numerical ground stiffness (N/m).
    pub numerical_stiffness: f64,
    /// Numerical ground damping (N·s/m).
    pub numerical_damping: f64,
    /// Physical mass (kg).
    pub physical_mass_kg: f64,
    /// Physical ground stiffness (N/m).
    pub physical_stiffness: f64,
    /// Physical ground damping (N·s/m).
    pub physical_damping: f64,
    /// Interface stiffness (N/m).
    pub interface_stiffness: f64,
    /// Interface damping (N·s/m).
    pub interface_damping: f64,
    /// Where the interface spring-damper is.
    pub interface_in_numerical: bool,
}

impl Default for TwoDofExample {
    fn default() -> Self {
        Self {
            numerical_mass_kg: 10.0,
            numerical_stiffness: 4.0e4,
            numerical_damping: 20.0,
            physical_mass_kg: 5.0,
            physical_stiffness: 2.0e4,
            physical_damping: 10.0,
            interface_stiffness: 1.0e4,
            interface_damping: 5.0,
            interface_in_numerical: true,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The tyre's default velocity cut-off is the board tyre's, so that the analysis and
    /// the board agree unless a set-up says otherwise.
    #[test]
    fn the_tyre_cutoff_is_the_boards() {
        assert_eq!(
            TyreExample::default().velocity_cutoff_hz,
            f64::from(TyreParams::PAPER.velocity_cutoff_hz)
        );
    }

    #[test]
    fn unknown_keys_are_refused() {
        let e = toml::from_str::<TyreExample>("tyre_stifness = 1.0").unwrap_err();
        assert!(e.to_string().contains("tyre_stifness"), "{e}");
    }

    #[test]
    fn the_axle_transform_maps_heave_and_pitch_to_the_axles() {
        let car = AeroExample::default();
        let l = car.axle_transform();
        // Pure pitch θ: the front axle goes down by l_f θ, the rear up by l_r θ.
        let theta = 0.01;
        assert_eq!(l[0][1] * theta, -car.front_axle_m * theta);
        assert_eq!(l[1][1] * theta, car.rear_axle_m * theta);
        assert_eq!([l[0][0], l[1][0]], [1.0, 1.0]);
    }
}
