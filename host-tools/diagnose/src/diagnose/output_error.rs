//! The output-error refinement: Levenberg–Marquardt on the simulated outputs at the fitting
//! blocks' samples (the whole record, or windows spread over a long one,
//! [`super::windows`]), with a coarse stage that stops a candidate that cannot be named, and
//! the refined parameters' misfit-robust covariance.

use super::criterion::{gain_on_noise, practical};
use super::parameters::{nonlinear_params, Covariance, Param};
use super::simulated::inverse_spreads;
use super::windows::{place_windows, Placed};
use crate::equation::{self, Coef, States};
use crate::model::Model;
use crate::record::Record;
use crate::simulate::{self, prepare_inputs};
use crate::split::Split;
use crate::{parallel, uncertainty};
use nalgebra::{DMatrix, DVector};

/// Effectively independent samples of each output (samples over the output-error
/// residual's correlation time) that the output-error refinement scores: 2000 (every
/// fitting block when they hold fewer; else [`REFINE_WINDOWS`](super::REFINE_WINDOWS) windows spread over the
/// record). A compute budget: the refinement starts from
/// the equation-error estimates of the whole fitting part, removes their
/// errors-in-variables bias and confirms each effect in simulation, for which the
/// precision of 2000 independent samples per output is ample; its cost then stops
/// growing with the record.
pub const REFINE_EFFECTIVE_SAMPLES: f64 = 2000.0;

/// A candidate's output-error refinement stops after its coarse stage when, on the
/// coarse windows' fitting samples it was fitted to, it removes less than this share of
/// the margin it would be named at times the measurement noise's sum of squares from every
/// output compared with the model it must beat: 0.5. The margin is [`CLOSING_MARGIN`](super::CLOSING_MARGIN) when
/// it removes this share of [`CLOSING_SHARE`](super::CLOSING_SHARE) of the excess over the noise there, else
/// [`PRACTICAL_MARGIN`](super::PRACTICAL_MARGIN), as in the naming itself (a stop at half the practical margin
/// alone dropped weak Bouc-Wen loops that the closing margin names). Its gain on the data
/// it was fitted to is an optimistic estimate of its gain on the validation blocks; the
/// share leaves room for the coarse windows being a sample of the record. (A compute
/// saving: the fine stage of a candidate that cannot be named is not run.)
pub const COARSE_MARGIN_SHARE: f64 = 0.5;

/// The least warm-up of an output-error refinement window, in decay times of the start
/// model's slowest mode ([`Model::slowest_decay_s`]): 3 (an error in the window's
/// estimated initial state falls to 5 % before the window is scored). A lightly damped
/// oscillator rings for seconds; windows warmed up over a fifth of their length were scored
/// on the ringing of their start state, and a Bouc-Wen loop refined on them fitted the
/// windows better and the whole record worse than the linear model. Chosen from the 5 %,
/// not tuned.
pub const REFINE_WARMUP_DECAYS: f64 = 3.0;

/// How many times the start model's integration steps per sample a trial of the
/// output-error refinement may need: 4 (a step that needs more creates a fast mode, such as
/// a mass collapsing towards zero, rather than refining the model; it is refused, which
/// also bounds the refinement's cost).
pub const MAX_SUBSTEP_GROWTH: usize = 4;

/// The least cap on a trial's integration steps per sample, whatever the start needs: 8.
pub const MIN_SUBSTEP_CAP: usize = 8;

/// The output-error refinement's coarse stage scores `1 / REFINE_COARSE_SHARE` of its
/// budget: 4, a quarter of [`REFINE_EFFECTIVE_SAMPLES`] (a compute trade-off: the coarse
/// iterations cost a quarter, the fine stage starts near its optimum).
pub const REFINE_COARSE_SHARE: f64 = 4.0;

/// What the output-error refinement fits on: the record, its measured outputs, the split and
/// the estimated states (initial states of the simulated windows).
pub(super) struct RefineOn<'a> {
    pub(super) record: &'a Record,
    pub(super) measured: &'a [&'a [f64]],
    pub(super) split: &'a Split,
    pub(super) st: &'a States,
    /// DOF positions and velocities at the record's first sample.
    pub(super) initial: (&'a [f64], &'a [f64]),
    /// Per output: the measurement noise's standard deviation ([`signal::noise_std`](crate::signal::noise_std)).
    pub(super) noise: Vec<f64>,
}

