//! DAQ commands: FREE_DAQ, ALLOC_DAQ, ALLOC_ODT, ALLOC_ODT_ENTRY, SET_DAQ_PTR, WRITE_DAQ,
//! SET_DAQ_LIST_MODE, GET_DAQ_LIST_MODE, START_STOP_DAQ_LIST, START_STOP_SYNCH,
//! GET_DAQ_CLOCK, GET_DAQ_PROCESSOR_INFO, GET_DAQ_RESOLUTION_INFO, GET_DAQ_EVENT_INFO.
//! Configuring, starting and stopping needs DAQ unlocked; the queries do not.

use crate::access::{resolve, Mta, Virtual};
use crate::daq::{mode, EVENT_CHANNELS, MAX_DAQ_LISTS, MAX_ODT_ENTRY_SIZE};
use crate::memory::Platform;
use crate::protocol::{resource, ErrorCode};
use crate::response::Responses;
use crate::slave::Slave;
use crate::wire::{byte, check_extension, dword, word, CmdResult};

/// Name of event channel 0, uploaded after GET_DAQ_EVENT_INFO.
pub(crate) const EVENT_NAME: &[u8] = b"control step";

/// DAQ_PROPERTIES: bit 0 dynamic configuration, bit 1 prescaler supported, bit 4 timestamps
/// supported (no resume, no bit-wise STIM, PID not switchable, no overload indication).
pub(crate) const DAQ_PROPERTIES: u8 = 0x13;
/// DAQ_KEY_BYTE: optimisation default, address extension free (always 0), identification
/// field "absolute ODT number" (bits 6–7 = 0).
pub(crate) const DAQ_KEY_BYTE: u8 = 0x00;
/// TIMESTAMP_MODE: size 4 bytes (bits 0–2 = 4), not fixed (bit 3 = 0: per list, SET_DAQ_LIST_MODE
/// bit 4), unit 1 µs (bits 4–7 = 3).
pub(crate) const TIMESTAMP_MODE: u8 = 0x34;
/// DAQ_EVENT_PROPERTIES: consistency per event channel (bits 6–7 = 2), DAQ (bit 2).
pub(crate) const EVENT_PROPERTIES: u8 = 0x84;
/// WRITE_DAQ bit offset meaning "whole element".
const NO_BIT_OFFSET: u8 = 0xFF;
/// GET_DAQ_CLOCK TRIGGER_INFO: time of sampling "on reception of the command" (3 << 3).
const CLOCK_TRIGGER_INFO: u8 = 0x18;
/// GET_DAQ_CLOCK PAYLOAD_FMT: 4-byte slave timestamp.
const CLOCK_PAYLOAD_FMT: u8 = 0x01;

/// EVENT_CHANNEL_TIME_CYCLE and _UNIT for a period in µs: the finest unit (1 µs, 10 µs, …,
/// 1 s; unit codes 3..=9) whose cycle fits a byte, rounded to the nearest cycle (exact for
/// periods like 200, 500, 1000 µs). 0 µs is "not cyclic" (cycle 0).
#[must_use]
pub(crate) fn event_cycle(period_us: u32) -> (u8, u8) {
    if period_us == 0 {
        return (0, 3);
    }
    let mut scale = 1_u32;
    for unit in 3_u8..=9 {
        let cycle = period_us / scale + u32::from(period_us % scale >= scale.div_ceil(2));
        if let Ok(c) = u8::try_from(cycle) {
            return (c, unit);
        }
        scale = scale.saturating_mul(10);
    }
    (u8::MAX, 9)
}

impl Slave {
    fn configurable(&self) -> CmdResult {
        self.require_unlocked(resource::DAQ)
    }

    fn stopped(&self) -> CmdResult {
        if self.daq.running() {
            Err(ErrorCode::DaqActive.into())
        } else {
            Ok(())
        }
    }

    /// FREE_DAQ `D6`: stops and frees every list.
    pub(crate) fn free_daq(&mut self, out: &mut Responses) -> CmdResult {
        self.configurable()?;
        self.daq.free();
        out.ok(&[]);
        Ok(())
    }

