//! Force elements: spring-damper elements between two points with switchable physical
//! effects, all off by default.
//!
//! An [`Element`] sits between two points of a simulated rig (a suspension between body and
//! hub, a tyre between hub and road post, a specimen between actuator and reaction frame).
//! Without effects it is the linear spring-damper `F = preload + k x + c v`. Each entry of
//! [`Effects`] switches on one nonlinearity, with its own documented parameters; they are
//! meant for generating data with a "hidden" effect that a diagnosis workflow must find.
//!
//! # Sign convention
//!
//! - `x` (m): element compression, positive when the two points approach each other.
//! - `v` (m/s): compression rate `dx/dt`, positive while the points approach.
//! - `F` (N): the force the element exerts on both points, pushing them apart; positive in
//!   compression. A linear element gives `F = k x + c v`.
//! - Positions are deviations from the static equilibrium, so an element that carries a
//!   static load there (a tyre carrying the car's weight) has `preload_n` added:
//!   `F = preload + k x + c v`.
//! - `z` (m): the internal hysteretic deflection of the Bouc-Wen model (the only internal
//!   state; start it at `z = 0`, the virgin state).
//!
//! # Order of evaluation
//!
//! [`Element::force`] evaluates, with `x_s` the spring deflection (`x`, or `x` with the free
//! play dead zone removed, see [`FreePlay`]):
//!
//! 1. spring path: `k x_s` (or the Bouc-Wen spring `alpha k x_s + (1 - alpha) k z`),
//!    plus the cubic term `k3 x_s³`;
//! 2. damper path: `c v` (or the asymmetric damper `c_bump v` / `c_rebound v`), plus the
//!    quadratic term `c2 v |v|`;
//! 3. Coulomb friction `F_c tanh(v / v_eps)`;
//! 4. bump stop (and rebound stop) on the raw compression `x`;
//! 5. the static preload;
//! 6. lift-off last: the total is clamped at `F >= 0`.
//!
//! [`Element::force`] is called millions of times per simulated run: it does not allocate,
//! branches only on which effects are on (perfectly predictable), and is `#[inline]`.

use serde::{Deserialize, Serialize};

/// A force element's parameters are out of their physical range.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("invalid force element: {field} {reason}")]
pub struct EffectError {
    /// The offending field, as a dotted path (e.g. `effects.bouc_wen.beta`).
    pub field: &'static str,
    /// What is wrong with it, including the offending value.
    pub reason: String,
}

impl EffectError {
    fn new(field: &'static str, reason: impl Into<String>) -> Self {
        Self {
            field,
            reason: reason.into(),
        }
    }
}

/// A spring-damper element between two points, with switchable effects.
///
/// See the [module documentation](self) for the sign convention and evaluation order.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Element {
    /// Linear stiffness `k` (N/m), `>= 0`. Also the scale of the Bouc-Wen spring.
    pub stiffness_n_per_m: f64,
    /// Linear damping `c` (N·s/m), `>= 0`. Unused while [`Effects::asymmetric_damping`] is on.
    pub damping_n_s_per_m: f64,
    /// Static preload (N) carried at `x = 0`, positive in compression. Must be `>= 0` with
    /// lift-off (an element that can only push cannot hold tension at equilibrium).
    #[serde(default)]
    pub preload_n: f64,
    /// Switchable effects, all off by default.
    #[serde(default)]
    pub effects: Effects,
}

/// The switchable effects of an [`Element`]; every one is off by default (`false` / `None`).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Effects {
    /// Lift-off: the element can only push (tyre leaving the road, wheel lifting off a
    /// post), `F = max(F, 0)`, applied last to the total force. A plain switch since it has
    /// no parameters; `false` = off.
    pub lift_off: bool,
    /// Coulomb (dry) friction `F_c tanh(v / v_eps)`, added to the damper path.
    pub coulomb_friction: Option<CoulombFriction>,
    /// Cubic (progressive) stiffness `k3 x_s³`, added to the spring path.
    pub cubic_stiffness: Option<CubicStiffness>,
    /// Bump stop beyond a compression gap, optionally a rebound stop beyond an extension gap.
    pub bump_stop: Option<BumpStop>,
    /// Free play (backlash) in the spring path: the spring sees a dead-zoned deflection.
    pub free_play: Option<FreePlay>,
    /// Quadratic (orifice-type) damping `c2 v |v|`, added to the damper path.
    pub quadratic_damping: Option<QuadraticDamping>,
    /// Asymmetric damping: replaces the linear damping by `c_bump` for `v > 0` and
    /// `c_rebound` for `v < 0`.
    pub asymmetric_damping: Option<AsymmetricDamping>,
    /// Bouc-Wen hysteresis: replaces the linear spring and adds one internal state `z` (m).
    pub bouc_wen: Option<BoucWen>,
}

/// Coulomb (dry) friction, smoothed: `F = F_c tanh(v / v_eps)`.
///
/// The force opposes the relative motion, so it is positive (pushing apart) while the
/// element is compressed further (`v > 0`). The `tanh` smoothing keeps the right-hand side
/// of the simulation continuous; it reaches 76 % of `F_c` at `|v| = v_eps` and 99.9 % at
/// `|v| = 4 v_eps`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CoulombFriction {
    /// Friction force magnitude `F_c` (N), `>= 0`.
    pub force_n: f64,
    /// Smoothing velocity `v_eps` (m/s), `> 0`; default 1e-4 m/s.
    #[serde(default = "CoulombFriction::default_smoothing_velocity_m_per_s")]
    pub smoothing_velocity_m_per_s: f64,
}

impl CoulombFriction {
    /// Default smoothing velocity `v_eps` (m/s).
    pub const DEFAULT_SMOOTHING_VELOCITY_M_PER_S: f64 = 1e-4;

