//! Real polynomials in descending powers of `s` (the convention of
//! [`mil_discretise::TransferFunction`]).

/// Product of two polynomials.
pub fn mul(a: &[f64], b: &[f64]) -> Vec<f64> {
    if a.is_empty() || b.is_empty() {
        return Vec::new();
    }
    let mut out = vec![0.0; a.len() + b.len() - 1];
    for (i, x) in a.iter().enumerate() {
        for (j, y) in b.iter().enumerate() {
            out[i + j] += x * y;
        }
    }
    out
}

/// Sum of two polynomials (aligned at the constant term).
pub fn add(a: &[f64], b: &[f64]) -> Vec<f64> {
    let n = a.len().max(b.len());
    let mut out = vec![0.0; n];
    for (k, x) in a.iter().rev().enumerate() {
        out[n - 1 - k] += x;
    }
    for (k, y) in b.iter().rev().enumerate() {
        out[n - 1 - k] += y;
    }
    out
}

/// `c · a`.
pub fn scale(a: &[f64], c: f64) -> Vec<f64> {
    a.iter().map(|x| x * c).collect()
}

/// Drops leading coefficients that are exactly zero. (Coefficients of different powers of
/// `s` are not comparable in size: `1e-13 s⁵` matters at a few kHz, so no relative
/// threshold is applied.)
pub fn trim(a: &[f64]) -> Vec<f64> {
    a.iter().skip_while(|x| **x == 0.0).copied().collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn product_and_sum_of_known_polynomials() {
        // (s + 1)(s + 2) = s² + 3 s + 2
        assert_eq!(mul(&[1.0, 1.0], &[1.0, 2.0]), vec![1.0, 3.0, 2.0]);
        // (s² + 3 s + 2) + (4 s + 1) = s² + 7 s + 3
        assert_eq!(add(&[1.0, 3.0, 2.0], &[4.0, 1.0]), vec![1.0, 7.0, 3.0]);
        assert_eq!(trim(&[0.0, 0.0, 2.0, 1.0]), vec![2.0, 1.0]);
        // A small leading coefficient of a high-order model is kept.
        assert_eq!(trim(&[1.3e-13, 3.4e-10, 1.0]), vec![1.3e-13, 3.4e-10, 1.0]);
        assert_eq!(scale(&[1.0, -2.0], 3.0), vec![3.0, -6.0]);
    }
}

/// A real rational function of `s` (descending powers), evaluated on the imaginary axis.
/// Unlike [`mil_discretise::TransferFunction`] it may be improper: a disturbance response
/// that contains an inertia (`−m s²`) grows without bound.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Rational {
    /// Numerator coefficients, descending powers of `s` (rad/s).
    pub numerator: Vec<f64>,
    /// Denominator coefficients, descending powers of `s`.
    pub denominator: Vec<f64>,
}

impl Rational {
    /// A rational function; leading (near-)zero coefficients are dropped.
    ///
    /// # Errors
    /// Non-finite coefficients or a zero denominator.
    pub fn new(numerator: Vec<f64>, denominator: Vec<f64>) -> crate::Result<Self> {
        let (numerator, denominator) = (trim(&numerator), trim(&denominator));
        if numerator.iter().chain(&denominator).any(|c| !c.is_finite()) {
            return Err(crate::error::setup_error(
                "non-finite polynomial coefficient",
            ));
        }
        if denominator.is_empty() {
            return Err(crate::error::setup_error("zero denominator polynomial"));
        }
        Ok(Self {
            numerator,
            denominator,
        })
    }

    /// Value at `s = j 2π f` (`f` in Hz).
    pub fn response(&self, frequency_hz: f64) -> num_complex::Complex64 {
        self.response_s(num_complex::Complex64::new(
            0.0,
            std::f64::consts::TAU * frequency_hz,
        ))
    }

    /// Value at a complex `s` (rad/s).
    pub fn response_s(&self, s: num_complex::Complex64) -> num_complex::Complex64 {
        mil_discretise::polyval(&self.numerator, s) / mil_discretise::polyval(&self.denominator, s)
    }
}
