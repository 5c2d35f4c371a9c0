//! A known linear discrete system for the identification tests, and small helpers.

use std::f64::consts::PI;

use mil_identify::Complex64;

/// Sample rate of the test records (Hz).
pub const FS: f64 = 1000.0;

/// A lightly damped second-order system with a pure delay, as a difference equation:
/// `y[n] = b0 x[n-d] + b1 x[n-d-1] + b2 x[n-d-2] - a1 y[n-1] - a2 y[n-2]`.
/// Poles: the impulse-invariant images `r e^{±jθ}` of a continuous mode of natural
/// frequency `f_n` and damping ratio `ζ`; zeros: a double zero at `z = -1`; unit DC gain.
pub struct TestSystem {
    pub b: [f64; 3],
    pub a: [f64; 2],
    pub delay: usize,
}

impl TestSystem {
    pub fn new(f_n_hz: f64, zeta: f64, delay: usize) -> Self {
        let wn = 2.0 * PI * f_n_hz / FS;
        let r = (-zeta * wn).exp();
        let theta = wn * (1.0 - zeta * zeta).sqrt();
        let a = [-2.0 * r * theta.cos(), r * r];
        let g = (1.0 + a[0] + a[1]) / 4.0;
        Self {
            b: [g, 2.0 * g, g],
            a,
            delay,
        }
    }

    /// The 40 Hz, ζ = 0.05 mode with a 3-sample (3 ms) delay used by most tests.
    pub fn standard() -> Self {
        Self::new(40.0, 0.05, 3)
    }

    /// Output for input `x`, starting at rest.
    pub fn simulate(&self, x: &[f64]) -> Vec<f64> {
        let mut y = vec![0.0; x.len()];
        let xd = |n: usize, k: usize| n.checked_sub(self.delay + k).map_or(0.0, |i| x[i]);
        for n in 0..x.len() {
            let mut v = self.b[0] * xd(n, 0) + self.b[1] * xd(n, 1) + self.b[2] * xd(n, 2);
            if n >= 1 {
                v -= self.a[0] * y[n - 1];
            }
            if n >= 2 {
                v -= self.a[1] * y[n - 2];
            }
            y[n] = v;
        }
        y
    }

    /// The exact frequency response `H(e^{jωT})` at `f` (Hz).
    pub fn response(&self, f: f64) -> Complex64 {
        let zi = Complex64::from_polar(1.0, -2.0 * PI * f / FS); // z^-1
        let num = self.b[0] + self.b[1] * zi + self.b[2] * zi * zi;
        let den = 1.0 + self.a[0] * zi + self.a[1] * zi * zi;
        zi.powu(self.delay as u32) * num / den
    }
}

/// Magnitude error in dB and phase error in degrees (wrapped to ±180) of `estimate`
/// against `exact`.
pub fn errors(estimate: Complex64, exact: Complex64) -> (f64, f64) {
    let ratio = estimate / exact;
    (20.0 * ratio.norm().log10(), ratio.arg().to_degrees())
}

/// A file name in the system's temporary directory, unique to this process.
pub fn temp_path(name: &str) -> std::path::PathBuf {
    std::env::temp_dir().join(format!("mil-identify-test-{}-{name}", std::process::id()))
}
