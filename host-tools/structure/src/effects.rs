//! The effect vocabulary: identifiers, parameters and the force laws they give an element
//! (or the transformations they apply to an input). One name, one parameter set and one
//! law each, for the simulated rig (`mil-rig`), diagnosis (`mil-diagnose`) and every file
//! that names an effect.
//!
//! An element's force (N, positive pushing its ends apart) at compression `x` (m), rate `v`
//! (m/s) and hysteretic state `z` (m) is evaluated by [`ElementLaw::force`]:
//!
//! 1. spring deflection `x_s = x − clamp(x, −b, b)` with `backlash` (half gap `b`), else `x`;
//! 2. spring path `k x_s` — with `hysteresis` `α k x_s + (1 − α) k z` (stored as
//!    `k_s x_s + k_h z`), `z' = A v − β |v| |z|^(n−1) z − γ v |z|^n` — plus
//!    `cubic_stiffness` `k3 x_s³`;
//! 3. damper path `c v` — with `asymmetric_damping` `c_bump` for `v > 0`, `c_rebound` for
//!    `v < 0` (stored as `c v + c_abs |v|`) — plus `quadratic_damping` `c2 v |v|` and
//!    `coulomb_friction` `F_c tanh(v / v_eps)`;
//! 4. `bump_stop`: `k_b (x − gap)` for `x > gap` and/or `k_b (x + rebound_gap)` for
//!    `x < −rebound_gap`;
//! 5. `lift_off` with static preload `P` (N): the element carries `P` at `x = 0` and can only
//!    push, so the force relative to equilibrium is `max(P + F, 0) − P`.
//!
//! Input effects (on a displacement or force input `u`, in the input's SI unit, applied in
//! this order): `input_delay` `u(t − τ)`, `rate_limit` `|du/dt| <= r`, `saturation`
//! `clamp(u, lower, upper)`, and on a displacement input `backlash`, free play of half gap
//! `b` in the input's linkage (the play operator: the output holds until the input has moved
//! `b` past it, then follows it at that distance).

use crate::{Error, Result};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// The effect identifiers (as used in structure files, set-ups and reports).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EffectKind {
    /// Element can only push: parameter `preload_n` (N, static load at equilibrium, >= 0).
    LiftOff,
    /// Dry friction `F_c tanh(v / v_eps)`: `force_n` (N), `smoothing_velocity_m_per_s` (m/s).
    CoulombFriction,
    /// `k3 x_s³`: `stiffness_n_per_m3` (N/m³; > 0 hardening).
    CubicStiffness,
    /// End stop: `stiffness_n_per_m` (N/m) and `gap_m` (compression side, m) and/or
    /// `rebound_gap_m` (extension side, m); a stop on both sides may have its own
    /// `rebound_stiffness_n_per_m` (N/m, default `stiffness_n_per_m`).
    BumpStop,
    /// Free play in an element's spring path, or in a displacement input's linkage (the
    /// play operator): `half_gap_m` (m).
    Backlash,
    /// Pure delay of an input: `delay_s` (s).
    InputDelay,
    /// Rate limit of an input: `rate_per_s` (input unit per s: m/s or N/s).
    RateLimit,
    /// Saturation of an input between `lower_limit` and `upper_limit` (input unit: m or N;
    /// `limit` alone for `±limit`).
    Saturation,
    /// `c2 v |v|`: `damping_n_s2_per_m2` (N·s²/m²).
    QuadraticDamping,
    /// Different damping in compression and extension: `bump_n_s_per_m`,
    /// `rebound_n_s_per_m` (N·s/m); replaces the element's linear damping.
    AsymmetricDamping,
    /// Bouc-Wen hysteresis in the spring path: `alpha` (-), `beta_per_m`, `gamma_per_m`
    /// (1/m^n), optional `a` (-, default 1) and `n` (-, default 1).
    Hysteresis,
}

impl EffectKind {
    /// Every effect, in the order.
    pub const ALL: [EffectKind; 11] = [
        EffectKind::LiftOff,
        EffectKind::CoulombFriction,
        EffectKind::CubicStiffness,
        EffectKind::BumpStop,
        EffectKind::Backlash,
        EffectKind::InputDelay,
        EffectKind::RateLimit,
        EffectKind::Saturation,
        EffectKind::QuadraticDamping,
        EffectKind::AsymmetricDamping,
        EffectKind::Hysteresis,
    ];

    /// The identifier (e.g. `"cubic_stiffness"`).
    pub fn name(self) -> &'static str {
        match self {
            EffectKind::LiftOff => "lift_off",
            EffectKind::CoulombFriction => "coulomb_friction",
            EffectKind::CubicStiffness => "cubic_stiffness",
            EffectKind::BumpStop => "bump_stop",
            EffectKind::Backlash => "backlash",
            EffectKind::InputDelay => "input_delay",
            EffectKind::RateLimit => "rate_limit",
            EffectKind::Saturation => "saturation",
            EffectKind::QuadraticDamping => "quadratic_damping",
            EffectKind::AsymmetricDamping => "asymmetric_damping",
            EffectKind::Hysteresis => "hysteresis",
        }
    }

    /// Whether the effect can attach to an input.
    pub fn fits_input(self) -> bool {
        matches!(
            self,
            EffectKind::InputDelay
                | EffectKind::RateLimit
                | EffectKind::Saturation
                | EffectKind::Backlash
        )
    }

    /// Whether the effect can attach to an element.
    pub fn fits_element(self) -> bool {
        !matches!(
            self,
            EffectKind::InputDelay | EffectKind::RateLimit | EffectKind::Saturation
        )
    }
}

impl std::fmt::Display for EffectKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Default smoothing velocity `v_eps` (m/s) of `coulomb_friction`: the smoothed law
/// reaches 76 % of `F_c` at `|v| = v_eps` and 99.9 % at `4 v_eps`.
pub const DEFAULT_SMOOTHING_VELOCITY_M_PER_S: f64 = 1e-3;

/// Bouc-Wen parameters of [`ElementLaw::hysteresis`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoucWen {
    /// `A` (-), > 0.
    pub a: f64,
    /// `β` (1/m^n).
    pub beta: f64,
    /// `γ` (1/m^n).
    pub gamma: f64,
    /// `n` (-), >= 1.
    pub n: f64,
}

impl BoucWen {
    /// `dz/dt` (m/s) at rate `v` (m/s) and state `z` (m).
    #[inline]
    pub fn rate(&self, v: f64, z: f64) -> f64 {
        let az = z.abs();
        if self.n == 1.0 {
            // The common case, without `powf` (which the compiler would otherwise call for
            // `n = 1` too, since `|z|⁰ = 1`).
            return self.a * v - self.beta * v.abs() * z - self.gamma * v * az;
        }
        let azn1 = az.powf(self.n - 1.0);
        self.a * v - self.beta * v.abs() * azn1 * z - self.gamma * v * azn1 * az
    }
}

