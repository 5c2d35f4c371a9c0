//! The structure file (TOML) and the validated [`Model`]: one schema for the simulated rig's
//! specimens, diagnosis' models and the analysis' mechanical parts.
//!
//! ```toml
//! name = "oscillator"
//! gravity_m_per_s2 = 9.81      # optional: gravity on the translation DOFs (up positive)
//!
//! [[dof]]                      # a generalised coordinate: a node's displacement (m) or a rotation (rad)
//! name = "x"
//! mass = 2.0                   # kg (kg m² with kind = "rotation")
//!
//! [[point]]                    # optional: a point moving with the DOFs, pos = Σ c_i q_i
//! name = "front_axle"
//! position = { z_b = 1.0, theta_b = -1.8 }
//!
//! [[element]]                  # spring-damper between two of: DOF, point, displacement input, "ground"
//! name = "spring"
//! upper = "x"
//! lower = "ground"             # compression x = pos(lower) - pos(upper)
//! stiffness_n_per_m = 5e4
//! damping_n_s_per_m = 10.0
//!
//! [[input]]
//! name = "u"
//! kind = "force"               # or "displacement" (then usable as an element end)
//! column = "u"
//! at = "x"                     # force inputs: the DOF or point it pushes (positive along it)
//!
//! [[output]]
//! column = "y"
//! kind = "displacement"        # velocity, acceleration (of a DOF or point), force (of an element)
//! of = "x"
//!
//! [[effect]]                   # optional: effects already in the model
//! effect = "cubic_stiffness"
//! element = "spring"           # element or input name
//! parameters = { stiffness_n_per_m3 = 1e9 }
//! ```
//!
//! Effect names, parameters and laws are `mil-structure`'s ([`EffectKind`]), the ones the
//! simulated rig runs. `lift_off` takes no parameters: the static load it lifts off from is
//! the element's preload.
//!
//! Positions are deviations from the static equilibrium. The static loads are stated once:
//! with `gravity_m_per_s2`, the translation DOFs' weights `m g` (downwards: DOFs are up
//! positive), and a force input's `static_n` (the force it applies at rest, e.g. the
//! actuator a quarter car hangs on), are carried by the elements, whose preloads follow from
//! the linear static solution `K u = f` (`f` the weights and static input forces per DOF,
//! `P_e = k_e a_e·u`; least squares when only the force inputs hold a DOF, and then `f` must
//! balance) unless the file states them (`preload_n` on the elements), which must then
//! balance `f` (within 1 %). Without static loads the preloads are the stated ones
//! (default 0).
//!
//! Unknown keys are errors. `gain` (default 1) scales a column into the SI quantity the model
//! uses (`value = gain × column`) for inputs, and the model's quantity into the column for
//! outputs (`column = gain × value`). A DOF may carry a constant generalised force `bias_n`
//! (N or N·m, default 0), e.g. a force offset.

use crate::effects::{EffectKind, ElementLaw, InputLaw};
use crate::plausible::{self, LoadedElement, Mode};
use crate::{Error, Result};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;

/// The model file as written (see the module documentation).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModelFile {
    /// Model name, for reports.
    pub name: String,
    /// Free text.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub description: Option<String>,
    /// Gravity (m/s², >= 0) on the translation DOFs, downwards; none by default.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gravity_m_per_s2: Option<f64>,
    /// Generalised coordinates (DOFs).
    #[serde(rename = "dof")]
    pub dofs: Vec<DofSpec>,
    /// Points that move with the DOFs.
    #[serde(default, rename = "point", skip_serializing_if = "Vec::is_empty")]
    pub points: Vec<PointSpec>,
    /// Spring-damper elements.
    #[serde(default, rename = "element")]
    pub elements: Vec<ElementSpec>,
    /// Inputs mapped to CSV columns.
    #[serde(default, rename = "input")]
    pub inputs: Vec<InputSpec>,
    /// Measured outputs mapped to CSV columns.
    #[serde(default, rename = "output")]
    pub outputs: Vec<OutputSpec>,
    /// Effects attached to elements or inputs.
    #[serde(default, rename = "effect", skip_serializing_if = "Vec::is_empty")]
    pub effects: Vec<EffectSpec>,
}

/// Kind of a DOF.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DofKind {
    /// A displacement (m); mass in kg.
    #[default]
    Translation,
    /// A rotation (rad); mass is the inertia in kg·m².
    Rotation,
}

/// A DOF with its (diagonal) mass.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DofSpec {
    /// Name (also usable as an element end, force input point and output).
    pub name: String,
    /// Mass (kg) or inertia (kg·m²), > 0.
    pub mass: f64,
    /// Translation (default) or rotation.
    #[serde(default, skip_serializing_if = "is_default")]
    pub kind: DofKind,
    /// Constant generalised force on the DOF (N or N·m), e.g. an offset; default 0.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub bias_n: f64,
}

