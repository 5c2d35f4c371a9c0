//! The record as the diagnosis uses it: the options and columns checked, a long record
//! averaged down within the budget ([`MAX_SAMPLES`]), the logged inputs low-passed, the
//! states estimated, a flipped force input refused, and the record split into fitting and
//! validation blocks.

use super::force_sign::{flipped_force, force_work_share, NET_WORK_FLOOR};
use super::Options;
use crate::equation::{self, States};
use crate::model::Model;
use crate::record::Record;
use crate::split::Split;
use crate::{signal, Error, Result};

/// The record as the diagnosis uses it: each input column that is not also an output is
/// low-passed (zero phase, [`signal::lowpass_zero_phase`]) an octave above its own signal
/// band edge ([`signal::signal_band_edge_hz`] at [`signal::SNR`]; at least 0.002 of the
/// sample rate, and left as it is when that is above 0.4 of it). A logged input carries measurement
/// noise like any channel; driven through a stiff path (a tyre's stiffness and damping from
/// a logged road) its noise, differentiated, would dominate the simulated outputs and be
/// mistaken for an effect that smooths the input (a delay, a saturation, quadratic damping).
/// Returns the record and, per filtered column, its name and cut-off (Hz).
pub fn prefilter_inputs(model: &Model, record: &Record) -> (Record, Vec<(String, f64)>) {
    let mut out = record.clone();
    let mut filtered = Vec::new();
    let fs = 1.0 / record.dt;
    for inp in &model.inputs {
        if model.outputs.iter().any(|o| o.column == inp.column) {
            continue;
        }
        let Some(j) = out.names.iter().position(|n| *n == inp.column) else {
            continue;
        };
        if filtered.iter().any(|(n, _)| *n == inp.column) {
            continue;
        }
        let col = &out.columns[j];
        // An octave above the band edge, so that the band itself passes (the forward-backward
        // fourth-order Butterworth keeps 99 % of the amplitude at half its cut-off).
        let fc = 2.0 * signal::signal_band_edge_hz(col, record.dt, signal::SNR);
        if fc >= 0.4 * fs {
            continue;
        }
        let fc = fc.max(0.002 * fs);
        out.columns[j] = signal::lowpass_zero_phase(col, fc, record.dt);
        filtered.push((inp.column.clone(), fc));
    }
    (out, filtered)
}

/// Most samples the diagnosis works on (it holds about 0.7 kB per sample: filtered
/// regressors, simulations, states): longer records are averaged down ([`within_budget`]).
pub const MAX_SAMPLES: usize = 1_000_000;

/// The record's highest signal frequency must stay below this fraction of the rate a long
/// record is averaged down to (block means keep 99.6 % of the amplitude there).
pub const DECIMATED_BAND_FRACTION: f64 = 0.05;

/// The record the diagnosis works on: `record` itself when it has at most [`MAX_SAMPLES`]
/// samples; otherwise its block means ([`Record::block_mean`]) over the fewest samples that
/// bring it within the budget, if its signals' band (the highest band edge of the model's
/// columns, [`signal::signal_band_edge_hz`]) stays below [`DECIMATED_BAND_FRACTION`] of
/// the new rate, with a line that says so.
///
/// # Errors
/// The record is too long and its band does not allow averaging it down enough: one line
/// with the figures and the longest record that would do.
pub fn within_budget<'a>(
    model: &Model,
    record: &'a Record,
) -> Result<(std::borrow::Cow<'a, Record>, Option<String>)> {
    let len = record.len();
    if len <= MAX_SAMPLES {
        return Ok((std::borrow::Cow::Borrowed(record), None));
    }
    let fs = 1.0 / record.dt;
    let mut edge = 0.0_f64;
    for c in model
        .outputs
        .iter()
        .map(|o| &o.column)
        .chain(model.inputs.iter().map(|i| &i.column))
    {
        edge = edge.max(signal::signal_band_edge_hz(
            record.column(c)?,
            record.dt,
            signal::SNR,
        ));
    }
    let needed = len.div_ceil(MAX_SAMPLES);
    let allowed = (DECIMATED_BAND_FRACTION * fs / edge).floor() as usize;
    if allowed < needed {
        let rate = fs / allowed.max(1) as f64;
        return Err(Error::Record(format!(
            "{len} samples at {fs:.0} Hz: the diagnosis works on at most {MAX_SAMPLES}, and \
             the signals reach {edge:.1} Hz, so the record can be averaged down to {rate:.0} Hz \
             only ({} samples): give at most {:.0} s of it",
            len / allowed.max(1),
            MAX_SAMPLES as f64 / rate
        )));
    }
    let reduced = record.block_mean(needed);
    let line = format!(
        "record of {len} samples at {fs:.0} Hz averaged over blocks of {needed} to {} samples \
         at {:.1} Hz (its signals reach {edge:.1} Hz)",
        reduced.len(),
        fs / needed as f64
    );
    Ok((std::borrow::Cow::Owned(reduced), Some(line)))
}

