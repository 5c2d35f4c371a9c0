//! The workflow: recalibrate, try candidate effects, select by a validation criterion,
//! confirm in simulation, and report.
//!
//! 1. The record is split into interleaved fitting and validation blocks
//!    ([`crate::split`]): both span the whole record, so the answer does not depend on the
//!    record's order (an up-sweep and a down-sweep are split alike). Logged inputs drive
//!    the simulations low-passed an octave above their signal band ([`prefilter_inputs`]),
//!    so that their measurement noise is not mistaken for an effect; the equation error
//!    applies input effects to the same low-passed inputs.
//! 2. **Recalibration** of the linear parameters (masses when a measured force — a force
//!    input, or an element's measured force, e.g. the tyre force — fixes the scale,
//!    stiffnesses and dampings that are non-zero in the model, one constant force per DOF)
//!    by equation-error least squares on the fitting blocks ([`crate::equation`]), within
//!    physical bounds: a mass stays positive, a stiffness or damping non-negative; a
//!    coefficient the data would put outside is held at its bound and the notes say so.
//!    Every effect stays passive too (a stop's stiffness, a friction force, a quadratic
//!    damping >= 0, both of an asymmetric damper's dampings >= 0), in the output-error
//!    refinements as in the equation error: `updated.toml` is a model file the reader takes.
//! 3. **Candidates**: each effect on each element (or input) it applies to (hysteresis also
//!    on an element with damping and no spring: dry friction through a compliant link, as in
//!    a friction or MR damper; an input effect only when it passes on at least
//!    [`INPUT_KEPT`] of the input's spread; an input delay from one sample period, see
//!    `candidates::unresolved`; a bump stop on one side or on both, the two-sided one kept when its
//!    second stop pays for its parameters and its stops are not engaged for most of the
//!    record, see `candidates::stops_are_free_play`), its
//!    coefficients fitted together with the linear parameters (linear least squares; effects
//!    with a threshold-like parameter — gap, preload, delay, limits, Bouc-Wen shape — by a
//!    grid over quantiles of the data, each grid point a linear fit, ranked on every few
//!    fitting blocks holding [`GRID_EFFECTIVE_SAMPLES`] effectively independent rows; the
//!    [`GRID_FINALISTS`] best grid points are then fitted on every fitting block).
//!    Candidates are fitted on all cores ([`Options::threads`]); the result does not depend
//!    on the thread count.
//! 4. **Ranking** on the validation blocks by the Bayesian information criterion
//!    `Δ = n_eff ln(SSE_candidate / SSE_current) + p ln(n_eff)` with `p` the candidate's
//!    added parameters and `n_eff` the validation rows divided by the current residual's
//!    correlation time (so filtered, correlated residuals do not count as independent
//!    samples).
//! 5. **Confirmation in simulation** (models restrained on their own): the
//!    [`SELECTION_BRANCHES`] best candidates with `Δ < 0` (filled up, while the model
//!    misses more than [`PRACTICAL_MARGIN`] of the noise beyond it on some output, with the
//!    candidates that do not reach `Δ < 0` but would by Akaike's criterion, `2p` in place
//!    of `p ln(n_eff)`, best first by their validation SSE: an effect brief in time but
//!    lasting in its consequences, such as a wheel off the road for a few samples, is weak
//!    in the equation error) are each refined by output error
//!    (Levenberg–Marquardt on the simulated outputs at the fitting blocks, the effect's and
//!    the linear parameters free) and must pay off on the validation blocks' simulated
//!    outputs: the same criterion against the current stage, and a practical margin — on
//!    some output the sum of squares removed reaches [`PRACTICAL_MARGIN`] times that
//!    output's measurement noise ([`crate::signal::noise_std`]), or [`CLOSING_MARGIN`]
//!    times it when the step removes at least [`CLOSING_SHARE`] of the stage's excess over
//!    the noise. Of the confirmed ones, the best by
//!    the criterion is named, unless one with fewer parameters is within
//!    [`PARSIMONY_Z`] standard errors of it (two forms that explain the record equally well: the simpler is named);
//!    the search goes on (greedy forward selection) until
//!    no candidate is confirmed or `max_effects` are named. When it ends with one effect,
//!    a stand-in check continues each of the first round's runners-up (the other confirmed
//!    candidates, best first) by one round (its candidates refined only when their
//!    equation-error fit beats the one effect's); the first pair found there that pays off
//!    against the one effect by the same test replaces it (one effect can stand in for two: a Bouc-Wen loop of
//!    small yield deflection for dry friction and a hardening spring). A backward elimination then
//!    removes any effect whose removal (the rest refined by output error) does not fail the
//!    same test, or, for an effect of one parameter, whose strength (e.g. `k3`, a friction
//!    force, a gap; see `strength`) is not distinguishable from none by a Wald test with the
//!    criterion's penalty (`z² < ln n_eff`; one parameter of several, such as a stop's
//!    stiffness beside its gap, has a variance inflated by their correlation and does not
//!    test the effect: its removal does); when it drops an effect while rounds are left, the forward search
//!    goes on from the reduced model for those rounds and the elimination runs again
//!    (once: [`STEPWISE_PASSES`]). With two effects or more, a replacement step then tries
//!    each named effect replaced by each other effect a round confirmed on the same element
//!    (the rest refined with it by output error) and makes the replacement that lowers the
//!    criterion most (`Δp` may be negative: as good a fit with fewer parameters; one with
//!    more parameters must also pass the practical margin): an effect named while the
//!    record still lacked another can be a stand-in for the right one (a Bouc-Wen loop for
//!    a hardening spring, while a rate limit's lag is not yet modelled). Models that are not
//!    restrained (a free mass) are selected by the equation-error criterion alone. No
//!    threshold depends on the record.
//! 6. **Gap**: NRMSE of the simulated outputs on the validation blocks (restrained models),
//!    else of the inverse-dynamics force prediction (equation-error residual over the
//!    right-hand side's spread).

