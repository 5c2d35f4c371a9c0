//! Dynamic DAQ lists in static storage: allocation (FREE → ALLOC_DAQ → ALLOC_ODT →
//! ALLOC_ODT_ENTRY), the DAQ pointer, list modes, start/stop, and sampling into DTO frames.
//!
//! Limits ([`MAX_DAQ_LISTS`], [`MAX_ODTS`], [`MAX_ODT_ENTRIES`] in total); beyond them
//! allocation answers `ERR_MEMORY_OVERFLOW`. One ODT is one DTO frame: PID (absolute ODT
//! number) and up to 7 data bytes; the first ODT of a list with timestamps carries the 4-byte
//! timestamp after the PID, leaving 3 data bytes.

use crate::access::{to_usize, Area};
use crate::memory::{Memory, Page};
use crate::protocol::{ErrorCode, MAX_DTO};

/// DAQ lists that can be allocated.
pub const MAX_DAQ_LISTS: usize = 4;
/// ODTs that can be allocated over all lists (so PIDs stay below 0xFC).
pub const MAX_ODTS: usize = 32;
/// ODT entries that can be allocated over all ODTs.
pub const MAX_ODT_ENTRIES: usize = 128;
/// Entries one ODT can hold (each at least one byte in 7 data bytes).
pub const MAX_ENTRIES_PER_ODT: u8 = 7;
/// Largest ODT entry (GET_DAQ_RESOLUTION_INFO); entries are 1..=4 bytes.
pub const MAX_ODT_ENTRY_SIZE: u8 = 4;
/// Timestamp size in the first DTO of a list with timestamps.
pub const TIMESTAMP_BYTES: usize = 4;
/// Data bytes of one ODT (DTO minus the PID).
pub const ODT_DATA_BYTES: usize = MAX_DTO - 1;
/// Event channels (only channel 0, "control step").
pub const EVENT_CHANNELS: u16 = 1;

/// SET_DAQ_LIST_MODE / GET_DAQ_LIST_MODE mode bits.
pub(crate) mod mode {
    pub const SELECTED: u8 = 0x01;
    pub const TIMESTAMP: u8 = 0x10;
    pub const RUNNING: u8 = 0x40;
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Entry {
    /// `None` until WRITE_DAQ wrote it.
    target: Option<(Area, u32)>,
    size: u8,
}

const EMPTY_ENTRY: Entry = Entry {
    target: None,
    size: 0,
};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Odt {
    first_entry: u16,
    entry_count: u8,
    entries_allocated: bool,
}

const EMPTY_ODT: Odt = Odt {
    first_entry: 0,
    entry_count: 0,
    entries_allocated: false,
};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct List {
    first_odt: u8,
    odt_count: u8,
    odts_allocated: bool,
    event: u16,
    timestamp: bool,
    priority: u8,
    /// Sample every `prescaler`-th event (1: every event).
    prescaler: u8,
    /// Events since the last sample (counts down to 0).
    countdown: u8,
    selected: bool,
    running: bool,
}

const EMPTY_LIST: List = List {
    first_odt: 0,
    odt_count: 0,
    odts_allocated: false,
    event: 0,
    timestamp: false,
    priority: 0,
    prescaler: 1,
    countdown: 0,
    selected: false,
    running: false,
};

/// Where the dynamic configuration stands; the standard's allowed order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Stage {
    Freed,
    Daq,
    Odt,
    Entry,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Pointer {
    list: u16,
    odt: u8,
    entry: u8,
}

/// The DAQ configuration and run state.
#[derive(Clone, Debug)]
pub(crate) struct Daq {
    lists: [List; MAX_DAQ_LISTS],
    list_count: u16,
    odts: [Odt; MAX_ODTS],
    odts_used: u8,
    entries: [Entry; MAX_ODT_ENTRIES],
    entries_used: u16,
    stage: Stage,
    pointer: Option<Pointer>,
}

type DaqResult<T> = Result<T, ErrorCode>;

impl Daq {
    pub const fn new() -> Self {
        Self {
            lists: [EMPTY_LIST; MAX_DAQ_LISTS],
            list_count: 0,
            odts: [EMPTY_ODT; MAX_ODTS],
            odts_used: 0,
            entries: [EMPTY_ENTRY; MAX_ODT_ENTRIES],
            entries_used: 0,
            stage: Stage::Freed,
            pointer: None,
        }
    }

