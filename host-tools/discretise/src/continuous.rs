//! Continuous-time linear models: transfer function, zero-pole-gain and state space.
//!
//! Frequencies are in Hz, the Laplace variable `s` in rad/s.

use nalgebra::DMatrix;
use num_complex::Complex64;

use crate::error::{DiscretiseError, Result};
use crate::pairing::{group_roots, Group, Root};
use crate::poly::{polyval, roots_conjugates, Conjugates};

/// `s = j 2π f` for a frequency in Hz.
pub(crate) fn s_at(f_hz: f64) -> Complex64 {
    Complex64::new(0.0, std::f64::consts::TAU * f_hz)
}

/// A continuous single-input single-output transfer function
/// `H(s) = (num[0] s^m + … + num[m]) / (den[0] s^n + … + den[n])`,
/// coefficients in descending powers of `s` (rad/s).
#[derive(Clone, Debug, PartialEq)]
pub struct TransferFunction {
    /// Numerator coefficients, descending powers of `s`.
    pub num: Vec<f64>,
    /// Denominator coefficients, descending powers of `s`.
    pub den: Vec<f64>,
}

/// Drops leading zero coefficients.
fn trim_leading(p: &[f64]) -> Vec<f64> {
    p.iter().skip_while(|&&c| c == 0.0).copied().collect()
}

impl TransferFunction {
    /// A transfer function from its coefficients (descending powers of `s`); leading zeros are
    /// dropped.
    ///
    /// # Errors
    /// Non-finite coefficients, an all-zero denominator, or an improper function (numerator
    /// degree above the denominator's).
    pub fn new(num: Vec<f64>, den: Vec<f64>) -> Result<Self> {
        let tf = Self {
            num: trim_leading(&num),
            den: trim_leading(&den),
        };
        tf.checked()?;
        Ok(tf)
    }

    /// Trimmed `(num, den)` after validation.
    fn checked(&self) -> Result<(Vec<f64>, Vec<f64>)> {
        if self.num.iter().chain(&self.den).any(|c| !c.is_finite()) {
            return Err(DiscretiseError::NonFinite("transfer function coefficients"));
        }
        let num = trim_leading(&self.num);
        let den = trim_leading(&self.den);
        if den.is_empty() {
            return Err(DiscretiseError::ZeroPolynomial("denominator"));
        }
        if num.len() > den.len() {
            return Err(DiscretiseError::Improper {
                zeros: num.len() - 1,
                poles: den.len() - 1,
            });
        }
        Ok((num, den))
    }

    /// Frequency response `H(j 2π f)` at `f_hz` (Hz).
    pub fn response(&self, f_hz: f64) -> Complex64 {
        let s = s_at(f_hz);
        polyval(&self.num, s) / polyval(&self.den, s)
    }

    /// Zeros, poles and gain (`gain = num[0] / den[0]` after trimming). Roots come from
    /// [`crate::polynomial_roots`]: polished, complex ones in exact conjugate pairs.
    ///
    /// # Errors
    /// As [`TransferFunction::new`], or a root-finding failure.
    pub fn to_zpk(&self) -> Result<Zpk> {
        let (num, den) = self.checked()?;
        let poles = roots_conjugates(&den, "denominator")?.to_roots();
        let Some(&num_lead) = num.first() else {
            return Ok(Zpk {
                zeros: Vec::new(),
                poles,
                gain: 0.0,
            });
        };
        let zeros = roots_conjugates(&num, "numerator")?.to_roots();
        let den_lead = den.first().copied().unwrap_or(1.0);
        Ok(Zpk {
            zeros,
            poles,
            gain: num_lead / den_lead,
        })
    }

    /// A minimal state-space realisation (see [`Zpk::to_state_space`]).
    ///
    /// # Errors
    /// As [`TransferFunction::to_zpk`].
    pub fn to_state_space(&self) -> Result<StateSpace> {
        self.to_zpk()?.to_state_space()
    }
}

