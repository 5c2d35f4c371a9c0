//! Fixed-step simulation of a [`Model`] driven by a record's inputs.
//!
//! State: DOF positions `q` (m, rad), velocities `q̇`, and one hysteretic deflection `z`
//! (m) per element with hysteresis. Equations of motion (diagonal mass `M`):
//!
//! ```text
//! M q̈ = bias + Σ_inputs t_j f_j − Σ_e a_e F_e(x_e, ẋ_e, z_e),   x_e = a_e·q + b_e·w
//! ```
//!
//! Classical RK4 with `substeps` equal steps per record sample; inputs (after their
//! effects) are interpolated linearly between samples, so a displacement input's rate is
//! constant over a sample interval.

use crate::effects::CompiledLaw;
use crate::model::{InputKind, Model, OutputKind, Target};
use crate::record::Record;
use crate::{Error, Result};

/// The model's inputs over a record, in SI units after `gain` and the input effects, one
/// vector per model input.
///
/// # Errors
/// A column the model names is missing.
pub fn prepare_inputs(model: &Model, record: &Record) -> Result<Vec<Vec<f64>>> {
    model
        .inputs
        .iter()
        .map(|inp| {
            let col = record.column(&inp.column)?;
            let si: Vec<f64> = col.iter().map(|v| v * inp.gain).collect();
            Ok(inp.law.transform(&si, record.dt))
        })
        .collect()
}

/// A simulated run.
#[derive(Clone, Debug, Default)]
pub struct Simulation {
    /// Per model output, per sample, in the output column's units (gain applied).
    pub outputs: Vec<Vec<f64>>,
    /// Per DOF, per sample: position (m, rad).
    pub q: Vec<Vec<f64>>,
    /// Per DOF, per sample: velocity (m/s, rad/s).
    pub qd: Vec<Vec<f64>>,
    /// RK4 steps per sample used.
    pub substeps: usize,
}

/// Number of RK4 steps per sample `dt` (s) so that the step is at most 0.5 over the
/// fastest rate of the linearised model (Gershgorin bounds on `M⁻¹K` and `M⁻¹C`, with
/// stops, friction smoothing and hysteresis included), between 1 and 400.
pub fn substeps(model: &Model, dt: f64) -> usize {
    let n = model.n();
    let mut rate: f64 = 0.0;
    for i in 0..n {
        let (mut k2, mut c) = (0.0, 0.0);
        for e in &model.elements {
            let l = &e.law;
            let row: f64 = e.a.iter().map(|v| v.abs()).sum::<f64>() * e.a[i].abs();
            let mut k = l.k.abs() + l.k_h.abs() * l.hysteresis.map_or(0.0, |h| h.a.abs());
            k += l.bump.map_or(0.0, |b| b.1.abs()) + l.rebound.map_or(0.0, |b| b.1.abs());
            let mut cc = l.c.abs() + l.c_abs.map_or(0.0, f64::abs);
            cc += l.coulomb.map_or(0.0, |(fc, veps)| fc.abs() / veps);
            k2 += row * k;
            c += row * cc;
        }
        rate = rate.max((k2 / model.mass[i]).sqrt()).max(c / model.mass[i]);
    }
    ((dt * rate / 0.5).ceil() as usize).clamp(1, 400)
}

/// The model compiled for the integrator, once per run: `1 / mass` instead of a division,
/// each element's law unpacked ([`CompiledLaw`]), the input couplings of the elements as
/// one flat list of non-zero terms, each output's source resolved, so that the per-sample
/// work matches no `Option`, searches nothing and recomputes no element force.
///
/// The DOF couplings (an element's `a`, a force input's `t`) stay dense: in a copy of the
/// integrator with a constant DOF count (see [`Dims`]) every DOF index is then a constant,
/// the loops over DOFs unroll and the DOF state stays in registers. Every sum is taken in
/// the order of the straightforward formulation (model order of elements, DOFs, inputs),
/// so the results are the same bit for bit (see [`Plan::eval`] for the zero terms).
struct Plan<'a> {
    /// DOFs.
    n: usize,
    /// State dimension `2 n + hysteretic states`.
    dim: usize,
    /// RK4 steps per sample ([`substeps`]).
    substeps: usize,
    /// Whether the DOF histories are recorded ([`simulate`]) or not ([`simulate_outputs`]).
    states: bool,
    /// Constant generalised force per DOF.
    bias: &'a [f64],
    /// `1 / mass` per DOF.
    inv_mass: Vec<f64>,
    /// Force inputs: `(input, t)`, `t` the generalised force on each DOF per unit force.
    force_inputs: Vec<(usize, &'a [f64])>,
    /// `(input, b)` with `b ≠ 0`, sliced by [`PlannedElement::b`].
    input_terms: Vec<(usize, f64)>,
    elements: Vec<PlannedElement<'a>>,
    outputs: Vec<PlannedOutput<'a>>,
}

/// An element as the integrator sees it.
struct PlannedElement<'a> {
    /// Compression per unit of each DOF ([`crate::model::Element::a`]).
    a: &'a [f64],
    /// Range of [`Plan::input_terms`] holding its input couplings.
    b: std::ops::Range<usize>,
    law: CompiledLaw,
    /// Index of its hysteretic state in `s[2n..]`.
    z: Option<usize>,
}

/// What an output reads, resolved once.
enum PlannedOutput<'a> {
    /// `gain · c·y` with `y` the DOF positions, velocities or accelerations.
    Motion {
        c: &'a [f64],
        of: Derivative,
        gain: f64,
    },
    /// `gain ·` the force of element `element`, as [`Plan::eval`] leaves it at the sample.
    Force { element: usize, gain: f64 },
}

/// Which time derivative of the DOF positions a motion output reads.
#[derive(Clone, Copy, Debug)]
enum Derivative {
    Position,
    Velocity,
    Acceleration,
}