    /// Whether any list is running.
    pub fn running(&self) -> bool {
        self.active_lists().any(|l| l.running)
    }

    /// Number of allocated lists.
    pub fn list_count(&self) -> u16 {
        self.list_count
    }

    fn active_lists(&self) -> impl Iterator<Item = &List> {
        self.lists.iter().take(usize::from(self.list_count))
    }

    fn list(&self, list: u16) -> DaqResult<&List> {
        if list >= self.list_count {
            return Err(ErrorCode::OutOfRange);
        }
        self.lists
            .get(usize::from(list))
            .ok_or(ErrorCode::OutOfRange)
    }

    fn list_mut(&mut self, list: u16) -> DaqResult<&mut List> {
        if list >= self.list_count {
            return Err(ErrorCode::OutOfRange);
        }
        self.lists
            .get_mut(usize::from(list))
            .ok_or(ErrorCode::OutOfRange)
    }

    fn odt_of(&self, list: &List, odt: u8) -> DaqResult<Odt> {
        if odt >= list.odt_count {
            return Err(ErrorCode::OutOfRange);
        }
        self.odts
            .get(usize::from(list.first_odt) + usize::from(odt))
            .copied()
            .ok_or(ErrorCode::OutOfRange)
    }

    /// FREE_DAQ (also on CONNECT and DISCONNECT): stops and forgets everything.
    pub fn free(&mut self) {
        *self = Self::new();
    }

    /// ALLOC_DAQ: only directly after FREE_DAQ.
    pub fn alloc_daq(&mut self, count: u16) -> DaqResult<()> {
        if self.stage != Stage::Freed {
            return Err(ErrorCode::Sequence);
        }
        if usize::from(count) > MAX_DAQ_LISTS {
            return Err(ErrorCode::MemoryOverflow);
        }
        self.list_count = count;
        self.stage = Stage::Daq;
        Ok(())
    }

    /// ALLOC_ODT: after ALLOC_DAQ or ALLOC_ODT, once per list.
    pub fn alloc_odt(&mut self, list: u16, count: u8) -> DaqResult<()> {
        if !matches!(self.stage, Stage::Daq | Stage::Odt) {
            return Err(ErrorCode::Sequence);
        }
        let first = self.odts_used;
        let total = usize::from(first) + usize::from(count);
        let l = self.list_mut(list)?;
        if l.odts_allocated {
            return Err(ErrorCode::Sequence);
        }
        if total > MAX_ODTS {
            return Err(ErrorCode::MemoryOverflow);
        }
        l.first_odt = first;
        l.odt_count = count;
        l.odts_allocated = true;
        self.odts_used = u8::try_from(total).map_err(|_| ErrorCode::MemoryOverflow)?;
        self.stage = Stage::Odt;
        Ok(())
    }

    /// ALLOC_ODT_ENTRY: after ALLOC_ODT or ALLOC_ODT_ENTRY, once per ODT.
    pub fn alloc_odt_entry(&mut self, list: u16, odt: u8, count: u8) -> DaqResult<()> {
        if !matches!(self.stage, Stage::Odt | Stage::Entry) {
            return Err(ErrorCode::Sequence);
        }
        let l = *self.list(list)?;
        let o = self.odt_of(&l, odt)?;
        if o.entries_allocated {
            return Err(ErrorCode::Sequence);
        }
        if count > MAX_ENTRIES_PER_ODT {
            return Err(ErrorCode::OutOfRange);
        }
        let first = self.entries_used;
        let total = usize::from(first) + usize::from(count);
        if total > MAX_ODT_ENTRIES {
            return Err(ErrorCode::MemoryOverflow);
        }
        let index = usize::from(l.first_odt) + usize::from(odt);
        let slot = self.odts.get_mut(index).ok_or(ErrorCode::OutOfRange)?;
        *slot = Odt {
            first_entry: first,
            entry_count: count,
            entries_allocated: true,
        };
        self.entries_used = u16::try_from(total).map_err(|_| ErrorCode::MemoryOverflow)?;
        self.stage = Stage::Entry;
        Ok(())
    }

