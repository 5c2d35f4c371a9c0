//! Discretisation methods: Tustin (bilinear, optionally pre-warped) and zero-order hold,
//! for zero-pole-gain and state-space models.

use nalgebra::DMatrix;
use num_complex::Complex64;

use crate::continuous::{StateSpace, TransferFunction, Zpk};
use crate::discrete::{roots_from, DiscreteRoot, DiscreteStateSpace, DiscreteZpk};
use crate::error::{check_dt, DiscretiseError, Result};
use crate::poly::{aberth, roots_conjugates, symmetrise, Conjugates};

const ONE: Complex64 = Complex64::new(1.0, 0.0);

/// The bilinear map's constant `K` in `s = K (z - 1)/(z + 1)`: `2/dt`, or with pre-warping
/// at `f_p` Hz, `ω_p / tan(ω_p dt / 2)` (so the discrete response at `f_p` equals the
/// continuous one there).
fn bilinear_constant(dt: f64, prewarp_hz: Option<f64>) -> Result<f64> {
    let dt = check_dt(dt)?;
    match prewarp_hz {
        None => Ok(2.0 / dt),
        Some(f) => {
            let nyquist_hz = 0.5 / dt;
            if !(f.is_finite() && f > 0.0 && f < nyquist_hz) {
                return Err(DiscretiseError::InvalidPrewarp {
                    freq_hz: f,
                    nyquist_hz,
                });
            }
            let w = std::f64::consts::TAU * f;
            Ok(w / (0.5 * w * dt).tan())
        }
    }
}

/// Tustin (bilinear) discretisation of a zero-pole-gain model with sample period `dt` (s),
/// optionally pre-warped to match the continuous response exactly at `prewarp_hz` (Hz).
///
/// Each root maps as `z = (K + s)/(K - s)` with `1 - z = -2s/(K - s)` computed directly
/// (`K = 2/dt`, i.e. `1 - z = -s dt/(1 - s dt/2)`; with pre-warping
/// `K = ω_p / tan(ω_p dt/2)`, which is the same as scaling `s` by
/// `ω_p / ((2/dt) tan(ω_p dt/2))`). Zeros at infinity map to `z = -1`. The discrete gain is
/// `gain · Π (K - zᵢ) / Π (K - pⱼ)`.
///
/// # Errors
/// Invalid `dt` or pre-warp frequency, an invalid model, or a root at `s = K`.
pub fn tustin(zpk: &Zpk, dt: f64, prewarp_hz: Option<f64>) -> Result<DiscreteZpk> {
    let k = bilinear_constant(dt, prewarp_hz)?;
    let (zeros, poles) = zpk.split()?;
    if let Some(s) = zeros
        .to_roots()
        .into_iter()
        .chain(poles.to_roots())
        .find(|s| (Complex64::new(k, 0.0) - s).norm() == 0.0)
    {
        return Err(DiscretiseError::BilinearSingular(s.re));
    }
    let kc = Complex64::new(k, 0.0);
    let map = |s: Complex64| DiscreteRoot {
        z: (kc + s) / (kc - s),
        one_minus_z: -2.0 * s / (kc - s),
    };
    // Π (K - r) over a conjugate set, real by construction.
    let factor = |set: &Conjugates| {
        set.reals.iter().map(|r| k - r).product::<f64>()
            * set
                .pairs
                .iter()
                .map(|p| (kc - p).norm_sqr())
                .product::<f64>()
    };
    let gain = zpk.gain * factor(&zeros) / factor(&poles);
    if !gain.is_finite() {
        return Err(DiscretiseError::NonFinite("Tustin gain"));
    }
    let mut dzeros = roots_from(&zeros, map);
    let at_infinity = DiscreteRoot {
        z: Complex64::new(-1.0, 0.0),
        one_minus_z: Complex64::new(2.0, 0.0),
    };
    dzeros.extend(std::iter::repeat_n(at_infinity, poles.len() - zeros.len()));
    Ok(DiscreteZpk {
        zeros: dzeros,
        poles: roots_from(&poles, map),
        gain,
        dt,
    })
}

