//! The run of a MiL set-up ([`crate::setup::SetUp::run`]): the board's model, limits and
//! filter, the simulated rig, the excitation, validated once into model-core's parameter
//! set. Built from the set-up file, never read from a file of its own.

use crate::signals::{RoadInput, SpeedInput, SpeedProfile};
use anyhow::{bail, Context, Result};
use mil_rig::experiment::PreparedSubstructure;
use model_core::substructure::MAX_ELEMENTS;
use model_core::{
    AeroParams, CascadeCoefficients, Causality, ControllerParams, DemandLimits, InterfaceParams,
    PreparedParams, SubstructureParams, TyreModelParams, TyreParams, MAX_DOF,
};
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// Which numerical model a run uses.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum ModelKind {
    /// Four point-follower tyres (hub-coupled rig), force demand per hub.
    Tyre,
    /// Aerodynamic down force (front and rear down-force actuators).
    Aero,
    /// A general mass-spring-damper substructure (model-core's `SubstructureModel`, up to
    /// 6 DOFs) computing the interface force through its `B_i` for force-controlled
    /// actuators: the paper's configuration 4, e.g. its 2-DOF example.
    Substructure,
}

/// Largest number of actuator channels of a substructure run.
pub const MAX_SUBSTRUCTURE_CHANNELS: usize = 4;

/// A whole run configuration.
#[derive(Clone, Debug)]
pub struct Config {
    /// Timing of the run.
    pub run: RunSection,
    /// Model selector.
    pub model: ModelSection,
    /// Tyre parameters (used when `model.kind = "tyre"`), the same for every wheel.
    pub tyre: Option<TyreSection>,
    /// Aero parameters (used when `model.kind = "aero"`).
    pub aero: Option<AeroSection>,
    /// Vehicle speed over the run (aero model, `[excitation] speed`); `speed_m_per_s` of
    /// [`AeroSection`] is the shorthand for a constant speed. One of the two.
    pub speed: Option<SpeedInput>,
    /// The numerical substructure (used when `model.kind = "substructure"`).
    pub substructure: Option<SubstructureSection>,
    /// Demand limits and the safe state, the same for every channel.
    pub limits: LimitsSection,
    /// Road input.
    pub input: RoadInput,
    /// The board's command filter (optional; none: identity).
    pub controller: ControllerSection,
    /// The simulated rig (`mil sim`; defaults: the paper's rig without effects).
    pub rig: RigSection,
    /// The rig's transducers (`mil sim`; default ideal).
    pub sensors: SensorsSection,
    /// The CAN link between rig and board (`mil sim`; default ideal).
    pub links: LinksSection,
    /// What `mil sim` compares the estimated response with.
    pub compare: CompareSection,
    /// The set-up's linear analysis, whose predictions `mil sim` compares the run with
    /// (none: only the emulated system).
    pub analysis: Option<Box<mil_analysis::setup::Setup>>,
    /// The analysis' inputs the run's road (channel 0's) drives: the prediction is the sum
    /// of their responses.
    pub analysis_inputs: Vec<String>,
    /// Folder of the set-up file (relative paths).
    pub base: PathBuf,
}

/// Timing of the run (`[controller] sample_rate_hz`, `[excitation] duration_s`).
#[derive(Clone, Debug)]
pub struct RunSection {
    /// Control loop rate (Hz); the controller's sample period is its inverse.
    pub sample_rate_hz: f64,
    /// Length of the run (s).
    pub duration_s: f64,
}

/// `[model]`.
#[derive(Clone, Debug)]
pub struct ModelSection {
    /// The model.
    pub kind: ModelKind,
}

/// model-core's tyre (`[numerical.tyre]`, the static load resolved).
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct TyreSection {
    /// Radial stiffness (N/m).
    pub stiffness_n_per_m: f32,
    /// Radial damping (N s/m).
    pub damping_n_s_per_m: f32,
    /// Static wheel load (N).
    pub static_load_n: f32,
    /// Whether the tyre force is limited to pushing (wheel lift-off).
    pub lift_off: bool,
    /// Cut-off of the deflection-velocity low-pass (Hz), 0 for none.
    pub velocity_cutoff_hz: f32,
}

/// model-core's aero model (`[numerical.aero]` with the half car's axles).
#[derive(Clone, Debug)]
pub struct AeroSection {
    /// `K_i` rows `[F_z; M_θ]`, columns `[z; θ]` (N/m, N/rad; N m/m, N m/rad).
    pub stiffness: [[f32; 2]; 2],
    /// `F_n = [F_z (N), M_θ (N m)]` at zero displacement and the reference speed.
    pub nominal_force: [f32; 2],
    /// Reference speed of `stiffness` and `nominal_force` (m/s).
    pub reference_speed_m_per_s: f32,
    /// Centroid to front axle (m).
    pub front_axle_m: f32,
    /// Centroid to rear axle (m).
    pub rear_axle_m: f32,
    /// Constant vehicle speed during the run (m/s; `[excitation] speed_m_per_s`).
    pub speed_m_per_s: Option<f32>,
}

