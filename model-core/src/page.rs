//! The board's parameter set ([`BoardParams`]) as a flat table of 4-byte words: the one
//! description of every parameter that the calibration page, the A2L file, Command-frame
//! indices and `mil param` share.
//!
//! [`BoardParams::visit`] walks every field in declaration order (all fields are 4 bytes,
//! so [`WORDS`], the page's length, is the struct's size over 4: a test checks that every
//! field is visited once) and hands each to a closure with its [`ParamInfo`]: group, name
//! and indices, unit, allowed range and how it is read ([`WordKind`]). Word `i` of the page
//! is the `i`-th field visited. On the page every word is an IEEE `f32`; counts and
//! switches (`u32` fields) are written as the integral `f32` of their value, so a
//! calibration tool sees one data type.
//!
//! [`to_words`] and [`from_words`] convert; `from_words` checks each word against its item
//! (finite, in range, integral where a count) and names the first word it refuses, before
//! the set as a whole is validated by [`BoardParams::prepare`].

use crate::aero::{
    AERO_AXLE_DISTANCE, AERO_MAP_FORCE, AERO_NOMINAL_FORCE, AERO_REFERENCE_SPEED, AERO_RIDE_HEIGHT,
    AERO_STIFFNESS, MAP_POINTS,
};
use crate::biquad::{FILTER_ALPHA, FILTER_BETA};
use crate::board::{BoardParams, BOARD_CHANNELS};
use crate::controller::SAFE_RAMP_RATE;
use crate::element::{
    ELEMENT_CUBIC_STIFFNESS, ELEMENT_DAMPING, ELEMENT_FRICTION, ELEMENT_FRICTION_VELOCITY,
    ELEMENT_GAP, ELEMENT_PRELOAD, ELEMENT_QUADRATIC_DAMPING, ELEMENT_STIFFNESS,
};
use crate::limits::{DEMAND_AMPLITUDE, DEMAND_RATE};
use crate::params::Range;
use crate::substructure::{
    ELEMENT_COEFFICIENT, MAX_DOF, MAX_ELEMENTS, SUBSTRUCTURE_DAMPING, SUBSTRUCTURE_MASS,
    SUBSTRUCTURE_STIFFNESS,
};
use crate::tyre::{TYRE_DAMPING, TYRE_STATIC_LOAD, TYRE_STIFFNESS};
use crate::velocity::VELOCITY_CUTOFF;
use crate::MAX_SECTIONS;

/// Number of 4-byte words of [`BoardParams`].
pub const WORDS: usize = core::mem::size_of::<BoardParams>() / 4;

/// How a word is read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WordKind {
    /// A real value.
    Real,
    /// A whole number (a count, an index or a selector), stored as its `f32`.
    Integer,
    /// 0 or 1.
    Switch,
}

/// What one word is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParamInfo {
    /// Group: empty (the model selection), `tyre`, `aero`, `aero_map`, `substructure`,
    /// `element`, `filter`, `limits`.
    pub group: &'static str,
    /// Name within the group.
    pub name: &'static str,
    /// Indices (channel, row and column, element, section, …), the first `dims` used.
    pub index: [u8; 2],
    /// Number of indices used.
    pub dims: u8,
    /// SI unit, `-` for none.
    pub unit: &'static str,
    /// One line for a calibration tool.
    pub description: &'static str,
    /// How it is read.
    pub kind: WordKind,
    /// Lowest allowed value.
    pub min: f32,
    /// Highest allowed value.
    pub max: f32,
}

impl core::fmt::Display for ParamInfo {
    /// The name a calibration tool shows: group, name and indices joined by `_`
    /// (`tyre_stiffness_0`, `substructure_mass_1_1`, `model_kind`).
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        if !self.group.is_empty() {
            write!(f, "{}_", self.group)?;
        }
        f.write_str(self.name)?;
        for i in self.index.iter().take(usize::from(self.dims)) {
            write!(f, "_{i}")?;
        }
        Ok(())
    }
}

/// A field handed to the [`BoardParams::visit`] closure.
#[derive(Debug)]
pub enum WordMut<'a> {
    /// An `f32` field.
    Real(&'a mut f32),
    /// A `u32` field (a count, an index, a selector or a switch).
    Count(&'a mut u32),
}

/// Why [`from_words`] refused a page.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WordError {
    /// Word `0` is NaN or infinite.
    NotFinite(usize),
    /// Word `0` is outside its item's range, or not integral where it must be.
    OutOfRange(usize),
}

