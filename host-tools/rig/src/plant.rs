//! The plant: a specimen driven at its attachment points either by the nonlinear actuators
//! (the MiL rig) or by an ideal interface law (the emulated system), integrated with the
//! classical fourth-order Runge–Kutta method at a fixed internal step.
//!
//! State vector: `q` (n), `q̇` (n), the elements' internal states (Bouc-Wen), then per
//! actuator `[x_v, ẋ_v, P_L, q_int]` ([`crate::actuator::state`]). Within one call of
//! [`Plant::advance`] the actuator demands are held (zero-order hold, as the rig's servo
//! controller applies each received demand) and the road inputs ramp linearly between their
//! samples.
//!
//! With actuators, each actuator's rod mass `m_a` joins the specimen's mass matrix at its
//! attachment (`M + m_a t_j t_jᵀ`), the piston force `F_p` acts on the specimen, and the
//! load cell measures `F_j = F_p,j − m_a ÿ_j` (the force on the specimen).
//!
//! # Exact steps in the linear regime
//!
//! A plant whose every part is affine in a region of its state space (every element linear
//! or with lift-off only, no Bouc-Wen; actuators with
//! [`ForceActuator::has_linear_regime`]; an ideal interface that declares its
//! [`IdealInterface::affine`] form) is piecewise linear: `ẋ = A x + B v` with
//! `v = [demand; road; road rate; 1]`. For it the plant takes *exact* internal steps: the
//! state-transition matrix `e^{A h}` and the input integrals over a step `h` (exact for a
//! held demand and a linearly ramping road, computed once per step length), applied while
//! the state at both ends of the step lies in the linear regime (element and interface
//! forces above their lift-off bounds, actuators in [`ForceActuator::in_linear_regime`]).
//! Any other step is the RK4 step from the same state, so a step that leaves or enters the
//! regime is exactly the plain RK4 one; an excursion out of the regime and back strictly
//! inside one internal step goes unnoticed (RK4 sees only its stage points, too). The
//! signals of [`Plant::sample`] come from the same affine model in the regime, and a
//! [`Plant::advance`] right after a sample in the regime takes its whole period (all its
//! internal steps, each boundary tested) in the same matrix-vector product as the sample.
//! [`Plant::set_exact_steps`] switches this off (plain RK4 everywhere);
//! [`Plant::step_counts`] counts both kinds of step.

use crate::actuator::{ForceActuator, ACTUATOR_STATES};
use crate::specimen::{Specimen, SpecimenError};
use mil_structure::CompiledLaw;

/// The forces an ideal interface (the emulated system's numerical part, coupled without
/// actuators, delay or sampling) applies at the attachment points.
pub trait IdealInterface {
    /// Writes the force per channel (N) into `forces`, given per channel the attachment
    /// position `y` (m) and velocity `y_dot` (m/s), and per road input its value `road` (m)
    /// and rate `road_rate` (m/s).
    fn forces(&self, y: &[f64], y_dot: &[f64], road: &[f64], road_rate: &[f64], forces: &mut [f64]);

    /// The law's affine form, if it has one: [`IdealInterface::forces`] must return exactly
    /// (to rounding) the [`AffineInterface`] force on every channel wherever that exceeds the
    /// channel's lower bound, and a force not above the bound elsewhere (e.g. lift-off). With
    /// it, the plant takes exact linear steps (see the module documentation). `None` (the
    /// default): the law is treated as nonlinear.
    fn affine(&self) -> Option<AffineInterface> {
        None
    }
}

/// The affine form of an ideal interface law (see [`IdealInterface::affine`]): per channel
/// `j`,
///
/// ```text
/// F_j = offset_j + Σ_k (position_jk y_k + velocity_jk ẏ_k) + Σ_i (road_ji w_i + road_rate_ji ẇ_i)
/// ```
///
/// valid where `F_j > lower_bound_j`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AffineInterface {
    /// Force at rest `offset_j` per channel (N).
    pub offset_n: Vec<f64>,
    /// Stiffness per channel and attachment `position_jk` (N/m).
    pub position_n_per_m: Vec<Vec<f64>>,
    /// Damping per channel and attachment `velocity_jk` (N·s/m).
    pub velocity_n_s_per_m: Vec<Vec<f64>>,
    /// Gain per channel and road input `road_ji` (N/m).
    pub road_n_per_m: Vec<Vec<f64>>,
    /// Gain per channel and road rate `road_rate_ji` (N·s/m).
    pub road_rate_n_s_per_m: Vec<Vec<f64>>,
    /// Per channel the force (N) the affine form must exceed to hold (`f64::NEG_INFINITY`:
    /// everywhere; 0 for lift-off).
    pub lower_bound_n: Vec<f64>,
}

/// What drives the specimen.
enum Drive {
    Actuators(Vec<ForceActuator>),
    Ideal(Box<dyn IdealInterface + Send + Sync>),
}

/// Signals of the plant at one instant.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PlantOutputs {
    /// Attachment (actuator rod) position per channel `y_j` (m).
    pub position: Vec<f64>,
    /// Attachment velocity per channel (m/s).
    pub velocity: Vec<f64>,
    /// Interface force on the specimen per channel (N): the load-cell force, or the ideal
    /// interface's force.
    pub force: Vec<f64>,
    /// Generalised positions `q` (m, rad).
    pub dofs: Vec<f64>,
    /// Load pressure per actuator (Pa); empty for the ideal interface.
    pub load_pressure: Vec<f64>,
    /// Spool opening per actuator (fraction of full opening).
    pub spool: Vec<f64>,
}

/// Internal steps taken since the plant was built, by kind (see the module documentation).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StepCounts {
    /// Exact linear steps.
    pub exact: u64,
    /// RK4 steps.
    pub rk4: u64,
}

/// An element's force law, specialised once.
#[derive(Clone, Copy, Debug)]
enum ElementLaw {
    /// `preload + k x + c v` (no effects).
    Linear { k: f64, c: f64, preload: f64 },
    /// `preload` plus the element's law (`mil-structure`'s, unpacked), with `states`
    /// internal states (the hysteretic deflection).
    General {
        law: CompiledLaw,
        preload: f64,
        states: usize,
    },
}

/// Size of the fixed-size derivative kernel: specimens of up to this many DOFs and road
/// inputs (every built-in one) are evaluated with their vectors padded with zeros to it, so
/// that every dot product is one unrolled expression.
const FIXED: usize = 4;

/// A vector of the fixed-size kernel.
type Fixed4 = [f64; FIXED];

/// The specimen's coefficients for the fixed-size kernel (zero-padded).
struct Fixed {
    /// `t_j` per channel.
    attachments: Vec<Fixed4>,
    /// `M⁻¹ t_j` per channel.
    inv_mass_attachments: Vec<Fixed4>,
    /// `a_e` per element.
    element_dofs: Vec<Fixed4>,
    /// `b_e` per element.
    element_inputs: Vec<Fixed4>,
    /// `M⁻¹ a_e` per element.
    inv_mass_elements: Vec<Fixed4>,
    /// `M⁻¹ g`.
    inv_mass_static: Fixed4,
}

/// `v` zero-padded (or cut) to [`FIXED`].
#[inline]
fn pad(v: &[f64]) -> Fixed4 {
    let mut a = [0.0; FIXED];
    copy(&mut a, v);
    a
}

/// The fixed-size dot product (pairwise; exact zeros in the padding).
#[inline]
fn dot4(a: &Fixed4, b: &Fixed4) -> f64 {
    (a[0] * b[0] + a[1] * b[1]) + (a[2] * b[2] + a[3] * b[3])
}

/// One test of the linear regime on the regime quantities (in order).
#[derive(Clone, Copy, Debug)]
enum RegimeTest {
    /// An element with lift-off: its unclamped force (N) `>= 0`.
    NonNegative,
    /// An ideal interface channel: its affine force (N) above the bound.
    Above(f64),
    /// Actuator `j`: the next three quantities are `u`, the flow demand and `P_L`.
    Actuator(usize),
}

/// Row capacities of the exact steps' matrices (the padded column length); a plant whose
/// matrices need more rows than the largest integrates by RK4 alone. The half car on four
/// posts needs 34 rows for one internal step per control sample.
const ROW_CAPACITIES: [usize; 9] = [8, 12, 16, 20, 24, 32, 40, 48, 64];

