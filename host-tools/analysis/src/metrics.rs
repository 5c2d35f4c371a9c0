//! Figures of frequency responses: frequency grids, stability margins and the closed-loop
//! stability verdict, resonance peaks, band errors between two responses, and peaks of the
//! control sensitivity.

use nalgebra::DMatrix;
use num_complex::Complex64;
use serde::Serialize;

/// A logarithmic frequency grid from `f_min_hz` to `f_max_hz` (both included, Hz) with
/// `points_per_decade` points per decade (at least 2 points in all).
pub fn log_grid(f_min_hz: f64, f_max_hz: f64, points_per_decade: usize) -> Vec<f64> {
    let decades = (f_max_hz / f_min_hz).log10().max(0.0);
    let n = ((decades * points_per_decade as f64).ceil() as usize).max(1) + 1;
    (0..n)
        .map(|k| f_min_hz * (f_max_hz / f_min_hz).powf(k as f64 / (n - 1) as f64))
        .collect()
}

/// A linear frequency grid from `f_min_hz` to `f_max_hz` (both included) with spacing at
/// most `step_hz`.
pub fn linear_grid(f_min_hz: f64, f_max_hz: f64, step_hz: f64) -> Vec<f64> {
    let n = (((f_max_hz - f_min_hz) / step_hz).ceil() as usize).max(1) + 1;
    (0..n)
        .map(|k| f_min_hz + (f_max_hz - f_min_hz) * k as f64 / (n - 1) as f64)
        .collect()
}

/// Phases (degrees) of `values`, unwrapped along the sequence, the first one taken in
/// (−270°, 90°] so that a loop phase just beyond −180° at low frequency stays a lag.
pub fn unwrapped_phase_deg(values: &[Complex64]) -> Vec<f64> {
    let mut phase: Vec<f64> = values.iter().map(|v| v.arg().to_degrees()).collect();
    if phase.first().is_some_and(|p| *p > 90.0) {
        for p in &mut phase {
            *p -= 360.0;
        }
    }
    mil_identify::unwrap_phase_deg(&mut phase);
    phase
}

/// Eigenvalues of a small complex matrix (closed form up to 2 × 2, Schur form above).
pub fn eigenvalues(m: &DMatrix<Complex64>) -> Vec<Complex64> {
    match m.nrows() {
        0 => Vec::new(),
        1 => vec![m[(0, 0)]],
        2 => {
            let (a, b, c, d) = (m[(0, 0)], m[(0, 1)], m[(1, 0)], m[(1, 1)]);
            let half_trace = (a + d) * 0.5;
            let disc = ((a - d) * 0.5 * ((a - d) * 0.5) + b * c).sqrt();
            vec![half_trace + disc, half_trace - disc]
        }
        _ => nalgebra::Schur::new(m.clone())
            .eigenvalues()
            .map(|v| v.iter().copied().collect())
            .unwrap_or_default(),
    }
}

/// Characteristic loci: the eigenvalues of the open-loop matrices along the grid, each locus
/// continued by nearest-neighbour matching. `loci[k][i]` is locus `k` at grid point `i`.
pub fn characteristic_loci(open_loop: &[DMatrix<Complex64>]) -> Vec<Vec<Complex64>> {
    let mut loci: Vec<Vec<Complex64>> = Vec::new();
    for (i, l) in open_loop.iter().enumerate() {
        let mut eig = eigenvalues(l);
        if i == 0 {
            loci = eig.into_iter().map(|e| vec![e]).collect();
            continue;
        }
        for locus in loci.iter_mut() {
            let last = locus.last().copied().unwrap_or_default();
            if let Some((k, _)) = eig.iter().enumerate().min_by(|(_, a), (_, b)| {
                (**a - last)
                    .norm()
                    .partial_cmp(&(**b - last).norm())
                    .unwrap_or(std::cmp::Ordering::Equal)
            }) {
                locus.push(eig.swap_remove(k));
            }
        }
    }
    loci
}

/// Closed-loop stability of a loop, from the argument principle
/// ([`crate::system::MilSystem::stability`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Stability {
    /// No closed-loop pole right of the contour.
    Stable,
    /// This many closed-loop poles right of the contour.
    Unstable(u32),
    /// Not determined (a measured table cannot be evaluated off the imaginary axis, or the
    /// loop gain does not fall below 0.1 by the end of the contour).
    Unknown,
}