/// The board's substructure, built from `[numerical] structure`: the numerical part, model-core's general mass-spring-damper
/// substructure with `B_i` numerical under force control (configuration 4): per channel it
/// turns the measured attachment position `x̂_p` into the interface force
/// `F_i = k_i (x_n,d − x̂_p) + c_i (ẋ_n,d − ẋ̂_p)` it demands of the actuator, and its masses
/// move under `−F_i` and their road springs:
/// `M ẍ + C' ẋ + K' x = G_k w + G_c ẇ − Σ_c e_d(c) F_i,c` (`K'`, `C'`: the matrices below
/// plus the road springs and dampers on the diagonal).
#[derive(Clone, Debug)]
pub struct SubstructureSection {
    /// DOF names, 1 to 6.
    pub dofs: Vec<String>,
    /// Mass matrix `M` (kg; kg m² for rotations), rows; symmetric positive definite.
    pub mass: Vec<Vec<f32>>,
    /// Damping matrix `C` between the masses and to fixed ground (N s/m), rows; the road
    /// dampers of `[[substructure.channels]] road` are added to its diagonal.
    pub damping: Vec<Vec<f32>>,
    /// Stiffness matrix `K` between the masses and to fixed ground (N/m), rows; the road
    /// springs of `[[substructure.channels]] road` are added to its diagonal.
    pub stiffness: Vec<Vec<f32>>,
    /// Cut-off (Hz) of the low-pass of the board's velocity estimates (measured attachment
    /// position and road input, backward difference); 0: plain backward difference.
    pub velocity_cutoff_hz: f32,
    /// One per actuator channel, in channel order (1 to 4).
    pub channels: Vec<SubstructureChannel>,
    /// The nonlinear elements (model-core's, up to its `MAX_ELEMENTS`); their linear part
    /// is not in `stiffness` and `damping` (model-core adds it).
    pub elements: Vec<BoardElement>,
}

/// A nonlinear element of the board's substructure.
#[derive(Clone, Debug)]
pub struct BoardElement {
    /// The structure file's element name, for messages.
    pub name: String,
    /// Compression per unit of each DOF (m/m, m/rad), in `dofs` order.
    pub dof_coefficients: Vec<f32>,
    /// Compression per unit of each channel's road input (m/m), in channel order.
    pub road_coefficients: Vec<f32>,
    /// The law, the board's form.
    pub law: model_core::ElementLaw,
}

/// `[[substructure.channels]]`: one actuator channel of the substructure.
#[derive(Clone, Debug)]
pub struct SubstructureChannel {
    /// The numerical DOF the interface `B_i` joins to the channel's attachment point.
    pub dof: String,
    /// Interface stiffness `k_i` (N/m).
    pub interface_stiffness_n_per_m: f32,
    /// Interface damping `c_i` (N s/m).
    pub interface_damping_n_s_per_m: f32,
    /// Springs and dampers from numerical DOFs to the channel's road input `w_c` (the run's
    /// road input of this channel).
    pub road: Vec<RoadCoupling>,
}

/// A spring and damper from a numerical DOF to a channel's road input.
#[derive(Clone, Debug)]
pub struct RoadCoupling {
    /// The numerical DOF.
    pub dof: String,
    /// Stiffness (N/m).
    pub stiffness_n_per_m: f32,
    /// Damping (N s/m).
    pub damping_n_s_per_m: f32,
}

/// `[controller]`.
#[derive(Clone, Debug, Default)]
pub struct ControllerSection {
    /// Command-filter file (`mil design-filter`'s JSON), relative to the configuration
    /// file; its sample rate must be the run's. None: no filter.
    pub filter: Option<String>,
}

