//! The analysis set-up (TOML form): a MiL set-up described once, validated at load, turned
//! into a [`MilSystem`] and [`AnalysisOptions`]. Relative file names inside (actuator tables,
//! the command filter, structure files) are relative to the given folder.
//!
//! This form is the analysis crate's internal input, not a file users write: `mil analyze`,
//! `mil design-filter` and `mil sim` read the MiL set-up file (`mil::setup::SetUp` in
//! `host-tools/mil/src/setup.rs`, one file for the analysis and the run), and
//! `mil::setup::SetUp::analysis` builds this [`SetupFile`] from it (e.g. its
//! `[numerical.tyre]` on a physical structure becomes a `custom` model, the tyre its
//! interface `B_i` at the hub and `road` its interface position; its structure files and
//! `[[interface.channels]]` a `custom` model, its `[sensors]` noise `[noise]`) and hands it to [`Setup::from_file`]. Its keys, for
//! reference:
//!
//! ```toml
//! name = "tyre"
//! [model]
//! example = "tyre"            # "tyre" | "aero" | "two-dof" | "custom"
//! [model.tyre]                # optional: any TyreExample field, paper values by default
//! velocity_cutoff_hz = 500.0  # board's tyre velocity low-pass (Hz), 0 = plain difference
//! velocity_estimate = "board" # "board" (default) | "continuous" (c_t s)
//! [actuator]
//! control = "force"           # "force" | "position"
//! tracking = "reference"      # or { numerator = [..], denominator = [..], delay_s = 0.0 }
//! disturbance = "reference"   #    or { table = "measured.csv" } or "none"
//! # "reference" is ServoHydraulicActuator under force control ([actuator.reference] to
//! # change its parameters) and PositionServoActuator under position control
//! # ([actuator.position_servo]).
//! [controller]
//! sample_rate_hz = 2000.0     # loop delay defaults to 1.5 samples
//! [noise]
//! rms = 2e-6                  # measurement noise (m or N, per channel)
//! [[analysis.responses]]
//! name = "tyre force / road"
//! input = "road"
//! output = "interface_force"
//! scale = 1e-3
//! unit = "N/mm"
//! ```
//!
//! A `custom` model gives `[numerical]` and `[physical]` (`dofs`, `mass`, `damping`,
//! `stiffness` matrices, or `structure = "file.toml"`: a structure file, linearised, whose
//! displacement inputs join the `[[inputs]]` of the same name), `[interface]` (`location`, `numerical_dofs`, `physical_dofs`,
//! `stiffness`, `damping`, optional `velocity_cutoff_hz`) and `[[inputs]]` (`name`, `unit`,
//! `forces` on DOFs, and for a numerical part without DOFs `interface_position`).
//!
//! # The numerical model's velocity
//! The board's tyre does not differentiate: it multiplies `c_t` by model-core's velocity
//! estimate of the sampled deflection (backward difference and first-order low-pass,
//! `model_core::velocity`). The MiL analysis of the `tyre` example models that estimator
//! exactly ([`crate::system::VelocityEstimate::Board`]: its discrete response at the
//! controller's sample period `1/sample_rate_hz` (s), from model-core's own `f32`
//! coefficients), with the cut-off `[model.tyre] velocity_cutoff_hz` (Hz; default 500, the
//! model-core tyre's `TyreParams::PAPER`; 0 = plain backward difference; 0 to 20000 Hz, and
//! `sample_rate_hz` 100 Hz to 20 kHz, as the board accepts). Give it the value the board
//! runs: the MiL set-up has one key for both, `[numerical.tyre] velocity_cutoff_hz` (500 Hz
//! in `host-tools/mil/examples/tyre.toml`), which `mil::setup::SetUp::analysis` passes here
//! (and its `velocity_estimate`). `velocity_estimate = "continuous"` analyses the ideal
//! `c_t s` instead, and so does the tyre under position control (configuration 3: the
//! numerical tyre then turns the measured force into a position through `B_i⁻¹`, integrated,
//! without a velocity estimate). A `custom` model is continuous (`C_i s`) unless
//! `[interface]` gives `velocity_cutoff_hz` (Hz), which is allowed for a numerical `B_i`
//! with a numerical part without DOFs under force control (configuration 4, the tyre's
//! form). The emulated system always uses `C_i s`.

