//! The parameters the workflow moves: the linear coefficients recalibrated, the effects'
//! coefficients, and ([`Param`]) every parameter the output-error refinement can move, read
//! from and set on a model within its physical range; an effect's reported parameters, and a
//! model without one effect.

use crate::effects::EffectKind;
use crate::equation::{self, Coef};
use crate::model::{InputKind, Model};
use nalgebra::DMatrix;
use std::collections::BTreeMap;

/// Parameters with their covariance.
pub(super) type Covariance = (Vec<Param>, DMatrix<f64>);

/// A parameter the output-error refinement can move.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Param {
    Lin(Coef),
    BumpGap(usize),
    RebGap(usize),
    Backlash(usize),
    Preload(usize),
    Beta(usize),
    Gamma(usize),
    Delay(usize),
    Rate(usize),
    SatLo(usize),
    SatHi(usize),
    Play(usize),
}

impl Param {
    pub(super) fn get(self, m: &Model) -> f64 {
        let l = |e: usize| &m.elements[e].law;
        match self {
            Param::Lin(c) => c.get(m),
            Param::BumpGap(e) => l(e).bump.map_or(0.0, |b| b.0),
            Param::RebGap(e) => l(e).rebound.map_or(0.0, |b| b.0),
            Param::Backlash(e) => l(e).backlash.unwrap_or(0.0),
            Param::Preload(e) => l(e).lift_off.unwrap_or(0.0),
            Param::Beta(e) => l(e).hysteresis.map_or(0.0, |h| h.beta),
            Param::Gamma(e) => l(e).hysteresis.map_or(0.0, |h| h.gamma),
            Param::Delay(j) => m.inputs[j].law.delay_s.unwrap_or(0.0),
            Param::Rate(j) => m.inputs[j].law.rate_limit.unwrap_or(0.0),
            Param::SatLo(j) => m.inputs[j].law.saturation.map_or(0.0, |s| s.0),
            Param::SatHi(j) => m.inputs[j].law.saturation.map_or(0.0, |s| s.1),
            Param::Play(j) => m.inputs[j].law.backlash.unwrap_or(0.0),
        }
    }

    /// Sets the value; false if it is outside the parameter's range.
    pub(super) fn set(self, m: &mut Model, v: f64) -> bool {
        if !v.is_finite() {
            return false;
        }
        let nonneg = v >= 0.0;
        match self {
            Param::Lin(c) => {
                let in_range = match c {
                    Coef::Mass(_) => v > 0.0,
                    Coef::K(_) | Coef::C(_) | Coef::KH(_) => v >= 0.0,
                    _ => true,
                };
                if !in_range {
                    return false;
                }
                c.set(m, v);
                true
            }
            Param::BumpGap(e) => {
                if let Some(b) = m.elements[e].law.bump.as_mut() {
                    b.0 = v;
                }
                nonneg
            }
            Param::RebGap(e) => {
                if let Some(b) = m.elements[e].law.rebound.as_mut() {
                    b.0 = v;
                }
                nonneg
            }
            Param::Backlash(e) => {
                m.elements[e].law.backlash = Some(v);
                nonneg
            }
            Param::Preload(e) => {
                m.elements[e].law.lift_off = Some(v);
                nonneg
            }
            Param::Beta(e) => {
                if let Some(h) = m.elements[e].law.hysteresis.as_mut() {
                    h.beta = v;
                }
                true
            }
            Param::Gamma(e) => {
                if let Some(h) = m.elements[e].law.hysteresis.as_mut() {
                    h.gamma = v;
                }
                true
            }
            Param::Delay(j) => {
                m.inputs[j].law.delay_s = Some(v);
                nonneg
            }
            Param::Rate(j) => {
                m.inputs[j].law.rate_limit = Some(v);
                v > 0.0
            }
            Param::SatLo(j) => match m.inputs[j].law.saturation.as_mut() {
                Some(s) if v < s.1 => {
                    s.0 = v;
                    true
                }
                _ => false,
            },
            Param::SatHi(j) => match m.inputs[j].law.saturation.as_mut() {
                Some(s) if v > s.0 => {
                    s.1 = v;
                    true
                }
                _ => false,
            },
            Param::Play(j) => {
                m.inputs[j].law.backlash = Some(v);
                nonneg
            }
        }
    }
}

/// The parameter that measures how strong effect `kind` on `target` is in `m`, where the
/// effect vanishes at a finite value of it (zero): cubic stiffness `k3`, friction force,
/// quadratic damping `c2`, asymmetric half difference, stop stiffness, backlash half gap,
/// hysteretic stiffness `k_h`, delay. Lift-off, rate limit and saturation vanish only as
/// their parameter goes to infinity: `None`.
pub(super) fn strength(m: &Model, kind: EffectKind, target: &str) -> Option<Param> {
    if let Some(j) = m.inputs.iter().position(|i| i.name == target) {
        return match kind {
            EffectKind::InputDelay => Some(Param::Delay(j)),
            EffectKind::Backlash => Some(Param::Play(j)),
            _ => None,
        };
    }
    let e = m.elements.iter().position(|x| x.name == target)?;
    let l = &m.elements[e].law;
    let coef = match kind {
        EffectKind::CubicStiffness => Coef::K3(e),
        EffectKind::CoulombFriction => Coef::Fc(e),
        EffectKind::QuadraticDamping => Coef::C2(e),
        EffectKind::AsymmetricDamping => Coef::CAbs(e),
        EffectKind::Hysteresis => Coef::KH(e),
        EffectKind::BumpStop if l.bump.is_some() => Coef::BumpK(e),
        EffectKind::BumpStop => Coef::RebK(e),
        EffectKind::Backlash => return Some(Param::Backlash(e)),
        _ => return None,
    };
    Some(Param::Lin(coef))
}