/// The simulated rig of `mil sim` (from `[physical]`, `[actuator]` and `[simulation]`).
#[derive(Clone, Debug)]
pub struct RigSection {
    /// RK4 step of the plants (s), at most the control period.
    pub internal_step_s: f64,
    /// Parameters of every actuator (the nonlinear servo-hydraulic actuator with its force
    /// loop, `[actuator.reference]` of a `mil analyze` set-up); default: the reference hub
    /// actuator, `ServoHydraulicActuator::REFERENCE`.
    pub actuator: Option<mil_params::ServoHydraulicActuator>,
    /// Switchable effects of every actuator (all off by default).
    pub actuator_effects: mil_rig::actuator::ActuatorEffects,
    /// Effects of the emulated (real) tyre, the vehicle's own, by name with their
    /// parameters (`mil_structure::EffectKind`, e.g. `{ lift_off = {}, bump_stop = { ... } }`);
    /// default: lift-off as the numerical tyre has it. Effects here and not in the board's model are
    /// hidden effects.
    pub tyre_effects:
        Option<std::collections::BTreeMap<mil_structure::EffectKind, mil_structure::Parameters>>,
    /// The physical specimen of a substructure run (required there): a structure file (the
    /// schema of `mil diagnose`'s models and `updated.toml`) and where the actuators act.
    pub structure: Option<StructureOnRig>,
    /// The tyre rig's quarter car (required there), one per wheel: its one attachment the
    /// hub, at rest when the hub actuator holds the tyre's static load.
    pub quarter_car: Option<mil_rig::specimen::Specimen>,
    /// The four-poster's half car (aero rig; required there).
    pub half_car: Option<HalfCarOnRig>,
}

/// The half car on the four-poster (`[physical] structure` under the aero model).
#[derive(Clone, Debug)]
pub struct HalfCarOnRig {
    /// The structure: two posts (displacement inputs, front then rear), two down-force
    /// actuators (force inputs, front then rear).
    pub model: mil_structure::Model,
    /// Where the actuators act: the front and rear axle points.
    pub axles: [String; 2],
    /// The actuators' force inputs, front and rear.
    pub actuators: [String; 2],
    /// The posts' indices among the structure's inputs, front and rear.
    pub posts: [usize; 2],
}

/// A structure file on the simulated rig (`[physical] structure`).
#[derive(Clone, Debug)]
pub struct StructureOnRig {
    /// The structure file, relative to the configuration. It must be at rest with zero
    /// actuator force: its springs carry its weights (`gravity_m_per_s2`).
    pub file: PathBuf,
    /// Per channel, the DOF or point the actuator drives (along its positive direction).
    pub attach: Vec<String>,
    /// The run's road input (`road_0` …) each of the structure's displacement inputs
    /// follows, by input name, or `"fixed"` (held at zero: the rig's bed).
    pub roads: std::collections::BTreeMap<String, String>,
}

impl Default for RigSection {
    fn default() -> Self {
        Self {
            internal_step_s: mil_rig::DEFAULT_INTERNAL_STEP_S,
            actuator: None,
            actuator_effects: Default::default(),
            tyre_effects: None,
            structure: None,
            quarter_car: None,
            half_car: None,
        }
    }
}

/// `[sensors]`: the same transducer spec on every channel.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SensorsSection {
    /// Displacement transducer (m).
    pub position: mil_rig::sensors::SensorSpec,
    /// Load cell (N).
    pub force: mil_rig::sensors::SensorSpec,
}

/// `[links]`: the same CAN link spec on every channel.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LinksSection {
    /// Measured position, rig to board (m).
    pub position: mil_rig::link::LinkSpec,
    /// Measured force, rig to board (N).
    pub force: mil_rig::link::LinkSpec,
    /// Demand, board to rig (N).
    pub demand: mil_rig::link::LinkSpec,
}

/// `[compare]`: how `mil sim` compares the run with the emulated system and with the
/// set-up's analysis.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CompareSection {
    /// Lower edge of the comparison band (Hz).
    pub f_min_hz: f64,
    /// Upper edge of the comparison band (Hz).
    pub f_max_hz: f64,
    /// Welch segment length of the response estimate (samples); none: the workspace's rule
    /// for a band from `f_min_hz` (`mil_identify::WelchOptions::for_band`: four bins below
    /// `f_min_hz` as long as the compared part of the run holds four segments).
    pub segment: Option<usize>,
    /// Start of the comparison (s): the first `settle_s` of the run, where the controller
    /// ramps from its safe demand to the model's (bumpless only when the safe demand is
    /// the static one) and the rig settles, are left out of the figures.
    pub settle_s: f64,
}

impl Default for CompareSection {
    fn default() -> Self {
        Self {
            f_min_hz: 1.0,
            f_max_hz: 30.0,
            segment: None,
            settle_s: 0.5,
        }
    }
}

/// `[controller] limits`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LimitsSection {
    /// Lowest demand (N).
    pub min: f32,
    /// Highest demand (N).
    pub max: f32,
    /// Largest demand rate in normal running (N/s).
    pub rate_per_s: f32,
    /// Demand in the safe state (N).
    pub safe_demand: f32,
    /// Ramp rate to the safe demand (N/s).
    pub safe_ramp_rate_per_s: f32,
}

