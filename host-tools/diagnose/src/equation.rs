//! The equation-error (inverse-dynamics) formulation on measured states.
//!
//! With every DOF's position measured (by displacement outputs, or for the DOFs they leave
//! open by accelerometers, [`crate::accelerometer`]), the states `q`, `q̇`, `q̈` are estimated by a
//! zero-phase low-pass `F` (fourth-order Butterworth, forward-backward) and five-point
//! differences. Each DOF's equation of motion
//!
//! ```text
//! m_i q̈_i + Σ_e a_ei F_e(x_e, ẋ_e, z_e) − bias_i = Σ_j t_ji f_j
//! ```
//!
//! is linear in the masses, the bias, the element coefficients `k`, `c` and most effects'
//! coefficients ([`Coef`]); the regressors are built from the estimated states, then every
//! column and the right-hand side are filtered once more by `F` (so the linear part is
//! filtered identically on both sides) and decimated to about five samples per cut-off
//! period. Models that are not stable on their own (a free mass driven by a force) are
//! handled by this formulation alone.
//!
//! The cut-off is set from the data: the highest frequency at which the measured
//! displacements' spectrum stands [`signal::SNR`] times above its noise floor
//! ([`signal::signal_band_edge_hz`]), within [0.002, 0.4] of the sample rate.

use crate::effects::BoucWen;
use crate::model::{InputKind, Model, OutputKind, Target};
use crate::record::Record;
use crate::signal;
use crate::Result;
use nalgebra::{DMatrix, DVector};
use std::sync::Arc;

/// Estimated states of the measured record (per DOF, per sample).
#[derive(Clone, Debug)]
pub struct States {
    /// Positions (m, rad).
    pub q: Vec<Vec<f64>>,
    /// Velocities.
    pub qd: Vec<Vec<f64>>,
    /// Accelerations.
    pub qdd: Vec<Vec<f64>>,
    /// Inputs in SI units (gain applied, no input effects) as the record holds them, not
    /// filtered like the states (`diagnose` passes its record with the logged inputs
    /// low-passed, [`crate::diagnose::prefilter_inputs`]: the input effects act on those).
    pub inputs_raw: Vec<Vec<f64>>,
    /// Measured element forces (N, SI: the column over its gain): `(element, force)` per
    /// force output. Each adds an equation `F_e(x_e, ẋ_e, z_e) = measured` per sample,
    /// which fixes the scale of the element's coefficients and so, through the equations
    /// of motion, the masses.
    pub forces_measured: Vec<(usize, Vec<f64>)>,
    /// Cut-off of the filter (Hz).
    pub fc_hz: f64,
    /// Sample interval (s).
    pub dt: f64,
    /// Decimation factor of the regression.
    pub decimation: usize,
    /// Samples dropped at each end (filter transients).
    pub edge: usize,
    /// The sample ranges the regression draws its rows from (the filter transients left
    /// out): one for a whole record, one per piece of [`States::pieces`].
    pub rows: Vec<std::ops::Range<usize>>,
    /// Memo of the state filter, its decimated results at the regression's samples: every
    /// `decimation`-th sample of each of [`States::rows`].
    pub cache: signal::LowpassCache,
}

/// Least-squares map from the displacement outputs to the DOF positions, if the
/// displacement outputs determine every DOF: `(matrix n × outputs, output indices)`.
pub fn displacement_map(model: &Model) -> Option<(DMatrix<f64>, Vec<usize>)> {
    let n = model.n();
    let rows: Vec<(usize, Vec<f64>)> = model
        .outputs
        .iter()
        .enumerate()
        .filter_map(|(i, o)| match (&o.target, o.kind) {
            (Target::Motion(c), OutputKind::Displacement) => {
                Some((i, c.iter().map(|v| v * o.gain).collect()))
            }
            _ => None,
        })
        .collect();
    if rows.len() < n {
        return None;
    }
    let c = DMatrix::from_fn(rows.len(), n, |r, j| rows[r].1[j]);
    let ctc = c.transpose() * &c;
    let eig = ctc.clone().symmetric_eigenvalues();
    let max = eig.iter().cloned().fold(0.0, f64::max);
    if !(max > 0.0 && eig.iter().all(|&v| v > 1e-10 * max)) {
        return None;
    }
    let pinv = ctc.try_inverse()? * c.transpose();
    Some((pinv, rows.into_iter().map(|r| r.0).collect()))
}

/// The DOFs (names) whose positions the displacement outputs do not determine: those with
/// a component outside the span of the outputs' coefficient rows (empty if they determine
/// every DOF).
pub fn undetermined_dofs(model: &Model) -> Vec<String> {
    let n = model.n();
    let rows: Vec<Vec<f64>> = model
        .outputs
        .iter()
        .filter_map(|o| match (&o.target, o.kind) {
            (Target::Motion(c), OutputKind::Displacement) => {
                Some(c.iter().map(|v| v * o.gain).collect())
            }
            _ => None,
        })
        .filter(|r: &Vec<f64>| r.iter().all(|v| v.is_finite()))
        .collect();
    // An orthonormal basis of the rows' span (Gram–Schmidt, twice for stability), then
    // each DOF's unit vector checked against it.
    let scale = rows
        .iter()
        .flatten()
        .fold(0.0_f64, |m, v| m.max(v.abs()))
        .max(f64::MIN_POSITIVE);
    let mut basis: Vec<Vec<f64>> = Vec::new();
    for r in &rows {
        let mut v: Vec<f64> = r.iter().map(|x| x / scale).collect();
        for _ in 0..2 {
            for b in &basis {
                let d: f64 = v.iter().zip(b).map(|(x, y)| x * y).sum();
                v.iter_mut().zip(b).for_each(|(x, y)| *x -= d * y);
            }
        }
        let norm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        if norm > 1e-6 {
            basis.push(v.iter().map(|x| x / norm).collect());
        }
    }
    (0..n)
        .filter(|&j| {
            let in_span: f64 = basis.iter().map(|b| b[j] * b[j]).sum();
            in_span < 1.0 - 1e-9
        })
        .map(|j| model.dofs[j].clone())
        .collect()
}

