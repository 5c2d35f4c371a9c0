//! The calibration page and the measurement block: what an XCP master (CANape, INCA, pyxcp,
//! `mil param`) reads and writes, by address, and what the A2L file describes.
//!
//! # Calibration page
//! [`SLOTS`] little-endian 4-byte slots, each an `f32`; slot `s` is Command-frame parameter
//! index `s` ([`crate::params`]; the frame's 8-bit index reaches slots 0–255, the rest
//! through XCP): the status period K, the watchdog limit N and the sample rate, then
//! model-core's board page ([`model_core::page`]: the model kind and channel count, every
//! model's parameters, per-channel filters, limits and safe state; counts as integral
//! values). Two pages share the addresses:
//! - the **working page** (XCP page 0): [`WORKING`], in RAM, written only with a change that
//!   [`validate_write`] accepted (by `xcp::Target`, the one calibration authority, for XCP
//!   and Command frames alike); at start it holds the running values ([`mirror`]);
//! - the **reference page** (XCP page 1, read-only): [`REFERENCE`], the build's defaults
//!   ([`crate::config`]), copied into RAM at start.
//!
//! A write (any byte range inside the page, e.g. one XCP DOWNLOAD or a whole block) is
//! applied to a copy of the working page; every touched slot must decode to a value within
//! its [`CalItem`] limits (finite; integral where the item is a count or a switch), and the
//! whole resulting controller parameter set must pass model-core's `BoardParams::prepare`
//! at the page's sample rate (filter stability, minimum below maximum, ...), and the
//! configuration must fit the bus budget (`mil_frames::bus_load`). A change of model kind,
//! channel count or sample rate is accepted only while the controller is Idle
//! ([`code::WRONG_MODE`] otherwise). Only then is it handed on (the caller installs the
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

use mil_frames::bus_load::Schedule;
use model_core::board::BOARD_CHANNELS;
use model_core::page::{self, WordError, WORDS};
pub use model_core::page::{ParamInfo as CalItem, WordKind as Kind};
use model_core::{limits, ModelKind};

use crate::config::{
    default_params, Params, Prepared, SAMPLE_RATE_HZ, SAMPLE_RATE_RANGE, STATUS_PERIOD_RANGE,
    STATUS_PERIOD_SAMPLES, WATCHDOG_OFF_ALLOWED, WATCHDOG_SAMPLES, WATCHDOG_SAMPLES_RANGE,
};
use crate::params::{self, code};

/// Number of 4-byte slots of the calibration page: three settings, then model-core's board
/// page ([`model_core::page`], the controller's whole parameter set).
pub const SLOTS: usize = SETTINGS_SLOTS + WORDS;
/// Size of the calibration page (bytes).
pub const PAGE_BYTES: usize = 4 * SLOTS;
/// Slots before the board page: the settings.
pub const SETTINGS_SLOTS: usize = 3;
/// Slot of the status period K.
pub const SLOT_STATUS_PERIOD: usize = 0;
/// Slot of the watchdog limit N.
pub const SLOT_WATCHDOG: usize = 1;
/// Slot of the sample rate (changed only while Idle).
pub const SLOT_SAMPLE_RATE: usize = 2;
/// Slot of the model kind (changed only while Idle): the board page's first word.
pub const SLOT_MODEL_KIND: usize = SETTINGS_SLOTS;
/// Slot of the channel count (changed only while Idle).
pub const SLOT_CHANNELS: usize = SETTINGS_SLOTS + 1;

/// The settings' items, slots 0 to [`SETTINGS_SLOTS`].
const SETTINGS: [CalItem; 3] = [
    CalItem {
        group: "",
        name: "status_period",
        index: [0, 0],
        dims: 0,
        unit: "-",
        description: "controller steps per status frame",
        kind: Kind::Integer,
        min: STATUS_PERIOD_RANGE.0 as f32,
        max: STATUS_PERIOD_RANGE.1 as f32,
    },
    CalItem {
        group: "",
        name: "watchdog_limit",
        index: [0, 0],
        dims: 0,
        unit: "-",
        description: "communication watchdog: silent ticks (0.5 ms) before a trip",
        kind: Kind::Integer,
        min: if WATCHDOG_OFF_ALLOWED {
            0.0
        } else {
            WATCHDOG_SAMPLES_RANGE.0 as f32
        },
        max: WATCHDOG_SAMPLES_RANGE.1 as f32,
    },
    CalItem {
        group: "",
        name: "sample_rate",
        index: [0, 0],
        dims: 0,
        unit: "Hz",
        description: "rate of the servo controller's measurement frames (changed only while Idle; the bus budget of the configuration must hold)",
        kind: Kind::Integer,
        min: SAMPLE_RATE_RANGE.0 as f32,
        max: SAMPLE_RATE_RANGE.1 as f32,
    },
];

