//! The MiL set-up file (TOML): one description of a model-in-the-loop experiment, read by
//! every command. `mil analyze` and `mil design-filter` take its linear analysis
//! ([`SetUp::analysis`]), `mil sim` and `mil run` its run ([`SetUp::run`]: the board's
//! parameter set, the simulated rig, the excitation), and `mil check` runs both. Relative
//! file names inside (structure files, the command filter, actuator tables, recorded roads)
//! are relative to the set-up's folder. Unknown keys are errors; units are SI and named in
//! the keys. The reference is `docs/setup.md`.
//!
//! ```toml
//! name = "tyre"
//! [controller]                   # the board
//! sample_rate_hz = 2000.0
//! limits = { min = -1000.0, max = 12000.0, rate_per_s = 2.0e6, safe_demand = 1667.7, safe_ramp_rate_per_s = 5.0e4 }
//! [numerical.tyre]               # the board's model: tyre, aero, or a structure file
//! stiffness_n_per_m = 2.5e5
//! damping_n_s_per_m = 500.0
//! [physical.quarter_car]         # what the rig holds: quarter car, half car, or a structure
//! [excitation]
//! duration_s = 20.0
//! road = { kind = "pink", rms_m = 0.0005, max_hz = 40.0, seed = 1 }
//! ```
//!
//! The pairs: the numerical tyre on the physical quarter car (four wheels, a hub actuator
//! each), the numerical aero model on the physical half car (front and rear down-force
//! actuators), or a numerical structure on a physical structure joined by
//! `[[interface.channels]]` (one actuator each). Every configuration of the paper can be
//! analysed; the board and the simulated rig run configuration 4 (force control, `B_i`
//! numerical), which is what model-core's models compute.

use crate::config::{
    AeroSection, CompareSection, Config, ControllerSection, LimitsSection, LinksSection, ModelKind,
    ModelSection, RigSection, RoadCoupling, RunSection, SensorsSection, StructureOnRig,
    SubstructureChannel, SubstructureSection, TyreSection,
};
use crate::signals::{RoadInput, SpeedInput};
use anyhow::{bail, Context, Result};
use mil_analysis::setup::{
    ActuatorSection, AnalysisSection, InterfaceSection, ModelSection as AnalysisModel,
    NoiseSection, PartSection, ResponseEntry, ResponseSection, Setup, SetupFile,
};
use mil_params::{AeroExample, TyreExample, TyreVelocity};
use mil_params::{PositionServoActuator, ServoHydraulicActuator};
use mil_rig::actuator::ActuatorEffects;
use mil_structure::model::InputKind;
use mil_structure::{EffectKind, Element, Parameters};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The paper's tyre example, built into the tool: `mil sim` and `mil run` without a file
/// use it.
pub const DEFAULT_SETUP: &str = include_str!("../examples/tyre.toml");

/// The whole set-up file.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SetUp {
    /// Name for reports.
    #[serde(default)]
    pub name: String,
    /// The paper's configuration (1–4) the set-up is meant to be; checked if given.
    pub configuration: Option<u8>,
    /// The board: rate, command filter, demand limits and safe state.
    pub controller: ControllerSetUp,
    /// The numerical part: the model the board runs (one of its tables is required).
    #[serde(default)]
    pub numerical: Numerical,
    /// The physical part: what stands on the rig (one of its tables is required).
    #[serde(default)]
    pub physical: Physical,
    /// Where the actuators join a numerical and a physical structure (structures only).
    pub interface: Option<InterfaceSetUp>,
    /// The actuators.
    #[serde(default)]
    pub actuator: ActuatorSetUp,
    /// The run's inputs and length.
    pub excitation: Excitation,
    /// The rig's transducers (default ideal).
    #[serde(default)]
    pub sensors: SensorsSection,
    /// The CAN link between rig and board (default ideal).
    #[serde(default)]
    pub links: LinksSection,
    /// The simulated rig's integration.
    #[serde(default)]
    pub simulation: Simulation,
    /// What `mil analyze` reports.
    #[serde(default)]
    pub analysis: AnalysisSection,
    /// How `mil sim` compares the run with the emulated system and the analysis.
    #[serde(default)]
    pub compare: CompareSection,
    /// Folder of the file (relative names); not read from TOML.
    #[serde(skip)]
    pub base: PathBuf,
}

/// `[controller]`: the board.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ControllerSetUp {
    /// Control loop rate (Hz), 100 to 20 000.
    pub sample_rate_hz: f64,
    /// Command filter (`mil design-filter`'s JSON) for the same rate; none: no filter.
    pub filter: Option<PathBuf>,
    /// Delay from measurement to demand in the analysis (s); default 1.5 samples.
    pub loop_delay_s: Option<f64>,
    /// Demand limits and the safe state (N under force control), the same on every channel.
    pub limits: LimitsSection,
}