/// An element's force law in the form the fits use (coefficients that enter linearly are
/// separate fields). See the module documentation.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct ElementLaw {
    /// Spring coefficient `k_s` on `x_s` (N/m): the linear stiffness, or `α k` with
    /// hysteresis.
    pub k: f64,
    /// Linear damping `c` (N·s/m); with asymmetric damping the mean of bump and rebound.
    pub c: f64,
    /// Hysteretic spring coefficient `k_h = (1 − α) k` (N/m) on `z`, with hysteresis.
    pub k_h: f64,
    /// Bouc-Wen law of `z`, if hysteresis is on.
    pub hysteresis: Option<BoucWen>,
    /// Cubic stiffness `k3` (N/m³), if on.
    pub k3: Option<f64>,
    /// Half the bump/rebound damping difference `c_abs` (N·s/m) on `|v|`, if asymmetric
    /// damping is on.
    pub c_abs: Option<f64>,
    /// Quadratic damping `c2` (N·s²/m²), if on.
    pub c2: Option<f64>,
    /// Coulomb friction `(F_c (N), v_eps (m/s))`, if on.
    pub coulomb: Option<(f64, f64)>,
    /// Compression-side stop `(gap (m), k_b (N/m))`, if on.
    pub bump: Option<(f64, f64)>,
    /// Extension-side stop `(rebound gap (m), k_b (N/m))`, if on.
    pub rebound: Option<(f64, f64)>,
    /// Backlash half gap `b` (m), if on.
    pub backlash: Option<f64>,
    /// Lift-off with static preload `P` (N), if on.
    pub lift_off: Option<f64>,
}

impl ElementLaw {
    /// The board's form of the law (model-core's [`model_core::ElementLaw`], `f32`), what
    /// model-core's substructure runs: the same force at every compression and rate (within
    /// `f32` rounding). Backlash and hysteresis have no real-time form on the board yet and
    /// are refused by name, as are values outside the board's ranges.
    ///
    /// # Errors
    /// [`crate::Error::Model`] naming the effect or the range.
    pub fn to_board(&self) -> crate::Result<model_core::ElementLaw> {
        for (on, name) in [
            (self.backlash.is_some(), EffectKind::Backlash),
            (self.hysteresis.is_some(), EffectKind::Hysteresis),
        ] {
            if on {
                return Err(crate::Error::Model(format!(
                    "effect {name} has no real-time form on the board (it runs lift_off, \
                     coulomb_friction, cubic_stiffness, bump_stop, quadratic_damping and \
                     asymmetric_damping)"
                )));
            }
        }
        let c_abs = self.c_abs.unwrap_or(0.0);
        let (friction_force, friction_velocity) = self.coulomb.unwrap_or((0.0, 1.0e-3));
        let (bump_gap, bump_stiffness) = self.bump.unwrap_or((0.0, 0.0));
        let (rebound_gap, rebound_stiffness) = self.rebound.unwrap_or((0.0, 0.0));
        let board = model_core::ElementLaw {
            stiffness: self.k as f32,
            bump_damping: (self.c + c_abs) as f32,
            rebound_damping: (self.c - c_abs) as f32,
            cubic_stiffness: self.k3.unwrap_or(0.0) as f32,
            quadratic_damping: self.c2.unwrap_or(0.0) as f32,
            bump_gap: bump_gap as f32,
            bump_stiffness: bump_stiffness as f32,
            rebound_gap: rebound_gap as f32,
            rebound_stiffness: rebound_stiffness as f32,
            friction_force: friction_force as f32,
            friction_velocity: friction_velocity as f32,
            preload: self.lift_off.unwrap_or(0.0) as f32,
            lift_off: u32::from(self.lift_off.is_some()),
        };
        board.validate().map_err(|e| {
            crate::Error::Model(format!("the law is outside the board's ranges ({e})"))
        })?;
        Ok(board)
    }

    /// A linear element with stiffness `k` (N/m) and damping `c` (N·s/m).
    pub fn linear(k: f64, c: f64) -> Self {
        Self {
            k,
            c,
            ..Self::default()
        }
    }

    /// Spring deflection `x_s` (m) at compression `x` (m).
    #[inline]
    pub fn spring_deflection(&self, x: f64) -> f64 {
        match self.backlash {
            Some(b) => play(x, b),
            None => x,
        }
    }

    /// Force (N) before lift-off at compression `x` (m), rate `v` (m/s), state `z` (m):
    /// `k x_s + c v (+ k_h z + k3 x_s³ + c_abs |v| + c2 v|v| + F_c tanh(v/v_eps) + stops)`
    /// with the effects that are on ([`CompiledLaw`] holds the arithmetic; a loop over
    /// many samples unpacks the law once with [`CompiledLaw::new`]).
    #[inline]
    pub fn force_unclipped(&self, x: f64, v: f64, z: f64) -> f64 {
        CompiledLaw::new(self).force_unclipped(x, v, z)
    }

    /// Force (N, relative to the static equilibrium) at compression `x` (m), rate `v`
    /// (m/s) and state `z` (m), lift-off included.
    #[inline]
    pub fn force(&self, x: f64, v: f64, z: f64) -> f64 {
        CompiledLaw::new(self).force(x, v, z)
    }

    /// `dz/dt` (m/s); 0 without hysteresis. Frozen inside a backlash gap.
    #[inline]
    pub fn state_rate(&self, x: f64, v: f64, z: f64) -> f64 {
        CompiledLaw::new(self).state_rate(x, v, z)
    }

    /// Number of internal states: 1 with hysteresis (the hysteretic deflection `z`), else 0.
    pub fn states(&self) -> usize {
        usize::from(self.hysteresis.is_some())
    }

    /// Small-signal stiffness (N/m) and damping (N·s/m) about `x = 0`, `v = 0`, `z = 0`:
    /// what a linear analysis sees. Contributions of the effects:
    ///
    /// - lift-off: none (the element is in contact at equilibrium, its preload >= 0);
    /// - Coulomb friction: none. The smoothed law has slope `F_c / v_eps` at `v = 0`, an
    ///   artefact of the smoothing that only holds for `|v| << v_eps`; the ideal (unsmoothed)
    ///   friction's linearisation, 0, is returned;
    /// - cubic stiffness, quadratic damping: none (their slopes vanish at 0);
    /// - bump stop: none (not engaged at `x = 0`; with a zero gap the one-sided slope is
    ///   ignored);
    /// - backlash of half gap `b > 0`: the spring path (linear or hysteretic) contributes
    ///   nothing, `x = 0` lies inside the gap;
    /// - asymmetric damping: the mean `(c_bump + c_rebound) / 2` (equal dissipation per
    ///   cycle of a symmetric oscillation);
    /// - hysteresis: the initial stiffness `k (α + (1 − α) A)`.
    pub fn linearised(&self) -> (f64, f64) {
        let k = match self.hysteresis {
            Some(bw) => self.k + self.k_h * bw.a,
            None => self.k,
        };
        let k = if self.backlash.is_some_and(|b| b > 0.0) {
            0.0
        } else {
            k
        };
        (k, self.c)
    }