/// [`tustin`] of a transfer function (via [`TransferFunction::to_zpk`]).
///
/// # Errors
/// As [`TransferFunction::to_zpk`] and [`tustin`].
pub fn tustin_tf(tf: &TransferFunction, dt: f64, prewarp_hz: Option<f64>) -> Result<DiscreteZpk> {
    tustin(&tf.to_zpk()?, dt, prewarp_hz)
}

/// Tustin (bilinear) discretisation of a state-space model with sample period `dt` (s),
/// optionally pre-warped at `prewarp_hz` (Hz).
///
/// With `T = 2/K` (`T = dt` without pre-warping) and `M = (I - A T/2)⁻¹`:
/// `Φ - I = T M A`, `Γ = T M B`, `C_d = C M`, `D_d = D + C M B T/2`, so that
/// `C_d (zI - Φ)⁻¹ Γ + D_d = C (sI - A)⁻¹ B + D` at `s = K (z - 1)/(z + 1)`.
///
/// # Errors
/// Invalid `dt`, pre-warp frequency or matrices, or `I - A T/2` singular.
pub fn tustin_ss(ss: &StateSpace, dt: f64, prewarp_hz: Option<f64>) -> Result<DiscreteStateSpace> {
    let t = 2.0 / bilinear_constant(dt, prewarp_hz)?;
    let (n, _, _) = ss.dimensions()?;
    let lhs = DMatrix::identity(n, n) - &ss.a * (0.5 * t);
    let lu = lhs.clone().lu();
    let singular = DiscretiseError::Singular("I - A T/2 (Tustin)");
    let ma = lu.solve(&ss.a).ok_or(singular.clone())?;
    let mb = lu.solve(&ss.b).ok_or(singular.clone())?;
    // C M = (Mᵀ Cᵀ)ᵀ = (solve(lhsᵀ, Cᵀ))ᵀ
    let cm = lhs
        .transpose()
        .lu()
        .solve(&ss.c.transpose())
        .ok_or(singular)?
        .transpose();
    let d = &ss.d + &cm * &ss.b * (0.5 * t);
    Ok(DiscreteStateSpace {
        delta: ma * t,
        gamma: mb * t,
        c: cm,
        d,
        dt,
    })
}

/// Maximum absolute column sum.
fn one_norm(m: &DMatrix<f64>) -> f64 {
    m.column_iter()
        .map(|c| c.iter().map(|v| v.abs()).sum::<f64>())
        .fold(0.0, f64::max)
}

/// `e^M - I` for a square matrix, accurate for small `M` (no `I + small - I` cancellation):
/// `mil_numerics::expm`'s scaling and squaring on `F = e^M - I` itself (the workspace's one
/// matrix exponential).
///
/// # Errors
/// A non-square or non-finite matrix.
pub fn expm_minus_identity(m: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    if !m.is_square() {
        return Err(DiscretiseError::Dimension {
            what: "matrix exponential",
            expected: (m.nrows(), m.nrows()),
            got: m.shape(),
        });
    }
    if !one_norm(m).is_finite() {
        return Err(DiscretiseError::NonFinite("matrix exponential argument"));
    }
    // Column-major storage passed as row-major is the transpose, and the transpose commutes
    // with the exponential: the result comes back column-major.
    let n = m.nrows();
    let mut f = DMatrix::zeros(n, n);
    let mut scratch = mil_numerics::expm::ExpmScratch::default();
    if !mil_numerics::expm::expm_minus_identity(
        m.as_slice(),
        n,
        1.0,
        f.as_mut_slice(),
        &mut scratch,
    ) {
        return Err(DiscretiseError::NonFinite("matrix exponential"));
    }
    Ok(f)
}

