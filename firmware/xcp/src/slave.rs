//! The slave: session state and the command dispatcher. The commands themselves live in
//! [`crate::commands`], one module per group.

use crate::access::Mta;
use crate::config::{ConfigError, SlaveConfig};
use crate::daq::Daq;
use crate::key::SEED_LEN;
use crate::memory::{Calibration, Memory, Page, Platform, Rejected};
use crate::pages::Pages;
use crate::protocol::{cmd, resource, ErrorCode, MAX_BLOCK_BYTES, MAX_CTO};
use crate::response::Responses;
use crate::wire::{CmdResult, Failure};

/// A seed handed out by GET_SEED, waiting for its UNLOCK (one try per seed).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct PendingSeed {
    pub resource: u8,
    pub seed: [u8; SEED_LEN],
}

/// A DOWNLOAD block (master block mode) being received; written as one piece when its last
/// byte arrives.
#[derive(Clone, Debug)]
pub(crate) struct Block {
    /// Address of the first byte (the MTA at DOWNLOAD).
    pub addr: u32,
    /// Offset in the calibration region (checked at DOWNLOAD for the whole block).
    pub offset: u32,
    /// Block length.
    pub total: u8,
    /// Bytes received so far.
    pub received: u8,
    pub data: [u8; MAX_BLOCK_BYTES],
}

/// The XCP slave (see the crate documentation).
///
/// On the board, [`Slave::handle`] (CAN receive) and [`Slave::sample_daq`] (control step)
/// run in different contexts: share the slave through a critical-section mutex.
#[derive(Clone, Debug)]
pub struct Slave {
    pub(crate) config: SlaveConfig,
    pub(crate) connected: bool,
    /// Resource bits still protected.
    pub(crate) protected: u8,
    pub(crate) seed: Option<PendingSeed>,
    pub(crate) seed_counter: u32,
    pub(crate) mta: Mta,
    pub(crate) block: Option<Block>,
    pub(crate) pages: Pages,
    pub(crate) daq: Daq,
    pub(crate) last_rejection: Option<Rejected>,
    /// A calibration store was requested (SET_REQUEST) and is not done yet.
    pub(crate) store_pending: bool,
}

impl Slave {
    /// A disconnected slave.
    ///
    /// # Errors
    /// The configuration's problem ([`SlaveConfig::validate`]).
    pub fn new(config: SlaveConfig) -> Result<Self, ConfigError> {
        config.validate()?;
        Ok(Self {
            config,
            connected: false,
            protected: resource::OFFERED,
            seed: None,
            seed_counter: 0,
            mta: Mta::Address(0),
            block: None,
            pages: Pages::new(),
            daq: Daq::new(),
            last_rejection: None,
            store_pending: false,
        })
    }

    /// The configuration.
    #[must_use]
    pub const fn config(&self) -> &SlaveConfig {
        &self.config
    }

    /// Whether a master is connected.
    #[must_use]
    pub const fn connected(&self) -> bool {
        self.connected
    }

    /// Sets the cycle of event channel 0 (µs; 0 = not cyclic) to what the application runs
    /// now (its sample rate may change while the slave lives): GET_DAQ_EVENT_INFO reports it.
    pub fn set_event_period_us(&mut self, period_us: u32) {
        self.config.event_period_us = period_us;
    }

    /// Whether at least one DAQ list is running.
    #[must_use]
    pub fn daq_running(&self) -> bool {
        self.daq.running()
    }

    /// Resource protection mask (bit 0 CAL/PAG, bit 2 DAQ; 1 = still locked).
    #[must_use]
    pub const fn protection(&self) -> u8 {
        self.protected
    }

    /// Whether `resource` (a bit of [`crate::protocol::resource`]) is unlocked: a session is
    /// connected and seed & key opened it (a disconnect locks every resource again).
    #[must_use]
    pub const fn unlocked(&self, resource: u8) -> bool {
        self.protected & resource == 0
    }