impl LimitsSection {
    /// The controller's parameter set for `model`, with these limits and safe state and
    /// the command filter `filter` on every channel.
    pub fn params<P, const CH: usize>(
        &self,
        model: P,
        filter: CascadeCoefficients,
    ) -> ControllerParams<P, CH> {
        ControllerParams {
            model,
            filter: [filter; CH],
            limits: [DemandLimits {
                min: self.min,
                max: self.max,
                rate: self.rate_per_s,
            }; CH],
            safe_demand: [self.safe_demand; CH],
            safe_ramp_rate: [self.safe_ramp_rate_per_s; CH],
        }
    }
}

/// A configuration turned into model-core parameters, validated by model-core itself.
#[derive(Clone, Debug)]
pub enum Validated {
    /// Four tyre channels.
    Tyre(Box<PreparedParams<model_core::TyreModel<4>, 4>>),
    /// Two aero channels, with the run's speed (m/s) over time.
    Aero(Box<PreparedParams<model_core::AeroModel, 2>>, SpeedProfile),
    /// A substructure on 1 to [`MAX_SUBSTRUCTURE_CHANNELS`] channels.
    Substructure(PreparedSubstructure),
}

impl Config {
    /// The board's aero model of `[numerical.aero]`.
    pub fn aero_params(&self) -> Option<AeroParams> {
        self.aero.as_ref().map(|a| AeroParams {
            stiffness: a.stiffness,
            nominal_force: a.nominal_force,
            reference_speed: a.reference_speed_m_per_s,
            front_axle: a.front_axle_m,
            rear_axle: a.rear_axle_m,
            ..AeroParams::PAPER
        })
    }

    /// The four-poster's half car at rest at `start_speed_m_per_s` (m/s): its actuators
    /// hold the board's static down force there, its preloads carry it with the weight.
    ///
    /// # Errors
    /// No half car or aero model, or static loads the structure cannot carry.
    pub fn half_car_specimen(
        &self,
        start_speed_m_per_s: f64,
    ) -> Result<mil_rig::specimen::Specimen> {
        let car = self
            .rig
            .half_car
            .as_ref()
            .context("the aero run needs the half car ([physical] structure)")?;
        let params = self
            .aero_params()
            .context("the aero run needs [numerical.aero]")?;
        let forces = mil_rig::rigs::aero_static_demand(&params, start_speed_m_per_s);
        let mut model = car.model.clone();
        for (name, force) in car.actuators.iter().zip(forces) {
            model = model.with_static_n(name, force).map_err(|e| {
                anyhow::anyhow!(
                    "physical.structure: the half car under the static down force {forces:?} N \
                     at {start_speed_m_per_s} m/s: {e}"
                )
            })?;
        }
        mil_rig::specimen::Specimen::from_structure(&model, &car.axles)
            .map_err(|e| anyhow::anyhow!("physical.structure: {e}"))
    }

    /// Number of actuator channels of the configured model.
    pub fn channels(&self) -> usize {
        match self.model.kind {
            ModelKind::Tyre => 4,
            ModelKind::Aero => 2,
            ModelKind::Substructure => self.substructure.as_ref().map_or(0, |s| s.channels.len()),
        }
    }

    /// The time of the run's last sample (s).
    pub fn end_s(&self) -> f64 {
        self.samples().saturating_sub(1) as f64 / self.run.sample_rate_hz
    }

    /// The aero run's speed: `speed_m_per_s` (constant) or `speed`, validated (a
    /// recorded profile is read here).
    ///
    /// # Errors
    /// Neither or both given, or an invalid speed.
    pub fn speed_profile(&self) -> Result<SpeedProfile> {
        let constant = self.aero.as_ref().and_then(|a| a.speed_m_per_s);
        match (constant, &self.speed) {
            (Some(v), None) => SpeedInput::Constant {
                speed_m_per_s: f64::from(v),
            }
            .profile(&self.base, self.end_s())
            .context("excitation.speed_m_per_s"),
            (None, Some(speed)) => speed.profile(&self.base, self.end_s()),
            (Some(_), Some(_)) => bail!(
                "the speed is given twice: use either excitation.speed_m_per_s (constant) or \
                 excitation.speed (a profile)"
            ),
            (None, None) => bail!(
                "the aero model needs a speed: excitation.speed_m_per_s (constant) or excitation.speed"
            ),
        }
    }

    /// Number of samples of the run.
    pub fn samples(&self) -> usize {
        (self.run.duration_s * self.run.sample_rate_hz).round() as usize
    }

    /// The command filter of `[controller]`, read and validated (identity when none); its
    /// sample rate must be the run's.
    pub fn command_filter(&self) -> Result<CascadeCoefficients> {
        let Some(file) = &self.controller.filter else {
            return Ok(CascadeCoefficients::IDENTITY);
        };
        let path = self.base.join(file);
        let (f, cascade) = mil_analysis::filter_file::FilterFile::read(&path)
            .with_context(|| format!("controller.filter {}", path.display()))?;
        let fs = self.run.sample_rate_hz;
        if (f.sample_rate_hz - fs).abs() > 1e-9 * fs {
            bail!(
                "controller.filter {} is designed for {} Hz, the run is at {fs} Hz",
                path.display(),
                f.sample_rate_hz
            );
        }
        Ok(cascade)
    }

