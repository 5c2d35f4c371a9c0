//! # mil-xcp
//!
//! The slave side of ASAM MCD-1 XCP 1.x on CAN for the MiL board, transport-independent:
//! [`Slave::handle`] takes the bytes of a received command frame (CTO, up to 8 bytes) and
//! fills [`Responses`] with the frames to send back; [`Slave::sample_daq`] turns the running
//! DAQ lists of an event into DTO frames. Masters: the host tool (`mil param`, `mil daq`) and
//! Python's `pyxcp`.
//!
//! `no_std`, no heap, no `unsafe`, no panics on any input. The slave never touches memory: it
//! checks every address range and calls the application's [`Memory`] and [`Calibration`]
//! traits with offsets inside the configured regions; the application validates every
//! calibration change as a whole parameter set and applies it atomically, or refuses it.
//!
//! ## Fixed choices
//!
//! MAX_CTO = MAX_DTO = 8, Intel byte order, address granularity BYTE, address extension 0
//! only (anything else: `ERR_OUT_OF_RANGE`). Responses `0xFF`, errors `0xFE code`; DTOs carry
//! the absolute ODT number as PID (0x00..=0xFB). Requests may be padded (only the bytes a
//! command needs are read; a shorter request is `ERR_CMD_SYNTAX`); responses have their
//! natural length (the transport may pad them to DLC 8). While disconnected only CONNECT is
//! answered; nothing else gets a response.
//!
//! ## Commands
//!
//! | code | command | request → positive response | lock |
//! |---|---|---|---|
//! | FF | CONNECT | `FF 00` → `FF 05 C0 08 08 00 01 01` (CAL/PAG + DAQ, optional + slave block mode, MAX_CTO 8, MAX_DTO 8, versions 1/1) | — |
//! | FE | DISCONNECT | `FE` → `FF` | — |
//! | FD | GET_STATUS | `FD` → `FF status protection 00 00 00` (status bit 0: store pending, bit 6: DAQ running) | — |
//! | FC | SYNCH | `FC` → `FE 00` | — |
//! | FB | GET_COMM_MODE_INFO | `FB` → `FF 00 01 00 2A 00 00 01` (master block mode, MAX_BS 42, MIN_ST 0, queue 0, driver 0x01) | — |
//! | FA | GET_ID | `FA 01` → `FF 00 00 00 len(u32)`, MTA → the ID string (UPLOAD it) | — |
//! | F9 | SET_REQUEST | `F9 01 00 00` (STORE_CAL_REQ) → `FF`; GET_STATUS bit 0 then says pending until the store is done, which sends `FD 03` (EV_STORE_CAL) | CAL/PAG |
//! | F8 | GET_SEED | `F8 00 res` → `FF 06 seed(6)` (`FF 00` if `res` is unlocked) | — |
//! | F7 | UNLOCK | `F7 06 key(6)` → `FF protection` | — |
//! | F6 | SET_MTA | `F6 00 00 00 addr(u32)` → `FF` | — |
//! | F5 | UPLOAD | `F5 n` (1..=255) → ⌈n/7⌉ frames `FF data(≤7)`, MTA += n | — |
//! | F4 | SHORT_UPLOAD | `F4 n 00 00 addr(u32)` (n 1..=7) → `FF data(n)`, MTA = addr + n | — |
//! | F0 | DOWNLOAD | `F0 n data(min(n,6))` → `FF` (n ≤ 6) or nothing (block start, n ≤ 252), MTA += n | CAL/PAG |
//! | EF | DOWNLOAD_NEXT | `EF remaining data(≤6)` → nothing, `FF` after the last | CAL/PAG |
//! | EB | SET_CAL_PAGE | `EB mode 00 page` → `FF` (mode 0x01 ECU, 0x02 XCP, 0x80 all) | CAL/PAG |
//! | EA | GET_CAL_PAGE | `EA mode 00` → `FF 00 00 page` | — |
//! | E9 | GET_PAG_PROCESSOR_INFO | `E9` → `FF 01 00` | — |
//! | E8 | GET_SEGMENT_INFO | `E8 0 00 info 00` → `FF 00 00 00 value(u32)` (info 0 address, 1 length); `E8 1 00 ..` → `FF 02 00 00 00 00` | — |
//! | E7 | GET_PAGE_INFO | `E7 00 00 page` → `FF props 00` (page 0 `3F`, page 1 `0F`) | — |
//! | E4 | COPY_CAL_PAGE | `E4 00 1 00 0` → `FF` (reference → working) | CAL/PAG |
//! | E2 | SET_DAQ_PTR | `E2 00 list(u16) odt entry` → `FF` | DAQ |
//! | E1 | WRITE_DAQ | `E1 FF size 00 addr(u32)` → `FF` (size 1..=4) | DAQ |
//! | E0 | SET_DAQ_LIST_MODE | `E0 mode list(u16) event(u16) prescaler prio` → `FF` (mode 0x10 timestamp) | DAQ |
//! | DF | GET_DAQ_LIST_MODE | `DF 00 list(u16)` → `FF mode 00 00 event(u16) prescaler prio` | — |
//! | DE | START_STOP_DAQ_LIST | `DE mode list(u16)` → `FF first_pid` (0 stop, 1 start, 2 select) | DAQ |
//! | DD | START_STOP_SYNCH | `DD mode` → `FF` (0 stop all, 1 start selected, 2 stop selected) | DAQ |
//! | DC | GET_DAQ_CLOCK | `DC` → `FF 00 18 01 time(u32, µs)` | — |
//! | DA | GET_DAQ_PROCESSOR_INFO | `DA` → `FF 13 max_daq(u16) 01 00 00 00` (dynamic, prescaler, timestamps, absolute ODT numbers) | — |
//! | D9 | GET_DAQ_RESOLUTION_INFO | `D9` → `FF 01 04 01 00 34 01 00` (entries ≤ 4 bytes, 4-byte timestamp, 1 µs, 1 tick) | — |
//! | D7 | GET_DAQ_EVENT_INFO | `D7 00 00 00` → `FF 84 04 0C cycle unit 00`, MTA → "control step" | — |
//! | D6 | FREE_DAQ | `D6` → `FF` | DAQ |
//! | D5 | ALLOC_DAQ | `D5 00 count(u16)` → `FF` | DAQ |
//! | D4 | ALLOC_ODT | `D4 00 list(u16) count` → `FF` | DAQ |
//! | D3 | ALLOC_ODT_ENTRY | `D3 00 list(u16) odt count` → `FF` | DAQ |
//!
//! Every other command: `ERR_CMD_UNKNOWN`. Not implemented: SET_REQUEST modes other than
//! STORE_CAL_REQ (`ERR_OUT_OF_RANGE`), BUILD_CHECKSUM,
//! SHORT_DOWNLOAD, DOWNLOAD_MAX, MODIFY_BITS, segment modes (freeze), CLEAR_DAQ_LIST,
//! READ_DAQ, GET_DAQ_LIST_INFO, WRITE_DAQ_MULTIPLE (needs MAX_CTO ≥ 10), STIM, PGM, the
//! XCP 1.3+ time correlation and level-1 commands.
//!
//! Decisions where the standard leaves room or where masters need it:
//! - **GET_ID** answers mode 0 ("upload from the MTA"): pyxcp's `identifier()` reads mode
//!   bit 0 set as "inline in the response", which cannot fit a CAN frame after the 7 fixed
//!   bytes. The MTA then points at a virtual area (no address) that only UPLOAD reads;
//!   GET_DAQ_EVENT_INFO does the same for the event name (pyxcp uploads it right after).
//! - **CONNECT** while connected starts a fresh session (as after DISCONNECT + CONNECT): DAQ
//!   stopped and freed, resources locked, MTA 0. The page selections are kept.
//! - **DOWNLOAD in the middle of a block** answers `ERR_SEQUENCE` and writes nothing: pyxcp
//!   (`Master._block_downloader`) sends the last packet of a 7–11 byte block as DOWNLOAD
//!   instead of DOWNLOAD_NEXT, which would otherwise write 1–5 bytes at the block's start.
//!   Another command drops a pending block silently. A wrong DOWNLOAD_NEXT count answers
//!   `FE 29 expected` (the standard's negative response with the expected count).
//! - **WRITE_DAQ** takes sizes 1..=4 (granularity 1, MAX_ODT_ENTRY_SIZE 4: pyxcp merges
//!   adjacent variables into entries of any length up to that) and bit offset 0xFF only.
//! - **SET_DAQ_LIST_MODE** accepts any prescaler (0 and 1: every event; n: every n-th event,
//!   the first right after START) and any priority (pyxcp sends 0xFF);
//!   direction STIM, PID_OFF and other mode bits are `ERR_OUT_OF_RANGE`.
//! - Timestamps are selectable per list (not fixed); pyxcp then leaves the first ODT of a
//!   timestamped list without entries (4 bytes of payload room − 4 timestamp bytes), which
//!   this slave sends as `PID ts(4)`. Every ODT of a running list is sent, empty or not.
//! - The queries (GET_CAL_PAGE, GET_*_INFO, GET_DAQ_LIST_MODE, GET_DAQ_CLOCK) are not locked.
//!
//! ## Resource protection, seed & key
//!
//! CONNECT protects CAL/PAG (bit 0) and DAQ (bit 2); STIM and PGM are not offered.
//! Calibration writes, page switching and page copying need CAL/PAG unlocked, DAQ
//! configuration and start/stop need DAQ unlocked (`ERR_ACCESS_LOCKED` otherwise); reads
//! (UPLOAD, SHORT_UPLOAD) only need a connection.
//!
//! GET_SEED mode 0 for one resource returns a 6-byte seed (one frame): the first 6 bytes of
//! `SHA-256("mil-xcp seed" ‖ counter ‖ e1 ‖ e2)` from the slave's seed counter and two words
//! of [`Platform::seed_entropy`] (on the board: a free-running timer mixed with a counter).
//! UNLOCK takes a 6-byte key:
//!
//! ```text
//! key = HMAC-SHA256(secret, [resource] ‖ seed)[0..6]
//! ```
//!
//! (HMAC key = the secret; message = the resource byte as sent in GET_SEED, 0x01 or 0x04,
//! then the 6 seed bytes; key = the first 6 bytes of the tag; [`compute_key`]). Python:
//! `hmac.new(secret, bytes([resource]) + seed, hashlib.sha256).digest()[:6]`, usable as
//! pyxcp's `seed_n_key_function(resource, seed)`. One UNLOCK per seed; UNLOCK without a
//! preceding GET_SEED is `ERR_SEQUENCE`; a wrong key answers `ERR_ACCESS_LOCKED` and
//! disconnects. The secret is given at construction (on the board from a build-time
//! environment variable); none is in this repository except the mock's obviously fake one.
//!
//! ## Memory regions
//!
//! [`SlaveConfig`] names a calibration region (read and written) and a measurement region
//! (read and DAQ only); they must not overlap or wrap past `u32::MAX`. An access is allowed
//! only when all its bytes lie inside one permitted region (checked arithmetic, so
//! `address + length` overflowing `u32` is refused); otherwise `ERR_ACCESS_DENIED` and
//! nothing is read or written:
//!
//! | access | permitted |
//! |---|---|
//! | UPLOAD, SHORT_UPLOAD | calibration region (XCP access page), measurement region, the virtual GET_ID / event name areas |
//! | DOWNLOAD(_NEXT) | calibration region, working page only (XCP page = reference: `ERR_WRITE_PROTECTED`) |
//! | WRITE_DAQ | calibration region (sampled from the ECU page), measurement region |
//!
//! Application refusals ([`Rejected`]): `NotFinite` / `OutOfRange` answer `ERR_OUT_OF_RANGE`,
//! `Unstable` / `Inconsistent` answer `ERR_GENERIC`; the reason stays readable through
//! [`Slave::last_rejection`]. COPY_CAL_PAGE reference → working is one full-page change the
//! application validates; anything into the reference page is `ERR_WRITE_PROTECTED`. The ECU
//! and XCP access pages are kept separately; the ECU page changes only when
//! [`Calibration::select_ecu_page`] accepts it.
//!
//! ## DAQ
//!
//! Dynamic configuration in static storage: at most [`MAX_DAQ_LISTS`] lists,
//! [`MAX_ODTS`] ODTs and [`MAX_ODT_ENTRIES`] entries in total (`ERR_MEMORY_OVERFLOW` beyond),
//! 7 entries per ODT. Order FREE_DAQ → ALLOC_DAQ → ALLOC_ODT (once per list) →
//! ALLOC_ODT_ENTRY (once per ODT), anything else `ERR_SEQUENCE`; changes while DAQ runs are
//! `ERR_DAQ_ACTIVE`. One event channel (0, "control step", cyclic with
//! [`SlaveConfig::event_period_us`]). An ODT is one DTO: PID = FIRST_PID of its list +
//! relative ODT number (FIRST_PID = ODTs of all lower-numbered lists), then up to 7 data
//! bytes; the first ODT of a list with timestamps carries the 4-byte µs timestamp after the
//! PID (3 data bytes left). An ODT over its capacity, an unwritten entry or a list without
//! ODTs is `ERR_DAQ_CONFIG` at START_STOP.
//!
//! ## Tests
//!
//! `CARGO_TARGET_DIR=target/xcp cargo test -p mil-xcp`: byte-exact layouts of every command,
//! seed & key (with a key vector computed by Python's `hmac`), region checks at and across
//! the boundaries and with `u32` overflow (the mock's bytes compared before and after), block
//! downloads and sequence errors, page switching, a full DAQ session down to the DTO bytes,
//! and proptest fuzzing of random command sequences against [`mock::MockEcu`] (guards,
//! reference page and measurement region never change, responses ≤ 8 bytes starting with
//! 0xFF / 0xFE, silence while disconnected). The board build:
//! `cargo build -p mil-xcp --target thumbv7em-none-eabihf --release`.
#![cfg_attr(not(test), no_std)]
#![forbid(unsafe_code)]
#![deny(missing_docs)]
#![cfg_attr(
    not(test),
    deny(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing)
)]

mod access;
mod commands;
pub mod config;
pub mod daq;
pub mod key;
pub mod memory;
mod pages;
pub mod protocol;
pub mod response;
mod slave;
mod wire;

#[cfg(any(test, feature = "mock"))]
pub mod mock;

#[cfg(test)]
mod tests;

pub use config::{ConfigError, Region, SlaveConfig, MIN_SECRET_LEN};
pub use daq::{MAX_DAQ_LISTS, MAX_ODTS, MAX_ODT_ENTRIES};
pub use key::{compute_key, verify_key, KEY_LEN, SEED_LEN};
pub use memory::{Calibration, Memory, Page, Platform, Rejected, StoreRefused};
pub use protocol::{ErrorCode, MAX_CTO, MAX_DTO};
pub use response::Responses;
pub use slave::Slave;
