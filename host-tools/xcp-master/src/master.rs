//! The XCP master: one command at a time over a [`Transport`], with the checks of every
//! response and the errors of [`crate::Error`].

use std::collections::VecDeque;
use std::str::FromStr;
use std::time::{Duration, Instant};

use mil_can::Transport;
use mil_frames::RawFrame;
use mil_xcp::{compute_key, KEY_LEN, SEED_LEN};

use crate::error::{Error, Result, XcpErrorCode};
use crate::protocol::{cmd, command_name, pid, resource, resource_name, ByteOrder};

/// The CAN IDs of XCP on CAN (standard 11-bit): commands master → board, responses and DAQ
/// packets board → master. The board's default is `0x7E0,0x7E1` (its build-time
/// `MIL_XCP_CAN_IDS`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct CanIds {
    /// Master → board (CMD/STIM).
    pub command: u16,
    /// Board → master (RES/ERR/EV/SERV/DAQ).
    pub response: u16,
}

impl Default for CanIds {
    fn default() -> Self {
        Self {
            command: 0x7E0,
            response: 0x7E1,
        }
    }
}

impl CanIds {
    /// Checked IDs: both 11-bit, different.
    ///
    /// # Errors
    /// What is wrong, as a sentence.
    pub fn new(command: u16, response: u16) -> std::result::Result<Self, String> {
        for id in [command, response] {
            if id > 0x7FF {
                return Err(format!("{id:#X} is not a standard 11-bit CAN ID"));
            }
        }
        if command == response {
            return Err("the command and response IDs must differ".into());
        }
        Ok(Self { command, response })
    }
}

impl FromStr for CanIds {
    type Err = String;

    /// `CMD,RES`, each hex with `0x` or decimal (as the firmware's `MIL_XCP_CAN_IDS`).
    fn from_str(text: &str) -> std::result::Result<Self, String> {
        let parse = |t: &str| -> std::result::Result<u16, String> {
            let t = t.trim();
            match t.strip_prefix("0x").or_else(|| t.strip_prefix("0X")) {
                Some(h) => u16::from_str_radix(h, 16),
                None => t.parse::<u16>(),
            }
            .map_err(|e| format!("`{t}` is not a CAN ID ({e})"))
        };
        let mut parts = text.split(',');
        let (Some(c), Some(r), None) = (parts.next(), parts.next(), parts.next()) else {
            return Err(format!("`{text}`: expected CMD,RES (e.g. 0x7E0,0x7E1)"));
        };
        Self::new(parse(c)?, parse(r)?)
    }
}

impl std::fmt::Display for CanIds {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{:#05X},{:#05X}", self.command, self.response)
    }
}

/// What CONNECT (and GET_COMM_MODE_INFO) told of the board.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SessionInfo {
    /// Resources the board offers (bits of [`crate::protocol::resource`]).
    pub resources: u8,
    /// Byte order of multi-byte protocol fields.
    pub byte_order: ByteOrder,
    /// Whether the board answers UPLOAD with several frames (slave block mode).
    pub slave_block_mode: bool,
    /// Largest command/response packet (bytes).
    pub max_cto: u8,
    /// Largest data packet (bytes).
    pub max_dto: u16,
    /// Protocol layer version (major).
    pub protocol_version: u8,
    /// Transport layer version (major).
    pub transport_version: u8,
    /// GET_COMM_MODE_INFO's answer, when the board offers it.
    pub comm_mode: Option<CommModeInfo>,
}

impl SessionInfo {
    /// Data bytes of one DOWNLOAD frame.
    #[must_use]
    pub fn download_bytes_per_frame(&self) -> usize {
        usize::from(self.max_cto.min(8)) - 2
    }

    /// Data bytes of one UPLOAD response frame.
    #[must_use]
    pub fn upload_bytes_per_frame(&self) -> usize {
        usize::from(self.max_cto.min(8)) - 1
    }

    /// The longest write the board validates as one change: one DOWNLOAD, or one master
    /// block (DOWNLOAD + DOWNLOAD_NEXTs, at most 255 bytes) where the board offers it.
    #[must_use]
    pub fn max_one_change(&self) -> usize {
        let per_frame = self.download_bytes_per_frame();
        match self.comm_mode {
            Some(c) if c.master_block_mode => {
                (usize::from(c.max_bs) * per_frame).clamp(per_frame, 255)
            }
            _ => per_frame,
        }
    }
}

/// GET_COMM_MODE_INFO's answer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CommModeInfo {
    /// DOWNLOAD in blocks (DOWNLOAD + DOWNLOAD_NEXT) is offered.
    pub master_block_mode: bool,
    /// Interleaved mode is offered.
    pub interleaved_mode: bool,
    /// Most frames in one block.
    pub max_bs: u8,
    /// Least separation between the frames of a block (units of 100 µs).
    pub min_st: u8,
    /// Queue size of interleaved mode.
    pub queue_size: u8,
    /// The slave driver's version (high nibble major, low nibble minor).
    pub driver_version: u8,
}

/// GET_STATUS's answer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Status {
    /// Session status bits (bit 6: DAQ running).
    pub session_status: u8,
    /// Protected resources (1 = locked; bits of [`crate::protocol::resource`]).
    pub protection: u8,
}

