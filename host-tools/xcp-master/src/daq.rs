//! A DAQ session: one dynamic DAQ list on one event with timestamps, its signals packed
//! into ODTs, and the DTOs decoded into timestamped samples of the named signals.
//!
//! Layout ([`DaqPlan`]): each signal stays whole inside one ODT (so one ODT never carries
//! half a value), split into ODT entries of at most MAX_ODT_ENTRY_SIZE bytes at consecutive
//! addresses; signals go, in the order given, into the first ODT with room. An ODT holds
//! MAX_DTO − 1 data bytes; the first ODT of the list carries the timestamp after the PID and
//! so has that many bytes less (with the board's 4-byte timestamp and 8-byte DTOs: 3 bytes,
//! no room for a 4-byte value, so it often carries the timestamp only).
//!
//! Session ([`Master::start_daq`]): FREE_DAQ, ALLOC_DAQ 1, ALLOC_ODT, ALLOC_ODT_ENTRY per
//! ODT with entries, SET_DAQ_PTR + WRITE_DAQ per entry, SET_DAQ_LIST_MODE (timestamps, event,
//! prescaler), START_STOP_DAQ_LIST select, START_STOP_SYNCH start selected. A cycle's ODTs
//! arrive in order; a sample is complete when its last ODT arrives, and an incomplete one
//! (a lost frame) is counted and dropped. [`DaqSession::stop`] (or dropping the session)
//! stops and frees the list.
//!
//! Prescaler: where the board applies one (DAQ_PROPERTIES bit 1) it is sent (the largest
//! factor of N up to 255, [`split_prescaler`]), so fewer DTOs load the bus; the session keeps
//! every n-th of the board's samples for the rest (all of N on a board without one).

use std::time::{Duration, Instant};

use mil_can::Transport;

use crate::a2l::Item;
use crate::error::{Error, Result};
use crate::master::{DaqProcessorInfo, DaqResolutionInfo, Master};

/// SET_DAQ_LIST_MODE bit: DTOs with timestamps.
const MODE_TIMESTAMP: u8 = 0x10;

/// What to record and how.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DaqOptions {
    /// Event channel (the board's 0 is its control step).
    pub event: u16,
    /// Keep every N-th sample (≥ 1).
    pub prescaler: u16,
    /// List priority.
    pub priority: u8,
}

impl Default for DaqOptions {
    fn default() -> Self {
        Self {
            event: 0,
            prescaler: 1,
            priority: 0,
        }
    }
}

/// One ODT entry: `size` bytes at `address`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Entry {
    /// Address.
    pub address: u32,
    /// Address extension.
    pub extension: u8,
    /// Bytes (≤ MAX_ODT_ENTRY_SIZE).
    pub size: u8,
}

/// `n` as (board, host) factors: the board takes the largest factor of `n` it can (≤ 255)
/// where it has a prescaler, the session keeps every host-th of its samples.
#[must_use]
pub fn split_prescaler(n: u16, board_has_prescaler: bool) -> (u8, u16) {
    let n = n.max(1);
    if !board_has_prescaler {
        return (1, n);
    }
    let board = (1..=n.min(255)).rev().find(|d| n % d == 0).unwrap_or(1);
    (board as u8, n / board)
}

/// A piece of a signal's bytes in one DTO.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Piece {
    /// ODT (relative to the list).
    pub odt: usize,
    /// Byte offset in the DTO (after the PID and, in ODT 0, the timestamp).
    pub offset: usize,
    /// Bytes.
    pub len: usize,
}

/// The list's layout: ODTs of entries and where each signal lands.
#[derive(Clone, Debug, PartialEq)]
pub struct DaqPlan {
    /// The ODTs' entries (ODT 0 may have none: it then carries the timestamp only).
    pub odts: Vec<Vec<Entry>>,
    /// Per signal (in the order given), where its bytes are, in order.
    pub placements: Vec<Vec<Piece>>,
    /// Timestamp bytes after the PID in ODT 0.
    pub timestamp_size: usize,
}

