//! The forward search for missing effects: each round fits every candidate on top of the
//! current fit ([`super::candidate_fit`]), ranks them by the equation-error criterion on
//! the validation blocks and, for a model restrained on its own, confirms the best few in
//! simulation ([`confirmation`]) before one is named.

mod confirmation;

use super::candidate_fit::fit_candidate;
use super::candidates::{cand_cost, candidates, physical, target_name, Candidate};
use super::criterion::{criterion, Evaluation, AKAIKE_PENALTY, PRACTICAL_MARGIN};
use super::fit::{Context, Fit};
use super::grid::{GRID_EFFECTIVE_SAMPLES, MAX_THIN};
use super::output_error::RefineOn;
use super::parameters::{Covariance, Param};
use super::report::{CandidateScore, NamedDetail, NamedEffect};
use super::simulated::Simulated;
use super::Options;
use crate::effects::EffectKind;
use crate::model::Model;
use crate::parallel;
use std::collections::BTreeMap;

/// Candidates, the best by the equation-error criterion, that each round refines by output
/// error and tests in simulation: 3 (the search goes on past a best candidate that
/// simulation does not confirm).
pub const SELECTION_BRANCHES: usize = 3;

impl NamedDetail {
    /// The detail of `cand` when it is selected (its parameters and deviations are filled
    /// in from the final model).
    pub(super) fn selected(model: &Model, cand: Candidate, criterion: f64, sse_ratio: f64) -> Self {
        NamedDetail {
            named: NamedEffect {
                effect: cand.kind,
                element: target_name(model, cand),
                parameters: BTreeMap::new(),
            },
            std: BTreeMap::new(),
            criterion,
            sse_ratio,
        }
    }
}

/// A state of the search for missing effects: the equation-error fit and the model
/// refined by output error after the effects named so far, its simulated validation
/// residual, the covariance of its parameters, and what was named.
#[derive(Clone)]
pub(super) struct Branch {
    pub(super) current: Fit,
    pub(super) updated: Model,
    pub(super) cur_eval: Option<Evaluation>,
    pub(super) covariance: Covariance,
    pub(super) named: Vec<NamedDetail>,
    pub(super) added_of: Vec<usize>,
}

/// A confirmed candidate on an element that a selection round did not name, as refined
/// there: what the replacement step tries in place of a named effect on that element.
#[derive(Clone)]
pub(super) struct Alternative {
    pub(super) kind: EffectKind,
    pub(super) target: String,
    /// Its parameters (SI names), as the element law writes them.
    pub(super) parameters: BTreeMap<String, f64>,
    /// The parameters it adds to the model.
    pub(super) added: usize,
}

/// What a search records besides its branches: the notes, every candidate's score, and the
/// rounds' other confirmed effects on an element ([`Alternative`]).
#[derive(Default)]
pub(super) struct Findings {
    pub(super) notes: Vec<String>,
    pub(super) scores: Vec<CandidateScore>,
    pub(super) alternatives: Vec<Alternative>,
}

/// What the selection of effects works with: the context the candidates are fitted in (the
/// middle of every block of a long record, [`super::pieces`]), the simulation that confirms
/// them, and the output-error refinement's data.
pub(super) struct Selection<'a> {
    /// The context the candidates are fitted and ranked in.
    pub(super) ctx: &'a Context<'a>,
    /// Its fitting rows (how far the grid ranking may thin them).
    pub(super) fit_rows: usize,
    pub(super) options: &'a Options,
    /// Whether the models are refined by output error and confirmed in simulation (the
    /// model is restrained on its own and [`Options::output_error`]).
    pub(super) oe: bool,
    pub(super) threads: usize,
    pub(super) sim: &'a Simulated<'a>,
    pub(super) refine_on: &'a RefineOn<'a>,
    /// Progress: a rough share of the work done and what was done.
    pub(super) log: &'a dyn Fn(f64, &str),
}

/// A candidate fitted in a round and ranked: its criterion, validation SSE ratio, fit, the
/// candidate, and the parameters it adds.
type Ranked = (f64, f64, Fit, Candidate, usize);