mod candidate_fit;
mod candidates;
mod criterion;
mod elimination;
mod fit;
mod force_sign;
mod gaps;
mod grid;
mod hysteresis;
mod output_error;
mod parameters;
mod pieces;
mod preparation;
mod recalibration;
mod replacement;
mod report;
mod report_evidence;
mod report_parameters;
mod selection;
mod simulated;
mod stand_in;
mod windows;

pub use candidate_fit::INPUT_KEPT;
pub use candidates::STOPS_AS_SPRING;
pub use criterion::{
    AKAIKE_PENALTY, CLOSING_MARGIN, CLOSING_SHARE, PARSIMONY_Z, PRACTICAL_MARGIN, RELATIVE_FLOOR,
};
pub use elimination::STEPWISE_PASSES;
pub use fit::{LIFT_OFF_FIT_PASSES, LIFT_OFF_RANKING_PASSES};
pub use force_sign::NET_WORK_FLOOR;
pub use grid::{GRID_EFFECTIVE_SAMPLES, GRID_FINALISTS};
pub use output_error::{
    COARSE_MARGIN_SHARE, MAX_SUBSTEP_GROWTH, MIN_SUBSTEP_CAP, REFINE_COARSE_SHARE,
    REFINE_EFFECTIVE_SAMPLES, REFINE_WARMUP_DECAYS,
};
pub use pieces::{SELECTION_SAMPLES, SELECTION_WARMUP_EDGES};
pub use preparation::{prefilter_inputs, within_budget, DECIMATED_BAND_FRACTION, MAX_SAMPLES};
pub use report::{CandidateScore, Diagnosis, Gap, GapBasis, JsonReport, NamedDetail, NamedEffect};
pub use selection::SELECTION_BRANCHES;
pub use windows::{REFINE_UNIFORM_SHARE, REFINE_WINDOWS};

