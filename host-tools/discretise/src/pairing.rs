//! Grouping poles and zeros into first- and second-order sections (the `zpk2sos` "nearest"
//! strategy): complex poles stay with their conjugate, real poles are paired in order of
//! their priority, and every pole group, worst (lowest priority) first, takes the zeros
//! nearest to its worst pole, subject to the remaining zeros still fitting the remaining
//! groups (a complex zero pair needs a two-pole group).

use num_complex::Complex64;

use crate::error::{DiscretiseError, Result};
use crate::poly::Conjugates;

/// A real root or a conjugate pair (given by its upper member).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Root {
    /// A real root.
    Real(f64),
    /// A complex-conjugate pair.
    Pair(Complex64),
}

impl Root {
    /// Position used for distances (upper member for a pair).
    pub fn pos(self) -> Complex64 {
        match self {
            Root::Real(r) => Complex64::new(r, 0.0),
            Root::Pair(p) => p,
        }
    }
}

/// One section: one or two poles and at most as many zeros.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct Group {
    /// One `Pair`, or one or two `Real`s.
    pub poles: Vec<Root>,
    /// At most as many zeros as poles: one `Pair`, or up to two `Real`s.
    pub zeros: Vec<Root>,
}

impl Group {
    /// Number of poles in the group (1 or 2).
    pub fn order(&self) -> usize {
        self.poles
            .iter()
            .map(|r| match r {
                Root::Real(_) => 1,
                Root::Pair(_) => 2,
            })
            .sum()
    }
}

/// Groups poles and zeros into sections; returns them best first, worst (lowest
/// `priority` of its worst pole) last.
///
/// # Errors
/// [`DiscretiseError::Improper`] when there are more zeros than poles.
pub(crate) fn group_roots<P>(
    poles: &Conjugates,
    zeros: &Conjugates,
    priority: P,
) -> Result<Vec<Group>>
where
    P: Fn(Complex64) -> f64,
{
    if zeros.len() > poles.len() {
        return Err(DiscretiseError::Improper {
            zeros: zeros.len(),
            poles: poles.len(),
        });
    }
    let mut real_poles = poles.reals.clone();
    real_poles.sort_by(|a, b| {
        priority(Complex64::new(*a, 0.0)).total_cmp(&priority(Complex64::new(*b, 0.0)))
    });
    let mut groups: Vec<(f64, Complex64, Group)> = Vec::new();
    for &p in &poles.pairs {
        groups.push((
            priority(p),
            p,
            Group {
                poles: vec![Root::Pair(p)],
                zeros: Vec::new(),
            },
        ));
    }
    for chunk in real_poles.chunks(2) {
        let Some(&worst) = chunk.first() else {
            continue;
        };
        let worst = Complex64::new(worst, 0.0);
        groups.push((
            priority(worst),
            worst,
            Group {
                poles: chunk.iter().map(|&r| Root::Real(r)).collect(),
                zeros: Vec::new(),
            },
        ));
    }
    groups.sort_by(|a, b| a.0.total_cmp(&b.0));

    let mut zr = zeros.reals.clone();
    let mut zc = zeros.pairs.clone();
    let mut g2 = groups.iter().filter(|g| g.2.order() == 2).count();
    let mut g1 = groups.len() - g2;
    for (_, reference, group) in &mut groups {
        let reference = *reference;
        let order = group.order();
        if order == 2 {
            g2 -= 1;
        } else {
            g1 -= 1;
        }
        let feasible = |nr: usize, nc: usize| nc <= g2 && nr + 2 * nc <= 2 * g2 + g1;
        let nearest = |set: &[Complex64]| {
            set.iter()
                .enumerate()
                .map(|(j, z)| (j, (z - reference).norm()))
                .min_by(|a, b| a.1.total_cmp(&b.1))
        };
        let reals_c: Vec<Complex64> = zr.iter().map(|&r| Complex64::new(r, 0.0)).collect();
        let nearest_real = nearest(&reals_c);
        let nearest_pair = nearest(&zc);
        if order == 1 {
            if let Some((j, _)) = nearest_real {
                group.zeros.push(Root::Real(zr.swap_remove(j)));
            }
            continue;
        }
        let take_reals = zr.len().min(2);
        let option_pair = nearest_pair.map(|(j, d)| (j, d, feasible(zr.len(), zc.len() - 1)));
        let option_reals =
            nearest_real.map(|(_, d)| (d, feasible(zr.len() - take_reals, zc.len())));
        let choose_pair = match (option_pair, option_reals) {
            // Nearest kind wins when both keep the rest feasible (or neither does).
            (Some((_, dp, fp)), Some((dr, fr))) => {
                if fp == fr {
                    dp <= dr
                } else {
                    fp
                }
            }
            (Some(_), None) => true,
            _ => false,
        };
        if choose_pair {
            if let Some((j, _, _)) = option_pair {
                group.zeros.push(Root::Pair(zc.swap_remove(j)));
            }
        } else {
            for _ in 0..take_reals {
                let reals_c: Vec<Complex64> = zr.iter().map(|&r| Complex64::new(r, 0.0)).collect();
                if let Some((j, _)) = nearest(&reals_c) {
                    group.zeros.push(Root::Real(zr.swap_remove(j)));
                }
            }
        }
    }
    Ok(groups.into_iter().rev().map(|g| g.2).collect())
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests {
    use super::*;

    #[test]
    fn complex_zero_pair_goes_to_two_pole_group() {
        // One real pole nearest to the complex zeros, but the pair must go to the complex
        // pole group because a one-pole group cannot hold it.
        let poles = Conjugates {
            reals: vec![0.5],
            pairs: vec![Complex64::new(-3.0, 3.0)],
        };
        let zeros = Conjugates {
            reals: vec![-4.0],
            pairs: vec![Complex64::new(0.5, 0.1)],
        };
        let groups = group_roots(&poles, &zeros, |x| x.norm()).unwrap();
        assert_eq!(groups.len(), 2);
        for g in &groups {
            assert!(g.zeros.len() <= g.poles.len());
            if g.order() == 1 {
                assert_eq!(g.zeros, vec![Root::Real(-4.0)]);
            }
        }
    }
}