    /// The effects that are on.
    pub fn kinds(&self) -> Vec<EffectKind> {
        let mut out = Vec::new();
        if self.lift_off.is_some() {
            out.push(EffectKind::LiftOff);
        }
        if self.coulomb.is_some() {
            out.push(EffectKind::CoulombFriction);
        }
        if self.k3.is_some() {
            out.push(EffectKind::CubicStiffness);
        }
        if self.bump.is_some() || self.rebound.is_some() {
            out.push(EffectKind::BumpStop);
        }
        if self.backlash.is_some() {
            out.push(EffectKind::Backlash);
        }
        if self.c2.is_some() {
            out.push(EffectKind::QuadraticDamping);
        }
        if self.c_abs.is_some() {
            out.push(EffectKind::AsymmetricDamping);
        }
        if self.hysteresis.is_some() {
            out.push(EffectKind::Hysteresis);
        }
        out
    }

    /// Whether the law is passive, as a spring-damper element is: no negative stiffness
    /// (linear, hysteretic or a stop's), damping, friction force or quadratic damping, and
    /// both of an asymmetric damper's dampings >= 0. A negative one would be an energy
    /// source in the element; a softening cubic (negative `k3`) is allowed, it is checked
    /// where it would make the spring pull (the model's travel is not known here).
    pub fn passive(&self) -> bool {
        let nonneg = |v: f64| v.is_finite() && v >= 0.0;
        nonneg(self.k)
            && nonneg(self.c)
            && nonneg(self.k_h)
            && self.c2.is_none_or(nonneg)
            && self.coulomb.is_none_or(|(fc, _)| nonneg(fc))
            && self.bump.is_none_or(|(_, kb)| nonneg(kb))
            && self.rebound.is_none_or(|(_, kr)| nonneg(kr))
            && self
                .c_abs
                .is_none_or(|ca| nonneg(self.c + ca) && nonneg(self.c - ca))
    }

    /// The nearest passive law in each of the effect parameters [`ElementLaw::passive`]
    /// bounds (a stop's stiffness, a friction force, a quadratic damping at 0 when below;
    /// an asymmetric half difference within `±c`): the projection a bounded refinement
    /// takes its steps through. The linear `k`, `c`, `k_h` are left as they are.
    pub fn make_passive(&mut self) {
        let at_least_0 = |v: &mut f64| *v = v.max(0.0);
        if let Some(c2) = self.c2.as_mut() {
            at_least_0(c2);
        }
        if let Some((fc, _)) = self.coulomb.as_mut() {
            at_least_0(fc);
        }
        if let Some((_, kb)) = self.bump.as_mut() {
            at_least_0(kb);
        }
        if let Some((_, kr)) = self.rebound.as_mut() {
            at_least_0(kr);
        }
        if let Some(ca) = self.c_abs.as_mut() {
            let c = self.c.max(0.0);
            *ca = ca.clamp(-c, c);
        }
    }

    /// The file's (total) stiffness `k` (N/m): `k_s + k_h` with hysteresis.
    pub fn stiffness_total(&self) -> f64 {
        if self.hysteresis.is_some() {
            self.k + self.k_h
        } else {
            self.k
        }
    }

    /// The parameters of effect `kind` as written in model files and reports (SI names),
    /// or `None` if it is off.
    pub fn parameters(&self, kind: EffectKind) -> Option<BTreeMap<String, f64>> {
        let mut p = BTreeMap::new();
        let mut put = |k: &str, v: f64| {
            p.insert(k.to_string(), v);
        };
        match kind {
            EffectKind::LiftOff => put("preload_n", self.lift_off?),
            EffectKind::CoulombFriction => {
                let (fc, veps) = self.coulomb?;
                put("force_n", fc);
                put("smoothing_velocity_m_per_s", veps);
            }
            EffectKind::CubicStiffness => put("stiffness_n_per_m3", self.k3?),
            EffectKind::BumpStop => {
                if self.bump.is_none() && self.rebound.is_none() {
                    return None;
                }
                // A side of zero stiffness (where a refinement held it at its bound) is
                // no stop: not written.
                let (bump, rebound) = match (self.bump, self.rebound) {
                    (Some(b), Some(r)) if r.1 == 0.0 && b.1 != 0.0 => (Some(b), None),
                    (Some(b), Some(r)) if b.1 == 0.0 && r.1 != 0.0 => (None, Some(r)),
                    sides => sides,
                };
                if let Some((g, kb)) = bump {
                    put("gap_m", g);
                    put("stiffness_n_per_m", kb);
                }
                match (bump, rebound) {
                    (Some((_, kb)), Some((g, kr))) => {
                        put("rebound_gap_m", g);
                        if kr != kb {
                            put("rebound_stiffness_n_per_m", kr);
                        }
                    }
                    (None, Some((g, kr))) => {
                        put("rebound_gap_m", g);
                        put("stiffness_n_per_m", kr);
                    }
                    _ => {}
                }
            }
            EffectKind::Backlash => put("half_gap_m", self.backlash?),
            EffectKind::QuadraticDamping => put("damping_n_s2_per_m2", self.c2?),
            EffectKind::AsymmetricDamping => {
                let ca = self.c_abs?;
                put("bump_n_s_per_m", self.c + ca);
                put("rebound_n_s_per_m", self.c - ca);
            }
            EffectKind::Hysteresis => {
                let bw = self.hysteresis?;
                let total = self.k + self.k_h;
                put("alpha", if total != 0.0 { self.k / total } else { 1.0 });
                put("a", bw.a);
                put("beta_per_m", bw.beta);
                put("gamma_per_m", bw.gamma);
                put("n", bw.n);
            }
            EffectKind::InputDelay | EffectKind::RateLimit | EffectKind::Saturation => return None,
        }
        Some(p)
    }