/// Estimates the states from the displacement outputs (see the module documentation), and
/// from accelerometers for the DOFs the displacements leave open ([`crate::accelerometer`]).
///
/// # Errors
/// The displacement and acceleration outputs do not determine every DOF, or a column is
/// missing.
pub fn estimate_states(model: &Model, record: &Record) -> Result<States> {
    let n = model.n();
    let len = record.len();
    let dt = record.dt;
    let q = match displacement_map(model) {
        Some((pinv, idx)) => {
            let meas: Vec<&[f64]> = idx
                .iter()
                .map(|&i| record.column(&model.outputs[i].column))
                .collect::<Result<_>>()?;
            let mut q = vec![vec![0.0; len]; n];
            for t in 0..len {
                for (i, qi) in q.iter_mut().enumerate() {
                    qi[t] = meas
                        .iter()
                        .enumerate()
                        .map(|(r, m)| pinv[(i, r)] * m[t])
                        .sum();
                }
            }
            q
        }
        None => {
            let open = undetermined_dofs(model);
            crate::accelerometer::positions(model, record, &open)?
        }
    };
    let edge = q
        .iter()
        .map(|qi| signal::signal_band_edge_hz(qi, dt, signal::SNR))
        .fold(0.0, f64::max);
    let fs = 1.0 / dt;
    let fc_hz = edge.clamp(0.002 * fs, 0.4 * fs);
    let qf: Vec<Vec<f64>> = q
        .iter()
        .map(|x| signal::lowpass_zero_phase(x, fc_hz, dt))
        .collect();
    let qd = qf.iter().map(|x| signal::derivative(x, dt)).collect();
    let qdd = qf
        .iter()
        .map(|x| signal::second_derivative(x, dt))
        .collect();
    let inputs_raw = model
        .inputs
        .iter()
        .map(|inp| {
            Ok(record
                .column(&inp.column)?
                .iter()
                .map(|v| v * inp.gain)
                .collect())
        })
        .collect::<Result<_>>()?;
    let forces_measured = model
        .outputs
        .iter()
        .filter_map(|o| match (&o.target, o.kind) {
            (Target::Element(e), OutputKind::Force) => Some((*e, o)),
            _ => None,
        })
        .map(|(e, o)| {
            Ok((
                e,
                record
                    .column(&o.column)?
                    .iter()
                    .map(|v| v / o.gain)
                    .collect(),
            ))
        })
        .collect::<Result<_>>()?;
    let decimation = ((fs / (5.0 * fc_hz)).floor() as usize).max(1);
    let edge = ((2.0 / (fc_hz * dt)).ceil() as usize).min(len / 20);
    let rows = std::iter::once(edge..len.saturating_sub(edge)).collect();
    let keep = (edge..len.saturating_sub(edge))
        .step_by(decimation)
        .collect();
    Ok(States {
        cache: signal::LowpassCache::new(fc_hz, dt, keep),
        rows,
        q: qf,
        qd,
        qdd,
        inputs_raw,
        forces_measured,
        fc_hz,
        dt,
        decimation,
        edge,
    })
}

impl States {
    /// The states of the record's first `len` samples (at most the record), with their
    /// own filter memo: the regression of a prefix, filtered over the prefix alone.
    pub fn prefix(&self, len: usize) -> States {
        let len = len.min(self.q.first().map_or(0, Vec::len));
        self.pieces(std::slice::from_ref(&(0..len)), 0)
    }

    /// The states of the record's pieces `ranges` (each within the record), concatenated,
    /// with their own filter memo that filters each piece on its own: a shorter regression
    /// problem drawn from the whole record. The states themselves are those of the whole
    /// record; each piece's rows start after `warmup` samples (at least the filter
    /// transient [`States::edge`]), so that the input effects and hysteretic states the
    /// regression integrates along a piece have settled from its start, and end
    /// [`States::edge`] before its end.
    pub fn pieces(&self, ranges: &[std::ops::Range<usize>], warmup: usize) -> States {
        let total = self.q.first().map_or(0, Vec::len);
        let ranges: Vec<std::ops::Range<usize>> = ranges
            .iter()
            .map(|r| r.start.min(total)..r.end.min(total))
            .filter(|r| !r.is_empty())
            .collect();
        let cut_one = |x: &[f64]| -> Vec<f64> {
            ranges
                .iter()
                .flat_map(|r| x[r.clone()].iter().copied())
                .collect()
        };
        let cut = |v: &[Vec<f64>]| -> Vec<Vec<f64>> { v.iter().map(|x| cut_one(x)).collect() };
        let (mut segments, mut rows, mut keep) = (Vec::new(), Vec::new(), Vec::new());
        let mut start = 0;
        for r in &ranges {
            let end = start + r.len();
            let row = (start + warmup.max(self.edge))..end.saturating_sub(self.edge);
            keep.extend(row.clone().step_by(self.decimation));
            segments.push(start..end);
            rows.push(row);
            start = end;
        }
        States {
            q: cut(&self.q),
            qd: cut(&self.qd),
            qdd: cut(&self.qdd),
            inputs_raw: cut(&self.inputs_raw),
            forces_measured: self
                .forces_measured
                .iter()
                .map(|(e, f)| (*e, cut_one(f)))
                .collect(),
            fc_hz: self.fc_hz,
            dt: self.dt,
            decimation: self.decimation,
            edge: self.edge,
            rows,
            cache: signal::LowpassCache::segmented(self.fc_hz, self.dt, keep, segments),
        }
    }

    /// The values of `x` (a signal along the states) in [`States::rows`]: the samples a
    /// distribution of the record is taken over.
    pub fn interior(&self, x: &[f64]) -> Vec<f64> {
        self.rows
            .iter()
            .flat_map(|r| x.get(r.clone()).unwrap_or(&[]).iter().copied())
            .collect()
    }
}

/// A coefficient that enters the equations of motion linearly.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Coef {
    /// Mass of DOF `i` (kg, kg·m²).
    Mass(usize),
    /// Bias (constant generalised force) of DOF `i` (N, N·m).
    Bias(usize),
    /// Spring coefficient `k_s` of element `e` (N/m).
    K(usize),
    /// Damping `c` of element `e` (N·s/m).
    C(usize),
    /// Hysteretic spring coefficient `k_h` of element `e` (N/m).
    KH(usize),
    /// Cubic stiffness `k3` of element `e` (N/m³).
    K3(usize),
    /// Asymmetric damping half difference `c_abs` of element `e` (N·s/m).
    CAbs(usize),
    /// Quadratic damping `c2` of element `e` (N·s²/m²).
    C2(usize),
    /// Coulomb friction force `F_c` of element `e` (N).
    Fc(usize),
    /// Bump-stop stiffness of element `e` (N/m).
    BumpK(usize),
    /// Rebound-stop stiffness of element `e` (N/m).
    RebK(usize),
}

impl Coef {
    /// The element it belongs to (`None` for a DOF's mass or bias).
    pub fn element(self) -> Option<usize> {
        match self {
            Coef::Mass(_) | Coef::Bias(_) => None,
            Coef::K(e)
            | Coef::C(e)
            | Coef::KH(e)
            | Coef::K3(e)
            | Coef::CAbs(e)
            | Coef::C2(e)
            | Coef::Fc(e)
            | Coef::BumpK(e)
            | Coef::RebK(e) => Some(e),
        }
    }