    /// [`Config::validate`], and for a substructure the physical specimen as `mil sim`
    /// builds it: read, valid, at rest with zero actuator force.
    pub fn validate_sim(&self) -> Result<Validated> {
        let validated = self.validate()?;
        if let (ModelKind::Tyre, Some(tyre)) = (self.model.kind, &self.tyre) {
            let car = self
                .rig
                .quarter_car
                .as_ref()
                .context("the tyre run needs the quarter car ([physical] structure)")?;
            let load = f64::from(tyre.static_load_n);
            car.validate()
                .and_then(|()| {
                    car.check_near_rest(&[load], mil_rig::specimen::STATIC_DEMAND_TOLERANCE)
                })
                .map_err(|e| {
                    anyhow::anyhow!(
                        "numerical.tyre.static_load_n = {load} N: the rig's quarter car: {e}"
                    )
                })?;
        }
        if let Validated::Aero(_, speed) = &validated {
            // At rest by construction (its actuators hold the board's static demand).
            self.half_car_specimen(speed.at(0.0))?
                .validate()
                .map_err(|e| anyhow::anyhow!("the rig's half car: {e}"))?;
        }
        if self.model.kind == ModelKind::Substructure {
            let channels = self.channels();
            let (specimen, _) = self.physical_specimen(channels)?;
            specimen
                .validate()
                .and_then(|()| specimen.check_at_rest(&vec![0.0; channels]))
                .map_err(|e| anyhow::anyhow!("the rig's physical specimen: {e}"))?;
        }
        Ok(validated)
    }

    /// Validates everything and builds the controller's parameter set.
    pub fn validate(&self) -> Result<Validated> {
        let fs = self.run.sample_rate_hz;
        if !(fs.is_finite() && (100.0..=20_000.0).contains(&fs)) {
            bail!("controller.sample_rate_hz must be in [100, 20000] Hz, got {fs}");
        }
        let d = self.run.duration_s;
        if !(d.is_finite() && d > 0.0 && d <= 3600.0) {
            bail!("excitation.duration_s must be in (0, 3600] s, got {d}");
        }
        self.input.validate(fs)?;
        let dt = (1.0 / fs) as f32;
        let filter = self.command_filter()?;
        let l = &self.limits;
        let param_error = |e: model_core::ParamError| {
            // The set-up's key, not model-core's field name; the code is the one the board's
            // status and XCP replies carry.
            anyhow::anyhow!(
                "{}: {} (the board would refuse it with error kind {})",
                set_up_key(e.field()),
                e.reason(),
                e.kind_code()
            )
        };
        match self.model.kind {
            ModelKind::Tyre => {
                let t = self
                    .tyre
                    .as_ref()
                    .context("the tyre run needs [numerical.tyre]")?;
                let tyre = TyreParams {
                    stiffness: t.stiffness_n_per_m,
                    damping: t.damping_n_s_per_m,
                    static_load: t.static_load_n,
                    lift_off: u32::from(t.lift_off),
                    velocity_cutoff_hz: t.velocity_cutoff_hz,
                };
                if self.speed.is_some() {
                    bail!("excitation.speed is for the aero model");
                }
                // The static deflection tells a stiffness in N/mm (1000x soft): the structure
                // file's bound on a static compression.
                let deflection = f64::from(t.static_load_n) / f64::from(t.stiffness_n_per_m);
                if t.stiffness_n_per_m > 0.0
                    && deflection > mil_structure::plausible::MAX_STATIC_COMPRESSION_M
                {
                    bail!(
                        "numerical.tyre.stiffness_n_per_m = {}: under a static load of {} N the tyre \
                         would deflect {deflection:.2} m; a stiffness in N/mm ({} N/mm = {:e} \
                         N/m)?",
                        t.stiffness_n_per_m,
                        t.static_load_n,
                        t.stiffness_n_per_m,
                        f64::from(t.stiffness_n_per_m) * 1e3
                    );
                }
                PreparedParams::new(&l.params(TyreModelParams { tyre: [tyre; 4] }, filter), dt)
                    .map(|p| Validated::Tyre(Box::new(p)))
                    .map_err(param_error)
            }
            ModelKind::Aero => {
                let aero = self
                    .aero_params()
                    .context("the aero run needs [numerical.aero]")?;
                let speed = self.speed_profile()?;
                PreparedParams::new(&l.params(aero, filter), dt)
                    .map(|p| Validated::Aero(Box::new(p), speed))
                    .map_err(param_error)
            }
            ModelKind::Substructure => {
                let s = self
                    .substructure
                    .as_ref()
                    .context("the substructure run needs [numerical] structure")?;
                if self.speed.is_some() {
                    bail!("excitation.speed is for the aero model");
                }
                s.check_elements(dt)?;
                s.check_elements(dt)?;
                let prepared = match s.channels.len() {
                    1 => PreparedSubstructure::One(Box::new(
                        PreparedParams::new(&l.params(s.params::<1>()?, filter), dt)
                            .map_err(param_error)?,
                    )),
                    2 => PreparedSubstructure::Two(Box::new(
                        PreparedParams::new(&l.params(s.params::<2>()?, filter), dt)
                            .map_err(param_error)?,
                    )),
                    3 => PreparedSubstructure::Three(Box::new(
                        PreparedParams::new(&l.params(s.params::<3>()?, filter), dt)
                            .map_err(param_error)?,
                    )),
                    4 => PreparedSubstructure::Four(Box::new(
                        PreparedParams::new(&l.params(s.params::<4>()?, filter), dt)
                            .map_err(param_error)?,
                    )),
                    n => bail!(
                        "interface.channels: {n} given, 1 to {MAX_SUBSTRUCTURE_CHANNELS} \
                         supported"
                    ),
                };
                Ok(Validated::Substructure(prepared))
            }
        }
    }
}