    /// Switches on effect `kind` with `parameters` (SI names, see [`EffectKind`]); the
    /// element's file stiffness `k_total` (N/m) and damping `c` (N·s/m) are needed by
    /// hysteresis and asymmetric damping, which replace part of the linear law.
    ///
    /// # Errors
    /// Unknown, missing or out-of-range parameters, named.
    pub fn apply(&mut self, kind: EffectKind, parameters: &BTreeMap<String, f64>) -> Result<()> {
        let mut reader = Params::new(kind, parameters);
        match kind {
            EffectKind::LiftOff => {
                let p = reader.get("preload_n")?;
                reader.check(p >= 0.0, "preload_n", p, ">= 0")?;
                self.lift_off = Some(p);
            }
            EffectKind::CoulombFriction => {
                let fc = reader.get("force_n")?;
                reader.check(fc >= 0.0, "force_n", fc, ">= 0")?;
                let veps = reader
                    .opt("smoothing_velocity_m_per_s")?
                    .unwrap_or(DEFAULT_SMOOTHING_VELOCITY_M_PER_S);
                reader.check(veps > 0.0, "smoothing_velocity_m_per_s", veps, "> 0")?;
                self.coulomb = Some((fc, veps));
            }
            EffectKind::CubicStiffness => self.k3 = Some(reader.get("stiffness_n_per_m3")?),
            EffectKind::BumpStop => {
                let kb = reader.get("stiffness_n_per_m")?;
                let gap = reader.opt("gap_m")?;
                let rgap = reader.opt("rebound_gap_m")?;
                let kr = reader.opt("rebound_stiffness_n_per_m")?;
                reader.check(kb >= 0.0, "stiffness_n_per_m", kb, ">= 0")?;
                if let Some(kr) = kr {
                    reader.check(kr >= 0.0, "rebound_stiffness_n_per_m", kr, ">= 0")?;
                }
                if kr.is_some() && (gap.is_none() || rgap.is_none()) {
                    return Err(Error::Model(
                        "bump_stop: rebound_stiffness_n_per_m is for a stop on both sides (give \
                         gap_m and rebound_gap_m); a rebound stop alone takes stiffness_n_per_m"
                            .into(),
                    ));
                }
                if gap.is_none() && rgap.is_none() {
                    return Err(Error::Model(
                        "bump_stop: give gap_m (compression) and/or rebound_gap_m (extension)"
                            .into(),
                    ));
                }
                if let Some(g) = gap {
                    reader.check(g >= 0.0, "gap_m", g, ">= 0")?;
                }
                if let Some(g) = rgap {
                    reader.check(g >= 0.0, "rebound_gap_m", g, ">= 0")?;
                }
                self.bump = gap.map(|g| (g, kb));
                self.rebound = rgap.map(|g| (g, kr.unwrap_or(kb)));
            }
            EffectKind::Backlash => {
                let b = reader.get("half_gap_m")?;
                reader.check(b >= 0.0, "half_gap_m", b, ">= 0")?;
                self.backlash = Some(b);
            }
            EffectKind::QuadraticDamping => {
                let c2 = reader.get("damping_n_s2_per_m2")?;
                reader.check(c2 >= 0.0, "damping_n_s2_per_m2", c2, ">= 0")?;
                self.c2 = Some(c2);
            }
            EffectKind::AsymmetricDamping => {
                let cb = reader.get("bump_n_s_per_m")?;
                let cr = reader.get("rebound_n_s_per_m")?;
                reader.check(cb >= 0.0, "bump_n_s_per_m", cb, ">= 0")?;
                reader.check(cr >= 0.0, "rebound_n_s_per_m", cr, ">= 0")?;
                self.c = 0.5 * (cb + cr);
                self.c_abs = Some(0.5 * (cb - cr));
            }
            EffectKind::Hysteresis => {
                let alpha = reader.get("alpha")?;
                reader.check((0.0..=1.0).contains(&alpha), "alpha", alpha, "in [0, 1]")?;
                let a = reader.opt("a")?.unwrap_or(1.0);
                reader.check(a > 0.0, "a", a, "> 0")?;
                let beta = reader.get("beta_per_m")?;
                // β <= 0 makes the loop an energy source (negative work per cycle).
                reader.check(beta > 0.0, "beta_per_m", beta, "> 0")?;
                let gamma = reader.get("gamma_per_m")?;
                let n = reader.opt("n")?.unwrap_or(1.0);
                reader.check(n >= 1.0, "n", n, ">= 1")?;
                let total = self.stiffness_total();
                self.k = alpha * total;
                self.k_h = (1.0 - alpha) * total;
                self.hysteresis = Some(BoucWen { a, beta, gamma, n });
            }
            EffectKind::InputDelay | EffectKind::RateLimit | EffectKind::Saturation => {
                return Err(Error::Model(format!(
                    "{kind} attaches to an input, not an element"
                )))
            }
        }
        reader.finish()
    }

    /// Switches effect `kind` off (restoring the linear law it replaced).
    pub fn remove(&mut self, kind: EffectKind) {
        match kind {
            EffectKind::LiftOff => self.lift_off = None,
            EffectKind::CoulombFriction => self.coulomb = None,
            EffectKind::CubicStiffness => self.k3 = None,
            EffectKind::BumpStop => {
                self.bump = None;
                self.rebound = None;
            }
            EffectKind::Backlash => self.backlash = None,
            EffectKind::QuadraticDamping => self.c2 = None,
            EffectKind::AsymmetricDamping => self.c_abs = None,
            EffectKind::Hysteresis => {
                if self.hysteresis.take().is_some() {
                    self.k += self.k_h;
                    self.k_h = 0.0;
                }
            }
            EffectKind::InputDelay | EffectKind::RateLimit | EffectKind::Saturation => {}
        }
    }
}

/// Deflection (m) beyond a play of half gap `b` (m) at compression `x`: zero inside
/// `[-b, b]`.
#[inline]
pub fn play(x: f64, b: f64) -> f64 {
    x - x.max(-b).min(b)
}

/// An [`ElementLaw`] unpacked for loops over many samples (the simulation's inner loop,
/// the contact masks, the hysteretic state): the effects that are on as bits of one word,
/// their parameters as plain numbers, so that an evaluation matches no `Option` (see
/// [`CompiledLaw::force`] for how the effects are dispatched). The element force law's
/// arithmetic lives here; [`ElementLaw`]'s methods unpack and call it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CompiledLaw {
    /// Bits of the effects that are on (the `Self::ON_*` constants).
    on: u16,
    /// [`ElementLaw::k`].
    k: f64,
    /// [`ElementLaw::c`].
    c: f64,
    /// [`ElementLaw::k_h`].
    k_h: f64,
    /// Bouc-Wen law (with [`Self::ON_HYSTERESIS`]).
    bouc_wen: BoucWen,
    /// Backlash half gap `b` (m).
    backlash: f64,
    /// `k3` (N/m³).
    k3: f64,
    /// `c_abs` (N·s/m).
    c_abs: f64,
    /// `c2` (N·s²/m²).
    c2: f64,
    /// Coulomb `F_c` (N) and `v_eps` (m/s).
    coulomb: (f64, f64),
    /// Compression-side stop `(gap, k_b)`.
    bump: (f64, f64),
    /// Extension-side stop `(rebound gap, k_b)`.
    rebound: (f64, f64),
    /// Lift-off preload `P` (N).
    preload: f64,
}

