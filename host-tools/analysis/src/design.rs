//! Command-filter design: the paper's least-squares method (its section 4.3) and an
//! optimised design that trades MiL-vs-emulated error against noise sensitivity (the
//! paper's stated future work).
//!
//! ## The filter
//! The command filter `F(s)` shapes the numerical model's output before it drives the
//! actuators (the same filter on every channel). Its poles are fixed by a
//! [`FilterStructure`]: `poles` roll-off poles at `rolloff_hz` (pairs with damping
//! `rolloff_damping`, one real pole when the count is odd), normalised to unit DC gain;
//! its numerator has `zeros` + 1 free coefficients. With fewer zeros than poles the filter
//! rolls off at `20 (poles − zeros)` dB/decade above the roll-off frequency, which limits
//! how much measurement noise it amplifies.
//!
//! ## Least-squares design ([`design_ls`])
//! With `P(jω)` the actuator tracking response and `τ` the loop delay, the numerator
//! coefficients minimise `Σ_k |F(jω_k) P(jω_k) e^{−jω_kτ} − 1|²` on a linear grid over the
//! fit band (0.1–30 Hz by default), a linear least-squares problem because the poles are
//! fixed. The static gain is constrained: `F(0) P(0) = 1` exactly when `P(0)` is known (a
//! model), so that the MiL system keeps the emulated system's static behaviour.
//!
//! ## Figures ([`FilterFigures`], defined once, used everywhere)
//! - *Command path*: `F(jω) P(jω) e^{−jωτ}`, from the numerical model's output to the
//!   actuator's output, including the loop delay (which the filter must also cancel).
//! - *Mean phase lag*: the mean of `|phase|` (degrees) of the command path on a linear
//!   0.1 Hz grid over the figures band (0.5–30 Hz); `|·|` so that over-compensation (lead)
//!   counts as error, not as a credit. *Phase-lag reduction* = `1 − lag(F P)/lag(P)` (%).
//! - *Magnitude error*: the worst `|20 log10 |F P e^{−jωτ}||` over the same band (dB).
//! - *Noise sensitivity*: the largest singular value of the closed-loop control sensitivity
//!   (actuator command per unit measurement noise, including the filter); its peak from
//!   60 Hz to the Nyquist frequency with the filter divided by the same peak without it is
//!   the *noise-sensitivity ratio*. The paper's figure ("about 30 times larger than before at
//!   around 100 Hz") compares the two at one frequency: reported as
//!   [`FilterFigures::noise_ratio_at_peak`], the pointwise ratio at the frequency where the
//!   filtered sensitivity peaks.
//! - *Gain margin with filter* of the MiL loop, and the closed-loop stability.
//! - *Response error*: RMS over the figures band (log grid) of `|H_MiL/H_emulated − 1|` of
//!   the set-up's first response (%), the MiL-vs-emulated accuracy the filter is for.
//!
//! ## Optimised design ([`design_optimal`])
//! Minimises `J = (1 − w) E/E₀ + w S/S₀` over the numerator coefficients and the roll-off
//! frequency and damping, where `E` is the response error, `S` the noise-sensitivity peak
//! (60 Hz to Nyquist), `E₀`, `S₀` their values for the least-squares design, subject to
//! the target's gain margin and command-path magnitude error and an out-of-band
//! amplification ([`FilterFigures::out_of_band_amplification`]) no worse than the
//! least-squares design's (penalties: without the last, the error term, measured in the
//! figures band, is cheapest to cut by pushing the lightly damped MiL resonance just above
//! the band instead of damping it), and a roll-off
//! between twice the fit band and a quarter of the sample rate, by Nelder–Mead from the
//! least-squares design. Sweeping `w` gives the trade-off front; every point is
//! discretised and its figures (including closed-loop stability) computed on the cascade.

use crate::error::{AnalysisError, Result};
use crate::metrics::{
    characteristic_loci, linear_grid, log_grid, margins, max_singular_value, Stability,
};
use crate::response::CommandFilter;
use crate::system::{Loop, MilSystem};
use mil_discretise::TransferFunction;
use model_core::CascadeCoefficients;
use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;
use serde::Serialize;
use std::f64::consts::TAU;

fn design_error(message: impl Into<String>) -> AnalysisError {
    AnalysisError::Design(message.into())
}

/// Pole structure of a command filter.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FilterStructure {
    /// Frequency of the roll-off poles (Hz).
    pub rolloff_hz: f64,
    /// Damping ratio of the roll-off pole pairs (0 < ζ).
    pub rolloff_damping: f64,
    /// Number of poles (1–8).
    pub poles: usize,
    /// Number of zeros (< `poles`; the numerator has `zeros + 1` coefficients).
    pub zeros: usize,
}

