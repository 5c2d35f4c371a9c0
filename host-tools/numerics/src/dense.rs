//! Small dense linear algebra on slices, row-major: the inverse of a small matrix (the rig
//! specimen's mass-matrix check, its plant's `M⁻¹`), the product and the balancing of square
//! matrices (the plant's exact steps, the matrix exponential), and the dot product, row and
//! copy of the plant's inner loops.

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
pub fn dot(a: &[f64], b: &[f64]) -> f64 {
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
pub fn row(m: &[f64], i: usize, n: usize) -> &[f64] {
    m.get(i * n..i * n + n).unwrap_or(&[])
}

/// `dst = src` over the shorter length.
#[inline]
pub fn copy(dst: &mut [f64], src: &[f64]) {
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
pub fn matmul(a: &[f64], b: &[f64], p: usize, out: &mut [f64]) {
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
pub fn balance(a: &mut [f64], p: usize) -> Vec<f64> {
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn invert_gives_the_inverse_and_refuses_singular_or_ragged_matrices() {
        let a = [
            vec![4.0, 1.0, 0.5],
            vec![1.0, 3.0, 0.2],
            vec![0.5, 0.2, 2.0],
        ];
        let inv = invert(&a).unwrap();
        for (i, a_row) in a.iter().enumerate() {
            for j in 0..3 {
                let p: f64 = (0..3).map(|k| a_row[k] * inv[k * 3 + j]).sum();
                let want = if i == j { 1.0 } else { 0.0 };
                assert!((p - want).abs() < 1e-14, "({i}, {j}): {p}");
            }
        }
        assert!(invert(&[vec![1.0, 2.0], vec![2.0, 4.0]]).is_none());
        assert!(invert(&[vec![1.0, 2.0], vec![3.0]]).is_none());
    }

    #[test]
    fn balancing_is_an_exact_similarity_by_powers_of_two() {
        // Units as far apart as m and Pa.
        let original = [0.0, 1.0, 0.0, -1e4, -10.0, 1e-9, 0.0, 1e9, -100.0];
        let mut a = original;
        let d = balance(&mut a, 3);
        assert!(d.iter().any(|v| *v != 1.0), "{d:?}");
        assert!(d.iter().all(|v| v.log2().fract() == 0.0), "{d:?}");
        for i in 0..3 {
            for j in 0..3 {
                assert_eq!(a[i * 3 + j], original[i * 3 + j] * d[j] / d[i]);
            }
        }
    }
}
