//! Small dense linear algebra in `f64` for deriving coefficients from physical parameters
//! (not used in the step path). Fixed-size arrays, no heap, no panics.

/// Error from a factorisation: the matrix is singular or not finite.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Singular;

/// LU factorisation with partial pivoting of the leading `n × n` block of an `N × N` matrix.
#[derive(Clone, Copy, Debug)]
pub struct Lu<const N: usize> {
    lu: [[f64; N]; N],
    perm: [usize; N],
    n: usize,
}

// Indexing below is bounded by loop ranges `0..self.n` with `n <= N` checked in `factor`, so
// no index can be out of bounds; writing it with iterators would obscure the algorithm.
#[allow(clippy::indexing_slicing, clippy::needless_range_loop)]
impl<const N: usize> Lu<N> {
    /// Factorises the leading `n × n` block of `a`. Fails for `n > N`, non-finite entries, or
    /// a pivot below `1e-300` or `1e-13` times the largest entry (numerically singular).
    pub fn factor(a: &[[f64; N]; N], n: usize) -> Result<Self, Singular> {
        let mut lu = Self {
            lu: *a,
            perm: [0; N],
            n,
        };
        lu.factorise(n)?;
        Ok(lu)
    }

    /// An all-zero matrix to fill ([`Lu::matrix_mut`]) and [`Lu::factorise`] in place (the
    /// matrices are kilobytes: no copy of them on the stack).
    pub const ZERO: Self = Self {
        lu: [[0.0; N]; N],
        perm: [0; N],
        n: 0,
    };

    /// The matrix to factorise (before [`Lu::factorise`]).
    pub fn matrix_mut(&mut self) -> &mut [[f64; N]; N] {
        &mut self.lu
    }

    /// Factorises the leading `n × n` block of the matrix it holds, in place (as
    /// [`Lu::factor`]).
    pub fn factorise(&mut self, n: usize) -> Result<(), Singular> {
        if n > N {
            return Err(Singular);
        }
        self.n = n;
        let lu = &mut self.lu;
        let perm = &mut self.perm;
        for (i, p) in perm.iter_mut().enumerate() {
            *p = i;
        }
        let mut scale: f64 = 0.0;
        for i in 0..n {
            for j in 0..n {
                if !lu[i][j].is_finite() {
                    return Err(Singular);
                }
                scale = scale.max(lu[i][j].abs());
            }
        }
        let tiny = (scale * 1e-13).max(1e-300);
        for k in 0..n {
            let mut p = k;
            for i in (k + 1)..n {
                if lu[i][k].abs() > lu[p][k].abs() {
                    p = i;
                }
            }
            if lu[p][k].abs() < tiny {
                return Err(Singular);
            }
            lu.swap(k, p);
            perm.swap(k, p);
            for i in (k + 1)..n {
                let f = lu[i][k] / lu[k][k];
                lu[i][k] = f;
                for j in (k + 1)..n {
                    lu[i][j] -= f * lu[k][j];
                }
            }
        }
        Ok(())
    }

    /// Solves `A x = b` for the leading `n` entries of `b` (in place).
    pub fn solve(&self, b: &mut [f64; N]) {
        let n = self.n;
        let mut x = [0.0; N];
        for i in 0..n {
            x[i] = b[self.perm[i]];
        }
        for i in 0..n {
            for j in 0..i {
                x[i] -= self.lu[i][j] * x[j];
            }
        }
        for i in (0..n).rev() {
            for j in (i + 1)..n {
                x[i] -= self.lu[i][j] * x[j];
            }
            x[i] /= self.lu[i][i];
        }
        b[..n].copy_from_slice(&x[..n]);
    }

    /// Solves `Aᵀ x = b` for the leading `n` entries of `b` (in place).
    pub fn solve_transposed(&self, b: &mut [f64; N]) {
        let n = self.n;
        // Aᵀ = Uᵀ Lᵀ Pᵀ... with P A = L U: Aᵀ = Uᵀ Lᵀ P, so solve Uᵀ y = b, Lᵀ z = y, x = Pᵀ z.
        let mut y = [0.0; N];
        y[..n].copy_from_slice(&b[..n]);
        for i in 0..n {
            for j in 0..i {
                y[i] -= self.lu[j][i] * y[j];
            }
            y[i] /= self.lu[i][i];
        }
        for i in (0..n).rev() {
            for j in (i + 1)..n {
                y[i] -= self.lu[j][i] * y[j];
            }
        }
        for i in 0..n {
            b[self.perm[i]] = y[i];
        }
    }
}

#[cfg(test)]
#[allow(clippy::indexing_slicing)]
mod tests {
    use super::*;

    #[test]
    fn solves_and_solves_transposed() {
        let a = [[4.0, 1.0, 0.5], [2.0, 5.0, 1.0], [0.0, 3.0, 7.0]];
        let lu = Lu::<3>::factor(&a, 3).unwrap();
        let x_true = [1.0, -2.0, 0.5];
        let mut b = [0.0; 3];
        let mut bt = [0.0; 3];
        for i in 0..3 {
            for j in 0..3 {
                b[i] += a[i][j] * x_true[j];
                bt[i] += a[j][i] * x_true[j];
            }
        }
        lu.solve(&mut b);
        lu.solve_transposed(&mut bt);
        for i in 0..3 {
            assert!((b[i] - x_true[i]).abs() < 1e-12, "solve error at {i}");
            assert!((bt[i] - x_true[i]).abs() < 1e-12, "transposed error at {i}");
        }
    }

    #[test]
    fn singular_is_reported() {
        let a = [[1.0, 2.0], [2.0, 4.0]];
        assert_eq!(Lu::<2>::factor(&a, 2).err(), Some(Singular));
        let nan = [[f64::NAN, 0.0], [0.0, 1.0]];
        assert_eq!(Lu::<2>::factor(&nan, 2).err(), Some(Singular));
        assert_eq!(Lu::<2>::factor(&nan, 3).err(), Some(Singular));
    }
}