impl FilterStructure {
    /// The paper's structure: roll-off above 100 Hz.
    pub const PAPER: Self = Self {
        rolloff_hz: 100.0,
        rolloff_damping: 0.5,
        poles: 4,
        zeros: 3,
    };

    fn validate(&self) -> Result<()> {
        if !(self.rolloff_hz.is_finite() && self.rolloff_hz > 0.0) {
            return Err(design_error("roll-off frequency must be > 0"));
        }
        if !(self.rolloff_damping.is_finite() && self.rolloff_damping > 0.0) {
            return Err(design_error("roll-off damping must be > 0"));
        }
        if !(1..=8).contains(&self.poles) || self.zeros >= self.poles {
            return Err(design_error(format!(
                "need 1 ≤ poles ≤ 8 and zeros < poles (got {} poles, {} zeros)",
                self.poles, self.zeros
            )));
        }
        Ok(())
    }

    /// Denominator in the normalised variable `σ = s/ω_r`, ascending powers, `D(0) = 1`.
    fn denominator_normalised(&self) -> Vec<f64> {
        let mut d = vec![1.0];
        for _ in 0..self.poles / 2 {
            d = crate::poly::mul(&d, &[1.0, 2.0 * self.rolloff_damping, 1.0]);
        }
        if self.poles % 2 == 1 {
            d = crate::poly::mul(&d, &[1.0, 1.0]);
        }
        d
    }
}

fn eval_ascending(c: &[f64], x: Complex64) -> Complex64 {
    c.iter()
        .rev()
        .fold(Complex64::new(0.0, 0.0), |acc, v| acc * x + v)
}

/// A continuous command filter: numerator coefficients in `σ = s/ω_r` over the structure's
/// denominator.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ContinuousFilter {
    /// The pole structure.
    pub structure: FilterStructure,
    /// Numerator coefficients in ascending powers of `σ = s/(2π rolloff_hz)`.
    pub numerator_normalised: Vec<f64>,
}

impl ContinuousFilter {
    /// Response at a complex `s` (rad/s).
    pub fn response_s(&self, s: Complex64) -> Complex64 {
        let sigma = s / (TAU * self.structure.rolloff_hz);
        eval_ascending(&self.numerator_normalised, sigma)
            / eval_ascending(&self.structure.denominator_normalised(), sigma)
    }

    /// The transfer function in `s` (rad/s), descending powers.
    ///
    /// # Errors
    /// Non-finite coefficients.
    pub fn transfer_function(&self) -> Result<TransferFunction> {
        let w = TAU * self.structure.rolloff_hz;
        let unscale = |c: &[f64]| -> Vec<f64> {
            c.iter()
                .enumerate()
                .map(|(k, v)| v / w.powi(k as i32))
                .rev()
                .collect()
        };
        Ok(TransferFunction::new(
            unscale(&self.numerator_normalised),
            unscale(&self.structure.denominator_normalised()),
        )?)
    }

    /// Discretises with Tustin (pre-warped at the roll-off frequency, so the roll-off
    /// corner stays where it was designed) into model-core's f32 delta-form cascade.
    ///
    /// # Errors
    /// Discretisation failures or a cascade model-core refuses.
    pub fn discretise(&self, sample_rate_hz: f64) -> Result<CascadeCoefficients> {
        let dt = 1.0 / sample_rate_hz;
        let prewarp = (self.structure.rolloff_hz < 0.45 * sample_rate_hz)
            .then_some(self.structure.rolloff_hz);
        let cascade =
            mil_discretise::tustin_tf(&self.transfer_function()?, dt, prewarp)?.to_cascade()?;
        cascade
            .validate()
            .map_err(|e| design_error(format!("model-core rejects the cascade: {e}")))?;
        Ok(cascade)
    }
}

/// Frequency bands and grids of a design.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct DesignOptions {
    /// Lowest frequency of the least-squares fit (Hz).
    pub fit_from_hz: f64,
    /// Highest frequency of the least-squares fit (Hz).
    pub fit_to_hz: f64,
    /// Band of the phase-lag, magnitude and response-error figures (Hz).
    pub figures_band_hz: (f64, f64),
    /// Lowest frequency of the noise-sensitivity peak (Hz); the peak runs to Nyquist.
    pub noise_from_hz: f64,
    /// Control loop rate (Hz); the exported cascade is for this rate.
    pub sample_rate_hz: f64,
    /// Pole structure.
    pub structure: FilterStructure,
}

