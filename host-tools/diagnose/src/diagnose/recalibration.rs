//! Recalibration of the linear parameters: the equation-error fit of the model as given
//! (its effects' coefficients free too) within physical bounds, the sign of a force input
//! checked against the signs it gives, and the recalibrated model refined by output error.

use super::criterion::Evaluation;
use super::fit::{Context, Fit};
use super::force_sign::flipped_force;
use super::output_error::{refine_output_error, RefineOn};
use super::parameters::{effect_coefs, linear_free, Covariance, Param};
use super::simulated::Simulated;
use crate::equation::{Coef, States};
use crate::model::Model;
use crate::{signal, Result};

/// The row weights of the equation error: one over each DOF's inertia-force spread.
pub(super) fn row_weights(model: &Model, st: &States) -> Vec<f64> {
    (0..model.n())
        .map(|i| {
            let r = model.mass[i] * signal::rms(&st.qdd[i]);
            if r > 0.0 {
                1.0 / r
            } else {
                1.0
            }
        })
        .collect()
}

/// The linear recalibration of `model` on `ctx`, starting from the model without its
/// effects' coefficients held: the coefficients freed and the fit. A coefficient held at
/// its physical bound gets a note.
///
/// # Errors
/// The force inputs take energy out of the specimen (`work`, see
/// [`super::force_sign::force_work_share`]) and the record puts every mass at or below 0
/// and a damping below 0: the force's sign is probably flipped.
pub(super) fn recalibrate(
    model: &Model,
    ctx: &Context<'_>,
    work: Option<&(f64, Vec<String>)>,
    notes: &mut Vec<String>,
    log: &dyn Fn(f64, &str),
) -> Result<(Vec<Coef>, Fit)> {
    let free0 = {
        let mut f = linear_free(model);
        f.extend(effect_coefs(model));
        f
    };
    let recal_fit = ctx.fit(model.clone(), &free0);
    // Every mass the record fixes at or below 0 and a damping below 0, with net work out of
    // the specimen: the equations of motion hold with every sign reversed.
    if let Some((share, negative)) = work.filter(|w| w.0 < 0.0) {
        let mut masses = free0
            .iter()
            .filter(|c| matches!(c, Coef::Mass(_)))
            .peekable();
        let held = |c: &Coef| recal_fit.bounded.contains(c);
        if masses.peek().is_some()
            && masses.all(held)
            && recal_fit.bounded.iter().any(|c| matches!(c, Coef::C(_)))
        {
            return Err(flipped_force(
                negative,
                &format!(
                    "takes energy out of the specimen (net work {share:.2} of the power it \
                     exchanges) and the record puts every mass at or below 0 and a damping \
                     below 0"
                ),
            ));
        }
    }
    for c in &recal_fit.bounded {
        let (range, held) = match c {
            Coef::Mass(_) => ("at or below 0", "its value in the model file"),
            _ => ("below 0", "the bound"),
        };
        notes.push(format!(
            "{}: the record puts it {range} (outside its physical range); held at {held}, {:.6e} (bound active)",
            c.label(model),
            c.get(&recal_fit.model)
        ));
    }
    log(
        0.1,
        &format!("recalibrated, validation SSE {:.4e}", recal_fit.sse_val),
    );
    Ok((free0, recal_fit))
}

/// The model the recalibration reaches, refined by output error when `oe` (and kept when
/// it simulates the validation blocks at least as well), with its parameters' covariance
/// and its simulated validation residual; without output error, the equation-error fit
/// `recal_fit`'s model and covariance and no residual.
pub(super) fn refine_recalibrated(
    recal_fit: &Fit,
    oe: bool,
    sim: &Simulated<'_>,
    refine_on: &RefineOn<'_>,
    threads: usize,
    log: &dyn Fn(f64, &str),
) -> (Model, Covariance, Option<Evaluation>) {
    let mut recal_model = recal_fit.model.clone();
    let mut cov_params: Vec<Param> = recal_fit.free.iter().map(|c| Param::Lin(*c)).collect();
    let mut cov = recal_fit.covariance.clone();
    let mut cur_eval = None;
    if oe {
        log(0.12, "output-error refinement of the recalibrated model");
        let start_eval = sim.evaluate(&recal_model);
        if let Ok((m, pc)) =
            refine_output_error(&recal_model, &recal_fit.free, refine_on, threads, None)
        {
            let ev = sim.evaluate(&m);
            let better = match (&ev, &start_eval) {
                (Some(a), Some(b)) => a.total() <= b.total(),
                (Some(_), None) => true,
                _ => false,
            };
            if better {
                recal_model = m;
                (cov_params, cov) = pc;
            }
        }
        cur_eval = sim.evaluate(&recal_model);
    }
    (recal_model, (cov_params, cov), cur_eval)
}
