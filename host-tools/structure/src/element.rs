//! An element's law as written in files: linear stiffness and damping, the static preload
//! and the effects by name.
//!
//! ```toml
//! stiffness_n_per_m = 1.2e5
//! damping_n_s_per_m = 2500.0
//! preload_n = 1471.5                 # static force at equilibrium (N, compression), default 0
//! effects = { bump_stop = { gap_m = 0.02, stiffness_n_per_m = 5e5 }, lift_off = {} }
//! ```
//!
//! Effect names and parameters are those of [`EffectKind`]; `lift_off` takes none, the
//! static load it lifts off from is the element's `preload_n` (stated once). Unknown keys,
//! unknown effects and out-of-range values are errors naming them.

use crate::effects::{CompiledLaw, EffectKind, ElementLaw};
use crate::{Error, Result};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// An effect's parameters by SI name (e.g. `gap_m`, `stiffness_n_per_m`).
pub type Parameters = BTreeMap<String, f64>;

/// A spring-damper element's law as written in files (see the module documentation).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Element {
    /// Linear stiffness `k` (N/m), `>= 0`; the scale of a hysteretic spring.
    pub stiffness_n_per_m: f64,
    /// Linear damping `c` (N·s/m), `>= 0`; replaced by an asymmetric damper's two.
    pub damping_n_s_per_m: f64,
    /// Static force (N, positive in compression) the element carries at equilibrium; `>= 0`
    /// with `lift_off`. Default 0.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub preload_n: f64,
    /// Effects by name, with their parameters. Default none.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub effects: BTreeMap<EffectKind, Parameters>,
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

impl Element {
    /// A linear element `F = k x + c v` with stiffness `k` (N/m) and damping `c` (N·s/m),
    /// no preload and no effects.
    pub fn linear(stiffness_n_per_m: f64, damping_n_s_per_m: f64) -> Self {
        Self {
            stiffness_n_per_m,
            damping_n_s_per_m,
            preload_n: 0.0,
            effects: BTreeMap::new(),
        }
    }

    /// The same element with static preload `preload_n` (N, positive in compression).
    pub fn with_preload(mut self, preload_n: f64) -> Self {
        self.preload_n = preload_n;
        self
    }

    /// The same element with effect `kind` on, with `parameters` (SI names); checked by
    /// [`Element::law`].
    pub fn with(mut self, kind: EffectKind, parameters: &[(&str, f64)]) -> Self {
        self.effects.insert(
            kind,
            parameters
                .iter()
                .map(|(name, value)| (name.to_string(), *value))
                .collect(),
        );
        self
    }

    /// Whether no effect is on (the element is `preload + k x + c v`).
    pub fn is_linear(&self) -> bool {
        self.effects.is_empty()
    }

    /// Whether the element is affine while its force is not negative: no effect but
    /// lift-off.
    pub fn is_piecewise_linear(&self) -> bool {
        self.effects.keys().all(|k| *k == EffectKind::LiftOff)
    }

    /// Whether `lift_off` is on.
    pub fn lifts_off(&self) -> bool {
        self.effects.contains_key(&EffectKind::LiftOff)
    }

    /// The effects that are on, in [`EffectKind`]'s order.
    pub fn kinds(&self) -> Vec<EffectKind> {
        self.effects.keys().copied().collect()
    }