    /// A number that tells the variants apart (memo keys).
    fn tag(self) -> u64 {
        match self {
            Coef::Mass(_) => 0,
            Coef::Bias(_) => 1,
            Coef::K(_) => 2,
            Coef::C(_) => 3,
            Coef::KH(_) => 4,
            Coef::K3(_) => 5,
            Coef::CAbs(_) => 6,
            Coef::C2(_) => 7,
            Coef::Fc(_) => 8,
            Coef::BumpK(_) => 9,
            Coef::RebK(_) => 10,
        }
    }

    /// Its value in `model`.
    pub fn get(self, m: &Model) -> f64 {
        let law = |e: usize| &m.elements[e].law;
        match self {
            Coef::Mass(i) => m.mass[i],
            Coef::Bias(i) => m.bias[i],
            Coef::K(e) => law(e).k,
            Coef::C(e) => law(e).c,
            Coef::KH(e) => law(e).k_h,
            Coef::K3(e) => law(e).k3.unwrap_or(0.0),
            Coef::CAbs(e) => law(e).c_abs.unwrap_or(0.0),
            Coef::C2(e) => law(e).c2.unwrap_or(0.0),
            Coef::Fc(e) => law(e).coulomb.map_or(0.0, |c| c.0),
            Coef::BumpK(e) => law(e).bump.map_or(0.0, |c| c.1),
            Coef::RebK(e) => law(e).rebound.map_or(0.0, |c| c.1),
        }
    }

    /// Sets its value in `model` (switching the effect on where it is an effect's).
    pub fn set(self, m: &mut Model, v: f64) {
        match self {
            Coef::Mass(i) => m.mass[i] = v,
            Coef::Bias(i) => m.bias[i] = v,
            Coef::K(e) => m.elements[e].law.k = v,
            Coef::C(e) => m.elements[e].law.c = v,
            Coef::KH(e) => m.elements[e].law.k_h = v,
            Coef::K3(e) => m.elements[e].law.k3 = Some(v),
            Coef::CAbs(e) => m.elements[e].law.c_abs = Some(v),
            Coef::C2(e) => m.elements[e].law.c2 = Some(v),
            Coef::Fc(e) => {
                let l = &mut m.elements[e].law;
                l.coulomb = Some((v, l.coulomb.map_or(1e-3, |c| c.1)));
            }
            Coef::BumpK(e) => {
                let l = &mut m.elements[e].law;
                l.bump = Some((l.bump.map_or(0.0, |c| c.0), v));
            }
            Coef::RebK(e) => {
                let l = &mut m.elements[e].law;
                l.rebound = Some((l.rebound.map_or(0.0, |c| c.0), v));
            }
        }
    }

    /// A readable name, e.g. `"suspension.stiffness_n_per_m"`.
    pub fn label(self, m: &Model) -> String {
        let el = |e: usize| m.elements[e].name.as_str();
        match self {
            Coef::Mass(i) => format!("{}.mass", m.dofs[i]),
            Coef::Bias(i) => format!("{}.bias_n", m.dofs[i]),
            Coef::K(e) => format!("{}.stiffness_n_per_m", el(e)),
            Coef::C(e) => format!("{}.damping_n_s_per_m", el(e)),
            Coef::KH(e) => format!("{}.hysteretic_stiffness_n_per_m", el(e)),
            Coef::K3(e) => format!("{}.cubic_stiffness_n_per_m3", el(e)),
            Coef::CAbs(e) => format!("{}.asymmetric_half_difference_n_s_per_m", el(e)),
            Coef::C2(e) => format!("{}.quadratic_damping_n_s2_per_m2", el(e)),
            Coef::Fc(e) => format!("{}.coulomb_force_n", el(e)),
            Coef::BumpK(e) => format!("{}.bump_stop_n_per_m", el(e)),
            Coef::RebK(e) => format!("{}.rebound_stop_n_per_m", el(e)),
        }
    }
}

/// Per element, over the record: compression (m), rate (m/s), hysteretic state (m).
pub struct ElementSignals {
    /// Compression.
    pub x: Vec<f64>,
    /// Compression rate.
    pub v: Vec<f64>,
    /// Hysteretic deflection (zeros without hysteresis).
    pub z: Vec<f64>,
}

/// Inputs as `model` sees them (input effects applied), filtered like the states; their
/// rates (for displacement inputs).
pub fn model_inputs(model: &Model, st: &States) -> (Vec<Vec<f64>>, Vec<Vec<f64>>) {
    let mut u = Vec::new();
    let mut ud = Vec::new();
    for (inp, raw) in model.inputs.iter().zip(&st.inputs_raw) {
        let t = inp.law.transform(raw, st.dt);
        let f = st.cache.full(&t);
        ud.push(if inp.kind == InputKind::Displacement {
            signal::derivative(&f, st.dt)
        } else {
            vec![0.0; f.len()]
        });
        u.push(f.to_vec());
    }
    (u, ud)
}

/// Compression, rate and hysteretic state of every element along the estimated states.
pub fn element_signals(
    model: &Model,
    st: &States,
    u: &[Vec<f64>],
    ud: &[Vec<f64>],
) -> Vec<ElementSignals> {
    let len = st.q.first().map_or(0, Vec::len);
    model
        .elements
        .iter()
        .map(|e| {
            let mut x = vec![0.0; len];
            let mut v = vec![0.0; len];
            for (a, (q, qd)) in e.a.iter().zip(st.q.iter().zip(&st.qd)) {
                if *a != 0.0 {
                    for t in 0..len {
                        x[t] += a * q[t];
                        v[t] += a * qd[t];
                    }
                }
            }
            for (b, (w, wd)) in e.b.iter().zip(u.iter().zip(ud)) {
                if *b != 0.0 {
                    for t in 0..len {
                        x[t] += b * w[t];
                        v[t] += b * wd[t];
                    }
                }
            }
            let z = match e.law.hysteresis {
                Some(bw) => hysteretic_state(&e.law, bw, &x, &v, st.dt),
                None => vec![0.0; len],
            };
            ElementSignals { x, v, z }
        })
        .collect()
}