    /// ALLOC_DAQ `D5 reserved count(u16)`.
    pub(crate) fn alloc_daq(&mut self, cto: &[u8], out: &mut Responses) -> CmdResult {
        self.configurable()?;
        let count = word(cto, 2)?;
        self.stopped()?;
        self.daq.alloc_daq(count)?;
        out.ok(&[]);
        Ok(())
    }

    /// ALLOC_ODT `D4 reserved list(u16) count`.
    pub(crate) fn alloc_odt(&mut self, cto: &[u8], out: &mut Responses) -> CmdResult {
        self.configurable()?;
        let list = word(cto, 2)?;
        let count = byte(cto, 4)?;
        self.stopped()?;
        self.daq.alloc_odt(list, count)?;
        out.ok(&[]);
        Ok(())
    }

    /// ALLOC_ODT_ENTRY `D3 reserved list(u16) odt count`.
    pub(crate) fn alloc_odt_entry(&mut self, cto: &[u8], out: &mut Responses) -> CmdResult {
        self.configurable()?;
        let list = word(cto, 2)?;
        let odt = byte(cto, 4)?;
        let count = byte(cto, 5)?;
        self.stopped()?;
        self.daq.alloc_odt_entry(list, odt, count)?;
        out.ok(&[]);
        Ok(())
    }

    /// SET_DAQ_PTR `E2 reserved list(u16) odt entry`.
    pub(crate) fn set_daq_ptr(&mut self, cto: &[u8], out: &mut Responses) -> CmdResult {
        self.configurable()?;
        let list = word(cto, 2)?;
        let odt = byte(cto, 4)?;
        let entry = byte(cto, 5)?;
        self.daq.set_pointer(list, odt, entry)?;
        out.ok(&[]);
        Ok(())
    }

    /// WRITE_DAQ `E1 bit_offset size ext addr(u32)`: bit offset 0xFF (whole element), size
    /// 1..=4, extension 0, all bytes inside the measurement or the calibration region; then
    /// the DAQ pointer moves to the next entry.
    pub(crate) fn write_daq(&mut self, cto: &[u8], out: &mut Responses) -> CmdResult {
        self.configurable()?;
        let bit_offset = byte(cto, 1)?;
        let size = byte(cto, 2)?;
        let ext = byte(cto, 3)?;
        let addr = dword(cto, 4)?;
        let slot = self.daq.write_target()?;
        if bit_offset != NO_BIT_OFFSET || size == 0 || size > MAX_ODT_ENTRY_SIZE {
            return Err(ErrorCode::OutOfRange.into());
        }
        check_extension(ext)?;
        let r =
            resolve(&self.config, addr, u32::from(size), false).ok_or(ErrorCode::AccessDenied)?;
        self.daq.write_entry(slot, r.area, r.offset, size)?;
        out.ok(&[]);
        Ok(())
    }

    /// SET_DAQ_LIST_MODE `E0 mode list(u16) event(u16) prescaler priority`: mode bit 4
    /// (timestamp) only, event 0, any prescaler (0 and 1: every event; n: every n-th event,
    /// the first one right after the start), any priority (stored, not used: lists of one
    /// event are sampled in list order).
    pub(crate) fn set_daq_list_mode(&mut self, cto: &[u8], out: &mut Responses) -> CmdResult {
        self.configurable()?;
        let m = byte(cto, 1)?;
        let list = word(cto, 2)?;
        let event = word(cto, 4)?;
        let prescaler = byte(cto, 6)?;
        let priority = byte(cto, 7)?;
        if m & !mode::TIMESTAMP != 0 || event >= EVENT_CHANNELS {
            return Err(ErrorCode::OutOfRange.into());
        }
        self.daq
            .set_mode(list, m & mode::TIMESTAMP != 0, event, prescaler, priority)?;
        out.ok(&[]);
        Ok(())
    }