/// What slot `slot` holds, or `None` beyond the page.
pub fn item(slot: usize) -> Option<CalItem> {
    match slot.checked_sub(SETTINGS_SLOTS) {
        None => SETTINGS.get(slot).copied(),
        Some(k) => page::info(k),
    }
}

/// The firmware settings that are not controller parameters.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Settings {
    /// Status period K (steps).
    pub status_period: u16,
    /// Watchdog limit N (ticks; [`crate::config::WATCHDOG_OFF`] for off).
    pub watchdog: u16,
    /// Sample rate (Hz) of the measurement frames: the controller's step.
    pub sample_rate_hz: u16,
}

impl Settings {
    /// The sample period (s).
    pub fn dt(&self) -> f32 {
        1.0 / f32::from(self.sample_rate_hz.max(1))
    }
}

/// The build's default settings.
pub const DEFAULT_SETTINGS: Settings = Settings {
    status_period: STATUS_PERIOD_SAMPLES,
    watchdog: WATCHDOG_SAMPLES,
    sample_rate_hz: SAMPLE_RATE_HZ as u16,
};

/// The page's slots for `params` and `settings` (values as `f32`).
pub fn page_values(p: &Params, s: &Settings) -> [f32; SLOTS] {
    let mut out = [0.0; SLOTS];
    for_each_slot(p, s, |slot, v| {
        if let Some(o) = out.get_mut(slot) {
            *o = f32::from_bits(v);
        }
    });
    out
}

/// Calls `put(slot, bits)` for each slot of the page of `p` and `s`, with no array of
/// them (the board's paths: each page is kilobytes).
fn for_each_slot(p: &Params, s: &Settings, mut put: impl FnMut(usize, u32)) {
    for (slot, v) in [
        (SLOT_STATUS_PERIOD, s.status_period),
        (SLOT_WATCHDOG, s.watchdog),
        (SLOT_SAMPLE_RATE, s.sample_rate_hz),
    ] {
        put(slot, f32::from(v).to_bits());
    }
    page::for_each_word(p, |k, v| put(SETTINGS_SLOTS + k, v.to_bits()));
}

/// The reference page (XCP page 1): the build's defaults, read-only.
pub fn reference_words() -> [u32; SLOTS] {
    page_values(&default_params(), &DEFAULT_SETTINGS).map(f32::to_bits)
}

/// The reference page's copy read by XCP ([`read`]), filled once at start
/// ([`init_pages`]) from [`reference_words`].
pub static REFERENCE: [AtomicU32; SLOTS] = [const { AtomicU32::new(0) }; SLOTS];

/// The working page (XCP page 0), in RAM. Written only with a validated change
/// ([`store_working`]) and, at start, the running values ([`mirror`]).
pub static WORKING: [AtomicU32; SLOTS] = [const { AtomicU32::new(0) }; SLOTS];

/// Fills both pages with the build's defaults (at start, before anything reads them).
pub fn init_pages() {
    init_reference();
    for (w, r) in WORKING.iter().zip(&REFERENCE) {
        w.store(r.load(Ordering::Relaxed), Ordering::Relaxed);
    }
}

/// Fills the reference page ([`REFERENCE`]) with the build's defaults: idempotent (always
/// the same words), done by [`crate::application::Application::new`].
pub fn init_reference() {
    for_each_slot(&default_params(), &DEFAULT_SETTINGS, |slot, v| {
        if let Some(r) = REFERENCE.get(slot) {
            r.store(v, Ordering::Relaxed);
        }
    });
}

/// Copies page `page` ([`WORKING`] or [`REFERENCE`]) into `out`, in place.
pub fn load_page(page: Page, out: &mut [u32; SLOTS]) {
    let words = match page {
        Page::Working => &WORKING,
        Page::Reference => &REFERENCE,
    };
    for (o, w) in out.iter_mut().zip(words) {
        *o = w.load(Ordering::Relaxed);
    }
}