/// The set-up key that carries a model-core parameter.
fn set_up_key(field: model_core::params::Field) -> &'static str {
    use model_core::params::Field as F;
    match field {
        F::TyreStiffness => "numerical.tyre.stiffness_n_per_m",
        F::TyreDamping => "numerical.tyre.damping_n_s_per_m",
        F::TyreStaticLoad => "numerical.tyre.static_load_n",
        F::TyreLiftOff => "numerical.tyre.lift_off",
        F::VelocityCutoff => "the velocity_cutoff_hz of [numerical]",
        F::AeroStiffness => "numerical.aero.stiffness",
        F::AeroNominalForce => "numerical.aero.nominal_force",
        F::AeroReferenceSpeed => "numerical.aero.reference_speed_m_per_s",
        F::AeroAxleDistance => "numerical.aero front_axle_m / rear_axle_m",
        F::SubstructureDof
        | F::SubstructureMass
        | F::SubstructureDamping
        | F::SubstructureStiffness
        | F::SubstructureGround => "numerical.structure",
        F::SubstructureElement => "numerical.structure (its elements with effects)",
        F::SubstructureInterface => "interface.channels",
        F::CommandFilter => "controller.filter",
        F::DemandAmplitude => "controller.limits min / max",
        F::DemandRate => "controller.limits.rate_per_s",
        F::SafeDemand => "controller.limits.safe_demand",
        F::SafeRampRate => "controller.limits.safe_ramp_rate_per_s",
        F::SamplePeriod => "controller.sample_rate_hz",
        _ => "a parameter of the set-up",
    }
}

impl Config {
    /// The physical specimen of a substructure run, from `[physical] structure`, and the
    /// run's road (channel) each of its road inputs follows (inputs `"fixed"` removed).
    ///
    /// # Errors
    /// None given, an unreadable or invalid structure file, an unknown attachment, an
    /// unmapped road input.
    pub fn physical_specimen(
        &self,
        channels: usize,
    ) -> Result<(mil_rig::specimen::Specimen, Vec<usize>)> {
        let on_rig = self.rig.structure.as_ref().context(
            "a substructure run needs the physical structure on the rig ([physical] structure \
             and the DOF or point each actuator drives)",
        )?;
        let path = self.base.join(&on_rig.file);
        let model = mil_structure::Model::read(&path)
            .map_err(|e| anyhow::anyhow!("physical.structure: {e}"))?;
        let specimen = mil_rig::specimen::Specimen::from_structure(&model, &on_rig.attach)
            .map_err(|e| anyhow::anyhow!("physical.structure ({}): {e}", path.display()))?;
        if let Some(name) = on_rig.roads.keys().find(|n| !specimen.inputs.contains(n)) {
            bail!(
                "physical.roads: {name:?} is no displacement input of {} (inputs: {:?})",
                path.display(),
                specimen.inputs
            );
        }
        // Each input's road; inputs held still (the rig's bed) leave the specimen, their
        // elements ending at zero.
        let mut specimen = specimen;
        let mut roads = Vec::new();
        for j in (0..specimen.inputs.len()).rev() {
            let input = &specimen.inputs[j];
            let road = on_rig.roads.get(input).with_context(|| {
                format!(
                    "physical.roads: say which run road the structure's input {input:?} \
                     follows, e.g. {input} = \"road_0\", or \"fixed\" (the rig's bed)"
                )
            })?;
            match road_channel(road, channels, "physical.roads", input)? {
                Some(c) => roads.push(c),
                None => {
                    specimen.inputs.remove(j);
                    for e in &mut specimen.elements {
                        if j < e.input_coefficients.len() {
                            e.input_coefficients.remove(j);
                        }
                    }
                }
            }
        }
        roads.reverse();
        Ok((specimen, roads))
    }
}