/// `[numerical]`: one of `tyre`, `aero` or `structure`.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Numerical {
    /// model-core's tyre, one per wheel.
    pub tyre: Option<NumericalTyre>,
    /// model-core's aerodynamic down-force model.
    pub aero: Option<NumericalAero>,
    /// A structure file (linear: the board runs model-core's substructure model).
    pub structure: Option<PathBuf>,
    /// The run's road each displacement input of the structure follows, by input name:
    /// `"road_0"`… (channel `c`'s road) or `"fixed"` (held at zero).
    #[serde(default)]
    pub roads: BTreeMap<String, String>,
    /// Cut-off (Hz) of the board's velocity estimates of a structure (0: plain backward
    /// difference; the analysis takes `C_i s`).
    pub velocity_cutoff_hz: Option<f32>,
}

/// `[numerical.tyre]`: model-core's tyre (`TyreParams`), the same on every wheel.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NumericalTyre {
    /// Radial stiffness `k_t` (N/m).
    pub stiffness_n_per_m: f32,
    /// Radial damping `c_t` (N s/m).
    pub damping_n_s_per_m: f32,
    /// Static wheel load (N); default the quarter car's weight `(m_s + m_u) g`.
    pub static_load_n: Option<f32>,
    /// Whether the tyre only pushes (wheel lift-off); default true.
    #[serde(default = "yes")]
    pub lift_off: bool,
    /// Cut-off (Hz) of the board's deflection-velocity low-pass (0: plain backward
    /// difference); default model-core's 500 Hz.
    #[serde(default = "tyre_cutoff")]
    pub velocity_cutoff_hz: f32,
    /// How the analysis models the velocity: `"board"` (the estimator the board runs,
    /// default) or `"continuous"` (`c_t s`).
    #[serde(default)]
    pub velocity_estimate: TyreVelocity,
}

fn yes() -> bool {
    true
}
fn tyre_cutoff() -> f32 {
    model_core::TyreParams::PAPER.velocity_cutoff_hz
}

/// `[numerical.aero]`: model-core's aerodynamic model (`AeroParams`, linear form); its axle
/// distances are the half car's.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NumericalAero {
    /// `K_i`, rows `[F_z; M_θ]`, columns `[z; θ]` (N/m, N/rad; N m/m, N m/rad), at the
    /// reference speed.
    pub stiffness: [[f32; 2]; 2],
    /// `F_n = [F_z (N), M_θ (N m)]` at zero displacement and the reference speed.
    pub nominal_force: [f32; 2],
    /// Reference speed of `stiffness` and `nominal_force` (m/s).
    pub reference_speed_m_per_s: f32,
}

/// `[physical]`: one of `quarter_car`, `half_car` or `structure`.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Physical {
    /// The tyre example's quarter car on a hub actuator (four wheels).
    pub quarter_car: Option<QuarterCar>,
    /// The aero example's half car on a four-poster.
    pub half_car: Option<HalfCar>,
    /// A structure file (`mil diagnose`'s schema: its `updated.toml` fits here). On the
    /// rig its springs carry its weight.
    pub structure: Option<PathBuf>,
    /// The run's road each displacement input of the structure follows: `"road_0"`… or
    /// `"fixed"` (the rig's bed).
    #[serde(default)]
    pub roads: BTreeMap<String, String>,
}

/// `[physical.quarter_car]`: paper values by default.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct QuarterCar {
    /// Sprung mass `m_s` (kg).
    pub sprung_mass_kg: f64,
    /// Unsprung mass `m_u` (kg).
    pub unsprung_mass_kg: f64,
    /// The suspension between them (its preload follows from the weight); the analysis
    /// takes its linear part.
    pub suspension: Element,
    /// The real tyre's effects (the emulated vehicle's); default lift-off as the numerical
    /// tyre has it. Effects here and not in the board's tyre are hidden effects.
    pub tyre_effects: Option<BTreeMap<EffectKind, Parameters>>,
}

impl Default for QuarterCar {
    fn default() -> Self {
        let car = TyreExample::default();
        Self {
            sprung_mass_kg: car.sprung_mass_kg,
            unsprung_mass_kg: car.unsprung_mass_kg,
            suspension: Element::linear(car.suspension_stiffness, car.suspension_damping),
            tyre_effects: None,
        }
    }
}