impl DaqPlan {
    /// Packs `signals` for DTOs of `max_dto` bytes, entries of at most `max_entry` bytes and
    /// a `timestamp_size`-byte timestamp in the first ODT. With `split` (the event samples
    /// all its ODTs consistently, DAQ_EVENT_PROPERTIES consistency "event") the signals fill
    /// the DTOs back to back and a value may continue in the next ODT; without it each
    /// signal stays whole in the first ODT with room.
    ///
    /// # Errors
    /// A signal larger than an ODT (without `split`), more ODTs than PIDs, or no signals.
    pub fn new(
        signals: &[&Item],
        max_dto: usize,
        max_entry: usize,
        timestamp_size: usize,
        split: bool,
    ) -> Result<Self> {
        if signals.is_empty() {
            return Err(Error::Unsupported("no signals to record".into()));
        }
        let data = max_dto.saturating_sub(1);
        let max_entry = max_entry.max(1);
        if data == 0 {
            return Err(Error::Unsupported(format!("DTOs of {max_dto} bytes")));
        }
        let mut odts: Vec<Vec<Entry>> = vec![Vec::new()];
        // Bytes taken in each ODT; the timestamp takes the first ODT's first bytes.
        let mut used: Vec<usize> = vec![timestamp_size];
        let mut placements = Vec::with_capacity(signals.len());
        for s in signals {
            let size = s.size();
            let mut pieces: Vec<Piece> = Vec::new();
            let mut place = |odts: &mut Vec<Vec<Entry>>,
                             used: &mut Vec<usize>,
                             odt: usize,
                             address: u32,
                             n: usize| {
                odts[odt].push(Entry {
                    address,
                    extension: s.extension,
                    size: n as u8,
                });
                match pieces.last_mut() {
                    Some(p) if p.odt == odt && p.offset + p.len == 1 + used[odt] => p.len += n,
                    _ => pieces.push(Piece {
                        odt,
                        offset: 1 + used[odt],
                        len: n,
                    }),
                }
                used[odt] += n;
            };
            if split {
                let mut left = size;
                let mut address = s.address;
                while left > 0 {
                    let mut odt = odts.len() - 1;
                    if used[odt] >= data {
                        odts.push(Vec::new());
                        used.push(0);
                        odt += 1;
                    }
                    let n = left.min(data - used[odt]).min(max_entry);
                    place(&mut odts, &mut used, odt, address, n);
                    address = address.wrapping_add(n as u32);
                    left -= n;
                }
            } else {
                if size > data {
                    return Err(Error::Unsupported(format!(
                        "{}: {size} bytes do not fit one DTO of {max_dto} bytes",
                        s.name
                    )));
                }
                let entries = size.div_ceil(max_entry);
                let odt = (0..odts.len())
                    .find(|&k| used[k] + size <= data && odts[k].len() + entries <= data)
                    .unwrap_or_else(|| {
                        odts.push(Vec::new());
                        used.push(0);
                        odts.len() - 1
                    });
                let mut left = size;
                let mut address = s.address;
                while left > 0 {
                    let n = left.min(max_entry);
                    place(&mut odts, &mut used, odt, address, n);
                    address = address.wrapping_add(n as u32);
                    left -= n;
                }
            }
            placements.push(pieces);
        }
        if odts.len() > 0xFC {
            return Err(Error::Unsupported(format!(
                "{} ODTs needed; a DAQ list has at most 252 PIDs",
                odts.len()
            )));
        }
        Ok(Self {
            odts,
            placements,
            timestamp_size,
        })
    }
}

/// One decoded sample.
#[derive(Clone, Debug, PartialEq)]
pub struct Sample {
    /// Time since the session's first sample (s), from the board's DTO timestamps (or the
    /// host clock when the board gives none).
    pub time_s: f64,
    /// Raw timestamp (ticks, unwrapped past the counter's wrap-around).
    pub ticks: u64,
    /// The signals' physical values, in the order given.
    pub values: Vec<f64>,
}

/// Counts of a session.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DaqStats {
    /// Samples returned.
    pub samples: u64,
    /// Cycles dropped because a DTO was missing.
    pub incomplete: u64,
    /// Complete cycles skipped by the host-side prescaler.
    pub decimated: u64,
    /// DTOs with a PID outside the list.
    pub foreign_pids: u64,
}

