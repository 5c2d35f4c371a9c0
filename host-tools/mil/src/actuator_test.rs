//! `mil actuator-test`: the blocked-rod force test of the set-up's actuator on the simulated
//! rig (`mil_rig::actuator_test`), the record `mil identify` turns into the tracking table
//! of the analysis. On a real rig the servo controller's own sweep or noise test writes the
//! same record.

use crate::setup::SetUp;
use anyhow::{anyhow, bail, Result};
use mil_identify::{try_band_limited_noise, try_log_sine_sweep};
use mil_params::ServoHydraulicActuator;
use mil_rig::actuator::ForceActuator;
use mil_rig::actuator_test::{ActuatorTestError, BlockedRodTest};
use serde::Serialize;
use std::io::Write;
use std::path::PathBuf;

/// The test signal.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Signal {
    /// Exponential sine sweep over the band (equal time per octave).
    Sweep,
    /// Band-limited white noise over the band (Gaussian, periodic in the record).
    Noise,
}

/// `mil actuator-test`'s arguments.
#[derive(Clone, Debug, clap::Args)]
pub struct Args {
    /// MiL set-up (TOML) whose actuator (`[actuator]`: parameters and effects), load cell
    /// (`[sensors] force`) and rate are tested; without it the built-in tyre example's.
    pub setup: Option<PathBuf>,
    /// The test signal.
    #[arg(long, value_enum, default_value_t = Signal::Sweep)]
    pub signal: Signal,
    /// Excited band, LOW:HIGH in Hz; HIGH at most the Nyquist frequency. Default: 0.5 Hz to
    /// a fifth of the sample rate.
    #[arg(long)]
    pub band: Option<String>,
    /// Amplitude (N): the sweep's peak, the noise's RMS. Default: 5 % (sweep) or 2 % (noise)
    /// of the actuator's force capacity (piston area × supply pressure).
    #[arg(long)]
    pub amplitude: Option<f64>,
    /// Mean force command (N). Default: the set-up's safe demand (the specimen's static
    /// load).
    #[arg(long)]
    pub offset: Option<f64>,
    /// Length of the record (s).
    #[arg(long, default_value_t = 60.0)]
    pub duration: f64,
    /// Sample rate (Hz). Default: the set-up's `[controller] sample_rate_hz`.
    #[arg(long)]
    pub rate: Option<f64>,
    /// Seed of the noise signal and of the load cell's noise.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Record file to write (CSV: time, force command, load cell). Default:
    /// `out/actuator/<signal>.csv`.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Print one JSON object with the summary.
    #[arg(long)]
    pub json: bool,
}

/// What the test did.
#[derive(Clone, Debug, Serialize)]
pub struct Summary {
    /// The signal.
    pub signal: Signal,
    /// Excited band (Hz).
    pub band_hz: (f64, f64),
    /// Sweep peak or noise RMS (N).
    pub amplitude_n: f64,
    /// Mean command (N).
    pub offset_n: f64,
    /// Sample rate (Hz).
    pub sample_rate_hz: f64,
    /// Samples written.
    pub samples: usize,
    /// Largest load-cell force (N, absolute).
    pub peak_force_n: f64,
    /// The actuator's force capacity, piston area × supply pressure (N).
    pub capacity_n: f64,
    /// The record file.
    pub record: String,
    /// The command that identifies the tracking response from it.
    pub next: String,
}

/// Column names of the record (units in brackets, read by every `mil` record reader).
pub const COLUMNS: [&str; 3] = ["time [s]", "force_command [N]", "force [N]"];