/// Why [`refine_output_error`] returns no model.
#[derive(Debug)]
pub(super) enum Unrefined {
    /// The simulation of the start model diverges.
    Diverged,
    /// After the coarse stage, the candidate gains less than [`COARSE_MARGIN_SHARE`] of the
    /// margin it would be named at on the model it must beat (the reason, with the figures).
    NoGain(String),
}

/// A window the output-error refinement simulates: where, and the estimated DOF positions
/// and velocities it starts from.
struct Window {
    at: Placed,
    q: Vec<f64>,
    qd: Vec<f64>,
}

/// Projects every element law of `m` on passive laws
/// ([`crate::effects::ElementLaw::make_passive`]).
pub(super) fn make_passive(m: &mut Model) {
    for e in m.elements.iter_mut() {
        e.law.make_passive();
    }
}

/// Levenberg–Marquardt on the simulated outputs at the fitting blocks' samples; the
/// parameters are the linear coefficients `free` and the effects' other parameters. The
/// whole record is simulated when its fitting blocks hold at most
/// [`REFINE_EFFECTIVE_SAMPLES`] effectively independent samples per output (judged on the
/// start model's residual); a longer record is simulated in [`REFINE_WINDOWS`](super::REFINE_WINDOWS) windows
/// spread over it that together hold that many, each started from the estimated states at
/// its start and scored after its first fifth. When a quarter of that budget
/// ([`REFINE_COARSE_SHARE`]) holds less than the fine stage, the iterations run first on
/// windows of that quarter and then on the full data from there. A mass stays positive, a
/// stiffness or damping non-negative (a step beyond is refused), and the start and every
/// step are projected on passive laws ([`crate::effects::ElementLaw::make_passive`]: a
/// stop's stiffness, a friction force, a quadratic damping held at 0; unbounded, a refinement had a stop turn into a pulling
/// spring that stood in for part of a hardening cubic). Returns the refined model
/// and the parameters with their covariance (the misfit-robust sandwich of
/// [`uncertainty::robust`]), or why there is none ([`Unrefined`]).
pub(super) fn refine_output_error(
    model: &Model,
    free: &[Coef],
    on: &RefineOn<'_>,
    threads: usize,
    beat: Option<&Model>,
) -> std::result::Result<(Model, Covariance), Unrefined> {
    let mut model = model.clone();
    make_passive(&mut model);
    let model = &model;
    let mut params: Vec<Param> = free.iter().map(|c| Param::Lin(*c)).collect();
    params.extend(nonlinear_params(model));
    let refinement = Refinement::new(model, params, on, threads);
    let whole = vec![Window {
        at: Placed {
            range: 0..on.record.len(),
            from: 0,
            weight: 1.0,
        },
        q: on.initial.0.to_vec(),
        qd: on.initial.1.to_vec(),
    }];
    let start = refinement
        .residual_on(model, &whole)
        .ok_or(Unrefined::Diverged)?;
    // Correlation time of the start residual (samples): sets the budget and the
    // convergence test.
    let tau0 = equation::correlation_time_rows(&start, 1);
    let budget = REFINE_EFFECTIVE_SAMPLES * tau0;
    let (coarse, fine) = refinement.windows(model, budget);
    let fine = fine.unwrap_or(whole);
    let start = match &coarse {
        Some(w) => refinement.coarse_stage(model, w, beat, tau0)?,
        None => model.clone(),
    };
    let (m, r, c, jac) = match refinement.lm(start, &fine, tau0) {
        Some(done) => done,
        None if coarse.is_some() => refinement
            .lm(model.clone(), &fine, tau0)
            .ok_or(Unrefined::Diverged)?,
        None => return Err(Unrefined::Diverged),
    };
    let covariance = refinement.covariance(&jac, &r, c, &fine);
    Ok((m, (refinement.params, covariance)))
}

