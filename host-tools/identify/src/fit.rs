//! A low-order model with delay fitted to a measured tracking response ([`LowOrderFit`]):
//! what extends a table beyond the band it was measured over (`mil_analysis::measured`,
//! which also reads the actuator's bandwidth and equivalent delay from the table).
//!
//! ## Models
//! The tracking response of a force- or position-controlled servo-hydraulic actuator is a
//! low-pass with a delay. Three candidates, each `K · G(s) · e^{-sτ}`:
//!
//! ```text
//! order 1   G = ω₁ / (s + ω₁)
//! order 2   G = ω_n² / (s² + 2ζω_n s + ω_n²)
//! order 3   G = ω_n² ω₁ / ((s² + 2ζω_n s + ω_n²)(s + ω₁))
//! ```
//!
//! and orders 2 and 3 with a real zero `(s/ω_z + 1)` in the numerator (the integral action
//! of a force loop leaves one at low frequency).
//!
//! ## Fit
//! Each candidate minimises the weighted squared complex log error
//! `Σ w_i |ln(M(f_i) / H_i)|²` (the log magnitude in nepers and the phase in radians on one
//! footing), so the fit does not depend on the response's scale or units. The weight of a
//! point is `γ²/(1 − γ²)` (`γ²` its coherence, capped at 0.999; 1 without coherence), the
//! inverse of the H1 estimate's relative variance. On a table evenly spaced in frequency
//! (as `mil identify` writes it) this weighs the upper octaves most: the fit is made for
//! the response around and above the bandwidth, where a table is extended, rather than for
//! its low-frequency detail, which the table itself carries. The minimisation is
//! Nelder–Mead in logarithmic parameters (positive by construction), restarted until it no
//! longer improves. The order is chosen by the Bayesian information criterion
//! `N ln(cost) + k ln N` (`k` parameters, `N` points): a higher order must earn its
//! parameters.
//!
//! The fit error reported is the RMS magnitude (dB) and phase (°) difference between the
//! model and the table's points.

use crate::table::FrfTable;
use mil_numerics::optimise::nelder_mead;
use num_complex::Complex64;
use std::f64::consts::TAU;

/// A low-order model with delay fitted to a table (see the module documentation).
#[derive(Clone, Debug, PartialEq)]
pub struct LowOrderFit {
    /// 1, 2 or 3 (the poles of `G`).
    pub order: usize,
    /// Static gain `K` (the response's units).
    pub gain: f64,
    /// Natural frequency of the second-order factor (Hz), orders 2 and 3.
    pub natural_frequency_hz: Option<f64>,
    /// Damping ratio of the second-order factor, orders 2 and 3.
    pub damping_ratio: Option<f64>,
    /// Corner frequency of the first-order factor (Hz), orders 1 and 3.
    pub corner_frequency_hz: Option<f64>,
    /// Frequency of the zero `(s/ω_z + 1)` (Hz), if the model has one (a force loop's
    /// integral action leaves one).
    pub zero_frequency_hz: Option<f64>,
    /// Pure delay `τ` (s).
    pub delay_s: f64,
    /// RMS magnitude difference over the table's points (dB).
    pub rms_db: f64,
    /// RMS phase difference over the table's points (degrees).
    pub rms_deg: f64,
}

/// Largest coherence used in the weights (a perfect point would otherwise take all).
const COHERENCE_CAP: f64 = 0.999;

/// A candidate's structure: its poles (1, 2 or 3) and whether it has a zero.
#[derive(Clone, Copy, Debug)]
struct Shape {
    order: usize,
    zero: bool,
}

/// The parameters of a candidate: `K`, the second-order factor `(ω_n, ζ)`, the first-order
/// pole `ω₁`, the zero `ω_z` (rad/s) and the delay `τ` (s).
type Parts = (f64, Option<(f64, f64)>, Option<f64>, Option<f64>, f64);

impl Shape {
    fn parameters(self) -> usize {
        let poles = match self.order {
            1 => 1,
            2 => 2,
            _ => 3,
        };
        2 + poles + usize::from(self.zero)
    }

