//! The paper's examples as linear MiL set-ups: the tyre on a hub-coupled rig (section 4),
//! the aerodynamic model on a four-poster (section 3) and the 2-DOF example (Lim et al.).
//! Parameters are the paper's (brief tables), in SI units. The tyre's damping velocity is by
//! default what the board's tyre computes (model-core's velocity estimator at the
//! controller's sample period and the model-core tyre's 500 Hz cut-off), see
//! [`crate::system::VelocityEstimate`].

use crate::error::{setup_error, Result};
use crate::system::{
    ExternalInput, ImpedanceLocation, Interface, MechanicalPart, VelocityEstimate,
};
use model_core::TyreParams;
use nalgebra::{dmatrix, DMatrix, DVector};
use serde::{Deserialize, Serialize};

/// The structural (actuator-independent) part of a set-up.
#[derive(Clone, Debug)]
pub struct Structure {
    /// Numerical part.
    pub numerical: MechanicalPart,
    /// Physical part.
    pub physical: MechanicalPart,
    /// Interface.
    pub interface: Interface,
    /// External inputs.
    pub inputs: Vec<ExternalInput>,
    /// Actuator coordinates `x_a = T x_i`.
    pub actuator_transform: DMatrix<f64>,
}

/// How the tyre example's analysis obtains the tyre's deflection velocity.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TyreVelocity {
    /// As the board's tyre model computes it: model-core's velocity estimator at the
    /// controller's sample period with [`TyreExample::velocity_cutoff_hz`]
    /// ([`VelocityEstimate::Board`]).
    #[default]
    Board,
    /// The ideal continuous derivative `c_t s` ([`VelocityEstimate::Continuous`]), e.g. to
    /// see what the estimator costs.
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

/// Adds a spring `k` and damper `c` between DOFs `i` and `j`.
fn couple(k_mat: &mut DMatrix<f64>, c_mat: &mut DMatrix<f64>, i: usize, j: usize, k: f64, c: f64) {
    for (a, b, sign) in [(i, i, 1.0), (j, j, 1.0), (i, j, -1.0), (j, i, -1.0)] {
        k_mat[(a, b)] += sign * k;
        c_mat[(a, b)] += sign * c;
    }
}

