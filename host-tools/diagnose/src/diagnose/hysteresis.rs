//! The hysteresis candidate: a Bouc-Wen loop on an element, its shape (β, γ) on a grid
//! and then refined by a shrinking pattern search, its hysteretic stiffness fitted with the
//! linear parameters.

use super::fit::{Context, Fit};
use super::grid::best_ranked;
use crate::effects::BoucWen;
use crate::equation::Coef;
use crate::model::Model;
use crate::signal;

/// Fits a Bouc-Wen loop on element `e` of `model` (compression `x`) with the coefficients
/// `free` (the hysteretic stiffness and the element's stiffness added): its shape on a grid
/// ranked on `grid` (or `ctx`), then refined ([`refine_hysteresis`]) and fitted on `ctx`.
/// Returns the fit and the parameters it adds (3).
pub(super) fn fit_hysteresis(
    ctx: &Context<'_>,
    grid: Option<&Context<'_>>,
    model: &Model,
    mut free: Vec<Coef>,
    x: &[f64],
    e: usize,
) -> Option<(Fit, usize)> {
    let st = ctx.st;
    let mut variants: Vec<Model> = Vec::new();
    let added = 3;
    let sx = signal::std(&st.interior(x)).max(1e-300);
    for bs in [0.3, 1.0, 3.0, 10.0, 30.0] {
        for gr in [-1.5, -0.75, 0.0, 0.5, 1.0] {
            let beta = bs / sx;
            let mut m = model.clone();
            let l = &mut m.elements[e].law;
            l.hysteresis = Some(BoucWen {
                a: 1.0,
                beta,
                gamma: gr * beta,
                n: 1.0,
            });
            l.k_h = 0.0;
            variants.push(m);
        }
    }
    free.push(Coef::KH(e));
    if !free.contains(&Coef::K(e)) {
        free.push(Coef::K(e));
    }
    let on = grid.unwrap_or(ctx);
    let best = best_ranked(on, variants, &free)?;
    // Local refinement of (ln β, γ/β) by a shrinking pattern search.
    let (refined, given) = refine_hysteresis(on, best, &free, e);
    // Fitted on every fitting block from the grid's estimate, or (ranked there
    // already) fitted again as given for its validation and covariance.
    let refined = if grid.is_some() {
        ctx.fit(refined.model, &free)
    } else {
        ctx.fit(given, &free)
    };
    Some((refined, added))
}

/// A shrinking pattern search on (ln β, γ/β) of element `e`'s Bouc-Wen law from the
/// ranked fit `best` (with the variant it was fitted from); returns the best ranked fit and
/// the model it was fitted from.
fn refine_hysteresis(
    ctx: &Context<'_>,
    (mut best, mut given): (Fit, Model),
    free: &[Coef],
    e: usize,
) -> (Fit, Model) {
    let Some(bw) = best.model.elements[e].law.hysteresis else {
        return (best, given);
    };
    let (mut lb, mut g) = (bw.beta.ln(), bw.gamma / bw.beta);
    let (mut slb, mut sg) = (0.5, 0.25);
    for _ in 0..4 {
        let mut improved = false;
        for (dl, dg) in [(slb, 0.0), (-slb, 0.0), (0.0, sg), (0.0, -sg)] {
            let mut m = best.model.clone();
            let beta = (lb + dl).exp();
            m.elements[e].law.hysteresis = Some(BoucWen {
                beta,
                gamma: (g + dg) * beta,
                ..bw
            });
            let f = ctx.rank(m.clone(), free);
            if f.sse_fit < best.sse_fit {
                best = f;
                given = m;
                lb += dl;
                g += dg;
                improved = true;
            }
        }
        if !improved {
            slb *= 0.5;
            sg *= 0.5;
        }
    }
    (best, given)
}
