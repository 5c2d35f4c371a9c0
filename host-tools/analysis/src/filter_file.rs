//! The command-filter file: the exported result of a filter design, loaded by the host
//! tools and (as f32 coefficients) by the firmware.
//!
//! JSON, for example:
//! ```json
//! { "format": "mil-command-filter", "version": 1, "sample_rate_hz": 2000.0,
//!   "sections": [ { "beta0": 1.9, "beta1": -0.21, "beta2": 0.0012,
//!                   "alpha1": 0.31, "alpha2": 0.024 } ],
//!   "figures": { "phase_lag_reduction_pct": 60.1, ... } }
//! ```
//! Sections are model-core's delta-form second-order sections
//! ([`model_core::BiquadCoefficients`]: `β0 = b0`, `β1 = 2 b0 + b1`, `β2 = b0 + b1 + b2`,
//! `α1 = 2 + a1`, `α2 = 1 + a1 + a2`), at most [`model_core::MAX_SECTIONS`], run in order.
//! Each section also carries, for other tools, its plain direct form in the scipy / MATLAB
//! `sos` convention (`[b0, b1, b2, 1, a1, a2]`, `H(z) = (b0 + b1 z⁻¹ + b2 z⁻²) /
//! (1 + a1 z⁻¹ + a2 z⁻²)`) and its zeros and poles (`[re, im]` pairs in the z-plane), all
//! derived from the delta form in `f64`; on reading, the delta form is what runs, and a file
//! whose `sos` disagrees with it is refused.

use crate::error::{AnalysisError, Result};
use model_core::{BiquadCoefficients, CascadeCoefficients};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The `format` tag of a filter file.
pub const FILTER_FORMAT: &str = "mil-command-filter";

/// One delta-form section as stored in the file (f32 values).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SectionRecord {
    /// `β0`.
    pub beta0: f32,
    /// `β1`.
    pub beta1: f32,
    /// `β2`.
    pub beta2: f32,
    /// `α1`.
    pub alpha1: f32,
    /// `α2`.
    pub alpha2: f32,
    /// The same section in the `sos` convention `[b0, b1, b2, 1, a1, a2]` (informative;
    /// checked against the delta form when present).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sos: Option<[f64; 6]>,
    /// Its zeros, `[re, im]` (informative; 0 to 2 of them).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub zeros: Option<Vec<[f64; 2]>>,
    /// Its poles, `[re, im]` (informative; 2).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub poles: Option<Vec<[f64; 2]>>,
}

impl SectionRecord {
    /// The record of `s`, with its direct form, zeros and poles.
    pub fn of(s: &BiquadCoefficients) -> Self {
        let ([b0, b1, b2], [a1, a2]) = s.to_direct_form();
        Self {
            beta0: s.beta0,
            beta1: s.beta1,
            beta2: s.beta2,
            alpha1: s.alpha1,
            alpha2: s.alpha2,
            sos: Some([b0, b1, b2, 1.0, a1, a2]),
            zeros: Some(roots(b0, b1, b2)),
            poles: Some(roots(1.0, a1, a2)),
        }
    }

    fn coefficients(&self) -> BiquadCoefficients {
        BiquadCoefficients {
            beta0: self.beta0,
            beta1: self.beta1,
            beta2: self.beta2,
            alpha1: self.alpha1,
            alpha2: self.alpha2,
        }
    }
}

/// The roots `[re, im]` of `c0 z² + c1 z + c2` (`mil_discretise::polynomial_roots`: a
/// leading zero coefficient lowers the degree; none for a constant or zero polynomial).
fn roots(c0: f64, c1: f64, c2: f64) -> Vec<[f64; 2]> {
    mil_discretise::polynomial_roots(&[c0, c1, c2])
        .map(|r| r.iter().map(|z| [z.re, z.im]).collect())
        .unwrap_or_default()
}