    /// GET_DAQ_LIST_MODE `DF reserved list(u16)`: `FF mode reserved(2) event(u16)
    /// prescaler(1) priority`; mode bits 0 selected, 4 timestamp, 6 running.
    pub(crate) fn get_daq_list_mode(&mut self, cto: &[u8], out: &mut Responses) -> CmdResult {
        let list = word(cto, 2)?;
        let (bits, event, prescaler, priority) = self.daq.mode(list)?;
        let [e0, e1] = event.to_le_bytes();
        out.ok(&[bits, 0, 0, e0, e1, prescaler, priority]);
        Ok(())
    }

    /// START_STOP_DAQ_LIST `DE mode list(u16)`: 0 stop, 1 start, 2 select; `FF first_pid`.
    /// Start and select check the list (`ERR_DAQ_CONFIG`).
    pub(crate) fn start_stop_daq_list(&mut self, cto: &[u8], out: &mut Responses) -> CmdResult {
        self.configurable()?;
        let op = byte(cto, 1)?;
        let list = word(cto, 2)?;
        let first_pid = self.daq.start_stop_list(list, op)?;
        out.ok(&[first_pid]);
        Ok(())
    }

    /// START_STOP_SYNCH `DD mode`: 0 stop all, 1 start selected, 2 stop selected.
    pub(crate) fn start_stop_synch(&mut self, cto: &[u8], out: &mut Responses) -> CmdResult {
        self.configurable()?;
        let op = byte(cto, 1)?;
        self.daq.start_stop_synch(op)?;
        out.ok(&[]);
        Ok(())
    }

    /// GET_DAQ_CLOCK `DC`: `FF reserved trigger_info payload_fmt timestamp(u32, µs)`.
    pub(crate) fn get_daq_clock(
        &mut self,
        platform: &impl Platform,
        out: &mut Responses,
    ) -> CmdResult {
        let [t0, t1, t2, t3] = platform.now_us().to_le_bytes();
        out.ok(&[0, CLOCK_TRIGGER_INFO, CLOCK_PAYLOAD_FMT, t0, t1, t2, t3]);
        Ok(())
    }

    /// GET_DAQ_PROCESSOR_INFO `DA`: `FF properties max_daq(u16) max_event(u16) min_daq
    /// key_byte`. MAX_DAQ is the number of lists allocated now (dynamic configuration:
    /// MIN_DAQ + DAQ_COUNT).
    pub(crate) fn get_daq_processor_info(&mut self, out: &mut Responses) -> CmdResult {
        let [d0, d1] = self.daq.list_count().to_le_bytes();
        let [e0, e1] = EVENT_CHANNELS.to_le_bytes();
        out.ok(&[DAQ_PROPERTIES, d0, d1, e0, e1, 0, DAQ_KEY_BYTE]);
        Ok(())
    }

    /// GET_DAQ_RESOLUTION_INFO `D9`: `FF granularity_daq(1) max_entry_daq(4)
    /// granularity_stim(1) max_entry_stim(0) timestamp_mode timestamp_ticks(u16 = 1)`.
    pub(crate) fn get_daq_resolution_info(&mut self, out: &mut Responses) -> CmdResult {
        out.ok(&[1, MAX_ODT_ENTRY_SIZE, 1, 0, TIMESTAMP_MODE, 1, 0]);
        Ok(())
    }

    /// GET_DAQ_EVENT_INFO `D7 reserved event(u16)`: event 0 only. `FF properties
    /// max_daq_list name_length cycle unit priority`; the MTA then points at the name.
    pub(crate) fn get_daq_event_info(&mut self, cto: &[u8], out: &mut Responses) -> CmdResult {
        let event = word(cto, 2)?;
        if event >= EVENT_CHANNELS {
            return Err(ErrorCode::OutOfRange.into());
        }
        let (cycle, unit) = event_cycle(self.config.event_period_us);
        self.mta = Mta::Virtual {
            area: Virtual::EventName,
            offset: 0,
        };
        out.ok(&[
            EVENT_PROPERTIES,
            MAX_DAQ_LISTS as u8,
            EVENT_NAME.len() as u8,
            cycle,
            unit,
            0,
        ]);
        Ok(())
    }
}
