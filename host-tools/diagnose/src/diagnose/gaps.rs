//! The gap figures: the NRMSE of the simulated outputs on the validation blocks for a
//! model restrained on its own, else of the inverse-dynamics force prediction (the
//! equation-error residual over the measured generalised forces' spread).

use super::fit::Context;
use super::report::{Gap, GapBasis};
use super::simulated::Simulated;
use crate::equation;
use crate::model::Model;
use crate::signal;

/// The models whose gaps are reported.
pub(super) struct Stages<'m> {
    /// The model as given.
    pub(super) given: &'m Model,
    /// The recalibrated linear model.
    pub(super) recalibrated: &'m Model,
    /// The updated model.
    pub(super) updated: &'m Model,
}

/// Per output, the simulated outputs of the recalibrated and of the updated model.
pub(super) type Simulations = (Vec<Vec<f64>>, Vec<Vec<f64>>);

/// The gaps of the three [`Stages`] and how they are measured.
pub(super) struct Gaps {
    pub(super) basis: GapBasis,
    pub(super) before: Gap,
    pub(super) recalibrated: Gap,
    pub(super) after: Gap,
    /// The simulated outputs of the recalibrated and of the updated model (simulation
    /// basis, both simulated).
    pub(super) sims: Option<Simulations>,
}

/// The gaps of `stages` on `ctx`'s validation blocks: simulated (`sim`) when the model was
/// `restrained` and the updated one is too, else by equation error (and a note says so).
pub(super) fn gaps(
    stages: &Stages<'_>,
    restrained: bool,
    ctx: &Context<'_>,
    sim: &Simulated<'_>,
    notes: &mut Vec<String>,
) -> Gaps {
    let (model, recal_model, updated) = (stages.given, stages.recalibrated, stages.updated);
    let basis = if restrained && updated.is_restrained() {
        GapBasis::Simulation
    } else {
        GapBasis::EquationError
    };
    // Normalised by the spread of the measured generalised forces (the inputs' as
    // measured: one denominator for every model, so that an input effect that shrinks the
    // force it passes on does not shrink the yardstick with it).
    let forces = equation::build(&strip(model), ctx.st, &[], &ctx.weights);
    let force_spread = signal::std(&forces.residuals(&[], |t| ctx.split.is_validation(t)));
    let ee_gap = |m: &Model| -> Gap {
        let sys = equation::build(m, ctx.st, &[], &ctx.weights);
        let r = sys.residuals(&[], |t| ctx.split.is_validation(t));
        Gap {
            nrmse: signal::rms(&r) / force_spread.max(1e-300),
        }
    };
    let (before, recalibrated, after, sims) = if basis == GapBasis::Simulation {
        let (b, _) = sim.gap(model);
        let (r, sr) = sim.gap(recal_model);
        let (a, sa) = sim.gap(updated);
        (b, r, a, sr.zip(sa))
    } else {
        notes.push(
            "the model is not restrained on its own (free simulation drifts): gaps are the inverse-dynamics force prediction on the validation blocks"
                .into(),
        );
        (ee_gap(model), ee_gap(recal_model), ee_gap(updated), None)
    };
    Gaps {
        basis,
        before,
        recalibrated,
        after,
        sims,
    }
}

/// `m` with no mass, bias or element force and its inputs as measured (no input effect):
/// its equation-error residual is the measured generalised forces.
fn strip(m: &Model) -> Model {
    let mut s = m.clone();
    for e in &mut s.elements {
        e.law = crate::effects::ElementLaw::linear(0.0, 0.0);
    }
    for i in &mut s.inputs {
        i.law = crate::effects::InputLaw::default();
    }
    s.mass.iter_mut().for_each(|v| *v = 0.0);
    s.bias.iter_mut().for_each(|v| *v = 0.0);
    s
}