impl<'a> Plan<'a> {
    fn new(model: &'a Model, dt: f64, states: bool) -> Self {
        let n = model.n();
        let mut input_terms = Vec::new();
        let mut nz = 0;
        let elements: Vec<PlannedElement> = model
            .elements
            .iter()
            .map(|e| {
                let from = input_terms.len();
                input_terms.extend(e.b.iter().copied().enumerate().filter(|(_, b)| *b != 0.0));
                let z = e.law.hysteresis.is_some().then(|| {
                    nz += 1;
                    nz - 1
                });
                PlannedElement {
                    a: &e.a,
                    b: from..input_terms.len(),
                    law: CompiledLaw::new(&e.law),
                    z,
                }
            })
            .collect();
        let force_inputs = model
            .inputs
            .iter()
            .enumerate()
            .filter(|(_, i)| i.kind == InputKind::Force)
            .map(|(j, i)| (j, &i.t[..]))
            .collect();
        let outputs = model
            .outputs
            .iter()
            .map(|o| match &o.target {
                Target::Motion(c) => PlannedOutput::Motion {
                    c,
                    of: match o.kind {
                        OutputKind::Displacement => Derivative::Position,
                        OutputKind::Velocity => Derivative::Velocity,
                        _ => Derivative::Acceleration,
                    },
                    gain: o.gain,
                },
                Target::Element(e) => PlannedOutput::Force {
                    element: *e,
                    gain: o.gain,
                },
            })
            .collect();
        Self {
            n,
            dim: 2 * n + nz,
            substeps: substeps(model, dt),
            states,
            bias: &model.bias,
            inv_mass: model.mass.iter().map(|m| 1.0 / m).collect(),
            force_inputs,
            input_terms,
            elements,
            outputs,
        }
    }

    /// Derivative `out` of state `s` with input values `u` and rates `ud`, and with
    /// `element_forces` each element's force; `n` is [`Plan::n`] (a constant in the
    /// specialised copies of [`Plan::integrate`]).
    ///
    /// An element's compression and rate are summed over all DOFs, zero coefficients
    /// included, and its force is subtracted from every DOF's acceleration: adding a zero
    /// coefficient's product `±0` changes only a `−0`, and a sum that starts at `+0` is
    /// never `−0` (a sum is `−0` only if both terms are), so the result is the sparse
    /// sum's bit for bit. (With finite states: a non-finite state is a divergence either
    /// way. An acceleration starts at the DOF's bias: only a bias of exactly `−0` could
    /// turn into `+0`.) A force input's zero coefficients are skipped (off the critical
    /// path, so the test costs nothing).
    #[inline(always)]
    fn eval(
        &self,
        n: usize,
        s: &State,
        u: &[f64],
        ud: &[f64],
        out: &mut State,
        mut element_forces: Option<&mut [f64]>,
    ) {
        let (q, qd) = s.m.split_at(n);
        let (vel, acc) = out.m.split_at_mut(n);
        vel.copy_from_slice(qd);
        acc.copy_from_slice(&self.bias[..n]);
        for &(j, t) in &self.force_inputs {
            let f = u[j];
            for (acc_i, &ti) in acc.iter_mut().zip(&t[..n]) {
                if ti != 0.0 {
                    *acc_i += ti * f;
                }
            }
        }
        for (i, e) in self.elements.iter().enumerate() {
            let a = &e.a[..n];
            let (mut x, mut v) = (0.0, 0.0);
            for ((ai, qi), qdi) in a.iter().zip(q).zip(qd) {
                x += ai * qi;
                v += ai * qdi;
            }
            for &(j, b) in &self.input_terms[e.b.clone()] {
                x += b * u[j];
                v += b * ud[j];
            }
            let zv = e.z.map_or(0.0, |k| s.z[k]);
            let f = e.law.force(x, v, zv);
            if let Some(forces) = element_forces.as_deref_mut() {
                forces[i] = f;
            }
            for (acc_i, ai) in acc.iter_mut().zip(a) {
                *acc_i -= ai * f;
            }
            if let Some(k) = e.z {
                out.z[k] = e.law.state_rate(x, v, zv);
            }
        }
        for (acc_i, im) in acc.iter_mut().zip(&self.inv_mass[..n]) {
            *acc_i *= im;
        }
    }

    /// Appends the outputs (and with [`Plan::states`] the DOF positions and velocities)
    /// at state `s` with derivative `deriv` and element forces `forces` (from
    /// [`Plan::eval`]) to `sim`; `n` as in [`Plan::eval`].
    ///
    /// An element's force is [`Plan::eval`]'s: the compression and rate
    /// [`element_motion`] gives summed densely over the inputs too, which is the same
    /// bit for bit (see [`Plan::eval`]).
    #[inline(always)]
    fn record(&self, n: usize, s: &State, deriv: &State, forces: &[f64], sim: &mut Simulation) {
        let (q, qd) = s.m.split_at(n);
        let qdd = &deriv.m[n..];
        if self.states {
            for i in 0..n {
                sim.q[i].push(q[i]);
                sim.qd[i].push(qd[i]);
            }
        }
        for (o, out) in self.outputs.iter().zip(&mut sim.outputs) {
            let v = match *o {
                PlannedOutput::Motion { c, of, gain } => {
                    // (Not one `dot` on a chosen slice: a pointer chosen at run time
                    // among the state vectors would keep them out of registers.)
                    let c = &c[..n];
                    let y = match of {
                        Derivative::Position => dot(c, q),
                        Derivative::Velocity => dot(c, qd),
                        Derivative::Acceleration => dot(c, qdd),
                    };
                    y * gain
                }
                PlannedOutput::Force { element, gain } => forces[element] * gain,
            };
            out.push(v);
        }
    }
}

/// A state vector (or a derivative) in two parts: the DOF positions and velocities
/// `m = [q, q̇]`, which the specialised integrators index by constants only (so that it
/// can live in registers), and the hysteretic states `z`, indexed at run time.
struct State<'a> {
    m: &'a mut [f64],
    z: &'a mut [f64],
}

impl<'a> State<'a> {
    /// The state with positions and velocities in `m` (cut to `2 n`), hysteretic states in
    /// `z`.
    #[inline(always)]
    fn new(m: &'a mut impl AsMut<[f64]>, z: &'a mut [f64], n: usize) -> Self {
        Self {
            m: &mut m.as_mut()[..2 * n],
            z,
        }
    }