use crate::analyze::{AnalysisOptions, ResponseSpec, Signal};
use crate::error::{setup_error, Result};
use crate::examples::{aero_structure, two_dof_structure, tyre_structure, Structure};
use crate::filter_file::FilterFile;
use crate::measured::MeasuredResponse;
use crate::poly::Rational;
use crate::response::LinearActuator;
use crate::response::{CommandFilter, ResponseSource};
use crate::system::{
    ActuatorControl, Actuators, ExternalInput, ImpedanceLocation, Interface, MechanicalPart,
    MilSystem, VelocityEstimate,
};
use mil_identify::FrfTable;
use mil_params::{AeroExample, TwoDofExample, TyreExample};
use mil_params::{PositionServoActuator, ServoHydraulicActuator};
use nalgebra::{DMatrix, DVector};
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// The whole file.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SetupFile {
    /// Name for reports.
    #[serde(default)]
    pub name: String,
    /// Expected configuration number (1–4); checked against the model if given.
    pub configuration: Option<u8>,
    /// The structure.
    pub model: ModelSection,
    /// Custom numerical part.
    pub numerical: Option<PartSection>,
    /// Custom physical part.
    pub physical: Option<PartSection>,
    /// Custom interface.
    pub interface: Option<InterfaceSection>,
    /// Custom inputs.
    #[serde(default)]
    pub inputs: Vec<InputSection>,
    /// Actuators.
    pub actuator: ActuatorSection,
    /// Controller.
    pub controller: ControllerSection,
    /// Measurement noise.
    #[serde(default)]
    pub noise: NoiseSection,
    /// Analysis options.
    #[serde(default)]
    pub analysis: AnalysisSection,
}

/// `[model]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModelSection {
    /// "tyre", "aero", "two-dof" or "custom".
    pub example: String,
    /// Tyre example parameters (paper values by default).
    #[serde(default)]
    pub tyre: TyreExample,
    /// Aero example parameters.
    #[serde(default)]
    pub aero: AeroExample,
    /// 2-DOF example parameters.
    #[serde(default)]
    pub two_dof: TwoDofExample,
}

/// A custom mechanical part: its matrices, or a structure file.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PartSection {
    /// DOF names.
    #[serde(default)]
    pub dofs: Vec<String>,
    /// Mass matrix (kg), rows.
    #[serde(default)]
    pub mass: Vec<Vec<f64>>,
    /// Damping matrix (N·s/m), rows.
    #[serde(default)]
    pub damping: Vec<Vec<f64>>,
    /// Stiffness matrix (N/m), rows.
    #[serde(default)]
    pub stiffness: Vec<Vec<f64>>,
    /// A structure file (relative to the set-up; `mil diagnose`'s schema, e.g. its
    /// `updated.toml`) instead of the matrices: the part is its linearisation about the
    /// static equilibrium, and its displacement inputs push the part through the set-up's
    /// `[[inputs]]` of the same name (one is added, unit m, where the set-up has none).
    pub structure: Option<std::path::PathBuf>,
    /// The structure already read and validated (its file name, `structure`, for
    /// messages); not read from TOML.
    #[serde(skip)]
    pub model: Option<mil_structure::Model>,
}

/// A part and the couplings of its structure's displacement inputs, by name: stiffness and
/// damping column over the part's DOFs.
type PartWithInputs = (
    MechanicalPart,
    Vec<(String, DVector<f64>, DVector<f64>)>,
    Option<mil_structure::Model>,
);

/// A custom interface.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InterfaceSection {
    /// "physical" or "numerical": where `B_i` is.
    pub location: String,
    /// Numerical DOF per channel (empty for a numerical part without DOFs).
    #[serde(default)]
    pub numerical_dofs: Vec<String>,
    /// Physical DOF per channel (or a structure file's point).
    pub physical_dofs: Vec<String>,
    /// `K_i` (N/m), rows.
    pub stiffness: Vec<Vec<f64>>,
    /// `C_i` (N·s/m), rows.
    pub damping: Vec<Vec<f64>>,
    /// Cut-off (Hz) of the board's velocity estimator that computes the velocity multiplying
    /// `C_i` (0: plain backward difference); none: the continuous `C_i s`.
    pub velocity_cutoff_hz: Option<f64>,
}

