//! Excitation signals: sweep frequency coverage, noise level and band limits.

use mil_identify::{
    band_limited_noise, log_sine_sweep, try_band_limited_noise, try_log_sine_sweep, Complex64,
};
use rustfft::FftPlanner;

/// Upward zero crossings (s), linearly interpolated between samples.
fn upward_crossings(x: &[f64], fs: f64) -> Vec<f64> {
    x.windows(2)
        .enumerate()
        .filter(|(_, w)| w[0] < 0.0 && w[1] >= 0.0)
        .map(|(i, w)| (i as f64 + w[0] / (w[0] - w[1])) / fs)
        .collect()
}

#[test]
fn sweep_instantaneous_frequency_covers_the_band() {
    let (f1, f2, duration, fs) = (10.0, 200.0, 10.0, 4000.0);
    let x = log_sine_sweep(f1, f2, duration, fs, 2.5);
    assert_eq!(x.len(), 40_000);
    // Amplitude: every sample within ±2.5, and the peaks reach it: at the low-frequency end
    // there are 400 samples per period, so the largest sample is within 1 - cos(π/400)
    // ≈ 3e-5 of the peak; 0.2 % is loose.
    let peak = x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(peak <= 2.5 && peak > 2.495, "peak {peak}");
    // Instantaneous frequency from the periods between upward zero crossings, assigned to
    // the period's middle, against f(t) = f1 (f2/f1)^(t/T). Over one period the exponential
    // sweep's frequency changes by at most a factor (f2/f1)^(1/(f1 T)) ≈ 3 %, and the period
    // average sits at the middle to second order, so 0.5 % is a fair bound.
    let c = upward_crossings(&x, fs);
    let mut worst = 0.0f64;
    let mut measured = Vec::new();
    for w in c.windows(2) {
        let t = 0.5 * (w[0] + w[1]);
        let f = 1.0 / (w[1] - w[0]);
        let expected = f1 * (f2 / f1).powf(t / duration);
        worst = worst.max((f / expected - 1.0).abs());
        measured.push(f);
    }
    let (first, last) = (measured[0], measured[measured.len() - 1]);
    println!(
        "sweep: {} periods, first {first:.3} Hz, last {last:.3} Hz, worst deviation from \
         f1·(f2/f1)^(t/T) {:.3} %",
        measured.len(),
        100.0 * worst
    );
    assert!(worst < 0.005, "worst deviation {worst}");
    // The band is covered: the first full period (its middle is 1.5 periods after the
    // start, about 0.15 s, where f = 10.45 Hz) is within 5 % of f1 and the last within 1 %
    // of f2 (half a period before the end).
    assert!((first / f1 - 1.0).abs() < 0.05, "first {first}");
    assert!((last / f2 - 1.0).abs() < 0.01, "last {last}");
    // Downward sweeps work the same way.
    let down = log_sine_sweep(200.0, 10.0, 10.0, fs, 1.0);
    let c = upward_crossings(&down, fs);
    let f_first = 1.0 / (c[1] - c[0]);
    assert!((f_first / 200.0 - 1.0).abs() < 0.01, "{f_first}");
}

#[test]
fn sweep_rejects_bad_arguments() {
    assert!(try_log_sine_sweep(0.0, 100.0, 1.0, 1000.0, 1.0).is_err());
    assert!(try_log_sine_sweep(10.0, 600.0, 1.0, 1000.0, 1.0).is_err()); // above Nyquist
    assert!(try_log_sine_sweep(10.0, 100.0, 0.001, 1000.0, 1.0).is_err()); // 1 sample
    assert!(try_log_sine_sweep(10.0, 100.0, 1.0, 1000.0, f64::NAN).is_err());
    assert!(try_log_sine_sweep(10.0, 100.0, 1.0, 0.0, 1.0).is_err());
    let r = std::panic::catch_unwind(|| log_sine_sweep(10.0, 100.0, 1.0, -1.0, 1.0));
    assert!(r.is_err());
}

/// Power per FFT bin of the whole record, bins 0..=n/2, and the bin frequencies (Hz).
fn spectrum(x: &[f64], fs: f64) -> (Vec<f64>, Vec<f64>) {
    let n = x.len();
    let mut buf: Vec<Complex64> = x.iter().map(|&v| Complex64::new(v, 0.0)).collect();
    FftPlanner::<f64>::new()
        .plan_fft_forward(n)
        .process(&mut buf);
    let f = (0..=n / 2).map(|k| k as f64 * fs / n as f64).collect();
    let p = buf[..=n / 2].iter().map(|c| c.norm_sqr()).collect();
    (f, p)
}

