//! Delta-form sections and cascades: exactness against the direct form, steady states,
//! boundedness under random stable coefficients and coefficient swaps.

mod common;
use common::*;
use model_core::{BiquadCoefficients, BiquadState, Cascade, CascadeCoefficients, CascadeState};
use proptest::prelude::*;

#[test]
fn delta_form_matches_direct_form_response() {
    // A 20 Hz, ζ = 0.1 resonance at 5 kHz, written in direct form (f64), converted, and its
    // response evaluated exactly in both forms: the conversion must be exact to f32 rounding.
    let dt = 2.0e-4;
    let (r, th) = (
        (-0.1 * 2.0 * std::f64::consts::PI * 20.0 * dt).exp(),
        2.0 * std::f64::consts::PI * 20.0 * dt,
    );
    let a = [-2.0 * r * th.cos(), r * r];
    let b = [0.3, 0.1, 0.05];
    let c = BiquadCoefficients::from_direct_form(b, a);
    for f in [0.5, 5.0, 20.0, 200.0, 2000.0] {
        let w = 2.0 * std::f64::consts::PI * f * dt;
        let z1 = (w.cos(), -w.sin()); // z^-1
        let z2 = ((2.0 * w).cos(), -(2.0 * w).sin());
        let num = (b[0] + b[1] * z1.0 + b[2] * z2.0, b[1] * z1.1 + b[2] * z2.1);
        let den = (1.0 + a[0] * z1.0 + a[1] * z2.0, a[0] * z1.1 + a[1] * z2.1);
        let h_direct = ((num.0.powi(2) + num.1.powi(2)) / (den.0.powi(2) + den.1.powi(2))).sqrt();
        let (re, im) = section_response(&c, f, dt);
        let h_delta = (re * re + im * im).sqrt();
        // Bound: f32 rounding of the α coefficients (relative 6e-8) amplified by the
        // resonance's sensitivity (~1/(2ζ ωT)) stays below 1e-3 relative.
        assert!(
            (h_delta / h_direct - 1.0).abs() < 1e-3,
            "f = {f}: {h_delta} vs {h_direct}"
        );
    }
    let (b2, a2) = c.to_direct_form();
    assert!((a2[0] - a[0]).abs() < 1e-6 && (a2[1] - a[1]).abs() < 1e-6);
    assert!((b2[0] - b[0]).abs() < 1e-7);
}

#[test]
fn slow_mode_keeps_precision_in_f32() {
    // 1 Hz, ζ = 0.05 at 5 kHz: the pole sum/product deviations from z = 1 are ~1e-5 and
    // ~1.6e-6; stored as α they keep f32 relative precision (error < 1e-6 relative).
    let dt = 2.0e-4;
    let w = 2.0 * std::f64::consts::PI * 1.0;
    let zeta: f64 = 0.05;
    let r = (-zeta * w * dt).exp();
    let th = w * (1.0 - zeta * zeta).sqrt() * dt;
    let c = section_from_polar((r, th), (0.0, 0.0), 1.0);
    let exact_alpha2 = 1.0 - 2.0 * r * th.cos() + r * r;
    assert!(((c.alpha2 as f64) / exact_alpha2 - 1.0).abs() < 1e-6);
    assert!(c.is_stable());
}

#[test]
fn steady_state_is_bumpless() {
    let c = section_from_polar((0.99, 0.05), (0.5, 0.3), 0.2);
    let mut s = BiquadState::steady(&c, 2.0);
    let y0 = c.dc_gain() * 2.0;
    for _ in 0..1000 {
        let y = c.step(&mut s, 2.0);
        assert!((y - y0).abs() <= 1e-4 * y0.abs().max(1.0), "{y} vs {y0}");
    }
}

#[test]
fn identity_cascade_passes_through() {
    let mut f = Cascade::new(CascadeCoefficients::IDENTITY);
    for k in 0..100 {
        let u = (k as f32 * 0.37).sin() * 1e3;
        assert_eq!(f.step(u), u);
    }
    let full = CascadeCoefficients::from_sections(&[BiquadCoefficients::IDENTITY; 4]).unwrap();
    let mut f = Cascade::new(full);
    for k in 0..100 {
        let u = (k as f32 * 0.37).sin() * 1e3;
        assert!((f.step(u) - u).abs() <= 1e-6 * u.abs().max(1.0));
    }
    assert!(CascadeCoefficients::from_sections(&[BiquadCoefficients::IDENTITY; 5]).is_none());
}

#[test]
fn unstable_sections_are_rejected() {
    let unstable = section_from_polar((1.001, 0.1), (0.0, 0.0), 1.0);
    assert!(!unstable.is_stable());
    let on_circle = section_from_polar((1.0, 0.1), (0.0, 0.0), 1.0);
    assert!(!on_circle.is_stable());
    let c = CascadeCoefficients::from_sections(&[unstable]).unwrap();
    assert!(c.validate().is_err());
    let nan = BiquadCoefficients {
        beta0: f32::NAN,
        ..BiquadCoefficients::IDENTITY
    };
    assert!(CascadeCoefficients::from_sections(&[nan])
        .unwrap()
        .validate()
        .is_err());
}

fn stable_section() -> impl Strategy<Value = BiquadCoefficients> {
    (
        0.0f64..0.999,
        0.0f64..std::f64::consts::PI,
        0.0f64..2.0,
        0.0f64..std::f64::consts::PI,
        0.05f64..5.0,
    )
        .prop_map(|(r, th, rz, thz, k)| section_from_polar((r, th), (rz, thz), k))
}