    /// Sets `self = s + c k` (an RK4 stage's state).
    #[inline(always)]
    fn stage(&mut self, s: &State, k: &State, c: f64) {
        // (Part by part, not by a loop over the parts, which would take the parts'
        // addresses into memory and the state out of registers.)
        stage(self.m, s.m, k.m, c);
        stage(self.z, s.z, k.z, c);
    }

    /// Advances `self` by an RK4 step `h` with stage derivatives `k`.
    #[inline(always)]
    fn advance(&mut self, k: [&State; 4], h: f64) {
        let [k0, k1, k2, k3] = k;
        advance(self.m, [k0.m, k1.m, k2.m, k3.m], h);
        advance(self.z, [k0.z, k1.z, k2.z, k3.z], h);
    }

    /// Whether every component is finite and at most 1e9 in magnitude (`|v| <= 1e9` is
    /// false for NaN and infinities); without an early exit, so that it compiles to a few
    /// branch-free instructions.
    #[inline(always)]
    fn bounded(&self) -> bool {
        let ok = |part: &[f64]| part.iter().fold(true, |ok, v| ok & (v.abs() <= 1e9));
        ok(self.m) & ok(self.z)
    }
}

/// `out = s + c k`, componentwise.
#[inline(always)]
fn stage(out: &mut [f64], s: &[f64], k: &[f64], c: f64) {
    for ((t, si), ki) in out.iter_mut().zip(s).zip(k) {
        *t = si + c * ki;
    }
}

/// `s += h / 6 (k0 + 2 k1 + 2 k2 + k3)`, componentwise.
#[inline(always)]
fn advance(s: &mut [f64], k: [&[f64]; 4], h: f64) {
    let [k0, k1, k2, k3] = k;
    for ((((si, a), b), c), d) in s.iter_mut().zip(k0).zip(k1).zip(k2).zip(k3) {
        *si += h / 6.0 * (a + 2.0 * b + 2.0 * c + d);
    }
}

/// Compression (m) and its rate (m/s) of element `e` at DOF positions `q`, velocities `qd`
/// and inputs `u` with rates `ud` (force inputs have `b = 0`).
#[inline]
pub fn element_motion(
    e: &crate::model::Element,
    q: &[f64],
    qd: &[f64],
    u: &[f64],
    ud: &[f64],
) -> (f64, f64) {
    let mut x = 0.0;
    let mut v = 0.0;
    for ((a, qi), qdi) in e.a.iter().zip(q).zip(qd) {
        x += a * qi;
        v += a * qdi;
    }
    for ((b, ui), udi) in e.b.iter().zip(u).zip(ud) {
        x += b * ui;
        v += b * udi;
    }
    (x, v)
}

/// Simulates `model` over samples `range` of `record` with prepared inputs `inputs` (see
/// [`prepare_inputs`]), from DOF positions `q0` and velocities `qd0` at the first sample
/// (`None`: rest), hysteretic states at 0.
///
/// # Errors
/// The state becomes non-finite or grows beyond 1e9 (diverged).
pub fn simulate(
    model: &Model,
    record: &Record,
    inputs: &[Vec<f64>],
    range: std::ops::Range<usize>,
    initial: Option<(&[f64], &[f64])>,
) -> Result<Simulation> {
    run(model, record, inputs, range, initial, true, &[])
}

/// [`simulate`] recording the outputs only ([`Simulation::q`] and [`Simulation::qd`] are
/// left empty): the fits' inner loop, which needs no DOF histories.
///
/// # Errors
/// As [`simulate`].
pub fn simulate_outputs(
    model: &Model,
    record: &Record,
    inputs: &[Vec<f64>],
    range: std::ops::Range<usize>,
    initial: Option<(&[f64], &[f64])>,
) -> Result<Simulation> {
    run(model, record, inputs, range, initial, false, &[])
}

/// [`simulate_outputs`] from DOF positions `q0`, velocities `qd0` and hysteretic states
/// `z0` (one per element with hysteresis, in the elements' order) at the first sample.
///
/// # Errors
/// As [`simulate`].
pub fn simulate_outputs_from(
    model: &Model,
    record: &Record,
    inputs: &[Vec<f64>],
    range: std::ops::Range<usize>,
    (q0, qd0, z0): (&[f64], &[f64], &[f64]),
) -> Result<Simulation> {
    run(model, record, inputs, range, Some((q0, qd0)), false, z0)
}

fn run(
    model: &Model,
    record: &Record,
    inputs: &[Vec<f64>],
    range: std::ops::Range<usize>,
    initial: Option<(&[f64], &[f64])>,
    states: bool,
    z0: &[f64],
) -> Result<Simulation> {
    let plan = Plan::new(model, record.dt, states);
    // The small models get a copy of the integrator with their dimensions as constants;
    // the others share one.
    let span = (record, inputs, range, initial, z0);
    match plan.n {
        1 => plan.integrate(Fixed::<1, 2>, span),
        2 => plan.integrate(Fixed::<2, 4>, span),
        3 => plan.integrate(Fixed::<3, 6>, span),
        4 => plan.integrate(Fixed::<4, 8>, span),
        n => plan.integrate(Dynamic(n), span),
    }
}

/// The DOF count of a copy of the integrator: a constant ([`Fixed`]) for the small
/// models, so that the compiler unrolls the loops over DOFs, drops their bounds checks and
/// keeps the positions and velocities (stack arrays) in registers; a run-time value
/// ([`Dynamic`], heap vectors) otherwise.
trait Dims: Copy {
    /// Positions and velocities `[q, q̇]`.
    type Motion: AsMut<[f64]>;
    /// DOFs.
    fn n(self) -> usize;
    /// `[q, q̇]` of zeros.
    fn zeros(self) -> Self::Motion;
}

/// `N` DOFs known at compile time; `M = 2 N` (the length of `[q, q̇]`).
#[derive(Clone, Copy, Debug)]
struct Fixed<const N: usize, const M: usize>;

impl<const N: usize, const M: usize> Dims for Fixed<N, M> {
    type Motion = [f64; M];
    #[inline(always)]
    fn n(self) -> usize {
        N
    }
    #[inline(always)]
    fn zeros(self) -> [f64; M] {
        [0.0; M]
    }
}

/// A DOF count known at run time only.
#[derive(Clone, Copy, Debug)]
struct Dynamic(usize);

