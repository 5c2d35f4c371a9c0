//! The plant: a specimen driven at its attachment points either by the nonlinear actuators
//! (the MiL rig) or by an ideal interface law (the emulated system), integrated with the
//! classical fourth-order Runge–Kutta method at a fixed internal step.
//!
//! State vector: `q` (n), `q̇` (n), the elements' internal states (Bouc-Wen), then per
//! actuator `[x_v, ẋ_v, P_L, q_int]` ([`crate::actuator::state`]). Within one call of
//! [`Plant::advance`] the actuator demands are held (zero-order hold, as the rig's servo
//! controller applies each received demand) and the road inputs ramp linearly between their
//! samples.
//!
//! With actuators, each actuator's rod mass `m_a` joins the specimen's mass matrix at its
//! attachment (`M + m_a t_j t_jᵀ`), the piston force `F_p` acts on the specimen, and the
//! load cell measures `F_j = F_p,j − m_a ÿ_j` (the force on the specimen).
//!
//! # Exact steps in the linear regime
//!
//! A plant whose every part is affine in a region of its state space (every element linear
//! or with lift-off only, no Bouc-Wen; actuators with
//! [`ForceActuator::has_linear_regime`]; an ideal interface that declares its
//! [`IdealInterface::affine`] form) is piecewise linear: `ẋ = A x + B v` with
//! `v = [demand; road; road rate; 1]`. For it the plant takes *exact* internal steps: the
//! state-transition matrix `e^{A h}` and the input integrals over a step `h` (exact for a
//! held demand and a linearly ramping road, computed once per step length), applied while
//! the state at both ends of the step lies in the linear regime (element and interface
//! forces above their lift-off bounds, actuators in [`ForceActuator::in_linear_regime`]).
//! Any other step is the RK4 step from the same state, so a step that leaves or enters the
//! regime is exactly the plain RK4 one; an excursion out of the regime and back strictly
//! inside one internal step goes unnoticed (RK4 sees only its stage points, too). The
//! signals of [`Plant::sample`] come from the same affine model in the regime, and a
//! [`Plant::advance`] right after a sample in the regime takes its whole period (all its
//! internal steps, each boundary tested) in the same matrix-vector product as the sample.
//! [`Plant::set_exact_steps`] switches this off (plain RK4 everywhere);
//! [`Plant::step_counts`] counts both kinds of step.

// One idea per file: `drive` (actuators or an ideal interface), `derivative` (the state
// derivative), `rk4` (advancing in time), `sample` (the signals at an instant), `linearise`
// (the affine model) and `linear` (its exact steps); the small matrix helpers are
// `mil_numerics::dense`.
mod derivative;
mod drive;
mod linear;
mod linearise;
mod rk4;
mod sample;

pub use drive::{AffineInterface, IdealInterface};
pub use sample::PlantOutputs;

use crate::actuator::{ForceActuator, ACTUATOR_STATES};
use crate::specimen::{Specimen, SpecimenError};
use derivative::{pad, ElementLaw, Fixed, FIXED};
use drive::Drive;
use linear::{with_linear, Linear};
use mil_numerics::dense::{dot, invert, row};
use mil_structure::CompiledLaw;

/// Internal steps taken since the plant was built, by kind (see the module documentation).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StepCounts {
    /// Exact linear steps.
    pub exact: u64,
    /// RK4 steps.
    pub rk4: u64,
}

/// The specimen with its drive, state and scratch space (no allocation while stepping; the
/// exact discretisation is recomputed, a few dozen small matrix products, whenever the
/// control period changes, and its matrices are widened, allocating, when a period takes
/// more internal steps than they have rows for).
pub struct Plant {
    specimen: Specimen,
    drive: Drive,
    n: usize,
    channels: usize,
    element_states: usize,
    /// Inverse of the total mass matrix, row-major.
    inv_mass: Vec<f64>,
    /// `M⁻¹ g` (static forces' accelerations).
    inv_mass_static: Vec<f64>,
    /// `M⁻¹ a_e`, row-major (elements × n).
    inv_mass_elements: Vec<f64>,
    /// `M⁻¹ t_j`, row-major (channels × n).
    inv_mass_attachments: Vec<f64>,
    laws: Vec<ElementLaw>,
    state: Vec<f64>,
    time_s: f64,
    internal_step_s: f64,
    // Scratch.
    k: [Vec<f64>; 4],
    tmp: Vec<f64>,
    accel: Vec<f64>,
    y: Vec<f64>,
    y_dot: Vec<f64>,
    forces: Vec<f64>,
    road: Vec<f64>,
    road_rate: Vec<f64>,
    /// Attachments `t_j`, row-major (channels × n).
    attachments: Vec<f64>,
    /// Elements' DOF coefficients `a_e`, row-major (elements × n).
    element_dofs: Vec<f64>,
    /// Elements' input coefficients `b_e`, row-major (elements × inputs).
    element_inputs: Vec<f64>,
    /// The first RK4 stage `k[0]` holds the derivative at the current state for the
    /// demand and road in `sampled_*` (set by [`Plant::sample`], cleared by any change of
    /// state).
    first_stage_ready: bool,
    sampled_demand: Vec<f64>,
    sampled_road: Vec<f64>,
    sampled_road_rate: Vec<f64>,
    /// The specimen's coefficients padded to [`FIXED`] (when it fits).
    fixed: Option<Fixed>,
    linear: Option<Linear>,
    /// The last [`Plant::sample`] took the exact path at the current state: its outputs
    /// are the linear model's, `[y; ẏ; F]` in `linear_out`.
    linear_outputs: bool,
    linear_out: Vec<f64>,
    /// `(duration (s), internal steps, step (s))` of the last [`Plant::advance`], so that
    /// the usual constant duration costs no divisions.
    advance_split: (f64, usize, f64),
    exact_steps: bool,
    counts: StepCounts,
}

