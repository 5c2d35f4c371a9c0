//! The paper's examples as linear MiL set-ups: the tyre on a hub-coupled rig (section 4),
//! the aerodynamic model on a four-poster (section 3) and the 2-DOF example (Lim et al.).
//! The parameter sets are `mil-params`' (the paper's tables, SI units). The tyre's damping velocity is by
//! default what the board's tyre computes (model-core's velocity estimator at the
//! controller's sample period and the model-core tyre's 500 Hz cut-off), see
//! [`crate::system::VelocityEstimate`].

use crate::error::{setup_error, Result};
use crate::response::LinearActuator;
use crate::system::{
    ExternalInput, ImpedanceLocation, Interface, MechanicalPart, VelocityEstimate,
};
use mil_params::{AeroExample, TwoDofExample, TyreExample, TyreVelocity};
use nalgebra::{dmatrix, DMatrix, DVector};

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

/// Adds a spring `k` and damper `c` between DOFs `i` and `j`.
fn couple(k_mat: &mut DMatrix<f64>, c_mat: &mut DMatrix<f64>, i: usize, j: usize, k: f64, c: f64) {
    for (a, b, sign) in [(i, i, 1.0), (j, j, 1.0), (i, j, -1.0), (j, i, -1.0)] {
        k_mat[(a, b)] += sign * k;
        c_mat[(a, b)] += sign * c;
    }
}

/// The tyre example's structure for a controller running every `sample_period_s` seconds:
/// physical DOFs `x_s` (body) and `x_u` (hub), numerical tyre `B_i = c_t V(s) + k_t` from the road
/// input `road` (m) to the hub, configuration 4. `V` is the board's velocity estimator at
/// that sample period and [`TyreExample::velocity_cutoff_hz`] (what `model_core`'s tyre
/// computes from the sampled deflection), or `s` with [`TyreVelocity::Continuous`].
///
/// # Errors
/// Non-finite parameters; with the board's estimator, a cut-off outside 0–20 kHz or a
/// sample period outside model-core's 5e-5 to 1e-2 s.
pub fn tyre_structure(car: &TyreExample, sample_period_s: f64) -> Result<Structure> {
    let velocity = match car.velocity_estimate {
        TyreVelocity::Continuous => VelocityEstimate::Continuous,
        TyreVelocity::Board => VelocityEstimate::Board {
            sample_period_s,
            cutoff_hz: car.velocity_cutoff_hz,
        },
    };
    // Validated as the board validates it.
    if velocity.coefficients().is_err() {
        return Err(setup_error(format!(
            "numerical.tyre.velocity_cutoff_hz = {} Hz at a sample period of {sample_period_s} s: \
                 the board's tyre needs a cut-off of 0 (plain backward difference) to \
                 20000 Hz and a sample period of 5e-5 to 1e-2 s (100 Hz to 20 kHz)",
            car.velocity_cutoff_hz
        )));
    }
    let mut k = DMatrix::zeros(2, 2);
    let mut c = DMatrix::zeros(2, 2);
    couple(
        &mut k,
        &mut c,
        0,
        1,
        car.suspension_stiffness,
        car.suspension_damping,
    );
    let physical = MechanicalPart::new(
        vec!["x_s".into(), "x_u".into()],
        DMatrix::from_diagonal(&DVector::from_vec(vec![
            car.sprung_mass_kg,
            car.unsprung_mass_kg,
        ])),
        c,
        k,
    )?;
    let interface = Interface {
        location: ImpedanceLocation::Numerical,
        numerical_select: DMatrix::zeros(1, 0),
        physical_select: dmatrix![0.0, 1.0],
        stiffness: dmatrix![car.tyre_stiffness],
        damping: dmatrix![car.tyre_damping],
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

/// The axle transform `L` ([`AeroExample::axle_transform`]) as a matrix.
pub fn axle_transform(car: &AeroExample) -> DMatrix<f64> {
    DMatrix::from_fn(2, 2, |i, j| car.axle_transform()[i][j])
}

/// The aero example's structure: physical DOFs `z_b` (m) and `theta_b` (rad); numerical part
/// without masses, `F_i = K_i x_pi` (so `B_i = −K_i`); inputs `road_heave` (m, both axles),
/// `road_pitch` (rad), `road_front` and `road_rear` (m); actuators at the axles;
/// configuration 4.
///
/// # Errors
/// Non-finite parameters or coincident axles.
pub fn aero_structure(car: &AeroExample) -> Result<Structure> {
    let l = axle_transform(car);
    let l_inv = l
        .clone()
        .try_inverse()
        .ok_or_else(|| crate::error::setup_error("aero example: axle positions make L singular"))?;
    let kd = DMatrix::from_diagonal(&DVector::from_vec(vec![
        car.front_stiffness,
        car.rear_stiffness,
    ]));
    let cd = DMatrix::from_diagonal(&DVector::from_vec(vec![
        car.front_damping,
        car.rear_damping,
    ]));
    let k = l.transpose() * &kd * &l;
    let c = l.transpose() * &cd * &l;
    let physical = MechanicalPart::new(
        vec!["z_b".into(), "theta_b".into()],
        DMatrix::from_diagonal(&DVector::from_vec(vec![
            car.body_mass_kg,
            car.pitch_inertia_kg_m2,
        ])),
        c.clone(),
        k.clone(),
    )?;
    let a = car.aero_stiffness;
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

/// The 2-DOF example's structure: DOFs `x_n`, `x_p`; inputs `z_n`, `z_p` (m).
///
/// # Errors
/// Non-finite parameters.
pub fn two_dof_structure(car: &TwoDofExample) -> Result<Structure> {
    let numerical = MechanicalPart::new(
        vec!["x_n".into()],
        dmatrix![car.numerical_mass_kg],
        dmatrix![car.numerical_damping],
        dmatrix![car.numerical_stiffness],
    )?;
    let physical = MechanicalPart::new(
        vec!["x_p".into()],
        dmatrix![car.physical_mass_kg],
        dmatrix![car.physical_damping],
        dmatrix![car.physical_stiffness],
    )?;
    let interface = Interface {
        location: if car.interface_in_numerical {
            ImpedanceLocation::Numerical
        } else {
            ImpedanceLocation::Physical
        },
        numerical_select: dmatrix![1.0],
        physical_select: dmatrix![1.0],
        stiffness: dmatrix![car.interface_stiffness],
        damping: dmatrix![car.interface_damping],
        velocity: VelocityEstimate::Continuous,
    };
    let mut z_n = ExternalInput::new("z_n", "m", 1, 1, 1);
    z_n.numerical_stiffness[0] = car.numerical_stiffness;
    z_n.numerical_damping[0] = car.numerical_damping;
    let mut z_p = ExternalInput::new("z_p", "m", 1, 1, 1);
    z_p.physical_stiffness[0] = car.physical_stiffness;
    z_p.physical_damping[0] = car.physical_damping;
    Ok(Structure {
        numerical,
        physical,
        interface,
        inputs: vec![z_n, z_p],
        actuator_transform: DMatrix::identity(1, 1),
    })
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

/// Force-controlled actuators with the responses of a [`mil_params::ServoHydraulicActuator`] and
/// a loop delay (s).
///
/// # Errors
/// Invalid actuator parameters.
pub fn force_actuators(
    actuator: &mil_params::ServoHydraulicActuator,
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