/// The samples of a window that are scored: its fitting samples from its first scored
/// one on.
fn scored<'s>(split: &'s Split, win: &Window) -> impl Iterator<Item = usize> + 's {
    let from = win.at.from;
    win.at
        .range
        .clone()
        .filter(move |&t| t >= from && split.is_fit(t))
}

/// The sum of squares of a residual.
fn cost(r: &[f64]) -> f64 {
    r.iter().map(|v| v * v).sum::<f64>()
}

/// The hysteretic elements' placement, Bouc-Wen laws and free play, and the input laws:
/// what the hysteretic states along the record depend on.
type HystereticKey = (Vec<f64>, Vec<crate::effects::InputLaw>);

/// Hysteretic states along the record, by what they depend on.
type Memo = Vec<(HystereticKey, std::sync::Arc<Vec<Vec<f64>>>)>;

/// What one output-error refinement works with: the data, the parameters it moves, the
/// outputs' scales, the cap on a trial's integration steps, and the hysteretic states of
/// the structures last simulated.
struct Refinement<'a> {
    on: &'a RefineOn<'a>,
    threads: usize,
    /// The linear coefficients freed, then the effects' other parameters.
    params: Vec<Param>,
    /// Per output: one over the measured output's spread on the fitting blocks.
    scale: Vec<f64>,
    /// The most integration steps per sample a trial may need.
    max_substeps: usize,
    /// A window that starts after the record's start takes its hysteretic states from the
    /// model's Bouc-Wen laws integrated along the estimated motion from the record's start
    /// (from 0 they settle only over a loop, which at a slow sweep's end is longer than the
    /// window's warm-up). They depend on the hysteretic elements' placement, Bouc-Wen laws
    /// and free play and on the input effects only, not on the linear coefficients that most
    /// of the Jacobian's columns vary: the states along the record are kept for the last few
    /// of those (one per parallel Jacobian column and a few more).
    memo: std::sync::Mutex<Memo>,
}

impl<'a> Refinement<'a> {
    /// The refinement of `params` in `model` (projected on passive laws) on `on`.
    fn new(model: &Model, params: Vec<Param>, on: &'a RefineOn<'a>, threads: usize) -> Self {
        let len = on.record.len();
        let fit_idx: Vec<usize> = (0..len).filter(|&t| on.split.is_fit(t)).collect();
        let scale = inverse_spreads(on.measured, &fit_idx);
        // A trial that needs many more integration steps than the start is a new fast mode (a
        // mass collapsing, a stiffness exploding), not a local refinement: refused.
        let max_substeps =
            (MAX_SUBSTEP_GROWTH * simulate::substeps(model, on.record.dt)).max(MIN_SUBSTEP_CAP);
        Self {
            on,
            threads,
            params,
            scale,
            max_substeps,
            memo: std::sync::Mutex::new(Vec::new()),
        }
    }

    /// The hysteretic states of `m` at each window's start (none for a window at the
    /// record's start: they start at 0).
    fn hysteretic_at(&self, m: &Model, windows: &[Window]) -> Vec<Vec<f64>> {
        let late = windows.iter().any(|win| win.at.range.start > 0);
        let z: std::sync::Arc<Vec<Vec<f64>>> =
            if late && m.elements.iter().any(|e| e.law.hysteresis.is_some()) {
                let mut placed = Vec::new();
                for e in m.elements.iter() {
                    if let Some(bw) = e.law.hysteresis {
                        placed.extend(e.a.iter().chain(&e.b));
                        placed.extend([bw.a, bw.beta, bw.gamma, bw.n]);
                        placed.push(e.law.backlash.unwrap_or(-1.0));
                    }
                }
                let key = (placed, m.inputs.iter().map(|i| i.law.clone()).collect());
                let known =
                    self.memo.lock().ok().and_then(|memo| {
                        memo.iter().find(|(k, _)| *k == key).map(|(_, z)| z.clone())
                    });
                match known {
                    Some(z) => z,
                    None => {
                        let (u, ud) = equation::model_inputs(m, self.on.st);
                        let z: Vec<Vec<f64>> = equation::element_signals(m, self.on.st, &u, &ud)
                            .into_iter()
                            .zip(&m.elements)
                            .filter(|(_, e)| e.law.hysteresis.is_some())
                            .map(|(sig, _)| sig.z)
                            .collect();
                        let z = std::sync::Arc::new(z);
                        if let Ok(mut memo) = self.memo.lock() {
                            if memo.len() >= 2 * self.threads.max(1) + 2 {
                                memo.remove(0);
                            }
                            memo.push((key, z.clone()));
                        }
                        z
                    }
                }
            } else {
                std::sync::Arc::new(Vec::new())
            };
        windows
            .iter()
            .map(|win| {
                z.iter()
                    .map(|z| z.get(win.at.range.start).copied().unwrap_or(0.0))
                    .collect()
            })
            .collect()
    }

