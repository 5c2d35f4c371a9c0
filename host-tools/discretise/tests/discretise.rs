//! Accuracy tests of the discretisations and of the f32 coefficients they produce.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing)]

mod common;

use common::{logspace, mat_rel, rel, second_order_step, two_dof, warped};
use mil_discretise::{
    cascade_response, simulate_cascade, to_delta_state_space, tustin, tustin_ss, zoh, zoh_ss,
    zoh_tf, DiscretiseError, TransferFunction, Zpk,
};
use model_core::{DeltaStateSpace, MAX_SECTIONS};
use nalgebra::DMatrix;
use num_complex::Complex64;
use std::f64::consts::TAU;

fn first_order(f_c: f64) -> Zpk {
    let a = TAU * f_c;
    Zpk::new(vec![], vec![Complex64::new(-a, 0.0)], a).unwrap()
}

// ---------------------------------------------------------------- 1. Tustin and ZOH, SISO

#[test]
fn tustin_first_and_second_order_match_continuous_response() {
    let dt = 1e-3;
    for (name, zpk) in [
        ("1st order 10 Hz", first_order(10.0)),
        (
            "2nd order 10 Hz, zeta 0.1",
            Zpk::second_order_lowpass(10.0, 0.1).unwrap(),
        ),
    ] {
        let d = tustin(&zpk, dt, None).unwrap();
        let mut worst_identity = 0.0f64;
        let mut worst_low = 0.0f64;
        for f in logspace(0.01, 490.0, 200) {
            // Exact identity: H_d(e^{jωT}) = H_c(j ω_warped); bound 1e-11 (rounding only).
            worst_identity =
                worst_identity.max(rel(d.response(f), zpk.response(warped(f, dt, None))));
            if f <= 20.0 {
                worst_low = worst_low.max(rel(d.response(f), zpk.response(f)));
            }
        }
        assert!(
            worst_identity < 1e-11,
            "{name}: warped identity error {worst_identity:e} >= 1e-11"
        );
        // Well below Nyquist (f <= fs/50) the only error is the frequency warp
        // (π f dt)²/3 = 1.3e-3 relative in ω, amplified ~1/(2ζ) = 5x near the resonance: 1e-2.
        assert!(
            worst_low < 1e-2,
            "{name}: error {worst_low:e} >= 1e-2 below fs/50"
        );
        println!("{name}: Tustin identity error {worst_identity:.2e}, |H_d - H_c|/|H_c| below fs/50: {worst_low:.2e}");

        // Pre-warped at 100 Hz: exact there (bound 1e-12).
        let dp = tustin(&zpk, dt, Some(100.0)).unwrap();
        let err = rel(dp.response(100.0), zpk.response(100.0));
        assert!(
            err < 1e-12,
            "{name}: pre-warped response at 100 Hz off by {err:e} >= 1e-12"
        );
        let unwarped = rel(d.response(100.0), zpk.response(100.0));
        assert!(
            unwarped > 1e3 * err,
            "{name}: pre-warping should matter at 100 Hz"
        );
    }
}

#[test]
fn zoh_first_order_poles_zeros_and_response_are_analytic() {
    let dt = 1e-3;
    let fc = 10.0;
    let a = TAU * fc;
    let d = zoh(&first_order(fc), dt).unwrap();
    let p = (-a * dt).exp();
    assert_eq!(d.poles.len(), 1);
    assert!(d.zeros.is_empty(), "ZOH of a/(s+a) has no finite zero");
    // Pole: z = e^{pT}, 1 - z = -expm1(pT), to 1e-15 relative.
    let err_z = (d.poles[0].z.re - p).abs() / p;
    let err_w = (d.poles[0].one_minus_z.re + (-a * dt).exp_m1()).abs() / (-a * dt).exp_m1().abs();
    assert!(
        err_z < 1e-15 && err_w < 1e-15,
        "pole errors {err_z:e}, {err_w:e} >= 1e-15"
    );
    // H_d(z) = (1 - e^{-aT}) / (z - e^{-aT}) exactly (bound 1e-13).
    for f in logspace(0.01, 499.0, 100) {
        let z = Complex64::from_polar(1.0, TAU * f * dt);
        let want = Complex64::new(1.0 - p, 0.0) / (z - p);
        let err = rel(d.response(f), want);
        assert!(
            err < 1e-13,
            "ZOH 1st order at {f} Hz: error {err:e} >= 1e-13"
        );
    }
}

