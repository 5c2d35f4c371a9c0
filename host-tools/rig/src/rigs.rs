//! The paper's rigs, ready to run: the quarter car on a hub-coupled rig with the numerical
//! tyre (tyre example), and the half car on a four-poster with the numerical aerodynamic
//! model driving front and rear down-force actuators (aero example), each with its emulated
//! counterpart.

use crate::actuator::ForceActuator;
use crate::effects::{Effects, Element};
use crate::harness::RigPart;
use crate::plant::{AffineInterface, IdealInterface, Plant};
use crate::specimen::{Specimen, SpecimenError};
use mil_analysis::examples::{AeroExample, TyreExample};
use model_core::aero::MAP_POINTS;
use model_core::{
    AeroModel, AeroParams, CascadeCoefficients, Controller, ControllerParams, DemandLimits,
    ModelInput, ParamError, TyreModel, TyreModelParams, TyreParams,
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
        let affine = self.tyres.iter().all(|t| {
            t.effects
                == Effects {
                    lift_off: t.effects.lift_off,
                    ..Effects::default()
                }
        });
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
                    if t.effects.lift_off {
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
/// stateless and uses neither the attachment velocities nor the road.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IdealAero {
    /// The board's aero parameters (their `f32` values, evaluated in `f64`).
    pub params: AeroParams,
    /// Vehicle speed `v` (m/s), constant over a run.
    pub speed_m_per_s: f64,
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
    /// The emulated aero model of `params` at `speed_m_per_s` (m/s).
    pub fn new(params: AeroParams, speed_m_per_s: f64) -> Self {
        Self {
            params,
            speed_m_per_s,
        }
    }

    /// Front and rear axle forces (N, up positive) at the axle displacements `x_front`,
    /// `x_rear` (m, up positive, from the static ride height).
    pub fn axle_forces(&self, x_front: f64, x_rear: f64) -> [f64; 2] {
        let p = &self.params;
        let ratio = self.speed_m_per_s / f64::from(p.reference_speed);
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
        _road: &[f64],
        _road_rate: &[f64],
        forces: &mut [f64],
    ) {
        let x = |j: usize| y.get(j).copied().unwrap_or(0.0);
        let f = self.axle_forces(x(0), x(1));
        for (o, v) in forces.iter_mut().zip(f) {
            *o = v;
        }
    }
}

/// The aero example's half car on a four-poster: the half car of `car` (its
/// [`Specimen::half_car`], with `suspensions` = (front, rear) as its suspension elements) with
/// one `actuator` at each axle point (controller channels `first_channel` (front) and
/// `first_channel + 1` (rear)), and the emulated half car driven at the axle points by the
/// ideal `aero` model. The run's road inputs `road_inputs` = [front post, rear post] (m)
/// drive the suspensions of both (the four-poster's posts are physical).
///
/// Static equilibrium at `q = 0`: the suspensions' preloads are the body's static axle
/// loads plus the static aero down force `−aero.static_forces()` (N) per axle, so the
/// specimen is at rest at `q = 0` when the actuators hold the model's static demand (the
/// board's `AeroParams::forces(0, 0, v)`, which differs from the `f64` value by `f32`
/// rounding, about 1e-4 N).
///
/// # Errors
/// An invalid specimen or step, or axle distances of `aero.params` that differ from the
/// car's by more than 1 µm (the model would put its forces elsewhere than the actuators
/// are).
pub fn half_car_part(
    car: &AeroExample,
    suspensions: (Element, Element),
    actuator: ForceActuator,
    aero: IdealAero,
    first_channel: usize,
    road_inputs: [usize; 2],
    internal_step_s: f64,
) -> Result<RigPart, SpecimenError> {
    let p = &aero.params;
    for (name, model, specimen) in [
        ("front", p.front_axle, car.front_axle_m),
        ("rear", p.rear_axle, car.rear_axle_m),
    ] {
        if (f64::from(model) - specimen).abs() > 1e-6 {
            return Err(SpecimenError(format!(
                "aero model's {name} axle at {model} m, the car's at {specimen} m"
            )));
        }
    }
    let mut specimen = Specimen::half_car(car, suspensions.0, suspensions.1);
    // half_car's elements: front suspension, then rear.
    for (e, f) in specimen.elements.iter_mut().zip(aero.static_forces()) {
        e.element.preload_n -= f;
    }
    Ok(RigPart {
        mil: Plant::with_actuators(specimen.clone(), vec![actuator; 2], internal_step_s)?,
        emulated: Plant::with_ideal_interface(specimen, Box::new(aero), internal_step_s)?,
        first_channel,
        mil_inputs: road_inputs.to_vec(),
        emulated_inputs: road_inputs.to_vec(),
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
        mil_analysis::ServoHydraulicActuator::REFERENCE,
        crate::actuator::ActuatorEffects::default(),
    )
    .map_err(|e| SpecimenError(e.to_string()))?;
    let params = AeroParams::PAPER;
    half_car_part(
        &car,
        Specimen::half_car_suspensions(&car),
        actuator,
        IdealAero::new(params, f64::from(params.reference_speed)),
        0,
        [0, 1],
        internal_step_s,
    )
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
}
