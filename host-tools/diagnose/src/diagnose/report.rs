//! What the workflow reports: the gap figure, the named effects, every candidate's score,
//! the [`Diagnosis`] with its human summary, and the JSON object of `mil diagnose --json`
//! ([`JsonReport`]).

use crate::effects::EffectKind;
use crate::evidence::{BandEvidence, RegionEvidence, WindowEvidence};
use crate::model::Model;
use crate::split::Split;
use crate::{Error, Result};
use mil_numerics::format::{number, with_uncertainty};
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The error figure of a model on the validation blocks.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Gap {
    /// Normalised RMS error (fraction): RMS over the outputs of
    /// `rms(model − measured) / std(measured)`.
    pub nrmse: f64,
}

/// A named effect as reported in the JSON object.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct NamedEffect {
    /// Identifier (e.g. `cubic_stiffness`).
    pub effect: EffectKind,
    /// Element or input it is attached to.
    pub element: String,
    /// Fitted parameters (SI names, see [`EffectKind`]).
    pub parameters: BTreeMap<String, f64>,
}

/// A named effect with its uncertainty and score.
#[derive(Clone, Debug, Serialize)]
pub struct NamedDetail {
    /// The effect and its parameters.
    pub named: NamedEffect,
    /// One standard deviation of each parameter (same names and units).
    pub std: BTreeMap<String, f64>,
    /// Criterion `Δ` when it was selected (negative; more negative is stronger evidence).
    pub criterion: f64,
    /// Validation SSE ratio (candidate / model before it) when selected.
    pub sse_ratio: f64,
}

/// One candidate's score in one selection round.
#[derive(Clone, Debug, Serialize)]
pub struct CandidateScore {
    /// Round (0 = first effect).
    pub round: usize,
    /// Effect.
    pub effect: EffectKind,
    /// Element or input.
    pub element: String,
    /// Criterion `Δ` (negative = better than the current model).
    pub criterion: f64,
    /// Validation SSE ratio (candidate / current).
    pub sse_ratio: f64,
    /// Parameters added.
    pub parameters_added: usize,
}

/// How the gap is measured.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum GapBasis {
    /// Simulated outputs (the model is restrained on its own).
    Simulation,
    /// Inverse-dynamics prediction (equation error), for models that drift when simulated.
    EquationError,
}

/// Everything the workflow found.
#[derive(Clone, Debug)]
pub struct Diagnosis {
    /// The model as given.
    pub original: Model,
    /// The recalibrated linear model (no effects added).
    pub recalibrated_model: Model,
    /// The updated model: recalibrated, with the named effects.
    pub updated: Model,
    /// Corrected linear parameters (e.g. `"spring.stiffness_n_per_m"`) of the updated model.
    pub recalibrated: BTreeMap<String, f64>,
    /// One standard deviation of each corrected parameter, misfit-robust
    /// ([`crate::uncertainty`]), from the final fit's covariance (the equation-error
    /// recalibration's for a parameter that fit does not hold); absent for a parameter held
    /// at a physical bound.
    pub recalibrated_std: BTreeMap<String, f64>,
    /// Named effects.
    pub named: Vec<NamedDetail>,
    /// Every candidate's score, all rounds.
    pub candidates: Vec<CandidateScore>,
    /// Gap of the model as given.
    pub gap_before: Gap,
    /// Gap of the recalibrated linear model.
    pub gap_recalibrated: Gap,
    /// Gap of the updated model.
    pub gap_after: Gap,
    /// How the gaps are measured.
    pub basis: GapBasis,
    /// The fitting and validation samples (interleaved blocks).
    pub split: Split,
    /// Filter cut-off of the state estimate (Hz).
    pub cutoff_hz: f64,
    /// Frequency-band evidence (simulation basis only).
    pub bands: Vec<BandEvidence>,
    /// Operating-region evidence per named element effect (baseline residual).
    pub regions: Vec<RegionEvidence>,
    /// Time-window evidence (the whole record).
    pub windows: Vec<WindowEvidence>,
    /// Remarks (e.g. output-error refinement kept or not).
    pub notes: Vec<String>,
}

/// The JSON object of `mil diagnose --json`: the named effects, the recalibrated
/// parameters, the gaps before and after, and the updated model's path.
#[derive(Clone, Debug, Serialize)]
pub struct JsonReport {
    /// Named effects; empty when no missing effect was found.
    pub named_effects: Vec<NamedEffect>,
    /// Corrected linear parameters.
    pub recalibrated: BTreeMap<String, f64>,
    /// Gap of the model as given (validation blocks).
    pub gap_before: Gap,
    /// Gap of the updated model (validation blocks).
    pub gap_after: Gap,
    /// Path of the updated model file.
    pub updated_model: String,
}