/// A continuous single-input single-output system in zero-pole-gain form,
/// `H(s) = gain · Π (s - zeros[i]) / Π (s - poles[j])` with `s` in rad/s.
///
/// Complex zeros and poles must come in conjugate pairs (the system is real).
#[derive(Clone, Debug, PartialEq)]
pub struct Zpk {
    /// Finite zeros (rad/s).
    pub zeros: Vec<Complex64>,
    /// Poles (rad/s).
    pub poles: Vec<Complex64>,
    /// Gain (coefficient of the highest power of `s` in the numerator over the
    /// denominator's, which is monic).
    pub gain: f64,
}

impl Zpk {
    /// A zero-pole-gain system; conjugate pairs are made exactly conjugate.
    ///
    /// # Errors
    /// Non-finite values, unmatched complex roots, or more zeros than poles.
    pub fn new(zeros: Vec<Complex64>, poles: Vec<Complex64>, gain: f64) -> Result<Self> {
        let (z, p) = Self { zeros, poles, gain }.split()?;
        Ok(Self {
            zeros: z.to_roots(),
            poles: p.to_roots(),
            gain,
        })
    }

    /// A second-order section with natural frequency `f_n_hz` (Hz), damping ratio `zeta` and
    /// unit DC gain: `ω² / (s² + 2ζω s + ω²)`, `ω = 2π f_n`.
    ///
    /// # Errors
    /// Non-finite or non-positive `f_n_hz`, or non-finite / negative `zeta`.
    pub fn second_order_lowpass(f_n_hz: f64, zeta: f64) -> Result<Self> {
        if !(f_n_hz.is_finite() && f_n_hz > 0.0 && zeta.is_finite() && zeta >= 0.0) {
            return Err(DiscretiseError::NonFinite(
                "second-order section parameters",
            ));
        }
        let w = std::f64::consts::TAU * f_n_hz;
        let poles = if zeta < 1.0 {
            let p = Complex64::new(-zeta * w, w * (1.0 - zeta * zeta).sqrt());
            vec![p, p.conj()]
        } else {
            // Overdamped: p1 p2 = ω², p1 + p2 = -2ζω; the small root from the product.
            let big = -w * (zeta + (zeta * zeta - 1.0).sqrt());
            vec![Complex64::new(big, 0.0), Complex64::new(w * w / big, 0.0)]
        };
        Ok(Self {
            zeros: Vec::new(),
            poles,
            gain: w * w,
        })
    }

    /// Validated roots as conjugate sets `(zeros, poles)`.
    pub(crate) fn split(&self) -> Result<(Conjugates, Conjugates)> {
        if !self.gain.is_finite() {
            return Err(DiscretiseError::NonFinite("gain"));
        }
        let zeros = Conjugates::split(&self.zeros, "zero")?;
        let poles = Conjugates::split(&self.poles, "pole")?;
        if zeros.len() > poles.len() {
            return Err(DiscretiseError::Improper {
                zeros: zeros.len(),
                poles: poles.len(),
            });
        }
        Ok((zeros, poles))
    }

    /// Frequency response `H(j 2π f)` at `f_hz` (Hz).
    pub fn response(&self, f_hz: f64) -> Complex64 {
        let s = s_at(f_hz);
        let num: Complex64 = self.zeros.iter().map(|z| s - z).product();
        let den: Complex64 = self.poles.iter().map(|p| s - p).product();
        num / den * self.gain
    }

    /// The equivalent transfer function (monic denominator).
    ///
    /// # Errors
    /// As [`Zpk::new`].
    pub fn to_transfer_function(&self) -> Result<TransferFunction> {
        let (zeros, poles) = self.split()?;
        Ok(TransferFunction {
            num: zeros.monic_poly().iter().map(|c| c * self.gain).collect(),
            den: poles.monic_poly(),
        })
    }

