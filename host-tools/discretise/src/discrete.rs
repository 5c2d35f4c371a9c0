//! Discrete-time models and their conversion to model-core's `f32` delta-form coefficients.
//!
//! Everything here works with `q = z - 1` and `1 - z` rather than `z`, so that roots near
//! `z = 1` (slow modes at high sample rates) keep full relative precision.

use model_core::{
    BiquadCoefficients, CascadeCoefficients, CascadeState, DeltaStateSpaceCoefficients,
    MAX_SECTIONS,
};
use nalgebra::DMatrix;
use num_complex::Complex64;

use crate::continuous::resolvent_response;
use crate::error::{check_dt, DiscretiseError, Result};
use crate::pairing::{group_roots, Group, Root};
use crate::poly::Conjugates;

/// `q = e^{jωT} - 1` for a frequency `f_hz` (Hz) and sample period `dt` (s), computed as
/// `-2 sin²(ωT/2) + j sin ωT` so that it keeps full relative precision for `f ≪ 1/dt`.
pub fn delta_operator_point(f_hz: f64, dt: f64) -> Complex64 {
    let theta = std::f64::consts::TAU * f_hz * dt;
    let half = (0.5 * theta).sin();
    Complex64::new(-2.0 * half * half, theta.sin())
}

/// One root of a discrete transfer function: the root `z` and `1 - z`, the latter computed
/// directly from the continuous root (not as `1 - z`) where the discretisation allows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DiscreteRoot {
    /// The root in the `z` plane.
    pub z: Complex64,
    /// `1 - z`, accurate to full relative precision for roots near `z = 1`.
    pub one_minus_z: Complex64,
}

impl DiscreteRoot {
    /// A root given by `z` alone (`1 - z` is formed by subtraction: use only for roots not
    /// close to `z = 1`).
    pub fn from_z(z: Complex64) -> Self {
        Self {
            z,
            one_minus_z: Complex64::new(1.0, 0.0) - z,
        }
    }

    /// A root given by `w = 1 - z` (exact); `z = 1 - w`.
    pub fn from_one_minus_z(w: Complex64) -> Self {
        Self {
            z: Complex64::new(1.0, 0.0) - w,
            one_minus_z: w,
        }
    }

    /// The complex-conjugate root.
    pub fn conj(self) -> Self {
        Self {
            z: self.z.conj(),
            one_minus_z: self.one_minus_z.conj(),
        }
    }
}

/// Expands a conjugate set given in `w = 1 - z` coordinates, with a function giving the
/// matching `z` for each `w`, into root pairs `[r, conj r]` (reals first).
pub(crate) fn roots_from<F: Fn(Complex64) -> DiscreteRoot>(
    set: &Conjugates,
    f: F,
) -> Vec<DiscreteRoot> {
    set.reals
        .iter()
        .map(|&r| {
            let mut root = f(Complex64::new(r, 0.0));
            root.z.im = 0.0;
            root.one_minus_z.im = 0.0;
            root
        })
        .chain(set.pairs.iter().flat_map(|&p| {
            let root = f(p);
            [root, root.conj()]
        }))
        .collect()
}

/// A discrete single-input single-output system in zero-pole-gain form,
/// `H(z) = gain · Π (z - zeros[i].z) / Π (z - poles[j].z)`, sampled every `dt` seconds.
///
/// Fewer zeros than poles means zeros at infinity (pure delays). Complex roots come in
/// conjugate pairs.
#[derive(Clone, Debug, PartialEq)]
pub struct DiscreteZpk {
    /// Finite zeros.
    pub zeros: Vec<DiscreteRoot>,
    /// Poles.
    pub poles: Vec<DiscreteRoot>,
    /// Gain (ratio of the leading coefficients in `z`).
    pub gain: f64,
    /// Sample period (s).
    pub dt: f64,
}

/// Closeness of a discrete root to the unit circle, `|1 - |z||`, from `w = 1 - z`:
/// `1 - |z|² = 2 Re w - |w|²`.
fn unit_circle_distance(w: Complex64) -> f64 {
    let z_abs = (Complex64::new(1.0, 0.0) - w).norm();
    ((2.0 * w.re - w.norm_sqr()) / (1.0 + z_abs)).abs()
}