impl DesignOptions {
    /// The paper's design at `sample_rate_hz`: fit 0.1–30 Hz, figures 0.5–30 Hz, noise peak
    /// from 60 Hz, [`FilterStructure::PAPER`].
    pub fn paper(sample_rate_hz: f64) -> Self {
        Self {
            fit_from_hz: 0.1,
            fit_to_hz: 30.0,
            figures_band_hz: (0.5, 30.0),
            noise_from_hz: 60.0,
            sample_rate_hz,
            structure: FilterStructure::PAPER,
        }
    }

    fn validate(&self) -> Result<()> {
        self.structure.validate()?;
        let nyquist = 0.5 * self.sample_rate_hz;
        let (lo, hi) = self.figures_band_hz;
        let ok = self.sample_rate_hz.is_finite()
            && self.fit_from_hz > 0.0
            && self.fit_to_hz > self.fit_from_hz
            && self.fit_to_hz < nyquist
            && lo > 0.0
            && hi > lo
            && hi < nyquist
            && self.noise_from_hz > 0.0
            && self.noise_from_hz < nyquist;
        if ok {
            Ok(())
        } else {
            Err(design_error(
                "design bands must be positive, ordered and below the Nyquist frequency",
            ))
        }
    }

    fn nyquist_hz(&self) -> f64 {
        0.5 * self.sample_rate_hz
    }
}

/// The design figures of one filter on one set-up (see the module documentation for the
/// definitions).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FilterFigures {
    /// Mean |phase| of the command path without filter over the figures band (degrees).
    pub mean_phase_lag_without_deg: f64,
    /// Mean |phase| of the command path with the filter (degrees).
    pub mean_phase_lag_with_deg: f64,
    /// `1 − with/without` (%).
    pub phase_lag_reduction_pct: f64,
    /// Worst |magnitude| of the command path with the filter over the band (dB).
    pub magnitude_error_db: f64,
    /// Worst |magnitude| of the command path without filter over the band (dB).
    pub magnitude_error_without_db: f64,
    /// Peak control sensitivity from the noise band's start to Nyquist, no filter
    /// (command units per measurement unit, e.g. N/m).
    pub noise_peak_without: f64,
    /// Its frequency (Hz).
    pub noise_peak_without_hz: f64,
    /// Peak control sensitivity with the filter.
    pub noise_peak_with: f64,
    /// Its frequency (Hz).
    pub noise_peak_with_hz: f64,
    /// `noise_peak_with / noise_peak_without`.
    pub noise_sensitivity_ratio: f64,
    /// With/without control sensitivity at `noise_peak_with_hz` (the paper's comparison).
    pub noise_ratio_at_peak: f64,
    /// Gain margin of the MiL loop without filter (`None`: no phase crossover).
    pub gain_margin_without: Option<f64>,
    /// Gain margin of the MiL loop with the filter.
    pub gain_margin_with_filter: Option<f64>,
    /// Frequency of the gain margin with the filter (Hz).
    pub gain_margin_with_filter_hz: Option<f64>,
    /// Phase margin with the filter (degrees).
    pub phase_margin_with_filter_deg: Option<f64>,
    /// Closed-loop stability with the filter.
    pub stability_with_filter: Stability,
    /// RMS relative MiL-vs-emulated error of the first response without filter (%).
    pub response_error_without_pct: f64,
    /// The same with the filter (%).
    pub response_error_with_pct: f64,
    /// Worst `|H_MiL/H_emulated|` of the first response above the figures band up to
    /// Nyquist, with the filter: a lead filter can move the lightly damped MiL resonance
    /// above the band instead of removing it; this says by how much it amplifies there.
    pub out_of_band_amplification: f64,
    /// Its frequency (Hz).
    pub out_of_band_amplification_hz: f64,
}

/// Which response the response-error figure uses: `(output, input)` picked from a loop
/// point, e.g. the interface force per road input.
pub type ResponsePick = dyn Fn(&crate::system::LoopPoint) -> Complex64 + Sync;

/// Pre-computed, filter-independent parts of the figures.
struct Baseline {
    band_grid: Vec<f64>,
    command_path: Vec<Complex64>,
    error_grid: Vec<f64>,
    emulated: Vec<Complex64>,
    noise_grid: Vec<f64>,
    margin_grid: Vec<f64>,
    above_grid: Vec<f64>,
    above_emulated: Vec<Complex64>,
    /// Control sensitivity without filter on `noise_grid`.
    noise_without: Vec<f64>,
    /// Reported gain margin of the MiL loop without filter.
    gain_margin_without: Option<f64>,
    /// RMS MiL-vs-emulated error without filter (%).
    response_error_without_pct: f64,
}

