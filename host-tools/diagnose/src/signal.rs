//! Signal helpers: zero-phase low-pass filtering, differentiation, spectra
//! and error figures.

use rustfft::{num_complex::Complex64, FftPlanner};

/// Signal-to-noise power ratio (-) at which a signal's band ends (the state filter's
/// cut-off, an accelerometer's low band edge, the record budget's band): 100 (20 dB), a
/// generic choice for "clearly above the noise", not tuned to any record.
pub const SNR: f64 = 100.0;

/// The zero-phase fourth-order Butterworth low-pass diagnosis filters with
/// (`mil_numerics::filter`, the workspace's one implementation).
pub use mil_numerics::filter::{
    lowpass4_zero_phase as lowpass_zero_phase, lowpass4_zero_phase_at as lowpass_zero_phase_at,
};

/// A 128-bit fingerprint of a signal's exact bits (and its length and `salt`), as a key of
/// [`LowpassCache`]: two independent multiply-xorshift chains, so that two different
/// signals share a key with probability about 2⁻¹²⁸.
pub fn fingerprint(x: &[f64], salt: u64) -> [u64; 2] {
    fingerprint_words(x.iter().map(|v| v.to_bits()), x.len(), salt)
}

/// [`fingerprint`] of a sequence of `len` words (a key made of indices and parameter
/// bits).
pub fn fingerprint_words(words: impl Iterator<Item = u64>, len: usize, salt: u64) -> [u64; 2] {
    let mut a = 0x243F_6A88_85A3_08D3 ^ salt;
    let mut b = 0x1319_8A2E_0370_7344 ^ (len as u64).rotate_left(17) ^ salt;
    for w in words {
        a = (a ^ w).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        a ^= a >> 29;
        b = (b.rotate_left(23) ^ w).wrapping_mul(0xD6E8_FEB8_6659_FD93);
    }
    [a ^ (a >> 32), b ^ (b >> 31)]
}

/// Memory the cache of a [`LowpassCache`] may hold (bytes) before it is emptied: 512 MiB.
pub const LOWPASS_CACHE_BYTES: usize = 512 << 20;

/// A memo of [`lowpass_zero_phase`] at one cut-off and sample interval, keyed by the
/// input's [`fingerprint`]: the discrepancy workflow filters the same regressor (a
/// stiffness column, a DOF's acceleration) for many candidate structures, and only the
/// changed ones need filtering again. Shared between threads; emptied when it holds more
/// than [`LOWPASS_CACHE_BYTES`]. A clone starts empty.
///
/// The signals may be concatenations of separate pieces of a record
/// ([`LowpassCache::segmented`]): each piece is then filtered on its own, as a record of
/// its own (padded at its ends), so that no junction leaks into its neighbours.
pub struct LowpassCache {
    fc_hz: f64,
    dt: f64,
    keep: Vec<usize>,
    /// The pieces, in order, covering the signals (empty: one piece, the whole signal).
    segments: Vec<std::ops::Range<usize>>,
    map: std::sync::Mutex<CacheMap>,
}

#[derive(Default)]
struct CacheMap {
    entries: std::collections::HashMap<[u64; 2], std::sync::Arc<Vec<f64>>>,
    bytes: usize,
}

impl LowpassCache {
    /// A cache for the low-pass at `fc_hz` (Hz) of signals sampled every `dt` (s), whose
    /// [`LowpassCache::kept_key`] results are taken at the sample indices `keep`.
    pub fn new(fc_hz: f64, dt: f64, keep: Vec<usize>) -> Self {
        Self::segmented(fc_hz, dt, keep, Vec::new())
    }

    /// [`LowpassCache::new`] for signals made of the pieces `segments` (consecutive ranges
    /// covering the signal from its first sample), each filtered on its own; `keep` is
    /// increasing and lies within them.
    pub fn segmented(
        fc_hz: f64,
        dt: f64,
        keep: Vec<usize>,
        segments: Vec<std::ops::Range<usize>>,
    ) -> Self {
        debug_assert!(segments.windows(2).all(|w| w[0].end == w[1].start));
        debug_assert!(keep.windows(2).all(|w| w[0] < w[1]));
        Self {
            fc_hz,
            dt,
            keep,
            segments,
            map: std::sync::Mutex::new(CacheMap::default()),
        }
    }

    /// [`lowpass_zero_phase`] of `x`, piece by piece (not memoised).
    pub fn lowpass(&self, x: &[f64]) -> Vec<f64> {
        if self.segments.len() <= 1 {
            return lowpass_zero_phase(x, self.fc_hz, self.dt);
        }
        let mut y = Vec::with_capacity(x.len());
        for s in &self.segments {
            y.extend(lowpass_zero_phase(&x[s.clone()], self.fc_hz, self.dt));
        }
        y
    }