/// A force from an input onto a DOF: `(stiffness + damping s) w`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ForceSection {
    /// "numerical" or "physical".
    pub part: String,
    /// DOF name.
    pub dof: String,
    /// N per input unit.
    #[serde(default)]
    pub stiffness: f64,
    /// N·s per input unit.
    #[serde(default)]
    pub damping: f64,
}

/// A custom input.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InputSection {
    /// Name.
    pub name: String,
    /// Unit ("m", "N", "rad").
    pub unit: String,
    /// Forces on DOFs.
    #[serde(default)]
    pub forces: Vec<ForceSection>,
    /// Prescribed numerical interface position per channel (numerical part without DOFs).
    #[serde(default)]
    pub interface_position: Vec<f64>,
}

/// A response given in the file.
#[derive(Clone, Debug, Deserialize)]
#[serde(untagged)]
pub enum ResponseEntry {
    /// "reference" (the reference actuator) or "none" (zero).
    Named(String),
    /// A rational model with optional delay.
    Model {
        /// Numerator, descending powers of s.
        numerator: Vec<f64>,
        /// Denominator.
        denominator: Vec<f64>,
        /// Pure delay (s).
        #[serde(default)]
        delay_s: f64,
    },
    /// A measured table (CSV of mil-identify).
    Table {
        /// File name.
        table: PathBuf,
    },
}

/// `[actuator]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ActuatorSection {
    /// "force" or "position".
    pub control: String,
    /// Tracking response.
    pub tracking: ResponseEntry,
    /// Disturbance response.
    pub disturbance: ResponseEntry,
    /// Reference force-controlled actuator parameters, used by `"reference"` responses under
    /// force control (defaults: [`ServoHydraulicActuator::REFERENCE`]).
    pub reference: Option<ServoHydraulicActuator>,
    /// Reference position servo parameters, used by `"reference"` responses under position
    /// control (defaults: [`PositionServoActuator::REFERENCE`]).
    pub position_servo: Option<PositionServoActuator>,
    /// Loop delay (s); default 1.5 samples of the controller.
    pub loop_delay_s: Option<f64>,
}

/// `[controller]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ControllerSection {
    /// Control loop rate (Hz).
    pub sample_rate_hz: f64,
    /// Command filter file (JSON, see [`crate::filter_file`]).
    pub filter: Option<PathBuf>,
}

/// `[noise]`.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NoiseSection {
    /// RMS measurement noise per channel (m or N), white to the Nyquist frequency.
    #[serde(default)]
    pub rms: f64,
}

/// `[analysis]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct AnalysisSection {
    /// Lowest frequency (Hz).
    pub f_min_hz: f64,
    /// Highest frequency (Hz); default the Nyquist frequency.
    pub f_max_hz: Option<f64>,
    /// Grid density.
    pub points_per_decade: usize,
    /// Error bands (Hz).
    pub bands: Vec<[f64; 2]>,
    /// Minimum resonance prominence (dB).
    pub min_prominence_db: f64,
    /// Responses to report.
    pub responses: Vec<ResponseSection>,
}

impl Default for AnalysisSection {
    fn default() -> Self {
        Self {
            f_min_hz: 0.5,
            f_max_hz: None,
            points_per_decade: 200,
            bands: vec![[0.5, 5.0], [5.0, 10.0], [10.0, 20.0], [20.0, 30.0]],
            min_prominence_db: 1.0,
            responses: Vec::new(),
        }
    }
}

/// `[[analysis.responses]]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ResponseSection {
    /// Name.
    pub name: String,
    /// Input name.
    pub input: String,
    /// Output signal (see [`Signal::parse`]).
    pub output: String,
    /// SI-to-display factor.
    #[serde(default = "one")]
    pub scale: f64,
    /// Display unit.
    #[serde(default)]
    pub unit: String,
}

fn one() -> f64 {
    1.0
}

