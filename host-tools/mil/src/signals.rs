//! Road (ground) input signals: sine sweep, pink noise, bump, and recorded CSV profiles.
//! All in SI units (m, s, Hz).

use anyhow::{bail, Context, Result};
use serde::Deserialize;
use std::path::Path;

/// A road input description, as written in the `[input]` table of a run configuration.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum RoadInput {
    /// Logarithmic sine sweep of constant displacement amplitude.
    Sweep {
        /// Displacement amplitude (m).
        amplitude_m: f64,
        /// Start frequency (Hz).
        start_hz: f64,
        /// End frequency (Hz).
        end_hz: f64,
    },
    /// Pink (1/f power) noise, band-limited to `max_hz`, scaled to an RMS displacement.
    Pink {
        /// RMS displacement (m).
        rms_m: f64,
        /// Upper band edge (Hz).
        max_hz: f64,
        /// Seed of the deterministic generator.
        seed: u64,
    },
    /// A single (1 - cos) bump of the given height and length in time, starting at `at_s`.
    Bump {
        /// Bump height (m).
        height_m: f64,
        /// Bump duration (s).
        duration_s: f64,
        /// Start time (s).
        at_s: f64,
    },
    /// A recorded profile: CSV with a header, `time` (s, uniform) first, then one road column
    /// per channel (m), or a single column applied to every channel.
    Csv {
        /// Path of the CSV file, relative to the configuration file.
        path: String,
    },
}

impl RoadInput {
    /// Checks the parameters (finite, positive where needed, sweep below Nyquist).
    pub fn validate(&self, sample_rate_hz: f64) -> Result<()> {
        let nyquist = sample_rate_hz / 2.0;
        match self {
            RoadInput::Sweep {
                amplitude_m,
                start_hz,
                end_hz,
            } => {
                if !(amplitude_m.is_finite() && *amplitude_m >= 0.0 && *amplitude_m < 1.0) {
                    bail!("input.amplitude_m must be in [0, 1) m, got {amplitude_m}");
                }
                if !(*start_hz > 0.0 && end_hz > start_hz && *end_hz < nyquist) {
                    bail!("input sweep needs 0 < start_hz < end_hz < {nyquist} Hz (Nyquist)");
                }
            }
            RoadInput::Pink { rms_m, max_hz, .. } => {
                if !(rms_m.is_finite() && *rms_m >= 0.0 && *rms_m < 1.0) {
                    bail!("input.rms_m must be in [0, 1) m, got {rms_m}");
                }
                if !(*max_hz > 0.0 && *max_hz < nyquist) {
                    bail!("input.max_hz must be in (0, {nyquist}) Hz");
                }
            }
            RoadInput::Bump {
                height_m,
                duration_s,
                at_s,
            } => {
                if !(height_m.is_finite() && height_m.abs() < 1.0) {
                    bail!("input.height_m must be finite and below 1 m");
                }
                if !(*duration_s > 0.0 && at_s.is_finite() && *at_s >= 0.0) {
                    bail!("input bump needs duration_s > 0 and at_s >= 0");
                }
            }
            RoadInput::Csv { path } => {
                if path.is_empty() {
                    bail!("input.path is empty");
                }
            }
        }
        Ok(())
    }

    /// Generates `n` samples at `sample_rate_hz` for `channels` channels, `[sample][channel]`.
    /// `base` is the folder relative paths are resolved against.
    pub fn generate(
        &self,
        n: usize,
        sample_rate_hz: f64,
        channels: usize,
        base: &Path,
    ) -> Result<Vec<Vec<f64>>> {
        let dt = 1.0 / sample_rate_hz;
        let single: Vec<f64> = match self {
            RoadInput::Sweep {
                amplitude_m,
                start_hz,
                end_hz,
            } => sweep(n, dt, *amplitude_m, *start_hz, *end_hz),
            RoadInput::Pink {
                rms_m,
                max_hz,
                seed,
            } => pink(n, dt, *rms_m, *max_hz, *seed),
            RoadInput::Bump {
                height_m,
                duration_s,
                at_s,
            } => (0..n)
                .map(|k| {
                    let t = k as f64 * dt - at_s;
                    if (0.0..=*duration_s).contains(&t) {
                        0.5 * height_m * (1.0 - (2.0 * std::f64::consts::PI * t / duration_s).cos())
                    } else {
                        0.0
                    }
                })
                .collect(),
            RoadInput::Csv { path } => {
                return read_profile(&base.join(path), n, dt, channels);
            }
        };
        Ok(single.into_iter().map(|z| vec![z; channels]).collect())
    }
}

/// Logarithmic sweep from `f0` to `f1` over `n` samples, amplitude `a`, with 0.5 s cosine
/// fade-in and fade-out so the road starts and ends at rest.
pub fn sweep(n: usize, dt: f64, a: f64, f0: f64, f1: f64) -> Vec<f64> {
    let duration = n as f64 * dt;
    let rate = (f1 / f0).ln() / duration;
    let fade = 0.5f64.min(duration / 4.0);
    (0..n)
        .map(|k| {
            let t = k as f64 * dt;
            // Phase of a log sweep: 2π f0 (e^{rate t} - 1)/rate.
            let phase = 2.0 * std::f64::consts::PI * f0 * ((rate * t).exp() - 1.0) / rate;
            let w = taper(t, duration, fade);
            a * w * phase.sin()
        })
        .collect()
}

fn taper(t: f64, duration: f64, fade: f64) -> f64 {
    let edge = |x: f64| {
        if x >= fade {
            1.0
        } else {
            0.5 * (1.0 - (std::f64::consts::PI * x / fade).cos())
        }
    };
    edge(t) * edge(duration - t)
}

/// The deterministic generator behind every noise source (reproducible from a seed).
pub use mil_rig::rng::SplitMix64;