    /// SET_DAQ_PTR.
    pub fn set_pointer(&mut self, list: u16, odt: u8, entry: u8) -> DaqResult<()> {
        if self.list_count == 0 {
            return Err(ErrorCode::Sequence);
        }
        let l = *self.list(list)?;
        if l.running {
            return Err(ErrorCode::DaqActive);
        }
        let o = self.odt_of(&l, odt)?;
        if entry >= o.entry_count {
            return Err(ErrorCode::OutOfRange);
        }
        self.pointer = Some(Pointer { list, odt, entry });
        Ok(())
    }

    /// The entry slot WRITE_DAQ would write, checked (pointer set, list stopped, not past
    /// the ODT's last entry).
    pub fn write_target(&self) -> DaqResult<usize> {
        let p = self.pointer.ok_or(ErrorCode::Sequence)?;
        let l = *self.list(p.list)?;
        if l.running {
            return Err(ErrorCode::DaqActive);
        }
        let o = self.odt_of(&l, p.odt)?;
        if p.entry >= o.entry_count {
            return Err(ErrorCode::OutOfRange);
        }
        Ok(usize::from(o.first_entry) + usize::from(p.entry))
    }

    /// WRITE_DAQ into the slot from [`Daq::write_target`]; the pointer moves to the next entry.
    pub fn write_entry(&mut self, slot: usize, area: Area, offset: u32, size: u8) -> DaqResult<()> {
        let entry = self.entries.get_mut(slot).ok_or(ErrorCode::OutOfRange)?;
        *entry = Entry {
            target: Some((area, offset)),
            size,
        };
        if let Some(p) = self.pointer.as_mut() {
            p.entry = p.entry.saturating_add(1);
        }
        Ok(())
    }

    /// SET_DAQ_LIST_MODE (parameters already checked by the command).
    pub fn set_mode(
        &mut self,
        list: u16,
        timestamp: bool,
        event: u16,
        prescaler: u8,
        priority: u8,
    ) -> DaqResult<()> {
        let l = self.list_mut(list)?;
        if l.running {
            return Err(ErrorCode::DaqActive);
        }
        l.timestamp = timestamp;
        l.event = event;
        l.prescaler = prescaler.max(1);
        l.countdown = 0;
        l.priority = priority;
        Ok(())
    }

    /// GET_DAQ_LIST_MODE: (mode bits, event, prescaler, priority).
    pub fn mode(&self, list: u16) -> DaqResult<(u8, u16, u8, u8)> {
        let l = self.list(list)?;
        let mut bits = 0;
        if l.selected {
            bits |= mode::SELECTED;
        }
        if l.timestamp {
            bits |= mode::TIMESTAMP;
        }
        if l.running {
            bits |= mode::RUNNING;
        }
        Ok((bits, l.event, l.prescaler, l.priority))
    }

    /// FIRST_PID of a list: the ODTs of all lower-numbered lists come first.
    pub fn first_pid(&self, list: u16) -> u8 {
        let sum: usize = self
            .active_lists()
            .take(usize::from(list))
            .map(|l| usize::from(l.odt_count))
            .sum();
        // At most MAX_ODTS (32) in total.
        u8::try_from(sum).unwrap_or(u8::MAX)
    }

    /// Whether a list can run: at least one ODT, every allocated entry written, every ODT
    /// within its capacity (7 data bytes, 3 in the first ODT with a timestamp).
    fn check(&self, l: &List) -> DaqResult<()> {
        if l.odt_count == 0 {
            return Err(ErrorCode::DaqConfig);
        }
        for odt in 0..l.odt_count {
            let o = self.odt_of(l, odt)?;
            let capacity = if odt == 0 && l.timestamp {
                ODT_DATA_BYTES - TIMESTAMP_BYTES
            } else {
                ODT_DATA_BYTES
            };
            let mut bytes = 0_usize;
            for e in self.odt_entries(&o) {
                if e.target.is_none() {
                    return Err(ErrorCode::DaqConfig);
                }
                bytes += usize::from(e.size);
            }
            if bytes > capacity {
                return Err(ErrorCode::DaqConfig);
            }
        }
        Ok(())
    }