    /// The page the controller should run with (set by SET_CAL_PAGE after the application
    /// accepted it through [`Calibration::select_ecu_page`]).
    #[must_use]
    pub const fn ecu_page(&self) -> Page {
        self.pages.ecu
    }

    /// The page XCP reads and writes.
    #[must_use]
    pub const fn xcp_page(&self) -> Page {
        self.pages.xcp
    }

    /// The application's last refusal of a calibration change (kept until the next refusal;
    /// for the firmware's status field, see [`Rejected::code`]).
    #[must_use]
    pub const fn last_rejection(&self) -> Option<Rejected> {
        self.last_rejection
    }

    /// Whether a calibration store was requested (SET_REQUEST STORE_CAL_REQ) and is not done
    /// yet: the application stores the working page, then calls [`Slave::store_finished`].
    #[must_use]
    pub const fn store_pending(&self) -> bool {
        self.store_pending
    }

    /// The requested store is done (`stored`: it went through): GET_STATUS no longer says
    /// pending, and `out` is set to the EV_STORE_CAL event packet `FD 03` to send when it
    /// went through (nothing otherwise: the master sees the pending bit clear without the
    /// event and reads the reason from the application's measurements).
    pub fn store_finished(&mut self, stored: bool, out: &mut Responses) {
        self.store_pending = false;
        out.clear();
        if stored {
            out.push(&[crate::protocol::pid::EV, crate::protocol::event::STORE_CAL]);
        }
    }

    /// End the session as DISCONNECT does (e.g. on CAN bus-off): DAQ stopped and freed,
    /// resources locked again, pending seed and DOWNLOAD block dropped. Pages are kept.
    pub fn disconnect(&mut self) {
        self.connected = false;
        self.reset_session();
    }

    pub(crate) fn reset_session(&mut self) {
        self.protected = resource::OFFERED;
        self.seed = None;
        self.mta = Mta::Address(0);
        self.block = None;
        self.daq.free();
    }

    /// Handle one received command packet (`cto`, the CAN frame's data) and put the answer
    /// into `out` (cleared first): usually one frame, several for an UPLOAD of more than 7
    /// bytes, none for a command that is not answered (anything but CONNECT while
    /// disconnected, and DOWNLOAD / DOWNLOAD_NEXT frames before the last of a block).
    ///
    /// Never panics; every input is untrusted.
    pub fn handle<T, P>(
        &mut self,
        cto: &[u8],
        target: &mut T,
        platform: &mut P,
        out: &mut Responses,
    ) where
        T: Memory + Calibration,
        P: Platform,
    {
        out.clear();
        let Some(&command) = cto.first() else {
            if self.connected {
                out.set_error(ErrorCode::CmdSyntax, None);
            }
            return;
        };
        if !self.connected && command != cmd::CONNECT {
            return;
        }
        if cto.len() > MAX_CTO {
            if self.connected {
                out.set_error(ErrorCode::CmdSyntax, None);
            }
            return;
        }
        // Anything but DOWNLOAD_NEXT ends a pending block; a new DOWNLOAD in the middle of a
        // block is a sequence error (nothing is written), see `commands::memory`.
        let interrupted = command != cmd::DOWNLOAD_NEXT && self.block.take().is_some();
        let result = if interrupted && command == cmd::DOWNLOAD {
            Err(Failure::from(ErrorCode::Sequence))
        } else {
            self.dispatch(command, cto, target, platform, out)
        };
        if let Err(failure) = result {
            out.set_error(failure.code, failure.detail);
        }
    }

