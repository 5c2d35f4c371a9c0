//! Butterworth low-pass filters (bilinear transform with pre-warping), causal or zero-phase
//! (forward-backward): the one implementation the rig's band comparisons, the generated
//! road noise and diagnosis' differentiation filters all use.

/// A second-order section `[b0, b1, b2, a1, a2]` (a0 = 1), transposed direct form II.
pub type Biquad = [f64; 5];

/// The low-pass section of quality `q` for `k = tan(π fc/fs)`.
fn section(k: f64, q: f64) -> Biquad {
    let norm = 1.0 / (1.0 + k / q + k * k);
    let b0 = k * k * norm;
    [
        b0,
        2.0 * b0,
        b0,
        2.0 * (k * k - 1.0) * norm,
        (1.0 - k / q + k * k) * norm,
    ]
}

/// Second-order Butterworth low-pass with cut-off `fc_over_fs` (cut-off over sample rate,
/// in (0, 0.5)): −3 dB at the cut-off.
pub fn butterworth2(fc_over_fs: f64) -> Biquad {
    section(
        (std::f64::consts::PI * fc_over_fs).tan(),
        std::f64::consts::FRAC_1_SQRT_2,
    )
}

/// Fourth-order Butterworth low-pass with cut-off `fc_over_fs`: its two sections.
pub fn butterworth4(fc_over_fs: f64) -> [Biquad; 2] {
    let k = (std::f64::consts::PI * fc_over_fs).tan();
    [0.541_196_100_146_197, 1.306_562_964_876_376_6].map(|q| section(k, q))
}

/// Runs section `s` over `samples` in place (forward or reversed, in the order given),
/// starting in the steady state of input `x0` (unit DC gain; `x0 = 0` is the zero state).
pub fn run_section<'a>(s: &Biquad, samples: impl Iterator<Item = &'a mut f64>, x0: f64) {
    let (mut s1, mut s2) = (x0 * (1.0 - s[0]), x0 * (s[2] - s[4]));
    for v in samples {
        let inp = *v;
        let out = s[0] * inp + s1;
        s1 = s[1] * inp - s[3] * out + s2;
        s2 = s[2] * inp - s[4] * out;
        *v = out;
    }
}

/// Runs the cascade of two sections over `samples` in place, both started in the steady
/// state of `x0`. The sections run in one loop so that the second's recursion overlaps the
/// first's (the arithmetic is that of running them one after the other).
pub fn run_cascade2<'a>(s: &[Biquad; 2], samples: impl Iterator<Item = &'a mut f64>, x0: f64) {
    let [a, b] = s;
    let (mut a1, mut a2) = (x0 * (1.0 - a[0]), x0 * (a[2] - a[4]));
    let (mut b1, mut b2) = (x0 * (1.0 - b[0]), x0 * (b[2] - b[4]));
    for v in samples {
        let inp = *v;
        let o1 = a[0] * inp + a1;
        a1 = a[1] * inp - a[3] * o1 + a2;
        a2 = a[2] * inp - a[4] * o1;
        let o2 = b[0] * o1 + b1;
        b1 = b[1] * o1 - b[3] * o2 + b2;
        b2 = b[2] * o1 - b[4] * o2;
        *v = o2;
    }
}

/// `x` through the second-order Butterworth low-pass at `fc_hz` (Hz, sample interval `dt`
/// s) forwards and then backwards: zero phase, fourth-order magnitude, −6 dB at the
/// cut-off. Each pass starts in the steady state of its first sample, so a static value
/// passes without a transient (no padding).
pub fn lowpass2_zero_phase(x: &[f64], fc_hz: f64, dt: f64) -> Vec<f64> {
    let Some(&first) = x.first() else {
        return Vec::new();
    };
    let s = butterworth2(fc_hz * dt);
    let mut y = x.to_vec();
    run_section(&s, y.iter_mut(), first);
    let last = y.last().copied().unwrap_or(first);
    run_section(&s, y.iter_mut().rev(), last);
    y
}

/// Zero-phase (forward-backward) fourth-order Butterworth low-pass at `fc_hz` (Hz) of a
/// signal sampled every `dt` (s): magnitude `|H|²` of the fourth-order filter, no phase.
/// The ends are padded by odd reflection to limit start-up transients. A cut-off at or
/// above 0.49 of the sample rate returns the signal unchanged. The filter is linear in
/// `x`.
pub fn lowpass4_zero_phase(x: &[f64], fc_hz: f64, dt: f64) -> Vec<f64> {
    match lowpass4_padded(x, fc_hz, dt) {
        Some((mut y, pad)) => {
            y.truncate(pad + x.len());
            y.drain(..pad);
            y
        }
        None => x.to_vec(),
    }
}

/// [`lowpass4_zero_phase`] of `x` at the sample indices `keep` only (each below `x.len()`):
/// the same numbers, without the copy of the whole filtered signal.
pub fn lowpass4_zero_phase_at(x: &[f64], fc_hz: f64, dt: f64, keep: &[usize]) -> Vec<f64> {
    match lowpass4_padded(x, fc_hz, dt) {
        Some((y, pad)) => keep.iter().map(|&t| y[pad + t]).collect(),
        None => keep.iter().map(|&t| x[t]).collect(),
    }
}

