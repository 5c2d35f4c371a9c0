//! The nonlinear element laws of the substructure: the real-time part of the effect
//! vocabulary `mil diagnose` names on elements (`mil_structure::effects` on the host, whose
//! laws these are, in `f32`).
//!
//! An element is a spring-damper whose compression `x` (m) and compression rate `v` (m/s)
//! give the force pushing its ends apart (N):
//!
//! ```text
//! F = k x + c(v) v + k3 x³ + c2 v |v| + F_c tanh(v / v_eps)
//!     + k_b max(x − g_b, 0) + k_r min(x + g_r, 0)
//! c(v) = c_bump for v >= 0, c_rebound for v < 0            (asymmetric damping)
//! lift-off: F = max(P + F, 0) − P                          (the element only pushes)
//! ```
//!
//! with `P` the element's static preload. Each effect is off at its zero parameter (a bump
//! stop with zero stiffness, friction with zero force, lift-off with its switch at 0); with
//! `c_bump = c_rebound` the damping is linear. Dry friction is the smoothed law
//! `F_c tanh(v / v_eps)`: its slope at rest, `F_c / v_eps`, is a viscous damper, so a fixed
//! step resolves it when `F_c / v_eps` is small against the element's stiffness times the
//! step (choose `v_eps` no smaller than the velocity resolution of the board's estimate).
//!
//! The force is evaluated in a fixed number of operations whatever the state (no loops, no
//! branches that depend on more than signs), and is finite for a valid element
//! ([`ElementLaw::validate`]) at every compression within ±[`ELEMENT_STATE_BOUND`] m and rate
//! within ±[`ELEMENT_STATE_BOUND`] m/s (far beyond any rig's stroke; the controller faults on
//! measurements out of range before they reach a model).

use crate::params::{Field, ParamError, Range};

/// Allowed stiffnesses of an element (N/m): its linear spring and its bump stops.
pub const ELEMENT_STIFFNESS: Range = Range::new(0.0, 1.0e9);
/// Allowed dampings of an element (N s/m).
pub const ELEMENT_DAMPING: Range = Range::new(0.0, 1.0e7);
/// Allowed cubic stiffness of an element (N/m³; negative: softening).
pub const ELEMENT_CUBIC_STIFFNESS: Range = Range::new(-1.0e15, 1.0e15);
/// Allowed quadratic damping of an element (N s²/m²).
pub const ELEMENT_QUADRATIC_DAMPING: Range = Range::new(0.0, 1.0e9);
/// Allowed bump-stop gaps (m).
pub const ELEMENT_GAP: Range = Range::new(0.0, 1.0);
/// Allowed dry-friction forces (N).
pub const ELEMENT_FRICTION: Range = Range::new(0.0, 1.0e6);
/// Allowed smoothing velocities of dry friction (m/s): above zero, so the law is smooth.
pub const ELEMENT_FRICTION_VELOCITY: Range = Range::new(1.0e-6, 10.0);
/// Allowed static preloads (N).
pub const ELEMENT_PRELOAD: Range = Range::new(-1.0e7, 1.0e7);
/// Compressions (m) and rates (m/s) up to which a valid element's force is finite.
pub const ELEMENT_STATE_BOUND: f32 = 1.0e3;

/// One element's law (see the module documentation). All-zero is a missing element (no
/// force).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct ElementLaw {
    /// Linear stiffness `k` (N/m).
    pub stiffness: f32,
    /// Damping in compression `c_bump` (N s/m, `v >= 0`).
    pub bump_damping: f32,
    /// Damping in extension `c_rebound` (N s/m, `v < 0`); equal to `bump_damping` for a
    /// linear damper.
    pub rebound_damping: f32,
    /// Cubic stiffness `k3` (N/m³).
    pub cubic_stiffness: f32,
    /// Quadratic (orifice) damping `c2` (N s²/m²).
    pub quadratic_damping: f32,
    /// Bump stop in compression: gap `g_b` (m) …
    pub bump_gap: f32,
    /// … and stiffness `k_b` (N/m; 0: no stop).
    pub bump_stiffness: f32,
    /// Stop in extension: gap `g_r` (m) …
    pub rebound_gap: f32,
    /// … and stiffness `k_r` (N/m; 0: no stop).
    pub rebound_stiffness: f32,
    /// Dry friction `F_c` (N; 0: none).
    pub friction_force: f32,
    /// Its smoothing velocity `v_eps` (m/s).
    pub friction_velocity: f32,
    /// Static preload `P` (N), what the element carries at rest; the lift-off threshold.
    pub preload: f32,
    /// 1: the element only pushes (lift-off at `P + F = 0`); 0: it pulls too.
    pub lift_off: u32,
}

