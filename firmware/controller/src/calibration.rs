//! The calibration page and the measurement block: what an XCP master (CANape, INCA, pyxcp,
//! `mil param`) reads and writes, by address, and what the A2L file describes.
//!
//! # Calibration page
//! [`SLOTS`] little-endian 4-byte slots; slot `s` holds the parameter of Command-frame index
//! [`CalItem::index`] ([`crate::params`]): the 31 controller parameters (indices 0–30) as
//! `f32`, then the status period K and the watchdog limit N (indices 100, 101) as `f32`
//! holding integers. Two pages share the addresses:
//! - the **working page** (XCP page 0): [`WORKING`], in RAM, written only with a change that
//!   [`validate_write`] accepted (by `xcp::Target`, the one calibration authority, for XCP
//!   and Command frames alike); at start it holds the running values ([`mirror`]);
//! - the **reference page** (XCP page 1, read-only): [`REFERENCE`], the build's defaults
//!   ([`crate::config`]), in flash.
//!
//! A write (any byte range inside the page, e.g. one XCP DOWNLOAD or a whole block) is
//! applied to a copy of the working page; every touched slot must decode to a value within
//! its [`CalItem`] limits (finite; integral where the item is a count or a switch), and the
//! whole resulting controller parameter set must pass `PreparedParams::new` (filter
//! stability, minimum below maximum, ...). Only then is it handed on (the caller installs the
//! prepared set between two control steps when the controller runs the working page, and
//! stores the words into [`WORKING`]); a rejected write changes nothing and returns the
//! CommandAck code of its reason ([`params::code`]). The controller always runs one of the
//! two pages: the one XCP's GET_CAL_PAGE names for the ECU.
//!
//! # Measurement block
//! [`MEASUREMENT`]: [`MEASUREMENTS`] 4-byte slots the control task stores once per step
//! (relaxed atomic stores, about one instruction each), read by XCP UPLOAD and DAQ.
//!
//! Both blocks are statics of `AtomicU32` (a layout equal to `u32`'s), so that they have real
//! addresses in the linked ELF for the A2L file (found by the symbol names
//! `mil_firmware::calibration::WORKING` and `...::MEASUREMENT`) without `unsafe`.

use core::sync::atomic::{AtomicU32, Ordering};

use model_core::controller::SAFE_RAMP_RATE;
use model_core::{limits, tyre, velocity, ParamError, Range, MAX_SECTIONS};

use crate::config::{
    default_params, Params, Prepared, DT, STATUS_PERIOD_RANGE, STATUS_PERIOD_SAMPLES,
    WATCHDOG_OFF_ALLOWED, WATCHDOG_SAMPLES, WATCHDOG_SAMPLES_RANGE,
};
use crate::params::{self, code, INDEX_STATUS_PERIOD, INDEX_WATCHDOG};

/// Number of 4-byte slots of the calibration page.
pub const SLOTS: usize = 33;
/// Size of the calibration page (bytes).
pub const PAGE_BYTES: usize = 4 * SLOTS;
/// Slot of the status period K.
pub const SLOT_STATUS_PERIOD: usize = 31;
/// Slot of the watchdog limit N.
pub const SLOT_WATCHDOG: usize = 32;

/// How a slot's `f32` is read: model-core's word kinds (a real value, an integer, a
/// switch), the ones its board page uses.
pub use model_core::page::WordKind as Kind;

/// One calibration parameter: what the A2L file says of it and what a write must satisfy.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CalItem {
    /// A2L name (an identifier).
    pub name: &'static str,
    /// A2L long identifier.
    pub description: &'static str,
    /// Physical unit (SI), `-` for none.
    pub unit: &'static str,
    /// Its Command-frame parameter index ([`crate::params`]).
    pub index: u16,
    /// How the value is read.
    pub kind: Kind,
    /// Lowest allowed value (unit as above).
    pub min: f32,
    /// Highest allowed value.
    pub max: f32,
}

const fn real(
    name: &'static str,
    description: &'static str,
    unit: &'static str,
    index: u16,
    r: Range,
) -> CalItem {
    CalItem {
        name,
        description,
        unit,
        index,
        kind: Kind::Real,
        min: r.min,
        max: r.max,
    }
}

pub use model_core::biquad::{FILTER_ALPHA, FILTER_BETA};

