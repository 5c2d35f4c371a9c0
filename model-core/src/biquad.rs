//! Second-order sections (biquads) and fixed-length cascades of them, in delta-operator form.
//!
//! # Why the delta form
//! A direct-form biquad `H(z) = (b0 + b1 z⁻¹ + b2 z⁻²) / (1 + a1 z⁻¹ + a2 z⁻²)` with a 1 Hz
//! resonance sampled at 5 kHz has `a1 ≈ -2 + 1.6e-6`: in `f32` (spacing 2.4e-7 near 2) the
//! pole is only known to about 15 %, and round-off noise is amplified by the nearly
//! cancelling feedback. Substituting `q = z - 1` gives
//!
//! ```text
//! H = (β0 + β1 q⁻¹ + β2 q⁻²) / (1 + α1 q⁻¹ + α2 q⁻²)
//! α1 = 2 + a1          α2 = 1 + a1 + a2
//! β0 = b0              β1 = 2 b0 + b1          β2 = b0 + b1 + b2
//! ```
//!
//! where `q⁻¹ = 1/(z - 1)` is an accumulator. The small numbers `α1`, `α2` are now stored with
//! full relative precision (for poles `p1`, `p2`: `α1 = (1-p1) + (1-p2)`,
//! `α2 = (1-p1)(1-p2)`), and the transposed structure
//!
//! ```text
//! y   = β0 u + s1
//! s1 += β1 u - α1 y + s2
//! s2 += β2 u - α2 y
//! ```
//!
//! accumulates increments instead of re-computing large nearly-cancelling products.
//! Host-side design (`mil-discretise`) computes `α`, `β` from poles and zeros in `f64`.
//!
//! # Coefficient swaps
//! Coefficients are plain values apart from the state. A swap between two steps keeps the
//! state; the transient that follows is bounded by the state's size times the new section's
//! gain (checked by property tests), never a blow-up.

use crate::params::{Field, ParamError};
use crate::MAX_SECTIONS;

/// Stability margin a command filter section must keep: every pole within `1 − POLE_MARGIN`
/// of the origin, i.e. a time constant of at most 1 000 000 samples (500 s at 2 kHz, 50 s
/// at 20 kHz). Beyond any useful command filter (a 1 Hz mode with ζ = 0.01 at 20 kHz has a
/// margin of 3.1e-6), and far above the pole shift the `f32` rounding of the delta
/// coefficients can cause, so an accepted filter stays stable as stored.
pub const POLE_MARGIN: f32 = 1.0e-6;

/// Allowed range of the delta-form feed-forward coefficients β (dimensionless): a section's
/// gain is bounded by the β's, so this bounds it at about 60 dB.
pub const FILTER_BETA: crate::params::Range = crate::params::Range::new(-1.0e3, 1.0e3);
/// Allowed range of the delta-form feedback coefficients α (dimensionless): a stable
/// section has `α1 = (1 − p1) + (1 − p2)` and `α2 = (1 − p1)(1 − p2)` in `(0, 4)`; stability
/// itself is checked on the whole set.
pub const FILTER_ALPHA: crate::params::Range = crate::params::Range::new(0.0, 4.0);

/// Coefficients of one second-order section in delta-operator form (see the module docs).
///
/// Dimensionless; the filter's input and output share a unit.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct BiquadCoefficients {
    /// `β0 = b0`: direct feed-through.
    pub beta0: f32,
    /// `β1 = 2 b0 + b1`.
    pub beta1: f32,
    /// `β2 = b0 + b1 + b2` (the numerator at `z = 1`).
    pub beta2: f32,
    /// `α1 = 2 + a1`.
    pub alpha1: f32,
    /// `α2 = 1 + a1 + a2` (the denominator at `z = 1`).
    pub alpha2: f32,
}

impl Default for BiquadCoefficients {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl BiquadCoefficients {
    /// The section that passes its input through unchanged (`b = [1, 0, 0]`, `a = [0, 0]`).
    pub const IDENTITY: Self = Self {
        beta0: 1.0,
        beta1: 2.0,
        beta2: 1.0,
        alpha1: 2.0,
        alpha2: 1.0,
    };

    /// Converts direct-form coefficients `b = [b0, b1, b2]`, `a = [a1, a2]` (with `a0 = 1`)
    /// computed in `f64`. Poles very close to `z = 1` lose precision already in `a`; design
    /// such sections from poles and zeros instead (`mil-discretise`).
    pub fn from_direct_form(b: [f64; 3], a: [f64; 2]) -> Self {
        let [b0, b1, b2] = b;
        let [a1, a2] = a;
        Self {
            beta0: b0 as f32,
            beta1: (2.0 * b0 + b1) as f32,
            beta2: (b0 + b1 + b2) as f32,
            alpha1: (2.0 + a1) as f32,
            alpha2: (1.0 + a1 + a2) as f32,
        }
    }