/// A point `pos = Σ c_i q_i` (m).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PointSpec {
    /// Name.
    pub name: String,
    /// Coefficient per DOF name (m/m or m/rad).
    pub position: BTreeMap<String, f64>,
}

/// A spring-damper element.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ElementSpec {
    /// Name.
    pub name: String,
    /// Upper end: DOF, point, displacement input or `ground`.
    pub upper: String,
    /// Lower end; compression `x = pos(lower) − pos(upper)` (m).
    pub lower: String,
    /// Linear stiffness `k` (N/m), >= 0, default 0.
    #[serde(default)]
    pub stiffness_n_per_m: f64,
    /// Linear damping `c` (N·s/m), >= 0, default 0.
    #[serde(default)]
    pub damping_n_s_per_m: f64,
    /// Static force (N, positive in compression) the element carries at equilibrium,
    /// default 0; the load a `lift_off` effect lifts off from (>= 0 with it).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub preload_n: f64,
}

/// Kind of an input.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum InputKind {
    /// A prescribed displacement (m), e.g. the road under a tyre.
    Displacement,
    /// A prescribed force (N) at a DOF or point.
    Force,
}

/// An input mapped to a CSV column.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InputSpec {
    /// Name (a displacement input is usable as an element end).
    pub name: String,
    /// Displacement or force.
    pub kind: InputKind,
    /// CSV column.
    pub column: String,
    /// Force inputs: the DOF or point the force acts at, along its positive direction.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub at: Option<String>,
    /// SI value per column unit (default 1).
    #[serde(default = "one", skip_serializing_if = "is_one")]
    pub gain: f64,
    /// Force inputs: the force it applies at rest (N, along `at`), e.g. the actuator that
    /// holds the specimen on the rig; the elements' preloads balance it with the weights
    /// (default 0).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub static_n: f64,
}

/// Measured quantity of an output.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum OutputKind {
    /// Displacement of a DOF or point (m).
    Displacement,
    /// Velocity of a DOF or point (m/s).
    Velocity,
    /// Acceleration of a DOF or point (m/s²).
    Acceleration,
    /// Force of an element (N, positive in compression).
    Force,
}

/// A measured output mapped to a CSV column.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutputSpec {
    /// CSV column.
    pub column: String,
    /// Measured quantity.
    pub kind: OutputKind,
    /// DOF or point (motion), element (force).
    pub of: String,
    /// Column units per SI unit (default 1).
    #[serde(default = "one", skip_serializing_if = "is_one")]
    pub gain: f64,
}

/// An effect attached to an element or input.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EffectSpec {
    /// Identifier.
    pub effect: EffectKind,
    /// Element or input name.
    pub element: String,
    /// Parameters (SI names, see [`EffectKind`]).
    #[serde(default)]
    pub parameters: BTreeMap<String, f64>,
}

/// The elements' preloads (see the module documentation): the static `loads` per DOF (the
/// weights and the force inputs' `static_n`) checked against the stated preloads, or
/// carried by preloads derived from the linear static solution when none is stated. A
/// structure held by its force inputs alone (no spring to ground: the stiffness matrix is
/// singular) is solved in the least-squares sense and must balance.
fn preloads(file: &ModelFile, elements: &mut [Element], loads: &[f64]) -> Result<()> {
    let n = loads.len();
    let total: f64 = loads.iter().map(|f| f.abs()).sum();
    let g = file.gravity_m_per_s2.unwrap_or(0.0);
    let held = file.inputs.iter().any(|i| i.static_n != 0.0);
    let load_names = if held {
        "its weight with the force inputs' static_n"
    } else {
        "its weight"
    };
    if elements.iter().any(|e| e.preload_n != 0.0) {
        if file.gravity_m_per_s2.is_none() && !held {
            return Ok(());
        }
        let stated: Vec<(&[f64], f64)> = elements.iter().map(|e| (&e.a[..], e.preload_n)).collect();
        if let Some((i, carried)) = unbalanced(loads, &stated) {
            let in_kg = g > 0.0 && (carried * g - loads[i]).abs() < 0.01 * total;
            return Err(Error::Model(format!(
                "the elements' preload_n carry {:.1} N at dof {:?}, but the static load there \
                 is {:.1} N ({load_names}, gravity_m_per_s2 = {g}){}: state every preload_n in \
                 N so that they balance the static loads, or leave them all out and they \
                 follow from them",
                -carried,
                file.dofs[i].name,
                -loads[i],
                if in_kg {
                    " -- preloads given in kg?"
                } else {
                    ""
                }
            )));
        }
        return Ok(());
    }
    if total == 0.0 {
        return Ok(());
    }
    let mut k = nalgebra::DMatrix::<f64>::zeros(n, n);
    for e in elements.iter() {
        k += e.law.k
            * nalgebra::DVector::from_column_slice(&e.a)
            * nalgebra::RowDVector::from_row_slice(&e.a);
    }
    let f = nalgebra::DVector::from_column_slice(loads);
    let u = match k.clone().lu().solve(&f) {
        Some(u) => u,
        None => {
            // Held (partly) by the force inputs: the least-squares solution, checked below.
            let svd = k.svd(true, true);
            let eps = 1e-12 * svd.singular_values.max();
            svd.solve(&f, eps)
                .map_err(|e| Error::Model(e.to_string()))?
        }
    };
    for e in elements.iter_mut() {
        e.preload_n = e.law.k * e.a.iter().zip(u.iter()).map(|(a, u)| a * u).sum::<f64>();
    }
    let derived: Vec<(&[f64], f64)> = elements.iter().map(|e| (&e.a[..], e.preload_n)).collect();
    if let Some((i, carried)) = unbalanced(loads, &derived) {
        return Err(Error::Model(format!(
            "the springs carry {:.1} N at dof {:?}, but the static load there is {:.1} N \
             ({load_names}; the stiffness matrix is singular): add the springs that carry the weight, give \
             the force input that holds it its static_n, or state each element's preload_n",
            -carried, file.dofs[i].name, -loads[i],
        )));
    }
    Ok(())
}

