//! Small fixed-order discrete state-space blocks in delta form.
//!
//! `x[k+1] = x[k] + Δ x[k] + Γ u[k]`, `y[k] = C x[k] + D u[k]`, with `Δ = Φ - I`.
//! Storing `Δ` rather than `Φ` keeps slow modes (eigenvalues of `Φ` near 1) at full `f32`
//! relative precision, as the delta-form biquads do. Coefficients are computed on the host in
//! `f64` (zero-order hold or Tustin, `mil-discretise`) or on the target from physical
//! parameters ([`crate::substructure`]).

/// Coefficients of an `N`-state, `I`-input, `O`-output discrete system in delta form.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct DeltaStateSpaceCoefficients<const N: usize, const I: usize, const O: usize> {
    /// `Δ = Φ - I` (state transition minus identity), row-major.
    pub delta: [[f32; N]; N],
    /// Input matrix `Γ`.
    pub gamma: [[f32; I]; N],
    /// Output matrix `C`.
    pub c: [[f32; N]; O],
    /// Feed-through matrix `D`.
    pub d: [[f32; I]; O],
}

impl<const N: usize, const I: usize, const O: usize> Default
    for DeltaStateSpaceCoefficients<N, I, O>
{
    fn default() -> Self {
        Self {
            delta: [[0.0; N]; N],
            gamma: [[0.0; I]; N],
            c: [[0.0; N]; O],
            d: [[0.0; I]; O],
        }
    }
}

impl<const N: usize, const I: usize, const O: usize> DeltaStateSpaceCoefficients<N, I, O> {
    /// `true` when every coefficient is finite. Stability (eigenvalues of `I + Δ` inside the
    /// unit circle) is checked where the coefficients are designed (`mil-discretise`), not
    /// here: an eigenvalue solver does not belong on the target.
    pub fn is_finite(&self) -> bool {
        let rows = |m: &[[f32; N]]| m.iter().flatten().all(|v| v.is_finite());
        let rows_i = |m: &[[f32; I]]| m.iter().flatten().all(|v| v.is_finite());
        rows(&self.delta) && rows_i(&self.gamma) && rows(&self.c) && rows_i(&self.d)
    }

    /// Output for state `x` and input `u`: `C x + D u`.
    #[inline]
    pub fn output(&self, x: &[f32; N], u: &[f32; I]) -> [f32; O] {
        let mut y = [0.0; O];
        for ((yo, c_row), d_row) in y.iter_mut().zip(&self.c).zip(&self.d) {
            *yo = dot(c_row, x) + dot(d_row, u);
        }
        y
    }

    /// Advances `x` by one sample with input `u`.
    #[inline]
    pub fn advance(&self, x: &mut [f32; N], u: &[f32; I]) {
        let mut dx = [0.0; N];
        for ((d, delta_row), gamma_row) in dx.iter_mut().zip(&self.delta).zip(&self.gamma) {
            *d = dot(delta_row, x) + dot(gamma_row, u);
        }
        for (xi, d) in x.iter_mut().zip(dx) {
            *xi += d;
        }
    }
}

#[inline]
fn dot<const K: usize>(a: &[f32; K], b: &[f32; K]) -> f32 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// A delta-form state-space block with its own state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DeltaStateSpace<const N: usize, const I: usize, const O: usize> {
    /// Coefficients (replace between two steps to retune).
    pub coefficients: DeltaStateSpaceCoefficients<N, I, O>,
    /// State vector.
    pub x: [f32; N],
}

impl<const N: usize, const I: usize, const O: usize> DeltaStateSpace<N, I, O> {
    /// A block at rest (zero state).
    pub fn new(coefficients: DeltaStateSpaceCoefficients<N, I, O>) -> Self {
        Self {
            coefficients,
            x: [0.0; N],
        }
    }

    /// One sample: returns `y[k] = C x[k] + D u[k]` and advances the state.
    #[inline]
    pub fn step(&mut self, u: &[f32; I]) -> [f32; O] {
        let y = self.coefficients.output(&self.x, u);
        self.coefficients.advance(&mut self.x, u);
        y
    }
}