    /// The equivalent direct-form coefficients `(b, a)` in `f64`.
    pub fn to_direct_form(&self) -> ([f64; 3], [f64; 2]) {
        let beta0 = f64::from(self.beta0);
        let beta1 = f64::from(self.beta1);
        let beta2 = f64::from(self.beta2);
        let alpha1 = f64::from(self.alpha1);
        let alpha2 = f64::from(self.alpha2);
        let b0 = beta0;
        let b1 = beta1 - 2.0 * beta0;
        let b2 = beta2 - b0 - b1;
        let a1 = alpha1 - 2.0;
        let a2 = alpha2 - 1.0 - a1;
        ([b0, b1, b2], [a1, a2])
    }

    /// `true` when every coefficient is finite and both poles lie strictly inside the unit
    /// circle (Jury conditions written in the delta coefficients, exact for small `α`).
    pub fn is_stable(&self) -> bool {
        let all_finite = [self.beta0, self.beta1, self.beta2, self.alpha1, self.alpha2]
            .iter()
            .all(|c| c.is_finite());
        let (a1, a2) = (self.alpha1, self.alpha2);
        all_finite
            && a2 > 0.0 // 1 + a1 + a2 > 0
            && 4.0 - 2.0 * a1 + a2 > 0.0 // 1 - a1 + a2 > 0
            && a1 > a2 // a2 < 1
            && a1 - a2 < 2.0 // a2 > -1
    }

    /// The section's distance from instability: `1 − max |pole|` (1 for a section without
    /// poles, negative when unstable), computed in `f64` from the delta coefficients, where
    /// `α1 = (1 − p1) + (1 − p2)` and `α2 = (1 − p1)(1 − p2)` keep a slow pole's distance
    /// from `z = 1` without cancellation. NaN when a coefficient is not finite.
    pub fn pole_margin(&self) -> f64 {
        let a1 = f64::from(self.alpha1);
        let a2 = f64::from(self.alpha2);
        let disc = a1 * a1 - 4.0 * a2;
        if disc < 0.0 {
            // Complex pair: |p|² = p1 p2 = 1 − α1 + α2.
            let r2 = 1.0 - a1 + a2;
            1.0 - libm::sqrt(r2.max(0.0))
        } else {
            // Real poles p = 1 − d, d the roots of d² − α1 d + α2 = 0 (stable form).
            let q = 0.5 * (a1 + libm::copysign(libm::sqrt(disc), a1));
            let (d1, d2) = if q == 0.0 { (0.0, 0.0) } else { (q, a2 / q) };
            let radius = |d: f64| (1.0 - d).abs();
            1.0 - radius(d1).max(radius(d2))
        }
    }

    /// Gain at DC (`z = 1`): `β2 / α2`. Infinite for a section with a pole at `z = 1`.
    pub fn dc_gain(&self) -> f32 {
        self.beta2 / self.alpha2
    }

    /// Advances `state` by one sample with input `u`; returns the output.
    #[inline]
    pub fn step(&self, state: &mut BiquadState, u: f32) -> f32 {
        let y = self.beta0 * u + state.s1;
        state.s1 += self.beta1 * u - self.alpha1 * y + state.s2;
        state.s2 += self.beta2 * u - self.alpha2 * y;
        y
    }
}

/// State of one delta-form second-order section.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BiquadState {
    /// First accumulator.
    pub s1: f32,
    /// Second accumulator.
    pub s2: f32,
}

impl BiquadState {
    /// The zero state.
    pub const ZERO: Self = Self { s1: 0.0, s2: 0.0 };

    /// The state in which `coefficients` rest at a constant input `u` with output
    /// `dc_gain * u` (bumpless start on a constant signal). Falls back to zero for sections
    /// with a pole at `z = 1` or non-finite results.
    pub fn steady(coefficients: &BiquadCoefficients, u: f32) -> Self {
        let y = coefficients.dc_gain() * u;
        // At rest: s2 increments vanish (β2 u = α2 y), s1 = y - β0 u, and the s1 increment
        // vanishes: s2 = α1 y - β1 u.
        let s1 = y - coefficients.beta0 * u;
        let s2 = coefficients.alpha1 * y - coefficients.beta1 * u;
        if y.is_finite() && s1.is_finite() && s2.is_finite() {
            Self { s1, s2 }
        } else {
            Self::ZERO
        }
    }

    /// `true` when both accumulators are finite.
    pub fn is_finite(&self) -> bool {
        self.s1.is_finite() && self.s2.is_finite()
    }
}

/// Coefficients of a cascade of up to [`MAX_SECTIONS`] sections. Unused sections hold
/// [`BiquadCoefficients::IDENTITY`]; `sections` says how many are applied.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct CascadeCoefficients {
    /// Number of sections applied, `0..=MAX_SECTIONS` (0: the filter passes its input through).
    pub sections: u32,
    /// The sections, applied in order from index 0.
    pub section: [BiquadCoefficients; MAX_SECTIONS],
}

