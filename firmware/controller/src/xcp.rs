//! The board as an XCP target, and the one authority over its parameters: `mil-xcp`'s
//! [`Memory`] and [`Calibration`] over the calibration page and the measurement block
//! ([`crate::calibration`]) and the running application, and the Command frames' parameter
//! writes ([`Target::command_frame`]) through the same transactions.
//!
//! - Reads: the working page, the reference page (the build's defaults) and the measurement
//!   block, byte for byte as their statics hold them.
//! - A write goes to the working page: the page's new content is validated slot by slot and
//!   as a whole (parameters and settings, [`calibration::validate_write`]); a refused write
//!   answers the XCP error of its reason and changes nothing. While the controller runs the
//!   working page the accepted set is installed at once ([`Application::install`]: between
//!   two control steps, parameters, status period and watchdog together or nothing); while
//!   it runs the reference page the change waits in the working page.
//! - SET_CAL_PAGE for the ECU installs the page's set (validated again) or changes nothing;
//!   COPY_CAL_PAGE reference → working is one write of the whole page.
//! - A Command frame's SetParam or SetWatchdog is a one-slot write of the working page, the
//!   same transaction, refused while the controller runs the reference page and, unless
//!   [`safe_without_unlock`], while no XCP session holds CAL/PAG unlocked.
//!
//! So the running set is always the page GET_CAL_PAGE names for the ECU. Validation runs
//! outside the application's lock; the XCP and configuration tasks run at one priority, one
//! command at a time, so no other change comes in between.

use mil_frames::RawFrame;
use mil_xcp::{Calibration, Memory, Page, Platform, Region, Rejected, SlaveConfig, StoreRefused};

use crate::application::{Application, Command};
use crate::calibration::{self, meas, Candidate, MEASUREMENTS, MEASUREMENT_BYTES, PAGE_BYTES};
use crate::config::{SAMPLE_RATE_HZ, XCP_ID, XCP_RESPONSE_ID};
use crate::params::code;

/// The default control step's period (µs): XCP event channel 0's cycle until the rate
/// changes ([`event_period_us`]).
pub const STEP_PERIOD_US: u32 = 1_000_000 / SAMPLE_RATE_HZ;

/// Event channel 0's cycle (µs, rounded) at the sample rate `rate_hz`: what
/// GET_DAQ_EVENT_INFO reports (the XCP task sets it before every command).
pub fn event_period_us(rate_hz: u16) -> u32 {
    let rate = u32::from(rate_hz.max(1));
    (1_000_000 + rate / 2) / rate
}

/// The slave's configuration on the board: the calibration region is the working page
/// ([`calibration::WORKING`]) and the measurement region the measurement block, at their
/// linked addresses (what the A2L file gives); event 0 is the control step.
pub fn slave_config(secret: &'static [u8]) -> SlaveConfig {
    SlaveConfig {
        calibration: Region::new(calibration::working_address(), PAGE_BYTES as u32),
        measurement: Region::new(calibration::measurement_address(), MEASUREMENT_BYTES as u32),
        id: XCP_ID,
        event_period_us: STEP_PERIOD_US,
        secret,
    }
}

/// Which of the board's links an XCP command came in on, so that its answer goes back
/// there. The board has one CAN bus; the QEMU build has two SLCAN ports on one virtual bus
/// (USART1, where the rig's lockstep runs, and USART2 for an XCP master such as pyxcp).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Link {
    /// CAN1 on the board; USART1 in QEMU.
    #[default]
    Bus,
    /// QEMU only: USART2.
    Aux,
}

/// One received XCP command frame for the XCP task.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct XcpRequest {
    /// The frame (ID [`crate::config::XCP_COMMAND_ID`]).
    pub frame: RawFrame,
    /// Where it came in.
    pub link: Link,
}

/// An XCP packet (response or DTO, 1..=8 bytes) as a CAN frame on the response ID: DLC =
/// the packet's length (no padding). `None` for an empty or over-long packet.
pub fn response_frame(packet: &[u8]) -> Option<RawFrame> {
    if packet.is_empty() {
        return None;
    }
    RawFrame::from_parts(XCP_RESPONSE_ID, packet)
}

/// What DAQ samples at one control step: a copy of the measurement block taken right after
/// the step (after its demand frame was queued), and the step's time. DAQ lists read their
/// measurement entries from this copy, so a sample is consistent even when the DAQ task
/// runs after the next step has begun; calibration entries are read from the page the
/// controller runs on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StepSample {
    /// The measurement block's words.
    pub words: [u32; MEASUREMENTS],
    /// The DAQ timestamp (µs): the board time of the step ([`meas::TIME_US`]: its sample
    /// periods summed, each at the rate it ran), wrapping.
    pub time_us: u32,
}

impl StepSample {
    /// The measurement block now (call it right after [`Application::record_step`]).
    pub fn take() -> Self {
        let words = calibration::measurement_words();
        Self {
            words,
            time_us: words.get(meas::TIME_US).copied().unwrap_or(0),
        }
    }
}

impl Memory for StepSample {
    fn read_calibration(&self, page: Page, offset: usize, out: &mut [u8]) {
        calibration::read(board_page(page), offset, out);
    }

    fn read_measurement(&self, offset: usize, out: &mut [u8]) {
        for (k, b) in out.iter_mut().enumerate() {
            let at = offset.saturating_add(k);
            *b = self
                .words
                .get(at / 4)
                .map_or(0, |w| w.to_le_bytes().get(at % 4).copied().unwrap_or(0));
        }
    }
}

/// The board's [`Platform`]: the DAQ clock is the board time of the last step
/// ([`meas::TIME_US`], the same base as [`StepSample::time_us`]); the seed entropy comes
/// from `entropy` (a free-running hardware counter) XOR-ed with a call counter.
pub struct StepPlatform<F> {
    entropy: F,
    calls: u32,
}

impl<F: FnMut() -> u32> StepPlatform<F> {
    /// A platform drawing seed entropy from `entropy`.
    pub fn new(entropy: F) -> Self {
        Self { entropy, calls: 0 }
    }
}