impl Status {
    /// Whether a DAQ list is running.
    #[must_use]
    pub fn daq_running(&self) -> bool {
        self.session_status & crate::protocol::session::DAQ_RUNNING != 0
    }

    /// Whether a calibration store (SET_REQUEST STORE_CAL_REQ) is still pending.
    #[must_use]
    pub fn store_pending(&self) -> bool {
        self.session_status & crate::protocol::session::STORE_CAL_REQ != 0
    }

    /// Whether `resource` still needs seed & key.
    #[must_use]
    pub fn locked(&self, resource: u8) -> bool {
        self.protection & resource != 0
    }
}

/// SET_CAL_PAGE / GET_CAL_PAGE mode bits.
pub mod page_mode {
    /// The page the controller runs with.
    pub const ECU: u8 = 0x01;
    /// The page XCP reads and writes.
    pub const XCP: u8 = 0x02;
    /// All segments.
    pub const ALL: u8 = 0x80;
}

/// The board's working page (RAM, writable).
pub const WORKING_PAGE: u8 = 0;
/// The board's reference page (flash, the build's defaults, read-only).
pub const REFERENCE_PAGE: u8 = 1;

/// GET_DAQ_PROCESSOR_INFO's answer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DaqProcessorInfo {
    /// DAQ_PROPERTIES (bit 0 dynamic, 1 prescaler, 2 resume, 3 bit STIM, 4 timestamps,
    /// 5 PID off, 6–7 overload indication).
    pub properties: u8,
    /// DAQ lists (dynamic configuration: allocated now).
    pub max_daq: u16,
    /// Event channels (0: unknown).
    pub max_event_channel: u16,
    /// Predefined lists.
    pub min_daq: u8,
    /// DAQ_KEY_BYTE (bits 6–7: identification field type; 0 = absolute ODT number).
    pub key_byte: u8,
}

impl DaqProcessorInfo {
    /// Dynamic DAQ configuration.
    #[must_use]
    pub fn dynamic(&self) -> bool {
        self.properties & 0x01 != 0
    }

    /// The board applies a prescaler.
    #[must_use]
    pub fn prescaler_supported(&self) -> bool {
        self.properties & 0x02 != 0
    }

    /// DTOs can carry timestamps.
    #[must_use]
    pub fn timestamp_supported(&self) -> bool {
        self.properties & 0x10 != 0
    }

    /// The identification field is the absolute ODT number (one PID byte).
    #[must_use]
    pub fn absolute_odt_number(&self) -> bool {
        self.key_byte & 0xC0 == 0
    }
}

/// GET_DAQ_RESOLUTION_INFO's answer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DaqResolutionInfo {
    /// Address granularity of ODT entries (bytes).
    pub granularity_odt_entry: u8,
    /// Largest ODT entry (bytes).
    pub max_odt_entry_size: u8,
    /// TIMESTAMP_MODE (bits 0–2 size in bytes, bit 3 fixed, bits 4–7 unit).
    pub timestamp_mode: u8,
    /// Ticks per timestamp unit.
    pub timestamp_ticks: u16,
}

impl DaqResolutionInfo {
    /// Timestamp size in bytes (0: none).
    #[must_use]
    pub fn timestamp_size(&self) -> usize {
        usize::from(self.timestamp_mode & 0x07)
    }

    /// Seconds per timestamp tick, when the unit is known.
    #[must_use]
    pub fn seconds_per_tick(&self) -> Option<f64> {
        crate::protocol::time_unit_seconds(self.timestamp_mode >> 4)
            .map(|unit| unit * f64::from(self.timestamp_ticks.max(1)))
    }
}

/// GET_DAQ_EVENT_INFO's answer, with the event's name.
#[derive(Clone, Debug, PartialEq)]
pub struct EventInfo {
    /// DAQ_EVENT_PROPERTIES.
    pub properties: u8,
    /// Most DAQ lists on this event.
    pub max_daq_list: u8,
    /// The event's name.
    pub name: String,
    /// Its cycle (s), `None` when not cyclic or the unit is unknown.
    pub cycle_s: Option<f64>,
    /// Its priority.
    pub priority: u8,
}

/// Frames the master received and set aside.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Counters {
    /// Frames on other CAN IDs (skipped).
    pub foreign_frames: u64,
    /// EV and SERV packets (skipped).
    pub events: u64,
    /// EV_STORE_CAL events (a calibration store done), counted among `events` too.
    pub store_events: u64,
    /// DTOs while no DAQ session ran, responses nothing waited for, empty frames.
    pub stray: u64,
    /// DTOs dropped because the DAQ queue was full.
    pub dto_overflow: u64,
}

/// Most DTOs kept while a command waits for its response during DAQ.
const DTO_QUEUE: usize = 1 << 20;

/// An XCP master on CAN (see the crate documentation).
pub struct Master<T: Transport> {
    transport: T,
    ids: CanIds,
    timeout: Duration,
    session: Option<SessionInfo>,
    daq_active: bool,
    dtos: VecDeque<Vec<u8>>,
    counters: Counters,
}

