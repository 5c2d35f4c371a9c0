//! A force input read with the opposite sign convention to the model's: the net work the
//! force inputs do on a specimen that only they drive, and the error that says so.

use crate::equation::States;
use crate::model::{InputKind, Model};
use crate::{signal, Error};

/// The least net work the force inputs may do on a specimen driven by force alone, as a
/// share of the power they exchange with it (`force_work_share`): −0.5. A passive
/// specimen only takes energy in, less what it held at the start; a force that takes out
/// half of what it exchanges has the opposite sign to the model's (a load cell read in
/// tension against a DOF positive in compression). A damper gives about +1 and a lightly
/// damped oscillator a small positive share, so the check does not depend on the record
/// beyond that physical bound. A wrong sign on a lightly damped record escapes it and is
/// caught by the recalibration instead: net work below 0 with every mass and a damping that
/// the record would make negative.
pub const NET_WORK_FLOOR: f64 = -0.5;

/// The net work of the force inputs on a specimen that no displacement input drives, as a
/// share of the power they exchange with it (`∫ F·v dt / ∫ |F·v| dt`, each force less its
/// mean, `v` the velocity of the point it acts at along it), with the inputs whose own
/// share is negative (name, column, share); `None` when a displacement input drives the
/// specimen or no force input exchanges power.
pub(super) fn force_work_share(model: &Model, st: &States) -> Option<(f64, Vec<String>)> {
    if model
        .inputs
        .iter()
        .any(|i| i.kind == InputKind::Displacement)
    {
        return None;
    }
    let mut total = (0.0, 0.0);
    let mut negative = Vec::new();
    for (inp, raw) in model.inputs.iter().zip(&st.inputs_raw) {
        if inp.kind != InputKind::Force {
            continue;
        }
        let v: Vec<f64> = (0..raw.len())
            .map(|t| {
                inp.t
                    .iter()
                    .zip(&st.qd)
                    .map(|(g, qd)| g * qd.get(t).copied().unwrap_or(0.0))
                    .sum()
            })
            .collect();
        let (f, v) = (st.interior(raw), st.interior(&v));
        let mean = signal::mean(&f);
        let (net, exchanged) = f.iter().zip(&v).fold((0.0, 0.0), |(n, e), (f, v)| {
            let p = (f - mean) * v;
            (n + p, e + p.abs())
        });
        total = (total.0 + net, total.1 + exchanged);
        if exchanged > 0.0 && net < 0.0 {
            negative.push(format!(
                "{:?} (column {:?}: {:.2})",
                inp.name,
                inp.column,
                net / exchanged
            ));
        }
    }
    (total.1 > 0.0).then(|| (total.0 / total.1, negative))
}

/// The error for force inputs whose sign is probably opposite to the model's: `why` is the
/// evidence.
pub(super) fn flipped_force(inputs: &[String], why: &str) -> Error {
    Error::Record(format!(
        "the force input {} {why}: its sign is probably opposite to the model's (positive \
         along the DOF or point it acts at); give the input `gain = -1` or flip the column",
        inputs.join(", ")
    ))
}
