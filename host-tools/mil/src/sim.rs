//! `mil sim`: the board's controller step in closed loop with the simulated rig, the emulated
//! system (the real vehicle) alongside on the same road, and how close the two are.
//!
//! It runs a MiL set-up ([`crate::setup::SetUp::sim`]): the board's model, limits and
//! filter, the rig (the physical part, the actuators, sensors, links) and the excitation.
//! Outputs: the time histories (CSV, `time` first, SI units),
//! SVG plots, and a summary: per channel the error figures of MiL against emulated for the
//! interface force and position (J1 delay at the cross-correlation peak, J2 normalised RMS
//! error, J3 normalised peak error, see [`mil_rig::metrics`]), and the response estimated
//! from the run (H1, Hann-windowed Welch) against the emulated one and, with
//! and against the set-up's own analysis (`mil analyze`'s prediction).

use crate::config::{Config, ModelKind, Validated};
use anyhow::{anyhow, bail, Context, Result};
use mil_analysis::analyze::Signal;
use mil_analysis::response::CommandFilter;
use mil_analysis::setup::Setup;
use mil_analysis::Loop;
use mil_identify::{h1_estimate, FrfEstimate, Record, WelchOptions, Window};
use mil_numerics::filter::lowpass2_zero_phase;
use mil_params::ServoHydraulicActuator;
use mil_plots::{BodePlot, BodeSeries, SeriesStyle, XyPlot, XySeries};
use mil_rig::actuator::ForceActuator;
use mil_rig::experiment::{self, Experiment, Outcome, Setting};
use mil_rig::harness::{Histories, Instrumentation, LinkStatistics};
use mil_rig::metrics::{compare, Comparison};
use mil_structure::{EffectKind, Element};
use model_core::{Mode, Status};
use num_complex::Complex64;
use serde::Serialize;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Delay window of the J1 search (s).
pub const MAX_LAG_S: f64 = 0.05;

/// Error figures of one channel.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct ChannelErrors {
    /// Channel index.
    pub channel: usize,
    /// What the channel drives (e.g. "wheel 0 hub", "front axle").
    pub name: String,
    /// Interface force, MiL load cell against the emulated interface force (N).
    pub force: Comparison,
    /// The same within the comparison band: both low-passed at `[compare] f_max_hz`
    /// (zero phase), so sensor noise the loop amplifies above the band is left out.
    pub force_in_band: Comparison,
    /// Attachment position, MiL against emulated (m).
    pub position: Comparison,
    /// The same within the comparison band.
    pub position_in_band: Comparison,
    /// Smallest and largest demand (N).
    pub demand_range: [f64; 2],
}

/// One estimated response against its references over the comparison band: the worst
/// magnitude (dB) and phase (degrees) deviations.
#[derive(Clone, Copy, Debug, Serialize, PartialEq)]
pub struct Deviation {
    /// Worst |20 log10 |ratio|| (dB).
    pub db: f64,
    /// Worst |arg ratio| (degrees).
    pub deg: f64,
}

impl Deviation {
    /// The worst magnitude (dB) and phase (degrees) deviation of `a` from `b`, bin by bin;
    /// none without bins.
    pub fn worst(a: &[Complex64], b: &[Complex64]) -> Option<Self> {
        let mut d: Option<Self> = None;
        for (x, y) in a.iter().zip(b) {
            let r = x / y;
            let (db, deg) = ((20.0 * r.norm().log10()).abs(), r.arg().to_degrees().abs());
            let w = d.get_or_insert(Self { db: 0.0, deg: 0.0 });
            w.db = w.db.max(db);
            w.deg = w.deg.max(deg);
        }
        d
    }
}

/// The bins of two estimates on one frequency grid that lie in `band` (Hz) and where both
/// are finite and coherent (coherence of at least 0.9): where two responses are compared.
pub fn coherent_bins(a: &FrfEstimate, b: &FrfEstimate, band: (f64, f64)) -> Vec<usize> {
    (0..a.frequency_hz.len().min(b.frequency_hz.len()))
        .filter(|&k| {
            (band.0..=band.1).contains(&a.frequency_hz[k])
                && a.coherence[k] >= 0.9
                && b.coherence[k] >= 0.9
                && a.response[k].is_finite()
                && b.response[k].is_finite()
        })
        .collect()
}

/// The estimated response of the run and its comparisons.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct ResponseSummary {
    /// Which response (e.g. "interface force / road, channel 0").
    pub name: String,
    /// Comparison band (Hz).
    pub band_hz: [f64; 2],
    /// Frequency bins in the band with coherence of at least 0.9 in both estimates.
    pub bins: usize,
    /// MiL estimate against the emulated estimate.
    pub mil_vs_emulated: Option<Deviation>,
    /// MiL estimate against the analysis' MiL prediction.
    pub mil_vs_analysis: Option<Deviation>,
    /// Emulated estimate against the analysis' emulated prediction.
    pub emulated_vs_analysis: Option<Deviation>,
    /// The name of the set-up whose analysis the run is compared with.
    pub analysis: Option<String>,
    /// Why the comparison with the analysis set-up was left out, if it was (e.g. an aero
    /// run away from the set-up's reference speed).
    pub analysis_skipped: Option<String>,
}

/// Summary of a simulation (printed as a table, or as JSON with `--json`).
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct SimSummary {
    /// Model kind.
    pub model: String,
    /// Number of channels.
    pub channels: usize,
    /// Control rate (Hz).
    pub sample_rate_hz: f64,
    /// Samples run.
    pub samples: usize,
    /// RK4 step of the plants (s).
    pub internal_step_s: f64,
    /// Sections of the command filter (0: none).
    pub filter_sections: usize,
    /// Lowest and highest vehicle speed of the run (m/s), for the aero model.
    pub speed_m_per_s: Option<[f64; 2]>,
    /// Comparison band (Hz): the in-band figures and the response comparison.
    pub band_hz: [f64; 2],
    /// Start of the comparison (s): the figures leave out the run's start.
    pub settle_s: f64,
    /// Error figures per channel.
    pub channel: Vec<ChannelErrors>,
    /// The response estimated from the run.
    pub response: Option<ResponseSummary>,
    /// Time of the first fault (s), if any.
    pub fault_at_s: Option<f64>,
    /// Fault flags at the end of the run.
    pub fault_flags: u8,
    /// Frames sent, dropped and corrupted on the links.
    pub links: LinkStatistics,
    /// Simulated seconds per wall-clock second (informational).
    pub realtime_factor: f64,
}

