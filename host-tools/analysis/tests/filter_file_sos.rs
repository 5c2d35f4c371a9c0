//! The filter file's `sos`, zeros and poles describe the filter the board runs: the delta
//! form stepped by model-core (f32) and a textbook direct-form-II-transposed cascade over the
//! file's `sos` rows (f64, written here) give the same impulse response; the poles and zeros
//! rebuild the sections' polynomials; a file whose `sos` disagrees is refused, one without
//! it still reads.

use mil_analysis::filter_file::FilterFile;
use model_core::{BiquadCoefficients, CascadeCoefficients, CascadeState};

/// Two sections as a designer would give them: a resonant pair of poles with a notch-like
/// pair of zeros, and a real pole with a real zero (direct form, `a0 = 1`).
fn cascade() -> CascadeCoefficients {
    let (r, th) = (0.93_f64, 0.31_f64);
    let s1 = BiquadCoefficients::from_direct_form(
        [0.8, -0.8 * 2.0 * 0.97 * 0.35_f64.cos(), 0.8 * 0.97 * 0.97],
        [-2.0 * r * th.cos(), r * r],
    );
    let s2 = BiquadCoefficients::from_direct_form([1.3, -0.52, 0.0], [-0.6, 0.0]);
    CascadeCoefficients::from_sections(&[s1, s2]).unwrap()
}

/// Direct form II transposed, one section per `sos` row `[b0, b1, b2, a0, a1, a2]`.
fn sos_impulse(sos: &[[f64; 6]], n: usize) -> Vec<f64> {
    let mut state = vec![[0.0_f64; 2]; sos.len()];
    (0..n)
        .map(|k| {
            let mut x = if k == 0 { 1.0 } else { 0.0 };
            for (row, z) in sos.iter().zip(state.iter_mut()) {
                let [b0, b1, b2, a0, a1, a2] = *row;
                assert_eq!(a0, 1.0);
                let y = b0 * x + z[0];
                z[0] = b1 * x - a1 * y + z[1];
                z[1] = b2 * x - a2 * y;
                x = y;
            }
            x
        })
        .collect()
}

#[test]
fn sos_poles_and_zeros_are_the_filter_that_runs() {
    let c = cascade();
    let file = FilterFile::new(&c, 2000.0);
    let text = serde_json::to_string(&file).unwrap();
    let back: FilterFile = serde_json::from_str(&text).unwrap();
    let c2 = back.cascade().unwrap();
    assert_eq!(c2, c);
    let sos: Vec<[f64; 6]> = back.sections.iter().map(|s| s.sos.unwrap()).collect();
    // Impulse responses: model-core's f32 delta form against the f64 sos cascade.
    let n = 400;
    let reference = sos_impulse(&sos, n);
    let mut state = CascadeState::ZERO;
    let peak = reference.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    for (k, want) in reference.iter().enumerate() {
        let got = f64::from(c.step(&mut state, if k == 0 { 1.0 } else { 0.0 }));
        assert!(
            (got - want).abs() <= 1e-5 * peak,
            "sample {k}: delta form {got} vs sos {want}"
        );
    }
    // Poles and zeros rebuild each section: z² + a1 z + a2 and b0 z² + b1 z + b2.
    for s in &back.sections {
        let [b0, b1, b2, _, a1, a2] = s.sos.unwrap();
        let poles = s.poles.as_ref().unwrap();
        assert_eq!(poles.len(), 2);
        let (p, q) = (poles[0], poles[1]);
        let sum = [p[0] + q[0], p[1] + q[1]];
        let product = [p[0] * q[0] - p[1] * q[1], p[0] * q[1] + p[1] * q[0]];
        assert!(
            (-sum[0] - a1).abs() < 1e-12 && sum[1].abs() < 1e-12,
            "{poles:?}"
        );
        assert!(
            (product[0] - a2).abs() < 1e-12 && product[1].abs() < 1e-12,
            "{poles:?}"
        );
        assert!(
            poles.iter().all(|p| p[0].hypot(p[1]) < 1.0),
            "stable: {poles:?}"
        );
        let zeros = s.zeros.as_ref().unwrap();
        match zeros.len() {
            2 => {
                let (p, q) = (zeros[0], zeros[1]);
                let sum = p[0] + q[0];
                let product = p[0] * q[0] - p[1] * q[1];
                assert!((-sum * b0 - b1).abs() < 1e-9, "{zeros:?}");
                assert!((product * b0 - b2).abs() < 1e-9, "{zeros:?}");
            }
            1 => assert!((b1 / b0 + zeros[0][0]).abs() < 1e-9 || b2 == 0.0),
            _ => panic!("{zeros:?}"),
        }
    }
}

#[test]
fn a_sos_that_is_not_the_delta_form_is_refused_and_none_is_fine() {
    let mut file = FilterFile::new(&cascade(), 2000.0);
    let mut tampered = file.clone();
    if let Some(sos) = tampered.sections[0].sos.as_mut() {
        sos[4] += 1e-3;
    }
    let e = tampered.cascade().unwrap_err().to_string();
    assert!(e.contains("section 0") && e.contains("delta form"), "{e}");
    for s in &mut file.sections {
        s.sos = None;
        s.zeros = None;
        s.poles = None;
    }
    let text = serde_json::to_string(&file).unwrap();
    assert!(!text.contains("sos"), "{text}");
    let back: FilterFile = serde_json::from_str(&text).unwrap();
    assert_eq!(back.cascade().unwrap(), cascade());
}