/// Pink noise: white Gaussian noise through Paul Kellet's 1/f filter, a second-order
/// Butterworth low-pass at `max_hz` (bilinear), a 0.2 Hz high-pass to remove drift, scaled to
/// `rms` and tapered at both ends.
pub fn pink(n: usize, dt: f64, rms: f64, max_hz: f64, seed: u64) -> Vec<f64> {
    let mut rng = SplitMix64::new(seed);
    let mut b = [0.0f64; 7];
    let mut raw: Vec<f64> = (0..n)
        .map(|_| {
            let w = rng.normal();
            b[0] = 0.99886 * b[0] + w * 0.0555179;
            b[1] = 0.99332 * b[1] + w * 0.0750759;
            b[2] = 0.96900 * b[2] + w * 0.1538520;
            b[3] = 0.86650 * b[3] + w * 0.3104856;
            b[4] = 0.55000 * b[4] + w * 0.5329522;
            b[5] = -0.7616 * b[5] - w * 0.0168980;
            let y = b[0] + b[1] + b[2] + b[3] + b[4] + b[5] + b[6] + w * 0.5362;
            b[6] = w * 0.115926;
            y
        })
        .collect();
    butterworth_lowpass(&mut raw, max_hz, dt);
    highpass(&mut raw, 0.2, dt);
    let duration = n as f64 * dt;
    let fade = 0.5f64.min(duration / 4.0);
    for (k, v) in raw.iter_mut().enumerate() {
        *v *= taper(k as f64 * dt, duration, fade);
    }
    let current = (raw.iter().map(|v| v * v).sum::<f64>() / n.max(1) as f64).sqrt();
    if current > 0.0 {
        raw.iter_mut().for_each(|v| *v *= rms / current);
    }
    raw
}

fn butterworth_lowpass(x: &mut [f64], fc: f64, dt: f64) {
    let k = (std::f64::consts::PI * fc * dt).tan();
    let q = std::f64::consts::FRAC_1_SQRT_2;
    let norm = 1.0 / (1.0 + k / q + k * k);
    let b0 = k * k * norm;
    let (b1, b2) = (2.0 * b0, b0);
    let a1 = 2.0 * (k * k - 1.0) * norm;
    let a2 = (1.0 - k / q + k * k) * norm;
    let (mut s1, mut s2) = (0.0, 0.0);
    for v in x.iter_mut() {
        let y = b0 * *v + s1;
        s1 = b1 * *v - a1 * y + s2;
        s2 = b2 * *v - a2 * y;
        *v = y;
    }
}

fn highpass(x: &mut [f64], fc: f64, dt: f64) {
    let a = (-2.0 * std::f64::consts::PI * fc * dt).exp();
    let (mut last_in, mut last_out) = (0.0, 0.0);
    for v in x.iter_mut() {
        let y = a * (last_out + *v - last_in);
        last_in = *v;
        last_out = y;
        *v = y;
    }
}

/// Reads a recorded road profile; checks the header, a uniform `time` column matching the
/// sample period (within 1e-6 relative), and finite values. Shorter records are an error.
pub fn read_profile(path: &Path, n: usize, dt: f64, channels: usize) -> Result<Vec<Vec<f64>>> {
    let mut reader = csv::Reader::from_path(path)
        .with_context(|| format!("cannot open road profile {}", path.display()))?;
    let header = reader.headers()?.clone();
    if header.get(0).map(str::trim) != Some("time") {
        bail!("{}: the first column must be `time`", path.display());
    }
    let columns = header.len() - 1;
    if columns != 1 && columns != channels {
        bail!(
            "{}: expected 1 or {channels} road columns, found {columns}",
            path.display()
        );
    }
    let mut out = Vec::with_capacity(n);
    for (row, record) in reader.records().enumerate() {
        if out.len() == n {
            break;
        }
        let record = record?;
        let values: Vec<f64> = record
            .iter()
            .map(|v| v.trim().parse::<f64>())
            .collect::<Result<_, _>>()
            .with_context(|| format!("{}: row {} is not numeric", path.display(), row + 2))?;
        let t = values.first().copied().unwrap_or(f64::NAN);
        let expected = row as f64 * dt;
        if (t - expected).abs() > 1e-6 * expected.max(1.0) + 1e-9 {
            bail!(
                "{}: row {}: time {t} s, expected {expected} s (uniform at the run's sample rate)",
                path.display(),
                row + 2
            );
        }
        let road: Vec<f64> = values.get(1..).unwrap_or(&[]).to_vec();
        if road.iter().any(|v| !v.is_finite()) {
            bail!("{}: row {}: non-finite value", path.display(), row + 2);
        }
        out.push(if road.len() == 1 {
            vec![road[0]; channels]
        } else {
            road
        });
    }
    if out.len() < n {
        bail!(
            "{}: {} samples, the run needs {n}",
            path.display(),
            out.len()
        );
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sweep_has_amplitude_and_starts_at_rest() {
        let s = sweep(50_000, 2e-4, 0.002, 0.5, 30.0);
        assert_eq!(s[0], 0.0);
        let peak = s.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        assert!((peak - 0.002).abs() < 1e-5, "peak {peak}");
    }

    #[test]
    fn pink_noise_is_scaled_and_reproducible() {
        let a = pink(20_000, 2e-4, 0.001, 50.0, 7);
        let b = pink(20_000, 2e-4, 0.001, 50.0, 7);
        let c = pink(20_000, 2e-4, 0.001, 50.0, 8);
        assert_eq!(a, b);
        assert_ne!(a, c);
        let rms = (a.iter().map(|v| v * v).sum::<f64>() / a.len() as f64).sqrt();
        assert!((rms - 0.001).abs() < 1e-9);
    }
}