/// Estimated and predicted responses, for the plot.
#[derive(Clone, Debug, Default)]
pub struct ResponseCurves {
    /// Title and axis label.
    pub name: String,
    /// Unit of the response.
    pub unit: String,
    /// Frequencies (Hz).
    pub frequency_hz: Vec<f64>,
    /// MiL estimate.
    pub mil: Vec<Complex64>,
    /// Emulated estimate.
    pub emulated: Vec<Complex64>,
    /// The comparison band (Hz) the plot covers: the estimates are drawn where coherent.
    pub band_hz: [f64; 2],
    /// The analysis' MiL and emulated predictions over the whole band.
    pub predicted: Option<PredictedCurves>,
}

/// The analysis' prediction of a run's response on a fine grid over the comparison band.
#[derive(Clone, Debug, Default)]
pub struct PredictedCurves {
    /// Frequencies (Hz).
    pub frequency_hz: Vec<f64>,
    /// MiL prediction.
    pub mil: Vec<Complex64>,
    /// Emulated prediction.
    pub emulated: Vec<Complex64>,
}

/// Result of a simulation.
pub struct SimOutput {
    /// Names of the road inputs, as in the CSV: the road (m) and, for the aero model, the
    /// speed (m/s) last.
    pub road_names: Vec<String>,
    /// Time histories.
    pub histories: Histories,
    /// Summary.
    pub summary: SimSummary,
    /// Response curves, when estimated.
    pub curves: Option<ResponseCurves>,
    /// The unit of each DOF history (`histories.mil_dofs`' order): `m` for a translation,
    /// `rad` for a rotation.
    pub dof_units: Vec<&'static str>,
}

/// The unit of each DOF history of a run of `config` (`mil_dofs`' order, each named
/// `<dof>_<first channel>`): `rad` for a rotation (the aero half car's pitch `theta_b`, a
/// structure's `kind = "rotation"` DOFs), else `m`.
fn dof_units(config: &Config, aero: bool, mil_dofs: &[(String, Vec<f64>)]) -> Vec<&'static str> {
    let rotations: Vec<String> = if aero {
        vec!["theta_b".into()]
    } else {
        config
            .rig
            .structure
            .as_ref()
            .and_then(|on_rig| mil_structure::Model::read(&config.base.join(&on_rig.file)).ok())
            .map(|m| {
                m.dofs
                    .iter()
                    .zip(&m.kinds)
                    .filter(|(_, k)| **k == mil_structure::model::DofKind::Rotation)
                    .map(|(d, _)| d.clone())
                    .collect()
            })
            .unwrap_or_default()
    };
    mil_dofs
        .iter()
        .map(|(name, _)| {
            let dof = name.rsplit_once('_').map_or(name.as_str(), |(d, _)| d);
            if rotations.iter().any(|r| r == dof) {
                "rad"
            } else {
                "m"
            }
        })
        .collect()
}

/// Everything [`simulate`] validates before it runs (what `mil check` runs on a set-up): the
/// board's parameters and the rig ([`Config::validate_sim`]), the integration step, the
/// comparison band and the analysis' prediction.
pub(crate) fn prepare(config: &Config) -> Result<(Validated, Option<Prediction>)> {
    let validated = config.validate_sim()?;
    let fs = config.run.sample_rate_hz;
    let step = config.rig.internal_step_s;
    if !(step.is_finite() && step > 0.0 && step <= 1.0 / fs) {
        bail!(
            "simulation.internal_step_s must be in (0, {}] s (the control period), got {step}",
            1.0 / fs
        );
    }
    let cmp = &config.compare;
    if !(cmp.f_min_hz > 0.0 && cmp.f_max_hz > cmp.f_min_hz && cmp.f_max_hz < fs / 2.0) {
        bail!(
            "compare: need 0 < f_min_hz < f_max_hz < {} Hz (Nyquist)",
            fs / 2.0
        );
    }
    Ok((validated, prediction(config)?))
}

/// Runs the configuration on the simulated rig; `progress` gets the fraction done.
///
/// # Errors
/// An invalid configuration, rig or analysis set-up.
pub fn simulate(config: &Config, progress: impl FnMut(f64)) -> Result<SimOutput> {
    simulate_with(config, progress, |experiment, progress| {
        // What the firmware runs (its run-time controller, configured as the set-up
        // configures the board), on the host.
        let mut board = model_core::BoardController::with_params(
            &experiment.setting.board_params(),
            experiment.setting.dt(),
        )
        .map_err(|e| anyhow!("the board's parameters: {e}"))?;
        Ok(experiment::run_on(experiment, &mut board, progress)?)
    })
}

/// What the firmware in QEMU did in [`simulate_on_qemu`].
#[derive(Clone, Debug, Serialize)]
pub struct QemuSummary {
    /// The firmware image run.
    pub elf: String,
    /// Demand frames compared with the host mirror of the firmware's controller.
    pub demand_frames: usize,
    /// Demand frames that differ from the mirror's (any bit of demand or flags): 0 when the
    /// image does what the host code does, configured as the set-up says.
    pub mismatches: usize,
    /// Parameter slots written over XCP by `mil sim` to configure the firmware for the
    /// set-up (0 when the board's XCP port was served: the engineer's tools configured it).
    pub slots_written: usize,
    /// Demand frames of the idle steps before the run (compared with the mirror as well):
    /// the board's demand moving to the set-up's safe demand.
    pub idle_frames: usize,
    /// Where the board's XCP port was served ([`ServeXcp`]), if it was.
    pub xcp_served_at: Option<String>,
    /// XCP clients (tool runs) served there.
    pub xcp_clients: usize,
}

/// The board's XCP port served for the engineer's own XCP tools (`mil param set`, `mil
/// filter upload`, `mil daq record`), instead of `mil sim` configuring the board itself: the
/// rig holds still until a DAQ measurement starts on the board, then runs the set-up's road.
#[derive(Clone, Copy, Debug)]
pub struct ServeXcp {
    /// Where the tools connect (`--port tcp:HOST:PORT`).
    pub listen: std::net::SocketAddr,
    /// How long to wait for the measurement.
    pub wait: std::time::Duration,
}

/// The board's settings for `config`: its sample rate (a whole number of Hz), the other
/// settings at the build's defaults.
///
/// # Errors
/// A sample rate the board cannot run.
fn board_settings(config: &Config) -> Result<mil_firmware::calibration::Settings> {
    let rate = config.run.sample_rate_hz;
    if !(rate.fract() == 0.0 && (1.0..=f64::from(u16::MAX)).contains(&rate)) {
        bail!("run.sample_rate_hz: the board runs at a whole number of Hz, got {rate}");
    }
    Ok(mil_firmware::calibration::Settings {
        sample_rate_hz: rate as u16,
        ..mil_firmware::calibration::DEFAULT_SETTINGS
    })
}

/// A configuration against the board's bus budget (the firmware's own schedule and check).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum BusBudget {
    /// Within the budget: the busier bus's worst-case load (fraction) over `buses` buses.
    Fits { load: f64, buses: u8 },
    /// Over it (the board refuses the configuration): the load and the highest sample
    /// rate within the budget.
    Refused { load: f64, max_rate_hz: f64 },
}