#[test]
fn zoh_second_order_poles_are_exp_pt_and_response_matches_state_space() {
    let dt = 2e-4;
    let zpk = Zpk::second_order_lowpass(1.0, 0.05).unwrap();
    let d = zoh(&zpk, dt).unwrap();
    for (cont, disc) in zpk.poles.iter().zip(&d.poles) {
        let x = cont * dt;
        // 1 - e^x from its Taylor series (independent of expm1): -(x + x²/2! + …).
        let mut term = x;
        let mut series = Complex64::new(0.0, 0.0);
        for k in 2..30 {
            series -= term;
            term = term * x / k as f64;
        }
        let err_w = rel(disc.one_minus_z, series);
        let err_z = rel(disc.z, x.exp());
        // 1 - z keeps full relative precision although |1 - z| = 1.3e-3: bound 1e-14.
        assert!(err_w < 1e-14, "1 - z relative error {err_w:e} >= 1e-14");
        assert!(err_z < 1e-15, "z relative error {err_z:e} >= 1e-15");
    }
    // The ZOH zpk and the ZOH state space are the same transfer function (bound 1e-9).
    let ss = zpk.to_state_space().unwrap();
    let dss = zoh_ss(&ss, dt).unwrap();
    for f in logspace(0.01, 2400.0, 100) {
        let err = rel(d.response(f), dss.response(f).unwrap()[(0, 0)]);
        assert!(
            err < 1e-9,
            "ZOH zpk vs state space at {f} Hz: {err:e} >= 1e-9"
        );
    }
    // DC gain exactly preserved (1e-12).
    assert!((d.dc_gain() - 1.0).abs() < 1e-12, "DC gain {}", d.dc_gain());
}

#[test]
fn zoh_first_order_lead_keeps_slow_zero_precision() {
    // (s - z0)/(s - p) with z0 at 0.01 Hz, p at 100 Hz, fs = 20 kHz. Exact ZOH zero:
    // 1 - z_zero = (1 - e^{pT}) z0 / p. Bound 1e-12 relative on a 1 - z of 3e-6.
    let dt = 5e-5;
    let z0 = -TAU * 0.01;
    let p = -TAU * 100.0;
    let zpk = Zpk::new(
        vec![Complex64::new(z0, 0.0)],
        vec![Complex64::new(p, 0.0)],
        1.0,
    )
    .unwrap();
    let d = zoh(&zpk, dt).unwrap();
    let want = -(p * dt).exp_m1() * z0 / p;
    let got = d.zeros[0].one_minus_z.re;
    let err = ((got - want) / want).abs();
    assert!(
        err < 1e-12,
        "slow ZOH zero: relative error {err:e} >= 1e-12 (1 - z = {want:e})"
    );
}