/// The forward-backward filtering of [`lowpass4_zero_phase`] on `x` padded at both ends:
/// `(padded result, pad)` (sample `t` of `x` at `pad + t`), or `None` when the signal is
/// passed unchanged (fewer than 4 samples, or a cut-off at or above 0.49 of the rate).
fn lowpass4_padded(x: &[f64], fc_hz: f64, dt: f64) -> Option<(Vec<f64>, usize)> {
    let r = fc_hz * dt;
    if x.len() < 4 || r >= 0.49 {
        return None;
    }
    let sections = butterworth4(r.max(1e-6));
    let pad = ((3.0 / r) as usize).min(x.len() - 1);
    let n = x.len();
    let mut y = Vec::with_capacity(n + 2 * pad);
    y.extend((1..=pad).rev().map(|i| 2.0 * x[0] - x[i]));
    y.extend_from_slice(x);
    y.extend((1..=pad).map(|i| 2.0 * x[n - 1] - x[n - 1 - i]));
    let first = y[0];
    run_cascade2(&sections, y.iter_mut(), first);
    let last = y[y.len() - 1];
    run_cascade2(&sections, y.iter_mut().rev(), last);
    Some((y, pad))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tone(f: f64, fs: f64) -> Vec<f64> {
        (0..8000)
            .map(|k| 5.0 + (std::f64::consts::TAU * f * k as f64 / fs).sin())
            .collect()
    }

    /// RMS amplitude (×√2) of the middle half, away from the ends.
    fn amplitude(x: &[f64]) -> f64 {
        let mid = &x[2000..6000];
        let m = mid.iter().sum::<f64>() / mid.len() as f64;
        (2.0 * mid.iter().map(|v| (v - m).powi(2)).sum::<f64>() / mid.len() as f64).sqrt()
    }

    #[test]
    fn second_order_zero_phase_passes_the_band_and_the_static_value() {
        let fs = 2000.0;
        let dt = 1.0 / fs;
        // 5 Hz through a 30 Hz cut-off: gain 1, no phase shift, the static 5 kept.
        let x = tone(5.0, fs);
        let y = lowpass2_zero_phase(&x, 30.0, dt);
        assert!((amplitude(&y) - 1.0).abs() < 1e-3, "{}", amplitude(&y));
        let worst = x[2000..6000]
            .iter()
            .zip(&y[2000..6000])
            .fold(0.0_f64, |w, (a, b)| w.max((a - b).abs()));
        assert!(worst < 2e-3, "{worst}");
        let flat = lowpass2_zero_phase(&[5.0; 100], 30.0, dt);
        assert!(flat.iter().all(|v| (v - 5.0).abs() < 1e-12), "{flat:?}");
        // At the cut-off −6 dB; 150 Hz attenuated by (30/150)^4.
        let at = amplitude(&lowpass2_zero_phase(&tone(30.0, fs), 30.0, dt));
        assert!((at - 0.5).abs() < 0.01, "{at}");
        let above = amplitude(&lowpass2_zero_phase(&tone(150.0, fs), 30.0, dt));
        assert!(above < 2.0 * (30.0f64 / 150.0).powi(4), "{above}");
        assert!(lowpass2_zero_phase(&[], 30.0, dt).is_empty());
    }

    #[test]
    fn fourth_order_zero_phase_is_the_square_of_the_fourth_order_magnitude() {
        let fs = 1000.0;
        let dt = 1.0 / fs;
        // At the cut-off |H|^2 = 1/2 for the fourth-order filter; an octave above, 1/257.
        let at = amplitude(&lowpass4_zero_phase(&tone(50.0, fs), 50.0, dt));
        assert!((at - 0.5).abs() < 0.01, "{at}");
        let octave = amplitude(&lowpass4_zero_phase(&tone(100.0, fs), 50.0, dt));
        assert!((octave - 1.0 / 257.0).abs() < 1e-3, "{octave}");
        // Linear, and the kept samples are the full result there.
        let x = tone(20.0, fs);
        let full = lowpass4_zero_phase(&x, 50.0, dt);
        let keep = [0, 17, 4000, 7999];
        let at = lowpass4_zero_phase_at(&x, 50.0, dt, &keep);
        for (k, v) in keep.iter().zip(at) {
            assert_eq!(full[*k], v);
        }
        // Above 0.49 of the rate: unchanged.
        assert_eq!(lowpass4_zero_phase(&x, 495.0, dt), x);
    }

    #[test]
    fn a_causal_section_from_rest_settles_to_unit_gain() {
        let mut x = vec![1.0; 400];
        run_section(&butterworth2(0.05), x.iter_mut(), 0.0);
        assert!(
            x[0] < 0.1 && (x[399] - 1.0).abs() < 1e-9,
            "{} {}",
            x[0],
            x[399]
        );
    }
}