/// The board's bus budget for `params` at `settings`' sample rate.
fn bus_budget(
    params: &model_core::BoardParams,
    settings: &mil_firmware::calibration::Settings,
) -> BusBudget {
    use mil_firmware::calibration::{schedule, BUS_BIT_PER_S};
    let s = schedule(params, settings);
    match s.check(BUS_BIT_PER_S) {
        Ok(()) => BusBudget::Fits {
            load: s.load(BUS_BIT_PER_S),
            buses: s.buses,
        },
        Err(over) => BusBudget::Refused {
            load: over.load,
            max_rate_hz: over.max_sample_rate_hz,
        },
    }
}

/// The board's bus budget for the set-up `config` (configuration 4): its board parameters
/// at its sample rate, as the firmware checks them when they are written.
///
/// # Errors
/// An invalid set-up, or a sample rate the board cannot run.
pub(crate) fn board_bus_budget(config: &Config) -> Result<BusBudget> {
    let settings = board_settings(config)?;
    let (validated, _) = prepare(config)?;
    let params = setting(config, validated)?.board_params();
    Ok(bus_budget(&params, &settings))
}

/// The board's calibration page (f32 words, slot order) for the set-up `config`: its board
/// parameters at its sample rate, the other settings at the build's defaults.
///
/// # Errors
/// An invalid set-up, a sample rate the board cannot run, or a configuration over the
/// board's bus budget (the board refuses it).
pub fn board_page(config: &Config) -> Result<[f32; mil_firmware::calibration::SLOTS]> {
    let settings = board_settings(config)?;
    let (validated, _) = prepare(config)?;
    let params = setting(config, validated)?.board_params();
    check_budget(&params, &settings)?;
    Ok(mil_firmware::calibration::page_values(&params, &settings))
}

/// `params` within the board's bus budget at `settings`' rate.
fn check_budget(
    params: &model_core::BoardParams,
    settings: &mil_firmware::calibration::Settings,
) -> Result<()> {
    if let BusBudget::Refused { load, max_rate_hz } = bus_budget(params, settings) {
        bail!(
            "the board refuses this configuration at {} Hz: {:.1} % of a 1 Mbit/s bus \
             (budget 60 %); it runs at up to {max_rate_hz:.0} Hz",
            settings.sample_rate_hz,
            100.0 * load
        );
    }
    Ok(())
}

/// As [`simulate`], with the firmware image `elf` in QEMU (its QEMU build) in place of the
/// host's controller, driven sample for sample by the same rig; every demand frame is
/// compared with the host mirror of the firmware's controller configured as the set-up says.
///
/// The firmware is configured over XCP with the set-up's board parameters and sample rate
/// (refused with the bus load figure where the rate needs more than the bus budget), or,
/// with `serve`, by the engineer's XCP tools through the board's XCP port served at
/// `serve.listen` (`ready` is called with the address once it is open): the run starts when
/// a DAQ measurement starts on the board, so the recording begins with the run; the mirror
/// then shows whether the board was configured as the set-up says.
///
/// # Errors
/// As [`simulate`]; QEMU or the firmware not answering; the firmware refusing the set; no
/// DAQ measurement within `serve.wait`.
pub fn simulate_on_qemu(
    config: &Config,
    elf: &std::path::Path,
    serve: Option<ServeXcp>,
    ready: impl FnOnce(std::net::SocketAddr),
    progress: impl FnMut(f64),
) -> Result<(SimOutput, QemuSummary)> {
    use mil_can::{configure, Qemu, QemuOptions, RemoteBoard, XcpRelay};
    use mil_firmware::calibration::{page_values, reference_words};
    let image = std::fs::read(elf).with_context(|| format!("cannot read {}", elf.display()))?;
    let working = mil_a2l::symbols(&image)
        .map_err(|e| anyhow!("{}: {e}", elf.display()))?
        .get(mil_a2l::WORKING_SYMBOL)
        .map(|(address, _)| *address as u32)
        .with_context(|| {
            format!(
                "{} is not the firmware (no {})",
                elf.display(),
                mil_a2l::WORKING_SYMBOL
            )
        })?;
    let settings = board_settings(config)?;
    // The QEMU build's secret: MIL_XCP_SECRET if it was built with one, else the public
    // test secret it uses without.
    let secret = match std::env::var(crate::xcp::SECRET_ENV) {
        Ok(text) => crate::xcp::parse_secret(&text, crate::xcp::SECRET_ENV)?,
        Err(_) => mil_xcp::mock::TEST_SECRET.to_vec(),
    };
    let mut summary = QemuSummary {
        elf: elf.display().to_string(),
        demand_frames: 0,
        mismatches: 0,
        slots_written: 0,
        idle_frames: 0,
        xcp_served_at: None,
        xcp_clients: 0,
    };
    let mut ready = Some(ready);
    let output = simulate_with(config, progress, |experiment, progress| {
        let params = experiment.setting.board_params();
        check_budget(&params, &settings)?;
        let target = page_values(&params, &settings).map(f32::to_bits);
        let options = QemuOptions {
            xcp_port: serve.is_some(),
            ..QemuOptions::default()
        };
        let (qemu, link) =
            Qemu::spawn(elf, &options).with_context(|| format!("QEMU with {}", elf.display()))?;
        let mut board = RemoteBoard::new(link).map_err(|e| anyhow!(e))?;
        let relay = match (serve, qemu.xcp_port()) {
            (Some(serve), Some(port)) => {
                let board_port = std::net::SocketAddr::from((std::net::Ipv4Addr::LOCALHOST, port));
                let ids = (
                    mil_firmware::config::XCP_COMMAND_ID,
                    mil_firmware::config::XCP_RESPONSE_ID,
                );
                let relay = XcpRelay::start(serve.listen, board_port, ids)?;
                summary.xcp_served_at = Some(relay.local_addr().to_string());
                if let Some(ready) = ready.take() {
                    ready(relay.local_addr());
                }
                if !relay.wait_for_daq_start(serve.wait) {
                    bail!(
                        "no DAQ measurement started on the board within {:.0} s (`mil daq record \
                         --port tcp:{}` starts the run)",
                        serve.wait.as_secs_f64(),
                        relay.local_addr()
                    );
                }
                // The mirror as the set-up configures the board: a board configured otherwise
                // shows as mismatching demand frames.
                board
                    .set_mirror(&params, settings.dt())
                    .map_err(|e| anyhow!(e))?;
                Some(relay)
            }
            _ => {
                let done = configure(
                    board.transport_mut(),
                    working,
                    &secret,
                    &reference_words(),
                    &target,
                )
                .map_err(|e| anyhow!("configuring the firmware over XCP: {e}"))?;
                board
                    .replay(&reference_words(), &done.writes)
                    .map_err(|e| anyhow!(e))?;
                summary.slots_written = done.writes.len();
                // Idle steps, as a rig streams its measurements before a test: the board's
                // demand moves from the configuration it booted with to the set-up's safe
                // demand, where the host's controller starts.
                let steps = idle_steps(
                    &mil_firmware::config::default_params(),
                    &params,
                    f64::from(settings.sample_rate_hz),
                );
                let speed = match experiment.setting {
                    Setting::HalfCar { .. } => experiment
                        .inputs
                        .get(2)
                        .and_then(|v| v.first())
                        .copied()
                        .unwrap_or(0.0),
                    _ => 0.0,
                };
                idle(&mut board, params.channels as usize, steps, speed as f32)?;
                summary.idle_frames = board.samples().len();
                None
            }
        };
        let outcome = experiment::run_on(experiment, &mut board, progress)?;
        summary.demand_frames = board.samples().len() - summary.idle_frames;
        summary.mismatches = board.mismatches();
        summary.xcp_clients = relay.as_ref().map_or(0, XcpRelay::clients);
        drop(relay);
        let mut link = board.into_transport();
        link.close().context("closing the SLCAN channel")?;
        let out = qemu
            .finish(std::time::Duration::from_secs(20))
            .context("QEMU did not exit")?;
        if !out.status.is_some_and(|s| s.success()) {
            bail!("QEMU exited with {:?}: {}", out.status, out.stderr.trim());
        }
        Ok(outcome)
    })?;
    Ok((output, summary))
}