impl WordError {
    /// The word refused.
    pub fn word(&self) -> usize {
        match *self {
            WordError::NotFinite(w) | WordError::OutOfRange(w) => w,
        }
    }
}

const fn range(r: Range) -> (f32, f32) {
    (r.min, r.max)
}

/// An item without indices.
const fn item(
    group: &'static str,
    name: &'static str,
    unit: &'static str,
    description: &'static str,
    kind: WordKind,
    (min, max): (f32, f32),
) -> ParamInfo {
    ParamInfo {
        group,
        name,
        index: [0, 0],
        dims: 0,
        unit,
        description,
        kind,
        min,
        max,
    }
}

const fn at(mut i: ParamInfo, index: usize) -> ParamInfo {
    i.index = [index as u8, 0];
    i.dims = 1;
    i
}

const fn at2(mut i: ParamInfo, a: usize, b: usize) -> ParamInfo {
    i.index = [a as u8, b as u8];
    i.dims = 2;
    i
}

const REAL: WordKind = WordKind::Real;
const INTEGER: WordKind = WordKind::Integer;
const SWITCH: WordKind = WordKind::Switch;

impl BoardParams {
    /// Calls `f` with every field, in declaration order, and what it is (see the module
    /// docs). `f` is a trait object, hidden from the optimiser: one copy of this long walk in
    /// the image, whatever the callers (specialised per caller it took 55 KB of the board's
    /// flash).
    pub fn visit(&mut self, f: &mut dyn FnMut(&ParamInfo, WordMut<'_>)) {
        self.walk(core::hint::black_box(f));
    }

    #[allow(clippy::too_many_lines)]
    #[inline(never)]
    fn walk(&mut self, f: &mut dyn FnMut(&ParamInfo, WordMut<'_>)) {
        use WordMut::{Count, Real};
        let ch_max = BOARD_CHANNELS as f32;
        f(
            &item(
                "",
                "model_kind",
                "-",
                "running model: 0 tyre, 1 aero, 2 substructure (changed only while Idle)",
                INTEGER,
                (0.0, 2.0),
            ),
            Count(&mut self.kind),
        );
        f(
            &item(
                "",
                "model_channels",
                "-",
                "actuator channels of the running model (tyre, substructure 1-4; aero 2)",
                INTEGER,
                (1.0, ch_max),
            ),
            Count(&mut self.channels),
        );
        for (c, t) in self.tyre.tyre.iter_mut().enumerate() {
            let i = |name, unit, description, kind, r| {
                at(item("tyre", name, unit, description, kind, r), c)
            };
            f(
                &i(
                    "stiffness",
                    "N/m",
                    "tyre radial stiffness k_t",
                    REAL,
                    range(TYRE_STIFFNESS),
                ),
                Real(&mut t.stiffness),
            );
            f(
                &i(
                    "damping",
                    "N*s/m",
                    "tyre radial damping c_t",
                    REAL,
                    range(TYRE_DAMPING),
                ),
                Real(&mut t.damping),
            );
            f(
                &i(
                    "static_load",
                    "N",
                    "static wheel load",
                    REAL,
                    range(TYRE_STATIC_LOAD),
                ),
                Real(&mut t.static_load),
            );
            f(
                &i(
                    "lift_off",
                    "-",
                    "tyre can lift off (1) or is linear (0)",
                    SWITCH,
                    (0.0, 1.0),
                ),
                Count(&mut t.lift_off),
            );
            f(
                &i(
                    "velocity_cutoff",
                    "Hz",
                    "deflection-velocity low-pass cut-off (0: none)",
                    REAL,
                    range(VELOCITY_CUTOFF),
                ),
                Real(&mut t.velocity_cutoff_hz),
            );
        }
        let a = &mut self.aero;
        for (r, row) in a.stiffness.iter_mut().enumerate() {
            for (c, v) in row.iter_mut().enumerate() {
                f(&at2(item("aero", "stiffness", "N/m", "aero stiffness K_i at the reference speed, rows [F_z; M_theta], columns [z; theta] (N/m, N/rad; N*m/m, N*m/rad)", REAL, range(AERO_STIFFNESS)), r, c), Real(v));
            }
        }
        for (r, v) in a.nominal_force.iter_mut().enumerate() {
            f(&at(item("aero", "nominal_force", "N", "nominal aero force [F_z (N); M_theta (N*m)] at the reference speed, up positive", REAL, range(AERO_NOMINAL_FORCE)), r), Real(v));
        }
        f(
            &item(
                "aero",
                "reference_speed",
                "m/s",
                "speed of the stiffness, nominal force and map",
                REAL,
                range(AERO_REFERENCE_SPEED),
            ),
            Real(&mut a.reference_speed),
        );
        f(
            &item(
                "aero",
                "front_axle",
                "m",
                "reference point to front axle l_f",
                REAL,
                range(AERO_AXLE_DISTANCE),
            ),
            Real(&mut a.front_axle),
        );
        f(
            &item(
                "aero",
                "rear_axle",
                "m",
                "reference point to rear axle l_r",
                REAL,
                range(AERO_AXLE_DISTANCE),
            ),
            Real(&mut a.rear_axle),
        );
        f(
            &item(
                "aero",
                "use_map",
                "-",
                "ride-height map (1) or linear model (0)",
                SWITCH,
                (0.0, 1.0),
            ),
            Count(&mut a.use_map),
        );
        let m = &mut a.map;
        let points = (2.0, MAP_POINTS as f32);
        f(
            &item(
                "aero_map",
                "front_points",
                "-",
                "front ride-height break points used",
                INTEGER,
                points,
            ),
            Count(&mut m.front_points),
        );
        f(
            &item(
                "aero_map",
                "rear_points",
                "-",
                "rear ride-height break points used",
                INTEGER,
                points,
            ),
            Count(&mut m.rear_points),
        );
        for (k, v) in m.front_height.iter_mut().enumerate() {
            f(
                &at(
                    item(
                        "aero_map",
                        "front_height",
                        "m",
                        "front ride-height break point (increasing)",
                        REAL,
                        range(AERO_RIDE_HEIGHT),
                    ),
                    k,
                ),
                Real(v),
            );
        }
        for (k, v) in m.rear_height.iter_mut().enumerate() {
            f(
                &at(
                    item(
                        "aero_map",
                        "rear_height",
                        "m",
                        "rear ride-height break point (increasing)",
                        REAL,
                        range(AERO_RIDE_HEIGHT),
                    ),
                    k,
                ),
                Real(v),
            );
        }
        for (r, row) in m.front_force.iter_mut().enumerate() {
            for (c, v) in row.iter_mut().enumerate() {
                f(&at2(item("aero_map", "front_force", "N", "front-axle down force [front index][rear index] at the reference speed", REAL, range(AERO_MAP_FORCE)), r, c), Real(v));
            }
        }
        for (r, row) in m.rear_force.iter_mut().enumerate() {
            for (c, v) in row.iter_mut().enumerate() {
                f(
                    &at2(
                        item(
                            "aero_map",
                            "rear_force",
                            "N",
                            "rear-axle down force [front index][rear index] at the reference speed",
                            REAL,
                            range(AERO_MAP_FORCE),
                        ),
                        r,
                        c,
                    ),
                    Real(v),
                );
            }
        }
        f(
            &item(
                "aero_map",
                "static_front_height",
                "m",
                "static front ride height (x_f = 0)",
                REAL,
                range(AERO_RIDE_HEIGHT),
            ),
            Real(&mut m.static_front_height),
        );
        f(
            &item(
                "aero_map",
                "static_rear_height",
                "m",
                "static rear ride height (x_r = 0)",
                REAL,
                range(AERO_RIDE_HEIGHT),
            ),
            Real(&mut m.static_rear_height),
        );
        let s = &mut self.substructure;
        f(
            &item(
                "substructure",
                "dof",
                "-",
                "degrees of freedom used",
                INTEGER,
                (1.0, MAX_DOF as f32),
            ),
            Count(&mut s.dof),
        );
        f(
            &item(
                "substructure",
                "causality",
                "-",
                "0 admittance, 1 impedance, 2 admittance through B_i, 3 prescribed motion (changed only while Idle)",
                INTEGER,
                (0.0, 3.0),
            ),
            Count(&mut s.causality),
        );
        for (name, unit, description, r, matrix) in [
            (
                "mass",
                "kg",
                "mass matrix M (kg; kg*m^2 for rotations)",
                range(SUBSTRUCTURE_MASS),
                &mut s.mass,
            ),
            (
                "damping",
                "N*s/m",
                "damping matrix C between the masses and to ground",
                range(SUBSTRUCTURE_DAMPING),
                &mut s.damping,
            ),
            (
                "stiffness",
                "N/m",
                "stiffness matrix K between the masses and to ground",
                range(SUBSTRUCTURE_STIFFNESS),
                &mut s.stiffness,
            ),
        ] {
            for (i, row) in matrix.iter_mut().enumerate() {
                for (j, v) in row.iter_mut().enumerate() {
                    f(
                        &at2(item("substructure", name, unit, description, REAL, r), i, j),
                        Real(v),
                    );
                }
            }
        }
        for (j, row) in s.ground_stiffness.iter_mut().enumerate() {
            for (c, v) in row.iter_mut().enumerate() {
                f(
                    &at2(
                        item(
                            "substructure",
                            "ground_stiffness",
                            "N/m",
                            "spring from DOF j to the road of channel c [j][c]",
                            REAL,
                            range(SUBSTRUCTURE_STIFFNESS),
                        ),
                        j,
                        c,
                    ),
                    Real(v),
                );
            }
        }
        for (j, row) in s.ground_damping.iter_mut().enumerate() {
            for (c, v) in row.iter_mut().enumerate() {
                f(
                    &at2(
                        item(
                            "substructure",
                            "ground_damping",
                            "N*s/m",
                            "damper from DOF j to the road of channel c [j][c]",
                            REAL,
                            range(SUBSTRUCTURE_DAMPING),
                        ),
                        j,
                        c,
                    ),
                    Real(v),
                );
            }
        }
        for (c, i) in s.interface.iter_mut().enumerate() {
            f(
                &at(
                    item(
                        "substructure",
                        "interface_dof",
                        "-",
                        "the DOF channel c couples to",
                        INTEGER,
                        (0.0, (MAX_DOF - 1) as f32),
                    ),
                    c,
                ),
                Count(&mut i.dof),
            );
            f(
                &at(
                    item(
                        "substructure",
                        "interface_stiffness",
                        "N/m",
                        "interface stiffness k_i of channel c (numerical B_i)",
                        REAL,
                        range(SUBSTRUCTURE_STIFFNESS),
                    ),
                    c,
                ),
                Real(&mut i.stiffness),
            );
            f(
                &at(
                    item(
                        "substructure",
                        "interface_damping",
                        "N*s/m",
                        "interface damping c_i of channel c (numerical B_i)",
                        REAL,
                        range(SUBSTRUCTURE_DAMPING),
                    ),
                    c,
                ),
                Real(&mut i.damping),
            );
        }
        f(
            &item(
                "substructure",
                "velocity_cutoff",
                "Hz",
                "low-pass of the velocity estimates (0: none)",
                REAL,
                range(VELOCITY_CUTOFF),
            ),
            Real(&mut s.velocity_cutoff_hz),
        );
        f(
            &item(
                "substructure",
                "element_count",
                "-",
                "nonlinear elements used",
                INTEGER,
                (0.0, MAX_ELEMENTS as f32),
            ),
            Count(&mut s.element_count),
        );
        for (e, el) in s.elements.iter_mut().enumerate() {
            for (j, v) in el.dof_coefficients.iter_mut().enumerate() {
                f(
                    &at2(
                        item(
                            "element",
                            "dof_coefficient",
                            "m/m",
                            "element e's compression per unit of DOF j [e][j]",
                            REAL,
                            range(ELEMENT_COEFFICIENT),
                        ),
                        e,
                        j,
                    ),
                    Real(v),
                );
            }
            for (c, v) in el.road_coefficients.iter_mut().enumerate() {
                f(
                    &at2(
                        item(
                            "element",
                            "road_coefficient",
                            "m/m",
                            "element e's compression per unit of channel c's road [e][c]",
                            REAL,
                            range(ELEMENT_COEFFICIENT),
                        ),
                        e,
                        c,
                    ),
                    Real(v),
                );
            }
            let l = &mut el.law;
            for (name, unit, description, r, v) in [
                (
                    "stiffness",
                    "N/m",
                    "linear stiffness k",
                    ELEMENT_STIFFNESS,
                    &mut l.stiffness,
                ),
                (
                    "bump_damping",
                    "N*s/m",
                    "damping in compression",
                    ELEMENT_DAMPING,
                    &mut l.bump_damping,
                ),
                (
                    "rebound_damping",
                    "N*s/m",
                    "damping in extension",
                    ELEMENT_DAMPING,
                    &mut l.rebound_damping,
                ),
                (
                    "cubic_stiffness",
                    "N/m^3",
                    "cubic stiffness k3",
                    ELEMENT_CUBIC_STIFFNESS,
                    &mut l.cubic_stiffness,
                ),
                (
                    "quadratic_damping",
                    "N*s^2/m^2",
                    "quadratic damping c2",
                    ELEMENT_QUADRATIC_DAMPING,
                    &mut l.quadratic_damping,
                ),
                (
                    "bump_gap",
                    "m",
                    "bump stop gap",
                    ELEMENT_GAP,
                    &mut l.bump_gap,
                ),
                (
                    "bump_stiffness",
                    "N/m",
                    "bump stop stiffness (0: none)",
                    ELEMENT_STIFFNESS,
                    &mut l.bump_stiffness,
                ),
                (
                    "rebound_gap",
                    "m",
                    "rebound stop gap",
                    ELEMENT_GAP,
                    &mut l.rebound_gap,
                ),
                (
                    "rebound_stiffness",
                    "N/m",
                    "rebound stop stiffness (0: none)",
                    ELEMENT_STIFFNESS,
                    &mut l.rebound_stiffness,
                ),
                (
                    "friction_force",
                    "N",
                    "dry friction F_c (0: none)",
                    ELEMENT_FRICTION,
                    &mut l.friction_force,
                ),
                (
                    "friction_velocity",
                    "m/s",
                    "dry friction smoothing velocity v_eps",
                    ELEMENT_FRICTION_VELOCITY,
                    &mut l.friction_velocity,
                ),
                (
                    "preload",
                    "N",
                    "static preload (the lift-off threshold)",
                    ELEMENT_PRELOAD,
                    &mut l.preload,
                ),
            ] {
                f(
                    &at(item("element", name, unit, description, REAL, range(r)), e),
                    Real(v),
                );
            }
            f(
                &at(
                    item(
                        "element",
                        "lift_off",
                        "-",
                        "the element only pushes (1) or pulls too (0)",
                        SWITCH,
                        (0.0, 1.0),
                    ),
                    e,
                ),
                Count(&mut l.lift_off),
            );
        }
        for (c, filter) in self.filter.iter_mut().enumerate() {
            f(
                &at(
                    item(
                        "filter",
                        "sections",
                        "-",
                        "command filter of channel c: sections applied",
                        INTEGER,
                        (0.0, MAX_SECTIONS as f32),
                    ),
                    c,
                ),
                Count(&mut filter.sections),
            );
            for (k, sec) in filter.section.iter_mut().enumerate() {
                for (name, description, r, v) in [
                    (
                        "beta0",
                        "section [c][s]: beta0 = b0 (delta form)",
                        FILTER_BETA,
                        &mut sec.beta0,
                    ),
                    (
                        "beta1",
                        "section [c][s]: beta1 = 2 b0 + b1 (delta form)",
                        FILTER_BETA,
                        &mut sec.beta1,
                    ),
                    (
                        "beta2",
                        "section [c][s]: beta2 = b0 + b1 + b2 (delta form)",
                        FILTER_BETA,
                        &mut sec.beta2,
                    ),
                    (
                        "alpha1",
                        "section [c][s]: alpha1 = 2 + a1 (delta form)",
                        FILTER_ALPHA,
                        &mut sec.alpha1,
                    ),
                    (
                        "alpha2",
                        "section [c][s]: alpha2 = 1 + a1 + a2 (delta form)",
                        FILTER_ALPHA,
                        &mut sec.alpha2,
                    ),
                ] {
                    f(
                        &at2(item("filter", name, "-", description, REAL, range(r)), c, k),
                        Real(v),
                    );
                }
            }
        }
        for (c, l) in self.limits.iter_mut().enumerate() {
            for (name, unit, description, r, v) in [
                (
                    "demand_min",
                    "N",
                    "lowest demand of channel c (m under position control)",
                    DEMAND_AMPLITUDE,
                    &mut l.min,
                ),
                (
                    "demand_max",
                    "N",
                    "highest demand of channel c",
                    DEMAND_AMPLITUDE,
                    &mut l.max,
                ),
                (
                    "demand_rate",
                    "N/s",
                    "demand rate limit of channel c",
                    DEMAND_RATE,
                    &mut l.rate,
                ),
            ] {
                f(
                    &at(item("limits", name, unit, description, REAL, range(r)), c),
                    Real(v),
                );
            }
        }
        for (c, v) in self.safe_demand.iter_mut().enumerate() {
            f(
                &at(
                    item(
                        "limits",
                        "safe_demand",
                        "N",
                        "demand of channel c in the safe state, within its limits",
                        REAL,
                        range(DEMAND_AMPLITUDE),
                    ),
                    c,
                ),
                Real(v),
            );
        }
        for (c, v) in self.safe_ramp_rate.iter_mut().enumerate() {
            f(
                &at(
                    item(
                        "limits",
                        "safe_ramp_rate",
                        "N/s",
                        "rate of channel c towards its safe demand",
                        REAL,
                        range(SAFE_RAMP_RATE),
                    ),
                    c,
                ),
                Real(v),
            );
        }
    }
}

/// The page words of `p` (counts as integral `f32`).
pub fn to_words(p: &BoardParams) -> [f32; WORDS] {
    let mut out = [0.0; WORDS];
    for_each_word(p, |k, v| {
        if let Some(o) = out.get_mut(k) {
            *o = v;
        }
    });
    out
}

/// Calls `f(k, word)` for each page word of `p` in order (counts as integral `f32`), with
/// no array of them (on the board, where each is kilobytes).
pub fn for_each_word(p: &BoardParams, mut f: impl FnMut(usize, f32)) {
    let mut copy = *p;
    let mut k = 0;
    copy.visit(&mut |_, w| {
        f(
            k,
            match w {
                WordMut::Real(v) => *v,
                WordMut::Count(v) => *v as f32,
            },
        );
        k += 1;
    });
}

/// The parameter set of page `words`, each word checked against its item (see the module
/// docs); the set as a whole is not validated here.
pub fn from_words(words: &[f32; WORDS]) -> Result<BoardParams, WordError> {
    let mut p = scratch();
    from_words_into(|k| words.get(k).copied(), &mut p)?;
    Ok(p)
}

/// As [`from_words`], reading word `k` as `word(k)` (`None` beyond the page) into `out`,
/// in place; on error `out` is partly written.
pub fn from_words_into(
    word: impl Fn(usize) -> Option<f32>,
    out: &mut BoardParams,
) -> Result<(), WordError> {
    let mut k = 0;
    let mut error = None;
    out.visit(&mut |info, w| {
        let v = word(k).unwrap_or(f32::NAN);
        if error.is_none() {
            match check(info, k, v) {
                Err(e) => error = Some(e),
                Ok(()) => match w {
                    WordMut::Real(x) => *x = v,
                    WordMut::Count(x) => *x = v as u32,
                },
            }
        }
        k += 1;
    });
    match error {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

/// Checks value `v` of word `word` against its item `info`.
pub fn check(info: &ParamInfo, word: usize, v: f32) -> Result<(), WordError> {
    if !v.is_finite() {
        return Err(WordError::NotFinite(word));
    }
    if v < info.min || v > info.max || (info.kind != WordKind::Real && libm::truncf(v) != v) {
        return Err(WordError::OutOfRange(word));
    }
    Ok(())
}

/// A set to walk the page's items with (its values do not matter: the items do not depend
/// on them).
fn scratch() -> BoardParams {
    BoardParams::tyres(
        crate::tyre::TyreParams::PAPER,
        1,
        crate::limits::DemandLimits {
            min: 0.0,
            max: 1.0,
            rate: 1.0,
        },
        0.0,
        1.0,
    )
}

/// Calls `f` with every word's index and what it is, in page order (one walk).
pub fn for_each_info(f: &mut dyn FnMut(usize, &ParamInfo)) {
    let mut p = scratch();
    let mut k = 0;
    p.visit(&mut |i, _| {
        f(k, i);
        k += 1;
    });
}

/// What word `word` is, or `None` beyond the page.
pub fn info(word: usize) -> Option<ParamInfo> {
    let mut found = None;
    for_each_info(&mut |k, i| {
        if k == word {
            found = Some(*i);
        }
    });
    found
}