macro_rules! section {
    ($s:literal) => {
        [
            real(
                concat!("filter_s", $s, "_beta0"),
                concat!("command filter section ", $s, ": beta0 = b0 (delta form)"),
                "-",
                11 + 5 * $s,
                FILTER_BETA,
            ),
            real(
                concat!("filter_s", $s, "_beta1"),
                concat!(
                    "command filter section ",
                    $s,
                    ": beta1 = 2 b0 + b1 (delta form)"
                ),
                "-",
                12 + 5 * $s,
                FILTER_BETA,
            ),
            real(
                concat!("filter_s", $s, "_beta2"),
                concat!(
                    "command filter section ",
                    $s,
                    ": beta2 = b0 + b1 + b2 (delta form)"
                ),
                "-",
                13 + 5 * $s,
                FILTER_BETA,
            ),
            real(
                concat!("filter_s", $s, "_alpha1"),
                concat!(
                    "command filter section ",
                    $s,
                    ": alpha1 = 2 + a1 (delta form)"
                ),
                "-",
                14 + 5 * $s,
                FILTER_ALPHA,
            ),
            real(
                concat!("filter_s", $s, "_alpha2"),
                concat!(
                    "command filter section ",
                    $s,
                    ": alpha2 = 1 + a1 + a2 (delta form)"
                ),
                "-",
                15 + 5 * $s,
                FILTER_ALPHA,
            ),
        ]
    };
}

const SECTIONS: [[CalItem; 5]; MAX_SECTIONS] = [section!(0), section!(1), section!(2), section!(3)];

const HEAD: [CalItem; 11] = [
    real(
        "tyre_stiffness",
        "tyre radial stiffness k_t",
        "N/m",
        0,
        tyre::TYRE_STIFFNESS,
    ),
    real(
        "tyre_damping",
        "tyre radial damping c_t",
        "N*s/m",
        1,
        tyre::TYRE_DAMPING,
    ),
    real(
        "tyre_static_load",
        "static wheel load",
        "N",
        2,
        tyre::TYRE_STATIC_LOAD,
    ),
    CalItem {
        name: "tyre_lift_off",
        description: "tyre can lift off the road (1) or is linear (0)",
        unit: "-",
        index: 3,
        kind: Kind::Switch,
        min: 0.0,
        max: 1.0,
    },
    real(
        "tyre_velocity_cutoff",
        "deflection-velocity low-pass cut-off (0: none; exact ZOH first order, stable at any value)",
        "Hz",
        4,
        velocity::VELOCITY_CUTOFF,
    ),
    real(
        "demand_min",
        "lowest force demand",
        "N",
        5,
        limits::DEMAND_AMPLITUDE,
    ),
    real(
        "demand_max",
        "highest force demand",
        "N",
        6,
        limits::DEMAND_AMPLITUDE,
    ),
    real(
        "demand_rate",
        "demand rate limit",
        "N/s",
        7,
        limits::DEMAND_RATE,
    ),
    real(
        "safe_demand",
        "demand in the safe state; must lie within [demand_min, demand_max] (a page where it does not is refused)",
        "N",
        8,
        limits::DEMAND_AMPLITUDE,
    ),
    real(
        "safe_ramp_rate",
        "rate towards the safe demand",
        "N/s",
        9,
        SAFE_RAMP_RATE,
    ),
    CalItem {
        name: "filter_sections",
        description: "command filter: number of sections applied",
        unit: "-",
        index: 10,
        kind: Kind::Integer,
        min: 0.0,
        max: MAX_SECTIONS as f32,
    },
];

const TAIL: [CalItem; 2] = [
    CalItem {
        name: "status_period",
        description: "controller steps per status frame",
        unit: "-",
        index: INDEX_STATUS_PERIOD,
        kind: Kind::Integer,
        min: STATUS_PERIOD_RANGE.0 as f32,
        max: STATUS_PERIOD_RANGE.1 as f32,
    },
    CalItem {
        name: "watchdog_limit",
        description: "communication watchdog: silent ticks before a trip",
        unit: "-",
        index: INDEX_WATCHDOG,
        kind: Kind::Integer,
        min: if WATCHDOG_OFF_ALLOWED {
            0.0
        } else {
            WATCHDOG_SAMPLES_RANGE.0 as f32
        },
        max: WATCHDOG_SAMPLES_RANGE.1 as f32,
    },
];

