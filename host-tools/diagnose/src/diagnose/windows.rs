//! Where the output-error refinement simulates a long record: [`REFINE_WINDOWS`] windows
//! placed by a density that mixes the uniform one with the outputs' power, each weighted by
//! the share of the record it stands for.

/// Windows the output-error refinement simulates when the fitting blocks hold more than its
/// budget ([`REFINE_EFFECTIVE_SAMPLES`](super::REFINE_EFFECTIVE_SAMPLES)): 8, evenly spread over the record.
pub const REFINE_WINDOWS: usize = 8;

/// The share of the uniform density in the one that places the output-error refinement's
/// windows ([`REFINE_WINDOWS`]): 0.5, the rest the outputs' power. A sine sweep's
/// resonance or a bump sequence's bumps hold most of what tells a model's dynamics apart in
/// a few seconds of the record; evenly spaced windows missed them (a Bouc-Wen loop refined
/// on them fitted its windows better and the whole record worse than the linear model). The
/// uniform half keeps windows in the quiet parts, where dry friction and free play show.
/// Each window's squared residuals are weighted by the share of the record it stands for,
/// so that the windows' cost estimates the whole record's whatever their places. Chosen
/// before any run (an even mixture), not tuned; checked on the development set and matrix.
pub const REFINE_UNIFORM_SHARE: f64 = 0.5;

/// A window of the output-error refinement ([`place_windows`]).
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Placed {
    /// The samples simulated.
    pub(super) range: std::ops::Range<usize>,
    /// The first sample scored (the ones before warm the window up).
    pub(super) from: usize,
    /// The weight of its squared residuals: the fitting samples it stands for per fitting
    /// sample it scores.
    pub(super) weight: f64,
}

/// Where the output-error refinement simulates a record of per-sample output power `power`
/// and fitting samples `is_fit`, for a budget of `budget` fitting samples (with a quarter
/// more for the windows' share of validation samples and edges), each window warmed up
/// over at least `warm_min` samples and a fifth of its length. `None`: the whole record
/// (its fitting samples are within the budget, or the windows would cover it).
///
/// The record is cut into [`REFINE_WINDOWS`] strata of equal share of a density that mixes
/// the uniform one ([`REFINE_UNIFORM_SHARE`]) with the power's; each stratum has one
/// window, the part it scores centred on the stratum's middle, weighted by the stratum's
/// fitting samples per fitting sample it scores, so that the windows' weighted sum of
/// squares estimates the whole record's wherever they lie.
pub(super) fn place_windows(
    power: &[f64],
    is_fit: &[bool],
    budget: f64,
    warm_min: usize,
) -> Option<Vec<Placed>> {
    let len = power.len().min(is_fit.len());
    let fit = is_fit.iter().take(len).filter(|f| **f).count();
    if len == 0 || fit as f64 <= budget {
        return None;
    }
    let share = fit as f64 / len as f64;
    let wl = (budget / share / REFINE_WINDOWS as f64 * 1.25).ceil() as usize;
    let warm = (wl / 5).max(warm_min);
    let wl = wl - wl / 5 + warm;
    if REFINE_WINDOWS * wl >= len {
        return None;
    }
    let total_power = power.iter().take(len).sum::<f64>();
    let mut acc = 0.0;
    let cumulative: Vec<f64> = power
        .iter()
        .take(len)
        .map(|e| {
            let p = if total_power > 0.0 {
                e / total_power
            } else {
                0.0
            };
            acc += REFINE_UNIFORM_SHARE / len as f64 + (1.0 - REFINE_UNIFORM_SHARE) * p;
            acc
        })
        .collect();
    let total = cumulative.last().copied().unwrap_or(1.0);
    let at = |c: f64| cumulative.partition_point(|&v| v < c).min(len);
    let fits = |r: std::ops::Range<usize>| {
        is_fit
            .get(r)
            .map_or(0, |f| f.iter().filter(|f| **f).count())
    };
    let k_of = |k: usize| k as f64 / REFINE_WINDOWS as f64 * total;
    Some(
        (0..REFINE_WINDOWS)
            .map(|k| {
                let stratum = if k + 1 == REFINE_WINDOWS {
                    at(k_of(k))..len
                } else {
                    at(k_of(k))..at(k_of(k + 1))
                };
                let centre = at(k_of(k) + 0.5 * total / REFINE_WINDOWS as f64).min(len - 1);
                let s0 = centre.saturating_sub(warm + (wl - warm) / 2).min(len - wl);
                let from = if s0 == 0 { 0 } else { s0 + warm };
                let weight = fits(stratum) as f64 / fits(from..s0 + wl).max(1) as f64;
                Placed {
                    range: s0..s0 + wl,
                    from,
                    weight,
                }
            })
            .collect(),
    )
}