impl Dims for Dynamic {
    type Motion = Vec<f64>;
    fn n(self) -> usize {
        self.0
    }
    fn zeros(self) -> Vec<f64> {
        vec![0.0; 2 * self.0]
    }
}

/// What [`Plan::integrate`] runs over: the record, its prepared inputs, the sample range,
/// the initial DOF positions and velocities (as [`simulate`] takes them) and the initial
/// hysteretic states (as [`simulate_outputs_from`] takes them; empty: 0).
type Span<'r> = (
    &'r Record,
    &'r [Vec<f64>],
    std::ops::Range<usize>,
    Option<(&'r [f64], &'r [f64])>,
    &'r [f64],
);

impl Plan<'_> {
    /// Integrates over `span` with `dims` [`Plan::n`] DOFs.
    fn integrate<S: Dims>(&self, dims: S, span: Span<'_>) -> Result<Simulation> {
        let (record, inputs, range, initial, z0) = span;
        let n = dims.n();
        assert_eq!(n, self.n, "integrator DOFs");
        let (dt, sub) = (record.dt, self.substeps);
        let h = dt / sub as f64;
        let len = range.len();
        let history = |keep: bool| -> Vec<Vec<f64>> {
            let cap = if keep { len } else { 0 };
            (0..n).map(|_| Vec::with_capacity(cap)).collect()
        };
        let mut sim = Simulation {
            outputs: (0..self.outputs.len())
                .map(|_| Vec::with_capacity(len))
                .collect(),
            q: history(self.states),
            qd: history(self.states),
            substeps: sub,
        };
        // The state, the four RK4 stages (the first also the derivative at the sample) and
        // the stage state.
        // (Six separate variables, not an array of six: the compiler then keeps each in
        // registers where it can.)
        let nz = self.dim - 2 * n;
        let mut m = (
            dims.zeros(),
            dims.zeros(),
            dims.zeros(),
            dims.zeros(),
            dims.zeros(),
            dims.zeros(),
        );
        let mut z = (
            vec![0.0; nz],
            vec![0.0; nz],
            vec![0.0; nz],
            vec![0.0; nz],
            vec![0.0; nz],
            vec![0.0; nz],
        );
        let mut s = State::new(&mut m.0, &mut z.0, n);
        let mut k0 = State::new(&mut m.1, &mut z.1, n);
        let mut k1 = State::new(&mut m.2, &mut z.2, n);
        let mut k2 = State::new(&mut m.3, &mut z.3, n);
        let mut k3 = State::new(&mut m.4, &mut z.4, n);
        let mut tmp = State::new(&mut m.5, &mut z.5, n);
        if let Some((q0, qd0)) = initial {
            s.m[..n].copy_from_slice(q0);
            s.m[n..].copy_from_slice(qd0);
        }
        for (z, v) in s.z.iter_mut().zip(z0) {
            *z = *v;
        }
        // The inputs at the sample, at the next sample, their rates and interpolated.
        let ni = inputs.len();
        let mut input_buf = vec![0.0; 4 * ni];
        let (u, rest) = input_buf.split_at_mut(ni);
        let (u1, rest) = rest.split_at_mut(ni);
        let (ud, ua) = rest.split_at_mut(ni);
        // The element forces at the sample.
        let mut forces = vec![0.0; self.elements.len()];
        let last = record.len() - 1;
        for idx in range.clone() {
            let next = (idx + 1).min(last);
            for (j, col) in inputs.iter().enumerate() {
                u[j] = col[idx];
                u1[j] = col[next];
                ud[j] = if next > idx { (u1[j] - u[j]) / dt } else { 0.0 };
            }
            self.eval(n, &s, u, ud, &mut k0, Some(&mut forces));
            self.record(n, &s, &k0, &forces, &mut sim);
            if idx + 1 == range.end {
                break;
            }
            for st in 0..sub {
                let f0 = st as f64 / sub as f64;
                let fm = (st as f64 + 0.5) / sub as f64;
                let f1 = (st as f64 + 1.0) / sub as f64;
                let at = |f: f64, out: &mut [f64]| {
                    for ((o, a), b) in out.iter_mut().zip(&*u).zip(&*u1) {
                        *o = a + f * (b - a);
                    }
                };
                if st > 0 {
                    // (At the first step, `k0` is the derivative at the sample, just taken.)
                    at(f0, ua);
                    self.eval(n, &s, ua, ud, &mut k0, None);
                }
                at(fm, ua);
                tmp.stage(&s, &k0, 0.5 * h);
                self.eval(n, &tmp, ua, ud, &mut k1, None);
                tmp.stage(&s, &k1, 0.5 * h);
                self.eval(n, &tmp, ua, ud, &mut k2, None);
                at(f1, ua);
                tmp.stage(&s, &k2, h);
                self.eval(n, &tmp, ua, ud, &mut k3, None);
                s.advance([&k0, &k1, &k2, &k3], h);
            }
            if !s.bounded() {
                return Err(Error::Simulation(format!(
                    "diverged at t = {:.4} s (sample {idx})",
                    record.t0 + idx as f64 * dt
                )));
            }
        }
        Ok(sim)
    }
}

