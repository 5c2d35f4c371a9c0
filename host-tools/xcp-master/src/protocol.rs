//! Protocol numbers the master uses: the command codes, packet identifiers and resource bits
//! of ASAM MCD-1 XCP 1.x (shared with the board's slave, `mil_xcp::protocol`), command names
//! for messages, and the byte order of multi-byte fields.

pub use mil_xcp::protocol::{cmd, event, pid, request, resource, session};

/// The name of a command code, as the standard spells it.
#[must_use]
pub fn command_name(code: u8) -> &'static str {
    match code {
        cmd::CONNECT => "CONNECT",
        cmd::DISCONNECT => "DISCONNECT",
        cmd::GET_STATUS => "GET_STATUS",
        cmd::SYNCH => "SYNCH",
        cmd::GET_COMM_MODE_INFO => "GET_COMM_MODE_INFO",
        cmd::GET_ID => "GET_ID",
        cmd::SET_REQUEST => "SET_REQUEST",
        cmd::GET_SEED => "GET_SEED",
        cmd::UNLOCK => "UNLOCK",
        cmd::SET_MTA => "SET_MTA",
        cmd::UPLOAD => "UPLOAD",
        cmd::SHORT_UPLOAD => "SHORT_UPLOAD",
        cmd::DOWNLOAD => "DOWNLOAD",
        cmd::DOWNLOAD_NEXT => "DOWNLOAD_NEXT",
        cmd::SET_CAL_PAGE => "SET_CAL_PAGE",
        cmd::GET_CAL_PAGE => "GET_CAL_PAGE",
        cmd::GET_PAG_PROCESSOR_INFO => "GET_PAG_PROCESSOR_INFO",
        cmd::GET_SEGMENT_INFO => "GET_SEGMENT_INFO",
        cmd::GET_PAGE_INFO => "GET_PAGE_INFO",
        cmd::COPY_CAL_PAGE => "COPY_CAL_PAGE",
        cmd::SET_DAQ_PTR => "SET_DAQ_PTR",
        cmd::WRITE_DAQ => "WRITE_DAQ",
        cmd::SET_DAQ_LIST_MODE => "SET_DAQ_LIST_MODE",
        cmd::GET_DAQ_LIST_MODE => "GET_DAQ_LIST_MODE",
        cmd::START_STOP_DAQ_LIST => "START_STOP_DAQ_LIST",
        cmd::START_STOP_SYNCH => "START_STOP_SYNCH",
        cmd::GET_DAQ_CLOCK => "GET_DAQ_CLOCK",
        cmd::GET_DAQ_PROCESSOR_INFO => "GET_DAQ_PROCESSOR_INFO",
        cmd::GET_DAQ_RESOLUTION_INFO => "GET_DAQ_RESOLUTION_INFO",
        cmd::GET_DAQ_EVENT_INFO => "GET_DAQ_EVENT_INFO",
        cmd::FREE_DAQ => "FREE_DAQ",
        cmd::ALLOC_DAQ => "ALLOC_DAQ",
        cmd::ALLOC_ODT => "ALLOC_ODT",
        cmd::ALLOC_ODT_ENTRY => "ALLOC_ODT_ENTRY",
        _ => "command",
    }
}

/// The name of a resource bit for messages.
#[must_use]
pub fn resource_name(bit: u8) -> &'static str {
    match bit {
        resource::CAL_PAG => "CAL/PAG",
        resource::DAQ => "DAQ",
        resource::STIM => "STIM",
        resource::PGM => "PGM",
        _ => "resource",
    }
}

/// Byte order of the slave's multi-byte protocol fields (CONNECT's COMM_MODE_BASIC bit 0).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ByteOrder {
    /// Little-endian (Intel), the board's.
    Intel,
    /// Big-endian (Motorola).
    Motorola,
}

impl ByteOrder {
    /// `v` as two bytes.
    #[must_use]
    pub fn u16_bytes(self, v: u16) -> [u8; 2] {
        match self {
            Self::Intel => v.to_le_bytes(),
            Self::Motorola => v.to_be_bytes(),
        }
    }

    /// `v` as four bytes.
    #[must_use]
    pub fn u32_bytes(self, v: u32) -> [u8; 4] {
        match self {
            Self::Intel => v.to_le_bytes(),
            Self::Motorola => v.to_be_bytes(),
        }
    }

    /// Two bytes as a number.
    #[must_use]
    pub fn u16(self, b: [u8; 2]) -> u16 {
        match self {
            Self::Intel => u16::from_le_bytes(b),
            Self::Motorola => u16::from_be_bytes(b),
        }
    }

    /// Four bytes as a number.
    #[must_use]
    pub fn u32(self, b: [u8; 4]) -> u32 {
        match self {
            Self::Intel => u32::from_le_bytes(b),
            Self::Motorola => u32::from_be_bytes(b),
        }
    }
}

/// Seconds of one unit of an XCP time unit code (event cycle and timestamp units:
/// 0 = 1 ns … 9 = 1 s, 10 = 1 ps, 11 = 10 ps, 12 = 100 ps); `None` for other codes.
#[must_use]
pub fn time_unit_seconds(code: u8) -> Option<f64> {
    const UNITS: [f64; 13] = [
        1e-9, 1e-8, 1e-7, 1e-6, 1e-5, 1e-4, 1e-3, 1e-2, 1e-1, 1.0, 1e-12, 1e-11, 1e-10,
    ];
    UNITS.get(usize::from(code)).copied()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn time_units() {
        assert_eq!(time_unit_seconds(3), Some(1e-6));
        assert_eq!(time_unit_seconds(9), Some(1.0));
        assert_eq!(time_unit_seconds(0), Some(1e-9));
        assert_eq!(time_unit_seconds(10), Some(1e-12));
        assert_eq!(time_unit_seconds(13), None);
    }

    #[test]
    fn byte_orders() {
        assert_eq!(
            ByteOrder::Intel.u32_bytes(0x1234_5678),
            [0x78, 0x56, 0x34, 0x12]
        );
        assert_eq!(ByteOrder::Motorola.u16_bytes(0x1234), [0x12, 0x34]);
        assert_eq!(ByteOrder::Motorola.u32([1, 2, 3, 4]), 0x0102_0304);
        assert_eq!(ByteOrder::Intel.u16([0x34, 0x12]), 0x1234);
    }
}