    /// The sample indices of [`LowpassCache::kept_key`] results.
    pub fn keep(&self) -> &[usize] {
        &self.keep
    }

    fn memo(&self, x: &[f64], salt: u64, f: impl FnOnce() -> Vec<f64>) -> std::sync::Arc<Vec<f64>> {
        self.memo_key(fingerprint(x, salt), f)
    }

    /// The vector memoised under `key`, made by `f` on a miss (a key from
    /// [`fingerprint_words`] of what determines the vector; keys of [`LowpassCache::full`]
    /// are content fingerprints with salt 1).
    pub fn memo_key(
        &self,
        key: [u64; 2],
        f: impl FnOnce() -> Vec<f64>,
    ) -> std::sync::Arc<Vec<f64>> {
        if let Some(v) = self.lock().entries.get(&key) {
            return v.clone();
        }
        // Filtered outside the lock: another thread may filter the same signal meanwhile,
        // which costs time only (both results are equal).
        let v = std::sync::Arc::new(f());
        let mut map = self.lock();
        let size = 8 * v.len() + 64;
        if map.bytes + size > LOWPASS_CACHE_BYTES {
            map.entries.clear();
            map.bytes = 0;
        }
        map.bytes += size;
        map.entries.insert(key, v.clone());
        v
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, CacheMap> {
        // A panic while holding the lock leaves a consistent map (insert or clear).
        self.map
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// [`lowpass_zero_phase`] of `x` at every sample.
    pub fn full(&self, x: &[f64]) -> std::sync::Arc<Vec<f64>> {
        self.memo(x, 1, || self.lowpass(x))
    }

    /// [`lowpass_zero_phase`] of the signal `x()` at the sample indices
    /// [`LowpassCache::keep`], memoised under `key` (see [`LowpassCache::memo_key`]): the
    /// signal is made only on a miss.
    pub fn kept_key(
        &self,
        key: [u64; 2],
        x: impl FnOnce() -> Vec<f64>,
    ) -> std::sync::Arc<Vec<f64>> {
        self.memo_key(key, || self.lowpass_kept(&x()))
    }

    fn lowpass_kept(&self, x: &[f64]) -> Vec<f64> {
        if self.segments.len() <= 1 {
            return lowpass_zero_phase_at(x, self.fc_hz, self.dt, &self.keep);
        }
        let mut out = Vec::with_capacity(self.keep.len());
        let mut rest = &self.keep[..];
        for s in &self.segments {
            let (here, after) = rest.split_at(rest.partition_point(|&t| t < s.end));
            let local: Vec<usize> = here.iter().map(|&t| t - s.start).collect();
            out.extend(lowpass_zero_phase_at(
                &x[s.clone()],
                self.fc_hz,
                self.dt,
                &local,
            ));
            rest = after;
        }
        out
    }
}

impl Clone for LowpassCache {
    fn clone(&self) -> Self {
        Self::segmented(
            self.fc_hz,
            self.dt,
            self.keep.clone(),
            self.segments.clone(),
        )
    }
}

impl std::fmt::Debug for LowpassCache {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LowpassCache")
            .field("fc_hz", &self.fc_hz)
            .field("dt", &self.dt)
            .field("kept_samples", &self.keep.len())
            .field("entries", &self.lock().entries.len())
            .finish()
    }
}

/// First derivative (per s) by the five-point central difference (error `O(h⁴)`), lower
/// order at the ends.
pub fn derivative(x: &[f64], dt: f64) -> Vec<f64> {
    let n = x.len();
    let mut d = vec![0.0; n];
    if n < 2 {
        return d;
    }
    for i in 0..n {
        d[i] = if i >= 2 && i + 2 < n {
            (-x[i + 2] + 8.0 * x[i + 1] - 8.0 * x[i - 1] + x[i - 2]) / (12.0 * dt)
        } else if i >= 1 && i + 1 < n {
            (x[i + 1] - x[i - 1]) / (2.0 * dt)
        } else if i == 0 {
            (x[1] - x[0]) / dt
        } else {
            (x[n - 1] - x[n - 2]) / dt
        };
    }
    d
}

/// Second derivative (per s²) by the five-point central difference, lower order at the
/// ends.
pub fn second_derivative(x: &[f64], dt: f64) -> Vec<f64> {
    let n = x.len();
    let mut d = vec![0.0; n];
    if n < 3 {
        return d;
    }
    let h2 = dt * dt;
    for i in 0..n {
        let j = i.clamp(1, n - 2);
        d[i] = if i >= 2 && i + 2 < n {
            (-x[i + 2] + 16.0 * x[i + 1] - 30.0 * x[i] + 16.0 * x[i - 1] - x[i - 2]) / (12.0 * h2)
        } else {
            (x[j + 1] - 2.0 * x[j] + x[j - 1]) / h2
        };
    }
    d
}

/// Mean.
pub fn mean(x: &[f64]) -> f64 {
    if x.is_empty() {
        0.0
    } else {
        x.iter().sum::<f64>() / x.len() as f64
    }
}

/// Root mean square.
pub fn rms(x: &[f64]) -> f64 {
    if x.is_empty() {
        0.0
    } else {
        (x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64).sqrt()
    }
}

/// Standard deviation (population).
pub fn std(x: &[f64]) -> f64 {
    let m = mean(x);
    if x.is_empty() {
        0.0
    } else {
        (x.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / x.len() as f64).sqrt()
    }
}

/// Normalised RMS error `rms(model − measured) / std(measured)` (fraction).
pub fn nrmse(measured: &[f64], model: &[f64]) -> f64 {
    let e: Vec<f64> = measured.iter().zip(model).map(|(a, b)| b - a).collect();
    let s = std(measured);
    if s > 0.0 {
        rms(&e) / s
    } else {
        f64::INFINITY
    }
}

/// The `p`-quantile (`p` in [0, 1]) of `x` (nearest rank).
pub fn quantile(x: &[f64], p: f64) -> f64 {
    quantile_of(x.to_vec(), p)
}

/// [`quantile`] of the values `v`, reordered in place.
pub fn quantile_of(mut v: Vec<f64>, p: f64) -> f64 {
    v.retain(|v| v.is_finite());
    if v.is_empty() {
        return 0.0;
    }
    let i = ((v.len() - 1) as f64 * p.clamp(0.0, 1.0)).round() as usize;
    // The i-th order statistic by selection (linear time), as a full sort would give it.
    *v.select_nth_unstable_by(i, f64::total_cmp).1
}

/// Frequency (Hz) below which the fraction `p` of the power of the mean-removed signal
/// lies (periodogram of the whole record, sampled every `dt` s).
pub fn power_quantile_hz(x: &[f64], dt: f64, p: f64) -> f64 {
    let n = x.len();
    if n < 4 {
        return 0.5 / dt;
    }
    let m = mean(x);
    let mut buf: Vec<Complex64> = x.iter().map(|v| Complex64::new(v - m, 0.0)).collect();
    FftPlanner::new().plan_fft_forward(n).process(&mut buf);
    let half = n / 2;
    let power: Vec<f64> = buf[1..=half].iter().map(|c| c.norm_sqr()).collect();
    let total: f64 = power.iter().sum();
    if total <= 0.0 {
        return 0.5 / dt;
    }
    let mut acc = 0.0;
    for (k, pw) in power.iter().enumerate() {
        acc += pw;
        if acc >= p * total {
            return (k + 1) as f64 / (n as f64 * dt);
        }
    }
    0.5 / dt
}

/// Highest frequency (Hz) where the mean-removed signal stands clearly above its noise
/// floor: the periodogram averaged in 1/6-octave bands exceeds `snr` times the noise floor,
/// taken as the median periodogram ordinate in the top 30 % of the band (0.35–0.5 of the
/// sample rate, where oversampled mechanical records hold measurement noise only).
/// Returns the Nyquist frequency when no band falls below the threshold.
pub fn signal_band_edge_hz(x: &[f64], dt: f64, snr: f64) -> f64 {
    match bands_above_noise(x, dt, snr) {
        Some((bands, df)) => bands
            .iter()
            .filter(|b| b.2)
            .map(|b| b.1)
            .fold(2.0 * df, f64::max)
            .min(0.5 / dt),
        None => 0.5 / dt,
    }
}

/// Lowest frequency (Hz) from which the mean-removed signal stands clearly above its noise
/// floor: the lower edge of the lowest 1/6-octave band whose mean periodogram exceeds
/// `snr` times the noise floor (as in [`signal_band_edge_hz`]). Returns the Nyquist
/// frequency when no band does, and two frequency bins for records too short to tell.
pub fn signal_low_edge_hz(x: &[f64], dt: f64, snr: f64) -> f64 {
    match bands_above_noise(x, dt, snr) {
        Some((bands, _)) => bands.iter().find(|b| b.2).map_or(0.5 / dt, |b| b.0),
        None => 2.0 / (x.len().max(1) as f64 * dt),
    }
}

/// The 1/6-octave bands from two frequency bins up to 0.35 of the sample rate, each
/// `(from Hz, to Hz, mean periodogram above snr × the noise floor)`, and the bin width;
/// `None` under 64 samples or with no noise floor (see [`signal_band_edge_hz`]).
#[allow(clippy::type_complexity)]
fn bands_above_noise(x: &[f64], dt: f64, snr: f64) -> Option<(Vec<(f64, f64, bool)>, f64)> {
    let n = x.len();
    if n < 64 {
        return None;
    }
    let m = mean(x);
    let mut buf: Vec<Complex64> = x.iter().map(|v| Complex64::new(v - m, 0.0)).collect();
    FftPlanner::new().plan_fft_forward(n).process(&mut buf);
    let half = n / 2;
    let df = 1.0 / (n as f64 * dt);
    let power: Vec<f64> = buf[..=half].iter().map(|c| c.norm_sqr()).collect();
    let lo = ((0.35 / dt) / df) as usize;
    let floor = quantile(&power[lo.min(half)..=half], 0.5);
    if floor <= 0.0 {
        return None;
    }
    let ratio = 2f64.powf(1.0 / 6.0);
    let mut f = 2.0 * df;
    let mut bands = Vec::new();
    while f < 0.35 / dt {
        let (a, b) = (
            (f / df) as usize,
            ((f * ratio / df) as usize).max((f / df) as usize + 1),
        );
        let band = &power[a.min(half)..b.min(half + 1)];
        bands.push((f, f * ratio, !band.is_empty() && mean(band) > snr * floor));
        f *= ratio;
    }
    Some((bands, df))
}

/// Standard deviation of the white measurement noise on `x` (sampled every `dt` s),
/// estimated from the top of the band (0.35–0.5 of the sample rate, where oversampled
/// mechanical records hold measurement noise only): for white noise of variance `σ²` the
/// periodogram ordinates `|X_k|²` are exponential with mean `n σ²`, so their median is
/// `n σ² ln 2`. Signal content in that band makes it an overestimate; 0 for fewer than 64
/// samples.
pub fn noise_std(x: &[f64], dt: f64) -> f64 {
    let n = x.len();
    if n < 64 {
        return 0.0;
    }
    let m = mean(x);
    let mut buf: Vec<Complex64> = x.iter().map(|v| Complex64::new(v - m, 0.0)).collect();
    FftPlanner::new().plan_fft_forward(n).process(&mut buf);
    let half = n / 2;
    let df = 1.0 / (n as f64 * dt);
    let lo = (((0.35 / dt) / df) as usize).min(half);
    let tail: Vec<f64> = buf[lo..=half].iter().map(|c| c.norm_sqr()).collect();
    (quantile(&tail, 0.5) / (n as f64 * std::f64::consts::LN_2)).sqrt()
}

/// Integrated autocorrelation time `τ = 1 + 2 Σ ρ_k` (samples, >= 1) of a residual, the sum
/// running until `ρ_k` first drops below 0.05 (at most `n/4` lags): `n / τ` is the number of
/// effectively independent samples.
pub fn correlation_time(r: &[f64]) -> f64 {
    let n = r.len();
    if n < 8 {
        return 1.0;
    }
    let m = mean(r);
    let c0: f64 = r.iter().map(|v| (v - m) * (v - m)).sum();
    if c0 <= 0.0 {
        return 1.0;
    }
    let mut tau = 1.0;
    for k in 1..n / 4 {
        let ck: f64 = r[k..].iter().zip(r).map(|(a, b)| (a - m) * (b - m)).sum();
        let rho = ck / c0;
        if rho < 0.05 {
            break;
        }
        tau += 2.0 * rho;
    }
    tau
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lowpass_at_kept_samples_is_the_full_lowpass_there() {
        let mut rng = mil_numerics::rng::SplitMix64::new(5u64);
        let x: Vec<f64> = (0..5000).map(|_| rng.uniform() - 0.5).collect();
        let full = lowpass_zero_phase(&x, 40.0, 1e-3);
        let keep: Vec<usize> = (7..4990).step_by(5).collect();
        let at = lowpass_zero_phase_at(&x, 40.0, 1e-3, &keep);
        assert_eq!(at, keep.iter().map(|&t| full[t]).collect::<Vec<_>>());
        // Passed unchanged above 0.49 of the rate, at the kept samples too.
        assert_eq!(
            lowpass_zero_phase_at(&x, 600.0, 1e-3, &[3, 9]),
            vec![x[3], x[9]]
        );
    }

    #[test]
    fn a_segmented_cache_filters_each_piece_as_a_record_of_its_own() {
        let mut rng = mil_numerics::rng::SplitMix64::new(11u64);
        // Three pieces, the middle one offset by a large step (a junction's jump).
        let pieces: Vec<Vec<f64>> = [0.0, 50.0, -3.0]
            .iter()
            .zip([1200usize, 900, 1500])
            .map(|(off, n)| (0..n).map(|_| off + rng.uniform() - 0.5).collect())
            .collect();
        let x: Vec<f64> = pieces.concat();
        let mut segments = Vec::new();
        let mut start = 0;
        for p in &pieces {
            segments.push(start..start + p.len());
            start += p.len();
        }
        let keep: Vec<usize> = segments
            .iter()
            .flat_map(|s| (s.start + 60..s.end - 60).step_by(3))
            .collect();
        let cache = LowpassCache::segmented(40.0, 1e-3, keep.clone(), segments.clone());
        let own: Vec<f64> = pieces
            .iter()
            .flat_map(|p| lowpass_zero_phase(p, 40.0, 1e-3))
            .collect();
        assert_eq!(cache.lowpass(&x), own);
        assert_eq!(*cache.full(&x), own);
        let at = cache.kept_key([1, 2], || x.clone());
        assert_eq!(*at, keep.iter().map(|&t| own[t]).collect::<Vec<_>>());
        // Filtered across the junctions instead, the kept samples near them differ.
        let across = lowpass_zero_phase(&x, 40.0, 1e-3);
        assert!(keep.iter().any(|&t| (across[t] - own[t]).abs() > 1e-3));
    }

    #[test]
    fn quantile_is_the_nearest_rank_of_the_sorted_values() {
        let mut rng = mil_numerics::rng::SplitMix64::new(17u64);
        let mut x: Vec<f64> = (0..1001).map(|_| rng.uniform()).collect();
        x.push(f64::NAN);
        let mut sorted: Vec<f64> = x.iter().copied().filter(|v| v.is_finite()).collect();
        sorted.sort_by(f64::total_cmp);
        for p in [0.0, 0.03, 0.5, 0.9, 0.997, 1.0] {
            let i = ((sorted.len() - 1) as f64 * p).round() as usize;
            assert_eq!(quantile(&x, p), sorted[i], "p = {p}");
        }
        assert_eq!(quantile(&[], 0.5), 0.0);
    }

    #[test]
    fn lowpass_passes_low_and_stops_high() {
        let dt = 1e-3;
        let sine = |f: f64| -> Vec<f64> {
            (0..4000)
                .map(|i| (2.0 * std::f64::consts::PI * f * i as f64 * dt).sin())
                .collect()
        };
        let low = lowpass_zero_phase(&sine(2.0), 50.0, dt);
        let s = sine(2.0);
        let err: f64 = low[500..3500]
            .iter()
            .zip(&s[500..3500])
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(err < 1e-3, "{err}");
        let high = lowpass_zero_phase(&sine(300.0), 50.0, dt);
        assert!(rms(&high[500..3500]) < 1e-3);
    }

    #[test]
    fn derivatives_of_a_sine() {
        let dt = 1e-3;
        let w = 2.0 * std::f64::consts::PI * 20.0;
        let x: Vec<f64> = (0..1000).map(|i| (w * i as f64 * dt).sin()).collect();
        let d = derivative(&x, dt);
        let dd = second_derivative(&x, dt);
        for i in 10..990 {
            let t = i as f64 * dt;
            assert!((d[i] - w * (w * t).cos()).abs() < 1e-4 * w);
            assert!((dd[i] + w * w * (w * t).sin()).abs() < 1e-4 * w * w);
        }
    }

    #[test]
    fn noise_std_of_a_slow_signal_with_white_noise() {
        let mut rng = mil_numerics::rng::SplitMix64::new(777);
        let mut normal = move || rng.normal();
        let dt = 1e-3;
        for sigma in [1e-4, 0.02] {
            let x: Vec<f64> = (0..20_000)
                .map(|i| {
                    (2.0 * std::f64::consts::PI * 3.0 * i as f64 * dt).sin() + sigma * normal()
                })
                .collect();
            let est = noise_std(&x, dt);
            assert!((est / sigma - 1.0).abs() < 0.1, "{sigma}: {est}");
        }
    }

    #[test]
    fn white_noise_has_unit_correlation_time() {
        let mut rng = mil_numerics::rng::SplitMix64::new(12345);
        let r: Vec<f64> = (0..5000).map(|_| rng.uniform() - 0.5).collect();
        assert!(correlation_time(&r) < 1.2);
        let smooth = lowpass_zero_phase(&r, 25.0, 1e-3);
        assert!(correlation_time(&smooth) > 5.0);
    }
}