use crate::effects::EffectKind;
use crate::model::Model;
use crate::record::Record;
use crate::simulate::prepare_inputs;
use crate::{parallel, Result};
use fit::Context;
use gaps::{gaps, Stages};
use output_error::RefineOn;
use pieces::selection_pieces;
use preparation::{prepare, Prepared};
use recalibration::{recalibrate, refine_recalibrated, row_weights};
use report_evidence::{bands_and_windows, regions};
use report_parameters::{fill_named, recalibrated_parameters, saturation_within_reach};
use selection::{Branch, Findings, Selection};
use simulated::{measured_outputs, Simulated};

/// Options of [`diagnose`].
#[derive(Clone, Debug)]
pub struct Options {
    /// Fraction of the record held out for validation (in blocks interleaved with the
    /// fitting blocks, [`crate::split`]), in (0, 0.9]; default 0.3.
    pub validation_fraction: f64,
    /// Most effects named; default 3.
    pub max_effects: usize,
    /// Effects tried; default all.
    pub candidates: Vec<EffectKind>,
    /// Refine by output error (simulation) when the model is restrained; default true.
    pub output_error: bool,
    /// Print progress lines to stderr (by [`diagnose`]; [`diagnose_with_progress`] reports
    /// to its callback instead); default false.
    pub progress: bool,
    /// Worker threads for the candidate fits and the output-error Jacobians (0: the
    /// machine's available parallelism); default 0. The result does not depend on it.
    pub threads: usize,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            validation_fraction: 0.3,
            max_effects: 3,
            candidates: EffectKind::ALL.to_vec(),
            output_error: true,
            progress: false,
            threads: 0,
        }
    }
}

/// Runs the workflow on `model` and `record` (see the module documentation); with
/// `options.progress` it prints progress lines to stderr.
///
/// # Errors
/// Missing columns, a record too short to split, displacement outputs that do not
/// determine every DOF's position (the equation-error recalibration and selection estimate
/// every DOF's states from them; the error names the undetermined DOFs).
pub fn diagnose(model: &Model, record: &Record, options: &Options) -> Result<Diagnosis> {
    let start = std::time::Instant::now();
    diagnose_with_progress(model, record, options, &|_, m: &str| {
        if options.progress {
            eprintln!("diagnose [{:7.2} s]: {m}", start.elapsed().as_secs_f64());
        }
    })
}

/// Everything [`diagnose`] checks of `model` and `record` before it searches (what `mil
/// check --against` runs): the options, the model's outputs, the record's columns, its
/// length against the sample budget and its scale against the model, that the outputs
/// determine every DOF's states, the force inputs' sign, and that the record is long enough
/// for a fitting and a validation part. Costs one state estimate.
///
/// # Errors
/// As [`diagnose`], before its search.
pub fn check_record(model: &Model, record: &Record, options: &Options) -> Result<()> {
    prepare(model, record, options, &|_, _| {}).map(|_| ())
}

