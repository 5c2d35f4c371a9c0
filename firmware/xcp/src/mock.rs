//! A host-side test ECU (feature `mock`, and in this crate's tests).
//!
//! One byte image holds the calibration working page and the measurement region, each
//! surrounded by [`GUARD`] bytes of [`GUARD_BYTE`]; the reference page is a separate array.
//! The [`Calibration`] implementation validates the whole working page after a change: every
//! 4-byte aligned word must be a finite `f32`, else the change is refused
//! ([`Rejected::NotFinite`]) and nothing is changed. An offset outside its region (which the
//! slave must never pass) is counted in [`MockEcu::violations`] and touches nothing.
//! [`MockPlatform`] is a deterministic seed source and a settable clock.

use core::cell::Cell;

use crate::config::{Region, SlaveConfig};
use crate::memory::{Calibration, Memory, Page, Platform, Rejected, StoreRefused};

/// Start of the mock's calibration region.
pub const CAL_START: u32 = 0x2000_0000;
/// Length of the calibration region (1024 `f32` parameters: room for the MiL board's page).
pub const CAL_LEN: usize = 4096;
/// Start of the mock's measurement region.
pub const MEAS_START: u32 = 0x2000_2000;
/// Length of the measurement region.
pub const MEAS_LEN: usize = 256;
/// Guard bytes before and after each region in the image.
pub const GUARD: usize = 64;
/// Value of every guard byte.
pub const GUARD_BYTE: u8 = 0xA5;
/// Position of the working page in [`MockEcu::image`].
pub const CAL_POS: usize = GUARD;
/// Position of the measurement region in [`MockEcu::image`].
pub const MEAS_POS: usize = GUARD + CAL_LEN + GUARD;
/// Length of the image.
pub const IMAGE_LEN: usize = MEAS_POS + MEAS_LEN + GUARD;
/// The GET_ID string of the mock.
pub const ID: &[u8] = b"mil_rig_mock";
/// Event period of the mock (2 kHz).
pub const EVENT_PERIOD_US: u32 = 500;
/// An obviously fake secret for tests. Never use it on a board.
pub const TEST_SECRET: &[u8] = b"FAKE-TEST-SECRET-do-not-use-0000";

/// The mock's slave configuration.
#[must_use]
pub const fn config() -> SlaveConfig {
    SlaveConfig {
        calibration: Region::new(CAL_START, CAL_LEN as u32),
        measurement: Region::new(MEAS_START, MEAS_LEN as u32),
        id: ID,
        event_period_us: EVENT_PERIOD_US,
        secret: TEST_SECRET,
    }
}

/// Initial working page: parameter `i` is `i as f32 * 0.5`.
#[must_use]
pub fn initial_working() -> [u8; CAL_LEN] {
    f32_page(|i| i as f32 * 0.5)
}

/// Reference page: parameter `i` is `100 + i`.
#[must_use]
pub fn initial_reference() -> [u8; CAL_LEN] {
    f32_page(|i| 100.0 + i as f32)
}

fn f32_page(value: impl Fn(usize) -> f32) -> [u8; CAL_LEN] {
    let mut page = [0_u8; CAL_LEN];
    for (i, word) in page.chunks_exact_mut(4).enumerate() {
        word.copy_from_slice(&value(i).to_le_bytes());
    }
    page
}

/// Measurement region: byte `i` is `i` (wrapping).
#[must_use]
pub fn initial_measurement() -> [u8; MEAS_LEN] {
    let mut m = [0_u8; MEAS_LEN];
    for (i, b) in m.iter_mut().enumerate() {
        *b = i as u8;
    }
    m
}

/// Whether every aligned word of a page is a finite `f32`.
fn all_finite(page: &[u8]) -> bool {
    page.chunks_exact(4).all(|w| {
        let mut b = [0_u8; 4];
        b.copy_from_slice(w);
        f32::from_le_bytes(b).is_finite()
    })
}

/// The test ECU.
#[derive(Clone, Debug)]
pub struct MockEcu {
    /// Guards, working page, guards, measurement region, guards.
    pub image: [u8; IMAGE_LEN],
    /// The reference page (read-only for the slave).
    pub reference: [u8; CAL_LEN],
    /// The page the controller runs with.
    pub ecu_page: Page,
    /// Offsets outside a region the slave passed (must stay 0).
    pub violations: Cell<u32>,
    /// Accepted calibration changes.
    pub writes: u32,
    /// Refused calibration changes.
    pub rejections: u32,
    /// Refuse every ECU page switch with this reason (to test the refusal path).
    pub refuse_page_switch: Option<Rejected>,
    /// Calibration stores requested (SET_REQUEST STORE_CAL_REQ) and taken.
    pub store_requests: u32,
    /// Refuse store requests with this reason; `None` takes them.
    pub refuse_store: Option<StoreRefused>,
}

impl Default for MockEcu {
    fn default() -> Self {
        Self::new()
    }
}

