//! Stepwise selection after the forward search: the backward elimination removes any
//! named effect the record does not need (its removal, the rest refined by output error,
//! does not fail the test an added effect passes, or a Wald test cannot tell its strength
//! from none), and when it drops one while rounds are left the forward search goes on from
//! the reduced model ([`STEPWISE_PASSES`]).

use super::criterion::Evaluation;
use super::fit::Fit;
use super::output_error::refine_output_error;
use super::parameters::{strength, without_effect, Param};
use super::report::NamedDetail;
use super::selection::{Branch, Findings, Selection};
use crate::effects::EffectKind;
use crate::equation::Coef;
use crate::model::Model;
use crate::parallel;
use nalgebra::DMatrix;

/// How many times the forward search goes on after the backward elimination dropped an
/// effect (each pass then eliminates again): bounds the cost, and a search cannot cycle.
pub const STEPWISE_PASSES: usize = 1;

/// Where the selection stands after the stepwise search: the model refined by output error
/// with the effects named, its parameters and their covariance, the linear coefficients it
/// frees, its simulated validation residual, and the parameters each named effect adds.
pub(super) struct Selected {
    pub(super) updated: Model,
    pub(super) cov_params: Vec<Param>,
    pub(super) cov: DMatrix<f64>,
    pub(super) named: Vec<NamedDetail>,
    pub(super) free_now: Vec<Coef>,
    pub(super) cur_eval: Option<Evaluation>,
    pub(super) added_of: Vec<usize>,
}

impl Branch {
    /// The branch's selection (its free parameters those of its current fit), and that fit.
    fn into_selected(self) -> (Fit, Selected) {
        let Branch {
            current,
            updated,
            cur_eval,
            covariance: (cov_params, cov),
            named,
            added_of,
        } = self;
        let selected = Selected {
            updated,
            cov_params,
            cov,
            named,
            free_now: current.free.clone(),
            cur_eval,
            added_of,
        };
        (current, selected)
    }
}

impl Selection<'_> {
    /// Stepwise: the backward elimination below, and when it drops an effect while rounds
    /// are left, the forward search goes on from the reduced model for those rounds (an
    /// effect named early as a stand-in and dropped once a later one explains the record
    /// leaves room for the one the record still lacks), then the elimination again.
    pub(super) fn stepwise(&self, mut main: Branch, found: &mut Findings) -> Selected {
        let mut passes = 0;
        loop {
            let (current, mut sel) = main.into_selected();
            let dropped = self.eliminate(&mut sel, &mut found.notes);
            if dropped.is_empty()
                || passes >= STEPWISE_PASSES
                || sel.named.len() >= self.options.max_effects
            {
                return sel;
            }
            passes += 1;
            // The search goes on from the equation-error fit of the reduced model.
            let (mut model_ee, mut free_ee) = (current.model.clone(), current.free.clone());
            free_ee.extend(current.bounded.iter().copied());
            for (what, target) in &dropped {
                (model_ee, free_ee) = without_effect(&model_ee, &free_ee, *what, target);
            }
            let before = sel.named.len();
            main = Branch {
                current: self.ctx.fit(model_ee, &free_ee),
                updated: sel.updated,
                cur_eval: sel.cur_eval,
                covariance: (sel.cov_params, sel.cov),
                named: sel.named,
                added_of: sel.added_of,
            };
            (self.log)(0.9, "the search goes on from the reduced model");
            self.forward(
                &mut main,
                before..self.options.max_effects,
                None,
                found,
                true,
            );
            if main.named.len() == before {
                return main.into_selected().1;
            }
        }
    }

    /// Backward elimination in simulation (with output error and two effects or more):
    /// each named effect is removed from the final model in turn and the rest refined by
    /// output error from the final parameters; an effect is dropped when the model without
    /// it, equally refined, is as good by the same test (a later effect may explain what an
    /// earlier one stood in for), or, for an effect of one parameter, when its strength
    /// (e.g. `k3`, a friction force, a gap; see [`strength`]) is not distinguishable from
    /// none by a Wald test with the criterion's penalty (`z² < ln n_eff`). One parameter of
    /// an effect of several (a stop's stiffness beside its gap, a loop's k_h beside its
    /// shape) has a marginal variance inflated by their correlation: the removal tests that
    /// effect. Returns the effects dropped (effect, element or input); `sel` is left
    /// without them.
    fn eliminate(&self, sel: &mut Selected, notes: &mut Vec<String>) -> Vec<(EffectKind, String)> {
        let mut dropped: Vec<(EffectKind, String)> = Vec::new();
        if !(self.oe && sel.named.len() > 1) {
            return dropped;
        }
        let (sim, refine_on, threads) = (self.sim, self.refine_on, self.threads);
        (self.log)(0.9, "backward elimination by simulation");
        let without = |updated: &Model, free_now: &[Coef], what: EffectKind, target: &str| {
            let (m_wo, free_wo) = without_effect(updated, free_now, what, target);
            refine_output_error(&m_wo, &free_wo, refine_on, threads, None)
                .ok()
                .and_then(|(m2, pc)| {
                    let ev = sim.evaluate(&m2)?;
                    Some((m2, pc, ev, free_wo))
                })
        };
        // Every removal from the final model, refined concurrently; they stay valid until an
        // effect is dropped (which changes the model the rest start from).
        let effects: Vec<(EffectKind, String)> = sel
            .named
            .iter()
            .map(|n| (n.named.effect, n.named.element.clone()))
            .collect();
        let mut speculative: Vec<Option<_>> = parallel::map(
            &effects,
            threads,
            |(what, target)| without(&sel.updated, &sel.free_now, *what, target),
            |_, _| {},
        )
        .into_iter()
        .map(Some)
        .collect();
        for i in (0..sel.named.len()).rev() {
            let Some(with) = sel.cur_eval.clone() else {
                break;
            };
            let what = sel.named[i].named.effect;
            let target = sel.named[i].named.element.clone();
            let n_eff_with = with.n_eff();
            let wald = strength(&sel.updated, what, &target).and_then(|par| {
                let k = sel.cov_params.iter().position(|x| *x == par)?;
                let var = sel.cov[(k, k)];
                let v = par.get(&sel.updated);
                (var.is_finite() && var > 0.0).then(|| v * v / var)
            });
            let weak =
                sel.added_of.get(i) == Some(&1) && wald.is_some_and(|z2| z2 < n_eff_with.ln());
            let refined_without = match speculative.get_mut(i).and_then(Option::take) {
                Some(r) if dropped.is_empty() => r,
                _ => without(&sel.updated, &sel.free_now, what, &target),
            };
            let Some((m2, pc, ev_wo, free_wo)) = refined_without else {
                continue;
            };
            let verdict = sim.pays_off(&ev_wo, &with, sel.added_of[i]);
            if weak || !verdict.confirmed {
                let why = match wald {
                    Some(z2) if weak => format!(
                        "its strength is within {:.2} standard errors of none (Wald z² {z2:.2} < ln n_eff = {:.1})",
                        z2.sqrt(),
                        n_eff_with.ln()
                    ),
                    _ => "the other effects refined without it do about as well in simulation".into(),
                };
                notes.push(format!("{what}: dropped, {why} ({})", verdict.text));
                sel.named.remove(i);
                sel.added_of.remove(i);
                sel.updated = m2;
                sel.free_now = free_wo;
                (sel.cov_params, sel.cov) = pc;
                sel.cur_eval = Some(ev_wo);
                dropped.push((what, target));
            }
        }
        dropped
    }
}
