//! The parameters the report gives: a named saturation's limits within the record's
//! reach, each named effect's parameters with their standard deviations (delta method over
//! the final fit's covariance), and the recalibrated linear parameters with theirs.

use super::fit::Fit;
use super::parameters::{effect_parameters, linear_free, Param};
use super::report::NamedDetail;
use crate::effects::EffectKind;
use crate::equation::{Coef, States};
use crate::model::Model;
use nalgebra::{DMatrix, DVector};
use std::collections::BTreeMap;

/// A named saturation's limit the record never reaches is reported at the input's
/// extreme (the limit is there or beyond; the record cannot say where), in `updated` and
/// with a note. A saturation the model file gave is left as it was.
pub(super) fn saturation_within_reach(
    updated: &mut Model,
    named: &[NamedDetail],
    st: &States,
    notes: &mut Vec<String>,
) {
    for (j, inp) in updated.inputs.iter_mut().enumerate() {
        let named_here = named
            .iter()
            .any(|n| n.named.effect == EffectKind::Saturation && n.named.element == inp.name);
        let Some((lo, hi)) = inp.law.saturation.filter(|_| named_here) else {
            continue;
        };
        let raw = &st.inputs_raw[j];
        let (min, max) = raw.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |a, v| {
            (a.0.min(*v), a.1.max(*v))
        });
        for (side, extreme, beyond) in [
            (
                "lower limit; reported at the input's minimum",
                min,
                lo <= min,
            ),
            (
                "upper limit; reported at the input's maximum",
                max,
                hi >= max,
            ),
        ] {
            if beyond {
                notes.push(format!(
                    "saturation on {:?}: the record never reaches a {side} {extreme:.6e} \
                     (the limit is there or beyond)",
                    inp.name
                ));
            }
        }
        inp.law.saturation = Some((lo.max(min), hi.min(max)));
    }
}

/// Fills in the named effects' parameters and their standard deviations from `updated`
/// and the covariance `cov` of its parameters `cov_params`.
pub(super) fn fill_named(
    named: &mut [NamedDetail],
    updated: &Model,
    cov_params: &[Param],
    cov: &DMatrix<f64>,
) {
    for n in named {
        let params = effect_parameters(updated, n.named.effect, &n.named.element);
        n.std = parameter_std(updated, cov_params, cov, n.named.effect, &n.named.element);
        n.named.parameters = params;
    }
}

/// The corrected linear parameters of `model` (e.g. `"spring.stiffness_n_per_m"`) as
/// `updated` holds them, and one standard deviation of each: from the covariance `cov` of
/// the final fit's parameters `cov_params`, else from the equation-error recalibration
/// `recal_fit`'s; none for a coefficient held at a physical bound.
pub(super) fn recalibrated_parameters(
    model: &Model,
    updated: &Model,
    cov_params: &[Param],
    cov: &DMatrix<f64>,
    recal_fit: &Fit,
) -> (BTreeMap<String, f64>, BTreeMap<String, f64>) {
    let mut recalibrated = BTreeMap::new();
    let mut recalibrated_std = BTreeMap::new();
    for c in linear_free(model) {
        let label = c.label(updated);
        let value = match c {
            Coef::K(e) => updated.elements[e].law.stiffness_total(),
            _ => c.get(updated),
        };
        recalibrated.insert(label.clone(), value);
        // From the covariance of the final fit (the one the value comes from; a total
        // stiffness sums its linear and hysteretic parts), else from the recalibration's;
        // none for a coefficient held at a bound.
        let parts = match c {
            Coef::K(e) => vec![c, Coef::KH(e)],
            _ => vec![c],
        };
        let at: Vec<usize> = parts
            .iter()
            .filter_map(|x| cov_params.iter().position(|p| *p == Param::Lin(*x)))
            .collect();
        let sd = if cov_params.contains(&Param::Lin(c)) {
            let var: f64 = at
                .iter()
                .flat_map(|&a| at.iter().map(move |&b| (a, b)))
                .map(|(a, b)| cov[(a, b)])
                .sum();
            Some(var.max(0.0).sqrt())
        } else {
            recal_fit
                .free
                .iter()
                .position(|x| *x == c)
                .map(|i| recal_fit.covariance[(i, i)].max(0.0).sqrt())
        };
        if let Some(sd) = sd.filter(|v| v.is_finite()) {
            recalibrated_std.insert(label, sd);
        }
    }
    (recalibrated, recalibrated_std)
}

/// Standard deviations of an effect's reported parameters by the delta method over the
/// covariance `cov` of `params`.
fn parameter_std(
    m: &Model,
    params: &[Param],
    cov: &DMatrix<f64>,
    kind: EffectKind,
    target: &str,
) -> BTreeMap<String, f64> {
    let base = effect_parameters(m, kind, target);
    let p = params.len();
    let mut grads: BTreeMap<String, Vec<f64>> =
        base.keys().map(|k| (k.clone(), vec![0.0; p])).collect();
    for (i, par) in params.iter().enumerate() {
        let v = par.get(m);
        let h = 1e-6 * v.abs().max(1e-12);
        let mut mm = m.clone();
        if !par.set(&mut mm, v + h) {
            continue;
        }
        let pert = effect_parameters(&mm, kind, target);
        for (k, g) in grads.iter_mut() {
            g[i] = (pert.get(k).copied().unwrap_or(0.0) - base[k]) / h;
        }
    }
    grads
        .into_iter()
        .map(|(k, g)| {
            let gv = DVector::from_vec(g);
            let var = (gv.transpose() * cov * &gv)[(0, 0)];
            (k, var.max(0.0).sqrt())
        })
        .collect()
}