impl CompiledLaw {
    const ON_HYSTERESIS: u16 = 1;
    const ON_BACKLASH: u16 = 1 << 1;
    const ON_CUBIC: u16 = 1 << 2;
    const ON_ASYMMETRIC: u16 = 1 << 3;
    const ON_QUADRATIC: u16 = 1 << 4;
    const ON_COULOMB: u16 = 1 << 5;
    const ON_BUMP: u16 = 1 << 6;
    const ON_REBOUND: u16 = 1 << 7;
    const ON_LIFT_OFF: u16 = 1 << 8;

    /// Unpacks `law`.
    pub fn new(law: &ElementLaw) -> Self {
        let mut on = 0;
        let mut flag = |present: bool, bit: u16| {
            if present {
                on |= bit;
            }
        };
        flag(law.hysteresis.is_some(), Self::ON_HYSTERESIS);
        flag(law.backlash.is_some(), Self::ON_BACKLASH);
        flag(law.k3.is_some(), Self::ON_CUBIC);
        flag(law.c_abs.is_some(), Self::ON_ASYMMETRIC);
        flag(law.c2.is_some(), Self::ON_QUADRATIC);
        flag(law.coulomb.is_some(), Self::ON_COULOMB);
        flag(law.bump.is_some(), Self::ON_BUMP);
        flag(law.rebound.is_some(), Self::ON_REBOUND);
        flag(law.lift_off.is_some(), Self::ON_LIFT_OFF);
        Self {
            on,
            k: law.k,
            c: law.c,
            k_h: law.k_h,
            bouc_wen: law.hysteresis.unwrap_or(BoucWen {
                a: 0.0,
                beta: 0.0,
                gamma: 0.0,
                n: 1.0,
            }),
            backlash: law.backlash.unwrap_or(0.0),
            k3: law.k3.unwrap_or(0.0),
            c_abs: law.c_abs.unwrap_or(0.0),
            c2: law.c2.unwrap_or(0.0),
            coulomb: law.coulomb.unwrap_or((0.0, 1.0)),
            bump: law.bump.unwrap_or((0.0, 0.0)),
            rebound: law.rebound.unwrap_or((0.0, 0.0)),
            preload: law.lift_off.unwrap_or(0.0),
        }
    }

    /// [`ElementLaw::force`]: the force with lift-off.
    ///
    /// A law with no effect or a single one (the fits' usual case) is evaluated by a copy
    /// of `force_with` with its effect set as a constant: straight-line code after
    /// one multi-way jump, instead of a test per effect. Other sets test each bit.
    #[inline(always)]
    pub fn force(&self, x: f64, v: f64, z: f64) -> f64 {
        macro_rules! dispatch {
            ($($bit:path),*) => {
                match self.on {
                    0 => self.force_with(0, x, v, z),
                    $($bit => self.force_with($bit, x, v, z),)*
                    on => self.force_with(on, x, v, z),
                }
            };
        }
        dispatch!(
            Self::ON_HYSTERESIS,
            Self::ON_BACKLASH,
            Self::ON_CUBIC,
            Self::ON_ASYMMETRIC,
            Self::ON_QUADRATIC,
            Self::ON_COULOMB,
            Self::ON_BUMP,
            Self::ON_REBOUND,
            Self::ON_LIFT_OFF
        )
    }

    /// [`Self::force`] with the effects `on` (the bits of [`Self::on`]).
    #[inline(always)]
    fn force_with(&self, on: u16, x: f64, v: f64, z: f64) -> f64 {
        let has = |bit: u16| on & bit != 0;
        let xs = if has(Self::ON_BACKLASH) {
            play(x, self.backlash)
        } else {
            x
        };
        let mut f = self.k * xs + self.c * v;
        if has(Self::ON_HYSTERESIS) {
            f += self.k_h * z;
        }
        if has(Self::ON_CUBIC) {
            f += self.k3 * xs * xs * xs;
        }
        if has(Self::ON_ASYMMETRIC) {
            f += self.c_abs * v.abs();
        }
        if has(Self::ON_QUADRATIC) {
            f += self.c2 * v * v.abs();
        }
        if has(Self::ON_COULOMB) {
            let (fc, veps) = self.coulomb;
            f += fc * (v / veps).tanh();
        }
        if has(Self::ON_BUMP) {
            let (gap, kb) = self.bump;
            f += kb * (x - gap).max(0.0);
        }
        if has(Self::ON_REBOUND) {
            let (gap, kb) = self.rebound;
            f += kb * (x + gap).min(0.0);
        }
        if has(Self::ON_LIFT_OFF) && self.preload + f < 0.0 {
            return -self.preload;
        }
        f
    }

    /// [`Self::force`] before lift-off (see [`ElementLaw::force_unclipped`]).
    #[inline]
    pub fn force_unclipped(&self, x: f64, v: f64, z: f64) -> f64 {
        self.force_with(self.on & !Self::ON_LIFT_OFF, x, v, z)
    }

    /// As [`ElementLaw::state_rate`] (0 without hysteresis).
    #[inline(always)]
    pub fn state_rate(&self, x: f64, v: f64, z: f64) -> f64 {
        if self.on & Self::ON_HYSTERESIS == 0 {
            return 0.0;
        }
        let vs = if self.on & Self::ON_BACKLASH != 0 && x.abs() <= self.backlash {
            0.0
        } else {
            v
        };
        self.bouc_wen.rate(vs, z)
    }
}

/// Effects on an input (see the module documentation).
#[derive(Clone, Debug, PartialEq, Default)]
pub struct InputLaw {
    /// Delay `τ` (s), if on.
    pub delay_s: Option<f64>,
    /// Rate limit (input unit per s), if on.
    pub rate_limit: Option<f64>,
    /// Saturation limits `(lower, upper)` (input unit), if on.
    pub saturation: Option<(f64, f64)>,
    /// Half gap `b` of the play in a displacement input's linkage (m), if on.
    pub backlash: Option<f64>,
}

