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
//! [physical]                     # what the rig holds: a structure file
//! structure = "tyre-physical.toml"
//! [excitation]
//! duration_s = 20.0
//! road = { kind = "pink", rms_m = 0.0005, max_hz = 40.0, seed = 1 }
//! ```
//!
//! The physical part is always a structure file. The pairs: the numerical tyre on a
//! structure hanging on one hub actuator (its one force input; four wheels, a hub actuator
//! each), the numerical aero model on a half car standing on two posts with two down-force
//! actuators (its two displacement and two force inputs), or a numerical structure on a
//! physical structure joined by `[[interface.channels]]` (one actuator each). The analysis
//! takes the tyre and the aero model as the interface `B_i` of a custom model. Every
//! configuration of the paper can be
//! analysed; the board and the simulated rig run configuration 4 (force control, `B_i`
//! numerical), which is what model-core's models compute.

use crate::config::{
    AeroSection, CompareSection, Config, ControllerSection, HalfCarOnRig, LimitsSection,
    LinksSection, ModelKind, ModelSection, RigSection, RoadCoupling, RunSection, SensorsSection,
    StructureOnRig, SubstructureChannel, SubstructureSection, TyreSection,
};
use crate::signals::{RoadInput, SpeedInput};
use anyhow::{bail, Context, Result};
use mil_analysis::setup::{
    ActuatorSection, AnalysisSection, ForceSection, InputSection, InterfaceSection,
    ModelSection as AnalysisModel, NoiseSection, PartSection, ResponseEntry, ResponseSection,
    Setup, SetupFile,
};
use mil_params::{AeroExample, TyreExample, TyreVelocity};
use mil_params::{PositionServoActuator, ServoHydraulicActuator};
use mil_rig::actuator::ActuatorEffects;
use mil_structure::model::InputKind;
use mil_structure::{EffectKind, Parameters};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The paper's tyre example, built into the tool: `mil sim` and `mil run` without a file
/// use it ([`SetUp::builtin`]).
pub const DEFAULT_SETUP: &str = include_str!("../examples/tyre.toml");

/// The paper's least-squares command filter for the built-in tyre example
/// (`examples/tyre-filter.json`): the main job runs the example without and with it.
pub const DEFAULT_FILTER: &str = include_str!("../examples/tyre-filter.json");

/// The built-in tyre example's physical part, [`DEFAULT_SETUP`]'s `[physical] structure`.
pub const DEFAULT_PHYSICAL: &str = include_str!("../examples/tyre-physical.toml");

/// The file name [`DEFAULT_SETUP`] gives its physical part.
const DEFAULT_PHYSICAL_FILE: &str = "tyre-physical.toml";

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
    /// The built-in set-up: its physical part is [`DEFAULT_PHYSICAL`]; not read from TOML.
    #[serde(skip)]
    builtin: bool,
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

/// `[numerical.aero]`: model-core's aerodynamic model (`AeroParams`, linear form).
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
    /// Body reference point (where `z` and `θ` are) to the front axle (m): the model turns
    /// the axle displacements into `[z; θ]` and its force and moment into axle forces with
    /// it and `rear_axle_m`.
    pub front_axle_m: f32,
    /// Body reference point to the rear axle (m).
    pub rear_axle_m: f32,
}