/// `[physical.half_car]`: paper values by default.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct HalfCar {
    /// Body mass (kg).
    pub body_mass_kg: f64,
    /// Pitch inertia (kg m²).
    pub pitch_inertia_kg_m2: f64,
    /// Centroid to front axle (m).
    pub front_axle_m: f64,
    /// Centroid to rear axle (m).
    pub rear_axle_m: f64,
    /// Front suspension (wheels and tyres lumped), post to axle.
    pub front_suspension: Element,
    /// Rear suspension.
    pub rear_suspension: Element,
}

impl Default for HalfCar {
    fn default() -> Self {
        let car = AeroExample::default();
        Self {
            body_mass_kg: car.body_mass_kg,
            pitch_inertia_kg_m2: car.pitch_inertia_kg_m2,
            front_axle_m: car.front_axle_m,
            rear_axle_m: car.rear_axle_m,
            front_suspension: Element::linear(car.front_stiffness, car.front_damping),
            rear_suspension: Element::linear(car.rear_stiffness, car.rear_damping),
        }
    }
}

/// `[interface]`: the actuators between a numerical and a physical structure.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InterfaceSetUp {
    /// Where the interface spring-damper `B_i` is: `"numerical"` (computed by the board,
    /// default) or `"physical"` (a real spring and damper on the rig).
    #[serde(default = "numerical")]
    pub location: String,
    /// One per actuator, in channel order.
    pub channels: Vec<InterfaceChannel>,
}

fn numerical() -> String {
    "numerical".into()
}

/// `[[interface.channels]]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InterfaceChannel {
    /// The numerical DOF `B_i` joins (none: a numerical part without DOFs).
    pub numerical: Option<String>,
    /// The physical DOF or point the actuator drives, along its positive direction.
    pub physical: String,
    /// `k_i` (N/m).
    pub stiffness_n_per_m: f64,
    /// `c_i` (N s/m).
    #[serde(default)]
    pub damping_n_s_per_m: f64,
}

/// `[actuator]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ActuatorSetUp {
    /// `"force"` (default) or `"position"`.
    #[serde(default = "force")]
    pub control: String,
    /// Tracking response for the analysis: `"reference"` (default: the parameters below),
    /// a transfer function `{ numerator, denominator, delay_s }` or `{ table = "x.csv" }`.
    #[serde(default = "reference")]
    pub tracking: ResponseEntry,
    /// Disturbance response (the actuator's compliance), the same forms or `"none"`.
    #[serde(default = "reference")]
    pub disturbance: ResponseEntry,
    /// The servo-hydraulic force actuator: the analysis' reference under force control and
    /// the simulated rig's actuator; default `ServoHydraulicActuator::REFERENCE`.
    pub reference: Option<ServoHydraulicActuator>,
    /// The position servo of the analysis under position control; default
    /// `PositionServoActuator::REFERENCE`.
    pub position_servo: Option<PositionServoActuator>,
    /// The simulated actuator's nonlinear effects (all off by default).
    #[serde(default)]
    pub effects: ActuatorEffects,
}

fn force() -> String {
    "force".into()
}
fn reference() -> ResponseEntry {
    ResponseEntry::Named("reference".into())
}

impl Default for ActuatorSetUp {
    fn default() -> Self {
        Self {
            control: force(),
            tracking: reference(),
            disturbance: reference(),
            reference: None,
            position_servo: None,
            effects: ActuatorEffects::default(),
        }
    }
}

/// `[excitation]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Excitation {
    /// Length of the run (s).
    pub duration_s: f64,
    /// The road under every channel (`kind` = `sweep`, `pink`, `bump` or `csv`).
    pub road: RoadInput,
    /// Constant vehicle speed (m/s), aero; or a `speed` profile.
    pub speed_m_per_s: Option<f64>,
    /// Vehicle speed over the run (aero).
    pub speed: Option<SpeedInput>,
}

/// `[simulation]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Simulation {
    /// RK4 step of the rig's plants (s), at most the control period.
    pub internal_step_s: f64,
}

impl Default for Simulation {
    fn default() -> Self {
        Self {
            internal_step_s: mil_rig::DEFAULT_INTERNAL_STEP_S,
        }
    }
}

/// What the two parts are.
enum Pair<'a> {
    Tyre(&'a NumericalTyre, &'a QuarterCar),
    Aero(&'a NumericalAero, &'a HalfCar),
    Structures(&'a Path, &'a Path, &'a InterfaceSetUp),
}

impl SetUp {
    /// Parses TOML text; `base` is the folder relative names refer to.
    ///
    /// # Errors
    /// TOML errors and unknown keys.
    pub fn from_toml(text: &str, base: &Path) -> Result<Self> {
        let mut s: SetUp = toml::from_str(text).context("invalid MiL set-up")?;
        s.base = base.to_path_buf();
        Ok(s)
    }