#[test]
fn zoh_eighth_order_zpk_matches_state_space() {
    // Two notches (50 Hz, 60 Hz), a 1 Hz and a 300 Hz resonance at 5 kHz: the numerator's
    // coefficients span many decades, the zeros near z = 1 come from Aberth iteration on the
    // state-space numerator. Transfer functions agree to 1e-8 relative.
    let dt = 2e-4;
    let pair = |f: f64, zeta: f64| {
        let w = TAU * f;
        let p = Complex64::new(-zeta * w, w * (1.0 - zeta * zeta).sqrt());
        [p, p.conj()]
    };
    let zeros = [pair(50.0, 0.01), pair(60.0, 0.02)].concat();
    let poles = [
        pair(50.0, 0.5),
        pair(60.0, 0.5),
        pair(1.0, 0.05),
        pair(300.0, 0.3),
    ]
    .concat();
    // Gain for unit DC gain.
    let gain = poles.iter().product::<Complex64>().re / zeros.iter().product::<Complex64>().re;
    let zpk = Zpk::new(zeros, poles, gain).unwrap();
    assert!((zpk.response(0.0).re - 1.0).abs() < 1e-12);
    let d = zoh(&zpk, dt).unwrap();
    let dss = zoh_ss(&zpk.to_state_space().unwrap(), dt).unwrap();
    let mut worst = 0.0f64;
    for f in logspace(0.01, 2400.0, 300).into_iter().chain([50.0, 60.0]) {
        worst = worst.max(rel(d.response(f), dss.response(f).unwrap()[(0, 0)]));
    }
    assert!(
        worst < 1e-8,
        "8th-order ZOH zpk vs state space: {worst:e} >= 1e-8"
    );
    let cascade = d.to_cascade().unwrap();
    assert_eq!(cascade.sections as usize, MAX_SECTIONS);
    assert!(cascade.validate().is_ok());
    // The f32 cascade's exact response follows the f64 one to 1e-5 (relative, floor 1e-3 of
    // the unit DC gain), including the notch depths; measured 1.4e-7 (f32 rounding).
    let mut worst32 = 0.0f64;
    for f in logspace(0.01, 2400.0, 300).into_iter().chain([50.0, 60.0]) {
        let want = d.response(f);
        worst32 =
            worst32.max((cascade_response(&cascade, f, dt) - want).norm() / want.norm().max(1e-3));
    }
    assert!(
        worst32 < 1e-5,
        "f32 cascade vs f64 zpk: {worst32:e} >= 1e-5"
    );
    println!("8th-order ZOH: zpk vs ss {worst:.2e}, f32 cascade vs zpk {worst32:.2e}");
}

// ------------------------------------------------------ 2. ZOH step response, f32 cascade

const F_N: f64 = 1.0;
const ZETA: f64 = 0.05;
const DT: f64 = 2e-4; // 5 kHz
const SAMPLES: usize = 25_000; // 5 s

#[test]
fn zoh_step_response_is_exact_at_samples() {
    // f64 delta-form state space from zoh_ss, stepped through 5 s: equals the analytic
    // continuous step response at every sample instant to 1e-10 (rounding only).
    let zpk = Zpk::second_order_lowpass(F_N, ZETA).unwrap();
    let dss = zoh_ss(&zpk.to_state_space().unwrap(), DT).unwrap();
    let mut x = DMatrix::zeros(2, 1);
    let u = DMatrix::from_element(1, 1, 1.0);
    let mut worst = 0.0f64;
    for k in 0..SAMPLES {
        let y = (&dss.c * &x + &dss.d * &u)[(0, 0)];
        worst = worst.max((y - second_order_step(F_N, ZETA, k as f64 * DT)).abs());
        x += &dss.delta * &x + &dss.gamma * &u;
    }
    assert!(worst < 1e-10, "f64 ZOH step error {worst:e} >= 1e-10");
    println!("f64 ZOH state-space step error: {worst:.2e}");
}

/// Max error of the model-core f32 cascade's step response vs the analytic one.
fn delta_cascade_step_error() -> f64 {
    let cascade = zoh(&Zpk::second_order_lowpass(F_N, ZETA).unwrap(), DT)
        .unwrap()
        .to_cascade()
        .unwrap();
    let y = simulate_cascade(&cascade, &vec![1.0f32; SAMPLES]);
    y.iter()
        .enumerate()
        .map(|(k, &y)| (f64::from(y) - second_order_step(F_N, ZETA, k as f64 * DT)).abs())
        .fold(0.0, f64::max)
}

#[test]
fn zoh_step_response_through_model_core_f32_cascade() {
    // 1 Hz, ζ = 0.05 at 5 kHz for 5 s through model-core's own f32 delta-form recursion.
    // Measured max error 4.6e-6 of the final value (peak overshoot 1.85); bound 2e-5.
    let err = delta_cascade_step_error();
    println!("f32 delta cascade step error: {err:.2e}");
    assert!(err < 2e-5, "f32 delta-form step error {err:e} >= 2e-5");
}