impl SubstructureSection {
    /// Index of the DOF named `name`.
    fn dof(&self, name: &str, what: &str) -> Result<usize> {
        self.dofs
            .iter()
            .position(|d| d == name)
            .with_context(|| format!("{what}: no DOF {name:?} (DOFs: {:?})", self.dofs))
    }

    /// model-core's parameters for `CH` channels (`CH` must be the number of channels);
    /// dimensions and names are checked here, values by model-core.
    ///
    /// # Errors
    /// Sizes, unknown or repeated DOF names, a channel count other than `CH`.
    pub fn params<const CH: usize>(&self) -> Result<SubstructureParams<CH>> {
        let n = self.dofs.len();
        if !(1..=MAX_DOF).contains(&n) {
            bail!("numerical.structure: {n} DOFs, the board runs 1 to {MAX_DOF}");
        }
        for (i, d) in self.dofs.iter().enumerate() {
            if self.dofs[..i].contains(d) {
                bail!("numerical.structure: DOF {d:?} named twice");
            }
        }
        if self.channels.len() != CH {
            bail!(
                "interface.channels: {} given for {CH} channel(s)",
                self.channels.len()
            );
        }
        let mut p = SubstructureParams::<CH>::zeroed(n as u32, Causality::Impedance);
        for (name, from, to) in [
            ("mass", &self.mass, &mut p.mass),
            ("damping", &self.damping, &mut p.damping),
            ("stiffness", &self.stiffness, &mut p.stiffness),
        ] {
            if from.len() != n || from.iter().any(|r| r.len() != n) {
                bail!("numerical.structure: {name} must be {n} x {n} (one row per DOF)");
            }
            for (row, values) in to.iter_mut().zip(from) {
                row[..n].copy_from_slice(values);
            }
        }
        p.velocity_cutoff_hz = self.velocity_cutoff_hz;
        for (c, ch) in self.channels.iter().enumerate() {
            let what = format!("interface.channels[{c}]");
            p.interface[c] = InterfaceParams {
                dof: self.dof(&ch.dof, &what)? as u32,
                stiffness: ch.interface_stiffness_n_per_m,
                damping: ch.interface_damping_n_s_per_m,
            };
            for r in &ch.road {
                let j = self.dof(&r.dof, &format!("{what}.road"))?;
                p.ground_stiffness[j][c] += r.stiffness_n_per_m;
                p.ground_damping[j][c] += r.damping_n_s_per_m;
            }
        }
        if self.elements.len() > MAX_ELEMENTS {
            bail!(
                "numerical.structure: {} elements with effects; the board runs up to                  {MAX_ELEMENTS} (the others must be linear)",
                self.elements.len()
            );
        }
        p.element_count = self.elements.len() as u32;
        for (slot, e) in p.elements.iter_mut().zip(&self.elements) {
            if e.dof_coefficients.len() != n || e.road_coefficients.len() != CH {
                bail!(
                    "numerical.structure: element {:?}: coefficient sizes",
                    e.name
                );
            }
            slot.dof_coefficients[..n].copy_from_slice(&e.dof_coefficients);
            slot.road_coefficients.copy_from_slice(&e.road_coefficients);
            slot.law = e.law;
        }
        Ok(p)
    }
}

impl SubstructureSection {
    /// Names the first element whose explicit part model-core refuses as too stiff for the
    /// step `dt` (s) on its mass (each element's check is its own: it is tried alone).
    ///
    /// # Errors
    /// That element, with what to change.
    fn check_elements(&self, dt: f32) -> Result<()> {
        let Ok(full) = self.params::<1>().or_else(|_| {
            // The check does not depend on the channels: any one serves.
            let mut one = self.clone();
            one.channels.truncate(1);
            for e in &mut one.elements {
                e.road_coefficients.truncate(1);
            }
            one.params::<1>()
        }) else {
            return Ok(()); // sizes are reported by `params` itself
        };
        for (i, e) in self.elements.iter().enumerate() {
            let mut alone = full;
            alone.element_count = 1;
            alone.elements[0] = full.elements[i];
            if let Err(model_core::ParamError::Unstable(_)) =
                <model_core::SubstructureModel<1> as model_core::Model<1>>::prepare(&alone, dt)
            {
                bail!(
                    "numerical.structure: element {:?}: its stops, dry-friction smoothing or \
                     lift-off are too stiff for the control rate on the mass it moves (k T²/m \
                     or c T/m above 1, see model-core's substructure docs): a softer stop, a \
                     larger smoothing velocity or a higher sample rate",
                    e.name
                );
            }
        }
        Ok(())
    }
}