impl<F: FnMut() -> u32> Platform for StepPlatform<F> {
    fn seed_entropy(&mut self) -> u32 {
        self.calls = self.calls.wrapping_add(0x9E37_79B9);
        (self.entropy)() ^ self.calls
    }

    fn now_us(&self) -> u32 {
        calibration::measurement_words()
            .get(meas::TIME_US)
            .copied()
            .unwrap_or(0)
    }
}

fn board_page(page: Page) -> calibration::Page {
    match page {
        Page::Working => calibration::Page::Working,
        Page::Reference => calibration::Page::Reference,
    }
}

/// The CommandAck code of an XCP rejection (for the measurement block's
/// `calibration_last_rejection`).
pub fn rejection_code(r: Rejected) -> u8 {
    match r {
        Rejected::NotFinite => code::NOT_FINITE,
        Rejected::OutOfRange => code::OUT_OF_RANGE,
        Rejected::Unstable => code::UNSTABLE,
        Rejected::Inconsistent => code::INCONSISTENT,
        Rejected::NotNow => code::WRONG_MODE,
    }
}

/// Records a calibration change's outcome in the measurement block and passes it on.
fn noted(result: Result<(), Rejected>) -> Result<(), Rejected> {
    calibration::note_change(match result {
        Ok(()) => code::OK,
        Err(r) => rejection_code(r),
    });
    result
}

/// Access to the shared application: `with` runs `f` under the application's lock (on the
/// board an RTIC resource lock; on the host a plain borrow).
pub trait AppAccess {
    /// Runs `f` with the application locked.
    fn with<R>(&mut self, f: impl FnOnce(&mut Application) -> R) -> R;
}

impl AppAccess for Application {
    fn with<R>(&mut self, f: impl FnOnce(&mut Application) -> R) -> R {
        f(self)
    }
}

/// The XCP target (see the module documentation).
pub struct Target<'c, A> {
    app: A,
    ecu_page: Page,
    /// Where a change is validated and prepared (kilobytes: owned by the configuration
    /// tasks, never on a stack).
    candidate: &'c mut Candidate,
}

/// The XCP rejection for a CommandAck code.
pub fn rejection(c: u8) -> Rejected {
    match c {
        code::NOT_FINITE => Rejected::NotFinite,
        code::UNSTABLE => Rejected::Unstable,
        code::INCONSISTENT => Rejected::Inconsistent,
        code::WRONG_MODE => Rejected::NotNow,
        _ => Rejected::OutOfRange,
    }
}

impl<'c, A: AppAccess> Target<'c, A> {
    /// The target over `app`, validating changes in `candidate`; the controller runs on the
    /// working page.
    pub fn new(app: A, candidate: &'c mut Candidate) -> Self {
        Self::with_page(app, Page::Working, candidate)
    }

    /// The target over `app` with the controller running on `ecu_page` (the firmware makes
    /// one per command, with the slave's [`mil_xcp::Slave::ecu_page`]).
    pub fn with_page(app: A, ecu_page: Page, candidate: &'c mut Candidate) -> Self {
        Self {
            app,
            ecu_page,
            candidate,
        }
    }

    /// The page the controller runs on.
    pub fn ecu_page(&self) -> Page {
        self.ecu_page
    }

    /// The application access (e.g. to step it in a host test).
    pub fn app_mut(&mut self) -> &mut A {
        &mut self.app
    }

    /// Installs the candidate's prepared set and settings under one lock, as one
    /// transaction ([`Application::install`]): all of it, or (CommandAck code) nothing.
    fn install(&mut self) -> Result<(), u8> {
        let Self { app, candidate, .. } = self;
        match app.with(|a| a.install(&candidate.prepared, candidate.settings)) {
            code::OK => Ok(()),
            c => Err(c),
        }
    }
}

impl<A: AppAccess> Target<'_, A> {
    /// A Command frame's command, as the configuration task applies it; returns the
    /// CommandAck code. `cal_unlocked`: an XCP session holds CAL/PAG unlocked (seed & key).
    ///
    /// Start, Stop and ClearFault operate the controller and touch no page. A parameter or
    /// setting write (SetParam, SetWatchdog) is a write of that one slot of the working page,
    /// the same transaction as an XCP DOWNLOAD, in this order:
    /// 1. the working page with the value is validated as a whole (a bad value is named
    ///    first, whoever sends it);
    /// 2. authority: it needs CAL/PAG unlocked ([`code::LOCKED`]) unless it is safe without
    ///    ([`safe_without_unlock`]);
    /// 3. it is refused while the controller runs the reference page
    ///    ([`code::REFERENCE_PAGE`]): the set that runs is always one of the two pages;
    /// 4. it is installed and stored, or (a refused install) nothing changes.
    pub fn command_frame(&mut self, command: &Command, cal_unlocked: bool) -> u8 {
        let result = self.command_write(command, cal_unlocked);
        if result != code::OK && !Self::operating(command) {
            self.app.with(|a| a.count_rejected());
        }
        result
    }

    fn operating(command: &Command) -> bool {
        matches!(
            command,
            Command::Start | Command::Stop | Command::ClearFault
        )
    }

    fn command_write(&mut self, command: &Command, cal_unlocked: bool) -> u8 {
        let (slot, value) = match *command {
            Command::Start | Command::Stop | Command::ClearFault => {
                return self.app.with(|a| a.command(command))
            }
            Command::SetWatchdog { seconds } => match crate::params::watchdog_from_seconds(seconds)
            {
                Ok(n) => (calibration::SLOT_WATCHDOG, f32::from(n)),
                Err(c) => return c,
            },
            Command::SetParam { index, value } => match calibration::slot_of(index) {
                Some(slot) => (slot, value),
                None => return code::UNKNOWN_INDEX,
            },
        };
        // The value first: a bad value is named as such, whoever sends it.
        if let Err(c) = self.validate(4 * slot, &value.to_le_bytes()) {
            return c;
        }
        let watchdog = self.app.with(|a| a.watchdog().limit);
        if !cal_unlocked && !safe_without_unlock(slot, value, watchdog) {
            return code::LOCKED;
        }
        if self.ecu_page == Page::Reference {
            return code::REFERENCE_PAGE;
        }
        match self.commit() {
            Ok(()) => code::OK,
            Err(c) => c,
        }
    }
}

