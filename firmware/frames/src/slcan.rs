//! SLCAN (Lawicel CAN232/CANUSB ASCII protocol) lines, `no_std`.
//!
//! A line is ASCII terminated by `\r`. [`LineBuffer`] assembles lines from a byte stream,
//! [`parse_line`] turns one line (without its `\r`) into a [`SlcanLine`], [`format_frame`]
//! writes a frame as `tIIILDD..\r`. Replies: [`OK`] (`\r`) and [`ERROR`] (BEL, `\x07`).
//!
//! # What python-can 4.6 sends and expects
//!
//! (`can/interfaces/slcan.py`, `slcanBus`; checked against python-can 4.6.1.)
//!
//! - Opening, after sleeping `sleep_after_open` (default 2 s; pass 0 for a board that is
//!   ready): with `bitrate=1_000_000` it writes `C\r`, `S8\r`, `\r` (the empty CAN FD
//!   data-bitrate code), `O\r`, then `O\r` again (`set_bitrate` closes, sets, opens, and the
//!   constructor opens once more). Without `bitrate`: only `O\r`. With `listen_only=True`,
//!   `L\r` instead of `O\r`; with a `timing` (BTR registers) `C\r`, `sXXYY\r`, `O\r`.
//!   Bitrate codes: `S0` 10k, `S1` 20k, `S2` 50k, `S3` 100k, `S4` 125k, `S5` 250k, `S6` 500k,
//!   `S7` 750k, `S8` 1M, `S9` 83.3k (python-can's table).
//! - It never waits for or checks the replies to these commands: a device may answer `\r` or
//!   BEL; both are read and dropped. A board must therefore accept `O` while already open and
//!   an empty line. Bytes sent before the device listens are lost, so a board that starts
//!   late may miss the handshake: treat the bus as open from the first frame on, or have the
//!   host repeat its handshake.
//! - Sending: `tIIIL` + data as upper-case hex + `\r` (standard), `TIIIIIIIIL...` (extended),
//!   `rIIIL` / `RIIIIIIIIL` (remote). DLC is one decimal digit.
//! - Receiving: it reads byte by byte and cuts at `\r` or BEL; a line starting with `t`, `T`,
//!   `x`, `r`, `R` (or the FD letters `d`, `D`, `b`, `B`) is a frame, anything else (the bare
//!   `\r` of an OK, BEL) is dropped silently. It reads the DLC as one decimal digit and takes
//!   exactly `2·DLC` hex digits; trailing characters (a timestamp) are ignored.
//! - `get_version()` writes `V\r` and expects `V` + hardware version (2 decimal digits) +
//!   software version (2 decimal digits) + `\r` ([`format_version`]); `get_serial_number()`
//!   writes `N\r` and expects `N` + serial + `\r` ([`format_serial_number`]). Lines that
//!   arrive meanwhile are queued, not lost.
//! - `shutdown()` writes `C\r`.
//!
//! python-can never sends `F`, `v`, `Z0`/`Z1`; they are parsed for other tools (Lawicel
//! status flags, firmware version, time stamps). This parser refuses time-stamped frames
//! (extra digits after the data are [`SlcanError::DlcMismatch`]): hosts do not send them.

use embedded_can::{ExtendedId, Frame, Id, StandardId};

use crate::codec::RawFrame;
use crate::error::SlcanError;

/// The OK reply.
pub const OK: &[u8] = b"\r";
/// The error reply (BEL).
pub const ERROR: &[u8] = b"\x07";
/// Longest valid line without its `\r`: `T` + 8 ID digits + DLC + 16 data digits.
pub const MAX_LINE: usize = 26;

/// Lawicel status-flag bits (reply to `F`, see [`format_status_flags`]).
pub mod status_flag {
    /// Receive FIFO full.
    pub const RX_FIFO_FULL: u8 = 1 << 0;
    /// Transmit FIFO full.
    pub const TX_FIFO_FULL: u8 = 1 << 1;
    /// Error warning (EI).
    pub const ERROR_WARNING: u8 = 1 << 2;
    /// Data overrun (DOI).
    pub const DATA_OVERRUN: u8 = 1 << 3;
    /// Error passive (EPI).
    pub const ERROR_PASSIVE: u8 = 1 << 5;
    /// Arbitration lost (ALI).
    pub const ARBITRATION_LOST: u8 = 1 << 6;
    /// Bus error (BEI).
    pub const BUS_ERROR: u8 = 1 << 7;
}

/// A CAN frame from an SLCAN line: standard or extended, data or remote.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SlcanFrame {
    /// Identifier.
    pub id: Id,
    /// Remote (RTR) frame: `len` is the requested DLC, `data` is zero.
    pub remote: bool,
    /// DLC (0..=8).
    pub len: u8,
    /// Data (the first `len` bytes of a data frame).
    pub data: [u8; 8],
}

