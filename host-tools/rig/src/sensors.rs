//! A measurement channel of the rig (displacement transducer or load cell), sampled at the
//! control rate.
//!
//! One sample goes through, in this order:
//!
//! ```text
//! true value ─▶ bandwidth (1st-order low-pass) ─▶ + offset ─▶ + noise ─▶ quantisation ─▶ measured
//! ```
//!
//! Every effect is off by default ([`SensorSpec::default`]), and an ideal channel passes
//! the true value through bit for bit.
//!
//! The bandwidth is a first-order low-pass `1/(τ s + 1)`, `τ = 1/(2π f_c)` (a second-order
//! conditioning filter is not modelled). It is discretised exactly for a true signal that is
//! linear between samples (the triangle-hold, or first-order-hold, equivalent): its pole is
//! the exact `a = e^{−2π f_c T}` for any `f_c` (no Nyquist limit), and unlike the zero-order-
//! hold (step-invariant) equivalent it adds no half-sample of lag to the continuous
//! transducer's phase:
//!
//! ```text
//! y[n] = a y[n−1] + b₀ u[n] + b₁ u[n−1],   b₀ = 1 − (1 − a)/r,   b₁ = (1 − a)/r − a,   r = 2π f_c T
//! ```
//!
//! Noise is white and Gaussian from a seeded [`SplitMix64`], so a run is reproducible.

use mil_numerics::rng::SplitMix64;
use serde::{Deserialize, Serialize};
use std::f64::consts::TAU;

/// The imperfections of one measurement channel, all off (ideal) by default. Units are the
/// measured quantity's: m for a displacement transducer, N for a load cell.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SensorSpec {
    /// White Gaussian noise RMS (m or N), added after the offset; 0: none.
    pub noise_rms: f64,
    /// Quantisation step, the LSB of the conditioning ADC (m or N); 0: none. Rounds to the
    /// nearest multiple, ties away from zero.
    pub quantum: f64,
    /// Bandwidth of the transducer and its conditioning (Hz): the corner frequency `f_c` of a
    /// first-order low-pass; 0: ideal (infinite bandwidth). Any finite value is allowed, also
    /// above Nyquist (the discretisation is exact).
    pub bandwidth_hz: f64,
    /// Constant offset added to the filtered value (m or N); may be negative.
    pub offset: f64,
}

/// An invalid [`SensorSpec`] or sample rate.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SensorError {
    /// A field has an invalid value.
    #[error("sensor: `{field}` must be {requirement} (is {value})")]
    Invalid {
        /// Name of the field (`noise_rms`, `quantum`, `bandwidth_hz`, `offset` or
        /// `sample_rate_hz`).
        field: &'static str,
        /// Its value (unit of the field).
        value: f64,
        /// What it must be.
        requirement: &'static str,
    },
}

impl SensorError {
    /// Name of the offending field.
    pub fn field(&self) -> &'static str {
        match self {
            Self::Invalid { field, .. } => field,
        }
    }
}

/// A measurement channel: the [`SensorSpec`] applied sample by sample at the control rate.
/// No allocation; `measure` costs a few multiplications (plus one normal draw with noise).
#[derive(Clone, Debug)]
pub struct Sensor {
    spec: SensorSpec,
    sample_rate_hz: f64,
    /// Low-pass coefficients (`a + b0 + b1 = 1`); `None`: ideal bandwidth.
    filter: Option<FirstOrderHold>,
    /// Previous filter output and input (true unit).
    y_prev: f64,
    u_prev: f64,
    rng: SplitMix64,
}

/// Triangle-hold equivalent of `1/(τ s + 1)`.
#[derive(Clone, Copy, Debug)]
struct FirstOrderHold {
    b0: f64,
    b1: f64,
}

impl FirstOrderHold {
    fn new(bandwidth_hz: f64, sample_rate_hz: f64) -> Self {
        let r = TAU * bandwidth_hz / sample_rate_hz; // T/τ
        let one_minus_a = -(-r).exp_m1();
        let b0 = 1.0 - one_minus_a / r;
        // b1 from the DC condition a + b0 + b1 = 1, so the steady state is exact.
        let b1 = one_minus_a - b0;
        Self { b0, b1 }
    }
}