/// A running DAQ list (see the module documentation). Dropping it stops and frees the list
/// (best effort); [`DaqSession::stop`] does so and reports errors.
pub struct DaqSession<'m, T: Transport> {
    master: &'m mut Master<T>,
    event_cycle_s: Option<f64>,
    signals: Vec<Item>,
    plan: DaqPlan,
    first_pid: u8,
    seconds_per_tick: Option<f64>,
    board_prescaler: u8,
    host_prescaler: u16,
    // decoding state
    cycle: Vec<Option<Vec<u8>>>,
    cycle_ticks: Option<u32>,
    last_ticks: Option<u32>,
    wraps: u64,
    first_ticks: Option<u64>,
    host_start: Instant,
    host_time: f64,
    complete_cycles: u64,
    stats: DaqStats,
    running: bool,
}

impl<'m, T: Transport> std::fmt::Debug for DaqSession<'m, T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("DaqSession")
            .field("plan", &self.plan)
            .field("first_pid", &self.first_pid)
            .field("stats", &self.stats)
            .finish_non_exhaustive()
    }
}

impl<T: Transport> Master<T> {
    /// Configures and starts one DAQ list sampling `signals` (measurements or
    /// characteristics) on `options.event` with timestamps (see the module documentation).
    /// DAQ must be unlocked ([`Master::unlock`]).
    ///
    /// # Errors
    /// The board's DAQ cannot do it (static lists, another PID scheme, a signal too large),
    /// timeout, or a negative response (e.g. `ERR_MEMORY_OVERFLOW` for too many signals,
    /// `ERR_ACCESS_LOCKED` while DAQ is locked).
    pub fn start_daq(
        &mut self,
        signals: &[&Item],
        options: DaqOptions,
    ) -> Result<DaqSession<'_, T>> {
        let info = *self.session().ok_or(Error::NotConnected)?;
        let processor: DaqProcessorInfo = self.daq_processor_info()?;
        if !processor.dynamic() {
            return Err(Error::Unsupported(
                "the board's DAQ lists are static; this master configures dynamic lists".into(),
            ));
        }
        if !processor.absolute_odt_number() {
            return Err(Error::Unsupported(
                "the board identifies DTOs by list and ODT; this master reads absolute ODT numbers"
                    .into(),
            ));
        }
        let resolution: DaqResolutionInfo = self.daq_resolution_info()?;
        if resolution.granularity_odt_entry != 1 {
            return Err(Error::Unsupported(format!(
                "ODT entry granularity {} bytes; this master places single bytes",
                resolution.granularity_odt_entry
            )));
        }
        let timestamps = processor.timestamp_supported() && resolution.timestamp_size() > 0;
        let timestamp_size = if timestamps {
            resolution.timestamp_size()
        } else {
            0
        };
        if ![0, 1, 2, 4].contains(&timestamp_size) {
            return Err(Error::Unsupported(format!(
                "{timestamp_size}-byte timestamps"
            )));
        }
        // Values may continue in the next ODT where the board samples a list's (or the
        // event's) ODTs together; the event info is optional in the standard.
        let event = match self.daq_event_info(options.event) {
            Ok(e) => Some(e),
            Err(Error::Negative { code, .. }) if code.0 == 0x20 => None,
            Err(e) => return Err(e),
        };
        let split = event
            .as_ref()
            .is_some_and(|e| e.properties & 0xC0 == 0x40 || e.properties & 0xC0 == 0x80);
        let plan = DaqPlan::new(
            signals,
            usize::from(info.max_dto.min(8)),
            usize::from(resolution.max_odt_entry_size.max(1)),
            timestamp_size,
            split,
        )?;
        let prescaler = options.prescaler.max(1);
        let (board_prescaler, host_prescaler) =
            split_prescaler(prescaler, processor.prescaler_supported());