/// The weights `−m g` per DOF (translations; a rotation's inertia has none) with gravity
/// `g` (m/s²).
fn weights(dofs: &[DofSpec], g: f64) -> Vec<f64> {
    dofs.iter()
        .map(|d| match d.kind {
            DofKind::Translation => -d.mass * g,
            DofKind::Rotation => 0.0,
        })
        .collect()
}

/// The first DOF whose weight `weights[i]` the preloads `(a_e, P_e)` do not carry
/// (`Σ a_e[i] P_e`) within 1 % of the total weight, with what they carry there.
fn unbalanced(weights: &[f64], loads: &[(&[f64], f64)]) -> Option<(usize, f64)> {
    let total: f64 = weights.iter().map(|w| w.abs()).sum();
    weights.iter().enumerate().find_map(|(i, w)| {
        let carried: f64 = loads.iter().map(|(a, p)| a[i] * p).sum();
        ((w - carried).abs() > 0.01 * total.max(f64::MIN_POSITIVE)).then_some((i, carried))
    })
}

/// The linearised structure `M q̈ + C q̇ + K q = K_w w + C_w ẇ + T f + bias` about the
/// static equilibrium, with `w` the displacement inputs and `f` the force inputs (each in
/// the file's input order; a force input's column of `K_w`, `C_w` and a displacement
/// input's column of `T` are zero). Elements enter with their small-signal stiffness and
/// damping ([`ElementLaw::linearised`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Linearised {
    /// `M` (kg, kg·m²), diagonal.
    pub mass: nalgebra::DMatrix<f64>,
    /// `C` (N·s/m).
    pub damping: nalgebra::DMatrix<f64>,
    /// `K` (N/m).
    pub stiffness: nalgebra::DMatrix<f64>,
    /// `K_w` (N/m), DOFs × inputs.
    pub input_stiffness: nalgebra::DMatrix<f64>,
    /// `C_w` (N·s/m), DOFs × inputs.
    pub input_damping: nalgebra::DMatrix<f64>,
    /// `T` (-), DOFs × inputs.
    pub force_input: nalgebra::DMatrix<f64>,
}

fn one() -> f64 {
    1.0
}
fn is_one(v: &f64) -> bool {
    *v == 1.0
}
fn is_zero(v: &f64) -> bool {
    *v == 0.0
}
fn is_default<T: Default + PartialEq>(v: &T) -> bool {
    *v == T::default()
}

/// A validated element: compression `x = a·q + b·w` over DOFs `q` and displacement inputs
/// `w`.
#[derive(Clone, Debug, PartialEq)]
pub struct Element {
    /// Name.
    pub name: String,
    /// Compression per unit of each DOF (m/m, m/rad).
    pub a: Vec<f64>,
    /// Compression per unit of each input (m/m; 0 for force inputs).
    pub b: Vec<f64>,
    /// Force law (relative to the static equilibrium).
    pub law: ElementLaw,
    /// Static force (N, compression) at equilibrium: stated, or carried weight (see the
    /// module documentation).
    pub preload_n: f64,
}

/// A validated input.
#[derive(Clone, Debug, PartialEq)]
pub struct Input {
    /// Name.
    pub name: String,
    /// Kind.
    pub kind: InputKind,
    /// CSV column.
    pub column: String,
    /// SI value per column unit.
    pub gain: f64,
    /// Force inputs: generalised force per unit force on each DOF; empty for displacement.
    pub t: Vec<f64>,
    /// Force inputs: the force applied at rest (N), which the preloads balance.
    pub static_n: f64,
    /// Input effects.
    pub law: InputLaw,
}