impl<T: Transport> std::fmt::Debug for Master<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Master")
            .field("ids", &self.ids)
            .field("timeout", &self.timeout)
            .field("session", &self.session)
            .field("counters", &self.counters)
            .finish_non_exhaustive()
    }
}

impl<T: Transport> Master<T> {
    /// A master on `transport`, not connected yet; `timeout` is how long it waits for each
    /// response.
    pub fn new(transport: T, ids: CanIds, timeout: Duration) -> Self {
        Self {
            transport,
            ids,
            timeout,
            session: None,
            daq_active: false,
            dtos: VecDeque::new(),
            counters: Counters::default(),
        }
    }

    /// The CAN IDs.
    pub fn ids(&self) -> CanIds {
        self.ids
    }

    /// The response timeout.
    pub fn timeout(&self) -> Duration {
        self.timeout
    }

    /// Changes the response timeout.
    pub fn set_timeout(&mut self, timeout: Duration) {
        self.timeout = timeout;
    }

    /// What CONNECT told, while connected.
    pub fn session(&self) -> Option<&SessionInfo> {
        self.session.as_ref()
    }

    /// The frames set aside so far.
    pub fn counters(&self) -> Counters {
        self.counters
    }

    /// The transport.
    pub fn transport_mut(&mut self) -> &mut T {
        &mut self.transport
    }

    /// The transport back (the session is left as it is).
    pub fn into_transport(self) -> T {
        self.transport
    }

    fn info(&self) -> Result<SessionInfo> {
        self.session.ok_or(Error::NotConnected)
    }

    fn order(&self) -> ByteOrder {
        self.session.map_or(ByteOrder::Intel, |s| s.byte_order)
    }

    // ---- frames --------------------------------------------------------------------

    fn send(&mut self, cto: &[u8]) -> Result<()> {
        let frame = RawFrame::from_parts(self.ids.command, cto).ok_or_else(|| {
            Error::Unsupported(format!(
                "a command of {} bytes does not fit a CAN frame",
                cto.len()
            ))
        })?;
        self.transport.send(&frame)?;
        Ok(())
    }

