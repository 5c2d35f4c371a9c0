//! Parameters by index: how a Command frame's "set parameter" (index, f32 value) maps onto the
//! controller's [`Params`], and the result codes of a CommandAck.
//!
//! A change is applied to a copy of the running set, the whole copy is validated with
//! [`PreparedParams::new`](model_core::PreparedParams::new) (outside any lock: the control
//! task keeps running), and only a valid set is swapped in with
//! [`Controller::swap_params`](model_core::Controller::swap_params) between two steps. A
//! rejected value changes nothing and is answered with an error code.
//!
//! | index | parameter (channel 0) | unit | allowed |
//! | --- | --- | --- | --- |
//! | 0 | tyre radial stiffness `k_t` | N/m | 0 ..= 1e8 |
//! | 1 | tyre radial damping `c_t` | N s/m | 0 ..= 1e6 |
//! | 2 | static wheel load | N | 0 ..= 1e6 |
//! | 3 | lift-off (1) or linear tyre (0) | – | exactly 0.0 or 1.0 |
//! | 4 | deflection-velocity low-pass cut-off (0: none) | Hz | 0 ..= 20 000 (exact ZOH first order: stable at any value) |
//! | 5 | demand minimum | N | ±1e7, below the maximum |
//! | 6 | demand maximum | N | ±1e7, above the minimum |
//! | 7 | demand rate limit | N/s | 1e-6 ..= 1e12 |
//! | 8 | safe demand | N | inside [min, max] |
//! | 9 | ramp rate to the safe demand | N/s | 1e-6 ..= 1e12 |
//! | 10 | command filter: number of sections applied | – | integer 0 ..= 4 |
//! | 11 + 5 s + c | command filter section `s` (0–3), coefficient `c` = β0, β1, β2, α1, α2 (delta form) | – | finite; applied sections stable |
//! | 100 | status period K (controller steps per status frame) | steps | integer 1 ..= 60 000 |
//! | 101 | communication watchdog N (silent ticks before a trip) | ticks | integer 2 ..= 10 000 (QEMU build: or 0, off) |
//!
//! Indices 100 and 101 are firmware settings, not controller parameters: they take effect at
//! once (no validation by model-core). The QEMU build also accepts 101 = 0, the watchdog off
//! until reset, for the instruction benchmark ([`crate::config::WATCHDOG_OFF`]); the board
//! build refuses it. Filter coefficients of sections beyond the applied count
//! are not checked until the count includes them, so a filter is loaded by writing the count
//! 0, then the coefficients, then the count (or as one block through XCP, as `mil filter
//! upload` does). A change while Running is bumpless (model-core's `Controller::swap_params`):
//! the filters restart at rest at the model's output and the demand fades to the new target
//! over `model_core::BUMPLESS_FADE_S`; narrowed limits close in at the rate limit.

use model_core::{ParamError, MAX_SECTIONS};

use crate::config::{
    Params, SAMPLE_RATE_HZ, STATUS_PERIOD_RANGE, WATCHDOG_OFF, WATCHDOG_OFF_ALLOWED,
    WATCHDOG_SAMPLES_RANGE,
};

