//! Fitting one candidate effect on top of the current fit by equation error: its
//! coefficients with the linear parameters (linear least squares), and an effect with a
//! threshold-like parameter by a grid over quantiles of the data ([`super::grid`]).

use super::candidates::{physical, stops_are_free_play, Candidate};
use super::criterion::criterion;
use super::fit::{Context, Fit};
use super::grid::best_grid;
use super::hysteresis::fit_hysteresis;
use crate::effects::EffectKind;
use crate::equation::{self, Coef};
use crate::model::Model;
use crate::signal;

/// The least share of an input's spread (standard deviation over the record) that an input
/// effect must pass on to be a candidate: 0.5. Saturation, rate limits and delays that a
/// rig has shape the input and keep most of it; one that leaves less than half of it is the
/// model giving up on the input, which lowers an equation error measured in that input's
/// units for no physical reason.
pub const INPUT_KEPT: f64 = 0.5;

/// Fits candidate `cand` on top of the fitted `base` (its free and bounded coefficients free
/// again); returns the best fit over its grid and the number of parameters it adds.
pub(super) fn fit_candidate(
    ctx: &Context<'_>,
    grid: Option<&Context<'_>>,
    base: &Fit,
    cand: Candidate,
) -> Option<(Fit, usize)> {
    let st = ctx.st;
    let model = &base.model;
    // Coefficients the base held at a bound are free again: with the candidate effect the
    // data may put them back in range (an input delay read as negative damping).
    let mut free = base.free.clone();
    free.extend(base.bounded.iter().copied());
    let (u, ud) = equation::model_inputs(model, st);
    let sig = equation::element_signals(model, st, &u, &ud);
    // Quantiles over the whole record (less the filter transients): the grid values do not
    // depend on the record's order.
    let e = cand.target;
    let mut variants: Vec<Model> = Vec::new();
    let q = |s: &[f64], p: f64| signal::quantile_of(st.interior(s), p);
    if cand.input {
        return fit_input_candidate(ctx, grid, model, &free, cand);
    }
    match cand.kind {
        EffectKind::CubicStiffness => {
            let mut m = model.clone();
            m.elements[e].law.k3 = Some(0.0);
            free.push(Coef::K3(e));
            variants.push(m);
        }
        EffectKind::CoulombFriction => {
            let mut m = model.clone();
            let veps = (0.01 * signal::rms(&st.interior(&sig[e].v))).max(1e-12);
            m.elements[e].law.coulomb = Some((0.0, veps));
            free.push(Coef::Fc(e));
            variants.push(m);
        }
        EffectKind::QuadraticDamping => {
            let mut m = model.clone();
            m.elements[e].law.c2 = Some(0.0);
            free.push(Coef::C2(e));
            variants.push(m);
        }
        EffectKind::AsymmetricDamping => {
            let mut m = model.clone();
            m.elements[e].law.c_abs = Some(0.0);
            free.push(Coef::CAbs(e));
            if !free.contains(&Coef::C(e)) {
                free.push(Coef::C(e));
            }
            variants.push(m);
        }
        EffectKind::BumpStop => return fit_bump_stop(ctx, grid, base, free, &sig[e].x, cand),
        EffectKind::Backlash => {
            let absx: Vec<f64> = sig[e].x.iter().map(|v| v.abs()).collect();
            for p in [0.03, 0.07, 0.15, 0.25, 0.35, 0.5] {
                let b = q(&absx, p);
                if b > 0.0 {
                    let mut m = model.clone();
                    m.elements[e].law.backlash = Some(b);
                    variants.push(m);
                }
            }
            if !free.contains(&Coef::K(e)) {
                free.push(Coef::K(e));
            }
        }
        EffectKind::LiftOff => {
            // The preload must be exceeded by the element's tension somewhere.
            let law = &model.elements[e].law;
            let unpacked = crate::effects::CompiledLaw::new(law);
            let tension: Vec<f64> = (0..sig[e].x.len())
                .map(|t| -unpacked.force_unclipped(sig[e].x[t], sig[e].v[t], sig[e].z[t]))
                .collect();
            // Down to a wheel off the road for a few tenths of a per cent of the record.
            for p in [0.8, 0.9, 0.95, 0.98, 0.995, 0.999, 0.9997] {
                let pre = q(&tension, p);
                if pre > 0.0 {
                    let mut m = model.clone();
                    m.elements[e].law.lift_off = Some(pre);
                    variants.push(m);
                }
            }
        }
        EffectKind::Hysteresis => return fit_hysteresis(ctx, grid, model, free, &sig[e].x, e),
        // Input effects are fitted above; none of them attaches to an element.
        EffectKind::InputDelay | EffectKind::RateLimit | EffectKind::Saturation => return None,
    }
    best_grid(ctx, grid, variants, &free).map(|f| (f, 1))
}

