//! The paper's rigs, ready to run: the quarter car on a hub-coupled rig with the numerical
//! tyre (tyre example), the half car on a four-poster with the numerical aerodynamic model
//! driving front and rear down-force actuators (aero example), and any mass-spring-damper
//! specimen on force-controlled actuators coupled to model-core's general substructure
//! model (configuration 4, e.g. the paper's 2-DOF example), each with its emulated
//! counterpart.

use crate::actuator::ForceActuator;
use crate::harness::RigPart;
use crate::plant::{AffineInterface, IdealInterface, Plant};
use crate::specimen::{Specimen, SpecimenError};
use mil_params::{AeroExample, TyreExample};
use mil_structure::{CompiledLaw, EffectKind, Element};
use model_core::aero::MAP_POINTS;
use model_core::{
    AeroModel, AeroParams, CascadeCoefficients, Causality, Controller, ControllerParams,
    DemandLimits, ModelInput, ParamError, SubstructureParams, TyreModel, TyreModelParams,
    TyreParams,
};

/// The ideal (emulated) tyre: the numerical tyre as a physical element between the road
/// under each channel and its hub, `F = F_0 + k_t (w − y) + c_t (ẇ − ẏ)` with the element's
/// effects (lift-off), evaluated continuously.
#[derive(Clone, Debug, PartialEq)]
pub struct IdealTyre {
    /// The tyre element per channel (preload: the static wheel load, N).
    tyres: Vec<Element>,
    /// Their laws, unpacked once.
    laws: Vec<CompiledLaw>,
}

impl IdealTyre {
    /// The ideal interface of `tyres` (one per channel).
    ///
    /// # Errors
    /// An element whose law does not validate, named by its channel.
    pub fn new(tyres: Vec<Element>) -> Result<Self, SpecimenError> {
        let laws = tyres
            .iter()
            .enumerate()
            .map(|(j, t)| {
                t.compile()
                    .map_err(|e| SpecimenError(format!("tyre of channel {j}: {e}")))
            })
            .collect::<Result<_, _>>()?;
        Ok(Self { tyres, laws })
    }

    /// The tyre element per channel.
    pub fn tyres(&self) -> &[Element] {
        &self.tyres
    }
}

impl IdealInterface for IdealTyre {
    /// The affine form while every tyre is linear apart from lift-off (tyre `j` between
    /// road input `j` and attachment `j`): `F_j = F_0 + k_t (w_j − y_j) + c_t (ẇ_j − ẏ_j)`,
    /// valid while `F_j > 0` with lift-off. `None` with other effects.
    fn affine(&self) -> Option<AffineInterface> {
        let n = self.tyres.len();
        let diagonal = |value: &dyn Fn(&Element) -> f64| -> Vec<Vec<f64>> {
            (0..n)
                .map(|j| {
                    (0..n)
                        .map(|i| if i == j { value(&self.tyres[j]) } else { 0.0 })
                        .collect()
                })
                .collect()
        };
        let affine = self.tyres.iter().all(Element::is_piecewise_linear);
        affine.then(|| AffineInterface {
            offset_n: self.tyres.iter().map(|t| t.preload_n).collect(),
            position_n_per_m: diagonal(&|t| -t.stiffness_n_per_m),
            velocity_n_s_per_m: diagonal(&|t| -t.damping_n_s_per_m),
            road_n_per_m: diagonal(&|t| t.stiffness_n_per_m),
            road_rate_n_s_per_m: diagonal(&|t| t.damping_n_s_per_m),
            lower_bound_n: self
                .tyres
                .iter()
                .map(|t| {
                    if t.lifts_off() {
                        0.0
                    } else {
                        f64::NEG_INFINITY
                    }
                })
                .collect(),
        })
    }

    fn forces(
        &self,
        y: &[f64],
        y_dot: &[f64],
        road: &[f64],
        road_rate: &[f64],
        forces: &mut [f64],
    ) {
        let tyres = self.tyres.iter().zip(&self.laws);
        for (j, ((tyre, law), f)) in tyres.zip(forces.iter_mut()).enumerate() {
            let x = road.get(j).copied().unwrap_or(0.0) - y.get(j).copied().unwrap_or(0.0);
            let v = road_rate.get(j).copied().unwrap_or(0.0) - y_dot.get(j).copied().unwrap_or(0.0);
            *f = tyre.preload_n + law.force(x, v, 0.0);
        }
    }
}

