//! Address checks: which region an access falls in, and the memory transfer address (MTA).
//!
//! An access is permitted only when all its bytes lie inside one permitted region; the
//! region's offset is then what the application traits receive. Nothing else is ever read or
//! written.

use crate::config::SlaveConfig;

/// The region an access resolved to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) enum Area {
    /// The calibration region (reads through a page; writes to the working page).
    Calibration,
    /// The measurement region (reads only).
    Measurement,
}

/// An access that lies entirely inside a region.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) struct Resolved {
    pub area: Area,
    /// Offset from the region's start; `offset + n <= region length`.
    pub offset: u32,
}

/// Where the `n` bytes from `addr` lie, `None` when they are not all inside one region.
/// `writable` restricts the answer to the calibration region.
pub(crate) fn resolve(config: &SlaveConfig, addr: u32, n: u32, writable: bool) -> Option<Resolved> {
    if let Some(offset) = config.calibration.offset_of(addr, n) {
        return Some(Resolved {
            area: Area::Calibration,
            offset,
        });
    }
    if writable {
        return None;
    }
    config
        .measurement
        .offset_of(addr, n)
        .map(|offset| Resolved {
            area: Area::Measurement,
            offset,
        })
}

/// Read-only areas that exist only for the master's UPLOADs, without an address.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) enum Virtual {
    /// The GET_ID string.
    Id,
    /// The name of event channel 0.
    EventName,
}

/// The memory transfer address.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) enum Mta {
    /// An XCP address (extension 0), set by SET_MTA or SHORT_UPLOAD.
    Address(u32),
    /// A position in a virtual area, set by GET_ID or GET_DAQ_EVENT_INFO.
    Virtual { area: Virtual, offset: u32 },
}

impl Mta {
    /// The MTA after `n` bytes were transferred (post-increment). Saturates instead of
    /// wrapping: a saturated MTA fails the next region check.
    pub fn advanced(self, n: u32) -> Self {
        match self {
            Self::Address(addr) => Self::Address(addr.saturating_add(n)),
            Self::Virtual { area, offset } => Self::Virtual {
                area,
                offset: offset.saturating_add(n),
            },
        }
    }
}

/// The bytes `offset .. offset + n` of a virtual area, when they exist.
pub(crate) fn virtual_bytes(area: &'static [u8], offset: u32, n: u32) -> Option<&'static [u8]> {
    if n == 0 {
        return None;
    }
    let start = usize::try_from(offset).ok()?;
    let end = start.checked_add(usize::try_from(n).ok()?)?;
    area.get(start..end)
}

/// `usize` of a region offset or length (always fits on 32- and 64-bit targets).
pub(crate) fn to_usize(value: u32) -> Option<usize> {
    usize::try_from(value).ok()
}