/// `[physical]`: what stands on the rig.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Physical {
    /// A structure file (`mil diagnose`'s schema: its `updated.toml` fits here). Under the
    /// numerical tyre: one wheel's quarter car, hanging on its hub actuator (its one force
    /// input, whose `static_n` is the static wheel load). Under the aero model: the half car
    /// on the four-poster's two posts (its two displacement inputs, front then rear) with
    /// the front and rear down-force actuators (its two force inputs). Under a numerical
    /// structure: its springs carry its weight.
    pub structure: Option<PathBuf>,
    /// The run's road each displacement input of the structure follows: `"road_0"`… or
    /// `"fixed"` (the rig's bed).
    #[serde(default)]
    pub roads: BTreeMap<String, String>,
    /// Under the numerical tyre: the real tyre's effects (the emulated vehicle's); default
    /// lift-off as the numerical tyre has it. Effects here and not in the board's tyre are
    /// hidden effects.
    pub tyre_effects: Option<BTreeMap<EffectKind, Parameters>>,
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
    Tyre(&'a NumericalTyre, &'a Path),
    Aero(&'a NumericalAero, &'a Path),
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

    /// The built-in tyre example ([`DEFAULT_SETUP`] with [`DEFAULT_PHYSICAL`]).
    ///
    /// # Errors
    /// None for the shipped text (tested).
    pub fn builtin() -> Result<Self> {
        let mut s = Self::from_toml(DEFAULT_SETUP, Path::new("."))?;
        s.builtin = true;
        Ok(s)
    }

    /// The four-poster's half car from `[physical] structure`: its two force inputs are the
    /// front and rear down-force actuators (their `at` the axle points), its two
    /// displacement inputs the front and rear posts, in file order. Where the axle points
    /// are heave-and-pitch rows `[1, −a]`, `[1, b]` of the structure's two DOFs, `a` and `b`
    /// must be the aero model's axle distances.
    fn half_car(&self, file: &Path, aero: &NumericalAero) -> Result<HalfCarOnRig> {
        let model = self.structure(file, "physical.structure")?;
        let of_kind = |kind: InputKind| -> Vec<usize> {
            (0..model.inputs.len())
                .filter(|&j| model.inputs[j].kind == kind)
                .collect()
        };
        let (forces, posts) = (of_kind(InputKind::Force), of_kind(InputKind::Displacement));
        let (&[front, rear], &[post_front, post_rear]) = (&forces[..], &posts[..]) else {
            bail!(
                "physical.structure {}: under the aero model the half car stands on two posts \
                 (two displacement inputs, front then rear) with two down-force actuators (two \
                 force inputs at the axles, front then rear); it has {} and {}",
                file.display(),
                posts.len(),
                forces.len()
            );
        };
        let axles = [
            force_input_at(&model, front)?,
            force_input_at(&model, rear)?,
        ];
        let rows: Vec<Vec<f64>> = axles.iter().filter_map(|a| model.position_of(a)).collect();
        if let [f, r] = &rows[..] {
            if f.len() == 2 && f[0] == 1.0 && r[0] == 1.0 {
                for (key, structure, numerical) in [
                    ("front_axle_m", -f[1], aero.front_axle_m),
                    ("rear_axle_m", r[1], aero.rear_axle_m),
                ] {
                    if (structure - f64::from(numerical)).abs() > 1e-3 {
                        bail!(
                            "numerical.aero.{key} = {numerical} m, but the physical structure's \
                             axle is {structure} m from its reference point: the model would put \
                             its forces elsewhere than the actuators are"
                        );
                    }
                }
            }
        }
        Ok(HalfCarOnRig {
            actuators: [
                model.inputs[front].name.clone(),
                model.inputs[rear].name.clone(),
            ],
            model,
            axles,
            posts: [post_front, post_rear],
        })
    }

    /// Reads a structure file of the set-up (`what` names its key in messages).
    fn structure(&self, file: &Path, what: &str) -> Result<mil_structure::Model> {
        if self.builtin && file == Path::new(DEFAULT_PHYSICAL_FILE) {
            return mil_structure::Model::from_toml(DEFAULT_PHYSICAL)
                .map_err(|e| anyhow::anyhow!("{what} (built in): {e}"));
        }
        mil_structure::Model::read(&self.base.join(file))
            .map_err(|e| anyhow::anyhow!("{what}: {e}"))
    }

    /// The tyre rig's quarter car from `[physical] structure`: its one force input is the
    /// hub actuator (where the tyre acts), whose static force becomes the tyre's static
    /// load (`numerical.tyre.static_load_n`, default the input's `static_n`).
    fn quarter_car(&self, file: &Path, tyre: &NumericalTyre) -> Result<QuarterCarOnRig> {
        let model = self.structure(file, "physical.structure")?;
        let forces: Vec<&mil_structure::model::Input> = model
            .inputs
            .iter()
            .filter(|i| i.kind == InputKind::Force)
            .collect();
        let [hub] = forces[..] else {
            bail!(
                "physical.structure {}: under the numerical tyre the quarter car hangs on one \
                 hub actuator: give it one force input at the hub (kind = \"force\", at = the \
                 hub, static_n = the car's weight), not {}",
                file.display(),
                forces.len()
            );
        };
        if let Some(post) = model
            .inputs
            .iter()
            .find(|i| i.kind == InputKind::Displacement)
        {
            bail!(
                "physical.structure {}: under the numerical tyre the quarter car stands on its \
                 hub actuator only, but it has the displacement input {:?} (the tyre to the road \
                 is the numerical model's)",
                file.display(),
                post.name
            );
        }
        let at = model
            .inputs
            .iter()
            .position(|i| i.name == hub.name)
            .map_or_else(
                || bail!("physical.structure: no input {:?}", hub.name),
                |j| force_input_at(&model, j),
            )?;
        let load = tyre.static_load_n.unwrap_or(hub.static_n as f32);
        let weight: f64 = -model.static_force.iter().sum::<f64>();
        let static_n = hub.static_n;
        let model = model
            .with_static_n(&hub.name, f64::from(load))
            .map_err(|e| {
                let kg = (f64::from(load) * mil_rig::specimen::GRAVITY_M_PER_S2 - weight).abs()
                    < 0.01 * weight;
                anyhow::anyhow!(
                    "numerical.tyre.static_load_n = {load} N does not hold the physical quarter \
                     car at rest: it weighs {weight:.1} N, and its hub actuator's static_n in \
                     physical.structure is {static_n} N{}",
                    if kg {
                        " -- the load given in kg?".to_string()
                    } else {
                        format!(" ({e})")
                    }
                )
            })?;
        Ok(QuarterCarOnRig {
            model,
            hub: at,
            load,
        })
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
        let physical = usize::from(p.structure.is_some());
        if numerical != 1 {
            bail!("[numerical]: give one of tyre, aero or structure");
        }
        if physical != 1 {
            bail!("[physical]: give the structure on the rig (structure = \"file.toml\")");
        }
        let pair = match (n, p) {
            (
                Numerical { tyre: Some(t), .. },
                Physical {
                    structure: Some(ps),
                    ..
                },
            ) => Pair::Tyre(t, ps),
            (
                Numerical { aero: Some(a), .. },
                Physical {
                    structure: Some(ps),
                    ..
                },
            ) => Pair::Aero(a, ps),
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
            _ => bail!("[numerical]: give one of tyre, aero or structure"),
        };
        if !matches!(pair, Pair::Structures(..)) {
            if self.interface.is_some() {
                bail!("[interface] is for a numerical and a physical structure");
            }
            if !(n.roads.is_empty() && p.roads.is_empty()) {
                bail!(
                    "roads are for the structures of a numerical and a physical structure (the \
                     tyre's quarter car stands on its hub actuator only; the half car's posts \
                     follow road_front and road_rear, in the file's order)"
                );
            }
        }
        if p.tyre_effects.is_some() && !matches!(pair, Pair::Tyre(..)) {
            bail!("physical.tyre_effects is for the numerical tyre (the real tyre's effects)");
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
        // Every pair is a custom model: the tyre and the aero model its interface B_i.
        let model = AnalysisModel {
            example: "custom".into(),
            tyre: TyreExample::default(),
            aero: AeroExample::default(),
            two_dof: Default::default(),
        };
        let mut numerical = None;
        let physical: Option<PartSection>;
        let interface: Option<InterfaceSection>;
        let mut inputs = Vec::new();
        let default_responses: Vec<ResponseSection>;
        match self.pair()? {
            Pair::Tyre(t, ps) => {
                // The tyre is the interface B_i = k_t + c_t V(s) between the road (the
                // numerical interface position) and the hub.
                let car = self.quarter_car(ps, t)?;
                physical = Some(structure_part(ps, Some(car.model)));
                // The board's velocity estimate; under position control the tyre turns the
                // measured force into a position through B_i⁻¹ without one.
                let board = t.velocity_estimate == TyreVelocity::Board && control_force;
                interface = Some(InterfaceSection {
                    location: "numerical".into(),
                    numerical_dofs: vec![],
                    physical_dofs: vec![car.hub],
                    stiffness: vec![vec![f64::from(t.stiffness_n_per_m)]],
                    damping: vec![vec![f64::from(t.damping_n_s_per_m)]],
                    velocity_cutoff_hz: board.then_some(f64::from(t.velocity_cutoff_hz)),
                });
                inputs.push(InputSection {
                    name: "road".into(),
                    unit: "m".into(),
                    forces: vec![],
                    interface_position: vec![1.0],
                });
                default_responses = vec![response(
                    "tyre force / road",
                    "road",
                    "interface_force",
                    1e-3,
                    "N/mm",
                )];
            }
            Pair::Aero(a, ps) => {
                // The model's K_i in axle coordinates: F_a = L⁻ᵀ K_i L⁻¹ x_a, B_i = −that.
                let car = self.half_car(ps, a)?;
                let (lf, lr) = (f64::from(a.front_axle_m), f64::from(a.rear_axle_m));
                let l_inv = mil_numerics::dense::invert(&[vec![1.0, -lf], vec![1.0, lr]])
                    .context("numerical.aero: the axles coincide (front_axle_m = -rear_axle_m)")?;
                let k_i = |r: usize, c: usize| f64::from(a.stiffness[r][c]);
                let b: Vec<Vec<f64>> = (0..2)
                    .map(|r| {
                        (0..2)
                            .map(|c| {
                                let mut sum = 0.0;
                                for p in 0..2 {
                                    for q in 0..2 {
                                        sum += l_inv[p * 2 + r] * k_i(p, q) * l_inv[q * 2 + c];
                                    }
                                }
                                -sum
                            })
                            .collect()
                    })
                    .collect();
                // The posts together (heave) and in pitch: r = L [z_r; θ_r].
                let linear = car.model.linearised();
                let post_force = |w: [f64; 2]| -> Vec<ForceSection> {
                    (0..car.model.n())
                        .map(|d| {
                            let (mut stiffness, mut damping) = (0.0, 0.0);
                            for (w, j) in w.iter().zip(car.posts) {
                                stiffness += w * linear.input_stiffness[(d, j)];
                                damping += w * linear.input_damping[(d, j)];
                            }
                            ForceSection {
                                part: "physical".into(),
                                dof: car.model.dofs[d].clone(),
                                stiffness,
                                damping,
                            }
                        })
                        .collect()
                };
                for (name, unit, w) in [
                    ("road_heave", "m", [1.0, 1.0]),
                    ("road_pitch", "rad", [-lf, lr]),
                ] {
                    inputs.push(InputSection {
                        name: name.into(),
                        unit: unit.into(),
                        forces: post_force(w),
                        interface_position: vec![],
                    });
                }
                physical = Some(structure_part(ps, Some(car.model)));
                interface = Some(InterfaceSection {
                    location: "numerical".into(),
                    numerical_dofs: vec![],
                    physical_dofs: car.axles.to_vec(),
                    stiffness: b,
                    damping: vec![vec![0.0; 2]; 2],
                    velocity_cutoff_hz: None,
                });
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
                numerical = Some(structure_part(ns, None));
                physical = Some(structure_part(ps, None));
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
            inputs,
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
            Pair::Tyre(t, ps) => {
                let car = self.quarter_car(ps, t)?;
                let load = car.load;
                tyre = Some(TyreSection {
                    stiffness_n_per_m: t.stiffness_n_per_m,
                    damping_n_s_per_m: t.damping_n_s_per_m,
                    static_load_n: load,
                    lift_off: t.lift_off,
                    velocity_cutoff_hz: t.velocity_cutoff_hz,
                });
                rig.quarter_car = Some(
                    mil_rig::specimen::Specimen::from_structure(&car.model, &[car.hub])
                        .map_err(|e| anyhow::anyhow!("physical.structure {}: {e}", ps.display()))?,
                );
                rig.tyre_effects = self.physical.tyre_effects.clone();
                (ModelKind::Tyre, vec!["road".to_string()])
            }
            Pair::Aero(a, ps) => {
                aero = Some(AeroSection {
                    stiffness: a.stiffness,
                    nominal_force: a.nominal_force,
                    reference_speed_m_per_s: a.reference_speed_m_per_s,
                    front_axle_m: a.front_axle_m,
                    rear_axle_m: a.rear_axle_m,
                    speed_m_per_s: self.excitation.speed_m_per_s.map(|v| v as f32),
                });
                rig.half_car = Some(self.half_car(ps, a)?);
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

    /// The board's substructure from a numerical structure file: the linearisation of its
    /// linear elements, the springs and dampers to each mapped displacement input as that
    /// channel's road couplings, its elements with effects as the board's nonlinear
    /// elements (their law's board form: what the board cannot run is refused by element
    /// and effect); and the structure's inputs that follow road 0.
    fn board_substructure(
        &self,
        file: &Path,
        interface: &InterfaceSetUp,
    ) -> Result<(SubstructureSection, Vec<String>)> {
        let path = self.base.join(file);
        let model = mil_structure::Model::read(&path)
            .map_err(|e| anyhow::anyhow!("numerical.structure: {e}"))?;
        let (nonlinear, linear): (Vec<_>, Vec<_>) = model
            .elements
            .iter()
            .cloned()
            .partition(|e| !e.law.kinds().is_empty());
        let l = mil_structure::Model {
            elements: linear,
            ..model.clone()
        }
        .linearised();
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
        let mut road_of = vec![None; model.inputs.len()];
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
            road_of[j] = Some(c);
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
        let elements = nonlinear
            .iter()
            .map(|e| {
                let law = e.law.to_board().map_err(|err| {
                    anyhow::anyhow!(
                        "numerical.structure {}: element {:?}: {err}",
                        path.display(),
                        e.name
                    )
                })?;
                let mut road_coefficients = vec![0.0f32; channels];
                for (b, c) in e.b.iter().zip(&road_of) {
                    if let Some(c) = c {
                        road_coefficients[*c] += *b as f32;
                    }
                }
                Ok(crate::config::BoardElement {
                    name: e.name.clone(),
                    dof_coefficients: e.a.iter().map(|&a| a as f32).collect(),
                    road_coefficients,
                    law,
                })
            })
            .collect::<Result<Vec<_>>>()?;
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
                elements,
            },
            road_0,
        ))
    }
}

/// Where force input `j` of `model` acts: the DOF or point its file names (`at`).
fn force_input_at(model: &mil_structure::Model, j: usize) -> Result<String> {
    model
        .file
        .inputs
        .get(j)
        .and_then(|i| i.at.clone())
        .context("physical.structure: a force input acts nowhere")
}

/// The tyre rig's quarter car: the structure with the hub actuator holding the static wheel
/// load, where it acts, and the load.
struct QuarterCarOnRig {
    model: mil_structure::Model,
    hub: String,
    load: f32,
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

/// The analysis' part of structure file `file`, already read as `model` or read there.
fn structure_part(file: &Path, model: Option<mil_structure::Model>) -> PartSection {
    PartSection {
        dofs: vec![],
        mass: vec![],
        damping: vec![],
        stiffness: vec![],
        structure: Some(file.to_path_buf()),
        model,
    }
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
        // Effects: those the board runs become its nonlinear elements; hysteresis, which it
        // cannot run, and a stop too stiff for the rate on 10 kg are refused by name.
        let dir = tempfile::tempdir().unwrap();
        for f in ["two-dof-physical.toml", "two-dof-filter.json"] {
            std::fs::copy(examples().join(f), dir.path().join(f)).unwrap();
        }
        let with_effect = |effect: &str, parameters: &str| {
            let numerical = std::fs::read_to_string(examples().join("two-dof-numerical.toml"))
                .unwrap()
                + &format!(
                    "\n[[effect]]\neffect = \"{effect}\"\nelement = \"k_n, c_n to the road\"\n\
                     parameters = {{ {parameters} }}\n"
                );
            std::fs::write(dir.path().join("two-dof-numerical.toml"), numerical).unwrap();
            SetUp::from_toml(&text, dir.path()).and_then(|s| s.run())
        };
        let cubic = with_effect("cubic_stiffness", "stiffness_n_per_m3 = 1e9")
            .unwrap()
            .substructure
            .unwrap();
        assert_eq!((cubic.stiffness[0][0], cubic.damping[0][0]), (0.0, 0.0));
        assert!(cubic.channels[0].road.is_empty());
        assert_eq!(cubic.elements.len(), 1);
        let e = &cubic.elements[0];
        assert_eq!(
            (e.law.stiffness, e.law.cubic_stiffness, e.law.bump_damping),
            (4.0e4, 1.0e9, 20.0)
        );
        assert_eq!(
            (&e.dof_coefficients[..], &e.road_coefficients[..]),
            (&[-1.0f32][..], &[1.0f32][..])
        );
        let refused = |r: anyhow::Result<crate::config::Config>| match r {
            Ok(_) => panic!("accepted"),
            Err(e) => format!("{e:#}"),
        };
        let hysteresis = refused(with_effect(
            "hysteresis",
            "alpha = 0.5, a = 1.0, beta_per_m = 100.0, gamma_per_m = 50.0, n = 1.0",
        ));
        assert!(
            hysteresis.contains("k_n, c_n to the road") && hysteresis.contains("hysteresis"),
            "{hysteresis}"
        );
        // k_b T²/m = 5e7 · 2.5e-7 / 10 = 1.25.
        let stiff = refused(
            with_effect("bump_stop", "gap_m = 1e-3, stiffness_n_per_m = 5e7").and_then(|c| {
                c.validate()?;
                Ok(c)
            }),
        );
        assert!(
            stiff.contains("k_n, c_n to the road") && stiff.contains("too stiff"),
            "{stiff}"
        );
        let softer = with_effect("bump_stop", "gap_m = 1e-3, stiffness_n_per_m = 3e7").unwrap();
        softer.validate().unwrap();
    }

    /// The physical structures the tyre and the aero model need are checked when the set-up
    /// is read, naming the file and what is missing: the whole quarter car on the road (the
    /// tyre twice), a second hub actuator, a half car without its posts, axles elsewhere
    /// than the aero model puts its forces.
    #[test]
    fn physical_structures_that_do_not_fit_the_model_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        for f in ["tyre.toml", "aero.toml"] {
            std::fs::copy(examples().join(f), dir.path().join(f)).unwrap();
        }
        let refused = |set_up: &str, file: &str, text: String| -> String {
            std::fs::write(dir.path().join(file), text).unwrap();
            match SetUp::read(&dir.path().join(set_up)).and_then(|s| s.sim()) {
                Ok(_) => panic!("accepted {file}"),
                Err(e) => format!("{e:#}"),
            }
        };
        let tyre = std::fs::read_to_string(examples().join("tyre-physical.toml")).unwrap();
        let on_road = std::fs::read_to_string(
            PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../diagnose/examples/quarter-car.toml"),
        )
        .unwrap();
        let e = refused("tyre.toml", "tyre-physical.toml", on_road.clone());
        assert!(e.contains("hub actuator") && e.contains("not 0"), "{e}");
        let e = refused(
            "tyre.toml",
            "tyre-physical.toml",
            on_road.replace("[[input]]", "[[input]]\nname = \"hub\"\nkind = \"force\"\ncolumn = \"f\"\nat = \"x_u\"\n\n[[input]]"),
        );
        assert!(e.contains("displacement input \"road\""), "{e}");
        let twice = tyre.clone()
            + "\n[[input]]\nname = \"second\"\nkind = \"force\"\ncolumn = \"f\"\nat = \"x_s\"\n";
        let e = refused("tyre.toml", "tyre-physical.toml", twice);
        assert!(e.contains("one force input") && e.contains("not 2"), "{e}");
        let aero = std::fs::read_to_string(examples().join("aero-physical.toml")).unwrap();
        let no_posts = aero
            .replace("lower = \"road_front\"", "lower = \"ground\"")
            .replace("lower = \"road_rear\"", "lower = \"ground\"")
            .replace(
                "kind = \"displacement\"\ncolumn = \"road_",
                "kind = \"force\"\nat = \"z_b\"\ncolumn = \"road_",
            );
        let e = refused("aero.toml", "aero-physical.toml", no_posts);
        assert!(e.contains("two posts"), "{e}");
        let moved = aero.replace("theta_b = -1.8", "theta_b = -1.6");
        let e = refused("aero.toml", "aero-physical.toml", moved);
        assert!(e.contains("numerical.aero.front_axle_m"), "{e}");
    }

    /// The tyre's static load defaults to the hub actuator's static force in the physical
    /// structure (the quarter car's weight); one that does not balance it (a load in kg) is
    /// refused; the built-in set-up is the example's.
    #[test]
    fn the_static_wheel_load_is_the_weight() {
        let c = SetUp::builtin().unwrap().run().unwrap();
        let load = c.tyre.as_ref().unwrap().static_load_n;
        assert!((f64::from(load) - 170.0 * 9.81).abs() < 1e-3, "{load}");
        c.validate_sim().unwrap();
        let from_file = SetUp::read(&examples().join("tyre.toml"))
            .unwrap()
            .run()
            .unwrap();
        assert_eq!(
            from_file.rig.quarter_car.as_ref(),
            c.rig.quarter_car.as_ref()
        );
        let marker = "# static_load_n: the hub actuator's static_n";
        assert!(DEFAULT_SETUP.contains(marker));
        let kg = DEFAULT_SETUP.replace(marker, &format!("static_load_n = 170.0\n{marker}"));
        let e = SetUp::from_toml(&kg, &examples())
            .and_then(|s| s.run())
            .and_then(|c| c.validate_sim())
            .unwrap_err();
        let e = format!("{e:#}");
        assert!(e.contains("static_load_n") && e.contains("kg"), "{e}");
    }
}
