//! Evidence: where model and measurement disagree — frequency bands (FRF and coherence of
//! the data against the model), operating regions (residual binned over an element's
//! compression and rate: the restoring-force view) and time windows.

use crate::signal;
use mil_identify::{h1_estimate, Record as FrfRecord, WelchOptions};
use serde::Serialize;

/// One frequency band of an input-to-output response.
#[derive(Clone, Debug, Serialize)]
pub struct BandEvidence {
    /// Input column.
    pub input: String,
    /// Output column.
    pub output: String,
    /// Band (Hz).
    pub band_hz: [f64; 2],
    /// Mean relative FRF error `|H_data − H_model| / |H_model|` before (model as given,
    /// recalibrated) (fraction).
    pub error_before: f64,
    /// The same with the updated model (fraction).
    pub error_after: f64,
    /// Mean coherence of the data (input to measured output) in the band.
    pub coherence: f64,
}

/// Mean residual over a grid of an element's compression and rate.
#[derive(Clone, Debug, Serialize)]
pub struct RegionEvidence {
    /// Element.
    pub element: String,
    /// Bin edges of the compression (m), quantiles of the data.
    pub x_edges_m: Vec<f64>,
    /// Bin edges of the compression rate (m/s).
    pub v_edges_m_per_s: Vec<f64>,
    /// Mean residual (N, the force the model misses on this element's DOF) per bin,
    /// `[x bin][v bin]`; NaN where a bin is empty.
    pub mean_residual_n: Vec<Vec<f64>>,
    /// The bin with the largest |mean| relative to its standard error: (x bin, v bin).
    pub worst_bin: (usize, usize),
}

/// Error in one time window.
#[derive(Clone, Debug, Serialize)]
pub struct WindowEvidence {
    /// Window (s).
    pub time_s: [f64; 2],
    /// NRMSE before (fraction).
    pub before: f64,
    /// NRMSE after (fraction).
    pub after: f64,
}

/// FRF comparison in logarithmically spaced bands between `f_lo` and `f_hi` (Hz): the
/// data's H1 estimate (input `u` → measured `y`) against the estimates from the same input
/// to the simulated outputs before and after.
#[allow(clippy::too_many_arguments)]
pub fn frf_bands(
    names: (&str, &str),
    u: &[f64],
    y: &[f64],
    before: &[f64],
    after: &[f64],
    dt: f64,
    f_lo: f64,
    f_hi: f64,
) -> Vec<BandEvidence> {
    let opts = WelchOptions::for_record(u.len());
    let est = |out: &[f64]| {
        h1_estimate(
            &[FrfRecord {
                input: u,
                output: out,
            }],
            1.0 / dt,
            &opts,
        )
        .ok()
    };
    let (Some(d), Some(b), Some(a)) = (est(y), est(before), est(after)) else {
        return Vec::new();
    };
    let f_lo = f_lo.max(2.0 / (opts.segment_length as f64 * dt));
    if f_hi.partial_cmp(&f_lo) != Some(std::cmp::Ordering::Greater) {
        return Vec::new();
    }
    let bands = 8;
    let ratio = (f_hi / f_lo).powf(1.0 / bands as f64);
    let mut out = Vec::new();
    for k in 0..bands {
        let lo = f_lo * ratio.powi(k);
        let hi = lo * ratio;
        let (mut eb, mut ea, mut coh, mut cnt) = (0.0, 0.0, 0.0, 0usize);
        for i in 0..d.frequency_hz.len() {
            let f = d.frequency_hz[i];
            if f < lo || f >= hi {
                continue;
            }
            let (hd, hb, ha) = (d.response[i], b.response[i], a.response[i]);
            if !(hd.re.is_finite() && hb.norm() > 0.0 && ha.norm() > 0.0) {
                continue;
            }
            eb += (hd - hb).norm() / hb.norm();
            ea += (hd - ha).norm() / ha.norm();
            coh += d.coherence[i];
            cnt += 1;
        }
        if cnt > 0 {
            let c = cnt as f64;
            out.push(BandEvidence {
                input: names.0.to_string(),
                output: names.1.to_string(),
                band_hz: [lo, hi],
                error_before: eb / c,
                error_after: ea / c,
                coherence: coh / c,
            });
        }
    }
    out
}

/// Restoring-force view: `residual` binned over `x` and `v` (5 × 5 quantile bins).
pub fn region(element: &str, x: &[f64], v: &[f64], residual: &[f64]) -> RegionEvidence {
    let bins = 5;
    let edges = |s: &[f64]| -> Vec<f64> {
        (0..=bins)
            .map(|k| signal::quantile(s, k as f64 / bins as f64))
            .collect()
    };
    let (xe, ve) = (edges(x), edges(v));
    let find = |e: &[f64], val: f64| -> usize { (1..bins).take_while(|&k| val >= e[k]).count() };
    let mut sum = vec![vec![0.0; bins]; bins];
    let mut sq = vec![vec![0.0; bins]; bins];
    let mut cnt = vec![vec![0usize; bins]; bins];
    for ((&xi, &vi), &r) in x.iter().zip(v).zip(residual) {
        let (a, b) = (find(&xe, xi), find(&ve, vi));
        sum[a][b] += r;
        sq[a][b] += r * r;
        cnt[a][b] += 1;
    }
    let mut mean = vec![vec![f64::NAN; bins]; bins];
    let mut worst = (0, 0);
    let mut worst_t = -1.0;
    for a in 0..bins {
        for b in 0..bins {
            if cnt[a][b] > 1 {
                let c = cnt[a][b] as f64;
                let m = sum[a][b] / c;
                let var = (sq[a][b] / c - m * m).max(0.0);
                let t = m.abs() / (var / c).sqrt().max(1e-300);
                mean[a][b] = m;
                if t > worst_t {
                    worst_t = t;
                    worst = (a, b);
                }
            }
        }
    }
    RegionEvidence {
        element: element.to_string(),
        x_edges_m: xe,
        v_edges_m_per_s: ve,
        mean_residual_n: mean,
        worst_bin: worst,
    }
}

/// NRMSE per window (10 windows over `range` samples) of outputs before and after.
pub fn windows(
    measured: &[&[f64]],
    before: &[Vec<f64>],
    after: &[Vec<f64>],
    range: std::ops::Range<usize>,
    t0: f64,
    dt: f64,
) -> Vec<WindowEvidence> {
    let count = 10;
    let len = range.len() / count;
    if len < 4 {
        return Vec::new();
    }
    (0..count)
        .map(|w| {
            let r = range.start + w * len..range.start + (w + 1) * len;
            let score = |sim: &[Vec<f64>]| {
                let v: Vec<f64> = measured
                    .iter()
                    .zip(sim)
                    .map(|(m, s)| signal::nrmse(&m[r.clone()], &s[r.clone()]).powi(2))
                    .collect();
                signal::mean(&v).sqrt()
            };
            WindowEvidence {
                time_s: [t0 + r.start as f64 * dt, t0 + r.end as f64 * dt],
                before: score(before),
                after: score(after),
            }
        })
        .collect()
}