        self.free_daq()?;
        let mode = if timestamps { MODE_TIMESTAMP } else { 0 };
        let configured = self.configure_list(&plan, mode, options, board_prescaler);
        let first_pid = match configured {
            Ok(pid) => pid,
            Err(e) => {
                // Leave nothing half-configured (or running) on the board.
                let _ = self.start_stop_synch(0);
                let _ = self.free_daq();
                return Err(e);
            }
        };
        let odts = plan.odts.len();
        Ok(DaqSession {
            master: self,
            event_cycle_s: event.and_then(|e| e.cycle_s),
            signals: signals.iter().map(|s| (*s).clone()).collect(),
            plan,
            first_pid,
            seconds_per_tick: if timestamps {
                resolution.seconds_per_tick()
            } else {
                None
            },
            board_prescaler,
            host_prescaler,
            cycle: vec![None; odts],
            cycle_ticks: None,
            last_ticks: None,
            wraps: 0,
            first_ticks: None,
            host_start: Instant::now(),
            host_time: 0.0,
            complete_cycles: 0,
            stats: DaqStats::default(),
            running: true,
        })
    }
}

impl<T: Transport> Master<T> {
    /// ALLOC_DAQ … START_STOP_SYNCH for `plan` as list 0 (after FREE_DAQ); FIRST_PID.
    fn configure_list(
        &mut self,
        plan: &DaqPlan,
        mode: u8,
        options: DaqOptions,
        prescaler: u8,
    ) -> Result<u8> {
        self.alloc_daq(1)?;
        self.alloc_odt(0, plan.odts.len() as u8)?;
        for (k, odt) in plan.odts.iter().enumerate() {
            if !odt.is_empty() {
                self.alloc_odt_entry(0, k as u8, odt.len() as u8)?;
            }
        }
        for (k, odt) in plan.odts.iter().enumerate() {
            if odt.is_empty() {
                continue;
            }
            self.set_daq_ptr(0, k as u8, 0)?;
            for e in odt {
                self.write_daq(e.size, e.extension, e.address)?;
            }
        }
        self.set_daq_list_mode(mode, 0, options.event, prescaler, options.priority)?;
        let first_pid = self.start_stop_daq_list(2, 0)?;
        self.start_stop_synch(1)?;
        Ok(first_pid)
    }
}

