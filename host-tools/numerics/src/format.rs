//! Figures as a person reads them: a number to its significant digits, a fitted value to
//! the digits its uncertainty leaves meaningful. The tools' summaries print with these; files
//! keep full precision.

/// `x` to `digits` significant digits for a person to read: plain notation from 0.001 to
/// 99 999 (`339`, `2.45`, `0.0123`, a whole number never cut: `12346`), scientific beyond
/// (`1.56e6`, `4.1e-5`); `0`, `inf`, `NaN` as such. The tools' summaries print figures
/// whose decimals have no fixed meaning with it (a response's magnitude, a sensitivity).
pub fn number(x: f64, digits: usize) -> String {
    let digits = digits.max(1);
    if x == 0.0 || !x.is_finite() {
        return format!("{}", x + 0.0);
    }
    let magnitude = x.abs();
    if (1e-3..99_999.5).contains(&magnitude) {
        let exponent = magnitude.log10().floor() as i64;
        let decimals = (digits as i64 - 1 - exponent).max(0) as usize;
        let text = format!("{x:.decimals$}");
        // Rounding up to the next decade (9.996 -> "10.00") keeps one decimal too many.
        let rounded: f64 = text.parse().unwrap_or(x);
        if rounded.abs().log10().floor() as i64 > exponent && decimals > 0 {
            return format!("{x:.prec$}", prec = decimals - 1);
        }
        text
    } else {
        format!("{x:.prec$e}", prec = digits - 1)
    }
}

/// `value ± sd` with the value rounded where the uncertainty's second significant digit
/// lies: `2500.708 ± 0.087`, `120012.3 ± 2.9`, `-0.00055 ± 0.00075`. Beyond plain notation
/// (|value| from 1e6, or an uncertainty below 1e-9) both in scientific notation; an
/// uncertainty that is not positive and finite gives the value to 6 digits and `± sd` as it
/// is (`± NaN`).
pub fn with_uncertainty(value: f64, sd: f64) -> String {
    if !(sd.is_finite() && sd > 0.0 && value.is_finite()) {
        return format!("{} ± {}", number(value, 6), number(sd, 2));
    }
    let decimals = 1 - sd.log10().floor() as i64;
    if value.abs() >= 1e6 || decimals > 10 {
        return format!("{value:.6e} ± {sd:.1e}");
    }
    // An uncertainty of tens or more: whole numbers.
    let decimals = decimals.max(0) as usize;
    format!("{value:.decimals$} ± {sd:.decimals$}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_are_printed_to_their_significant_digits() {
        for (x, digits, text) in [
            (339.12, 3, "339"),
            (2.4518, 3, "2.45"),
            (0.012_345, 3, "0.0123"),
            (1000.0, 3, "1000"),
            (12_345.6, 3, "12346"),
            (1_561_600.0, 3, "1.56e6"),
            (14_040_000.0, 3, "1.40e7"),
            (-0.000_041_2, 2, "-4.1e-5"),
            (9.996, 3, "10.0"),
            (0.999_96, 3, "1.00"),
            (-17.17, 3, "-17.2"),
            (0.0, 3, "0"),
            (-0.0, 3, "0"),
            (f64::INFINITY, 3, "inf"),
            (f64::NAN, 3, "NaN"),
            (3.0, 0, "3"),
        ] {
            assert_eq!(number(x, digits), text, "{x} to {digits} digits");
        }
    }

    #[test]
    fn a_value_shows_the_digits_its_uncertainty_leaves() {
        for (value, sd, text) in [
            (2500.708, 8.73e-2, "2500.708 ± 0.087"),
            (1.200123e5, 2.93, "120012.3 ± 2.9"),
            (-5.539932e-4, 7.50e-4, "-0.00055 ± 0.00075"),
            (-1667.700, 1.54e-3, "-1667.7000 ± 0.0015"),
            (20.00434, 3.34e-4, "20.00434 ± 0.00033"),
            (150.0167, 25.0, "150 ± 25"),
            (150.0167, 250.0, "150 ± 250"),
            (6.0e9, 1.0e7, "6.000000e9 ± 1.0e7"),
            (1.0, 1e-12, "1.000000e0 ± 1.0e-12"),
            (3.5, f64::NAN, "3.50000 ± NaN"),
            (3.5, 0.0, "3.50000 ± 0"),
        ] {
            assert_eq!(with_uncertainty(value, sd), text, "{value} ± {sd}");
        }
    }
}