/// Every calibration parameter, in slot order (slot `s` at byte offset `4 s`).
// Evaluated at compile time: an index out of range fails the build, never the board.
#[allow(clippy::indexing_slicing)]
pub const ITEMS: [CalItem; SLOTS] = {
    let mut out = [HEAD[0]; SLOTS];
    let mut i = 0;
    while i < HEAD.len() {
        out[i] = HEAD[i];
        i += 1;
    }
    let mut s = 0;
    while s < MAX_SECTIONS {
        let mut c = 0;
        while c < 5 {
            out[HEAD.len() + 5 * s + c] = SECTIONS[s][c];
            c += 1;
        }
        s += 1;
    }
    out[SLOT_STATUS_PERIOD] = TAIL[0];
    out[SLOT_WATCHDOG] = TAIL[1];
    out
};

/// The firmware settings that are not controller parameters.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Settings {
    /// Status period K (steps).
    pub status_period: u16,
    /// Watchdog limit N (ticks; [`crate::config::WATCHDOG_OFF`] for off).
    pub watchdog: u16,
}

/// The build's default settings.
pub const DEFAULT_SETTINGS: Settings = Settings {
    status_period: STATUS_PERIOD_SAMPLES,
    watchdog: WATCHDOG_SAMPLES,
};

/// The page's slots for `params` and `settings` (values as `f32`).
pub fn page_values(p: &Params, s: &Settings) -> [f32; SLOTS] {
    let mut out = [0.0; SLOTS];
    for (slot, (v, item)) in out.iter_mut().zip(ITEMS.iter()).enumerate() {
        *v = match slot {
            SLOT_STATUS_PERIOD => f32::from(s.status_period),
            SLOT_WATCHDOG => f32::from(s.watchdog),
            _ => params::read(p, item.index).unwrap_or(0.0),
        };
    }
    out
}

// Evaluated at compile time: an index out of range fails the build, never the board.
#[allow(clippy::indexing_slicing)]
const fn reference_words() -> [u32; SLOTS] {
    // `params::read` is not `const`: the defaults are spelled out once more, and
    // `the_reference_page_holds_the_defaults` checks them against it.
    let p = default_params();
    let [tyre] = p.model.tyre;
    let [lim] = p.limits;
    let [filter] = p.filter;
    let mut w = [0u32; SLOTS];
    w[0] = tyre.stiffness.to_bits();
    w[1] = tyre.damping.to_bits();
    w[2] = tyre.static_load.to_bits();
    w[3] = (tyre.lift_off as f32).to_bits();
    w[4] = tyre.velocity_cutoff_hz.to_bits();
    w[5] = lim.min.to_bits();
    w[6] = lim.max.to_bits();
    w[7] = lim.rate.to_bits();
    w[8] = p.safe_demand[0].to_bits();
    w[9] = p.safe_ramp_rate[0].to_bits();
    w[10] = (filter.sections as f32).to_bits();
    let mut s = 0;
    while s < MAX_SECTIONS {
        let c = filter.section[s];
        w[11 + 5 * s] = c.beta0.to_bits();
        w[12 + 5 * s] = c.beta1.to_bits();
        w[13 + 5 * s] = c.beta2.to_bits();
        w[14 + 5 * s] = c.alpha1.to_bits();
        w[15 + 5 * s] = c.alpha2.to_bits();
        s += 1;
    }
    w[SLOT_STATUS_PERIOD] = (DEFAULT_SETTINGS.status_period as f32).to_bits();
    w[SLOT_WATCHDOG] = (DEFAULT_SETTINGS.watchdog as f32).to_bits();
    w
}

/// The reference page (XCP page 1): the build's defaults, read-only, in flash.
pub static REFERENCE: [u32; SLOTS] = reference_words();

/// The working page (XCP page 0), in RAM. Written only with a validated change
/// ([`store_working`]) and, at start, the running values ([`mirror`]).
// Evaluated at compile time: an index out of range fails the build, never the board.
#[allow(clippy::indexing_slicing)]
pub static WORKING: [AtomicU32; SLOTS] = {
    let words = reference_words();
    let mut out = [const { AtomicU32::new(0) }; SLOTS];
    let mut i = 0;
    while i < SLOTS {
        out[i] = AtomicU32::new(words[i]);
        i += 1;
    }
    out
};

