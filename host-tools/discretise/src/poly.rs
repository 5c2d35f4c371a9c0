//! Real polynomials: evaluation, expansion from conjugate-symmetric roots, and roots
//! (Aberth–Ehrlich simultaneous iteration, Newton polishing, exact conjugate pairing).

use num_complex::Complex64;

use crate::error::{DiscretiseError, Result};

const EPS: f64 = f64::EPSILON;
const ZERO: Complex64 = Complex64::new(0.0, 0.0);
const ONE: Complex64 = Complex64::new(1.0, 0.0);

/// Evaluates a real polynomial given in descending powers (`c[0] x^n + … + c[n]`) at the
/// complex point `x` (Horner's scheme). An empty slice is the zero polynomial.
pub fn polyval(coeffs_desc: &[f64], x: Complex64) -> Complex64 {
    coeffs_desc.iter().fold(ZERO, |acc, &c| acc * x + c)
}

/// The roots of a real polynomial given in descending powers of its variable.
///
/// Leading zero coefficients are ignored; trailing zero coefficients give exact roots at 0.
/// The other roots come from Aberth–Ehrlich iteration started on the circles of the
/// Newton polygon (so roots of very different magnitude converge alike), are polished by
/// Newton steps, and are returned conjugate-symmetric: every complex root is followed by its
/// exact complex conjugate and real roots have an imaginary part of exactly zero. Real roots
/// come first.
///
/// # Errors
/// [`DiscretiseError::NonFinite`] for a NaN or infinite coefficient,
/// [`DiscretiseError::ZeroPolynomial`] if every coefficient is zero,
/// [`DiscretiseError::RootFinding`] if the iteration produced non-finite roots.
pub fn polynomial_roots(coeffs_desc: &[f64]) -> Result<Vec<Complex64>> {
    Ok(roots_conjugates(coeffs_desc, "polynomial")?.to_roots())
}

/// Roots of a real polynomial (descending powers) as a [`Conjugates`] set.
pub(crate) fn roots_conjugates(coeffs_desc: &[f64], what: &'static str) -> Result<Conjugates> {
    if coeffs_desc.iter().any(|c| !c.is_finite()) {
        return Err(DiscretiseError::NonFinite(what));
    }
    let first = coeffs_desc
        .iter()
        .position(|&c| c != 0.0)
        .ok_or(DiscretiseError::ZeroPolynomial(what))?;
    let trimmed = coeffs_desc.get(first..).unwrap_or(&[]);
    let zero_roots = trimmed.iter().rev().take_while(|&&c| c == 0.0).count();
    let core = trimmed.get(..trimmed.len() - zero_roots).unwrap_or(&[]);
    // Ascending, monic.
    let lead = core.first().copied().unwrap_or(1.0);
    let asc: Vec<f64> = core.iter().rev().map(|&c| c / lead).collect();
    let found = match asc.len() {
        0 | 1 => Vec::new(),
        2 => vec![Complex64::new(-asc.first().copied().unwrap_or(0.0), 0.0)],
        _ => {
            let ratio = |x: Complex64| {
                let (p, dp) = horner_with_derivative(&asc, x);
                p / dp
            };
            let polished: Vec<Complex64> = aberth(initial_guesses(&asc), ratio, 500)
                .into_iter()
                .map(|r| newton_polish(&asc, r))
                .collect();
            if polished.iter().any(|r| !r.is_finite()) {
                return Err(DiscretiseError::RootFinding(what));
            }
            polished
        }
    };
    let mut set = symmetrise(found);
    set.reals.extend(std::iter::repeat_n(0.0, zero_roots));
    Ok(set)
}

/// `p(x)` and `p'(x)` for a polynomial in ascending powers.
fn horner_with_derivative(asc: &[f64], x: Complex64) -> (Complex64, Complex64) {
    asc.iter()
        .rev()
        .fold((ZERO, ZERO), |(p, dp), &c| (p * x + c, dp * x + p))
}

/// At most three Newton steps, each kept only if it reduces `|p|`.
fn newton_polish(asc: &[f64], mut x: Complex64) -> Complex64 {
    let (mut p, mut dp) = horner_with_derivative(asc, x);
    for _ in 0..3 {
        if p == ZERO || dp == ZERO {
            break;
        }
        let candidate = x - p / dp;
        let (pc, dpc) = horner_with_derivative(asc, candidate);
        if !(candidate.is_finite() && pc.norm() < p.norm()) {
            break;
        }
        x = candidate;
        p = pc;
        dp = dpc;
    }
    x
}

