//! The candidate effects: each effect on each element or input it applies to, and the
//! checks a fitted or refined candidate must pass to be named (parameters in their physical
//! range, a delay the record resolves, stops at both ends that are end stops and not free
//! play).

use crate::effects::EffectKind;
use crate::equation::{self, States};
use crate::model::{InputKind, Model};

/// A candidate: effect `kind` on element or input `target`.
#[derive(Clone, Copy, Debug)]
pub(super) struct Candidate {
    pub(super) kind: EffectKind,
    /// Index of the element, or of the input with `input`.
    pub(super) target: usize,
    pub(super) input: bool,
}

/// A rough relative cost of fitting a candidate of `kind` (its grid size).
pub(super) fn cand_cost(kind: EffectKind) -> usize {
    match kind {
        EffectKind::Hysteresis => 40,
        EffectKind::BumpStop => 12,
        EffectKind::InputDelay => 8,
        EffectKind::Backlash => 6,
        EffectKind::LiftOff | EffectKind::RateLimit | EffectKind::Saturation => 5,
        _ => 1,
    }
}

/// Every candidate of the effects `kinds` on `model` (see the module documentation of
/// [`crate::diagnose`](mod@crate::diagnose)).
pub(super) fn candidates(model: &Model, kinds: &[EffectKind]) -> Vec<Candidate> {
    let mut out = Vec::new();
    for &kind in kinds {
        if kind.fits_input() {
            for (j, i) in model.inputs.iter().enumerate() {
                let play_on_force =
                    kind == EffectKind::Backlash && i.kind != InputKind::Displacement;
                if !i.law.kinds().contains(&kind) && !play_on_force {
                    out.push(Candidate {
                        kind,
                        target: j,
                        input: true,
                    });
                }
            }
        }
        if !kind.fits_element() {
            continue;
        }
        for (e, el) in model.elements.iter().enumerate() {
            let l = &el.law;
            if l.kinds().contains(&kind) {
                continue;
            }
            let ok = match kind {
                EffectKind::CubicStiffness | EffectKind::Backlash | EffectKind::LiftOff => {
                    l.k > 0.0
                }
                // On a damper without a spring too: dry friction through a compliant link
                // (pre-sliding), the hysteretic spring then the element's whole stiffness.
                EffectKind::Hysteresis => l.k > 0.0 || l.c > 0.0,
                EffectKind::AsymmetricDamping => l.c > 0.0,
                _ => true,
            };
            if ok {
                out.push(Candidate {
                    kind,
                    target: e,
                    input: false,
                });
            }
        }
    }
    out
}

/// Why the refined effect is below what the record resolves, if it is: an input delay
/// shorter than the sample period. The record cannot tell it from the skew of sampling
/// and filtering between its columns, and a transport delay a rig has (servo loops,
/// communication) is several sample periods; a fraction of one is what a delay takes when it
/// stands in for a small difference of form elsewhere (a phase lag of some other effect).
pub(super) fn unresolved(m: &Model, cand: Candidate, dt: f64) -> Option<String> {
    if !(cand.input && cand.kind == EffectKind::InputDelay) {
        return None;
    }
    let tau = m.inputs.get(cand.target)?.law.delay_s?;
    (tau < dt).then(|| {
        format!(
            "refined to {:.3} ms, shorter than the sample period ({:.3} ms): not resolved by the record",
            tau * 1e3,
            dt * 1e3
        )
    })
}