/// Integrates the Bouc-Wen state along measured `x`, `v` (4 RK2 steps per sample, `v`
/// interpolated linearly), from `z = 0`.
pub fn hysteretic_state(
    law: &crate::effects::ElementLaw,
    _bw: BoucWen,
    x: &[f64],
    v: &[f64],
    dt: f64,
) -> Vec<f64> {
    let law = crate::effects::CompiledLaw::new(law);
    let mut z = vec![0.0; x.len()];
    let sub = 4;
    let h = dt / sub as f64;
    let mut zc = 0.0;
    for t in 1..x.len() {
        for s in 0..sub {
            let f0 = s as f64 / sub as f64;
            let fm = (s as f64 + 0.5) / sub as f64;
            let xm = x[t - 1] + fm * (x[t] - x[t - 1]);
            let vm = v[t - 1] + fm * (v[t] - v[t - 1]);
            let x0 = x[t - 1] + f0 * (x[t] - x[t - 1]);
            let v0 = v[t - 1] + f0 * (v[t] - v[t - 1]);
            let k1 = law.state_rate(x0, v0, zc);
            let k2 = law.state_rate(xm, vm, zc + 0.5 * h * k1);
            zc += h * k2;
        }
        if !zc.is_finite() {
            zc = 0.0;
        }
        z[t] = zc;
    }
    z
}

/// The regression of one model structure: filtered, decimated columns (one per free
/// coefficient) and right-hand side, rows `(sample, DOF)` interleaved.
pub struct System {
    /// Free coefficients, one per column.
    pub free: Vec<Coef>,
    /// Columns (rows × free).
    pub columns: Vec<Vec<f64>>,
    /// Right-hand side.
    pub rhs: Vec<f64>,
    /// Record sample index of each row.
    pub sample: Vec<usize>,
    /// Equation of each row: the DOF, or `n + k` for the `k`-th measured element force
    /// ([`States::forces_measured`]).
    pub dof: Vec<usize>,
}

/// Builds the regression of `model` with coefficients `free` estimated (the others held at
/// their values in `model`), row weights `weights` per DOF.
///
/// The filter is linear, so every column and the right-hand side are combinations, at the
/// kept samples, of filtered basis signals (an element's regressor, a DOF's acceleration, a
/// force input, the constant); each basis signal is filtered once and memoised in
/// [`States::cache`], so structures that share regressors share their filtering.
pub fn build(model: &Model, st: &States, free: &[Coef], weights: &[f64]) -> System {
    let n = model.n();
    let len = st.q.first().map_or(0, Vec::len);
    let (inputs, sigs) = memo_inputs_and_signals(model, st);
    // Lift-off contact masks from the current law, with their content keys.
    let masks = contact_masks(model, &sigs, len);
    let is_free = |c: Coef| free.contains(&c);
    // The regressor of an element coefficient over the record (contact mask applied).
    let basis = |c: Coef| -> Vec<f64> {
        let Some(e) = c.element() else {
            return vec![0.0; len];
        };
        let l = &model.elements[e].law;
        let (x, rest) = sigs[e].1.split_at(len);
        let (v, z) = rest.split_at(len);
        let veps = l.coulomb.map_or(1e-3, |c| c.1);
        let bump = l.bump.map_or(0.0, |b| b.0);
        let rebound = l.rebound.map_or(0.0, |b| b.0);
        let mut b: Vec<f64> = x
            .iter()
            .zip(v)
            .zip(z)
            .map(|((&x, &v), &z)| match c {
                Coef::K(_) => l.spring_deflection(x),
                Coef::C(_) => v,
                Coef::KH(_) => z,
                Coef::K3(_) => l.spring_deflection(x).powi(3),
                Coef::CAbs(_) => v.abs(),
                Coef::C2(_) => v * v.abs(),
                Coef::Fc(_) => (v / veps).tanh(),
                Coef::BumpK(_) => (x - bump).max(0.0),
                Coef::RebK(_) => (x + rebound).min(0.0),
                Coef::Mass(_) | Coef::Bias(_) => 0.0,
            })
            .collect();
        if let Some((_, m)) = &masks[e] {
            b.iter_mut().zip(m).for_each(|(v, m)| *v *= m);
        }
        b
    };
    // What an element coefficient's regressor depends on besides the element's signals
    // and mask.
    let basis_key = |c: Coef| -> [u64; 2] {
        let e = c.element().unwrap_or(usize::MAX);
        let l = model.elements.get(e).map(|el| &el.law);
        let param =
            |f: &dyn Fn(&crate::effects::ElementLaw) -> Option<f64>| opt_words(l.and_then(f));
        let extra = match c {
            Coef::K(_) | Coef::K3(_) => param(&|l| l.backlash),
            Coef::Fc(_) => param(&|l| l.coulomb.map(|c| c.1)),
            Coef::BumpK(_) => param(&|l| l.bump.map(|b| b.0)),
            Coef::RebK(_) => param(&|l| l.rebound.map(|b| b.0)),
            _ => [0, 0],
        };
        let sig = sigs.get(e).map_or([0, 0], |s| s.0);
        let mask = masks
            .get(e)
            .and_then(|m| m.as_ref())
            .map_or([0, 0], |m| m.0);
        let words = [
            3,
            c.tag(),
            e as u64,
            sig[0],
            sig[1],
            extra[0],
            extra[1],
            mask[0],
            mask[1],
        ];
        signal::fingerprint_words(words.into_iter(), words.len(), 3)
    };
    let keyed = |words: &[u64], x: &dyn Fn() -> Vec<f64>| {
        st.cache.kept_key(
            signal::fingerprint_words(words.iter().copied(), words.len(), 4),
            x,
        )
    };
    let keep = st.cache.keep();
    let kept = keep.len();
    let ones = keyed(&[4], &|| vec![1.0; len]);
    let qdd: Vec<_> = (0..n)
        .map(|i| keyed(&[5, i as u64], &|| st.qdd[i].clone()))
        .collect();
    // Filtered regressors of every element coefficient that is on (free or held).
    let mut elem: Vec<Vec<(Coef, Arc<Vec<f64>>)>> = Vec::new();
    for (e, el) in model.elements.iter().enumerate() {
        let mut coefs = vec![Coef::K(e), Coef::C(e)];
        coefs.extend(effect_coefs_of(e, &el.law));
        let extra: Vec<Coef> = free
            .iter()
            .copied()
            .filter(|c| c.element() == Some(e) && !coefs.contains(c))
            .collect();
        coefs.extend(extra);
        elem.push(
            coefs
                .into_iter()
                .filter(|&c| is_free(c) || c.get(model) != 0.0)
                .map(|c| (c, st.cache.kept_key(basis_key(c), || basis(c))))
                .collect(),
        );
    }
    let liftoff: Vec<Option<Arc<Vec<f64>>>> = masks
        .iter()
        .map(|m| {
            m.as_ref()
                .map(|(k, m)| keyed(&[6, k[0], k[1]], &|| m.iter().map(|v| 1.0 - v).collect()))
        })
        .collect();
    let forces: Vec<Option<Arc<Vec<f64>>>> = model
        .inputs
        .iter()
        .zip(&inputs)
        .map(|(inp, (k, uv))| {
            (inp.kind == InputKind::Force).then(|| keyed(&[7, k[0], k[1]], &|| uv[..len].to_vec()))
        })
        .collect();
    // Equations per kept sample: one per DOF, then one per measured element force.
    let n_eq = n + st.forces_measured.len();
    let rows = kept * n_eq;
    let mut columns = vec![vec![0.0; rows]; free.len()];
    let mut rhs = vec![0.0; rows];
    let mut acc = vec![0.0; kept];
    for (k, (e, f)) in st.forces_measured.iter().enumerate() {
        let (e, row) = (*e, n + k);
        let measured = keyed(&[8, k as u64, e as u64], &|| f.clone());
        let w = 1.0 / signal::rms(&measured).max(f64::MIN_POSITIVE);
        let el = &model.elements[e];
        acc.iter_mut()
            .zip(measured.iter())
            .for_each(|(a, y)| *a = *y);
        for (c, y) in &elem[e] {
            if !is_free(*c) {
                let v = c.get(model);
                acc.iter_mut().zip(y.iter()).for_each(|(a, y)| *a -= v * y);
            }
        }
        if let (Some(p), Some(y)) = (el.law.lift_off, &liftoff[e]) {
            acc.iter_mut().zip(y.iter()).for_each(|(a, y)| *a += p * y);
        }
        for (r, v) in acc.iter().enumerate() {
            rhs[r * n_eq + row] = w * v;
        }
        for (ci, &c) in free.iter().enumerate() {
            if c.element() != Some(e) {
                continue;
            }
            if let Some((_, y)) = elem[e].iter().find(|(x, _)| *x == c) {
                for (r, v) in y.iter().enumerate() {
                    columns[ci][r * n_eq + row] = w * v;
                }
            }
        }
    }
    for i in 0..n {
        let w = weights[i];
        // Right-hand side.
        acc.iter_mut().for_each(|v| *v = 0.0);
        let mut add = |k: f64, y: &[f64]| {
            if k != 0.0 {
                acc.iter_mut().zip(y).for_each(|(a, y)| *a += k * y);
            }
        };
        for (inp, f) in model.inputs.iter().zip(&forces) {
            if let Some(f) = f {
                add(inp.t[i], f);
            }
        }
        if !is_free(Coef::Bias(i)) {
            add(model.bias[i], &ones);
        }
        if !is_free(Coef::Mass(i)) {
            add(-model.mass[i], &qdd[i]);
        }
        for (e, el) in model.elements.iter().enumerate() {
            let a = el.a[i];
            if a == 0.0 {
                continue;
            }
            for (c, y) in &elem[e] {
                if !is_free(*c) {
                    add(-a * c.get(model), y);
                }
            }
            if let (Some(p), Some(y)) = (el.law.lift_off, &liftoff[e]) {
                add(a * p, y);
            }
        }
        for (r, v) in acc.iter().enumerate() {
            rhs[r * n_eq + i] = w * v;
        }
        // Columns.
        for (ci, &c) in free.iter().enumerate() {
            let (k, y): (f64, &[f64]) = match c {
                Coef::Mass(j) if j == i => (1.0, &qdd[i]),
                Coef::Bias(j) if j == i => (-1.0, &ones),
                Coef::Mass(_) | Coef::Bias(_) => continue,
                _ => {
                    let Some(e) = c.element() else { continue };
                    let a = model.elements[e].a[i];
                    match elem[e].iter().find(|(x, _)| *x == c) {
                        Some((_, y)) if a != 0.0 => (a, y),
                        _ => continue,
                    }
                }
            };
            for (r, v) in y.iter().enumerate() {
                columns[ci][r * n_eq + i] = w * k * v;
            }
        }
    }
    let mut sample = Vec::with_capacity(rows);
    let mut dof = Vec::with_capacity(rows);
    for &t in keep {
        for i in 0..n_eq {
            sample.push(t);
            dof.push(i);
        }
    }
    System {
        free: free.to_vec(),
        columns,
        rhs,
        sample,
        dof,
    }
}

