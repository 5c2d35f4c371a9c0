//! How close the MiL rig is to the emulated system: the error figures of the real-time
//! hybrid simulation benchmark (Silva, Dyke et al., 2020), applied to a MiL output
//! `x_m` (measured on the rig) against the same output of the emulated system `x_d`
//! (desired):
//!
//! ```text
//! J1 = delay at the peak of the cross-correlation of x_m and x_d (ms, > 0: MiL lags)
//! J2 = 100 std(x_m − x_d) / std(x_d)          (normalised RMS error, %)
//! J3 = 100 max|x_m − x_d| / max|x_d − x_d,0|  (normalised peak error, %)
//! ```
//!
//! The benchmark's signals are displacements about zero; ours carry static values (the
//! wheel load), so J3 normalises by the largest deviation of `x_d` from its first sample
//! (the static equilibrium the run starts from). J1 is found on the mean-removed signals
//! within a lag window, refined between samples by a parabola through the peak and its two
//! neighbours.

use serde::Serialize;

/// The comparison of one output.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Comparison {
    /// J1: delay of `x_m` behind `x_d` at the cross-correlation peak (ms); `None` when the
    /// peak lies on the edge of the lag window or a signal is constant.
    pub delay_ms: Option<f64>,
    /// J2: normalised RMS error (%); `None` when `x_d` is constant.
    pub nrms_error_pct: Option<f64>,
    /// J3: normalised peak error (%); `None` when `x_d` never leaves its first value.
    pub peak_error_pct: Option<f64>,
    /// RMS of `x_m − x_d` (unit of the signal).
    pub rms_error: f64,
    /// Largest `|x_m − x_d|` (unit of the signal).
    pub peak_error: f64,
    /// Standard deviation of `x_d` (unit of the signal).
    pub desired_std: f64,
}

fn mean(x: &[f64]) -> f64 {
    x.iter().sum::<f64>() / x.len().max(1) as f64
}

fn std(x: &[f64]) -> f64 {
    let m = mean(x);
    (x.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / x.len().max(1) as f64).sqrt()
}

/// Compares `measured` (`x_m`) with `desired` (`x_d`), sampled at `sample_rate_hz` (Hz),
/// searching the delay within ±`max_lag_s` (s). The signals are cut to the shorter length.
pub fn compare(
    measured: &[f64],
    desired: &[f64],
    sample_rate_hz: f64,
    max_lag_s: f64,
) -> Comparison {
    let n = measured.len().min(desired.len());
    let (m, d) = (&measured[..n], &desired[..n]);
    let error: Vec<f64> = m.iter().zip(d).map(|(a, b)| a - b).collect();
    let rms_error = (error.iter().map(|e| e * e).sum::<f64>() / n.max(1) as f64).sqrt();
    let peak_error = error.iter().fold(0.0_f64, |p, e| p.max(e.abs()));
    let desired_std = std(d);
    let error_std = std(&error);
    let start = d.first().copied().unwrap_or(0.0);
    let desired_peak = d.iter().fold(0.0_f64, |p, v| p.max((v - start).abs()));
    let max_lag = (max_lag_s * sample_rate_hz).round().max(1.0) as usize;
    Comparison {
        delay_ms: delay_samples(m, d, max_lag).map(|s| 1e3 * s / sample_rate_hz),
        nrms_error_pct: (desired_std > 0.0).then(|| 100.0 * error_std / desired_std),
        peak_error_pct: (desired_peak > 0.0).then(|| 100.0 * peak_error / desired_peak),
        rms_error,
        peak_error,
        desired_std,
    }
}

/// The lag (samples, fractional) at which `measured` best matches `desired` delayed:
/// the peak of `r(l) = Σ x_m[k] x_d[k − l]` over `|l| ≤ max_lag` (mean-removed, summed over
/// the overlap), refined by
/// a parabola; `None` for a constant signal or a peak on the window's edge.
pub fn delay_samples(measured: &[f64], desired: &[f64], max_lag: usize) -> Option<f64> {
    let n = measured.len().min(desired.len());
    if n < 3 {
        return None;
    }
    let (mm, md) = (mean(&measured[..n]), mean(&desired[..n]));
    let m: Vec<f64> = measured[..n].iter().map(|v| v - mm).collect();
    let d: Vec<f64> = desired[..n].iter().map(|v| v - md).collect();
    let max_lag = max_lag.min(n - 2);
    let r = |lag: isize| -> f64 {
        // Σ_k m[k] d[k − lag] over the overlap (the biased estimate: the overlap shrinks
        // with the lag, which keeps a flat peak from wandering to the window's edge).
        let (m0, d0, len) = if lag >= 0 {
            let l = lag as usize;
            (l, 0, n - l)
        } else {
            let l = (-lag) as usize;
            (0, l, n - l)
        };
        let s: f64 = m[m0..m0 + len]
            .iter()
            .zip(&d[d0..d0 + len])
            .map(|(a, b)| a * b)
            .sum();
        s
    };
    let lags: Vec<isize> = (-(max_lag as isize)..=max_lag as isize).collect();
    let values: Vec<f64> = lags.iter().map(|&l| r(l)).collect();
    let (best, &peak) = values
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.total_cmp(b.1))?;
    if peak <= 0.0 || best == 0 || best + 1 == values.len() {
        return None;
    }
    let (y0, y1, y2) = (values[best - 1], peak, values[best + 1]);
    let curvature = y0 - 2.0 * y1 + y2;
    let shift = if curvature < 0.0 {
        0.5 * (y0 - y2) / curvature
    } else {
        0.0
    };
    Some(lags[best] as f64 + shift)
}