/// Whether a Command-frame write of `value` into `slot` is safe without the calibration
/// unlocked (`watchdog`: the limit running now): the status period (reporting only), a
/// watchdog limit no longer than the running one (a tighter watchdog trips sooner), and in
/// the QEMU build the watchdog switched off (a test build: the instruction benchmark).
/// Everything else changes the force and needs seed & key.
pub fn safe_without_unlock(slot: usize, value: f32, watchdog: u16) -> bool {
    match slot {
        calibration::SLOT_STATUS_PERIOD => true,
        calibration::SLOT_WATCHDOG => {
            let off = crate::config::WATCHDOG_OFF_ALLOWED
                && value == f32::from(crate::config::WATCHDOG_OFF);
            let tighter = watchdog != crate::config::WATCHDOG_OFF && value <= f32::from(watchdog);
            off || tighter
        }
        _ => false,
    }
}

impl<A> Memory for Target<'_, A> {
    fn read_calibration(&self, page: Page, offset: usize, out: &mut [u8]) {
        calibration::read(board_page(page), offset, out);
    }

    fn read_measurement(&self, offset: usize, out: &mut [u8]) {
        calibration::read_measurement(offset, out);
    }
}

impl<A: AppAccess> Calibration for Target<'_, A> {
    fn write(&mut self, offset: usize, data: &[u8]) -> Result<(), Rejected> {
        noted(self.write_page(offset, data).map_err(rejection))
    }

    /// The reference page's words written over the whole working page: one transaction as
    /// a write of every byte (validated as a whole, installed while the controller runs the
    /// working page, stored).
    fn copy_reference_to_working(&mut self) -> Result<(), Rejected> {
        let copy = |t: &mut Self| {
            t.candidate.prepared.params_mut();
            let c = &mut *t.candidate;
            calibration::load_page(calibration::Page::Reference, &mut c.words);
            c.settings = calibration::decode_page_into(&c.words, &mut c.prepared)?;
            t.commit()
        };
        noted(copy(self).map_err(rejection))
    }

    fn select_ecu_page(&mut self, page: Page) -> Result<(), Rejected> {
        noted(self.select_page(page).map_err(rejection))
    }

    /// Taken unless the controller runs: a flash erase stalls the processor for up to
    /// seconds, which only Idle or Fault (demand at the safe value) can afford. The XCP task
    /// then stores the working page ([`crate::store::Store::save`]).
    fn request_store(&mut self) -> Result<(), StoreRefused> {
        let running = self
            .app
            .with(|a| a.controller().mode() == model_core::Mode::Running);
        if running {
            crate::store::note_store(Err(crate::store::StoreError::Running));
            Err(StoreRefused::NotNow)
        } else {
            Ok(())
        }
    }
}