/// Per element with lift-off: the contact mask (1 in contact, 0 lifted off) of its current
/// law along its signals `sigs` (see `signals_memo`), with the mask's content key.
fn contact_masks(
    model: &Model,
    sigs: &[([u64; 2], Arc<Vec<f64>>)],
    len: usize,
) -> Vec<Option<([u64; 2], Vec<f64>)>> {
    model
        .elements
        .iter()
        .zip(sigs)
        .map(|(e, (_, s))| {
            e.law.lift_off.map(|p| {
                let law = crate::effects::CompiledLaw::new(&e.law);
                let (x, rest) = s.split_at(len);
                let (v, z) = rest.split_at(len);
                let m: Vec<f64> = x
                    .iter()
                    .zip(v)
                    .zip(z)
                    .map(|((&x, &v), &z)| {
                        if p + law.force_unclipped(x, v, z) > 0.0 {
                            1.0
                        } else {
                            0.0
                        }
                    })
                    .collect();
                (signal::fingerprint(&m, 3), m)
            })
        })
        .collect()
}

/// The content keys of the lift-off contact masks [`build`] would use for `model` (`None`
/// per element without lift-off): two models with equal keys and equal coefficients give
/// the same regression.
pub fn contact_mask_keys(model: &Model, st: &States) -> Vec<Option<[u64; 2]>> {
    let len = st.q.first().map_or(0, Vec::len);
    let (_, sigs) = memo_inputs_and_signals(model, st);
    contact_masks(model, &sigs, len)
        .into_iter()
        .map(|m| m.map(|(k, _)| k))
        .collect()
}

/// A memoised vector under its key.
type Keyed = ([u64; 2], Arc<Vec<f64>>);

/// The model's inputs (see `input_memo`) and its elements' signals (see `signals_memo`),
/// memoised in [`States::cache`].
fn memo_inputs_and_signals(model: &Model, st: &States) -> (Vec<Keyed>, Vec<Keyed>) {
    let inputs: Vec<Keyed> = model
        .inputs
        .iter()
        .zip(&st.inputs_raw)
        .enumerate()
        .map(|(j, (inp, raw))| input_memo(st, inp, j, raw))
        .collect();
    let sigs = (0..model.elements.len())
        .map(|e| signals_memo(model, st, e, &inputs))
        .collect();
    (inputs, sigs)
}

/// Key words of an optional parameter.
fn opt_words(v: Option<f64>) -> [u64; 2] {
    match v {
        Some(x) => [1, x.to_bits()],
        None => [0, 0],
    }
}