/// Zero-order-hold discretisation of a state-space model with sample period `dt` (s).
///
/// `Φ - I` and `Γ` are the blocks of `e^{[[A, B], [0, 0]] dt} - I`
/// ([`expm_minus_identity`]), so `Φ - I = A Ψ dt` and `Γ = Ψ B dt` with
/// `Ψ = Σ (A dt)^k/(k+1)!` keep full precision for slow modes; `C`, `D` are unchanged.
///
/// # Errors
/// Invalid `dt` or matrices.
pub fn zoh_ss(ss: &StateSpace, dt: f64) -> Result<DiscreteStateSpace> {
    let dt = check_dt(dt)?;
    let (n, m, _) = ss.dimensions()?;
    let mut aug = DMatrix::zeros(n + m, n + m);
    aug.view_mut((0, 0), (n, n)).copy_from(&(&ss.a * dt));
    aug.view_mut((0, n), (n, m)).copy_from(&(&ss.b * dt));
    let f = expm_minus_identity(&aug)?;
    Ok(DiscreteStateSpace {
        delta: f.view((0, 0), (n, n)).into_owned(),
        gamma: f.view((0, n), (n, m)).into_owned(),
        c: ss.c.clone(),
        d: ss.d.clone(),
        dt,
    })
}

/// `1 - e^{s dt}` without forming `e^{s dt}`:
/// `-(expm1(σT) cos ωT - 2 sin²(ωT/2)) - j e^{σT} sin ωT` for `s = σ + jω`.
fn one_minus_exp(s: Complex64, dt: f64) -> Complex64 {
    let (sigma, omega) = (s.re * dt, s.im * dt);
    let half = (0.5 * omega).sin();
    Complex64::new(
        -(sigma.exp_m1() * omega.cos() - 2.0 * half * half),
        -sigma.exp() * omega.sin(),
    )
}

