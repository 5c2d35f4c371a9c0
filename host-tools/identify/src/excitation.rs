//! Excitation signals for identification tests: a logarithmic sine sweep and band-limited
//! (white or pink) random noise. Both are deterministic.

use std::f64::consts::PI;

use num_complex::Complex64;
use rustfft::FftPlanner;

use crate::error::{IdentifyError, Result};
use mil_numerics::rng::SplitMix64;

/// Number of samples for a duration, with the checks common to both signals.
fn sample_count(duration_s: f64, sample_rate_hz: f64) -> Result<usize> {
    if !(sample_rate_hz.is_finite() && sample_rate_hz > 0.0) {
        return Err(IdentifyError::InvalidArgument(format!(
            "sample rate {sample_rate_hz} Hz is not positive and finite"
        )));
    }
    let n = duration_s * sample_rate_hz;
    if !(n.is_finite() && n.round() >= 2.0 && n.round() <= 1e9) {
        return Err(IdentifyError::InvalidArgument(format!(
            "duration {duration_s} s at {sample_rate_hz} Hz is not between 2 and 1e9 samples"
        )));
    }
    Ok(n.round() as usize)
}

fn check_amplitude(name: &str, value: f64) -> Result<()> {
    if value.is_finite() && value >= 0.0 {
        Ok(())
    } else {
        Err(IdentifyError::InvalidArgument(format!(
            "{name} {value} is not finite and >= 0"
        )))
    }
}

/// Exponential (logarithmic) sine sweep, as [`log_sine_sweep`]; errors instead of panicking.
///
/// Errors: frequencies not in `(0, sample_rate/2]`, a duration of fewer than 2 samples, a
/// non-finite or negative amplitude.
pub fn try_log_sine_sweep(
    f_start_hz: f64,
    f_end_hz: f64,
    duration_s: f64,
    sample_rate_hz: f64,
    amplitude: f64,
) -> Result<Vec<f64>> {
    let n = sample_count(duration_s, sample_rate_hz)?;
    let nyquist = sample_rate_hz / 2.0;
    for (name, f) in [("start", f_start_hz), ("end", f_end_hz)] {
        if !(f.is_finite() && f > 0.0 && f <= nyquist) {
            return Err(IdentifyError::InvalidArgument(format!(
                "sweep {name} frequency {f} Hz is not in (0, {nyquist}] Hz"
            )));
        }
    }
    check_amplitude("amplitude", amplitude)?;
    // Instantaneous frequency f(t) = f1 · (f2/f1)^(t/T) = f1 · e^(k t / T), k = ln(f2/f1);
    // phase φ(t) = 2π ∫ f dt = 2π f1 T / k · (e^(k t/T) - 1) (→ 2π f1 t as k → 0).
    let k = (f_end_hz / f_start_hz).ln();
    let t_total = duration_s;
    Ok((0..n)
        .map(|i| {
            let t = i as f64 / sample_rate_hz;
            let phase = if k.abs() < 1e-12 {
                2.0 * PI * f_start_hz * t
            } else {
                2.0 * PI * f_start_hz * t_total / k * (k * t / t_total).exp_m1()
            };
            amplitude * phase.sin()
        })
        .collect())
}

/// Exponential (logarithmic) sine sweep `amplitude · sin φ(t)` (signal units), sampled at
/// `t = i / sample_rate_hz`, `i = 0 .. round(duration_s · sample_rate_hz)`.
///
/// The instantaneous frequency `f(t) = f_start · (f_end / f_start)^(t / duration)` (Hz)
/// rises (or falls) exponentially from `f_start_hz` at `t = 0` to `f_end_hz` at
/// `t = duration_s`, so every octave gets the same time; the sweep starts at phase 0 and
/// has no taper.
///
/// # Panics
/// On the invalid arguments that [`try_log_sine_sweep`] reports as errors (frequencies not
/// in `(0, sample_rate/2]`, fewer than 2 samples, negative or non-finite amplitude).
pub fn log_sine_sweep(
    f_start_hz: f64,
    f_end_hz: f64,
    duration_s: f64,
    sample_rate_hz: f64,
    amplitude: f64,
) -> Vec<f64> {
    try_log_sine_sweep(f_start_hz, f_end_hz, duration_s, sample_rate_hz, amplitude)
        .unwrap_or_else(|e| panic!("log_sine_sweep: {e}"))
}