/// A loaded, validated set-up.
#[derive(Clone, Debug)]
pub struct Setup {
    /// Name.
    pub name: String,
    /// The system.
    pub system: MilSystem,
    /// Analysis options.
    pub options: AnalysisOptions,
    /// Control loop rate (Hz).
    pub sample_rate_hz: f64,
    /// Reference force-controlled actuator parameters, where the file uses them.
    pub reference_actuator: ServoHydraulicActuator,
    /// Reference position servo parameters, where the file uses them.
    pub position_servo: PositionServoActuator,
}

fn matrix(rows: &[Vec<f64>], what: &str) -> Result<DMatrix<f64>> {
    let n = rows.len();
    let m = rows.first().map_or(0, Vec::len);
    if rows.iter().any(|r| r.len() != m) {
        return Err(setup_error(format!("{what}: rows of different lengths")));
    }
    Ok(DMatrix::from_fn(n, m, |i, j| rows[i][j]))
}

fn part(p: &PartSection, what: &str, folder: &Path) -> Result<PartWithInputs> {
    let Some(file) = &p.structure else {
        let part = MechanicalPart::new(
            p.dofs.clone(),
            matrix(&p.mass, &format!("{what} mass"))?,
            matrix(&p.damping, &format!("{what} damping"))?,
            matrix(&p.stiffness, &format!("{what} stiffness"))?,
        )?;
        return Ok((part, Vec::new(), None));
    };
    if !(p.dofs.is_empty() && p.mass.is_empty() && p.damping.is_empty() && p.stiffness.is_empty()) {
        return Err(setup_error(format!(
            "[{what}]: give a structure file or dofs and matrices, not both"
        )));
    }
    let model = match &p.model {
        Some(model) => model.clone(),
        None => mil_structure::Model::read(&folder.join(file))
            .map_err(|e| setup_error(format!("{what}.structure: {e}")))?,
    };
    let l = model.linearised();
    let part = MechanicalPart::new(model.dofs.clone(), l.mass, l.damping, l.stiffness)?;
    let inputs = model
        .inputs
        .iter()
        .enumerate()
        .filter(|(_, i)| i.kind == mil_structure::model::InputKind::Displacement)
        .map(|(j, i)| {
            (
                i.name.clone(),
                l.input_stiffness.column(j).into_owned(),
                l.input_damping.column(j).into_owned(),
            )
        })
        .collect();
    Ok((part, inputs, Some(model)))
}

fn location(text: &str) -> Result<ImpedanceLocation> {
    match text {
        "physical" => Ok(ImpedanceLocation::Physical),
        "numerical" => Ok(ImpedanceLocation::Numerical),
        _ => Err(setup_error(format!(
            "interface.location {text:?}: use \"physical\" or \"numerical\""
        ))),
    }
}

/// The rows selecting `dofs` of `part`: DOFs, or a structure file's points (`structure`).
fn selector(
    part: &MechanicalPart,
    structure: Option<&mil_structure::Model>,
    dofs: &[String],
    what: &str,
) -> Result<DMatrix<f64>> {
    let mut q = DMatrix::zeros(dofs.len(), part.len());
    for (k, d) in dofs.iter().enumerate() {
        match (part.index(d), structure.and_then(|m| m.position_of(d))) {
            (Some(j), _) => q[(k, j)] = 1.0,
            (None, Some(c)) => {
                for (j, v) in c.iter().enumerate() {
                    q[(k, j)] = *v;
                }
            }
            (None, None) => {
                return Err(setup_error(format!(
                    "{what}: no DOF or point {d:?} in {:?}",
                    part.dofs
                )))
            }
        }
    }
    Ok(q)
}