/// `M ξ` for a matrix stored by columns of `R` rows (`m[j]` multiplies `ξ_j`) into `out`:
/// fixed-length column updates (vector instructions, no horizontal sums, no bounds
/// checks). The exact steps' inner loop.
///
/// Compiled twice: for the baseline CPU and with AVX (4-wide; no FMA, so that both give
/// the same bits), chosen at run time.
#[multiversion::multiversion(targets("x86_64+avx"))]
fn matvec<const R: usize>(m: &[[f64; R]], xi: &[f64], out: &mut [f64; R]) {
    *out = [0.0; R];
    for (column, &x) in m.iter().zip(xi) {
        for (o, c) in out.iter_mut().zip(column) {
            *o += c * x;
        }
    }
}

/// [`LinearModel`] for the smallest row capacity `R` that holds it.
enum Linear {
    R8(Box<LinearModel<8>>),
    R12(Box<LinearModel<12>>),
    R16(Box<LinearModel<16>>),
    R20(Box<LinearModel<20>>),
    R24(Box<LinearModel<24>>),
    R32(Box<LinearModel<32>>),
    R40(Box<LinearModel<40>>),
    R48(Box<LinearModel<48>>),
    R64(Box<LinearModel<64>>),
}

/// Runs `$body` with `$m` bound to the [`LinearModel`] inside a [`Linear`], whatever its
/// row capacity.
macro_rules! with_linear {
    ($linear:expr, $m:ident => $body:expr) => {
        match $linear {
            Linear::R8($m) => $body,
            Linear::R12($m) => $body,
            Linear::R16($m) => $body,
            Linear::R20($m) => $body,
            Linear::R24($m) => $body,
            Linear::R32($m) => $body,
            Linear::R40($m) => $body,
            Linear::R48($m) => $body,
            Linear::R64($m) => $body,
        }
    };
}

impl Linear {
    /// `parts` padded to the smallest row capacity of at least `rows` (`None` if none
    /// holds them).
    fn with_rows(parts: LinearParts, rows: usize) -> Option<Self> {
        let rows = rows.max(parts.minimum_rows());
        let capacity = ROW_CAPACITIES.iter().copied().find(|&c| c >= rows)?;
        Some(match capacity {
            8 => Self::R8(Box::new(parts.padded())),
            12 => Self::R12(Box::new(parts.padded())),
            16 => Self::R16(Box::new(parts.padded())),
            20 => Self::R20(Box::new(parts.padded())),
            24 => Self::R24(Box::new(parts.padded())),
            32 => Self::R32(Box::new(parts.padded())),
            40 => Self::R40(Box::new(parts.padded())),
            48 => Self::R48(Box::new(parts.padded())),
            _ => Self::R64(Box::new(parts.padded())),
        })
    }

    /// The row capacity.
    fn capacity(&self) -> usize {
        with_linear!(self, m => m.sampled.len())
    }
}

/// The piecewise-linear plant's affine model and its exact discretisation. Columns of the
/// extended vector `ξ = [x (N); demand (channels); road (inputs); road rate (inputs); 1]`;
/// matrices stored by columns of `R` rows (zero-padded).
///
/// The generator `G` (`ξ̇ = G ξ` in the regime, the road ramping at its rate) is
/// discretised for the control period `T` split into `s` internal steps of `h = T / s`.
/// Per control sample the plant then needs one matrix-vector product, of the *fused*
/// matrix, at the sample's `ξ`, whose rows are:
///
/// ```text
/// [ R            ]   regime quantities at the sample (tested there)
/// [ Φ_T          ]   the state one control period later (`e^{G T}`'s state rows)
/// [ R e^{G h}    ]   regime quantities at the end of internal step 1
/// [  ...         ]
/// [ R e^{G s h}  ]   ... and of step s
/// [ O            ]   outputs [y; ẏ; F] at the sample
/// ```
///
/// so the whole period is tested at every internal step boundary, exactly as `s` separate
/// exact steps would be, and taken in one product. The step starts from the sample's
/// point with the ramp's road rate instead of the sample's (central) one: the difference
/// is added as one column update. When any test fails, the period is integrated step by
/// step (the stacked `[Φ_h; R e^{G h}]` per exact step, RK4 for a step that leaves the
/// regime).
struct LinearModel<const R: usize> {
    parts: LinearParts,
    /// The fused matrix by columns (rows as in the type's documentation; without the step
    /// rows while `fused_steps` is 0).
    fused: Vec<[f64; R]>,
    /// Control period (s) and internal steps the fused matrix is for (`NaN`, 0: none).
    fused_period_s: f64,
    fused_steps: usize,
    /// First row of `O` in `fused`.
    outputs_at: usize,
    /// `[Φ_h; R e^{G h}]` by columns, for one internal step `step_s` (s; `NaN`: none).
    step_matrix: Vec<[f64; R]>,
    step_s: f64,
    /// The control period (s) the last successful [`LinearModel::discretise`] was for, with
    /// or without a fused matrix (`NaN`: none), so that a period too long for a fused
    /// matrix is not discretised again every period.
    period_s: f64,
    xi: Vec<f64>,
    /// The fused product at the last sample in the linear regime, and whether its step
    /// rows are valid for `fused_period_s` (cleared when used).
    sampled: [f64; R],
    sample_pending: bool,
    // The matrix exponential (cols × cols) and its scratch.
    exp: Vec<f64>,
    expm_scratch: mil_numerics::expm::ExpmScratch,
}

/// The sizes of a [`LinearModel`]: `ξ` has `states + channels + 2 inputs + 1 = cols` entries.
#[derive(Clone, Copy, Debug)]
struct Shape {
    states: usize,
    cols: usize,
    channels: usize,
    inputs: usize,
}

/// A [`LinearModel`]'s parts as the construction finds them (rows of `cols`).
#[derive(Clone)]
struct LinearParts {
    shape: Shape,
    /// `[[A, B], [0, S]]` (cols × cols, row-major; `S` ramps the road with its rate),
    /// balanced: `D⁻¹ G D` with `D = diag(balance)`.
    generator: Vec<f64>,
    balance: Vec<f64>,
    /// `3 channels × cols`, row-major.
    outputs: Vec<f64>,
    /// Regime quantities' rows `R` over `ξ` (one per quantity), tested by `tests`.
    regime: Vec<Vec<f64>>,
    tests: Vec<RegimeTest>,
}

impl LinearParts {
    /// Rows the matrices need without a fused step: `[R; O]` at a sample with room for
    /// `Φ_T`, and `[Φ_h; R e^{G h}]`.
    fn minimum_rows(&self) -> usize {
        self.fused_rows(0)
    }

    /// Rows of the fused matrix for `steps` internal steps per control period.
    fn fused_rows(&self, steps: usize) -> usize {
        let regime = self.regime.len();
        regime * (1 + steps) + self.shape.states + 3 * self.shape.channels
    }

    /// The model with its columns zero-padded to `R` rows (`R ≥ minimum_rows`), without a
    /// discretisation yet.
    fn padded<const R: usize>(self) -> LinearModel<R> {
        let cols = self.shape.cols;
        let mut model = LinearModel {
            fused: vec![[0.0; R]; cols],
            fused_period_s: f64::NAN,
            fused_steps: 0,
            outputs_at: 0,
            step_matrix: vec![[0.0; R]; cols],
            step_s: f64::NAN,
            period_s: f64::NAN,
            xi: vec![0.0; cols],
            sampled: [0.0; R],
            sample_pending: false,
            exp: vec![0.0; cols * cols],
            expm_scratch: Default::default(),
            parts: self,
        };
        model.set_fused(None, 0);
        model
    }
}

impl<const R: usize> LinearModel<R> {
    /// Writes the fused matrix's columns: `R`, then `Φ_T` and `R e^{G j h}` from `powers`
    /// (`e^{G j h}` row-major for `j = 1..=steps`; `None`: no step rows), then `O`.
    fn set_fused(&mut self, powers: Option<&[Vec<f64>]>, steps: usize) {
        let p = &self.parts;
        let (cols, states) = (p.shape.cols, p.shape.states);
        let regime = p.regime.len();
        let steps = if powers.is_some() { steps } else { 0 };
        let outputs_at = regime * (1 + steps) + states;
        for (j, column) in self.fused.iter_mut().enumerate() {
            *column = [0.0; R];
            let mut rows = column.iter_mut();
            for r in &p.regime {
                if let Some(c) = rows.next() {
                    *c = r.get(j).copied().unwrap_or(0.0);
                }
            }
            let power = |k: usize, i: usize| -> f64 {
                powers
                    .and_then(|ps| ps.get(k))
                    .and_then(|e| e.get(i * cols + j))
                    .copied()
                    .unwrap_or(0.0)
            };
            for i in 0..states {
                if let Some(c) = rows.next() {
                    *c = power(steps.wrapping_sub(1), i);
                }
            }
            for k in 0..steps {
                for r in &p.regime {
                    if let Some(c) = rows.next() {
                        *c = r.iter().enumerate().map(|(i, ri)| ri * power(k, i)).sum();
                    }
                }
            }
            for (c, o) in column
                .iter_mut()
                .skip(outputs_at)
                .zip(p.outputs.iter().skip(j).step_by(cols.max(1)))
            {
                *c = *o;
            }
        }
        self.outputs_at = outputs_at;
        self.fused_steps = steps;
        self.sample_pending = false;
    }