fn band_power(f: &[f64], p: &[f64], lo: f64, hi: f64) -> f64 {
    f.iter()
        .zip(p)
        .filter(|(&f, _)| f >= lo && f < hi)
        .map(|(_, &p)| p)
        .sum()
}

#[test]
fn noise_has_requested_rms_and_band() {
    let (f_min, f_max, duration, fs) = (20.0, 200.0, 20.0, 1000.0);
    for pink in [false, true] {
        let x = band_limited_noise(f_min, f_max, duration, fs, 0.3, pink, 42);
        assert_eq!(x.len(), 20_000);
        let rms = (x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64).sqrt();
        let mean = x.iter().sum::<f64>() / x.len() as f64;
        assert!((rms / 0.3 - 1.0).abs() < 0.01, "rms {rms}");
        assert!(mean.abs() < 1e-9, "mean {mean}");
        // Out of band, as a fraction of the mean in-band bin power: required below -40 dB;
        // by construction it is rounding noise only (≈ -300 dB).
        let (f, p) = spectrum(&x, fs);
        let in_band: Vec<f64> = f
            .iter()
            .zip(&p)
            .filter(|(&f, _)| f >= f_min && f <= f_max)
            .map(|(_, &p)| p)
            .collect();
        let mean_in = in_band.iter().sum::<f64>() / in_band.len() as f64;
        let worst_out = f
            .iter()
            .zip(&p)
            .filter(|(&f, _)| f < f_min || f > f_max)
            .fold(0.0f64, |m, (_, &p)| m.max(p));
        let db = 10.0 * (worst_out / mean_in).log10();
        println!(
            "noise (pink {pink}): rms {rms:.6}, worst out-of-band bin {db:.0} dB re mean in-band"
        );
        assert!(db < -40.0, "{db} dB");

        // Spectral shape: power in the octave 25..50 Hz against 100..200 Hz. Pink noise has
        // equal power per octave (ratio 1); white has 4× the power in the upper octave (4× the
        // bins). Each octave sums ≥ 500 bins of independent χ²(2) powers, ≈ 4.5 % relative
        // spread, so ±20 % is > 4σ while still telling the two apart.
        let ratio = band_power(&f, &p, 100.0, 200.0) / band_power(&f, &p, 25.0, 50.0);
        let expected = if pink { 1.0 } else { 4.0 };
        println!("  upper/lower octave power ratio {ratio:.3} (expected {expected})");
        assert!((ratio / expected - 1.0).abs() < 0.2, "ratio {ratio}");
    }
}

#[test]
fn noise_is_deterministic_per_seed() {
    let a = band_limited_noise(5.0, 100.0, 2.0, 1000.0, 1.0, true, 1);
    let b = band_limited_noise(5.0, 100.0, 2.0, 1000.0, 1.0, true, 1);
    let c = band_limited_noise(5.0, 100.0, 2.0, 1000.0, 1.0, true, 2);
    assert_eq!(a, b);
    // Different seeds: nearly uncorrelated (|r| < 0.15 for ~190 independent bins, > 4σ).
    let r = a.iter().zip(&c).map(|(x, y)| x * y).sum::<f64>() / a.len() as f64;
    assert!(r.abs() < 0.15, "correlation {r}");
}

#[test]
fn noise_rejects_bad_arguments() {
    let ok = |f_min, f_max, pink| try_band_limited_noise(f_min, f_max, 1.0, 1000.0, 1.0, pink, 0);
    assert!(ok(0.0, 100.0, false).is_ok());
    assert!(ok(0.0, 100.0, true).is_err()); // pink needs f_min > 0
    assert!(ok(100.0, 50.0, false).is_err());
    assert!(ok(10.0, 501.0, false).is_err());
    assert!(ok(10.2, 10.8, false).is_err()); // no 1 Hz bin inside
    assert!(try_band_limited_noise(1.0, 10.0, 1.0, 1000.0, -1.0, false, 0).is_err());
    assert!(
        std::panic::catch_unwind(|| band_limited_noise(1.0, 10.0, 0.0, 1000.0, 1.0, false, 0))
            .is_err()
    );
}