    /// The next frame on the response ID by `deadline`.
    fn next_frame(&mut self, deadline: Instant) -> Result<Option<RawFrame>> {
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return Ok(None);
            }
            match self.transport.recv(left)? {
                Some(f) if f.id == self.ids.response => return Ok(Some(f)),
                Some(_) => self.counters.foreign_frames += 1,
                None => {}
            }
        }
    }

    fn keep_dto(&mut self, payload: &[u8]) {
        if !self.daq_active {
            self.counters.stray += 1;
            return;
        }
        if self.dtos.len() >= DTO_QUEUE {
            self.dtos.pop_front();
            self.counters.dto_overflow += 1;
        }
        self.dtos.push_back(payload.to_vec());
    }

    /// The response to the command `code` just sent (the whole frame, PID `FF` first).
    fn response(&mut self, code: u8) -> Result<Vec<u8>> {
        let deadline = Instant::now() + self.timeout;
        loop {
            let Some(frame) = self.next_frame(deadline)? else {
                return Err(Error::Timeout {
                    command: command_name(code),
                    timeout: self.timeout,
                });
            };
            let p = frame.payload();
            match p.first().copied() {
                Some(pid::RES) => return Ok(p.to_vec()),
                Some(pid::ERR) => return Err(self.negative(code, p)),
                Some(pid::EV | pid::SERV) => {
                    self.counters.events += 1;
                    if p == [pid::EV, crate::protocol::event::STORE_CAL] {
                        self.counters.store_events += 1;
                    }
                }
                Some(_) => self.keep_dto(p),
                None => self.counters.stray += 1,
            }
        }
    }

    fn negative(&mut self, code: u8, p: &[u8]) -> Error {
        let Some(&err) = p.get(1) else {
            return Error::Unexpected {
                command: command_name(code),
                bytes: p.to_vec(),
                why: "error packet without an error code".into(),
            };
        };
        Error::Negative {
            command: command_name(code),
            command_code: code,
            code: XcpErrorCode(err),
            detail: p.get(2).copied(),
        }
    }

    /// Responses still arriving after a failed block (the slave answers every frame after
    /// the one it refused): read until the line is quiet.
    fn drain(&mut self) {
        let quiet = self.timeout.min(Duration::from_millis(100));
        while let Ok(Some(f)) = self.next_frame(Instant::now() + quiet) {
            if f.payload().first().is_some_and(|&p| p < pid::SERV) {
                self.keep_dto(f.payload());
            } else {
                self.counters.stray += 1;
            }
        }
    }

    /// Sends `cto` and returns its positive response (the frame, `FF` first), at least
    /// `min_len` bytes long.
    fn transact(&mut self, cto: &[u8], min_len: usize) -> Result<Vec<u8>> {
        let code = cto.first().copied().unwrap_or(0);
        if code != cmd::CONNECT {
            self.info()?;
        }
        self.send(cto)?;
        let r = self.response(code)?;
        if r.len() < min_len {
            return Err(Error::Unexpected {
                command: command_name(code),
                bytes: r,
                why: format!("shorter than the {min_len} bytes expected"),
            });
        }
        Ok(r)
    }

    // ---- session -------------------------------------------------------------------

    /// CONNECT (normal mode), then GET_COMM_MODE_INFO where offered. Checks that the board
    /// speaks byte-granular XCP in CAN-sized packets (MAX_CTO 8, MAX_DTO 2..=8). A CONNECT
    /// while connected starts a fresh session (DAQ stopped and freed, resources locked).
    ///
    /// # Errors
    /// Timeout, a negative or malformed response, or a board this master cannot serve.
    pub fn connect(&mut self) -> Result<SessionInfo> {
        self.session = None;
        self.daq_active = false;
        self.dtos.clear();
        let r = self.transact(&[cmd::CONNECT, 0], 8)?;
        let basic = r[2];
        let byte_order = if basic & 0x01 == 0 {
            ByteOrder::Intel
        } else {
            ByteOrder::Motorola
        };
        let unexpected = |why: String| Error::Unexpected {
            command: "CONNECT",
            bytes: r.clone(),
            why,
        };
        if basic & 0x06 != 0 {
            return Err(unexpected(
                "address granularity is not BYTE; this master addresses bytes".into(),
            ));
        }
        let max_cto = r[3];
        let max_dto = byte_order.u16([r[4], r[5]]);
        if max_cto < 8 {
            return Err(unexpected(format!(
                "MAX_CTO {max_cto}: this master sends commands of up to 8 bytes"
            )));
        }
        if !(2..=8).contains(&max_dto) {
            return Err(unexpected(format!(
                "MAX_DTO {max_dto}: a classic CAN frame carries 2..=8 bytes"
            )));
        }
        let mut info = SessionInfo {
            resources: r[1],
            byte_order,
            slave_block_mode: basic & 0x40 != 0,
            max_cto: max_cto.min(8),
            max_dto,
            protocol_version: r[6],
            transport_version: r[7],
            comm_mode: None,
        };
        self.session = Some(info);
        if basic & 0x80 != 0 {
            let c = self.transact(&[cmd::GET_COMM_MODE_INFO], 8)?;
            info.comm_mode = Some(CommModeInfo {
                master_block_mode: c[2] & 0x01 != 0,
                interleaved_mode: c[2] & 0x02 != 0,
                max_bs: c[4],
                min_st: c[5],
                queue_size: c[6],
                driver_version: c[7],
            });
            self.session = Some(info);
        }
        Ok(info)
    }

    /// DISCONNECT (nothing to do when not connected). The board stops and frees DAQ and
    /// locks its resources again.
    ///
    /// # Errors
    /// Timeout or a negative response (the master counts itself disconnected either way).
    pub fn disconnect(&mut self) -> Result<()> {
        if self.session.is_none() {
            return Ok(());
        }
        let result = self.transact(&[cmd::DISCONNECT], 1).map(|_| ());
        self.session = None;
        self.daq_active = false;
        self.dtos.clear();
        result
    }

    /// GET_STATUS.
    ///
    /// # Errors
    /// Not connected, timeout, a negative or malformed response.
    pub fn get_status(&mut self) -> Result<Status> {
        let r = self.transact(&[cmd::GET_STATUS], 3)?;
        Ok(Status {
            session_status: r[1],
            protection: r[2],
        })
    }

    /// SET_REQUEST STORE_CAL_REQ: asks the board to store its working page in non-volatile
    /// memory, then polls GET_STATUS until the store is no longer pending (every 20 ms, at
    /// most `wait`). `Ok(true)`: the board sent EV_STORE_CAL (stored); `Ok(false)`: the
    /// pending bit cleared without it (the store failed: the board's measurements say why).
    ///
    /// # Errors
    /// Not connected, a negative response (e.g. `ERR_RESOURCE_TEMPORARY_NOT_ACCESSIBLE`
    /// while the controller runs, `ERR_ACCESS_LOCKED`), a timeout, or still pending after
    /// `wait`.
    pub fn store_calibration(&mut self, wait: Duration) -> Result<bool> {
        let before = self.counters.store_events;
        self.transact(
            &[
                cmd::SET_REQUEST,
                crate::protocol::request::STORE_CAL_REQ,
                0,
                0,
            ],
            1,
        )?;
        let deadline = Instant::now() + wait;
        loop {
            if !self.get_status()?.store_pending() {
                return Ok(self.counters.store_events > before);
            }
            if Instant::now() > deadline {
                return Err(Error::Unsupported(format!(
                    "the board's calibration store is still pending after {} s",
                    wait.as_secs_f64()
                )));
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// GET_ID type 1 (the ASAM-MC2 file name without path and extension), uploaded from the
    /// MTA where the board puts it there.
    ///
    /// # Errors
    /// Not connected, timeout, a negative or malformed response.
    pub fn get_id(&mut self) -> Result<String> {
        let r = self.transact(&[cmd::GET_ID, 1], 8)?;
        let len = self.order().u32([r[4], r[5], r[6], r[7]]) as usize;
        if len == 0 {
            return Ok(String::new());
        }
        if r[1] & 0x01 != 0 {
            return Err(Error::Unsupported(
                "GET_ID answers inline, which a CAN frame cannot carry".into(),
            ));
        }
        let mut out = Vec::with_capacity(len);
        while out.len() < len {
            let n = (len - out.len()).min(255);
            out.extend(self.upload_from_mta(n)?);
        }
        Ok(String::from_utf8_lossy(&out).into_owned())
    }

    /// Unlocks `resource` (a bit of [`crate::protocol::resource`]) by seed & key: GET_SEED,
    /// then UNLOCK with `mil_xcp::compute_key(secret, resource, seed)`. Nothing is sent
    /// beyond GET_SEED when the resource is already unlocked (seed length 0).
    ///
    /// # Errors
    /// [`Error::KeyRejected`] for a wrong secret (the board then disconnects), timeout, a
    /// negative or malformed response.
    pub fn unlock(&mut self, resource: u8, secret: &[u8]) -> Result<()> {
        let r = self.transact(&[cmd::GET_SEED, 0, resource], 2)?;
        let len = usize::from(r[1]);
        if len == 0 {
            return Ok(());
        }
        if len != SEED_LEN || r.len() < 2 + SEED_LEN {
            return Err(Error::Unexpected {
                command: "GET_SEED",
                bytes: r,
                why: format!(
                    "a seed of {len} bytes; the board's key algorithm takes {SEED_LEN} (is this the MiL board?)"
                ),
            });
        }
        let mut seed = [0u8; SEED_LEN];
        seed.copy_from_slice(&r[2..2 + SEED_LEN]);
        let key = compute_key(secret, resource, &seed);
        let mut cto = vec![cmd::UNLOCK, KEY_LEN as u8];
        cto.extend_from_slice(&key);
        let r = match self.transact(&cto, 2) {
            Ok(r) => r,
            Err(Error::Negative { code, .. }) if code.0 == 0x25 => {
                self.session = None;
                self.daq_active = false;
                return Err(Error::KeyRejected {
                    resource: resource_name(resource),
                });
            }
            Err(e) => return Err(e),
        };
        if r[1] & resource != 0 {
            return Err(Error::Unexpected {
                command: "UNLOCK",
                bytes: r,
                why: format!("{} is still protected", resource_name(resource)),
            });
        }
        Ok(())
    }

    /// Unlocks each resource of `resources` (bits) that GET_STATUS reports protected.
    ///
    /// # Errors
    /// As [`Master::unlock`].
    pub fn unlock_all(&mut self, resources: u8, secret: &[u8]) -> Result<()> {
        let status = self.get_status()?;
        for bit in [
            resource::CAL_PAG,
            resource::DAQ,
            resource::STIM,
            resource::PGM,
        ] {
            if resources & bit != 0 && status.locked(bit) {
                self.unlock(bit, secret)?;
            }
        }
        Ok(())
    }

    // ---- memory ----------------------------------------------------------------------

    /// SET_MTA.
    ///
    /// # Errors
    /// Not connected, timeout, a negative response.
    pub fn set_mta(&mut self, address: u32, extension: u8) -> Result<()> {
        let a = self.order().u32_bytes(address);
        self.transact(&[cmd::SET_MTA, 0, 0, extension, a[0], a[1], a[2], a[3]], 1)?;
        Ok(())
    }

    /// SHORT_UPLOAD of `n` bytes (1..=7) at `address`.
    ///
    /// # Errors
    /// `n` out of range, not connected, timeout, a negative or short response.
    pub fn short_upload(&mut self, address: u32, extension: u8, n: usize) -> Result<Vec<u8>> {
        let per_frame = self.info()?.upload_bytes_per_frame();
        if n == 0 || n > per_frame {
            return Err(Error::Unsupported(format!(
                "SHORT_UPLOAD takes 1..={per_frame} bytes, not {n}"
            )));
        }
        let a = self.order().u32_bytes(address);
        let r = self.transact(
            &[
                cmd::SHORT_UPLOAD,
                n as u8,
                0,
                extension,
                a[0],
                a[1],
                a[2],
                a[3],
            ],
            1 + n,
        )?;
        Ok(r[1..=n].to_vec())
    }

    /// UPLOAD of `n` (1..=255) bytes from the MTA: one response frame, or several in slave
    /// block mode.
    fn upload_from_mta(&mut self, n: usize) -> Result<Vec<u8>> {
        let per_frame = self.info()?.upload_bytes_per_frame();
        let mut out = Vec::with_capacity(n);
        let first = self.transact(&[cmd::UPLOAD, n as u8], 1 + n.min(per_frame))?;
        out.extend_from_slice(&first[1..=n.min(per_frame)]);
        while out.len() < n {
            let want = (n - out.len()).min(per_frame);
            let r = self.response(cmd::UPLOAD)?;
            if r.len() < 1 + want {
                return Err(Error::Unexpected {
                    command: "UPLOAD",
                    bytes: r,
                    why: format!("a block frame shorter than the {want} bytes expected"),
                });
            }
            out.extend_from_slice(&r[1..=want]);
        }
        Ok(out)
    }

    /// Reads `len` bytes at `address`: SHORT_UPLOAD when they fit one frame, else SET_MTA and
    /// UPLOADs (up to 255 bytes each in slave block mode, else one frame each).
    ///
    /// # Errors
    /// Not connected, timeout, a negative or short response.
    pub fn upload(&mut self, address: u32, extension: u8, len: usize) -> Result<Vec<u8>> {
        let info = self.info()?;
        if len == 0 {
            return Ok(Vec::new());
        }
        let per_frame = info.upload_bytes_per_frame();
        if len <= per_frame {
            return self.short_upload(address, extension, len);
        }
        self.set_mta(address, extension)?;
        let chunk = if info.slave_block_mode {
            255
        } else {
            per_frame
        };
        let mut out = Vec::with_capacity(len);
        while out.len() < len {
            let n = (len - out.len()).min(chunk);
            out.extend(self.upload_from_mta(n)?);
        }
        Ok(out)
    }

    /// Writes `data` at `address` as ONE change the board validates as a whole: one
    /// DOWNLOAD (up to 6 bytes) or one master block (DOWNLOAD + DOWNLOAD_NEXTs, up to
    /// [`SessionInfo::max_one_change`] bytes).
    ///
    /// # Errors
    /// Longer than one change, not connected, timeout, the board's refusal (nothing was
    /// changed then).
    pub fn download_one_change(&mut self, address: u32, extension: u8, data: &[u8]) -> Result<()> {
        let info = self.info()?;
        let max = info.max_one_change();
        if data.len() > max {
            return Err(Error::Unsupported(format!(
                "a write of {} bytes cannot be one change: the board takes at most {max} in one {}",
                data.len(),
                if max > info.download_bytes_per_frame() {
                    "block"
                } else {
                    "DOWNLOAD (no master block mode)"
                }
            )));
        }
        if data.is_empty() {
            return Ok(());
        }
        self.set_mta(address, extension)?;
        self.download_at_mta(data)
    }

    /// Writes `data` at `address`: in one change where it fits
    /// ([`Master::download_one_change`]), else as several changes one after another (each
    /// validated by the board on its own).
    ///
    /// # Errors
    /// Not connected, timeout, the board's refusal of a change (earlier changes stay).
    pub fn download(&mut self, address: u32, extension: u8, data: &[u8]) -> Result<()> {
        let max = self.info()?.max_one_change();
        if data.is_empty() {
            return Ok(());
        }
        self.set_mta(address, extension)?;
        for chunk in data.chunks(max) {
            self.download_at_mta(chunk)?;
        }
        Ok(())
    }

    /// One DOWNLOAD, or one block, at the MTA (`data` no longer than one change).
    fn download_at_mta(&mut self, data: &[u8]) -> Result<()> {
        let info = self.info()?;
        let per_frame = info.download_bytes_per_frame();
        let n = data.len();
        let mut first = vec![cmd::DOWNLOAD, n as u8];
        first.extend_from_slice(&data[..n.min(per_frame)]);
        if n <= per_frame {
            self.transact(&first, 1)?;
            return Ok(());
        }
        let min_st = info.comm_mode.map_or(Duration::ZERO, |c| {
            Duration::from_micros(100 * u64::from(c.min_st))
        });
        self.send(&first)?;
        let mut sent = per_frame;
        while sent < n {
            if !min_st.is_zero() {
                std::thread::sleep(min_st);
            }
            let k = (n - sent).min(per_frame);
            let mut next = vec![cmd::DOWNLOAD_NEXT, (n - sent) as u8];
            next.extend_from_slice(&data[sent..sent + k]);
            self.send(&next)?;
            sent += k;
        }
        match self.response(cmd::DOWNLOAD_NEXT) {
            Ok(_) => Ok(()),
            Err(e @ Error::Negative { .. }) => {
                // The first answer names the reason; the frames after a refused one are
                // answered too (sequence errors): read them off the line.
                self.drain();
                Err(relabel_block_error(e))
            }
            Err(e) => Err(e),
        }
    }

    // ---- pages -----------------------------------------------------------------------

    /// SET_CAL_PAGE: `mode` bits of [`page_mode`], segment, page ([`WORKING_PAGE`],
    /// [`REFERENCE_PAGE`]).
    ///
    /// # Errors
    /// Not connected, timeout, a negative response (the board may refuse to run on a page).
    pub fn set_cal_page(&mut self, mode: u8, segment: u8, page: u8) -> Result<()> {
        self.transact(&[cmd::SET_CAL_PAGE, mode, segment, page], 1)?;
        Ok(())
    }

    /// GET_CAL_PAGE for [`page_mode::ECU`] or [`page_mode::XCP`].
    ///
    /// # Errors
    /// Not connected, timeout, a negative or short response.
    pub fn get_cal_page(&mut self, mode: u8, segment: u8) -> Result<u8> {
        let r = self.transact(&[cmd::GET_CAL_PAGE, mode, segment], 4)?;
        Ok(r[3])
    }

    /// COPY_CAL_PAGE (e.g. reference → working: the board validates the whole page as one
    /// change).
    ///
    /// # Errors
    /// Not connected, timeout, a negative response.
    pub fn copy_cal_page(
        &mut self,
        src_segment: u8,
        src_page: u8,
        dst_segment: u8,
        dst_page: u8,
    ) -> Result<()> {
        self.transact(
            &[
                cmd::COPY_CAL_PAGE,
                src_segment,
                src_page,
                dst_segment,
                dst_page,
            ],
            1,
        )?;
        Ok(())
    }

    /// GET_SEGMENT_INFO mode 0: the segment's (address, length in bytes).
    ///
    /// # Errors
    /// Not connected, timeout, a negative or short response.
    pub fn segment_address(&mut self, segment: u8) -> Result<(u32, u32)> {
        let mut values = [0u32; 2];
        for (info, v) in values.iter_mut().enumerate() {
            let r = self.transact(&[cmd::GET_SEGMENT_INFO, 0, segment, info as u8, 0], 8)?;
            *v = self.order().u32([r[4], r[5], r[6], r[7]]);
        }
        Ok((values[0], values[1]))
    }

    // ---- DAQ -------------------------------------------------------------------------

    /// GET_DAQ_PROCESSOR_INFO.
    ///
    /// # Errors
    /// Not connected, timeout, a negative or short response.
    pub fn daq_processor_info(&mut self) -> Result<DaqProcessorInfo> {
        let r = self.transact(&[cmd::GET_DAQ_PROCESSOR_INFO], 8)?;
        let o = self.order();
        Ok(DaqProcessorInfo {
            properties: r[1],
            max_daq: o.u16([r[2], r[3]]),
            max_event_channel: o.u16([r[4], r[5]]),
            min_daq: r[6],
            key_byte: r[7],
        })
    }

    /// GET_DAQ_RESOLUTION_INFO.
    ///
    /// # Errors
    /// Not connected, timeout, a negative or short response.
    pub fn daq_resolution_info(&mut self) -> Result<DaqResolutionInfo> {
        let r = self.transact(&[cmd::GET_DAQ_RESOLUTION_INFO], 8)?;
        Ok(DaqResolutionInfo {
            granularity_odt_entry: r[1],
            max_odt_entry_size: r[2],
            timestamp_mode: r[5],
            timestamp_ticks: self.order().u16([r[6], r[7]]),
        })
    }

    /// GET_DAQ_EVENT_INFO for `event`, then the event's name (uploaded from the MTA).
    ///
    /// # Errors
    /// Not connected, timeout, a negative or short response.
    pub fn daq_event_info(&mut self, event: u16) -> Result<EventInfo> {
        let e = self.order().u16_bytes(event);
        let r = self.transact(&[cmd::GET_DAQ_EVENT_INFO, 0, e[0], e[1]], 7)?;
        let name_len = usize::from(r[3]);
        let name = if name_len > 0 {
            String::from_utf8_lossy(&self.upload_from_mta(name_len)?).into_owned()
        } else {
            String::new()
        };
        let cycle_s = match r[4] {
            0 => None,
            c => crate::protocol::time_unit_seconds(r[5]).map(|u| f64::from(c) * u),
        };
        Ok(EventInfo {
            properties: r[1],
            max_daq_list: r[2],
            name,
            cycle_s,
            priority: r.get(6).copied().unwrap_or(0),
        })
    }

    /// GET_DAQ_CLOCK: the board's DAQ clock in ticks (as the timestamps).
    ///
    /// # Errors
    /// Not connected, timeout, a negative or short response.
    pub fn daq_clock(&mut self) -> Result<u32> {
        let r = self.transact(&[cmd::GET_DAQ_CLOCK], 8)?;
        Ok(self.order().u32([r[4], r[5], r[6], r[7]]))
    }

    /// FREE_DAQ: stops and frees every DAQ list.
    ///
    /// # Errors
    /// Not connected, timeout, a negative response (DAQ locked).
    pub fn free_daq(&mut self) -> Result<()> {
        self.transact(&[cmd::FREE_DAQ], 1)?;
        self.daq_active = false;
        self.dtos.clear();
        Ok(())
    }

    /// ALLOC_DAQ.
    ///
    /// # Errors
    /// Not connected, timeout, a negative response.
    pub fn alloc_daq(&mut self, count: u16) -> Result<()> {
        let c = self.order().u16_bytes(count);
        self.transact(&[cmd::ALLOC_DAQ, 0, c[0], c[1]], 1)?;
        Ok(())
    }

    /// ALLOC_ODT.
    ///
    /// # Errors
    /// Not connected, timeout, a negative response.
    pub fn alloc_odt(&mut self, list: u16, count: u8) -> Result<()> {
        let l = self.order().u16_bytes(list);
        self.transact(&[cmd::ALLOC_ODT, 0, l[0], l[1], count], 1)?;
        Ok(())
    }

    /// ALLOC_ODT_ENTRY.
    ///
    /// # Errors
    /// Not connected, timeout, a negative response.
    pub fn alloc_odt_entry(&mut self, list: u16, odt: u8, count: u8) -> Result<()> {
        let l = self.order().u16_bytes(list);
        self.transact(&[cmd::ALLOC_ODT_ENTRY, 0, l[0], l[1], odt, count], 1)?;
        Ok(())
    }

    /// SET_DAQ_PTR.
    ///
    /// # Errors
    /// Not connected, timeout, a negative response.
    pub fn set_daq_ptr(&mut self, list: u16, odt: u8, entry: u8) -> Result<()> {
        let l = self.order().u16_bytes(list);
        self.transact(&[cmd::SET_DAQ_PTR, 0, l[0], l[1], odt, entry], 1)?;
        Ok(())
    }

    /// WRITE_DAQ: the entry at the DAQ pointer samples `size` bytes at `address` (whole
    /// element, bit offset 0xFF); the pointer moves on.
    ///
    /// # Errors
    /// Not connected, timeout, a negative response.
    pub fn write_daq(&mut self, size: u8, extension: u8, address: u32) -> Result<()> {
        let a = self.order().u32_bytes(address);
        self.transact(
            &[
                cmd::WRITE_DAQ,
                0xFF,
                size,
                extension,
                a[0],
                a[1],
                a[2],
                a[3],
            ],
            1,
        )?;
        Ok(())
    }

    /// SET_DAQ_LIST_MODE (`mode` bit 4: timestamps).
    ///
    /// # Errors
    /// Not connected, timeout, a negative response.
    pub fn set_daq_list_mode(
        &mut self,
        mode: u8,
        list: u16,
        event: u16,
        prescaler: u8,
        priority: u8,
    ) -> Result<()> {
        let o = self.order();
        let l = o.u16_bytes(list);
        let e = o.u16_bytes(event);
        self.transact(
            &[
                cmd::SET_DAQ_LIST_MODE,
                mode,
                l[0],
                l[1],
                e[0],
                e[1],
                prescaler,
                priority,
            ],
            1,
        )?;
        Ok(())
    }

    /// START_STOP_DAQ_LIST (`mode` 0 stop, 1 start, 2 select); returns FIRST_PID.
    ///
    /// # Errors
    /// Not connected, timeout, a negative or short response.
    pub fn start_stop_daq_list(&mut self, mode: u8, list: u16) -> Result<u8> {
        let l = self.order().u16_bytes(list);
        if mode == 1 {
            self.daq_active = true;
        }
        let r = self.transact(&[cmd::START_STOP_DAQ_LIST, mode, l[0], l[1]], 2);
        if r.is_err() && mode == 1 {
            self.daq_active = false;
        }
        Ok(r?[1])
    }

    /// START_STOP_SYNCH (`mode` 0 stop all, 1 start selected, 2 stop selected).
    ///
    /// # Errors
    /// Not connected, timeout, a negative response.
    pub fn start_stop_synch(&mut self, mode: u8) -> Result<()> {
        if mode == 1 {
            // DTOs may arrive before the response: keep them from here on.
            self.daq_active = true;
        }
        let r = self.transact(&[cmd::START_STOP_SYNCH, mode], 1);
        match (&r, mode) {
            (Err(_), 1) | (Ok(_), 0) => {
                self.daq_active = false;
            }
            _ => {}
        }
        r.map(|_| ())
    }

    /// The next DTO (the frame's bytes, PID first) of the running DAQ, waiting at most
    /// `timeout`; `None` when none came.
    ///
    /// # Errors
    /// The transport failed.
    pub(crate) fn next_dto(&mut self, timeout: Duration) -> Result<Option<Vec<u8>>> {
        if let Some(d) = self.dtos.pop_front() {
            return Ok(Some(d));
        }
        let deadline = Instant::now() + timeout;
        while let Some(frame) = self.next_frame(deadline)? {
            let p = frame.payload();
            match p.first().copied() {
                Some(p0) if p0 < pid::SERV => return Ok(Some(p.to_vec())),
                Some(pid::EV | pid::SERV) => {
                    self.counters.events += 1;
                    if p == [pid::EV, crate::protocol::event::STORE_CAL] {
                        self.counters.store_events += 1;
                    }
                }
                _ => self.counters.stray += 1,
            }
        }
        Ok(None)
    }
}

/// A refused block is reported under DOWNLOAD (the command the user asked for).
fn relabel_block_error(e: Error) -> Error {
    match e {
        Error::Negative {
            code,
            detail,
            command_code,
            ..
        } => Error::Negative {
            command: "DOWNLOAD (block)",
            command_code,
            code,
            detail,
        },
        other => other,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn can_ids_parse_like_the_firmware_build() {
        assert_eq!(
            "0x7E0,0x7E1".parse::<CanIds>(),
            Ok(CanIds {
                command: 0x7E0,
                response: 0x7E1
            })
        );
        assert_eq!(
            " 2016 , 0X7e1"
                .parse::<CanIds>()
                .map(|i| (i.command, i.response)),
            Ok((2016, 0x7E1))
        );
        assert!("0x800,0x7E1"
            .parse::<CanIds>()
            .unwrap_err()
            .contains("11-bit"));
        assert!("0x7E0,0x7E0"
            .parse::<CanIds>()
            .unwrap_err()
            .contains("differ"));
        assert!("0x7E0".parse::<CanIds>().unwrap_err().contains("CMD,RES"));
        assert!("0x7E0,zz".parse::<CanIds>().is_err());
        assert_eq!(CanIds::default().to_string(), "0x7E0,0x7E1");
    }
}