/// The channel of a road name (`"road_c"`), or `None` for `"fixed"`.
pub(crate) fn road_channel(
    road: &str,
    channels: usize,
    what: &str,
    input: &str,
) -> Result<Option<usize>> {
    if road == "fixed" {
        return Ok(None);
    }
    road.strip_prefix("road_")
        .and_then(|c| c.parse::<usize>().ok())
        .filter(|c| *c < channels)
        .map(Some)
        .with_context(|| {
            format!(
                "{what}: {input} = {road:?}: name the run's road it follows, road_0 to road_{}, \
                 or \"fixed\"",
                channels.saturating_sub(1)
            )
        })
}

#[cfg(test)]
mod tests {
    use crate::config::Validated;
    use crate::setup::{SetUp, DEFAULT_SETUP};
    use std::path::Path;

    /// Two masses on two channels, each with a road element; the second element's stop is
    /// too stiff for 2 kHz on its 10 kg (k_b T²/m = 5e7 · 2.5e-7 / 10 = 1.25): named,
    /// whatever the channel count; softer, accepted.
    #[test]
    fn a_too_stiff_element_is_named_on_any_channel_count() {
        use super::{BoardElement, SubstructureChannel, SubstructureSection};
        let element = |name: &str, dof: usize, bump_stiffness: f32| BoardElement {
            name: name.into(),
            dof_coefficients: (0..2).map(|j| if j == dof { -1.0 } else { 0.0 }).collect(),
            road_coefficients: (0..2).map(|c| if c == dof { 1.0 } else { 0.0 }).collect(),
            law: model_core::ElementLaw {
                bump_gap: 0.001,
                bump_stiffness,
                ..model_core::ElementLaw::linear(4.0e4, 200.0)
            },
        };
        let channel = |dof: &str| SubstructureChannel {
            dof: dof.into(),
            interface_stiffness_n_per_m: 1.0e4,
            interface_damping_n_s_per_m: 5.0,
            road: Vec::new(),
        };
        let mut s = SubstructureSection {
            dofs: vec!["a".into(), "b".into()],
            mass: vec![vec![10.0, 0.0], vec![0.0, 10.0]],
            damping: vec![vec![0.0; 2]; 2],
            stiffness: vec![vec![0.0; 2]; 2],
            velocity_cutoff_hz: 0.0,
            channels: vec![channel("a"), channel("b")],
            elements: vec![element("front", 0, 1.0e5), element("rear", 1, 5.0e7)],
        };
        let e = s.check_elements(5.0e-4).unwrap_err().to_string();
        assert!(e.contains("\"rear\"") && e.contains("too stiff"), "{e}");
        s.elements[1].law.bump_stiffness = 3.0e7;
        assert!(s.check_elements(5.0e-4).is_ok());
        assert!(s.params::<2>().is_ok());
    }

    fn run(text: &str) -> anyhow::Result<Validated> {
        SetUp::from_toml(
            text,
            &Path::new(env!("CARGO_MANIFEST_DIR")).join("examples"),
        )?
        .run()?
        .validate()
    }

    #[test]
    fn default_set_up_is_valid() {
        assert!(matches!(run(DEFAULT_SETUP).unwrap(), Validated::Tyre(_)));
    }

    #[test]
    fn typos_and_bad_values_are_rejected() {
        let typo = DEFAULT_SETUP.replace("stiffness_n_per_m = 2.5e5", "stifness_n_per_m = 2.5e5");
        assert_ne!(typo, DEFAULT_SETUP);
        assert!(SetUp::from_toml(
            &typo,
            &Path::new(env!("CARGO_MANIFEST_DIR")).join("examples")
        )
        .is_err());
        let negative =
            DEFAULT_SETUP.replace("damping_n_s_per_m = 500.0", "damping_n_s_per_m = -1.0");
        assert_ne!(negative, DEFAULT_SETUP);
        let err = run(&negative).unwrap_err().to_string();
        // Named by the set-up's key, not model-core's field name.
        assert!(err.contains("numerical.tyre.damping_n_s_per_m"), "{err}");
        assert!(!err.contains("TyreDamping"), "{err}");
        let fast = DEFAULT_SETUP.replace("max_hz = 40.0", "max_hz = 3000.0");
        assert_ne!(fast, DEFAULT_SETUP);
        assert!(run(&fast).is_err());
    }
}