/// One round of a search.
struct Round<'r> {
    /// Round (0 = first effect).
    index: usize,
    /// A model the candidates must beat in the end, with its equation-error validation SSE
    /// (see [`Selection::forward`]).
    rival: Option<(&'r Model, f64)>,
    /// Whether progress is reported and alternatives collected.
    collect: bool,
}

impl Selection<'_> {
    /// The search for missing effects on branch `b`, rounds `rounds`; with `collect`,
    /// progress is reported. A candidate's refinement must gain on the branch's model, or
    /// on `rival` when given (a model it must beat in the end, with its equation-error
    /// validation SSE: a candidate that does not beat that either is not refined). Returns
    /// the first round's runners-up (the other confirmed candidates, best first by the
    /// criterion) as branches of their own; with `collect`, every round's other confirmed
    /// candidates on an element go to `found.alternatives` too (for the replacement step).
    pub(super) fn forward(
        &self,
        b: &mut Branch,
        rounds: std::ops::Range<usize>,
        rival: Option<(&Model, f64)>,
        found: &mut Findings,
        collect: bool,
    ) -> Vec<Branch> {
        let mut runners_up = Vec::new();
        for index in rounds {
            let round = Round {
                index,
                rival,
                collect,
            };
            let n_eff = (b.current.val_rows as f64 / b.current.tau).max(2.0);
            let fitted = self.fit_candidates(&b.current, &round, n_eff);
            let mut ranked = self.rank(fitted, b, &round, n_eff, &mut found.scores);
            let chosen = if self.oe {
                let (chosen, first) = self.confirm(b, ranked, &round, found);
                if let Some(first) = first {
                    runners_up = first;
                }
                chosen
            } else {
                (!ranked.is_empty()).then(|| ranked.swap_remove(0))
            };
            let Some((crit, ratio, fit, cand, added)) = chosen else {
                break;
            };
            if !self.oe {
                b.updated = fit.model.clone();
                b.covariance = (
                    fit.free.iter().map(|c| Param::Lin(*c)).collect(),
                    fit.covariance.clone(),
                );
            }
            b.named
                .push(NamedDetail::selected(&fit.model, cand, crit, ratio));
            b.added_of.push(added);
            b.current = fit;
        }
        runners_up
    }

    /// Reports progress when the round collects it.
    fn say(&self, round: &Round<'_>, f: f64, m: &str) {
        if round.collect {
            (self.log)(f, m);
        }
    }

    /// Every candidate on `current`'s model, each with its fit on top of `current` and the
    /// parameters it adds (none when it does not fit), in the candidates' order.
    fn fit_candidates(
        &self,
        current: &Fit,
        round: &Round<'_>,
        n_eff: f64,
    ) -> Vec<(Candidate, Option<(Fit, usize)>)> {
        let sctx = self.ctx;
        // The grids of the threshold-like parameters (gaps, preloads, delays, limits, the
        // Bouc-Wen shape) are ranked on a thinned fitting set, every `thin`-th block, that
        // holds `GRID_EFFECTIVE_SAMPLES` effectively independent rows and still spans the
        // record; the best grid points are then fitted on every fitting block.
        let grid_ctx = {
            let needed = GRID_EFFECTIVE_SAMPLES * current.tau.max(1.0);
            let thin = ((self.fit_rows as f64 / needed).floor() as usize).min(MAX_THIN);
            (thin >= 2).then(|| Context {
                st: sctx.st,
                weights: sctx.weights.clone(),
                split: sctx.split,
                thin,
            })
        };
        let cands = candidates(&current.model, &self.options.candidates);
        // The costly grids start first, so that the threads finish together; the results
        // are taken in the candidates' order.
        let mut work: Vec<usize> = (0..cands.len()).collect();
        work.sort_by_key(|&i| std::cmp::Reverse(cand_cost(cands[i].kind)));
        let n_cands = cands.len().max(1) as f64;
        let mut finished = 0usize;
        let rounds = self.options.max_effects.max(1) as f64;
        let round_f = round.index as f64;
        let mut fits: Vec<Option<(Fit, usize)>> = parallel::map(
            &work,
            self.threads,
            |&i| fit_candidate(sctx, grid_ctx.as_ref(), current, cands[i]),
            |w, fit| {
                let i = work[w];
                // Selection rounds share 0.15..0.85 of the work; later rounds may not happen.
                finished += 1;
                let done = 0.15 + 0.7 * (round_f + 0.5 * finished as f64 / n_cands) / rounds;
                let cand = cands[i];
                let what = match fit {
                    None => "no fit".to_string(),
                    Some((f, _)) if !physical(&f.model, cand) => "non-physical fit, skipped".into(),
                    Some((f, added)) => {
                        let ratio = f.sse_val / current.sse_val;
                        let crit = criterion(n_eff, ratio, *added as f64);
                        format!("Δ = {crit:.1}, SSE x{ratio:.4}")
                    }
                };
                self.say(
                    round,
                    done,
                    &format!(
                        "round {}: {} on {:?}: {what}",
                        round.index,
                        cand.kind,
                        target_name(&current.model, cand)
                    ),
                );
            },
        );
        let mut by_candidate: Vec<Option<(Fit, usize)>> = (0..cands.len()).map(|_| None).collect();
        for (&i, fit) in work.iter().zip(fits.drain(..)) {
            by_candidate[i] = fit;
        }
        cands.into_iter().zip(by_candidate).collect()
    }

    /// The candidates `fitted` on branch `b` that lower the criterion (`Δ < 0`), best
    /// first, and beat the round's rival; with output error, while the model misses enough
    /// in simulation, filled up to [`SELECTION_BRANCHES`] by those Akaike's criterion would
    /// take. Every physical fit's score goes to `scores`.
    fn rank(
        &self,
        fitted: Vec<(Candidate, Option<(Fit, usize)>)>,
        b: &Branch,
        round: &Round<'_>,
        n_eff: f64,
        scores: &mut Vec<CandidateScore>,
    ) -> Vec<Ranked> {
        let current = &b.current;
        let mut ranked: Vec<Ranked> = Vec::new();
        // Candidates the equation error does not rank but that fit its validation
        // blocks better by Akaike's criterion (see AKAIKE_PENALTY).
        let mut unranked: Vec<Ranked> = Vec::new();
        for (cand, fit) in fitted {
            let Some((fit, added)) = fit else {
                continue;
            };
            if !physical(&fit.model, cand) {
                continue;
            }
            let ratio = fit.sse_val / current.sse_val;
            let crit = criterion(n_eff, ratio, added as f64);
            scores.push(CandidateScore {
                round: round.index,
                effect: cand.kind,
                element: target_name(&current.model, cand),
                criterion: crit,
                sse_ratio: ratio,
                parameters_added: added,
            });
            let beats_rival = round.rival.is_none_or(|(_, sse)| fit.sse_val < sse);
            if crit.is_finite() && crit < 0.0 && beats_rival {
                ranked.push((crit, ratio, fit, cand, added));
            } else if n_eff * ratio.ln() + AKAIKE_PENALTY * (added as f64) < 0.0 && beats_rival {
                unranked.push((crit, ratio, fit, cand, added));
            }
        }
        ranked.sort_by(|a, b| a.0.total_cmp(&b.0));
        // While the model misses enough beyond the noise in simulation that a step could
        // still pay off ([`PRACTICAL_MARGIN`] of the noise on some output), the equation
        // error's blind spots (an effect brief in time but lasting in its consequences,
        // such as a wheel off the road for a few samples) are searched too: the
        // candidates it does not rank but that Akaike's criterion would, best first by
        // their equation-error validation SSE (ordered by the criterion instead, a
        // hardening oscillator had a 0.1 % rate limit confirmed), fill the branches up
        // to SELECTION_BRANCHES.
        let room_to_pay = b.cur_eval.as_ref().is_some_and(|ev| {
            ev.sse
                .iter()
                .zip(&self.sim.noise_sse)
                .any(|(sse, noise)| *sse >= (1.0 + PRACTICAL_MARGIN) * noise)
        });
        if self.oe && room_to_pay && ranked.len() < SELECTION_BRANCHES {
            unranked.sort_by(|a, b| a.1.total_cmp(&b.1));
            let room = SELECTION_BRANCHES - ranked.len();
            ranked.extend(unranked.into_iter().take(room));
        }
        ranked
    }
}