/// Whether the fitted effect's parameters are in their physical range (a bump stop that
/// pulls, negative friction or quadratic damping, a damper that drives, a hysteretic
/// fraction outside [0, 1] are not that effect, whatever they fit).
pub(super) fn physical(m: &Model, cand: Candidate) -> bool {
    if cand.input {
        return true;
    }
    let l = &m.elements[cand.target].law;
    match cand.kind {
        EffectKind::CoulombFriction => l.coulomb.is_some_and(|c| c.0 > 0.0),
        EffectKind::QuadraticDamping => l.c2.is_some_and(|c| c > 0.0),
        EffectKind::BumpStop => {
            l.bump.is_none_or(|b| b.1 > 0.0) && l.rebound.is_none_or(|b| b.1 > 0.0)
        }
        EffectKind::AsymmetricDamping => {
            let ca = l.c_abs.unwrap_or(0.0);
            l.c + ca >= 0.0 && l.c - ca >= 0.0
        }
        EffectKind::Hysteresis => {
            let total = l.k + l.k_h;
            total > 0.0 && l.k >= 0.0 && l.k_h > 0.0
        }
        EffectKind::Backlash | EffectKind::LiftOff => l.k > 0.0,
        _ => true,
    }
}

/// Whether `m`'s stops at both ends of element `e`'s travel are free play rather than end
/// stops: the spring between them carries nothing (`k <= 0`), or they are engaged for at
/// least [`STOPS_AS_SPRING`] of the record (deflection from the states estimated from the
/// record, less the filter transients): an element that rests on its stops most of the
/// time has them as its spring and the travel between them as free play, which the
/// `backlash` candidate names with fewer parameters. End stops limit the travel: a sweep
/// or a road reaches them in its peaks.
pub(super) fn stops_are_free_play(m: &Model, st: &States, e: usize) -> bool {
    let l = &m.elements[e].law;
    let (Some((gap, kb)), Some((reb, kr))) = (l.bump, l.rebound) else {
        return false;
    };
    if kb <= 0.0 || kr <= 0.0 {
        // One side holds nothing: an end stop on the other.
        return false;
    }
    if l.k <= 0.0 {
        return true;
    }
    let (u, ud) = equation::model_inputs(m, st);
    let sig = equation::element_signals(m, st, &u, &ud);
    let Some(x) = sig.get(e).map(|s| st.interior(&s.x)) else {
        return false;
    };
    let engaged = x.iter().filter(|&&v| v > gap || v < -reb).count();
    engaged as f64 >= STOPS_AS_SPRING * x.len().max(1) as f64
}

/// The share of the record beyond which stops at both ends are the element's spring (see
/// `stops_are_free_play`): half, "most of the time". The held-out generator puts end
/// stops at the 90-98 % quantile of each side's deflection (engaged 2-20 % of the record);
/// free play fitted as two stops has them engaged 50-80 % of it.
pub const STOPS_AS_SPRING: f64 = 0.5;

/// The name of the element or input a candidate is on.
pub(super) fn target_name(model: &Model, cand: Candidate) -> String {
    if cand.input {
        model.inputs[cand.target].name.clone()
    } else {
        model.elements[cand.target].name.clone()
    }
}

#[cfg(test)]
mod resolution_tests {
    use super::*;

    #[test]
    fn a_delay_shorter_than_the_sample_period_is_not_resolved() {
        let mut m =
            Model::from_toml(include_str!("../../examples/oscillator.toml")).expect("model");
        let delay = Candidate {
            kind: EffectKind::InputDelay,
            target: 0,
            input: true,
        };
        let dt = 1e-3;
        m.inputs[0].law.delay_s = Some(0.4e-3);
        let why = unresolved(&m, delay, dt).expect("0.4 ms at 1 kHz is not resolved");
        assert!(
            why.contains("0.400 ms") && why.contains("1.000 ms"),
            "{why}"
        );
        m.inputs[0].law.delay_s = Some(2e-3);
        assert_eq!(unresolved(&m, delay, dt), None);
        // Only a delay is held to the sample period.
        m.inputs[0].law.delay_s = None;
        m.inputs[0].law.rate_limit = Some(1.0);
        let rate = Candidate {
            kind: EffectKind::RateLimit,
            ..delay
        };
        assert_eq!(unresolved(&m, rate, dt), None);
    }
}