impl Default for CascadeCoefficients {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl CascadeCoefficients {
    /// The pass-through cascade (no sections).
    pub const IDENTITY: Self = Self {
        sections: 0,
        section: [BiquadCoefficients::IDENTITY; MAX_SECTIONS],
    };

    /// Every coefficient zero (not a valid filter): a place holder of zero bits.
    pub const ZERO: Self = Self {
        sections: 0,
        section: [BiquadCoefficients {
            beta0: 0.0,
            beta1: 0.0,
            beta2: 0.0,
            alpha1: 0.0,
            alpha2: 0.0,
        }; MAX_SECTIONS],
    };

    /// A cascade of the given sections; `None` if more than [`MAX_SECTIONS`] are given.
    pub fn from_sections(sections: &[BiquadCoefficients]) -> Option<Self> {
        if sections.len() > MAX_SECTIONS {
            return None;
        }
        let mut c = Self::IDENTITY;
        for (dst, src) in c.section.iter_mut().zip(sections) {
            *dst = *src;
        }
        c.sections = sections.len() as u32;
        Some(c)
    }

    /// The sections that are applied.
    pub fn active(&self) -> &[BiquadCoefficients] {
        let n = (self.sections as usize).min(MAX_SECTIONS);
        self.section.get(..n).unwrap_or(&[])
    }

    /// Validates the cascade: section count in range, every applied section finite and stable
    /// with margin (every pole within `1 − POLE_MARGIN` of the origin), and a finite DC gain.
    pub fn validate(&self) -> Result<(), ParamError> {
        if self.sections as usize > MAX_SECTIONS {
            return Err(ParamError::OutOfRange(Field::CommandFilter));
        }
        for s in self.active() {
            if ![s.beta0, s.beta1, s.beta2, s.alpha1, s.alpha2]
                .iter()
                .all(|c| c.is_finite())
            {
                return Err(ParamError::NotFinite(Field::CommandFilter));
            }
            if !s.is_stable() || s.pole_margin() < f64::from(POLE_MARGIN) {
                return Err(ParamError::Unstable(Field::CommandFilter));
            }
        }
        // Stable sections can still have a subnormal α2 whose DC gain overflows.
        if !self.dc_gain().is_finite() {
            return Err(ParamError::Unstable(Field::CommandFilter));
        }
        Ok(())
    }

    /// Gain of the whole cascade at DC.
    pub fn dc_gain(&self) -> f32 {
        self.active()
            .iter()
            .map(BiquadCoefficients::dc_gain)
            .product()
    }

    /// Advances `state` by one sample; returns the cascade's output.
    #[inline]
    pub fn step(&self, state: &mut CascadeState, u: f32) -> f32 {
        self.active()
            .iter()
            .zip(state.section.iter_mut())
            .fold(u, |x, (c, s)| c.step(s, x))
    }
}

/// State of a cascade: one [`BiquadState`] per possible section.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CascadeState {
    /// Per-section state.
    pub section: [BiquadState; MAX_SECTIONS],
}

impl CascadeState {
    /// The zero state.
    pub const ZERO: Self = Self {
        section: [BiquadState::ZERO; MAX_SECTIONS],
    };

    /// The state in which `coefficients` rest at constant input `u` (bumpless start).
    pub fn steady(coefficients: &CascadeCoefficients, u: f32) -> Self {
        let mut state = Self::ZERO;
        let mut x = u;
        for (c, s) in coefficients.active().iter().zip(state.section.iter_mut()) {
            *s = BiquadState::steady(c, x);
            x *= c.dc_gain();
        }
        state
    }

    /// `true` when every accumulator is finite. Branch-free: NaN and infinities propagate
    /// through the sum (a finite sum that overflows also reports `false`, which only happens
    /// with accumulators near `f32::MAX`, i.e. a filter that has blown up anyway).
    #[inline]
    pub fn is_finite(&self) -> bool {
        self.section
            .iter()
            .map(|s| s.s1 + s.s2)
            .sum::<f32>()
            .is_finite()
    }
}

/// A cascade with its own coefficients and state, for use outside the controller.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Cascade {
    /// The coefficients (replace them between two steps to retune).
    pub coefficients: CascadeCoefficients,
    /// The state.
    pub state: CascadeState,
}

impl Cascade {
    /// A cascade at rest with the given coefficients.
    pub fn new(coefficients: CascadeCoefficients) -> Self {
        Self {
            coefficients,
            state: CascadeState::ZERO,
        }
    }

    /// One sample.
    #[inline]
    pub fn step(&mut self, u: f32) -> f32 {
        self.coefficients.step(&mut self.state, u)
    }
}
