//! Single-input single-output frequency responses from a model or a measured table, and the
//! command filter placed in front of the actuators.

use crate::error::Result;
use crate::poly::Rational;
use mil_discretise::TransferFunction;
use mil_identify::FrfTable;
use model_core::CascadeCoefficients;
use num_complex::Complex64;
use std::f64::consts::TAU;

/// An actuator model whose linear responses are rational in `s`: the tracking response
/// (`P_f` or `P_d` of the paper's framework) and the disturbance response (`R_f` or `R_d`).
pub trait LinearActuator {
    /// Tracking response: output per command, with the specimen side held still (force
    /// control) or unloaded (position control).
    ///
    /// # Errors
    /// Invalid parameters, named.
    fn tracking(&self) -> Result<Rational>;

    /// Disturbance response: the output the specimen side causes with the command held at
    /// zero (N/m for force control, m/N for position control).
    ///
    /// # Errors
    /// Invalid parameters, named.
    fn disturbance(&self) -> Result<Rational>;
}

/// Where a frequency response comes from.
#[derive(Clone, Debug)]
pub enum ResponseSource {
    /// A rational function of `s` (rad/s) followed by a pure delay.
    Model {
        /// The rational part.
        transfer_function: Rational,
        /// Pure delay (s), `e^{-s τ}`.
        delay_s: f64,
    },
    /// A measured frequency-response table, interpolated (see [`mil_identify::FrfTable`]).
    Table(FrfTable),
    /// A measured tracking table extended beyond its band by its fitted low-order model
    /// ([`crate::measured`]): defined at every frequency.
    Measured(Box<crate::measured::MeasuredResponse>),
    /// Identically zero (e.g. the disturbance response of an ideal actuator).
    Zero,
}

impl ResponseSource {
    /// One line for reports: what the response is made of.
    pub fn describe(&self) -> String {
        match self {
            Self::Model {
                transfer_function,
                delay_s,
            } => {
                let order = |c: &[f64]| c.len().saturating_sub(1);
                let mut out = format!(
                    "model, numerator order {} / denominator order {}",
                    order(&transfer_function.numerator),
                    order(&transfer_function.denominator)
                );
                if *delay_s > 0.0 {
                    out.push_str(&format!(", delay {:.3} ms", delay_s * 1e3));
                }
                out
            }
            Self::Table(table) => {
                let (lo, hi) = table.frequency_range();
                format!(
                    "measured table, {} points, {lo:.3}-{hi:.1} Hz",
                    table.points().len()
                )
            }
            Self::Measured(m) => m.describe(),
            Self::Zero => "none (zero)".to_string(),
        }
    }

    /// A constant gain.
    pub fn gain(k: f64) -> Result<Self> {
        Ok(Self::Model {
            transfer_function: Rational::new(vec![k], vec![1.0])?,
            delay_s: 0.0,
        })
    }

    /// The response at `frequency_hz` (Hz).
    ///
    /// # Errors
    /// A table queried outside its frequency range.
    pub fn response(&self, frequency_hz: f64) -> Result<Complex64> {
        Ok(match self {
            Self::Model {
                transfer_function,
                delay_s,
            } => {
                transfer_function.response(frequency_hz)
                    * Complex64::from_polar(1.0, -TAU * frequency_hz * delay_s)
            }
            Self::Table(table) => table.response(frequency_hz)?,
            Self::Measured(m) => m.response(frequency_hz),
            Self::Zero => Complex64::new(0.0, 0.0),
        })
    }

    /// The response at a complex `s` (rad/s). Tables are only defined on the imaginary axis.
    ///
    /// # Errors
    /// A table queried off the imaginary axis or outside its range.
    pub fn response_s(&self, s: Complex64) -> Result<Complex64> {
        if s.re == 0.0 {
            return self.response(s.im / TAU);
        }
        Ok(match self {
            Self::Model {
                transfer_function,
                delay_s,
            } => transfer_function.response_s(s) * (-s * *delay_s).exp(),
            Self::Table(_) => {
                return Err(crate::error::setup_error(
                    "a measured table has no values off the imaginary axis",
                ))
            }
            Self::Measured(m) => m.response_s(s),
            Self::Zero => Complex64::new(0.0, 0.0),
        })
    }

    /// The static gain `P(0)` where it is known: a model's value at `s = 0`; a measured
    /// table's real part at its lowest frequency (extended or not: below its band the
    /// extension holds the table's level); none for a zero response.
    pub fn static_gain(&self) -> Option<f64> {
        match self {
            Self::Model {
                transfer_function, ..
            } => Some(transfer_function.response_s(Complex64::new(0.0, 0.0)).re),
            Self::Table(table) => table.points().first().map(|p| p.complex().re),
            Self::Measured(m) => Some(m.response(0.0).re),
            Self::Zero => None,
        }
    }

    /// The frequency range (Hz) over which the response is defined: a table's range, else all
    /// positive frequencies.
    pub fn frequency_range(&self) -> (f64, f64) {
        match self {
            Self::Table(table) => table.frequency_range(),
            _ => (0.0, f64::INFINITY),
        }
    }
}

/// A command filter shaping the actuator command (before the actuators' tracking response).
#[derive(Clone, Debug)]
pub enum CommandFilter {
    /// The model-core cascade that runs on the board, evaluated exactly at `e^{jωT}`.
    Discrete {
        /// The f32 delta-form cascade.
        cascade: CascadeCoefficients,
        /// Sample period (s).
        sample_period_s: f64,
    },
    /// A continuous design (before discretisation).
    Continuous(TransferFunction),
}

impl CommandFilter {
    /// One line for reports: the filter's form and size.
    pub fn describe(&self) -> String {
        match self {
            Self::Discrete {
                cascade,
                sample_period_s,
            } => format!(
                "discrete f32 cascade, {} biquad section(s) at {:.0} Hz",
                cascade.sections,
                1.0 / sample_period_s
            ),
            Self::Continuous(tf) => format!(
                "continuous, numerator order {} / denominator order {}",
                tf.num.len().saturating_sub(1),
                tf.den.len().saturating_sub(1)
            ),
        }
    }

    /// The response at a complex `s` (rad/s); a discrete cascade at `z = e^{sT}`.
    pub fn response_s(&self, s: Complex64) -> Complex64 {
        match self {
            Self::Discrete {
                cascade,
                sample_period_s,
            } => {
                let q = (s * *sample_period_s).exp() - 1.0;
                cascade
                    .active()
                    .iter()
                    .map(|c| {
                        let num =
                            (q * f64::from(c.beta0) + f64::from(c.beta1)) * q + f64::from(c.beta2);
                        let den = (q + f64::from(c.alpha1)) * q + f64::from(c.alpha2);
                        num / den
                    })
                    .product()
            }
            Self::Continuous(tf) => {
                mil_discretise::polyval(&tf.num, s) / mil_discretise::polyval(&tf.den, s)
            }
        }
    }

    /// The response at `frequency_hz` (Hz).
    pub fn response(&self, frequency_hz: f64) -> Complex64 {
        self.response_s(Complex64::new(0.0, TAU * frequency_hz))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn delay_adds_linear_phase_and_keeps_magnitude() {
        let r = ResponseSource::Model {
            transfer_function: Rational::new(vec![1.0], vec![1.0]).unwrap(),
            delay_s: 1e-3,
        };
        let h = r.response(100.0).unwrap();
        assert!((h.norm() - 1.0).abs() < 1e-12);
        // 100 Hz × 1 ms = 0.1 turn = -36°
        assert!((h.arg().to_degrees() + 36.0).abs() < 1e-9);
    }
}
