//! Confirmation in simulation: a round's best candidates by the equation error are each
//! refined by output error and must pay off on the validation blocks' simulated outputs;
//! the best confirmed by the criterion is named, unless one with fewer parameters explains
//! the record as well ([`PARSIMONY_Z`]).

use super::{Alternative, Branch, Findings, Ranked, Round, Selection, SELECTION_BRANCHES};
use crate::diagnose::candidates::{stops_are_free_play, target_name, unresolved};
use crate::diagnose::criterion::{log_ratio_std, Evaluation, Verdict, PARSIMONY_Z};
use crate::diagnose::output_error::{refine_output_error, Unrefined};
use crate::diagnose::parameters::{effect_parameters, Covariance};
use crate::diagnose::report::NamedDetail;
use crate::effects::EffectKind;
use crate::model::Model;
use crate::parallel;

/// A candidate confirmed in simulation: its index among the round's ranked candidates, the
/// model refined by output error, its parameters' covariance and its simulated validation
/// residual.
type Confirmed = (usize, Model, Covariance, Evaluation);

impl Selection<'_> {
    /// The output-error step of a round on branch `b`: the best [`SELECTION_BRANCHES`] of
    /// `ranked` are refined and confirmed in simulation, and the one picked is taken (`b`
    /// then holds its refined model, covariance and simulated residual). Returns the
    /// candidate named, if any, and in the first round the runners-up as branches of their
    /// own. With `round.collect`, the other confirmed effects on an element go to
    /// `found.alternatives`.
    pub(super) fn confirm(
        &self,
        b: &mut Branch,
        mut ranked: Vec<Ranked>,
        round: &Round<'_>,
        found: &mut Findings,
    ) -> (Option<Ranked>, Option<Vec<Branch>>) {
        // The best few by the equation error are each refined by output error and must
        // pay off in simulation on the validation blocks; the best of them by the
        // criterion is taken (so a candidate the equation error ranks first but
        // simulation does not confirm does not end the search).
        ranked.truncate(SELECTION_BRANCHES);
        let mut confirmed = self.confirmed(b, &ranked, round, &mut found.notes);
        let (pick, scored) = self.pick(b, &ranked, &confirmed, round, &mut found.notes);
        // Every round's other confirmed effects on an element, as refined there.
        if let (true, Some(w)) = (round.collect, pick) {
            collect_alternatives(&ranked, &confirmed, w, &mut found.alternatives);
        }
        // The first round's runners-up, the starts of the alternative branches.
        let runners_up = match (round.index, pick) {
            (0, Some(w)) => Some(runners_up(&ranked, &confirmed, &scored, w)),
            _ => None,
        };
        let best = pick.map(|w| confirmed.swap_remove(w));
        let chosen = best.map(|(i, m, pc, ev)| {
            b.cur_eval = Some(ev);
            b.updated = m;
            b.covariance = pc;
            ranked.swap_remove(i)
        });
        (chosen, runners_up)
    }

    /// The candidates of `ranked` that, refined by output error, pay off in simulation on
    /// branch `b`'s model (each must gain on the model reached so far, when that
    /// simulates, or on the round's rival); every verdict goes to `notes`.
    fn confirmed(
        &self,
        b: &Branch,
        ranked: &[Ranked],
        round: &Round<'_>,
        notes: &mut Vec<String>,
    ) -> Vec<Confirmed> {
        let (sim, refine_on, threads) = (self.sim, self.refine_on, self.threads);
        let index = round.index;
        let rounds = self.options.max_effects.max(1) as f64;
        self.say(
            round,
            0.15 + 0.7 * (index as f64 + 0.5) / rounds,
            &format!(
                "round {index}: output-error refinement of the best {}",
                ranked.len()
            ),
        );
        // Each must gain on the model reached so far (when that simulates).
        let beat = round
            .rival
            .map(|r| r.0)
            .or(b.cur_eval.as_ref().map(|_| &b.updated));
        let refined = parallel::map(
            ranked,
            threads,
            |(_, _, fit, _, _)| {
                let (m, pc) = refine_output_error(&fit.model, &fit.free, refine_on, threads, beat)?;
                let ev = sim.evaluate(&m).ok_or(Unrefined::Diverged)?;
                Ok((m, pc, ev))
            },
            |_, _| {},
        );
        let mut confirmed: Vec<Confirmed> = Vec::new();
        for (i, r) in refined.into_iter().enumerate() {
            let (_, _, fit, cand, added) = &ranked[i];
            let what = format!("{} on {:?}", cand.kind, target_name(&fit.model, *cand));
            let (m, pc, ev) = match r {
                Ok(done) => done,
                Err(Unrefined::Diverged) => {
                    notes.push(format!(
                        "round {index}: {what}: simulation diverged, not confirmed"
                    ));
                    continue;
                }
                Err(Unrefined::NoGain(why)) => {
                    notes.push(format!(
                        "round {index}: {what}: not confirmed by simulation (its refinement stopped after the coarse stage: {why})"
                    ));
                    continue;
                }
            };
            if let Some(why) = unresolved(&m, *cand, self.ctx.st.dt) {
                notes.push(format!("round {index}: {what}: {why}, not named"));
                continue;
            }
            if !cand.input
                && cand.kind == EffectKind::BumpStop
                && stops_are_free_play(&m, self.ctx.st, cand.target)
            {
                notes.push(format!(
                    "round {index}: {what}: refined to stops on both sides engaged for most of the record (free play, not end stops), not named"
                ));
                continue;
            }
            let verdict = match &b.cur_eval {
                Some(prev) => sim.pays_off(prev, &ev, *added),
                None => Verdict {
                    confirmed: true,
                    text: "the model without it diverges, with it the simulation stays finite"
                        .into(),
                },
            };
            notes.push(format!(
                "round {index}: {what}: {} by simulation ({})",
                if verdict.confirmed {
                    "confirmed"
                } else {
                    "not confirmed"
                },
                verdict.text
            ));
            if verdict.confirmed {
                confirmed.push((i, m, pc, ev));
            }
        }
        confirmed
    }

    /// Among the `confirmed`, the best by the criterion (a branch with more parameters
    /// must explain more to be preferred); then, repeatedly, a confirmed branch with
    /// fewer parameters whose criterion is within [`PARSIMONY_Z`] standard errors of it
    /// (the two explain the record equally well). Returns its index in `confirmed` and,
    /// per confirmed branch, its criterion and the parameters it adds.
    fn pick(
        &self,
        b: &Branch,
        ranked: &[Ranked],
        confirmed: &[Confirmed],
        round: &Round<'_>,
        notes: &mut Vec<String>,
    ) -> (Option<usize>, Vec<(f64, usize)>) {
        let cur_eval = &b.cur_eval;
        let score = |ev: &Evaluation, added: usize| match cur_eval {
            Some(prev) => {
                let n_eff = prev.n_eff();
                n_eff * ev.total().ln() + added as f64 * n_eff.ln()
            }
            None => ev.total(),
        };
        // Per confirmed branch: (criterion, parameters added).
        let scored: Vec<(f64, usize)> = confirmed
            .iter()
            .map(|(i, _, _, ev)| (score(ev, ranked[*i].4), ranked[*i].4))
            .collect();
        let best_among = |among: &mut dyn Iterator<Item = usize>| {
            among.min_by(|&a, &b| scored[a].0.total_cmp(&scored[b].0))
        };
        let mut pick = best_among(&mut (0..confirmed.len()));
        while let (Some(w), Some(prev)) = (pick, cur_eval) {
            let simpler = best_among(&mut (0..confirmed.len()).filter(|&c| {
                scored[c].1 < scored[w].1
                    && scored[c].0 - scored[w].0
                        < PARSIMONY_Z
                            * prev.n_eff()
                            * log_ratio_std(&confirmed[c].3, &confirmed[w].3)
            }));
            let Some(c) = simpler else { break };
            let name = |k: usize| {
                let (_, _, fit, cand, _) = &ranked[confirmed[k].0];
                format!("{} on {:?}", cand.kind, target_name(&fit.model, *cand))
            };
            notes.push(format!(
                "round {}: {} explains the record as well as {} with fewer parameters (criteria within {PARSIMONY_Z} standard errors): preferred",
                round.index,
                name(c),
                name(w),
            ));
            pick = Some(c);
        }
        (pick, scored)
    }
}