/// The running safe demand of each channel (`f32` bits) and the number of channels, for the
/// fatal path: written by [`Application::install`](crate::application::Application::install)
/// with every installed set (atomic stores, so a reader never sees half a value), read by
/// [`crate::link::safe_demand_frame`] when a panic or HardFault has stopped every task.
pub static SAFE_DEMAND: [AtomicU32; BOARD_CHANNELS] =
    [const { AtomicU32::new(crate::config::SAFE_DEMAND_N.to_bits()) }; BOARD_CHANNELS];
/// The running number of channels (see [`SAFE_DEMAND`]).
pub static RUNNING_CHANNELS: AtomicU32 = AtomicU32::new(1);
/// The buses the running configuration's channels are spread over (1 or 2, [`schedule`]):
/// the transmit half routes each channel's frames by it.
pub static RUNNING_BUSES: AtomicU32 = AtomicU32::new(1);

/// The buses the running configuration uses ([`RUNNING_BUSES`]).
pub fn running_buses() -> u8 {
    RUNNING_BUSES.load(Ordering::Relaxed).clamp(1, 2) as u8
}

/// The safe demand of channel `ch` of the set installed last ([`SAFE_DEMAND`]).
pub fn running_safe_demand(ch: usize) -> f32 {
    SAFE_DEMAND
        .get(ch)
        .map_or(0.0, |w| f32::from_bits(w.load(Ordering::Relaxed)))
}

/// The number of channels of the set installed last.
pub fn running_channels() -> usize {
    RUNNING_CHANNELS.load(Ordering::Relaxed) as usize
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
    let words = match page {
        Page::Working => &WORKING,
        Page::Reference => &REFERENCE,
    };
    for (k, b) in out.iter_mut().enumerate() {
        let at = offset.saturating_add(k);
        let word = words.get(at / 4).map(|w| w.load(Ordering::Relaxed));
        *b = word.map_or(0, |w| w.to_le_bytes().get(at % 4).copied().unwrap_or(0));
    }
}

/// Writes the running `params` and `settings` into [`WORKING`] (at start and after a change
/// made by a Command frame, so that both paths show the same values).
pub fn mirror(p: &Params, s: &Settings) {
    for_each_slot(p, s, |slot, v| {
        if let Some(w) = WORKING.get(slot) {
            w.store(v, Ordering::Relaxed);
        }
    });
}

/// The CommandAck code of a refused page word.
fn word_code(e: WordError) -> u8 {
    match e {
        WordError::NotFinite(_) => code::NOT_FINITE,
        WordError::OutOfRange(_) => code::OUT_OF_RANGE,
    }
}

/// The bus schedule of a configuration: its channels at its rate, on one bus when it fits
/// there, else channel `c` on CAN `c mod 2` (`mil_frames::bus_load::Schedule::fitting`); the aero model's
/// speed, and every channel's measured force for a substructure that takes forces.
pub fn schedule(p: &Params, s: &Settings) -> Schedule {
    let channels = p.channels.min(BOARD_CHANNELS as u32) as u8;
    let rate = f64::from(s.sample_rate_hz);
    let forces = p.substructure.causality().is_some_and(|c| {
        matches!(
            c,
            model_core::Causality::Admittance | model_core::Causality::AdmittanceThroughImpedance
        )
    });
    let one_bus = match p.model_kind() {
        Some(ModelKind::Aero) => Schedule::aero(rate),
        Some(ModelKind::Substructure) => Schedule::substructure(channels, forces, rate),
        _ => Schedule::tyre(channels, rate),
    };
    one_bus.fitting(BUS_BIT_PER_S)
}

/// The bus rate the schedules are budgeted for (bit/s): classic CAN at 1 Mbit/s.
pub const BUS_BIT_PER_S: f64 = 1.0e6;

/// The parameters and settings the page's `words` hold, validated slot by slot, as a whole
/// set at the page's sample rate, and against the bus budget, or the CommandAck code of
/// the first refusal. Host side: returns kilobytes by value (the board decodes in place,
/// [`decode_page_into`]).
#[cfg(not(target_os = "none"))]
pub fn decode_page(words: &[u32; SLOTS]) -> Result<(Prepared, Settings), u8> {
    let mut prepared = Prepared::BLANK;
    let settings = decode_page_into(words, &mut prepared)?;
    Ok((prepared, settings))
}