impl TyreExample {
    /// The structure for a controller running every `sample_period_s` seconds: physical DOFs
    /// `x_s` (body) and `x_u` (hub), numerical tyre `B_i = c_t V(s) + k_t` from the road
    /// input `road` (m) to the hub, configuration 4. `V` is the board's velocity estimator at
    /// that sample period and [`TyreExample::velocity_cutoff_hz`] (what `model_core`'s tyre
    /// computes from the sampled deflection), or `s` with [`TyreVelocity::Continuous`].
    ///
    /// # Errors
    /// Non-finite parameters; with the board's estimator, a cut-off outside 0–20 kHz or a
    /// sample period outside model-core's 5e-5 to 1e-2 s.
    pub fn structure(&self, sample_period_s: f64) -> Result<Structure> {
        let velocity = match self.velocity_estimate {
            TyreVelocity::Continuous => VelocityEstimate::Continuous,
            TyreVelocity::Board => VelocityEstimate::Board {
                sample_period_s,
                cutoff_hz: self.velocity_cutoff_hz,
            },
        };
        // Validated as the board validates it.
        if velocity.coefficients().is_err() {
            return Err(setup_error(format!(
                "numerical.tyre.velocity_cutoff_hz = {} Hz at a sample period of {sample_period_s} s: \
                 the board's tyre needs a cut-off of 0 (plain backward difference) to \
                 20000 Hz and a sample period of 5e-5 to 1e-2 s (100 Hz to 20 kHz)",
                self.velocity_cutoff_hz
            )));
        }
        let mut k = DMatrix::zeros(2, 2);
        let mut c = DMatrix::zeros(2, 2);
        couple(
            &mut k,
            &mut c,
            0,
            1,
            self.suspension_stiffness,
            self.suspension_damping,
        );
        let physical = MechanicalPart::new(
            vec!["x_s".into(), "x_u".into()],
            DMatrix::from_diagonal(&DVector::from_vec(vec![
                self.sprung_mass_kg,
                self.unsprung_mass_kg,
            ])),
            c,
            k,
        )?;
        let interface = Interface {
            location: ImpedanceLocation::Numerical,
            numerical_select: DMatrix::zeros(1, 0),
            physical_select: dmatrix![0.0, 1.0],
            stiffness: dmatrix![self.tyre_stiffness],
            damping: dmatrix![self.tyre_damping],
            velocity,
        };
        let mut road = ExternalInput::new("road", "m", 0, 2, 1);
        road.interface_position[0] = 1.0;
        Ok(Structure {
            numerical: MechanicalPart::massless(),
            physical,
            interface,
            inputs: vec![road],
            actuator_transform: DMatrix::identity(1, 1),
        })
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
    /// Axle transform `L = [1 −l_f; 1 l_r]`: axle displacements from `[z; θ]`.
    pub fn axle_transform(&self) -> DMatrix<f64> {
        dmatrix![1.0, -self.front_axle_m; 1.0, self.rear_axle_m]
    }

    /// The structure: physical DOFs `z_b` (m) and `theta_b` (rad); numerical part without
    /// masses, `F_i = K_i x_pi` (so `B_i = −K_i`); inputs `road_heave` (m, both axles),
    /// `road_pitch` (rad), `road_front` and `road_rear` (m); actuators at the axles;
    /// configuration 4.
    ///
    /// # Errors
    /// Non-finite parameters or coincident axles.
    pub fn structure(&self) -> Result<Structure> {
        let l = self.axle_transform();
        let l_inv = l.clone().try_inverse().ok_or_else(|| {
            crate::error::setup_error("aero example: axle positions make L singular")
        })?;
        let kd = DMatrix::from_diagonal(&DVector::from_vec(vec![
            self.front_stiffness,
            self.rear_stiffness,
        ]));
        let cd = DMatrix::from_diagonal(&DVector::from_vec(vec![
            self.front_damping,
            self.rear_damping,
        ]));
        let k = l.transpose() * &kd * &l;
        let c = l.transpose() * &cd * &l;
        let physical = MechanicalPart::new(
            vec!["z_b".into(), "theta_b".into()],
            DMatrix::from_diagonal(&DVector::from_vec(vec![
                self.body_mass_kg,
                self.pitch_inertia_kg_m2,
            ])),
            c.clone(),
            k.clone(),
        )?;
        let a = self.aero_stiffness;
        let interface = Interface {
            location: ImpedanceLocation::Numerical,
            numerical_select: DMatrix::zeros(2, 0),
            physical_select: DMatrix::identity(2, 2),
            stiffness: -dmatrix![a[0][0], a[0][1]; a[1][0], a[1][1]],
            damping: DMatrix::zeros(2, 2),
            velocity: VelocityEstimate::Continuous,
        };
        // Road: [z_r; θ_r] = L⁻¹ [r_f; r_r]; force on the body (C s + K)[z_r; θ_r].
        let mut inputs = Vec::new();
        let generalised = [
            ("road_heave", "m", DVector::from_vec(vec![1.0, 0.0])),
            ("road_pitch", "rad", DVector::from_vec(vec![0.0, 1.0])),
            ("road_front", "m", l_inv.column(0).into_owned()),
            ("road_rear", "m", l_inv.column(1).into_owned()),
        ];
        for (name, unit, road) in generalised {
            let mut input = ExternalInput::new(name, unit, 0, 2, 2);
            input.physical_stiffness = &k * &road;
            input.physical_damping = &c * &road;
            inputs.push(input);
        }
        Ok(Structure {
            numerical: MechanicalPart::massless(),
            physical,
            interface,
            inputs,
            actuator_transform: l,
        })
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

impl TwoDofExample {
    /// The structure: DOFs `x_n`, `x_p`; inputs `z_n`, `z_p` (m).
    ///
    /// # Errors
    /// Non-finite parameters.
    pub fn structure(&self) -> Result<Structure> {
        let numerical = MechanicalPart::new(
            vec!["x_n".into()],
            dmatrix![self.numerical_mass_kg],
            dmatrix![self.numerical_damping],
            dmatrix![self.numerical_stiffness],
        )?;
        let physical = MechanicalPart::new(
            vec!["x_p".into()],
            dmatrix![self.physical_mass_kg],
            dmatrix![self.physical_damping],
            dmatrix![self.physical_stiffness],
        )?;
        let interface = Interface {
            location: if self.interface_in_numerical {
                ImpedanceLocation::Numerical
            } else {
                ImpedanceLocation::Physical
            },
            numerical_select: dmatrix![1.0],
            physical_select: dmatrix![1.0],
            stiffness: dmatrix![self.interface_stiffness],
            damping: dmatrix![self.interface_damping],
            velocity: VelocityEstimate::Continuous,
        };
        let mut z_n = ExternalInput::new("z_n", "m", 1, 1, 1);
        z_n.numerical_stiffness[0] = self.numerical_stiffness;
        z_n.numerical_damping[0] = self.numerical_damping;
        let mut z_p = ExternalInput::new("z_p", "m", 1, 1, 1);
        z_p.physical_stiffness[0] = self.physical_stiffness;
        z_p.physical_damping[0] = self.physical_damping;
        Ok(Structure {
            numerical,
            physical,
            interface,
            inputs: vec![z_n, z_p],
            actuator_transform: DMatrix::identity(1, 1),
        })
    }
}

impl Structure {
    /// The MiL system of this structure with the given actuators (their transform is
    /// replaced by the structure's) and no command filter.
    pub fn with_actuators(self, mut actuators: crate::system::Actuators) -> crate::MilSystem {
        actuators.transform = self.actuator_transform;
        crate::MilSystem {
            numerical: self.numerical,
            physical: self.physical,
            interface: self.interface,
            inputs: self.inputs,
            actuators,
            filter: None,
        }
    }
}

/// Force-controlled actuators with the responses of a [`crate::ServoHydraulicActuator`] and
/// a loop delay (s).
///
/// # Errors
/// Invalid actuator parameters.
pub fn force_actuators(
    actuator: &crate::ServoHydraulicActuator,
    loop_delay_s: f64,
) -> Result<crate::system::Actuators> {
    Ok(crate::system::Actuators {
        control: crate::system::ActuatorControl::Force,
        tracking: crate::ResponseSource::Model {
            transfer_function: actuator.tracking()?,
            delay_s: 0.0,
        },
        disturbance: crate::ResponseSource::Model {
            transfer_function: actuator.disturbance()?,
            delay_s: 0.0,
        },
        transform: DMatrix::identity(1, 1),
        loop_delay_s,
    })
}