impl Plant {
    /// The MiL rig: `actuators[j]` drives attachment `j`; `internal_step_s` is the RK4 step
    /// (s).
    ///
    /// # Errors
    /// An invalid specimen, a count of actuators other than the attachments', or a
    /// non-positive step.
    pub fn with_actuators(
        specimen: Specimen,
        actuators: Vec<ForceActuator>,
        internal_step_s: f64,
    ) -> Result<Self, SpecimenError> {
        if actuators.len() != specimen.attachments.len() {
            return Err(SpecimenError(format!(
                "{} actuators for {} attachments",
                actuators.len(),
                specimen.attachments.len()
            )));
        }
        Self::new(specimen, Drive::Actuators(actuators), internal_step_s)
    }

    /// The emulated system: the specimen coupled to `interface` ideally.
    ///
    /// # Errors
    /// An invalid specimen or a non-positive step.
    pub fn with_ideal_interface(
        specimen: Specimen,
        interface: Box<dyn IdealInterface + Send + Sync>,
        internal_step_s: f64,
    ) -> Result<Self, SpecimenError> {
        Self::new(specimen, Drive::Ideal(interface), internal_step_s)
    }

    fn new(specimen: Specimen, drive: Drive, internal_step_s: f64) -> Result<Self, SpecimenError> {
        specimen.validate()?;
        if !(internal_step_s.is_finite() && internal_step_s > 0.0) {
            return Err(SpecimenError(format!(
                "internal step must be > 0 s (is {internal_step_s})"
            )));
        }
        let n = specimen.len();
        let channels = specimen.attachments.len();
        let mut total = specimen.mass.clone();
        if let Drive::Actuators(acts) = &drive {
            for (t, a) in specimen.attachments.iter().zip(acts) {
                for i in 0..n {
                    for j in 0..n {
                        total[i][j] += a.moving_mass_kg() * t[i] * t[j];
                    }
                }
            }
        }
        let inv_mass =
            invert(&total).ok_or_else(|| SpecimenError("singular total mass matrix".into()))?;
        let times_inv_mass =
            |v: &[f64]| -> Vec<f64> { (0..n).map(|i| dot(row(&inv_mass, i, n), v)).collect() };
        let inv_mass_static = times_inv_mass(&specimen.static_force);
        let inv_mass_elements = specimen
            .elements
            .iter()
            .flat_map(|e| times_inv_mass(&e.dof_coefficients))
            .collect();
        let inv_mass_attachments = specimen
            .attachments
            .iter()
            .flat_map(|t| times_inv_mass(t))
            .collect();
        let inputs = specimen.inputs.len();
        let fixed = (n <= FIXED && inputs <= FIXED).then(|| Fixed {
            attachments: specimen.attachments.iter().map(|t| pad(t)).collect(),
            inv_mass_attachments: specimen
                .attachments
                .iter()
                .map(|t| pad(&times_inv_mass(t)))
                .collect(),
            element_dofs: specimen
                .elements
                .iter()
                .map(|e| pad(&e.dof_coefficients))
                .collect(),
            element_inputs: specimen
                .elements
                .iter()
                .map(|e| pad(&e.input_coefficients))
                .collect(),
            inv_mass_elements: specimen
                .elements
                .iter()
                .map(|e| pad(&times_inv_mass(&e.dof_coefficients)))
                .collect(),
            inv_mass_static: pad(&inv_mass_static),
        });
        let laws = specimen
            .elements
            .iter()
            .map(|e| {
                let el = &e.element;
                if el.is_linear() {
                    return Ok(ElementLaw::Linear {
                        k: el.stiffness_n_per_m,
                        c: el.damping_n_s_per_m,
                        preload: el.preload_n,
                    });
                }
                let law = el
                    .law()
                    .map_err(|x| SpecimenError(format!("element {:?}: {x}", e.name)))?;
                Ok(ElementLaw::General {
                    law: CompiledLaw::new(&law),
                    preload: el.preload_n,
                    states: law.states(),
                })
            })
            .collect::<Result<Vec<_>, SpecimenError>>()?;
        let element_states = laws
            .iter()
            .map(|l| match l {
                ElementLaw::General { states, .. } => *states,
                ElementLaw::Linear { .. } => 0,
            })
            .sum();
        let actuator_states = match &drive {
            Drive::Actuators(a) => a.len() * ACTUATOR_STATES,
            Drive::Ideal(_) => 0,
        };
        let len = 2 * n + element_states + actuator_states;
        let mut plant = Self {
            n,
            channels,
            element_states,
            inv_mass,
            inv_mass_static,
            inv_mass_elements,
            inv_mass_attachments,
            laws,
            state: vec![0.0; len],
            time_s: 0.0,
            internal_step_s,
            k: [
                vec![0.0; len],
                vec![0.0; len],
                vec![0.0; len],
                vec![0.0; len],
            ],
            tmp: vec![0.0; len],
            accel: vec![0.0; n],
            y: vec![0.0; channels],
            y_dot: vec![0.0; channels],
            forces: vec![0.0; channels],
            road: vec![0.0; inputs],
            road_rate: vec![0.0; inputs],
            attachments: specimen.attachments.iter().flatten().copied().collect(),
            element_dofs: specimen
                .elements
                .iter()
                .flat_map(|e| e.dof_coefficients.iter().copied())
                .collect(),
            element_inputs: specimen
                .elements
                .iter()
                .flat_map(|e| e.input_coefficients.iter().copied())
                .collect(),
            first_stage_ready: false,
            sampled_demand: vec![0.0; channels],
            sampled_road: vec![0.0; inputs],
            sampled_road_rate: vec![0.0; inputs],
            specimen,
            drive,
            fixed,
            linear: None,
            linear_outputs: false,
            linear_out: vec![0.0; 3 * channels],
            advance_split: (f64::NAN, 1, f64::NAN),
            exact_steps: true,
            counts: StepCounts::default(),
        };
        plant.linear = plant.linear_model();
        Ok(plant)
    }