impl Frame for SlcanFrame {
    fn new(id: impl Into<Id>, data: &[u8]) -> Option<Self> {
        let raw = RawFrame::from_parts(0, data)?;
        Some(SlcanFrame {
            id: id.into(),
            remote: false,
            len: raw.len,
            data: raw.data,
        })
    }

    fn new_remote(id: impl Into<Id>, dlc: usize) -> Option<Self> {
        let len = u8::try_from(dlc).ok().filter(|l| *l <= 8)?;
        Some(SlcanFrame {
            id: id.into(),
            remote: true,
            len,
            data: [0; 8],
        })
    }

    fn is_extended(&self) -> bool {
        matches!(self.id, Id::Extended(_))
    }

    fn is_remote_frame(&self) -> bool {
        self.remote
    }

    fn id(&self) -> Id {
        self.id
    }

    fn dlc(&self) -> usize {
        usize::from(self.len.min(8))
    }

    /// The data of a data frame; empty for a remote frame.
    fn data(&self) -> &[u8] {
        if self.remote {
            &[]
        } else {
            self.data.get(..self.dlc()).unwrap_or(&[])
        }
    }
}

impl From<RawFrame> for SlcanFrame {
    /// A standard data frame (an `id` beyond 0x7FF reads as 0x7FF, `len` beyond 8 as 8).
    fn from(f: RawFrame) -> Self {
        SlcanFrame {
            id: Id::Standard(StandardId::new(f.id).unwrap_or(StandardId::MAX)),
            remote: false,
            len: f.len.min(8),
            data: f.data,
        }
    }
}

/// One parsed SLCAN line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SlcanLine {
    /// An empty line (python-can sends one as the empty FD data-bitrate code): answer OK.
    Empty,
    /// `t`, `T`, `r`, `R`: a frame to transmit.
    Frame(SlcanFrame),
    /// `O`: open the channel.
    Open,
    /// `L`: open the channel listen-only.
    ListenOnly,
    /// `C`: close the channel.
    Close,
    /// `S0`..`S9`: set the bitrate.
    SetBitrate {
        /// The digit after `S`.
        code: u8,
        /// Bitrate, bit/s (python-can's table: `S9` is 83.3 kbit/s).
        bit_per_s: u32,
    },
    /// `sXXYY`: set the SJA1000 bit-timing registers.
    SetBtr {
        /// BTR0.
        btr0: u8,
        /// BTR1.
        btr1: u8,
    },
    /// `V`: hardware and software version (answer with [`format_version`]).
    Version,
    /// `v`: firmware version (some adapters).
    FirmwareVersion,
    /// `N`: serial number (answer with [`format_serial_number`]).
    SerialNumber,
    /// `F`: status flags (answer with [`format_status_flags`]).
    StatusFlags,
    /// `Z0` / `Z1`: time stamps off / on.
    Timestamps(bool),
}

/// Bitrate of an `S` code, bit/s (python-can's table).
pub const fn bitrate_of_code(code: u8) -> Option<u32> {
    Some(match code {
        0 => 10_000,
        1 => 20_000,
        2 => 50_000,
        3 => 100_000,
        4 => 125_000,
        5 => 250_000,
        6 => 500_000,
        7 => 750_000,
        8 => 1_000_000,
        9 => 83_300,
        _ => return None,
    })
}

const fn hex_val(c: u8) -> Option<u8> {
    match c {
        b'0'..=b'9' => Some(c - b'0'),
        b'A'..=b'F' => Some(c - b'A' + 10),
        b'a'..=b'f' => Some(c - b'a' + 10),
        _ => None,
    }
}

/// Hex digits as a number (at most 8 digits).
fn hex_number(digits: &[u8]) -> Result<u32, SlcanError> {
    digits.iter().try_fold(0_u32, |acc, c| {
        hex_val(*c)
            .map(|v| (acc << 4) | u32::from(v))
            .ok_or(SlcanError::BadHex)
    })
}