/// The running safe demand (channel 0, `f32` bits), for the fatal path: written by
/// [`Application::install`](crate::application::Application::install) with every installed
/// set (one atomic store, so a reader never sees half a value), read by
/// [`crate::link::safe_demand_frame`] when a panic or HardFault has stopped every task.
pub static SAFE_DEMAND: AtomicU32 = AtomicU32::new(crate::config::SAFE_DEMAND_N.to_bits());

/// The safe demand of the set installed last ([`SAFE_DEMAND`]).
pub fn running_safe_demand() -> f32 {
    f32::from_bits(SAFE_DEMAND.load(Ordering::Relaxed))
}

/// Which page an access addresses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Page {
    /// Page 0: the running values.
    Working,
    /// Page 1: the build's defaults.
    Reference,
}

/// Copies `out.len()` bytes of `page` from byte `offset` into `out`; bytes beyond the page
/// read as 0 (the XCP slave checks the range before it calls this).
pub fn read(page: Page, offset: usize, out: &mut [u8]) {
    for (k, b) in out.iter_mut().enumerate() {
        let at = offset.saturating_add(k);
        let word = match page {
            Page::Working => WORKING.get(at / 4).map(|w| w.load(Ordering::Relaxed)),
            Page::Reference => REFERENCE.get(at / 4).copied(),
        };
        *b = word.map_or(0, |w| w.to_le_bytes().get(at % 4).copied().unwrap_or(0));
    }
}

/// Writes the running `params` and `settings` into [`WORKING`] (at start and after a change
/// made by a Command frame, so that both paths show the same values).
pub fn mirror(p: &Params, s: &Settings) {
    for (w, v) in WORKING.iter().zip(page_values(p, s)) {
        w.store(v.to_bits(), Ordering::Relaxed);
    }
}

/// The parameters and settings the page's `words` hold, validated slot by slot and as a
/// whole set, or the CommandAck code of the first refusal.
pub fn decode_page(words: &[u32; SLOTS]) -> Result<(Prepared, Settings), u8> {
    let mut next = default_params();
    let mut settings = DEFAULT_SETTINGS;
    for (slot, (&w, item)) in words.iter().zip(ITEMS.iter()).enumerate() {
        let value = f32::from_bits(w);
        check_slot(slot, value)?;
        match slot {
            SLOT_STATUS_PERIOD => settings.status_period = params::status_period(value)?,
            SLOT_WATCHDOG => settings.watchdog = params::watchdog_limit(value)?,
            _ => params::write(&mut next, item.index, value)?,
        }
    }
    let prepared = Prepared::new(&next, DT).map_err(|e: ParamError| params::error_code(&e))?;
    Ok((prepared, settings))
}

/// Stores `words` as the working page (a validated change; see `xcp::Target`).
pub fn store_working(words: &[u32; SLOTS]) {
    for (w, &v) in WORKING.iter().zip(words) {
        w.store(v, Ordering::Relaxed);
    }
}

/// The page slot of parameter `index` ([`CalItem::index`]), or `None` for an unknown index.
pub fn slot_of(index: u16) -> Option<usize> {
    ITEMS.iter().position(|item| item.index == index)
}

/// The working page's words now.
pub fn working_words() -> [u32; SLOTS] {
    core::array::from_fn(|i| WORKING.get(i).map_or(0, |w| w.load(Ordering::Relaxed)))
}

/// Tests that write or compare the page statics take turns through this lock.
#[cfg(test)]
pub(crate) fn test_lock() -> std::sync::MutexGuard<'static, ()> {
    static PAGES: std::sync::Mutex<()> = std::sync::Mutex::new(());
    PAGES
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// A validated change of the working page: the page's new words, and the prepared
/// controller parameters and settings they hold (to install between two steps).
pub struct Accepted {
    /// The whole controller parameter set, validated.
    pub prepared: Prepared,
    /// The settings.
    pub settings: Settings,
    /// The working page's words with the change.
    pub words: [u32; SLOTS],
}