/// A copy of `system` with `filter` in place of its command filter.
pub fn with_filter(system: &MilSystem, filter: Option<CommandFilter>) -> MilSystem {
    let mut s = system.clone();
    s.filter = filter;
    s
}

impl Baseline {
    fn new(system: &MilSystem, options: &DesignOptions, pick: &ResponsePick) -> Result<Self> {
        let (lo, hi) = options.figures_band_hz;
        let band_grid = linear_grid(lo, hi, 0.1);
        let command_path = band_grid
            .iter()
            .map(|&f| command_path(system, f))
            .collect::<Result<Vec<_>>>()?;
        let error_grid = log_grid(lo, hi, 40);
        let emulated = error_grid
            .iter()
            .map(|&f| Ok(pick(&system.point(f, Loop::Emulated)?)))
            .collect::<Result<Vec<_>>>()?;
        let noise_grid = log_grid(options.noise_from_hz, options.nyquist_hz(), 60);
        let margin_grid = log_grid(0.1, options.nyquist_hz(), 150);
        let above_grid = log_grid(hi, options.nyquist_hz(), 60);
        let above_emulated = above_grid
            .iter()
            .map(|&f| Ok(pick(&system.point(f, Loop::Emulated)?)))
            .collect::<Result<Vec<_>>>()?;
        let noise_without = noise_trace(system, &noise_grid)?;
        let gain_margin_without = gain_margin(system, &margin_grid)?
            .reported_gain_margin(system.stability(Loop::Mil))
            .0;
        let mut base = Self {
            above_grid,
            above_emulated,
            band_grid,
            command_path,
            error_grid,
            emulated,
            noise_grid,
            margin_grid,
            noise_without,
            gain_margin_without,
            response_error_without_pct: 0.0,
        };
        base.response_error_without_pct = response_error_pct(system, &base, pick)?;
        Ok(base)
    }
}

/// The command path without filter at `frequency_hz` (Hz): the actuator tracking response
/// times the loop delay (the same on every channel).
///
/// # Errors
/// A tracking table that does not cover the frequency.
pub fn command_path(system: &MilSystem, frequency_hz: f64) -> Result<Complex64> {
    let p = system.actuators.tracking.response(frequency_hz)?;
    Ok(p * Complex64::from_polar(1.0, -TAU * frequency_hz * system.actuators.loop_delay_s))
}

fn mean_abs_phase_deg(values: &[Complex64]) -> f64 {
    let phase = crate::metrics::unwrapped_phase_deg(values);
    phase.iter().map(|p| p.abs()).sum::<f64>() / phase.len().max(1) as f64
}

fn worst_db(values: &[Complex64]) -> f64 {
    values
        .iter()
        .map(|v| (20.0 * v.norm().log10()).abs())
        .fold(0.0, f64::max)
}

fn noise_trace(system: &MilSystem, grid: &[f64]) -> Result<Vec<f64>> {
    grid.iter()
        .map(|&f| {
            Ok(max_singular_value(
                &system.point(f, Loop::Mil)?.noise_to_command,
            ))
        })
        .collect()
}

fn argmax(values: &[f64]) -> usize {
    values
        .iter()
        .enumerate()
        .fold((0, f64::NEG_INFINITY), |(bi, bv), (i, &v)| {
            if v > bv {
                (i, v)
            } else {
                (bi, bv)
            }
        })
        .0
}

fn response_error_pct(system: &MilSystem, base: &Baseline, pick: &ResponsePick) -> Result<f64> {
    let mut sum = 0.0;
    for (f, emu) in base.error_grid.iter().zip(&base.emulated) {
        let mil = pick(&system.point(*f, Loop::Mil)?);
        sum += (mil / emu - 1.0).norm_sqr();
    }
    Ok(100.0 * (sum / base.error_grid.len() as f64).sqrt())
}

fn gain_margin(system: &MilSystem, grid: &[f64]) -> Result<crate::metrics::Margins> {
    let points = grid
        .iter()
        .map(|&f| Ok(system.point(f, Loop::Mil)?.open_loop))
        .collect::<Result<Vec<_>>>()?;
    Ok(margins(grid, &characteristic_loci(&points)))
}

/// The design figures of `filter` on `system` (the filter replaces any filter the system
/// has).
///
/// # Errors
/// Invalid options or a singular loop.
pub fn filter_figures(
    system: &MilSystem,
    filter: &CommandFilter,
    options: &DesignOptions,
    pick: &ResponsePick,
) -> Result<FilterFigures> {
    options.validate()?;
    let bare = with_filter(system, None);
    let base = Baseline::new(&bare, options, pick)?;
    figures_with(&bare, &base, filter, pick)
}

