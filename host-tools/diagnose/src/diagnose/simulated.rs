//! Models simulated over the record and scored on the validation blocks: their residuals,
//! their gap, and whether a step between two of them pays off against this record's noise.

use super::criterion::{pays_off, Evaluation, Verdict};
use super::report::Gap;
use crate::model::Model;
use crate::record::Record;
use crate::signal;
use crate::simulate::{self, prepare_inputs};
use crate::split::Split;
use crate::Result;

/// Simulation of models over the record, scored on the validation blocks.
pub(super) struct Simulated<'a> {
    record: &'a Record,
    measured: &'a [&'a [f64]],
    initial: (&'a [f64], &'a [f64]),
    val_idx: Vec<usize>,
    /// Per output: one over the measured output's spread on the validation blocks.
    scale: Vec<f64>,
    /// Per output: the validation sum of squares that measurement noise alone gives
    /// (normalised like the residual).
    pub(super) noise_sse: Vec<f64>,
}

impl<'a> Simulated<'a> {
    /// `noise`: per output, the measurement noise's standard deviation.
    pub(super) fn new(
        measured: &'a [&'a [f64]],
        noise: &[f64],
        split: &Split,
        record: &'a Record,
        initial: (&'a [f64], &'a [f64]),
    ) -> Self {
        let val_idx: Vec<usize> = (0..record.len())
            .filter(|&t| split.is_validation(t))
            .collect();
        let scale = inverse_spreads(measured, &val_idx);
        let noise_sse = noise
            .iter()
            .zip(&scale)
            .map(|(sd, sc)| val_idx.len() as f64 * (sd * sc).powi(2))
            .collect();
        Self {
            record,
            measured,
            initial,
            val_idx,
            scale,
            noise_sse,
        }
    }

    /// The simulated outputs of `m` over the whole record (`None` if it diverges).
    fn outputs(&self, m: &Model) -> Option<Vec<Vec<f64>>> {
        let inp = prepare_inputs(m, self.record).ok()?;
        simulate::simulate_outputs(
            m,
            self.record,
            &inp,
            0..self.record.len(),
            Some(self.initial),
        )
        .ok()
        .map(|s| s.outputs)
    }

    /// `m`'s residuals on the validation blocks (`None` if the simulation diverges).
    pub(super) fn evaluate(&self, m: &Model) -> Option<Evaluation> {
        let out = self.outputs(m)?;
        let mut resid = Vec::with_capacity(self.val_idx.len() * out.len());
        let mut sse = Vec::with_capacity(out.len());
        for ((me, s), sc) in self.measured.iter().zip(&out).zip(&self.scale) {
            let from = resid.len();
            resid.extend(self.val_idx.iter().map(|&t| (s[t] - me[t]) * sc));
            sse.push(resid[from..].iter().map(|v| v * v).sum::<f64>());
        }
        sse.iter()
            .all(|v| v.is_finite())
            .then_some(Evaluation { sse, resid })
    }

    /// The gap (NRMSE on the validation blocks) of `m`, with its simulated outputs.
    pub(super) fn gap(&self, m: &Model) -> (Gap, Option<Vec<Vec<f64>>>) {
        match self.outputs(m) {
            Some(out) => {
                let v: Vec<f64> = self
                    .measured
                    .iter()
                    .zip(&out)
                    .zip(&self.scale)
                    .map(|((me, s), sc)| {
                        let e: Vec<f64> = self.val_idx.iter().map(|&t| s[t] - me[t]).collect();
                        (signal::rms(&e) * sc).powi(2)
                    })
                    .collect();
                (
                    Gap {
                        nrmse: signal::mean(&v).sqrt(),
                    },
                    Some(out),
                )
            }
            None => (
                Gap {
                    nrmse: f64::INFINITY,
                },
                None,
            ),
        }
    }

    /// Whether going from `before` to `after` with `added` parameters pays off
    /// ([`pays_off`] with this record's noise).
    pub(super) fn pays_off(
        &self,
        before: &Evaluation,
        after: &Evaluation,
        added: usize,
    ) -> Verdict {
        pays_off(&self.noise_sse, before, after, added)
    }
}

/// Per measured output: one over its spread at the samples `idx` (the residuals' scale).
pub(super) fn inverse_spreads(measured: &[&[f64]], idx: &[usize]) -> Vec<f64> {
    measured
        .iter()
        .map(|m| {
            let v: Vec<f64> = idx.iter().map(|&t| m[t]).collect();
            1.0 / signal::std(&v).max(1e-300)
        })
        .collect()
}

/// The model's measured outputs, as the record's columns, and each one's measurement
/// noise (standard deviation, [`signal::noise_std`]).
///
/// # Errors
/// A column the record does not hold.
pub(super) fn measured_outputs<'r>(
    model: &Model,
    record: &'r Record,
) -> Result<(Vec<&'r [f64]>, Vec<f64>)> {
    let measured: Vec<&[f64]> = model
        .outputs
        .iter()
        .map(|o| record.column(&o.column))
        .collect::<Result<_>>()?;
    let noise: Vec<f64> = measured
        .iter()
        .map(|m| signal::noise_std(m, record.dt))
        .collect();
    Ok((measured, noise))
}
