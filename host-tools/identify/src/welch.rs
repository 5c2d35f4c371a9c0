//! H1 frequency-response estimation with Welch averaging and coherence.

use num_complex::Complex64;
use rustfft::FftPlanner;

use crate::error::{IdentifyError, Result};
use crate::table::FrfTable;

/// One test record: the input (e.g. the force command) and the output (e.g. the measured
/// force) of the system being identified, the same length, uniformly sampled at the rate
/// given to [`h1_estimate`]. Units are the signals' own; the response has units
/// output/input.
#[derive(Debug, Clone, Copy)]
pub struct Record<'a> {
    /// Input samples.
    pub input: &'a [f64],
    /// Output samples, simultaneous with the input.
    pub output: &'a [f64],
}

/// The data window applied to each Welch segment.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Window {
    /// Periodic Hann window `0.5 - 0.5 cos(2πn/L)`, `n = 0..L`: low leakage; the default.
    #[default]
    Hann,
    /// No window (all ones): only for excitation that is periodic in the segment length.
    Rectangular,
}

impl Window {
    /// The window's `length` samples.
    pub fn samples(self, length: usize) -> Vec<f64> {
        match self {
            Window::Hann => (0..length)
                .map(|n| 0.5 - 0.5 * (2.0 * std::f64::consts::PI * n as f64 / length as f64).cos())
                .collect(),
            Window::Rectangular => vec![1.0; length],
        }
    }
}

/// Options of the Welch averaging in [`h1_estimate`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WelchOptions {
    /// Samples per segment (>= 4). The frequency resolution is `sample_rate / segment_length`
    /// (Hz); any length works, powers of two are fastest.
    pub segment_length: usize,
    /// Fraction of a segment shared with the next one, in `[0, 1)`; the hop between segment
    /// starts is `round(segment_length · (1 - overlap))` samples (at least 1).
    ///
    /// The default 0.75 suits both record kinds. 0.5 is enough for stationary (noise)
    /// records, but not for a sweep with the Hann window: with 50 % overlap the summed window weight `Σ w²` along the record varies
    /// by ±33 %, and since each frequency of a sweep occurs at one time, and reaches the
    /// output a group delay later, this biases the estimate near lightly damped modes (in the
    /// crate's tests about 0.8 dB at a ζ = 0.05 mode, against 0.2 dB with 0.75).
    pub overlap: f64,
    /// Window applied to each segment after removing its mean.
    pub window: Window,
}

impl Default for WelchOptions {
    /// 4096-sample segments, 75 % overlap (right for sweep and noise records alike), Hann
    /// window.
    fn default() -> Self {
        Self {
            segment_length: 4096,
            overlap: 0.75,
            window: Window::Hann,
        }
    }
}

impl WelchOptions {
    /// Longest segment [`WelchOptions::for_record`] chooses (samples).
    pub const MAX_AUTO_SEGMENT: usize = 4096;
    /// Shortest segment [`WelchOptions::for_record`] chooses (samples).
    pub const MIN_AUTO_SEGMENT: usize = 16;

    /// The workspace's segment rule for a record of `samples` samples whose user gave no
    /// segment length: the longest power of two that fits 8 times into the record (about 29
    /// averaged segments at 75 % overlap: a coherence worth reading), between
    /// [`Self::MIN_AUTO_SEGMENT`] and [`Self::MAX_AUTO_SEGMENT`]; default overlap and window.
    pub fn for_record(samples: usize) -> Self {
        let mut segment = Self::MIN_AUTO_SEGMENT;
        while segment * 2 <= samples / 8 && segment < Self::MAX_AUTO_SEGMENT {
            segment *= 2;
        }
        Self {
            segment_length: segment,
            ..Self::default()
        }
    }