impl InputLaw {
    /// The effects that are on.
    pub fn kinds(&self) -> Vec<EffectKind> {
        let mut out = Vec::new();
        if self.delay_s.is_some() {
            out.push(EffectKind::InputDelay);
        }
        if self.rate_limit.is_some() {
            out.push(EffectKind::RateLimit);
        }
        if self.saturation.is_some() {
            out.push(EffectKind::Saturation);
        }
        if self.backlash.is_some() {
            out.push(EffectKind::Backlash);
        }
        out
    }

    /// Parameters of effect `kind` (SI names), or `None` if off.
    pub fn parameters(&self, kind: EffectKind) -> Option<BTreeMap<String, f64>> {
        let pairs: Vec<(&str, f64)> = match kind {
            EffectKind::InputDelay => vec![("delay_s", self.delay_s?)],
            EffectKind::RateLimit => vec![("rate_per_s", self.rate_limit?)],
            EffectKind::Saturation => {
                let (lo, hi) = self.saturation?;
                vec![("lower_limit", lo), ("upper_limit", hi)]
            }
            EffectKind::Backlash => vec![("half_gap_m", self.backlash?)],
            _ => return None,
        };
        Some(pairs.into_iter().map(|(k, v)| (k.to_string(), v)).collect())
    }

    /// Switches on input effect `kind` with `parameters`.
    ///
    /// # Errors
    /// Unknown, missing or out-of-range parameters, or an element effect.
    pub fn apply(&mut self, kind: EffectKind, parameters: &BTreeMap<String, f64>) -> Result<()> {
        let mut reader = Params::new(kind, parameters);
        match kind {
            EffectKind::InputDelay => {
                let d = reader.get("delay_s")?;
                reader.check(d >= 0.0, "delay_s", d, ">= 0")?;
                self.delay_s = Some(d);
            }
            EffectKind::RateLimit => {
                let r = reader.get("rate_per_s")?;
                reader.check(r > 0.0, "rate_per_s", r, "> 0")?;
                self.rate_limit = Some(r);
            }
            EffectKind::Saturation => {
                let has = |k: &str| reader.map.contains_key(k);
                if has("limit") && (has("lower_limit") || has("upper_limit")) {
                    return Err(Error::Model(
                        "saturation: give limit (symmetric) or lower_limit and upper_limit, \
                         not both"
                            .into(),
                    ));
                }
                let limits = match reader.opt("limit")? {
                    Some(l) => {
                        reader.check(l > 0.0, "limit", l, "> 0")?;
                        (-l, l)
                    }
                    None => {
                        let lo = reader.get("lower_limit")?;
                        let hi = reader.get("upper_limit")?;
                        reader.check(hi > lo, "upper_limit", hi, "above lower_limit")?;
                        (lo, hi)
                    }
                };
                self.saturation = Some(limits);
            }
            EffectKind::Backlash => {
                let b = reader.get("half_gap_m")?;
                reader.check(b >= 0.0, "half_gap_m", b, ">= 0")?;
                self.backlash = Some(b);
            }
            _ => {
                return Err(Error::Model(format!(
                    "{kind} attaches to an element, not an input"
                )))
            }
        }
        reader.finish()
    }

    /// Switches effect `kind` off.
    pub fn remove(&mut self, kind: EffectKind) {
        match kind {
            EffectKind::InputDelay => self.delay_s = None,
            EffectKind::RateLimit => self.rate_limit = None,
            EffectKind::Saturation => self.saturation = None,
            EffectKind::Backlash => self.backlash = None,
            _ => {}
        }
    }

    /// The input signal `u` (input unit, sampled every `dt` s) as the model sees it: delayed
    /// (linear interpolation, the first sample held before the start), rate limited,
    /// saturated, passed through the play (centred on the first sample).
    pub fn transform(&self, u: &[f64], dt: f64) -> Vec<f64> {
        let mut out: Vec<f64> = match self.delay_s {
            Some(d) if d > 0.0 => {
                let shift = d / dt;
                (0..u.len())
                    .map(|i| mil_numerics::interpolate::sample_at(u, i as f64 - shift))
                    .collect()
            }
            _ => u.to_vec(),
        };
        if let Some(r) = self.rate_limit {
            let step = r * dt;
            for i in 1..out.len() {
                let prev = out[i - 1];
                out[i] = out[i].max(prev - step).min(prev + step);
            }
        }
        if let Some((lo, hi)) = self.saturation {
            for v in &mut out {
                *v = v.max(lo).min(hi);
            }
        }
        if let Some(b) = self.backlash {
            let mut held = out.first().copied().unwrap_or(0.0);
            for v in &mut out {
                held = held.max(*v - b).min(*v + b);
                *v = held;
            }
        }
        out
    }
}

/// Reads an effect's parameter map, tracking unknown keys.
struct Params<'a> {
    kind: EffectKind,
    map: &'a BTreeMap<String, f64>,
    used: Vec<&'static str>,
}

impl<'a> Params<'a> {
    fn new(kind: EffectKind, map: &'a BTreeMap<String, f64>) -> Self {
        Self {
            kind,
            map,
            used: Vec::new(),
        }
    }

    fn opt(&mut self, key: &'static str) -> Result<Option<f64>> {
        self.used.push(key);
        match self.map.get(key) {
            Some(v) if v.is_finite() => Ok(Some(*v)),
            Some(v) => Err(Error::Model(format!(
                "{}: parameter {key} must be finite, got {v}",
                self.kind
            ))),
            None => Ok(None),
        }
    }

    fn get(&mut self, key: &'static str) -> Result<f64> {
        let given: Vec<&str> = self.map.keys().map(String::as_str).collect();
        self.opt(key)?.ok_or_else(|| {
            Error::Model(format!(
                "{}: missing parameter {key} (given: {})",
                self.kind,
                given.join(", ")
            ))
        })
    }

    fn check(&self, ok: bool, key: &str, value: f64, what: &str) -> Result<()> {
        if ok {
            Ok(())
        } else {
            Err(Error::Model(format!(
                "{}: parameter {key} must be {what}, got {value}",
                self.kind
            )))
        }
    }