    /// `e^{G h}` (row-major, un-balanced) into `exp`: `mil_numerics::expm` (scaling and
    /// squaring) on the balanced generator, `NaN` if it is not finite.
    fn exponential(&mut self, h: f64) {
        let p = self.parts.shape.cols;
        if !mil_numerics::expm::expm_minus_identity(
            &self.parts.generator,
            p,
            h,
            &mut self.exp,
            &mut self.expm_scratch,
        ) {
            self.exp.fill(f64::NAN);
            return;
        }
        for e in self.exp.iter_mut().step_by(p + 1) {
            *e += 1.0;
        }
        // Un-balance in place: e^{Gh} = D (balanced exponential) D⁻¹.
        for i in 0..p {
            let di = self.parts.balance.get(i).copied().unwrap_or(1.0);
            for (j, e) in self
                .exp
                .get_mut(i * p..i * p + p)
                .unwrap_or(&mut [])
                .iter_mut()
                .enumerate()
            {
                *e = di * *e / self.parts.balance.get(j).copied().unwrap_or(1.0);
            }
        }
    }

    /// Discretises for the control period `period_s` (s) in `steps` internal steps: the
    /// step matrix `[Φ_h; R e^{G h}]` and, when the rows fit, the fused matrix. False (and
    /// neither) if the exponential is not finite.
    fn discretise(&mut self, period_s: f64, steps: usize) -> bool {
        let h = period_s / steps.max(1) as f64;
        self.exponential(h);
        let (p, states) = (self.parts.shape.cols, self.parts.shape.states);
        if !self.exp.iter().all(|v| v.is_finite()) {
            self.step_s = f64::NAN;
            self.period_s = f64::NAN;
            self.fused_period_s = f64::NAN;
            self.set_fused(None, 0);
            return false;
        }
        for (j, column) in self.step_matrix.iter_mut().enumerate() {
            *column = [0.0; R];
            let exp_column = |i: usize| self.exp.get(i * p + j).copied().unwrap_or(0.0);
            for (i, c) in column.iter_mut().enumerate().take(states) {
                *c = exp_column(i);
            }
            for (r, c) in self.parts.regime.iter().zip(column.iter_mut().skip(states)) {
                *c = r
                    .iter()
                    .take(p)
                    .enumerate()
                    .map(|(k, rk)| rk * exp_column(k))
                    .sum();
            }
        }
        self.step_s = h;
        self.period_s = period_s;
        if self.parts.fused_rows(steps) <= R {
            let mut powers = vec![self.exp.clone()];
            for _ in 1..steps {
                let mut next = vec![0.0; p * p];
                if let Some(last) = powers.last() {
                    matmul(last, &self.exp, p, &mut next);
                }
                powers.push(next);
            }
            if powers.iter().flatten().all(|v| v.is_finite()) {
                self.set_fused(Some(&powers), steps);
                self.fused_period_s = period_s;
                return true;
            }
        }
        self.set_fused(None, 0);
        self.fused_period_s = f64::NAN;
        true
    }

    /// Fills `xi` with `[x; demand; road; road rate; 1]`.
    fn fill(&mut self, x: &[f64], demand: &[f64], road: &[f64], road_rate: &[f64]) {
        let s = self.parts.shape;
        let (xs, rest) = self.xi.split_at_mut(s.states.min(s.cols));
        copy(xs, x);
        let (ds, rest) = rest.split_at_mut(s.channels.min(rest.len()));
        copy(ds, demand);
        let (ws, rest) = rest.split_at_mut(s.inputs.min(rest.len()));
        copy(ws, road);
        let (rs, one) = rest.split_at_mut(s.inputs.min(rest.len()));
        copy(rs, road_rate);
        if let Some(o) = one.first_mut() {
            *o = 1.0;
        }
    }

    /// Sets the road in `xi` to the ramp from `from` to `to` (m) over `duration_s` (s) at
    /// `fraction` of it, and the road rate to the ramp's (m/s), as [`Plant::advance`]'s RK4
    /// steps do.
    fn set_ramp(&mut self, from: &[f64], to: &[f64], fraction: f64, duration_s: f64) {
        let s = self.parts.shape;
        let rest = self.xi.get_mut(s.states + s.channels..).unwrap_or(&mut []);
        let (ws, rest) = rest.split_at_mut(s.inputs.min(rest.len()));
        for ((w, rate), (a, b)) in ws.iter_mut().zip(rest.iter_mut()).zip(from.iter().zip(to)) {
            *w = a + fraction * (b - a);
            *rate = (b - a) / duration_s;
        }
    }

    /// Whether the regime quantities `values` (in the order of `tests`) pass every test
    /// (false for NaN).
    #[inline(always)]
    fn passes(&self, values: &[f64], actuators: &[ForceActuator]) -> bool {
        let mut values = values.iter();
        for test in &self.parts.tests {
            let pass = match *test {
                RegimeTest::NonNegative => values.next().is_some_and(|v| *v >= 0.0),
                RegimeTest::Above(bound) => values.next().is_some_and(|v| *v > bound),
                RegimeTest::Actuator(j) => match (values.next(), values.next(), values.next()) {
                    // The model exists only for actuators with a linear regime.
                    (Some(u), Some(demanded), Some(pl)) => actuators
                        .get(j)
                        .is_some_and(|a| a.linear_regime_holds(*u, *demanded, *pl)),
                    _ => false,
                },
            };
            if !pass {
                return false;
            }
        }
        true
    }

    /// Whether `xi` lies in the linear regime (false for NaN).
    fn in_regime(&self, actuators: &[ForceActuator]) -> bool {
        let mut values = [0.0; R];
        for (v, r) in values.iter_mut().zip(&self.parts.regime) {
            *v = dot(r, &self.xi);
        }
        self.passes(&values, actuators)
    }

    /// Evaluates the fused matrix at state `x` with `(demand, road, road rate)`; true if
    /// that point lies in the linear regime (its outputs then in [`LinearModel::output`],
    /// and the period from it ready for [`LinearModel::advance_period`]).
    fn sample(
        &mut self,
        x: &[f64],
        actuators: &[ForceActuator],
        (demand, road, road_rate): (&[f64], &[f64], &[f64]),
    ) -> bool {
        self.fill(x, demand, road, road_rate);
        matvec(&self.fused, &self.xi, &mut self.sampled);
        let inside = self.passes(&self.sampled, actuators);
        self.sample_pending = inside && self.fused_steps > 0;
        inside
    }

    /// The outputs `[y; ẏ; F]` (per channel each) at the last sample in the regime.
    fn outputs(&self) -> &[f64] {
        let start = self.outputs_at;
        let len = 3 * self.parts.shape.channels;
        self.sampled.get(start..start + len).unwrap_or(&[])
    }

    /// The control period `period_s` (s) from the last sample's point in one product (see
    /// the type's documentation), with `demand` held and the road on the ramp from `from`
    /// to `to` (m): true (and `x` advanced) when it is the period the fused matrix is for,
    /// the sample's demand and road, and every internal step boundary lies in the regime;
    /// false (and `x` unchanged) otherwise. Consumes the sample.
    fn advance_period(
        &mut self,
        x: &mut [f64],
        actuators: &[ForceActuator],
        demand: &[f64],
        (from, to): (&[f64], &[f64]),
        period_s: f64,
    ) -> bool {
        if !std::mem::take(&mut self.sample_pending) || period_s != self.fused_period_s {
            return false;
        }
        let s = self.parts.shape;
        let road_at = s.states + s.channels;
        let rate_at = road_at + s.inputs;
        if self.xi.get(s.states..road_at) != Some(demand)
            || self.xi.get(road_at..rate_at) != Some(from)
        {
            return false;
        }
        let regime = self.parts.regime.len();
        if s.inputs > 0 {
            // The ramp's road rate in place of the sample's: one column update per input of
            // the rows before the outputs (which stay the sample's).
            let rows = self.outputs_at;
            let mut moved = false;
            let sampled_rate = self.xi.get(rate_at..).unwrap_or(&[]);
            let rate_columns = self.fused.get(rate_at..).unwrap_or(&[]);
            for (((a, b), sampled), column) in
                from.iter().zip(to).zip(sampled_rate).zip(rate_columns)
            {
                let delta = (b - a) / period_s - sampled;
                if delta != 0.0 {
                    moved = true;
                    for (v, c) in self.sampled.iter_mut().zip(column).take(rows) {
                        *v += c * delta;
                    }
                }
            }
            if moved && !self.passes(&self.sampled, actuators) {
                return false;
            }
        }
        let after_state = regime + s.states;
        let mut end = after_state;
        for _ in 0..self.fused_steps {
            if !self.passes(self.sampled.get(end..).unwrap_or(&[]), actuators) {
                return false;
            }
            end += regime;
        }
        copy(x, self.sampled.get(regime..after_state).unwrap_or(&[]));
        true
    }

