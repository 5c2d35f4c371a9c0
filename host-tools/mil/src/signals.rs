//! Road (ground) input signals: sine sweep, pink noise, bump, and recorded CSV profiles;
//! and the vehicle speed over a run (constant, ramp, step, recorded CSV). All in SI units
//! (m, m/s, s, Hz).

use anyhow::{bail, Context, Result};
use serde::Deserialize;
use std::path::Path;

/// A road input, as written in a set-up's `[excitation] road`.
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
        /// RMS displacement (m) over the road's first 20 s ([`PINK_REFERENCE_S`]): runs of
        /// every duration drive the same road.
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
        /// Path of the CSV file, relative to the set-up file.
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
                    bail!("excitation.road.amplitude_m must be in [0, 1) m, got {amplitude_m}");
                }
                if !(*start_hz > 0.0 && end_hz > start_hz && *end_hz < nyquist) {
                    bail!("excitation.road (sweep) needs 0 < start_hz < end_hz < {nyquist} Hz (Nyquist)");
                }
            }
            RoadInput::Pink { rms_m, max_hz, .. } => {
                if !(rms_m.is_finite() && *rms_m >= 0.0 && *rms_m < 1.0) {
                    bail!("excitation.road.rms_m must be in [0, 1) m, got {rms_m}");
                }
                if !(*max_hz > 0.0 && *max_hz < nyquist) {
                    bail!("excitation.road.max_hz must be in (0, {nyquist}) Hz");
                }
            }
            RoadInput::Bump {
                height_m,
                duration_s,
                at_s,
            } => {
                if !(height_m.is_finite() && height_m.abs() < 1.0) {
                    bail!("excitation.road.height_m must be finite and below 1 m");
                }
                if !(*duration_s > 0.0 && at_s.is_finite() && *at_s >= 0.0) {
                    bail!("excitation.road (bump) needs duration_s > 0 and at_s >= 0");
                }
            }
            RoadInput::Csv { path } => {
                if path.is_empty() {
                    bail!("excitation.road.path is empty");
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

use mil_numerics::rng::SplitMix64;

/// The stretch of a pink road its `rms_m` holds over (s): the road is one road whatever the
/// run's duration (a shorter run drives its start, a longer one drives on), scaled so that
/// its first 20 s, faded in and out as a 20 s run is, have the RMS asked for.
pub const PINK_REFERENCE_S: f64 = 20.0;

/// Pink noise: white Gaussian noise through Paul Kellet's 1/f filter, a second-order
/// Butterworth low-pass at `max_hz` (bilinear), a 0.2 Hz high-pass to remove drift, scaled so
/// that its first [`PINK_REFERENCE_S`] (tapered as a run of that length) have RMS `rms`, and
/// tapered at both ends of the run. The same `seed` gives the same road for every `n`: two
/// runs of different lengths agree up to the shorter one's end fade.
pub fn pink(n: usize, dt: f64, rms: f64, max_hz: f64, seed: u64) -> Vec<f64> {
    let reference = (PINK_REFERENCE_S / dt).round().max(1.0) as usize;
    let mut rng = SplitMix64::new(seed);
    let mut b = [0.0f64; 7];
    let mut raw: Vec<f64> = (0..n.max(reference))
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
    // The scale from the reference stretch, faded as a run of its length.
    let faded = |x: &[f64], k: usize, count: usize| {
        let duration = count as f64 * dt;
        x[k] * taper(k as f64 * dt, duration, 0.5f64.min(duration / 4.0))
    };
    let current = ((0..reference)
        .map(|k| faded(&raw, k, reference).powi(2))
        .sum::<f64>()
        / reference as f64)
        .sqrt();
    raw.truncate(n);
    let mut road: Vec<f64> = (0..n).map(|k| faded(&raw, k, n)).collect();
    if current > 0.0 {
        road.iter_mut().for_each(|v| *v *= rms / current);
    }
    road
}

fn butterworth_lowpass(x: &mut [f64], fc: f64, dt: f64) {
    let s = mil_numerics::filter::butterworth2(fc * dt);
    mil_numerics::filter::run_section(&s, x.iter_mut(), 0.0);
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

/// The table in `path` (the workspace's one reader, `mil_numerics::record`) with `time`
/// first (in s, where the header gives a unit); `what` names the file in errors.
fn read_timed_table(path: &Path, what: &str) -> Result<mil_numerics::record::Table> {
    let table = mil_numerics::record::read(path).with_context(|| format!("cannot read {what}"))?;
    if let Err(why) = table.require_time_first() {
        bail!("{}: {why}", path.display());
    }
    Ok(table)
}

/// Reads a recorded road profile: `time` (s) and 1 or `channels` road columns (m), a uniform
/// time base (`mil_numerics::record::uniform_time_base`: timing jitter up to 0.4 of a
/// sample passes) starting at 0 with the run's sample period (within 1 %), finite values.
/// Shorter records are an error; rows beyond the run's `n` are ignored.
pub fn read_profile(path: &Path, n: usize, dt: f64, channels: usize) -> Result<Vec<Vec<f64>>> {
    let table = read_timed_table(path, "road profile")?;
    let name = path.display();
    let columns = table.names.len() - 1;
    if columns != 1 && columns != channels {
        bail!("{name}: expected 1 or {channels} road columns, found {columns}");
    }
    let rows = table.rows();
    if rows < n {
        bail!("{name}: {rows} samples, the run needs {n}");
    }
    let base = table
        .time_base()
        .map_err(|(line, e)| anyhow::anyhow!("{name}: line {line}: {e}"))?;
    // 1 %: the interval of a short record with timing jitter is only known to about
    // jitter / samples; a wrong rate is off by far more.
    if (base.dt - dt).abs() > 1e-2 * dt {
        bail!(
            "{name}: sample interval {} s, the run's is {dt} s (uniform at the run's sample rate)",
            base.dt
        );
    }
    if base.t0.abs() > mil_numerics::record::JITTER_TOLERANCE * dt {
        bail!("{name}: time starts at {} s, not 0", base.t0);
    }
    Ok((0..n)
        .map(|k| {
            let road: Vec<f64> = table.columns[1..].iter().map(|c| c[k]).collect();
            if road.len() == 1 {
                vec![road[0]; channels]
            } else {
                road
            }
        })
        .collect())
}

/// Largest vehicle speed (m/s) a run may ask for: model-core's aero input limit
/// ([`model_core::aero::AERO_MAX_SPEED`]).
pub const MAX_SPEED_M_PER_S: f64 = model_core::aero::AERO_MAX_SPEED as f64;

/// A vehicle speed over the run (the aero model's `v`), as written in `speed` of
/// a set-up's `[excitation]`; `excitation.speed_m_per_s` is the shorthand for a constant speed. Every
/// speed must be finite and in `[0, MAX_SPEED_M_PER_S]` m/s. The board reads the speed at
/// each control sample; the emulated aero model follows the same samples, ramped linearly
/// between them.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum SpeedInput {
    /// A constant speed.
    Constant {
        /// Speed (m/s).
        speed_m_per_s: f64,
    },
    /// A linear ramp: `from_m_per_s` until `at_s`, then linearly to `to_m_per_s` over
    /// `duration_s`, then held.
    Ramp {
        /// Speed before the ramp (m/s).
        from_m_per_s: f64,
        /// Speed after the ramp (m/s).
        to_m_per_s: f64,
        /// Start of the ramp (s).
        at_s: f64,
        /// Length of the ramp (s), > 0.
        duration_s: f64,
    },
    /// A step: `from_m_per_s` before `at_s`, `to_m_per_s` from `at_s` on (the first control
    /// sample at or after `at_s` has the new speed).
    Step {
        /// Speed before the step (m/s).
        from_m_per_s: f64,
        /// Speed from the step on (m/s).
        to_m_per_s: f64,
        /// Time of the step (s).
        at_s: f64,
    },
    /// A recorded speed: CSV with a header, `time` (s) first, strictly increasing (any
    /// spacing, e.g. a 10 Hz log), and a speed column (m/s); linearly interpolated between
    /// rows. The rows must cover the run (first time at most 0 s, last at least the last
    /// sample's time).
    Csv {
        /// Path of the CSV file, relative to the set-up file.
        path: String,
        /// Header of the speed column; none: the file must have exactly one column after
        /// `time`.
        #[serde(default)]
        column: Option<String>,
    },
}

/// A validated speed over a run (see [`SpeedInput`]), evaluated at any time.
#[derive(Clone, Debug, PartialEq)]
pub enum SpeedProfile {
    /// Constant speed (m/s).
    Constant(f64),
    /// `(from, to, at, duration)`: m/s, m/s, s, s (a step has duration 0).
    Ramp(f64, f64, f64, f64),
    /// Breakpoints: times (s, strictly increasing) and speeds (m/s), interpolated linearly.
    Table(Vec<f64>, Vec<f64>),
}

impl SpeedInput {
    /// Checks the parameters and reads a recorded profile (relative to `base`); `end_s` is
    /// the time of the run's last sample (s), which a recorded profile must reach.
    ///
    /// # Errors
    /// A speed that is not finite or outside `[0, MAX_SPEED_M_PER_S]` m/s, a bad ramp or step
    /// time, or a recorded profile that cannot be read, is not numeric, not strictly
    /// increasing in time, or does not cover the run; the message names the row.
    pub fn profile(&self, base: &Path, end_s: f64) -> Result<SpeedProfile> {
        let speed = |name: &str, v: f64| -> Result<f64> {
            if !(v.is_finite() && (0.0..=MAX_SPEED_M_PER_S).contains(&v)) {
                bail!("excitation.speed.{name} must be in [0, {MAX_SPEED_M_PER_S}] m/s, got {v}");
            }
            Ok(v)
        };
        let time = |name: &str, v: f64| -> Result<f64> {
            if !(v.is_finite() && v >= 0.0) {
                bail!("excitation.speed.{name} must be >= 0 s, got {v}");
            }
            Ok(v)
        };
        Ok(match self {
            SpeedInput::Constant { speed_m_per_s } => {
                SpeedProfile::Constant(speed("speed_m_per_s", *speed_m_per_s)?)
            }
            SpeedInput::Ramp {
                from_m_per_s,
                to_m_per_s,
                at_s,
                duration_s,
            } => {
                if !(duration_s.is_finite() && *duration_s > 0.0) {
                    bail!("excitation.speed.duration_s must be > 0 s (a step is kind = \"step\"), got {duration_s}");
                }
                SpeedProfile::Ramp(
                    speed("from_m_per_s", *from_m_per_s)?,
                    speed("to_m_per_s", *to_m_per_s)?,
                    time("at_s", *at_s)?,
                    *duration_s,
                )
            }
            SpeedInput::Step {
                from_m_per_s,
                to_m_per_s,
                at_s,
            } => SpeedProfile::Ramp(
                speed("from_m_per_s", *from_m_per_s)?,
                speed("to_m_per_s", *to_m_per_s)?,
                time("at_s", *at_s)?,
                0.0,
            ),
            SpeedInput::Csv { path, column } => {
                if path.is_empty() {
                    bail!("excitation.speed.path is empty");
                }
                let (t, v) = read_speed_profile(&base.join(path), column.as_deref(), end_s)?;
                SpeedProfile::Table(t, v)
            }
        })
    }
}

impl SpeedProfile {
    /// Speed (m/s) at time `t_s` (s).
    pub fn at(&self, t_s: f64) -> f64 {
        match self {
            SpeedProfile::Constant(v) => *v,
            SpeedProfile::Ramp(from, to, at, duration) => {
                if t_s < *at {
                    *from
                } else if t_s >= at + duration {
                    *to
                } else {
                    from + (to - from) * (t_s - at) / duration
                }
            }
            SpeedProfile::Table(time, speed) => {
                let i = time.partition_point(|x| *x <= t_s);
                match (i.checked_sub(1), time.get(i)) {
                    (None, _) => speed.first().copied().unwrap_or(0.0),
                    (Some(j), None) => speed[j],
                    (Some(j), Some(t1)) => {
                        let f = (t_s - time[j]) / (t1 - time[j]);
                        speed[j] + f * (speed[i] - speed[j])
                    }
                }
            }
        }
    }

    /// The speed (m/s) at each of `n` control samples at `sample_rate_hz` (Hz).
    pub fn samples(&self, n: usize, sample_rate_hz: f64) -> Vec<f64> {
        (0..n).map(|k| self.at(k as f64 / sample_rate_hz)).collect()
    }
}

/// Reads a recorded speed profile (see [`SpeedInput::Csv`]): times (s) and speeds (m/s).
///
/// # Errors
/// See [`SpeedInput::profile`].
pub fn read_speed_profile(
    path: &Path,
    column: Option<&str>,
    end_s: f64,
) -> Result<(Vec<f64>, Vec<f64>)> {
    let table = read_timed_table(path, "speed profile")?;
    let name = path.display();
    let index = match column {
        Some(c) => table
            .index(c)
            .filter(|&i| i > 0)
            .with_context(|| format!("{name}: no column {c:?} (excitation.speed.column)"))?,
        None if table.names.len() == 2 => 1,
        None => bail!(
            "{name}: {} columns after `time`: name the speed column with excitation.speed.column",
            table.names.len().saturating_sub(1)
        ),
    };
    let time = table.columns[0].clone();
    let speed = table.columns[index].clone();
    for (k, (w, &v)) in time.windows(2).zip(speed.iter().skip(1)).enumerate() {
        let line = k + 3;
        if w[1] <= w[0] {
            bail!(
                "{name}: line {line}: time {} s does not increase (previous row {} s)",
                w[1],
                w[0]
            );
        }
        if !(0.0..=MAX_SPEED_M_PER_S).contains(&v) {
            bail!("{name}: line {line}: speed {v} m/s is outside [0, {MAX_SPEED_M_PER_S}] m/s");
        }
    }
    if let Some(&v) = speed.first() {
        if !(0.0..=MAX_SPEED_M_PER_S).contains(&v) {
            bail!("{name}: line 2: speed {v} m/s is outside [0, {MAX_SPEED_M_PER_S}] m/s");
        }
    }
    match (time.first(), time.last()) {
        (Some(first), Some(last)) if *first <= 1e-9 && *last >= end_s - 1e-9 => {}
        (Some(first), Some(last)) => {
            bail!("{name}: covers {first} to {last} s, the run needs 0 to {end_s} s")
        }
        _ => bail!("{name}: no rows"),
    }
    Ok((time, speed))
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
        // 20 s at 5 kHz: the reference stretch, RMS as asked for.
        let a = pink(100_000, 2e-4, 0.001, 50.0, 7);
        let b = pink(100_000, 2e-4, 0.001, 50.0, 7);
        let c = pink(100_000, 2e-4, 0.001, 50.0, 8);
        assert_eq!(a, b);
        assert_ne!(a, c);
        let rms = (a.iter().map(|v| v * v).sum::<f64>() / a.len() as f64).sqrt();
        assert!((rms - 0.001).abs() < 1e-9);
    }

    #[test]
    fn a_pink_road_is_one_road_whatever_the_run_s_duration() {
        let dt = 5e-4;
        let long = pink(120_000, dt, 5e-4, 40.0, 1);
        for seconds in [3.0, 5.0, 20.0, 45.0] {
            let n = (seconds / dt) as usize;
            let short = pink(n, dt, 5e-4, 40.0, 1);
            assert_eq!(short.len(), n);
            // Equal between the fade-in and the shorter run's fade-out (0.5 s each).
            let (from, to) = ((0.5 / dt) as usize, n - (0.5 / dt) as usize);
            for k in from..to {
                assert!(
                    (short[k] - long[k]).abs() <= 1e-12 * 5e-4,
                    "{seconds} s, sample {k}: {} vs {}",
                    short[k],
                    long[k]
                );
            }
            // Faded in and out: at rest at both ends.
            assert_eq!(short[0], 0.0);
            assert!(
                short[n - 1].abs() < 1e-3 * 5e-4,
                "{seconds} s: {}",
                short[n - 1]
            );
        }
        // The same road at any rate the run asks for is scaled alike (20 s RMS as asked).
        let at_2k = pink(40_000, dt, 5e-4, 40.0, 1);
        let rms = (at_2k.iter().map(|v| v * v).sum::<f64>() / at_2k.len() as f64).sqrt();
        assert!((rms - 5e-4).abs() < 1e-12, "{rms}");
    }

    #[test]
    fn speed_profiles_ramp_step_and_interpolate() {
        let base = Path::new(".");
        let ramp = SpeedInput::Ramp {
            from_m_per_s: 20.0,
            to_m_per_s: 40.0,
            at_s: 1.0,
            duration_s: 2.0,
        }
        .profile(base, 5.0)
        .unwrap();
        let at = |p: &SpeedProfile, t: f64| p.at(t);
        assert_eq!(
            [0.0, 1.0, 1.5, 3.0, 9.0].map(|t| at(&ramp, t)),
            [20.0, 20.0, 25.0, 40.0, 40.0]
        );
        let step = SpeedInput::Step {
            from_m_per_s: 30.0,
            to_m_per_s: 10.0,
            at_s: 0.5,
        }
        .profile(base, 5.0)
        .unwrap();
        assert_eq!(step.samples(3, 4.0), [30.0, 30.0, 10.0]);
        let table = SpeedProfile::Table(vec![0.0, 1.0, 3.0], vec![10.0, 20.0, 0.0]);
        assert_eq!(
            [0.0, 0.5, 1.0, 2.0, 3.0, 4.0].map(|t| at(&table, t)),
            [10.0, 15.0, 20.0, 10.0, 0.0, 0.0]
        );
        let e = SpeedInput::Constant {
            speed_m_per_s: f64::NAN,
        }
        .profile(base, 1.0)
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("speed.speed_m_per_s must be in [0, 150] m/s"),
            "{e}"
        );
    }

    /// Road profiles as DAQ exports write them read; a wrong rate, a dropped sample and a time
    /// column in ms are refused, naming the file and the line or the unit.
    #[test]
    fn road_profiles_from_daq_exports() {
        let dir = tempfile::tempdir().unwrap();
        let write = |name: &str, text: &str| {
            let p = dir.path().join(name);
            std::fs::write(&p, text).unwrap();
            p
        };
        let dt = 5e-4;
        let mut daq = String::from("# exported 2026-11-29\ntime [s];road [m]\n");
        for k in 0..200 {
            let jitter = if k % 2 == 0 { 0.1 } else { -0.1 };
            let t = (k as f64 + jitter) * dt;
            daq.push_str(&format!("{t:.6};{}\n", 0.001 * k as f64).replace('.', ","));
        }
        let road = read_profile(&write("daq.csv", &daq), 150, dt, 2).unwrap();
        assert_eq!(road.len(), 150);
        assert_eq!(road[10], vec![0.01, 0.01]);
        let e = read_profile(&write("daq.csv", &daq), 150, 4e-4, 2).unwrap_err();
        assert!(format!("{e:#}").contains("sample interval"), "{e:#}");
        let mut dropped = String::from("time,road\n");
        for k in (0..200).filter(|&k| k != 100) {
            dropped.push_str(&format!("{},0\n", k as f64 * dt));
        }
        let e = format!(
            "{:#}",
            read_profile(&write("gap.csv", &dropped), 150, dt, 1).unwrap_err()
        );
        assert!(
            e.contains("gap.csv: line") && e.contains("dropped or repeated"),
            "{e}"
        );
        let ms = daq.replace("time [s]", "time [ms]");
        let e = format!(
            "{:#}",
            read_profile(&write("ms.csv", &ms), 150, dt, 1).unwrap_err()
        );
        assert!(e.contains("\"ms\""), "{e}");
    }
}