/// A command-filter file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FilterFile {
    /// Always [`FILTER_FORMAT`].
    pub format: String,
    /// File format version (1).
    pub version: u32,
    /// Sample rate the coefficients are for (Hz).
    pub sample_rate_hz: f64,
    /// The cascade's sections, in order.
    pub sections: Vec<SectionRecord>,
    /// Design figures (informative; not used when loading).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub figures: Option<serde_json::Value>,
}

impl FilterFile {
    /// A file for `cascade` at `sample_rate_hz`.
    pub fn new(cascade: &CascadeCoefficients, sample_rate_hz: f64) -> Self {
        Self {
            format: FILTER_FORMAT.into(),
            version: 1,
            sample_rate_hz,
            sections: cascade.active().iter().map(SectionRecord::of).collect(),
            figures: None,
        }
    }

    /// The validated cascade (model-core's own checks: finite, stable, finite DC gain).
    ///
    /// # Errors
    /// Wrong format or version, a bad sample rate, too many sections, or a cascade model-core
    /// refuses.
    pub fn cascade(&self) -> Result<CascadeCoefficients> {
        let bad = AnalysisError::FilterFile;
        if self.format != FILTER_FORMAT || self.version != 1 {
            return Err(bad(format!(
                "not a {FILTER_FORMAT} version 1 file (format {:?}, version {})",
                self.format, self.version
            )));
        }
        if !(self.sample_rate_hz.is_finite() && self.sample_rate_hz > 0.0) {
            return Err(bad("sample_rate_hz must be > 0".into()));
        }
        let sections: Vec<BiquadCoefficients> = self
            .sections
            .iter()
            .map(SectionRecord::coefficients)
            .collect();
        for (k, (record, s)) in self.sections.iter().zip(&sections).enumerate() {
            if let Some(sos) = record.sos {
                let ([b0, b1, b2], [a1, a2]) = s.to_direct_form();
                let want = [b0, b1, b2, 1.0, a1, a2];
                // The delta form is f32: agreement to its precision, scaled by the section.
                let scale = want.iter().fold(1.0_f64, |m, v| m.max(v.abs()));
                let off = sos
                    .iter()
                    .zip(want)
                    .map(|(x, y)| (x - y).abs())
                    .fold(0.0_f64, f64::max);
                if off > 1e-9 * scale {
                    return Err(bad(format!(
                        "section {k}: its sos {sos:?} is not its delta form's {want:?} (the \
                         delta form runs: fix or drop the sos)"
                    )));
                }
            }
        }
        let cascade = CascadeCoefficients::from_sections(&sections).ok_or_else(|| {
            bad(format!(
                "{} sections; at most {} fit model-core",
                sections.len(),
                model_core::MAX_SECTIONS
            ))
        })?;
        cascade
            .validate()
            .map_err(|e| bad(format!("model-core rejects the cascade: {e}")))?;
        Ok(cascade)
    }

    /// Reads and validates a filter file.
    ///
    /// # Errors
    /// I/O, JSON or validation errors.
    pub fn read(path: &Path) -> Result<(Self, CascadeCoefficients)> {
        let text = std::fs::read_to_string(path).map_err(|source| AnalysisError::Io {
            path: path.display().to_string(),
            source,
        })?;
        let file: Self = serde_json::from_str(&text).map_err(|e| AnalysisError::Parse {
            path: path.display().to_string(),
            message: e.to_string(),
        })?;
        let cascade = file.cascade().map_err(|e| match e {
            AnalysisError::FilterFile(m) => {
                AnalysisError::FilterFile(format!("{}: {m}", path.display()))
            }
            other => other,
        })?;
        Ok((file, cascade))
    }

    /// Writes the file (pretty JSON).
    ///
    /// # Errors
    /// I/O errors.
    pub fn write(&self, path: &Path) -> Result<()> {
        let text = serde_json::to_string_pretty(self).map_err(|e| AnalysisError::Parse {
            path: path.display().to_string(),
            message: e.to_string(),
        })?;
        // Whole or not at all: a board never loads a half-written filter.
        mil_numerics::files::write_atomic(path, (text + "\n").as_bytes())
            .map_err(AnalysisError::Write)
    }
}
