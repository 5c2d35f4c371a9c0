//! Axis ranges, tick positions and tick labels.
//!
//! Every axis of every plot is an [`Axis`]: a linear or logarithmic `f64` coordinate with tick
//! positions computed here (not by plotters), so that log axes get decade labels with light
//! 2..9 grid lines and phase axes get ticks at multiples of 45 degrees or so.

use std::ops::Range;

use plotters::coord::ranged1d::{DefaultFormatting, KeyPointHint, Ranged};

/// Values beyond this magnitude are clamped before computing ranges, so that spans stay finite.
const HUGE: f64 = 1e300;

/// How tick labels are written.
#[derive(Clone, Copy, Debug, PartialEq)]
enum TickFormat {
    /// Fixed point with this many decimals.
    Fixed(usize),
    /// Scientific with this many mantissa decimals.
    Scientific(usize),
    /// Log-axis ticks (`k * 10^n`): plain numbers for moderate exponents, `2e-5` otherwise.
    LogTicks,
}

/// A linear or logarithmic plot axis with precomputed ticks.
#[derive(Clone, Debug)]
pub(crate) struct Axis {
    lo: f64,
    hi: f64,
    log: bool,
    /// `ln(lo)` and `ln(hi)` for a log axis.
    ln_lo: f64,
    ln_hi: f64,
    /// Labelled ticks (bold grid lines).
    bold: Vec<f64>,
    /// Unlabelled light grid lines.
    light: Vec<f64>,
    format: TickFormat,
}

impl Axis {
    /// A linear axis covering `values` (non-finite values ignored) with 5 % padding.
    pub(crate) fn linear(values: impl IntoIterator<Item = f64>) -> Option<Axis> {
        let (min, max) = min_max(values.into_iter().filter(|v| v.is_finite()))?;
        let (lo, hi) = padded_linear_range(min, max);
        Some(Self::linear_with_range(lo, hi))
    }

    /// A linear axis over exactly `lo..hi` (`lo < hi`, both finite) with nice ticks.
    fn linear_with_range(lo: f64, hi: f64) -> Axis {
        let (bold, light, format) = linear_ticks(lo, hi);
        Axis {
            lo,
            hi,
            log: false,
            ln_lo: 0.0,
            ln_hi: 0.0,
            bold,
            light,
            format,
        }
    }

    /// A logarithmic axis covering the positive finite `values` (others ignored).
    ///
    /// The range is widened by the factor `pad` at both ends (1 = no padding) and then snapped
    /// outwards to 1-2-5 values.
    pub(crate) fn log(values: impl IntoIterator<Item = f64>, pad: f64) -> Option<Axis> {
        let (min, max) = min_max(values.into_iter().filter(|v| v.is_finite() && *v > 0.0))?;
        let (min, max) = (min.max(1e-300), max.min(HUGE));
        let (min, max) = if max <= min * (1.0 + 1e-9) {
            (min / 2.0, max * 2.0)
        } else {
            (min / pad, max * pad)
        };
        let lo = snap_125_down(min);
        let hi = snap_125_up(max);
        if !(lo > 0.0 && hi > lo && hi.is_finite()) {
            return None;
        }
        let (bold, light, format) = log_ticks(lo, hi);
        Some(Axis {
            lo,
            hi,
            log: true,
            ln_lo: lo.ln(),
            ln_hi: hi.ln(),
            bold,
            light,
            format,
        })
    }

    /// A phase axis in degrees: ticks at multiples of 5, 15, 45, 90, 180 or 360 * 2^k degrees,
    /// range padded by 3 % at both ends.
    pub(crate) fn phase(values: impl IntoIterator<Item = f64>) -> Option<Axis> {
        let (min, max) = min_max(values.into_iter().filter(|v| v.is_finite()))?;
        if max - min > 36_000.0 {
            return Self::linear([min, max]);
        }
        let (lo, hi) = if max - min < 1.0 {
            (min - 5.0, max + 5.0)
        } else {
            let pad = 0.03 * (max - min);
            (min - pad, max + pad)
        };
        let mut step = 5.0;
        for candidate in [
            5.0, 15.0, 45.0, 90.0, 180.0, 360.0, 720.0, 1440.0, 2880.0, 5760.0,
        ] {
            step = candidate;
            if (hi / step).floor() - (lo / step).ceil() <= 8.0 {
                break;
            }
        }
        let multiples = |step: f64| -> Vec<f64> {
            let first = (lo / step).ceil();
            let count = ((hi / step).floor() - first).clamp(-1.0, 100.0) as i64;
            (0..=count).map(|k| (first + k as f64) * step).collect()
        };
        let bold = multiples(step);
        let light_step = if step >= 90.0 {
            step / 2.0
        } else if step >= 15.0 {
            step / 3.0
        } else {
            step / 5.0
        };
        let light = multiples(light_step)
            .into_iter()
            .filter(|v| !bold.iter().any(|b| (b - v).abs() < 1e-9 * step))
            .collect();
        Some(Axis {
            lo,
            hi,
            log: false,
            ln_lo: 0.0,
            ln_hi: 0.0,
            bold,
            light,
            format: TickFormat::Fixed(0),
        })
    }

