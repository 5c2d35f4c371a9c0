//! The error type of every fallible operation in this crate.

use thiserror::Error;

/// Why a model could not be represented or discretised.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum DiscretiseError {
    /// The sample period `dt` (s) is not finite and positive.
    #[error("sample period must be finite and > 0 s, got {0} s")]
    InvalidSamplePeriod(f64),
    /// The pre-warp frequency (Hz) is not inside `(0, 1/(2 dt))`.
    #[error(
        "pre-warp frequency {freq_hz} Hz must lie strictly between 0 and Nyquist ({nyquist_hz} Hz)"
    )]
    InvalidPrewarp {
        /// The requested pre-warp frequency (Hz).
        freq_hz: f64,
        /// The Nyquist frequency `1/(2 dt)` (Hz).
        nyquist_hz: f64,
    },
    /// A coefficient, root, gain or matrix entry is NaN or infinite.
    #[error("non-finite value in {0}")]
    NonFinite(&'static str),
    /// A polynomial has no non-zero coefficient (e.g. an all-zero denominator).
    #[error("{0} polynomial is empty or identically zero")]
    ZeroPolynomial(&'static str),
    /// More zeros than poles: the system is not proper and has no causal discrete equivalent.
    #[error("improper system: {zeros} zeros but only {poles} poles")]
    Improper {
        /// Number of finite zeros.
        zeros: usize,
        /// Number of poles.
        poles: usize,
    },
    /// A complex root has no complex-conjugate partner, so the system is not real.
    #[error("complex {what} {re} + {im}j has no complex-conjugate partner")]
    NotConjugate {
        /// `"pole"` or `"zero"`.
        what: &'static str,
        /// Real part of the unmatched root.
        re: f64,
        /// Imaginary part of the unmatched root.
        im: f64,
    },
    /// Matrix or array dimensions do not fit together.
    #[error("dimension mismatch in {what}: expected {expected:?}, got {got:?}")]
    Dimension {
        /// Which matrix or conversion.
        what: &'static str,
        /// Expected `(rows, columns)`.
        expected: (usize, usize),
        /// Actual `(rows, columns)`.
        got: (usize, usize),
    },
    /// A matrix that must be inverted is singular (to working precision).
    #[error("singular matrix in {0}")]
    Singular(&'static str),
    /// A continuous pole or zero sits exactly on the Tustin map's singular point
    /// `s = 2/dt` (or `s = ω_p / tan(ω_p dt/2)` with pre-warping).
    #[error("root at s = {0} maps to infinity under the bilinear transform")]
    BilinearSingular(f64),
    /// The iterative root finder did not produce finite roots.
    #[error("root finding failed for {0}")]
    RootFinding(&'static str),
    /// The filter needs more second-order sections than `model_core::MAX_SECTIONS`.
    #[error("{needed} second-order sections needed, model-core holds at most {max}")]
    TooManySections {
        /// Sections the filter needs.
        needed: usize,
        /// `model_core::MAX_SECTIONS`.
        max: usize,
    },
    /// A coefficient does not fit in `f32` (overflows to infinity).
    #[error("coefficient {0} overflows f32")]
    F32Overflow(f64),
}

/// Shorthand for `Result<T, DiscretiseError>`.
pub type Result<T> = core::result::Result<T, DiscretiseError>;

/// `Ok(dt)` if the sample period is finite and positive.
pub(crate) fn check_dt(dt: f64) -> Result<f64> {
    if dt.is_finite() && dt > 0.0 {
        Ok(dt)
    } else {
        Err(DiscretiseError::InvalidSamplePeriod(dt))
    }
}