/// "stable", "unstable (2 closed-loop poles in the right half-plane)", "not determined".
impl std::fmt::Display for Stability {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Stability::Stable => f.write_str("stable"),
            Stability::Unstable(n) => write!(
                f,
                "unstable ({n} closed-loop pole{} in the right half-plane)",
                if *n == 1 { "" } else { "s" }
            ),
            Stability::Unknown => f.write_str("not determined"),
        }
    }
}

/// Gain and phase margins of a loop (negative-feedback convention, return difference
/// `1 + L`). `None` where the loop never crosses (an infinite margin).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Margins {
    /// Upper gain margin: the smallest `1/|L|` over the phase crossovers (phase of `L` at
    /// −180° mod 360°) where `|L| < 1`, i.e. the factor by which the loop gain may rise.
    pub gain_margin: Option<f64>,
    /// Frequency of that phase crossover (Hz).
    pub gain_margin_hz: Option<f64>,
    /// Gain-reduction margin: the largest `1/|L|` over the phase crossovers where
    /// `|L| ≥ 1` (below 1). For an unstable loop it is the factor the gain must fall by at
    /// that crossover; for a stable one the loop is conditionally stable there (a free mass
    /// on a spring hugs −180° at low frequency with `|L| ≫ 1` without that mattering).
    pub gain_reduction_margin: Option<f64>,
    /// Frequency of that phase crossover (Hz).
    pub gain_reduction_margin_hz: Option<f64>,
    /// Smallest phase margin over the gain crossovers (where `|L|` crosses 1), degrees: the
    /// angle between `L` and the critical point −1 there (0…180°), negative where the lag
    /// (unwrapped from low frequency) is beyond 180° (see [`phase_margin_at`]).
    pub phase_margin_deg: Option<f64>,
    /// Frequency of that gain crossover (Hz).
    pub phase_margin_hz: Option<f64>,
}

impl Margins {
    /// The gain margin to report and its frequency: the upper margin, except for an
    /// unstable loop, where it is the gain-reduction margin (below 1), so that an unstable
    /// loop never shows a margin above 1.
    pub fn reported_gain_margin(&self, stability: Stability) -> (Option<f64>, Option<f64>) {
        match stability {
            Stability::Unstable(_) => (self.gain_reduction_margin, self.gain_reduction_margin_hz),
            _ => (self.gain_margin, self.gain_margin_hz),
        }
    }
}

/// Linear interpolation in log-frequency between grid points `i` and `i + 1` for the
/// parameter `t` in [0, 1].
fn interp_log_f(f: &[f64], i: usize, t: f64) -> f64 {
    (f[i].ln() + t * (f[i + 1].ln() - f[i].ln())).exp()
}

/// Phase margin (degrees) of a gain crossover at the unwrapped loop phase `phase_deg`
/// (unwrapped from low frequency, starting in (−270°, 90°], see [`unwrapped_phase_deg`]):
/// its magnitude is the angle from `L` to −1, `180° − |φ|` with `φ` wrapped to
/// (−180°, 180°], so always at most 180°; its sign is negative where the lag exceeds 180°
/// (`phase_deg < −180°`). So −160° gives 20°, −190° gives −10°, and a crossover in phase
/// lead (+2.4°, `L` near +1, the farthest point from −1) gives 177.6°.
pub fn phase_margin_at(phase_deg: f64) -> f64 {
    let wrapped = phase_deg - 360.0 * (phase_deg / 360.0).round();
    let distance = 180.0 - wrapped.abs();
    if phase_deg < -180.0 {
        -distance
    } else {
        distance
    }
}

