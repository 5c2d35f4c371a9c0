//! Interpolation of uniformly sampled signals.

/// `u` at fractional sample index `s` (linear interpolation; the end samples are held
/// outside the record, an empty signal is 0).
pub fn sample_at(u: &[f64], s: f64) -> f64 {
    let (Some(&first), Some(&last)) = (u.first(), u.last()) else {
        return 0.0;
    };
    if s <= 0.0 || s.is_nan() {
        return first;
    }
    let end = u.len() - 1;
    if s >= end as f64 {
        return last;
    }
    let i = s.floor() as usize;
    let f = s - i as f64;
    u[i] + f * (u[i + 1] - u[i])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interpolates_inside_and_holds_the_ends() {
        let u = [0.0, 10.0, 30.0];
        assert_eq!(sample_at(&u, 0.5), 5.0);
        assert_eq!(sample_at(&u, 1.25), 15.0);
        assert_eq!(sample_at(&u, -3.0), 0.0);
        assert_eq!(sample_at(&u, 7.0), 30.0);
        assert_eq!(sample_at(&u, 2.0), 30.0);
        assert_eq!(sample_at(&[], 1.0), 0.0);
    }
}