/// Idle steps that take a board configured from `from` to `to` at `fs`: its demand ramps
/// from `from`'s safe demand to `to`'s at `to`'s safe ramp rate, a configuration change
/// fading in over model-core's `BUMPLESS_FADE_S`; with half as much again for margin, at
/// most 10 s.
fn idle_steps(from: &model_core::BoardParams, to: &model_core::BoardParams, fs: f64) -> usize {
    let dt = 1.0 / fs;
    let ramp = (0..(to.channels as usize).min(model_core::BOARD_CHANNELS))
        .map(|c| {
            let gap = f64::from((from.safe_demand[c] - to.safe_demand[c]).abs());
            let rate = f64::from(to.safe_ramp_rate[c]);
            if rate > 0.0 {
                (gap / (rate * dt)).ceil()
            } else {
                0.0
            }
        })
        .fold(0.0, f64::max);
    let fade = (f64::from(model_core::BUMPLESS_FADE_S) * fs).ceil();
    (1.5 * (ramp + fade) + 2.0).min(10.0 * fs) as usize
}

/// `steps` idle lockstep samples of a `channels`-channel board at rest (positions and forces
/// zero, roads level, the aero model's `speed`): the model does not run while Idle.
fn idle<T: mil_can::Transport>(
    board: &mut mil_can::RemoteBoard<T>,
    channels: usize,
    steps: usize,
    speed: f32,
) -> Result<()> {
    fn go<T: mil_can::Transport, const CH: usize>(
        board: &mut mil_can::RemoteBoard<T>,
        steps: usize,
        speed: f32,
    ) -> Result<()> {
        let rest = model_core::ModelInput::<CH> {
            speed,
            ..model_core::ModelInput::default()
        };
        for _ in 0..steps {
            mil_rig::harness::Board::<CH>::step(board, &rest).map_err(|e| anyhow!(e))?;
        }
        Ok(())
    }
    match channels {
        1 => go::<T, 1>(board, steps, speed),
        2 => go::<T, 2>(board, steps, speed),
        3 => go::<T, 3>(board, steps, speed),
        4 => go::<T, 4>(board, steps, speed),
        n => bail!("a {n}-channel board: the rig drives 1 to 4"),
    }
}

/// [`simulate`] with the experiment run by `run`.
fn simulate_with(
    config: &Config,
    progress: impl FnMut(f64),
    run: impl FnOnce(&Experiment, &mut dyn FnMut(f64)) -> Result<Outcome>,
) -> Result<SimOutput> {
    let mut progress = progress;
    let (validated, prediction) = prepare(config)?;
    let fs = config.run.sample_rate_hz;
    let step = config.rig.internal_step_s;
    let n = config.samples();
    let channels = config.channels();
    let rows = config.input.generate(n, fs, channels, &config.base)?;
    let instrumentation = Instrumentation {
        position_sensor: config.sensors.position.clone(),
        force_sensor: config.sensors.force.clone(),
        position_link: config.links.position.clone(),
        force_link: config.links.force.clone(),
        demand_link: config.links.demand.clone(),
    };
    // The aero run's speed is its third input (m/s), per sample.
    let speed = match &validated {
        Validated::Aero(_, profile) => Some(profile.samples(n, fs)),
        _ => None,
    };
    let aero = speed.is_some();
    let mut inputs = columns(&rows, channels);
    inputs.extend(speed);
    let setting = setting(config, validated)?;
    let experiment = Experiment {
        setting,
        actuator: ForceActuator::new(
            config
                .rig
                .actuator
                .unwrap_or(ServoHydraulicActuator::REFERENCE),
            config.rig.actuator_effects,
        )
        .map_err(|e| anyhow!("actuator.reference: {e}"))?,
        instrumentation,
        sample_rate_hz: fs,
        internal_step_s: step,
        inputs,
        // The road and the speed as the board receives them: in its measurement frames.
        board_view: experiment::BoardView {
            road: road_on_can,
            speed: speed_on_can,
            demand: demand_on_can,
            position: position_on_can,
            force: force_on_can,
        },
    };
    let started = std::time::Instant::now();
    let Outcome {
        histories,
        links,
        filter_sections,
    } = run(&experiment, &mut progress)?;
    let elapsed = started.elapsed().as_secs_f64().max(1e-9);
    let road_names = experiment.setting.input_names();
    let channel_names = experiment.setting.channel_names();
    let skip = settle_samples(config, histories.len());
    let band = |x: &[f64]| lowpass2_zero_phase(x, config.compare.f_max_hz, 1.0 / fs);
    let channel = (0..channels)
        .map(|c| {
            let (mf, ef) = (
                &histories.mil_force[c][skip..],
                &histories.emulated_force[c][skip..],
            );
            let (mp, ep) = (
                &histories.mil_position[c][skip..],
                &histories.emulated_position[c][skip..],
            );
            ChannelErrors {
                channel: c,
                name: channel_names[c].clone(),
                force: compare(mf, ef, fs, MAX_LAG_S),
                force_in_band: compare(&band(mf), &band(ef), fs, MAX_LAG_S),
                position: compare(mp, ep, fs, MAX_LAG_S),
                position_in_band: compare(&band(mp), &band(ep), fs, MAX_LAG_S),
                demand_range: histories.demand[c]
                    .iter()
                    .fold([f64::INFINITY, f64::NEG_INFINITY], |[lo, hi], d| {
                        [lo.min(*d), hi.max(*d)]
                    }),
            }
        })
        .collect();
    let dof_units = dof_units(config, aero, &histories.mil_dofs);
    let (response, curves) = match response(config, &histories, prediction.as_ref())? {
        Some((s, c)) => (Some(s), Some(c)),
        None => (None, None),
    };
    let status = &histories.status;
    let summary = SimSummary {
        model: format!("{:?}", config.model.kind).to_lowercase(),
        channels,
        sample_rate_hz: fs,
        samples: n,
        internal_step_s: step,
        filter_sections,
        speed_m_per_s: speed_range(config, &histories),
        band_hz: [config.compare.f_min_hz, config.compare.f_max_hz],
        settle_s: skip as f64 / fs,
        channel,
        response,
        fault_at_s: status
            .iter()
            .position(|s| s.mode == Mode::Fault)
            .map(|k| k as f64 / fs),
        fault_flags: status.last().map_or(0, |s: &Status| s.fault),
        links,
        realtime_factor: n as f64 / fs / elapsed,
    };
    Ok(SimOutput {
        road_names,
        histories,
        summary,
        curves,
        dof_units,
    })
}