#[test]
fn naive_direct_form_f32_is_much_worse() {
    // Same system, direct form: a1, a2, b in f32, y = b·u - a·y in f32. a1 ≈ -2 + 1.3e-4 has
    // an f32 spacing of 1.2e-7, i.e. ~7 % of α2 = 1.6e-6: the pole frequency and DC gain are
    // off by percent. The delta form must be at least 10x better (measured: far more).
    let d = zoh(&Zpk::second_order_lowpass(F_N, ZETA).unwrap(), DT).unwrap();
    let (num, den) = d.to_direct_form().unwrap();
    let mut b = [0.0f32; 3];
    for (dst, src) in b.iter_mut().rev().zip(num.iter().rev()) {
        *dst = *src as f32;
    }
    let a = [den[1] as f32, den[2] as f32];
    let (mut u1, mut u2, mut y1, mut y2) = (0.0f32, 0.0f32, 0.0f32, 0.0f32);
    let mut naive = 0.0f64;
    for k in 0..SAMPLES {
        let u = 1.0f32;
        let y = b[0] * u + b[1] * u1 + b[2] * u2 - a[0] * y1 - a[1] * y2;
        (u2, u1, y2, y1) = (u1, u, y1, y);
        naive = naive.max((f64::from(y) - second_order_step(F_N, ZETA, k as f64 * DT)).abs());
    }
    let delta = delta_cascade_step_error();
    println!("step error: naive f32 direct form {naive:.2e}, f32 delta form {delta:.2e}");
    assert!(
        naive >= 10.0 * delta,
        "naive {naive:e} is not >= 10x delta-form {delta:e}"
    );
}

// ------------------------------------------------------------- 3. State-space methods

#[test]
fn tustin_ss_matches_continuous_at_warped_frequency() {
    let ss = two_dof();
    let dt = 1e-3;
    for prewarp in [None, Some(37.0)] {
        let d = tustin_ss(&ss, dt, prewarp).unwrap();
        let mut worst = 0.0f64;
        for f in logspace(0.1, 490.0, 150) {
            let got = d.response(f).unwrap();
            let want = ss.response(warped(f, dt, prewarp)).unwrap();
            worst = worst.max(mat_rel(&got, &want));
        }
        // H_d(e^{jωT}) = H_c(j K tan(ωT/2)) exactly: bound 1e-10.
        assert!(worst < 1e-10, "tustin_ss {prewarp:?}: {worst:e} >= 1e-10");
        println!("tustin_ss {prewarp:?}: warped identity error {worst:.2e}");
    }
    // Pre-warped at 37 Hz: exact response there (1e-10).
    let d = tustin_ss(&ss, dt, Some(37.0)).unwrap();
    let err = mat_rel(&d.response(37.0).unwrap(), &ss.response(37.0).unwrap());
    assert!(err < 1e-10, "pre-warped tustin_ss at 37 Hz: {err:e}");
}

#[test]
fn zoh_ss_two_dof_matches_exponential_eigenvalues_and_response() {
    let ss = two_dof();
    let dt = 1e-3;
    let d = zoh_ss(&ss, dt).unwrap();
    // Φ against nalgebra's own Padé matrix exponential: 1e-13 absolute.
    let phi_ref = (&ss.a * dt).exp();
    let err_phi = (d.phi() - &phi_ref).abs().max();
    assert!(err_phi < 1e-13, "Φ vs nalgebra exp: {err_phi:e} >= 1e-13");
    // Eigenvalues of Φ - I equal expm1(λ dt) for the eigenvalues λ of A: 1e-9 relative.
    let lambdas = ss.a.clone().complex_eigenvalues();
    let mus = d.delta.clone().complex_eigenvalues();
    for l in lambdas.iter() {
        let want = (l * dt).exp() - 1.0;
        let err = mus
            .iter()
            .map(|m| rel(*m, want))
            .fold(f64::INFINITY, f64::min);
        assert!(
            err < 1e-9,
            "eigenvalue expm1({l} dt): relative error {err:e} >= 1e-9"
        );
        println!("eigenvalue {l:.3}: expm1(λT) vs eig(Φ - I) relative error {err:.1e}");
    }
    // DC gain exact: -C Δ⁻¹ Γ = -C A⁻¹ B (1e-10 relative).
    let dc_d = -&d.c * d.delta.clone().lu().solve(&d.gamma).unwrap();
    let dc_c = -&ss.c * ss.a.clone().lu().solve(&ss.b).unwrap();
    let err_dc = (&dc_d - &dc_c).abs().max() / dc_c.abs().max();
    assert!(err_dc < 1e-10, "ZOH DC gain error {err_dc:e}");
    // Well below Nyquist, ZOH ≈ continuous with half a sample of delay: H_c e^{-jωT/2}.
    // The remaining error is O((ωT)²) relative, amplified at the lightly damped modes;
    // bound 1e-2 below fs/20 = 50 Hz.
    let mut worst = 0.0f64;
    for f in logspace(0.1, 50.0, 200) {
        let want = ss.response(f).unwrap() * Complex64::from_polar(1.0, -0.5 * TAU * f * dt);
        worst = worst.max(mat_rel(&d.response(f).unwrap(), &want));
    }
    assert!(worst < 1e-2, "ZOH vs delayed continuous: {worst:e} >= 1e-2");
    println!("2-DOF ZOH: Φ err {err_phi:.1e}, DC err {err_dc:.1e}, half-delay approx {worst:.2e}");
}

