//! The exact steps of a piecewise-linear plant (see the [`plant`](super) module
//! documentation): its affine model `ξ̇ = G ξ` discretised for a control period, the fused
//! matrix that takes a whole period, testing every internal step boundary, in one
//! matrix-vector product, the single exact step, and the tests of the linear regime.
//! [`super::linearise`] builds the model from the plant.

use crate::actuator::ForceActuator;
use mil_numerics::dense::{copy, dot, matmul};

/// One test of the linear regime on the regime quantities (in order).
#[derive(Clone, Copy, Debug)]
pub(super) enum RegimeTest {
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
pub(super) enum Linear {
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
pub(super) use with_linear;

impl Linear {
    /// `parts` padded to the smallest row capacity of at least `rows` (`None` if none
    /// holds them).
    pub(super) fn with_rows(parts: LinearParts, rows: usize) -> Option<Self> {
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
    pub(super) fn capacity(&self) -> usize {
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
pub(super) struct LinearModel<const R: usize> {
    pub(super) parts: LinearParts,
    /// The fused matrix by columns (rows as in the type's documentation; without the step
    /// rows while `fused_steps` is 0).
    fused: Vec<[f64; R]>,
    /// Control period (s) and internal steps the fused matrix is for (`NaN`, 0: none).
    fused_period_s: f64,
    pub(super) fused_steps: usize,
    /// First row of `O` in `fused`.
    outputs_at: usize,
    /// `[Φ_h; R e^{G h}]` by columns, for one internal step `step_s` (s; `NaN`: none).
    step_matrix: Vec<[f64; R]>,
    pub(super) step_s: f64,
    /// The control period (s) the last successful [`LinearModel::discretise`] was for, with
    /// or without a fused matrix (`NaN`: none), so that a period too long for a fused
    /// matrix is not discretised again every period.
    pub(super) period_s: f64,
    xi: Vec<f64>,
    /// The fused product at the last sample in the linear regime, and whether its step
    /// rows are valid for `fused_period_s` (cleared when used).
    sampled: [f64; R],
    pub(super) sample_pending: bool,
    // The matrix exponential (cols × cols) and its scratch.
    exp: Vec<f64>,
    expm_scratch: mil_numerics::expm::ExpmScratch,
}

/// The sizes of a [`LinearModel`]: `ξ` has `states + channels + 2 inputs + 1 = cols` entries.
#[derive(Clone, Copy, Debug)]
pub(super) struct Shape {
    pub(super) states: usize,
    pub(super) cols: usize,
    pub(super) channels: usize,
    pub(super) inputs: usize,
}

/// A [`LinearModel`]'s parts as the construction finds them (rows of `cols`).
#[derive(Clone)]
pub(super) struct LinearParts {
    pub(super) shape: Shape,
    /// `[[A, B], [0, S]]` (cols × cols, row-major; `S` ramps the road with its rate),
    /// balanced: `D⁻¹ G D` with `D = diag(balance)`.
    pub(super) generator: Vec<f64>,
    pub(super) balance: Vec<f64>,
    /// `3 channels × cols`, row-major.
    pub(super) outputs: Vec<f64>,
    /// Regime quantities' rows `R` over `ξ` (one per quantity), tested by `tests`.
    pub(super) regime: Vec<Vec<f64>>,
    pub(super) tests: Vec<RegimeTest>,
}

impl LinearParts {
    /// Rows the matrices need without a fused step: `[R; O]` at a sample with room for
    /// `Φ_T`, and `[Φ_h; R e^{G h}]`.
    fn minimum_rows(&self) -> usize {
        self.fused_rows(0)
    }

    /// Rows of the fused matrix for `steps` internal steps per control period.
    pub(super) fn fused_rows(&self, steps: usize) -> usize {
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
    pub(super) fn discretise(&mut self, period_s: f64, steps: usize) -> bool {
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
    /// `fraction` of it, and the road rate to the ramp's (m/s), as [`Plant::advance`](super::Plant::advance)'s RK4
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
    /// that point lies in the linear regime (its outputs then in [`LinearModel::outputs`],
    /// and the period from it ready for [`LinearModel::advance_period`]).
    pub(super) fn sample(
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
    pub(super) fn outputs(&self) -> &[f64] {
        let start = self.outputs_at;
        let len = 3 * self.parts.shape.channels;
        self.sampled.get(start..start + len).unwrap_or(&[])
    }

    /// The control period `period_s` (s) from the last sample's point in one product (see
    /// the type's documentation), with `demand` held and the road on the ramp from `from`
    /// to `to` (m): true (and `x` advanced) when it is the period the fused matrix is for,
    /// the sample's demand and road, and every internal step boundary lies in the regime;
    /// false (and `x` unchanged) otherwise. Consumes the sample.
    pub(super) fn advance_period(
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
    pub(super) fn step(
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