    fn odt_entries(&self, o: &Odt) -> impl Iterator<Item = &Entry> {
        self.entries
            .iter()
            .skip(usize::from(o.first_entry))
            .take(usize::from(o.entry_count))
    }

    /// START_STOP_DAQ_LIST: 0 stop, 1 start, 2 select. Returns FIRST_PID.
    pub fn start_stop_list(&mut self, list: u16, op: u8) -> DaqResult<u8> {
        let l = *self.list(list)?;
        match op {
            0 => {
                self.list_mut(list)?.running = false;
            }
            1 => {
                self.check(&l)?;
                let l = self.list_mut(list)?;
                l.running = true;
                l.countdown = 0;
            }
            2 => {
                self.check(&l)?;
                self.list_mut(list)?.selected = true;
            }
            _ => return Err(ErrorCode::OutOfRange),
        }
        Ok(self.first_pid(list))
    }

    /// START_STOP_SYNCH: 0 stop all, 1 start selected, 2 stop selected; clears the
    /// selection. Starting checks every selected list first and starts none when one fails.
    pub fn start_stop_synch(&mut self, op: u8) -> DaqResult<()> {
        let count = usize::from(self.list_count);
        match op {
            0 => {
                for l in self.lists.iter_mut().take(count) {
                    l.running = false;
                    l.selected = false;
                }
            }
            1 => {
                for l in self.active_lists().filter(|l| l.selected) {
                    self.check(l)?;
                }
                for l in self.lists.iter_mut().take(count) {
                    if l.selected {
                        l.running = true;
                        l.countdown = 0;
                        l.selected = false;
                    }
                }
            }
            2 => {
                for l in self.lists.iter_mut().take(count) {
                    if l.selected {
                        l.running = false;
                        l.selected = false;
                    }
                }
            }
            _ => return Err(ErrorCode::OutOfRange),
        }
        Ok(())
    }

    /// Emit one DTO per ODT of every running list on `event` (see
    /// [`Slave::sample_daq`](crate::Slave::sample_daq)).
    pub fn sample(
        &mut self,
        event: u16,
        timestamp_us: u32,
        calibration_page: Page,
        memory: &impl Memory,
        emit: &mut impl FnMut(&[u8]),
    ) {
        // The prescalers first: a list samples on the event that brings its countdown to 0.
        let count = usize::from(self.list_count);
        let mut due = [false; MAX_DAQ_LISTS];
        for (l, d) in self.lists.iter_mut().take(count).zip(due.iter_mut()) {
            if l.running && l.event == event {
                *d = l.countdown == 0;
                l.countdown = if l.countdown == 0 {
                    l.prescaler.saturating_sub(1)
                } else {
                    l.countdown - 1
                };
            }
        }
        let mut pid = 0_u8;
        for (l, &due) in self.active_lists().zip(due.iter()) {
            let first_pid = pid;
            pid = pid.saturating_add(l.odt_count);
            if !due {
                continue;
            }
            for odt in 0..l.odt_count {
                let Ok(o) = self.odt_of(l, odt) else {
                    continue;
                };
                let mut frame = [0_u8; MAX_DTO];
                frame[0] = first_pid.saturating_add(odt);
                let mut len = 1;
                if odt == 0 && l.timestamp {
                    if let Some(ts) = frame.get_mut(1..=TIMESTAMP_BYTES) {
                        ts.copy_from_slice(&timestamp_us.to_le_bytes());
                    }
                    len += TIMESTAMP_BYTES;
                }
                for e in self.odt_entries(&o) {
                    let size = usize::from(e.size);
                    let end = len + size;
                    if let (Some(dst), Some((area, offset))) = (frame.get_mut(len..end), e.target) {
                        read_entry(memory, calibration_page, area, offset, dst);
                    }
                    len = end.min(MAX_DTO);
                }
                if let Some(dto) = frame.get(..len) {
                    emit(dto);
                }
            }
        }
    }
}

/// Read one entry; bytes that cannot be read stay zero.
fn read_entry(memory: &impl Memory, page: Page, area: Area, offset: u32, dst: &mut [u8]) {
    let Some(offset) = to_usize(offset) else {
        return;
    };
    match area {
        Area::Calibration => memory.read_calibration(page, offset, dst),
        Area::Measurement => memory.read_measurement(offset, dst),
    }
}
