//! One open-loop run of the real-time controller step over a road input.

use crate::config::{Config, Validated};
use anyhow::Result;
use mil_rig::experiment::PreparedSubstructure;
use model_core::{Controller, Mode, Model, ModelInput, PreparedParams, Status};
use serde::Serialize;
use std::io::Write;
use std::path::Path;

/// Statistics of one channel's demand over a run.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct ChannelSummary {
    /// Channel index.
    pub channel: usize,
    /// Mean demand (N).
    pub mean: f64,
    /// Standard deviation of the demand (N).
    pub std: f64,
    /// Smallest demand (N).
    pub min: f64,
    /// Largest demand (N).
    pub max: f64,
    /// Samples in which the amplitude limit acted.
    pub amplitude_limited_samples: usize,
    /// Samples in which the rate limit acted.
    pub rate_limited_samples: usize,
}

/// Summary of a run (printed as a table, or as JSON with `--json`).
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Summary {
    /// Model kind.
    pub model: String,
    /// Number of channels.
    pub channels: usize,
    /// Control rate (Hz).
    pub sample_rate_hz: f64,
    /// Samples run.
    pub samples: usize,
    /// Per-channel statistics.
    pub channel: Vec<ChannelSummary>,
    /// Time of the first fault (s), if any.
    pub fault_at_s: Option<f64>,
    /// Fault flags at the end of the run.
    pub fault_flags: u8,
    /// Host wall-clock throughput (steps per second), informational only.
    pub host_steps_per_s: f64,
}

/// The time histories and summary of a run.
#[derive(Clone, Debug)]
pub struct RunOutput {
    /// Sample times (s).
    pub time: Vec<f64>,
    /// Road input per sample and channel (m).
    pub road: Vec<Vec<f64>>,
    /// Vehicle speed per sample (m/s), for the aero model.
    pub speed: Option<Vec<f64>>,
    /// Demand per sample and channel (N).
    pub demand: Vec<Vec<f64>>,
    /// Status per sample.
    pub status: Vec<Status>,
    /// Summary.
    pub summary: Summary,
}

/// Runs the configuration; `progress` is called with the fraction done from time to time.
pub fn run(config: &Config, mut progress: impl FnMut(f64)) -> Result<RunOutput> {
    let validated = config.validate()?;
    let n = config.samples();
    let fs = config.run.sample_rate_hz;
    let road = config
        .input
        .generate(n, fs, config.channels(), &config.base)?;
    let started = std::time::Instant::now();
    let mut speed = None;
    // Measured positions and forces of a rigid rig: zero (the aero model takes the road as
    // its body position).
    fn road_input<const CH: usize>(_: usize, z: &[f64]) -> ModelInput<CH> {
        ModelInput {
            road: to_array(z),
            ..ModelInput::default()
        }
    }
    let (demand, status) = match validated {
        Validated::Tyre(p) => drive(*p, &road, road_input, &mut progress),
        Validated::Aero(p, profile) => {
            let v = profile.samples(n, fs);
            let out = drive(
                *p,
                &road,
                |k, z| ModelInput {
                    position: to_array(z),
                    speed: v[k] as f32,
                    ..ModelInput::default()
                },
                &mut progress,
            );
            speed = Some(v);
            out
        }
        Validated::Substructure(PreparedSubstructure::One(p)) => {
            drive(*p, &road, road_input, &mut progress)
        }
        Validated::Substructure(PreparedSubstructure::Two(p)) => {
            drive(*p, &road, road_input, &mut progress)
        }
        Validated::Substructure(PreparedSubstructure::Three(p)) => {
            drive(*p, &road, road_input, &mut progress)
        }
        Validated::Substructure(PreparedSubstructure::Four(p)) => {
            drive(*p, &road, road_input, &mut progress)
        }
    };
    let elapsed = started.elapsed().as_secs_f64().max(1e-9);
    let time: Vec<f64> = (0..n).map(|k| k as f64 / fs).collect();
    let channels = config.channels();
    let channel = (0..channels)
        .map(|ch| {
            let v: Vec<f64> = demand.iter().map(|d| d[ch]).collect();
            let mean = v.iter().sum::<f64>() / n.max(1) as f64;
            let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n.max(1) as f64;
            let bit = 1u8 << ch;
            ChannelSummary {
                channel: ch,
                mean,
                std: var.sqrt(),
                min: v.iter().copied().fold(f64::INFINITY, f64::min),
                max: v.iter().copied().fold(f64::NEG_INFINITY, f64::max),
                amplitude_limited_samples: status
                    .iter()
                    .filter(|s| s.amplitude_limited & bit != 0)
                    .count(),
                rate_limited_samples: status.iter().filter(|s| s.rate_limited & bit != 0).count(),
            }
        })
        .collect();
    let fault_at_s = status
        .iter()
        .position(|s| s.mode == Mode::Fault)
        .map(|k| k as f64 / fs);
    let summary = Summary {
        model: format!("{:?}", config.model.kind).to_lowercase(),
        channels,
        sample_rate_hz: fs,
        samples: n,
        channel,
        fault_at_s,
        fault_flags: status.last().map(|s| s.fault).unwrap_or(0),
        host_steps_per_s: n as f64 / elapsed,
    };
    Ok(RunOutput {
        time,
        road,
        speed,
        demand,
        status,
        summary,
    })
}