    fn default_smoothing_velocity_m_per_s() -> f64 {
        Self::DEFAULT_SMOOTHING_VELOCITY_M_PER_S
    }

    /// Friction force (N) at compression rate `v` (m/s).
    #[inline]
    pub fn force(&self, v: f64) -> f64 {
        self.force_n * (v / self.smoothing_velocity_m_per_s).tanh()
    }
}

/// Cubic stiffness: `F += k3 x_s³` on the spring deflection `x_s`.
///
/// `k3 > 0` is a progressive (hardening) spring, whose secant stiffness `k + k3 x²` grows
/// with `|x|`. `k3 < 0` (softening, Duffing) is allowed, but the tangent stiffness
/// `k + 3 k3 x²` turns negative beyond `|x| = sqrt(k / (3 |k3|))`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CubicStiffness {
    /// Cubic stiffness coefficient `k3` (N/m³), finite.
    pub stiffness_n_per_m3: f64,
}

/// Bump stop: an extra spring engaging beyond a compression gap, optionally a rebound stop
/// engaging beyond an extension gap.
///
/// `F += k_b (x - gap)` for `x > gap`; with a rebound stop also `F += k_b (x + rebound_gap)`
/// (negative, pulling the points together) for `x < -rebound_gap`. Zero in between, so the
/// force is continuous at both gaps with a slope jump of `k_b`. The stops act on the raw
/// compression `x` (they are parallel to the spring, not behind its free play).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BumpStop {
    /// Compression at which the bump stop engages (m), `>= 0`.
    pub gap_m: f64,
    /// Stop stiffness `k_b` (N/m), `>= 0`; shared by the rebound stop.
    pub stiffness_n_per_m: f64,
    /// Extension at which the rebound stop engages (m), `>= 0`; `None` = no rebound stop.
    #[serde(default)]
    pub rebound_gap_m: Option<f64>,
}

impl BumpStop {
    /// Stop force (N) at compression `x` (m).
    #[inline]
    pub fn force(&self, x: f64) -> f64 {
        let bump = (x - self.gap_m).max(0.0);
        let rebound = match self.rebound_gap_m {
            Some(gap) => (x + gap).min(0.0),
            None => 0.0,
        };
        self.stiffness_n_per_m * (bump + rebound)
    }
}

/// Free play (backlash) of total width `2 b` in the spring path.
///
/// The spring (linear or Bouc-Wen, and the cubic term) sees the dead-zoned deflection
/// `x_s = x - clamp(x, -b, b)`: no spring force inside `|x| <= b`, slope `k` outside,
/// continuous at `±b`. The damper path is taken to act in parallel with the backlash and
/// keeps seeing the full rate `v` (a shock absorber in parallel with a loose spring seat);
/// bump stops act on the raw `x`. The Bouc-Wen state only evolves while the spring is
/// engaged (`|x| > b`), see [`Element::state_rate`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FreePlay {
    /// Half the gap `b` (m), `>= 0`.
    pub half_gap_m: f64,
}

impl FreePlay {
    /// Spring deflection `x_s` (m) behind the free play at compression `x` (m).
    #[inline]
    pub fn spring_deflection(&self, x: f64) -> f64 {
        let b = self.half_gap_m;
        // `max`/`min` rather than `clamp`, which panics for a (non-validated) negative `b`.
        x - x.max(-b).min(b)
    }

    /// Whether the spring is engaged (outside the gap) at compression `x` (m).
    #[inline]
    pub fn engaged(&self, x: f64) -> bool {
        x.abs() > self.half_gap_m
    }
}

/// Quadratic damping: `F += c2 v |v|` (orifice flow in a hydraulic damper).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct QuadraticDamping {
    /// Quadratic damping coefficient `c2` (N·s²/m²), `>= 0`.
    pub damping_n_s2_per_m2: f64,
}

/// Asymmetric damping: replaces the linear damping `c v` by `c_bump v` for `v > 0`
/// (compression, "bump") and `c_rebound v` for `v < 0` (extension, "rebound").
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AsymmetricDamping {
    /// Damping in compression `c_bump` (N·s/m), `>= 0`.
    pub bump_n_s_per_m: f64,
    /// Damping in extension `c_rebound` (N·s/m), `>= 0`.
    pub rebound_n_s_per_m: f64,
}

impl AsymmetricDamping {
    /// Damper force (N) at compression rate `v` (m/s).
    #[inline]
    pub fn force(&self, v: f64) -> f64 {
        // Branch-free: mean slope times v plus half the difference times |v|.
        let mean = 0.5 * (self.bump_n_s_per_m + self.rebound_n_s_per_m);
        let half_diff = 0.5 * (self.bump_n_s_per_m - self.rebound_n_s_per_m);
        mean * v + half_diff * v.abs()
    }
}

/// Bouc-Wen hysteresis, replacing the linear spring.
///
/// Spring force `F_s = alpha k x_s + (1 - alpha) k z`, with the internal hysteretic
/// deflection `z` (m) obeying
///
/// `z' = A v_s - beta |v_s| |z|^(n-1) z - gamma v_s |z|^n`,
///
/// where `v_s` is the spring deflection rate (`v`, or 0 inside a free play gap).
/// Under monotonic loading `z` saturates at the yield deflection
/// `z_y = (A / (beta + gamma))^(1/n)` ([`BoucWen::yield_deflection_m`]), so the hysteretic
/// part of the force saturates at `(1 - alpha) k z_y`. The initial (small-signal) stiffness
/// is `k (alpha + (1 - alpha) A)`, the post-yield stiffness `alpha k`. Larger `n` makes the
/// elastic-to-plastic transition sharper. `beta > 0` and `-beta < gamma <= beta` keep the
/// loop bounded and dissipative; `gamma = beta` gives unloading at the initial stiffness.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoucWen {
    /// Ratio `alpha` of post-yield to elastic stiffness (-), in `[0, 1]`; 1 = linear spring.
    pub alpha: f64,
    /// `A` (-), `> 0`: initial slope `dz/dx` of the hysteretic deflection.
    pub a: f64,
    /// `beta` (1/m^n), `> 0`.
    pub beta: f64,
    /// `gamma` (1/m^n), in `(-beta, beta]`.
    pub gamma: f64,
    /// Exponent `n` (-), `>= 1`.
    pub n: f64,
}