fn figures_with(
    bare: &MilSystem,
    base: &Baseline,
    filter: &CommandFilter,
    pick: &ResponsePick,
) -> Result<FilterFigures> {
    let filtered = with_filter(bare, Some(filter.clone()));
    let path_with: Vec<Complex64> = base
        .band_grid
        .iter()
        .zip(&base.command_path)
        .map(|(f, p)| filter.response(*f) * p)
        .collect();
    let lag_without = mean_abs_phase_deg(&base.command_path);
    let lag_with = mean_abs_phase_deg(&path_with);
    let noise_without = &base.noise_without;
    let noise_with = noise_trace(&filtered, &base.noise_grid)?;
    let (iw, io) = (argmax(&noise_with), argmax(noise_without));
    let margins_with = gain_margin(&filtered, &base.margin_grid)?;
    let stability_with_filter = filtered.stability(Loop::Mil);
    let gm_with = margins_with.reported_gain_margin(stability_with_filter);
    let above = base
        .above_grid
        .iter()
        .zip(&base.above_emulated)
        .map(|(f, emu)| Ok((pick(&filtered.point(*f, Loop::Mil)?) / emu).norm()))
        .collect::<Result<Vec<_>>>()?;
    let ia = argmax(&above);
    Ok(FilterFigures {
        mean_phase_lag_without_deg: lag_without,
        mean_phase_lag_with_deg: lag_with,
        phase_lag_reduction_pct: 100.0 * (1.0 - lag_with / lag_without),
        magnitude_error_db: worst_db(&path_with),
        magnitude_error_without_db: worst_db(&base.command_path),
        noise_peak_without: noise_without[io],
        noise_peak_without_hz: base.noise_grid[io],
        noise_peak_with: noise_with[iw],
        noise_peak_with_hz: base.noise_grid[iw],
        noise_sensitivity_ratio: noise_with[iw] / noise_without[io],
        noise_ratio_at_peak: noise_with[iw] / noise_without[iw],
        gain_margin_without: base.gain_margin_without,
        gain_margin_with_filter: gm_with.0,
        gain_margin_with_filter_hz: gm_with.1,
        phase_margin_with_filter_deg: margins_with.phase_margin_deg,
        stability_with_filter,
        response_error_without_pct: base.response_error_without_pct,
        response_error_with_pct: response_error_pct(&filtered, base, pick)?,
        out_of_band_amplification: above[ia],
        out_of_band_amplification_hz: base.above_grid[ia],
    })
}

/// A designed filter: the continuous design, the exported cascade and its figures.
#[derive(Clone, Debug)]
pub struct FilterDesign {
    /// The continuous design.
    pub continuous: ContinuousFilter,
    /// The f32 cascade at the options' sample rate (what runs on the board).
    pub cascade: CascadeCoefficients,
    /// Figures of the discrete cascade (not of the continuous design).
    pub figures: FilterFigures,
}

impl FilterDesign {
    /// The cascade as a [`CommandFilter`] at `sample_rate_hz`.
    pub fn command_filter(&self, sample_rate_hz: f64) -> CommandFilter {
        CommandFilter::Discrete {
            cascade: self.cascade,
            sample_period_s: 1.0 / sample_rate_hz,
        }
    }

    /// Refuses a design that may not be exported: the closed loop must be stable (or, with
    /// measured tables, at least keep a gain margin above 1).
    ///
    /// # Errors
    /// [`AnalysisError::Design`] naming the problem.
    pub fn check_exportable(&self) -> Result<()> {
        match self.figures.stability_with_filter {
            Stability::Stable => Ok(()),
            Stability::Unstable(n) => Err(design_error(format!(
                "the MiL loop with this filter is unstable ({n} closed-loop poles in the right \
                 half-plane)"
            ))),
            Stability::Unknown => match self.figures.gain_margin_with_filter {
                Some(gm) if gm <= 1.0 => Err(design_error(format!(
                    "gain margin with this filter is {gm:.2} (≤ 1)"
                ))),
                _ => Ok(()),
            },
        }
    }
}