/// Checks one slot's value against its item: the CommandAck code of the reason if refused.
pub fn check_slot(slot: usize, value: f32) -> Result<(), u8> {
    let item = ITEMS.get(slot).ok_or(code::UNKNOWN_INDEX)?;
    if !value.is_finite() {
        return Err(code::NOT_FINITE);
    }
    if value < item.min || value > item.max {
        return Err(code::OUT_OF_RANGE);
    }
    let integral = value == (value as i64) as f32;
    match item.kind {
        Kind::Real => Ok(()),
        Kind::Integer | Kind::Switch if integral => Ok(()),
        _ => Err(code::OUT_OF_RANGE),
    }
}

/// Validates writing `data` at byte `offset` of the page holding `p` and `s` (see the
/// module documentation): the page's new words and what they hold, or the CommandAck code
/// of the refusal. Pure: changes nothing (the caller installs and stores it).
pub fn validate_write(
    p: &Params,
    s: &Settings,
    offset: usize,
    data: &[u8],
) -> Result<Accepted, u8> {
    let end = offset.checked_add(data.len()).ok_or(code::OUT_OF_RANGE)?;
    if end > PAGE_BYTES || data.is_empty() {
        return Err(code::OUT_OF_RANGE);
    }
    let mut words = page_values(p, s).map(f32::to_bits);
    for (k, &b) in data.iter().enumerate() {
        let at = offset + k;
        let w = words.get_mut(at / 4).ok_or(code::OUT_OF_RANGE)?;
        let mut bytes = w.to_le_bytes();
        if let Some(x) = bytes.get_mut(at % 4) {
            *x = b;
        }
        *w = u32::from_le_bytes(bytes);
    }
    let first = offset / 4;
    let last = (end - 1) / 4;
    let mut next = *p;
    let mut settings = *s;
    for slot in first..=last {
        let value = f32::from_bits(words.get(slot).copied().ok_or(code::OUT_OF_RANGE)?);
        check_slot(slot, value)?;
        match slot {
            SLOT_STATUS_PERIOD => settings.status_period = params::status_period(value)?,
            SLOT_WATCHDOG => settings.watchdog = params::watchdog_limit(value)?,
            _ => {
                let index = ITEMS.get(slot).ok_or(code::UNKNOWN_INDEX)?.index;
                params::write(&mut next, index, value)?;
            }
        }
    }
    let prepared = Prepared::new(&next, DT).map_err(|e: ParamError| params::error_code(&e))?;
    Ok(Accepted {
        prepared,
        settings,
        words,
    })
}

/// One measurement: what the A2L file says of it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeasItem {
    /// A2L name.
    pub name: &'static str,
    /// A2L long identifier.
    pub description: &'static str,
    /// Physical unit (SI), `-` for none.
    pub unit: &'static str,
    /// `true`: `f32`; `false`: `u32`.
    pub float: bool,
    /// Lowest value it can take (unit as above).
    pub min: f32,
    /// Highest value it can take.
    pub max: f32,
}

/// Number of measurement slots.
pub const MEASUREMENTS: usize = 14;
/// Size of the measurement block (bytes).
pub const MEASUREMENT_BYTES: usize = 4 * MEASUREMENTS;