impl Diagnosis {
    /// The JSON report, naming `updated_model` as the updated model's path.
    pub fn json_report(&self, updated_model: &str) -> JsonReport {
        JsonReport {
            named_effects: self.named.iter().map(|n| n.named.clone()).collect(),
            recalibrated: self.recalibrated.clone(),
            gap_before: self.gap_before,
            gap_after: self.gap_after,
            updated_model: updated_model.to_string(),
        }
    }

    /// Writes `updated.toml` (the updated model) and `report.json` into `dir` (created if
    /// needed); returns the updated model's path.
    ///
    /// # Errors
    /// The files cannot be written.
    pub fn write(&self, dir: &Path) -> Result<PathBuf> {
        let io = |p: &Path, source| Error::Io {
            path: p.display().to_string(),
            source,
        };
        std::fs::create_dir_all(dir).map_err(|e| io(dir, e))?;
        let path = dir.join("updated.toml");
        mil_numerics::files::write_atomic(&path, self.updated.to_toml().as_bytes())
            .map_err(Error::Write)?;
        let report = self.json_report(&path.display().to_string());
        let json = serde_json::to_string_pretty(&report).unwrap_or_default();
        let rpath = dir.join("report.json");
        mil_numerics::files::write_atomic(&rpath, json.as_bytes()).map_err(Error::Write)?;
        Ok(path)
    }

    /// A human summary: named effects with parameters ± one standard deviation, the
    /// recalibrated parameters, the gaps and the evidence.
    pub fn summary(&self) -> String {
        let mut s = String::new();
        let basis = match self.basis {
            GapBasis::Simulation => "simulated outputs",
            GapBasis::EquationError => "inverse-dynamics force prediction",
        };
        s.push_str(&format!(
            "model {:?}: gap on the validation blocks ({basis}): {:.4} as given, {:.4} recalibrated, {:.4} updated\n",
            self.original.file.name,
            self.gap_before.nrmse,
            self.gap_recalibrated.nrmse,
            self.gap_after.nrmse
        ));
        s.push_str("recalibrated:\n");
        for (k, v) in &self.recalibrated {
            match self.recalibrated_std.get(k) {
                Some(sd) => s.push_str(&format!("  {k} = {}\n", with_uncertainty(*v, *sd))),
                None => s.push_str(&format!(
                    "  {k} = {} (no uncertainty: see the notes)\n",
                    number(*v, 6)
                )),
            }
        }
        if self.named.is_empty() {
            if self.candidates.iter().any(|c| c.criterion < 0.0) {
                s.push_str("no missing effect named: the candidates that lowered the criterion were not confirmed by simulation (see the notes)\n");
            } else {
                s.push_str("no missing effect found (every candidate's criterion >= 0)\n");
            }
        }
        for n in &self.named {
            s.push_str(&format!(
                "named: {} on {:?} (criterion {:.1}, validation SSE x{:.3})\n",
                n.named.effect, n.named.element, n.criterion, n.sse_ratio
            ));
            for (k, v) in &n.named.parameters {
                let sd = n.std.get(k).copied().unwrap_or(f64::NAN);
                s.push_str(&format!("  {k} = {}\n", with_uncertainty(*v, sd)));
            }
        }
        for r in &self.regions {
            let (a, b) = r.worst_bin;
            s.push_str(&format!(
                "  region: {:?} misses {} N on average at x in [{}, {}] m, v in [{}, {}] m/s\n",
                r.element,
                number(r.mean_residual_n[a][b], 3),
                number(r.x_edges_m[a], 3),
                number(r.x_edges_m[a + 1], 3),
                number(r.v_edges_m_per_s[b], 3),
                number(r.v_edges_m_per_s[b + 1], 3)
            ));
        }
        if let Some(b) = self.bands.iter().max_by(|a, b| {
            (a.error_before - a.error_after).total_cmp(&(b.error_before - b.error_after))
        }) {
            s.push_str(&format!(
                "  band: {}->{} {:.1}-{:.1} Hz FRF error {:.3} -> {:.3} (coherence {:.2})\n",
                b.input,
                b.output,
                b.band_hz[0],
                b.band_hz[1],
                b.error_before,
                b.error_after,
                b.coherence
            ));
        }
        for n in &self.notes {
            s.push_str(&format!("note: {n}\n"));
        }
        s
    }
}