/// Ascending coefficients `[c0, c1, c2]` of `Π (q + w)` over the group's roots in
/// `w = 1 - z` coordinates, padded with `pad` roots at `z = 0` (`w = 1`).
fn q_poly(roots: &[Root], pad: usize) -> [f64; 3] {
    let mut poly = vec![1.0];
    let factor = |poly: &[f64], f: &[f64]| crate::poly::convolve(poly, f);
    for r in roots {
        poly = match *r {
            Root::Real(w) => factor(&poly, &[w, 1.0]),
            Root::Pair(w) => factor(&poly, &[w.norm_sqr(), 2.0 * w.re, 1.0]),
        };
    }
    for _ in 0..pad {
        poly = factor(&poly, &[1.0, 1.0]);
    }
    let mut out = [0.0; 3];
    for (o, c) in out.iter_mut().zip(poly) {
        *o = c;
    }
    out
}

/// `(β, α)` in `f64` of one group with unit gain: `β = [β0, β1, β2]`, `α = [α1, α2]`.
fn group_coefficients(g: &Group) -> ([f64; 3], [f64; 2]) {
    let pad = 2usize.saturating_sub(g.order());
    let [a2, a1, _] = q_poly(&g.poles, pad);
    let [b2, b1, b0] = q_poly(&g.zeros, pad);
    ([b0, b1, b2], [a1, a2])
}

/// `H(q)` of a delta-form section in `f64`.
fn section_response(beta: [f64; 3], alpha: [f64; 2], q: Complex64) -> Complex64 {
    let [b0, b1, b2] = beta;
    let [a1, a2] = alpha;
    (q * q * b0 + q * b1 + b2) / (q * q + q * a1 + a2)
}

/// Largest `|H|` of a unit-gain section over DC, its pole angles and a logarithmic grid of
/// normalised frequencies from `1e-5 π` to `π`; `None` if no finite, non-zero value.
fn peak_gain(g: &Group, beta: [f64; 3], alpha: [f64; 2]) -> Option<f64> {
    let mut angles: Vec<f64> = (0..=48)
        .map(|i| std::f64::consts::PI * 10f64.powf(-5.0 + 5.0 * f64::from(i) / 48.0))
        .collect();
    angles.push(0.0);
    for p in &g.poles {
        let z = Complex64::new(1.0, 0.0) - p.pos();
        angles.push(z.arg().abs());
    }
    angles
        .into_iter()
        .map(|theta| {
            let half = (0.5 * theta).sin();
            section_response(beta, alpha, Complex64::new(-2.0 * half * half, theta.sin())).norm()
        })
        .filter(|v| v.is_finite() && *v > 0.0)
        .reduce(f64::max)
}

/// `f64 → f32` with an overflow check.
fn to_f32(v: f64) -> Result<f32> {
    let x = v as f32;
    if x.is_finite() {
        Ok(x)
    } else if v.is_finite() {
        Err(DiscretiseError::F32Overflow(v))
    } else {
        Err(DiscretiseError::NonFinite("coefficient"))
    }
}

/// Delta-form section from `f64` coefficients scaled by `k`.
fn biquad(beta: [f64; 3], alpha: [f64; 2], k: f64) -> Result<BiquadCoefficients> {
    let [b0, b1, b2] = beta;
    let [a1, a2] = alpha;
    Ok(BiquadCoefficients {
        beta0: to_f32(k * b0)?,
        beta1: to_f32(k * b1)?,
        beta2: to_f32(k * b2)?,
        alpha1: to_f32(a1)?,
        alpha2: to_f32(a2)?,
    })
}

impl DiscreteZpk {
    /// The validated roots in `w = 1 - z` coordinates `(zeros, poles)`.
    fn split_w(&self) -> Result<(Conjugates, Conjugates)> {
        if !self.gain.is_finite() {
            return Err(DiscretiseError::NonFinite("gain"));
        }
        let w = |r: &[DiscreteRoot]| r.iter().map(|x| x.one_minus_z).collect::<Vec<_>>();
        let zeros = Conjugates::split(&w(&self.zeros), "zero")?;
        let poles = Conjugates::split(&w(&self.poles), "pole")?;
        if zeros.len() > poles.len() {
            return Err(DiscretiseError::Improper {
                zeros: zeros.len(),
                poles: poles.len(),
            });
        }
        Ok((zeros, poles))
    }

    /// `H` at `q = z - 1` (from the `1 - z` values: `z - r = q + (1 - r)`).
    pub(crate) fn response_at_q(&self, q: Complex64) -> Complex64 {
        let num: Complex64 = self.zeros.iter().map(|r| q + r.one_minus_z).product();
        let den: Complex64 = self.poles.iter().map(|r| q + r.one_minus_z).product();
        num / den * self.gain
    }