    /// One exact internal step of `self.step_s` from `x` (in place) with the demand held
    /// and the road on the ramp from `from` to `to` (m) over `duration_s` (s), from the
    /// fraction `f0` of it; false (and `x` unchanged) when either end is outside the
    /// linear regime. The start is tested unless `start_known` (it is where the last exact
    /// step ended).
    #[allow(clippy::too_many_arguments)]
    fn step(
        &mut self,
        x: &mut [f64],
        actuators: &[ForceActuator],
        demand: &[f64],
        (from, to): (&[f64], &[f64]),
        f0: f64,
        duration_s: f64,
        start_known: bool,
    ) -> bool {
        self.fill(x, demand, &[], &[]);
        self.set_ramp(from, to, f0, duration_s);
        if !start_known && !self.in_regime(actuators) {
            return false;
        }
        let mut next = [0.0; R];
        matvec(&self.step_matrix, &self.xi, &mut next);
        let states = self.parts.shape.states;
        if !self.passes(next.get(states..).unwrap_or(&[]), actuators) {
            return false;
        }
        copy(x, &next);
        true
    }
}

/// The specimen with its drive, state and scratch space (no allocation while stepping; the
/// exact discretisation is recomputed, a few dozen small matrix products, whenever the
/// control period changes, and its matrices are widened, allocating, when a period takes
/// more internal steps than they have rows for).
pub struct Plant {
    specimen: Specimen,
    drive: Drive,
    n: usize,
    channels: usize,
    element_states: usize,
    /// Inverse of the total mass matrix, row-major.
    inv_mass: Vec<f64>,
    /// `M⁻¹ g` (static forces' accelerations).
    inv_mass_static: Vec<f64>,
    /// `M⁻¹ a_e`, row-major (elements × n).
    inv_mass_elements: Vec<f64>,
    /// `M⁻¹ t_j`, row-major (channels × n).
    inv_mass_attachments: Vec<f64>,
    laws: Vec<ElementLaw>,
    state: Vec<f64>,
    time_s: f64,
    internal_step_s: f64,
    // Scratch.
    k: [Vec<f64>; 4],
    tmp: Vec<f64>,
    accel: Vec<f64>,
    y: Vec<f64>,
    y_dot: Vec<f64>,
    forces: Vec<f64>,
    road: Vec<f64>,
    road_rate: Vec<f64>,
    /// Attachments `t_j`, row-major (channels × n).
    attachments: Vec<f64>,
    /// Elements' DOF coefficients `a_e`, row-major (elements × n).
    element_dofs: Vec<f64>,
    /// Elements' input coefficients `b_e`, row-major (elements × inputs).
    element_inputs: Vec<f64>,
    /// The first RK4 stage `k[0]` holds the derivative at the current state for the
    /// demand and road in `sampled_*` (set by [`Plant::sample`], cleared by any change of
    /// state).
    first_stage_ready: bool,
    sampled_demand: Vec<f64>,
    sampled_road: Vec<f64>,
    sampled_road_rate: Vec<f64>,
    /// The specimen's coefficients padded to [`FIXED`] (when it fits).
    fixed: Option<Fixed>,
    linear: Option<Linear>,
    /// The last [`Plant::sample`] took the exact path at the current state: its outputs
    /// are the linear model's, `[y; ẏ; F]` in `linear_out`.
    linear_outputs: bool,
    linear_out: Vec<f64>,
    /// `(duration (s), internal steps, step (s))` of the last [`Plant::advance`], so that
    /// the usual constant duration costs no divisions.
    advance_split: (f64, usize, f64),
    exact_steps: bool,
    counts: StepCounts,
}

/// The actuators of a drive (none for an ideal interface).
fn drive_actuators(drive: &Drive) -> &[ForceActuator] {
    match drive {
        Drive::Actuators(a) => a,
        Drive::Ideal(_) => &[],
    }
}

/// Inverse of a small square matrix given as rows (Gauss–Jordan with partial pivoting),
/// row-major; `None` when singular.
pub fn invert(rows: &[Vec<f64>]) -> Option<Vec<f64>> {
    let n = rows.len();
    let mut a: Vec<f64> = rows.iter().flat_map(|r| r.iter().copied()).collect();
    if a.len() != n * n {
        return None;
    }
    let mut inv = vec![0.0; n * n];
    for i in 0..n {
        inv[i * n + i] = 1.0;
    }
    let scale = a.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    for col in 0..n {
        let pivot =
            (col..n).max_by(|&i, &j| a[i * n + col].abs().total_cmp(&a[j * n + col].abs()))?;
        if a[pivot * n + col].abs() <= 1e-12 * scale {
            return None;
        }
        for j in 0..n {
            a.swap(col * n + j, pivot * n + j);
            inv.swap(col * n + j, pivot * n + j);
        }
        let d = a[col * n + col];
        for j in 0..n {
            a[col * n + j] /= d;
            inv[col * n + j] /= d;
        }
        for i in 0..n {
            if i != col {
                let f = a[i * n + col];
                if f != 0.0 {
                    for j in 0..n {
                        a[i * n + j] -= f * a[col * n + j];
                        inv[i * n + j] -= f * inv[col * n + j];
                    }
                }
            }
        }
    }
    Some(inv)
}

/// `a · b` over the shorter length, in four interleaved partial sums (lets the compiler
/// vectorise it).
#[inline]
fn dot(a: &[f64], b: &[f64]) -> f64 {
    let mut acc = [0.0; 4];
    let (mut ca, mut cb) = (a.chunks_exact(4), b.chunks_exact(4));
    for (x, y) in (&mut ca).zip(&mut cb) {
        for ((s, xi), yi) in acc.iter_mut().zip(x).zip(y) {
            *s += xi * yi;
        }
    }
    let tail: f64 = ca
        .remainder()
        .iter()
        .zip(cb.remainder())
        .map(|(x, y)| x * y)
        .sum();
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
}

/// Row `i` of a row-major matrix with rows of `n` (empty beyond the end). Multiplies where
/// `chunks_exact` would divide: this is the integration's inner loop.
#[inline]
fn row(m: &[f64], i: usize, n: usize) -> &[f64] {
    m.get(i * n..i * n + n).unwrap_or(&[])
}

/// `dst = src` over the shorter length.
#[inline]
fn copy(dst: &mut [f64], src: &[f64]) {
    match (dst, src) {
        // One value (a channel's demand, a road input) without a `memcpy` call.
        ([d], [s, ..]) => *d = *s,
        (dst, src) => {
            for (d, s) in dst.iter_mut().zip(src) {
                *d = *s;
            }
        }
    }
}

/// `out = a b` for square row-major matrices of size `p`.
fn matmul(a: &[f64], b: &[f64], p: usize, out: &mut [f64]) {
    if p == 0 {
        return;
    }
    for (o_row, a_row) in out.chunks_exact_mut(p).zip(a.chunks_exact(p)) {
        o_row.iter_mut().for_each(|o| *o = 0.0);
        for (aik, b_row) in a_row.iter().zip(b.chunks_exact(p)) {
            if *aik != 0.0 {
                for (o, bkj) in o_row.iter_mut().zip(b_row) {
                    *o += aik * bkj;
                }
            }
        }
    }
}

/// Balances the square row-major matrix `a` (size `p`) in place by a diagonal similarity of
/// powers of two (exact), `a ← D⁻¹ a D`; returns `D`'s diagonal. Makes the norm that
/// scales the matrix exponential meaningful for states in units as far apart as m and Pa.
fn balance(a: &mut [f64], p: usize) -> Vec<f64> {
    let mut d = vec![1.0; p];
    for _ in 0..100 {
        let mut done = true;
        for i in 0..p {
            let (mut c, mut r) = (0.0, 0.0);
            for j in (0..p).filter(|&j| j != i) {
                c += a.get(j * p + i).map_or(0.0, |v| v.abs());
                r += a.get(i * p + j).map_or(0.0, |v| v.abs());
            }
            if !(c > 0.0 && r > 0.0 && c.is_finite() && r.is_finite()) {
                continue;
            }
            let s = c + r;
            let mut f = 1.0;
            while c < r / 2.0 && f < 1e150 {
                f *= 2.0;
                c *= 4.0;
            }
            while c >= r * 2.0 && f > 1e-150 {
                f /= 2.0;
                c /= 4.0;
            }
            if (c + r) / f < 0.95 * s {
                done = false;
                if let Some(di) = d.get_mut(i) {
                    *di *= f;
                }
                for j in 0..p {
                    if let Some(v) = a.get_mut(i * p + j) {
                        *v /= f;
                    }
                    if let Some(v) = a.get_mut(j * p + i) {
                        *v *= f;
                    }
                }
            }
        }
        if done {
            break;
        }
    }
    d
}