    fn finish(self) -> Result<()> {
        if let Some(k) = self.map.keys().find(|k| !self.used.contains(&k.as_str())) {
            return Err(Error::Model(format!(
                "{}: unknown parameter {k:?} (known: {})",
                self.kind,
                self.used.join(", ")
            )));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parameters_round_trip_through_apply() {
        for kind in EffectKind::ALL.iter().copied().filter(|k| k.fits_element()) {
            let mut law = ElementLaw::linear(1e4, 100.0);
            let pairs: Vec<(&str, f64)> = match kind {
                EffectKind::LiftOff => [("preload_n", 500.0)].to_vec(),
                EffectKind::CoulombFriction => {
                    [("force_n", 20.0), ("smoothing_velocity_m_per_s", 1e-3)].to_vec()
                }
                EffectKind::CubicStiffness => [("stiffness_n_per_m3", 1e9)].to_vec(),
                EffectKind::BumpStop => [("gap_m", 0.01), ("stiffness_n_per_m", 1e5)].to_vec(),
                EffectKind::Backlash => [("half_gap_m", 1e-3)].to_vec(),
                EffectKind::QuadraticDamping => [("damping_n_s2_per_m2", 50.0)].to_vec(),
                EffectKind::AsymmetricDamping => {
                    [("bump_n_s_per_m", 80.0), ("rebound_n_s_per_m", 120.0)].to_vec()
                }
                EffectKind::Hysteresis => [
                    ("alpha", 0.5),
                    ("a", 1.0),
                    ("beta_per_m", 800.0),
                    ("gamma_per_m", -100.0),
                    ("n", 1.0),
                ]
                .to_vec(),
                _ => unreachable!(),
            };
            let params: BTreeMap<String, f64> =
                pairs.into_iter().map(|(k, v)| (k.to_string(), v)).collect();
            law.apply(kind, &params).unwrap();
            assert_eq!(law.kinds(), vec![kind]);
            assert_eq!(law.parameters(kind).unwrap(), params, "{kind}");
            let mut bad = params.clone();
            bad.insert("nonsense".into(), 1.0);
            let err = ElementLaw::linear(1e4, 100.0)
                .apply(kind, &bad)
                .unwrap_err();
            assert!(err.to_string().contains("nonsense"), "{err}");
        }
    }

    #[test]
    fn a_stop_on_both_sides_keeps_its_own_stiffnesses() {
        let map = |pairs: &[(&str, f64)]| -> BTreeMap<String, f64> {
            pairs.iter().map(|(k, v)| (k.to_string(), *v)).collect()
        };
        let both = map(&[
            ("gap_m", 0.01),
            ("rebound_gap_m", 0.02),
            ("stiffness_n_per_m", 1e5),
            ("rebound_stiffness_n_per_m", 3e5),
        ]);
        let mut law = ElementLaw::linear(1e4, 100.0);
        law.apply(EffectKind::BumpStop, &both).unwrap();
        assert_eq!(law.parameters(EffectKind::BumpStop).unwrap(), both);
        // 1 mm past each gap.
        assert!((law.force(0.011, 0.0, 0.0) - (110.0 + 100.0)).abs() < 1e-9);
        assert!((law.force(-0.021, 0.0, 0.0) - (-210.0 - 300.0)).abs() < 1e-9);
        let mut one = both.clone();
        one.remove("gap_m");
        let err = ElementLaw::linear(1e4, 100.0)
            .apply(EffectKind::BumpStop, &one)
            .unwrap_err();
        assert!(err.to_string().contains("both sides"), "{err}");
    }

    #[test]
    fn an_energy_source_is_refused_naming_the_field() {
        let map = |pairs: &[(&str, f64)]| -> BTreeMap<String, f64> {
            pairs.iter().map(|(k, v)| (k.to_string(), *v)).collect()
        };
        // Each effect with its sign-constrained parameter negative, the field it must name.
        let cases: [(EffectKind, BTreeMap<String, f64>, &str); 6] = [
            (
                EffectKind::CoulombFriction,
                map(&[("force_n", -20.0)]),
                "force_n",
            ),
            (
                EffectKind::BumpStop,
                map(&[("gap_m", 0.01), ("stiffness_n_per_m", -1e3)]),
                "stiffness_n_per_m",
            ),
            (
                EffectKind::BumpStop,
                map(&[
                    ("gap_m", 0.01),
                    ("rebound_gap_m", 0.02),
                    ("stiffness_n_per_m", 1e5),
                    ("rebound_stiffness_n_per_m", -3e5),
                ]),
                "rebound_stiffness_n_per_m",
            ),
            (
                EffectKind::QuadraticDamping,
                map(&[("damping_n_s2_per_m2", -5.0)]),
                "damping_n_s2_per_m2",
            ),
            (
                EffectKind::AsymmetricDamping,
                map(&[("bump_n_s_per_m", -10.0), ("rebound_n_s_per_m", 120.0)]),
                "bump_n_s_per_m",
            ),
            (
                EffectKind::AsymmetricDamping,
                map(&[("bump_n_s_per_m", 80.0), ("rebound_n_s_per_m", -1.0)]),
                "rebound_n_s_per_m",
            ),
        ];
        for (kind, params, field) in cases {
            let mut law = ElementLaw::linear(1e4, 100.0);
            let before = law.clone();
            let err = law.apply(kind, &params).unwrap_err().to_string();
            assert!(err.contains(field) && err.contains(">= 0"), "{kind}: {err}");
            assert_eq!(law, before, "{kind}: a refused effect changes nothing");
            // The same values set directly make the law active, not passive.
            let mut ok = params.clone();
            for v in ok.values_mut() {
                *v = v.abs();
            }
            let mut law = ElementLaw::linear(1e4, 100.0);
            law.apply(kind, &ok).unwrap();
            assert!(law.passive(), "{kind}");
        }
        let mut pulling = ElementLaw::linear(1e4, 100.0);
        pulling.bump = Some((0.01, -1e3));
        assert!(!pulling.passive());
        let mut source = ElementLaw::linear(1e4, 100.0);
        source.c_abs = Some(150.0);
        assert!(!source.passive());
        // A softening cubic is not an energy source by itself.
        let mut softening = ElementLaw::linear(1e4, 100.0);
        softening.k3 = Some(-1e6);
        assert!(softening.passive());
    }

    /// The law written out effect by effect from the module documentation, each `Option`
    /// matched in turn: the oracle of the unpacked arithmetic.
    fn reference(law: &ElementLaw, x: f64, v: f64, z: f64) -> (f64, f64, f64) {
        let xs = match law.backlash {
            Some(b) => x - x.max(-b).min(b),
            None => x,
        };
        let mut f = law.k * xs + law.c * v;
        if law.hysteresis.is_some() {
            f += law.k_h * z;
        }
        if let Some(k3) = law.k3 {
            f += k3 * xs * xs * xs;
        }
        if let Some(ca) = law.c_abs {
            f += ca * v.abs();
        }
        if let Some(c2) = law.c2 {
            f += c2 * v * v.abs();
        }
        if let Some((fc, veps)) = law.coulomb {
            f += fc * (v / veps).tanh();
        }
        if let Some((gap, kb)) = law.bump {
            f += kb * (x - gap).max(0.0);
        }
        if let Some((gap, kb)) = law.rebound {
            f += kb * (x + gap).min(0.0);
        }
        let clipped = match law.lift_off {
            Some(p) if p + f < 0.0 => -p,
            _ => f,
        };
        let rate = match law.hysteresis {
            Some(bw) => {
                let vs = match law.backlash {
                    Some(b) if x.abs() <= b => 0.0,
                    _ => v,
                };
                bw.rate(vs, z)
            }
            None => 0.0,
        };
        (f, clipped, rate)
    }

    #[test]
    fn the_law_is_its_effects_summed_bit_for_bit() {
        // Every set of element effects, at compressions and rates on both sides of each
        // effect's thresholds (and at both zeros), through the unpacked law (with its
        // dispatch on the effect set) and through `ElementLaw`.
        for set in 0u32..512 {
            let on = |bit: u32| set & (1 << bit) != 0;
            let mut law = ElementLaw::linear(2e4, 150.0);
            if on(0) {
                law.k = 1e4;
                law.k_h = 1e4;
                law.hysteresis = Some(BoucWen {
                    a: 1.0,
                    beta: 300.0,
                    gamma: -50.0,
                    n: if set % 3 == 0 { 1.0 } else { 1.7 },
                });
            }
            if on(1) {
                law.backlash = Some(2e-3);
            }
            if on(2) {
                law.k3 = Some(3e8);
            }
            if on(3) {
                law.c_abs = Some(-40.0);
            }
            if on(4) {
                law.c2 = Some(80.0);
            }
            if on(5) {
                law.coulomb = Some((25.0, 1e-2));
            }
            if on(6) {
                law.bump = Some((5e-3, 2e5));
            }
            if on(7) {
                law.rebound = Some((7e-3, 1e5));
            }
            if on(8) {
                law.lift_off = Some(150.0);
            }
            let fast = CompiledLaw::new(&law);
            for x in [
                -0.02, -7.5e-3, -2e-3, -1e-4, -0.0, 0.0, 1e-4, 2e-3, 5.5e-3, 0.02,
            ] {
                for v in [-0.3, -0.01, -0.0, 0.0, 0.004, 0.5] {
                    for z in [-3e-3, 0.0, 1e-3] {
                        let at = format!("effects {set:#b}, x {x}, v {v}, z {z}");
                        let (unclipped, force, rate) = reference(&law, x, v, z);
                        for (got, want, what) in [
                            (fast.force(x, v, z), force, "force"),
                            (law.force(x, v, z), force, "law force"),
                            (fast.force_unclipped(x, v, z), unclipped, "unclipped"),
                            (law.force_unclipped(x, v, z), unclipped, "law unclipped"),
                            (fast.state_rate(x, v, z), rate, "state rate"),
                            (law.state_rate(x, v, z), rate, "law state rate"),
                        ] {
                            assert_eq!(got.to_bits(), want.to_bits(), "{what}, {at}");
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn lift_off_clips_at_minus_preload() {
        let mut law = ElementLaw::linear(1e4, 0.0);
        law.lift_off = Some(100.0);
        assert_eq!(law.force(-0.005, 0.0, 0.0), -50.0);
        assert_eq!(law.force(-0.05, 0.0, 0.0), -100.0);
    }

    #[test]
    fn input_law_delays_limits_and_saturates() {
        let u: Vec<f64> = (0..100).map(|i| i as f64).collect();
        let law = InputLaw {
            delay_s: Some(0.0025),
            ..InputLaw::default()
        };
        let y = law.transform(&u, 0.001);
        assert!((y[50] - 47.5).abs() < 1e-12);
        let law = InputLaw {
            rate_limit: Some(500.0),
            saturation: Some((-5.0, 20.0)),
            ..InputLaw::default()
        };
        let y = law.transform(&u, 0.001);
        assert!((y[10] - 5.0).abs() < 1e-12);
        assert_eq!(y[99], 20.0);
        let down: Vec<f64> = u.iter().map(|v| -v).collect();
        assert_eq!(law.transform(&down, 0.001)[99], -5.0);
    }

    #[test]
    fn input_play_holds_until_the_input_moves_past_the_gap() {
        // Up 0 -> 10, back down to 4, up again to 8.
        let u: Vec<f64> = (0..=10)
            .chain((4..10).rev())
            .chain(5..=8)
            .map(f64::from)
            .collect();
        let law = InputLaw {
            backlash: Some(2.0),
            ..InputLaw::default()
        };
        let y = law.transform(&u, 1.0);
        // Follows 2 behind on the way up, holds at 8 while the input comes back to 6, then
        // follows 2 ahead; holds again at 6 until the input passes 8.
        assert_eq!(y[10], 8.0);
        assert_eq!(&y[11..14], &[8.0, 8.0, 8.0]);
        assert_eq!(y[16], 6.0);
        assert_eq!(y[y.len() - 1], 6.0);
        assert!(y.iter().zip(&u).all(|(a, b)| (a - b).abs() <= 2.0));
    }

    #[test]
    fn input_parameters_round_trip_and_saturation_takes_one_or_two_limits() {
        let map = |pairs: &[(&str, f64)]| -> BTreeMap<String, f64> {
            pairs.iter().map(|(k, v)| (k.to_string(), *v)).collect()
        };
        let mut law = InputLaw::default();
        law.apply(EffectKind::Saturation, &map(&[("limit", 3.0)]))
            .unwrap();
        assert_eq!(law.saturation, Some((-3.0, 3.0)));
        let two = map(&[("lower_limit", -1.0), ("upper_limit", 4.0)]);
        law.apply(EffectKind::Saturation, &two).unwrap();
        assert_eq!(law.parameters(EffectKind::Saturation).unwrap(), two);
        let both = map(&[("limit", 3.0), ("upper_limit", 4.0)]);
        assert!(InputLaw::default()
            .apply(EffectKind::Saturation, &both)
            .is_err());
        let crossed = map(&[("lower_limit", 2.0), ("upper_limit", 1.0)]);
        let err = InputLaw::default()
            .apply(EffectKind::Saturation, &crossed)
            .unwrap_err();
        assert!(err.to_string().contains("upper_limit"), "{err}");
        let play = map(&[("half_gap_m", 0.002)]);
        law.apply(EffectKind::Backlash, &play).unwrap();
        assert_eq!(law.parameters(EffectKind::Backlash).unwrap(), play);
        assert_eq!(
            law.kinds(),
            vec![EffectKind::Saturation, EffectKind::Backlash]
        );
        assert!(InputLaw::default()
            .apply(
                EffectKind::CubicStiffness,
                &map(&[("stiffness_n_per_m3", 1.0)])
            )
            .is_err());
    }
}