    /// Frequency response `H(e^{j2πf dt})` at `f_hz` (Hz), evaluated through `q = z - 1` and
    /// the stored `1 - z` values (accurate for slow roots).
    pub fn response(&self, f_hz: f64) -> Complex64 {
        self.response_at_q(delta_operator_point(f_hz, self.dt))
    }

    /// Gain at DC (`z = 1`): `gain · Π (1 - zero) / Π (1 - pole)` (infinite with a pole at 1).
    pub fn dc_gain(&self) -> f64 {
        self.response_at_q(Complex64::new(0.0, 0.0)).re
    }

    /// Direct-form polynomials `(num, den)` in descending powers of `z`, `den` monic, formed
    /// from the `z` values. Poles near `z = 1` lose their precision in these coefficients:
    /// prefer [`DiscreteZpk::to_sections`].
    ///
    /// # Errors
    /// Unmatched complex roots, more zeros than poles, or a non-finite gain.
    pub fn to_direct_form(&self) -> Result<(Vec<f64>, Vec<f64>)> {
        self.split_w()?;
        let z = |r: &[DiscreteRoot]| r.iter().map(|x| x.z).collect::<Vec<_>>();
        let zeros = Conjugates::split(&z(&self.zeros), "zero")?;
        let poles = Conjugates::split(&z(&self.poles), "pole")?;
        Ok((
            zeros.monic_poly().iter().map(|c| c * self.gain).collect(),
            poles.monic_poly(),
        ))
    }

    /// Second-order sections in model-core's delta form.
    ///
    /// Complex poles stay with their conjugate, real poles are paired, and each pole group
    /// (worst, i.e. closest to the unit circle, first) takes its nearest zeros (scipy's
    /// `zpk2sos` "nearest" pairing); the sections are returned best first, the one with the
    /// poles closest to the unit circle last. A single remaining real pole gives a first-order
    /// section (second pole at `z = 0`). Every section but the last is scaled to a peak gain
    /// of 1 over frequency; the last one carries the remaining gain. `α`, `β` are computed
    /// from the `1 - z` values in `f64`, then rounded to `f32`.
    ///
    /// A system without poles gives one pure-gain section.
    ///
    /// # Errors
    /// Unmatched complex roots, more zeros than poles, a non-finite gain, or a coefficient
    /// that overflows `f32`.
    pub fn to_sections(&self) -> Result<Vec<BiquadCoefficients>> {
        let (zeros, poles) = self.split_w()?;
        if poles.len() == 0 {
            let k = self.gain;
            return Ok(vec![biquad([1.0, 2.0, 1.0], [2.0, 1.0], k)?]);
        }
        let groups = group_roots(&poles, &zeros, unit_circle_distance)?;
        let coefficients: Vec<([f64; 3], [f64; 2])> =
            groups.iter().map(group_coefficients).collect();
        let mut sections = Vec::with_capacity(groups.len());
        let mut remaining = self.gain;
        let last = groups.len().saturating_sub(1);
        for (i, (g, &(beta, alpha))) in groups.iter().zip(&coefficients).enumerate() {
            let k = if i == last {
                remaining
            } else {
                let k = peak_gain(g, beta, alpha).map_or(1.0, |p| 1.0 / p);
                remaining /= k;
                k
            };
            sections.push(biquad(beta, alpha, k)?);
        }
        Ok(sections)
    }

    /// The sections of [`DiscreteZpk::to_sections`] as a model-core cascade.
    ///
    /// # Errors
    /// As [`DiscreteZpk::to_sections`], or [`DiscretiseError::TooManySections`] when more than
    /// [`MAX_SECTIONS`] sections are needed.
    pub fn to_cascade(&self) -> Result<CascadeCoefficients> {
        let sections = self.to_sections()?;
        CascadeCoefficients::from_sections(&sections).ok_or(DiscretiseError::TooManySections {
            needed: sections.len(),
            max: MAX_SECTIONS,
        })
    }
}

/// A discrete linear system in delta form sampled every `dt` seconds:
/// `x[k+1] = x[k] + Δ x[k] + Γ u[k]`, `y[k] = C x[k] + D u[k]`, `Δ = Φ - I`.
#[derive(Clone, Debug, PartialEq)]
pub struct DiscreteStateSpace {
    /// `Δ = Φ - I` (n × n).
    pub delta: DMatrix<f64>,
    /// Input matrix `Γ` (n × inputs).
    pub gamma: DMatrix<f64>,
    /// Output matrix `C` (outputs × n).
    pub c: DMatrix<f64>,
    /// Feed-through matrix `D` (outputs × inputs).
    pub d: DMatrix<f64>,
    /// Sample period (s).
    pub dt: f64,
}