impl MockEcu {
    /// Guards, [`initial_working`], [`initial_measurement`], [`initial_reference`].
    #[must_use]
    pub fn new() -> Self {
        let mut image = [GUARD_BYTE; IMAGE_LEN];
        if let Some(dst) = image.get_mut(CAL_POS..CAL_POS + CAL_LEN) {
            dst.copy_from_slice(&initial_working());
        }
        if let Some(dst) = image.get_mut(MEAS_POS..MEAS_POS + MEAS_LEN) {
            dst.copy_from_slice(&initial_measurement());
        }
        Self {
            image,
            reference: initial_reference(),
            ecu_page: Page::Working,
            violations: Cell::new(0),
            writes: 0,
            rejections: 0,
            refuse_page_switch: None,
            store_requests: 0,
            refuse_store: None,
        }
    }

    /// The working page.
    #[must_use]
    pub fn working(&self) -> &[u8] {
        self.image.get(CAL_POS..CAL_POS + CAL_LEN).unwrap_or(&[])
    }

    /// The measurement region.
    #[must_use]
    pub fn measurement(&self) -> &[u8] {
        self.image.get(MEAS_POS..MEAS_POS + MEAS_LEN).unwrap_or(&[])
    }

    /// Mutable measurement region (the "application" writing its signals).
    pub fn measurement_mut(&mut self) -> &mut [u8] {
        self.image
            .get_mut(MEAS_POS..MEAS_POS + MEAS_LEN)
            .unwrap_or(&mut [])
    }

    /// Whether every guard byte still has its value.
    #[must_use]
    pub fn guards_intact(&self) -> bool {
        let guards = [
            0..CAL_POS,
            CAL_POS + CAL_LEN..MEAS_POS,
            MEAS_POS + MEAS_LEN..IMAGE_LEN,
        ];
        guards.into_iter().all(|r| {
            self.image
                .get(r)
                .is_some_and(|g| g.iter().all(|&b| b == GUARD_BYTE))
        })
    }

    fn violation(&self) {
        self.violations.set(self.violations.get().saturating_add(1));
    }

    /// Validate `candidate` and make it the working page, or refuse it.
    fn commit(&mut self, candidate: &[u8; CAL_LEN]) -> Result<(), Rejected> {
        if !all_finite(candidate) {
            self.rejections += 1;
            return Err(Rejected::NotFinite);
        }
        if let Some(dst) = self.image.get_mut(CAL_POS..CAL_POS + CAL_LEN) {
            dst.copy_from_slice(candidate);
        }
        self.writes += 1;
        Ok(())
    }
}

fn copy_out(src: &[u8], offset: usize, out: &mut [u8]) -> bool {
    match offset
        .checked_add(out.len())
        .and_then(|end| src.get(offset..end))
    {
        Some(s) => {
            out.copy_from_slice(s);
            true
        }
        None => false,
    }
}

impl Memory for MockEcu {
    fn read_calibration(&self, page: Page, offset: usize, out: &mut [u8]) {
        let src = match page {
            Page::Working => self.working(),
            Page::Reference => self.reference.as_slice(),
        };
        if !copy_out(src, offset, out) {
            self.violation();
        }
    }

    fn read_measurement(&self, offset: usize, out: &mut [u8]) {
        if !copy_out(self.measurement(), offset, out) {
            self.violation();
        }
    }
}

impl Calibration for MockEcu {
    fn write(&mut self, offset: usize, data: &[u8]) -> Result<(), Rejected> {
        let mut candidate = [0_u8; CAL_LEN];
        for (c, w) in candidate.iter_mut().zip(self.working()) {
            *c = *w;
        }
        let Some(dst) = offset
            .checked_add(data.len())
            .and_then(|end| candidate.get_mut(offset..end))
        else {
            self.violation();
            return Err(Rejected::OutOfRange);
        };
        dst.copy_from_slice(data);
        self.commit(&candidate)
    }

    fn copy_reference_to_working(&mut self) -> Result<(), Rejected> {
        let candidate = self.reference;
        self.commit(&candidate)
    }

    fn select_ecu_page(&mut self, page: Page) -> Result<(), Rejected> {
        if let Some(reason) = self.refuse_page_switch {
            return Err(reason);
        }
        self.ecu_page = page;
        Ok(())
    }

    fn request_store(&mut self) -> Result<(), StoreRefused> {
        if let Some(reason) = self.refuse_store {
            return Err(reason);
        }
        self.store_requests += 1;
        Ok(())
    }
}

/// The test board services: a deterministic entropy source and a settable clock.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MockPlatform {
    /// State of the entropy source (xorshift32; must not be 0).
    pub entropy: u32,
    /// Answer of [`Platform::now_us`].
    pub now_us: u32,
}

impl Default for MockPlatform {
    fn default() -> Self {
        Self {
            entropy: 0x1234_5678,
            now_us: 0,
        }
    }
}

impl Platform for MockPlatform {
    fn seed_entropy(&mut self) -> u32 {
        // xorshift32: deterministic, different on every call.
        let mut x = self.entropy;
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        self.entropy = x;
        x
    }

    fn now_us(&self) -> u32 {
        self.now_us
    }
}