impl<T: Transport> DaqSession<'_, T> {
    /// The list's layout.
    pub fn plan(&self) -> &DaqPlan {
        &self.plan
    }

    /// The signals, in sample order.
    pub fn signals(&self) -> &[Item] {
        &self.signals
    }

    /// The event's cycle (s) as the board reports it, when it is cyclic.
    pub fn event_cycle_s(&self) -> Option<f64> {
        self.event_cycle_s
    }

    /// The first PID of the list.
    pub fn first_pid(&self) -> u8 {
        self.first_pid
    }

    /// Whether the board applies the whole prescaler (else the session keeps every n-th of
    /// the board's samples, [`DaqSession::host_prescaler`]).
    pub fn prescaler_on_board(&self) -> bool {
        self.host_prescaler == 1
    }

    /// The prescaler the board applies (1: every event).
    pub fn board_prescaler(&self) -> u8 {
        self.board_prescaler
    }

    /// The part of the prescaler the session applies to the board's samples.
    pub fn host_prescaler(&self) -> u16 {
        self.host_prescaler
    }

    /// Whether the samples' times come from the board's timestamps.
    pub fn board_timestamps(&self) -> bool {
        self.seconds_per_tick.is_some()
    }

    /// The counts so far.
    pub fn stats(&self) -> DaqStats {
        self.stats
    }

    /// The next complete sample, waiting at most `timeout` for each DTO.
    ///
    /// # Errors
    /// [`Error::NoDaqData`] when no DTO came within `timeout`; the transport failed; an
    /// unsupported conversion of a signal.
    pub fn next_sample(&mut self, timeout: Duration) -> Result<Sample> {
        loop {
            let Some(dto) = self.master.next_dto(timeout)? else {
                return Err(Error::NoDaqData { timeout });
            };
            if let Some(sample) = self.accept(&dto)? {
                return Ok(sample);
            }
        }
    }

    /// Takes one DTO; a sample when it completes one.
    fn accept(&mut self, dto: &[u8]) -> Result<Option<Sample>> {
        let Some(&pid) = dto.first() else {
            return Ok(None);
        };
        let odts = self.plan.odts.len();
        let Some(k) = pid
            .checked_sub(self.first_pid)
            .map(usize::from)
            .filter(|&k| k < odts)
        else {
            self.stats.foreign_pids += 1;
            return Ok(None);
        };
        if k == 0 {
            if self.cycle.iter().any(Option::is_some) {
                self.stats.incomplete += 1;
            }
            self.cycle.iter_mut().for_each(|c| *c = None);
            let ts = self.plan.timestamp_size;
            self.cycle_ticks = if ts > 0 {
                let mut b = [0u8; 4];
                let Some(src) = dto.get(1..1 + ts) else {
                    self.stats.incomplete += 1;
                    return Ok(None);
                };
                b[..ts].copy_from_slice(src);
                // Timestamps are in the board's byte order.
                Some(match self.master.session().map(|s| s.byte_order) {
                    Some(crate::protocol::ByteOrder::Motorola) => {
                        b[..ts].reverse();
                        u32::from_le_bytes(b)
                    }
                    _ => u32::from_le_bytes(b),
                })
            } else {
                None
            };
            self.host_time = self.host_start.elapsed().as_secs_f64();
        } else if self.cycle[k - 1].is_none() {
            // The cycle's earlier ODTs are missing.
            if self.cycle.iter().any(Option::is_some) {
                self.stats.incomplete += 1;
                self.cycle.iter_mut().for_each(|c| *c = None);
            }
            return Ok(None);
        }
        self.cycle[k] = Some(dto.to_vec());
        if k + 1 < odts {
            return Ok(None);
        }
        // Complete.
        let frames: Vec<Vec<u8>> = self.cycle.iter_mut().filter_map(Option::take).collect();
        self.complete_cycles += 1;
        let ticks = self.unwrap_ticks();
        if (self.complete_cycles - 1) % u64::from(self.host_prescaler) != 0 {
            self.stats.decimated += 1;
            return Ok(None);
        }
        let mut values = Vec::with_capacity(self.signals.len());
        let mut bytes = Vec::with_capacity(8);
        for (s, pieces) in self.signals.iter().zip(&self.plan.placements) {
            bytes.clear();
            for p in pieces {
                let Some(b) = frames
                    .get(p.odt)
                    .and_then(|f| f.get(p.offset..p.offset + p.len))
                else {
                    // A DTO shorter than its ODT.
                    self.stats.incomplete += 1;
                    return Ok(None);
                };
                bytes.extend_from_slice(b);
            }
            values.push(s.decode(&bytes)?);
        }
        let time_s = match (self.seconds_per_tick, ticks) {
            (Some(spt), Some(t)) => {
                let t0 = *self.first_ticks.get_or_insert(t);
                (t - t0) as f64 * spt
            }
            _ => self.host_time,
        };
        self.stats.samples += 1;
        Ok(Some(Sample {
            time_s,
            ticks: ticks.unwrap_or(0),
            values,
        }))
    }

    /// The cycle's timestamp, unwrapped past the counter's wrap-around.
    fn unwrap_ticks(&mut self) -> Option<u64> {
        let t = self.cycle_ticks?;
        let bits = 8 * self.plan.timestamp_size as u32;
        if let Some(last) = self.last_ticks {
            if t < last {
                self.wraps += 1;
            }
        }
        self.last_ticks = Some(t);
        Some((self.wraps << bits) + u64::from(t))
    }

    /// Stops the list (START_STOP_SYNCH stop all) and frees it (FREE_DAQ).
    ///
    /// # Errors
    /// Timeout or a negative response.
    pub fn stop(mut self) -> Result<DaqStats> {
        self.running = false;
        self.master.start_stop_synch(0)?;
        self.master.free_daq()?;
        Ok(self.stats)
    }
}

