//! A measured tracking table made usable at every frequency the analysis asks for: inside
//! the measured band the table itself, outside it the low-order model with delay fitted to
//! the table ([`mil_identify::LowOrderFit`]), joined without a step.
//!
//! ## The extension
//! `H(f) = M(f) · e^{c(f)}` with `M` the fitted model and `c = ln(H_table / M)` the table's
//! correction to it:
//! - at the table's points `c` is the table's own value, so `H` is the table there;
//! - between points (also across coherence gaps, where `mil identify` dropped points)
//!   `c` is interpolated linearly in `log f`: the gap follows the model's shape, not a
//!   straight line between its edges;
//! - below the band `c` keeps its value at the table's lowest frequency: the response there
//!   is the model's shape on the measured level (the refusal rules below make the lowest
//!   frequency at most a tenth of the bandwidth, where a tracking response is flat);
//! - above the band `c` fades from its edge value to 0 over one octave: the response
//!   continues without a step and becomes the model's.
//!
//! Off the imaginary axis (the stability contour runs at `σ = 2π · 1 mHz`) the model is
//! evaluated at `s` and the correction at `|ω|`.
//!
//! ## When the table is refused
//! The model outside the band is only as good as the table that fixed it:
//! - the table must reach the actuator's −3 dB bandwidth (its gain must fall 3 dB below
//!   its gain at its lowest frequency: above the table, a model that has not seen the
//!   roll-off would be a guess), and start at a tenth of it (the static gain measured);
//! - over the table's top octave, where the extension starts, the model must follow the
//!   table to [`EDGE_RMS_DB`] and [`EDGE_RMS_DEG`].
//!
//! The refusal names the band needed and the commands that measure it.

use crate::error::{setup_error, Result};
use crate::poly::Rational;
use mil_identify::{FrfTable, LowOrderFit};
use num_complex::Complex64;
use std::f64::consts::TAU;

/// Largest RMS magnitude difference (dB) between the fitted model and the table over the
/// table's top octave.
pub const EDGE_RMS_DB: f64 = 1.5;
/// Largest RMS phase difference (degrees) between the fitted model and the table over the
/// table's top octave.
pub const EDGE_RMS_DEG: f64 = 10.0;

/// A measured tracking table with its fitted model (see the module documentation).
#[derive(Clone, Debug)]
pub struct MeasuredResponse {
    table: FrfTable,
    fit: LowOrderFit,
    rational: Rational,
    /// `(ln f, c)` at the table's points.
    correction: Vec<(f64, Complex64)>,
    /// The −3 dB bandwidth (Hz) and the phase lag there as a delay (s), found once.
    bandwidth: (f64, f64),
}

