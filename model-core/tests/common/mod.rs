//! Helpers shared by the model-core integration tests.
#![allow(dead_code)]

use model_core::{BiquadCoefficients, CascadeCoefficients, DemandLimits, MAX_SECTIONS};

/// Exact (f64) response of a delta-form section at `q = e^{jωT} - 1`; returns (re, im).
pub fn section_response(c: &BiquadCoefficients, f_hz: f64, dt: f64) -> (f64, f64) {
    let w = 2.0 * std::f64::consts::PI * f_hz * dt;
    let q = (-2.0 * (w / 2.0).sin().powi(2), w.sin());
    let mul = |a: (f64, f64), b: (f64, f64)| (a.0 * b.0 - a.1 * b.1, a.0 * b.1 + a.1 * b.0);
    let q2 = mul(q, q);
    let (b0, b1, b2) = (c.beta0 as f64, c.beta1 as f64, c.beta2 as f64);
    let (a1, a2) = (c.alpha1 as f64, c.alpha2 as f64);
    let num = (b0 * q2.0 + b1 * q.0 + b2, b0 * q2.1 + b1 * q.1);
    let den = (q2.0 + a1 * q.0 + a2, q2.1 + a1 * q.1);
    let d2 = den.0 * den.0 + den.1 * den.1;
    (
        (num.0 * den.0 + num.1 * den.1) / d2,
        (num.1 * den.0 - num.0 * den.1) / d2,
    )
}

/// Impulse response of a cascade computed in f64 with the same recursion (independent of
/// model-core's f32 code), `n` samples.
pub fn impulse_response_f64(c: &CascadeCoefficients, n: usize) -> Vec<f64> {
    let mut states = [(0.0f64, 0.0f64); MAX_SECTIONS];
    (0..n)
        .map(|k| {
            let mut x = if k == 0 { 1.0 } else { 0.0 };
            for (s, sec) in states.iter_mut().zip(c.active()) {
                x = step_f64(sec, s, x);
            }
            x
        })
        .collect()
}

/// One f64 step of the delta-form recursion.
pub fn step_f64(c: &BiquadCoefficients, s: &mut (f64, f64), u: f64) -> f64 {
    let y = c.beta0 as f64 * u + s.0;
    s.0 += c.beta1 as f64 * u - c.alpha1 as f64 * y + s.1;
    s.1 += c.beta2 as f64 * u - c.alpha2 as f64 * y;
    y
}

/// Section from pole (radius, angle) pairs and zero (radius, angle) pairs, with gain `k`,
/// computed the accurate way: α from (1 - p) products.
pub fn section_from_polar(pole: (f64, f64), zero: (f64, f64), k: f64) -> BiquadCoefficients {
    // For a conjugate pair p, p̄: (1-p)+(1-p̄) = 2 - 2 r cos θ; (1-p)(1-p̄) = 1 - 2 r cos θ + r².
    let sum = |(r, th): (f64, f64)| 2.0 - 2.0 * r * th.cos();
    let prod = |(r, th): (f64, f64)| 1.0 - 2.0 * r * th.cos() + r * r;
    BiquadCoefficients {
        beta0: k as f32,
        beta1: (k * sum(zero)) as f32,
        beta2: (k * prod(zero)) as f32,
        alpha1: sum(pole) as f32,
        alpha2: prod(pole) as f32,
    }
}

/// Wide limits for tests that do not exercise limiting.
pub const WIDE: DemandLimits = DemandLimits {
    min: -1.0e6,
    max: 1.0e6,
    rate: 1.0e11,
};