#[cfg(test)]
mod tests {
    use super::*;
    use mil_numerics::rng::SplitMix64;

    /// Smooth broadband test signal: white noise through two one-pole low-passes.
    fn signal(n: usize, seed: u64) -> Vec<f64> {
        let mut rng = SplitMix64::new(seed);
        let (mut a, mut b) = (0.0, 0.0);
        (0..n)
            .map(|_| {
                a += 0.1 * (rng.normal() - a);
                b += 0.1 * (a - b);
                b
            })
            .collect()
    }

    #[test]
    fn delay_of_a_shifted_signal_is_found_to_a_fraction_of_a_sample() {
        let x = signal(20_000, 3);
        for shift in [0usize, 1, 3, 7] {
            let delayed: Vec<f64> = (0..x.len())
                .map(|k| if k >= shift { x[k - shift] } else { 0.0 })
                .collect();
            let s = delay_samples(&delayed, &x, 50).unwrap();
            assert!((s - shift as f64).abs() < 0.05, "{shift}: {s}");
        }
        // A half-sample delay (linear interpolation) lands between the samples.
        let half: Vec<f64> = (0..x.len())
            .map(|k| if k >= 1 { 0.5 * (x[k] + x[k - 1]) } else { 0.0 })
            .collect();
        let s = delay_samples(&half, &x, 50).unwrap();
        assert!((s - 0.5).abs() < 0.1, "{s}");
        // MiL leading (negative delay), and the window edge.
        let lead: Vec<f64> = (0..x.len())
            .map(|k| x.get(k + 4).copied().unwrap_or(0.0))
            .collect();
        assert!((delay_samples(&lead, &x, 50).unwrap() + 4.0).abs() < 0.05);
        assert_eq!(delay_samples(&lead, &x, 3), None);
        assert_eq!(delay_samples(&vec![1.0; 100], &x[..100], 10), None);
    }

    #[test]
    fn error_figures_follow_their_definitions() {
        let fs = 1000.0;
        let d: Vec<f64> = (0..4000)
            .map(|k| 100.0 + 10.0 * (k as f64 * 0.01).sin())
            .collect();
        // x_m = x_d + 10 % of its deviation, plus one spike of 5.
        let mut m: Vec<f64> = d.iter().map(|v| v + 0.1 * (v - 100.0)).collect();
        m[2000] += 5.0;
        let c = compare(&m, &d, fs, 0.05);
        let std_d = 10.0 / 2f64.sqrt();
        assert!((c.desired_std - std_d).abs() < 0.05, "{c:?}");
        // J2: std of the error ≈ sqrt(0.1² σ² + spike²/N).
        let expected = (0.01 * std_d * std_d + 25.0 / 4000.0).sqrt() / std_d * 100.0;
        assert!((c.nrms_error_pct.unwrap() - expected).abs() < 0.1, "{c:?}");
        // J3: the peak error is the spike plus the proportional part there, over 10.
        let at = m[2000] - d[2000];
        assert!((c.peak_error - at.abs()).abs() < 1e-9, "{c:?}");
        assert!(
            (c.peak_error_pct.unwrap() - 100.0 * at.abs() / 10.0).abs() < 0.2,
            "{c:?}"
        );
        // Identical signals: no error, no delay.
        let same = compare(&d, &d, fs, 0.05);
        assert_eq!((same.rms_error, same.peak_error), (0.0, 0.0));
        assert_eq!(same.nrms_error_pct, Some(0.0));
        assert!(same.delay_ms.unwrap().abs() < 1e-9);
        // A constant desired signal has no normalised figures.
        let flat = compare(&m, &vec![100.0; 4000], fs, 0.05);
        assert_eq!((flat.nrms_error_pct, flat.peak_error_pct), (None, None));
    }
}
