//! # mil-identify
//!
//! Frequency-response identification from time-series test records and the
//! frequency-response table (CSV) that the analysis reads (`mil-analysis`), following the
//! identification step of A. R. Plummer, *Model-in-the-loop testing*, Proc. IMechE Part I
//! 220 (2006): the rig engineer drives the actuator with a sine sweep and with random (pink)
//! noise, records input and output, and estimates the frequency response with the H1
//! estimator, Welch averaging and the coherence.
//!
//! Host side, `std`, `f64`. Units: SI; frequencies in Hz; phase in degrees; magnitudes
//! linear (not dB) in the response's own units (output units per input unit).
//!
//! ## Overview
//! - Excitation: [`log_sine_sweep`], [`band_limited_noise`] (and the non-panicking
//!   [`try_log_sine_sweep`], [`try_band_limited_noise`]).
//! - Records: [`read_record_csv`] / [`read_record_from_reader`] read a time-series CSV;
//!   [`Record`] pairs an input and an output.
//! - Estimation: [`h1_estimate`] with [`WelchOptions`] gives an [`FrfEstimate`];
//!   [`FrfEstimate::to_table`] keeps the well-excited band as an [`FrfTable`].
//! - Tables: [`FrfTable`] (validated, phase unwrapped), CSV read and write, interpolation
//!   ([`FrfTable::response`]).
//!
//! ## H1 estimator
//! For an input `u` and output `y = h * u + n`, with `n` noise uncorrelated with `u`, the
//! cross-spectrum is `S_yu = H S_uu` (the noise averages out of it), so
//! `H1(f) = S_yu(f) / S_uu(f)` is an unbiased estimate of the response `H(f)` however noisy the
//! **output** is: output noise only adds random error, which averaging reduces. Noise on the
//! measured **input** biases H1 low (by `S_uu / (S_uu + S_nn)`); use the actual input
//! signal (e.g. the command) where possible. Here `S_yu = E[Y U*]`.
//!
//! ## Welch averaging
//! The spectra are estimated by averaging over segments ([`WelchOptions`]): each record is
//! cut into segments of `segment_length` samples overlapping by a fraction `overlap`
//! (default 4096 samples, 75 %); each segment has its mean removed, is multiplied by a window
//! (default Hann, to limit leakage) and transformed by an FFT; the products `|U|²`, `|Y|²`,
//! `Y U*` are summed over all segments of all records given. Several records (e.g. a sweep
//! and a noise record) are thus averaged together, each contributing where it has power.
//! The frequency resolution is `sample_rate / segment_length`; more segments mean less random
//! error (the random error of `|H1|` is about `√(1 − γ²) / (γ √(2 n_segments))` relative).
//! Long segments also reduce the bias from the leakage of responses longer than a segment
//! (lightly damped modes, delays): choose the resolution well below a mode's half-power
//! bandwidth `2ζ f_n`. For sweep records use an overlap of 2/3 or 3/4 with the Hann window
//! (see [`WelchOptions::overlap`]). The DC bin and the Nyquist bin are not reported.
//!
//! ## Coherence
//! `γ²(f) = |S_yu|² / (S_uu S_yy)`, between 0 and 1: the fraction of the output power at `f`
//! that is linearly explained by the input. It is 1 for a noise-free linear system with
//! enough excitation, and drops with output noise, nonlinearity, unexcited frequencies and
//! leakage. [`FrfEstimate::to_table`] keeps only points with coherence above a threshold
//! (0.9–0.95 is usual) inside a band, which should be the excited band: coherence does not
//! reveal leakage into unexcited bins where the response is flat.
//!
//! ## Frequency-response table (CSV)
//! This is the single definition of this file format in the project.
//!
//! ```text
//! frequency_hz,magnitude,phase_deg,coherence
//! 1,1.0002,-0.61,0.998
//! 1.12,1.0003,-0.69,0.999
//! ```
//!
//! - A header, exactly `frequency_hz,magnitude,phase_deg`, optionally followed by a fourth
//!   column `coherence`; one row per frequency; comma-separated, spaces around fields ignored.
//! - `frequency_hz`: frequency (Hz), finite, > 0, strictly increasing down the file (no
//!   duplicates).
//! - `magnitude`: linear (not dB), finite, >= 0, in the response's own units: dimensionless for
//!   a tracking response (measured / demanded force), N/m for a force-per-displacement
//!   disturbance response, and so on.
//! - `phase_deg`: phase (degrees), finite. Written unwrapped (continuous: consecutive rows
//!   differ by at most 180°). A wrapped column (e.g. in `(-180, 180]`) is accepted on reading
//!   and unwrapped: each phase is shifted by a multiple of 360° so that consecutive rows differ
//!   by a value in `(-180°, 180°]`, keeping the first row's phase.
//! - `coherence` (optional): ordinary coherence of the estimate, in `[0, 1]`.
//!
//! Numbers are written in the shortest form that reads back to the same `f64` (exponent
//! notation for very small or large values). Reading rejects a wrong header, a wrong number
//! of fields, a non-number or non-finite value, an unsorted or duplicate frequency, a
//! negative magnitude, a coherence outside `[0, 1]`, and fewer than 2 rows, with an error
//! naming the file and line.
//!
//! Between rows, [`FrfTable::response`] interpolates linearly in `log10(frequency)` both
//! `ln(magnitude)` and the unwrapped phase; it is exact at the rows and refuses frequencies
//! outside the first and last row.

pub mod error;
pub mod excitation;
pub mod fit;
pub mod record;
pub mod table;
pub mod welch;

pub use error::{IdentifyError, Result};
pub use excitation::{
    band_limited_noise, log_sine_sweep, try_band_limited_noise, try_log_sine_sweep,
};
pub use fit::LowOrderFit;
pub use num_complex::Complex64;
pub use record::{read_record_csv, read_record_from_reader};
pub use table::{unwrap_phase_deg, FrfPoint, FrfTable, CSV_COLUMNS};
pub use welch::{h1_estimate, FrfEstimate, Record, WelchOptions, Window};