impl ElementLaw {
    /// Every field zero bits (the smoothing velocity too: not a law to evaluate), a place
    /// holder in zero-initialised blanks.
    pub const ZERO: Self = Self {
        friction_velocity: 0.0,
        ..Self::NONE
    };

    /// No element: every parameter zero (no force).
    pub const NONE: Self = Self {
        stiffness: 0.0,
        bump_damping: 0.0,
        rebound_damping: 0.0,
        cubic_stiffness: 0.0,
        quadratic_damping: 0.0,
        bump_gap: 0.0,
        bump_stiffness: 0.0,
        rebound_gap: 0.0,
        rebound_stiffness: 0.0,
        friction_force: 0.0,
        friction_velocity: 1.0e-3,
        preload: 0.0,
        lift_off: 0,
    };

    /// A linear spring-damper `k`, `c`.
    pub const fn linear(stiffness: f32, damping: f32) -> Self {
        Self {
            stiffness,
            bump_damping: damping,
            rebound_damping: damping,
            ..Self::NONE
        }
    }

    /// Checks every parameter against its range (a stiffness, damping, gap or friction
    /// below zero, a non-finite value, a lift-off switch other than 0 or 1, a lift-off
    /// element with a negative preload).
    pub fn validate(&self) -> Result<(), ParamError> {
        let f = Field::SubstructureElement;
        for (range, value) in [
            (&ELEMENT_STIFFNESS, self.stiffness),
            (&ELEMENT_DAMPING, self.bump_damping),
            (&ELEMENT_DAMPING, self.rebound_damping),
            (&ELEMENT_CUBIC_STIFFNESS, self.cubic_stiffness),
            (&ELEMENT_QUADRATIC_DAMPING, self.quadratic_damping),
            (&ELEMENT_GAP, self.bump_gap),
            (&ELEMENT_STIFFNESS, self.bump_stiffness),
            (&ELEMENT_GAP, self.rebound_gap),
            (&ELEMENT_STIFFNESS, self.rebound_stiffness),
            (&ELEMENT_FRICTION, self.friction_force),
            (&ELEMENT_FRICTION_VELOCITY, self.friction_velocity),
            (&ELEMENT_PRELOAD, self.preload),
        ] {
            range.check(f, value)?;
        }
        match self.lift_off {
            0 => Ok(()),
            1 if self.preload >= 0.0 => Ok(()),
            1 => Err(ParamError::Inconsistent(f)),
            _ => Err(ParamError::OutOfRange(f)),
        }
    }

    /// The force (N, pushing the ends apart) at compression `x` (m) and compression rate
    /// `v` (m/s), relative to the static preload: 0 at rest.
    #[inline]
    pub fn force(&self, x: f32, v: f32) -> f32 {
        let damping = if v >= 0.0 {
            self.bump_damping
        } else {
            self.rebound_damping
        };
        let friction = if self.friction_force > 0.0 {
            self.friction_force * libm::tanhf(v / self.friction_velocity)
        } else {
            0.0
        };
        let f = self.stiffness * x
            + damping * v
            + self.cubic_stiffness * x * x * x
            + self.quadratic_damping * v * v.abs()
            + friction
            + self.bump_stiffness * positive_part(x - self.bump_gap)
            + self.rebound_stiffness * negative_part(x + self.rebound_gap);
        if self.lift_off != 0 && self.preload + f < 0.0 {
            -self.preload
        } else {
            f
        }
    }
}

/// `max(x, 0)` by a compare (on the Cortex-M4 `f32::max` is a call to `fmaxf`); `x` is
/// finite here (the state and the inputs are checked).
#[inline]
fn positive_part(x: f32) -> f32 {
    if x > 0.0 {
        x
    } else {
        0.0
    }
}

