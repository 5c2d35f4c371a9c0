//! Parameters by index: a Command frame's "set parameter" (index, f32 value) writes slot
//! `index` of the calibration page ([`crate::calibration`]: model-core's board page, then
//! the status period, the watchdog limit and the sample rate), the same transaction as an
//! XCP write of that slot; and the result codes of a CommandAck.
//!
//! A change is applied to a copy of the working page, the whole page is validated (each
//! slot against its item, the set with model-core's `BoardParams::prepare`, the bus budget),
//! outside any lock (the control task keeps running), and only a valid set is swapped in
//! between two steps. A rejected value changes nothing and is answered with an error code.
//! A change of model kind, channel count or sample rate is taken only while the controller
//! is Idle ([`code::WRONG_MODE`]); other changes while Running are bumpless
//! (model-core's `Controller::swap_params`): the filters restart at rest at the model's
//! output and the demand fades to the new target over `model_core::BUMPLESS_FADE_S`;
//! narrowed limits close in at the rate limit.
//!
//! Filter coefficients of sections beyond a channel's applied count are checked only for
//! their range until the count includes them, so a filter is loaded by writing the count
//! 0, then the coefficients, then the count (or as one block through XCP, as `mil filter
//! upload` does). The QEMU build also accepts the watchdog limit 0, the watchdog off until
//! reset, for the instruction benchmark ([`crate::config::WATCHDOG_OFF`]); the board build
//! refuses it.

use model_core::ParamError;

use crate::config::{
    STATUS_PERIOD_RANGE, TICK_RATE_HZ, WATCHDOG_OFF, WATCHDOG_OFF_ALLOWED, WATCHDOG_SAMPLES_RANGE,
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
    /// The configuration (model, channels, sample rate) needs more than the bus budget of
    /// 60 % of 1 Mbit/s (`mil_frames::bus_load`); nothing changed.
    pub const BUS_BUDGET: u8 = FIRMWARE + 21;
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
/// (the DBC's unit): `N = round(value · TICK_RATE_HZ)` ticks of 0.5 ms, so 5 ms gives the
/// default N = 10. Allowed: N in 2 ..= 10 000 (1 ms to 5 s). In the QEMU build a tick lasts
/// longer (see [`crate::config::QEMU_TICK_US`]), so the timeout there is N ticks of QEMU
/// time, not `value` seconds.
pub fn watchdog_from_seconds(value: f32) -> Result<u16, u8> {
    if !value.is_finite() {
        return Err(code::NOT_FINITE);
    }
    let n = value * TICK_RATE_HZ as f32;
    if !(0.0..=1.0e6).contains(&n) {
        return Err(code::OUT_OF_RANGE);
    }
    // Non-negative and below 2^24: adding one half and truncating rounds exactly.
    integer_in((n + 0.5) as u32 as f32, WATCHDOG_SAMPLES_RANGE)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{default_params, DT};

    #[test]
    fn rejections_name_the_reason() {
        // Negative stiffness: refused by model-core as a whole.
        let mut p = default_params();
        p.tyre.tyre[0].stiffness = -1.0;
        let e = p.prepare(DT).map(|_| ()).unwrap_err();
        assert_eq!(error_code(&e), code::OUT_OF_RANGE);
        // Minimum above maximum.
        let mut p = default_params();
        p.limits[0].min = 20_000.0;
        let e = p.prepare(DT).map(|_| ()).unwrap_err();
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