/// [`diagnose`], reporting its progress to `progress(fraction, message)` instead of stderr
/// (`options.progress` is ignored): `fraction` is a rough share of the work done, from 0 to
/// 1, never decreasing (by phase: state estimate, recalibration, candidates of each
/// selection round, output-error refinements, evidence); `message` says what was done.
///
/// # Errors
/// As [`diagnose`].
pub fn diagnose_with_progress(
    model: &Model,
    record: &Record,
    options: &Options,
    progress: &dyn Fn(f64, &str),
) -> Result<Diagnosis> {
    let log = |f: f64, m: &str| progress(f.clamp(0.0, 1.0), m);
    let Prepared {
        record,
        mut notes,
        st,
        work,
        split,
        fit_rows,
    } = prepare(model, record, options, &log)?;
    let record = &record;
    let ctx = Context {
        st: &st,
        weights: row_weights(model, &st),
        split: &split,
        thin: 1,
    };
    let (free0, recal_fit) = recalibrate(model, &ctx, work.as_ref(), &mut notes, &log)?;
    let mut current = recal_fit.clone();
    let restrained = recal_fit.model.is_restrained();
    let oe = restrained && options.output_error;
    let inputs = prepare_inputs(model, record)?;
    let q0: Vec<f64> = st.q.iter().map(|q| q[0]).collect();
    let qd0: Vec<f64> = st.qd.iter().map(|q| q[0]).collect();
    let (measured, noise) = measured_outputs(model, record)?;
    let sim = Simulated::new(&measured, &noise, &split, record, (&q0, &qd0));
    let refine_on = RefineOn {
        record,
        measured: &measured,
        split: &split,
        st: &st,
        initial: (&q0, &qd0),
        noise,
    };
    let threads = parallel::threads(options.threads);
    // The model each stage reaches, refined by output error where the model is restrained,
    // with its parameters' covariance and its simulated validation residual.
    let (recal_model, covariance, cur_eval) =
        refine_recalibrated(&recal_fit, oe, &sim, &refine_on, threads, &log);
    // A long record's candidate search (equation error) runs on the middle of every block
    // (see SELECTION_SAMPLES); the refinement and simulation use the whole record.
    let pieces = selection_pieces(&st, &split, oe, record.len());
    let (sel_st, sel_split) = pieces.as_ref().map_or((&st, &split), |p| (&p.st, &p.split));
    let sctx = Context {
        st: sel_st,
        weights: ctx.weights.clone(),
        split: sel_split,
        thin: 1,
    };
    let fit_rows = if let Some(p) = &pieces {
        notes.push(p.note.clone());
        current = sctx.fit(model.clone(), &free0);
        sel_st
            .cache
            .keep()
            .iter()
            .filter(|&&t| sel_split.is_fit(t))
            .count()
    } else {
        fit_rows
    };
    let selection = Selection {
        ctx: &sctx,
        fit_rows,
        options,
        oe,
        threads,
        sim: &sim,
        refine_on: &refine_on,
        log: &log,
    };
    let mut found = Findings {
        notes,
        ..Findings::default()
    };
    let mut main = Branch {
        current,
        updated: recal_model.clone(),
        cur_eval,
        covariance,
        named: Vec::new(),
        added_of: Vec::new(),
    };
    let runners_up = selection.forward(&mut main, 0..options.max_effects, None, &mut found, true);
    let main = selection.stand_in(main, runners_up, &mut found.notes);
    let mut sel = selection.stepwise(main, &mut found);
    selection.replace(&mut sel, &found.alternatives, &mut found.notes);
    let Findings {
        mut notes, scores, ..
    } = found;
    let stages = Stages {
        given: model,
        recalibrated: &recal_model,
        updated: &sel.updated,
    };
    let gaps = gaps(&stages, restrained, &ctx, &sim, &mut notes);
    saturation_within_reach(&mut sel.updated, &sel.named, &st, &mut notes);
    // Named effects' parameters and uncertainties.
    fill_named(&mut sel.named, &sel.updated, &sel.cov_params, &sel.cov);
    let (recalibrated, recalibrated_std) =
        recalibrated_parameters(model, &sel.updated, &sel.cov_params, &sel.cov, &recal_fit);
    log(
        0.95,
        "evidence: operating regions, frequency bands, time windows",
    );
    let regions = regions(model, &recal_fit, &ctx, &sel.named);
    let (bands, windows) = bands_and_windows(
        model,
        record,
        &measured,
        &inputs,
        gaps.sims.as_ref(),
        st.fc_hz,
    );
    log(1.0, "done");
    Ok(Diagnosis {
        original: model.clone(),
        recalibrated_model: recal_model,
        updated: sel.updated,
        recalibrated,
        recalibrated_std,
        named: sel.named,
        candidates: scores,
        gap_before: gaps.before,
        gap_recalibrated: gaps.recalibrated,
        gap_after: gaps.after,
        basis: gaps.basis,
        split,
        cutoff_hz: st.fc_hz,
        bands,
        regions,
        windows,
        notes,
    })
}