impl Plant {
    /// The MiL rig: `actuators[j]` drives attachment `j`; `internal_step_s` is the RK4 step
    /// (s).
    ///
    /// # Errors
    /// An invalid specimen, a count of actuators other than the attachments', or a
    /// non-positive step.
    pub fn with_actuators(
        specimen: Specimen,
        actuators: Vec<ForceActuator>,
        internal_step_s: f64,
    ) -> Result<Self, SpecimenError> {
        if actuators.len() != specimen.attachments.len() {
            return Err(SpecimenError(format!(
                "{} actuators for {} attachments",
                actuators.len(),
                specimen.attachments.len()
            )));
        }
        Self::new(specimen, Drive::Actuators(actuators), internal_step_s)
    }

    /// The emulated system: the specimen coupled to `interface` ideally.
    ///
    /// # Errors
    /// An invalid specimen or a non-positive step.
    pub fn with_ideal_interface(
        specimen: Specimen,
        interface: Box<dyn IdealInterface + Send + Sync>,
        internal_step_s: f64,
    ) -> Result<Self, SpecimenError> {
        Self::new(specimen, Drive::Ideal(interface), internal_step_s)
    }

    fn new(specimen: Specimen, drive: Drive, internal_step_s: f64) -> Result<Self, SpecimenError> {
        specimen.validate()?;
        if !(internal_step_s.is_finite() && internal_step_s > 0.0) {
            return Err(SpecimenError(format!(
                "internal step must be > 0 s (is {internal_step_s})"
            )));
        }
        let n = specimen.len();
        let channels = specimen.attachments.len();
        let mut total = specimen.mass.clone();
        if let Drive::Actuators(acts) = &drive {
            for (t, a) in specimen.attachments.iter().zip(acts) {
                for i in 0..n {
                    for j in 0..n {
                        total[i][j] += a.moving_mass_kg() * t[i] * t[j];
                    }
                }
            }
        }
        let inv_mass =
            invert(&total).ok_or_else(|| SpecimenError("singular total mass matrix".into()))?;
        let times_inv_mass =
            |v: &[f64]| -> Vec<f64> { (0..n).map(|i| dot(row(&inv_mass, i, n), v)).collect() };
        let inv_mass_static = times_inv_mass(&specimen.static_force);
        let inv_mass_elements = specimen
            .elements
            .iter()
            .flat_map(|e| times_inv_mass(&e.dof_coefficients))
            .collect();
        let inv_mass_attachments = specimen
            .attachments
            .iter()
            .flat_map(|t| times_inv_mass(t))
            .collect();
        let inputs = specimen.inputs.len();
        let fixed = (n <= FIXED && inputs <= FIXED).then(|| Fixed {
            attachments: specimen.attachments.iter().map(|t| pad(t)).collect(),
            inv_mass_attachments: specimen
                .attachments
                .iter()
                .map(|t| pad(&times_inv_mass(t)))
                .collect(),
            element_dofs: specimen
                .elements
                .iter()
                .map(|e| pad(&e.dof_coefficients))
                .collect(),
            element_inputs: specimen
                .elements
                .iter()
                .map(|e| pad(&e.input_coefficients))
                .collect(),
            inv_mass_elements: specimen
                .elements
                .iter()
                .map(|e| pad(&times_inv_mass(&e.dof_coefficients)))
                .collect(),
            inv_mass_static: pad(&inv_mass_static),
        });
        let laws = specimen
            .elements
            .iter()
            .map(|e| {
                let el = &e.element;
                if el.is_linear() {
                    return Ok(ElementLaw::Linear {
                        k: el.stiffness_n_per_m,
                        c: el.damping_n_s_per_m,
                        preload: el.preload_n,
                    });
                }
                let law = el
                    .law()
                    .map_err(|x| SpecimenError(format!("element {:?}: {x}", e.name)))?;
                Ok(ElementLaw::General {
                    law: CompiledLaw::new(&law),
                    preload: el.preload_n,
                    states: law.states(),
                })
            })
            .collect::<Result<Vec<_>, SpecimenError>>()?;
        let element_states = laws
            .iter()
            .map(|l| match l {
                ElementLaw::General { states, .. } => *states,
                ElementLaw::Linear { .. } => 0,
            })
            .sum();
        let actuator_states = match &drive {
            Drive::Actuators(a) => a.len() * ACTUATOR_STATES,
            Drive::Ideal(_) => 0,
        };
        let len = 2 * n + element_states + actuator_states;
        let mut plant = Self {
            n,
            channels,
            element_states,
            inv_mass,
            inv_mass_static,
            inv_mass_elements,
            inv_mass_attachments,
            laws,
            state: vec![0.0; len],
            time_s: 0.0,
            internal_step_s,
            k: [
                vec![0.0; len],
                vec![0.0; len],
                vec![0.0; len],
                vec![0.0; len],
            ],
            tmp: vec![0.0; len],
            accel: vec![0.0; n],
            y: vec![0.0; channels],
            y_dot: vec![0.0; channels],
            forces: vec![0.0; channels],
            road: vec![0.0; inputs],
            road_rate: vec![0.0; inputs],
            attachments: specimen.attachments.iter().flatten().copied().collect(),
            element_dofs: specimen
                .elements
                .iter()
                .flat_map(|e| e.dof_coefficients.iter().copied())
                .collect(),
            element_inputs: specimen
                .elements
                .iter()
                .flat_map(|e| e.input_coefficients.iter().copied())
                .collect(),
            first_stage_ready: false,
            sampled_demand: vec![0.0; channels],
            sampled_road: vec![0.0; inputs],
            sampled_road_rate: vec![0.0; inputs],
            specimen,
            drive,
            fixed,
            linear: None,
            linear_outputs: false,
            linear_out: vec![0.0; 3 * channels],
            advance_split: (f64::NAN, 1, f64::NAN),
            exact_steps: true,
            counts: StepCounts::default(),
        };
        plant.linear = plant.linear_model();
        Ok(plant)
    }

    /// The affine model of a piecewise-linear plant (`None` otherwise).
    fn linear_model(&self) -> Option<Linear> {
        if self.element_states > 0
            || !self
                .specimen
                .elements
                .iter()
                .all(|e| e.element.is_piecewise_linear())
        {
            return None;
        }
        let ch = self.channels;
        let inputs = self.road.len();
        let affine = match &self.drive {
            Drive::Actuators(acts) => {
                if !acts.iter().all(ForceActuator::has_linear_regime) {
                    return None;
                }
                None
            }
            Drive::Ideal(law) => {
                let a = law.affine()?;
                let square = |m: &[Vec<f64>], cols: usize| {
                    m.len() == ch
                        && m.iter()
                            .all(|r| r.len() == cols && r.iter().all(|v| v.is_finite()))
                };
                let ok = a.offset_n.len() == ch
                    && a.offset_n.iter().all(|v| v.is_finite())
                    && square(&a.position_n_per_m, ch)
                    && square(&a.velocity_n_s_per_m, ch)
                    && square(&a.road_n_per_m, inputs)
                    && square(&a.road_rate_n_s_per_m, inputs)
                    && a.lower_bound_n.len() == ch
                    && a.lower_bound_n
                        .iter()
                        .all(|b| !b.is_nan() && *b < f64::INFINITY);
                if !ok {
                    return None;
                }
                Some(a)
            }
        };
        let states = self.state.len();
        let cols = states + ch + 2 * inputs + 1;
        let mut generator = vec![0.0; cols * cols];
        let mut outputs = vec![0.0; 3 * ch * cols];
        let mut regime: Vec<Vec<f64>> = Vec::new();
        let mut tests = Vec::new();
        let mut xi = vec![0.0; cols];
        for col in 0..cols {
            xi.iter_mut().for_each(|v| *v = 0.0);
            // The constant column: ξ = 0 with the constants; any other: a unit ξ without.
            let constants = if col + 1 == cols {
                1.0
            } else {
                xi[col] = 1.0;
                0.0
            };
            let (dx, obs, quantities, t) = self.affine_eval(affine.as_ref(), &xi, constants);
            for (i, v) in dx.iter().enumerate() {
                generator[i * cols + col] = *v;
            }
            for (i, v) in obs.iter().enumerate() {
                outputs[i * cols + col] = *v;
            }
            if regime.is_empty() {
                regime = vec![vec![0.0; cols]; quantities.len()];
                tests = t;
            }
            for (r, v) in regime.iter_mut().zip(&quantities) {
                r[col] = *v;
            }
        }
        // The road ramps at its rate: d(road_i)/dt = road_rate_i.
        for i in 0..inputs {
            generator[(states + ch + i) * cols + states + ch + inputs + i] = 1.0;
        }
        let balance = balance(&mut generator, cols);
        let parts = LinearParts {
            shape: Shape {
                states,
                cols,
                channels: ch,
                inputs,
            },
            generator,
            balance,
            outputs,
            regime,
            tests,
        };
        // Room for one internal step per control period; `advance` widens it when the
        // period takes more.
        let rows = parts.fused_rows(1);
        Linear::with_rows(parts, rows)
    }