/// Runs the test and writes the record.
///
/// # Errors
/// An invalid set-up, band, amplitude or rate, or the record cannot be written.
pub fn run(args: &Args) -> Result<Summary> {
    let setup = match &args.setup {
        Some(path) => SetUp::read(path)?,
        None => SetUp::builtin()?,
    };
    let config = setup.run()?;
    let fs = args.rate.unwrap_or(config.run.sample_rate_hz);
    if !(fs.is_finite() && (10.0..=100e3).contains(&fs)) {
        bail!("--rate {fs} Hz: give the servo controller's sample rate, 10 Hz to 100 kHz");
    }
    let band = match &args.band {
        Some(b) => crate::identify::parse_band(b)?,
        None => (0.5, fs / 5.0),
    };
    if band.1 > fs / 2.0 {
        bail!(
            "--band {}:{}: the top is above the Nyquist frequency {} Hz of --rate {fs} Hz",
            band.0,
            band.1,
            fs / 2.0
        );
    }
    let params = config
        .rig
        .actuator
        .unwrap_or(ServoHydraulicActuator::REFERENCE);
    let actuator = ForceActuator::new(params, config.rig.actuator_effects)
        .map_err(|e| anyhow!("actuator.reference: {e}"))?;
    let capacity = params.piston_area_m2 * params.supply_pressure_pa;
    let amplitude = args.amplitude.unwrap_or(match args.signal {
        Signal::Sweep => 0.05 * capacity,
        Signal::Noise => 0.02 * capacity,
    });
    if !(amplitude.is_finite() && amplitude > 0.0) {
        bail!("--amplitude {amplitude} N: give a force amplitude > 0 N");
    }
    let offset = args
        .offset
        .unwrap_or_else(|| f64::from(config.limits.safe_demand));
    let reach = offset.abs()
        + match args.signal {
            Signal::Sweep => amplitude,
            Signal::Noise => 4.0 * amplitude,
        };
    if !offset.is_finite() || reach > capacity {
        bail!(
            "--amplitude {amplitude} N about --offset {offset} N reaches {reach:.0} N, beyond the \
             actuator's force capacity {capacity:.0} N (piston area x supply pressure): a test \
             that large measures the pressure limit, not the tracking response (a force in kN \
             given in N?)"
        );
    }
    let signal = match args.signal {
        Signal::Sweep => try_log_sine_sweep(band.0, band.1, args.duration, fs, amplitude),
        Signal::Noise => try_band_limited_noise(
            band.0,
            band.1,
            args.duration,
            fs,
            amplitude,
            false,
            args.seed,
        ),
    }
    .map_err(|e| anyhow!("{e}"))?;
    let command: Vec<f64> = signal.iter().map(|v| v + offset).collect();
    let out = args.out.clone().unwrap_or_else(|| {
        PathBuf::from("out/actuator").join(match args.signal {
            Signal::Sweep => "sweep.csv",
            Signal::Noise => "noise.csv",
        })
    });
    if let Some(folder) = out.parent().filter(|p| !p.as_os_str().is_empty()) {
        crate::cli::check_output_folder(folder)?;
    }
    let test = BlockedRodTest {
        actuator,
        load_cell: config.sensors.force.clone(),
        sample_rate_hz: fs,
        internal_step_s: config.rig.internal_step_s.min(1.0 / fs),
        seed: args.seed.wrapping_add(0x5eed),
    };
    let bar = crate::cli::progress_bar(args.json, 1000, "testing the actuator");
    let force = test
        .run(&command, |f| bar.set_position((f * 1000.0) as u64))
        .map_err(|e| match e {
            // The only sensor is the load cell: name its set-up key.
            ActuatorTestError::Sensor(_) => anyhow!("[sensors] force: {e}"),
            e => anyhow!("{e}"),
        })?;
    bar.finish_and_clear();
    crate::cli::write_atomic(&out, |w| {
        writeln!(w, "{}", COLUMNS.join(","))?;
        for (i, (u, y)) in command.iter().zip(&force).enumerate() {
            writeln!(w, "{:.6},{u:.6},{y:.6}", i as f64 / fs)?;
        }
        Ok(())
    })?;
    Ok(Summary {
        signal: args.signal,
        band_hz: band,
        amplitude_n: amplitude,
        offset_n: offset,
        sample_rate_hz: fs,
        samples: command.len(),
        peak_force_n: force.iter().fold(0.0, |m, v| m.max(v.abs())),
        capacity_n: capacity,
        next: format!(
            "mil identify --data {} --input force_command --output force --band {}:{}",
            out.display(),
            band.0,
            band.1
        ),
        record: out.display().to_string(),
    })
}

impl Summary {
    /// The summary as lines of text.
    pub fn text(&self) -> String {
        format!(
            "blocked-rod {} test, {}-{} Hz, amplitude {:.0} N about {:.0} N, {} samples at {} \
             Hz\npeak load-cell force {:.0} N of the actuator's {:.0} N capacity\nwrote {}\n\
             next: {}",
            match self.signal {
                Signal::Sweep => "sine-sweep",
                Signal::Noise => "noise",
            },
            self.band_hz.0,
            self.band_hz.1,
            self.amplitude_n,
            self.offset_n,
            self.samples,
            self.sample_rate_hz,
            self.peak_force_n,
            self.capacity_n,
            self.record,
            self.next
        )
    }
}