    /// `m`'s scaled residual on `windows` (each output's scored samples in turn, window
    /// after window); `None` if the simulation fails.
    fn residual_on(&self, m: &Model, windows: &[Window]) -> Option<Vec<f64>> {
        let inp = prepare_inputs(m, self.on.record).ok()?;
        let z0 = self.hysteretic_at(m, windows);
        let mut r = Vec::new();
        for (win, z0) in windows.iter().zip(&z0) {
            let w = &win.at.range;
            let sim = simulate::simulate_outputs_from(
                m,
                self.on.record,
                &inp,
                w.clone(),
                (&win.q, &win.qd, z0),
            )
            .ok()?;
            for ((me, s), sc) in self.on.measured.iter().zip(&sim.outputs).zip(&self.scale) {
                let sc = sc * win.at.weight.sqrt();
                for t in scored(self.on.split, win) {
                    r.push((s[t - w.start] - me[t]) * sc);
                }
            }
        }
        Some(r)
    }

    /// [`Refinement::residual_on`] for a trial: `None` also when it needs more integration
    /// steps per sample than [`Refinement::max_substeps`].
    fn residual(&self, m: &Model, windows: &[Window]) -> Option<Vec<f64>> {
        if simulate::substeps(m, self.on.record.dt) > self.max_substeps {
            return None;
        }
        self.residual_on(m, windows)
    }

    /// The coarse stage's windows (a quarter of `budget`, [`REFINE_COARSE_SHARE`]) and the
    /// fine stage's (`budget`) for `model`; `None`: the whole record.
    fn windows(&self, model: &Model, budget: f64) -> (Option<Vec<Window>>, Option<Vec<Window>>) {
        let len = self.on.record.len();
        // Each output's power at every sample (less its mean, scaled by its inverse spread).
        let power: Vec<f64> = {
            let means: Vec<f64> = self
                .on
                .measured
                .iter()
                .map(|me| me.iter().sum::<f64>() / len.max(1) as f64)
                .collect();
            (0..len)
                .map(|t| {
                    self.on
                        .measured
                        .iter()
                        .zip(&means)
                        .zip(&self.scale)
                        .map(|((me, mu), sc)| ((me[t] - mu) * sc).powi(2))
                        .sum::<f64>()
                })
                .collect()
        };
        let is_fit: Vec<bool> = (0..len).map(|t| self.on.split.is_fit(t)).collect();
        // The warm-up of a window: at least [`REFINE_WARMUP_DECAYS`] of the start model's
        // slowest decay time (samples; none when the model has a mode that does not decay).
        let warm_decays = model.slowest_decay_s().map_or(0, |t| {
            (REFINE_WARMUP_DECAYS * t / self.on.record.dt)
                .ceil()
                .min(len as f64) as usize
        });
        let windows_for = |budget: f64| -> Option<Vec<Window>> {
            let placed = place_windows(&power, &is_fit, budget, warm_decays)?;
            Some(
                placed
                    .into_iter()
                    .map(|at| {
                        let s0 = at.range.start;
                        Window {
                            q: self.on.st.q.iter().map(|x| x[s0]).collect(),
                            qd: self.on.st.qd.iter().map(|x| x[s0]).collect(),
                            at,
                        }
                    })
                    .collect(),
            )
        };
        // A coarse stage on a quarter of the budget first, when that is less than the fine
        // stage's data: most iterations then cost a quarter, and the fine stage starts
        // converged or nearly so.
        let coarse = windows_for(budget / REFINE_COARSE_SHARE);
        (coarse, windows_for(budget))
    }