/// The `confirmed` effects on an element other than the one picked (`w`), as refined,
/// added to `alternatives` unless they are there already.
fn collect_alternatives(
    ranked: &[Ranked],
    confirmed: &[Confirmed],
    w: usize,
    alternatives: &mut Vec<Alternative>,
) {
    for (c, (i, m, _, _)) in confirmed.iter().enumerate() {
        let (_, _, fit, cand, added) = &ranked[*i];
        let target = target_name(&fit.model, *cand);
        let known = alternatives
            .iter()
            .any(|a| a.kind == cand.kind && a.target == target);
        if c != w && !cand.input && !known {
            alternatives.push(Alternative {
                kind: cand.kind,
                parameters: effect_parameters(m, cand.kind, &target),
                target,
                added: *added,
            });
        }
    }
}

/// The `confirmed` candidates other than the one picked (`w`), best first by their
/// criterion (`scored`), each as a branch that names it.
fn runners_up(
    ranked: &[Ranked],
    confirmed: &[Confirmed],
    scored: &[(f64, usize)],
    w: usize,
) -> Vec<Branch> {
    let mut others: Vec<usize> = (0..confirmed.len()).filter(|&c| c != w).collect();
    others.sort_by(|&a, &b| scored[a].0.total_cmp(&scored[b].0));
    others
        .into_iter()
        .map(|c| {
            let (i, m, covariance, ev) = confirmed[c].clone();
            let (crit, ratio, fit, cand, added) = ranked[i].clone();
            Branch {
                named: vec![NamedDetail::selected(&fit.model, cand, crit, ratio)],
                added_of: vec![added],
                current: fit,
                updated: m,
                cur_eval: Some(ev),
                covariance,
            }
        })
        .collect()
}
