//! Helpers shared by the integration tests.
#![allow(
    dead_code,
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing
)]

use mil_discretise::StateSpace;
use nalgebra::DMatrix;
use num_complex::Complex64;
use std::f64::consts::TAU;

/// `|a - b| / |b|`.
pub fn rel(a: Complex64, b: Complex64) -> f64 {
    (a - b).norm() / b.norm()
}

/// Unit-step response of `ω²/(s² + 2ζω s + ω²)` (ζ < 1) at time `t` (s).
pub fn second_order_step(f_n_hz: f64, zeta: f64, t: f64) -> f64 {
    let w = TAU * f_n_hz;
    let wd = w * (1.0 - zeta * zeta).sqrt();
    1.0 - (-zeta * w * t).exp() * ((wd * t).cos() + zeta * w / wd * (wd * t).sin())
}

/// The Tustin frequency warp: the continuous frequency (Hz) that the discrete response at
/// `f_hz` reproduces, `(K/2π) tan(π f dt)` with `K = 2/dt` or the pre-warped constant.
pub fn warped(f_hz: f64, dt: f64, prewarp_hz: Option<f64>) -> f64 {
    let k = match prewarp_hz {
        None => 2.0 / dt,
        Some(fp) => TAU * fp / (0.5 * TAU * fp * dt).tan(),
    };
    k * (0.5 * TAU * f_hz * dt).tan() / TAU
}

/// Two masses (m1 = 10 kg on k1 = 1e4 N/m, c1 = 20 N s/m to ground; m2 = 1 kg on
/// k2 = 5e4 N/m, c2 = 10 N s/m to m1), forces on both masses in, both positions out.
/// States `[x1, x2, v1, v2]`. Undamped modes near 4.8 Hz and 37 Hz.
pub fn two_dof() -> StateSpace {
    let (m1, m2, k1, k2, c1, c2) = (10.0, 1.0, 1e4, 5e4, 20.0, 10.0);
    let minv = DMatrix::from_row_slice(2, 2, &[1.0 / m1, 0.0, 0.0, 1.0 / m2]);
    let k = DMatrix::from_row_slice(2, 2, &[k1 + k2, -k2, -k2, k2]);
    let c = DMatrix::from_row_slice(2, 2, &[c1 + c2, -c2, -c2, c2]);
    let mut a = DMatrix::zeros(4, 4);
    a.view_mut((0, 2), (2, 2))
        .copy_from(&DMatrix::identity(2, 2));
    a.view_mut((2, 0), (2, 2)).copy_from(&(-&minv * k));
    a.view_mut((2, 2), (2, 2)).copy_from(&(-&minv * c));
    let mut b = DMatrix::zeros(4, 2);
    b.view_mut((2, 0), (2, 2)).copy_from(&minv);
    let mut cm = DMatrix::zeros(2, 4);
    cm.view_mut((0, 0), (2, 2))
        .copy_from(&DMatrix::identity(2, 2));
    StateSpace::new(a, b, cm, DMatrix::zeros(2, 2)).unwrap()
}

/// Largest element-wise relative error between two response matrices (relative to the
/// largest entry of `want`).
pub fn mat_rel(got: &DMatrix<Complex64>, want: &DMatrix<Complex64>) -> f64 {
    let scale = want.iter().map(|v| v.norm()).fold(0.0, f64::max);
    got.iter()
        .zip(want.iter())
        .map(|(g, w)| (g - w).norm() / scale)
        .fold(0.0, f64::max)
}

/// Logarithmically spaced frequencies from `lo` to `hi` (Hz), `n` points.
pub fn logspace(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    (0..n)
        .map(|i| lo * (hi / lo).powf(i as f64 / (n - 1) as f64))
        .collect()
}