#[test]
fn delta_state_space_conversion_checks_dimensions_and_runs_in_f32() {
    let ss = two_dof();
    let dt = 1e-3;
    let d = zoh_ss(&ss, dt).unwrap();
    assert!(matches!(
        to_delta_state_space::<3, 2, 2>(&d),
        Err(DiscretiseError::Dimension { .. })
    ));
    assert!(matches!(
        to_delta_state_space::<4, 1, 2>(&d),
        Err(DiscretiseError::Dimension { .. })
    ));
    let coefficients = to_delta_state_space::<4, 2, 2>(&d).unwrap();
    assert!(coefficients.is_finite());
    // A 100 N step on mass 1 for 2 s: f32 model-core block vs f64 delta recursion, error
    // below 1e-5 of the static deflection (1e-2 m).
    let mut block = DeltaStateSpace::new(coefficients);
    let mut x = DMatrix::zeros(4, 1);
    let u = DMatrix::from_row_slice(2, 1, &[100.0, 0.0]);
    let mut worst = 0.0f64;
    for _ in 0..2000 {
        let y32 = block.step(&[100.0, 0.0]);
        let y64 = &d.c * &x + &d.d * &u;
        x += &d.delta * &x + &d.gamma * &u;
        for (a, b) in y32.iter().zip(y64.iter()) {
            worst = worst.max((f64::from(*a) - b).abs());
        }
    }
    assert!(
        worst < 1e-7,
        "f32 delta state space vs f64: {worst:e} m >= 1e-7 m"
    );
    println!("2-DOF f32 DeltaStateSpace error: {worst:.2e} m");
}

// ------------------------------------------------------------------ 4. Roots round trip