    /// The parts from the fit's coordinates `[ln K, (ln ω_n, ln ζ), (ln ω₁), (ln ω_z),
    /// √(τ / 1 ms)]`, as the shape uses them.
    fn decode(self, x: &[f64]) -> Parts {
        let k = x[0].exp();
        let tau = 1e-3 * x[x.len() - 1] * x[x.len() - 1];
        let zero = self.zero.then(|| x[x.len() - 2].exp());
        match self.order {
            1 => (k, None, Some(x[1].exp()), zero, tau),
            2 => (k, Some((x[1].exp(), x[2].exp())), None, zero, tau),
            _ => (
                k,
                Some((x[1].exp(), x[2].exp())),
                Some(x[3].exp()),
                zero,
                tau,
            ),
        }
    }
}

/// `ln M(jω)` with a continuous phase: the log magnitude and the phase (radians) of
/// `K G(jω) e^{-jωτ}`.
fn log_model(parts: Parts, w: f64) -> Complex64 {
    let (k, second, first, zero, tau) = parts;
    let mut out = Complex64::new(k.ln(), -w * tau);
    if let Some((wn, zeta)) = second {
        let re = wn * wn - w * w;
        let im = 2.0 * zeta * wn * w;
        // The phase of ω_n² / (re + j im) runs continuously from 0 to −π.
        out += Complex64::new(
            (wn * wn).ln() - 0.5 * (re * re + im * im).ln(),
            -im.atan2(re),
        );
    }
    if let Some(w1) = first {
        out += Complex64::new(-0.5 * (1.0 + (w / w1).powi(2)).ln(), -(w / w1).atan());
    }
    if let Some(wz) = zero {
        out += Complex64::new(0.5 * (1.0 + (w / wz).powi(2)).ln(), (w / wz).atan());
    }
    out
}

impl LowOrderFit {
    /// Fits the three candidates to `table` and keeps the one the information criterion
    /// prefers. None if the table has fewer points than a first-order model's parameters
    /// or a zero magnitude.
    pub fn fit(table: &FrfTable) -> Option<Self> {
        let points = table.points();
        if points.len() < 4 || points.iter().any(|p| p.magnitude <= 0.0) {
            return None;
        }
        let data: Vec<(f64, Complex64, f64)> = points
            .iter()
            .map(|p| {
                let g = p.coherence.unwrap_or(0.5).min(COHERENCE_CAP);
                (
                    TAU * p.frequency_hz,
                    Complex64::new(p.magnitude.ln(), p.phase_deg.to_radians()),
                    g / (1.0 - g),
                )
            })
            .collect();
        let total: f64 = data.iter().map(|d| d.2).sum();
        let n = data.len() as f64;
        // Start: the static gain from the lowest point; the second-order factor where the
        // phase reaches −90° (the top of the table if it does not); no delay.
        let k0 = points[0].magnitude;
        let w90 = points
            .iter()
            .find(|p| p.phase_deg <= points[0].phase_deg - 90.0)
            .map_or(TAU * points[points.len() - 1].frequency_hz, |p| {
                TAU * p.frequency_hz
            });
        let mut best: Option<(f64, Self)> = None;
        for (order, zero) in [(1, false), (2, false), (3, false), (2, true), (3, true)] {
            let shape = Shape { order, zero };
            let cost = |x: &[f64]| -> f64 {
                let parts = shape.decode(x);
                let mut sum = 0.0;
                for &(w, h, weight) in &data {
                    sum += weight * (log_model(parts, w) - h).norm_sqr();
                }
                if sum.is_finite() {
                    sum / total
                } else {
                    f64::INFINITY
                }
            };
            let mut x = match order {
                1 => vec![k0.ln(), (0.5 * w90).ln()],
                2 => vec![k0.ln(), w90.ln(), 0.7f64.ln()],
                _ => vec![k0.ln(), w90.ln(), 0.7f64.ln(), (2.0 * w90).ln()],
            };
            if zero {
                x.push((0.5 * w90).ln());
            }
            x.push(0.5);
            let mut value = cost(&x);
            for _ in 0..12 {
                let step: Vec<f64> = x.iter().map(|_| 0.3).collect();
                let next = nelder_mead(cost, &x, &step, 200 * (x.len() + 1));
                let v = cost(&next);
                let improved = v < value * (1.0 - 1e-6);
                if v < value {
                    (x, value) = (next, v);
                }
                if !improved {
                    break;
                }
            }
            if !value.is_finite() {
                continue;
            }
            // The cost is floored at (1e-4)² (0.001 dB, 0.006°): below it candidates are equally
            // good and the criterion's parameter count decides.
            let criterion = n * value.max(1e-8).ln() + shape.parameters() as f64 * n.ln();
            if best.as_ref().is_none_or(|(c, _)| criterion < *c) {
                best = Some((criterion, Self::from_parts(order, shape.decode(&x), table)));
            }
        }
        best.map(|(_, fit)| fit)
    }