/// Band-limited random noise, as [`band_limited_noise`]; errors instead of panicking.
///
/// Errors: a band not satisfying `0 <= f_min < f_max <= sample_rate/2` (`f_min > 0` for
/// pink noise), a duration of fewer than 2 samples, a band holding no frequency bin of the
/// record, a non-finite or negative `rms`.
pub fn try_band_limited_noise(
    f_min_hz: f64,
    f_max_hz: f64,
    duration_s: f64,
    sample_rate_hz: f64,
    rms: f64,
    pink: bool,
    seed: u64,
) -> Result<Vec<f64>> {
    let n = sample_count(duration_s, sample_rate_hz)?;
    let nyquist = sample_rate_hz / 2.0;
    let lowest = if pink { f64::MIN_POSITIVE } else { 0.0 };
    if !(f_min_hz.is_finite()
        && f_max_hz.is_finite()
        && f_min_hz >= lowest
        && f_min_hz < f_max_hz
        && f_max_hz <= nyquist)
    {
        return Err(IdentifyError::InvalidArgument(format!(
            "noise band [{f_min_hz}, {f_max_hz}] Hz must satisfy {} f_min < f_max <= {nyquist} Hz",
            if pink { "0 <" } else { "0 <=" }
        )));
    }
    check_amplitude("rms", rms)?;

    // Hermitian spectrum with independent complex Gaussian coefficients in the band, zero
    // elsewhere (including DC), amplitude ∝ f^(-1/2) for pink noise (power ∝ 1/f).
    let mut rng = SplitMix64::new(seed);
    let mut spectrum = vec![Complex64::default(); n];
    let mut in_band = 0usize;
    for k in 1..=n / 2 {
        let f = k as f64 * sample_rate_hz / n as f64;
        if f < f_min_hz || f > f_max_hz {
            continue;
        }
        in_band += 1;
        let gain = if pink { 1.0 / f.sqrt() } else { 1.0 };
        let (a, b) = rng.normal_pair();
        if 2 * k == n {
            // Nyquist bin of an even length: real for a real signal.
            spectrum[k] = Complex64::new(gain * a, 0.0);
        } else {
            let c = Complex64::new(gain * a, gain * b);
            spectrum[k] = c;
            spectrum[n - k] = c.conj();
        }
    }
    if in_band == 0 {
        return Err(IdentifyError::InvalidArgument(format!(
            "noise band [{f_min_hz}, {f_max_hz}] Hz holds no frequency bin of a \
             {duration_s} s record (bin spacing {} Hz)",
            sample_rate_hz / n as f64
        )));
    }
    FftPlanner::<f64>::new()
        .plan_fft_inverse(n)
        .process(&mut spectrum);
    let mut x: Vec<f64> = spectrum.iter().map(|c| c.re).collect();
    let current = (x.iter().map(|v| v * v).sum::<f64>() / n as f64).sqrt();
    let scale = rms / current;
    for v in &mut x {
        *v *= scale;
    }
    Ok(x)
}

/// Band-limited random noise (signal units) with RMS `rms`, sampled at
/// `t = i / sample_rate_hz`, `i = 0 .. round(duration_s · sample_rate_hz)`.
///
/// Its spectrum is confined to `[f_min_hz, f_max_hz]` (Hz): flat (white) or, with `pink`,
/// with power ∝ 1/f (equal power per octave, −3 dB per octave in amplitude). It is made in
/// the frequency domain: independent complex Gaussian coefficients on the record's
/// frequency bins inside the band (zero outside, and at DC), then one inverse FFT of the
/// whole record, so the signal is periodic in the record length and Gaussian in amplitude,
/// with zero mean; it is then scaled to exactly `rms`. The same `seed` gives the same
/// signal.
///
/// # Panics
/// On the invalid arguments that [`try_band_limited_noise`] reports as errors.
pub fn band_limited_noise(
    f_min_hz: f64,
    f_max_hz: f64,
    duration_s: f64,
    sample_rate_hz: f64,
    rms: f64,
    pink: bool,
    seed: u64,
) -> Vec<f64> {
    try_band_limited_noise(
        f_min_hz,
        f_max_hz,
        duration_s,
        sample_rate_hz,
        rms,
        pink,
        seed,
    )
    .unwrap_or_else(|e| panic!("band_limited_noise: {e}"))
}
