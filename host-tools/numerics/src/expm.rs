//! The matrix exponential: `e^{sM} − I` by scaling and squaring, accurate for small
//! arguments, on row-major slices with reusable scratch (no allocation once warmed up).
//! The simulated rig's exact linear steps and the analysis' zero-order-hold discretisation
//! both call it.

use crate::dense::matmul;

/// Scratch buffers of [`expm_minus_identity`], reused across calls.
#[derive(Clone, Debug, Default)]
pub struct ExpmScratch {
    x: Vec<f64>,
    term: Vec<f64>,
    product: Vec<f64>,
}

/// Degree of the Taylor series of `e^X − I` at `‖X‖₁ <= 1/2`: the truncation is below
/// `0.5^19 / 19! ≈ 2e-23` relative.
const DEGREE: u32 = 18;

/// Most squarings taken (a norm up to `2^199`; a larger finite one overflows anyway).
const MAX_SQUARINGS: u32 = 200;

/// `out = e^{scale·M} − I` for the `n × n` row-major matrix `m`.
///
/// Scaling and squaring on `F = e^X − I` itself: `X = scale·M·2^-s` with `‖X‖₁ <= 1/2`,
/// `F(X) = Σ_{k=1}^{18} X^k/k!`, then `F(2X) = 2F(X) + F(X)²` `s` times, which never forms
/// `I + F` and so keeps slow modes' `e^{x} − 1 ≈ x` to full relative precision.
///
/// The transpose commutes with the exponential, so a column-major matrix passed as it is
/// gives the column-major result.
///
/// Returns false (and `out` unspecified) if `m` or `out` does not hold `n × n` entries or
/// the argument or result is not finite.
pub fn expm_minus_identity(
    m: &[f64],
    n: usize,
    scale: f64,
    out: &mut [f64],
    scratch: &mut ExpmScratch,
) -> bool {
    let len = n * n;
    if m.len() != len || out.len() != len {
        return false;
    }
    let norm = (0..n)
        .map(|j| (0..n).map(|i| (m[i * n + j] * scale).abs()).sum::<f64>())
        .fold(0.0_f64, f64::max);
    if !norm.is_finite() {
        return false;
    }
    let mut squarings = 0;
    let mut reduced = norm;
    let mut factor = scale;
    while reduced > 0.5 && squarings < MAX_SQUARINGS {
        reduced *= 0.5;
        factor *= 0.5;
        squarings += 1;
    }
    let ExpmScratch { x, term, product } = scratch;
    for buffer in [&mut *x, &mut *term, &mut *product] {
        buffer.clear();
        buffer.resize(len, 0.0);
    }
    for ((xi, ti), mi) in x.iter_mut().zip(term.iter_mut()).zip(m) {
        *xi = mi * factor;
        *ti = *xi;
    }
    out.copy_from_slice(x);
    for k in 2..=DEGREE {
        matmul(term, x, n, product);
        let f = 1.0 / f64::from(k);
        for ((t, p), o) in term.iter_mut().zip(product.iter()).zip(out.iter_mut()) {
            *t = p * f;
            *o += *t;
        }
    }
    for _ in 0..squarings {
        matmul(out, out, n, product);
        for (o, p) in out.iter_mut().zip(product.iter()) {
            *o = 2.0 * *o + p;
        }
    }
    out.iter().all(|v| v.is_finite())
}

/// `out = a b` for `n × n` row-major matrices.
#[cfg(test)]
mod tests {
    use super::*;

    fn expm1(m: &[f64], n: usize, scale: f64) -> Vec<f64> {
        let mut out = vec![0.0; n * n];
        assert!(expm_minus_identity(
            m,
            n,
            scale,
            &mut out,
            &mut ExpmScratch::default()
        ));
        out
    }

    #[test]
    fn diagonal_matrices_give_expm1_to_full_relative_precision() {
        // Slow and fast modes together: e^x − 1 must come out as expm1, not e^x − 1 with
        // the cancellation.
        let d = [-1e-9, 2e-12, -3.0, 40.0];
        let mut m = vec![0.0; 16];
        for (i, v) in d.iter().enumerate() {
            m[i * 4 + i] = *v;
        }
        let f = expm1(&m, 4, 1.0);
        for (i, v) in d.iter().enumerate() {
            let want = v.exp_m1();
            assert!(
                ((f[i * 4 + i] - want) / want).abs() < 1e-13,
                "{v}: {}",
                f[i * 4 + i]
            );
        }
        assert!(f.iter().enumerate().all(|(k, v)| k % 5 == 0 || *v == 0.0));
    }

    #[test]
    fn a_rotation_and_a_jordan_block_match_their_closed_forms() {
        // [[0, w], [−w, 0]] t: rotation by w t.
        let (w, t) = (7.0, 0.9);
        let f = expm1(&[0.0, w, -w, 0.0], 2, t);
        let (c, s) = ((w * t).cos(), (w * t).sin());
        for (got, want) in f.iter().zip([c - 1.0, s, -s, c - 1.0]) {
            assert!((got - want).abs() < 1e-13, "{got} vs {want}");
        }
        // [[a, 1], [0, a]]: e^{a} [[1, 1], [0, 1]], scaled by 3.
        let a = -0.4;
        let f = expm1(&[a, 1.0, 0.0, a], 2, 3.0);
        let e = (3.0 * a).exp();
        for (got, want) in f.iter().zip([e - 1.0, 3.0 * e, 0.0, e - 1.0]) {
            assert!((got - want).abs() < 1e-13, "{got} vs {want}");
        }
    }

    #[test]
    fn bad_sizes_and_non_finite_arguments_are_refused() {
        let mut out = vec![0.0; 4];
        let mut s = ExpmScratch::default();
        assert!(!expm_minus_identity(&[1.0; 3], 2, 1.0, &mut out, &mut s));
        assert!(!expm_minus_identity(
            &[1.0; 4],
            2,
            f64::NAN,
            &mut out,
            &mut s
        ));
        assert!(!expm_minus_identity(&[1e300; 4], 2, 1e10, &mut out, &mut s));
        assert!(expm_minus_identity(&[0.0; 4], 2, 1.0, &mut out, &mut s));
        assert_eq!(out, vec![0.0; 4]);
    }
}