/// Frame line: `t`/`r` with 3 ID digits or `T`/`R` with 8; then DLC and data.
fn parse_frame(line: &[u8], extended: bool, remote: bool) -> Result<SlcanLine, SlcanError> {
    let id_digits = if extended { 8 } else { 3 };
    let rest = line.get(1..).unwrap_or(&[]);
    let (id_hex, rest) = rest
        .split_at_checked(id_digits)
        .ok_or(SlcanError::Truncated)?;
    let raw_id = hex_number(id_hex)?;
    let id = if extended {
        Id::Extended(ExtendedId::new(raw_id).ok_or(SlcanError::BadId)?)
    } else {
        let raw = u16::try_from(raw_id).map_err(|_| SlcanError::BadId)?;
        Id::Standard(StandardId::new(raw).ok_or(SlcanError::BadId)?)
    };
    let (&dlc_char, data_hex) = rest.split_first().ok_or(SlcanError::Truncated)?;
    let len = match dlc_char {
        b'0'..=b'8' => dlc_char - b'0',
        _ => return Err(SlcanError::BadDlc),
    };
    let mut data = [0_u8; 8];
    if remote {
        if !data_hex.is_empty() {
            return Err(SlcanError::DlcMismatch);
        }
    } else {
        if data_hex.len() != 2 * usize::from(len) {
            return Err(SlcanError::DlcMismatch);
        }
        for (byte, pair) in data.iter_mut().zip(data_hex.chunks_exact(2)) {
            *byte = hex_number(pair)? as u8;
        }
    }
    Ok(SlcanLine::Frame(SlcanFrame {
        id,
        remote,
        len,
        data,
    }))
}

/// Parses one line (the bytes before its `\r`; a `\r` inside is [`SlcanError::UnknownCommand`]
/// or [`SlcanError::BadHex`]). Never panics.
pub fn parse_line(line: &[u8]) -> Result<SlcanLine, SlcanError> {
    let Some((&first, rest)) = line.split_first() else {
        return Ok(SlcanLine::Empty);
    };
    if line.len() > MAX_LINE {
        return Err(SlcanError::Overflow);
    }
    let single = |cmd: SlcanLine| {
        if rest.is_empty() {
            Ok(cmd)
        } else {
            Err(SlcanError::TrailingData)
        }
    };
    match first {
        b't' => parse_frame(line, false, false),
        b'T' => parse_frame(line, true, false),
        b'r' => parse_frame(line, false, true),
        b'R' => parse_frame(line, true, true),
        b'O' => single(SlcanLine::Open),
        b'L' => single(SlcanLine::ListenOnly),
        b'C' => single(SlcanLine::Close),
        b'V' => single(SlcanLine::Version),
        b'v' => single(SlcanLine::FirmwareVersion),
        b'N' => single(SlcanLine::SerialNumber),
        b'F' => single(SlcanLine::StatusFlags),
        b'S' | b'Z' => {
            let (&digit, tail) = rest.split_first().ok_or(SlcanError::Truncated)?;
            if !tail.is_empty() {
                return Err(SlcanError::TrailingData);
            }
            let code = digit.wrapping_sub(b'0');
            if first == b'S' {
                let bit_per_s = bitrate_of_code(code).ok_or(SlcanError::BadDlc)?;
                Ok(SlcanLine::SetBitrate { code, bit_per_s })
            } else {
                match code {
                    0 => Ok(SlcanLine::Timestamps(false)),
                    1 => Ok(SlcanLine::Timestamps(true)),
                    _ => Err(SlcanError::BadDlc),
                }
            }
        }
        b's' => {
            if rest.len() < 4 {
                return Err(SlcanError::Truncated);
            }
            if rest.len() > 4 {
                return Err(SlcanError::TrailingData);
            }
            let v = hex_number(rest)?;
            Ok(SlcanLine::SetBtr {
                btr0: (v >> 8) as u8,
                btr1: v as u8,
            })
        }
        b'd' | b'D' | b'b' | b'B' | b'Y' | b'M' | b'm' | b'P' | b'A' | b'X' | b'Q' | b'U' => {
            Err(SlcanError::Unsupported)
        }
        _ => Err(SlcanError::UnknownCommand),
    }
}

/// Writes bytes into `out` at `*at`, advancing it.
struct Writer<'a> {
    out: &'a mut [u8],
    at: usize,
}

impl Writer<'_> {
    fn byte(&mut self, b: u8) -> Result<(), SlcanError> {
        let slot = self
            .out
            .get_mut(self.at)
            .ok_or(SlcanError::BufferTooSmall)?;
        *slot = b;
        self.at += 1;
        Ok(())
    }

    /// The low `digits` hex digits of `v`, upper case, most significant first.
    fn hex(&mut self, v: u32, digits: u32) -> Result<(), SlcanError> {
        const HEX: &[u8; 16] = b"0123456789ABCDEF";
        for i in (0..digits).rev() {
            let nibble = (v.wrapping_shr(4 * i) & 0xF) as usize;
            self.byte(HEX.get(nibble).copied().unwrap_or(b'0'))?;
        }
        Ok(())
    }

    /// `v` (< 100) as two decimal digits.
    fn dec2(&mut self, v: u8) -> Result<(), SlcanError> {
        self.byte(b'0' + (v / 10) % 10)?;
        self.byte(b'0' + v % 10)
    }
}

