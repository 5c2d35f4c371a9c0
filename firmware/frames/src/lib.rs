//! # mil-frames
//!
//! The CAN frames between the rig's servo controller, the MiL board and host tools: the single
//! source of truth is `mil.dbc` in this crate's folder. `build.rs` parses it with `can-dbc`
//! and generates the layout table ([`dbc`]) the codec uses, so a factor, a bit position or a
//! DLC changed in the DBC changes the codec; the build fails, naming the object, when the DBC
//! lacks or adds a message or signal, or describes one the codec cannot handle.
//!
//! `no_std`, no heap, no `unsafe`, no panics on any input: every frame from the bus is
//! untrusted and decoding returns a typed error with a stable code.
//!
//! ## Frames
//!
//! Classic CAN, standard 11-bit IDs, Intel (little-endian) signals. IDs are offsets from a
//! configurable base ID ([`Layout`], default 0x100); offsets `0x00..0x30` above the base are
//! the MiL range. Per-channel frames exist for channels 0..7 (`ch`).
//!
//! | frame | ID | DLC | direction | signals (factor, limits) |
//! |---|---|---|---|---|
//! | [`Measurement`] | base + 0x00 + ch | 7 | servo → board, every sample | `Position` i24 (1e-6 m, ±1 m), `Road` i24 (1e-6 m, ±1 m), `Counter` u8 |
//! | [`MeasurementAux`] | base + 0x08 + ch | 6 | servo → board, where needed | `Force` i32 (0.1 N, ±400 kN), `Speed` u16 (0.01 m/s, 0..150 m/s) |
//! | [`Demand`] | base + 0x10 + ch | 6 | board → servo, one per measurement | `Demand` i32 (0.1 N, ±400 kN, saturating), `Counter` u8 (echo), `Mode` 2 bits, `FaultLatched`, `AmplitudeLimited`, `RateLimited` 1 bit each |
//! | [`Status`] | base + 0x20 | 8 | board → bus, 10 Hz | `Mode` u4, `CalibrationSource` u4, `FaultCauses` u8, `MissedSamples`, `LateSamples`, `MalformedFrames` u16 (saturating) |
//! | [`Command`] | base + 0x21 | 8 | tool → board | `Command` u8 (1 start, 2 stop, 3 clear fault, 4 set parameter, 5 set watchdog), `Index` u16 (bytes 1–2: every slot of the board's page; byte 2 was reserved before, so an 8-bit index means the same), byte 3 reserved (0), `Value` f32 |
//! | [`CommandAck`] | base + 0x22 | 4 | board → tool | `Command` u8 (echo), `Index` u8 (echo of the index's low byte), `Result` u8 (0 ok, else an error code), `Mode` u8 |
//!
//! Free IDs inside the range (base + 0x18..0x20, 0x23..0x30) are [`DecodeError::UnknownId`];
//! IDs outside it are [`DecodeError::Foreign`] (ignore and count).
//!
//! Decisions:
//! - **Not available**: a physical signal's most negative raw value (signed; 0x800000 for
//!   24 bits) or all ones (unsigned; 0xFFFF for the speed) means "not available / invalid"
//!   (J1939 style) and decodes to [`DecodeError::NotAvailable`]; encoders never produce it.
//! - **Limits from the DBC**: a physical value beyond the DBC's `[min, max]` decodes to
//!   [`DecodeError::OutOfRange`] (the models refuse positions beyond 1 m). Measurement
//!   encoders refuse such values ([`EncodeError::OutOfRange`]); the demand encoder saturates.
//!   Force and demand are limited to ±400 kN so every valid raw value is below 2^22 counts:
//!   f32 holds it exactly and decode → encode gives back the same bytes.
//! - **Reserved bits** (inside the DLC, covered by no signal) must be 0
//!   ([`DecodeError::ReservedNotZero`]); so must the index of a command other than set
//!   parameter.
//! - **Strict length**: the data length must equal the DBC's DLC.
//! - **Modes** 0 idle, 1 running, 2 fault (`model_core::Mode`'s values); other values are
//!   [`DecodeError::InvalidMode`].
//! - The command value is IEEE-754 single precision (`SIG_VALTYPE_ ... : 1`); NaN and
//!   infinities decode to [`DecodeError::NotFinite`] and cannot be encoded.
//! - The board answers a command frame that fails to decode with
//!   [`CommandAck::rejecting`]: the raw command and index echoed, the error code as result.
//!
//! ## Accuracy
//!
//! Values are f32 in SI units. Encoding rounds to the nearest count (ties away from zero), so
//! `|decode(encode(x)) − x| ≤ factor/2 + 2^-23·|x|` (half a count plus the f32 rounding of the
//! two operations, below 1.2e-7 m at 1 m); tested by proptest, and against `cantools`
//! (Python) decoding our frames and encoding frames we decode. Decode → encode reproduces
//! the frame's bytes exactly at the DBC's factors.
//!
//! ## Bus load
//!
//! Worst-case frame length with bit stuffing, `47 + 8n + ⌊(33 + 8n)/4⌋` bits ([`bus_load`]).
//! A channel costs a Measurement (125 bits) and a Demand (115 bits) per sample; the 10 Hz
//! heartbeat 1350 bit/s. At 1 Mbit/s with a 60 % budget ([`bus_load::BUDGET`]):
//!
//! | schedule | worst-case load | highest sample rate within 60 % |
//! |---|---|---|
//! | tyre ×1 at 2 kHz | 48.1 % (nominal 39.7 %) | 2494 Hz |
//! | tyre ×2 | — | 1247 Hz |
//! | tyre ×4 | 192 % at 2 kHz | 624 Hz |
//! | aero ×2 (speed on one channel) | — | 1006 Hz |
//!
//! So one classic CAN bus at 1 Mbit/s carries one or two channels at 1–2 kHz, not the full
//! car's four channels at 2 kHz. Printed by `cargo run -p mil-frames --example bus_load` and
//! asserted in the unit tests of [`bus_load`].
//!
//! ## Error codes
//!
//! Stable, unique across the crate (`code()` on every error type; 0 is "ok" in a
//! [`CommandAck`]; 128–255 are the firmware's):
//!
//! | code | error | meaning |
//! |---|---|---|
//! | 1 | [`DecodeError::Foreign`] | standard ID outside the MiL range (ignore, count) |
//! | 2 | [`DecodeError::ExtendedId`] | extended ID (ignore, count as foreign) |
//! | 3 | [`DecodeError::RemoteFrame`] | RTR frame in the MiL range |
//! | 4 | [`DecodeError::UnknownId`] | free ID in the MiL range |
//! | 5 | [`DecodeError::WrongLength`] | data length ≠ DLC |
//! | 6 | [`DecodeError::ReservedNotZero`] | reserved bit set / index on a command without one |
//! | 7 | [`DecodeError::NotAvailable`] | "not available" raw value |
//! | 8 | [`DecodeError::OutOfRange`] | beyond the DBC limits |
//! | 9 | [`DecodeError::InvalidMode`] | mode not 0, 1, 2 |
//! | 10 | [`DecodeError::UnknownCommand`] | command number not 1..=5 |
//! | 11 | [`DecodeError::NotFinite`] | NaN or infinite command value |
//! | 32 | [`EncodeError::BadChannel`] | channel ≥ 8 |
//! | 33 | [`EncodeError::NotFinite`] | NaN or infinite value |
//! | 34 | [`EncodeError::OutOfRange`] | measurement beyond its limits; index on a command without one |
//! | 48 | [`LayoutError::BaseIdTooHigh`] | base + 0x22 > 0x7FF |
//! | 49 | [`LayoutError::BadFactor`] | factor not finite and > 0 |
//! | 64 | [`SlcanError::UnknownCommand`] | unknown first character |
//! | 65 | [`SlcanError::Unsupported`] | CAN FD and other unsupported commands |
//! | 66 | [`SlcanError::Truncated`] | line ends inside ID or before DLC |
//! | 67 | [`SlcanError::BadHex`] | not a hex digit |
//! | 68 | [`SlcanError::BadId`] | ID beyond 11 / 29 bits |
//! | 69 | [`SlcanError::BadDlc`] | DLC not 0..8, bad `S`/`Z` digit |
//! | 70 | [`SlcanError::DlcMismatch`] | data digits ≠ 2·DLC |
//! | 71 | [`SlcanError::TrailingData`] | characters after a command |
//! | 72 | [`SlcanError::Overflow`] | line too long |
//! | 73 | [`SlcanError::BufferTooSmall`] | output buffer too small |
//!
//! ## SLCAN
//!
//! [`slcan`] parses and formats Lawicel ASCII lines and assembles them from a byte stream;
//! its module docs say exactly what python-can 4.6's `slcan` interface sends on open
//! (`C`, `S8`, an empty line, `O`, `O` for 1 Mbit/s), that it ignores the `\r` / BEL replies,
//! and what it expects from `V` and `N`. Tested against python-can itself.
//!
//! ## Python peers
//!
//! The interoperability tests run `cantools` and `python-can` from a virtual environment:
//! the interpreter in `MIL_PY`, else `<workspace>/target/py-peers/bin/python`, created by
//! `firmware/frames/tests/peer/setup-venv.sh` (pinned in `requirements.txt`). Without it those
//! tests fail and say so.
#![no_std]
#![forbid(unsafe_code)]
#![deny(missing_docs)]
#![cfg_attr(
    not(test),
    deny(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing)
)]

pub mod bus_load;
mod codec;
pub mod dbc;
mod error;
mod layout;
mod limits;
pub mod slcan;

pub use codec::{
    decode, decode_frame, encode, encode_command, encode_command_ack, encode_demand,
    encode_measurement, encode_measurement_aux, encode_status, Command, CommandAck, CommandKind,
    Demand, DemandFlags, Measurement, MeasurementAux, Message, Mode, RawFrame, Status,
};
pub use embedded_can;
pub use error::{DecodeError, EncodeError, LayoutError, SlcanError};
pub use layout::{Layout, MessageKind, Scales};

#[cfg(test)]
mod tests;