/// Least-squares numerator for a fixed pole structure (see the module documentation).
///
/// # Errors
/// A tracking response that cannot be evaluated on the fit band, or a singular fit.
pub fn fit_numerator(
    system: &MilSystem,
    structure: FilterStructure,
    options: &DesignOptions,
) -> Result<ContinuousFilter> {
    structure.validate()?;
    let grid = linear_grid(options.fit_from_hz, options.fit_to_hz, 0.1);
    let wr = TAU * structure.rolloff_hz;
    let den = structure.denominator_normalised();
    let n = structure.zeros + 1;
    // Static gain constraint F(0) P(0) = 1 when P(0) is known (a model's, or a measured
    // table's at its lowest frequency).
    let dc = system
        .actuators
        .tracking
        .static_gain()
        .filter(|p0| p0.is_finite() && p0.abs() > 1e-9)
        .map(|p0| 1.0 / p0);
    let first_free = usize::from(dc.is_some());
    let unknowns = n - first_free;
    let rows = 2 * grid.len();
    let mut a = DMatrix::<f64>::zeros(rows, unknowns.max(1));
    let mut b = DVector::<f64>::zeros(rows);
    for (k, &f) in grid.iter().enumerate() {
        let sigma = Complex64::new(0.0, TAU * f / wr);
        let g = command_path(system, f)? / eval_ascending(&den, sigma);
        // residual = g Σ n_j σ^j − 1
        let mut target = Complex64::new(1.0, 0.0);
        if let Some(n0) = dc {
            target -= g * n0;
        }
        for j in first_free..n {
            let col = g * sigma.powi(j as i32);
            a[(2 * k, j - first_free)] = col.re;
            a[(2 * k + 1, j - first_free)] = col.im;
        }
        b[2 * k] = target.re;
        b[2 * k + 1] = target.im;
    }
    let mut coefficients = Vec::with_capacity(n);
    if let Some(n0) = dc {
        coefficients.push(n0);
    }
    if unknowns > 0 {
        let x = a
            .svd(true, true)
            .solve(&b, 1e-12)
            .map_err(|e| design_error(format!("least-squares fit failed: {e}")))?;
        coefficients.extend(x.iter());
    }
    if coefficients.iter().any(|c| !c.is_finite()) {
        return Err(design_error(
            "least-squares fit gave non-finite coefficients",
        ));
    }
    Ok(ContinuousFilter {
        structure,
        numerator_normalised: coefficients,
    })
}

/// The paper's least-squares design, discretised, with its figures.
///
/// # Errors
/// Invalid options, a failed fit or discretisation.
pub fn design_ls(
    system: &MilSystem,
    options: &DesignOptions,
    pick: &ResponsePick,
) -> Result<FilterDesign> {
    options.validate()?;
    let bare = with_filter(system, None);
    let base = Baseline::new(&bare, options, pick)?;
    let continuous = fit_numerator(&bare, options.structure, options)?;
    finish(&bare, &base, continuous, options, pick)
}

fn finish(
    bare: &MilSystem,
    base: &Baseline,
    continuous: ContinuousFilter,
    options: &DesignOptions,
    pick: &ResponsePick,
) -> Result<FilterDesign> {
    let cascade = continuous.discretise(options.sample_rate_hz)?;
    let filter = CommandFilter::Discrete {
        cascade,
        sample_period_s: 1.0 / options.sample_rate_hz,
    };
    let figures = figures_with(bare, base, &filter, pick)?;
    Ok(FilterDesign {
        continuous,
        cascade,
        figures,
    })
}

/// The design target of the optimised method (the target on the reference actuator).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct DesignTarget {
    /// Lowest phase-lag reduction (%).
    pub min_phase_lag_reduction_pct: f64,
    /// Largest magnitude error of the command path (dB).
    pub max_magnitude_error_db: f64,
    /// Largest noise-sensitivity ratio.
    pub max_noise_sensitivity_ratio: f64,
    /// Lowest gain margin with the filter.
    pub min_gain_margin: f64,
}

impl DesignTarget {
    /// Phase-lag reduction ≥ 80 % with ≤ 3 dB magnitude error, noise-sensitivity ratio ≤ 10,
    /// gain margin ≥ 2.
    pub const DEFAULT: Self = Self {
        min_phase_lag_reduction_pct: 80.0,
        max_magnitude_error_db: 3.0,
        max_noise_sensitivity_ratio: 10.0,
        min_gain_margin: 2.0,
    };

    /// Whether `figures` meet the target (a stable loop is required as well).
    pub fn met_by(&self, figures: &FilterFigures) -> bool {
        figures.phase_lag_reduction_pct >= self.min_phase_lag_reduction_pct
            && figures.magnitude_error_db <= self.max_magnitude_error_db
            && figures.noise_sensitivity_ratio <= self.max_noise_sensitivity_ratio
            && figures
                .gain_margin_with_filter
                .is_none_or(|g| g >= self.min_gain_margin)
            && figures.stability_with_filter == Stability::Stable
    }
}