/// [`fit_candidate`] for an input effect (`cand.input`): its grid over quantiles of the
/// logged input, fitted with the coefficients `free`.
fn fit_input_candidate(
    ctx: &Context<'_>,
    grid: Option<&Context<'_>>,
    model: &Model,
    free: &[Coef],
    cand: Candidate,
) -> Option<(Fit, usize)> {
    let st = ctx.st;
    let mut variants: Vec<Model> = Vec::new();
    let mut added = 1;
    let q = |s: &[f64], p: f64| signal::quantile_of(st.interior(s), p);
    let j = cand.target;
    let raw = &st.inputs_raw[j];
    let with = |set: &dyn Fn(&mut crate::effects::InputLaw)| {
        let mut m = model.clone();
        set(&mut m.inputs[j].law);
        m
    };
    // An input effect that passes on less than INPUT_KEPT of the input's spread does
    // not shape the input, it removes it (a rate limit far below the input's rates: the
    // equation error then shrinks with the force it no longer has to explain).
    let spread = signal::std(&st.interior(raw));
    let keeps = |m: &Model| {
        let t = m.inputs[j].law.transform(raw, st.dt);
        signal::std(&st.interior(&t)) >= INPUT_KEPT * spread
    };
    match cand.kind {
        EffectKind::InputDelay => {
            // From one sample period: a shorter delay is not resolved (see `unresolved`).
            for k in [1.0, 2.0, 3.0, 5.0, 8.0, 12.0, 20.0] {
                variants.push(with(&|l| l.delay_s = Some(k * st.dt)));
            }
        }
        EffectKind::Saturation => {
            // Both limits at the same quantile level, or one of them out of reach:
            // symmetric and one-sided clipping (the refinement then moves both).
            added = 2;
            let (top, bottom) = (q(raw, 1.0), q(raw, 0.0));
            let span = top - bottom;
            let (below, above) = (bottom - span, top + span);
            for p in [0.8, 0.9, 0.95, 0.99, 0.997] {
                let (lo, hi) = (q(raw, 1.0 - p), q(raw, p));
                for limits in [(lo, hi), (lo, above), (below, hi)] {
                    if limits.1 > limits.0 {
                        variants.push(with(&|l| l.saturation = Some(limits)));
                    }
                }
            }
            // The refinement cannot bring back a limit that clips nothing: when the best
            // is one-sided, the other limit is tried at each level too.
            variants.retain(keeps);
            let best = best_grid(ctx, grid, variants, free)?;
            let Some((lo, hi)) = best.model.inputs[j].law.saturation else {
                return Some((best, added));
            };
            let mut others = Vec::new();
            for p in [0.8, 0.9, 0.95, 0.99, 0.997] {
                let limits = if lo <= below {
                    (q(raw, 1.0 - p), hi)
                } else if hi >= above {
                    (lo, q(raw, p))
                } else {
                    continue;
                };
                if limits.1 > limits.0 {
                    others.push(with(&|l| l.saturation = Some(limits)));
                }
            }
            others.retain(keeps);
            let other = best_grid(ctx, grid, others, free);
            return Some(match other {
                Some(o) if o.sse_fit < best.sse_fit => (o, added),
                _ => (best, added),
            });
        }
        EffectKind::Backlash => {
            // Half gaps at quantiles of the input's distance from its median (scale
            // free, whatever the record's order).
            let mid = q(raw, 0.5);
            let dev: Vec<f64> = raw.iter().map(|v| (v - mid).abs()).collect();
            for p in [0.03, 0.07, 0.15, 0.25, 0.35, 0.5] {
                let b = q(&dev, p);
                if b > 0.0 {
                    variants.push(with(&|l| l.backlash = Some(b)));
                }
            }
        }
        _ => {
            // Rates at quantiles of the rate of the input the limit acts on (the
            // low-passed logged input), from a limit most of the record reaches (a sweep
            // whose upper half of frequencies is limited) up to the rarest events (bumps).
            let d = signal::derivative(raw, st.dt);
            let a: Vec<f64> = d.iter().map(|v| v.abs()).collect();
            for p in [0.3, 0.5, 0.7, 0.9, 0.97, 0.99, 0.997, 0.999] {
                let l = q(&a, p);
                if l > 0.0 {
                    variants.push(with(&|law| law.rate_limit = Some(l)));
                }
            }
        }
    }
    variants.retain(keeps);
    best_grid(ctx, grid, variants, free).map(|f| (f, added))
}