fn custom_structure(file: &SetupFile, sample_period_s: f64, folder: &Path) -> Result<Structure> {
    let (numerical, numerical_couplings, numerical_structure) = match &file.numerical {
        Some(p) => part(p, "numerical", folder)?,
        None => (MechanicalPart::massless(), Vec::new(), None),
    };
    let (physical, physical_couplings, physical_structure) = part(
        file.physical
            .as_ref()
            .ok_or_else(|| setup_error("a custom model needs [physical]"))?,
        "physical",
        folder,
    )?;
    let i = file
        .interface
        .as_ref()
        .ok_or_else(|| setup_error("a custom model needs [interface]"))?;
    let m = i.physical_dofs.len();
    let numerical_select = if numerical.is_empty() {
        DMatrix::zeros(m, 0)
    } else {
        if i.numerical_dofs.len() != m {
            return Err(setup_error(
                "interface: numerical_dofs and physical_dofs need one entry per channel",
            ));
        }
        selector(
            &numerical,
            numerical_structure.as_ref(),
            &i.numerical_dofs,
            "interface.channels numerical",
        )?
    };
    let interface = Interface {
        location: location(&i.location)?,
        numerical_select,
        physical_select: selector(
            &physical,
            physical_structure.as_ref(),
            &i.physical_dofs,
            "interface.channels physical",
        )?,
        stiffness: matrix(&i.stiffness, "interface stiffness")?,
        damping: matrix(&i.damping, "interface damping")?,
        velocity: match i.velocity_cutoff_hz {
            None => VelocityEstimate::Continuous,
            Some(cutoff_hz) => VelocityEstimate::Board {
                sample_period_s,
                cutoff_hz,
            },
        },
    };
    if interface.velocity.coefficients().is_err() {
        return Err(setup_error(format!(
            "interface velocity_cutoff_hz = {} Hz at a sample period of {sample_period_s} s: \
             the board's estimator needs a cut-off of 0 (plain backward difference) to \
             20000 Hz and a sample period of 5e-5 to 1e-2 s (100 Hz to 20 kHz)",
            i.velocity_cutoff_hz.unwrap_or_default()
        )));
    }
    let mut inputs = Vec::new();
    for s in &file.inputs {
        let mut input = ExternalInput::new(&s.name, &s.unit, numerical.len(), physical.len(), m);
        for force in &s.forces {
            let (target, stiff, damp) = match force.part.as_str() {
                "numerical" => (
                    &numerical,
                    &mut input.numerical_stiffness,
                    &mut input.numerical_damping,
                ),
                "physical" => (
                    &physical,
                    &mut input.physical_stiffness,
                    &mut input.physical_damping,
                ),
                other => {
                    return Err(setup_error(format!(
                        "input {:?}: part {other:?} is not \"numerical\" or \"physical\"",
                        s.name
                    )))
                }
            };
            let j = target.index(&force.dof).ok_or_else(|| {
                setup_error(format!("input {:?}: no DOF {:?}", s.name, force.dof))
            })?;
            stiff[j] += force.stiffness;
            damp[j] += force.damping;
        }
        if !s.interface_position.is_empty() {
            if s.interface_position.len() != m {
                return Err(setup_error(format!(
                    "input {:?}: interface_position needs {m} entries",
                    s.name
                )));
            }
            input.interface_position = DVector::from_vec(s.interface_position.clone());
        }
        inputs.push(input);
    }
    // The structure files' displacement inputs, by name.
    for (couplings, numerical_part) in [(numerical_couplings, true), (physical_couplings, false)] {
        for (name, stiffness, damping) in couplings {
            let k = match inputs.iter().position(|i| i.name == name) {
                Some(k) => k,
                None => {
                    inputs.push(ExternalInput::new(
                        &name,
                        "m",
                        numerical.len(),
                        physical.len(),
                        m,
                    ));
                    inputs.len() - 1
                }
            };
            let input = &mut inputs[k];
            if numerical_part {
                input.numerical_stiffness += &stiffness;
                input.numerical_damping += &damping;
            } else {
                input.physical_stiffness += &stiffness;
                input.physical_damping += &damping;
            }
        }
    }
    Ok(Structure {
        numerical,
        physical,
        interface,
        inputs,
        actuator_transform: DMatrix::identity(m, m),
    })
}

/// Largest factor (either way) between a tracking table's gain at its lowest frequency and
/// 1 that the tracking-table check accepts.
pub const MAX_TRACKING_DC_FACTOR: f64 = 4.0;