/// The experiment's setting from the configuration and its validated board parameters: the
/// specimen on the rig (the quarter car with its tyre, the half car, or the physical
/// structure) and the board's model for it.
fn setting(config: &Config, validated: Validated) -> Result<Setting> {
    Ok(match validated {
        Validated::Tyre(board) => {
            let tyre = config
                .tyre
                .as_ref()
                .context("the tyre run needs [numerical.tyre]")?;
            let specimen = config
                .rig
                .quarter_car
                .clone()
                .context("the tyre run needs the quarter car ([physical] structure)")?;
            let mut tyre_element = Element::linear(
                f64::from(tyre.stiffness_n_per_m),
                f64::from(tyre.damping_n_s_per_m),
            )
            .with_preload(f64::from(tyre.static_load_n));
            tyre_element.effects = match &config.rig.tyre_effects {
                Some(effects) => effects.clone(),
                None if tyre.lift_off => [(EffectKind::LiftOff, Default::default())].into(),
                None => Default::default(),
            };
            tyre_element
                .validate()
                .map_err(|e| anyhow!("physical.tyre_effects: {e}"))?;
            Setting::QuarterCars {
                board,
                specimen,
                tyre: tyre_element,
            }
        }
        Validated::Aero(board, speed) => Setting::HalfCar {
            board,
            specimen: config.half_car_specimen(speed.at(0.0))?,
        },
        Validated::Substructure(board) => {
            let (specimen, specimen_inputs) = config.physical_specimen(board.channels())?;
            Setting::Structure {
                board,
                specimen,
                specimen_inputs,
            }
        }
    })
}

/// The aero run's lowest and highest speed (m/s): the histories' `speed` column.
fn speed_range(config: &Config, h: &Histories) -> Option<[f64; 2]> {
    if config.model.kind != ModelKind::Aero {
        return None;
    }
    h.road.get(2).map(|v| {
        v.iter()
            .fold([f64::INFINITY, f64::NEG_INFINITY], |[lo, hi], x| {
                [lo.min(*x), hi.max(*x)]
            })
    })
}

/// Samples left out at the start of the comparison (`[compare] settle_s`), at most all.
fn settle_samples(config: &Config, samples: usize) -> usize {
    ((config.compare.settle_s * config.run.sample_rate_hz).round() as usize).min(samples)
}

/// `[sample][channel]` rows to per-channel columns.
/// Position and road (m) as the board's Measurement frame carries them (its DBC resolution,
/// 1 µm); a value the frame cannot carry is left as it is (the board would refuse it).
fn measurement_on_can(position_m: f64, road_m: f64) -> Option<(f64, f64)> {
    let m = mil_frames::Measurement {
        channel: 0,
        position_m: position_m as f32,
        road_m: road_m as f32,
        counter: 0,
    };
    let frame = mil_frames::encode_measurement(&mil_can::LAYOUT, &m).ok()?;
    match mil_frames::decode(&mil_can::LAYOUT, &frame) {
        Ok(mil_frames::Message::Measurement(m)) => {
            Some((f64::from(m.position_m), f64::from(m.road_m)))
        }
        _ => None,
    }
}

/// Force (N) and speed (m/s) as the board's MeasurementAux frame carries them (0.1 N,
/// 0.01 m/s).
fn measurement_aux_on_can(force_n: f64, speed: f64) -> Option<(f64, f64)> {
    let m = mil_frames::MeasurementAux {
        channel: 0,
        force_n: force_n as f32,
        speed_m_s: speed as f32,
    };
    let frame = mil_frames::encode_measurement_aux(&mil_can::LAYOUT, &m).ok()?;
    match mil_frames::decode(&mil_can::LAYOUT, &frame) {
        Ok(mil_frames::Message::MeasurementAux(m)) => {
            Some((f64::from(m.force_n), f64::from(m.speed_m_s)))
        }
        _ => None,
    }
}

fn road_on_can(road_m: f64) -> f64 {
    measurement_on_can(0.0, road_m).map_or(road_m, |(_, r)| r)
}

fn position_on_can(position_m: f64) -> f64 {
    measurement_on_can(position_m, 0.0).map_or(position_m, |(p, _)| p)
}

fn speed_on_can(speed: f64) -> f64 {
    measurement_aux_on_can(0.0, speed).map_or(speed, |(_, v)| v)
}

fn force_on_can(force_n: f64) -> f64 {
    measurement_aux_on_can(force_n, 0.0).map_or(force_n, |(f, _)| f)
}

/// A demand (N) as the board's Demand frame carries it (0.1 N).
fn demand_on_can(demand_n: f64) -> f64 {
    let d = mil_frames::Demand {
        channel: 0,
        demand_n: demand_n as f32,
        counter: 0,
        flags: mil_frames::DemandFlags::default(),
    };
    match mil_frames::encode_demand(&mil_can::LAYOUT, &d)
        .map(|f| mil_frames::decode(&mil_can::LAYOUT, &f))
    {
        Ok(Ok(mil_frames::Message::Demand(d))) => f64::from(d.demand_n),
        _ => demand_n,
    }
}

fn columns(rows: &[Vec<f64>], channels: usize) -> Vec<Vec<f64>> {
    (0..channels)
        .map(|c| {
            rows.iter()
                .map(|r| r.get(c).copied().unwrap_or(0.0))
                .collect()
        })
        .collect()
}