fn check(
    field: &'static str,
    value: f64,
    ok: bool,
    requirement: &'static str,
) -> Result<(), SensorError> {
    if ok {
        Ok(())
    } else {
        Err(SensorError::Invalid {
            field,
            value,
            requirement,
        })
    }
}

fn finite_non_negative(field: &'static str, value: f64) -> Result<(), SensorError> {
    check(
        field,
        value,
        value.is_finite() && value >= 0.0,
        "finite and >= 0",
    )
}

impl Sensor {
    /// A channel with `spec`, sampled at `sample_rate_hz` (Hz), its noise drawn from `seed`.
    /// The filter starts at rest at 0 (see [`Sensor::reset`]).
    ///
    /// # Errors
    /// [`SensorError::Invalid`] naming the field: `noise_rms`, `quantum`, `bandwidth_hz` not
    /// finite and `>= 0`, `offset` not finite, `sample_rate_hz` not finite and `> 0`.
    pub fn new(spec: &SensorSpec, sample_rate_hz: f64, seed: u64) -> Result<Self, SensorError> {
        check(
            "sample_rate_hz",
            sample_rate_hz,
            sample_rate_hz.is_finite() && sample_rate_hz > 0.0,
            "finite and > 0",
        )?;
        finite_non_negative("noise_rms", spec.noise_rms)?;
        finite_non_negative("quantum", spec.quantum)?;
        finite_non_negative("bandwidth_hz", spec.bandwidth_hz)?;
        check("offset", spec.offset, spec.offset.is_finite(), "finite")?;
        let filter = (spec.bandwidth_hz > 0.0)
            .then(|| FirstOrderHold::new(spec.bandwidth_hz, sample_rate_hz));
        Ok(Self {
            spec: spec.clone(),
            sample_rate_hz,
            filter,
            y_prev: 0.0,
            u_prev: 0.0,
            rng: SplitMix64::new(seed),
        })
    }

    /// The channel's spec.
    pub fn spec(&self) -> &SensorSpec {
        &self.spec
    }

    /// The sample rate (Hz).
    pub fn sample_rate_hz(&self) -> f64 {
        self.sample_rate_hz
    }

    /// One sample: the true value (m or N) at this sample instant to the measured value (m or
    /// N). Order: bandwidth filter (on the true signal), + offset, + noise, then
    /// quantisation. Effects that are off are skipped, so an ideal channel returns
    /// `true_value` bit for bit (also `-0.0` and NaN). A NaN true value poisons the filter
    /// state until [`Sensor::reset`].
    pub fn measure(&mut self, true_value: f64) -> f64 {
        let mut y = match self.filter {
            Some(f) => {
                let y_prev = self.y_prev;
                // y = a y' + b0 u + b1 u', written so that a steady input is kept exactly.
                let y = y_prev + f.b0 * (true_value - y_prev) + f.b1 * (self.u_prev - y_prev);
                self.y_prev = y;
                self.u_prev = true_value;
                y
            }
            None => true_value,
        };
        if self.spec.offset != 0.0 {
            y += self.spec.offset;
        }
        if self.spec.noise_rms > 0.0 {
            y += self.spec.noise_rms * self.rng.normal();
        }
        if self.spec.quantum > 0.0 {
            y = (y / self.spec.quantum).round() * self.spec.quantum;
        }
        y
    }