impl BoucWen {
    /// Yield deflection `z_y = (A / (beta + gamma))^(1/n)` (m): the value `z` saturates at
    /// under monotonic loading.
    pub fn yield_deflection_m(&self) -> f64 {
        (self.a / (self.beta + self.gamma)).powf(1.0 / self.n)
    }

    /// Rate `dz/dt` (m/s) of the hysteretic deflection `z` (m) at spring deflection rate
    /// `v_s` (m/s).
    #[inline]
    pub fn rate(&self, v_s: f64, z: f64) -> f64 {
        let abs_z = z.abs();
        // |z|^(n-1); the common n = 1 avoids the `powf` (and 0^0 = 1 is what n = 1 means).
        let abs_z_n1 = if self.n == 1.0 {
            1.0
        } else {
            abs_z.powf(self.n - 1.0)
        };
        self.a * v_s - self.beta * v_s.abs() * abs_z_n1 * z - self.gamma * v_s * abs_z_n1 * abs_z
    }
}

impl Element {
    /// A linear element `F = k x + c v` with stiffness `k` (N/m) and damping `c` (N·s/m),
    /// no preload and no effects.
    pub fn linear(stiffness_n_per_m: f64, damping_n_s_per_m: f64) -> Self {
        Self {
            stiffness_n_per_m,
            damping_n_s_per_m,
            preload_n: 0.0,
            effects: Effects::default(),
        }
    }

    /// The same element with static preload `preload_n` (N, positive in compression).
    pub fn with_preload(mut self, preload_n: f64) -> Self {
        self.preload_n = preload_n;
        self
    }

    /// The same element with the given effects.
    pub fn with_effects(mut self, effects: Effects) -> Self {
        self.effects = effects;
        self
    }

    /// Checks that every parameter is finite and in its physical range; the error names the
    /// first offending field.
    pub fn validate(&self) -> Result<(), EffectError> {
        let e = &self.effects;
        non_negative("stiffness_n_per_m", self.stiffness_n_per_m)?;
        non_negative("damping_n_s_per_m", self.damping_n_s_per_m)?;
        finite("preload_n", self.preload_n)?;
        if e.lift_off && self.preload_n < 0.0 {
            return Err(EffectError::new(
                "preload_n",
                format!(
                    "must be >= 0 with lift_off (the element cannot pull), got {}",
                    self.preload_n
                ),
            ));
        }
        if let Some(cf) = e.coulomb_friction {
            non_negative("effects.coulomb_friction.force_n", cf.force_n)?;
            positive(
                "effects.coulomb_friction.smoothing_velocity_m_per_s",
                cf.smoothing_velocity_m_per_s,
            )?;
        }
        if let Some(cs) = e.cubic_stiffness {
            finite(
                "effects.cubic_stiffness.stiffness_n_per_m3",
                cs.stiffness_n_per_m3,
            )?;
        }
        if let Some(bs) = e.bump_stop {
            non_negative("effects.bump_stop.gap_m", bs.gap_m)?;
            non_negative("effects.bump_stop.stiffness_n_per_m", bs.stiffness_n_per_m)?;
            if let Some(gap) = bs.rebound_gap_m {
                non_negative("effects.bump_stop.rebound_gap_m", gap)?;
            }
        }
        if let Some(fp) = e.free_play {
            non_negative("effects.free_play.half_gap_m", fp.half_gap_m)?;
        }
        if let Some(qd) = e.quadratic_damping {
            non_negative(
                "effects.quadratic_damping.damping_n_s2_per_m2",
                qd.damping_n_s2_per_m2,
            )?;
        }
        if let Some(ad) = e.asymmetric_damping {
            non_negative(
                "effects.asymmetric_damping.bump_n_s_per_m",
                ad.bump_n_s_per_m,
            )?;
            non_negative(
                "effects.asymmetric_damping.rebound_n_s_per_m",
                ad.rebound_n_s_per_m,
            )?;
        }
        if let Some(bw) = e.bouc_wen {
            finite("effects.bouc_wen.alpha", bw.alpha)?;
            if !(0.0..=1.0).contains(&bw.alpha) {
                return Err(EffectError::new(
                    "effects.bouc_wen.alpha",
                    format!("must be in [0, 1], got {}", bw.alpha),
                ));
            }
            positive("effects.bouc_wen.a", bw.a)?;
            positive("effects.bouc_wen.beta", bw.beta)?;
            finite("effects.bouc_wen.gamma", bw.gamma)?;
            if !(bw.gamma > -bw.beta && bw.gamma <= bw.beta) {
                return Err(EffectError::new(
                    "effects.bouc_wen.gamma",
                    format!(
                        "must be in (-beta, beta] = ({}, {}] for a bounded dissipative loop, got {}",
                        -bw.beta, bw.beta, bw.gamma
                    ),
                ));
            }
            finite("effects.bouc_wen.n", bw.n)?;
            if bw.n < 1.0 {
                return Err(EffectError::new(
                    "effects.bouc_wen.n",
                    format!("must be >= 1, got {}", bw.n),
                ));
            }
        }
        Ok(())
    }

    /// Number of internal states: 1 with Bouc-Wen (the hysteretic deflection `z`), else 0.
    pub fn states(&self) -> usize {
        usize::from(self.effects.bouc_wen.is_some())
    }