/// The analysis' prediction of the run's response: the set-up's analysis with the run's
/// command filter, the output signal and the inputs the run's road drives.
pub(crate) struct Prediction {
    /// The set-up's name.
    name: String,
    /// The analysis, its command filter the run's.
    setup: Setup,
    /// The predicted output.
    output: Signal,
    /// The analysis inputs the run's road drives (their responses are summed).
    inputs: Vec<usize>,
}

/// The prediction of the run's response from the set-up's analysis, checked before the run
/// so that a bad set-up is refused at once: see [`response`] for the signals per model.
fn prediction(config: &Config) -> Result<Option<Prediction>> {
    let Some(setup) = &config.analysis else {
        return Ok(None);
    };
    let fs = config.run.sample_rate_hz;
    let mut setup = (**setup).clone();
    // The prediction is for the controller that runs: the run's command filter.
    let cascade = config.command_filter()?;
    setup.system.filter = (cascade.sections > 0).then_some(CommandFilter::Discrete {
        cascade,
        sample_period_s: 1.0 / fs,
    });
    let signal = match config.model.kind {
        ModelKind::Tyre | ModelKind::Substructure => "interface_force",
        ModelKind::Aero => "physical:z_b",
    };
    let output = Signal::parse(signal, &setup.system).context("the analysis' output")?;
    let available: Vec<&str> = setup
        .system
        .inputs
        .iter()
        .map(|i| i.name.as_str())
        .collect();
    if config.analysis_inputs.is_empty() {
        bail!("no input of the analysis follows the run's road_0: map a structure input to it");
    }
    let inputs = config
        .analysis_inputs
        .iter()
        .map(|name| {
            available.iter().position(|i| i == name).with_context(|| {
                format!("the analysis has no input {name:?} (inputs: {available:?})")
            })
        })
        .collect::<Result<Vec<usize>>>()?;
    Ok(Some(Prediction {
        name: setup.name.clone(),
        setup,
        output,
        inputs,
    }))
}

/// Points per decade of the analysis' curves on the response plot.
const PREDICTION_POINTS_PER_DECADE: usize = 100;

/// The response the run estimates, per model: tyre, channel 0's interface force per road
/// under it (analysis: `interface_force` per `road`); aero, the body's heave per road heave
/// (analysis: `physical:z_b` per `road_heave`), when both posts carry the same road;
/// substructure, channel 0's interface force per channel 0's road (analysis:
/// `interface_force` per the sum of the inputs that follow road 0). The analysis comparison of
/// an aero run is left out, with the reason, unless the speed is the reference speed
/// throughout (the set-up's `K_i` holds there only).
fn response(
    config: &Config,
    h: &Histories,
    prediction: Option<&Prediction>,
) -> Result<Option<(ResponseSummary, ResponseCurves)>> {
    let fs = config.run.sample_rate_hz;
    let cmp = &config.compare;
    let skip = settle_samples(config, h.len());
    let segment = cmp
        .segment
        .unwrap_or(WelchOptions::for_band(h.len() - skip, fs, cmp.f_min_hz).segment_length);
    if segment < 64 || segment > h.len() - skip {
        // Too short a run for the estimate: no response section.
        return Ok(None);
    }
    // Aero: body heave from the axle positions, z_b = (l_r y_f + l_f y_r) / (l_f + l_r),
    // per road heave (the same road under both posts).
    let heave = |y: &[Vec<f64>]| -> Vec<f64> {
        let (lf, lr) = config.aero.as_ref().map_or((1.0, 1.0), |a| {
            (f64::from(a.front_axle_m), f64::from(a.rear_axle_m))
        });
        match (y.first(), y.get(1)) {
            (Some(f), Some(r)) => f
                .iter()
                .zip(r)
                .map(|(a, b)| (lr * a + lf * b) / (lf + lr))
                .collect(),
            _ => Vec::new(),
        }
    };
    let (name, unit, input, mil_out, emu_out) = match config.model.kind {
        ModelKind::Tyre | ModelKind::Substructure => (
            "interface force / road, channel 0",
            "N/m",
            h.road[0].clone(),
            h.mil_force[0].clone(),
            h.emulated_force[0].clone(),
        ),
        ModelKind::Aero => {
            // Columns: front post, rear post, speed.
            if h.road.len() < 2 || h.road[0] != h.road[1] {
                // A recorded profile with different posts: no single heave input.
                return Ok(None);
            }
            (
                "body heave / road heave",
                "m/m",
                h.road[0].clone(),
                heave(&h.mil_position),
                heave(&h.emulated_position),
            )
        }
    };
    let input = &input[skip..];
    if input.iter().all(|v| Some(v) == input.first()) {
        // A level road (e.g. a speed or load case): nothing to estimate a response from.
        return Ok(None);
    }
    let (mil_out, emu_out) = (&mil_out[skip..], &emu_out[skip..]);
    let options = WelchOptions {
        segment_length: segment,
        overlap: 0.75,
        window: Window::Hann,
    };
    let estimate = |out: &[f64]| -> Result<FrfEstimate> {
        Ok(h1_estimate(&[Record { input, output: out }], fs, &options)?)
    };
    let (mil, emu) = (estimate(mil_out)?, estimate(emu_out)?);
    let keep = coherent_bins(&mil, &emu, (cmp.f_min_hz, cmp.f_max_hz));
    let mut curves = ResponseCurves {
        name: name.into(),
        unit: unit.into(),
        frequency_hz: keep.iter().map(|&k| mil.frequency_hz[k]).collect(),
        mil: keep.iter().map(|&k| mil.response[k]).collect(),
        emulated: keep.iter().map(|&k| emu.response[k]).collect(),
        band_hz: [cmp.f_min_hz, cmp.f_max_hz],
        predicted: None,
    };
    let deviation = Deviation::worst;
    let mut summary = ResponseSummary {
        name: name.into(),
        band_hz: [cmp.f_min_hz, cmp.f_max_hz],
        bins: keep.len(),
        mil_vs_emulated: deviation(&curves.mil, &curves.emulated),
        mil_vs_analysis: None,
        emulated_vs_analysis: None,
        analysis: None,
        analysis_skipped: None,
    };
    if let (Some(_), Some(reference), Some(v)) = (
        prediction,
        config.aero.as_ref().map(|a| a.reference_speed_m_per_s),
        speed_range(config, h),
    ) {
        let reference = f64::from(reference);
        let what = if v[0] == v[1] {
            format!("the run is at {} m/s", v[0])
        } else {
            format!("the run's speed varies from {} to {} m/s", v[0], v[1])
        };
        if v != [reference; 2] {
            summary.analysis_skipped = Some(format!(
                "the set-up's analysis holds at the reference speed ({reference} m/s) only, {what}"
            ));
            return Ok(Some((summary, curves)));
        }
    }
    if let Some(p) = prediction {
        // MiL and emulated predictions at the frequencies `f`.
        let predict = |f: &[f64]| -> Result<PredictedCurves> {
            let mut out = PredictedCurves::default();
            for &f in f {
                let (mil, emulated) = (
                    p.setup.system.point(f, Loop::Mil)?,
                    p.setup.system.point(f, Loop::Emulated)?,
                );
                out.frequency_hz.push(f);
                out.mil
                    .push(p.inputs.iter().map(|&i| p.output.pick(&mil, i)).sum());
                out.emulated
                    .push(p.inputs.iter().map(|&i| p.output.pick(&emulated, i)).sum());
            }
            Ok(out)
        };
        // Compared at the estimate's coherent bins, drawn over the whole band.
        let at_bins = predict(&curves.frequency_hz)?;
        summary.mil_vs_analysis = deviation(&curves.mil, &at_bins.mil);
        summary.emulated_vs_analysis = deviation(&curves.emulated, &at_bins.emulated);
        summary.analysis = Some(p.name.clone());
        curves.predicted = Some(predict(&mil_analysis::metrics::log_grid(
            cmp.f_min_hz,
            cmp.f_max_hz,
            PREDICTION_POINTS_PER_DECADE,
        ))?);
    }
    Ok(Some((summary, curves)))
}