/// As [`decode_page`], preparing the set in place in `prepared` (kilobytes: no copy of it
/// on the stack); returns the settings. On a refusal `prepared` is not ready.
pub fn decode_page_into(words: &[u32; SLOTS], prepared: &mut Prepared) -> Result<Settings, u8> {
    page::from_words_into(
        |k| words.get(SETTINGS_SLOTS + k).map(|w| f32::from_bits(*w)),
        prepared.params_mut(),
    )
    .map_err(word_code)?;
    let mut settings = DEFAULT_SETTINGS;
    for slot in 0..SETTINGS_SLOTS {
        let value = f32::from_bits(words.get(slot).copied().ok_or(code::OUT_OF_RANGE)?);
        check_slot(slot, value)?;
        match slot {
            SLOT_STATUS_PERIOD => settings.status_period = params::status_period(value)?,
            SLOT_WATCHDOG => settings.watchdog = params::watchdog_limit(value)?,
            _ => settings.sample_rate_hz = params::integer_in(value, SAMPLE_RATE_RANGE)?,
        }
    }
    if !watchdog_spans_samples(&settings) {
        prepared.params_mut();
        return Err(code::INCONSISTENT);
    }
    prepared
        .prepare(settings.dt())
        .map_err(|e| params::error_code(&e))?;
    if schedule(prepared.params(), &settings)
        .check(BUS_BIT_PER_S)
        .is_err()
    {
        prepared.params_mut();
        return Err(code::BUS_BUDGET);
    }
    Ok(settings)
}

/// `true` when the watchdog (unless off) spans at least two sample periods: its limit is in
/// ticks of the fixed tick rate, so a slow sample rate needs a longer one (at 100 Hz the
/// default 10 ticks, 5 ms, would trip between every two samples).
pub fn watchdog_spans_samples(s: &Settings) -> bool {
    s.watchdog == crate::config::WATCHDOG_OFF
        || u32::from(s.watchdog) * u32::from(s.sample_rate_hz) >= 2 * crate::config::TICK_RATE_HZ
}

/// Stores `words` as the working page (a validated change; see `xcp::Target`).
pub fn store_working(words: &[u32; SLOTS]) {
    for (w, &v) in WORKING.iter().zip(words) {
        w.store(v, Ordering::Relaxed);
    }
}

/// The page slot of Command-frame parameter `index`: the slot itself, or `None` beyond
/// the page.
pub fn slot_of(index: u16) -> Option<usize> {
    let slot = usize::from(index);
    (slot < SLOTS).then_some(slot)
}

/// The slot of the item named `name` (as the A2L names it: group, name and indices joined
/// by `_`, e.g. `tyre_stiffness_0`), or `None`. Host side (formats every name).
#[cfg(not(target_os = "none"))]
pub fn slot_named(name: &str) -> Option<usize> {
    extern crate std;
    use std::string::ToString;
    (0..SLOTS).find(|&s| item(s).is_some_and(|i| i.to_string() == name))
}

/// The working page's words now.
pub fn working_words() -> [u32; SLOTS] {
    core::array::from_fn(|i| WORKING.get(i).map_or(0, |w| w.load(Ordering::Relaxed)))
}

/// Tests that write or compare the page statics take turns through this lock.
#[cfg(test)]
pub(crate) fn test_lock() -> std::sync::MutexGuard<'static, ()> {
    static PAGES: std::sync::Mutex<()> = std::sync::Mutex::new(());
    let guard = PAGES
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    if REFERENCE
        .first()
        .is_some_and(|w| w.load(Ordering::Relaxed) == 0)
        && REFERENCE
            .get(1)
            .is_some_and(|w| w.load(Ordering::Relaxed) == 0)
    {
        init_pages();
    }
    guard
}

/// A change of the working page being validated: the page's new words, and the controller
/// parameters and settings they hold, prepared in place (to install between two steps).
/// Kilobytes: one lives in the configuration tasks' shared resource, never on a stack.
pub struct Candidate {
    /// The whole controller parameter set, validated when ready.
    pub prepared: Prepared,
    /// The settings.
    pub settings: Settings,
    /// The working page's words with the change.
    pub words: [u32; SLOTS],
}