/// Dot product.
#[inline]
pub fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Half-width (decades) of the band around each power of 1000 (an SI prefix step: mm for m,
/// kN for N, µm for m) in which [`check_scale`] takes the ratio between an output column's
/// RMS and the model's response for a unit mistake.
pub const PREFIX_BAND_DECADES: f64 = 0.5;

/// Checks that no output column is an SI prefix step (a power of 1000) off the scale of the
/// model's response to the record's inputs (the linear model as given, simulated from rest
/// over the whole record; means removed): the ratio of RMS values is refused within
/// [`PREFIX_BAND_DECADES`] of 10^(3k), k ≠ 0. A model that is merely far off (a normalised
/// model of a circuit, like the Silverbox example's, 10^5 away) passes: recalibration fixes
/// its scale. Models that are not restrained on their own (a free mass) or whose simulation
/// diverges are not checked.
///
/// # Errors
/// An output whose scale looks like a unit mistake: the message names the column, the
/// ratio, the likely unit and the `gain` that would fix it.
pub fn check_scale(model: &Model, record: &Record) -> Result<()> {
    if !model.is_restrained() || record.len() < 16 {
        return Ok(());
    }
    let Ok(inputs) = prepare_inputs(model, record) else {
        return Ok(());
    };
    let Ok(sim) = simulate_outputs(model, record, &inputs, 0..record.len(), None) else {
        return Ok(());
    };
    let rms = |x: &[f64]| {
        let mean = x.iter().sum::<f64>() / x.len().max(1) as f64;
        (x.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / x.len().max(1) as f64).sqrt()
    };
    for (output, predicted) in model.outputs.iter().zip(&sim.outputs) {
        let measured = record.column(&output.column)?;
        let (m, p) = (rms(measured), rms(predicted));
        if !(m > 0.0 && p > 0.0 && m.is_finite() && p.is_finite()) {
            continue;
        }
        let ratio = m / p;
        let steps = (ratio.log10() / 3.0).round();
        if steps == 0.0 || (ratio.log10() - 3.0 * steps).abs() > PREFIX_BAND_DECADES {
            continue;
        }
        let decade = 10f64.powf(3.0 * steps);
        let unit = match (output.kind, 3 * steps as i32) {
            (OutputKind::Displacement, 3) => " (mm for m?)",
            (OutputKind::Displacement, 6) => " (µm for m?)",
            (OutputKind::Force, -3) => " (kN for N?)",
            (_, 3) => " (a milli-unit for the SI unit?)",
            _ => "",
        };
        return Err(Error::Record(format!(
            "column {:?} (a {:?} output) has {ratio:.3e} times the RMS of the model's response \
             to the record's inputs{unit}: if the column is in other units, give the output \
             gain = {:e} (column units per SI unit), or check the inputs' units",
            output.column,
            output.kind,
            decade * output.gain
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::effects::BoucWen;
    use crate::model::Output;

    /// The straightforward implementation this module had before [`Plan`] (closures over
    /// vectors per substep, every `Option` of the law matched per evaluation, sparse
    /// couplings, each element force output recomputed): the reference the integrator
    /// must match bit for bit.
    mod reference {
        use super::super::{dot, element_motion, substeps, Simulation};
        use crate::model::{InputKind, Model, OutputKind, Target};
        use crate::record::Record;
        use crate::{Error, Result};

        /// The model's equations of motion in a form the integrator evaluates quickly: only the
        /// non-zero couplings, `1 / mass` instead of a division.
        struct Rhs<'a> {
            n: usize,
            bias: &'a [f64],
            /// Per DOF.
            inv_mass: Vec<f64>,
            /// Force inputs: `(input index, [(DOF, t)])`.
            forces: Vec<(usize, Vec<(usize, f64)>)>,
            elements: Vec<CompiledElement<'a>>,
        }

        struct CompiledElement<'a> {
            /// `(DOF, a)` with `a ≠ 0`.
            a: Vec<(usize, f64)>,
            /// `(input, b)` with `b ≠ 0`.
            b: Vec<(usize, f64)>,
            law: &'a crate::effects::ElementLaw,
            /// Index of its hysteretic state in `s[2n..]`.
            z: Option<usize>,
        }

        impl<'a> Rhs<'a> {
            fn new(model: &'a Model) -> Self {
                let nonzero = |v: &[f64]| -> Vec<(usize, f64)> {
                    v.iter()
                        .copied()
                        .enumerate()
                        .filter(|(_, x)| *x != 0.0)
                        .collect()
                };
                let mut zi = 0;
                let elements = model
                    .elements
                    .iter()
                    .map(|e| {
                        let z = e.law.hysteresis.is_some().then(|| {
                            zi += 1;
                            zi - 1
                        });
                        CompiledElement {
                            a: nonzero(&e.a),
                            b: nonzero(&e.b),
                            law: &e.law,
                            z,
                        }
                    })
                    .collect();
                Self {
                    n: model.n(),
                    bias: &model.bias,
                    inv_mass: model.mass.iter().map(|m| 1.0 / m).collect(),
                    forces: model
                        .inputs
                        .iter()
                        .enumerate()
                        .filter(|(_, i)| i.kind == InputKind::Force)
                        .map(|(j, i)| (j, nonzero(&i.t)))
                        .collect(),
                    elements,
                }
            }

            /// Derivative of `s = [q, q̇, z]` with input values `u` and rates `ud`.
            fn eval(&self, s: &[f64], u: &[f64], ud: &[f64], out: &mut [f64]) {
                let n = self.n;
                let (q, rest) = s.split_at(n);
                let (qd, z) = rest.split_at(n);
                let (head, zrate) = out.split_at_mut(2 * n);
                let (vel, acc) = head.split_at_mut(n);
                vel.copy_from_slice(qd);
                acc.copy_from_slice(self.bias);
                for (j, t) in &self.forces {
                    let f = u[*j];
                    for &(i, ti) in t {
                        acc[i] += ti * f;
                    }
                }
                for e in &self.elements {
                    let (mut x, mut v) = (0.0, 0.0);
                    for &(i, a) in &e.a {
                        x += a * q[i];
                        v += a * qd[i];
                    }
                    for &(j, b) in &e.b {
                        x += b * u[j];
                        v += b * ud[j];
                    }
                    let zv = e.z.map_or(0.0, |k| z[k]);
                    let f = e.law.force(x, v, zv);
                    for &(i, a) in &e.a {
                        acc[i] -= a * f;
                    }
                    if let Some(k) = e.z {
                        zrate[k] = e.law.state_rate(x, v, zv);
                    }
                }
                for (a, im) in acc.iter_mut().zip(&self.inv_mass) {
                    *a *= im;
                }
            }
        }

        pub(super) fn run(
            model: &Model,
            record: &Record,
            inputs: &[Vec<f64>],
            range: std::ops::Range<usize>,
            initial: Option<(&[f64], &[f64])>,
            states: bool,
        ) -> Result<Simulation> {
            let n = model.n();
            let dt = record.dt;
            let nz = model
                .elements
                .iter()
                .filter(|e| e.law.hysteresis.is_some())
                .count();
            let dim = 2 * n + nz;
            let rhs = Rhs::new(model);
            let sub = substeps(model, dt);
            let h = dt / sub as f64;
            let mut s = vec![0.0; dim];
            if let Some((q0, qd0)) = initial {
                s[..n].copy_from_slice(q0);
                s[n..2 * n].copy_from_slice(qd0);
            }
            let len = range.len();
            let mut sim = Simulation {
                outputs: vec![Vec::with_capacity(len); model.outputs.len()],
                q: vec![Vec::with_capacity(if states { len } else { 0 }); n],
                qd: vec![Vec::with_capacity(if states { len } else { 0 }); n],
                substeps: sub,
            };
            let ni = inputs.len();
            let (mut u, mut ud, mut u1) = (vec![0.0; ni], vec![0.0; ni], vec![0.0; ni]);
            let mut ua = vec![0.0; ni];
            let mut k: [Vec<f64>; 4] = std::array::from_fn(|_| vec![0.0; dim]);
            let mut tmp = vec![0.0; dim];
            let mut deriv = vec![0.0; dim];
            for idx in range.clone() {
                let next = (idx + 1).min(record.len() - 1);
                for j in 0..ni {
                    u[j] = inputs[j][idx];
                    u1[j] = inputs[j][next];
                    ud[j] = if next > idx { (u1[j] - u[j]) / dt } else { 0.0 };
                }
                // Record the outputs at this sample.
                rhs.eval(&s, &u, &ud, &mut deriv);
                record_outputs(model, &s, &deriv, &u, &ud, &mut sim, states);
                if idx + 1 == range.end {
                    break;
                }
                for st in 0..sub {
                    let f0 = st as f64 / sub as f64;
                    let fm = (st as f64 + 0.5) / sub as f64;
                    let f1 = (st as f64 + 1.0) / sub as f64;
                    let at = |f: f64, out: &mut Vec<f64>| {
                        for j in 0..ni {
                            out[j] = u[j] + f * (u1[j] - u[j]);
                        }
                    };
                    if st == 0 {
                        // The derivative at the sample, with the sample's inputs, was just taken.
                        k[0].copy_from_slice(&deriv);
                    } else {
                        at(f0, &mut ua);
                        rhs.eval(&s, &ua, &ud, &mut k[0]);
                    }
                    at(fm, &mut ua);
                    let [k0, k1, k2, k3] = &mut k;
                    let stage = |tmp: &mut [f64], kk: &[f64], c: f64| {
                        for ((t, si), ki) in tmp.iter_mut().zip(&s).zip(kk) {
                            *t = si + c * ki;
                        }
                    };
                    stage(&mut tmp, k0, 0.5 * h);
                    rhs.eval(&tmp, &ua, &ud, k1);
                    stage(&mut tmp, k1, 0.5 * h);
                    rhs.eval(&tmp, &ua, &ud, k2);
                    at(f1, &mut ua);
                    stage(&mut tmp, k2, h);
                    rhs.eval(&tmp, &ua, &ud, k3);
                    for ((((si, a), b), c), d) in
                        s.iter_mut().zip(&*k0).zip(&*k1).zip(&*k2).zip(&*k3)
                    {
                        *si += h / 6.0 * (a + 2.0 * b + 2.0 * c + d);
                    }
                }
                if s.iter().any(|v| !v.is_finite() || v.abs() > 1e9) {
                    return Err(Error::Simulation(format!(
                        "diverged at t = {:.4} s (sample {idx})",
                        record.t0 + idx as f64 * dt
                    )));
                }
            }
            Ok(sim)
        }

        fn record_outputs(
            model: &Model,
            s: &[f64],
            deriv: &[f64],
            u: &[f64],
            ud: &[f64],
            sim: &mut Simulation,
            states: bool,
        ) {
            let n = model.n();
            let (q, qd, qdd) = (&s[..n], &s[n..2 * n], &deriv[n..2 * n]);
            if states {
                for i in 0..n {
                    sim.q[i].push(q[i]);
                    sim.qd[i].push(qd[i]);
                }
            }
            for (o, out) in model.outputs.iter().zip(&mut sim.outputs) {
                let v = match (&o.target, o.kind) {
                    (Target::Motion(c), OutputKind::Displacement) => dot(c, q),
                    (Target::Motion(c), OutputKind::Velocity) => dot(c, qd),
                    (Target::Motion(c), _) => dot(c, qdd),
                    (Target::Element(e), _) => {
                        let el = &model.elements[*e];
                        let (x, v) = element_motion(el, q, qd, u, ud);
                        let zi = model.elements[..*e]
                            .iter()
                            .filter(|e| e.law.hysteresis.is_some())
                            .count();
                        let z = if el.law.hysteresis.is_some() {
                            s[2 * n + zi]
                        } else {
                            0.0
                        };
                        el.law.force(x, v, z)
                    }
                };
                out.push(v * o.gain);
            }
        }
    }

    /// Reads `examples/NAME`.
    fn example(name: &str) -> Model {
        let path = format!("{}/examples/{name}", env!("CARGO_MANIFEST_DIR"));
        Model::from_toml(&std::fs::read_to_string(path).expect("example")).expect("model")
    }

    /// A chain of `n` 10 kg masses, each on a spring-damper to the one below, the lowest on
    /// a prescribed base displacement `base`, a force `push` at the top mass (with
    /// displacement and force outputs).
    fn chain(n: usize) -> Model {
        let mut text = String::from("name = \"chain\"\n");
        for i in 0..n {
            text += &format!("[[dof]]\nname = \"m{i}\"\nmass = {}\n", 10.0 + i as f64);
        }
        for i in 0..n {
            let lower = if i == 0 {
                "base".to_string()
            } else {
                format!("m{}", i - 1)
            };
            text += &format!(
                "[[element]]\nname = \"e{i}\"\nupper = \"m{i}\"\nlower = \"{lower}\"\n\
                 stiffness_n_per_m = {}\ndamping_n_s_per_m = 40.0\n",
                2.0e4 * (1.0 + 0.1 * i as f64)
            );
        }
        text += &format!(
            "[[input]]\nname = \"base\"\nkind = \"displacement\"\ncolumn = \"base\"\n\
             [[input]]\nname = \"push\"\nkind = \"force\"\ncolumn = \"push\"\nat = \"m{}\"\n\
             [[output]]\ncolumn = \"top\"\nkind = \"displacement\"\nof = \"m{}\"\n",
            n - 1,
            n - 1
        );
        Model::from_toml(&text).expect("chain model")
    }

    /// A record of `len` samples (1 ms) with smooth random signals on `model`'s input
    /// columns: displacements of about 10 mm, forces of about 10 mm times the total
    /// stiffness (100 N without stiffness).
    fn record_for(model: &Model, len: usize, seed: u64) -> Record {
        let stiffness: f64 = model.elements.iter().map(|e| e.law.k.abs()).sum();
        let mut s = seed | 1;
        let mut names = Vec::new();
        let mut columns = Vec::new();
        for inp in &model.inputs {
            let scale = match inp.kind {
                InputKind::Displacement => 0.01,
                InputKind::Force if stiffness > 0.0 => 0.01 * stiffness,
                InputKind::Force => 100.0,
            };
            let mut y = 0.0;
            let col: Vec<f64> = (0..len)
                .map(|_| {
                    s ^= s << 13;
                    s ^= s >> 7;
                    s ^= s << 17;
                    let r = (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
                    y = 0.98 * y + 0.2 * r;
                    y * scale / 0.3 / inp.gain
                })
                .collect();
            names.push(inp.column.clone());
            columns.push(col);
        }
        let t: Vec<f64> = (0..len).map(|i| i as f64 * 1e-3).collect();
        Record::new(&t, names, columns).expect("record")
    }

    /// Adds velocity and acceleration outputs of every DOF and a force output of every
    /// element (gains other than 1).
    fn add_outputs(model: &mut Model) {
        let n = model.n();
        for i in 0..n {
            let mut c = vec![0.0; n];
            c[i] = 1.0;
            for kind in [OutputKind::Velocity, OutputKind::Acceleration] {
                model.outputs.push(Output {
                    column: format!("{kind:?}{i}"),
                    kind,
                    target: Target::Motion(c.clone()),
                    gain: 1.5,
                });
            }
        }
        for e in 0..model.elements.len() {
            model.outputs.push(Output {
                column: format!("force{e}"),
                kind: OutputKind::Force,
                target: Target::Element(e),
                gain: 2.0,
            });
        }
    }

    /// RMS compression (m) and compression rate (m/s) of each element of `model` over
    /// `record` (reference simulation).
    fn motion_rms(model: &Model, record: &Record) -> Vec<(f64, f64)> {
        let inputs = prepare_inputs(model, record).expect("inputs");
        let sim = reference::run(model, record, &inputs, 0..record.len(), None, true)
            .expect("linear model settles");
        let len = record.len();
        model
            .elements
            .iter()
            .map(|e| {
                let (mut sx, mut sv) = (0.0, 0.0);
                for t in 0..len {
                    let q: Vec<f64> = sim.q.iter().map(|h| h[t]).collect();
                    let qd: Vec<f64> = sim.qd.iter().map(|h| h[t]).collect();
                    let u: Vec<f64> = inputs.iter().map(|c| c[t]).collect();
                    let ud = vec![0.0; u.len()];
                    let (x, v) = element_motion(e, &q, &qd, &u, &ud);
                    sx += x * x;
                    sv += v * v;
                }
                let rms = |s: f64| (s / len as f64).sqrt().max(1e-6);
                (rms(sx), rms(sv))
            })
            .collect()
    }

    /// Which element effects a variant switches on.
    #[derive(Clone, Copy, Debug)]
    enum Variant {
        /// Bump and rebound stops, lift-off.
        Stops,
        /// Coulomb friction, quadratic and asymmetric damping, cubic stiffness.
        Damping,
        /// Hysteresis (`n = 1` and `n = 1.5` alternately) and backlash.
        Hysteresis,
        /// Every element effect at once (hysteresis `n = 1`).
        All,
    }

    /// Switches the effects of `variant` on in every element of `model`, scaled to the
    /// RMS compression and rate `rms` of the linear model so that they act.
    fn with_effects(model: &Model, variant: Variant, rms: &[(f64, f64)]) -> Model {
        let mut m = model.clone();
        for (i, (e, &(x, v))) in m.elements.iter_mut().zip(rms).enumerate() {
            let l = &mut e.law;
            let k = l.k.max(1e3);
            let c = l.c.max(10.0);
            let stops = |l: &mut crate::effects::ElementLaw| {
                l.bump = Some((0.5 * x, 5.0 * k));
                l.rebound = Some((0.8 * x, 3.0 * k));
                l.lift_off = Some(1.2 * k * x);
            };
            let damping = |l: &mut crate::effects::ElementLaw| {
                l.coulomb = Some((0.1 * k * x, 0.05 * v));
                l.c2 = Some(0.5 * c / v);
                l.c_abs = Some(-0.3 * c);
                l.k3 = Some(0.5 * k / (x * x));
            };
            let hysteresis = |l: &mut crate::effects::ElementLaw, n: f64| {
                // (`k`, not `l.k`: a spring for the hysteresis of a damper alone too.)
                l.k_h = 0.5 * k;
                l.k *= 0.5;
                l.hysteresis = Some(BoucWen {
                    a: 1.0,
                    beta: 0.5 / x.powf(n),
                    gamma: 0.2 / x.powf(n),
                    n,
                });
                l.backlash = Some(0.1 * x);
            };
            match variant {
                Variant::Stops => stops(l),
                Variant::Damping => damping(l),
                Variant::Hysteresis => hysteresis(l, if i % 2 == 0 { 1.0 } else { 1.5 }),
                Variant::All => {
                    stops(l);
                    damping(l);
                    hysteresis(l, 1.0);
                }
            }
        }
        m
    }

    /// Whether two simulations are the same bit for bit.
    fn assert_same(a: &Simulation, b: &Simulation, what: &str) {
        assert_eq!(a.substeps, b.substeps, "{what}: substeps");
        for (name, x, y) in [
            ("outputs", &a.outputs, &b.outputs),
            ("q", &a.q, &b.q),
            ("qd", &a.qd, &b.qd),
        ] {
            assert_eq!(x.len(), y.len(), "{what}: {name} count");
            for (k, (u, v)) in x.iter().zip(y).enumerate() {
                assert_eq!(u.len(), v.len(), "{what}: {name}[{k}] length");
                for (t, (p, r)) in u.iter().zip(v).enumerate() {
                    assert!(
                        p.to_bits() == r.to_bits(),
                        "{what}: {name}[{k}] at sample {t}: {p:e} != {r:e}"
                    );
                }
            }
        }
    }

    /// Simulates `model` over `record` both ways, with and without the DOF histories, over
    /// the whole record from rest and over two windows from the reference's state.
    fn compare(model: &Model, record: &Record, what: &str) {
        let inputs = prepare_inputs(model, record).expect("inputs");
        let len = record.len();
        let whole = reference::run(model, record, &inputs, 0..len, None, true).expect(what);
        for (range, from) in [(0..len, None), (137..len, Some(137)), (50..901, Some(50))] {
            let q0: Option<(Vec<f64>, Vec<f64>)> = from.map(|t| {
                (
                    whole.q.iter().map(|h| h[t]).collect(),
                    whole.qd.iter().map(|h| h[t]).collect(),
                )
            });
            let initial = q0.as_ref().map(|(q, qd)| (&q[..], &qd[..]));
            for states in [true, false] {
                let want = reference::run(model, record, &inputs, range.clone(), initial, states);
                let got = run(model, record, &inputs, range.clone(), initial, states, &[]);
                let what = format!("{what}, samples {range:?}, states {states}");
                assert_same(&got.expect(&what), &want.expect(&what), &what);
            }
        }
    }

    /// A hysteretic state given at the start acts as the element's force `k_h z₀` on a
    /// model at rest: `|y| = k_h z₀ t² / (2 m)` after a short time `t` (ω t = 0.2, where the
    /// spring's own restoring force is still 0.3 % of it), opposite for `−z₀`, and nothing
    /// moves from `z₀ = 0`.
    #[test]
    fn an_initial_hysteretic_state_acts_as_its_force() {
        let mut model = example("boucwen.toml");
        let law = &mut model.elements[0].law;
        (law.k, law.k_h) = (4.0e4, 4.0e4);
        law.hysteresis = Some(BoucWen {
            a: 1.0,
            beta: 500.0,
            gamma: 500.0,
            n: 1.0,
        });
        let k_h = law.k_h;
        let len = 16;
        let t: Vec<f64> = (0..len).map(|i| i as f64 * 1e-3).collect();
        let record = Record::new(&t, vec!["u".into()], vec![vec![0.0; len]]).expect("record");
        let inputs = prepare_inputs(&model, &record).expect("inputs");
        let from = |z0: f64| {
            let sim =
                simulate_outputs_from(&model, &record, &inputs, 0..len, (&[0.0], &[0.0], &[z0]));
            sim.expect("simulation").outputs[0][1]
        };
        assert_eq!(from(0.0), 0.0);
        let z0 = 1e-4;
        let want = k_h * z0 * 1e-6 / (2.0 * model.mass[0]);
        let (up, down) = (from(z0), from(-z0));
        assert!(
            (up.abs() - want).abs() <= 0.01 * want,
            "{up} against {want}"
        );
        assert!((up + down).abs() <= 1e-6 * want, "{up} and {down}");
    }

    #[test]
    fn integrator_matches_the_reference_bit_for_bit() {
        let mut models: Vec<(String, Model)> = [
            "quarter-car.toml",
            "half-car.toml",
            "boucwen.toml",
            "oscillator.toml",
            "silverbox.toml",
            "emps.toml",
        ]
        .iter()
        .map(|name| (name.to_string(), example(name)))
        .collect();
        // Three DOFs (a constant in the integrator) and six (a run-time value).
        models.push(("chain of 3".into(), chain(3)));
        models.push(("chain of 6".into(), chain(6)));
        let mut acted = 0;
        for (seed, (name, mut model)) in models.into_iter().enumerate() {
            add_outputs(&mut model);
            let record = record_for(&model, 2000, 0x9e37_79b9 + seed as u64);
            compare(&model, &record, &format!("{name} linear"));
            let rms = motion_rms(&model, &record);
            let inputs = prepare_inputs(&model, &record).expect("inputs");
            let linear =
                simulate_outputs(&model, &record, &inputs, 0..record.len(), None).expect("linear");
            for variant in [
                Variant::Stops,
                Variant::Damping,
                Variant::Hysteresis,
                Variant::All,
            ] {
                let m = with_effects(&model, variant, &rms);
                let what = format!("{name} {variant:?}");
                compare(&m, &record, &what);
                // The effects act (the outputs move away from the linear model's).
                let sim =
                    simulate_outputs(&m, &record, &inputs, 0..record.len(), None).expect(&what);
                if sim.outputs != linear.outputs {
                    acted += 1;
                }
            }
            // Lift-off reached: some element force at exactly minus its preload.
            let m = with_effects(&model, Variant::Stops, &rms);
            let sim = simulate_outputs(&m, &record, &inputs, 0..record.len(), None).expect("");
            let lifted = m
                .outputs
                .iter()
                .zip(&sim.outputs)
                .any(|(o, y)| match o.target {
                    Target::Element(e) => {
                        let p = m.elements[e].law.lift_off.expect("lift-off on");
                        y.iter().any(|v| *v == -p * o.gain)
                    }
                    Target::Motion(_) => false,
                });
            assert!(lifted, "{name}: no lift-off");
        }
        assert_eq!(acted, 8 * 4, "every variant changes the outputs");
    }

    #[test]
    fn divergence_is_reported_at_the_same_sample() {
        let mut model = example("quarter-car.toml");
        model.elements[0].law.k = -5e5;
        model.elements[1].law.lift_off = Some(1667.0);
        let record = record_for(&model, 3000, 7);
        let inputs = prepare_inputs(&model, &record).expect("inputs");
        for states in [true, false] {
            let want = reference::run(&model, &record, &inputs, 0..3000, None, states);
            let got = run(&model, &record, &inputs, 0..3000, None, states, &[]);
            let (want, got) = (want.unwrap_err(), got.unwrap_err());
            assert!(want.to_string().contains("diverged"), "{want}");
            assert_eq!(got.to_string(), want.to_string());
        }
    }
}