impl SimOutput {
    /// Writes the time histories as CSV: `time` (s), the road inputs (m; `road_<i>`, or
    /// `road_front`, `road_rear` and the vehicle `speed` (m/s) for the aero model), then per
    /// channel
    /// `demand_<c>` (N), `mil_position_<c>` (m), `mil_force_<c>` (N),
    /// `emulated_position_<c>` (m), `emulated_force_<c>` (N), then every specimen DOF's
    /// displacement on the MiL rig, `mil_dof_<dof>_<c>` (m or rad, `c` its part's first
    /// channel: a structure file's `[[output]]` can read it as a body transducer), then
    /// `mode` and `fault`.
    ///
    /// # Errors
    /// I/O errors.
    pub fn write_csv(&self, path: &Path) -> Result<()> {
        // Whole or not at all: an interrupted run leaves no truncated file.
        crate::cli::write_atomic(path, |w| {
            let h = &self.histories;
            let ch = self.summary.channels;
            // Every column with its unit (SI).
            let mut header = vec!["time [s]".to_string()];
            header.extend(self.road_names.iter().map(|name| {
                let unit = if name == "speed" { "m/s" } else { "m" };
                format!("{name} [{unit}]")
            }));
            for c in 0..ch {
                header.extend(
                    [
                        ("demand", "N"),
                        ("mil_position", "m"),
                        ("mil_force", "N"),
                        ("emulated_position", "m"),
                        ("emulated_force", "N"),
                    ]
                    .map(|(s, unit)| format!("{s}_{c} [{unit}]")),
                );
            }
            header.extend(
                h.mil_dofs
                    .iter()
                    .zip(self.dof_units.iter().chain(std::iter::repeat(&"m")))
                    .map(|((name, _), unit)| format!("mil_dof_{name} [{unit}]")),
            );
            header.extend(["mode", "fault"].map(String::from));
            writeln!(w, "{}", header.join(","))?;
            for k in 0..h.len() {
                write!(w, "{:.6}", h.time[k])?;
                for r in &h.road {
                    write!(w, ",{:.9e}", r[k])?;
                }
                for c in 0..ch {
                    write!(
                        w,
                        ",{:.6e},{:.9e},{:.6e},{:.9e},{:.6e}",
                        h.demand[c][k],
                        h.mil_position[c][k],
                        h.mil_force[c][k],
                        h.emulated_position[c][k],
                        h.emulated_force[c][k]
                    )?;
                }
                for (_, q) in &h.mil_dofs {
                    write!(w, ",{:.9e}", q[k])?;
                }
                writeln!(w, ",{},{}", h.status[k].mode as u8, h.status[k].fault)?;
            }
            Ok(())
        })
    }

    /// Writes the plots into `dir`: `forces.svg` and `positions.svg` (MiL against emulated,
    /// channel 0, over the second around the largest force error) and, when estimated, `response.svg` (Bode diagram of the
    /// estimates and predictions). Returns the files written.
    ///
    /// # Errors
    /// Drawing or I/O errors.
    pub fn write_plots(&self, dir: &Path) -> Result<Vec<PathBuf>> {
        let h = &self.histories;
        let mut files = Vec::new();
        // One second around channel 0's largest force error (the whole run if shorter).
        let fs = self.summary.sample_rate_hz;
        let skip = ((self.summary.settle_s * fs).round() as usize).min(h.len());
        let worst = match (h.mil_force.first(), h.emulated_force.first()) {
            (Some(m), Some(e)) => m
                .iter()
                .zip(e)
                .map(|(a, b)| (a - b).abs())
                .enumerate()
                .skip(skip)
                .max_by(|a, b| a.1.total_cmp(&b.1))
                .map_or(0, |(k, _)| k),
            _ => 0,
        };
        let half = (0.5 * fs) as usize;
        let from = worst.saturating_sub(half);
        let to = (from + 2 * half).min(h.len());
        let from = to.saturating_sub(2 * half);
        let window = format!(
            "{:.2}-{:.2} s, around the largest force error",
            from as f64 / fs,
            to as f64 / fs
        );
        let trace = |v: &[f64], scale: f64| -> Vec<(f64, f64)> {
            h.time[from..to]
                .iter()
                .zip(&v[from..to])
                .map(|(t, x)| (*t, x * scale))
                .collect()
        };
        let name = self
            .summary
            .channel
            .first()
            .map_or_else(String::new, |c| c.name.clone());
        for (file, title, label, mil, emu, scale) in [
            (
                "forces.svg",
                format!("Interface force, {name}, {window}"),
                "force [kN]",
                &h.mil_force,
                &h.emulated_force,
                1e-3,
            ),
            (
                "positions.svg",
                format!("Attachment position, {name}, {window}"),
                "position [mm]",
                &h.mil_position,
                &h.emulated_position,
                1e3,
            ),
        ] {
            let (Some(m), Some(e)) = (mil.first(), emu.first()) else {
                continue;
            };
            let mut plot = XyPlot::new(title, "time [s]", label);
            plot.series = vec![
                XySeries::new("emulated (vehicle)", trace(e, scale), SeriesStyle::Line),
                XySeries::new("MiL rig", trace(m, scale), SeriesStyle::Dashed),
            ];
            let path = dir.join(file);
            mil_plots::xy_svg(&path, &plot)?;
            files.push(path);
        }
        // A run too short for the comparison band gives no estimate: no response plot.
        if let Some(c) = self.curves.as_ref().filter(|c| !c.frequency_hz.is_empty()) {
            // The band the figures claim, the estimates where they are coherent, the
            // analysis over the whole band.
            // In dB with its unit, force per road in N/mm as `mil analyze` shows it.
            let (factor, unit) = crate::plot::response_unit(&c.unit);
            let mut plot = BodePlot::new(
                format!("Response from the run: {}", c.name),
                format!("{} [dB re 1 {unit}]", c.name),
            );
            plot.magnitude_scale = mil_plots::MagnitudeScale::Decibel;
            plot.magnitude_factor = factor;
            plot.frequency_span = Some(c.band_hz);
            plot.series = vec![
                BodeSeries::new(
                    "emulated, estimated (coherence >= 0.9)",
                    c.frequency_hz.clone(),
                    c.emulated.clone(),
                ),
                BodeSeries::new(
                    "MiL, estimated (coherence >= 0.9)",
                    c.frequency_hz.clone(),
                    c.mil.clone(),
                ),
            ];
            if let Some(p) = &c.predicted {
                let mut a = BodeSeries::new(
                    "emulated, analysis",
                    p.frequency_hz.clone(),
                    p.emulated.clone(),
                );
                a.dashed = true;
                let mut b = BodeSeries::new("MiL, analysis", p.frequency_hz.clone(), p.mil.clone());
                b.dashed = true;
                plot.series.extend([a, b]);
            }
            let path = dir.join("response.svg");
            mil_plots::bode_svg(&path, &plot)?;
            files.push(path);
        }
        Ok(files)
    }