/// Input `j` as `model` sees it (its effects applied), filtered like the states, and its
/// rate (displacement inputs; zeros for force inputs), concatenated, memoised in
/// [`States::cache`] under a key of the input's index, kind and effect parameters.
fn input_memo(
    st: &States,
    inp: &crate::model::Input,
    j: usize,
    raw: &[f64],
) -> ([u64; 2], Arc<Vec<f64>>) {
    let l = &inp.law;
    let (d, r, s) = (
        opt_words(l.delay_s),
        opt_words(l.rate_limit),
        opt_words(l.saturation.map(|s| s.0)),
    );
    let (s_hi, p) = (opt_words(l.saturation.map(|s| s.1)), opt_words(l.backlash));
    let disp = inp.kind == InputKind::Displacement;
    let words = [
        1,
        j as u64,
        u64::from(disp),
        d[0],
        d[1],
        r[0],
        r[1],
        s[0],
        s[1],
        s_hi[1],
        p[0],
        p[1],
    ];
    let key = signal::fingerprint_words(words.into_iter(), words.len(), 5);
    let v = st.cache.memo_key(key, || {
        let t = l.transform(raw, st.dt);
        let mut f = st.cache.lowpass(&t);
        let rate = if disp {
            signal::derivative(&f, st.dt)
        } else {
            vec![0.0; f.len()]
        };
        f.extend(rate);
        f
    });
    (key, v)
}

/// Element `e`'s compression, rate and hysteretic state along the estimated states
/// (as [`element_signals`]), concatenated, memoised in [`States::cache`] under a key of
/// its couplings, the keys of the inputs it sees and its hysteresis law.
fn signals_memo(
    model: &Model,
    st: &States,
    e: usize,
    inputs: &[([u64; 2], Arc<Vec<f64>>)],
) -> ([u64; 2], Arc<Vec<f64>>) {
    let el = &model.elements[e];
    let len = st.q.first().map_or(0, Vec::len);
    let mut words: Vec<u64> = vec![2, e as u64];
    words.extend(el.a.iter().map(|v| v.to_bits()));
    for (b, (k, _)) in el.b.iter().zip(inputs) {
        words.push(b.to_bits());
        if *b != 0.0 {
            words.extend(k);
        }
    }
    if let Some(h) = el.law.hysteresis {
        words.extend([
            1,
            h.a.to_bits(),
            h.beta.to_bits(),
            h.gamma.to_bits(),
            h.n.to_bits(),
        ]);
        words.extend(opt_words(el.law.backlash));
    }
    let key = signal::fingerprint_words(words.iter().copied(), words.len(), 6);
    let v = st.cache.memo_key(key, || {
        let mut x = vec![0.0; len];
        let mut v = vec![0.0; len];
        for (a, (q, qd)) in el.a.iter().zip(st.q.iter().zip(&st.qd)) {
            if *a != 0.0 {
                for t in 0..len {
                    x[t] += a * q[t];
                    v[t] += a * qd[t];
                }
            }
        }
        for (b, (_, uv)) in el.b.iter().zip(inputs) {
            if *b != 0.0 {
                for t in 0..len {
                    x[t] += b * uv[t];
                    v[t] += b * uv[len + t];
                }
            }
        }
        let z = match el.law.hysteresis {
            Some(bw) => hysteretic_state(&el.law, bw, &x, &v, st.dt),
            None => vec![0.0; len],
        };
        x.extend(v);
        x.extend(z);
        x
    });
    (key, v)
}

/// A least-squares solution on a subset of rows.
#[derive(Clone, Debug)]
pub struct Solution {
    /// Estimated coefficients (order of [`System::free`]).
    pub theta: Vec<f64>,
    /// Covariance of the estimate, same order: the misfit-robust sandwich
    /// ([`crate::uncertainty`]), or σ² (AᵀA)⁻¹ inflated by the residual's correlation time
    /// when the rows are too few for its batches.
    pub covariance: DMatrix<f64>,
    /// Sum of squared residuals on the fitted rows.
    pub sse: f64,
    /// Rows fitted.
    pub rows: usize,
}

impl System {
    /// Least squares on the rows whose sample index satisfies `use_row` (column-scaled
    /// normal equations solved by SVD; a column that is all zero gets 0).
    pub fn solve(&self, use_row: impl Fn(usize) -> bool) -> Solution {
        self.solve_with(use_row, true)
    }

    /// [`System::solve`] without the covariance (all NaN): the estimate and its sum of
    /// squares, for ranking structures (the residual's correlation time is not needed).
    pub fn solve_ranking(&self, use_row: impl Fn(usize) -> bool) -> Solution {
        self.solve_with(use_row, false)
    }