    /// The linear regime's model at `xi` with the constant terms (static forces, preloads,
    /// interface offsets) times `constants`: the state derivative, the outputs `[y; ẏ; F]`,
    /// the regime quantities and their tests. Construction only (allocates).
    fn affine_eval(
        &self,
        affine: Option<&AffineInterface>,
        xi: &[f64],
        constants: f64,
    ) -> (Vec<f64>, Vec<f64>, Vec<f64>, Vec<RegimeTest>) {
        let (n, ch, inputs) = (self.n, self.channels, self.road.len());
        let states = self.state.len();
        let x = &xi[..states];
        let demand = &xi[states..states + ch];
        let w = &xi[states + ch..states + ch + inputs];
        let w_dot = &xi[states + ch + inputs..states + ch + 2 * inputs];
        let (q, qd) = (&x[..n], &x[n..2 * n]);
        let y: Vec<f64> = self
            .specimen
            .attachments
            .iter()
            .map(|t| dot(t, q))
            .collect();
        let y_dot: Vec<f64> = self
            .specimen
            .attachments
            .iter()
            .map(|t| dot(t, qd))
            .collect();
        let mut generalised: Vec<f64> = self
            .specimen
            .static_force
            .iter()
            .map(|g| constants * g)
            .collect();
        let mut quantities = Vec::new();
        let mut tests = Vec::new();
        for e in &self.specimen.elements {
            let el = &e.element;
            let xe = dot(&e.dof_coefficients, q) + dot(&e.input_coefficients, w);
            let ve = dot(&e.dof_coefficients, qd) + dot(&e.input_coefficients, w_dot);
            let f =
                el.stiffness_n_per_m * xe + el.damping_n_s_per_m * ve + constants * el.preload_n;
            if el.lifts_off() {
                quantities.push(f);
                tests.push(RegimeTest::NonNegative);
            }
            for (g, a) in generalised.iter_mut().zip(&e.dof_coefficients) {
                *g -= a * f;
            }
        }
        let act_states = &x[2 * n..];
        let state_of = |j: usize| -> [f64; ACTUATOR_STATES] {
            let mut s = [0.0; ACTUATOR_STATES];
            copy(
                &mut s,
                &act_states[j * ACTUATOR_STATES..(j + 1) * ACTUATOR_STATES],
            );
            s
        };
        let mut forces = vec![0.0; ch];
        match (&self.drive, affine) {
            (Drive::Actuators(acts), _) => {
                for (j, a) in acts.iter().enumerate() {
                    forces[j] = a.piston_force(&state_of(j), y_dot[j]);
                }
            }
            (Drive::Ideal(_), Some(a)) => {
                for (j, f) in forces.iter_mut().enumerate() {
                    *f = constants * a.offset_n[j]
                        + dot(&a.position_n_per_m[j], &y)
                        + dot(&a.velocity_n_s_per_m[j], &y_dot)
                        + dot(&a.road_n_per_m[j], w)
                        + dot(&a.road_rate_n_s_per_m[j], w_dot);
                    if a.lower_bound_n[j] > f64::NEG_INFINITY {
                        quantities.push(*f);
                        tests.push(RegimeTest::Above(a.lower_bound_n[j]));
                    }
                }
            }
            (Drive::Ideal(_), None) => {}
        }
        for (t, f) in self.specimen.attachments.iter().zip(&forces) {
            for (g, ti) in generalised.iter_mut().zip(t) {
                *g += ti * f;
            }
        }
        let accel: Vec<f64> = (0..n)
            .map(|i| dot(row(&self.inv_mass, i, n), &generalised))
            .collect();
        let mut dx = vec![0.0; states];
        dx[..n].copy_from_slice(qd);
        dx[n..2 * n].copy_from_slice(&accel);
        if let Drive::Actuators(acts) = &self.drive {
            for (j, a) in acts.iter().enumerate() {
                let s = state_of(j);
                forces[j] -= a.moving_mass_kg() * dot(&self.specimen.attachments[j], &accel);
                let (u, demanded) = a.valve_signals(&s, demand[j], forces[j], y_dot[j]);
                quantities.extend([u, demanded, s[crate::actuator::state::LOAD_PRESSURE]]);
                tests.push(RegimeTest::Actuator(j));
                let start = 2 * n + j * ACTUATOR_STATES;
                dx[start..start + ACTUATOR_STATES].copy_from_slice(
                    &a.linear_regime_derivative(&s, demand[j], forces[j], y_dot[j]),
                );
            }
        }
        let outputs = y.into_iter().chain(y_dot).chain(forces).collect();
        (dx, outputs, quantities, tests)
    }

    /// The specimen.
    pub fn specimen(&self) -> &Specimen {
        &self.specimen
    }

    /// Interface channels.
    pub fn channels(&self) -> usize {
        self.channels
    }

    /// Simulated time (s).
    pub fn time_s(&self) -> f64 {
        self.time_s
    }

    /// The RK4 step (s).
    pub fn internal_step_s(&self) -> f64 {
        self.internal_step_s
    }

    /// The full state vector (see the module documentation).
    pub fn state(&self) -> &[f64] {
        &self.state
    }

    /// Whether the plant is piecewise linear, so that it can take exact steps in its
    /// linear regime (see the module documentation).
    pub fn has_exact_steps(&self) -> bool {
        self.linear.is_some()
    }

    /// Switches the exact linear steps on (the default) or off (plain RK4 at the internal
    /// step everywhere, e.g. as a reference).
    pub fn set_exact_steps(&mut self, on: bool) {
        self.exact_steps = on;
        self.first_stage_ready = false;
        self.linear_outputs = false;
        if let Some(linear) = self.linear.as_mut() {
            with_linear!(linear, m => m.sample_pending = false);
        }
    }

    /// Internal steps taken so far, exact and RK4.
    pub fn step_counts(&self) -> StepCounts {
        self.counts
    }

    /// Puts the plant at rest at `q = 0` with every actuator holding `demand[j]` (N): the
    /// static equilibrium of the specimen description (see [`Specimen`]).
    pub fn rest(&mut self, demand: &[f64]) {
        self.state.iter_mut().for_each(|x| *x = 0.0);
        self.time_s = 0.0;
        self.first_stage_ready = false;
        self.linear_outputs = false;
        if let Some(linear) = self.linear.as_mut() {
            with_linear!(linear, m => m.sample_pending = false);
        }
        let offset = 2 * self.n + self.element_states;
        if let Drive::Actuators(acts) = &self.drive {
            for (j, (a, f)) in acts.iter().zip(demand).enumerate() {
                let s = a.equilibrium(*f);
                self.state[offset + j * ACTUATOR_STATES..offset + (j + 1) * ACTUATOR_STATES]
                    .copy_from_slice(&s);
            }
        }
    }

    /// Evaluates the derivative of `state` (or of the RK4 trial state `tmp`) into
    /// `k[which]` with demands `demand` (N) and the road in `self.road`, `self.road_rate`;
    /// also leaves the attachment kinematics in `self.y`, `self.y_dot`, the accelerations in
    /// `self.accel` and the interface forces in `self.forces`.
    fn derivative(&mut self, which: usize, from_tmp: bool, demand: &[f64]) {
        if self.fixed.is_some() {
            self.derivative_fixed(which, from_tmp, demand);
        } else {
            self.derivative_general(which, from_tmp, demand);
        }
    }

