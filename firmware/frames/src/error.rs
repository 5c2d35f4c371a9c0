//! Errors with stable numeric codes.
//!
//! Every error type has `code() -> u8`; codes are unique across the crate and never reused, so
//! one byte (a counter index, the `Result` of a [`CommandAck`](crate::CommandAck), a log
//! field) identifies the error. Ranges: decode 1–31, encode 32–47, layout 48–63, SLCAN 64–95;
//! 0 means "ok" in a command acknowledgement; 128–255 are left to the firmware's own results.

/// Why a received frame was not decoded. Every input from the bus is untrusted: decoding never
/// panics and returns one of these instead.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum DecodeError {
    /// Standard ID outside the MiL range `base .. base + ID_RANGE`: not ours; ignore and count.
    Foreign = 1,
    /// Extended (29-bit) ID: never used by MiL; ignore and count with the foreign frames
    /// ([`DecodeError::is_foreign`]).
    ExtendedId = 2,
    /// Remote (RTR) frame with an ID in the MiL range: MiL frames are never requested.
    RemoteFrame = 3,
    /// ID in the MiL range that no message uses.
    UnknownId = 4,
    /// Data length differs from the message's DLC (or exceeds 8).
    WrongLength = 5,
    /// A reserved bit (inside the DLC, covered by no signal) is set, or a command that takes
    /// no index has a non-zero index.
    ReservedNotZero = 6,
    /// A physical signal holds its "not available" raw value (signed: the most negative value,
    /// e.g. 0x800000 for 24 bits; unsigned: all ones).
    NotAvailable = 7,
    /// A physical signal beyond its DBC limits (e.g. a position beyond ±1 m).
    OutOfRange = 8,
    /// A mode value other than 0 (idle), 1 (running), 2 (fault).
    InvalidMode = 9,
    /// A command number that is not a [`CommandKind`](crate::CommandKind).
    UnknownCommand = 10,
    /// A float value (the command's `Value`) that is NaN or infinite.
    NotFinite = 11,
}

impl DecodeError {
    /// Every variant, in code order.
    pub const ALL: [DecodeError; 11] = [
        DecodeError::Foreign,
        DecodeError::ExtendedId,
        DecodeError::RemoteFrame,
        DecodeError::UnknownId,
        DecodeError::WrongLength,
        DecodeError::ReservedNotZero,
        DecodeError::NotAvailable,
        DecodeError::OutOfRange,
        DecodeError::InvalidMode,
        DecodeError::UnknownCommand,
        DecodeError::NotFinite,
    ];

    /// Stable numeric code (1–31).
    pub const fn code(self) -> u8 {
        self as u8
    }

    /// The variant with this code, if any.
    pub fn from_code(code: u8) -> Option<Self> {
        Self::ALL.iter().copied().find(|e| e.code() == code)
    }

    /// Name of the variant (as in the DBC's `Result` value table).
    pub const fn name(self) -> &'static str {
        match self {
            DecodeError::Foreign => "Foreign",
            DecodeError::ExtendedId => "ExtendedId",
            DecodeError::RemoteFrame => "RemoteFrame",
            DecodeError::UnknownId => "UnknownId",
            DecodeError::WrongLength => "WrongLength",
            DecodeError::ReservedNotZero => "ReservedNotZero",
            DecodeError::NotAvailable => "NotAvailable",
            DecodeError::OutOfRange => "OutOfRange",
            DecodeError::InvalidMode => "InvalidMode",
            DecodeError::UnknownCommand => "UnknownCommand",
            DecodeError::NotFinite => "NotFinite",
        }
    }

    /// The frame is not addressed to MiL at all ([`Foreign`](Self::Foreign) or
    /// [`ExtendedId`](Self::ExtendedId)): the firmware ignores it and counts it as foreign,
    /// not as malformed.
    pub const fn is_foreign(self) -> bool {
        matches!(self, DecodeError::Foreign | DecodeError::ExtendedId)
    }
}