/// The record and what the workflow estimates from it before any fit.
pub(super) struct Prepared {
    /// The record as the diagnosis uses it ([`within_budget`], [`prefilter_inputs`]).
    pub(super) record: Record,
    /// The notes the preparation leaves: each input column low-passed, and the record
    /// averaged down if it was.
    pub(super) notes: Vec<String>,
    /// The states estimated from the record.
    pub(super) st: States,
    /// The force inputs' net work share and the inputs whose own share is negative
    /// ([`force_work_share`]).
    pub(super) work: Option<(f64, Vec<String>)>,
    /// The fitting and validation blocks.
    pub(super) split: Split,
    /// The equation error's fitting rows.
    pub(super) fit_rows: usize,
}

/// Checks `options`, the model's outputs and the record's columns, and prepares `record`
/// (see the module documentation); `log` reports progress.
///
/// # Errors
/// As [`super::diagnose`]: a bad validation fraction, no outputs, missing columns, a record
/// beyond the budget or too short to split, undetermined DOFs, a flipped force input.
pub(super) fn prepare(
    model: &Model,
    record: &Record,
    options: &Options,
    log: &dyn Fn(f64, &str),
) -> Result<Prepared> {
    if !(options.validation_fraction > 0.0 && options.validation_fraction <= 0.9) {
        return Err(Error::Diagnose(format!(
            "validation_fraction must be in (0, 0.9], got {}",
            options.validation_fraction
        )));
    }
    if model.outputs.is_empty() {
        return Err(Error::Model(
            "no [[output]]: the structure measures nothing to compare with the record".into(),
        ));
    }
    for o in &model.outputs {
        record.column(&o.column)?;
    }
    for i in &model.inputs {
        record.column(&i.column)?;
    }
    let (record, reduced) = within_budget(model, record)?;
    if let Some(m) = &reduced {
        log(0.0, m);
    }
    let record = record.as_ref();
    crate::simulate::check_scale(model, record)?;
    let len = record.len();
    let (prefiltered, input_cutoffs) = prefilter_inputs(model, record);
    let record = &prefiltered;
    // The equation error applies the input effects to the inputs the simulations see (the
    // low-passed logged inputs), then filters every regressor alike: a rate limit,
    // saturation or play applied to the raw logged input would act on its measurement noise
    // (whose sample-to-sample rate is most of a noisy input's rate) and fit worse than none.
    let st = equation::estimate_states(model, record)?;
    // A force column read with the opposite sign convention: refused when the energy says
    // so alone, or (below) with the recalibration's signs.
    let work = force_work_share(model, &st);
    if let Some((share, negative)) = work.as_ref().filter(|w| w.0 < NET_WORK_FLOOR) {
        return Err(flipped_force(
            negative,
            &format!(
                "takes energy out of the specimen (net work {share:.2} of the power it \
                 exchanges; a passive specimen driven by force only takes energy in)"
            ),
        ));
    }
    // Blocks of at least four filter transients, a guard of one cut-off period.
    let split = Split::new(
        len,
        options.validation_fraction,
        4 * st.edge.max(1),
        (1.0 / (st.fc_hz * st.dt)).ceil() as usize,
    );
    let kept = st.cache.keep();
    let (fit_rows, val_rows) = (
        kept.iter().filter(|&&t| split.is_fit(t)).count(),
        kept.iter().filter(|&&t| split.is_validation(t)).count(),
    );
    if fit_rows < 16 || val_rows < 16 {
        return Err(Error::Diagnose(format!(
            "record too short for a fitting and a validation part ({len} samples)"
        )));
    }
    log(
        0.05,
        &format!(
            "states estimated, cut-off {:.2} Hz, decimation {}, {} blocks of {} samples",
            st.fc_hz,
            st.decimation,
            len.div_ceil(split.block),
            split.block
        ),
    );
    let mut notes: Vec<String> = input_cutoffs
        .iter()
        .map(|(c, fc)| format!("input column {c:?} low-passed at {fc:.1} Hz (an octave above its signal band edge)"))
        .collect();
    notes.extend(reduced);
    Ok(Prepared {
        record: prefiltered,
        notes,
        st,
        work,
        split,
        fit_rows,
    })
}