/// Result codes of a CommandAck (0: accepted and applied). Codes below 128 are mil-frames'
/// decoding errors (`DecodeError::code`, e.g. a NaN value or an unknown command number,
/// answered as they are); the firmware's own codes start at 128.
pub mod code {
    /// Accepted and applied.
    pub const OK: u8 = 0;
    /// First firmware code.
    pub const FIRMWARE: u8 = 128;
    /// The value is NaN or infinite (model-core `ParamError::NotFinite`).
    pub const NOT_FINITE: u8 = FIRMWARE + 1;
    /// The value is outside its documented range (`ParamError::OutOfRange`).
    pub const OUT_OF_RANGE: u8 = FIRMWARE + 2;
    /// The resulting filter or model would be unstable (`ParamError::Unstable`).
    pub const UNSTABLE: u8 = FIRMWARE + 3;
    /// Inconsistent with another parameter, e.g. minimum above maximum
    /// (`ParamError::Inconsistent`).
    pub const INCONSISTENT: u8 = FIRMWARE + 4;
    /// The parameter index is not known.
    pub const UNKNOWN_INDEX: u8 = FIRMWARE + 16;
    /// Not possible in the current mode (start outside Idle, clear without a fault).
    pub const WRONG_MODE: u8 = FIRMWARE + 17;
    /// The command queue was full: the command was dropped, nothing changed.
    pub const BUSY: u8 = FIRMWARE + 18;
    /// A parameter write by Command frame that needs the calibration unlocked: an XCP
    /// session must hold CAL/PAG unlocked (seed & key) for it; nothing changed.
    pub const LOCKED: u8 = FIRMWARE + 19;
    /// A parameter write by Command frame while the controller runs the reference page
    /// (read-only, the build's defaults): switch it to the working page first (XCP
    /// SET_CAL_PAGE); nothing changed.
    pub const REFERENCE_PAGE: u8 = FIRMWARE + 20;
}

/// Index of the status period K.
pub const INDEX_STATUS_PERIOD: u16 = 100;
/// Index of the watchdog limit N.
pub const INDEX_WATCHDOG: u16 = 101;

/// Index of the first filter coefficient.
const FILTER_BASE: u16 = 11;
/// Coefficients per filter section.
const PER_SECTION: u16 = 5;
/// One past the last filter coefficient index.
const FILTER_END: u16 = FILTER_BASE + PER_SECTION * MAX_SECTIONS as u16;

/// What a parameter index refers to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Target {
    /// A field of the controller's parameter set.
    Controller,
    /// The status period K.
    StatusPeriod,
    /// The watchdog limit N.
    Watchdog,
}

/// Which kind of setting `index` is, or `None` for an unknown index.
pub fn target(index: u16) -> Option<Target> {
    match index {
        0..FILTER_END => Some(Target::Controller),
        INDEX_STATUS_PERIOD => Some(Target::StatusPeriod),
        INDEX_WATCHDOG => Some(Target::Watchdog),
        _ => None,
    }
}

/// The CommandAck code of a model-core validation error: 128 + `ParamError::kind_code`.
pub fn error_code(e: &ParamError) -> u8 {
    code::FIRMWARE.saturating_add(e.kind_code())
}

/// `value` as an integer in `range`, or the error code.
pub fn integer_in(value: f32, range: (u16, u16)) -> Result<u16, u8> {
    if !value.is_finite() {
        return Err(code::NOT_FINITE);
    }
    if value < f32::from(range.0) || value > f32::from(range.1) {
        return Err(code::OUT_OF_RANGE);
    }
    // In range: the conversion truncates; only an integral value converts back to itself.
    let n = value as u16;
    if f32::from(n) != value {
        return Err(code::OUT_OF_RANGE);
    }
    Ok(n)
}

/// The status period K from a command value.
pub fn status_period(value: f32) -> Result<u16, u8> {
    integer_in(value, STATUS_PERIOD_RANGE)
}

/// The watchdog limit N (ticks) from a parameter value (index 101: N itself); 0
/// ([`WATCHDOG_OFF`]) only in the QEMU build ([`WATCHDOG_OFF_ALLOWED`]).
pub fn watchdog_limit(value: f32) -> Result<u16, u8> {
    watchdog_limit_in(value, WATCHDOG_OFF_ALLOWED)
}

/// [`watchdog_limit`] with the build's choice made explicit: `off_allowed` accepts exactly
/// 0.0 as [`WATCHDOG_OFF`] besides the range.
pub fn watchdog_limit_in(value: f32, off_allowed: bool) -> Result<u16, u8> {
    if off_allowed && value == 0.0 {
        return Ok(WATCHDOG_OFF);
    }
    integer_in(value, WATCHDOG_SAMPLES_RANGE)
}

