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
    run(model, record, inputs, range, initial, true)
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
    run(model, record, inputs, range, initial, false)
}

fn run(
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
            for ((((si, a), b), c), d) in s.iter_mut().zip(&*k0).zip(&*k1).zip(&*k2).zip(&*k3) {
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

/// Dot product.
#[inline]
pub fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}
