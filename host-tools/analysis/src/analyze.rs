//! A complete analysis of one set-up: responses of the MiL and the emulated system over a
//! frequency grid, open-loop margins, resonances, band errors and noise sensitivity.

use crate::error::{setup_error, Result};
use crate::metrics::{
    band_errors, characteristic_loci, log_grid, margins, max_singular_value, resonances, BandError,
    Margins, Resonance, Stability,
};
use crate::system::{CMatrix, Loop, LoopPoint, MilSystem};
use num_complex::Complex64;
use serde::Serialize;

/// A signal of the loop that a response can be taken at.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Signal {
    /// Position of a physical DOF (by index).
    Physical(usize),
    /// Position of a numerical DOF.
    Numerical(usize),
    /// True interface force on the physical part, channel `k`.
    InterfaceForce(usize),
    /// Actuator command, channel `k`.
    Command(usize),
    /// Measured interface signal, channel `k`.
    Measured(usize),
}

impl Signal {
    /// Parses `physical:<dof>`, `numerical:<dof>`, `interface_force[:k]`, `command[:k]`,
    /// `measured[:k]`.
    ///
    /// # Errors
    /// Unknown kinds, DOFs or channels.
    pub fn parse(text: &str, system: &MilSystem) -> Result<Self> {
        let (kind, arg) = text.split_once(':').unwrap_or((text, ""));
        let channel = || -> Result<usize> {
            let k = if arg.is_empty() {
                0
            } else {
                arg.parse::<usize>()
                    .map_err(|_| setup_error(format!("bad channel in signal {text:?}")))?
            };
            if k >= system.channels() {
                return Err(setup_error(format!(
                    "signal {text:?}: channel {k} does not exist ({} channels)",
                    system.channels()
                )));
            }
            Ok(k)
        };
        let dof = |part: &crate::system::MechanicalPart, which: &str| {
            part.index(arg).ok_or_else(|| {
                setup_error(format!(
                    "signal {text:?}: no {which} DOF {arg:?} (DOFs: {:?})",
                    part.dofs
                ))
            })
        };
        Ok(match kind {
            "physical" => Self::Physical(dof(&system.physical, "physical")?),
            "numerical" => Self::Numerical(dof(&system.numerical, "numerical")?),
            "interface_force" => Self::InterfaceForce(channel()?),
            "command" => Self::Command(channel()?),
            "measured" => Self::Measured(channel()?),
            _ => {
                return Err(setup_error(format!(
                    "unknown signal {text:?}: use physical:<dof>, numerical:<dof>, \
                     interface_force[:k], command[:k] or measured[:k]"
                )))
            }
        })
    }

    /// This signal's response to input `input` at one loop point.
    pub fn pick(&self, point: &LoopPoint, input: usize) -> Complex64 {
        let (m, row): (&CMatrix, usize) = match *self {
            Self::Physical(j) => (&point.physical, j),
            Self::Numerical(j) => (&point.numerical, j),
            Self::InterfaceForce(k) => (&point.interface_force, k),
            Self::Command(k) => (&point.command, k),
            Self::Measured(k) => (&point.measured, k),
        };
        m[(row, input)]
    }
}

/// One input-to-output response to report.
#[derive(Clone, Debug)]
pub struct ResponseSpec {
    /// Name for reports and plots.
    pub name: String,
    /// Input index into [`MilSystem::inputs`].
    pub input: usize,
    /// Output signal.
    pub output: Signal,
    /// Factor from SI to the display unit (e.g. 1e-3 for N/m shown as N/mm).
    pub display_scale: f64,
    /// Display unit, e.g. "N/mm".
    pub display_unit: String,
}

/// Options of an analysis run.
#[derive(Clone, Debug)]
pub struct AnalysisOptions {
    /// Lowest grid frequency (Hz).
    pub f_min_hz: f64,
    /// Highest grid frequency (Hz).
    pub f_max_hz: f64,
    /// Grid density.
    pub points_per_decade: usize,
    /// Bands (Hz) for MiL-vs-emulated errors.
    pub bands: Vec<(f64, f64)>,
    /// Responses to report.
    pub responses: Vec<ResponseSpec>,
    /// Minimum prominence of a resonance peak (dB).
    pub min_prominence_db: f64,
    /// RMS measurement noise per channel (m for measured positions, N for forces), white up
    /// to the Nyquist frequency.
    pub noise_rms: f64,
    /// Nyquist frequency of the control loop (Hz); the noise-sensitivity figures use
    /// 60 Hz to this frequency.
    pub nyquist_hz: f64,
}