    /// Force (N, positive pushing the points apart) at compression `x` (m), compression rate
    /// `v` (m/s) and internal state `z` (m; ignored without Bouc-Wen). See the
    /// [module documentation](self) for the evaluation order.
    #[inline]
    pub fn force(&self, x: f64, v: f64, z: f64) -> f64 {
        let e = &self.effects;
        let k = self.stiffness_n_per_m;
        let x_s = match e.free_play {
            Some(fp) => fp.spring_deflection(x),
            None => x,
        };
        let mut f = match e.bouc_wen {
            Some(bw) => k * (bw.alpha * x_s + (1.0 - bw.alpha) * z),
            None => k * x_s,
        };
        if let Some(cs) = e.cubic_stiffness {
            f += cs.stiffness_n_per_m3 * x_s * x_s * x_s;
        }
        f += match e.asymmetric_damping {
            Some(ad) => ad.force(v),
            None => self.damping_n_s_per_m * v,
        };
        if let Some(qd) = e.quadratic_damping {
            f += qd.damping_n_s2_per_m2 * v * v.abs();
        }
        if let Some(cf) = e.coulomb_friction {
            f += cf.force(v);
        }
        if let Some(bs) = e.bump_stop {
            f += bs.force(x);
        }
        f += self.preload_n;
        // Comparison rather than `max`, so that a NaN force stays visible.
        if e.lift_off && f < 0.0 {
            0.0
        } else {
            f
        }
    }

    /// Rate `dz/dt` (m/s) of the internal state at compression `x` (m), compression rate
    /// `v` (m/s) and state `z` (m); 0 without Bouc-Wen. `x` matters only with free play:
    /// inside the gap the spring is not deflected and `z` stays put.
    #[inline]
    pub fn state_rate(&self, x: f64, v: f64, z: f64) -> f64 {
        match self.effects.bouc_wen {
            Some(bw) => {
                let v_s = match self.effects.free_play {
                    Some(fp) if !fp.engaged(x) => 0.0,
                    _ => v,
                };
                bw.rate(v_s, z)
            }
            None => 0.0,
        }
    }

    /// Small-signal stiffness (N/m) and damping (N·s/m) about `x = 0`, `v = 0`, `z = 0`: what
    /// a linear analysis sees. `(k, c)` for a linear element. Contributions of the effects:
    ///
    /// - lift-off: none (the element is taken to be in contact at equilibrium, which
    ///   [`Element::validate`] ensures via `preload_n >= 0`);
    /// - Coulomb friction: none. The smoothed law has slope `F_c / v_eps` at `v = 0`, but that
    ///   only holds for `|v| << v_eps` and is an artefact of the smoothing; the linearisation
    ///   of the ideal (unsmoothed) friction is returned, i.e. 0;
    /// - cubic stiffness: none (`3 k3 x² = 0` at `x = 0`);
    /// - bump stop: none (the stops are not engaged at `x = 0`; with a zero gap the one-sided
    ///   slope is ignored);
    /// - free play: the spring path (linear or Bouc-Wen) contributes nothing if `b > 0`,
    ///   since `x = 0` lies inside the gap;
    /// - quadratic damping: none (`2 c2 |v| = 0` at `v = 0`);
    /// - asymmetric damping: the mean `(c_bump + c_rebound) / 2`, the equivalent linear
    ///   damping of a symmetric oscillation (equal dissipation per cycle);
    /// - Bouc-Wen: the initial stiffness `k (alpha + (1 - alpha) A)`.
    pub fn linearised(&self) -> (f64, f64) {
        let e = &self.effects;
        let mut k = match e.bouc_wen {
            Some(bw) => self.stiffness_n_per_m * (bw.alpha + (1.0 - bw.alpha) * bw.a),
            None => self.stiffness_n_per_m,
        };
        if matches!(e.free_play, Some(fp) if fp.half_gap_m > 0.0) {
            k = 0.0;
        }
        let c = match e.asymmetric_damping {
            Some(ad) => 0.5 * (ad.bump_n_s_per_m + ad.rebound_n_s_per_m),
            None => self.damping_n_s_per_m,
        };
        (k, c)
    }

    /// Whether no effect is on (the element is `preload + k x + c v`).
    pub fn is_linear(&self) -> bool {
        self.effects == Effects::default()
    }

    /// Which effects are on, as short names (the [`Effects`] field names, in their order),
    /// for reports: e.g. `["lift_off", "bouc_wen"]`.
    pub fn active_effects(&self) -> Vec<&'static str> {
        let e = &self.effects;
        [
            ("lift_off", e.lift_off),
            ("coulomb_friction", e.coulomb_friction.is_some()),
            ("cubic_stiffness", e.cubic_stiffness.is_some()),
            ("bump_stop", e.bump_stop.is_some()),
            ("free_play", e.free_play.is_some()),
            ("quadratic_damping", e.quadratic_damping.is_some()),
            ("asymmetric_damping", e.asymmetric_damping.is_some()),
            ("bouc_wen", e.bouc_wen.is_some()),
        ]
        .into_iter()
        .filter_map(|(name, on)| on.then_some(name))
        .collect()
    }
}

fn finite(field: &'static str, value: f64) -> Result<(), EffectError> {
    if value.is_finite() {
        Ok(())
    } else {
        Err(EffectError::new(
            field,
            format!("must be finite, got {value}"),
        ))
    }
}

fn non_negative(field: &'static str, value: f64) -> Result<(), EffectError> {
    finite(field, value)?;
    if value >= 0.0 {
        Ok(())
    } else {
        Err(EffectError::new(
            field,
            format!("must be >= 0, got {value}"),
        ))
    }
}

