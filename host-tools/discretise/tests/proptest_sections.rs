//! Property: random stable continuous second-order sections, discretised by Tustin and by
//! zero-order hold at random rates, give stable model-core sections whose f32 DC gain
//! matches the continuous one.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing)]

use mil_discretise::{cascade_response, tustin, zoh, Zpk};
use num_complex::Complex64;
use proptest::prelude::*;
use std::f64::consts::TAU;

/// Conjugate pair (or two real roots for ζ ≥ 1) of `s² + 2ζω s + ω²`.
fn pair(f_hz: f64, zeta: f64) -> Vec<Complex64> {
    let w = TAU * f_hz;
    if zeta < 1.0 {
        let p = Complex64::new(-zeta * w, w * (1.0 - zeta * zeta).sqrt());
        vec![p, p.conj()]
    } else {
        let big = -w * (zeta + (zeta * zeta - 1.0).sqrt());
        vec![Complex64::new(big, 0.0), Complex64::new(w * w / big, 0.0)]
    }
}

/// A random section: poles at `f_n` (0.5 Hz … 1 kHz, log-uniform) with ζ in 0.01 … 2, and
/// either no zeros or a zero pair at `f_z` (0.5 Hz … 1 kHz) with ζ_z in 0 … 1; DC gain 1.
fn section() -> impl Strategy<Value = (Vec<Complex64>, Vec<Complex64>, f64)> {
    (
        (0.5f64.ln()..1000f64.ln()).prop_map(f64::exp),
        0.01f64..2.0,
        prop::option::of(((0.5f64.ln()..1000f64.ln()).prop_map(f64::exp), 0.0f64..1.0)),
    )
        .prop_map(|(f_n, zeta, zero)| {
            let poles = pair(f_n, zeta);
            let (zeros, gain) = match zero {
                None => (vec![], (TAU * f_n).powi(2)),
                Some((f_z, zeta_z)) => (pair(f_z, zeta_z), (f_n / f_z).powi(2)),
            };
            (zeros, poles, gain)
        })
}

/// One or two random sections in series with a random DC gain (0.01 … 100, log-uniform),
/// so that `β2 ≠ α2` and the f32 rounding of both shows in the DC gain.
fn system() -> impl Strategy<Value = Zpk> {
    (
        prop::collection::vec(section(), 1..=2),
        (0.01f64.ln()..100f64.ln()).prop_map(f64::exp),
    )
        .prop_map(|(sections, dc)| {
            let mut zeros = Vec::new();
            let mut poles = Vec::new();
            let mut gain = dc;
            for (z, p, g) in sections {
                zeros.extend(z);
                poles.extend(p);
                gain *= g;
            }
            Zpk::new(zeros, poles, gain).unwrap()
        })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn discretised_sections_are_stable_with_matching_dc_gain(
        zpk in system(),
        fs in 1000.0f64..20_000.0,
    ) {
        let dt = 1.0 / fs;
        let dc_continuous = zpk.response(0.0).re;
        for (method, d) in [("tustin", tustin(&zpk, dt, None)), ("zoh", zoh(&zpk, dt))] {
            let d = d.map_err(|e| TestCaseError::fail(format!("{method}: {e}")))?;
            let cascade = d.to_cascade().map_err(|e| TestCaseError::fail(format!("{method}: {e}")))?;
            for s in cascade.active() {
                prop_assert!(s.is_stable(), "{method}: unstable section {s:?}");
            }
            prop_assert!(cascade.validate().is_ok(), "{method}: cascade rejected");
            // DC gain of the f32 sections (β2/α2 products in f32, and exactly from the f32
            // coefficients in f64) vs the continuous DC gain: 1e-3 relative.
            let dc32 = f64::from(cascade.dc_gain());
            let dc_exact = cascade_response(&cascade, 0.0, dt).re;
            for dc in [dc32, dc_exact] {
                prop_assert!(
                    (dc - dc_continuous).abs() < 1e-3 * dc_continuous.abs(),
                    "{method}: DC gain {dc} vs continuous {dc_continuous} (bound 1e-3 relative)"
                );
            }
        }
    }
}