/// Starting points for the Aberth iteration: for each edge of the upper convex hull of
/// `(k, ln|a_k|)` (the Newton polygon), as many points as the edge is long, on the circle
/// whose radius is the edge's root-magnitude estimate (Bini 1996).
fn initial_guesses(asc: &[f64]) -> Vec<Complex64> {
    let degree = asc.len().saturating_sub(1);
    let points: Vec<(f64, f64)> = asc
        .iter()
        .enumerate()
        .filter(|(_, c)| **c != 0.0)
        .map(|(k, c)| (k as f64, c.abs().ln()))
        .collect();
    let mut hull: Vec<(f64, f64)> = Vec::with_capacity(points.len());
    for p in points {
        while let [.., o, a] = hull.as_slice() {
            let cross = (a.0 - o.0) * (p.1 - o.1) - (a.1 - o.1) * (p.0 - o.0);
            if cross >= 0.0 {
                hull.pop();
            } else {
                break;
            }
        }
        hull.push(p);
    }
    let n = degree.max(1) as f64;
    let mut guesses = Vec::with_capacity(degree);
    for (i, edge) in hull.windows(2).enumerate() {
        if let [(k0, l0), (k1, l1)] = edge {
            let count = (k1 - k0).round().max(1.0) as usize;
            let radius = ((l0 - l1) / (k1 - k0)).exp();
            for j in 0..count {
                let angle = std::f64::consts::TAU * (j as f64 / count as f64 + i as f64 / n) + 0.7;
                guesses.push(Complex64::from_polar(radius, angle));
            }
        }
    }
    guesses
}

/// Aberth–Ehrlich iteration (Gauss–Seidel form) on a function with as many roots as
/// `start` holds; `ratio(x)` returns `f(x) / f'(x)`. Stops when every correction is at the
/// rounding level of its root or after `max_iter` sweeps.
pub(crate) fn aberth<F>(mut z: Vec<Complex64>, ratio: F, max_iter: usize) -> Vec<Complex64>
where
    F: Fn(Complex64) -> Complex64,
{
    let n = z.len();
    let mut done = vec![false; n];
    for sweep in 0..max_iter {
        let mut all_done = true;
        for i in 0..n {
            if done.get(i).copied().unwrap_or(true) {
                continue;
            }
            let Some(&zi) = z.get(i) else { continue };
            let r = ratio(zi);
            if r == ZERO {
                if let Some(d) = done.get_mut(i) {
                    *d = true;
                }
                continue;
            }
            let s: Complex64 = z
                .iter()
                .enumerate()
                .filter(|(j, _)| *j != i)
                .map(|(_, &zj)| ONE / (zi - zj))
                .sum();
            let w = r / (ONE - r * s);
            let next = if w.is_finite() {
                zi - w
            } else {
                // Coinciding iterates or a vanishing derivative: nudge and retry.
                zi + Complex64::new(0.5, 0.7) * (1e-8 * (1.0 + zi.norm())) * (sweep as f64 + 1.0)
            };
            if let Some(slot) = z.get_mut(i) {
                *slot = next;
            }
            if w.is_finite() && w.norm() <= 4.0 * EPS * next.norm() {
                if let Some(d) = done.get_mut(i) {
                    *d = true;
                }
            } else {
                all_done = false;
            }
        }
        if all_done {
            break;
        }
    }
    z
}

/// Real roots and one representative (positive imaginary part) per complex-conjugate pair.
///
/// The coordinates are whatever the caller chose (`s`, `z` or `1 - z`); pairing is
/// invariant under `x ↦ 1 - x`.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct Conjugates {
    /// Real roots.
    pub reals: Vec<f64>,
    /// Upper-half-plane member of each conjugate pair.
    pub pairs: Vec<Complex64>,
}

impl Conjugates {
    /// Adds the conjugate pair `m`, `m̄`: stored by its upper-half-plane member, or as a
    /// double real root when `m` is real.
    fn push_pair(&mut self, m: Complex64) {
        if m.im == 0.0 {
            self.reals.extend([m.re, m.re]);
        } else if m.im > 0.0 {
            self.pairs.push(m);
        } else {
            self.pairs.push(m.conj());
        }
    }

    /// Number of roots (each pair counts twice).
    pub fn len(&self) -> usize {
        self.reals.len() + 2 * self.pairs.len()
    }

    /// All roots: reals first, then each pair member followed by its conjugate.
    pub fn to_roots(&self) -> Vec<Complex64> {
        self.reals
            .iter()
            .map(|&r| Complex64::new(r, 0.0))
            .chain(self.pairs.iter().flat_map(|&p| [p, p.conj()]))
            .collect()
    }

    /// Applies `f` to every root; `f` must map conjugates to conjugates and reals to reals
    /// (a real-coefficient map). Pairs whose image is real become two real roots.
    pub fn map<F: Fn(Complex64) -> Complex64>(&self, f: F) -> Self {
        let mut out = Self {
            reals: self
                .reals
                .iter()
                .map(|&r| f(Complex64::new(r, 0.0)).re)
                .collect(),
            pairs: Vec::with_capacity(self.pairs.len()),
        };
        for &p in &self.pairs {
            out.push_pair(f(p));
        }
        out
    }

