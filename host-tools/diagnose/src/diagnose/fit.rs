//! Fitting a model structure by equation error ([`crate::equation`]) on the fitting blocks,
//! within physical bounds: the [`Fit`] and the [`Context`] it is fitted in (the estimated
//! states, the row weights, the split, and a thinned fitting set for ranking grids).

use crate::equation::{self, Coef, States};
use crate::model::Model;
use crate::split::Split;
use nalgebra::DMatrix;

/// A fitted model structure.
#[derive(Clone)]
pub(super) struct Fit {
    pub(super) model: Model,
    pub(super) free: Vec<Coef>,
    pub(super) covariance: DMatrix<f64>,
    pub(super) sse_fit: f64,
    pub(super) sse_val: f64,
    pub(super) val_rows: usize,
    pub(super) tau: f64,
    /// Coefficients the least-squares fit would have put outside their physical range
    /// (a mass <= 0, a stiffness or damping < 0), held at their bound instead (a mass at its
    /// value in the model fitted, a stiffness or damping at 0) and no longer free.
    pub(super) bounded: Vec<Coef>,
}

/// The physical bound a linear coefficient's estimate violates, if any: the value to hold it
/// at instead.
fn bound_of(c: Coef, value: f64, held: &Model) -> Option<f64> {
    match c {
        Coef::Mass(_) if value <= 0.0 => Some(c.get(held)),
        Coef::K(_) | Coef::C(_) | Coef::KH(_) if value < 0.0 => Some(0.0),
        _ => None,
    }
}

/// What a structure is fitted on: the estimated states, the row weights (one over each
/// DOF's inertia-force spread) and the split into fitting and validation blocks.
pub(super) struct Context<'a> {
    pub(super) st: &'a States,
    pub(super) weights: Vec<f64>,
    pub(super) split: &'a Split,
    /// Keep the fitting blocks whose index is a multiple of this (1: every fitting block): a
    /// thinned fitting set spread over the record, for ranking grids.
    pub(super) thin: usize,
}

impl Context<'_> {
    fn is_fit(&self, t: usize) -> bool {
        self.split.is_fit(t) && (self.thin <= 1 || self.split.block_of(t) % self.thin == 0)
    }

    fn is_val(&self, t: usize) -> bool {
        self.split.is_validation(t)
    }

    /// Fits `free` in `model` on the fitting blocks (lift-off: the contact mask is updated
    /// from the fitted law and the fit repeated). A coefficient whose estimate leaves its
    /// physical range is held at its bound and the rest fitted again ([`Fit::bounded`]).
    pub(super) fn fit(&self, model: Model, free: &[Coef]) -> Fit {
        let held = model.clone();
        self.fit_bounded(model, free.to_vec(), &held, false)
    }

    /// [`Context::fit`] for ranking structures: the same coefficients and fitting sum of
    /// squares, without the validation residuals and the covariance (`sse_val`, `tau` and
    /// `covariance` are NaN, `val_rows` 0).
    pub(super) fn rank(&self, model: Model, free: &[Coef]) -> Fit {
        let held = model.clone();
        self.fit_bounded(model, free.to_vec(), &held, true)
    }

    /// The active set of [`Context::fit`]: fits, holds the coefficient that leaves its range
    /// furthest (relative to its value in `held`, the model given) at its bound, and fits
    /// the rest again, until every free coefficient is in range. Holding one coefficient
    /// moves the others, so one at a time.
    fn fit_bounded(&self, mut model: Model, mut free: Vec<Coef>, held: &Model, rank: bool) -> Fit {
        let mut bounded = Vec::new();
        loop {
            let f = self.fit_unbounded(model.clone(), &free, rank);
            let worst = f
                .free
                .iter()
                .filter_map(|&c| {
                    let v = c.get(&f.model);
                    bound_of(c, v, held).map(|b| {
                        let scale = c.get(held).abs().max(f64::MIN_POSITIVE);
                        (c, b, (v - b).abs() / scale)
                    })
                })
                .max_by(|a, b| a.2.total_cmp(&b.2));
            let Some((c, b, _)) = worst else {
                let mut f = f;
                f.bounded = bounded;
                return f;
            };
            free.retain(|x| *x != c);
            c.set(&mut model, b);
            bounded.push(c);
        }
    }

    /// [`Context::fit`] (or with `rank`, [`Context::rank`]) without the physical bounds.
    fn fit_unbounded(&self, mut model: Model, free: &[Coef], rank: bool) -> Fit {
        let passes = if model.elements.iter().any(|e| e.law.lift_off.is_some()) {
            if rank {
                LIFT_OFF_RANKING_PASSES
            } else {
                LIFT_OFF_FIT_PASSES
            }
        } else {
            1
        };
        let mut last = None;
        let mut used = Vec::new();
        for pass in 0..passes {
            // A pass whose contact masks are those of the previous pass would build the
            // same regression and find the same coefficients: the fixed point is reached.
            let keys = equation::contact_mask_keys(&model, self.st);
            if pass > 0 && keys == used {
                break;
            }
            used = keys;
            let sys = equation::build(&model, self.st, free, &self.weights);
            let sol = if rank {
                sys.solve_ranking(|t| self.is_fit(t))
            } else {
                sys.solve(|t| self.is_fit(t))
            };
            for (c, v) in free.iter().zip(&sol.theta) {
                c.set(&mut model, *v);
            }
            last = Some((sys, sol));
        }
        let Some((sys, sol)) = last else {
            unreachable!("at least one pass")
        };
        if rank {
            return Fit {
                free: free.to_vec(),
                covariance: sol.covariance,
                sse_fit: sol.sse,
                sse_val: f64::NAN,
                val_rows: 0,
                tau: f64::NAN,
                model,
                bounded: Vec::new(),
            };
        }
        let val = if sol.sse.is_finite() {
            sys.residuals(&sol.theta, |t| self.is_val(t))
        } else {
            vec![f64::INFINITY]
        };
        let dofs = sys.dof.iter().copied().max().map_or(1, |m| m + 1);
        Fit {
            free: free.to_vec(),
            covariance: sol.covariance,
            sse_fit: sol.sse,
            sse_val: val.iter().map(|v| v * v).sum(),
            val_rows: val.len(),
            tau: equation::correlation_time_rows(&val, dofs),
            model,
            bounded: Vec::new(),
        }
    }
}

/// Passes of the lift-off contact masks when a candidate's grid values are ranked: 2 (each
/// pass solves the regression with the contact of the previous pass' coefficients). A
/// single pass misranked the preload grid (1717 N instead of 1668 N on the tyre example).
pub const LIFT_OFF_RANKING_PASSES: usize = 2;

/// Passes of the lift-off contact masks in a fit: 3 (stops early at a fixed point).
pub const LIFT_OFF_FIT_PASSES: usize = 3;