/// Margins of the loci of `L` on grid `frequency_hz`. Crossings are located by linear
/// interpolation between grid points (use a fine grid: the error is second order in the
/// spacing).
pub fn margins(frequency_hz: &[f64], loci: &[Vec<Complex64>]) -> Margins {
    let mut out = Margins::default();
    for locus in loci {
        let phase = unwrapped_phase_deg(locus);
        let mag: Vec<f64> = locus.iter().map(|v| v.norm()).collect();
        for i in 0..locus.len().saturating_sub(1) {
            // Phase crossover: (φ + 180)/360 passes an integer.
            let (a, b) = ((phase[i] + 180.0) / 360.0, (phase[i + 1] + 180.0) / 360.0);
            if a.floor() != b.floor() || a == a.floor() {
                let target = if b > a { b.floor() } else { a.floor() };
                let t = if b != a { (target - a) / (b - a) } else { 0.0 };
                let m = (mag[i].ln() + t * (mag[i + 1].ln() - mag[i].ln())).exp();
                let gm = 1.0 / m;
                let hz = interp_log_f(frequency_hz, i, t);
                if gm > 1.0 {
                    if out.gain_margin.is_none_or(|g| gm < g) {
                        out.gain_margin = Some(gm);
                        out.gain_margin_hz = Some(hz);
                    }
                } else if out.gain_reduction_margin.is_none_or(|g| gm > g) {
                    out.gain_reduction_margin = Some(gm);
                    out.gain_reduction_margin_hz = Some(hz);
                }
            }
            // Gain crossover: |L| passes 1.
            let (la, lb) = (mag[i].ln(), mag[i + 1].ln());
            if (la >= 0.0) != (lb >= 0.0) {
                let t = la / (la - lb);
                let ph = phase[i] + t * (phase[i + 1] - phase[i]);
                let pm = phase_margin_at(ph);
                if out.phase_margin_deg.is_none_or(|p| pm < p) {
                    out.phase_margin_deg = Some(pm);
                    out.phase_margin_hz = Some(interp_log_f(frequency_hz, i, t));
                }
            }
        }
    }
    out
}

/// A resonance peak of a response magnitude.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Resonance {
    /// Peak frequency (Hz).
    pub hz: f64,
    /// Peak magnitude (in the response's units, e.g. N/m).
    pub magnitude: f64,
    /// Equivalent damping ratio from the half-power bandwidth (or, where a half-power point
    /// is not reached, from the curvature of `1/|H|²` at the peak).
    pub damping_ratio: f64,
}

/// Resonance peaks of `|h(f)|`: local maxima on the grid that stand at least
/// `min_prominence_db` above the lower of the minima on either side, refined by a golden-
/// section search on `h` itself, with damping from the half-power points found by
/// bisection on `h`.
pub fn resonances<F>(
    frequency_hz: &[f64],
    magnitude: &[f64],
    min_prominence_db: f64,
    h: F,
) -> Vec<Resonance>
where
    F: Fn(f64) -> Option<f64>,
{
    let n = magnitude.len();
    let mut out = Vec::new();
    for i in 1..n.saturating_sub(1) {
        if !(magnitude[i] > magnitude[i - 1] && magnitude[i] >= magnitude[i + 1]) {
            continue;
        }
        // Neighbouring minima (valleys) on each side.
        let mut lo = i;
        while lo > 0 && magnitude[lo - 1] <= magnitude[lo] {
            lo -= 1;
        }
        let mut hi = i;
        while hi + 1 < n && magnitude[hi + 1] <= magnitude[hi] {
            hi += 1;
        }
        let valley = magnitude[lo].max(magnitude[hi]);
        if 20.0 * (magnitude[i] / valley).log10() < min_prominence_db {
            continue;
        }
        // Golden-section refinement of the peak in [f_{i-1}, f_{i+1}].
        let (mut a, mut b) = (frequency_hz[i - 1], frequency_hz[i + 1]);
        let g = (5f64.sqrt() - 1.0) / 2.0;
        for _ in 0..60 {
            let c = b - g * (b - a);
            let d = a + g * (b - a);
            let (hc, hd) = (h(c).unwrap_or(0.0), h(d).unwrap_or(0.0));
            if hc > hd {
                b = d;
            } else {
                a = c;
            }
        }
        let fp = 0.5 * (a + b);
        let peak = h(fp).unwrap_or(magnitude[i]).max(magnitude[i]);
        let half = peak / std::f64::consts::SQRT_2;
        let bisect = |mut inside: f64, mut outside: f64| {
            for _ in 0..60 {
                let mid = 0.5 * (inside + outside);
                if h(mid).unwrap_or(0.0) > half {
                    inside = mid;
                } else {
                    outside = mid;
                }
            }
            0.5 * (inside + outside)
        };
        let left = (magnitude[lo] < half).then(|| bisect(fp, frequency_hz[lo]));
        let right = (magnitude[hi] < half).then(|| bisect(fp, frequency_hz[hi]));
        let damping_ratio = match (left, right) {
            (Some(l), Some(r)) => (r - l) / (2.0 * fp),
            (Some(l), None) => (fp - l) / fp,
            (None, Some(r)) => (r - fp) / fp,
            (None, None) => {
                let delta = 0.01 * fp;
                let ratio = (peak / h(fp + delta).unwrap_or(peak)).powi(2);
                if ratio > 1.0 {
                    delta / (fp * (ratio - 1.0).sqrt())
                } else {
                    f64::NAN
                }
            }
        };
        out.push(Resonance {
            hz: fp,
            magnitude: peak,
            damping_ratio,
        });
    }
    out
}