impl<A: AppAccess> Target<'_, A> {
    /// Writes `data` at byte `offset` of the working page as one transaction
    /// ([`Self::validate`], then [`Self::commit`]).
    fn write_page(&mut self, offset: usize, data: &[u8]) -> Result<(), u8> {
        self.validate(offset, data)?;
        self.commit()
    }

    /// The working page with `data` written at byte `offset`, validated as a whole page
    /// into the candidate (CommandAck code of the refusal). Changes nothing else.
    fn validate(&mut self, offset: usize, data: &[u8]) -> Result<(), u8> {
        calibration::load_page(calibration::Page::Working, &mut self.candidate.words);
        calibration::validate_write_in_place(offset, data, self.candidate)
    }

    /// Makes the validated change in the candidate: while the controller runs the working
    /// page the new set is installed with it ([`Self::install`]), while it runs the
    /// reference page the change waits in the working page; then the page is stored. A
    /// refused install (CommandAck code) changes neither the page nor the running set.
    fn commit(&mut self) -> Result<(), u8> {
        if !self.candidate.prepared.is_ready() {
            return Err(code::INCONSISTENT);
        }
        if self.ecu_page == Page::Working {
            self.install()?;
        }
        calibration::store_working(&self.candidate.words);
        Ok(())
    }

    /// Switches the controller to `page` as one transaction: that page's set is validated
    /// and installed, or (CommandAck code) nothing changes and the ECU page stays.
    fn select_page(&mut self, page: Page) -> Result<(), u8> {
        let c = &mut *self.candidate;
        calibration::load_page(board_page(page), &mut c.words);
        c.settings = calibration::decode_page_into(&c.words, &mut c.prepared)?;
        self.install()?;
        self.ecu_page = page;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibration::SLOT_STATUS_PERIOD;
    use crate::calibration::{test_lock, MEASUREMENT_BYTES, PAGE_BYTES};
    use crate::config::{TYRE, XCP_RESPONSE_ID};
    use mil_xcp::mock::{MockPlatform, TEST_SECRET};
    use mil_xcp::{compute_key, Region, Responses, Slave, SlaveConfig};
    use std::vec;
    use std::vec::Vec;

    const CAL: u32 = 0x2000_0100;

    /// The address of the calibration item named `name` (the A2L's name).
    fn at(name: &str) -> u32 {
        CAL + 4 * calibration::slot_named(name).expect("an item") as u32
    }

    /// The Command-frame index of the item named `name`.
    fn index(name: &str) -> u16 {
        calibration::slot_named(name).expect("an item") as u16
    }
    const MEAS: u32 = 0x2000_2000;

    fn slave() -> Slave {
        Slave::new(SlaveConfig {
            calibration: Region {
                start: CAL,
                len: PAGE_BYTES as u32,
            },
            measurement: Region {
                start: MEAS,
                len: MEASUREMENT_BYTES as u32,
            },
            id: b"mil",
            event_period_us: 500,
            secret: TEST_SECRET,
        })
        .expect("config")
    }

    struct Session {
        slave: Slave,
        target: Target<'static, Application>,
        platform: MockPlatform,
        out: Responses,
    }

    impl Session {
        fn new() -> Self {
            let app = Application::new(256).expect("app");
            app.mirror_to_working_page();
            Self {
                slave: slave(),
                target: Target::new(app, crate::calibration::host_candidate()),
                platform: MockPlatform::default(),
                out: Responses::default(),
            }
        }

        fn send(&mut self, cto: &[u8]) -> Vec<u8> {
            self.slave
                .handle(cto, &mut self.target, &mut self.platform, &mut self.out);
            self.out.iter().flat_map(|f| f.to_vec()).collect()
        }

        fn connect_and_unlock(&mut self) {
            assert_eq!(self.send(&[0xFF, 0x00])[0], 0xFF);
            for resource in [0x01u8, 0x04] {
                let seed = self.send(&[0xF8, 0x00, resource]);
                assert_eq!(&seed[..2], &[0xFF, 0x06], "{seed:02X?}");
                let seed: [u8; 6] = seed[2..8].try_into().expect("6 bytes");
                let key = compute_key(TEST_SECRET, resource, &seed);
                let mut unlock = vec![0xF7, 0x06];
                unlock.extend_from_slice(&key);
                assert_eq!(self.send(&unlock)[0], 0xFF);
            }
        }

        fn set_mta(&mut self, address: u32) {
            let a = address.to_le_bytes();
            assert_eq!(self.send(&[0xF6, 0, 0, 0, a[0], a[1], a[2], a[3]]), [0xFF]);
        }

        fn download_f32(&mut self, address: u32, value: f32) -> Vec<u8> {
            self.set_mta(address);
            let v = value.to_le_bytes();
            self.send(&[0xF0, 4, v[0], v[1], v[2], v[3]])
        }

        fn upload_f32(&mut self, address: u32) -> f32 {
            let a = address.to_le_bytes();
            let r = self.send(&[0xF4, 4, 0, 0, a[0], a[1], a[2], a[3]]);
            assert_eq!(r[0], 0xFF, "{r:02X?}");
            f32::from_le_bytes(r[1..5].try_into().expect("4 bytes"))
        }
    }

    #[test]
    fn a_download_reaches_the_running_model_and_bad_values_change_nothing() {
        let _turn = test_lock();
        let mut s = Session::new();
        s.connect_and_unlock();
        // Tyre damping: 500 → 800 N s/m.
        assert_eq!(s.upload_f32(at("tyre_damping_0")), TYRE.damping);
        assert_eq!(s.download_f32(at("tyre_damping_0"), 800.0), [0xFF]);
        assert_eq!(s.target.app.params().tyre.tyre[0].damping, 800.0);
        assert_eq!(s.upload_f32(at("tyre_damping_0")), 800.0);
        // NaN, out of range, inconsistent (minimum above maximum), outside the page: refused
        // with the XCP error, nothing changes.
        let before = *s.target.app.params();
        assert_eq!(s.download_f32(at("tyre_damping_0"), f32::NAN), [0xFE, 0x22]);
        assert_eq!(s.download_f32(at("tyre_stiffness_0"), -5.0), [0xFE, 0x22]);
        assert_eq!(
            s.download_f32(at("limits_demand_min_0"), 50_000.0),
            [0xFE, 0x31]
        );
        assert_eq!(s.slave.last_rejection(), Some(Rejected::Inconsistent));
        assert_eq!(s.download_f32(CAL + PAGE_BYTES as u32, 1.0)[0], 0xFE);
        assert_eq!(*s.target.app.params(), before);
        assert_eq!(s.upload_f32(at("tyre_damping_0")), 800.0);
        // The status period (a firmware setting) goes through the same path.
        assert_eq!(
            s.download_f32(CAL + 4 * calibration::SLOT_STATUS_PERIOD as u32, 50.0),
            [0xFF]
        );
        assert_eq!(s.target.app.status_period(), 50);
        // Back to the defaults for the other tests.
        assert_eq!(s.send(&[0xE4, 0, 1, 0, 0]), [0xFF]);
        assert_eq!(s.target.app.params().tyre.tyre[0].damping, TYRE.damping);
        assert_eq!(s.target.app.status_period(), 200);
    }

    #[test]
    fn the_ecu_runs_the_reference_page_while_the_working_page_is_prepared() {
        let _turn = test_lock();
        let mut s = Session::new();
        s.connect_and_unlock();
        assert_eq!(s.download_f32(at("tyre_stiffness_0"), 3.0e5), [0xFF]);
        assert_eq!(s.target.app.params().tyre.tyre[0].stiffness, 3.0e5);
        // ECU → reference page (mode 0x01, segment 0, page 1): the defaults run.
        assert_eq!(s.send(&[0xEB, 0x01, 0x00, 0x01]), [0xFF]);
        assert_eq!(s.target.app.params().tyre.tyre[0].stiffness, TYRE.stiffness);
        // A change to the working page waits there.
        assert_eq!(s.download_f32(at("tyre_damping_0"), 900.0), [0xFF]);
        assert_eq!(s.target.app.params().tyre.tyre[0].damping, TYRE.damping);
        // XCP reads of the reference page (XCP access page 1) show the defaults.
        assert_eq!(s.send(&[0xEB, 0x02, 0x00, 0x01]), [0xFF]);
        assert_eq!(s.upload_f32(at("tyre_stiffness_0")), TYRE.stiffness);
        // Writes through the reference page are refused (write protected).
        assert_eq!(s.download_f32(at("tyre_stiffness_0"), 1.0), [0xFE, 0x23]);
        // ECU and XCP back to the working page: the prepared set runs.
        assert_eq!(s.send(&[0xEB, 0x83, 0x00, 0x00]), [0xFF]);
        let tyre = s.target.app.params().tyre.tyre[0];
        assert_eq!((tyre.stiffness, tyre.damping), (3.0e5, 900.0));
        assert_eq!(s.send(&[0xE4, 0, 1, 0, 0]), [0xFF]);
    }

    impl Session {
        /// Whether the slave holds CAL/PAG unlocked.
        fn cal_unlocked(&self) -> bool {
            self.slave.unlocked(mil_xcp::protocol::resource::CAL_PAG)
        }

        /// A fuzzer's command through the slave: SET_MTA + DOWNLOAD pairs travel as two
        /// commands; `check` sees the answer of each.
        fn handle_parts(&mut self, c: &[u8], mut check: impl FnMut(&Responses)) {
            let parts: Vec<&[u8]> = if c.first() == Some(&0xF6) && c.len() > 8 {
                vec![&c[..8], &c[8..]]
            } else {
                vec![c]
            };
            for p in parts {
                self.slave
                    .handle(p, &mut self.target, &mut self.platform, &mut self.out);
                check(&self.out);
            }
        }

        /// A Command frame's command, as the configuration task applies it.
        fn command(&mut self, c: Command) -> u8 {
            let unlocked = self.cal_unlocked();
            self.target.command_frame(&c, unlocked)
        }

        /// The running set, settings included.
        fn running(&self) -> (crate::config::Params, crate::calibration::Settings) {
            let a = &self.target.app;
            let settings = crate::calibration::Settings {
                status_period: a.status_period(),
                watchdog: a.watchdog().limit,
                sample_rate_hz: a.sample_rate_hz(),
            };
            (*a.params(), settings)
        }

        /// The page GET_CAL_PAGE names for the ECU, as XCP reads it.
        fn ecu_page_as_read(&mut self) -> [u32; calibration::SLOTS] {
            let r = self.send(&[0xEA, 0x01, 0x00]);
            assert_eq!(r[0], 0xFF, "GET_CAL_PAGE {r:02X?}");
            match r[3] {
                0 => calibration::working_words(),
                _ => calibration::reference_words(),
            }
        }

        /// The invariant: the running set is what the page GET_CAL_PAGE names decodes to.
        fn assert_runs_the_named_page(&mut self) {
            let words = self.ecu_page_as_read();
            let (prepared, settings) = calibration::decode_page(&words).expect("valid page");
            assert_eq!(self.running(), (*prepared.params(), settings));
        }

        /// Back to the defaults on both pages for the other tests.
        fn restore(&mut self) {
            let app = Application::new(256).expect("app");
            app.mirror_to_working_page();
        }
    }

    /// Issue 19, point 2: with the ECU on the reference page, a Command frame (even a
    /// refused one) must not overwrite the working page with the running set.
    #[test]
    fn a_command_frame_leaves_the_prepared_working_page_alone() {
        let _turn = test_lock();
        let mut s = Session::new();
        s.connect_and_unlock();
        assert_eq!(s.download_f32(at("tyre_stiffness_0"), 3.0e5), [0xFF]);
        assert_eq!(s.send(&[0xEB, 0x01, 0x00, 0x01]), [0xFF]);
        assert_eq!(s.command(Command::ClearFault), code::WRONG_MODE);
        assert_eq!(s.command(Command::Start), code::OK);
        assert_eq!(s.command(Command::Stop), code::OK);
        assert_eq!(
            f32::from_bits(calibration::working_words()[usize::from(index("tyre_stiffness_0"))]),
            3.0e5
        );
        s.assert_runs_the_named_page();
        // Back on the working page, the prepared value runs.
        assert_eq!(s.send(&[0xEB, 0x01, 0x00, 0x00]), [0xFF]);
        assert_eq!(s.target.app.params().tyre.tyre[0].stiffness, 3.0e5);
        s.assert_runs_the_named_page();
        s.restore();
    }

    /// Issue 19, point 3: a Command-frame parameter write while the ECU runs the reference
    /// page must not run a set that is on neither page: it is refused and changes nothing.
    #[test]
    fn a_command_parameter_write_on_the_reference_page_is_refused() {
        let _turn = test_lock();
        let mut s = Session::new();
        s.connect_and_unlock();
        assert_eq!(s.send(&[0xEB, 0x01, 0x00, 0x01]), [0xFF]);
        let before = (s.running(), calibration::working_words());
        let write = Command::SetParam {
            index: index("tyre_damping_0"),
            value: 900.0,
        };
        assert_eq!(s.command(write), code::REFERENCE_PAGE);
        let status = Command::SetParam {
            index: SLOT_STATUS_PERIOD as u16,
            value: 20.0,
        };
        assert_eq!(s.command(status), code::REFERENCE_PAGE);
        assert_eq!((s.running(), calibration::working_words()), before);
        s.assert_runs_the_named_page();
        // On the working page the same write is one transaction on that page.
        assert_eq!(s.send(&[0xEB, 0x01, 0x00, 0x00]), [0xFF]);
        assert_eq!(s.command(write), code::OK);
        assert_eq!(
            f32::from_bits(calibration::working_words()[usize::from(index("tyre_damping_0"))]),
            900.0
        );
        s.assert_runs_the_named_page();
        s.restore();
    }

    /// Issue 19, point 4: a refused page switch or page copy changes nothing (the QEMU
    /// build's watchdog switched off cannot be switched back on by a page; only that build
    /// has the off state, so CI also runs these tests with `--features qemu`).
    #[cfg(feature = "qemu")]
    #[test]
    fn a_refused_page_switch_or_copy_changes_nothing() {
        let _turn = test_lock();
        let mut s = Session::new();
        s.target.app.switch_watchdog_off();
        s.target.app.mirror_to_working_page();
        s.connect_and_unlock();
        assert_eq!(s.download_f32(at("tyre_stiffness_0"), 3.0e5), [0xFF]);
        let before = (s.running(), calibration::working_words());
        // SET_CAL_PAGE, ECU → reference (its watchdog slot says N): refused.
        assert_eq!(s.send(&[0xEB, 0x01, 0x00, 0x01])[0], 0xFE);
        assert_eq!(s.send(&[0xEA, 0x01, 0x00])[3], 0, "GET_CAL_PAGE");
        assert_eq!((s.running(), calibration::working_words()), before);
        s.assert_runs_the_named_page();
        // COPY_CAL_PAGE reference → working: refused alike.
        assert_eq!(s.send(&[0xE4, 0, 1, 0, 0])[0], 0xFE);
        assert_eq!((s.running(), calibration::working_words()), before);
        s.assert_runs_the_named_page();
        s.restore();
    }

    /// Issue 19, point 5: with XCP locked, a Command frame does not change what seed & key
    /// protects; the changes that are safe without it still go through.
    #[test]
    fn seed_and_key_protects_command_frame_writes_too() {
        let _turn = test_lock();
        let mut s = Session::new();
        let before = s.running();
        let stiffness = Command::SetParam {
            index: index("tyre_stiffness_0"),
            value: 3.0e5,
        };
        // Not connected, then connected but locked.
        assert_eq!(s.command(stiffness), code::LOCKED);
        assert_eq!(s.send(&[0xFF, 0x00])[0], 0xFF);
        assert_eq!(s.command(stiffness), code::LOCKED);
        // A longer watchdog is not safe either; a shorter one and the status period are.
        let longer = Command::SetWatchdog {
            seconds: 2.0 * f32::from(crate::config::WATCHDOG_SAMPLES) / 2000.0,
        };
        assert_eq!(s.command(longer), code::LOCKED);
        assert_eq!(s.running(), before);
        assert_eq!(s.command(Command::SetWatchdog { seconds: 0.002 }), code::OK);
        assert_eq!(s.target.app.watchdog().limit, 4);
        let status = Command::SetParam {
            index: SLOT_STATUS_PERIOD as u16,
            value: 20.0,
        };
        assert_eq!(s.command(status), code::OK);
        s.assert_runs_the_named_page();
        // Unlocked: the write is made, on the working page.
        s.connect_and_unlock();
        assert_eq!(s.command(stiffness), code::OK);
        assert_eq!(s.target.app.params().tyre.tyre[0].stiffness, 3.0e5);
        s.assert_runs_the_named_page();
        // A disconnect locks it again.
        assert_eq!(s.send(&[0xFE]), [0xFF]);
        assert_eq!(
            s.command(Command::SetParam {
                index: index("tyre_stiffness_0"),
                value: 2.0e5
            }),
            code::LOCKED
        );
        s.restore();
    }

    /// Issue 19, point 7, through the application logic: STORE_CAL_REQ is refused while
    /// the controller runs, taken in Idle, and the XCP task's store
    /// ([`crate::store::store_working`]) keeps the working page; after a power cycle the
    /// board boots that page (working page, running set, GET_CAL_PAGE and the status frame's
    /// source agree), and a flash whose record is not this build's boots the defaults and
    /// says so.
    #[test]
    fn a_stored_calibration_survives_a_power_cycle() {
        use crate::calibration::Source;
        use crate::store::{self, complete, RamFlash, Store};
        let _turn = test_lock();
        let mut flash = Store::new(RamFlash::<4, 4096>::new(), 0..16384).expect("range");
        let mut s = Session::new();
        assert_eq!(
            complete(store::boot(
                &mut s.target.app,
                &mut flash,
                crate::calibration::host_candidate()
            )),
            Some(Source::Defaults)
        );
        s.connect_and_unlock();
        assert_eq!(s.download_f32(at("tyre_stiffness_0"), 3.0e5), [0xFF]);
        assert_eq!(
            s.download_f32(CAL + 4 * calibration::SLOT_STATUS_PERIOD as u32, 20.0),
            [0xFF]
        );
        // Running: refused, nothing pending.
        assert_eq!(s.command(Command::Start), code::OK);
        assert_eq!(s.send(&[0xF9, 0x01, 0, 0]), [0xFE, 0x33]);
        assert!(!s.slave.store_pending());
        assert_eq!(
            calibration::measurement_words()[meas::CAL_STORE_ERROR],
            store::StoreError::Running as u32
        );
        // Idle: taken, pending until the store is done, then EV_STORE_CAL.
        assert_eq!(s.command(Command::Stop), code::OK);
        assert_eq!(s.send(&[0xF9, 0x01, 0, 0]), [0xFF]);
        assert_eq!(s.send(&[0xFD])[1] & 0x01, 0x01, "GET_STATUS: store pending");
        let stores = calibration::measurement_words()[meas::CAL_STORES];
        let result = complete(store::store_working(&mut flash, |w| {
            calibration::decode_page(w).is_ok()
        }));
        assert_eq!(result, Some(Ok(())));
        s.slave.store_finished(true, &mut s.out);
        assert_eq!(s.out.iter().next(), Some(&[0xFD, 0x03][..]));
        assert_eq!(s.send(&[0xFD])[1] & 0x01, 0, "GET_STATUS: done");
        let w = calibration::measurement_words();
        assert_eq!(
            (w[meas::CAL_STORES], w[meas::CAL_STORE_ERROR]),
            (stores + 1, 0)
        );
        let stored = calibration::working_words();

        // Power cycle: RAM back to the build's state, a new application, the same flash.
        s.restore();
        let mut s = Session::new();
        assert_eq!(
            complete(store::boot(
                &mut s.target.app,
                &mut flash,
                crate::calibration::host_candidate()
            )),
            Some(Source::Stored)
        );
        assert_eq!(calibration::working_words(), stored);
        assert_eq!(s.target.app.params().tyre.tyre[0].stiffness, 3.0e5);
        assert_eq!(s.target.app.status_period(), 20);
        assert_eq!(
            s.target.app.status().calibration_source,
            Source::Stored as u8
        );
        s.connect_and_unlock();
        s.assert_runs_the_named_page();
        // The status frame says so.
        let frame = crate::link::status_frame(&s.target.app.status());
        let Ok(mil_frames::Message::Status(st)) = mil_frames::decode(&crate::link::LAYOUT, &frame)
        else {
            panic!("status frame");
        };
        assert_eq!(st.calibration_source, Source::Stored as u8);

        // A record of another layout (a flash written by another firmware): the defaults,
        // and the source says the stored page was refused.
        let mut other = Store::new(RamFlash::<4, 4096>::new(), 0..16384).expect("range");
        let mut record = store::encode(&stored);
        record[4] ^= 0x5A;
        let mut buffer = [0u8; store::RECORD_BYTES + 64];
        let mut map = sequential_storage::map::MapStorage::<u8, _, _>::new(
            other.into_flash(),
            sequential_storage::map::MapConfig::new(0..16384),
            sequential_storage::cache::Cache::new_uncached(),
        );
        complete(map.store_item(&mut buffer, &0u8, &&record[..]))
            .expect("completes")
            .expect("stored");
        other = Store::new(map.destroy().0, 0..16384).expect("range");
        s.restore();
        let mut s = Session::new();
        assert_eq!(
            complete(store::boot(
                &mut s.target.app,
                &mut other,
                crate::calibration::host_candidate()
            )),
            Some(Source::Refused)
        );
        assert_eq!(s.target.app.params().tyre.tyre[0].stiffness, TYRE.stiffness);
        assert_eq!(
            calibration::measurement_words()[meas::CAL_SOURCE],
            Source::Refused as u32
        );
        s.restore();
    }

    #[test]
    fn daq_reads_the_step_copy_and_packets_become_response_frames() {
        let _turn = test_lock();
        let mut app = Application::new(256).expect("app");
        let m = crate::application::Measurement {
            channel: 0,
            position_m: -1.0e-3,
            road_m: 0.0,
            counter: 0,
        };
        app.on_measurement(&m).expect("step");
        app.record_step();
        let sample = StepSample::take();
        assert_eq!(sample.words[meas::STEPS], 1);
        assert_eq!(sample.time_us, STEP_PERIOD_US);
        // The copy stays what it was when the block changes (the next step).
        app.on_measurement(&crate::application::Measurement { counter: 1, ..m })
            .expect("step");
        app.record_step();
        let mut out = [0u8; 6];
        sample.read_measurement(4 * meas::STEPS, &mut out);
        assert_eq!(out, [1, 0, 0, 0, 0, 0], "bytes past the block read 0");
        let mut pos = [0u8; 4];
        sample.read_measurement(4 * meas::POSITION, &mut pos);
        assert_eq!(f32::from_le_bytes(pos), -1.0e-3);
        let mut k = [0u8; 4];
        sample.read_calibration(
            Page::Reference,
            (at("tyre_stiffness_0") - CAL) as usize,
            &mut k,
        );
        assert_eq!(f32::from_le_bytes(k), TYRE.stiffness);
        // The platform's clock is the same step time.
        let platform = StepPlatform::new(|| 7);
        assert_eq!(platform.now_us(), 2 * STEP_PERIOD_US);
        // Packets: DLC = length, on the response ID; empty or over-long ones are not frames.
        let f = response_frame(&[0xFF, 1, 2]).expect("frame");
        assert_eq!((f.id, f.payload()), (XCP_RESPONSE_ID, &[0xFF, 1, 2][..]));
        assert!(response_frame(&[]).is_none());
        assert!(response_frame(&[0; 9]).is_none());
    }

    #[test]
    fn calibration_outcomes_are_counted_in_the_measurement_block() {
        let _turn = test_lock();
        let mut s = Session::new();
        s.connect_and_unlock();
        let changes = calibration::measurement_words()[meas::CAL_CHANGES];
        assert_eq!(s.download_f32(at("tyre_damping_0"), 700.0), [0xFF]);
        assert_eq!(
            calibration::measurement_words()[meas::CAL_CHANGES],
            changes + 1
        );
        assert_eq!(
            s.download_f32(at("tyre_damping_0"), f32::INFINITY),
            [0xFE, 0x22]
        );
        let w = calibration::measurement_words();
        assert_eq!(w[meas::CAL_CHANGES], changes + 1);
        assert_eq!(w[meas::CAL_REJECTION], u32::from(code::NOT_FINITE));
        assert_eq!(s.send(&[0xE4, 0, 1, 0, 0]), [0xFF]);
    }

    #[test]
    fn a_whole_filter_goes_in_as_one_block_download() {
        let _turn = test_lock();
        let mut s = Session::new();
        s.connect_and_unlock();
        // Sections = 1 and section 0 of channel 0 (6 slots, 24 bytes) in one block:
        // DOWNLOAD with 6 bytes, then DOWNLOAD_NEXT frames.
        let vals = [1.0f32, 0.0, 0.0, 0.01, 0.2, 0.01];
        let bytes: Vec<u8> = vals.iter().flat_map(|v| v.to_le_bytes()).collect();
        s.set_mta(at("filter_sections_0"));
        let mut first = vec![0xF0, 24];
        first.extend_from_slice(&bytes[..6]);
        assert!(s.send(&first).is_empty(), "block start: no answer");
        let mut at = 6;
        let mut answer = Vec::new();
        while at < bytes.len() {
            let n = (bytes.len() - at).min(6);
            let mut next = vec![0xEF, (bytes.len() - at) as u8];
            next.extend_from_slice(&bytes[at..at + n]);
            answer = s.send(&next);
            at += n;
        }
        assert_eq!(answer, [0xFF]);
        let f = s.target.app.params().filter[0];
        assert_eq!((f.sections, f.section[0].alpha1), (1, 0.2));
        assert_eq!(s.send(&[0xE4, 0, 1, 0, 0]), [0xFF]);
        assert_eq!(s.target.app.params().filter[0].sections, 0);
    }

    /// A command for the fuzzer: mostly well-formed memory and page commands aimed at the
    /// calibration page, its edges and beyond, with random values (NaN, huge, negative),
    /// and random bytes.
    fn command() -> impl proptest::strategy::Strategy<Value = Vec<u8>> {
        use proptest::prelude::*;
        let address = prop_oneof![
            (0u32..PAGE_BYTES as u32 + 8).prop_map(|o| CAL.wrapping_add(o)),
            (0u32..MEASUREMENT_BYTES as u32 + 8).prop_map(|o| MEAS.wrapping_add(o)),
            any::<u32>(),
            Just(CAL.wrapping_sub(4)),
        ];
        let value = prop_oneof![
            any::<f32>(),
            -1.0e6f32..1.0e6,
            0.0f32..4.0,
            Just(f32::NAN),
            Just(1.0),
            Just(0.0),
        ];
        prop_oneof![
            (address.clone(), 1u8..=6, value.clone()).prop_map(|(a, n, v)| {
                let a = a.to_le_bytes();
                let v = v.to_le_bytes();
                let mut c = vec![0xF6, 0, 0, 0, a[0], a[1], a[2], a[3], 0xF0, n];
                c.extend_from_slice(&v);
                c.extend_from_slice(&[v[0], v[1]]);
                c
            }),
            (address, 1u8..=7).prop_map(|(a, n)| {
                let a = a.to_le_bytes();
                vec![0xF4, n, 0, 0, a[0], a[1], a[2], a[3]]
            }),
            (0u8..=0x83, 0u8..3).prop_map(|(mode, page)| vec![0xEB, mode, 0, page]),
            Just(vec![0xE4, 0, 1, 0, 0]),
            (1u8..=6, proptest::collection::vec(any::<u8>(), 6)).prop_map(|(n, d)| {
                let mut c = vec![0xEF, n];
                c.extend(d);
                c
            }),
            proptest::collection::vec(any::<u8>(), 0..9),
        ]
    }

    /// One step of a mixed session: an XCP command, a Command frame, or the XCP session
    /// ending and starting again locked or unlocked.
    #[derive(Clone, Debug)]
    enum Step {
        Xcp(Vec<u8>),
        Frame(Command),
        Reconnect { unlock: bool },
    }

    fn step() -> impl proptest::strategy::Strategy<Value = Step> {
        use proptest::prelude::*;
        let index = prop_oneof![0u16..31, Just(100u16), Just(101), any::<u16>()];
        let value = prop_oneof![
            any::<f32>(),
            0.0f32..1.0e6,
            -2.0e4f32..2.0e4,
            0.0f32..20.0,
            Just(f32::NAN),
            Just(0.0),
        ];
        prop_oneof![
            4 => command().prop_map(Step::Xcp),
            // Page switches and copies, often.
            2 => (0u8..=0x83, 0u8..2).prop_map(|(mode, page)| Step::Xcp(vec![0xEB, mode, 0, page])),
            1 => Just(Step::Xcp(vec![0xE4, 0, 1, 0, 0])),
            4 => (index, value).prop_map(|(index, value)| Step::Frame(Command::SetParam { index, value })),
            1 => prop_oneof![-1.0f32..6.0, Just(f32::NAN)]
                .prop_map(|seconds| Step::Frame(Command::SetWatchdog { seconds })),
            1 => prop_oneof![Just(Command::Start), Just(Command::Stop), Just(Command::ClearFault)]
                .prop_map(Step::Frame),
            1 => any::<bool>().prop_map(|unlock| Step::Reconnect { unlock }),
        ]
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig { cases: 300, ..Default::default() })]

        /// Command frames interleaved with XCP page operations and sessions that lock and
        /// unlock: after every step the running set (parameters and settings) is what the
        /// page GET_CAL_PAGE names decodes to, and a Command-frame write that needs the
        /// unlock changes nothing while the session is locked.
        #[test]
        fn command_frames_and_xcp_pages_keep_one_source_of_truth(
            steps in proptest::collection::vec(step(), 1..50)
        ) {
            let _turn = test_lock();
            let mut s = Session::new();
            s.connect_and_unlock();
            for st in &steps {
                let before = (s.running(), calibration::working_words());
                match st {
                    Step::Xcp(c) => {
                        s.handle_parts(c, |_| ());
                    }
                    Step::Frame(c) => {
                        let locked = !s.cal_unlocked();
                        let result = s.command(*c);
                        let slot = match *c {
                            Command::SetParam { index, .. } => calibration::slot_of(index),
                            Command::SetWatchdog { .. } => Some(calibration::SLOT_WATCHDOG),
                            _ => None,
                        };
                        let needs_unlock = match (*c, slot) {
                            (Command::SetParam { value, .. }, Some(slot)) => {
                                !safe_without_unlock(slot, value, before.0 .1.watchdog)
                            }
                            _ => false,
                        };
                        if locked && needs_unlock {
                            proptest::prop_assert_ne!(result, code::OK);
                            proptest::prop_assert_eq!(&(s.running(), calibration::working_words()), &before);
                        }
                        if result != code::OK && slot.is_some() {
                            proptest::prop_assert_eq!(&(s.running(), calibration::working_words()), &before);
                        }
                    }
                    Step::Reconnect { unlock } => {
                        s.send(&[0xFE]);
                        if *unlock {
                            s.connect_and_unlock();
                        } else {
                            proptest::prop_assert_eq!(s.send(&[0xFF, 0x00])[0], 0xFF);
                        }
                    }
                }
                if !s.slave.connected() {
                    s.connect_and_unlock();
                }
                proptest::prop_assert_eq!(s.slave.ecu_page(), s.target.ecu_page());
                let words = s.ecu_page_as_read();
                let (prepared, settings) = calibration::decode_page(&words).expect("valid page");
                proptest::prop_assert_eq!(s.running(), (*prepared.params(), settings));
            }
            s.send(&[0xFE]);
            s.restore();
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig { cases: 300, ..Default::default() })]

        /// Random XCP command sequences through the slave into the running application:
        /// nothing panics, the running parameters are always a valid set equal to what the
        /// ECU page holds, the measurement block's signals are never written (only the
        /// calibration counters move), and every answer is well-formed.
        #[test]
        fn random_xcp_sessions_only_ever_run_validated_parameters(
            commands in proptest::collection::vec(command(), 1..40)
        ) {
            let _turn = test_lock();
            let mut s = Session::new();
            s.connect_and_unlock();
            let meas_before = calibration::measurement_words();
            for c in &commands {
                let mut well_formed = true;
                s.handle_parts(c, |out| {
                    well_formed &= out.iter().all(|r| r.len() <= 8 && matches!(r[0], 0xFF | 0xFE));
                });
                proptest::prop_assert!(well_formed);
                if !s.slave.connected() {
                    s.connect_and_unlock();
                }
                let running = *s.target.app.params();
                proptest::prop_assert!(running.prepare(crate::config::DT).is_ok());
                let page = match s.target.ecu_page() {
                    Page::Working => calibration::working_words(),
                    Page::Reference => calibration::reference_words(),
                };
                let (expected, _) = calibration::decode_page(&page).expect("the ECU page is valid");
                proptest::prop_assert_eq!(expected.params(), &running);
            }
            proptest::prop_assert_eq!(
                &calibration::measurement_words()[..meas::CAL_CHANGES],
                &meas_before[..meas::CAL_CHANGES]
            );
            // Back to the defaults for the other tests.
            s.send(&[0xEB, 0x83, 0, 0]);
            s.send(&[0xE4, 0, 1, 0, 0]);
        }
    }
}