/// Every measurement, in slot order (slot `s` at byte offset `4 s` of [`MEASUREMENT`]).
pub const MEAS_ITEMS: [MeasItem; MEASUREMENTS] = [
    MeasItem {
        name: "position",
        description: "measured actuator position (channel 0)",
        unit: "m",
        min: -1.0,
        max: 1.0,
        float: true,
    },
    MeasItem {
        name: "road",
        description: "road displacement input (channel 0)",
        unit: "m",
        min: -1.0,
        max: 1.0,
        float: true,
    },
    MeasItem {
        name: "demand",
        description: "force demand sent to the servo controller (channel 0)",
        unit: "N",
        min: limits::DEMAND_AMPLITUDE.min,
        max: limits::DEMAND_AMPLITUDE.max,
        float: true,
    },
    MeasItem {
        name: "mode",
        description: "controller mode: 0 idle, 1 running, 2 fault",
        unit: "-",
        min: 0.0,
        max: 2.0,
        float: false,
    },
    MeasItem {
        name: "fault_causes",
        description: "latched fault causes (bit mask, as in the Status frame)",
        unit: "-",
        min: 0.0,
        max: 255.0,
        float: false,
    },
    MeasItem {
        name: "steps",
        description: "controller steps since start",
        unit: "-",
        min: 0.0,
        max: u32::MAX as f32,
        float: false,
    },
    MeasItem {
        name: "missed_samples",
        description: "measurement samples missed (counter gaps)",
        unit: "-",
        min: 0.0,
        max: u32::MAX as f32,
        float: false,
    },
    MeasItem {
        name: "malformed_frames",
        description: "malformed frames received",
        unit: "-",
        min: 0.0,
        max: u32::MAX as f32,
        float: false,
    },
    MeasItem {
        name: "calibration_changes",
        description: "calibration changes applied since start",
        unit: "-",
        min: 0.0,
        max: u32::MAX as f32,
        float: false,
    },
    MeasItem {
        name: "calibration_last_rejection",
        description: "CommandAck code of the last refused calibration change (0: none)",
        unit: "-",
        min: 0.0,
        max: 255.0,
        float: false,
    },
    MeasItem {
        name: "daq_dropped",
        description: "XCP DAQ samples or packets dropped (queue full, bus busy)",
        unit: "-",
        min: 0.0,
        max: u32::MAX as f32,
        float: false,
    },
    MeasItem {
        name: "calibration_source",
        description: "running calibration at boot: 0 build defaults (nothing stored), 1 stored page, 2 build defaults (stored page refused), 3 build defaults (storage unreadable)",
        unit: "-",
        min: 0.0,
        max: 3.0,
        float: false,
    },
    MeasItem {
        name: "calibration_stores",
        description: "calibration stores (SET_REQUEST STORE_CAL_REQ) written to flash since start",
        unit: "-",
        min: 0.0,
        max: u32::MAX as f32,
        float: false,
    },
    MeasItem {
        name: "calibration_store_error",
        description: "outcome of the last store: 0 stored, 1 page invalid, 2 flash error, 3 read-back differs",
        unit: "-",
        min: 0.0,
        max: 4.0,
        float: false,
    },
];

/// Where the running calibration came from at boot (measurement `calibration_source`,
/// [`meas::CAL_SOURCE`]; status frame `CalibrationSource`): chosen by
/// [`crate::store::boot`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum Source {
    /// The build's defaults: nothing is stored.
    Defaults = 0,
    /// The stored page.
    Stored = 1,
    /// The build's defaults: a stored page was refused (format, layout, CRC or validation).
    Refused = 2,
    /// The build's defaults: the storage could not be read.
    Unreadable = 3,
}

/// Slot of each measurement in [`MEASUREMENT`].
pub mod meas {
    /// Position (m).
    pub const POSITION: usize = 0;
    /// Road (m).
    pub const ROAD: usize = 1;
    /// Demand (N).
    pub const DEMAND: usize = 2;
    /// Mode.
    pub const MODE: usize = 3;
    /// Fault causes.
    pub const FAULT: usize = 4;
    /// Steps.
    pub const STEPS: usize = 5;
    /// Missed samples.
    pub const MISSED: usize = 6;
    /// Malformed frames.
    pub const MALFORMED: usize = 7;
    /// Calibration changes applied.
    pub const CAL_CHANGES: usize = 8;
    /// Last calibration rejection code.
    pub const CAL_REJECTION: usize = 9;
    /// DAQ samples or packets dropped.
    pub const DAQ_DROPPED: usize = 10;
    /// Where the running calibration came from at boot.
    pub const CAL_SOURCE: usize = 11;
    /// Calibration stores written.
    pub const CAL_STORES: usize = 12;
    /// Outcome of the last calibration store.
    pub const CAL_STORE_ERROR: usize = 13;
}

/// The measurement block, in RAM (see the module documentation).
pub static MEASUREMENT: [AtomicU32; MEASUREMENTS] = [const { AtomicU32::new(0) }; MEASUREMENTS];

/// Stores `value` in measurement `slot` (an `f32` slot).
pub fn store_f32(slot: usize, value: f32) {
    if let Some(w) = MEASUREMENT.get(slot) {
        w.store(value.to_bits(), Ordering::Relaxed);
    }
}

/// Stores `value` in measurement `slot` (a `u32` slot).
pub fn store_u32(slot: usize, value: u32) {
    if let Some(w) = MEASUREMENT.get(slot) {
        w.store(value, Ordering::Relaxed);
    }
}