impl<T: Transport> Drop for DaqSession<'_, T> {
    fn drop(&mut self) {
        if self.running {
            let _ = self.master.start_stop_synch(0);
            let _ = self.master.free_daq();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::a2l::{Conversion, DataType, Endian};

    fn item(name: &str, address: u32, datatype: DataType) -> Item {
        Item {
            name: name.into(),
            description: String::new(),
            address,
            extension: 0,
            datatype,
            endian: Endian::Little,
            conversion: Conversion::Identical,
            min: -1e9,
            max: 1e9,
            unit: String::new(),
        }
    }

    fn piece(odt: usize, offset: usize, len: usize) -> Piece {
        Piece { odt, offset, len }
    }

    #[test]
    fn the_board_takes_the_largest_prescaler_factor_it_can() {
        assert_eq!(split_prescaler(1, true), (1, 1));
        assert_eq!(split_prescaler(10, true), (10, 1));
        assert_eq!(split_prescaler(255, true), (255, 1));
        assert_eq!(split_prescaler(300, true), (150, 2));
        assert_eq!(split_prescaler(257, true), (1, 257));
        assert_eq!(split_prescaler(10, false), (1, 10));
        assert_eq!(split_prescaler(0, true), (1, 1));
    }

    #[test]
    fn whole_four_byte_signals_leave_the_timestamp_odt_alone() {
        let a = item("a", 0x100, DataType::F32);
        let b = item("b", 0x104, DataType::F32);
        let c = item("c", 0x108, DataType::U32);
        let plan = DaqPlan::new(&[&a, &b, &c], 8, 4, 4, false).unwrap();
        assert_eq!(plan.odts.len(), 4);
        assert!(plan.odts[0].is_empty());
        assert_eq!(plan.placements[0], vec![piece(1, 1, 4)]);
        assert_eq!(plan.placements[1], vec![piece(2, 1, 4)]);
        assert_eq!(plan.placements[2], vec![piece(3, 1, 4)]);
    }

    #[test]
    fn with_event_consistency_values_fill_the_dtos_back_to_back() {
        let a = item("a", 0x100, DataType::F32);
        let b = item("b", 0x200, DataType::F32);
        let c = item("c", 0x300, DataType::U32);
        let plan = DaqPlan::new(&[&a, &b, &c], 8, 4, 4, true).unwrap();
        // 4 timestamp bytes + 12 data bytes in three DTOs of 7 data bytes.
        assert_eq!(plan.odts.len(), 3);
        assert_eq!(plan.placements[0], vec![piece(0, 5, 3), piece(1, 1, 1)]);
        assert_eq!(plan.placements[1], vec![piece(1, 2, 4)]);
        assert_eq!(plan.placements[2], vec![piece(1, 6, 2), piece(2, 1, 2)]);
        assert_eq!(
            plan.odts[0],
            vec![Entry {
                address: 0x100,
                extension: 0,
                size: 3
            }]
        );
        assert_eq!(
            plan.odts[1],
            vec![
                Entry {
                    address: 0x103,
                    extension: 0,
                    size: 1
                },
                Entry {
                    address: 0x200,
                    extension: 0,
                    size: 4
                },
                Entry {
                    address: 0x300,
                    extension: 0,
                    size: 2
                }
            ]
        );
        assert_eq!(
            plan.odts[2],
            vec![Entry {
                address: 0x302,
                extension: 0,
                size: 2
            }]
        );
    }

    #[test]
    fn small_signals_fill_the_timestamp_odt_and_large_ones_split_into_entries() {
        let small = item("s", 0x10, DataType::U16);
        let tiny = item("t", 0x20, DataType::U8);
        let big = item("d", 0x30, DataType::U32);
        let plan = DaqPlan::new(&[&big, &small, &tiny], 8, 2, 4, false).unwrap();
        assert_eq!(plan.placements[1], vec![piece(0, 5, 2)]);
        assert_eq!(plan.placements[2], vec![piece(0, 7, 1)]);
        // The word goes to ODT 1 as two 2-byte entries at consecutive addresses.
        assert_eq!(plan.placements[0], vec![piece(1, 1, 4)]);
        assert_eq!(
            plan.odts[1],
            vec![
                Entry {
                    address: 0x30,
                    extension: 0,
                    size: 2
                },
                Entry {
                    address: 0x32,
                    extension: 0,
                    size: 2
                }
            ]
        );
        let double = item("x", 0x40, DataType::F64);
        assert!(DaqPlan::new(&[&double], 8, 4, 0, false).is_err());
        // Split, it spans two DTOs.
        let plan = DaqPlan::new(&[&double], 8, 4, 0, true).unwrap();
        assert_eq!(plan.placements[0], vec![piece(0, 1, 7), piece(1, 1, 1)]);
        assert!(DaqPlan::new(&[], 8, 4, 4, false).is_err());
    }
}