    /// Reads and parses a set-up file.
    ///
    /// # Errors
    /// I/O, TOML errors and unknown keys.
    pub fn read(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("cannot read {}", path.display()))?;
        let base = path.parent().unwrap_or(Path::new(".")).to_path_buf();
        Self::from_toml(&text, &base).with_context(|| format!("in {}", path.display()))
    }

    fn pair(&self) -> Result<Pair<'_>> {
        let (n, p) = (&self.numerical, &self.physical);
        let numerical = usize::from(n.tyre.is_some())
            + usize::from(n.aero.is_some())
            + usize::from(n.structure.is_some());
        let physical = usize::from(p.quarter_car.is_some())
            + usize::from(p.half_car.is_some())
            + usize::from(p.structure.is_some());
        if numerical != 1 {
            bail!("[numerical]: give one of tyre, aero or structure");
        }
        if physical != 1 {
            bail!("[physical]: give one of quarter_car, half_car or structure");
        }
        let pair = match (n, p) {
            (
                Numerical { tyre: Some(t), .. },
                Physical {
                    quarter_car: Some(q),
                    ..
                },
            ) => Pair::Tyre(t, q),
            (
                Numerical { aero: Some(a), .. },
                Physical {
                    half_car: Some(h), ..
                },
            ) => Pair::Aero(a, h),
            (
                Numerical {
                    structure: Some(ns),
                    ..
                },
                Physical {
                    structure: Some(ps),
                    ..
                },
            ) => Pair::Structures(
                ns,
                ps,
                self.interface.as_ref().context(
                    "a numerical and a physical structure need [interface] (its channels: the \
                     DOFs each actuator joins)",
                )?,
            ),
            _ => bail!(
                "[numerical] and [physical] do not pair: the numerical tyre goes with the \
                 physical quarter_car, aero with half_car, a structure with a structure"
            ),
        };
        if !matches!(pair, Pair::Structures(..)) {
            if self.interface.is_some() {
                bail!("[interface] is for a numerical and a physical structure");
            }
            if !(n.roads.is_empty() && p.roads.is_empty()) {
                bail!("roads are for structures' displacement inputs");
            }
        }
        if !matches!(pair, Pair::Aero(..))
            && (self.excitation.speed.is_some() || self.excitation.speed_m_per_s.is_some())
        {
            bail!("excitation.speed is for the aero model");
        }
        if n.velocity_cutoff_hz.is_some() && n.structure.is_none() {
            bail!("numerical.velocity_cutoff_hz is for a structure (the tyre has its own)");
        }
        Ok(pair)
    }

    /// The linear analysis of the set-up (`mil analyze`, `mil design-filter`).
    ///
    /// # Errors
    /// Anything the analysis refuses, named.
    pub fn analysis(&self) -> Result<Setup> {
        let c = &self.controller;
        let control_force = self.actuator.control == "force";
        let mut model = AnalysisModel {
            example: String::new(),
            tyre: TyreExample::default(),
            aero: AeroExample::default(),
            two_dof: Default::default(),
        };
        let (mut numerical, mut physical, mut interface) = (None, None, None);
        let default_responses: Vec<ResponseSection>;
        match self.pair()? {
            Pair::Tyre(t, q) => {
                model.example = "tyre".into();
                model.tyre = TyreExample {
                    sprung_mass_kg: q.sprung_mass_kg,
                    suspension_stiffness: q.suspension.stiffness_n_per_m,
                    suspension_damping: q.suspension.damping_n_s_per_m,
                    unsprung_mass_kg: q.unsprung_mass_kg,
                    tyre_stiffness: f64::from(t.stiffness_n_per_m),
                    tyre_damping: f64::from(t.damping_n_s_per_m),
                    velocity_cutoff_hz: f64::from(t.velocity_cutoff_hz),
                    velocity_estimate: t.velocity_estimate,
                };
                default_responses = vec![response(
                    "tyre force / road",
                    "road",
                    "interface_force",
                    1e-3,
                    "N/mm",
                )];
            }
            Pair::Aero(a, h) => {
                model.example = "aero".into();
                model.aero = AeroExample {
                    body_mass_kg: h.body_mass_kg,
                    pitch_inertia_kg_m2: h.pitch_inertia_kg_m2,
                    front_stiffness: h.front_suspension.stiffness_n_per_m,
                    front_damping: h.front_suspension.damping_n_s_per_m,
                    rear_stiffness: h.rear_suspension.stiffness_n_per_m,
                    rear_damping: h.rear_suspension.damping_n_s_per_m,
                    front_axle_m: h.front_axle_m,
                    rear_axle_m: h.rear_axle_m,
                    aero_stiffness: a.stiffness.map(|r| r.map(f64::from)),
                };
                default_responses = vec![
                    response(
                        "body vertical / road heave",
                        "road_heave",
                        "physical:z_b",
                        1.0,
                        "m/m",
                    ),
                    response(
                        "body pitch / road pitch",
                        "road_pitch",
                        "physical:theta_b",
                        1.0,
                        "rad/rad",
                    ),
                ];
            }
            Pair::Structures(ns, ps, i) => {
                model.example = "custom".into();
                let part = |file: &Path| PartSection {
                    dofs: vec![],
                    mass: vec![],
                    damping: vec![],
                    stiffness: vec![],
                    structure: Some(file.to_path_buf()),
                };
                numerical = Some(part(ns));
                physical = Some(part(ps));
                let m = i.channels.len();
                let diagonal = |f: &dyn Fn(&InterfaceChannel) -> f64| {
                    (0..m)
                        .map(|r| {
                            (0..m)
                                .map(|k| if r == k { f(&i.channels[r]) } else { 0.0 })
                                .collect()
                        })
                        .collect()
                };
                let numerical_dofs: Vec<String> = i
                    .channels
                    .iter()
                    .filter_map(|c| c.numerical.clone())
                    .collect();
                if !(numerical_dofs.is_empty() || numerical_dofs.len() == m) {
                    bail!("interface.channels: name the numerical DOF on every channel or none");
                }
                interface = Some(InterfaceSection {
                    location: i.location.clone(),
                    numerical_dofs,
                    physical_dofs: i.channels.iter().map(|c| c.physical.clone()).collect(),
                    stiffness: diagonal(&|c| c.stiffness_n_per_m),
                    damping: diagonal(&|c| c.damping_n_s_per_m),
                    velocity_cutoff_hz: None,
                });
                // The interface force per each displacement input (read only when needed).
                default_responses = if self.analysis.responses.is_empty() {
                    structure_inputs(&[ns, ps], &self.base)?
                        .iter()
                        .map(|name| {
                            response(
                                &format!("interface force / {name}"),
                                name,
                                "interface_force",
                                1e-3,
                                "N/mm",
                            )
                        })
                        .collect()
                } else {
                    Vec::new()
                };
            }
        }
        let mut analysis = self.analysis.clone();
        if analysis.responses.is_empty() {
            analysis.responses = default_responses;
        }
        // The analysis' measurement noise is the transducer the numerical model reads: the
        // displacement under force control, the load cell under position control.
        let noise = if control_force {
            &self.sensors.position
        } else {
            &self.sensors.force
        };
        let file = SetupFile {
            name: self.name.clone(),
            configuration: self.configuration,
            model,
            numerical,
            physical,
            interface,
            inputs: vec![],
            actuator: ActuatorSection {
                control: self.actuator.control.clone(),
                tracking: self.actuator.tracking.clone(),
                disturbance: self.actuator.disturbance.clone(),
                reference: self.actuator.reference,
                position_servo: self.actuator.position_servo,
                loop_delay_s: c.loop_delay_s,
            },
            controller: mil_analysis::setup::ControllerSection {
                sample_rate_hz: c.sample_rate_hz,
                filter: c.filter.clone(),
            },
            noise: NoiseSection {
                rms: noise.noise_rms,
            },
            analysis,
        };
        Setup::from_file(&file, &self.base).map_err(|e| anyhow::anyhow!("{e}"))
    }

    /// The run: the board's parameters, the simulated rig, the excitation and what the
    /// run is compared with (`mil sim`, `mil run`), validated as they validate it.
    ///
    /// # Errors
    /// A set-up the board or the rig cannot run (another configuration than 4, effects in a
    /// numerical structure, …) or invalid values, named.
    pub fn run(&self) -> Result<Config> {
        let c = &self.controller;
        if self.actuator.control != "force" {
            bail!(
                "actuator.control = {:?}: the board's models demand forces (configuration 4); \
                 `mil analyze` analyses the other configurations",
                self.actuator.control
            );
        }
        let mut rig = RigSection {
            internal_step_s: self.simulation.internal_step_s,
            actuator: self.actuator.reference,
            actuator_effects: self.actuator.effects,
            ..RigSection::default()
        };
        let (mut tyre, mut aero, mut substructure) = (None, None, None);
        let (kind, analysis_inputs) = match self.pair()? {
            Pair::Tyre(t, q) => {
                let car = TyreExample {
                    sprung_mass_kg: q.sprung_mass_kg,
                    unsprung_mass_kg: q.unsprung_mass_kg,
                    ..TyreExample::default()
                };
                let load = t
                    .static_load_n
                    .unwrap_or(crate::config::wheel_weight_n(&car) as f32);
                tyre = Some(TyreSection {
                    stiffness_n_per_m: t.stiffness_n_per_m,
                    damping_n_s_per_m: t.damping_n_s_per_m,
                    static_load_n: load,
                    lift_off: t.lift_off,
                    velocity_cutoff_hz: t.velocity_cutoff_hz,
                });
                rig.quarter_car = Some(car);
                rig.suspension = Some(q.suspension.clone());
                rig.tyre_effects = q.tyre_effects.clone();
                (ModelKind::Tyre, vec!["road".to_string()])
            }
            Pair::Aero(a, h) => {
                aero = Some(AeroSection {
                    stiffness: a.stiffness,
                    nominal_force: a.nominal_force,
                    reference_speed_m_per_s: a.reference_speed_m_per_s,
                    front_axle_m: h.front_axle_m as f32,
                    rear_axle_m: h.rear_axle_m as f32,
                    speed_m_per_s: self.excitation.speed_m_per_s.map(|v| v as f32),
                });
                rig.half_car = Some(AeroExample {
                    body_mass_kg: h.body_mass_kg,
                    pitch_inertia_kg_m2: h.pitch_inertia_kg_m2,
                    front_axle_m: h.front_axle_m,
                    rear_axle_m: h.rear_axle_m,
                    ..AeroExample::default()
                });
                rig.front_suspension = Some(h.front_suspension.clone());
                rig.rear_suspension = Some(h.rear_suspension.clone());
                (ModelKind::Aero, vec!["road_heave".to_string()])
            }
            Pair::Structures(ns, ps, i) => {
                if i.location != "numerical" {
                    bail!(
                        "interface.location = {:?}: the board computes the interface \
                         spring-damper (\"numerical\", configuration 4); `mil analyze` \
                         analyses the other configurations",
                        i.location
                    );
                }
                let (section, inputs) = self.board_substructure(ns, i)?;
                substructure = Some(section);
                rig.structure = Some(StructureOnRig {
                    file: ps.to_path_buf(),
                    attach: i.channels.iter().map(|c| c.physical.clone()).collect(),
                    roads: self.physical.roads.clone(),
                });
                // The analysis inputs the run's road 0 drives: the numerical structure's
                // and the physical one's.
                let mut names = inputs;
                names.extend(
                    self.physical
                        .roads
                        .iter()
                        .filter(|(_, r)| r.as_str() == "road_0")
                        .map(|(n, _)| n.clone()),
                );
                (ModelKind::Substructure, names)
            }
        };
        let config = Config {
            run: RunSection {
                sample_rate_hz: c.sample_rate_hz,
                duration_s: self.excitation.duration_s,
            },
            model: ModelSection { kind },
            tyre,
            aero,
            speed: self.excitation.speed.clone(),
            substructure,
            limits: c.limits.clone(),
            input: self.excitation.road.clone(),
            controller: ControllerSection {
                filter: c.filter.as_ref().map(|f| f.display().to_string()),
            },
            rig,
            sensors: self.sensors.clone(),
            links: self.links.clone(),
            compare: self.compare.clone(),
            analysis: None,
            analysis_inputs,
            base: self.base.clone(),
        };
        Ok(config)
    }

    /// [`SetUp::run`] with the analysis attached for `mil sim`'s comparison.
    ///
    /// # Errors
    /// As [`SetUp::run`] and [`SetUp::analysis`].
    pub fn sim(&self) -> Result<Config> {
        let mut config = self.run()?;
        config.analysis = Some(Box::new(self.analysis()?));
        Ok(config)
    }

    /// The board's substructure from a numerical structure file: its linearisation, the
    /// springs and dampers to each mapped displacement input as that channel's road
    /// couplings; and the structure's inputs that follow road 0.
    fn board_substructure(
        &self,
        file: &Path,
        interface: &InterfaceSetUp,
    ) -> Result<(SubstructureSection, Vec<String>)> {
        let path = self.base.join(file);
        let model = mil_structure::Model::read(&path)
            .map_err(|e| anyhow::anyhow!("numerical.structure: {e}"))?;
        if let Some(e) = model.elements.iter().find(|e| !e.law.kinds().is_empty()) {
            bail!(
                "numerical.structure {}: element {:?} has effects ({:?}); the board's \
                 substructure model is linear",
                path.display(),
                e.name,
                e.law.kinds()
            );
        }
        let l = model.linearised();
        let n = model.n();
        let channels = interface.channels.len();
        let mut stiffness: Vec<Vec<f64>> = (0..n)
            .map(|i| (0..n).map(|j| l.stiffness[(i, j)]).collect())
            .collect();
        let mut damping: Vec<Vec<f64>> = (0..n)
            .map(|i| (0..n).map(|j| l.damping[(i, j)]).collect())
            .collect();
        let mut roads: Vec<Vec<RoadCoupling>> = vec![Vec::new(); channels];
        let mut road_0 = Vec::new();
        for name in self.numerical.roads.keys() {
            if !model
                .inputs
                .iter()
                .any(|i| &i.name == name && i.kind == InputKind::Displacement)
            {
                bail!(
                    "numerical.roads: {name:?} is no displacement input of {}",
                    path.display()
                );
            }
        }
        for (j, input) in model.inputs.iter().enumerate() {
            if input.kind != InputKind::Displacement {
                continue;
            }
            let road = self.numerical.roads.get(&input.name).with_context(|| {
                format!(
                    "numerical.roads: say which road the structure's input {:?} follows, \
                     e.g. {} = \"road_0\" (or \"fixed\")",
                    input.name, input.name
                )
            })?;
            let Some(c) =
                crate::config::road_channel(road, channels, "numerical.roads", &input.name)?
            else {
                continue;
            };
            if c == 0 {
                road_0.push(input.name.clone());
            }
            for d in 0..n {
                let (k, cw) = (l.input_stiffness[(d, j)], l.input_damping[(d, j)]);
                if k != 0.0 || cw != 0.0 {
                    stiffness[d][d] -= k;
                    damping[d][d] -= cw;
                    roads[c].push(RoadCoupling {
                        dof: model.dofs[d].clone(),
                        stiffness_n_per_m: k as f32,
                        damping_n_s_per_m: cw as f32,
                    });
                }
            }
        }
        let f32s = |m: Vec<Vec<f64>>| -> Vec<Vec<f32>> {
            m.into_iter()
                .map(|r| r.into_iter().map(|v| v as f32).collect())
                .collect()
        };
        let channels = interface
            .channels
            .iter()
            .zip(roads)
            .enumerate()
            .map(|(k, (ch, road))| {
                Ok(SubstructureChannel {
                    dof: ch.numerical.clone().with_context(|| {
                        format!(
                            "interface.channels[{k}].numerical: the board's substructure joins \
                             B_i to a numerical DOF"
                        )
                    })?,
                    interface_stiffness_n_per_m: ch.stiffness_n_per_m as f32,
                    interface_damping_n_s_per_m: ch.damping_n_s_per_m as f32,
                    road,
                })
            })
            .collect::<Result<_>>()?;
        Ok((
            SubstructureSection {
                dofs: model.dofs.clone(),
                mass: f32s(
                    (0..n)
                        .map(|i| (0..n).map(|j| l.mass[(i, j)]).collect())
                        .collect(),
                ),
                damping: f32s(damping),
                stiffness: f32s(stiffness),
                velocity_cutoff_hz: self.numerical.velocity_cutoff_hz.unwrap_or(0.0),
                channels,
            },
            road_0,
        ))
    }
}