/// Copies `out.len()` bytes of the measurement block from byte `offset`; bytes beyond it
/// read as 0.
pub fn read_measurement(offset: usize, out: &mut [u8]) {
    for (k, b) in out.iter_mut().enumerate() {
        let at = offset.saturating_add(k);
        *b = MEASUREMENT.get(at / 4).map_or(0, |w| {
            w.load(Ordering::Relaxed)
                .to_le_bytes()
                .get(at % 4)
                .copied()
                .unwrap_or(0)
        });
    }
}

/// Adds one to the counter in measurement `slot` (wrapping).
pub fn count(slot: usize) {
    if let Some(w) = MEASUREMENT.get(slot) {
        // A load and a store, not `fetch_add`: only one context writes each counter slot
        // (the calibration tasks, which never preempt each other, or the DAQ task), and
        // the same code then builds for targets without atomic read-modify-write.
        w.store(w.load(Ordering::Relaxed).wrapping_add(1), Ordering::Relaxed);
    }
}

/// Records the outcome of a calibration change (a parameter or setting command, or an XCP
/// write, copy or page switch): [`meas::CAL_CHANGES`] counts the applied ones,
/// [`meas::CAL_REJECTION`] keeps the CommandAck code of the last refused one.
pub fn note_change(result: u8) {
    if result == code::OK {
        count(meas::CAL_CHANGES);
    } else {
        store_u32(meas::CAL_REJECTION, u32::from(result));
    }
}

/// The measurement block's words now.
pub fn measurement_words() -> [u32; MEASUREMENTS] {
    core::array::from_fn(|i| MEASUREMENT.get(i).map_or(0, |w| w.load(Ordering::Relaxed)))
}

/// The address of the working page ([`WORKING`]): the start of the XCP calibration region.
/// On the board it is a 32-bit RAM address; on a 64-bit host only the low 32 bits.
pub fn working_address() -> u32 {
    WORKING.as_ptr() as usize as u32
}

