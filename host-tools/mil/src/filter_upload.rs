//! `mil filter upload`: the command filter of a filter file (`mil design-filter`) onto the
//! board, each channel's filter as ONE block download, so that the board validates a
//! channel's whole filter at once (a channel never runs a half-written cascade).
//!
//! The file holds model-core's f32 delta-form sections (`β0 = b0`, `β1 = 2 b0 + b1`,
//! `β2 = b0 + b1 + b2`, `α1 = 2 + a1`, `α2 = 1 + a1 + a2`), which is what the firmware's
//! calibration page holds for each channel C: `filter_sections_C` (the number of sections
//! applied) and `filter_beta0_C_K`, `…_beta1_C_K`, `…_beta2_C_K`, `…_alpha1_C_K`,
//! `…_alpha2_C_K` for each section K of the A2L, one after another in memory. The same
//! filter goes to every channel of the A2L (channels the running model does not use are
//! only range-checked by the board). Sections the file does not use are written as model-core's
//! pass-through section (`β = 1, 2, 1`, `α = 2, 1`), so the board holds exactly the file's
//! cascade. Before anything is sent: the file is validated by model-core (finite, stable,
//! finite DC gain), every coefficient is checked against its A2L limits, and the file's
//! sample rate against the board's control step (its DAQ event cycle).

use std::fmt::Write as _;
use std::path::Path;

use anyhow::{bail, Context, Result};
use mil_analysis::filter_file::FilterFile;
use mil_can::Transport;
use mil_xcp_master::{resource, A2l, Change, Item, Master};
use model_core::BiquadCoefficients;

/// Coefficient names of a section, in memory order.
pub const COEFFICIENTS: [&str; 5] = ["beta0", "beta1", "beta2", "alpha1", "alpha2"];

/// The parameters and values a filter file becomes: per channel `filter_sections_C`, then
/// every section slot of the A2L.
#[derive(Clone, Debug, PartialEq)]
pub struct FilterWrite<'a> {
    /// The file's sample rate (Hz).
    pub sample_rate_hz: f64,
    /// Sections the file applies.
    pub sections: usize,
    /// Section slots the A2L has.
    pub slots: usize,
    /// Channels the A2L has.
    pub channels: usize,
    /// The parameters, channel by channel, each `filter_sections_C` first.
    pub items: Vec<&'a Item>,
    /// Their values.
    pub values: Vec<f64>,
}

/// Reads and validates `path` and maps it onto `a2l`'s filter parameters (checked against
/// their A2L limits).
///
/// # Errors
/// The file is not a valid filter file, has more sections than the board, the A2L lacks a
/// filter parameter, or a coefficient is outside its A2L limits.
pub fn plan<'a>(a2l: &'a A2l, path: &Path) -> Result<FilterWrite<'a>> {
    let (file, cascade) = FilterFile::read(path).with_context(|| path.display().to_string())?;
    let slots = (0..)
        .take_while(|k| a2l.characteristic(&format!("filter_beta0_0_{k}")).is_ok())
        .count();
    let channels = (0..)
        .take_while(|c| a2l.characteristic(&format!("filter_sections_{c}")).is_ok())
        .count();
    let sections = cascade.active();
    if sections.len() > slots {
        bail!(
            "{}: {} sections; the board has {slots}",
            path.display(),
            sections.len()
        );
    }
    if channels == 0 {
        bail!("the A2L has no filter_sections_0: not a MiL board's A2L");
    }
    let mut items = Vec::new();
    let mut values = Vec::new();
    for c in 0..channels {
        items.push(a2l.characteristic(&format!("filter_sections_{c}"))?);
        values.push(sections.len() as f64);
        for k in 0..slots {
            let s = sections
                .get(k)
                .copied()
                .unwrap_or(BiquadCoefficients::IDENTITY);
            let coefficients = [s.beta0, s.beta1, s.beta2, s.alpha1, s.alpha2];
            for (name, v) in COEFFICIENTS.iter().zip(coefficients) {
                items.push(a2l.characteristic(&format!("filter_{name}_{c}_{k}"))?);
                values.push(f64::from(v));
            }
        }
    }
    for (item, v) in items.iter().zip(&values) {
        item.encode_checked(*v)
            .with_context(|| format!("{}", path.display()))?;
    }
    Ok(FilterWrite {
        sample_rate_hz: file.sample_rate_hz,
        sections: sections.len(),
        slots,
        channels,
        items,
        values,
    })
}

/// Checks the sample rate against the board's control step, unlocks CAL/PAG with `secret`
/// and writes each channel's filter as one change, channel by channel; the changes as read
/// back.
///
/// # Errors
/// A sample rate other than the board's, a wrong secret, the board's refusal (nothing
/// changed then).
pub fn upload<T: Transport>(
    master: &mut Master<T>,
    filter: &FilterWrite<'_>,
    secret: &[u8],
) -> Result<Vec<Change>> {
    // The board's control step is its DAQ event 0; a board without the query is not checked.
    if let Ok(event) = master.daq_event_info(0) {
        if let Some(cycle) = event.cycle_s {
            let board_hz = 1.0 / cycle;
            if (filter.sample_rate_hz - board_hz).abs() > 1e-6 * board_hz {
                bail!(
                    "the filter is designed for {} Hz; the board's control step runs at {board_hz} Hz",
                    filter.sample_rate_hz
                );
            }
        }
    }
    master.unlock(resource::CAL_PAG, secret)?;
    let per_channel = 1 + 5 * filter.slots;
    let mut changes = Vec::with_capacity(filter.items.len());
    for (items, values) in filter
        .items
        .chunks(per_channel)
        .zip(filter.values.chunks(per_channel))
    {
        changes.extend(master.write_items_as_one_change(items, values)?);
    }
    Ok(changes)
}

/// The coefficients written, one section a line (channel 0's; every channel gets the
/// same), and `filter_sections`.
pub fn table(filter: &FilterWrite<'_>, changes: &[Change]) -> String {
    let mut t = String::new();
    let Some(count) = changes.first() else {
        return t;
    };
    let _ = writeln!(
        t,
        "filter_sections: {} → {} on each of {} channel(s) (one block of {} parameters a \
         channel at {} Hz)",
        count.old,
        count.new,
        filter.channels,
        1 + 5 * filter.slots,
        filter.sample_rate_hz
    );
    let _ = writeln!(
        t,
        "{:<8} {:>14} {:>14} {:>14} {:>14} {:>14}",
        "section", "beta0", "beta1", "beta2", "alpha1", "alpha2"
    );
    let per_channel = 1 + 5 * filter.slots;
    let first = changes
        .get(1..per_channel.min(changes.len()))
        .unwrap_or(&[]);
    for (k, section) in first.chunks(5).enumerate() {
        let _ = write!(t, "{:<8}", format!("s{k}"));
        for c in section {
            let _ = write!(t, " {:>14}", format!("{}", c.new as f32));
        }
        let _ = writeln!(
            t,
            "{}",
            if k < filter.sections {
                ""
            } else {
                "  (pass-through)"
            }
        );
    }
    t
}
