//! The evidence the report gives for what was named: operating regions where the
//! recalibrated model's force residual is largest, and, with the simulation basis,
//! frequency bands and time windows where the updated model closes the gap
//! ([`crate::evidence`]).

use super::fit::{Context, Fit};
use super::gaps::Simulations;
use super::report::NamedDetail;
use crate::equation;
use crate::evidence::{self, BandEvidence, RegionEvidence, WindowEvidence};
use crate::model::Model;
use crate::record::Record;

/// Per named element effect (once per element): the operating-region evidence of the
/// recalibrated model's equation-error residual on `ctx`, on the DOF the element moves
/// most per unit mass.
pub(super) fn regions(
    model: &Model,
    recal_fit: &Fit,
    ctx: &Context<'_>,
    named: &[NamedDetail],
) -> Vec<RegionEvidence> {
    let mut regions = Vec::new();
    let sys = equation::build(&recal_fit.model, ctx.st, &[], &ctx.weights);
    let (u, ud) = equation::model_inputs(&recal_fit.model, ctx.st);
    let sig = equation::element_signals(&recal_fit.model, ctx.st, &u, &ud);
    for n in named {
        if recal_fit.model.is_input(&n.named.element)
            || regions
                .iter()
                .any(|r: &RegionEvidence| r.element == n.named.element)
        {
            continue;
        }
        let Some(e) = recal_fit
            .model
            .elements
            .iter()
            .position(|x| x.name == n.named.element)
        else {
            continue;
        };
        let el = &recal_fit.model.elements[e];
        let dof = (0..model.n())
            .max_by(|&a, &b| {
                (el.a[a].abs() / model.mass[a]).total_cmp(&(el.a[b].abs() / model.mass[b]))
            })
            .unwrap_or(0);
        let rows: Vec<usize> = (0..sys.rhs.len()).filter(|&r| sys.dof[r] == dof).collect();
        let x: Vec<f64> = rows.iter().map(|&r| sig[e].x[sys.sample[r]]).collect();
        let v: Vec<f64> = rows.iter().map(|&r| sig[e].v[sys.sample[r]]).collect();
        let res: Vec<f64> = rows
            .iter()
            .map(|&r| sys.rhs[r] / ctx.weights[dof] * el.a[dof].signum())
            .collect();
        regions.push(evidence::region(&el.name, &x, &v, &res));
    }
    regions
}

/// The frequency-band evidence of every input-output pair and the time-window evidence,
/// from the simulated outputs before and after (`sims`: the recalibrated and the updated
/// model's); none without them. `inputs`: the inputs as the simulations see them.
pub(super) fn bands_and_windows(
    model: &Model,
    record: &Record,
    measured: &[&[f64]],
    inputs: &[Vec<f64>],
    sims: Option<&Simulations>,
    fc_hz: f64,
) -> (Vec<BandEvidence>, Vec<WindowEvidence>) {
    let mut bands = Vec::new();
    let mut windows = Vec::new();
    if let Some((before, after)) = sims {
        windows = evidence::windows(
            measured,
            before,
            after,
            0..record.len(),
            record.t0,
            record.dt,
        );
        for (inp, u) in model.inputs.iter().zip(inputs) {
            for (o, output) in model.outputs.iter().enumerate() {
                bands.extend(evidence::frf_bands(
                    (&inp.column, &output.column),
                    u,
                    measured[o],
                    &before[o],
                    &after[o],
                    record.dt,
                    0.0,
                    fc_hz.min(0.45 / record.dt),
                ));
            }
        }
    }
    (bands, windows)
}
