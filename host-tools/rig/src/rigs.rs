//! The paper's rigs, ready to run: the quarter car on a hub-coupled rig with the numerical
//! tyre (tyre example), with its emulated counterpart.

use crate::actuator::ForceActuator;
use crate::effects::{Effects, Element};
use crate::harness::RigPart;
use crate::plant::{IdealInterface, Plant};
use crate::specimen::{Specimen, SpecimenError};
use mil_analysis::examples::TyreExample;
use model_core::{
    CascadeCoefficients, Controller, ControllerParams, DemandLimits, ModelInput, ParamError,
    TyreModel, TyreModelParams, TyreParams,
};

/// The ideal (emulated) tyre: the numerical tyre as a physical element between the road
/// under each channel and its hub, `F = F_0 + k_t (w − y) + c_t (ẇ − ẏ)` with the element's
/// effects (lift-off), evaluated continuously.
#[derive(Clone, Debug, PartialEq)]
pub struct IdealTyre {
    /// The tyre element per channel (preload: the static wheel load, N).
    pub tyres: Vec<Element>,
}

impl IdealInterface for IdealTyre {
    fn forces(
        &self,
        y: &[f64],
        y_dot: &[f64],
        road: &[f64],
        road_rate: &[f64],
        forces: &mut [f64],
    ) {
        for (j, (tyre, f)) in self.tyres.iter().zip(forces.iter_mut()).enumerate() {
            let x = road.get(j).copied().unwrap_or(0.0) - y.get(j).copied().unwrap_or(0.0);
            let v = road_rate.get(j).copied().unwrap_or(0.0) - y_dot.get(j).copied().unwrap_or(0.0);
            *f = tyre.force(x, v, 0.0);
        }
    }
}

/// One wheel of the tyre example: the quarter car (`car`, with `suspension` as its
/// suspension element) on a hub actuator, and the emulated quarter car standing on the ideal
/// `tyre` (whose preload is the static wheel load). The run's road input `road_input` drives
/// the emulated tyre (the MiL rig's road goes to the numerical model only); the plant serves
/// controller channel `channel`.
///
/// # Errors
/// An invalid specimen or step.
pub fn quarter_car_part(
    car: &TyreExample,
    suspension: Element,
    actuator: ForceActuator,
    tyre: Element,
    channel: usize,
    road_input: usize,
    internal_step_s: f64,
) -> Result<RigPart, SpecimenError> {
    let specimen = Specimen::quarter_car(car, suspension);
    let mut emulated_specimen = specimen.clone();
    emulated_specimen.inputs = vec!["road".into()];
    for e in &mut emulated_specimen.elements {
        e.input_coefficients = vec![0.0];
    }
    Ok(RigPart {
        mil: Plant::with_actuators(specimen, vec![actuator], internal_step_s)?,
        emulated: Plant::with_ideal_interface(
            emulated_specimen,
            Box::new(IdealTyre { tyres: vec![tyre] }),
            internal_step_s,
        )?,
        first_channel: channel,
        mil_inputs: vec![],
        emulated_inputs: vec![road_input],
    })
}

/// The emulated tyre element of model-core's tyre parameters: `k_t`, `c_t`, the static
/// wheel load as preload, lift-off as the board's tyre has it.
pub fn ideal_tyre(params: &TyreParams) -> Element {
    Element::linear(f64::from(params.stiffness), f64::from(params.damping))
        .with_preload(f64::from(params.static_load))
        .with_effects(Effects {
            lift_off: params.lift_off != 0,
            ..Effects::default()
        })
}

/// The board's controller for one tyre channel at `sample_rate_hz` (Hz): model-core's tyre
/// with `params`, no command filter, `limits`, the static wheel load as the safe demand.
///
/// # Errors
/// Parameters model-core refuses.
pub fn tyre_controller(
    params: TyreParams,
    limits: DemandLimits,
    sample_rate_hz: f64,
) -> Result<Controller<TyreModel<1>, 1>, ParamError> {
    let controller_params = ControllerParams {
        model: TyreModelParams { tyre: [params] },
        filter: [CascadeCoefficients::IDENTITY],
        limits: [limits],
        safe_demand: [params.static_load],
        safe_ramp_rate: [1.0e5],
    };
    Controller::with_params(&controller_params, (1.0 / sample_rate_hz) as f32)
}

/// The tyre controller's input from the received measurements and the road sample (the
/// `input` argument of [`crate::harness::run`]).
pub fn tyre_input(
    position: &[f64; 1],
    force: &[f64; 1],
    road: &[f64],
    _sample: usize,
) -> ModelInput<1> {
    ModelInput {
        position: [position[0] as f32],
        force: [force[0] as f32],
        road: [road.first().copied().unwrap_or(0.0) as f32],
        speed: 0.0,
    }
}

/// The paper's tyre example on one channel: [`TyreExample::default`]'s quarter car with
/// its linear suspension, the reference actuator without effects, and the emulated tyre of
/// [`TyreParams::PAPER`], driven by road input 0.
///
/// # Errors
/// A non-positive step.
pub fn paper_tyre_part(internal_step_s: f64) -> Result<RigPart, SpecimenError> {
    let car = TyreExample::default();
    let actuator = ForceActuator::new(
        mil_analysis::ServoHydraulicActuator::REFERENCE,
        crate::actuator::ActuatorEffects::default(),
    )
    .map_err(|e| SpecimenError(e.to_string()))?;
    quarter_car_part(
        &car,
        Specimen::quarter_car_suspension(&car),
        actuator,
        ideal_tyre(&TyreParams::PAPER),
        0,
        0,
        internal_step_s,
    )
}