/// The displacement inputs of the structure files `parts` (relative to `base`), in order.
fn structure_inputs(parts: &[&Path], base: &Path) -> Result<Vec<String>> {
    let mut names = Vec::new();
    for part in parts {
        let model =
            mil_structure::Model::read(&base.join(part)).map_err(|e| anyhow::anyhow!("{e}"))?;
        for i in &model.inputs {
            if i.kind == InputKind::Displacement && !names.contains(&i.name) {
                names.push(i.name.clone());
            }
        }
    }
    if names.is_empty() {
        bail!("analysis.responses: the structures have no displacement input to respond to");
    }
    Ok(names)
}

/// A response of the analysis.
fn response(name: &str, input: &str, output: &str, scale: f64, unit: &str) -> ResponseSection {
    ResponseSection {
        name: name.into(),
        input: input.into(),
        output: output.into(),
        scale,
        unit: unit.into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn examples() -> PathBuf {
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("examples")
    }

    /// The numerical structure of the 2-DOF example becomes the board's substructure as it
    /// was written by hand before the set-up: no spring or damper between the mass and fixed
    /// ground, `k_n` and `c_n` to channel 0's road.
    #[test]
    fn a_numerical_structure_becomes_the_boards_substructure() {
        let s = SetUp::read(&examples().join("two-dof.toml")).unwrap();
        let c = s.run().unwrap();
        let sub = c.substructure.as_ref().unwrap();
        assert_eq!(sub.dofs, ["x_n"]);
        assert_eq!(sub.mass, [[10.0]]);
        assert_eq!(sub.stiffness, [[0.0]]);
        assert_eq!(sub.damping, [[0.0]]);
        let ch = &sub.channels[0];
        assert_eq!(ch.dof, "x_n");
        assert_eq!(
            (
                ch.interface_stiffness_n_per_m,
                ch.interface_damping_n_s_per_m
            ),
            (1.0e4, 5.0)
        );
        assert_eq!(ch.road.len(), 1);
        assert_eq!(
            (
                ch.road[0].dof.as_str(),
                ch.road[0].stiffness_n_per_m,
                ch.road[0].damping_n_s_per_m
            ),
            ("x_n", 4.0e4, 20.0)
        );
        assert_eq!(c.analysis_inputs, ["z_n"]);
        assert!(c.validate().is_ok());
    }

    /// An input held `"fixed"` keeps its springs in the board's stiffness (they end on
    /// fixed ground); an unmapped input, an unknown road, effects the board cannot run and
    /// mismatched parts are refused, naming the key.
    #[test]
    fn roads_effects_and_pairs_are_checked() {
        let text = std::fs::read_to_string(examples().join("two-dof.toml")).unwrap();
        let base = examples();
        let fixed = text.replace(
            "roads = { z_n = \"road_0\" }",
            "roads = { z_n = \"fixed\" }",
        );
        let c = SetUp::from_toml(&fixed, &base).unwrap().run().unwrap();
        let sub = c.substructure.unwrap();
        assert_eq!((sub.stiffness[0][0], sub.damping[0][0]), (4.0e4, 20.0));
        assert!(sub.channels[0].road.is_empty());
        let err = |t: &str| match SetUp::from_toml(t, &base).and_then(|s| s.run()) {
            Ok(_) => panic!("accepted"),
            Err(e) => format!("{e:#}"),
        };
        let unmapped = text.replace("roads = { z_n = \"road_0\" }", "");
        assert_ne!(unmapped, text);
        assert!(
            err(&unmapped).contains("numerical.roads"),
            "{}",
            err(&unmapped)
        );
        let far = text.replace("z_n = \"road_0\"", "z_n = \"road_3\"");
        assert!(err(&far).contains("road_3"), "{}", err(&far));
        let position = text.replace("control = \"force\"", "control = \"position\"");
        assert_ne!(position, text);
        assert!(err(&position).contains("actuator.control"));
        let tyre = text.replace(
            "[numerical]\nstructure = \"two-dof-numerical.toml\"",
            "[numerical.tyre]\nstiffness_n_per_m = 2.5e5\ndamping_n_s_per_m = 500.0\n[numerical.x]\nstructure = \"two-dof-numerical.toml\"",
        );
        assert!(
            SetUp::from_toml(&tyre, &base).is_err(),
            "unknown key refused"
        );
        let dir = tempfile::tempdir().unwrap();
        let numerical = std::fs::read_to_string(examples().join("two-dof-numerical.toml"))
            .unwrap()
            + "\n[[effect]]\neffect = \"cubic_stiffness\"\nelement = \"k_n, c_n to the road\"\nparameters = { stiffness_n_per_m3 = 1e9 }\n";
        std::fs::write(dir.path().join("two-dof-numerical.toml"), numerical).unwrap();
        for f in ["two-dof-physical.toml", "two-dof-filter.json"] {
            std::fs::copy(examples().join(f), dir.path().join(f)).unwrap();
        }
        let e = match SetUp::from_toml(&text, dir.path()).and_then(|s| s.run()) {
            Ok(_) => panic!("effects accepted"),
            Err(e) => format!("{e:#}"),
        };
        assert!(e.contains("linear") && e.contains("CubicStiffness"), "{e}");
    }

    /// The tyre's static load defaults to the quarter car's weight, and one that does not
    /// balance it (a load in kg) is refused.
    #[test]
    fn the_static_wheel_load_is_the_weight() {
        let c = SetUp::from_toml(DEFAULT_SETUP, Path::new("."))
            .unwrap()
            .run()
            .unwrap();
        let load = c.tyre.as_ref().unwrap().static_load_n;
        assert!((f64::from(load) - 170.0 * 9.81).abs() < 1e-3, "{load}");
        let kg = DEFAULT_SETUP.replace(
            "# static_load_n: the quarter car's weight",
            "static_load_n = 170.0\n# static_load_n: the quarter car's weight",
        );
        let e = SetUp::from_toml(&kg, Path::new("."))
            .unwrap()
            .run()
            .unwrap()
            .validate_sim()
            .unwrap_err()
            .to_string();
        assert!(e.contains("static_load_n") && e.contains("kg"), "{e}");
    }
}
