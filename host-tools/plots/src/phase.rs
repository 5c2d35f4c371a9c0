//! Phase unwrapping as drawn on the Bode diagrams.

use num_complex::Complex64;

/// Unwraps a sequence of phase angles in degrees and anchors it.
///
/// Consecutive finite values are made continuous: each step is replaced by the equivalent step
/// in [-180, 180] degrees, so the result has no 360-degree jumps. Then the whole sequence is
/// shifted by a multiple of 360 degrees so that its first finite value lies in (-180, 180].
/// Non-finite entries stay NaN in the output and do not interrupt the unwrapping (the next finite
/// value continues from the last finite one). The input order is the unwrapping order, so pass
/// phases sorted by ascending frequency.
pub fn unwrap_phase_deg(phase_deg: &[f64]) -> Vec<f64> {
    let mut unwrapped = Vec::with_capacity(phase_deg.len());
    let mut previous: Option<(f64, f64)> = None; // (raw input, unwrapped output)
    for &raw in phase_deg {
        if !raw.is_finite() {
            unwrapped.push(f64::NAN);
            continue;
        }
        let value = match previous {
            None => raw,
            Some((previous_raw, previous_unwrapped)) => {
                let step = raw - previous_raw;
                previous_unwrapped + (step - 360.0 * (step / 360.0).round())
            }
        };
        previous = Some((raw, value));
        unwrapped.push(value);
    }
    if let Some(first) = unwrapped.iter().copied().find(|v| v.is_finite()) {
        let shift = 360.0 * ((first - 180.0) / 360.0).ceil();
        if shift != 0.0 {
            for value in &mut unwrapped {
                *value -= shift;
            }
        }
    }
    unwrapped
}

/// The phase of each response value in degrees, unwrapped and anchored as by
/// [`unwrap_phase_deg`] (this is the phase the Bode diagrams draw).
///
/// Zero and non-finite values have no phase and give NaN. The input order is the unwrapping
/// order, so pass the response sorted by ascending frequency.
pub fn bode_phase_deg(response: &[Complex64]) -> Vec<f64> {
    let raw: Vec<f64> = response
        .iter()
        .map(|h| {
            if h.re.is_finite() && h.im.is_finite() && h.norm() > 0.0 {
                h.arg().to_degrees()
            } else {
                f64::NAN
            }
        })
        .collect();
    unwrap_phase_deg(&raw)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn pure_delay_phase_is_linear_over_many_turns() {
        let delay = 0.01; // s: one turn per 100 Hz
        let frequency: Vec<f64> = (1..=2000).map(|k| f64::from(k) * 0.5).collect(); // to 1 kHz
        let response: Vec<Complex64> = frequency
            .iter()
            .map(|f| Complex64::from_polar(1.0, -2.0 * PI * f * delay))
            .collect();
        let phase = bode_phase_deg(&response);
        for (f, p) in frequency.iter().zip(&phase) {
            let expected = -360.0 * f * delay;
            assert!((p - expected).abs() < 1e-6, "at {f} Hz: {p} vs {expected}");
        }
        // Ten full turns, no jumps.
        assert!(phase.last().unwrap() < &-3599.0);
        assert!(phase.windows(2).all(|w| (w[1] - w[0]).abs() < 10.0));
    }

    #[test]
    fn start_is_anchored_into_half_open_interval() {
        let phase = unwrap_phase_deg(&[350.0, 355.0, 365.0, 10.0]);
        let expected = [-10.0, -5.0, 5.0, 10.0];
        for (p, e) in phase.iter().zip(expected) {
            assert!((p - e).abs() < 1e-9, "{phase:?}");
        }
        assert_eq!(unwrap_phase_deg(&[180.0])[0], 180.0);
        assert_eq!(unwrap_phase_deg(&[-180.0])[0], 180.0);
        assert_eq!(unwrap_phase_deg(&[-540.0, -545.0])[1], 175.0);
        assert!((unwrap_phase_deg(&[-170.0, 170.0])[1] - -190.0).abs() < 1e-9);
    }

    #[test]
    fn non_finite_entries_are_skipped() {
        let phase = unwrap_phase_deg(&[f64::NAN, 170.0, f64::INFINITY, -170.0]);
        assert!(phase[0].is_nan() && phase[2].is_nan());
        assert!((phase[1] - 170.0).abs() < 1e-9);
        assert!((phase[3] - 190.0).abs() < 1e-9);
        let zero = bode_phase_deg(&[Complex64::new(0.0, 0.0), Complex64::new(0.0, -1.0)]);
        assert!(zero[0].is_nan());
        assert!((zero[1] + 90.0).abs() < 1e-9);
        assert!(unwrap_phase_deg(&[]).is_empty());
    }
}