/// Formats a frame as an SLCAN line with its `\r` into `out`; returns the number of bytes.
/// Standard data frames give `tIIILDD..\r`, extended `TIIIIIIIIL..\r`, remote `rIIIL\r` /
/// `RIIIIIIIIL\r`; hex digits are upper case (as python-can writes them). A line is at most
/// [`MAX_LINE`] + 1 bytes.
///
/// Errors: [`SlcanError::BufferTooSmall`]; [`SlcanError::BadDlc`] for a frame reporting more
/// than 8 data bytes.
pub fn format_frame<F: Frame>(frame: &F, out: &mut [u8]) -> Result<usize, SlcanError> {
    let mut w = Writer { out, at: 0 };
    let remote = frame.is_remote_frame();
    match frame.id() {
        Id::Standard(id) => {
            w.byte(if remote { b'r' } else { b't' })?;
            w.hex(u32::from(id.as_raw()), 3)?;
        }
        Id::Extended(id) => {
            w.byte(if remote { b'R' } else { b'T' })?;
            w.hex(id.as_raw(), 8)?;
        }
    }
    let dlc = if remote {
        frame.dlc()
    } else {
        frame.data().len()
    };
    if dlc > 8 {
        return Err(SlcanError::BadDlc);
    }
    w.byte(b'0' + dlc as u8)?;
    if !remote {
        for b in frame.data() {
            w.hex(u32::from(*b), 2)?;
        }
    }
    w.byte(b'\r')?;
    Ok(w.at)
}

/// The reply to `V`: `V` + `hardware` and `software` as two decimal digits each (values
/// above 99 keep their last two digits) + `\r`, the form python-can's `get_version()` parses.
pub fn format_version(hardware: u8, software: u8, out: &mut [u8]) -> Result<usize, SlcanError> {
    let mut w = Writer { out, at: 0 };
    w.byte(b'V')?;
    w.dec2(hardware)?;
    w.dec2(software)?;
    w.byte(b'\r')?;
    Ok(w.at)
}

/// The reply to `N`: `N` + four upper-case hex digits + `\r`.
pub fn format_serial_number(serial: u16, out: &mut [u8]) -> Result<usize, SlcanError> {
    let mut w = Writer { out, at: 0 };
    w.byte(b'N')?;
    w.hex(u32::from(serial), 4)?;
    w.byte(b'\r')?;
    Ok(w.at)
}

/// The reply to `F`: `F` + two hex digits of [`status_flag`] bits + `\r`.
pub fn format_status_flags(flags: u8, out: &mut [u8]) -> Result<usize, SlcanError> {
    let mut w = Writer { out, at: 0 };
    w.byte(b'F')?;
    w.hex(u32::from(flags), 2)?;
    w.byte(b'\r')?;
    Ok(w.at)
}

/// Assembles `\r`-terminated lines from a byte stream without allocating.
///
/// `N` should be at least [`MAX_LINE`]. `\n` bytes are ignored (terminals send `\r\n`). A line
/// longer than `N` gives one [`SlcanError::Overflow`] and is discarded up to and including
/// the next `\r`, after which assembly resumes (resynchronisation).
#[derive(Clone, Debug)]
pub struct LineBuffer<const N: usize> {
    buf: [u8; N],
    len: usize,
    discarding: bool,
}

impl<const N: usize> Default for LineBuffer<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> LineBuffer<N> {
    /// An empty buffer.
    pub const fn new() -> Self {
        LineBuffer {
            buf: [0; N],
            len: 0,
            discarding: false,
        }
    }

    /// Feeds one byte. Returns the complete line (without `\r`; possibly empty) when `byte`
    /// is `\r`, `None` otherwise, and [`SlcanError::Overflow`] at the byte that makes the line
    /// too long.
    pub fn push(&mut self, byte: u8) -> Result<Option<&[u8]>, SlcanError> {
        match byte {
            b'\r' => {
                let n = self.len;
                self.len = 0;
                if self.discarding {
                    self.discarding = false;
                    Ok(None)
                } else {
                    Ok(Some(self.buf.get(..n).unwrap_or(&[])))
                }
            }
            b'\n' => Ok(None),
            _ if self.discarding => Ok(None),
            _ => match self.buf.get_mut(self.len) {
                Some(slot) => {
                    *slot = byte;
                    self.len += 1;
                    Ok(None)
                }
                None => {
                    self.discarding = true;
                    self.len = 0;
                    Err(SlcanError::Overflow)
                }
            },
        }
    }

    /// Drops a partial line (e.g. after a UART error).
    pub fn clear(&mut self) {
        self.len = 0;
        self.discarding = false;
    }

    /// Bytes of the partial line so far.
    pub const fn len(&self) -> usize {
        self.len
    }

    /// No partial line.
    pub const fn is_empty(&self) -> bool {
        self.len == 0
    }
}