    /// The segment rule for a response compared over a band starting at `f_min_hz`: the
    /// resolution `sample_rate_hz / segment` puts at least four bins below `f_min_hz`, so the
    /// band's lowest mode is resolved (a lightly damped mode between coarse bins loses its
    /// coherence to leakage and bias), as long as the record holds four segments (13
    /// averages at 75 % overlap); never shorter than [`Self::for_record`]'s segment.
    /// A band edge that is not positive and finite gives [`Self::for_record`].
    pub fn for_band(samples: usize, sample_rate_hz: f64, f_min_hz: f64) -> Self {
        let base = Self::for_record(samples);
        if !(f_min_hz.is_finite() && f_min_hz > 0.0 && sample_rate_hz.is_finite()) {
            return base;
        }
        // Shortest power of two with fs / segment <= f_min / 4 ...
        let wanted = 4.0 * sample_rate_hz / f_min_hz;
        let mut segment = base.segment_length;
        // ... no longer than a quarter of the record.
        while (segment as f64) < wanted && segment * 2 <= samples / 4 {
            segment *= 2;
        }
        Self {
            segment_length: segment,
            ..base
        }
    }

    /// Checks the options; errors name the bad field.
    pub fn validate(&self) -> Result<()> {
        if self.segment_length < 4 {
            return Err(IdentifyError::InvalidArgument(format!(
                "segment_length {} is below 4 samples",
                self.segment_length
            )));
        }
        if !(self.overlap.is_finite() && (0.0..1.0).contains(&self.overlap)) {
            return Err(IdentifyError::InvalidArgument(format!(
                "overlap {} is outside [0, 1)",
                self.overlap
            )));
        }
        Ok(())
    }

    /// The hop between the starts of consecutive segments (samples).
    pub fn hop(&self) -> usize {
        ((self.segment_length as f64 * (1.0 - self.overlap)).round() as usize).max(1)
    }
}

/// An H1 frequency-response estimate, one entry per frequency bin.
#[derive(Debug, Clone, PartialEq)]
pub struct FrfEstimate {
    /// Bin frequencies `k · sample_rate / segment_length` (Hz), `k = 1, 2, …` up to below
    /// the Nyquist frequency (DC and the Nyquist bin are excluded).
    pub frequency_hz: Vec<f64>,
    /// H1 estimate `S_yu / S_uu` (output units per input unit); NaN in a bin where the
    /// input has no power at all.
    pub response: Vec<Complex64>,
    /// Ordinary coherence `|S_yu|² / (S_uu S_yy)`, in `[0, 1]` (0 where a spectrum is 0).
    pub coherence: Vec<f64>,
    /// Number of segments averaged, over all records.
    pub segments: usize,
}

impl FrfEstimate {
    /// The points with frequency in `[f_min_hz, f_max_hz]` (Hz), a finite response and
    /// coherence >= `min_coherence`, as a table (phase unwrapped, coherence column kept).
    ///
    /// Phase is unwrapped across the points kept: if the selection leaves gaps where the
    /// phase changes by more than 180°, the unwrapped phase is ambiguous there.
    ///
    /// Give the excited band as `[f_min_hz, f_max_hz]`: just outside it the input holds only
    /// the window's leakage from the band, and where the response is nearly flat the
    /// coherence of such bins can still be close to 1 although their estimate is really the
    /// response at the band's edge.
    ///
    /// Errors: invalid band or threshold; fewer than 2 points pass.
    pub fn to_table(&self, f_min_hz: f64, f_max_hz: f64, min_coherence: f64) -> Result<FrfTable> {
        if !(f_min_hz.is_finite() && f_max_hz.is_finite() && f_min_hz <= f_max_hz) {
            return Err(IdentifyError::InvalidArgument(format!(
                "frequency band [{f_min_hz}, {f_max_hz}] Hz is not a finite interval"
            )));
        }
        if min_coherence.is_nan() {
            return Err(IdentifyError::InvalidArgument(
                "min_coherence is NaN".to_string(),
            ));
        }
        let mut frequency = Vec::new();
        let mut response = Vec::new();
        let mut coherence = Vec::new();
        for ((&f, &h), &c) in self
            .frequency_hz
            .iter()
            .zip(&self.response)
            .zip(&self.coherence)
        {
            if f >= f_min_hz
                && f <= f_max_hz
                && c >= min_coherence
                && h.re.is_finite()
                && h.im.is_finite()
            {
                frequency.push(f);
                response.push(h);
                coherence.push(c);
            }
        }
        if frequency.len() < 2 {
            return Err(IdentifyError::TooFewEstimatePoints {
                count: frequency.len(),
                f_min_hz,
                f_max_hz,
                min_coherence,
            });
        }
        FrfTable::from_response(&frequency, &response, Some(&coherence))
    }
}