/// A tracking response (achieved per demanded, both in the same unit) has a gain near 1 at
/// low frequency: a table far from it was measured with demand and response in different
/// units (kN and N, mm and m) or is not a tracking response.
fn check_tracking_gain(frf: &FrfTable, path: &Path) -> Result<()> {
    let Some(first) = frf.points().first() else {
        return Ok(());
    };
    let g = first.magnitude;
    if (1.0 / MAX_TRACKING_DC_FACTOR..=MAX_TRACKING_DC_FACTOR).contains(&g) {
        return Ok(());
    }
    let decade = 10f64.powf(g.log10().round());
    Err(setup_error(format!(
        "actuator tracking table {}: gain {g:.4} at its lowest frequency {} Hz, where a \
         tracking response is near 1{}: were demand and response logged in different units, or \
         is this not the tracking response?",
        path.display(),
        first.frequency_hz,
        if decade >= 100.0 || decade <= 0.01 {
            format!(" ({decade:e}x: e.g. N against kN, or mm against m)")
        } else {
            String::new()
        }
    )))
}

fn response(
    entry: &ResponseEntry,
    reference: Rational,
    folder: &Path,
    what: &str,
) -> Result<ResponseSource> {
    Ok(match entry {
        ResponseEntry::Named(n) if n == "reference" => ResponseSource::Model {
            transfer_function: reference,
            delay_s: 0.0,
        },
        ResponseEntry::Named(n) if n == "none" => ResponseSource::Zero,
        ResponseEntry::Named(n) => {
            return Err(setup_error(format!(
                "actuator.{what} {n:?}: use \"reference\", \"none\", a model or a table"
            )))
        }
        ResponseEntry::Model {
            numerator,
            denominator,
            delay_s,
        } => {
            if !(delay_s.is_finite() && *delay_s >= 0.0) {
                return Err(setup_error(format!("actuator.{what} delay_s must be >= 0")));
            }
            ResponseSource::Model {
                transfer_function: Rational::new(numerator.clone(), denominator.clone())?,
                delay_s: *delay_s,
            }
        }
        ResponseEntry::Table { table } => {
            let path = folder.join(table);
            let frf = FrfTable::read_csv(&path)?;
            if what == "tracking" {
                check_tracking_gain(&frf, &path)?;
                ResponseSource::Measured(Box::new(MeasuredResponse::new(
                    frf,
                    &path.display().to_string(),
                )?))
            } else {
                // A table is defined over its band only, and the analysis evaluates the
                // response at every frequency of its stability contour (0 to 20 kHz, off the
                // imaginary axis): only a tracking table has a fitted extension.
                let (lo, hi) = frf.frequency_range();
                return Err(setup_error(format!(
                    "actuator.{what} = {{ table = {table:?} }}: a measured {what} table \
                     ({lo:.2}-{hi:.1} Hz in {}) is not extended beyond its band as a tracking \
                     table is, and the analysis needs the {what} response at every frequency \
                     (0 Hz to 20 kHz for the loop's stability); give it as a model fitted to \
                     the table (`{what} = {{ numerator = [...], denominator = [...], delay_s = \
                     ... }}`, coefficients in descending powers of s) or \"reference\"",
                    path.display()
                )));
            }
        }
    })
}