    /// Levenberg–Marquardt from `m` on `windows` (`tau0`: the start residual's correlation
    /// time, samples): the model, its residual, cost and last Jacobian.
    fn lm(
        &self,
        mut m: Model,
        windows: &[Window],
        tau0: f64,
    ) -> Option<(Model, Vec<f64>, f64, DMatrix<f64>)> {
        let p = self.params.len();
        let mut r = self.residual(&m, windows)?;
        let mut c = cost(&r);
        let mut lambda = 1e-3;
        let mut jac = DMatrix::<f64>::zeros(r.len(), p);
        for _ in 0..25 {
            // Jacobian by forward differences, one simulation per parameter, in parallel.
            let columns = parallel::map(
                &self.params,
                self.threads,
                |par| {
                    let v = par.get(&m);
                    let h = 1e-5 * v.abs().max(1e-9);
                    let mut mm = m.clone();
                    let ok = par.set(&mut mm, v + h);
                    let rk = if ok {
                        self.residual(&mm, windows)
                    } else {
                        None
                    };
                    (rk, h)
                },
                |_, _| {},
            );
            for (k, (rk, h)) in columns.into_iter().enumerate() {
                match rk {
                    Some(rk) => {
                        for (i, (a, b)) in rk.iter().zip(&r).enumerate() {
                            jac[(i, k)] = (a - b) / h;
                        }
                    }
                    None => {
                        for i in 0..r.len() {
                            jac[(i, k)] = 0.0;
                        }
                    }
                }
            }
            let jtj = jac.transpose() * &jac;
            let jtr = jac.transpose() * DVector::from_column_slice(&r);
            let mut improved = false;
            for _try in 0..6 {
                let mut a = jtj.clone();
                for k in 0..p {
                    a[(k, k)] += lambda * jtj[(k, k)].max(1e-300);
                }
                let Some(step) = a.clone().cholesky().map(|ch| ch.solve(&(-&jtr))) else {
                    lambda *= 10.0;
                    continue;
                };
                let mut mm = m.clone();
                let ok = self
                    .params
                    .iter()
                    .enumerate()
                    .all(|(k, par)| par.set(&mut mm, par.get(&m) + step[k]));
                // The steps are projected on passive laws (a stop, a friction force, a
                // damping does not turn into an energy source).
                make_passive(&mut mm);
                let trial = if ok {
                    self.residual(&mm, windows)
                } else {
                    None
                };
                match trial {
                    Some(rt) if cost(&rt) < c => {
                        let rel = (c - cost(&rt)) / c;
                        let c_before = c;
                        m = mm;
                        r = rt;
                        c = cost(&r);
                        lambda = (lambda / 3.0).max(1e-9);
                        // Converged when the step moved the parameters by less than a
                        // tenth of a standard error: a cost decrease `δᵀJᵀJδ` below
                        // 0.01 σ² τ.
                        let sigma2 = c / (r.len().saturating_sub(p).max(1)) as f64;
                        improved = rel > 1e-7 && c_before - c > 0.01 * sigma2 * tau0;
                        break;
                    }
                    _ => lambda *= 4.0,
                }
            }
            if !improved {
                break;
            }
        }
        Some((m, r, c, jac))
    }

    /// Per output: the sum of squares of a residual of [`Refinement::residual_on`] on
    /// `windows` and the fitting samples it stands for (the windows' weights).
    fn by_output(&self, r: &[f64], windows: &[Window]) -> (Vec<f64>, f64) {
        let mut sse = vec![0.0; self.on.measured.len()];
        let (mut at, mut n) = (0, 0.0);
        for win in windows {
            let k = scored(self.on.split, win).count();
            for s in sse.iter_mut() {
                *s += r
                    .get(at..at + k)
                    .unwrap_or(&[])
                    .iter()
                    .map(|v| v * v)
                    .sum::<f64>();
                at += k;
            }
            n += k as f64 * win.at.weight;
        }
        (sse, n)
    }