    /// Whether `v` can be drawn on this axis (finite, and positive on a log axis).
    pub(crate) fn accepts(&self, v: f64) -> bool {
        v.is_finite() && (!self.log || v > 0.0)
    }

    /// The lower end of the range.
    pub(crate) fn lo(&self) -> f64 {
        self.lo
    }

    /// The upper end of the range.
    pub(crate) fn hi(&self) -> f64 {
        self.hi
    }

    /// The labelled tick positions.
    #[cfg(test)]
    pub(crate) fn ticks(&self) -> &[f64] {
        &self.bold
    }

    /// The tick labels.
    pub(crate) fn labels(&self) -> impl Iterator<Item = String> + '_ {
        self.bold.iter().map(|&v| self.label(v))
    }

    /// The tick label for `v`.
    pub(crate) fn label(&self, v: f64) -> String {
        match self.format {
            TickFormat::Fixed(decimals) => {
                let s = format!("{v:.decimals$}");
                // Avoid "-0" and "-0.0".
                if s.starts_with('-') && s[1..].chars().all(|c| c == '0' || c == '.') {
                    s[1..].to_string()
                } else {
                    s
                }
            }
            TickFormat::Scientific(_) if v == 0.0 => "0".to_string(),
            TickFormat::Scientific(decimals) => format!("{v:.decimals$e}"),
            TickFormat::LogTicks => log_tick_label(v),
        }
    }
}

impl Ranged for Axis {
    type FormatOption = DefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        let t = if self.log {
            (value.ln() - self.ln_lo) / (self.ln_hi - self.ln_lo)
        } else {
            (value - self.lo) / (self.hi - self.lo)
        };
        let pixel = f64::from(limit.0) + t * f64::from(limit.1 - limit.0);
        // NaN maps to 0 by `as`; clamping keeps wild values from producing huge paths.
        pixel.clamp(-1e5, 1e5).round() as i32
    }

    fn key_points<Hint: KeyPointHint>(&self, hint: Hint) -> Vec<f64> {
        if hint.weight().allow_light_points() {
            self.light.clone()
        } else {
            self.bold.clone()
        }
    }

    fn range(&self) -> Range<f64> {
        self.lo..self.hi
    }
}

/// Minimum and maximum of an iterator of non-NaN values, clamped to +-1e300.
fn min_max(values: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    values
        .map(|v| v.clamp(-HUGE, HUGE))
        .fold(None, |acc, v| match acc {
            None => Some((v, v)),
            Some((lo, hi)) => Some((v.min(lo), v.max(hi))),
        })
}

/// A linear range around `min..=max` with 5 % padding; a degenerate range is widened.
fn padded_linear_range(min: f64, max: f64) -> (f64, f64) {
    let scale = min.abs().max(max.abs());
    let span = max - min;
    if span <= 1e-9 * scale || span == 0.0 {
        let centre = 0.5 * (min + max);
        let d = 0.1 * centre.abs();
        if centre - d < centre + d {
            (centre - d, centre + d)
        } else {
            // Zero, or too small to widen relatively.
            (centre - 1.0, centre + 1.0)
        }
    } else {
        let pad = 0.05 * span;
        (min - pad, max + pad)
    }
}

/// A "nice" tick step (1, 2 or 5 times a power of ten) close to `raw`, and its mantissa.
fn nice_step(raw: f64) -> (f64, f64) {
    let exponent = raw.log10().floor();
    let power = 10f64.powf(exponent);
    let fraction = raw / power;
    let mantissa = if fraction < 1.5 {
        1.0
    } else if fraction < 3.0 {
        2.0
    } else if fraction < 7.0 {
        5.0
    } else {
        10.0
    };
    (mantissa * power, mantissa)
}