    /// The specimen.
    pub fn specimen(&self) -> &Specimen {
        &self.specimen
    }

    /// Interface channels.
    pub fn channels(&self) -> usize {
        self.channels
    }

    /// Simulated time (s).
    pub fn time_s(&self) -> f64 {
        self.time_s
    }

    /// The RK4 step (s).
    pub fn internal_step_s(&self) -> f64 {
        self.internal_step_s
    }

    /// The full state vector (see the module documentation).
    pub fn state(&self) -> &[f64] {
        &self.state
    }

    /// Whether the plant is piecewise linear, so that it can take exact steps in its
    /// linear regime (see the module documentation).
    pub fn has_exact_steps(&self) -> bool {
        self.linear.is_some()
    }

    /// Switches the exact linear steps on (the default) or off (plain RK4 at the internal
    /// step everywhere, e.g. as a reference).
    pub fn set_exact_steps(&mut self, on: bool) {
        self.exact_steps = on;
        self.first_stage_ready = false;
        self.linear_outputs = false;
        if let Some(linear) = self.linear.as_mut() {
            with_linear!(linear, m => m.sample_pending = false);
        }
    }

    /// Internal steps taken so far, exact and RK4.
    pub fn step_counts(&self) -> StepCounts {
        self.counts
    }

    /// Puts the plant at rest at `q = 0` with every actuator holding `demand[j]` (N): the
    /// static equilibrium of the specimen description (see [`Specimen`]).
    pub fn rest(&mut self, demand: &[f64]) {
        self.state.iter_mut().for_each(|x| *x = 0.0);
        self.time_s = 0.0;
        self.first_stage_ready = false;
        self.linear_outputs = false;
        if let Some(linear) = self.linear.as_mut() {
            with_linear!(linear, m => m.sample_pending = false);
        }
        let offset = 2 * self.n + self.element_states;
        if let Drive::Actuators(acts) = &self.drive {
            for (j, (a, f)) in acts.iter().zip(demand).enumerate() {
                let s = a.equilibrium(*f);
                self.state[offset + j * ACTUATOR_STATES..offset + (j + 1) * ACTUATOR_STATES]
                    .copy_from_slice(&s);
            }
        }
    }
}