    fn dispatch<T, P>(
        &mut self,
        command: u8,
        cto: &[u8],
        target: &mut T,
        platform: &mut P,
        out: &mut Responses,
    ) -> CmdResult
    where
        T: Memory + Calibration,
        P: Platform,
    {
        match command {
            cmd::CONNECT => self.connect(cto, out),
            cmd::DISCONNECT => self.cmd_disconnect(out),
            cmd::GET_STATUS => self.get_status(out),
            cmd::SYNCH => Err(ErrorCode::CmdSynch.into()),
            cmd::GET_COMM_MODE_INFO => self.get_comm_mode_info(out),
            cmd::GET_ID => self.get_id(cto, out),
            cmd::SET_REQUEST => self.set_request(cto, target, out),
            cmd::GET_SEED => self.get_seed(cto, platform, out),
            cmd::UNLOCK => self.unlock(cto, out),
            cmd::SET_MTA => self.set_mta(cto, out),
            cmd::UPLOAD => self.upload(cto, target, out),
            cmd::SHORT_UPLOAD => self.short_upload(cto, target, out),
            cmd::DOWNLOAD => self.download(cto, target, out),
            cmd::DOWNLOAD_NEXT => self.download_next(cto, target, out),
            cmd::SET_CAL_PAGE => self.set_cal_page(cto, target, out),
            cmd::GET_CAL_PAGE => self.get_cal_page(cto, out),
            cmd::GET_PAG_PROCESSOR_INFO => self.get_pag_processor_info(out),
            cmd::GET_SEGMENT_INFO => self.get_segment_info(cto, out),
            cmd::GET_PAGE_INFO => self.get_page_info(cto, out),
            cmd::COPY_CAL_PAGE => self.copy_cal_page(cto, target, out),
            cmd::FREE_DAQ => self.free_daq(out),
            cmd::ALLOC_DAQ => self.alloc_daq(cto, out),
            cmd::ALLOC_ODT => self.alloc_odt(cto, out),
            cmd::ALLOC_ODT_ENTRY => self.alloc_odt_entry(cto, out),
            cmd::SET_DAQ_PTR => self.set_daq_ptr(cto, out),
            cmd::WRITE_DAQ => self.write_daq(cto, out),
            cmd::SET_DAQ_LIST_MODE => self.set_daq_list_mode(cto, out),
            cmd::GET_DAQ_LIST_MODE => self.get_daq_list_mode(cto, out),
            cmd::START_STOP_DAQ_LIST => self.start_stop_daq_list(cto, out),
            cmd::START_STOP_SYNCH => self.start_stop_synch(cto, out),
            cmd::GET_DAQ_CLOCK => self.get_daq_clock(platform, out),
            cmd::GET_DAQ_PROCESSOR_INFO => self.get_daq_processor_info(out),
            cmd::GET_DAQ_RESOLUTION_INFO => self.get_daq_resolution_info(out),
            cmd::GET_DAQ_EVENT_INFO => self.get_daq_event_info(cto, out),
            _ => Err(ErrorCode::CmdUnknown.into()),
        }
    }

    /// `ERR_ACCESS_LOCKED` while `resource` is protected.
    pub(crate) fn require_unlocked(&self, resource: u8) -> CmdResult {
        if self.protected & resource == 0 {
            Ok(())
        } else {
            Err(ErrorCode::AccessLocked.into())
        }
    }

    /// Record an application refusal and turn it into the XCP error.
    pub(crate) fn rejected(&mut self, reason: Rejected) -> Failure {
        self.last_rejection = Some(reason);
        reason.xcp_error().into()
    }

    /// Sample every running DAQ list on `event`: each of its ODTs becomes one DTO frame
    /// (`PID = FIRST_PID + relative ODT`, the 4-byte `timestamp_us` after the PID in the
    /// first ODT of a list with timestamps, then the entries' bytes in order) passed to
    /// `emit`. Entries in the calibration region are read from the ECU page.
    ///
    /// Cost: O(entries of the running lists) reads through `memory`, one 8-byte stack buffer,
    /// no allocation. Never fails: an entry that could not be read (cannot happen, WRITE_DAQ
    /// checked it) gives zeros.
    pub fn sample_daq(
        &mut self,
        event: u16,
        timestamp_us: u32,
        memory: &impl Memory,
        mut emit: impl FnMut(&[u8]),
    ) {
        if !self.connected {
            return;
        }
        self.daq
            .sample(event, timestamp_us, self.pages.ecu, memory, &mut emit);
    }
}