/// `min(x, 0)` by a compare (see [`positive_part`]).
#[inline]
fn negative_part(x: f32) -> f32 {
    if x < 0.0 {
        x
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each effect against its law written out here, at points where it matters.
    #[test]
    fn each_effect_is_its_law() {
        let lin = ElementLaw::linear(1.0e5, 2.0e3);
        assert_eq!(lin.force(0.0, 0.0), 0.0);
        assert_eq!(lin.force(0.01, -0.1), 1.0e3 - 200.0);
        let asym = ElementLaw {
            rebound_damping: 3.0e3,
            ..lin
        };
        assert_eq!(asym.force(0.0, 0.1), 200.0);
        assert_eq!(asym.force(0.0, -0.1), -300.0);
        let cubic = ElementLaw {
            cubic_stiffness: 1.0e9,
            ..ElementLaw::NONE
        };
        assert!((cubic.force(0.01, 0.0) - 1.0e3).abs() < 1e-3);
        let quad = ElementLaw {
            quadratic_damping: 1.0e4,
            ..ElementLaw::NONE
        };
        assert!((quad.force(0.0, -0.2) + 400.0).abs() < 1e-3);
        let stops = ElementLaw {
            bump_gap: 0.02,
            bump_stiffness: 5.0e5,
            rebound_gap: 0.03,
            rebound_stiffness: 2.0e5,
            ..ElementLaw::NONE
        };
        assert_eq!(stops.force(0.019, 0.0), 0.0);
        assert!((stops.force(0.025, 0.0) - 2.5e3).abs() < 1e-2);
        assert_eq!(stops.force(-0.029, 0.0), 0.0);
        assert!((stops.force(-0.04, 0.0) + 2.0e3).abs() < 1e-2);
        let dry = ElementLaw {
            friction_force: 50.0,
            friction_velocity: 1.0e-3,
            ..ElementLaw::NONE
        };
        assert!((dry.force(0.0, 1.0) - 50.0).abs() < 1e-3);
        assert!((dry.force(0.0, -1.0) + 50.0).abs() < 1e-3);
        assert_eq!(dry.force(0.0, 0.0), 0.0);
        let tyre = ElementLaw {
            preload: 1667.7,
            lift_off: 1,
            ..ElementLaw::linear(2.5e5, 500.0)
        };
        assert_eq!(tyre.force(-0.1, 0.0), -1667.7);
        assert!((tyre.force(-0.001, 0.0) + 250.0).abs() < 1e-3);
    }

    proptest::proptest! {
        /// Any valid element, anywhere within the state bound: a finite force, and exactly
        /// `−P` when lifted off.
        #[test]
        fn the_force_is_finite_within_the_bound(
            k in 0.0f32..1.0e9, cb in 0.0f32..1.0e7, cr in 0.0f32..1.0e7,
            k3 in -1.0e15f32..1.0e15, c2 in 0.0f32..1.0e9,
            gb in 0.0f32..1.0, kb in 0.0f32..1.0e9, gr in 0.0f32..1.0, kr in 0.0f32..1.0e9,
            fc in 0.0f32..1.0e6, ve in 1.0e-6f32..10.0, p in 0.0f32..1.0e7, lift in 0u32..2,
            x in -ELEMENT_STATE_BOUND..ELEMENT_STATE_BOUND,
            v in -ELEMENT_STATE_BOUND..ELEMENT_STATE_BOUND,
        ) {
            let e = ElementLaw {
                stiffness: k, bump_damping: cb, rebound_damping: cr, cubic_stiffness: k3,
                quadratic_damping: c2, bump_gap: gb, bump_stiffness: kb, rebound_gap: gr,
                rebound_stiffness: kr, friction_force: fc, friction_velocity: ve, preload: p,
                lift_off: lift,
            };
            proptest::prop_assert_eq!(e.validate(), Ok(()));
            let f = e.force(x, v);
            proptest::prop_assert!(f.is_finite(), "{:?} at {} m, {} m/s: {}", e, x, v, f);
            if lift == 1 {
                proptest::prop_assert!(f >= -p, "{} below -P", f);
            }
        }
    }

    /// What validation refuses, each naming the element field.
    #[test]
    fn bad_elements_are_refused() {
        let f = Field::SubstructureElement;
        let ok = ElementLaw::linear(1.0e5, 1.0e3);
        assert_eq!(ok.validate(), Ok(()));
        assert_eq!(ElementLaw::NONE.validate(), Ok(()));
        for bad in [
            ElementLaw {
                stiffness: -1.0,
                ..ok
            },
            ElementLaw {
                bump_gap: -0.01,
                ..ok
            },
            ElementLaw {
                friction_force: 10.0,
                friction_velocity: 0.0,
                ..ok
            },
            ElementLaw { lift_off: 2, ..ok },
        ] {
            assert_eq!(bad.validate(), Err(ParamError::OutOfRange(f)), "{bad:?}");
        }
        assert_eq!(
            ElementLaw {
                rebound_damping: f32::NAN,
                ..ok
            }
            .validate(),
            Err(ParamError::NotFinite(f))
        );
        assert_eq!(
            ElementLaw {
                lift_off: 1,
                preload: -5.0,
                ..ok
            }
            .validate(),
            Err(ParamError::Inconsistent(f))
        );
    }
}