/// Nice ticks within `lo..=hi`: labelled, light, and the label format.
fn linear_ticks(lo: f64, hi: f64) -> (Vec<f64>, Vec<f64>, TickFormat) {
    let (step, mantissa) = nice_step((hi - lo) / 6.0);
    if !(step > 0.0 && step.is_finite()) {
        return (vec![lo, hi], vec![], TickFormat::Scientific(3));
    }
    let multiples = |step: f64| -> Vec<f64> {
        let first = (lo / step).ceil();
        let last = (hi / step).floor();
        let count = (last - first).clamp(-1.0, 200.0) as i64;
        (0..=count)
            .map(|k| {
                let v = (first + k as f64) * step;
                if v.abs() < step * 1e-9 {
                    0.0
                } else {
                    v
                }
            })
            .collect()
    };
    let bold = multiples(step);
    let light_step = if mantissa == 2.0 {
        step / 4.0
    } else {
        step / 5.0
    };
    let light = multiples(light_step)
        .into_iter()
        .filter(|v| !bold.iter().any(|b| (b - v).abs() < step * 1e-6))
        .collect();
    let largest = lo.abs().max(hi.abs());
    let step_exponent = step.log10().floor();
    let format = if largest >= 1e6 || step < 1e-4 {
        let digits = (largest.log10().floor() - step_exponent).clamp(0.0, 6.0);
        TickFormat::Scientific(digits as usize)
    } else {
        TickFormat::Fixed((-step_exponent).max(0.0) as usize)
    };
    (bold, light, format)
}

/// The largest 1, 2 or 5 times a power of ten that is at most `v` (`v > 0`).
fn snap_125_down(v: f64) -> f64 {
    let power = 10f64.powf(v.log10().floor());
    let fraction = v / power;
    let mantissa = if fraction >= 5.0 * (1.0 - 1e-9) {
        5.0
    } else if fraction >= 2.0 * (1.0 - 1e-9) {
        2.0
    } else {
        1.0
    };
    mantissa * power
}

/// The smallest 1, 2 or 5 times a power of ten that is at least `v` (`v > 0`).
fn snap_125_up(v: f64) -> f64 {
    let power = 10f64.powf(v.log10().floor());
    let fraction = v / power;
    let mantissa = if fraction <= 1.0 + 1e-9 {
        1.0
    } else if fraction <= 2.0 * (1.0 + 1e-9) {
        2.0
    } else if fraction <= 5.0 * (1.0 + 1e-9) {
        5.0
    } else {
        10.0
    };
    mantissa * power
}

/// Ticks for a log axis over `lo..=hi` (`0 < lo < hi`): decades where the range holds at least
/// two of them (thinned to at most about ten labels), else 1-2-5 values, else all 1..9 values,
/// else linear ticks.
fn log_ticks(lo: f64, hi: f64) -> (Vec<f64>, Vec<f64>, TickFormat) {
    let inside = |v: f64| v >= lo * (1.0 - 1e-9) && v <= hi * (1.0 + 1e-9);
    let first = lo.log10().floor() as i32 - 1;
    let last = hi.log10().ceil() as i32 + 1;
    let decades: Vec<i32> = (first..=last).filter(|&e| inside(pow10(e))).collect();
    let multiples = |mantissas: &[f64]| -> Vec<f64> {
        (first..=last)
            .flat_map(|e| mantissas.iter().map(move |m| m * pow10(e)))
            .filter(|&v| inside(v))
            .collect()
    };
    if decades.len() >= 2 {
        let thin = decades.len().div_ceil(10).max(1) as i32;
        let bold: Vec<f64> = decades
            .iter()
            .filter(|&&e| e.rem_euclid(thin) == 0)
            .map(|&e| pow10(e))
            .collect();
        let light = if thin == 1 {
            multiples(&[2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0])
        } else {
            decades
                .iter()
                .filter(|&&e| e.rem_euclid(thin) != 0)
                .map(|&e| pow10(e))
                .collect()
        };
        return (bold, light, TickFormat::LogTicks);
    }
    let one_two_five = multiples(&[1.0, 2.0, 5.0]);
    if one_two_five.len() >= 3 {
        let light = multiples(&[3.0, 4.0, 6.0, 7.0, 8.0, 9.0]);
        return (one_two_five, light, TickFormat::LogTicks);
    }
    let all = multiples(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0]);
    if all.len() >= 2 {
        return (all, vec![], TickFormat::LogTicks);
    }
    linear_ticks(lo, hi)
}

/// `10^e` for a decade exponent.
fn pow10(e: i32) -> f64 {
    10f64.powi(e)
}