    /// A minimal state-space realisation as a series connection of first- and second-order
    /// blocks (poles grouped with their nearest zeros). Each second-order block
    /// `(n0 s² + n1 s + n2)/(s² + d1 s + d2)` uses the scaled companion form
    /// `A = [[0, ω0], [-d2/ω0, -d1]]`, `B = [0, 1]ᵀ`, `C = [(n2 - n0 d2)/ω0, n1 - n0 d1]`,
    /// `D = n0` with `ω0 = √|d2|`, which keeps the entries at the block's own frequency
    /// scale. The gain is applied to the last block's `C` and `D`.
    ///
    /// # Errors
    /// As [`Zpk::new`].
    pub fn to_state_space(&self) -> Result<StateSpace> {
        let (zeros, poles) = self.split()?;
        let groups = group_roots(&poles, &zeros, |s| s.re.abs())?;
        let mut total = StateSpace::gain(1.0);
        for g in &groups {
            total = series(&total, &block(g));
        }
        total.c *= self.gain;
        total.d *= self.gain;
        Ok(total)
    }
}

/// Real polynomial (descending) of the roots of a group member list.
fn group_poly(roots: &[Root]) -> Vec<f64> {
    let mut set = Conjugates::default();
    for r in roots {
        match *r {
            Root::Real(x) => set.reals.push(x),
            Root::Pair(p) => set.pairs.push(p),
        }
    }
    set.monic_poly()
}

/// State-space realisation of one pole group (unit gain).
fn block(g: &Group) -> StateSpace {
    let den = group_poly(&g.poles);
    let num_short = group_poly(&g.zeros);
    // Pad the numerator to the denominator's length (leading zeros).
    let mut num = vec![0.0; den.len().saturating_sub(num_short.len())];
    num.extend(num_short);
    match (den.as_slice(), num.as_slice()) {
        ([_, d1], [n0, n1]) => StateSpace {
            a: DMatrix::from_element(1, 1, -d1),
            b: DMatrix::from_element(1, 1, 1.0),
            c: DMatrix::from_element(1, 1, n1 - n0 * d1),
            d: DMatrix::from_element(1, 1, *n0),
        },
        ([_, d1, d2], [n0, n1, n2]) => {
            let w0 = if *d2 == 0.0 { 1.0 } else { d2.abs().sqrt() };
            StateSpace {
                a: DMatrix::from_row_slice(2, 2, &[0.0, w0, -d2 / w0, -d1]),
                b: DMatrix::from_row_slice(2, 1, &[0.0, 1.0]),
                c: DMatrix::from_row_slice(1, 2, &[(n2 - n0 * d2) / w0, n1 - n0 * d1]),
                d: DMatrix::from_element(1, 1, *n0),
            }
        }
        _ => StateSpace::gain(1.0),
    }
}

/// `second ∘ first`: the output of `first` drives `second`.
fn series(first: &StateSpace, second: &StateSpace) -> StateSpace {
    let (n1, n2) = (first.a.nrows(), second.a.nrows());
    let (m, p) = (first.b.ncols(), second.c.nrows());
    let mut a = DMatrix::zeros(n1 + n2, n1 + n2);
    a.view_mut((0, 0), (n1, n1)).copy_from(&first.a);
    a.view_mut((n1, 0), (n2, n1))
        .copy_from(&(&second.b * &first.c));
    a.view_mut((n1, n1), (n2, n2)).copy_from(&second.a);
    let mut b = DMatrix::zeros(n1 + n2, m);
    b.view_mut((0, 0), (n1, m)).copy_from(&first.b);
    b.view_mut((n1, 0), (n2, m))
        .copy_from(&(&second.b * &first.d));
    let mut c = DMatrix::zeros(p, n1 + n2);
    c.view_mut((0, 0), (p, n1))
        .copy_from(&(&second.d * &first.c));
    c.view_mut((0, n1), (p, n2)).copy_from(&second.c);
    StateSpace {
        a,
        b,
        c,
        d: &second.d * &first.d,
    }
}