fn stable_cascade() -> impl Strategy<Value = CascadeCoefficients> {
    prop::collection::vec(stable_section(), 0..=model_core::MAX_SECTIONS)
        .prop_map(|s| CascadeCoefficients::from_sections(&s).unwrap())
        .prop_filter("stable in f32", |c| c.validate().is_ok())
}

fn l1_norm(c: &CascadeCoefficients) -> f64 {
    impulse_response_f64(c, 40_000)
        .iter()
        .map(|h| h.abs())
        .sum()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// Bounded input, bounded output: |y| <= ||h||₁ · max|u| (plus f32 rounding, 1e-3 rel).
    #[test]
    fn random_stable_filters_stay_bounded(c in stable_cascade(), seed in any::<u64>()) {
        let bound = l1_norm(&c);
        let mut f = Cascade::new(c);
        let mut x = seed;
        for _ in 0..4000 {
            x = x.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            let u = ((x >> 40) as f32 / (1u64 << 24) as f32) * 2.0 - 1.0;
            let y = f.step(u) as f64;
            prop_assert!(y.is_finite());
            prop_assert!(y.abs() <= bound * (1.0 + 1e-3) + 1e-4, "|y| = {} > {}", y.abs(), bound);
        }
    }

    /// A swap between two steps: the output after the swap is the new filter's zero-state
    /// response (<= ||h_B||₁ max|u|) plus its free response from the kept state; both are
    /// bounded, and so is the sum.
    #[test]
    fn coefficient_swaps_stay_bounded(a in stable_cascade(), b in stable_cascade(), seed in any::<u64>()) {
        let mut f = Cascade::new(a);
        let mut x = seed;
        let mut next_u = || {
            x = x.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((x >> 40) as f32 / (1u64 << 24) as f32) * 2.0 - 1.0
        };
        for _ in 0..2000 {
            f.step(next_u());
        }
        let kept: CascadeState = f.state;
        // Free response of B from the kept state, in f64, over a long horizon.
        let mut s: Vec<(f64, f64)> = kept.section.iter().map(|s| (s.s1 as f64, s.s2 as f64)).collect();
        let mut free_max: f64 = 0.0;
        for _ in 0..40_000 {
            let mut v = 0.0;
            for (st, sec) in s.iter_mut().zip(b.active()) {
                v = step_f64(sec, st, v);
            }
            free_max = free_max.max(v.abs());
        }
        // By linearity y = (zero-state response, |.| <= ||h_B||₁ · max|u|) + (free response).
        let bound = l1_norm(&b) + free_max;
        f.coefficients = b;
        for _ in 0..4000 {
            let y = f.step(next_u()) as f64;
            prop_assert!(y.is_finite());
            prop_assert!(y.abs() <= bound * (1.0 + 1e-3) + 1e-3, "|y| = {} > {}", y.abs(), bound);
        }
    }
}

/// A cascade must keep every pole within `1 − POLE_MARGIN` of the origin: `pole_margin` is
/// exact for complex and for real poles near `z = 1` and near `z = −1`, and `validate`
/// refuses a stable section too close to the unit circle.
#[test]
fn stability_needs_a_margin() {
    use model_core::POLE_MARGIN;
    let margin = f64::from(POLE_MARGIN);
    // Complex pairs: the margin is 1 − r.
    for r in [0.5, 0.99, 0.9999, 1.0 - 4.0 * margin] {
        let c = section_from_polar((r, 0.01), (0.0, 0.0), 1.0);
        assert!(
            (c.pole_margin() - (1.0 - r)).abs() < 1e-3 * (1.0 - r) + 1e-9,
            "r {r}: {}",
            c.pole_margin()
        );
        assert!(CascadeCoefficients::from_sections(&[c])
            .unwrap()
            .validate()
            .is_ok());
    }
    // Real poles from the delta coefficients: d = 1 − p for p = 0.3 and p = 1 − m/4 (slow),
    // and p = −(1 − m/4) (near z = −1).
    let real = |p1: f64, p2: f64| BiquadCoefficients {
        beta0: 1.0,
        beta1: 2.0,
        beta2: 1.0,
        alpha1: ((1.0 - p1) + (1.0 - p2)) as f32,
        alpha2: ((1.0 - p1) * (1.0 - p2)) as f32,
    };
    let slow = 1.0 - margin / 4.0;
    for (p1, p2, ok) in [
        (0.3, -0.2, true),
        (0.3, 1.0 - 2.0 * margin, true),
        (0.3, slow, false),
        (-slow, 0.1, false),
    ] {
        let c = real(p1, p2);
        assert!(c.is_stable(), "{p1} {p2}");
        let expected = 1.0 - f64::max(p1.abs(), p2.abs());
        // Near z = −1 the f32 α's carry the margin only to their resolution (about 2.4e-7
        // at α1 ≈ 3); near z = 1 the delta form keeps it to f32 relative precision.
        assert!(
            (c.pole_margin() - expected).abs() < 0.05 * expected + 5.0e-7,
            "{p1} {p2}: {} vs {expected}",
            c.pole_margin()
        );
        let v = CascadeCoefficients::from_sections(&[c]).unwrap().validate();
        assert_eq!(v.is_ok(), ok, "{p1} {p2}: {v:?}");
    }
    // A complex pair inside the circle but within the margin is refused.
    let tight = section_from_polar((1.0 - margin / 4.0, 0.01), (0.0, 0.0), 1.0);
    assert!(tight.is_stable());
    assert!(CascadeCoefficients::from_sections(&[tight])
        .unwrap()
        .validate()
        .is_err());
    // No poles at all (identity): margin 1.
    assert_eq!(BiquadCoefficients::IDENTITY.pole_margin(), 1.0);
}