/// One point of the trade-off front of the optimised design.
#[derive(Clone, Debug)]
pub struct FrontPoint {
    /// Weight `w` of the noise term (0: accuracy only, 1: noise only).
    pub weight: f64,
    /// The design at this weight (discretised, with figures).
    pub design: FilterDesign,
    /// Whether it meets the target.
    pub meets_target: bool,
}

/// Result of [`design_optimal`].
#[derive(Clone, Debug)]
pub struct OptimalDesign {
    /// The front, in order of increasing weight.
    pub front: Vec<FrontPoint>,
    /// The exported design: of the front and the least-squares design, the most accurate
    /// (smallest response error) meeting the target, or when none does the most accurate
    /// with a stable loop and the target's gain margin.
    pub chosen: FilterDesign,
    /// The weight of the chosen design (`None`: the least-squares design).
    pub chosen_weight: Option<f64>,
    /// Whether the chosen point meets the target.
    pub target_met: bool,
    /// The least-squares design the optimisation started from.
    pub least_squares: FilterDesign,
}

/// Weights of the default trade-off sweep (the terms are normalised by the least-squares
/// design's error and noise peak, so `w = 0.5` weighs them as that design does).
pub const DEFAULT_WEIGHTS: [f64; 9] = [0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.75, 0.9];

/// Cheap figures for the optimiser (continuous filter, coarse grids).
struct Objective<'a> {
    bare: &'a MilSystem,
    base: Baseline,
    pick: &'a ResponsePick,
    error_scale: f64,
    noise_scale: f64,
    margin_grid: Vec<f64>,
    target: DesignTarget,
    zeros: usize,
    dc: f64,
    poles: usize,
    rolloff_range_hz: (f64, f64),
    /// Largest out-of-band amplification allowed: the least-squares design's (at least 1).
    max_amplification: f64,
}

impl Objective<'_> {
    fn filter(&self, x: &[f64]) -> Option<ContinuousFilter> {
        let (coeffs, shape) = x.split_at(self.zeros);
        let (rolloff_hz, damping) = (shape.first()?.exp(), shape.get(1)?.exp());
        // Keep the roll-off where the paper puts it (above the fit band, well below Nyquist)
        // and the pole pairs neither nearly undamped nor split far apart.
        if !(self.rolloff_range_hz.0..=self.rolloff_range_hz.1).contains(&rolloff_hz)
            || !(0.3..=1.5).contains(&damping)
        {
            return None;
        }
        let mut numerator = vec![self.dc];
        numerator.extend_from_slice(coeffs);
        let structure = FilterStructure {
            rolloff_hz,
            rolloff_damping: damping,
            poles: self.poles,
            zeros: self.zeros,
        };
        structure.validate().ok()?;
        Some(ContinuousFilter {
            structure,
            numerator_normalised: numerator,
        })
    }

    /// `(response error %, noise peak, gain margin, magnitude error dB, out-of-band
    /// amplification)` of the design `x`.
    fn parts(&self, x: &[f64]) -> Option<(f64, f64, f64, f64, f64)> {
        let filter = self.filter(x)?;
        let magnitude_db = worst_db(
            &self
                .base
                .band_grid
                .iter()
                .zip(&self.base.command_path)
                .map(|(f, p)| filter.response_s(Complex64::new(0.0, TAU * f)) * p)
                .collect::<Vec<_>>(),
        );
        let sys = with_filter(
            self.bare,
            Some(CommandFilter::Continuous(filter.transfer_function().ok()?)),
        );
        let error = response_error_pct(&sys, &self.base, self.pick).ok()?;
        let noise = noise_trace(&sys, &self.base.noise_grid)
            .ok()?
            .into_iter()
            .fold(0.0, f64::max);
        let gm = gain_margin(&sys, &self.margin_grid)
            .ok()?
            .gain_margin
            .unwrap_or(f64::INFINITY);
        let amplification = self
            .base
            .above_grid
            .iter()
            .zip(&self.base.above_emulated)
            .map(|(f, emu)| Some(((self.pick)(&sys.point(*f, Loop::Mil).ok()?) / emu).norm()))
            .try_fold(0.0_f64, |m, v| Some(m.max(v?)))?;
        Some((error, noise, gm, magnitude_db, amplification))
    }

    fn cost(&self, x: &[f64], weight: f64) -> f64 {
        match self.parts(x) {
            Some((error, noise, gm, magnitude_db, amplification))
                if error.is_finite() && noise.is_finite() =>
            {
                let t = &self.target;
                let penalty = if gm < t.min_gain_margin {
                    10.0 * (1.0 + t.min_gain_margin - gm)
                } else {
                    0.0
                } + if magnitude_db > t.max_magnitude_error_db {
                    10.0 * (1.0 + magnitude_db - t.max_magnitude_error_db)
                } else {
                    0.0
                } + if amplification > self.max_amplification {
                    10.0 * amplification / self.max_amplification
                } else {
                    0.0
                };
                (1.0 - weight) * error / self.error_scale
                    + weight * noise / self.noise_scale
                    + penalty
            }
            _ => f64::INFINITY,
        }
    }
}