impl Setup {
    /// Builds the set-up from a parsed file; `folder` resolves relative file names.
    ///
    /// # Errors
    /// Any inconsistency (named).
    pub fn from_file(file: &SetupFile, folder: &Path) -> Result<Self> {
        let fs = file.controller.sample_rate_hz;
        if !(fs.is_finite() && fs > 0.0) {
            return Err(setup_error("controller.sample_rate_hz must be > 0"));
        }
        let structure = match file.model.example.as_str() {
            "tyre" => tyre_structure(&file.model.tyre, 1.0 / fs)?,
            "aero" => aero_structure(&file.model.aero)?,
            "two-dof" => two_dof_structure(&file.model.two_dof)?,
            "custom" => custom_structure(file, 1.0 / fs, folder)?,
            other => {
                return Err(setup_error(format!(
                    "model example {other:?}: use \"tyre\", \"aero\", \"two-dof\" or \"custom\""
                )))
            }
        };
        if file.model.example != "custom"
            && (file.numerical.is_some() || file.physical.is_some() || file.interface.is_some())
        {
            return Err(setup_error(
                "[numerical], [physical] and [interface] belong to example = \"custom\"",
            ));
        }
        let control = match file.actuator.control.as_str() {
            "force" => ActuatorControl::Force,
            "position" => ActuatorControl::Position,
            other => {
                return Err(setup_error(format!(
                    "actuator.control {other:?}: use \"force\" or \"position\""
                )))
            }
        };
        let reference_actuator = file
            .actuator
            .reference
            .unwrap_or(ServoHydraulicActuator::REFERENCE);
        let position_servo = file
            .actuator
            .position_servo
            .unwrap_or(PositionServoActuator::REFERENCE);
        let (ref_p, ref_r) = match control {
            ActuatorControl::Force => (
                reference_actuator.tracking()?,
                reference_actuator.disturbance()?,
            ),
            ActuatorControl::Position => {
                (position_servo.tracking()?, position_servo.disturbance()?)
            }
        };
        let loop_delay_s = file.actuator.loop_delay_s.unwrap_or(1.5 / fs);
        let actuators = Actuators {
            control,
            tracking: response(&file.actuator.tracking, ref_p, folder, "tracking")?,
            disturbance: response(&file.actuator.disturbance, ref_r, folder, "disturbance")?,
            transform: DMatrix::identity(1, 1),
            loop_delay_s,
        };
        let mut system = structure.with_actuators(actuators);
        if file.model.example == "tyre" && control == ActuatorControl::Position {
            // Under position control (configuration 3) the numerical tyre turns the measured
            // force into a position through B_i⁻¹ (integrated, no velocity estimate): what
            // the board computes is then modelled by the continuous B_i.
            system.interface.velocity = VelocityEstimate::Continuous;
        }
        if let Some(filter) = &file.controller.filter {
            let (ff, cascade) = FilterFile::read(&folder.join(filter))?;
            if (ff.sample_rate_hz - fs).abs() > 1e-9 * fs {
                return Err(setup_error(format!(
                    "controller.filter {} is for {} Hz, the controller runs at {fs} Hz",
                    filter.display(),
                    ff.sample_rate_hz
                )));
            }
            system.filter = Some(CommandFilter::Discrete {
                cascade,
                sample_period_s: 1.0 / fs,
            });
        }
        system.validate()?;
        if let Some(c) = file.configuration {
            if c != system.configuration() {
                return Err(setup_error(format!(
                    "configuration = {c} but the model and actuators make configuration {}",
                    system.configuration()
                )));
            }
        }
        let a = &file.analysis;
        let nyquist = fs / 2.0;
        let mut responses = Vec::new();
        for r in &a.responses {
            let input = system
                .inputs
                .iter()
                .position(|i| i.name == r.input)
                .ok_or_else(|| {
                    setup_error(format!(
                        "analysis.responses {:?}: no input {:?} (inputs: {:?})",
                        r.name,
                        r.input,
                        system.inputs.iter().map(|i| &i.name).collect::<Vec<_>>()
                    ))
                })?;
            responses.push(ResponseSpec {
                name: r.name.clone(),
                input,
                output: Signal::parse(&r.output, &system)?,
                display_scale: r.scale,
                display_unit: r.unit.clone(),
            });
        }
        if responses.is_empty() {
            return Err(setup_error(
                "analysis.responses: give at least one response",
            ));
        }
        if !(file.noise.rms.is_finite() && file.noise.rms >= 0.0) {
            return Err(setup_error(
                "the measurement noise (sensors noise_rms) must be >= 0",
            ));
        }
        let options = AnalysisOptions {
            f_min_hz: a.f_min_hz,
            f_max_hz: a.f_max_hz.unwrap_or(nyquist),
            points_per_decade: a.points_per_decade.max(10),
            bands: a.bands.iter().map(|b| (b[0], b[1])).collect(),
            responses,
            min_prominence_db: a.min_prominence_db,
            noise_rms: file.noise.rms,
            nyquist_hz: nyquist,
        };
        Ok(Self {
            name: file.name.clone(),
            system,
            options,
            sample_rate_hz: fs,
            reference_actuator,
            position_servo,
        })
    }
}