impl DiscreteStateSpace {
    /// Validates dimensions and values; returns `(states, inputs, outputs)`.
    ///
    /// # Errors
    /// Mismatched dimensions, non-finite entries or an invalid `dt`.
    pub fn dimensions(&self) -> Result<(usize, usize, usize)> {
        check_dt(self.dt)?;
        crate::continuous::check_abcd(&self.delta, &self.gamma, &self.c, &self.d)
    }

    /// The state-transition matrix `Φ = I + Δ` (loses the precision of `Δ` for slow modes).
    pub fn phi(&self) -> DMatrix<f64> {
        let n = self.delta.nrows();
        &self.delta + DMatrix::identity(n, n)
    }

    /// Response `C (qI - Δ)⁻¹ Γ + D` at a point `q = z - 1`.
    pub(crate) fn response_at_q(&self, q: Complex64) -> Result<DMatrix<Complex64>> {
        resolvent_response(&self.delta, &self.gamma, &self.c, &self.d, q)
    }

    /// Frequency response matrix `C (zI - Φ)⁻¹ Γ + D` at `z = e^{j2πf dt}` (outputs × inputs),
    /// evaluated as `C (qI - Δ)⁻¹ Γ + D` with `q = z - 1`.
    ///
    /// # Errors
    /// Invalid matrices, or `z` is an eigenvalue of `Φ`.
    pub fn response(&self, f_hz: f64) -> Result<DMatrix<Complex64>> {
        self.dimensions()?;
        self.response_at_q(delta_operator_point(f_hz, self.dt))
    }
}

/// Copies an `f64` matrix into a fixed-size `f32` array after checking its shape.
fn fill<const R: usize, const C: usize>(
    m: &DMatrix<f64>,
    what: &'static str,
    out: &mut [[f32; C]; R],
) -> Result<()> {
    if m.shape() != (R, C) {
        return Err(DiscretiseError::Dimension {
            what,
            expected: (R, C),
            got: m.shape(),
        });
    }
    for (i, row) in out.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            let x = m.get((i, j)).copied().ok_or(DiscretiseError::Dimension {
                what,
                expected: (R, C),
                got: m.shape(),
            })?;
            *v = to_f32(x)?;
        }
    }
    Ok(())
}

/// model-core's delta-form state-space coefficients (`N` states, `I` inputs, `O` outputs)
/// from a discrete system ([`crate::zoh_ss`] or [`crate::tustin_ss`]), rounded to `f32`.
///
/// # Errors
/// [`DiscretiseError::Dimension`] when the matrices' shapes are not `N × N`, `N × I`,
/// `O × N`, `O × I`; [`DiscretiseError::F32Overflow`] / [`DiscretiseError::NonFinite`] for
/// values that do not fit in `f32`.
pub fn to_delta_state_space<const N: usize, const I: usize, const O: usize>(
    ss: &DiscreteStateSpace,
) -> Result<DeltaStateSpaceCoefficients<N, I, O>> {
    let mut out = DeltaStateSpaceCoefficients::<N, I, O>::default();
    fill(&ss.delta, "delta (Φ - I)", &mut out.delta)?;
    fill(&ss.gamma, "gamma", &mut out.gamma)?;
    fill(&ss.c, "C", &mut out.c)?;
    fill(&ss.d, "D", &mut out.d)?;
    Ok(out)
}

/// Frequency response at `f_hz` (Hz) of a model-core cascade run every `dt` seconds,
/// evaluated exactly (in `f64`) from its `f32` coefficients:
/// `Π (β0 q² + β1 q + β2) / (q² + α1 q + α2)` with `q = e^{jωT} - 1`.
pub fn cascade_response(cascade: &CascadeCoefficients, f_hz: f64, dt: f64) -> Complex64 {
    let q = delta_operator_point(f_hz, dt);
    cascade
        .active()
        .iter()
        .map(|s| {
            let beta = [f64::from(s.beta0), f64::from(s.beta1), f64::from(s.beta2)];
            let alpha = [f64::from(s.alpha1), f64::from(s.alpha2)];
            section_response(beta, alpha, q)
        })
        .product()
}

/// Runs `input` through the cascade from rest with model-core's own `f32` recursion
/// ([`CascadeCoefficients::step`]); returns one output per input sample.
pub fn simulate_cascade(cascade: &CascadeCoefficients, input: &[f32]) -> Vec<f32> {
    let mut state = CascadeState::ZERO;
    input.iter().map(|&u| cascade.step(&mut state, u)).collect()
}