    /// Sets the filter state to a steady true value (m or N, before the offset), as if the
    /// input had been `steady_value` forever, so a run that starts at a static load sees no
    /// start-up transient. The noise generator is not reset.
    pub fn reset(&mut self, steady_value: f64) {
        self.y_prev = steady_value;
        self.u_prev = steady_value;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const FS: f64 = 10_000.0;

    fn sensor(spec: SensorSpec, seed: u64) -> Sensor {
        Sensor::new(&spec, FS, seed).unwrap()
    }

    #[test]
    fn ideal_spec_passes_values_bit_exactly() {
        let mut s = sensor(SensorSpec::default(), 1);
        let values = [
            0.0,
            -0.0,
            1.0,
            -3.25e-7,
            1.234_567_890_123e5,
            f64::MIN_POSITIVE,
            f64::MAX,
            f64::INFINITY,
            f64::NAN,
        ];
        for _ in 0..3 {
            for &v in &values {
                assert_eq!(s.measure(v).to_bits(), v.to_bits(), "{v}");
            }
        }
    }

    #[test]
    fn offset_is_added() {
        let spec = SensorSpec {
            offset: -2.5,
            ..SensorSpec::default()
        };
        let mut s = sensor(spec, 1);
        assert_eq!(s.measure(10.0), 7.5);
    }

    fn noise_run(seed: u64, n: usize) -> Vec<f64> {
        let spec = SensorSpec {
            noise_rms: 0.3,
            ..SensorSpec::default()
        };
        let mut s = sensor(spec, seed);
        (0..n).map(|_| s.measure(5.0) - 5.0).collect()
    }

    #[test]
    fn noise_has_stated_rms_and_zero_mean() {
        let n = 100_000;
        let e = noise_run(42, n);
        let mean = e.iter().sum::<f64>() / n as f64;
        let rms = (e.iter().map(|x| x * x).sum::<f64>() / n as f64).sqrt();
        assert!((rms / 0.3 - 1.0).abs() < 0.03, "rms {rms}");
        // 4 standard errors of the mean.
        assert!(mean.abs() < 4.0 * 0.3 / (n as f64).sqrt(), "mean {mean}");
    }

    #[test]
    fn noise_is_reproducible_from_the_seed() {
        assert_eq!(noise_run(7, 1000), noise_run(7, 1000));
        assert_ne!(noise_run(7, 1000), noise_run(8, 1000));
    }

    #[test]
    fn quantisation_gives_multiples_of_the_quantum_within_half_a_step() {
        let q = 0.1;
        let spec = SensorSpec {
            quantum: q,
            ..SensorSpec::default()
        };
        let mut s = sensor(spec, 1);
        let mut rng = SplitMix64::new(3);
        for _ in 0..10_000 {
            let v = (rng.uniform() - 0.5) * 200.0;
            let y = s.measure(v);
            let k = y / q;
            assert!((k - k.round()).abs() < 1e-9, "{y} is not a multiple of {q}");
            assert!((y - v).abs() <= q / 2.0 * (1.0 + 1e-9), "{v} -> {y}");
        }
        assert_eq!(s.measure(0.26), 0.30000000000000004); // 3 * 0.1 in f64
        assert_eq!(s.measure(-0.24), -0.2);
    }

    #[test]
    fn quantisation_comes_after_offset_and_noise() {
        let spec = SensorSpec {
            noise_rms: 0.01,
            quantum: 1.0,
            offset: 0.4,
            ..SensorSpec::default()
        };
        let mut s = sensor(spec, 9);
        for _ in 0..1000 {
            let y = s.measure(2.0);
            assert_eq!(y, y.round());
            assert!((y - 2.4).abs() <= 0.5 + 0.1);
        }
    }

    #[test]
    fn step_response_reaches_63_percent_at_one_time_constant() {
        for tau_samples in [10.0, 100.0, 1000.0] {
            let fc = FS / (TAU * tau_samples);
            let spec = SensorSpec {
                bandwidth_hz: fc,
                ..SensorSpec::default()
            };
            let mut s = sensor(spec, 1);
            s.reset(0.0);
            let target = 1.0 - (-1.0f64).exp();
            let n = (0..10_000).position(|_| s.measure(1.0) >= target).unwrap() as f64;
            assert!((n - tau_samples).abs() <= 1.0, "τ = {tau_samples}: n = {n}");
            // Converges to the input exactly.
            for _ in 0..(40.0 * tau_samples) as usize {
                s.measure(1.0);
            }
            assert!((s.measure(1.0) - 1.0).abs() < 1e-12);
        }
    }

    /// Amplitude gain of the channel for a steady sine at `f` (Hz).
    fn sine_gain(bandwidth_hz: f64, f: f64) -> f64 {
        let spec = SensorSpec {
            bandwidth_hz,
            ..SensorSpec::default()
        };
        let mut s = sensor(spec, 1);
        let w = TAU * f / FS;
        // Settle for 50 time constants, then project over an integer number of periods.
        let settle = (50.0 * FS / (TAU * bandwidth_hz)) as usize;
        let period = FS / f;
        let n = (period * 20.0).round() as usize;
        let (mut c, mut si) = (0.0, 0.0);
        for k in 0..settle + n {
            let y = s.measure((w * k as f64).sin());
            if k >= settle {
                c += y * (w * k as f64).cos();
                si += y * (w * k as f64).sin();
            }
        }
        2.0 * (c * c + si * si).sqrt() / n as f64
    }

    #[test]
    fn sine_gain_at_the_bandwidth_is_minus_3_db() {
        for fc in [10.0, 100.0] {
            let g = sine_gain(fc, fc);
            assert!(
                (g * std::f64::consts::SQRT_2 - 1.0).abs() < 0.02,
                "fc {fc}: {g}"
            );
        }
        // Well below the corner the channel passes the signal.
        assert!((sine_gain(100.0, 1.0) - 1.0).abs() < 1e-3);
    }

    #[test]
    fn reset_avoids_the_start_up_transient() {
        let spec = SensorSpec {
            bandwidth_hz: 20.0,
            offset: 1.0,
            ..SensorSpec::default()
        };
        let mut s = sensor(spec, 1);
        s.reset(-5000.0);
        for _ in 0..100 {
            assert_eq!(s.measure(-5000.0), -4999.0);
        }
        // Without reset the filter starts at 0.
        let mut s = sensor(spec_with_bandwidth(20.0), 1);
        assert!(s.measure(-5000.0) > -100.0);
    }

    fn spec_with_bandwidth(bandwidth_hz: f64) -> SensorSpec {
        SensorSpec {
            bandwidth_hz,
            ..SensorSpec::default()
        }
    }

    #[test]
    fn bandwidth_above_nyquist_is_nearly_ideal() {
        let mut s = sensor(spec_with_bandwidth(1e6), 1);
        s.measure(0.0);
        let y = s.measure(1.0);
        assert!((y - 1.0).abs() < 0.01, "{y}");
    }

    #[test]
    fn invalid_specs_are_refused_naming_the_field() {
        let cases: [(SensorSpec, f64, &str); 8] = [
            (
                SensorSpec {
                    noise_rms: -1.0,
                    ..SensorSpec::default()
                },
                FS,
                "noise_rms",
            ),
            (
                SensorSpec {
                    noise_rms: f64::NAN,
                    ..SensorSpec::default()
                },
                FS,
                "noise_rms",
            ),
            (
                SensorSpec {
                    quantum: -0.1,
                    ..SensorSpec::default()
                },
                FS,
                "quantum",
            ),
            (
                SensorSpec {
                    quantum: f64::INFINITY,
                    ..SensorSpec::default()
                },
                FS,
                "quantum",
            ),
            (spec_with_bandwidth(-10.0), FS, "bandwidth_hz"),
            (
                SensorSpec {
                    offset: f64::NAN,
                    ..SensorSpec::default()
                },
                FS,
                "offset",
            ),
            (SensorSpec::default(), 0.0, "sample_rate_hz"),
            (SensorSpec::default(), f64::NAN, "sample_rate_hz"),
        ];
        for (spec, fs, field) in cases {
            let err = Sensor::new(&spec, fs, 1).unwrap_err();
            assert_eq!(err.field(), field);
            assert!(err.to_string().contains(field), "{err}");
        }
    }
}