impl Candidate {
    /// Empty (not ready). All zero bits: the static one is zero-initialised RAM (`.bss`),
    /// not a 13 KB image in flash copied at start.
    pub const NEW: Self = Self {
        prepared: Prepared::BLANK,
        settings: Settings {
            status_period: 0,
            watchdog: 0,
            sample_rate_hz: 0,
        },
        words: [0; SLOTS],
    };
}

/// Host side (tests, host tools): a candidate of its own, for the life of the process.
#[cfg(not(target_os = "none"))]
pub fn host_candidate() -> &'static mut Candidate {
    extern crate std;
    std::boxed::Box::leak(std::boxed::Box::new(Candidate::NEW))
}

/// Checks one slot's value against its item: the CommandAck code of the reason if refused.
/// Out of line: looking the item up walks a scratch parameter set (kilobytes), whose frame
/// must be gone before a caller goes on to prepare the whole set.
#[inline(never)]
pub fn check_slot(slot: usize, value: f32) -> Result<(), u8> {
    let item = item(slot).ok_or(code::UNKNOWN_INDEX)?;
    page::check(&item, slot, value).map_err(word_code)
}

/// Validates writing `data` at byte `offset` of the page `words` (see the module
/// documentation) into `out`: the page's new words and what they hold, or the CommandAck
/// code of the refusal (the first refused slot's reason, then the whole set's; `out` then
/// not ready). Changes nothing else (the caller installs and stores it).
pub fn validate_write(
    words: &[u32; SLOTS],
    offset: usize,
    data: &[u8],
    out: &mut Candidate,
) -> Result<(), u8> {
    out.words = *words;
    validate_write_in_place(offset, data, out)
}