/// Zero-order-hold discretisation of a zero-pole-gain model with sample period `dt` (s).
///
/// - Poles: `z = e^{p dt}`, `1 - z` from `expm1` ([`DiscreteRoot`] keeps both).
/// - Zeros: the model is realised in state space ([`Zpk::to_state_space`]) and discretised
///   by [`zoh_ss`]; in `q = z - 1` the numerator is `N(q) = H_d(q) Π (q - qⱼ)` with
///   `H_d(q) = C (qI - Δ)⁻¹ Γ + D`. Starting values come from interpolating `N` on a circle
///   (inverse DFT), then every root is refined by Aberth iteration on `N` evaluated through
///   the state space, which keeps zeros near `z = 1` at full relative precision. A continuous
///   zero at `s = 0` gives an exact discrete zero at `z = 1`.
/// - Gain: matched at DC to the continuous DC gain (ZOH preserves it exactly), or, when the
///   model has a pole or zero at `s = 0`, matched to `H_d` at a quarter of the sample rate
///   (`f = 1/(4 dt)`).
///
/// Exactly cancelling poles and zeros at `s = 0` are removed first.
///
/// # Errors
/// Invalid `dt` or model, a singular evaluation, or a root-finding failure.
pub fn zoh(zpk: &Zpk, dt: f64) -> Result<DiscreteZpk> {
    let dt = check_dt(dt)?;
    let (mut zeros, mut poles) = zpk.split()?;
    // Cancel exact pole/zero pairs at s = 0.
    loop {
        let zi = zeros.reals.iter().position(|&r| r == 0.0);
        let pi = poles.reals.iter().position(|&r| r == 0.0);
        match (zi, pi) {
            (Some(zi), Some(pi)) => {
                zeros.reals.swap_remove(zi);
                poles.reals.swap_remove(pi);
            }
            _ => break,
        }
    }
    let pole_map = |s: Complex64| DiscreteRoot {
        z: (s * dt).exp(),
        one_minus_z: one_minus_exp(s, dt),
    };
    let dpoles = roots_from(&poles, pole_map);
    let n = poles.len();
    if zpk.gain == 0.0 || n == 0 {
        return Ok(DiscreteZpk {
            zeros: Vec::new(),
            poles: dpoles,
            gain: zpk.gain,
            dt,
        });
    }
    let reduced = Zpk {
        zeros: zeros.to_roots(),
        poles: poles.to_roots(),
        gain: zpk.gain,
    };
    let dss = zoh_ss(&reduced.to_state_space()?, dt)?;
    let h = |q: Complex64| -> Result<Complex64> {
        let r = dss.response_at_q(q)?;
        r.get((0, 0)).copied().ok_or(DiscretiseError::Dimension {
            what: "ZOH realisation response",
            expected: (1, 1),
            got: r.shape(),
        })
    };
    let zero_at_origin = zeros.reals.contains(&0.0);
    let exact = usize::from(zero_at_origin);
    let m_total = if zeros.len() == n { n } else { n - 1 };
    let m_find = m_total.saturating_sub(exact);
    let w_poles: Vec<Complex64> = dpoles.iter().map(|r| r.one_minus_z).collect();

    // Starting values: interpolate N(q) = H_d(q) Π (q + w_j) on |q| = R (inverse DFT).
    let max_q = w_poles.iter().map(|w| w.norm()).fold(2.0, f64::max);
    let radius = 1.25 * max_q;
    let points = n + 1;
    let mut samples = Vec::with_capacity(points);
    for i in 0..points {
        let theta = std::f64::consts::TAU * (i as f64 + 0.5) / points as f64;
        let q = Complex64::from_polar(radius, theta);
        let den: Complex64 = w_poles.iter().map(|w| q + w).product();
        samples.push((theta, h(q)? * den));
    }
    let coeff = |k: usize| -> f64 {
        let sum: Complex64 = samples
            .iter()
            .map(|(theta, v)| v * Complex64::from_polar(1.0, -(k as f64) * theta))
            .sum();
        sum.re / points as f64 / radius.powi(k as i32)
    };
    // Descending coefficients of N(q)/q^exact, degree m_find.
    let desc: Vec<f64> = (exact..=m_total).rev().map(coeff).collect();
    let mut start = if m_find == 0 {
        Vec::new()
    } else {
        roots_conjugates(&desc, "ZOH numerator").map_or_else(|_| Vec::new(), |c| c.to_roots())
    };
    // Too few starting values (vanishing leading coefficient): add points on the circle.
    while start.len() < m_find {
        let theta = 0.9 + std::f64::consts::TAU * start.len() as f64 / m_find as f64;
        start.push(Complex64::from_polar(radius, theta));
    }
    start.truncate(m_find);
    // Separate coinciding starting values.
    for i in 0..start.len() {
        let (head, tail) = start.split_at_mut(i);
        if let Some(x) = tail.first_mut() {
            while head.iter().any(|y| y == x) {
                *x += Complex64::new(1e-9, 1e-9) * (1.0 + x.norm());
            }
        }
    }

    // Aberth on f(q) = N(q)/q^exact: f'/f = H'/H + Σ 1/(q + w_j) - exact/q.
    let n_states = dss.delta.nrows();
    let to_c = |m: &DMatrix<f64>| m.map(|v| Complex64::new(v, 0.0));
    let (delta_c, gamma_c, c_c, d_c) = (
        to_c(&dss.delta),
        to_c(&dss.gamma),
        to_c(&dss.c),
        to_c(&dss.d),
    );
    let ratio = |q: Complex64| -> Complex64 {
        let lu = (DMatrix::<Complex64>::identity(n_states, n_states) * q - &delta_c).lu();
        let (Some(x), d) = (
            lu.solve(&gamma_c),
            d_c.get((0, 0)).copied().unwrap_or_default(),
        ) else {
            return Complex64::new(f64::NAN, 0.0);
        };
        let Some(y) = lu.solve(&x) else {
            return Complex64::new(f64::NAN, 0.0);
        };
        let hq = (&c_c * &x).get((0, 0)).copied().unwrap_or_default() + d;
        if hq == Complex64::new(0.0, 0.0) {
            return hq;
        }
        let dh = -(&c_c * &y).get((0, 0)).copied().unwrap_or_default();
        let log_derivative = dh / hq + w_poles.iter().map(|w| ONE / (q + w)).sum::<Complex64>()
            - Complex64::new(exact as f64, 0.0) / q;
        ONE / log_derivative
    };
    let found = aberth(start, ratio, 200);
    if found.iter().any(|q| !q.is_finite()) {
        return Err(DiscretiseError::RootFinding("ZOH zeros"));
    }
    // Roots driven far out are zeros at infinity (numerator degree lower than expected).
    let finite: Vec<Complex64> = found
        .into_iter()
        .filter(|q| q.norm() < 1e8 * radius)
        .collect();
    let q_zeros = symmetrise(finite);
    let mut dzeros = roots_from(&q_zeros.map(|q| -q), DiscreteRoot::from_one_minus_z);
    if zero_at_origin {
        dzeros.push(DiscreteRoot::from_one_minus_z(Complex64::new(0.0, 0.0)));
    }
    let mut result = DiscreteZpk {
        zeros: dzeros,
        poles: dpoles,
        gain: 1.0,
        dt,
    };
    let pole_at_origin = poles.reals.contains(&0.0);
    let gain = if zero_at_origin || pole_at_origin {
        let q_ref = Complex64::new(-1.0, 1.0); // e^{jπ/2} - 1, f = 1/(4 dt)
        (h(q_ref)? / result.response_at_q(q_ref)).re
    } else {
        // Continuous DC gain: gain · Π(-z) / Π(-p), real by conjugate symmetry.
        let prod = |set: &Conjugates| {
            set.reals.iter().map(|r| -r).product::<f64>()
                * set.pairs.iter().map(|p| p.norm_sqr()).product::<f64>()
        };
        zpk.gain * prod(&zeros) / prod(&poles) / result.dc_gain()
    };
    if !gain.is_finite() {
        return Err(DiscretiseError::NonFinite("ZOH gain"));
    }
    result.gain = gain;
    Ok(result)
}