/// Error of one response against a reference over a frequency band.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct BandError {
    /// Band start (Hz).
    pub from_hz: f64,
    /// Band end (Hz).
    pub to_hz: f64,
    /// Largest magnitude error `|20 log10 |h/h_ref||` in the band (dB).
    pub max_magnitude_db: f64,
    /// RMS magnitude error over the grid points in the band (dB).
    pub rms_magnitude_db: f64,
    /// Largest phase error `|∠(h/h_ref)|` in the band (degrees).
    pub max_phase_deg: f64,
    /// RMS phase error over the grid points in the band (degrees).
    pub rms_phase_deg: f64,
}

/// Band errors of `h` against `reference` (both on `frequency_hz`), one per band
/// `(from, to)` (Hz). Bands without grid points are skipped.
pub fn band_errors(
    frequency_hz: &[f64],
    h: &[Complex64],
    reference: &[Complex64],
    bands: &[(f64, f64)],
) -> Vec<BandError> {
    let ratio: Vec<Complex64> = h.iter().zip(reference).map(|(a, b)| a / b).collect();
    let phase = unwrapped_phase_deg(&ratio);
    bands
        .iter()
        .filter_map(|&(from, to)| {
            let idx: Vec<usize> = (0..frequency_hz.len())
                .filter(|&k| frequency_hz[k] >= from && frequency_hz[k] <= to)
                .collect();
            if idx.is_empty() {
                return None;
            }
            let db: Vec<f64> = idx
                .iter()
                .map(|&k| 20.0 * ratio[k].norm().log10())
                .collect();
            let ph: Vec<f64> = idx
                .iter()
                .map(|&k| phase[k] - 360.0 * (phase[k] / 360.0).round())
                .collect();
            let rms = |v: &[f64]| (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt();
            let max = |v: &[f64]| v.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
            Some(BandError {
                from_hz: from,
                to_hz: to,
                max_magnitude_db: max(&db),
                rms_magnitude_db: rms(&db),
                max_phase_deg: max(&ph),
                rms_phase_deg: rms(&ph),
            })
        })
        .collect()
}

/// Largest singular value of a small complex matrix (the gain of a matrix response).
pub fn max_singular_value(m: &DMatrix<Complex64>) -> f64 {
    if m.nrows() == 1 && m.ncols() == 1 {
        return m[(0, 0)].norm();
    }
    let gram = m.adjoint() * m;
    eigenvalues(&gram)
        .iter()
        .fold(0.0_f64, |acc, e| acc.max(e.re))
        .max(0.0)
        .sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::TAU;

    fn siso(f: &[f64], l: impl Fn(f64) -> Complex64) -> Vec<Vec<Complex64>> {
        vec![f.iter().map(|&x| l(x)).collect()]
    }

    #[test]
    fn integrator_with_delay_has_textbook_margins() {
        // L(s) = K e^{-sτ}/s: phase crossover where ωτ = π/2 → f = 1/(4τ), GM = π/(2Kτ);
        // gain crossover at ω = K, PM = 90° − Kτ (rad → deg).
        let (k, tau) = (20.0, 0.01);
        let f = log_grid(0.1, 100.0, 2000);
        let l = |x: f64| {
            let s = Complex64::new(0.0, TAU * x);
            k * (-s * tau).exp() / s
        };
        let m = margins(&f, &siso(&f, l));
        let gm = std::f64::consts::PI / (2.0 * k * tau);
        assert!((m.gain_margin.unwrap() - gm).abs() < 1e-4 * gm, "{m:?}");
        assert!((m.gain_margin_hz.unwrap() - 1.0 / (4.0 * tau)).abs() < 1e-3);
        let pm = 90.0 - (k * tau).to_degrees();
        assert!((m.phase_margin_deg.unwrap() - pm).abs() < 1e-3, "{m:?}");
        assert!((m.phase_margin_hz.unwrap() - k / TAU).abs() < 1e-4);
    }

    #[test]
    fn phase_margin_is_the_angle_to_minus_one_signed_by_the_lag() {
        for (phase, pm) in [
            (-160.0, 20.0),
            (-190.0, -10.0),
            (-90.0, 90.0),
            (2.4, 177.6),
            (-2.4, 177.6),
            (-357.6, -177.6),
            (-400.0, -140.0),
        ] {
            assert!(
                (phase_margin_at(phase) - pm).abs() < 1e-9,
                "{phase}: {}",
                phase_margin_at(phase)
            );
        }
        // A locus crossing |L| = 1 in phase lead: L = 2 e^{j 2.4°} … 0.5 e^{j 2.4°}.
        let f = log_grid(1.0, 100.0, 50);
        let locus: Vec<Complex64> = f
            .iter()
            .map(|hz| Complex64::from_polar(2.0 * (1.0 / hz).powf(0.3), 2.4f64.to_radians()))
            .collect();
        let m = margins(&f, &[locus]);
        assert!((m.phase_margin_deg.unwrap() - 177.6).abs() < 1e-9, "{m:?}");
        assert!(m.gain_margin.is_none(), "{m:?}");
    }

    #[test]
    fn passive_loop_has_no_phase_crossover() {
        // L = k/(s(s + a)): phase between −90° and −180°, never crossing.
        let f = log_grid(0.01, 1000.0, 200);
        let l = |x: f64| {
            let s = Complex64::new(0.0, TAU * x);
            100.0 / (s * (s + 5.0))
        };
        let m = margins(&f, &siso(&f, l));
        assert_eq!(m.gain_margin, None);
        assert!(m.phase_margin_deg.unwrap() > 0.0);
    }

    #[test]
    fn second_order_peak_frequency_and_damping() {
        // H = ωn²/(s² + 2ζωn s + ωn²): peak at fn √(1 − 2ζ²), height 1/(2ζ√(1 − ζ²)).
        for &zeta in &[0.02, 0.05, 0.2] {
            let fnat = 17.0;
            let h = |x: f64| {
                let s = Complex64::new(0.0, TAU * x);
                let wn = TAU * fnat;
                wn * wn / (s * s + 2.0 * zeta * wn * s + wn * wn)
            };
            let f = log_grid(1.0, 100.0, 100);
            let mag: Vec<f64> = f.iter().map(|&x| h(x).norm()).collect();
            let r = resonances(&f, &mag, 1.0, |x| Some(h(x).norm()));
            assert_eq!(r.len(), 1, "{r:?}");
            let fp = fnat * (1.0 - 2.0 * zeta * zeta).sqrt();
            let peak = 1.0 / (2.0 * zeta * (1.0 - zeta * zeta).sqrt());
            assert!((r[0].hz - fp).abs() < 1e-6 * fp);
            assert!((r[0].magnitude - peak).abs() < 1e-9 * peak);
            // Half-power bandwidth gives ζ to first order (error O(ζ²)).
            assert!((r[0].damping_ratio - zeta).abs() < 0.05 * zeta + 2.0 * zeta * zeta);
        }
    }

    #[test]
    fn band_errors_of_a_known_gain_and_delay() {
        let f = linear_grid(1.0, 10.0, 0.5);
        let reference: Vec<Complex64> = f.iter().map(|_| Complex64::new(1.0, 0.0)).collect();
        // 2 dB high and 1 ms late.
        let g = 10f64.powf(2.0 / 20.0);
        let h: Vec<Complex64> = f
            .iter()
            .map(|&x| Complex64::from_polar(g, -TAU * x * 1e-3))
            .collect();
        let e = band_errors(&f, &h, &reference, &[(1.0, 10.0)]);
        assert!((e[0].max_magnitude_db - 2.0).abs() < 1e-9);
        assert!((e[0].max_phase_deg - 3.6).abs() < 1e-9);
    }

    #[test]
    fn eigenvalues_of_a_2x2_and_3x3() {
        let m = DMatrix::from_row_slice(
            2,
            2,
            &[
                Complex64::new(2.0, 0.0),
                Complex64::new(1.0, 0.0),
                Complex64::new(1.0, 0.0),
                Complex64::new(2.0, 0.0),
            ],
        );
        let mut e: Vec<f64> = eigenvalues(&m).iter().map(|v| v.re).collect();
        e.sort_by(|a, b| a.partial_cmp(b).unwrap());
        assert!((e[0] - 1.0).abs() < 1e-12 && (e[1] - 3.0).abs() < 1e-12);
        let d = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![
            Complex64::new(1.0, 1.0),
            Complex64::new(-2.0, 0.0),
            Complex64::new(0.5, -3.0),
        ]));
        let e3 = eigenvalues(&d);
        assert_eq!(e3.len(), 3);
        assert!(e3
            .iter()
            .any(|v| (v - Complex64::new(0.5, -3.0)).norm() < 1e-12));
    }
}