/// A continuous linear time-invariant system `ẋ = A x + B u`, `y = C x + D u`
/// (time in s; `A` in 1/s).
#[derive(Clone, Debug, PartialEq)]
pub struct StateSpace {
    /// State matrix `A` (n × n).
    pub a: DMatrix<f64>,
    /// Input matrix `B` (n × inputs).
    pub b: DMatrix<f64>,
    /// Output matrix `C` (outputs × n).
    pub c: DMatrix<f64>,
    /// Feed-through matrix `D` (outputs × inputs).
    pub d: DMatrix<f64>,
}

/// Checks that `A, B, C, D` fit together and are finite; returns `(states, inputs, outputs)`.
pub(crate) fn check_abcd(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    c: &DMatrix<f64>,
    d: &DMatrix<f64>,
) -> Result<(usize, usize, usize)> {
    let n = a.nrows();
    let (m, p) = (b.ncols(), c.nrows());
    let expect = |what, m: &DMatrix<f64>, shape: (usize, usize)| {
        if m.shape() == shape {
            Ok(())
        } else {
            Err(DiscretiseError::Dimension {
                what,
                expected: shape,
                got: m.shape(),
            })
        }
    };
    expect("A", a, (n, n))?;
    expect("B", b, (n, m))?;
    expect("C", c, (p, n))?;
    expect("D", d, (p, m))?;
    if a.iter()
        .chain(b.iter())
        .chain(c.iter())
        .chain(d.iter())
        .any(|v| !v.is_finite())
    {
        return Err(DiscretiseError::NonFinite("state-space matrices"));
    }
    Ok((n, m, p))
}

impl StateSpace {
    /// A state-space system from its matrices.
    ///
    /// # Errors
    /// Mismatched dimensions or non-finite entries.
    pub fn new(a: DMatrix<f64>, b: DMatrix<f64>, c: DMatrix<f64>, d: DMatrix<f64>) -> Result<Self> {
        check_abcd(&a, &b, &c, &d)?;
        Ok(Self { a, b, c, d })
    }

    /// A static single-input single-output gain (no states).
    pub fn gain(k: f64) -> Self {
        Self {
            a: DMatrix::zeros(0, 0),
            b: DMatrix::zeros(0, 1),
            c: DMatrix::zeros(1, 0),
            d: DMatrix::from_element(1, 1, k),
        }
    }

    /// Validates dimensions and values; returns `(states, inputs, outputs)`.
    ///
    /// # Errors
    /// Mismatched dimensions or non-finite entries.
    pub fn dimensions(&self) -> Result<(usize, usize, usize)> {
        check_abcd(&self.a, &self.b, &self.c, &self.d)
    }

    /// Frequency response matrix `C (j2πf I - A)⁻¹ B + D` (outputs × inputs) at `f_hz` (Hz).
    ///
    /// # Errors
    /// Invalid matrices, or `j2πf` is an eigenvalue of `A`.
    pub fn response(&self, f_hz: f64) -> Result<DMatrix<Complex64>> {
        self.dimensions()?;
        resolvent_response(&self.a, &self.b, &self.c, &self.d, s_at(f_hz))
    }
}

/// `C (x I - A)⁻¹ B + D` for a complex point `x`.
pub(crate) fn resolvent_response(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    c: &DMatrix<f64>,
    d: &DMatrix<f64>,
    x: Complex64,
) -> Result<DMatrix<Complex64>> {
    let to_c = |m: &DMatrix<f64>| m.map(|v| Complex64::new(v, 0.0));
    let n = a.nrows();
    let shifted = DMatrix::<Complex64>::identity(n, n) * x - to_c(a);
    let solved = shifted
        .lu()
        .solve(&to_c(b))
        .ok_or(DiscretiseError::Singular(
            "frequency response (point is an eigenvalue)",
        ))?;
    Ok(to_c(c) * solved + to_c(d))
}
