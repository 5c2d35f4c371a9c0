//! The replacement step: with two effects or more, each named effect is tried replaced by
//! each of the other effects a round confirmed on its element (as refined there), the whole
//! refined by output error. An effect named first can stand in for the right one on its
//! element while the record still lacks the other effect (a Bouc-Wen loop for a hardening
//! spring when a rate limit's lag is not yet modelled); with the other effect in, the right
//! one explains the record better. A replacement is made when it lowers the criterion
//! `n_eff ln(SSE ratio) + Δp ln n_eff` (fewer parameters for as good a fit, or a better fit
//! that pays for its parameters) and, when it has more parameters, passes the practical
//! margin as any added effect.

use super::criterion::{criterion, Evaluation};
use super::elimination::Selected;
use super::output_error::refine_output_error;
use super::parameters::{effect_coefs, without_effect, Covariance};
use super::report::{NamedDetail, NamedEffect};
use super::selection::{Alternative, Selection};
use crate::equation::Coef;
use crate::model::Model;
use crate::parallel;
use std::collections::BTreeMap;

/// A model refined by output error: the model, its parameters' covariance, its simulated
/// validation residual and the linear coefficients it frees.
type Refined = (Model, Covariance, Evaluation, Vec<Coef>);

impl Selection<'_> {
    /// The replacement step on `sel` with the rounds' `alternatives`; what it tries and
    /// makes goes to `notes`.
    pub(super) fn replace(
        &self,
        sel: &mut Selected,
        alternatives: &[Alternative],
        notes: &mut Vec<String>,
    ) {
        if !(self.oe && sel.named.len() >= 2 && !alternatives.is_empty()) {
            return;
        }
        (self.log)(0.95, "replacement by the rounds' alternatives");
        for i in 0..sel.named.len() {
            let Some(with) = sel.cur_eval.clone() else {
                break;
            };
            let Some((crit, ratio, a, (m2, pc, ev, free_sw))) =
                self.best_replacement(sel, i, &with, alternatives, notes)
            else {
                continue;
            };
            let (what, target) = (
                sel.named[i].named.effect,
                sel.named[i].named.element.clone(),
            );
            let kind = a.kind;
            notes.push(format!(
                "replacement: {kind} on {target:?} named in place of {what} (criterion {crit:.1})"
            ));
            if let Some(n) = sel.named.get_mut(i) {
                *n = NamedDetail {
                    named: NamedEffect {
                        effect: kind,
                        element: target.clone(),
                        parameters: BTreeMap::new(),
                    },
                    std: BTreeMap::new(),
                    criterion: crit,
                    sse_ratio: ratio,
                };
            }
            if let Some(p) = sel.added_of.get_mut(i) {
                *p = a.added;
            }
            sel.updated = m2;
            sel.free_now = free_sw;
            (sel.cov_params, sel.cov) = pc;
            sel.cur_eval = Some(ev);
        }
    }

    /// The best replacement of `sel`'s named effect `i` (simulated validation residual
    /// `with`) among the `alternatives` on its element: its criterion, validation SSE
    /// ratio, the alternative and its refined replacement; `None` when none lowers the
    /// criterion and pays off.
    fn best_replacement<'x>(
        &self,
        sel: &Selected,
        i: usize,
        with: &Evaluation,
        alternatives: &'x [Alternative],
        notes: &mut Vec<String>,
    ) -> Option<(f64, f64, &'x Alternative, Refined)> {
        let (sim, refine_on, threads) = (self.sim, self.refine_on, self.threads);
        let (updated, free_now, named) = (&sel.updated, &sel.free_now, &sel.named);
        let (what, target) = (named[i].named.effect, named[i].named.element.clone());
        let p_named = sel.added_of.get(i).copied().unwrap_or(0);
        let tries: Vec<&Alternative> = alternatives
            .iter()
            .filter(|a| {
                a.target == target
                    && !named
                        .iter()
                        .any(|n| n.named.effect == a.kind && n.named.element == a.target)
            })
            .collect();
        if tries.is_empty() {
            return None;
        }
        let refined = parallel::map(
            &tries,
            threads,
            |a| {
                let (mut m_sw, free_wo) = without_effect(updated, free_now, what, &target);
                let before = effect_coefs(&m_sw);
                let el = m_sw.elements.iter_mut().find(|e| e.name == a.target)?;
                el.law.apply(a.kind, &a.parameters).ok()?;
                let mut free_sw = free_wo;
                free_sw.extend(
                    effect_coefs(&m_sw)
                        .into_iter()
                        .filter(|c| !before.contains(c)),
                );
                let (m2, pc) =
                    refine_output_error(&m_sw, &free_sw, refine_on, threads, None).ok()?;
                let ev = sim.evaluate(&m2)?;
                Some((m2, pc, ev, free_sw))
            },
            |_, _| {},
        );
        let n_eff = with.n_eff();
        // (criterion, SSE ratio, the alternative, its refined replacement)
        let mut best: Option<(f64, f64, &'x Alternative, Refined)> = None;
        for (r, a) in refined.into_iter().zip(tries.iter().copied()) {
            let Some((m2, pc, ev, free_sw)) = r else {
                continue;
            };
            let kind = a.kind;
            let ratio = ev.total() / with.total();
            let crit = criterion(n_eff, ratio, a.added as f64 - p_named as f64);
            let pays = a.added <= p_named || sim.pays_off(with, &ev, a.added - p_named).confirmed;
            notes.push(format!(
                "replacement: {kind} on {target:?} in place of {what}: validation SSE x{ratio:.3}, criterion {crit:.1}{}",
                if crit < 0.0 && pays { "" } else { ", not made" }
            ));
            if crit.is_finite() && crit < 0.0 && pays && best.as_ref().is_none_or(|b| crit < b.0) {
                best = Some((crit, ratio, a, (m2, pc, ev, free_sw)));
            }
        }
        best
    }
}
