//! What the slave asks of the application: reading memory, validated calibration writes, page
//! selection, a seed source and a clock. The slave never touches memory itself.
//!
//! Offsets are relative to the start of the region ([`SlaveConfig`](crate::SlaveConfig)) and
//! always keep the access inside it: `offset + len <= region length` for every call (the slave
//! checks the address range with checked arithmetic before calling; the tests assert it with
//! guard areas around the mock's regions).

use crate::protocol::ErrorCode;

/// One of the two pages of calibration segment 0.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum Page {
    /// Page 0: the working page (RAM, writable through XCP).
    Working = 0,
    /// Page 1: the reference page (flash, read-only).
    Reference = 1,
}

impl Page {
    /// The page for a logical page number, `None` beyond page 1.
    #[must_use]
    pub const fn from_number(number: u8) -> Option<Self> {
        match number {
            0 => Some(Self::Working),
            1 => Some(Self::Reference),
            _ => None,
        }
    }

    /// The logical page number.
    #[must_use]
    pub const fn number(self) -> u8 {
        self as u8
    }
}

/// Why the application refused a calibration change. The whole resulting parameter set is
/// validated; a rejected change leaves the parameters as they were.
///
/// XCP error answered ([`Rejected::xcp_error`]): a value problem (`NotFinite`, `OutOfRange`)
/// answers `ERR_OUT_OF_RANGE` (0x22), a problem of the set as a whole (`Unstable`,
/// `Inconsistent`) answers `ERR_GENERIC` (0x31), a change the application takes only in
/// another state (`NotNow`, e.g. another model while the controller runs) answers
/// `ERR_RESOURCE_TEMPORARY_NOT_ACCESSIBLE` (0x33). The reason itself is kept by the slave
/// ([`Slave::last_rejection`](crate::Slave::last_rejection)) for the firmware's status field,
/// as [`Rejected::code`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum Rejected {
    /// A value would be NaN or infinite.
    NotFinite = 1,
    /// A value would be outside its documented range.
    OutOfRange = 2,
    /// The resulting model or filter would be unstable.
    Unstable = 3,
    /// The values are individually valid but contradict each other.
    Inconsistent = 4,
    /// The change is valid but not possible in the application's present state (e.g. the
    /// model changes while the controller runs): retry when it allows.
    NotNow = 5,
}

impl Rejected {
    /// Stable code for status fields (1..=5; 0 is "none").
    #[must_use]
    pub const fn code(self) -> u8 {
        self as u8
    }

    /// The XCP error code the slave answers for this reason.
    #[must_use]
    pub const fn xcp_error(self) -> ErrorCode {
        match self {
            Self::NotFinite | Self::OutOfRange => ErrorCode::OutOfRange,
            Self::Unstable | Self::Inconsistent => ErrorCode::Generic,
            Self::NotNow => ErrorCode::ResourceTemporaryNotAccessible,
        }
    }
}

/// Read access to the calibration pages and the measurement region.
///
/// Reads cannot fail: the slave only asks for bytes inside the configured regions.
pub trait Memory {
    /// Copy `out.len()` bytes of `page` of the calibration region, starting `offset` bytes
    /// after its start, into `out`.
    fn read_calibration(&self, page: Page, offset: usize, out: &mut [u8]);

    /// Copy `out.len()` bytes of the measurement region, starting `offset` bytes after its
    /// start, into `out`.
    fn read_measurement(&self, offset: usize, out: &mut [u8]);
}

/// Changes to the calibration parameters. Every change is validated by the application as a
/// whole parameter set and applied atomically (between two control steps), or rejected and
/// not applied at all.
pub trait Calibration {
    /// Write `data` into the working page at `offset` (relative to the calibration region).
    ///
    /// # Errors
    /// The reason when the resulting parameter set is refused; nothing is changed then.
    fn write(&mut self, offset: usize, data: &[u8]) -> Result<(), Rejected>;

    /// Copy the whole reference page into the working page (COPY_CAL_PAGE 1 → 0).
    ///
    /// # Errors
    /// The reason when the resulting parameter set is refused; nothing is changed then.
    fn copy_reference_to_working(&mut self) -> Result<(), Rejected>;

    /// Make the controller run with the parameters of `page` (SET_CAL_PAGE, ECU mode).
    ///
    /// # Errors
    /// The reason when the application refuses to switch; the page stays as it was.
    fn select_ecu_page(&mut self, page: Page) -> Result<(), Rejected>;

    /// Accept a request to store the working page in non-volatile memory (SET_REQUEST
    /// STORE_CAL_REQ). The store itself runs later, outside the command (a flash write takes
    /// long): the slave reports it pending in GET_STATUS until the application calls
    /// [`Slave::store_finished`](crate::Slave::store_finished). Default: not supported.
    ///
    /// # Errors
    /// Why the application does not take the request now.
    fn request_store(&mut self) -> Result<(), StoreRefused> {
        Err(StoreRefused::Unsupported)
    }
}

/// Why the application does not take a calibration store request now.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum StoreRefused {
    /// The application keeps no calibration in non-volatile memory (`ERR_OUT_OF_RANGE`).
    Unsupported,
    /// Not now, e.g. while the controller runs (`ERR_RESOURCE_TEMPORARY_NOT_ACCESSIBLE`).
    NotNow,
}

impl StoreRefused {
    /// The XCP error code the slave answers for this reason.
    #[must_use]
    pub const fn xcp_error(self) -> ErrorCode {
        match self {
            Self::Unsupported => ErrorCode::OutOfRange,
            Self::NotNow => ErrorCode::ResourceTemporaryNotAccessible,
        }
    }
}

/// Board services: seed entropy and the DAQ clock.
pub trait Platform {
    /// 32 bits that differ from one call to the next. On the board: a free-running timer
    /// (e.g. the cycle counter) XOR-ed with a call counter. The slave hashes two of these
    /// words with its own counter into the 6-byte seed, so a repeated value does not repeat
    /// a seed within one power cycle.
    fn seed_entropy(&mut self) -> u32;

    /// The DAQ clock in µs (wrapping), the same time base as the timestamps given to
    /// [`Slave::sample_daq`](crate::Slave::sample_daq). Answered by GET_DAQ_CLOCK.
    fn now_us(&self) -> u32;
}