    /// [`Plant::derivative`] with the fixed-size kernel.
    fn derivative_fixed(&mut self, which: usize, from_tmp: bool, demand: &[f64]) {
        let Some(fx) = &self.fixed else {
            return;
        };
        let n = self.n;
        let x: &[f64] = if from_tmp { &self.tmp } else { &self.state };
        let (q, rest) = x.split_at(n.min(x.len()));
        let (qd, rest) = rest.split_at(n.min(rest.len()));
        let (zs, act_states) = rest.split_at(self.element_states.min(rest.len()));
        let Some(out) = self.k.get_mut(which) else {
            return;
        };
        let (q4, qd4) = (pad(q), pad(qd));
        let (road, road_rate) = (pad(&self.road), pad(&self.road_rate));
        // Attachment kinematics.
        for ((y, y_dot), t) in self
            .y
            .iter_mut()
            .zip(self.y_dot.iter_mut())
            .zip(&fx.attachments)
        {
            *y = dot4(t, &q4);
            *y_dot = dot4(t, &qd4);
        }
        // Accelerations: static forces, elements.
        let mut accel = fx.inv_mass_static;
        let mut zi = 0;
        for (((law, a), b), m) in self
            .laws
            .iter()
            .zip(&fx.element_dofs)
            .zip(&fx.element_inputs)
            .zip(&fx.inv_mass_elements)
        {
            let xe = dot4(a, &q4) + dot4(b, &road);
            let ve = dot4(a, &qd4) + dot4(b, &road_rate);
            let f = element_force(law, xe, ve, zs, &mut zi, out, 2 * n);
            for (acc, mi) in accel.iter_mut().zip(m) {
                *acc -= mi * f;
            }
        }
        // Interface forces: piston forces (actuators) or the ideal law.
        interface_forces(
            &self.drive,
            act_states,
            &self.y,
            &self.y_dot,
            &self.road,
            &self.road_rate,
            &mut self.forces,
        );
        for (f, m) in self.forces.iter().zip(&fx.inv_mass_attachments) {
            for (acc, mi) in accel.iter_mut().zip(m) {
                *acc += mi * f;
            }
        }
        copy(&mut self.accel, &accel);
        let len = out.len();
        let (velocities, rest) = out.split_at_mut(n.min(len));
        copy(velocities, qd);
        copy(rest, accel.get(..n).unwrap_or(&[]));
        // Actuators: load cell (F_p − m_a ÿ) and their own dynamics.
        if let Drive::Actuators(acts) = &self.drive {
            let offset = 2 * n + self.element_states;
            for (j, ((a, t), ((f, y_dot), demand))) in acts
                .iter()
                .zip(&fx.attachments)
                .zip(self.forces.iter_mut().zip(&self.y_dot).zip(demand))
                .enumerate()
            {
                *f -= a.moving_mass_kg() * dot4(t, &accel);
                let d = a.derivative(actuator_state(act_states, j), *demand, *f, *y_dot);
                let start = offset + j * ACTUATOR_STATES;
                if let Some(o) = out.get_mut(start..start + ACTUATOR_STATES) {
                    copy(o, &d);
                }
            }
        }
    }

    /// [`Plant::derivative`] for any size.
    fn derivative_general(&mut self, which: usize, from_tmp: bool, demand: &[f64]) {
        let n = self.n;
        let inputs = self.road.len();
        let x: &[f64] = if from_tmp { &self.tmp } else { &self.state };
        let (q, rest) = x.split_at(n.min(x.len()));
        let (qd, rest) = rest.split_at(n.min(rest.len()));
        let (zs, act_states) = rest.split_at(self.element_states.min(rest.len()));
        let Some(out) = self.k.get_mut(which) else {
            return;
        };
        // Attachment kinematics.
        for (j, (y, y_dot)) in self.y.iter_mut().zip(self.y_dot.iter_mut()).enumerate() {
            let t = row(&self.attachments, j, n);
            *y = dot(t, q);
            *y_dot = dot(t, qd);
        }
        // Accelerations: static forces, elements (`M⁻¹ a_e` precomputed).
        copy(&mut self.accel, &self.inv_mass_static);
        let mut zi = 0;
        for (i, law) in self.laws.iter().enumerate() {
            let a = row(&self.element_dofs, i, n);
            let (mut xe, mut ve) = (dot(a, q), dot(a, qd));
            if inputs > 0 {
                let b = row(&self.element_inputs, i, inputs);
                xe += dot(b, &self.road);
                ve += dot(b, &self.road_rate);
            }
            let f = element_force(law, xe, ve, zs, &mut zi, out, 2 * n);
            for (acc, m) in self
                .accel
                .iter_mut()
                .zip(row(&self.inv_mass_elements, i, n))
            {
                *acc -= m * f;
            }
        }
        // Interface forces: piston forces (actuators) or the ideal law.
        interface_forces(
            &self.drive,
            act_states,
            &self.y,
            &self.y_dot,
            &self.road,
            &self.road_rate,
            &mut self.forces,
        );
        for (j, f) in self.forces.iter().enumerate() {
            for (acc, m) in self
                .accel
                .iter_mut()
                .zip(row(&self.inv_mass_attachments, j, n))
            {
                *acc += m * f;
            }
        }
        let len = out.len();
        let (velocities, rest) = out.split_at_mut(n.min(len));
        copy(velocities, qd);
        copy(rest, &self.accel);
        // Actuators: load cell (F_p − m_a ÿ) and their own dynamics.
        if let Drive::Actuators(acts) = &self.drive {
            let offset = 2 * n + self.element_states;
            for (j, (a, ((f, y_dot), demand))) in acts
                .iter()
                .zip(self.forces.iter_mut().zip(&self.y_dot).zip(demand))
                .enumerate()
            {
                *f -= a.moving_mass_kg() * dot(row(&self.attachments, j, n), &self.accel);
                let d = a.derivative(actuator_state(act_states, j), *demand, *f, *y_dot);
                let start = offset + j * ACTUATOR_STATES;
                if let Some(o) = out.get_mut(start..start + ACTUATOR_STATES) {
                    copy(o, &d);
                }
            }
        }
    }

    fn set_road(&mut self, from: &[f64], to: &[f64], fraction: f64, duration_s: f64) {
        for ((r, rr), (a, b)) in self
            .road
            .iter_mut()
            .zip(self.road_rate.iter_mut())
            .zip(from.iter().zip(to))
        {
            *r = a + fraction * (b - a);
            *rr = (b - a) / duration_s;
        }
    }

    /// Advances by `duration_s` (s) in RK4 steps of at most the internal step, with the
    /// actuator demands `demand` (N per channel; ignored by an ideal interface) held and the
    /// road ramping from `road_from` to `road_to` (m per input). A piecewise-linear plant
    /// takes the same steps exactly while in its linear regime (see the module
    /// documentation); after a [`Plant::sample`] in the regime with the same demand and
    /// `road_from`, the whole period is one matrix-vector product.
    ///
    /// When [`Plant::sample`] was called last with the same demand, `road_from` and the
    /// ramp's rate `(road_to − road_from) / duration_s` (m/s), the first RK4 stage is the
    /// derivative it evaluated and is not evaluated again.
    pub fn advance(&mut self, duration_s: f64, demand: &[f64], road_from: &[f64], road_to: &[f64]) {
        self.linear_outputs = false;
        if self.exact_steps {
            if let Some(linear) = self.linear.as_mut() {
                let actuators = drive_actuators(&self.drive);
                let state = &mut self.state;
                let steps = with_linear!(linear, m => m.advance_period(
                    state,
                    actuators,
                    demand,
                    (road_from, road_to),
                    duration_s,
                )
                .then_some(m.fused_steps));
                if let Some(steps) = steps {
                    self.counts.exact += steps as u64;
                    self.time_s += duration_s;
                    return;
                }
            }
        }
        self.advance_in_steps(duration_s, demand, road_from, road_to);
    }