#[cfg(test)]
mod budget_tests {
    use super::*;

    fn oscillator() -> Model {
        Model::from_toml(include_str!("../../examples/oscillator.toml")).expect("model")
    }

    /// `len` samples at `fs`: a force and a displacement that are sines at 2 Hz and `top`
    /// Hz plus 1 % of white noise.
    fn record(len: usize, fs: f64, top: f64) -> Record {
        let noise = 0.01;
        let mut rng = mil_numerics::rng::SplitMix64::new(11u64);
        let mut rnd = move || rng.uniform() - 0.5;
        let t: Vec<f64> = (0..len).map(|i| i as f64 / fs).collect();
        let sine = |t: &f64| {
            (std::f64::consts::TAU * 2.0 * t).sin() + 0.3 * (std::f64::consts::TAU * top * t).sin()
        };
        let f: Vec<f64> = t.iter().map(|t| 10.0 * sine(t) + noise * rnd()).collect();
        let x: Vec<f64> = t
            .iter()
            .map(|t| 1e-3 * sine(t) + 1e-4 * noise * rnd())
            .collect();
        Record::new(&t, vec!["force".into(), "x".into()], vec![f, x]).expect("record")
    }

    #[test]
    fn a_record_within_the_budget_is_used_as_it_is() {
        let rec = record(5000, 1000.0, 5.0);
        let (r, line) = within_budget(&oscillator(), &rec).expect("fits");
        assert!(matches!(r, std::borrow::Cow::Borrowed(_)) && line.is_none());
    }

    #[test]
    fn a_long_oversampled_record_is_averaged_down_and_a_broadband_one_refused() {
        let len = 2 * MAX_SAMPLES + 10;
        // Up to 20 Hz at 10 kHz: averaged over blocks of 3 (the fewest that fit), 3.3 kHz.
        let rec = record(len, 10_000.0, 20.0);
        let (r, line) = within_budget(&oscillator(), &rec).expect("averaged down");
        assert!(r.len() <= MAX_SAMPLES && r.len() == len / 3, "{}", r.len());
        let line = line.expect("a note");
        assert!(line.contains("blocks of 3"), "{line}");
        // Up to 150 Hz at 1 kHz: averaging would blur it.
        let rec = record(len, 1000.0, 150.0);
        let err = within_budget(&oscillator(), &rec)
            .expect_err("refused")
            .to_string();
        assert!(
            err.contains(&format!("at most {MAX_SAMPLES}")) && err.contains("give at most"),
            "{err}"
        );
        assert_eq!(err.lines().count(), 1, "{err}");
    }
}