/// [`zoh`] of a transfer function (via [`TransferFunction::to_zpk`]).
///
/// # Errors
/// As [`TransferFunction::to_zpk`] and [`zoh`].
pub fn zoh_tf(tf: &TransferFunction, dt: f64) -> Result<DiscreteZpk> {
    zoh(&tf.to_zpk()?, dt)
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests {
    use super::*;

    #[test]
    fn one_minus_exp_matches_direct_formula() {
        // For a fast pole the direct 1 - e^{sT} is accurate; agreement to 1e-14 relative.
        let s = Complex64::new(-300.0, 2000.0);
        let dt = 1e-3;
        let direct = ONE - (s * dt).exp();
        let err = (one_minus_exp(s, dt) - direct).norm() / direct.norm();
        assert!(err < 1e-14, "relative error {err:e} >= 1e-14");
    }

    #[test]
    fn expm_minus_identity_small_argument_is_relative_accurate() {
        // diag(-1e-9, 2e-12): e^x - 1 must come out as expm1 to 1e-15 relative.
        let m = DMatrix::from_row_slice(2, 2, &[-1e-9, 0.0, 0.0, 2e-12]);
        let f = expm_minus_identity(&m).unwrap();
        for (i, x) in [-1e-9f64, 2e-12].iter().enumerate() {
            let err = ((f[(i, i)] - x.exp_m1()) / x.exp_m1()).abs();
            assert!(err < 1e-15, "entry {i}: relative error {err:e} >= 1e-15");
        }
    }
}