/// [`fit_candidate`] for a bump stop on element `cand.target` (compression `x`), with the
/// coefficients `free`: a stop in compression or in extension (its gap on a grid, its
/// stiffness fitted; two parameters), or one at each end of the travel (four) when the
/// second pays for its parameters on the validation blocks and the two are end stops
/// ([`stops_are_free_play`]).
fn fit_bump_stop(
    ctx: &Context<'_>,
    grid: Option<&Context<'_>>,
    base: &Fit,
    mut free: Vec<Coef>,
    x: &[f64],
    cand: Candidate,
) -> Option<(Fit, usize)> {
    let (st, model, e) = (ctx.st, &base.model, cand.target);
    let mut variants: Vec<Model> = Vec::new();
    let q = |s: &[f64], p: f64| signal::quantile_of(st.interior(s), p);
    let added = 2;
    free.push(Coef::BumpK(e));
    for p in [0.6, 0.75, 0.85, 0.92, 0.97, 0.99] {
        let gap = q(x, p);
        if gap > 0.0 {
            let mut m = model.clone();
            m.elements[e].law.bump = Some((gap, 0.0));
            variants.push(m);
        }
    }
    // Extension side: a separate structure (rebound stop), same parameter count.
    let neg: Vec<f64> = x.iter().map(|v| -v).collect();
    let mut reb = Vec::new();
    for p in [0.6, 0.75, 0.85, 0.92, 0.97, 0.99] {
        let gap = q(&neg, p);
        if gap > 0.0 {
            let mut m = model.clone();
            m.elements[e].law.rebound = Some((gap, 0.0));
            reb.push(m);
        }
    }
    let mut free_r = base.free.clone();
    free_r.extend(base.bounded.iter().copied());
    free_r.push(Coef::RebK(e));
    // Only stops that push back (a fit that pulls is not a stop, see `physical`).
    let pushes = |f: &Fit| physical(&f.model, cand);
    // A stop at each end of the travel: each gap at its own quantile level of its
    // side's deflection (the two ends need not be reached alike), each stop's
    // stiffness free (two more parameters).
    let levels = [0.75, 0.85, 0.92, 0.97, 0.99];
    let mut both = Vec::new();
    for pg in levels {
        for pr in levels {
            let (gap, rg) = (q(x, pg), q(&neg, pr));
            if gap > 0.0 && rg > 0.0 {
                let mut m = model.clone();
                m.elements[e].law.bump = Some((gap, 0.0));
                m.elements[e].law.rebound = Some((rg, 0.0));
                both.push(m);
            }
        }
    }
    let mut free_2 = free.clone();
    free_2.push(Coef::RebK(e));
    let best_b = best_grid(ctx, grid, variants, &free).filter(pushes);
    let best_r = best_grid(ctx, grid, reb, &free_r).filter(pushes);
    let best = match (best_b, best_r) {
        (Some(a), Some(b)) => Some(if a.sse_fit <= b.sse_fit { a } else { b }),
        (a, b) => a.or(b),
    };
    let best_2 = best_grid(ctx, grid, both, &free_2)
        .filter(pushes)
        .filter(|f| !stops_are_free_play(&f.model, st, e));
    match (best, best_2) {
        (Some(one), Some(two)) => {
            // The second stop must pay for its two parameters on the validation
            // blocks, by the criterion the ranking uses.
            let n_eff = (one.val_rows as f64 / one.tau).max(2.0);
            let crit = criterion(n_eff, two.sse_val / one.sse_val, 2.0);
            Some(if crit < 0.0 { (two, 4) } else { (one, added) })
        }
        (Some(one), None) => Some((one, added)),
        (None, two) => two.map(|f| (f, 4)),
    }
}