/// Figures of one loop (MiL or emulated).
#[derive(Clone, Debug, Serialize)]
pub struct LoopFigures {
    /// Gain margin (`None`/null: no phase crossover).
    pub gain_margin: Option<f64>,
    /// Phase-crossover frequency (Hz).
    pub gain_margin_hz: Option<f64>,
    /// Phase margin (degrees).
    pub phase_margin_deg: Option<f64>,
    /// Gain-crossover frequency (Hz).
    pub phase_margin_hz: Option<f64>,
    /// Resonances of the first reported response.
    pub resonances: Vec<Resonance>,
    /// Closed-loop stability (argument principle).
    pub stability: Stability,
}

impl LoopFigures {
    fn new(m: Margins, resonances: Vec<Resonance>, stability: Stability) -> Self {
        let (gain_margin, gain_margin_hz) = m.reported_gain_margin(stability);
        Self {
            stability,
            gain_margin,
            gain_margin_hz,
            phase_margin_deg: m.phase_margin_deg,
            phase_margin_hz: m.phase_margin_hz,
            resonances,
        }
    }
}

/// Figures of one reported response.
#[derive(Clone, Debug, Serialize)]
pub struct ResponseFigures {
    /// Name.
    pub name: String,
    /// Display unit of magnitudes.
    pub unit: String,
    /// Resonances of the MiL response (magnitudes in display units).
    pub mil_resonances: Vec<Resonance>,
    /// Resonances of the emulated response.
    pub emulated_resonances: Vec<Resonance>,
    /// MiL-vs-emulated errors per band.
    pub band_errors: Vec<BandError>,
}

/// Noise-sensitivity figures (actuator command per unit measurement noise).
#[derive(Clone, Copy, Debug, Serialize)]
pub struct NoiseFigures {
    /// Peak control sensitivity over the grid (command units per measurement unit, SI).
    pub peak: f64,
    /// Frequency of that peak (Hz).
    pub peak_hz: f64,
    /// Peak between 60 Hz and the Nyquist frequency.
    pub peak_above_60hz: f64,
    /// Frequency of that peak (Hz).
    pub peak_above_60hz_hz: f64,
    /// RMS actuator command caused by the stated measurement noise (command units).
    pub command_rms: f64,
}

/// The result of [`analyze`].
#[derive(Clone, Debug, Serialize)]
pub struct AnalysisReport {
    /// The paper's configuration number (1–4).
    pub configuration: u8,
    /// Interface channels.
    pub channels: usize,
    /// The MiL loop's elements (actuator, delay, velocity estimate, command filter).
    pub mil_loop: crate::system::LoopDescription,
    /// MiL loop figures.
    pub mil: LoopFigures,
    /// Emulated loop figures.
    pub emulated: LoopFigures,
    /// Every reported response.
    pub responses: Vec<ResponseFigures>,
    /// Control sensitivity of the MiL loop.
    pub noise: NoiseFigures,
    /// The grid and traces, for plots and CSV (not serialised).
    #[serde(skip)]
    pub traces: Traces,
}

/// Responses on the grid.
#[derive(Clone, Debug, Default)]
pub struct Traces {
    /// Grid (Hz).
    pub frequency_hz: Vec<f64>,
    /// Per reported response: MiL values (display units).
    pub mil: Vec<Vec<Complex64>>,
    /// Per reported response: emulated values (display units).
    pub emulated: Vec<Vec<Complex64>>,
    /// Characteristic loci of the MiL open loop.
    pub mil_open_loop: Vec<Vec<Complex64>>,
    /// Characteristic loci of the emulated open loop.
    pub emulated_open_loop: Vec<Vec<Complex64>>,
    /// Largest singular value of the control sensitivity on the grid (SI).
    pub noise_sensitivity: Vec<f64>,
}

/// Loop points of one loop on a grid.
///
/// # Errors
/// As [`MilSystem::point`].
pub fn sweep(system: &MilSystem, grid: &[f64], which: Loop) -> Result<Vec<LoopPoint>> {
    grid.iter().map(|&f| system.point(f, which)).collect()
}

/// Peak of `values` over grid points within `[from, to]`: `(peak, frequency)`.
pub fn peak_in(grid: &[f64], values: &[f64], from: f64, to: f64) -> (f64, f64) {
    grid.iter()
        .zip(values)
        .filter(|(f, _)| **f >= from && **f <= to)
        .fold(
            (0.0, f64::NAN),
            |(p, fp), (f, v)| {
                if *v > p {
                    (*v, *f)
                } else {
                    (p, fp)
                }
            },
        )
}