/// The watchdog limit N from a SetWatchdog command, whose value is the timeout in seconds
/// of sample time (the DBC's unit): `N = round(value · SAMPLE_RATE_HZ)`, so 5 ms gives the
/// default N = 10. Allowed: N in 2 ..= 10 000 (1 ms to 5 s at 2 kHz). In the QEMU build a
/// tick lasts longer than a sample period (see [`crate::config::QEMU_TICK_US`]), so the
/// timeout there is N ticks of QEMU time, not `value` seconds.
pub fn watchdog_from_seconds(value: f32) -> Result<u16, u8> {
    if !value.is_finite() {
        return Err(code::NOT_FINITE);
    }
    let n = value * SAMPLE_RATE_HZ as f32;
    if !(0.0..=1.0e6).contains(&n) {
        return Err(code::OUT_OF_RANGE);
    }
    // Non-negative and below 2^24: adding one half and truncating rounds exactly.
    integer_in((n + 0.5) as u32 as f32, WATCHDOG_SAMPLES_RANGE)
}

/// Writes `value` into the controller parameter at `index` of `params` (channel 0). Only
/// checks what the parameter set cannot express (a finite value, integral counts and
/// switches); the ranges are checked by `PreparedParams::new` on the whole set afterwards.
pub fn write(params: &mut Params, index: u16, value: f32) -> Result<(), u8> {
    if !value.is_finite() {
        return Err(code::NOT_FINITE);
    }
    let [tyre] = &mut params.model.tyre;
    let [limits] = &mut params.limits;
    let [safe] = &mut params.safe_demand;
    let [ramp] = &mut params.safe_ramp_rate;
    let [filter] = &mut params.filter;
    match index {
        0 => tyre.stiffness = value,
        1 => tyre.damping = value,
        2 => tyre.static_load = value,
        3 => tyre.lift_off = u32::from(integer_in(value, (0, 1))?),
        4 => tyre.velocity_cutoff_hz = value,
        5 => limits.min = value,
        6 => limits.max = value,
        7 => limits.rate = value,
        8 => *safe = value,
        9 => *ramp = value,
        10 => filter.sections = u32::from(integer_in(value, (0, MAX_SECTIONS as u16))?),
        FILTER_BASE..FILTER_END => {
            let k = index - FILTER_BASE;
            let s = filter
                .section
                .get_mut(usize::from(k / PER_SECTION))
                .ok_or(code::UNKNOWN_INDEX)?;
            match k % PER_SECTION {
                0 => s.beta0 = value,
                1 => s.beta1 = value,
                2 => s.beta2 = value,
                3 => s.alpha1 = value,
                _ => s.alpha2 = value,
            }
        }
        _ => return Err(code::UNKNOWN_INDEX),
    }
    Ok(())
}