fn check_record(index: usize, record: &Record<'_>, segment_length: usize) -> Result<()> {
    if record.input.len() != record.output.len() {
        return Err(IdentifyError::LengthMismatch {
            record: index,
            input: record.input.len(),
            output: record.output.len(),
        });
    }
    if record.input.len() < segment_length {
        return Err(IdentifyError::RecordTooShort {
            record: index,
            samples: record.input.len(),
            segment_length,
        });
    }
    for (signal, data) in [("input", record.input), ("output", record.output)] {
        if let Some((i, &v)) = data.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(IdentifyError::NonFinite {
                record: index,
                signal,
                index: i,
                value: v,
            });
        }
    }
    Ok(())
}

/// Fills `buffer` with the mean-removed, windowed segment.
fn load_segment(buffer: &mut [Complex64], data: &[f64], window: &[f64]) {
    let mean = data.iter().sum::<f64>() / data.len() as f64;
    for ((b, &x), &w) in buffer.iter_mut().zip(data).zip(window) {
        *b = Complex64::new((x - mean) * w, 0.0);
    }
}

/// H1 frequency-response estimate from one or more records, with Welch averaging.
///
/// Every record is cut into segments of `options.segment_length` samples, consecutive
/// segments overlapping by `options.overlap`; each segment of input `u` and output `y` has
/// its mean removed, is windowed and Fourier transformed (`U_m`, `Y_m`). The spectra are
/// summed over all segments of all records (so a sweep record and a noise record are
/// averaged together, each segment with the weight of its own power):
/// `S_uu = Σ|U_m|²`, `S_yy = Σ|Y_m|²`, `S_yu = Σ Y_m U_m*`; then `H1 = S_yu / S_uu` and the
/// coherence `γ² = |S_yu|² / (S_uu S_yy)`. Scale factors cancel in both ratios.
///
/// `sample_rate_hz` (Hz) is the sampling rate of all records.
///
/// Errors: no records, bad sample rate or options, input and output of different lengths,
/// a record shorter than one segment, a non-finite sample, an input without any variation.
pub fn h1_estimate(
    records: &[Record<'_>],
    sample_rate_hz: f64,
    options: &WelchOptions,
) -> Result<FrfEstimate> {
    if !(sample_rate_hz.is_finite() && sample_rate_hz > 0.0) {
        return Err(IdentifyError::InvalidArgument(format!(
            "sample rate {sample_rate_hz} Hz is not positive and finite"
        )));
    }
    options.validate()?;
    if records.is_empty() {
        return Err(IdentifyError::InvalidArgument(
            "no records to estimate from".to_string(),
        ));
    }
    let len = options.segment_length;
    for (i, r) in records.iter().enumerate() {
        check_record(i, r, len)?;
    }

    let window = options.window.samples(len);
    let hop = options.hop();
    // Bins 1..=bins: DC excluded, and the Nyquist bin (even lengths), whose Fourier
    // coefficients are real and so carry no phase.
    let bins = (len - 1) / 2;
    let fft = FftPlanner::<f64>::new().plan_fft_forward(len);
    let mut scratch = vec![Complex64::default(); fft.get_inplace_scratch_len()];
    let mut u_buf = vec![Complex64::default(); len];
    let mut y_buf = vec![Complex64::default(); len];
    let mut s_uu = vec![0.0; bins];
    let mut s_yy = vec![0.0; bins];
    let mut s_yu = vec![Complex64::default(); bins];
    let mut segments = 0;

    for r in records {
        let n = r.input.len();
        for start in (0..=n - len).step_by(hop) {
            load_segment(&mut u_buf, &r.input[start..start + len], &window);
            load_segment(&mut y_buf, &r.output[start..start + len], &window);
            fft.process_with_scratch(&mut u_buf, &mut scratch);
            fft.process_with_scratch(&mut y_buf, &mut scratch);
            for k in 0..bins {
                let (u, y) = (u_buf[k + 1], y_buf[k + 1]);
                s_uu[k] += u.norm_sqr();
                s_yy[k] += y.norm_sqr();
                s_yu[k] += y * u.conj();
            }
            segments += 1;
        }
    }

    if s_uu.iter().all(|&p| p == 0.0) {
        return Err(IdentifyError::InvalidArgument(
            "the input has no variation within any segment".to_string(),
        ));
    }

    let frequency_hz = (1..=bins)
        .map(|k| k as f64 * sample_rate_hz / len as f64)
        .collect();
    let response = s_yu
        .iter()
        .zip(&s_uu)
        .map(|(&c, &p)| {
            if p > 0.0 {
                c / p
            } else {
                Complex64::new(f64::NAN, f64::NAN)
            }
        })
        .collect();
    let coherence = s_yu
        .iter()
        .zip(s_uu.iter().zip(&s_yy))
        .map(|(&c, (&pu, &py))| {
            let d = pu * py;
            if d > 0.0 {
                (c.norm_sqr() / d).clamp(0.0, 1.0)
            } else {
                0.0
            }
        })
        .collect();
    Ok(FrfEstimate {
        frequency_hz,
        response,
        coherence,
        segments,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_segment_rule_fits_eight_segments_between_its_bounds() {
        assert_eq!(WelchOptions::for_record(0).segment_length, 16);
        assert_eq!(WelchOptions::for_record(100).segment_length, 16);
        // 8 × 512 = 4096 fits, 8 × 1024 does not.
        assert_eq!(WelchOptions::for_record(4096).segment_length, 512);
        assert_eq!(WelchOptions::for_record(8191).segment_length, 512);
        assert_eq!(WelchOptions::for_record(8192).segment_length, 1024);
        assert_eq!(WelchOptions::for_record(10_000_000).segment_length, 4096);
        for n in [64, 1000, 33_000, 1 << 20] {
            let o = WelchOptions::for_record(n);
            assert!(o.segment_length.is_power_of_two());
            assert!(o.segment_length == 16 || 8 * o.segment_length <= n, "{n}");
            assert_eq!(o.overlap, WelchOptions::default().overlap);
        }
    }

    #[test]
    fn the_band_rule_resolves_the_lowest_band_edge_within_the_record() {
        // 1 Hz at 2 kHz: 8192 samples (0.24 Hz) from a 20 s run, as many as fit 4 times
        // into a short one, never shorter than the record rule.
        assert_eq!(
            WelchOptions::for_band(39_000, 2000.0, 1.0).segment_length,
            8192
        );
        assert_eq!(
            WelchOptions::for_band(20_000, 2000.0, 1.0).segment_length,
            4096
        );
        assert_eq!(
            WelchOptions::for_band(4000, 2000.0, 1.0).segment_length,
            512
        );
        assert_eq!(WelchOptions::for_record(4000).segment_length, 256);
        // A high band edge needs no more than the record rule.
        assert_eq!(
            WelchOptions::for_band(1 << 20, 2000.0, 100.0).segment_length,
            4096
        );
        assert_eq!(
            WelchOptions::for_band(1 << 20, 1000.0, 1.0).segment_length,
            4096
        );
        assert_eq!(
            WelchOptions::for_band(1 << 20, 1000.0, 0.5).segment_length,
            8192
        );
        for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert_eq!(
                WelchOptions::for_band(39_000, 2000.0, bad),
                WelchOptions::for_record(39_000)
            );
        }
    }
}