    /// The coarse stage on windows `w`: the model it reaches from `model` (`model` itself
    /// when it diverges), or [`Unrefined::NoGain`] when it gains too little on `beat`.
    fn coarse_stage(
        &self,
        model: &Model,
        w: &[Window],
        beat: Option<&Model>,
        tau0: f64,
    ) -> std::result::Result<Model, Unrefined> {
        let Some((m, r, ..)) = self.lm(model.clone(), w, tau0) else {
            // A coarse stage that diverges leaves the fine stage to start from the given model.
            return Ok(model.clone());
        };
        // The gain on the model to beat, in noise sums of squares on its best output
        // and in share of the excess over the noise, against the margins scaled down.
        if let Some(other) = beat.and_then(|b| self.residual(b, w)) {
            let ((mine, n), (theirs, _)) = (self.by_output(&r, w), self.by_output(&other, w));
            let noise_sse: Vec<f64> = self
                .on
                .noise
                .iter()
                .zip(&self.scale)
                .map(|(sd, sc)| n * (sd * sc).powi(2))
                .collect();
            let (gain, closed) = gain_on_noise(&noise_sse, &theirs, &mine);
            if !practical(gain, closed, COARSE_MARGIN_SHARE) {
                return Err(Unrefined::NoGain(format!(
                    "it explains {gain:.2}x the noise on its best output and {:.0} % of the excess over the noise on the data it was fitted to",
                    100.0 * closed
                )));
            }
        }
        Ok(m)
    }

    /// The covariance of the parameters at the fine stage's end (Jacobian `jac`, residual
    /// `r`, cost `c` on windows `fine`): the misfit-robust sandwich of
    /// [`uncertainty::robust`].
    fn covariance(&self, jac: &DMatrix<f64>, r: &[f64], c: f64, fine: &[Window]) -> DMatrix<f64> {
        let p = self.params.len();
        // Covariance with the columns scaled to unit norm (parameters of very different
        // magnitudes), then unscaled.
        let d: Vec<f64> = (0..p)
            .map(|k| {
                let n = jac.column(k).norm();
                if n > 0.0 {
                    1.0 / n
                } else {
                    0.0
                }
            })
            .collect();
        let js = DMatrix::from_fn(jac.nrows(), p, |i, k| jac[(i, k)] * d[k]);
        let jtj = js.transpose() * &js;
        if !jtj.iter().all(|v| v.is_finite()) {
            return DMatrix::from_element(p, p, f64::NAN);
        }
        let tau = equation::correlation_time_rows(r, 1);
        let h = jtj
            .pseudo_inverse(1e-12)
            .map(|inv| DMatrix::from_fn(p, p, |a, b| inv[(a, b)] * d[a] * d[b]))
            .unwrap_or_else(|_| DMatrix::zeros(p, p));
        // Misfit-robust: the sandwich over batches of consecutive fitting samples of each
        // window, every output's rows at those samples together (the residual holds, per
        // window, each output's samples in turn); σ² (JᵀJ)⁻¹ inflated by the correlation time
        // when they are too few for batches.
        let per_output: usize = fine
            .iter()
            .map(|win| scored(self.on.split, win).count())
            .sum();
        let batch = uncertainty::batch_len(per_output, tau);
        let mut scores: Vec<DVector<f64>> = Vec::new();
        let mut at = 0;
        for win in fine {
            let k = scored(self.on.split, win).count();
            for s in (0..k).step_by(batch) {
                let e = (s + batch).min(k);
                let mut v = DVector::<f64>::zeros(p);
                for o in 0..self.on.measured.len() {
                    for i in (at + o * k + s)..(at + o * k + e) {
                        if let Some(ri) = r.get(i) {
                            for a in 0..p {
                                v[a] += jac[(i, a)] * ri;
                            }
                        }
                    }
                }
                scores.push(v);
            }
            at += k * self.on.measured.len();
        }
        let sigma2 = c / (r.len().saturating_sub(p).max(1)) as f64;
        uncertainty::robust(h, &scores, sigma2 * tau)
    }
}