/// What an output measures.
#[derive(Clone, Debug, PartialEq)]
pub enum Target {
    /// A motion `c·q` (and its derivatives) with coefficients `c` per DOF.
    Motion(Vec<f64>),
    /// The force of element `e`.
    Element(usize),
}

/// A validated output.
#[derive(Clone, Debug, PartialEq)]
pub struct Output {
    /// CSV column.
    pub column: String,
    /// Quantity.
    pub kind: OutputKind,
    /// What it measures.
    pub target: Target,
    /// Column units per SI unit.
    pub gain: f64,
}

/// A validated model: diagonal mass matrix, elements, inputs and outputs.
#[derive(Clone, Debug, PartialEq)]
pub struct Model {
    /// The file it came from (kept to write the updated model back).
    pub file: ModelFile,
    /// DOF names.
    pub dofs: Vec<String>,
    /// Mass per DOF (kg or kg·m²).
    pub mass: Vec<f64>,
    /// Constant generalised force per DOF (N or N·m).
    pub bias: Vec<f64>,
    /// Kind per DOF.
    pub kinds: Vec<DofKind>,
    /// Static generalised force per DOF (N or N·m) the elements' preloads balance: the
    /// weight `−m g` of translation DOFs with gravity, else 0.
    pub static_force: Vec<f64>,
    /// Elements.
    pub elements: Vec<Element>,
    /// Inputs.
    pub inputs: Vec<Input>,
    /// Outputs.
    pub outputs: Vec<Output>,
}

impl Model {
    /// Parses and validates a model file's text.
    ///
    /// # Errors
    /// TOML syntax, unknown keys, unknown names, non-physical values — each named.
    pub fn from_toml(text: &str) -> Result<Self> {
        let file: ModelFile = toml::from_str(text).map_err(|e| Error::Model(e.to_string()))?;
        Self::new(file)
    }

