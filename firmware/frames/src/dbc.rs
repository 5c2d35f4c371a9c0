//! The frame layout as `mil.dbc` defines it, generated at build time by `build.rs` with the
//! `can-dbc` parser. The codec reads every bit position, length, signedness, factor, offset
//! and limit from here; the build fails if the DBC lacks a message or signal the codec expects
//! or describes one the codec cannot handle.
//!
//! IDs are offsets from the base ID ([`DEFAULT_BASE_ID`] is `Measurement_Ch0`'s ID in the
//! DBC); per-channel messages are at `base + id_offset + channel`.

/// The DBC file itself (for tools that want to write it out next to a log).
pub const DBC_TEXT: &str = include_str!("../mil.dbc");

/// What kind of value a signal holds (the codec's rules for each are in the crate docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SignalKind {
    /// Fixed-point physical quantity, `physical = raw · factor + offset`, with a
    /// "not available" raw pattern and physical limits `[min, max]`.
    Physical,
    /// A whole byte: counter, command number, index, result code or bit mask.
    Byte,
    /// An enumeration (the mode).
    Enum,
    /// One bit.
    Flag,
    /// An event count, saturating at the largest raw value.
    Count,
    /// An unsigned index of 8 to 16 bits (the command's parameter index).
    Index,
    /// IEEE-754 single precision.
    Float32,
}

/// One signal of a message, as the DBC defines it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SignalSpec {
    /// Signal name in the DBC.
    pub name: &'static str,
    /// What the codec does with it.
    pub kind: SignalKind,
    /// Position of the least significant bit (Intel byte order: bit `8·byte + bit`).
    pub start_bit: u8,
    /// Length, bits.
    pub len: u8,
    /// Two's complement signed.
    pub signed: bool,
    /// Scale factor, physical units per count (DBC factor).
    pub factor: f64,
    /// Offset, physical units (DBC offset).
    pub offset: f64,
    /// Smallest valid physical value (DBC minimum), physical units.
    pub min: f64,
    /// Largest valid physical value (DBC maximum), physical units.
    pub max: f64,
    /// Unit (DBC unit string; SI).
    pub unit: &'static str,
    /// Smallest valid raw value at the DBC's factor (physical signals: `min` rounded inwards,
    /// "not available" excluded; others: 0; floats: unused, 0).
    pub raw_min: i64,
    /// Largest valid raw value at the DBC's factor (physical signals: `max` rounded inwards,
    /// "not available" excluded; others: all ones; floats: unused, 0).
    pub raw_max: i64,
}

/// One message, as the DBC defines it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MessageSpec {
    /// Message name in the DBC (per-channel messages: without the `_Ch<n>` suffix).
    pub name: &'static str,
    /// One message per channel (`<name>_Ch0` .. `<name>_Ch7`, IDs `base + id_offset + ch`).
    pub per_channel: bool,
    /// ID offset from the base ID (channel 0 for per-channel messages).
    pub id_offset: u16,
    /// Data length, bytes.
    pub dlc: u8,
    /// Bits covered by signals (bit `8·byte + bit`); every other bit inside the DLC is
    /// reserved and must be 0.
    pub used_bits: u64,
}

include!(concat!(env!("OUT_DIR"), "/dbc_layout.rs"));