    fn solve_with(&self, use_row: impl Fn(usize) -> bool, covariance: bool) -> Solution {
        let p = self.free.len();
        let idx: Vec<usize> = (0..self.rhs.len())
            .filter(|&r| use_row(self.sample[r]))
            .collect();
        // The used rows gathered into contiguous columns; each entry of the normal
        // equations is then one pass over two columns (a row whose first factor is zero
        // adds nothing, as a non-finite second factor must not).
        let gather = |c: &[f64]| -> Vec<f64> { idx.iter().map(|&r| c[r]).collect() };
        let cols: Vec<Vec<f64>> = self.columns.iter().map(|c| gather(c)).collect();
        let rhs = gather(&self.rhs);
        let dot = |x: &[f64], y: &[f64]| {
            // Four interleaved partial sums (the additions no longer wait on each other).
            let term = |a: f64, b: f64| if a == 0.0 { 0.0 } else { a * b };
            let mut acc = [0.0; 4];
            let (xc, yc) = (x.chunks_exact(4), y.chunks_exact(4));
            let (xr, yr) = (xc.remainder(), yc.remainder());
            for (a, b) in xc.zip(yc) {
                for k in 0..4 {
                    acc[k] += term(a[k], b[k]);
                }
            }
            let tail: f64 = xr.iter().zip(yr).map(|(a, b)| term(*a, *b)).sum();
            (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
        };
        let mut ata = DMatrix::<f64>::zeros(p, p);
        let mut atb = DVector::<f64>::zeros(p);
        for a in 0..p {
            atb[a] = dot(&cols[a], &rhs);
            for b in a..p {
                ata[(a, b)] = dot(&cols[a], &cols[b]);
            }
        }
        for a in 0..p {
            for b in 0..a {
                ata[(a, b)] = ata[(b, a)];
            }
        }
        if !(ata.iter().all(|v| v.is_finite()) && atb.iter().all(|v| v.is_finite())) {
            // Overflowing regressors (e.g. an unbounded hysteretic state): no fit.
            return Solution {
                theta: vec![0.0; p],
                covariance: DMatrix::from_element(p, p, f64::INFINITY),
                sse: f64::INFINITY,
                rows: idx.len(),
            };
        }
        let scale: Vec<f64> = (0..p)
            .map(|a| {
                let d = ata[(a, a)];
                if d > 0.0 {
                    1.0 / d.sqrt()
                } else {
                    0.0
                }
            })
            .collect();
        let s = DMatrix::from_fn(p, p, |a, b| ata[(a, b)] * scale[a] * scale[b]);
        let sb = DVector::from_fn(p, |a, _| atb[a] * scale[a]);
        let svd = s.clone().svd(true, true);
        let pinv = svd
            .pseudo_inverse(1e-12)
            .unwrap_or_else(|_| DMatrix::zeros(p, p));
        let y = &pinv * sb;
        let theta: Vec<f64> = (0..p).map(|a| y[a] * scale[a]).collect();
        let mut res = rhs;
        for (c, t) in cols.iter().zip(&theta) {
            res.iter_mut().zip(c).for_each(|(r, x)| *r -= x * t);
        }
        let sse: f64 = res.iter().map(|v| v * v).sum();
        if !covariance {
            return Solution {
                theta,
                covariance: DMatrix::from_element(p, p, f64::NAN),
                sse,
                rows: idx.len(),
            };
        }
        let dofs = self.dof.iter().copied().max().map_or(1, |m| m + 1);
        let tau = correlation_time_rows(&res, dofs);
        // Misfit-robust: the sandwich over batches of consecutive samples (the rows are in
        // time order, `dofs` per sample); σ² (AᵀA)⁻¹ inflated by the correlation time when
        // the record is too short for batches.
        let h = DMatrix::from_fn(p, p, |a, b| pinv[(a, b)] * scale[a] * scale[b]);
        let batch = crate::uncertainty::batch_len(idx.len() / dofs, tau) * dofs;
        let scores: Vec<DVector<f64>> = (0..res.len())
            .step_by(batch.max(1))
            .map(|s| {
                let e = (s + batch).min(res.len());
                DVector::from_fn(p, |a, _| {
                    cols[a][s..e]
                        .iter()
                        .zip(&res[s..e])
                        .map(|(x, r)| if *x == 0.0 { 0.0 } else { x * r })
                        .sum()
                })
            })
            .collect();
        let sigma2 = sse / (idx.len().saturating_sub(p).max(1)) as f64;
        let covariance = crate::uncertainty::robust(h, &scores, sigma2 * tau);
        Solution {
            theta,
            covariance,
            sse,
            rows: idx.len(),
        }
    }

    /// Residual `rhs − A θ` of row `r`.
    pub fn residual(&self, r: usize, theta: &[f64]) -> f64 {
        self.rhs[r]
            - self
                .columns
                .iter()
                .zip(theta)
                .map(|(c, t)| c[r] * t)
                .sum::<f64>()
    }

    /// Residuals on the rows whose sample index satisfies `use_row`.
    pub fn residuals(&self, theta: &[f64], use_row: impl Fn(usize) -> bool) -> Vec<f64> {
        (0..self.rhs.len())
            .filter(|&r| use_row(self.sample[r]))
            .map(|r| self.residual(r, theta))
            .collect()
    }
}

/// Correlation time of interleaved residual rows (`dofs` per sample): the largest of the
/// per-DOF correlation times (samples).
pub fn correlation_time_rows(res: &[f64], dofs: usize) -> f64 {
    (0..dofs.max(1))
        .map(|i| {
            let r: Vec<f64> = res.iter().skip(i).step_by(dofs.max(1)).copied().collect();
            signal::correlation_time(&r)
        })
        .fold(1.0, f64::max)
}

/// The coefficients of element `e`'s effects that are on in its law `l` (besides its
/// stiffness and damping), in the regressor order.
pub(crate) fn effect_coefs_of(e: usize, l: &crate::effects::ElementLaw) -> Vec<Coef> {
    [
        (l.hysteresis.is_some(), Coef::KH(e)),
        (l.k3.is_some(), Coef::K3(e)),
        (l.c_abs.is_some(), Coef::CAbs(e)),
        (l.c2.is_some(), Coef::C2(e)),
        (l.coulomb.is_some(), Coef::Fc(e)),
        (l.bump.is_some(), Coef::BumpK(e)),
        (l.rebound.is_some(), Coef::RebK(e)),
    ]
    .into_iter()
    .filter_map(|(on, coef)| on.then_some(coef))
    .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A record of the oscillator example driven by a random force, displacement from an
    /// exact-enough simulation, with a little noise.
    fn oscillator() -> (Model, Record) {
        let text = include_str!("../examples/oscillator.toml");
        let model = Model::from_toml(text).expect("oscillator.toml");
        let (n, dt) = (4000, 1e-3);
        let mut rng = mil_numerics::rng::SplitMix64::new(99u64);
        let mut rnd = move || rng.uniform() - 0.5;
        let force: Vec<f64> = (0..n).map(|_| 50.0 * rnd()).collect();
        let t: Vec<f64> = (0..n).map(|i| i as f64 * dt).collect();
        let rec = Record::new(
            &t,
            vec!["force".into(), "x".into()],
            vec![force.clone(), vec![0.0; n]],
        )
        .expect("record");
        let inputs = crate::simulate::prepare_inputs(&model, &rec).expect("inputs");
        let sim = crate::simulate::simulate(&model, &rec, &inputs, 0..n, None).expect("sim");
        let x: Vec<f64> = sim.outputs[0].iter().map(|v| v + 1e-6 * rnd()).collect();
        let rec = Record::new(&t, vec!["force".into(), "x".into()], vec![force, x]).expect("rec");
        (model, rec)
    }

    #[test]
    fn the_dofs_the_displacement_outputs_leave_undetermined_are_named() {
        let text = include_str!("../examples/quarter-car.toml");
        let model = Model::from_toml(text).expect("quarter-car.toml");
        assert!(undetermined_dofs(&model).is_empty());
        assert!(displacement_map(&model).is_some());
        // The hub's velocity measured only: its position is not determined (an
        // accelerometer would do, see `accelerometer`; a velocity is not used).
        let hub = "column = \"hub\"\nkind = \"displacement\"";
        assert!(text.contains(hub));
        let model = Model::from_toml(&text.replace(hub, "column = \"hub\"\nkind = \"velocity\""))
            .expect("model");
        assert_eq!(undetermined_dofs(&model), ["x_u"]);
        let t: Vec<f64> = (0..100).map(|i| f64::from(i) * 1e-3).collect();
        let cols = ["road", "body", "hub"];
        let rec = Record::new(
            &t,
            cols.iter().map(|c| c.to_string()).collect(),
            vec![vec![0.0; 100]; 3],
        )
        .expect("record");
        let Err(err) = estimate_states(&model, &rec) else {
            panic!("the hub's position is not determined: an error")
        };
        let err = err.to_string();
        assert!(err.contains("`x_u`") && !err.contains("`x_s`"), "{err}");
        assert!(err.contains("displacement or acceleration"), "{err}");
    }

    #[test]
    fn the_ranking_solve_is_the_full_solve_without_covariance() {
        let (model, rec) = oscillator();
        let st = estimate_states(&model, &rec).expect("states");
        let free = [Coef::Mass(0), Coef::K(0), Coef::C(0)];
        let sys = build(&model, &st, &free, &[1.0]);
        let use_row = |t: usize| t % 3 != 0;
        let full = sys.solve(use_row);
        let rank = sys.solve_ranking(use_row);
        assert_eq!(full.theta, rank.theta);
        assert_eq!(full.sse, rank.sse);
        assert_eq!(full.rows, rank.rows);
        assert!(full.covariance.iter().all(|v| v.is_finite()));
        assert!(rank.covariance.iter().all(|v| v.is_nan()));
        // The estimate is the least-squares one: its sum of squares is that of its
        // residuals, and a nudge of any coefficient makes it larger.
        let rows: Vec<usize> = (0..sys.rhs.len())
            .filter(|&r| use_row(sys.sample[r]))
            .collect();
        let sse = |th: &[f64]| {
            rows.iter()
                .map(|&r| sys.residual(r, th).powi(2))
                .sum::<f64>()
        };
        assert!((sse(&full.theta) - full.sse).abs() <= 1e-9 * full.sse);
        for k in 0..free.len() {
            let mut th = full.theta.clone();
            th[k] *= 1.0 + 1e-3;
            assert!(sse(&th) > full.sse, "coefficient {k}");
        }
    }

    #[test]
    fn columns_are_the_filtered_regressors_at_the_kept_samples() {
        let (model, rec) = oscillator();
        let st = estimate_states(&model, &rec).expect("states");
        let free = [Coef::Mass(0), Coef::K(0), Coef::C(0)];
        let w = [0.5];
        let sys = build(&model, &st, &free, &w);
        // Recomputed directly: the element's compression is −x, its rate −ẋ.
        let a = model.elements[0].a[0];
        let x: Vec<f64> = st.q[0].iter().map(|q| -q).collect();
        let v: Vec<f64> = st.qd[0].iter().map(|q| -q).collect();
        let expect = |sig: &[f64], k: f64| -> Vec<f64> {
            let f = signal::lowpass_zero_phase(sig, st.fc_hz, st.dt);
            st.cache.keep().iter().map(|&t| w[0] * k * f[t]).collect()
        };
        let cols = [expect(&st.qdd[0], 1.0), expect(&x, a), expect(&v, a)];
        for (ci, col) in cols.iter().enumerate() {
            let scale = col.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            assert!(scale > 0.0);
            for (got, want) in sys.columns[ci].iter().zip(col) {
                assert!(
                    (got - want).abs() <= 1e-12 * scale,
                    "column {ci}: {got} vs {want}"
                );
            }
        }
        // A second build is served from the memo and is identical.
        let again = build(&model, &st, &free, &w);
        assert_eq!(again.columns, sys.columns);
        assert_eq!(again.rhs, sys.rhs);
        // The right-hand side is the filtered force (mass, stiffness and damping free).
        let fu: Vec<f64> = {
            // The force input is filtered once as an input and once as a column.
            let once = signal::lowpass_zero_phase(rec.column("force").expect("f"), st.fc_hz, st.dt);
            let twice = signal::lowpass_zero_phase(&once, st.fc_hz, st.dt);
            st.cache.keep().iter().map(|&t| w[0] * twice[t]).collect()
        };
        for (got, want) in sys.rhs.iter().zip(&fu) {
            assert!((got - want).abs() <= 1e-9 * 25.0, "{got} vs {want}");
        }
    }

    #[test]
    fn pieces_are_the_records_states_with_their_own_rows_and_filter() {
        let (model, rec) = oscillator();
        let st = estimate_states(&model, &rec).expect("states");
        let len = st.q[0].len();
        let ranges = [300..1900, len / 2..len / 2 + 1500, len - 1700..len];
        let warmup = 3 * st.edge;
        let p = st.pieces(&ranges, warmup);
        let total: usize = ranges.iter().map(|r| r.len()).sum();
        assert_eq!(p.q[0].len(), total);
        assert_eq!(p.inputs_raw[0].len(), total);
        let mut at = 0;
        for (r, rows) in ranges.iter().zip(&p.rows) {
            // The record's own states, piece by piece; rows after the warm-up, an edge
            // before the end.
            assert_eq!(p.q[0][at..at + r.len()], st.q[0][r.clone()]);
            assert_eq!(p.qdd[0][at..at + r.len()], st.qdd[0][r.clone()]);
            assert_eq!(rows.start, at + warmup);
            assert_eq!(rows.end, at + r.len() - st.edge);
            at += r.len();
        }
        let keep = p.cache.keep();
        assert!(keep.iter().all(|t| p.rows.iter().any(|r| r.contains(t))));
        // A column is the regressor filtered within its piece, at the kept samples.
        let free = [Coef::Mass(0), Coef::K(0)];
        let sys = build(&model, &p, &free, &[1.0]);
        assert_eq!(sys.rhs.len(), keep.len());
        let mut want = Vec::new();
        let mut at = 0;
        for r in &ranges {
            let f = signal::lowpass_zero_phase(&st.qdd[0][r.clone()], st.fc_hz, st.dt);
            want.extend(
                keep.iter()
                    .filter(|&&t| t >= at && t < at + r.len())
                    .map(|&t| f[t - at]),
            );
            at += r.len();
        }
        assert_eq!(sys.columns[0], want);
        // The distribution of a signal is taken over the rows only.
        let ones: Vec<f64> = (0..total).map(|t| t as f64).collect();
        let inside = p.interior(&ones);
        assert_eq!(inside.len(), p.rows.iter().map(|r| r.len()).sum::<usize>());
    }

    #[test]
    fn a_prefix_has_its_own_rows() {
        let (model, rec) = oscillator();
        let st = estimate_states(&model, &rec).expect("states");
        let pre = st.prefix(2000);
        assert_eq!(pre.q[0].len(), 2000);
        assert_eq!(pre.q[0][..], st.q[0][..2000]);
        let last = *pre.cache.keep().last().expect("rows");
        assert!(last < 2000 - pre.edge);
        let sys = build(&model, &pre, &[Coef::K(0)], &[1.0]);
        assert_eq!(sys.rhs.len(), pre.cache.keep().len());
    }
}