/// A label for a log-axis tick `k * 10^n`.
fn log_tick_label(v: f64) -> String {
    if !(v > 0.0 && v.is_finite()) {
        return format!("{v}");
    }
    let exponent = (v.log10() + 1e-9).floor();
    if (-3.0..5.0).contains(&exponent) {
        let decimals = (-exponent).max(0.0) as usize;
        format!("{v:.decimals$}")
    } else {
        let mantissa = v / 10f64.powf(exponent);
        let mantissa = (mantissa * 10.0).round() / 10.0;
        if (mantissa - 1.0).abs() < 1e-9 {
            format!("1e{exponent}")
        } else {
            format!("{mantissa}e{exponent}")
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_axis_snaps_to_125_and_labels_decades() {
        let axis = Axis::log([0.3, 150.0], 1.0).unwrap();
        assert!((axis.lo() - 0.2).abs() < 1e-12, "lo {}", axis.lo());
        assert!((axis.hi() - 200.0).abs() < 1e-9, "hi {}", axis.hi());
        assert_eq!(axis.ticks(), &[1.0, 10.0, 100.0]);
        assert_eq!(axis.label(1.0), "1");
        assert_eq!(axis.label(100.0), "100");
        let small = Axis::log([1e-7, 1e-3], 1.0).unwrap();
        assert_eq!(small.label(1e-7), "1e-7");
        assert_eq!(small.label(1e-3), "0.001");
    }

    #[test]
    fn log_axis_within_one_decade_uses_125_ticks() {
        let axis = Axis::log([12.0, 45.0], 1.0).unwrap();
        assert_eq!(axis.ticks(), &[10.0, 20.0, 50.0]);
        let axis = Axis::log([21.0, 33.0], 1.0).unwrap();
        assert_eq!(axis.ticks(), &[20.0, 30.0, 40.0, 50.0]);
        let narrow = Axis::log([2.1, 2.9], 1.0).unwrap();
        assert!(narrow.ticks().len() >= 2);
    }

    #[test]
    fn log_axis_skips_non_positive_and_handles_single_point() {
        let axis = Axis::log([0.0, -3.0, f64::NAN, 7.0], 1.0).unwrap();
        assert!(axis.lo() < 7.0 && axis.hi() > 7.0);
        assert!(Axis::log([0.0, -1.0], 1.0).is_none());
    }

    #[test]
    fn linear_axis_degenerate_and_padded() {
        let axis = Axis::linear([3.0, 3.0]).unwrap();
        assert!(axis.lo() < 3.0 && axis.hi() > 3.0);
        let zero = Axis::linear([0.0]).unwrap();
        assert!(zero.lo() < 0.0 && zero.hi() > 0.0);
        let axis = Axis::linear([0.0, 10.0, f64::INFINITY]).unwrap();
        assert!(axis.lo() < 0.0 && axis.hi() > 10.0 && axis.hi() < 11.0);
        assert_eq!(axis.ticks(), &[0.0, 2.0, 4.0, 6.0, 8.0, 10.0]);
        assert_eq!(axis.label(4.0), "4");
        assert!(Axis::linear([f64::NAN]).is_none());
        let micro = Axis::linear([0.0, 5e-5]).unwrap();
        assert_eq!(micro.label(0.0), "0");
        assert_eq!(micro.label(2e-5), "2e-5");
        let subnormal = Axis::linear([5e-324]).unwrap();
        assert!(subnormal.lo() < subnormal.hi());
        let huge = Axis::linear([-f64::MAX, f64::MAX]).unwrap();
        assert!(huge.lo().is_finite() && huge.hi().is_finite());
    }

    #[test]
    fn phase_axis_ticks_at_multiples_of_45_or_90() {
        let axis = Axis::phase([-10.0, -200.0]).unwrap();
        assert!(axis.lo() < -200.0 && axis.lo() > -210.0, "{}", axis.lo());
        assert!(axis.hi() > -10.0 && axis.hi() < 0.0, "{}", axis.hi());
        assert_eq!(axis.ticks(), &[-180.0, -135.0, -90.0, -45.0]);
        let turns = Axis::phase([0.0, -1000.0]).unwrap();
        assert!(turns.ticks().iter().all(|t| t % 180.0 == 0.0));
        assert!(turns.ticks().len() >= 4);
        let flat = Axis::phase([0.0]).unwrap();
        assert!(flat.lo() < 0.0 && flat.hi() > 0.0);
    }
}