/// RMS command from white measurement noise of RMS `noise_rms` on every channel, spread
/// evenly over 0…`nyquist_hz`, through the control sensitivity `sigma` (trapezoidal rule
/// over the part of the grid below the Nyquist frequency; each channel's noise independent).
fn command_rms(grid: &[f64], points: &[LoopPoint], noise_rms: f64, nyquist_hz: f64) -> f64 {
    let psd = noise_rms * noise_rms / nyquist_hz;
    let power: Vec<(f64, f64)> = grid
        .iter()
        .zip(points)
        .filter(|(f, _)| **f <= nyquist_hz)
        .map(|(f, p)| {
            let s = &p.noise_to_command;
            // Largest row sum of |S_kj|²: the worst channel's command.
            let worst = (0..s.nrows())
                .map(|k| (0..s.ncols()).map(|j| s[(k, j)].norm_sqr()).sum::<f64>())
                .fold(0.0, f64::max);
            (*f, worst)
        })
        .collect();
    let integral: f64 = power
        .windows(2)
        .map(|w| 0.5 * (w[0].1 + w[1].1) * (w[1].0 - w[0].0))
        .sum();
    (integral * psd).sqrt()
}

/// Runs the analysis.
///
/// # Errors
/// Invalid set-up or options, or a singular loop at some frequency.
pub fn analyze(system: &MilSystem, options: &AnalysisOptions) -> Result<AnalysisReport> {
    system.validate()?;
    if !(options.f_min_hz > 0.0 && options.f_max_hz > options.f_min_hz) {
        return Err(setup_error(
            "analysis frequency range must be 0 < f_min < f_max",
        ));
    }
    if options.responses.is_empty() {
        return Err(setup_error("no responses to analyse"));
    }
    let grid = log_grid(
        options.f_min_hz,
        options.f_max_hz,
        options.points_per_decade,
    );
    let mil = sweep(system, &grid, Loop::Mil)?;
    let emulated = sweep(system, &grid, Loop::Emulated)?;
    let mil_loci =
        characteristic_loci(&mil.iter().map(|p| p.open_loop.clone()).collect::<Vec<_>>());
    let emu_loci = characteristic_loci(
        &emulated
            .iter()
            .map(|p| p.open_loop.clone())
            .collect::<Vec<_>>(),
    );

    let mut traces = Traces {
        frequency_hz: grid.clone(),
        mil_open_loop: mil_loci.clone(),
        emulated_open_loop: emu_loci.clone(),
        noise_sensitivity: mil
            .iter()
            .map(|p| max_singular_value(&p.noise_to_command))
            .collect(),
        ..Traces::default()
    };
    let mut responses = Vec::new();
    for spec in &options.responses {
        let trace = |pts: &[LoopPoint]| -> Vec<Complex64> {
            pts.iter()
                .map(|p| spec.output.pick(p, spec.input) * spec.display_scale)
                .collect()
        };
        let (hm, he) = (trace(&mil), trace(&emulated));
        let peaks = |h: &[Complex64], which: Loop| {
            let mag: Vec<f64> = h.iter().map(|v| v.norm()).collect();
            resonances(&grid, &mag, options.min_prominence_db, |f| {
                system
                    .point(f, which)
                    .ok()
                    .map(|p| (spec.output.pick(&p, spec.input) * spec.display_scale).norm())
            })
        };
        responses.push(ResponseFigures {
            name: spec.name.clone(),
            unit: spec.display_unit.clone(),
            mil_resonances: peaks(&hm, Loop::Mil),
            emulated_resonances: peaks(&he, Loop::Emulated),
            band_errors: band_errors(&grid, &hm, &he, &options.bands),
        });
        traces.mil.push(hm);
        traces.emulated.push(he);
    }
    let (peak, peak_hz) = peak_in(&grid, &traces.noise_sensitivity, 0.0, f64::INFINITY);
    let (peak_above_60hz, peak_above_60hz_hz) =
        peak_in(&grid, &traces.noise_sensitivity, 60.0, options.nyquist_hz);
    let noise = NoiseFigures {
        peak,
        peak_hz,
        peak_above_60hz,
        peak_above_60hz_hz,
        command_rms: command_rms(&grid, &mil, options.noise_rms, options.nyquist_hz),
    };
    let first = &responses[0];
    Ok(AnalysisReport {
        configuration: system.configuration(),
        channels: system.channels(),
        mil_loop: system.describe_loop(),
        mil: LoopFigures::new(
            margins(&grid, &mil_loci),
            first.mil_resonances.clone(),
            system.stability(Loop::Mil),
        ),
        emulated: LoopFigures::new(
            margins(&grid, &emu_loci),
            first.emulated_resonances.clone(),
            system.stability(Loop::Emulated),
        ),
        responses,
        noise,
        traces,
    })
}
