//! Raw-value limits of a physical signal. Shared, as source, by `build.rs` (which writes the
//! limits of the DBC's own factors into the generated table) and by `Layout::new` (which
//! recomputes them for other factors), so both always agree. Core arithmetic only: no `libm`,
//! no `std`.

/// Largest signal length in bits the codec handles for integer signals.
pub(crate) const MAX_INT_BITS: u8 = 32;

/// The raw value that means "not available" (J1939 style) for a physical signal of `len`
/// bits: the most negative value when signed, all ones when unsigned.
pub(crate) const fn not_available(len: u8, signed: bool) -> i64 {
    if signed {
        -(1_i64 << (len - 1))
    } else {
        (1_i64 << len) - 1
    }
}

/// Largest integer `<= v` for `|v| < 2^53`.
fn floor(v: f64) -> i64 {
    let t = v as i64;
    if (t as f64) > v {
        t - 1
    } else {
        t
    }
}

/// Smallest integer `>= v` for `|v| < 2^53`.
fn ceil(v: f64) -> i64 {
    let t = v as i64;
    if (t as f64) < v {
        t + 1
    } else {
        t
    }
}

/// Inclusive raw limits `(raw_min, raw_max)` of a physical signal of `len` bits
/// (`1..=MAX_INT_BITS`) with `physical = raw * factor + offset`, valid in `[min, max]`
/// (physical units), the "not available" pattern excluded. The limits in counts are widened by
/// a relative 2^-23 (two f32 rounding steps; the codec holds factors as f32) before rounding
/// inwards, so that a limit that is an exact multiple of a decimal factor (1 m at 1e-6 m,
/// 400 kN at 0.1 N) stays reachable despite binary rounding of the factor.
///
/// `None` when the factor is not finite and positive, an input is not finite, the length is
/// out of range, or no raw value is valid.
pub(crate) fn raw_limits(
    factor: f64,
    offset: f64,
    min: f64,
    max: f64,
    len: u8,
    signed: bool,
) -> Option<(i64, i64)> {
    let finite = factor.is_finite() && offset.is_finite() && min.is_finite() && max.is_finite();
    if !finite
        || factor <= 0.0
        || min > max
        || len == 0
        || len > MAX_INT_BITS
        || (signed && len < 2)
    {
        return None;
    }
    let (type_min, type_max) = if signed {
        (not_available(len, true) + 1, (1_i64 << (len - 1)) - 1)
    } else {
        (0, not_available(len, false) - 1)
    };
    let lo = (min - offset) / factor;
    let hi = (max - offset) / factor;
    // Clamp before converting so that the integer conversions stay far inside i64.
    let bound = (1_i64 << (MAX_INT_BITS + 1)) as f64;
    let lo = lo.clamp(-bound, bound);
    let hi = hi.clamp(-bound, bound);
    let tol = |v: f64| 1.2e-7 * (if v < 0.0 { -v } else { v }) + 1e-9;
    let raw_min = ceil(lo - tol(lo)).max(type_min);
    let raw_max = floor(hi + tol(hi)).min(type_max);
    if raw_min > raw_max {
        None
    } else {
        Some((raw_min, raw_max))
    }
}