#[test]
fn transfer_function_roots_round_trip() {
    // (s + 1)(s + 20)(s² + 6s + 25): roots -1, -20, -3 ± 4j; error < 1e-9.
    let tf = TransferFunction::new(vec![3.0, 3.0], vec![1.0, 27.0, 171.0, 645.0, 500.0]).unwrap();
    let zpk = tf.to_zpk().unwrap();
    let want = [
        Complex64::new(-1.0, 0.0),
        Complex64::new(-20.0, 0.0),
        Complex64::new(-3.0, 4.0),
        Complex64::new(-3.0, -4.0),
    ];
    assert_eq!(zpk.poles.len(), 4);
    for w in want {
        let err = zpk
            .poles
            .iter()
            .map(|p| (p - w).norm())
            .fold(f64::INFINITY, f64::min);
        assert!(err < 1e-9, "pole {w}: error {err:e} >= 1e-9");
    }
    // Complex roots are exact conjugates, real roots exactly real.
    for p in &zpk.poles {
        if p.im.abs() > 0.0 {
            let exact = zpk
                .poles
                .iter()
                .any(|q| q.re.to_bits() == p.re.to_bits() && q.im.to_bits() == (-p.im).to_bits());
            assert!(exact, "pole {p} has no exact conjugate");
        }
    }
    assert_eq!(zpk.zeros.len(), 1);
    assert!((zpk.zeros[0] - Complex64::new(-1.0, 0.0)).norm() < 1e-12);
    assert!((zpk.gain - 3.0).abs() < 1e-15);
    // And back: the expanded polynomial matches (1e-12 relative).
    let back = zpk.to_transfer_function().unwrap();
    for (a, b) in back.den.iter().zip(&tf.den) {
        assert!(
            (a - b).abs() <= 1e-12 * b.abs(),
            "den coefficient {a} vs {b}"
        );
    }
    // Through zoh_tf, the poles are exp(p dt).
    let d = zoh_tf(&tf, 1e-3).unwrap();
    for p in &zpk.poles {
        let want = (p * 1e-3).exp();
        let err = d
            .poles
            .iter()
            .map(|q| (q.z - want).norm())
            .fold(f64::INFINITY, f64::min);
        assert!(err < 1e-12, "ZOH pole of {p}: {err:e}");
    }
}

// ------------------------------------------------------------------- Sections, cascade

#[test]
fn sections_pair_and_scale_and_cascade_limits_hold() {
    // 4th-order Tustin design: 2 sections, the first scaled to unit peak gain, the cascade's
    // exact response equal to the f64 zpk to 1e-5 relative (f32 rounding).
    let dt = 1e-3;
    let pair = |f: f64, zeta: f64| {
        let w = TAU * f;
        let p = Complex64::new(-zeta * w, w * (1.0 - zeta * zeta).sqrt());
        [p, p.conj()]
    };
    let zpk = Zpk::new(
        vec![],
        [pair(5.0, 0.7), pair(40.0, 0.05)].concat(),
        (TAU * 5.0).powi(2) * (TAU * 40.0).powi(2),
    )
    .unwrap();
    let d = tustin(&zpk, dt, None).unwrap();
    let sections = d.to_sections().unwrap();
    assert_eq!(sections.len(), 2);
    // The lightly damped 40 Hz pair is closest to the unit circle, so it comes last:
    // 1 - |p|² = 1 - a2 = α1 - α2 is smaller for the last section.
    let margin = |s: &model_core::BiquadCoefficients| s.alpha1 - s.alpha2;
    assert!(margin(&sections[1]) < margin(&sections[0]), "{sections:?}");
    let cascade = d.to_cascade().unwrap();
    let first = model_core::CascadeCoefficients::from_sections(&sections[..1]).unwrap();
    let peak = logspace(0.01, 499.0, 2000)
        .into_iter()
        .map(|f| cascade_response(&first, f, dt).norm())
        .fold(0.0, f64::max);
    assert!(
        (peak - 1.0).abs() < 1e-3,
        "first section peak gain {peak} not 1 ± 1e-3"
    );
    for f in logspace(0.01, 499.0, 200) {
        let err = rel(cascade_response(&cascade, f, dt), d.response(f));
        assert!(err < 1e-5, "cascade vs zpk at {f} Hz: {err:e} >= 1e-5");
    }
    // 5 resonances need 5 sections: more than model-core holds.
    let poles: Vec<Complex64> = (1..=5)
        .flat_map(|i| pair(10.0 * f64::from(i), 0.1))
        .collect();
    let big = tustin(&Zpk::new(vec![], poles, 1.0).unwrap(), dt, None).unwrap();
    assert!(matches!(
        big.to_cascade(),
        Err(DiscretiseError::TooManySections {
            needed: 5,
            max: MAX_SECTIONS
        })
    ));
}