/// Reads the controller parameter at `index` (channel 0), `None` for an unknown index.
pub fn read(params: &Params, index: u16) -> Option<f32> {
    let [tyre] = &params.model.tyre;
    let [limits] = &params.limits;
    let [filter] = &params.filter;
    Some(match index {
        0 => tyre.stiffness,
        1 => tyre.damping,
        2 => tyre.static_load,
        3 => tyre.lift_off as f32,
        4 => tyre.velocity_cutoff_hz,
        5 => limits.min,
        6 => limits.max,
        7 => limits.rate,
        8 => params.safe_demand.first().copied()?,
        9 => params.safe_ramp_rate.first().copied()?,
        10 => filter.sections as f32,
        FILTER_BASE..FILTER_END => {
            let k = index - FILTER_BASE;
            let s = filter.section.get(usize::from(k / PER_SECTION))?;
            match k % PER_SECTION {
                0 => s.beta0,
                1 => s.beta1,
                2 => s.beta2,
                3 => s.alpha1,
                _ => s.alpha2,
            }
        }
        _ => return None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{default_params, Prepared, DT};

    #[test]
    fn every_controller_index_round_trips() {
        for index in 0..FILTER_END {
            let mut p = default_params();
            let v = if index == 3 || index == 10 { 1.0 } else { 0.5 };
            assert_eq!(write(&mut p, index, v), Ok(()), "index {index}");
            assert_eq!(read(&p, index), Some(v), "index {index}");
            assert_eq!(target(index), Some(Target::Controller));
        }
        assert_eq!(target(FILTER_END), None);
        assert_eq!(target(INDEX_STATUS_PERIOD), Some(Target::StatusPeriod));
        assert_eq!(target(INDEX_WATCHDOG), Some(Target::Watchdog));
        assert_eq!(
            write(&mut default_params(), 99, 1.0),
            Err(code::UNKNOWN_INDEX)
        );
    }

    #[test]
    fn rejections_name_the_reason() {
        let mut p = default_params();
        assert_eq!(write(&mut p, 0, f32::NAN), Err(code::NOT_FINITE));
        assert_eq!(write(&mut p, 3, 0.5), Err(code::OUT_OF_RANGE));
        assert_eq!(write(&mut p, 10, 5.0), Err(code::OUT_OF_RANGE));
        assert_eq!(p, default_params());
        // Negative stiffness: written, then refused by model-core as a whole.
        assert_eq!(write(&mut p, 0, -1.0), Ok(()));
        let e = Prepared::new(&p, DT).map(|_| ()).unwrap_err();
        assert_eq!(error_code(&e), code::OUT_OF_RANGE);
        // Minimum above maximum.
        let mut p = default_params();
        assert_eq!(write(&mut p, 5, 20_000.0), Ok(()));
        let e = Prepared::new(&p, DT).map(|_| ()).unwrap_err();
        assert_eq!(error_code(&e), code::INCONSISTENT);
        assert_eq!(watchdog_limit(1.0), Err(code::OUT_OF_RANGE));
        assert_eq!(watchdog_limit(f32::INFINITY), Err(code::NOT_FINITE));
        assert_eq!(watchdog_limit(25.0), Ok(25));
        // Off (0) only where the build allows it (the QEMU build), never a fraction.
        assert_eq!(watchdog_limit_in(0.0, false), Err(code::OUT_OF_RANGE));
        assert_eq!(watchdog_limit_in(0.0, true), Ok(WATCHDOG_OFF));
        assert_eq!(watchdog_limit_in(0.5, true), Err(code::OUT_OF_RANGE));
        assert_eq!(watchdog_limit_in(1.0, true), Err(code::OUT_OF_RANGE));
        assert_eq!(watchdog_limit_in(f32::NAN, true), Err(code::NOT_FINITE));
        assert_eq!(watchdog_limit_in(25.0, true), Ok(25));
        assert_eq!(
            watchdog_limit(0.0).is_ok(),
            cfg!(feature = "qemu"),
            "off only in the QEMU build"
        );
        assert_eq!(status_period(0.0), Err(code::OUT_OF_RANGE));
        assert_eq!(status_period(2.5), Err(code::OUT_OF_RANGE));
        assert_eq!(watchdog_from_seconds(0.005), Ok(10));
        assert_eq!(watchdog_from_seconds(0.0051), Ok(10));
        assert_eq!(watchdog_from_seconds(5.0), Ok(10_000));
        assert_eq!(watchdog_from_seconds(0.0005), Err(code::OUT_OF_RANGE));
        assert_eq!(watchdog_from_seconds(-1.0), Err(code::OUT_OF_RANGE));
        assert_eq!(watchdog_from_seconds(f32::NAN), Err(code::NOT_FINITE));
        assert_eq!(watchdog_from_seconds(1.0e30), Err(code::OUT_OF_RANGE));
    }
}