impl MeasuredResponse {
    /// Fits the model and checks that the table can be extended; `origin` names the table
    /// in messages.
    ///
    /// # Errors
    /// No model fits, the table does not reach the bandwidth or its tenth, or the model
    /// does not follow the table's top octave: the message names the band needed.
    pub fn new(table: FrfTable, origin: &str) -> Result<Self> {
        let (lo, hi) = table.frequency_range();
        let fit = LowOrderFit::fit(&table).ok_or_else(|| {
            setup_error(format!(
                "actuator tracking table {origin}: no low-order model fits it (fewer than 4 \
                 points or a zero magnitude), so it cannot be extended beyond {lo:.3}-{hi:.1} Hz"
            ))
        })?;
        let how = |top: f64| {
            format!(
                "test the actuator over 0.5-{top:.0} Hz and identify that band: `mil \
                 actuator-test SETUP --band 0.5:{top:.0}` (on a rig: its sweep or noise test \
                 to {top:.0} Hz), then `mil identify ... --band 0.5:{top:.0}`"
            )
        };
        let (mut n, mut sum_db, mut sum_deg) = (0usize, 0.0, 0.0);
        let correction: Vec<(f64, Complex64)> = table
            .points()
            .iter()
            .map(|p| {
                let c = Complex64::new(p.magnitude.ln(), p.phase_deg.to_radians())
                    - fit.log_response(p.frequency_hz);
                if p.frequency_hz >= 0.5 * hi {
                    n += 1;
                    sum_db += (c.re * 20.0 / std::f64::consts::LN_10).powi(2);
                    sum_deg += c.im.to_degrees().powi(2);
                }
                (p.frequency_hz.ln(), c)
            })
            .collect();
        let (edge_db, edge_deg) = (
            (sum_db / n.max(1) as f64).sqrt(),
            (sum_deg / n.max(1) as f64).sqrt(),
        );
        if edge_db > EDGE_RMS_DB || edge_deg > EDGE_RMS_DEG {
            return Err(setup_error(format!(
                "actuator tracking table {origin}: the model fitted to it ({}) differs from its \
                 top octave {:.1}-{hi:.1} Hz by {edge_db:.2} dB / {edge_deg:.1} deg RMS (more \
                 than {EDGE_RMS_DB} dB / {EDGE_RMS_DEG} deg), so the response above {hi:.1} Hz \
                 cannot be extended from it; {}",
                fit.describe(),
                0.5 * hi,
                how(4.0 * hi)
            )));
        }
        let (num, den) = fit.rational();
        let rational = Rational::new(num, den)?;
        let mut measured = Self {
            table,
            fit,
            rational,
            correction,
            bandwidth: (f64::NAN, f64::NAN),
        };
        let Some(edge) = measured.band_edge() else {
            return Err(setup_error(format!(
                "actuator tracking table {origin} ends at {hi:.1} Hz before its gain falls 3 dB \
                 below its low-frequency gain: it does not reach the actuator's bandwidth, and \
                 the analysis extends a table beyond its band only from its measured roll-off; \
                 {}",
                how(4.0 * hi)
            )));
        };
        measured.bandwidth = edge;
        let bandwidth = edge.0;
        if lo > 0.1 * bandwidth {
            return Err(setup_error(format!(
                "actuator tracking table {origin} starts at {lo:.2} Hz, above a tenth of the \
                 actuator's bandwidth ({bandwidth:.0} Hz): its static gain is not measured; \
                 test from {:.2} Hz (`--band {:.2}:{hi:.0}`)",
                0.05 * bandwidth,
                0.05 * bandwidth
            )));
        }
        Ok(measured)
    }

    /// The fitted model.
    pub fn fit(&self) -> &LowOrderFit {
        &self.fit
    }

    /// The correction `c` at `frequency_hz` (see the module documentation).
    fn correction(&self, frequency_hz: f64) -> Complex64 {
        let x = frequency_hz.max(1e-12).ln();
        let c = &self.correction;
        let (first, last) = (c[0], c[c.len() - 1]);
        let fade = |edge: (f64, Complex64)| {
            let octaves = (x - edge.0).abs() / 2f64.ln();
            edge.1 * (1.0 - octaves).max(0.0)
        };
        if x <= first.0 {
            return first.1;
        }
        if x >= last.0 {
            return fade(last);
        }
        let i = c.partition_point(|p| p.0 < x).max(1);
        let (a, b) = (c[i - 1], c[i]);
        let u = (x - a.0) / (b.0 - a.0);
        a.1 + (b.1 - a.1) * u
    }

    /// The response at `frequency_hz` (Hz): the table inside its band, the model outside.
    pub fn response(&self, frequency_hz: f64) -> Complex64 {
        (self.fit.log_response(frequency_hz) + self.correction(frequency_hz)).exp()
    }

    /// The response at a complex `s` (rad/s), the correction taken at `|Im s|`.
    pub fn response_s(&self, s: Complex64) -> Complex64 {
        self.rational.response_s(s)
            * (-s * self.fit.delay_s).exp()
            * self.correction(s.im.abs() / TAU).exp()
    }

    /// The actuator's −3 dB bandwidth (Hz), read from the measured response (where its gain
    /// first falls 3 dB below its gain at the table's lowest frequency), and its phase lag
    /// there as a delay (s): the figures the engineer judges the actuator by, from the
    /// measurement rather than the model.
    pub fn bandwidth(&self) -> (f64, f64) {
        self.bandwidth
    }