#[cfg(test)]
mod window_tests {
    use super::*;

    /// 50 000 samples in blocks of 100, 7 of every 10 fitting.
    fn fitting(len: usize) -> Vec<bool> {
        (0..len).map(|t| (t / 100) % 10 < 7).collect()
    }

    fn scored(p: &Placed, is_fit: &[bool]) -> usize {
        (p.from..p.range.end).filter(|&t| is_fit[t]).count()
    }

    /// A sweep's resonance: the outputs' power 400 times higher over 5 % of the record.
    /// Windows cluster there (half the density is the power's, which the burst holds 95 %
    /// of), the rest spread over the quiet parts; the weighted windows stand for every
    /// fitting sample exactly once; each warms up over at least what was asked.
    #[test]
    fn windows_follow_the_power_and_stand_for_the_whole_record() {
        let len = 50_000;
        let burst = 15_000..17_500;
        let power: Vec<f64> = (0..len)
            .map(|t| if burst.contains(&t) { 400.0 } else { 1.0 })
            .collect();
        let is_fit = fitting(len);
        let warm_min = 900;
        let placed = place_windows(&power, &is_fit, 2000.0, warm_min).expect("windows");
        assert_eq!(placed.len(), REFINE_WINDOWS);
        let stood_for: f64 = placed
            .iter()
            .map(|p| p.weight * scored(p, &is_fit) as f64)
            .sum();
        let fit = is_fit.iter().filter(|f| **f).count() as f64;
        assert!((stood_for - fit).abs() < 1e-6 * fit, "{stood_for} of {fit}");
        let in_burst = placed
            .iter()
            .filter(|p| {
                let mid = (p.from + p.range.end) / 2;
                burst.contains(&mid)
            })
            .count();
        assert!(in_burst >= 3, "{in_burst} windows at the burst: {placed:?}");
        assert!(
            in_burst < REFINE_WINDOWS,
            "no window in the quiet parts: {placed:?}"
        );
        for p in &placed {
            assert!(p.range.end <= len);
            let warm = p.from - p.range.start;
            assert!(p.range.start == 0 || warm >= warm_min, "{p:?}");
            assert!(p.range.start == 0 || 5 * warm >= p.range.len(), "{p:?}");
        }
    }

    /// Even power: the windows sit in the middles of eight equal strata; a budget that
    /// holds the record's fitting samples, or windows that would cover it, give the whole
    /// record.
    #[test]
    fn even_power_spreads_the_windows_and_a_covered_record_is_simulated_whole() {
        let len = 50_000;
        let power = vec![1.0; len];
        let is_fit = fitting(len);
        let placed = place_windows(&power, &is_fit, 2000.0, 0).expect("windows");
        for (k, p) in placed.iter().enumerate() {
            let mid = (p.from + p.range.end) as f64 / 2.0;
            let want = (k as f64 + 0.5) * len as f64 / REFINE_WINDOWS as f64;
            assert!((mid - want).abs() <= 2.0, "window {k}: {p:?}");
        }
        assert_eq!(place_windows(&power, &is_fit, 35_000.0, 0), None);
        assert_eq!(place_windows(&power, &is_fit, 2000.0, len / 8), None);
    }
}