/// The optimised design over `weights` (see the module documentation), with the
/// trade-off front; `progress` is called after each weight.
///
/// # Errors
/// Invalid options, or no stable design at any weight.
pub fn design_optimal(
    system: &MilSystem,
    options: &DesignOptions,
    weights: &[f64],
    target: &DesignTarget,
    pick: &ResponsePick,
    mut progress: impl FnMut(usize, usize),
) -> Result<OptimalDesign> {
    options.validate()?;
    if weights.is_empty() || weights.iter().any(|w| !(0.0..=1.0).contains(w)) {
        return Err(design_error("weights must lie in 0…1"));
    }
    let bare = with_filter(system, None);
    let base = Baseline::new(&bare, options, pick)?;
    let continuous = fit_numerator(&bare, options.structure, options)?;
    let least_squares = finish(&bare, &base, continuous, options, pick)?;
    let ls = &least_squares.continuous;
    let objective = Objective {
        bare: &bare,
        error_scale: least_squares.figures.response_error_with_pct.max(1e-9),
        noise_scale: least_squares.figures.noise_peak_with.max(1e-300),
        rolloff_range_hz: (2.0 * options.fit_to_hz, 0.25 * options.sample_rate_hz),
        base,
        pick,
        margin_grid: log_grid(1.0, options.nyquist_hz(), 20),
        target: *target,
        zeros: ls.structure.zeros,
        dc: ls.numerator_normalised.first().copied().unwrap_or(1.0),
        poles: ls.structure.poles,
        max_amplification: least_squares.figures.out_of_band_amplification.max(1.0),
    };
    let mut start: Vec<f64> = ls.numerator_normalised.iter().skip(1).copied().collect();
    start.push(ls.structure.rolloff_hz.ln());
    start.push(ls.structure.rolloff_damping.ln());
    let step: Vec<f64> = start
        .iter()
        .enumerate()
        .map(|(i, v)| {
            if i < objective.zeros {
                0.2 * v.abs().max(1e-3)
            } else {
                0.2
            }
        })
        .collect();
    let mut front = Vec::new();
    let mut x = start;
    for (i, &w) in weights.iter().enumerate() {
        // Warm start from the previous weight's optimum: the front is traced continuously.
        x = mil_numerics::optimise::nelder_mead(
            |p| objective.cost(p, w),
            &x,
            &step,
            80 * (x.len() + 1),
        );
        if let Some(continuous) = objective.filter(&x) {
            if let Ok(design) = finish(&bare, &objective.base, continuous, options, pick) {
                front.push(FrontPoint {
                    weight: w,
                    meets_target: target.met_by(&design.figures),
                    design,
                });
            }
        }
        progress(i + 1, weights.len());
    }
    // Candidates: the front and the least-squares design it started from.
    let candidates: Vec<(Option<f64>, &FilterDesign)> = std::iter::once((None, &least_squares))
        .chain(front.iter().map(|p| (Some(p.weight), &p.design)))
        .collect();
    let acceptable = |d: &FilterDesign| {
        d.figures.stability_with_filter == Stability::Stable
            && d.figures
                .gain_margin_with_filter
                .is_none_or(|g| g >= target.min_gain_margin)
    };
    let most_accurate = |only_target: bool| {
        candidates
            .iter()
            .filter(|(_, d)| acceptable(d) && (!only_target || target.met_by(&d.figures)))
            .min_by(|a, b| {
                a.1.figures
                    .response_error_with_pct
                    .total_cmp(&b.1.figures.response_error_with_pct)
            })
            .map(|(w, d)| (*w, (*d).clone()))
    };
    let ((chosen_weight, chosen), target_met) = match most_accurate(true) {
        Some(c) => (c, true),
        None => (
            most_accurate(false).ok_or_else(|| {
                design_error("no stable design with the minimum gain margin at any weight")
            })?,
            false,
        ),
    };
    Ok(OptimalDesign {
        front,
        chosen,
        chosen_weight,
        target_met,
        least_squares,
    })
}