fn positive(field: &'static str, value: f64) -> Result<(), EffectError> {
    finite(field, value)?;
    if value > 0.0 {
        Ok(())
    } else {
        Err(EffectError::new(field, format!("must be > 0, got {value}")))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const K: f64 = 2.0e5;
    const C: f64 = 3.0e3;

    fn with(effects: Effects) -> Element {
        Element::linear(K, C).with_effects(effects)
    }

    /// Compression grid (m) and rate grid (m/s) used by the sweeps.
    fn grid(lo: f64, hi: f64, n: usize) -> impl Iterator<Item = f64> {
        (0..=n).map(move |i| lo + (hi - lo) * i as f64 / n as f64)
    }

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol * (1.0 + a.abs().max(b.abs()))
    }

    #[test]
    fn linear_element_is_exact() {
        let el = Element::linear(K, C);
        el.validate().unwrap();
        assert!(el.is_linear());
        assert!(el.active_effects().is_empty());
        assert_eq!(el.states(), 0);
        assert_eq!(el.linearised(), (K, C));
        for x in grid(-0.1, 0.1, 40) {
            for v in grid(-2.0, 2.0, 40) {
                assert_eq!(el.force(x, v, 0.7), K * x + C * v);
                assert_eq!(el.state_rate(x, v, 0.7), 0.0);
            }
        }
    }

    #[test]
    fn preload_is_added() {
        let p = 4_000.0;
        let el = Element::linear(K, C).with_preload(p);
        assert_eq!(el.force(0.0, 0.0, 0.0), p);
        for x in grid(-0.1, 0.1, 20) {
            for v in grid(-1.0, 1.0, 20) {
                assert!(close(el.force(x, v, 0.0), p + K * x + C * v, 1e-14));
            }
        }
        // Preload alone is not an effect, and a linear analysis does not see it.
        assert!(el.active_effects().is_empty());
        assert_eq!(el.linearised(), (K, C));
    }

    #[test]
    fn lift_off_never_pulls() {
        let p = 4_000.0;
        let el = Element::linear(K, 0.0)
            .with_preload(p)
            .with_effects(Effects {
                lift_off: true,
                ..Effects::default()
            });
        el.validate().unwrap();
        assert_eq!(el.active_effects(), ["lift_off"]);
        // Stretching beyond P / k (x < -P / k) at rest leaves exactly zero force.
        let x_lift = -p / K;
        for x in grid(1.001 * x_lift, 50.0 * x_lift, 100) {
            assert_eq!(el.force(x, 0.0, 0.0), 0.0);
        }
        // In contact it is the linear element.
        assert_eq!(el.force(0.5 * x_lift, 0.0, 0.0), p + K * 0.5 * x_lift);
        // With damping, never negative anywhere; exactly where the linear law is negative,
        // the force is exactly zero, and elsewhere unchanged.
        let el = Element::linear(K, C)
            .with_preload(p)
            .with_effects(el.effects);
        let linear = Element::linear(K, C).with_preload(p);
        let mut lifted = 0;
        for x in grid(-0.2, 0.2, 80) {
            for v in grid(-3.0, 3.0, 60) {
                let f = el.force(x, v, 0.0);
                let f_lin = linear.force(x, v, 0.0);
                assert!(f >= 0.0);
                if f_lin < 0.0 {
                    assert_eq!(f, 0.0);
                    lifted += 1;
                } else {
                    assert_eq!(f, f_lin);
                }
            }
        }
        assert!(lifted > 100, "the sweep must reach lift-off ({lifted})");
    }

    #[test]
    fn coulomb_friction_jumps_by_twice_the_friction_force_and_is_odd() {
        let fc = 150.0;
        let v_eps = 1e-4;
        let el = Element::linear(K, 0.0).with_effects(Effects {
            coulomb_friction: Some(CoulombFriction {
                force_n: fc,
                smoothing_velocity_m_per_s: v_eps,
            }),
            ..Effects::default()
        });
        el.validate().unwrap();
        assert_eq!(el.active_effects(), ["coulomb_friction"]);
        assert_eq!(el.linearised(), (K, 0.0));
        let jump = el.force(0.0, 10.0 * v_eps, 0.0) - el.force(0.0, -10.0 * v_eps, 0.0);
        assert!(close(jump, 2.0 * fc, 1e-6), "jump {jump}");
        // Odd in v; at higher speed it is a constant F_c.
        for v in grid(0.0, 50.0 * v_eps, 100) {
            let up = el.force(0.0, v, 0.0);
            let down = el.force(0.0, -v, 0.0);
            assert!((up + down).abs() < 1e-12, "not odd at v = {v}");
            assert!(up >= 0.0 && up <= fc);
        }
        assert_eq!(el.force(0.0, 1.0, 0.0), fc);
        // The friction adds to the spring, independent of x.
        assert!(close(el.force(0.01, 0.1, 0.0), K * 0.01 + fc, 1e-14));
    }

    #[test]
    fn cubic_stiffness_adds_k3_x_cubed_and_hardens() {
        let k3 = 5.0e8;
        let el = with(Effects {
            cubic_stiffness: Some(CubicStiffness {
                stiffness_n_per_m3: k3,
            }),
            ..Effects::default()
        });
        el.validate().unwrap();
        assert_eq!(el.linearised(), (K, C));
        let mut last_secant = K;
        for x in grid(0.001, 0.05, 49) {
            let f = el.force(x, 0.0, 0.0);
            assert!(close(f - K * x, k3 * x * x * x, 1e-12));
            // Odd in x.
            assert!(close(el.force(-x, 0.0, 0.0), -f, 1e-14));
            let secant = f / x;
            assert!(secant > last_secant, "secant stiffness must grow with |x|");
            last_secant = secant;
        }
        assert!(last_secant > 2.0 * K);
    }

    #[test]
    fn bump_stop_engages_beyond_the_gap_continuously() {
        let gap = 0.03;
        let kb = 1.5e6;
        let rebound_gap = 0.05;
        let el = with(Effects {
            bump_stop: Some(BumpStop {
                gap_m: gap,
                stiffness_n_per_m: kb,
                rebound_gap_m: Some(rebound_gap),
            }),
            ..Effects::default()
        });
        el.validate().unwrap();
        assert_eq!(el.linearised(), (K, C));
        let extra = |x: f64| el.force(x, 0.0, 0.0) - K * x;
        // Zero extra force between the stops.
        for x in grid(-rebound_gap, gap, 80) {
            assert_eq!(extra(x), 0.0, "x = {x}");
        }
        // Slope k_b beyond, continuous at the gaps.
        let h = 1e-4;
        let slope_bump = (extra(gap + 2.0 * h) - extra(gap + h)) / h;
        assert!(close(slope_bump, kb, 1e-6), "bump slope {slope_bump}");
        assert!(close(extra(gap + 0.02), kb * 0.02, 1e-9));
        assert!(extra(gap + 1e-9).abs() < kb * 2e-9);
        let slope_rebound = (extra(-rebound_gap - h) - extra(-rebound_gap - 2.0 * h)) / h;
        assert!(
            close(slope_rebound, kb, 1e-6),
            "rebound slope {slope_rebound}"
        );
        assert!(close(extra(-rebound_gap - 0.01), -kb * 0.01, 1e-9));
        assert!(extra(-rebound_gap - 1e-9).abs() < kb * 2e-9);
        // Without a rebound stop, extension adds nothing.
        let no_rebound = with(Effects {
            bump_stop: Some(BumpStop {
                gap_m: gap,
                stiffness_n_per_m: kb,
                rebound_gap_m: None,
            }),
            ..Effects::default()
        });
        assert_eq!(no_rebound.force(-1.0, 0.0, 0.0), -K);
    }

    #[test]
    fn free_play_dead_zones_the_spring() {
        let b = 0.002;
        let el = with(Effects {
            free_play: Some(FreePlay { half_gap_m: b }),
            ..Effects::default()
        });
        el.validate().unwrap();
        // Linear analysis sees no spring about x = 0 (inside the gap), the damper unchanged.
        assert_eq!(el.linearised(), (0.0, C));
        // No spring force inside ±b; the damper still acts.
        for x in grid(-b, b, 40) {
            assert_eq!(el.force(x, 0.0, 0.0), 0.0);
            assert_eq!(el.force(x, 0.1, 0.0), C * 0.1);
        }
        // Slope k outside, continuous at ±b.
        for x in grid(b, 10.0 * b, 30) {
            assert!(close(el.force(x, 0.0, 0.0), K * (x - b), 1e-12));
            assert!(close(el.force(-x, 0.0, 0.0), -K * (x - b), 1e-12));
        }
        assert!(el.force(b * (1.0 + 1e-9), 0.0, 0.0).abs() < K * b * 2e-9);
        // The cubic term sees the same dead-zoned deflection.
        let k3 = 1e9;
        let both = with(Effects {
            free_play: Some(FreePlay { half_gap_m: b }),
            cubic_stiffness: Some(CubicStiffness {
                stiffness_n_per_m3: k3,
            }),
            ..Effects::default()
        });
        let x = 5.0 * b;
        let x_s = x - b;
        assert!(close(
            both.force(x, 0.0, 0.0),
            K * x_s + k3 * x_s * x_s * x_s,
            1e-12
        ));
        assert_eq!(both.force(0.5 * b, 0.0, 0.0), 0.0);
    }

    #[test]
    fn quadratic_damping_scales_with_v_abs_v() {
        let c2 = 800.0;
        let el = with(Effects {
            quadratic_damping: Some(QuadraticDamping {
                damping_n_s2_per_m2: c2,
            }),
            ..Effects::default()
        });
        el.validate().unwrap();
        assert_eq!(el.linearised(), (K, C));
        let extra = |v: f64| el.force(0.0, v, 0.0) - C * v;
        for v in grid(0.05, 2.0, 39) {
            assert!(close(extra(2.0 * v), 4.0 * extra(v), 1e-12));
            assert!(close(extra(v), c2 * v * v, 1e-12));
            // Opposes the motion in both directions.
            assert!(close(extra(-v), -extra(v), 1e-14));
        }
    }

    #[test]
    fn asymmetric_damping_ratio_is_bump_over_rebound() {
        let (cb, cr) = (1_000.0, 3_500.0);
        let el = with(Effects {
            asymmetric_damping: Some(AsymmetricDamping {
                bump_n_s_per_m: cb,
                rebound_n_s_per_m: cr,
            }),
            ..Effects::default()
        });
        el.validate().unwrap();
        assert_eq!(el.linearised(), (K, 0.5 * (cb + cr)));
        for v in grid(0.01, 2.0, 40) {
            let up = el.force(0.0, v, 0.0);
            let down = el.force(0.0, -v, 0.0);
            assert!(up > 0.0 && down < 0.0);
            assert!(close(up / -down, cb / cr, 1e-12));
            // The linear damping is replaced, not added to.
            assert!(close(up, cb * v, 1e-12));
            assert!(close(down, -cr * v, 1e-12));
        }
        assert_eq!(el.force(0.0, 0.0, 0.0), 0.0);
    }

    fn bouc_wen(alpha: f64, n: f64) -> BoucWen {
        // Yield deflection z_y = (A / (beta + gamma))^(1/n) = 2 mm.
        let z_y: f64 = 0.002;
        let a = 1.0;
        let beta = 0.5 * a / z_y.powf(n);
        BoucWen {
            alpha,
            a,
            beta,
            gamma: beta,
            n,
        }
    }

    /// Drives `x = X sin(2π f t)` for `cycles` cycles, integrating `z` with RK4, and returns
    /// the samples `(x, v, F)` of the last cycle.
    fn drive(el: &Element, amplitude: f64, cycles: usize) -> Vec<(f64, f64, f64)> {
        let w = 2.0 * std::f64::consts::PI * 0.5;
        let steps_per_cycle = 4000;
        let dt = 2.0 * std::f64::consts::PI / w / steps_per_cycle as f64;
        let xv = |t: f64| (amplitude * (w * t).sin(), amplitude * w * (w * t).cos());
        let rate = |t: f64, z: f64| {
            let (x, v) = xv(t);
            el.state_rate(x, v, z)
        };
        let mut z = 0.0;
        let mut out = Vec::new();
        for i in 0..cycles * steps_per_cycle {
            let t = i as f64 * dt;
            if i >= (cycles - 1) * steps_per_cycle {
                let (x, v) = xv(t);
                out.push((x, v, el.force(x, v, z)));
            }
            let k1 = rate(t, z);
            let k2 = rate(t + 0.5 * dt, z + 0.5 * dt * k1);
            let k3 = rate(t + 0.5 * dt, z + 0.5 * dt * k2);
            let k4 = rate(t + dt, z + dt * k3);
            z += dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
        }
        let (x, v) = xv((cycles * steps_per_cycle) as f64 * dt);
        out.push((x, v, el.force(x, v, z)));
        out
    }

    /// `∮ F dx` (J) over the sampled closed loop (trapezoidal).
    fn loop_work(samples: &[(f64, f64, f64)]) -> f64 {
        samples
            .windows(2)
            .map(|w| 0.5 * (w[0].2 + w[1].2) * (w[1].0 - w[0].0))
            .sum()
    }

    /// Force at the `x = 0` crossing (interpolated) on the loading (`v > 0`) and unloading
    /// (`v < 0`) branch.
    fn force_at_zero(samples: &[(f64, f64, f64)]) -> (f64, f64) {
        let (mut loading, mut unloading) = (f64::NAN, f64::NAN);
        for w in samples.windows(2) {
            let ((x0, v0, f0), (x1, _, f1)) = (w[0], w[1]);
            if (x0 <= 0.0 && x1 > 0.0) || (x0 >= 0.0 && x1 < 0.0) {
                let f = f0 + (f1 - f0) * (0.0 - x0) / (x1 - x0);
                if v0 > 0.0 {
                    loading = f;
                } else {
                    unloading = f;
                }
            }
        }
        (loading, unloading)
    }

    #[test]
    fn bouc_wen_loop_dissipates_energy() {
        for n in [1.0, 2.0] {
            let alpha = 0.2;
            let bw = bouc_wen(alpha, n);
            let z_y = bw.yield_deflection_m();
            assert!(close(z_y, 0.002, 1e-12));
            // No damping: all the loop area is the hysteresis.
            let el = Element::linear(K, 0.0).with_effects(Effects {
                bouc_wen: Some(bw),
                ..Effects::default()
            });
            el.validate().unwrap();
            assert_eq!(el.states(), 1);
            assert_eq!(el.active_effects(), ["bouc_wen"]);
            assert_eq!(el.linearised(), (K * (alpha + (1.0 - alpha) * bw.a), 0.0));
            // Far enough past yield that `z` reaches ~z_y (1 - e^-7 for n = 1) by x = 0.
            let amplitude = 8.0 * z_y;
            let samples = drive(&el, amplitude, 3);
            let work = loop_work(&samples);
            let f_y = (1.0 - alpha) * K * z_y;
            // Dissipated per cycle: positive, below the rectangle 2 F_y × 2 X.
            assert!(work > 0.0, "n = {n}: loop work {work}");
            assert!(work < 4.0 * f_y * amplitude, "n = {n}: loop work {work}");
            // A clearly open loop: at least half of the elastic-plastic 4 F_y (X - z_y).
            assert!(
                work > 0.5 * 4.0 * f_y * (amplitude - z_y),
                "n = {n}: loop work {work}"
            );
            // At x = 0 the loading branch sits at +F_y, the unloading one at -F_y.
            let (loading, unloading) = force_at_zero(&samples);
            assert!(close(loading, f_y, 0.01), "n = {n}: loading {loading}");
            assert!(
                close(unloading, -f_y, 0.01),
                "n = {n}: unloading {unloading}"
            );
            // The state saturates at the yield deflection.
            assert!(samples
                .iter()
                .all(
                    |&(x, _, f)| ((f - alpha * K * x) / ((1.0 - alpha) * K)).abs()
                        <= z_y * (1.0 + 1e-6)
                ));
        }
    }

    #[test]
    fn bouc_wen_with_alpha_one_is_the_linear_spring() {
        let el = with(Effects {
            bouc_wen: Some(bouc_wen(1.0, 1.0)),
            ..Effects::default()
        });
        el.validate().unwrap();
        assert_eq!(el.linearised(), (K, C));
        for x in grid(-0.05, 0.05, 20) {
            for z in grid(-0.002, 0.002, 8) {
                assert_eq!(el.force(x, 0.3, z), K * x + C * 0.3);
            }
        }
        let samples = drive(&Element::linear(K, 0.0).with_effects(el.effects), 0.01, 2);
        let work = loop_work(&samples);
        assert!(work.abs() < 1e-9 * K * 0.01 * 0.01, "loop work {work}");
    }

    #[test]
    fn bouc_wen_state_is_frozen_inside_free_play() {
        let b = 0.001;
        let el = with(Effects {
            bouc_wen: Some(bouc_wen(0.3, 1.0)),
            free_play: Some(FreePlay { half_gap_m: b }),
            ..Effects::default()
        });
        el.validate().unwrap();
        assert_eq!(el.active_effects(), ["free_play", "bouc_wen"]);
        assert_eq!(el.linearised(), (0.0, C));
        assert_eq!(el.state_rate(0.5 * b, 0.2, 0.0005), 0.0);
        assert_eq!(el.state_rate(-0.5 * b, -0.2, 0.0005), 0.0);
        assert!(el.state_rate(2.0 * b, 0.2, 0.0) > 0.0);
        // Spring path: alpha k x_s + (1 - alpha) k z with x_s the dead-zoned deflection.
        let z = 0.0004;
        assert!(close(
            el.force(3.0 * b, 0.0, z),
            K * (0.3 * 2.0 * b + 0.7 * z),
            1e-12
        ));
    }

    #[test]
    fn active_effects_lists_every_effect_in_order() {
        let all = Effects {
            lift_off: true,
            coulomb_friction: Some(CoulombFriction {
                force_n: 10.0,
                smoothing_velocity_m_per_s: CoulombFriction::DEFAULT_SMOOTHING_VELOCITY_M_PER_S,
            }),
            cubic_stiffness: Some(CubicStiffness {
                stiffness_n_per_m3: 1e8,
            }),
            bump_stop: Some(BumpStop {
                gap_m: 0.02,
                stiffness_n_per_m: 1e6,
                rebound_gap_m: None,
            }),
            free_play: Some(FreePlay { half_gap_m: 1e-3 }),
            quadratic_damping: Some(QuadraticDamping {
                damping_n_s2_per_m2: 100.0,
            }),
            asymmetric_damping: Some(AsymmetricDamping {
                bump_n_s_per_m: 1e3,
                rebound_n_s_per_m: 2e3,
            }),
            bouc_wen: Some(bouc_wen(0.5, 1.5)),
        };
        let el = with(all).with_preload(1_000.0);
        el.validate().unwrap();
        assert!(!el.is_linear());
        assert_eq!(
            el.active_effects(),
            [
                "lift_off",
                "coulomb_friction",
                "cubic_stiffness",
                "bump_stop",
                "free_play",
                "quadratic_damping",
                "asymmetric_damping",
                "bouc_wen",
            ]
        );
        // Everything on together stays finite and never pulls.
        for x in grid(-0.1, 0.1, 40) {
            for v in grid(-2.0, 2.0, 40) {
                let f = el.force(x, v, 0.001);
                assert!(f.is_finite() && f >= 0.0);
                assert!(el.state_rate(x, v, 0.001).is_finite());
            }
        }
        let defaults = Effects::default();
        assert!(!defaults.lift_off);
        assert_eq!(with(defaults).active_effects(), Vec::<&str>::new());
    }

    #[test]
    fn validate_names_the_offending_field() {
        let check = |el: Element, field: &str| {
            let err = el.validate().unwrap_err();
            assert_eq!(err.field, field);
            assert!(err.to_string().contains(field), "{err}");
        };
        check(Element::linear(f64::NAN, C), "stiffness_n_per_m");
        check(Element::linear(-1.0, C), "stiffness_n_per_m");
        check(Element::linear(K, -C), "damping_n_s_per_m");
        check(Element::linear(K, f64::INFINITY), "damping_n_s_per_m");
        check(Element::linear(K, C).with_preload(f64::NAN), "preload_n");
        // A negative preload is fine for a tension element, not one that can only push.
        Element::linear(K, C)
            .with_preload(-10.0)
            .validate()
            .unwrap();
        check(
            with(Effects {
                lift_off: true,
                ..Effects::default()
            })
            .with_preload(-10.0),
            "preload_n",
        );
        check(
            with(Effects {
                coulomb_friction: Some(CoulombFriction {
                    force_n: 10.0,
                    smoothing_velocity_m_per_s: 0.0,
                }),
                ..Effects::default()
            }),
            "effects.coulomb_friction.smoothing_velocity_m_per_s",
        );
        check(
            with(Effects {
                cubic_stiffness: Some(CubicStiffness {
                    stiffness_n_per_m3: f64::NAN,
                }),
                ..Effects::default()
            }),
            "effects.cubic_stiffness.stiffness_n_per_m3",
        );
        check(
            with(Effects {
                bump_stop: Some(BumpStop {
                    gap_m: 0.01,
                    stiffness_n_per_m: 1e6,
                    rebound_gap_m: Some(-0.01),
                }),
                ..Effects::default()
            }),
            "effects.bump_stop.rebound_gap_m",
        );
        check(
            with(Effects {
                free_play: Some(FreePlay { half_gap_m: -1e-3 }),
                ..Effects::default()
            }),
            "effects.free_play.half_gap_m",
        );
        check(
            with(Effects {
                quadratic_damping: Some(QuadraticDamping {
                    damping_n_s2_per_m2: -1.0,
                }),
                ..Effects::default()
            }),
            "effects.quadratic_damping.damping_n_s2_per_m2",
        );
        check(
            with(Effects {
                asymmetric_damping: Some(AsymmetricDamping {
                    bump_n_s_per_m: 1e3,
                    rebound_n_s_per_m: f64::NAN,
                }),
                ..Effects::default()
            }),
            "effects.asymmetric_damping.rebound_n_s_per_m",
        );
        let bw = |f: fn(&mut BoucWen)| {
            let mut p = bouc_wen(0.5, 1.0);
            f(&mut p);
            with(Effects {
                bouc_wen: Some(p),
                ..Effects::default()
            })
        };
        check(bw(|p| p.alpha = 1.5), "effects.bouc_wen.alpha");
        check(bw(|p| p.a = 0.0), "effects.bouc_wen.a");
        check(bw(|p| p.beta = -1.0), "effects.bouc_wen.beta");
        check(bw(|p| p.gamma = 2.0 * p.beta), "effects.bouc_wen.gamma");
        check(bw(|p| p.gamma = -p.beta), "effects.bouc_wen.gamma");
        check(bw(|p| p.n = 0.5), "effects.bouc_wen.n");
        check(bw(|p| p.n = f64::NAN), "effects.bouc_wen.n");
        bw(|p| p.gamma = 0.0).validate().unwrap();
    }
}