/// The parameters of `model`'s effects that are not linear coefficients.
pub(super) fn nonlinear_params(model: &Model) -> Vec<Param> {
    let mut out = Vec::new();
    for (e, el) in model.elements.iter().enumerate() {
        let l = &el.law;
        if l.bump.is_some() {
            out.push(Param::BumpGap(e));
        }
        if l.rebound.is_some() {
            out.push(Param::RebGap(e));
        }
        if l.backlash.is_some() {
            out.push(Param::Backlash(e));
        }
        if l.lift_off.is_some() {
            out.push(Param::Preload(e));
        }
        if l.hysteresis.is_some() {
            out.push(Param::Beta(e));
            out.push(Param::Gamma(e));
        }
    }
    for (j, i) in model.inputs.iter().enumerate() {
        if i.law.delay_s.is_some() {
            out.push(Param::Delay(j));
        }
        if i.law.rate_limit.is_some() {
            out.push(Param::Rate(j));
        }
        if i.law.saturation.is_some() {
            out.push(Param::SatLo(j));
            out.push(Param::SatHi(j));
        }
        if i.law.backlash.is_some() {
            out.push(Param::Play(j));
        }
    }
    out
}

/// The linear coefficients recalibrated in `model` (see the module documentation).
pub(super) fn linear_free(model: &Model) -> Vec<Coef> {
    // A measured force, in or out, fixes the scale of the equations of motion.
    let has_force = model.inputs.iter().any(|i| i.kind == InputKind::Force)
        || model
            .outputs
            .iter()
            .any(|o| o.kind == crate::model::OutputKind::Force);
    let mut free = Vec::new();
    for i in 0..model.n() {
        if has_force {
            free.push(Coef::Mass(i));
        }
        free.push(Coef::Bias(i));
    }
    for (e, el) in model.elements.iter().enumerate() {
        if el.law.k > 0.0 {
            free.push(Coef::K(e));
        }
        if el.law.c > 0.0 {
            free.push(Coef::C(e));
        }
    }
    free
}

/// The coefficients of the effects that are on in `model`.
pub(super) fn effect_coefs(model: &Model) -> Vec<Coef> {
    model
        .elements
        .iter()
        .enumerate()
        .flat_map(|(e, el)| equation::effect_coefs_of(e, &el.law))
        .collect()
}

/// `m` without the effect `what` on `target` (an element or an input), and `free` without
/// that effect's coefficients.
pub(super) fn without_effect(
    m: &Model,
    free: &[Coef],
    what: EffectKind,
    target: &str,
) -> (Model, Vec<Coef>) {
    let mut m_wo = m.clone();
    if m.is_input(target) {
        if let Some(inp) = m_wo.inputs.iter_mut().find(|x| x.name == target) {
            inp.law.remove(what);
        }
    } else if let Some(el) = m_wo.elements.iter_mut().find(|x| x.name == target) {
        el.law.remove(what);
    }
    let coefs_with = effect_coefs(m);
    let coefs_wo = effect_coefs(&m_wo);
    let free_wo = free
        .iter()
        .copied()
        .filter(|c| !coefs_with.contains(c) || coefs_wo.contains(c))
        .collect();
    (m_wo, free_wo)
}

/// The parameters (SI names) of effect `kind` on `target` (an element or an input) in `m`;
/// empty when it has none.
pub(super) fn effect_parameters(
    m: &Model,
    kind: EffectKind,
    target: &str,
) -> BTreeMap<String, f64> {
    if m.is_input(target) {
        m.inputs
            .iter()
            .find(|i| i.name == target)
            .and_then(|i| i.law.parameters(kind))
            .unwrap_or_default()
    } else {
        m.elements
            .iter()
            .find(|e| e.name == target)
            .and_then(|e| e.law.parameters(kind))
            .unwrap_or_default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn removing_an_effect_frees_only_its_own_coefficients() {
        let mut m =
            Model::from_toml(include_str!("../../examples/oscillator.toml")).expect("model");
        m.elements[0].law.k3 = Some(1e6);
        m.elements[0].law.coulomb = Some((2.0, 1e-3));
        m.inputs[0].law.delay_s = Some(2e-3);
        let free = [
            Coef::Mass(0),
            Coef::K(0),
            Coef::C(0),
            Coef::K3(0),
            Coef::Fc(0),
        ];
        let (wo, f) = without_effect(&m, &free, EffectKind::CubicStiffness, "spring");
        assert_eq!(wo.elements[0].law.k3, None);
        assert_eq!(wo.elements[0].law.coulomb, m.elements[0].law.coulomb);
        assert_eq!(f, [Coef::Mass(0), Coef::K(0), Coef::C(0), Coef::Fc(0)]);
        // An input effect: the element and every coefficient stay.
        let (wo, f) = without_effect(&m, &free, EffectKind::InputDelay, "force");
        assert_eq!(wo.inputs[0].law.delay_s, None);
        assert_eq!(wo.elements[0].law.k3, Some(1e6));
        assert_eq!(f, free);
    }
}