/// One wheel of the tyre example: the quarter car `specimen` (e.g.
/// [`Specimen::quarter_car`], or a structure file's, with one attachment: the hub) on a hub
/// actuator, and the emulated quarter car standing on the ideal `tyre` (whose preload is the
/// static wheel load) at the hub. The run's road input `road_input` drives the emulated tyre
/// (the MiL rig's road goes to the numerical model only); the plant serves controller
/// channel `channel`.
///
/// # Errors
/// An invalid specimen or step, a specimen with road inputs or not one attachment.
pub fn quarter_car_part(
    specimen: Specimen,
    actuator: ForceActuator,
    tyre: Element,
    channel: usize,
    road_input: usize,
    internal_step_s: f64,
) -> Result<RigPart, SpecimenError> {
    if specimen.attachments.len() != 1 || !specimen.inputs.is_empty() {
        return Err(SpecimenError(format!(
            "the tyre rig's quarter car hangs on one hub actuator and stands on nothing else: \
             {} attachments and road inputs {:?} given",
            specimen.attachments.len(),
            specimen.inputs
        )));
    }
    let mut emulated_specimen = specimen.clone();
    emulated_specimen.inputs = vec!["road".into()];
    for e in &mut emulated_specimen.elements {
        e.input_coefficients = vec![0.0];
    }
    Ok(RigPart {
        mil: Plant::with_actuators(specimen, vec![actuator], internal_step_s)?,
        emulated: Plant::with_ideal_interface(
            emulated_specimen,
            Box::new(IdealTyre::new(vec![tyre])?),
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
    let tyre = Element::linear(f64::from(params.stiffness), f64::from(params.damping))
        .with_preload(f64::from(params.static_load));
    if params.lift_off != 0 {
        tyre.with(EffectKind::LiftOff, &[])
    } else {
        tyre
    }
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
        mil_params::ServoHydraulicActuator::REFERENCE,
        crate::actuator::ActuatorEffects::default(),
    )
    .map_err(|e| SpecimenError(e.to_string()))?;
    quarter_car_part(
        Specimen::quarter_car(&car, Specimen::quarter_car_suspension(&car)),
        actuator,
        ideal_tyre(&TyreParams::PAPER),
        0,
        0,
        internal_step_s,
    )
}

/// The ideal (emulated) aerodynamic model: the down-force law of model-core's
/// [`AeroModel`] evaluated continuously in `f64` from the attachment positions (no sampling,
/// delay or actuators). Channel 0 is the front axle point, channel 1 the rear; the forces
/// are the axle forces on the body (N, up positive, so down force is negative), including
/// the static nominal down force at `q = 0`:
///
/// ```text
/// linear:  [F_z; M_θ] = (v / v_ref)² (K_i [z; θ] + F_n),   [z; θ] = L⁻¹ [x_f; x_r]
///          F_f = (l_r F_z − M_θ) / (l_f + l_r),  F_r = (l_f F_z + M_θ) / (l_f + l_r)
/// map:     F_f = −(v / v_ref)² D_f(h_f0 + x_f, h_r0 + x_r), likewise F_r
/// ```
///
/// with the parameters' own `l_f`, `l_r` (as the board has them) and the ride-height map
/// interpolated bilinearly and clamped at its edges as model-core does. The model is
/// stateless and uses neither the attachment velocities nor the posts' road inputs; the
/// speed is constant ([`IdealAero::speed_m_per_s`]) or, with
/// [`IdealAero::with_speed_input`], one of the plant's road inputs carrying the speed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IdealAero {
    /// The board's aero parameters (their `f32` values, evaluated in `f64`).
    pub params: AeroParams,
    /// Vehicle speed `v` (m/s): the speed of a run at constant speed, and the speed at the
    /// start (the static equilibrium of [`half_car_part_varying_speed`]) of one whose speed
    /// follows [`IdealAero::speed_input`].
    pub speed_m_per_s: f64,
    /// Index of the plant's road input that carries the vehicle speed (m/s), if the speed
    /// varies over the run; `None`: the constant [`IdealAero::speed_m_per_s`].
    pub speed_input: Option<usize>,
}

/// Index of the map cell holding `h` (m) and the fractional position in it, clamped to the
/// grid (model-core's `locate` in `f64`).
fn map_locate(grid: &[f32; MAP_POINTS], points: u32, h: f64) -> (usize, f64) {
    let n = (points as usize).clamp(2, MAP_POINTS);
    let used = &grid[..n];
    let (first, last) = (f64::from(used[0]), f64::from(used[n - 1]));
    if h.is_nan() || h <= first {
        return (0, 0.0);
    }
    if h >= last {
        return (n - 2, 1.0);
    }
    let i = used
        .windows(2)
        .position(|w| h >= f64::from(w[0]) && h < f64::from(w[1]))
        .unwrap_or(0);
    let (lo, hi) = (f64::from(grid[i]), f64::from(grid[i + 1]));
    (i, ((h - lo) / (hi - lo)).clamp(0.0, 1.0))
}

/// Bilinear interpolation in cell `(i, j)` at fractions `ti`, `tj` (model-core's in `f64`).
fn map_bilinear(
    table: &[[f32; MAP_POINTS]; MAP_POINTS],
    i: usize,
    j: usize,
    ti: f64,
    tj: f64,
) -> f64 {
    let at = |a: usize, b: usize| f64::from(table[a][b]);
    let lo = at(i, j) + (at(i, j + 1) - at(i, j)) * tj;
    let hi = at(i + 1, j) + (at(i + 1, j + 1) - at(i + 1, j)) * tj;
    lo + (hi - lo) * ti
}

impl IdealAero {
    /// The emulated aero model of `params` at the constant speed `speed_m_per_s` (m/s).
    pub fn new(params: AeroParams, speed_m_per_s: f64) -> Self {
        Self {
            params,
            speed_m_per_s,
            speed_input: None,
        }
    }

    /// The same model with its speed (m/s) read from the plant's road input `input` (the
    /// harness ramps it linearly between samples, as every road input);
    /// [`IdealAero::speed_m_per_s`] stays the speed at the start.
    pub fn with_speed_input(mut self, input: usize) -> Self {
        self.speed_input = Some(input);
        self
    }

    /// Front and rear axle forces (N, up positive) at the axle displacements `x_front`,
    /// `x_rear` (m, up positive, from the static ride height) and the speed
    /// [`IdealAero::speed_m_per_s`].
    pub fn axle_forces(&self, x_front: f64, x_rear: f64) -> [f64; 2] {
        self.axle_forces_at(x_front, x_rear, self.speed_m_per_s)
    }

    /// Front and rear axle forces (N, up positive) at the axle displacements `x_front`,
    /// `x_rear` (m) and the speed `speed_m_per_s` (m/s): the down force scales with
    /// `(v / v_ref)²`.
    pub fn axle_forces_at(&self, x_front: f64, x_rear: f64, speed_m_per_s: f64) -> [f64; 2] {
        let p = &self.params;
        let ratio = speed_m_per_s / f64::from(p.reference_speed);
        let q = ratio * ratio;
        let (lf, lr) = (f64::from(p.front_axle), f64::from(p.rear_axle));
        let wheelbase = lf + lr;
        if p.use_map == 1 {
            let m = &p.map;
            let (i, tf) = map_locate(
                &m.front_height,
                m.front_points,
                f64::from(m.static_front_height) + x_front,
            );
            let (j, tr) = map_locate(
                &m.rear_height,
                m.rear_points,
                f64::from(m.static_rear_height) + x_rear,
            );
            [
                -q * map_bilinear(&m.front_force, i, j, tf, tr),
                -q * map_bilinear(&m.rear_force, i, j, tf, tr),
            ]
        } else {
            let z = (lr * x_front + lf * x_rear) / wheelbase;
            let theta = (x_rear - x_front) / wheelbase;
            let k = p.stiffness.map(|row| row.map(f64::from));
            let f_z = q * (k[0][0] * z + k[0][1] * theta + f64::from(p.nominal_force[0]));
            let m_theta = q * (k[1][0] * z + k[1][1] * theta + f64::from(p.nominal_force[1]));
            [
                (lr * f_z - m_theta) / wheelbase,
                (lf * f_z + m_theta) / wheelbase,
            ]
        }
    }

    /// The static axle forces (N, up positive): [`IdealAero::axle_forces`] at `x = 0`, the
    /// nominal down force at this speed that the suspensions carry at static equilibrium.
    pub fn static_forces(&self) -> [f64; 2] {
        self.axle_forces(0.0, 0.0)
    }
}

impl IdealInterface for IdealAero {
    fn forces(
        &self,
        y: &[f64],
        _y_dot: &[f64],
        road: &[f64],
        _road_rate: &[f64],
        forces: &mut [f64],
    ) {
        let x = |j: usize| y.get(j).copied().unwrap_or(0.0);
        let speed = self
            .speed_input
            .and_then(|i| road.get(i).copied())
            .unwrap_or(self.speed_m_per_s);
        let f = self.axle_forces_at(x(0), x(1), speed);
        for (o, v) in forces.iter_mut().zip(f) {
            *o = v;
        }
    }
}

/// The aero example's half car on a four-poster: the half car `specimen` (e.g.
/// [`Specimen::half_car_holding`], or a structure file's) with one `actuator` at each of its
/// two attachments, the axle points (controller channels `first_channel` (front) and
/// `first_channel + 1` (rear)), and the emulated half car driven at the axle points by the
/// ideal `aero` model. The run's road inputs `road_inputs` = [front post, rear post] (m)
/// drive the specimen's two road inputs in both (the four-poster's posts are physical).
///
/// The specimen must be at rest at `q = 0` when the actuators hold the model's static
/// down force `aero.static_forces()` (N per axle; the board's `AeroParams::forces(0, 0, v)`
/// differs by `f32` rounding, about 1e-4 N): its preloads carry the weight and the down
/// force.
///
/// # Errors
/// An invalid specimen or step, a specimen without two attachments and two road inputs or
/// not at rest under the static down force, or an `aero` whose speed follows a road input
/// (use [`half_car_part_varying_speed`]).
pub fn half_car_part(
    specimen: Specimen,
    actuator: ForceActuator,
    aero: IdealAero,
    first_channel: usize,
    road_inputs: [usize; 2],
    internal_step_s: f64,
) -> Result<RigPart, SpecimenError> {
    if aero.speed_input.is_some() {
        return Err(SpecimenError(
            "half_car_part runs at the constant speed: a varying speed needs \
             half_car_part_varying_speed"
                .into(),
        ));
    }
    build_half_car(
        specimen,
        actuator,
        aero,
        first_channel,
        road_inputs,
        None,
        internal_step_s,
    )
}

/// [`half_car_part`] with a speed that varies over the run: the run's road input
/// `speed_input` carries the vehicle speed (m/s) per sample. The emulated aero model reads
/// it as its plant's third road input (after the two posts; the suspensions do not use it),
/// ramped linearly between samples like every road input; the board reads the same column
/// ([`aero_input_varying_speed`]). `aero.speed_m_per_s` is the speed at the start: the
/// specimen is at rest under the down force at that speed, so the rig starts at rest when
/// the actuators hold [`aero_static_demand`] at it.
///
/// # Errors
/// As [`half_car_part`].
pub fn half_car_part_varying_speed(
    specimen: Specimen,
    actuator: ForceActuator,
    aero: IdealAero,
    first_channel: usize,
    road_inputs: [usize; 2],
    speed_input: usize,
    internal_step_s: f64,
) -> Result<RigPart, SpecimenError> {
    build_half_car(
        specimen,
        actuator,
        aero.with_speed_input(2),
        first_channel,
        road_inputs,
        Some(speed_input),
        internal_step_s,
    )
}

/// The half car's rig part; with `speed_input`, the emulated specimen takes the speed as
/// its third road input (`aero` reads its input 2).
fn build_half_car(
    specimen: Specimen,
    actuator: ForceActuator,
    aero: IdealAero,
    first_channel: usize,
    road_inputs: [usize; 2],
    speed_input: Option<usize>,
    internal_step_s: f64,
) -> Result<RigPart, SpecimenError> {
    if specimen.attachments.len() != 2 || specimen.inputs.len() != 2 {
        return Err(SpecimenError(format!(
            "the four-poster's half car has two actuators (front and rear axle) and two posts: \
             {} attachments and road inputs {:?} given",
            specimen.attachments.len(),
            specimen.inputs
        )));
    }
    specimen
        .check_near_rest(
            &aero.static_forces(),
            crate::specimen::STATIC_DEMAND_TOLERANCE,
        )
        .map_err(|e| {
            SpecimenError(format!(
                "under the aero model's static down force at {} m/s: {}",
                aero.speed_m_per_s, e.0
            ))
        })?;
    let mut emulated = specimen.clone();
    let mut emulated_inputs = road_inputs.to_vec();
    if let Some(speed) = speed_input {
        emulated.inputs.push("speed".into());
        for e in &mut emulated.elements {
            e.input_coefficients.push(0.0);
        }
        emulated_inputs.push(speed);
    }
    Ok(RigPart {
        mil: Plant::with_actuators(specimen, vec![actuator; 2], internal_step_s)?,
        emulated: Plant::with_ideal_interface(emulated, Box::new(aero), internal_step_s)?,
        first_channel,
        mil_inputs: road_inputs.to_vec(),
        emulated_inputs,
    })
}

/// The board's static aero demand (N per channel, front and rear): model-core's
/// [`AeroParams::forces`] at `x = 0` and `speed_m_per_s` (m/s), the `initial_demand` of
/// [`crate::harness::run`] for a rig at rest.
pub fn aero_static_demand(params: &AeroParams, speed_m_per_s: f64) -> [f64; 2] {
    params.forces(0.0, 0.0, speed_m_per_s as f32).map(f64::from)
}

/// The board's controller for the front and rear down-force channels at `sample_rate_hz`
/// (Hz): model-core's aero model with `params`, no command filter, `limits` on both
/// channels, and the static demand at the reference speed
/// ([`aero_static_demand`]`(params, v_ref)`, N) as the safe demand.
///
/// # Errors
/// Parameters model-core refuses (including a safe demand outside `limits`).
pub fn aero_controller(
    params: AeroParams,
    limits: DemandLimits,
    sample_rate_hz: f64,
) -> Result<Controller<AeroModel, 2>, ParamError> {
    let controller_params = ControllerParams {
        model: params,
        filter: [CascadeCoefficients::IDENTITY; 2],
        limits: [limits; 2],
        safe_demand: params.forces(0.0, 0.0, params.reference_speed),
        safe_ramp_rate: [1.0e5; 2],
    };
    Controller::with_params(&controller_params, (1.0 / sample_rate_hz) as f32)
}

/// The aero controller's input builder for a constant vehicle speed `speed_m_per_s` (m/s):
/// the returned function (the `input` argument of [`crate::harness::run`]) passes the
/// received attachment positions (m) and forces (N) per channel, the run's road inputs 0
/// and 1 (the front and rear posts, m, as [`paper_aero_part`] maps them; the aero model does
/// not use them) and the speed.
pub fn aero_input(
    speed_m_per_s: f64,
) -> impl Fn(&[f64; 2], &[f64; 2], &[f64], usize) -> ModelInput<2> + Copy {
    move |position, force, road, _sample| {
        let road_at = |i: usize| road.get(i).copied().unwrap_or(0.0) as f32;
        ModelInput {
            position: position.map(|v| v as f32),
            force: force.map(|v| v as f32),
            road: [road_at(0), road_at(1)],
            speed: speed_m_per_s as f32,
        }
    }
}

/// The aero controller's input builder for a speed that varies over the run: as
/// [`aero_input`], with the speed (m/s) taken from the run's road input `speed_input` at
/// each sample (the column [`half_car_part_varying_speed`] gives the emulated model).
pub fn aero_input_varying_speed(
    speed_input: usize,
) -> impl Fn(&[f64; 2], &[f64; 2], &[f64], usize) -> ModelInput<2> + Copy {
    move |position, force, road, sample| {
        let speed = road.get(speed_input).copied().unwrap_or(0.0);
        aero_input(speed)(position, force, road, sample)
    }
}

/// The paper's aero example on channels 0 (front) and 1 (rear): [`AeroExample::default`]'s
/// half car with its linear suspensions, the reference actuator without effects at each
/// axle, and the emulated aero model of [`AeroParams::PAPER`] at its reference speed
/// (50 m/s, where the model's stiffness is the analysis' `K_i`), driven by road inputs 0
/// (front post) and 1 (rear post).
///
/// # Errors
/// A non-positive step.
pub fn paper_aero_part(internal_step_s: f64) -> Result<RigPart, SpecimenError> {
    let car = AeroExample::default();
    let actuator = ForceActuator::new(
        mil_params::ServoHydraulicActuator::REFERENCE,
        crate::actuator::ActuatorEffects::default(),
    )
    .map_err(|e| SpecimenError(e.to_string()))?;
    let params = AeroParams::PAPER;
    let aero = IdealAero::new(params, f64::from(params.reference_speed));
    let (front, rear) = Specimen::half_car_suspensions(&car);
    half_car_part(
        Specimen::half_car_holding(&car, front, rear, aero.static_forces()),
        actuator,
        aero,
        0,
        [0, 1],
        internal_step_s,
    )
}

/// The ideal (emulated) numerical substructure of model-core's
/// [`SubstructureParams`] under [`Causality::Impedance`] (the paper's configuration 4:
/// `B_i` numerical, force-controlled actuators), as the interface law of an emulated plant
/// whose specimen holds the physical DOFs *and* the numerical masses.
///
/// The emulated plant's attachments are, in order, the `m` actuator channels' attachment
/// points `y_c` on the physical specimen, then one attachment per numerical DOF (`x_n,i`,
/// the unit vector of that DOF), and its road inputs are the physical specimen's, then the
/// model's road input `w_c` of each channel. The law, evaluated continuously in `f64` from
/// the board's `f32` parameters:
///
/// ```text
/// channel c:        F_c = k_i,c (x_n,d(c) − y_c) + c_i,c (ẋ_n,d(c) − ẏ_c)     (on the physical part)
/// numerical DOF i:  G_i = −(K' x_n + C' ẋ_n)_i + Σ_c (G_k[i][c] w_c + G_c[i][c] ẇ_c)
///                         − Σ_{c: d(c) = i} F_c
/// ```
///
/// with `K' = K + diag(Σ_c G_k[·][c])`, `C' = C + diag(Σ_c G_c[·][c])` (model-core folds the
/// road springs and dampers into the diagonal the same way), so that the numerical masses
/// obey `M ẍ_n = G`, model-core's equation with the exact (not estimated) interface velocity.
/// The law is affine ([`IdealInterface::affine`]), so a linear specimen takes exact steps.
///
/// The substructure's nonlinear elements act on the numerical DOFs with their whole laws
/// (`F_e(x_e, v_e)` at the element's compression `x_e = a·x_n + b·w` and its rate, as
/// `−a F_e`; the law evaluated as the board evaluates it, model-core's `ElementLaw`, in
/// `f32`): with any element the law is nonlinear and [`IdealInterface::affine`] is `None`.
#[derive(Clone, Debug, PartialEq)]
pub struct IdealSubstructure {
    /// The affine law over the attachments and road inputs described above (the network
    /// without the elements).
    pub law: AffineInterface,
    /// The elements: coefficients `a` per numerical DOF, `b` per model road input, law.
    elements: Vec<(Vec<f64>, Vec<f64>, model_core::ElementLaw)>,
    /// Attachments before the numerical DOFs (the channels), and road inputs before the
    /// model's (the physical specimen's).
    channels: usize,
    specimen_inputs: usize,
}

impl IdealSubstructure {
    /// The law of `params` for an emulated plant whose physical specimen has
    /// `specimen_inputs` road inputs (the model's `CH` road inputs follow them).
    ///
    /// # Errors
    /// A causality other than [`Causality::Impedance`] (the rig's actuators are
    /// force-controlled and the law needs `B_i` numerical), or parameters model-core
    /// refuses.
    pub fn new<const CH: usize>(
        params: &SubstructureParams<CH>,
        specimen_inputs: usize,
    ) -> Result<Self, SpecimenError> {
        params
            .validate()
            .map_err(|e| SpecimenError(format!("substructure parameters: {e}")))?;
        if params.causality() != Some(Causality::Impedance) {
            return Err(SpecimenError(format!(
                "substructure causality {:?}: the simulated rig's actuators are \
                 force-controlled, so the numerical model must compute B_i (impedance, the \
                 paper's configuration 4)",
                params.causality()
            )));
        }
        let n = params.dof as usize;
        let rows = CH + n;
        let inputs = specimen_inputs + CH;
        let f = f64::from;
        let mut position = vec![vec![0.0; rows]; rows];
        let mut velocity = vec![vec![0.0; rows]; rows];
        let mut road = vec![vec![0.0; inputs]; rows];
        let mut road_rate = vec![vec![0.0; inputs]; rows];
        for i in 0..n {
            for j in 0..n {
                position[CH + i][CH + j] -= f(params.stiffness[i][j]);
                velocity[CH + i][CH + j] -= f(params.damping[i][j]);
            }
            for c in 0..CH {
                let (k, d) = (
                    f(params.ground_stiffness[i][c]),
                    f(params.ground_damping[i][c]),
                );
                position[CH + i][CH + i] -= k;
                velocity[CH + i][CH + i] -= d;
                road[CH + i][specimen_inputs + c] += k;
                road_rate[CH + i][specimen_inputs + c] += d;
            }
        }
        for (c, interface) in params.interface.iter().enumerate() {
            let d = CH + interface.dof as usize;
            let (k, damping) = (f(interface.stiffness), f(interface.damping));
            // F_c on the physical attachment ...
            position[c][d] += k;
            position[c][c] -= k;
            velocity[c][d] += damping;
            velocity[c][c] -= damping;
            // ... and −F_c on the numerical DOF.
            position[d][d] -= k;
            position[d][c] += k;
            velocity[d][d] -= damping;
            velocity[d][c] += damping;
        }
        let elements = params
            .used_elements()
            .iter()
            .map(|e| {
                (
                    e.dof_coefficients.iter().take(n).map(|a| f(*a)).collect(),
                    e.road_coefficients.iter().map(|b| f(*b)).collect(),
                    e.law,
                )
            })
            .collect();
        Ok(Self {
            law: AffineInterface {
                offset_n: vec![0.0; rows],
                position_n_per_m: position,
                velocity_n_s_per_m: velocity,
                road_n_per_m: road,
                road_rate_n_s_per_m: road_rate,
                lower_bound_n: vec![f64::NEG_INFINITY; rows],
            },
            elements,
            channels: CH,
            specimen_inputs,
        })
    }
}

impl IdealInterface for IdealSubstructure {
    fn affine(&self) -> Option<AffineInterface> {
        self.elements.is_empty().then(|| self.law.clone())
    }

    fn forces(
        &self,
        y: &[f64],
        y_dot: &[f64],
        road: &[f64],
        road_rate: &[f64],
        forces: &mut [f64],
    ) {
        let a = &self.law;
        let dot = |row: &[f64], v: &[f64]| row.iter().zip(v).map(|(p, q)| p * q).sum::<f64>();
        for (j, out) in forces.iter_mut().enumerate() {
            *out = a.offset_n[j]
                + dot(&a.position_n_per_m[j], y)
                + dot(&a.velocity_n_s_per_m[j], y_dot)
                + dot(&a.road_n_per_m[j], road)
                + dot(&a.road_rate_n_s_per_m[j], road_rate);
        }
        let tail = |v: &[f64], from: usize| v.get(from..).unwrap_or(&[]).to_vec();
        let (x_n, v_n) = (tail(y, self.channels), tail(y_dot, self.channels));
        let (w, w_dot) = (
            tail(road, self.specimen_inputs),
            tail(road_rate, self.specimen_inputs),
        );
        for (a_e, b_e, law) in &self.elements {
            let x = dot(a_e, &x_n) + dot(b_e, &w);
            let v = dot(a_e, &v_n) + dot(b_e, &w_dot);
            let force = f64::from(law.force(x as f32, v as f32));
            for (out, a) in forces.iter_mut().skip(self.channels).zip(a_e) {
                *out -= a * force;
            }
        }
    }
}

/// A mass-spring-damper specimen on force-controlled actuators with model-core's general
/// substructure as the numerical part (configuration 4): the MiL rig is `specimen` with
/// `actuators[c]` at its attachment `c` (controller channel `first_channel + c`); the
/// emulated system is the same specimen coupled ideally to the numerical masses of `params`
/// through `B_i` ([`IdealSubstructure`]: the emulated specimen holds the physical DOFs and,
/// after them, the numerical ones). The physical specimen's road inputs are driven by the
/// run's road inputs `specimen_inputs` (indices, one per `specimen.inputs`), the model's
/// road input of channel `c` by the run's road input `model_roads[c]` (the board reads the
/// same columns, [`substructure_input`]).
///
/// The numerical model's output at rest is zero (no static force), so the specimen must be
/// in static equilibrium at `q = 0` with zero actuator force: its element preloads carry its
/// static forces ([`Specimen::static_imbalance`]).
///
/// # Errors
/// An invalid specimen or step, attachments or actuators other than `CH`, a specimen not at
/// rest with zero actuator force (imbalance above 1e-6 N), an input map of the wrong
/// length, or substructure parameters [`IdealSubstructure::new`] refuses.
#[allow(clippy::too_many_arguments)]
pub fn substructure_part<const CH: usize>(
    specimen: Specimen,
    actuators: Vec<ForceActuator>,
    params: &SubstructureParams<CH>,
    first_channel: usize,
    specimen_inputs: &[usize],
    model_roads: [usize; CH],
    internal_step_s: f64,
) -> Result<RigPart, SpecimenError> {
    specimen.validate()?;
    if specimen.attachments.len() != CH || actuators.len() != CH {
        return Err(SpecimenError(format!(
            "the substructure serves {CH} channel(s): the specimen has {} attachment(s) and \
             {} actuator(s)",
            specimen.attachments.len(),
            actuators.len()
        )));
    }
    if specimen_inputs.len() != specimen.inputs.len() {
        return Err(SpecimenError(format!(
            "{} road input(s) mapped for the specimen's {}",
            specimen_inputs.len(),
            specimen.inputs.len()
        )));
    }
    specimen.check_at_rest(&[0.0; CH])?;
    let law = IdealSubstructure::new(params, specimen.inputs.len())?;
    let (np, nn) = (specimen.len(), params.dof as usize);
    let pad = |v: &[f64], extra: usize| -> Vec<f64> {
        v.iter()
            .copied()
            .chain(std::iter::repeat_n(0.0, extra))
            .collect()
    };
    let mut emulated = specimen.clone();
    emulated
        .dofs
        .extend((0..nn).map(|i| format!("numerical_{i}")));
    emulated.mass = specimen
        .mass
        .iter()
        .map(|row| pad(row, nn))
        .chain((0..nn).map(|i| {
            let mut row = vec![0.0; np];
            row.extend((0..nn).map(|j| f64::from(params.mass[i][j])));
            row
        }))
        .collect();
    emulated.static_force = pad(&specimen.static_force, nn);
    for e in &mut emulated.elements {
        e.dof_coefficients = pad(&e.dof_coefficients, nn);
        e.input_coefficients = pad(&e.input_coefficients, CH);
    }
    emulated
        .inputs
        .extend((0..CH).map(|c| format!("model_road_{c}")));
    emulated.attachments = specimen
        .attachments
        .iter()
        .map(|t| pad(t, nn))
        .chain((0..nn).map(|i| {
            let mut t = vec![0.0; np + nn];
            t[np + i] = 1.0;
            t
        }))
        .collect();
    let mut emulated_inputs = specimen_inputs.to_vec();
    emulated_inputs.extend(model_roads);
    Ok(RigPart {
        mil: Plant::with_actuators(specimen, actuators, internal_step_s)?,
        emulated: Plant::with_ideal_interface(emulated, Box::new(law), internal_step_s)?,
        first_channel,
        mil_inputs: specimen_inputs.to_vec(),
        emulated_inputs,
    })
}

/// The substructure controller's input builder (the `input` argument of
/// [`crate::harness::run`]): the received attachment positions (m) and forces (N) per
/// channel, and per channel `c` the run's road input `model_roads[c]` (m) as the model's
/// road input; speed zero.
pub fn substructure_input<const CH: usize>(
    model_roads: [usize; CH],
) -> impl Fn(&[f64; CH], &[f64; CH], &[f64], usize) -> ModelInput<CH> + Copy {
    move |position, force, road, _sample| ModelInput {
        position: position.map(|v| v as f32),
        force: force.map(|v| v as f32),
        road: model_roads.map(|i| road.get(i).copied().unwrap_or(0.0) as f32),
        speed: 0.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::harness::{run, Instrumentation};

    const FS: f64 = 2000.0;

    /// At rest on a flat road the aero rig holds the static down force: both load cells
    /// read the static demand, the emulated forces are the same, and nothing moves (the
    /// harness starts at the static equilibrium, which includes the aero load).
    #[test]
    fn aero_rig_starts_and_stays_at_rest() {
        let params = AeroParams::PAPER;
        let speed = f64::from(params.reference_speed);
        let limits = DemandLimits {
            min: -20_000.0,
            max: 20_000.0,
            rate: 1.0e9,
        };
        let mut controller = aero_controller(params, limits, FS).unwrap();
        let mut parts = vec![paper_aero_part(100e-6).unwrap()];
        let demand = aero_static_demand(&params, speed);
        let road = vec![vec![0.0; 2000]; 2];
        let (h, _) = run(
            &mut controller,
            &mut parts,
            &Instrumentation::default(),
            FS,
            &road,
            &demand,
            aero_input(speed),
            |_| {},
        )
        .unwrap();
        assert_eq!(h.len(), 2000);
        assert!(h.status.iter().all(|s| s.fault == 0));
        // The static down force: −8.28 kN and −1.49 kN m split onto the axles (l_f, l_r as
        // f32 move it by 9e-6 N).
        let ideal = IdealAero::new(params, speed).static_forces();
        assert!((ideal[0] + 3156.875).abs() < 1e-4, "{ideal:?}");
        assert!((ideal[1] + 5123.125).abs() < 1e-4, "{ideal:?}");
        for (c, static_demand) in demand.iter().enumerate() {
            for ((f, y), d) in h.mil_force[c]
                .iter()
                .zip(&h.mil_position[c])
                .zip(&h.demand[c])
            {
                assert!((f - static_demand).abs() < 1e-3, "channel {c}: {f}");
                assert!(y.abs() < 1e-8, "channel {c}: {y}");
                assert!((d - static_demand).abs() < 1e-3, "channel {c}: demand {d}");
            }
            // (The f32 static demand differs from the f64 down force by about 1e-4 N.)
            for (f, y) in h.emulated_force[c].iter().zip(&h.emulated_position[c]) {
                assert!((f - static_demand).abs() < 1e-3, "channel {c}: {f}");
                assert!(y.abs() < 1e-8, "channel {c}: {y}");
            }
        }
    }

    /// The ideal model is the board's (f32) model: the same axle forces at displaced
    /// positions, speeds, and with a ride-height map.
    #[test]
    fn ideal_aero_matches_the_board_model() {
        let mut mapped = AeroParams::PAPER;
        mapped.use_map = 1;
        mapped.map.front_points = 3;
        mapped.map.rear_points = 2;
        mapped.map.front_height[..3].copy_from_slice(&[0.0, 0.04, 0.1]);
        mapped.map.rear_height[..2].copy_from_slice(&[0.0, 0.1]);
        mapped.map.front_force[0][..2].copy_from_slice(&[5000.0, 4500.0]);
        mapped.map.front_force[1][..2].copy_from_slice(&[4000.0, 3800.0]);
        mapped.map.front_force[2][..2].copy_from_slice(&[3000.0, 2900.0]);
        mapped.map.rear_force[0][..2].copy_from_slice(&[6000.0, 5000.0]);
        mapped.map.rear_force[1][..2].copy_from_slice(&[5500.0, 4800.0]);
        mapped.map.rear_force[2][..2].copy_from_slice(&[5200.0, 4000.0]);
        for params in [AeroParams::PAPER, mapped] {
            for speed in [20.0_f32, 50.0, 70.0] {
                let ideal = IdealAero::new(params, f64::from(speed));
                for (xf, xr) in [(0.0, 0.0), (3e-3, -2e-3), (-0.02, 0.01), (0.2, -0.2)] {
                    let board = params.forces(xf as f32, xr as f32, speed);
                    let f = ideal.axle_forces(xf, xr);
                    for c in 0..2 {
                        let scale = f64::from(board[c]).abs().max(1.0);
                        assert!(
                            (f[c] - f64::from(board[c])).abs() < 1e-5 * scale,
                            "{xf} {xr} {speed}: {f:?} vs {board:?}"
                        );
                    }
                }
            }
        }
    }

    /// The paper's 2-DOF example (m_n = 10 kg on 4e4 N/m, 20 N s/m from its road; B_i =
    /// 1e4 N/m, 5 N s/m) as the board's substructure, configuration 4.
    fn two_dof_numerical() -> SubstructureParams<1> {
        let mut p = SubstructureParams::<1>::zeroed(1, Causality::Impedance);
        p.mass[0][0] = 10.0;
        p.ground_stiffness[0][0] = 4.0e4;
        p.ground_damping[0][0] = 20.0;
        p.interface[0] = model_core::InterfaceParams {
            dof: 0,
            stiffness: 1.0e4,
            damping: 5.0,
        };
        p
    }

    /// Its physical mass, 5 kg on 2e4 N/m and 10 N s/m to the bed, carrying its weight
    /// with `preload` (N).
    fn two_dof_physical(preload: f64) -> Specimen {
        Specimen {
            dofs: vec!["x_p".into()],
            mass: vec![vec![5.0]],
            static_force: vec![-5.0 * crate::specimen::GRAVITY_M_PER_S2],
            elements: vec![crate::specimen::PlacedElement {
                name: "k_p".into(),
                element: Element::linear(2.0e4, 10.0).with_preload(preload),
                dof_coefficients: vec![-1.0],
                input_coefficients: vec![],
            }],
            inputs: vec![],
            attachments: vec![vec![1.0]],
        }
    }

    fn reference_actuator() -> ForceActuator {
        ForceActuator::new(
            mil_params::ServoHydraulicActuator::REFERENCE,
            crate::actuator::ActuatorEffects::default(),
        )
        .unwrap()
    }

    /// The ideal substructure law is model-core's equation: the interface force on the
    /// physical attachment and the forces on the numerical mass, term by term.
    #[test]
    fn ideal_substructure_is_the_models_law() {
        let law = IdealSubstructure::new(&two_dof_numerical(), 1).unwrap();
        // Attachments [y_p, x_n], inputs [specimen's post, model road].
        let (y, y_dot, w, w_dot) = ([0.002, -0.001], [0.1, 0.3], [0.5, 0.004], [7.0, -0.2]);
        let mut f = [0.0; 2];
        law.forces(&y, &y_dot, &w, &w_dot, &mut f);
        let interface = 1.0e4 * (y[1] - y[0]) + 5.0 * (y_dot[1] - y_dot[0]);
        let numerical = -4.0e4 * (y[1] - w[1]) - 20.0 * (y_dot[1] - w_dot[1]) - interface;
        assert!((f[0] - interface).abs() < 1e-9, "{f:?}");
        assert!((f[1] - numerical).abs() < 1e-9, "{f:?}");
        assert!(law.affine().is_some());
        // Other causalities need a position-controlled actuator or B_i on the rig.
        let mut other = two_dof_numerical();
        other.causality = Causality::PrescribedMotion as u32;
        let e = IdealSubstructure::new(&other, 0).unwrap_err();
        assert!(e.0.contains("impedance"), "{e}");
    }

    /// The substructure's nonlinear elements act in the emulated system: the 2-DOF
    /// example's road spring and damper written as an element (compression `z_n − x_n`) with
    /// a linear law gives the network's forces, term by term, and the law is then not
    /// affine; with a bump stop 1 mm from rest, the stop's force appears exactly beyond it.
    #[test]
    fn ideal_substructure_carries_the_elements() {
        let network = IdealSubstructure::new(&two_dof_numerical(), 1).unwrap();
        let mut as_element = two_dof_numerical();
        as_element.ground_stiffness[0][0] = 0.0;
        as_element.ground_damping[0][0] = 0.0;
        as_element.element_count = 1;
        as_element.elements[0] = model_core::SubstructureElement {
            dof_coefficients: [-1.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            road_coefficients: [1.0],
            law: model_core::ElementLaw::linear(4.0e4, 20.0),
        };
        let element = IdealSubstructure::new(&as_element, 1).unwrap();
        assert!(network.affine().is_some() && element.affine().is_none());
        let mut worst: f64 = 0.0;
        for (y, y_dot, w, w_dot) in [
            ([0.002, -0.001], [0.1, 0.3], [0.5, 0.004], [7.0, -0.2]),
            ([-0.01, 0.003], [-0.2, 0.05], [0.0, -0.002], [0.0, 0.4]),
        ] {
            let (mut a, mut b) = ([0.0; 2], [0.0; 2]);
            network.forces(&y, &y_dot, &w, &w_dot, &mut a);
            element.forces(&y, &y_dot, &w, &w_dot, &mut b);
            for (a, b) in a.iter().zip(b) {
                // The element's law is the board's, in f32.
                worst = worst.max((a - b).abs() / a.abs().max(1.0));
            }
        }
        assert!(worst < 1e-6, "{worst:e}");
        // A bump stop: 1e5 N/m beyond 1 mm of compression, nothing before.
        as_element.elements[0].law.bump_gap = 1e-3;
        as_element.elements[0].law.bump_stiffness = 1e5;
        let stop = IdealSubstructure::new(&as_element, 1).unwrap();
        let force_on_mass = |law: &IdealSubstructure, x_n: f64| {
            let mut f = [0.0; 2];
            law.forces(&[0.0, x_n], &[0.0, 0.0], &[0.0, 0.0], &[0.0, 0.0], &mut f);
            f[1]
        };
        for x_n in [-0.5e-3, 0.5e-3] {
            let d = force_on_mass(&stop, x_n) - force_on_mass(&element, x_n);
            assert!(d.abs() < 1e-6, "{x_n}: {d}");
        }
        // 2 mm of compression (the mass 2 mm down): 1 mm into the stop pushes it up 100 N more.
        let d = force_on_mass(&stop, -2e-3) - force_on_mass(&element, -2e-3);
        assert!((d - 100.0).abs() < 1e-3, "{d}");
    }

    /// The 2-DOF rig starts and stays at rest (the spring's preload carries the weight, the
    /// model demands nothing at rest); a specimen that is not balanced is refused.
    #[test]
    fn substructure_rig_starts_at_rest_and_an_unbalanced_specimen_is_refused() {
        let weight = 5.0 * crate::specimen::GRAVITY_M_PER_S2;
        let params = two_dof_numerical();
        let mut parts = vec![substructure_part(
            two_dof_physical(weight),
            vec![reference_actuator()],
            &params,
            0,
            &[],
            [0],
            100e-6,
        )
        .unwrap()];
        // The emulated plant holds both masses and takes exact steps.
        assert_eq!(parts[0].emulated.specimen().len(), 2);
        assert!(parts[0].emulated.has_exact_steps());
        let limits = DemandLimits {
            min: -1000.0,
            max: 1000.0,
            rate: 1.0e9,
        };
        let mut controller: Controller<model_core::SubstructureModel<1>, 1> =
            Controller::with_params(
                &ControllerParams {
                    model: params,
                    filter: [CascadeCoefficients::IDENTITY],
                    limits: [limits],
                    safe_demand: [0.0],
                    safe_ramp_rate: [1.0e5],
                },
                (1.0 / FS) as f32,
            )
            .unwrap();
        let (h, _) = run(
            &mut controller,
            &mut parts,
            &Instrumentation::default(),
            FS,
            &[vec![0.0; 1000]],
            &[0.0],
            substructure_input([0]),
            |_| {},
        )
        .unwrap();
        assert!(h.status.iter().all(|s| s.fault == 0));
        for v in [&h.mil_force[0], &h.mil_position[0], &h.emulated_force[0]] {
            assert!(v.iter().all(|x| x.abs() < 1e-9), "{:?}", &v[..4]);
        }
        let e = substructure_part(
            two_dof_physical(0.9 * weight),
            vec![reference_actuator()],
            &params,
            0,
            &[],
            [0],
            100e-6,
        )
        .err()
        .unwrap();
        assert!(e.0.contains("not at rest with zero actuator force"), "{e}");
        assert!(e.0.contains("-4.905"), "{e}");
    }

    /// A speed column that holds the constant speed gives exactly the constant-speed rig's
    /// run (the emulated model reads the column, the board the same samples), and the
    /// constant-speed builder refuses a model whose speed follows a column.
    #[test]
    fn a_constant_speed_column_matches_the_constant_speed_rig() {
        let params = AeroParams::PAPER;
        let speed = 45.0;
        let car = AeroExample::default();
        let limits = DemandLimits {
            min: -20_000.0,
            max: 20_000.0,
            rate: 1.0e9,
        };
        let road: Vec<f64> = (0..2000).map(|k| 1e-3 * (0.02 * k as f64).sin()).collect();
        let aero = IdealAero::new(params, speed);
        let (front, rear) = Specimen::half_car_suspensions(&car);
        let specimen = Specimen::half_car_holding(&car, front, rear, aero.static_forces());
        let constant = half_car_part(
            specimen.clone(),
            reference_actuator(),
            aero,
            0,
            [0, 1],
            100e-6,
        )
        .unwrap();
        let varying = half_car_part_varying_speed(
            specimen.clone(),
            reference_actuator(),
            aero,
            0,
            [0, 1],
            2,
            100e-6,
        )
        .unwrap();
        let columns = [road.clone(), road, vec![speed; 2000]];
        let mut runs = Vec::new();
        for (part, varying) in [(constant, false), (varying, true)] {
            let mut controller = aero_controller(params, limits, FS).unwrap();
            let demand = aero_static_demand(&params, speed);
            let mut parts = vec![part];
            let (h, _) = if varying {
                run(
                    &mut controller,
                    &mut parts,
                    &Instrumentation::default(),
                    FS,
                    &columns,
                    &demand,
                    aero_input_varying_speed(2),
                    |_| {},
                )
            } else {
                run(
                    &mut controller,
                    &mut parts,
                    &Instrumentation::default(),
                    FS,
                    &columns[..2],
                    &demand,
                    aero_input(speed),
                    |_| {},
                )
            }
            .unwrap();
            runs.push(h);
        }
        for c in 0..2 {
            for (a, b) in [
                (&runs[0].mil_force[c], &runs[1].mil_force[c]),
                (&runs[0].emulated_force[c], &runs[1].emulated_force[c]),
                (&runs[0].emulated_position[c], &runs[1].emulated_position[c]),
            ] {
                let worst = a
                    .iter()
                    .zip(b)
                    .map(|(x, y)| (x - y).abs())
                    .fold(0.0, f64::max);
                assert!(
                    worst < 1e-9 * a.iter().fold(1.0_f64, |m, x| m.max(x.abs())),
                    "{worst}"
                );
            }
        }
        let e = half_car_part(
            specimen,
            reference_actuator(),
            aero.with_speed_input(2),
            0,
            [0, 1],
            100e-6,
        )
        .err()
        .unwrap();
        assert!(e.0.contains("half_car_part_varying_speed"), "{e}");
    }
}