    /// [`Plant::advance`] step by step: exact internal steps while in the regime, RK4
    /// otherwise (and everywhere without exact steps).
    #[inline(never)]
    fn advance_in_steps(
        &mut self,
        duration_s: f64,
        demand: &[f64],
        road_from: &[f64],
        road_to: &[f64],
    ) {
        if self.advance_split.0 != duration_s {
            let steps = (duration_s / self.internal_step_s - 1e-9).ceil().max(1.0) as usize;
            self.advance_split = (duration_s, steps, duration_s / steps as f64);
        }
        let (_, steps, h) = self.advance_split;
        let mut exact = false;
        if self.exact_steps {
            if let Some(linear) = self.linear.as_mut() {
                let (ready, rows) = with_linear!(&*linear, m => (
                    m.step_s == h && m.period_s == duration_s,
                    m.parts.fused_rows(steps),
                ));
                if !ready && rows > linear.capacity() {
                    // A period of more internal steps than the fused matrix has room for:
                    // widen it (allocates; only when the period changes).
                    let parts = with_linear!(&*linear, m => m.parts.clone());
                    if let Some(wider) = Linear::with_rows(parts, rows) {
                        *linear = wider;
                    }
                }
                exact = ready || with_linear!(linear, m => m.discretise(duration_s, steps));
            }
        }
        let mut previous_exact = false;
        for s in 0..steps {
            if exact {
                if let Some(linear) = self.linear.as_mut() {
                    let f0 = if s == 0 { 0.0 } else { s as f64 / steps as f64 };
                    let actuators = drive_actuators(&self.drive);
                    let state = &mut self.state;
                    // After an exact step the start was tested as that step's end.
                    let done = with_linear!(linear, m => m.step(
                        state,
                        actuators,
                        demand,
                        (road_from, road_to),
                        f0,
                        duration_s,
                        previous_exact,
                    ));
                    previous_exact = done;
                    if done {
                        self.counts.exact += 1;
                        continue;
                    }
                }
            }
            self.rk4_step(s, steps, h, demand, road_from, road_to, duration_s);
        }
        self.first_stage_ready = false;
        self.time_s += duration_s;
    }

    /// RK4 step `s` of `steps` (each `h`, s) of [`Plant::advance`].
    #[allow(clippy::too_many_arguments)]
    fn rk4_step(
        &mut self,
        s: usize,
        steps: usize,
        h: f64,
        demand: &[f64],
        road_from: &[f64],
        road_to: &[f64],
        duration_s: f64,
    ) {
        let f0 = s as f64 / steps as f64;
        let fm = (s as f64 + 0.5) / steps as f64;
        let f1 = (s as f64 + 1.0) / steps as f64;
        self.set_road(road_from, road_to, f0, duration_s);
        let reuse = s == 0
            && self.first_stage_ready
            && self.sampled_demand == demand
            && self.sampled_road == self.road
            && self.sampled_road_rate == self.road_rate;
        if !reuse {
            self.derivative(0, false, demand);
        }
        self.set_road(road_from, road_to, fm, duration_s);
        let half = 0.5 * h;
        stage(&mut self.tmp, &self.state, &self.k[0], half);
        self.derivative(1, true, demand);
        stage(&mut self.tmp, &self.state, &self.k[1], half);
        self.derivative(2, true, demand);
        self.set_road(road_from, road_to, f1, duration_s);
        stage(&mut self.tmp, &self.state, &self.k[2], h);
        self.derivative(3, true, demand);
        let sixth = h / 6.0;
        let [k0, k1, k2, k3] = &self.k;
        for ((x, a), ((b, c), d)) in self.state.iter_mut().zip(k0).zip(k1.iter().zip(k2).zip(k3)) {
            *x += sixth * (a + 2.0 * b + 2.0 * c + d);
        }
        self.first_stage_ready = false;
        self.counts.rk4 += 1;
    }

    /// Evaluates the plant's signals now, for demands `demand` (N; they set the load-cell
    /// force through the accelerations) and road `road` with rate `road_rate` (m/s); read
    /// them with [`Plant::position`], [`Plant::velocity`] and [`Plant::force`]. Allocates
    /// nothing.
    pub fn sample(&mut self, demand: &[f64], road: &[f64], road_rate: &[f64]) {
        if self.exact_steps {
            if let Some(linear) = self.linear.as_mut() {
                let actuators: &[ForceActuator] = match &self.drive {
                    Drive::Actuators(a) => a,
                    Drive::Ideal(_) => &[],
                };
                let (state, outputs) = (&self.state, &mut self.linear_out);
                let inside = with_linear!(linear, m => {
                    let inside = m.sample(state, actuators, (demand, road, road_rate));
                    copy(outputs, m.outputs());
                    inside
                });
                if inside {
                    self.first_stage_ready = false;
                    self.linear_outputs = true;
                    return;
                }
            }
        }
        self.linear_outputs = false;
        copy(&mut self.road, road);
        copy(&mut self.road_rate, road_rate);
        self.derivative(0, false, demand);
        copy(&mut self.sampled_demand, demand);
        copy(&mut self.sampled_road, road);
        copy(&mut self.sampled_road_rate, road_rate);
        self.first_stage_ready = true;
    }

    /// Output `k` (0: position, 1: velocity, 2: force) of the last [`Plant::sample`].
    fn sampled_output(&self, k: usize) -> &[f64] {
        if self.linear_outputs {
            let ch = self.channels;
            return self.linear_out.get(k * ch..(k + 1) * ch).unwrap_or(&[]);
        }
        match k {
            0 => &self.y,
            1 => &self.y_dot,
            _ => &self.forces,
        }
    }

    /// Attachment position per channel (m) at the last [`Plant::sample`].
    pub fn position(&self) -> &[f64] {
        self.sampled_output(0)
    }

    /// Attachment velocity per channel (m/s) at the last [`Plant::sample`].
    pub fn velocity(&self) -> &[f64] {
        self.sampled_output(1)
    }

    /// Interface force on the specimen per channel (N) at the last [`Plant::sample`]: the
    /// load-cell force, or the ideal interface's force.
    pub fn force(&self) -> &[f64] {
        self.sampled_output(2)
    }

    /// The plant's signals now (see [`Plant::sample`]), collected.
    pub fn outputs(&mut self, demand: &[f64], road: &[f64], road_rate: &[f64]) -> PlantOutputs {
        self.sample(demand, road, road_rate);
        let offset = 2 * self.n + self.element_states;
        let actuators = match &self.drive {
            Drive::Actuators(a) => a.len(),
            Drive::Ideal(_) => 0,
        };
        let pick = |k: usize| {
            (0..actuators)
                .map(|j| self.state[offset + j * ACTUATOR_STATES + k])
                .collect()
        };
        PlantOutputs {
            position: self.position().to_vec(),
            velocity: self.velocity().to_vec(),
            force: self.force().to_vec(),
            dofs: self.state[..self.n].to_vec(),
            load_pressure: pick(crate::actuator::state::LOAD_PRESSURE),
            spool: pick(crate::actuator::state::SPOOL),
        }
    }
}

/// Force (N) of one element at compression `xe` (m) and rate `ve` (m/s) by its law; an
/// element with an internal state takes it from `zs[*zi]`, writes its rate into
/// `out[states_at + *zi]` and advances `*zi`.
#[inline]
fn element_force(
    law: &ElementLaw,
    xe: f64,
    ve: f64,
    zs: &[f64],
    zi: &mut usize,
    out: &mut [f64],
    states_at: usize,
) -> f64 {
    match law {
        // The order of `Element::force`: k x, + c v, + preload.
        ElementLaw::Linear { k, c, preload } => k * xe + c * ve + preload,
        ElementLaw::General {
            law,
            preload,
            states,
        } => {
            if *states > 0 {
                let z = zs.get(*zi).copied().unwrap_or(0.0);
                if let Some(rate) = out.get_mut(states_at + *zi) {
                    *rate = law.state_rate(xe, ve, z);
                }
                *zi += states;
                preload + law.force(xe, ve, z)
            } else {
                preload + law.force(xe, ve, 0.0)
            }
        }
    }
}

/// The interface forces (N) into `forces`: the actuators' piston forces from their states
/// `act_states` and rod velocities, or the ideal interface's law.
#[inline]
fn interface_forces(
    drive: &Drive,
    act_states: &[f64],
    y: &[f64],
    y_dot: &[f64],
    road: &[f64],
    road_rate: &[f64],
    forces: &mut [f64],
) {
    match drive {
        Drive::Actuators(acts) => {
            for (j, (a, (f, v))) in acts.iter().zip(forces.iter_mut().zip(y_dot)).enumerate() {
                *f = a.piston_force(actuator_state(act_states, j), *v);
            }
        }
        Drive::Ideal(law) => law.forces(y, y_dot, road, road_rate, forces),
    }
}

/// Actuator `j`'s states in the actuators' part of the state vector.
#[inline]
fn actuator_state(states: &[f64], j: usize) -> &[f64; ACTUATOR_STATES] {
    states
        .get(j * ACTUATOR_STATES..(j + 1) * ACTUATOR_STATES)
        .and_then(|s| s.try_into().ok())
        .unwrap_or(&[0.0; ACTUATOR_STATES])
}

/// `tmp = x + h k` (an RK4 trial state).
#[inline]
fn stage(tmp: &mut [f64], x: &[f64], k: &[f64], h: f64) {
    for ((t, a), b) in tmp.iter_mut().zip(x).zip(k) {
        *t = a + h * b;
    }
}
