//! Grids of threshold-like parameter values (gaps, preloads, delays, limits, the Bouc-Wen
//! shape): each grid point a linear fit, ranked on a thinned fitting set, the best few
//! fitted on every fitting block.

use super::fit::{Context, Fit};
use crate::equation::Coef;
use crate::model::Model;

/// Effectively independent rows (fitting rows over the residual's correlation time) on
/// which a candidate's grid of threshold-like parameter values is ranked (see
/// [`diagnose`](super::diagnose)): 2000, a standard error of about 2 % on a sum of squares, ample to rank
/// grid values that differ by a modelled effect.
pub const GRID_EFFECTIVE_SAMPLES: f64 = 2000.0;

/// Grid values (the best on the prefix, see [`GRID_EFFECTIVE_SAMPLES`]) fitted on the
/// whole fitting part, of which the best is kept: 2, so that a ranking on the prefix that
/// differs in the last digits from the whole record's does not decide the value.
pub const GRID_FINALISTS: usize = 2;

/// The most the grid ranking thins the fitting blocks (every 5th block at most, so that
/// the thinned set still holds blocks from every part of the record).
pub(super) const MAX_THIN: usize = 5;

/// The best of `variants` fitted on `ctx`. With a `grid` context (a prefix of the record),
/// the variants are ranked on it and the [`GRID_FINALISTS`] best are fitted on `ctx`.
pub(super) fn best_grid(
    ctx: &Context<'_>,
    grid: Option<&Context<'_>>,
    variants: Vec<Model>,
    free: &[Coef],
) -> Option<Fit> {
    match grid {
        Some(g) if variants.len() > GRID_FINALISTS => {
            let mut ranked: Vec<Fit> = variants
                .into_iter()
                .map(|m| g.rank(m, free))
                .filter(|f| f.sse_fit.is_finite())
                .collect();
            ranked.sort_by(|a, b| a.sse_fit.total_cmp(&b.sse_fit));
            let finalists = ranked
                .into_iter()
                .take(GRID_FINALISTS)
                .map(|f| f.model)
                .collect();
            best_of(ctx, finalists, free)
        }
        _ => best_of(ctx, variants, free),
    }
}

/// The best of `variants` fitted on `ctx` (ranked on it first when there are several).
fn best_of(ctx: &Context<'_>, mut variants: Vec<Model>, free: &[Coef]) -> Option<Fit> {
    let best = if variants.len() == 1 {
        variants.pop()?
    } else {
        best_ranked(ctx, variants, free)?.1
    };
    Some(ctx.fit(best, free)).filter(|f| f.sse_fit.is_finite())
}

/// The best of `variants` ranked on `ctx` ([`Context::rank`]): its ranking fit and the
/// variant as given (which [`Context::fit`] turns into the same fit, with its validation
/// and covariance).
pub(super) fn best_ranked(
    ctx: &Context<'_>,
    variants: Vec<Model>,
    free: &[Coef],
) -> Option<(Fit, Model)> {
    variants
        .into_iter()
        .map(|m| (ctx.rank(m.clone(), free), m))
        .filter(|(f, _)| f.sse_fit.is_finite())
        .min_by(|a, b| a.0.sse_fit.total_cmp(&b.0.sse_fit))
}