/// As [`validate_write`] on the page `out.words` already holds (no copy of it).
pub fn validate_write_in_place(offset: usize, data: &[u8], out: &mut Candidate) -> Result<(), u8> {
    out.prepared.params_mut();
    let end = offset.checked_add(data.len()).ok_or(code::OUT_OF_RANGE)?;
    if end > PAGE_BYTES || data.is_empty() {
        return Err(code::OUT_OF_RANGE);
    }
    let words = &mut out.words;
    for (k, &b) in data.iter().enumerate() {
        let at = offset + k;
        let w = words.get_mut(at / 4).ok_or(code::OUT_OF_RANGE)?;
        let mut bytes = w.to_le_bytes();
        if let Some(x) = bytes.get_mut(at % 4) {
            *x = b;
        }
        *w = u32::from_le_bytes(bytes);
    }
    // The touched slots first: a bad value is named as such.
    for slot in offset / 4..=(end - 1) / 4 {
        check_slot(
            slot,
            f32::from_bits(words.get(slot).copied().ok_or(code::OUT_OF_RANGE)?),
        )?;
    }
    out.settings = decode_page_into(&out.words, &mut out.prepared)?;
    Ok(())
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
pub const MEASUREMENTS: usize = 15;
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
    MeasItem {
        name: "time_us",
        description: "board time: the sample periods of the control steps since start, each at the rate it ran (wrapping); the DAQ timestamp",
        unit: "us",
        min: 0.0,
        max: u32::MAX as f32,
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
    /// Board time (µs, wrapping): every control step adds its sample period.
    pub const TIME_US: usize = 14;
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
    use std::string::ToString;

    /// [`validate_write`] into a fresh candidate.
    fn validate(
        words: &[u32; SLOTS],
        offset: usize,
        data: &[u8],
    ) -> Result<std::boxed::Box<Candidate>, u8> {
        let mut c = std::boxed::Box::new(Candidate::NEW);
        validate_write(words, offset, data, &mut c)?;
        assert!(c.prepared.is_ready());
        Ok(c)
    }

    fn lock() -> std::sync::MutexGuard<'static, ()> {
        test_lock()
    }

    fn bytes(v: f32) -> [u8; 4] {
        v.to_le_bytes()
    }

    fn slot(name: &str) -> usize {
        slot_named(name).unwrap_or_else(|| panic!("no slot {name}"))
    }

    fn defaults() -> [u32; SLOTS] {
        reference_words()
    }

    #[test]
    fn items_are_the_settings_then_the_board_page() {
        let mut names = std::collections::BTreeSet::new();
        for s in 0..SLOTS {
            let item = item(s).unwrap();
            assert!(names.insert(item.to_string()), "{item} twice");
        }
        assert!(item(SLOTS).is_none());
        assert_eq!(slot("status_period"), SLOT_STATUS_PERIOD);
        assert_eq!(slot("watchdog_limit"), SLOT_WATCHDOG);
        assert_eq!(slot("sample_rate"), SLOT_SAMPLE_RATE);
        assert_eq!(slot("model_kind"), SLOT_MODEL_KIND);
        assert_eq!(slot("model_channels"), SLOT_CHANNELS);
        assert_eq!(slot("tyre_stiffness_0"), SETTINGS_SLOTS + 2);
        // Command frames (8-bit index) reach the model, the tyres and the aero model.
        assert!(slot("tyre_velocity_cutoff_3") < 256 && slot("aero_use_map") < 256);
    }

    #[test]
    fn the_reference_page_holds_the_defaults() {
        let _turn = lock();
        let want = page_values(&default_params(), &DEFAULT_SETTINGS).map(f32::to_bits);
        assert_eq!(defaults(), want);
        let mut out = [0u8; 4];
        read(Page::Reference, 4 * slot("tyre_stiffness_0"), &mut out);
        assert_eq!(out, bytes(2.5e5));
        for (s, &v) in want.iter().enumerate() {
            assert!(
                check_slot(s, f32::from_bits(v)).is_ok(),
                "default of slot {s}"
            );
        }
        assert!(decode_page(&want).is_ok());
    }

    #[test]
    fn a_valid_write_is_validated_and_stores_nothing_by_itself() {
        let _turn = lock();
        init_pages();
        let before = working_words();
        let damping = slot("tyre_damping_0");
        let a = validate(&before, 4 * damping, &bytes(800.0)).expect("accepted");
        assert_eq!(a.prepared.params().tyre.tyre[0].damping, 800.0);
        assert_eq!(f32::from_bits(a.words[damping]), 800.0);
        assert_eq!(working_words(), before, "validation stores nothing");
        store_working(&a.words);
        let mut out = [0u8; 4];
        read(Page::Working, 4 * damping, &mut out);
        assert_eq!(out, bytes(800.0));
        read(Page::Reference, 4 * damping, &mut out);
        assert_eq!(out, bytes(500.0));
        let a = validate(&before, 4 * SLOT_STATUS_PERIOD, &bytes(20.0)).expect("accepted");
        assert_eq!(a.prepared.params(), &default_params());
        assert_eq!(a.settings.status_period, 20);
        init_pages();
    }

    #[test]
    fn refused_writes_name_the_reason() {
        let words = defaults();
        let cases = [
            ("tyre_stiffness_0", f32::NAN, code::NOT_FINITE),
            ("tyre_stiffness_0", -1.0, code::OUT_OF_RANGE),
            ("tyre_stiffness_0", 2.0e8, code::OUT_OF_RANGE),
            ("tyre_lift_off_0", 0.5, code::OUT_OF_RANGE),
            ("limits_demand_min_0", 20_000.0, code::INCONSISTENT),
            ("filter_sections_0", 1.5, code::OUT_OF_RANGE),
            ("model_kind", 3.0, code::OUT_OF_RANGE),
            ("model_channels", 5.0, code::OUT_OF_RANGE),
            ("sample_rate", 50.0, code::OUT_OF_RANGE),
            // The garbage of a channel that does not run is only range-checked…
            ("limits_demand_min_3", 20_000.0, code::OK),
            // …until it runs.
            ("model_channels", 4.0, code::INCONSISTENT),
        ];
        let mut w = words;
        for (name, value, want) in cases {
            let got = match validate(&w, 4 * slot(name), &bytes(value)) {
                Ok(a) => {
                    w = a.words;
                    code::OK
                }
                Err(c) => c,
            };
            assert_eq!(got, want, "{name} = {value}");
        }
        // An unstable section once applied: alpha1 = alpha2 = 0 is a double pole at z = 1.
        let mut block = [0u8; 24];
        block[0..4].copy_from_slice(&bytes(1.0)); // sections = 1
        block[4..8].copy_from_slice(&bytes(1.0)); // beta0
        assert_eq!(
            validate(&words, 4 * slot("filter_sections_0"), &block).err(),
            Some(code::UNSTABLE)
        );
        assert!(validate(&words, PAGE_BYTES - 2, &[0; 4]).is_err());
        assert!(validate(&words, 0, &[]).is_err());
        assert!(validate(&words, usize::MAX, &[0; 2]).is_err());
    }

    /// The configuration (sample rate, model kind, channels: slots 2–4, one block) must
    /// fit the bus budget: four tyres at 2 kHz do not, at 1 kHz they do (on both buses);
    /// the aero model at 1 kHz does.
    #[test]
    fn a_configuration_beyond_the_bus_budget_is_refused() {
        let words = defaults();
        let config = |rate: f32, kind: ModelKind, channels: f32| {
            let mut block = [0u8; 12];
            block[0..4].copy_from_slice(&bytes(rate));
            block[4..8].copy_from_slice(&bytes(kind as u32 as f32));
            block[8..12].copy_from_slice(&bytes(channels));
            validate(&words, 4 * SLOT_SAMPLE_RATE, &block).map(|a| a.settings.sample_rate_hz)
        };
        assert_eq!(
            config(2000.0, ModelKind::Tyre, 4.0).err(),
            Some(code::BUS_BUDGET)
        );
        assert_eq!(config(1000.0, ModelKind::Tyre, 4.0), Ok(1000));
        assert_eq!(config(2000.0, ModelKind::Tyre, 1.0), Ok(2000));
        assert_eq!(config(1000.0, ModelKind::Aero, 2.0), Ok(1000));
        assert_eq!(config(2000.0, ModelKind::Aero, 2.0), Ok(2000));
        assert_eq!(
            config(2500.0, ModelKind::Aero, 2.0).err(),
            Some(code::BUS_BUDGET)
        );
        // One bus while it carries the configuration (a rig with one bus wired runs it),
        // both beyond.
        let buses = |rate: u16, kind: ModelKind, channels: u32| {
            let mut p = default_params();
            p.kind = kind as u32;
            p.channels = channels;
            let s = Settings {
                sample_rate_hz: rate,
                ..DEFAULT_SETTINGS
            };
            schedule(&p, &s).buses
        };
        assert_eq!(buses(2000, ModelKind::Tyre, 1), 1);
        assert_eq!(buses(1000, ModelKind::Aero, 2), 1);
        assert_eq!(buses(2000, ModelKind::Aero, 2), 2);
        assert_eq!(buses(500, ModelKind::Tyre, 4), 1);
        assert_eq!(buses(1000, ModelKind::Tyre, 4), 2);
    }

    /// A slow sample rate needs a watchdog of at least two of its periods (the limit is in
    /// ticks of the fixed tick rate): 100 Hz with the default 10 ticks (5 ms) is refused as
    /// inconsistent, with 40 ticks (20 ms) accepted, and 400 Hz takes the default.
    #[test]
    fn a_watchdog_shorter_than_two_samples_is_refused() {
        let words = defaults();
        let settings = |rate: f32, watchdog: f32| {
            let mut block = [0u8; 8];
            block[0..4].copy_from_slice(&bytes(watchdog));
            block[4..8].copy_from_slice(&bytes(rate));
            validate(&words, 4 * SLOT_WATCHDOG, &block).map(|a| a.settings.sample_rate_hz)
        };
        assert_eq!(SLOT_SAMPLE_RATE, SLOT_WATCHDOG + 1);
        assert_eq!(settings(100.0, 10.0).err(), Some(code::INCONSISTENT));
        assert_eq!(settings(100.0, 40.0), Ok(100));
        assert_eq!(settings(400.0, 10.0), Ok(400));
        assert_eq!(settings(399.0, 10.0).err(), Some(code::INCONSISTENT));
    }

    #[test]
    fn a_whole_filter_goes_in_as_one_block() {
        // Count 1 and one stable section (poles at 0.9 ± 0: alpha1 = 0.2, alpha2 = 0.01,
        // unity DC gain: beta2 = alpha2).
        let vals = [1.0f32, 0.0, 0.0, 0.01, 0.2, 0.01];
        let mut block = [0u8; 24];
        for (k, v) in vals.iter().enumerate() {
            block[4 * k..4 * k + 4].copy_from_slice(&bytes(*v));
        }
        let a = validate(&defaults(), 4 * slot("filter_sections_0"), &block)
            .expect("stable filter accepted");
        let f = a.prepared.params().filter[0];
        assert_eq!(f.sections, 1);
        assert_eq!(f.section[0].alpha1, 0.2);
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