    fn from_parts(order: usize, parts: Parts, table: &FrfTable) -> Self {
        let (gain, second, first, zero, delay_s) = parts;
        let mut fit = Self {
            order,
            gain,
            natural_frequency_hz: second.map(|(wn, _)| wn / TAU),
            damping_ratio: second.map(|(_, z)| z),
            corner_frequency_hz: first.map(|w1| w1 / TAU),
            zero_frequency_hz: zero.map(|wz| wz / TAU),
            delay_s,
            rms_db: 0.0,
            rms_deg: 0.0,
        };
        let points = table.points();
        let (mut sum_db, mut sum_deg) = (0.0, 0.0);
        for p in points {
            let d = fit.log_response(p.frequency_hz)
                - Complex64::new(p.magnitude.ln(), p.phase_deg.to_radians());
            let (db, deg) = (d.re * 20.0 / std::f64::consts::LN_10, d.im.to_degrees());
            sum_db += db * db;
            sum_deg += deg * deg;
        }
        fit.rms_db = (sum_db / points.len() as f64).sqrt();
        fit.rms_deg = (sum_deg / points.len() as f64).sqrt();
        fit
    }

    fn second(&self) -> Option<(f64, f64)> {
        Some((TAU * self.natural_frequency_hz?, self.damping_ratio?))
    }

    fn first(&self) -> Option<f64> {
        Some(TAU * self.corner_frequency_hz?)
    }

    fn zero(&self) -> Option<f64> {
        Some(TAU * self.zero_frequency_hz?)
    }

    /// `ln` of the model's response at `frequency_hz` (Hz), its phase continuous from 0.
    pub fn log_response(&self, frequency_hz: f64) -> Complex64 {
        log_model(
            (
                self.gain,
                self.second(),
                self.first(),
                self.zero(),
                self.delay_s,
            ),
            TAU * frequency_hz,
        )
    }

    /// The model's response at `frequency_hz` (Hz).
    pub fn response(&self, frequency_hz: f64) -> Complex64 {
        self.log_response(frequency_hz).exp()
    }

    /// The rational part `K G(s)` as numerator and denominator coefficients in descending
    /// powers of `s` (rad/s); the delay is [`LowOrderFit::delay_s`].
    pub fn rational(&self) -> (Vec<f64>, Vec<f64>) {
        let mut num = self.gain;
        let mut den = vec![1.0];
        if let Some((wn, z)) = self.second() {
            num *= wn * wn;
            den = vec![1.0, 2.0 * z * wn, wn * wn];
        }
        if let Some(w1) = self.first() {
            num *= w1;
            den = [den.as_slice(), &[0.0]]
                .concat()
                .iter()
                .zip([&[0.0], den.as_slice()].concat())
                .map(|(a, b)| a + w1 * b)
                .collect();
        }
        let num = match self.zero() {
            Some(wz) => vec![num / wz, num],
            None => vec![num],
        };
        (num, den)
    }