/// The first `CH` values of `v` as f32 (zeros where `v` is shorter): a controller input
/// field from host doubles.
pub(crate) fn to_array<const CH: usize>(v: &[f64]) -> [f32; CH] {
    let mut a = [0.0; CH];
    for (o, x) in a.iter_mut().zip(v) {
        *o = *x as f32;
    }
    a
}

fn drive<M: Model<CH>, const CH: usize>(
    prepared: PreparedParams<M, CH>,
    road: &[Vec<f64>],
    input: impl Fn(usize, &[f64]) -> ModelInput<CH>,
    progress: &mut impl FnMut(f64),
) -> (Vec<Vec<f64>>, Vec<Status>) {
    let mut controller = Controller::new(prepared);
    controller.start();
    let n = road.len();
    let mut demand = Vec::with_capacity(n);
    let mut status = Vec::with_capacity(n);
    for (k, z) in road.iter().enumerate() {
        let d = controller.step(&input(k, z));
        demand.push(d.iter().map(|v| f64::from(*v)).collect());
        status.push(controller.status());
        if k % 4096 == 0 {
            progress(k as f64 / n as f64);
        }
    }
    progress(1.0);
    (demand, status)
}

impl RunOutput {
    /// Writes the time histories as CSV: `time` (s), `road_<ch>` (m), `speed` (m/s, aero
    /// model only), `demand_<ch>` (N), `mode`, `amplitude_limited`, `rate_limited` (bit
    /// masks).
    pub fn write_csv(&self, path: &Path) -> Result<()> {
        // Whole or not at all: an interrupted run leaves no truncated file.
        crate::cli::write_atomic(path, |w| {
            let ch = self.summary.channels;
            // Every column with its unit (SI); the status columns have none.
            let mut header = vec!["time [s]".to_string()];
            header.extend((0..ch).map(|c| format!("road_{c} [m]")));
            if self.speed.is_some() {
                header.push("speed [m/s]".into());
            }
            header.extend((0..ch).map(|c| format!("demand_{c} [N]")));
            header.extend(["mode", "amplitude_limited", "rate_limited"].map(String::from));
            writeln!(w, "{}", header.join(","))?;
            for (k, (((t, z), d), s)) in self
                .time
                .iter()
                .zip(&self.road)
                .zip(&self.demand)
                .zip(&self.status)
                .enumerate()
            {
                write!(w, "{t:.6}")?;
                for v in z {
                    write!(w, ",{v:.9e}")?;
                }
                if let Some(v) = &self.speed {
                    write!(w, ",{:.6}", v[k])?;
                }
                for v in d {
                    write!(w, ",{v:.6e}")?;
                }
                writeln!(
                    w,
                    ",{},{},{}",
                    s.mode as u8, s.amplitude_limited, s.rate_limited
                )?;
            }
            Ok(())
        })
    }