#[test]
fn invalid_inputs_are_errors() {
    let zpk = first_order(10.0);
    assert!(matches!(
        tustin(&zpk, 0.0, None),
        Err(DiscretiseError::InvalidSamplePeriod(_))
    ));
    assert!(matches!(
        zoh(&zpk, f64::NAN),
        Err(DiscretiseError::InvalidSamplePeriod(_))
    ));
    assert!(matches!(
        tustin(&zpk, 1e-3, Some(600.0)),
        Err(DiscretiseError::InvalidPrewarp { .. })
    ));
    let unpaired = Zpk {
        zeros: vec![],
        poles: vec![Complex64::new(-1.0, 2.0)],
        gain: 1.0,
    };
    assert!(matches!(
        zoh(&unpaired, 1e-3),
        Err(DiscretiseError::NotConjugate { .. })
    ));
    assert!(matches!(
        TransferFunction::new(vec![1.0, 0.0, 0.0], vec![1.0, 1.0]),
        Err(DiscretiseError::Improper { .. })
    ));
    assert!(matches!(
        TransferFunction::new(vec![1.0], vec![0.0, 0.0]),
        Err(DiscretiseError::ZeroPolynomial(_))
    ));
}

#[test]
fn zoh_with_integrator_or_differentiator_matches_analytic() {
    let dt = 1e-3;
    let a = TAU * 20.0;
    let e = (-a * dt).exp();
    let origin = Complex64::new(0.0, 0.0);
    // 1/(s (s + a)): H_d = [(aT - 1 + e) z + (1 - e - aT e)] / (a² (z - 1)(z - e)).
    let integ = Zpk::new(vec![], vec![origin, Complex64::new(-a, 0.0)], 1.0).unwrap();
    let d = zoh(&integ, dt).unwrap();
    assert!(
        d.poles.iter().any(|p| p.one_minus_z.norm() == 0.0),
        "pole at z = 1 must be exact"
    );
    // s/(s + a): H_d = (z - 1)/(z - e), the zero at z = 1 exact.
    let diff = Zpk::new(vec![origin], vec![Complex64::new(-a, 0.0)], 1.0).unwrap();
    let dd = zoh(&diff, dt).unwrap();
    assert!(
        dd.zeros.iter().any(|z| z.one_minus_z.norm() == 0.0),
        "zero at z = 1 must be exact"
    );
    for f in logspace(0.01, 499.0, 100) {
        let z = Complex64::from_polar(1.0, TAU * f * dt);
        let want =
            ((a * dt - 1.0 + e) * z + (1.0 - e - a * dt * e)) / (a * a * (z - 1.0) * (z - e));
        let err = rel(d.response(f), want);
        // Gain matched at fs/4 against the ZOH state space: 1e-10 everywhere.
        assert!(err < 1e-10, "ZOH 1/(s(s+a)) at {f} Hz: {err:e} >= 1e-10");
        let want = (z - 1.0) / (z - e);
        let err = rel(dd.response(f), want);
        assert!(err < 1e-10, "ZOH s/(s+a) at {f} Hz: {err:e} >= 1e-10");
    }
}

#[test]
fn tustin_with_zeros_matches_warped_response() {
    // Lead-lag (s + 2π·2)/(s + 2π·50) · 25 at 2 kHz, pre-warped at 50 Hz; zeros do not go
    // to infinity, so no z = -1 zero is added. Identity bound 1e-12.
    let dt = 5e-4;
    let zpk = Zpk::new(
        vec![Complex64::new(-TAU * 2.0, 0.0)],
        vec![Complex64::new(-TAU * 50.0, 0.0)],
        25.0,
    )
    .unwrap();
    let d = tustin(&zpk, dt, Some(50.0)).unwrap();
    assert_eq!(d.zeros.len(), 1);
    for f in logspace(0.01, 999.0, 100) {
        let err = rel(d.response(f), zpk.response(warped(f, dt, Some(50.0))));
        assert!(err < 1e-12, "lead-lag Tustin at {f} Hz: {err:e} >= 1e-12");
    }
    // 1 - z of the 2 Hz zero: -sT/(1 - sT/2) scaled by the pre-warp, 1e-15 relative.
    let k = TAU * 50.0 / (0.5 * TAU * 50.0 * dt).tan();
    let s = -TAU * 2.0;
    let want = -2.0 * s / (k - s);
    let err = ((d.zeros[0].one_minus_z.re - want) / want).abs();
    assert!(err < 1e-15, "Tustin 1 - z relative error {err:e}");
}