/// Why a message was not encoded.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum EncodeError {
    /// Channel number not below [`CHANNELS`](crate::dbc::CHANNELS).
    BadChannel = 32,
    /// A NaN or infinite value (a demand or command value is never sent non-finite).
    NotFinite = 33,
    /// A physical value beyond its DBC limits or the raw range (measurements only; the
    /// demand saturates instead).
    OutOfRange = 34,
}

impl EncodeError {
    /// Every variant, in code order.
    pub const ALL: [EncodeError; 3] = [
        EncodeError::BadChannel,
        EncodeError::NotFinite,
        EncodeError::OutOfRange,
    ];

    /// Stable numeric code (32–47).
    pub const fn code(self) -> u8 {
        self as u8
    }
}

/// Why a [`Layout`](crate::Layout) was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum LayoutError {
    /// Base ID + highest offset does not fit 11 bits (0x7FF).
    BaseIdTooHigh = 48,
    /// A scale factor that is not finite and positive, or leaves no valid raw value.
    BadFactor = 49,
}

impl LayoutError {
    /// Every variant, in code order.
    pub const ALL: [LayoutError; 2] = [LayoutError::BaseIdTooHigh, LayoutError::BadFactor];

    /// Stable numeric code (48–63).
    pub const fn code(self) -> u8 {
        self as u8
    }
}

/// Why an SLCAN line was not parsed or formatted.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum SlcanError {
    /// First character is no SLCAN command this crate knows.
    UnknownCommand = 64,
    /// A known but unsupported command: CAN FD frames (`d`, `D`, `b`, `B`), FD data bitrate
    /// (`Y`), acceptance filters (`M`, `m`), polling (`P`, `A`), auto-poll (`X`), auto-start
    /// (`Q`), UART rate (`U`).
    Unsupported = 65,
    /// The line ends inside the ID or before the DLC.
    Truncated = 66,
    /// A character that should be a hexadecimal digit is not.
    BadHex = 67,
    /// An ID beyond 0x7FF (standard) or 0x1FFF_FFFF (extended).
    BadId = 68,
    /// DLC character not `0`..`8`, a bitrate digit (`S`) not `0`..`9`, a time-stamp digit
    /// (`Z`) not `0` or `1`.
    BadDlc = 69,
    /// Number of data hex digits differs from twice the DLC (or an RTR frame carries data).
    DlcMismatch = 70,
    /// Characters after a complete command (e.g. `O1`).
    TrailingData = 71,
    /// Line too long: longer than [`MAX_LINE`](crate::slcan::MAX_LINE) for
    /// [`parse_line`](crate::slcan::parse_line), or than the
    /// [`LineBuffer`](crate::slcan::LineBuffer), which then discards it up to the next `\r`.
    Overflow = 72,
    /// Output buffer too small for the formatted line.
    BufferTooSmall = 73,
}

impl SlcanError {
    /// Every variant, in code order.
    pub const ALL: [SlcanError; 10] = [
        SlcanError::UnknownCommand,
        SlcanError::Unsupported,
        SlcanError::Truncated,
        SlcanError::BadHex,
        SlcanError::BadId,
        SlcanError::BadDlc,
        SlcanError::DlcMismatch,
        SlcanError::TrailingData,
        SlcanError::Overflow,
        SlcanError::BufferTooSmall,
    ];

    /// Stable numeric code (64–95).
    pub const fn code(self) -> u8 {
        self as u8
    }
}

impl core::fmt::Display for DecodeError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(
            f,
            "frame not decoded: {} (code {})",
            self.name(),
            self.code()
        )
    }
}

impl core::fmt::Display for EncodeError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "message not encoded: {self:?} (code {})", self.code())
    }
}

impl core::fmt::Display for LayoutError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "layout refused: {self:?} (code {})", self.code())
    }
}

impl core::fmt::Display for SlcanError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "SLCAN: {self:?} (code {})", self.code())
    }
}

impl core::error::Error for DecodeError {}
impl core::error::Error for EncodeError {}
impl core::error::Error for LayoutError {}
impl core::error::Error for SlcanError {}