    /// The summary as a human-readable table.
    pub fn table(&self) -> String {
        let s = &self.summary;
        let mut out = format!(
            "model {} | {} channels | {:.0} Hz | {} samples ({:.1} s)\n",
            s.model,
            s.channels,
            s.sample_rate_hz,
            s.samples,
            s.samples as f64 / s.sample_rate_hz
        );
        out += "channel     mean [N]      std [N]      min [N]      max [N]  amp-limited  rate-limited\n";
        for c in &s.channel {
            out += &format!(
                "{:>7} {:>12.1} {:>12.1} {:>12.1} {:>12.1} {:>12} {:>13}\n",
                c.channel,
                c.mean,
                c.std,
                c.min,
                c.max,
                c.amplitude_limited_samples,
                c.rate_limited_samples
            );
        }
        out += &fault_line(s.fault_at_s, s.fault_flags);
        out += &format!(
            "host throughput: {:.2e} steps/s (informational)\n",
            s.host_steps_per_s
        );
        out
    }
}

/// The controller's fault causes (model-core's `fault` bits), in words.
pub fn fault_causes(flags: u8) -> String {
    use model_core::fault::{INVALID_INPUT, NUMERICAL};
    let mut causes = Vec::new();
    if flags & INVALID_INPUT != 0 {
        causes.push(
            "invalid input: a measurement non-finite or beyond the model's range (a road or \
             position given in mm instead of m?)",
        );
    }
    if flags & NUMERICAL != 0 {
        causes.push("numerical: a non-finite value inside the model or the command filter");
    }
    if flags & !(INVALID_INPUT | NUMERICAL) != 0 || causes.is_empty() {
        causes.push("another cause");
    }
    format!("{} (flags {flags:#04x})", causes.join("; "))
}

/// The summary's fault line: none, or when and why (the demand then ramps to the safe one).
pub fn fault_line(fault_at_s: Option<f64>, flags: u8) -> String {
    match fault_at_s {
        Some(t) => format!(
            "FAULT at {t:.4} s: {}; the demand ramps to the safe demand from there\n",
            fault_causes(flags)
        ),
        None => "no fault\n".to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::setup::{SetUp, DEFAULT_SETUP};

    #[test]
    fn tyre_run_matches_the_spring_damper_law() {
        let pink = "road = { kind = \"pink\", rms_m = 0.0005, max_hz = 40.0, seed = 1 }";
        assert!(DEFAULT_SETUP.contains(pink));
        let sweep =
            "road = { kind = \"sweep\", amplitude_m = 0.004, start_hz = 0.5, end_hz = 30.0 }";
        let text = DEFAULT_SETUP.replace(pink, sweep);
        let c = SetUp::from_toml(
            &text,
            &Path::new(env!("CARGO_MANIFEST_DIR")).join("examples"),
        )
        .unwrap()
        .run()
        .unwrap();
        let out = run(&c, |_| {}).unwrap();
        assert_eq!(out.summary.samples, 40_000);
        assert!(out.summary.fault_at_s.is_none());
        // Rigid rig: force = static + k z + c ż (velocity low-passed); at the sweep's low-
        // frequency part (t ≈ 2 s, f ≈ 0.6 Hz) the damping term is negligible (< 1 %).
        let k = 4000;
        let expected = 1667.7 + 2.5e5 * out.road[k][0];
        assert!(
            (out.demand[k][0] - expected).abs() < 0.01 * 2.5e5 * 0.004,
            "{} vs {expected}",
            out.demand[k][0]
        );
        // Mean demand is the static load: the sweep has zero mean.
        let mean = out.summary.channel[0].mean;
        assert!((mean - 1667.7).abs() < 20.0, "mean {mean}");
    }
}