/// The address of the measurement block ([`MEASUREMENT`]): the start of the XCP measurement
/// region (32-bit on the board, see [`working_address`]).
pub fn measurement_address() -> u32 {
    MEASUREMENT.as_ptr() as usize as u32
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;

    fn lock() -> std::sync::MutexGuard<'static, ()> {
        test_lock()
    }

    fn bytes(v: f32) -> [u8; 4] {
        v.to_le_bytes()
    }

    #[test]
    fn items_match_the_parameter_indices_and_are_unique() {
        for (slot, item) in ITEMS.iter().enumerate() {
            match slot {
                SLOT_STATUS_PERIOD => assert_eq!(item.index, INDEX_STATUS_PERIOD),
                SLOT_WATCHDOG => assert_eq!(item.index, INDEX_WATCHDOG),
                _ => assert_eq!(usize::from(item.index), slot, "{}", item.name),
            }
            assert!(item.min <= item.max && item.min.is_finite() && item.max.is_finite());
            for other in &ITEMS[slot + 1..] {
                assert_ne!(item.name, other.name);
            }
        }
        assert_eq!(ITEMS[11].name, "filter_s0_beta0");
        assert_eq!(ITEMS[30].name, "filter_s3_alpha2");
        assert_eq!(ITEMS[30].index, 30);
    }

    #[test]
    fn the_reference_page_holds_the_defaults() {
        let want = page_values(&default_params(), &DEFAULT_SETTINGS).map(f32::to_bits);
        assert_eq!(REFERENCE, want);
        let mut out = [0u8; PAGE_BYTES];
        read(Page::Reference, 0, &mut out);
        assert_eq!(&out[0..4], &bytes(2.5e5));
        for (slot, &v) in page_values(&default_params(), &DEFAULT_SETTINGS)
            .iter()
            .enumerate()
        {
            assert!(check_slot(slot, v).is_ok(), "default of slot {slot}");
        }
    }

    #[test]
    fn a_valid_write_is_validated_and_stores_nothing_by_itself() {
        let _turn = lock();
        let p = default_params();
        let s = DEFAULT_SETTINGS;
        mirror(&p, &s);
        let before = working_words();
        let a = validate_write(&p, &s, 4, &bytes(800.0)).expect("accepted");
        assert_eq!(a.prepared.params().model.tyre[0].damping, 800.0);
        assert_eq!(f32::from_bits(a.words[1]), 800.0);
        assert_eq!(working_words(), before, "validation stores nothing");
        store_working(&a.words);
        let mut out = [0u8; 4];
        read(Page::Working, 4, &mut out);
        assert_eq!(out, bytes(800.0));
        // The reference page is untouched.
        read(Page::Reference, 4, &mut out);
        assert_eq!(out, bytes(500.0));
        // Settings.
        let a = validate_write(&p, &s, 4 * SLOT_STATUS_PERIOD, &bytes(20.0)).expect("accepted");
        assert_eq!(a.prepared.params(), &p);
        assert_eq!(a.settings.status_period, 20);
        mirror(&p, &s);
    }

    #[test]
    fn refused_writes_change_nothing_and_name_the_reason() {
        let _turn = lock();
        let p = default_params();
        let s = DEFAULT_SETTINGS;
        mirror(&p, &s);
        let before: [u32; SLOTS] = core::array::from_fn(|i| WORKING[i].load(Ordering::Relaxed));
        let cases: [(usize, [u8; 4], u8); 6] = [
            (0, bytes(f32::NAN), code::NOT_FINITE),
            (0, bytes(-1.0), code::OUT_OF_RANGE),
            (0, bytes(2.0e8), code::OUT_OF_RANGE),
            (12, bytes(0.5), code::OUT_OF_RANGE), // lift-off switch 0.5
            (20, bytes(20_000.0), code::INCONSISTENT), // minimum above maximum
            (40, bytes(1.5), code::OUT_OF_RANGE), // section count 1.5
        ];
        for (offset, data, want) in cases {
            assert_eq!(
                validate_write(&p, &s, offset, &data).err(),
                Some(want),
                "offset {offset}"
            );
        }
        // An unstable section once applied: alpha2 of section 0 = 0 with alpha1 = 0 is a
        // double pole at z = 1.
        let mut block = [0u8; 24];
        block[0..4].copy_from_slice(&bytes(1.0)); // sections = 1
        block[4..8].copy_from_slice(&bytes(1.0)); // beta0
                                                  // beta1, beta2, alpha1, alpha2 = 0
        assert_eq!(
            validate_write(&p, &s, 40, &block).err(),
            Some(code::UNSTABLE)
        );
        // Straddling the end, empty, and overflowing.
        assert!(validate_write(&p, &s, PAGE_BYTES - 2, &[0; 4]).is_err());
        assert!(validate_write(&p, &s, 0, &[]).is_err());
        assert!(validate_write(&p, &s, usize::MAX, &[0; 2]).is_err());
        let after: [u32; SLOTS] = core::array::from_fn(|i| WORKING[i].load(Ordering::Relaxed));
        assert_eq!(before, after);
    }

    #[test]
    fn a_whole_filter_goes_in_as_one_block() {
        let _turn = lock();
        let p = default_params();
        let s = DEFAULT_SETTINGS;
        // Count 1 and one stable section (poles at 0.9 ± 0: alpha1 = 0.2, alpha2 = 0.01,
        // unity DC gain: beta2 = alpha2).
        let vals = [1.0f32, 0.0, 0.0, 0.01, 0.2, 0.01];
        let mut block = [0u8; 24];
        for (k, v) in vals.iter().enumerate() {
            block[4 * k..4 * k + 4].copy_from_slice(&bytes(*v));
        }
        let a = validate_write(&p, &s, 40, &block).expect("stable filter accepted");
        let f = a.prepared.params().filter[0];
        assert_eq!(f.sections, 1);
        assert_eq!(f.section[0].alpha1, 0.2);
        mirror(&p, &s);
    }

    #[test]
    fn measurements_read_back_as_stored() {
        store_f32(meas::DEMAND, 1234.5);
        store_u32(meas::STEPS, 0x0102_0304);
        let mut out = [0u8; 4];
        read_measurement(4 * meas::DEMAND, &mut out);
        assert_eq!(out, 1234.5f32.to_le_bytes());
        read_measurement(4 * meas::STEPS, &mut out);
        assert_eq!(out, [4, 3, 2, 1]);
        // Beyond the block: zeros.
        read_measurement(MEASUREMENT_BYTES - 2, &mut out);
        assert_eq!(&out[2..], &[0, 0]);
        assert_eq!(MEAS_ITEMS.len(), MEASUREMENTS);
    }
}