    /// Splits a root list that must be conjugate-symmetric: roots with a zero imaginary part
    /// are real, every other root needs a partner within a relative distance of `1e-9` of
    /// its conjugate (the pair is then replaced by its exactly conjugate mean).
    pub fn split(roots: &[Complex64], what: &'static str) -> Result<Self> {
        let mut out = Self::default();
        let mut lower = Vec::new();
        let mut upper = Vec::new();
        for &r in roots {
            if !r.is_finite() {
                return Err(DiscretiseError::NonFinite(what));
            }
            if r.im == 0.0 {
                out.reals.push(r.re);
            } else if r.im > 0.0 {
                upper.push(r);
            } else {
                lower.push(r);
            }
        }
        for u in upper {
            let best = lower
                .iter()
                .enumerate()
                .map(|(j, l)| (j, (l - u.conj()).norm()))
                .min_by(|a, b| a.1.total_cmp(&b.1));
            match best {
                Some((j, d)) if d <= 1e-9 * u.norm() => {
                    let l = lower.swap_remove(j);
                    out.pairs.push((u + l.conj()) * 0.5);
                }
                _ => {
                    return Err(DiscretiseError::NotConjugate {
                        what,
                        re: u.re,
                        im: u.im,
                    })
                }
            }
        }
        if let Some(l) = lower.first() {
            return Err(DiscretiseError::NotConjugate {
                what,
                re: l.re,
                im: l.im,
            });
        }
        Ok(out)
    }

    /// Coefficients (descending powers) of `Π (x - r)` over the roots.
    pub fn monic_poly(&self) -> Vec<f64> {
        let mut poly = vec![1.0];
        for &r in &self.reals {
            poly = convolve(&poly, &[1.0, -r]);
        }
        for &p in &self.pairs {
            poly = convolve(&poly, &[1.0, -2.0 * p.re, p.norm_sqr()]);
        }
        poly
    }
}

/// Product of two polynomials (any consistent power order).
pub(crate) fn convolve(a: &[f64], b: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; (a.len() + b.len()).saturating_sub(1)];
    for (i, &x) in a.iter().enumerate() {
        for (o, &y) in out.iter_mut().skip(i).zip(b) {
            *o += x * y;
        }
    }
    out
}

/// Makes a computed root set of a real function exactly conjugate-symmetric: the root with
/// the largest imaginary part is paired with the root nearest its conjugate when that
/// partner is closer to the conjugate than the root itself is (a genuine pair, or a double
/// real root split by rounding); otherwise the root is taken as real.
pub(crate) fn symmetrise(mut rest: Vec<Complex64>) -> Conjugates {
    let mut out = Conjugates::default();
    while !rest.is_empty() {
        let Some(i) = rest
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.im.abs().total_cmp(&b.1.im.abs()))
            .map(|(i, _)| i)
        else {
            break;
        };
        let r = rest.swap_remove(i);
        if r.im == 0.0 {
            out.reals.push(r.re);
            continue;
        }
        let partner = rest
            .iter()
            .enumerate()
            .map(|(j, x)| (j, (x - r.conj()).norm()))
            .min_by(|a, b| a.1.total_cmp(&b.1));
        match partner {
            Some((j, d)) if d < r.im.abs() => {
                let other = rest.swap_remove(j);
                out.push_pair((r + other.conj()) * 0.5);
            }
            _ => out.reals.push(r.re),
        }
    }
    out
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests {
    use super::*;

    #[test]
    fn wide_dynamic_range_roots() {
        // (x + 1e-4)(x + 1)(x + 1e4)(x^2 + 2x + 5): relative error of every root < 1e-12.
        let set = Conjugates {
            reals: vec![-1e-4, -1.0, -1e4],
            pairs: vec![Complex64::new(-1.0, 2.0)],
        };
        let roots = polynomial_roots(&set.monic_poly()).unwrap();
        for want in set.to_roots() {
            let err = roots
                .iter()
                .map(|r| (r - want).norm() / want.norm())
                .fold(f64::INFINITY, f64::min);
            assert!(err < 1e-12, "root {want}: relative error {err:e} >= 1e-12");
        }
    }

    #[test]
    fn exact_zero_and_double_roots() {
        // x^2 (x - 3)^2: two exact zeros and a double root (error ~ sqrt(eps) allowed: 1e-6).
        let roots = polynomial_roots(&[1.0, -6.0, 9.0, 0.0, 0.0]).unwrap();
        assert_eq!(roots.len(), 4);
        assert_eq!(roots.iter().filter(|r| r.norm() == 0.0).count(), 2);
        for r in roots.iter().filter(|r| r.norm() != 0.0) {
            assert!((r - 3.0).norm() < 1e-6, "double root 3 found as {r}");
        }
    }
}