    /// The main job's side-by-side: this run (without a command filter) and `with` (the same
    /// run with `filter_name`), per channel the in-band J2 and J1 of force and position, and
    /// one line on what the figures measure.
    pub fn side_by_side(&self, with: &SimSummary, filter_name: &str) -> String {
        let s = &self.summary;
        let band = format!("{:.0}-{:.0} Hz", s.band_hz[0], s.band_hz[1]);
        let mut out = format!(
            "\nThe paper's problem and its answer: the same run with {filter_name}.\nLook at J2 \
             within {band}, the MiL rig's RMS error over the real car's RMS in the band that \
             matters (J1: the delay at the cross-correlation peak; J3: the peak error over the \
             car's peak).\n{:<28} {:>22}   {:>22}\n{:<28} {:>10} {:>11}   {:>10} {:>11}\n",
            "",
            format!("J2 within {band} [%]"),
            "J1 delay [ms]",
            "",
            "no filter",
            "with filter",
            "no filter",
            "with filter"
        );
        let opt = |v: Option<f64>, digits: usize| {
            v.map_or_else(|| "-".to_string(), |x| format!("{x:.digits$}"))
        };
        for (a, b) in s.channel.iter().zip(&with.channel) {
            for (what, x, y) in [
                ("force", &a.force_in_band, &b.force_in_band),
                ("position", &a.position_in_band, &b.position_in_band),
            ] {
                out += &format!(
                    "{:<28} {:>10} {:>11}   {:>10} {:>11}\n",
                    format!("{} {what}", a.name),
                    opt(x.nrms_error_pct, 1),
                    opt(y.nrms_error_pct, 1),
                    opt(x.delay_ms, 2),
                    opt(y.delay_ms, 2)
                );
            }
        }
        out
    }

    /// The summary as a human-readable table.
    pub fn table(&self) -> String {
        let s = &self.summary;
        let opt = |v: Option<f64>, digits: usize| {
            v.map_or_else(|| "-".to_string(), |x| format!("{x:.digits$}"))
        };
        let mut out = format!(
            "model {} on the simulated rig | compared from {:.2} s | {} channels | {:.0} Hz | {} samples ({:.1} s) | RK4 {:.0} us | command filter: {}\n",
            s.model,
            s.settle_s,
            s.channels,
            s.sample_rate_hz,
            s.samples,
            s.samples as f64 / s.sample_rate_hz,
            s.internal_step_s * 1e6,
            if s.filter_sections == 0 {
                "none".to_string()
            } else {
                format!("{} section(s)", s.filter_sections)
            }
        );
        if let Some([lo, hi]) = s.speed_m_per_s {
            out += &if lo == hi {
                format!("vehicle speed {lo:.1} m/s\n")
            } else {
                format!("vehicle speed {lo:.1} to {hi:.1} m/s\n")
            };
        }
        out += "MiL vs emulated   signal     J1 delay [ms]  J2 NRMS [%]  J3 peak [%]   RMS error  peak error\n";
        for c in &s.channel {
            let in_band = format!("<{:.0} Hz", s.band_hz[1]);
            for (what, cmp, unit, scale) in [
                ("force", &c.force, "N", 1.0),
                (in_band.as_str(), &c.force_in_band, "N", 1.0),
                ("position", &c.position, "mm", 1e3),
                (in_band.as_str(), &c.position_in_band, "mm", 1e3),
            ] {
                out += &format!(
                    "{:<17} {:<9} {:>14} {:>12} {:>12} {:>9.3} {unit} {:>8.3} {unit}\n",
                    c.name,
                    what,
                    opt(cmp.delay_ms, 2),
                    opt(cmp.nrms_error_pct, 2),
                    opt(cmp.peak_error_pct, 2),
                    cmp.rms_error * scale,
                    cmp.peak_error * scale,
                );
            }
        }
        if let Some(r) = &s.response {
            let dev = |d: &Option<Deviation>| {
                d.map_or_else(
                    || "-".to_string(),
                    |d| format!("{:.2} dB / {:.1} deg", d.db, d.deg),
                )
            };
            out += &format!(
                "response {} over {:.1}-{:.1} Hz ({} bins, coherence >= 0.9), worst deviation:\n",
                r.name, r.band_hz[0], r.band_hz[1], r.bins
            );
            out += &format!(
                "  MiL vs emulated (both estimated): {}\n",
                dev(&r.mil_vs_emulated)
            );
            if let Some(note) = &r.analysis_skipped {
                out += &format!("  analysis comparison skipped: {note}\n");
            }
            if r.analysis.is_some() {
                out += &format!(
                    "  MiL vs analysis prediction:      {}\n",
                    dev(&r.mil_vs_analysis)
                );
                out += &format!(
                    "  emulated vs analysis prediction: {}\n",
                    dev(&r.emulated_vs_analysis)
                );
            }
        }
        out += &crate::run::fault_line(s.fault_at_s, s.fault_flags);
        out += &format!(
            "links: {} frames, {} dropped, {} corrupted | real-time factor {}x (informational)\n",
            s.links.frames,
            s.links.dropped,
            s.links.corrupted,
            // Two significant figures below 10 (QEMU runs slower than real time: 0.21x).
            if s.realtime_factor < 10.0 {
                format!("{:.2}", s.realtime_factor)
            } else {
                format!("{:.0}", s.realtime_factor)
            }
        );
        out
    }
}