    /// The law (force relative to the static equilibrium, see [`ElementLaw`]), every field
    /// and parameter checked.
    ///
    /// # Errors
    /// A negative or non-finite stiffness or damping, a non-finite preload, a negative one
    /// with lift-off, an input effect on an element, unknown, missing or out-of-range effect
    /// parameters: the message names the field.
    pub fn law(&self) -> Result<ElementLaw> {
        let non_negative = |field: &str, v: f64| {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err(Error::Model(format!("{field} must be >= 0, got {v}")))
            }
        };
        non_negative("stiffness_n_per_m", self.stiffness_n_per_m)?;
        non_negative("damping_n_s_per_m", self.damping_n_s_per_m)?;
        if !self.preload_n.is_finite() {
            return Err(Error::Model(format!(
                "preload_n must be finite, got {}",
                self.preload_n
            )));
        }
        let mut law = ElementLaw::linear(self.stiffness_n_per_m, self.damping_n_s_per_m);
        for (&kind, parameters) in &self.effects {
            if kind == EffectKind::LiftOff {
                if let Some(key) = parameters.keys().next() {
                    return Err(Error::Model(format!(
                        "lift_off takes no parameters (got {key:?}): the static load it lifts \
                         off from is the element's preload_n"
                    )));
                }
                if self.preload_n < 0.0 {
                    return Err(Error::Model(format!(
                        "preload_n must be >= 0 with lift_off (the element cannot pull), got {}",
                        self.preload_n
                    )));
                }
                law.lift_off = Some(self.preload_n);
                continue;
            }
            law.apply(kind, parameters)?;
        }
        Ok(law)
    }

    /// Checks every field and parameter (as [`Element::law`]).
    ///
    /// # Errors
    /// As [`Element::law`].
    pub fn validate(&self) -> Result<()> {
        self.law().map(|_| ())
    }

    /// The law unpacked for an inner loop; its force is relative to the equilibrium (add
    /// [`Element::preload_n`] for the element's total force).
    ///
    /// # Errors
    /// As [`Element::law`].
    pub fn compile(&self) -> Result<CompiledLaw> {
        self.law().map(|law| CompiledLaw::new(&law))
    }

    /// Total force (N, pushing the ends apart, preload included) at compression `x` (m),
    /// rate `v` (m/s) and hysteretic state `z` (m). Unpacks the law each call: a loop over
    /// many samples uses [`Element::compile`].
    ///
    /// # Errors
    /// As [`Element::law`].
    pub fn force(&self, x: f64, v: f64, z: f64) -> Result<f64> {
        self.compile()
            .map(|law| self.preload_n + law.force(x, v, z))
    }

    /// The element from a law and its static preload (the inverse of [`Element::law`]):
    /// what diagnosis writes back.
    pub fn from_law(law: &ElementLaw, preload_n: f64) -> Self {
        let mut element = Self::linear(law.stiffness_total(), law.c).with_preload(preload_n);
        for kind in law.kinds() {
            if kind == EffectKind::LiftOff {
                element.preload_n = law.lift_off.unwrap_or(preload_n);
                element.effects.insert(kind, Parameters::new());
            } else if let Some(p) = law.parameters(kind) {
                // An asymmetric damper's two dampings replace the linear one (written as
                // their mean, which is what reading them back sets).
                element.effects.insert(kind, p);
            }
        }
        element
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quarter_car_tyre() -> Element {
        Element::linear(2.5e5, 500.0)
            .with_preload(1667.7)
            .with(EffectKind::LiftOff, &[])
            .with(
                EffectKind::BumpStop,
                &[("gap_m", 0.02), ("stiffness_n_per_m", 5e5)],
            )
    }

    #[test]
    fn reads_the_documented_form_and_round_trips() {
        let text = r#"
stiffness_n_per_m = 1.2e5
damping_n_s_per_m = 2500.0
preload_n = 1471.5
effects = { bump_stop = { gap_m = 0.02, stiffness_n_per_m = 5e5 }, lift_off = {} }
"#;
        let e: Element = toml::from_str(text).unwrap();
        assert_eq!(e.kinds(), vec![EffectKind::LiftOff, EffectKind::BumpStop]);
        let written = toml::to_string(&e).unwrap();
        let back: Element = toml::from_str(&written).unwrap();
        assert_eq!(back, e, "{written}");
        let law = e.law().unwrap();
        assert_eq!(law.lift_off, Some(1471.5));
        assert_eq!(Element::from_law(&law, e.preload_n), e);
    }

    #[test]
    fn unknown_keys_effects_and_parameters_are_named() {
        let err = |text: &str| match toml::from_str::<Element>(text) {
            Ok(e) => e.law().unwrap_err().to_string(),
            Err(e) => e.to_string(),
        };
        let base = "stiffness_n_per_m = 1e5\ndamping_n_s_per_m = 10.0\n";
        assert!(err(&format!("{base}stiffnes = 1.0")).contains("stiffnes"));
        assert!(err(&format!(
            "{base}effects = {{ free_play = {{ half_gap_m = 1e-3 }} }}"
        ))
        .contains("free_play"));
        assert!(err(&format!(
            "{base}effects = {{ backlash = {{ half_gap_mm = 1.0 }} }}"
        ))
        .contains("half_gap_mm"));
        assert!(err(&format!(
            "{base}effects = {{ input_delay = {{ delay_s = 1e-3 }} }}"
        ))
        .contains("attaches to an input"));
        assert!(err(&format!(
            "{base}effects = {{ lift_off = {{ preload_n = 100.0 }} }}"
        ))
        .contains("preload_n"));
        assert!(err(&format!(
            "{base}preload_n = -5.0\neffects = {{ lift_off = {{}} }}"
        ))
        .contains("preload_n must be >= 0"));
        let negative = "stiffness_n_per_m = -1e5\ndamping_n_s_per_m = 10.0\n";
        assert!(err(negative).contains("stiffness_n_per_m"));
    }

    #[test]
    fn total_force_is_preload_plus_the_law_and_lifts_off_at_zero() {
        let tyre = quarter_car_tyre();
        // At equilibrium the tyre carries its preload.
        assert_eq!(tyre.force(0.0, 0.0, 0.0).unwrap(), 1667.7);
        // 1 mm of compression: k x more.
        assert!((tyre.force(1e-3, 0.0, 0.0).unwrap() - (1667.7 + 250.0)).abs() < 1e-9);
        // Far in extension the wheel has left the road: no force, never a pull.
        assert_eq!(tyre.force(-0.05, 0.0, 0.0).unwrap(), 0.0);
        // 1 mm past the bump stop: spring, stop and preload.
        let f = tyre.force(0.021, 0.0, 0.0).unwrap();
        assert!(
            (f - (1667.7 + 2.5e5 * 0.021 + 5e5 * 1e-3)).abs() < 1e-6,
            "{f}"
        );
    }

    #[test]
    fn linearisation_is_what_an_analysis_sees() {
        let hyst = Element::linear(1e5, 300.0).with(
            EffectKind::Hysteresis,
            &[
                ("alpha", 0.25),
                ("a", 2.0),
                ("beta_per_m", 500.0),
                ("gamma_per_m", 100.0),
            ],
        );
        let (k, c) = hyst.law().unwrap().linearised();
        assert!((k - 1e5 * (0.25 + 0.75 * 2.0)).abs() < 1e-6, "{k}");
        assert_eq!(c, 300.0);
        let asym = Element::linear(1e5, 300.0).with(
            EffectKind::AsymmetricDamping,
            &[("bump_n_s_per_m", 200.0), ("rebound_n_s_per_m", 600.0)],
        );
        assert_eq!(asym.law().unwrap().linearised(), (1e5, 400.0));
        let loose = Element::linear(1e5, 300.0).with(EffectKind::Backlash, &[("half_gap_m", 1e-4)]);
        assert_eq!(loose.law().unwrap().linearised(), (0.0, 300.0));
        assert_eq!(
            quarter_car_tyre().law().unwrap().linearised(),
            (2.5e5, 500.0)
        );
    }
}