    /// One line: the model and its figures.
    pub fn describe(&self) -> String {
        let mut out = format!("order {}", self.order);
        if let (Some(f), Some(z)) = (self.natural_frequency_hz, self.damping_ratio) {
            out.push_str(&format!(", {f:.1} Hz, damping {z:.2}"));
        }
        if let Some(f) = self.corner_frequency_hz {
            out.push_str(&format!(", corner {f:.1} Hz"));
        }
        if let Some(f) = self.zero_frequency_hz {
            out.push_str(&format!(", zero {f:.1} Hz"));
        }
        out.push_str(&format!(", delay {:.2} ms", self.delay_s * 1e3));
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::table::FrfPoint;

    /// A table of `h` at `n` evenly spaced frequencies up to `top` Hz.
    fn table(h: impl Fn(f64) -> Complex64, n: usize, top: f64) -> FrfTable {
        FrfTable::new(
            (1..=n)
                .map(|i| {
                    let f = top * i as f64 / n as f64;
                    let v = h(f);
                    FrfPoint {
                        frequency_hz: f,
                        magnitude: v.norm(),
                        phase_deg: v.arg().to_degrees(),
                        coherence: Some(0.99),
                    }
                })
                .collect(),
        )
        .unwrap()
    }

    #[test]
    fn a_second_order_with_delay_is_recovered_in_any_units() {
        for scale in [1.0, 1e-3, 250.0] {
            let h = |f: f64| {
                let s = Complex64::new(0.0, TAU * f);
                let wn = TAU * 60.0;
                scale * wn * wn / (s * s + 2.0 * 0.5 * wn * s + wn * wn) * (-s * 0.8e-3).exp()
            };
            let fit = LowOrderFit::fit(&table(h, 300, 150.0)).unwrap();
            assert_eq!(fit.order, 2, "{fit:?}");
            assert!((fit.gain / scale - 1.0).abs() < 1e-3, "{fit:?}");
            assert!(
                (fit.natural_frequency_hz.unwrap() - 60.0).abs() < 0.1,
                "{fit:?}"
            );
            assert!((fit.delay_s - 0.8e-3).abs() < 2e-5, "{fit:?}");
            assert!(fit.rms_db < 0.01 && fit.rms_deg < 0.1, "{fit:?}");
            let (num, den) = fit.rational();
            let s = Complex64::new(0.0, TAU * 40.0);
            let r = num[0] / (den[0] * s * s + den[1] * s + den[2]) * (-s * fit.delay_s).exp();
            assert!((r / fit.response(40.0) - 1.0).norm() < 1e-9);
        }
    }

    #[test]
    fn a_first_order_lag_is_not_given_more_poles() {
        let h = |f: f64| 1.0 / Complex64::new(1.0, f / 20.0);
        let fit = LowOrderFit::fit(&table(h, 200, 100.0)).unwrap();
        assert_eq!(fit.order, 1, "{fit:?}");
        assert!(
            (fit.corner_frequency_hz.unwrap() - 20.0).abs() < 0.05,
            "{fit:?}"
        );
        assert!(fit.rms_db < 0.01 && fit.rms_deg < 0.1, "{fit:?}");
        let (num, den) = fit.rational();
        assert_eq!(den.len(), 2);
        let s = Complex64::new(0.0, TAU * 7.0);
        let r = num[0] / (den[0] * s + den[1]);
        assert!((r / fit.response(7.0) - 1.0).norm() < 1e-9);
    }

    #[test]
    fn third_order_rational_matches_the_response() {
        let fit = LowOrderFit {
            order: 3,
            gain: 2.0,
            natural_frequency_hz: Some(50.0),
            damping_ratio: Some(0.3),
            corner_frequency_hz: Some(80.0),
            zero_frequency_hz: Some(20.0),
            delay_s: 0.0,
            rms_db: 0.0,
            rms_deg: 0.0,
        };
        let (num, den) = fit.rational();
        let s = Complex64::new(0.0, TAU * 33.0);
        let d = ((den[0] * s + den[1]) * s + den[2]) * s + den[3];
        let n = num[0] * s + num[1];
        assert!((n / d / fit.response(33.0) - 1.0).norm() < 1e-9);
    }
}