    /// Where the response first falls 3 dB below its value at the table's lowest
    /// frequency, searched inside the table's band (on a grid of 1/200 decade, then by
    /// bisection; across a coherence gap the response follows the model's shape), with its
    /// phase lag there as a delay (s); none if it does not within the table.
    fn band_edge(&self) -> Option<(f64, f64)> {
        let (lo, hi) = self.table.frequency_range();
        let level = self.response(lo).norm() / 2f64.sqrt();
        let below = |f: f64| self.response(f).norm() < level;
        let step = 10f64.powf(1.0 / 200.0);
        let mut a = lo;
        let mut b = loop {
            let next = (a * step).min(hi);
            if below(next) {
                break next;
            }
            if next >= hi {
                return None;
            }
            a = next;
        };
        for _ in 0..50 {
            let mid = (a * b).sqrt();
            if below(mid) {
                b = mid;
            } else {
                a = mid;
            }
        }
        let phase = self.fit.log_response(b).im + self.correction(b).im;
        Some((b, -phase / (TAU * b)))
    }

    /// One line for reports.
    pub fn describe(&self) -> String {
        let (lo, hi) = self.table.frequency_range();
        format!(
            "measured table, {} points, {lo:.2}-{hi:.1} Hz: bandwidth {:.1} Hz, equivalent \
             delay {:.2} ms; extended by its fitted model ({}; {:.2} dB / {:.1} deg RMS)",
            self.table.points().len(),
            self.bandwidth.0,
            self.bandwidth.1 * 1e3,
            self.fit.describe(),
            self.fit.rms_db,
            self.fit.rms_deg
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mil_identify::FrfPoint;

    /// A second-order tracking response with delay (ζ 0.5, 60 Hz, 0.8 ms), tabled to 150 Hz:
    /// the bandwidth and the lag there are the exact response's, the table is reproduced at
    /// its points, and beyond it the response is the model's.
    #[test]
    fn the_bandwidth_and_delay_are_the_responses_and_the_table_is_kept() {
        let (wn, zeta, tau) = (TAU * 60.0, 0.5, 0.8e-3);
        let h = |f: f64| {
            let s = Complex64::new(0.0, TAU * f);
            wn * wn / (s * s + 2.0 * zeta * wn * s + wn * wn) * (-s * tau).exp()
        };
        let points = (1..=300)
            .map(|i| {
                let f = 0.5 * f64::from(i);
                let v = h(f);
                FrfPoint {
                    frequency_hz: f,
                    magnitude: v.norm(),
                    phase_deg: v.arg().to_degrees(),
                    coherence: Some(0.99),
                }
            })
            .collect();
        let table = FrfTable::new(points).unwrap();
        let m = MeasuredResponse::new(table.clone(), "test").unwrap();
        // −3 dB of ζ = 0.5 is at ω_n √(1 − 2ζ² + √(4ζ⁴ − 4ζ² + 2)) = 1.2720 ω_n.
        let (bw, delay) = m.bandwidth();
        let expected = 60.0
            * (1.0 - 2.0 * zeta * zeta + (4.0 * zeta.powi(4) - 4.0 * zeta * zeta + 2.0f64).sqrt())
                .sqrt();
        assert!((bw / expected - 1.0).abs() < 1e-3, "{bw} vs {expected}");
        let w = TAU * expected;
        let lag = (2.0 * zeta * wn * w).atan2(wn * wn - w * w) + w * tau;
        assert!((delay - lag / w).abs() < 2e-5, "{delay} vs {}", lag / w);
        for p in table.points().iter().step_by(37) {
            assert!((m.response(p.frequency_hz) / p.complex() - 1.0).norm() < 1e-9);
        }
        for f in [300.0, 1000.0, 5000.0] {
            assert!((m.response(f) / h(f) - 1.0).norm() < 1e-3, "{f} Hz");
        }
    }
}
