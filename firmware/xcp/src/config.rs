//! The slave's configuration: the two address regions, the GET_ID string, the event period
//! and the seed & key secret; checked once at construction.

/// A range of XCP addresses, `start .. start + len` (address extension 0).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Region {
    /// First address.
    pub start: u32,
    /// Length in bytes (at least 1; `start + len` must not exceed `u32::MAX`).
    pub len: u32,
}

impl Region {
    /// A region of `len` bytes from `start`.
    #[must_use]
    pub const fn new(start: u32, len: u32) -> Self {
        Self { start, len }
    }

    /// The offset of `addr` in the region when all `n` bytes from `addr` lie inside it
    /// (`n >= 1`); checked arithmetic, so no wrap-around is ever accepted.
    #[must_use]
    pub fn offset_of(&self, addr: u32, n: u32) -> Option<u32> {
        if n == 0 {
            return None;
        }
        let offset = addr.checked_sub(self.start)?;
        let end = offset.checked_add(n)?;
        (end <= self.len).then_some(offset)
    }

    /// The address one past the last byte, when it fits in `u32`.
    #[must_use]
    pub fn end(&self) -> Option<u32> {
        self.start.checked_add(self.len)
    }

    fn overlaps(&self, other: &Region) -> bool {
        match (self.end(), other.end()) {
            (Some(a_end), Some(b_end)) => self.start < b_end && other.start < a_end,
            _ => true,
        }
    }
}

/// Shortest secret accepted for the seed & key HMAC.
pub const MIN_SECRET_LEN: usize = 16;

/// Everything the slave needs to know about the board. `Debug` shows the secret's length
/// only.
#[derive(Clone, Copy)]
pub struct SlaveConfig {
    /// Calibration region: what A2L characteristics point into. Read through the XCP access
    /// page, written (working page only) through [`Calibration`](crate::Calibration).
    pub calibration: Region,
    /// Measurement region: read by UPLOAD and DAQ, never written.
    pub measurement: Region,
    /// GET_ID type 1 answer (ASAM-MC2 file name without path and extension), uploaded from a
    /// virtual area the MTA points to after GET_ID.
    pub id: &'static [u8],
    /// Cycle of event channel 0 ("control step") in µs; 0 = not cyclic.
    pub event_period_us: u32,
    /// Seed & key secret (at least [`MIN_SECRET_LEN`] bytes). On the board it comes from a
    /// build-time environment variable; never commit a real one.
    pub secret: &'static [u8],
}

impl core::fmt::Debug for SlaveConfig {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("SlaveConfig")
            .field("calibration", &self.calibration)
            .field("measurement", &self.measurement)
            .field("id", &self.id)
            .field("event_period_us", &self.event_period_us)
            .field("secret_len", &self.secret.len())
            .finish()
    }
}

/// Why a [`SlaveConfig`] was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ConfigError {
    /// A region is empty or ends beyond `u32::MAX`.
    BadRegion,
    /// The calibration and measurement regions overlap.
    RegionsOverlap,
    /// The secret is shorter than [`MIN_SECRET_LEN`].
    SecretTooShort,
    /// The GET_ID string is longer than `u32::MAX` bytes.
    IdTooLong,
}

impl SlaveConfig {
    /// Check the configuration.
    ///
    /// # Errors
    /// The first problem found.
    pub fn validate(&self) -> Result<(), ConfigError> {
        for region in [&self.calibration, &self.measurement] {
            if region.len == 0 || region.end().is_none() {
                return Err(ConfigError::BadRegion);
            }
        }
        if self.calibration.overlaps(&self.measurement) {
            return Err(ConfigError::RegionsOverlap);
        }
        if self.secret.len() < MIN_SECRET_LEN {
            return Err(ConfigError::SecretTooShort);
        }
        if u32::try_from(self.id.len()).is_err() {
            return Err(ConfigError::IdTooLong);
        }
        Ok(())
    }
}