    /// Reads and validates a model file.
    ///
    /// # Errors
    /// As [`Model::from_toml`], or the file cannot be read.
    pub fn read(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|source| Error::Io {
            path: path.display().to_string(),
            source,
        })?;
        Self::from_toml(&text).map_err(|e| match e {
            // Keep one "model:" prefix: the file name goes after it.
            Error::Model(m) => Error::Model(format!("{}: {m}", path.display())),
            other => other,
        })
    }

    /// Validates a parsed model file.
    ///
    /// # Errors
    /// Unknown names, duplicates, non-physical values — each named.
    pub fn new(file: ModelFile) -> Result<Self> {
        let err = |m: String| Err(Error::Model(m));
        let n = file.dofs.len();
        if n == 0 {
            return err("no [[dof]]".into());
        }
        let mut names: Vec<String> = vec!["ground".into()];
        let unique = |names: &mut Vec<String>, what: &str, s: &str| -> Result<()> {
            if s.is_empty() {
                return Err(Error::Model(format!("{what} with an empty name")));
            }
            if names.iter().any(|x| x == s) {
                return Err(Error::Model(format!("{what} {s:?}: name already used")));
            }
            names.push(s.to_string());
            Ok(())
        };
        let dofs: Vec<String> = file.dofs.iter().map(|d| d.name.clone()).collect();
        for d in &file.dofs {
            unique(&mut names, "dof", &d.name)?;
            if !(d.mass.is_finite() && d.mass > 0.0) {
                return err(format!(
                    "dof {:?}: mass must be > 0, got {}",
                    d.name, d.mass
                ));
            }
            if !d.bias_n.is_finite() {
                return err(format!("dof {:?}: bias_n must be finite", d.name));
            }
        }
        let mut points: BTreeMap<&str, Vec<f64>> = BTreeMap::new();
        for (i, d) in dofs.iter().enumerate() {
            let mut c = vec![0.0; n];
            c[i] = 1.0;
            points.insert(d, c);
        }
        for p in &file.points {
            unique(&mut names, "point", &p.name)?;
            let mut c = vec![0.0; n];
            for (dof, v) in &p.position {
                let Some(i) = dofs.iter().position(|d| d == dof) else {
                    return err(format!("point {:?}: unknown dof {dof:?}", p.name));
                };
                if !v.is_finite() {
                    return err(format!(
                        "point {:?}: coefficient of {dof} not finite",
                        p.name
                    ));
                }
                c[i] = *v;
            }
            points.insert(&p.name, c);
        }
        let m = file.inputs.len();
        let mut inputs = Vec::new();
        for inp in &file.inputs {
            unique(&mut names, "input", &inp.name)?;
            if !(inp.gain.is_finite() && inp.gain != 0.0) {
                return err(format!(
                    "input {:?}: gain must be finite, non-zero",
                    inp.name
                ));
            }
            let t = match (inp.kind, &inp.at) {
                (InputKind::Force, Some(at)) => match points.get(at.as_str()) {
                    Some(c) => c.clone(),
                    None => {
                        return err(format!(
                            "input {:?}: `at` {at:?} is not a dof or point",
                            inp.name
                        ))
                    }
                },
                (InputKind::Force, None) => {
                    return err(format!("force input {:?} needs `at`", inp.name))
                }
                (InputKind::Displacement, Some(_)) => {
                    return err(format!(
                    "displacement input {:?}: `at` is for force inputs (use it as an element end)",
                    inp.name
                ))
                }
                (InputKind::Displacement, None) => Vec::new(),
            };
            if !inp.static_n.is_finite()
                || (inp.kind == InputKind::Displacement && inp.static_n != 0.0)
            {
                return err(format!(
                    "input {:?}: static_n must be finite, and is for force inputs only",
                    inp.name
                ));
            }
            inputs.push(Input {
                name: inp.name.clone(),
                kind: inp.kind,
                column: inp.column.clone(),
                gain: inp.gain,
                t,
                static_n: inp.static_n,
                law: InputLaw::default(),
            });
        }
        let end = |s: &str, elem: &str| -> Result<(Vec<f64>, Vec<f64>)> {
            if s == "ground" {
                return Ok((vec![0.0; n], vec![0.0; m]));
            }
            if let Some(c) = points.get(s) {
                return Ok((c.clone(), vec![0.0; m]));
            }
            if let Some(j) = inputs.iter().position(|i| i.name == s) {
                if inputs[j].kind == InputKind::Force {
                    return Err(Error::Model(format!(
                        "element {elem:?}: end {s:?} is a force input, not a position"
                    )));
                }
                let mut b = vec![0.0; m];
                b[j] = 1.0;
                return Ok((vec![0.0; n], b));
            }
            Err(Error::Model(format!(
                "element {elem:?}: end {s:?} is not a dof, point, displacement input or ground"
            )))
        };
        let mut elements = Vec::new();
        for e in &file.elements {
            unique(&mut names, "element", &e.name)?;
            for (what, v) in [
                ("stiffness_n_per_m", e.stiffness_n_per_m),
                ("damping_n_s_per_m", e.damping_n_s_per_m),
            ] {
                if !(v.is_finite() && v >= 0.0) {
                    return err(format!(
                        "element {:?}: {what} must be >= 0, got {v}",
                        e.name
                    ));
                }
            }
            if !e.preload_n.is_finite() {
                return err(format!(
                    "element {:?}: preload_n must be finite, got {}",
                    e.name, e.preload_n
                ));
            }
            let (au, bu) = end(&e.upper, &e.name)?;
            let (al, bl) = end(&e.lower, &e.name)?;
            let a: Vec<f64> = al.iter().zip(&au).map(|(l, u)| l - u).collect();
            let b: Vec<f64> = bl.iter().zip(&bu).map(|(l, u)| l - u).collect();
            if a.iter().all(|v| *v == 0.0) {
                return err(format!(
                    "element {:?}: both ends are fixed (no DOF moves it)",
                    e.name
                ));
            }
            elements.push(Element {
                name: e.name.clone(),
                a,
                b,
                law: ElementLaw::linear(e.stiffness_n_per_m, e.damping_n_s_per_m),
                preload_n: e.preload_n,
            });
        }
        let mut outputs = Vec::new();
        for o in &file.outputs {
            if !(o.gain.is_finite() && o.gain != 0.0) {
                return err(format!(
                    "output {:?}: gain must be finite, non-zero",
                    o.column
                ));
            }
            let target = match o.kind {
                OutputKind::Force => match elements.iter().position(|e| e.name == o.of) {
                    Some(i) => Target::Element(i),
                    None => {
                        return err(format!(
                            "output {:?}: force of {:?}, which is not an element",
                            o.column, o.of
                        ))
                    }
                },
                _ => match points.get(o.of.as_str()) {
                    Some(c) => Target::Motion(c.clone()),
                    None => {
                        return err(format!(
                            "output {:?}: {:?} is not a dof or point",
                            o.column, o.of
                        ))
                    }
                },
            };
            outputs.push(Output {
                column: o.column.clone(),
                kind: o.kind,
                target,
                gain: o.gain,
            });
        }
        let kinds: Vec<DofKind> = file.dofs.iter().map(|d| d.kind).collect();
        let static_force: Vec<f64> = match file.gravity_m_per_s2 {
            None => vec![0.0; n],
            Some(g) if g.is_finite() && g >= 0.0 => weights(&file.dofs, g),
            Some(g) => return err(format!("gravity_m_per_s2 must be >= 0, got {g}")),
        };
        let mut loads = static_force.clone();
        for i in &inputs {
            for (l, t) in loads.iter_mut().zip(&i.t) {
                *l += t * i.static_n;
            }
        }
        preloads(&file, &mut elements, &loads)?;
        let mut model = Model {
            dofs,
            mass: file.dofs.iter().map(|d| d.mass).collect(),
            bias: file.dofs.iter().map(|d| d.bias_n).collect(),
            kinds,
            static_force,
            elements,
            inputs,
            outputs,
            file: file.clone(),
        };
        for fx in &file.effects {
            model.add_effect(fx)?;
        }
        model.check_plausible()?;
        Ok(model)
    }

    /// The structure with force input `input` applying `static_n` (N) at rest: the file
    /// validated again, its preloads balancing the new static loads.
    ///
    /// # Errors
    /// No force input of that name, or static loads the preloads cannot balance.
    pub fn with_static_n(&self, input: &str, static_n: f64) -> Result<Self> {
        let mut file = self.file.clone();
        let spec = file
            .inputs
            .iter_mut()
            .find(|i| i.name == input && i.kind == InputKind::Force)
            .ok_or_else(|| Error::Model(format!("no force input {input:?}")))?;
        spec.static_n = static_n;
        Self::new(file)
    }

    /// Whether `name` is one of the inputs (else an element, if anything).
    pub fn is_input(&self, name: &str) -> bool {
        self.inputs.iter().any(|i| i.name == name)
    }

    /// Attaches an effect (replacing one of the same kind on the same target).
    ///
    /// # Errors
    /// Unknown target or bad parameters.
    pub fn add_effect(&mut self, fx: &EffectSpec) -> Result<()> {
        let wrap = |e: Error, fx: &EffectSpec| match e {
            Error::Model(m) => Error::Model(format!("effect on {:?}: {m}", fx.element)),
            other => other,
        };
        let on_input = self.is_input(&fx.element);
        if !on_input && !self.elements.iter().any(|e| e.name == fx.element) {
            return Err(Error::Model(format!(
                "effect {}: {:?} is neither an element nor an input",
                fx.effect, fx.element
            )));
        }
        let (fits, is, other) = if on_input {
            (fx.effect.fits_input(), "an input", "an element")
        } else {
            (fx.effect.fits_element(), "an element", "an input")
        };
        if !fits {
            return Err(Error::Model(format!(
                "effect {}: {:?} is {is}; {} attaches to {other}",
                fx.effect, fx.element, fx.effect
            )));
        }
        if on_input {
            let inp = self
                .inputs
                .iter_mut()
                .find(|i| i.name == fx.element)
                .ok_or_else(|| Error::Model(format!("{:?} is not an input", fx.element)))?;
            if fx.effect == EffectKind::Backlash && inp.kind != InputKind::Displacement {
                return Err(Error::Model(format!(
                    "effect backlash on {:?}: free play needs a displacement input, this one is a \
                     force",
                    fx.element
                )));
            }
            inp.law
                .apply(fx.effect, &fx.parameters)
                .map_err(|e| wrap(e, fx))
        } else {
            let Some(el) = self.elements.iter_mut().find(|e| e.name == fx.element) else {
                return Err(Error::Model(format!(
                    "effect {}: {:?} is not an element",
                    fx.effect, fx.element
                )));
            };
            let parameters = if fx.effect == EffectKind::LiftOff {
                // The load it lifts off from is the element's `preload_n`, stated once.
                if let Some(key) = fx.parameters.keys().next() {
                    return Err(Error::Model(format!(
                        "effect lift_off on {:?} takes no parameters (got {key:?}): give the \
                         static load as the element's preload_n",
                        fx.element
                    )));
                }
                [("preload_n".to_string(), el.preload_n)].into()
            } else {
                fx.parameters.clone()
            };
            el.law.remove(fx.effect);
            el.law
                .apply(fx.effect, &parameters)
                .map_err(|e| wrap(e, fx))
        }
    }

    /// Every effect that is on, as file entries (`lift_off` without parameters: its
    /// preload is the element's, [`Model::to_file`]).
    pub fn effect_specs(&self) -> Vec<EffectSpec> {
        let mut out = Vec::new();
        for e in &self.elements {
            for k in e.law.kinds() {
                if k == EffectKind::LiftOff {
                    out.push(EffectSpec {
                        effect: k,
                        element: e.name.clone(),
                        parameters: BTreeMap::new(),
                    });
                } else if let Some(p) = e.law.parameters(k) {
                    out.push(EffectSpec {
                        effect: k,
                        element: e.name.clone(),
                        parameters: p,
                    });
                }
            }
        }
        for i in &self.inputs {
            for k in i.law.kinds() {
                if let Some(p) = i.law.parameters(k) {
                    out.push(EffectSpec {
                        effect: k,
                        element: i.name.clone(),
                        parameters: p,
                    });
                }
            }
        }
        out
    }

    /// The model file with the current parameters and effects.
    pub fn to_file(&self) -> ModelFile {
        let mut f = self.file.clone();
        for (d, (m, b)) in f.dofs.iter_mut().zip(self.mass.iter().zip(&self.bias)) {
            d.mass = *m;
            d.bias_n = *b;
        }
        for (spec, e) in f.elements.iter_mut().zip(&self.elements) {
            spec.stiffness_n_per_m = e.law.stiffness_total();
            spec.damping_n_s_per_m = e.law.c;
            // A fitted lift-off preload is written where the file states preloads; with
            // gravity and derived preloads the weights fix them (the fit's value is in the
            // report).
            if let Some(preload) = e.law.lift_off {
                if f.gravity_m_per_s2.is_none() {
                    spec.preload_n = preload;
                }
            }
        }
        if let Some(g) = f.gravity_m_per_s2 {
            // Force inputs that hold the structure carry the recalibrated weight: their
            // static forces scale with it.
            let weight = |dofs: &[DofSpec]| weights(dofs, g).iter().sum::<f64>();
            let (before, after) = (weight(&self.file.dofs), weight(&f.dofs));
            if before != 0.0 && after != before {
                for spec in &mut f.inputs {
                    spec.static_n *= after / before;
                }
            }
            // Stated preloads that no longer carry the (recalibrated) weights go: they then
            // follow from gravity.
            let stated = f.elements.iter().any(|spec| spec.preload_n != 0.0);
            let stated_loads: Vec<(&[f64], f64)> = f
                .elements
                .iter()
                .zip(&self.elements)
                .map(|(spec, e)| (&e.a[..], spec.preload_n))
                .collect();
            let mut loads = weights(&f.dofs, g);
            for (spec, input) in f.inputs.iter().zip(&self.inputs) {
                for (l, t) in loads.iter_mut().zip(&input.t) {
                    *l += t * spec.static_n;
                }
            }
            if stated && unbalanced(&loads, &stated_loads).is_some() {
                for spec in &mut f.elements {
                    spec.preload_n = 0.0;
                }
            }
        }
        f.effects = self.effect_specs();
        f
    }

    /// The model file's text with the current parameters and effects.
    pub fn to_toml(&self) -> String {
        toml::to_string(&self.to_file()).unwrap_or_else(|e| format!("# not serialisable: {e}\n"))
    }

    /// The undamped modes the springs restrain (small-signal stiffnesses, [`Model::linearised`]),
    /// by ascending frequency; unrestrained directions (a free mass) have none
    /// ([`plausible::modes`]).
    pub fn modes(&self) -> Vec<Mode> {
        plausible::modes(self.linearised().stiffness, &self.mass)
    }

    /// The physical plausibility every structure must pass ([`crate::plausible`]): the static
    /// compressions under the weights, then the natural frequencies.
    fn check_plausible(&self) -> Result<()> {
        let elements = self.elements.iter().map(|e| LoadedElement {
            name: &e.name,
            preload_n: e.preload_n,
            stiffness_n_per_m: e.law.linearised().0,
        });
        plausible::static_compression(self.file.gravity_m_per_s2, elements)?;
        plausible::natural_frequencies(&self.modes(), &self.dofs, &self.mass)
    }

    /// The linearised structure (see [`Linearised`]).
    pub fn linearised(&self) -> Linearised {
        let (n, m) = (self.n(), self.inputs.len());
        let mut l = Linearised {
            mass: nalgebra::DMatrix::from_diagonal(&nalgebra::DVector::from_column_slice(
                &self.mass,
            )),
            damping: nalgebra::DMatrix::zeros(n, n),
            stiffness: nalgebra::DMatrix::zeros(n, n),
            input_stiffness: nalgebra::DMatrix::zeros(n, m),
            input_damping: nalgebra::DMatrix::zeros(n, m),
            force_input: nalgebra::DMatrix::zeros(n, m),
        };
        for e in &self.elements {
            let (k, c) = e.law.linearised();
            let a = nalgebra::DVector::from_column_slice(&e.a);
            let b = nalgebra::RowDVector::from_row_slice(&e.b);
            let aat = &a * a.transpose();
            l.stiffness += k * &aat;
            l.damping += c * &aat;
            l.input_stiffness -= k * &a * &b;
            l.input_damping -= c * &a * &b;
        }
        for (j, input) in self.inputs.iter().enumerate() {
            for (i, t) in input.t.iter().enumerate() {
                l.force_input[(i, j)] = *t;
            }
        }
        l
    }

    /// The coefficients `c` of DOF or point `name` (`pos = c·q`), or `None` if it is
    /// neither.
    pub fn position_of(&self, name: &str) -> Option<Vec<f64>> {
        let n = self.n();
        if let Some(i) = self.dofs.iter().position(|d| d == name) {
            let mut c = vec![0.0; n];
            c[i] = 1.0;
            return Some(c);
        }
        let point = self.file.points.iter().find(|p| p.name == name)?;
        Some(
            self.dofs
                .iter()
                .map(|d| point.position.get(d).copied().unwrap_or(0.0))
                .collect(),
        )
    }

    /// The elements' static preloads (N, compression), in element order.
    pub fn preloads(&self) -> Vec<f64> {
        self.elements.iter().map(|e| e.preload_n).collect()
    }

    /// Number of DOFs.
    pub fn n(&self) -> usize {
        self.dofs.len()
    }

    /// The slowest decay time (s) of the linear part of the model, `1 / min |Re λ|` over
    /// the eigenvalues `λ` of `[0 I; −M⁻¹K −M⁻¹C]` (`K = Σ k_e a_e a_eᵀ` with each
    /// element's total linear stiffness, `C` likewise with its linear damping): how long an
    /// error in the initial state takes to fall by `e`. `None` when a mode does not decay
    /// (an undamped or unrestrained direction, a non-positive mass).
    pub fn slowest_decay_s(&self) -> Option<f64> {
        let n = self.n();
        if n == 0 || !self.mass.iter().all(|m| *m > 0.0) {
            return None;
        }
        let mut a = nalgebra::DMatrix::<f64>::zeros(2 * n, 2 * n);
        for i in 0..n {
            a[(i, n + i)] = 1.0;
        }
        for e in &self.elements {
            let (k, c) = (e.law.stiffness_total(), e.law.c);
            for i in 0..n {
                for j in 0..n {
                    a[(n + i, j)] -= k * e.a[i] * e.a[j] / self.mass[i];
                    a[(n + i, n + j)] -= c * e.a[i] * e.a[j] / self.mass[i];
                }
            }
        }
        if !a.iter().all(|v| v.is_finite()) {
            return None;
        }
        let eig = a.complex_eigenvalues();
        let fastest = eig.iter().map(|l| l.norm()).fold(0.0, f64::max);
        let slowest = eig.iter().map(|l| -l.re).fold(f64::INFINITY, f64::min);
        // (A rate below 1e-9 of the fastest mode is a root at 0 or on the imaginary axis.)
        (slowest > 1e-9 * fastest && slowest.is_finite()).then(|| 1.0 / slowest)
    }

    /// Whether the linear stiffness matrix `Σ k_e a_e a_eᵀ` is positive definite, i.e.
    /// every DOF is restrained and a free simulation of the model settles (with damping).
    /// A free mass driven by a force (no spring to ground) is not.
    pub fn is_restrained(&self) -> bool {
        let n = self.n();
        let mut k = nalgebra::DMatrix::<f64>::zeros(n, n);
        for e in &self.elements {
            let kk = e.law.stiffness_total().max(e.law.k);
            for i in 0..n {
                for j in 0..n {
                    k[(i, j)] += kk * e.a[i] * e.a[j];
                }
            }
        }
        // Scale by the masses to compare DOFs of different units.
        for i in 0..n {
            for j in 0..n {
                k[(i, j)] /= (self.mass[i] * self.mass[j]).sqrt();
            }
        }
        let eig = k.symmetric_eigenvalues();
        let max = eig.iter().cloned().fold(0.0, f64::max);
        max > 0.0 && eig.iter().all(|&v| v > 1e-9 * max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn oscillator(m: f64, k: f64, c: f64) -> Model {
        Model::from_toml(&format!(
            "name = \"o\"\n[[dof]]\nname = \"x\"\nmass = {m}\n\
             [[element]]\nname = \"s\"\nupper = \"x\"\nlower = \"ground\"\n\
             stiffness_n_per_m = {k}\ndamping_n_s_per_m = {c}\n\
             [[input]]\nname = \"f\"\nkind = \"force\"\ncolumn = \"f\"\nat = \"x\"\n\
             [[output]]\ncolumn = \"x\"\nkind = \"displacement\"\nof = \"x\"\n"
        ))
        .expect("model")
    }

    /// An underdamped oscillator decays in `2 m / c`; an overdamped one at its slow root
    /// `(c − √(c² − 4 m k)) / (2 m)`; without damping or without a spring nothing decays.
    #[test]
    fn the_slowest_decay_is_that_of_the_slowest_root() {
        let decay = |m, k, c| oscillator(m, k, c).slowest_decay_s();
        let under = decay(76.0, 4.9e4, 176.0).expect("underdamped");
        assert!((under - 2.0 * 76.0 / 176.0).abs() < 1e-9 * under, "{under}");
        let (m, k, c) = (1.0, 100.0, 50.0);
        let over = decay(m, k, c).expect("overdamped");
        let slow = (c - (c * c - 4.0 * m * k).sqrt()) / (2.0 * m);
        assert!((over - 1.0 / slow).abs() < 1e-9 * over, "{over}");
        assert_eq!(decay(2.0, 1.0e4, 0.0), None);
        assert_eq!(decay(2.0, 0.0, 10.0), None);
    }
}
