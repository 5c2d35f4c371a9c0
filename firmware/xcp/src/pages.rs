//! Calibration segment 0 and its two pages: which page the controller (ECU) uses and which
//! page XCP reads and writes, kept separately.

use crate::memory::Page;

/// SET_CAL_PAGE / GET_CAL_PAGE mode bits.
pub(crate) mod mode {
    /// The page the ECU (controller) uses.
    pub const ECU: u8 = 0x01;
    /// The page XCP accesses.
    pub const XCP: u8 = 0x02;
    /// Every segment (the segment number is ignored).
    pub const ALL: u8 = 0x80;
}

/// Number of calibration segments.
pub const SEGMENTS: u8 = 1;
/// Pages of segment 0.
pub const PAGES: u8 = 2;

/// GET_PAGE_INFO page properties: bits 0–1 ECU access (without / with XCP), 2–3 XCP read
/// access (without / with ECU), 4–5 XCP write access (without / with ECU).
pub(crate) const fn page_properties(page: Page) -> u8 {
    match page {
        // RAM: the ECU and XCP read and write it, also at the same time.
        Page::Working => 0x3F,
        // Flash: the ECU and XCP read it, nobody writes it.
        Page::Reference => 0x0F,
    }
}

/// The page selections; both start on the working page.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Pages {
    pub ecu: Page,
    pub xcp: Page,
}

impl Pages {
    pub const fn new() -> Self {
        Self {
            ecu: Page::Working,
            xcp: Page::Working,
        }
    }
}
