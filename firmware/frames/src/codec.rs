//! Typed messages, [`decode`] and the `encode_*` functions.

use embedded_can::{Frame, Id, StandardId};

use crate::dbc::{self, SignalSpec};
use crate::error::{DecodeError, EncodeError};
use crate::layout::{Layout, MessageKind};

/// A classic CAN data frame with a standard ID, as the codec reads and writes it.
///
/// Fields are public so that drivers can fill them directly; [`decode`] checks them all
/// (an `id` beyond 0x7FF is [`DecodeError::Foreign`], a `len` other than the message's DLC is
/// [`DecodeError::WrongLength`]). Bytes of `data` beyond `len` are ignored by [`decode`] and
/// zero in encoded frames.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RawFrame {
    /// Standard 11-bit identifier.
    pub id: u16,
    /// Data length code, bytes (0..=8).
    pub len: u8,
    /// Data bytes (the first `len` are the payload).
    pub data: [u8; 8],
}

impl RawFrame {
    /// A frame with the given ID and payload; `None` if `id > 0x7FF` or the payload is
    /// longer than 8 bytes.
    pub fn from_parts(id: u16, payload: &[u8]) -> Option<Self> {
        if id > 0x7FF || payload.len() > 8 {
            return None;
        }
        let mut data = [0_u8; 8];
        for (d, s) in data.iter_mut().zip(payload) {
            *d = *s;
        }
        Some(RawFrame {
            id,
            len: payload.len() as u8,
            data,
        })
    }

    /// The payload: the first `len` bytes (all 8 when `len` exceeds 8).
    pub fn payload(&self) -> &[u8] {
        self.data.get(..usize::from(self.len)).unwrap_or(&self.data)
    }

    /// A raw frame from any `embedded-can` frame.
    ///
    /// Errors: [`DecodeError::ExtendedId`] for an extended ID, [`DecodeError::RemoteFrame`] for
    /// a remote frame, [`DecodeError::WrongLength`] for more than 8 data bytes.
    pub fn try_from_frame<F: Frame>(frame: &F) -> Result<Self, DecodeError> {
        let id = match frame.id() {
            Id::Standard(id) => id.as_raw(),
            Id::Extended(_) => return Err(DecodeError::ExtendedId),
        };
        if frame.is_remote_frame() {
            return Err(DecodeError::RemoteFrame);
        }
        RawFrame::from_parts(id, frame.data()).ok_or(DecodeError::WrongLength)
    }

    /// This frame as another `embedded-can` frame type (e.g. the CAN driver's), for
    /// transmission; `None` if `id > 0x7FF`, `len > 8` or the driver refuses it.
    pub fn to_frame<F: Frame>(&self) -> Option<F> {
        if self.len > 8 {
            return None;
        }
        F::new(StandardId::new(self.id)?, self.payload())
    }

    /// Payload as a little-endian word (bit `8·byte + bit`), bytes beyond `len` zeroed.
    fn word(&self) -> u64 {
        let mut bytes = [0_u8; 8];
        for (d, s) in bytes.iter_mut().zip(self.payload()) {
            *d = *s;
        }
        u64::from_le_bytes(bytes)
    }
}

/// `embedded-can` view of a raw frame: always a standard data frame. `new` refuses extended
/// IDs and more than 8 bytes, `new_remote` always returns `None` (MiL never uses remote frames).
impl Frame for RawFrame {
    fn new(id: impl Into<Id>, data: &[u8]) -> Option<Self> {
        match id.into() {
            Id::Standard(id) => RawFrame::from_parts(id.as_raw(), data),
            Id::Extended(_) => None,
        }
    }

    fn new_remote(_id: impl Into<Id>, _dlc: usize) -> Option<Self> {
        None
    }

    fn is_extended(&self) -> bool {
        false
    }

    fn is_remote_frame(&self) -> bool {
        false
    }

    /// The ID; an out-of-range `id` field (beyond 0x7FF) reads as 0x7FF.
    fn id(&self) -> Id {
        Id::Standard(StandardId::new(self.id).unwrap_or(StandardId::MAX))
    }

    fn dlc(&self) -> usize {
        self.payload().len()
    }

    fn data(&self) -> &[u8] {
        self.payload()
    }
}

/// Operating mode of the MiL board; the values are `model_core::Mode`'s discriminants.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum Mode {
    /// Model stopped, demand at (or ramping to) the safe demand.
    #[default]
    Idle = 0,
    /// Model running.
    Running = 1,
    /// Latched fault: demand at (or ramping to) the safe demand until cleared.
    Fault = 2,
}

impl Mode {
    /// Every mode, in value order.
    pub const ALL: [Mode; 3] = [Mode::Idle, Mode::Running, Mode::Fault];

    /// The mode with this wire value.
    pub const fn from_u8(v: u8) -> Option<Mode> {
        match v {
            0 => Some(Mode::Idle),
            1 => Some(Mode::Running),
            2 => Some(Mode::Fault),
            _ => None,
        }
    }

    /// Name as in the DBC's value tables.
    pub const fn name(self) -> &'static str {
        match self {
            Mode::Idle => "Idle",
            Mode::Running => "Running",
            Mode::Fault => "Fault",
        }
    }
}

/// Commands a tool sends to the board (`Command.Command`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum CommandKind {
    /// Start the model (Idle → Running). Index 0, value ignored (finite).
    Start = 1,
    /// Stop the model (→ Idle). Index 0, value ignored (finite).
    Stop = 2,
    /// Clear a latched fault (Fault → Idle). Index 0, value ignored (finite).
    ClearFault = 3,
    /// Set parameter `index` to `value` (SI units of that parameter).
    SetParam = 4,
    /// Set the measurement watchdog: `value` is the timeout in s (the firmware defines
    /// what 0 means). Index 0.
    SetWatchdog = 5,
}

impl CommandKind {
    /// Every command, in value order.
    pub const ALL: [CommandKind; 5] = [
        CommandKind::Start,
        CommandKind::Stop,
        CommandKind::ClearFault,
        CommandKind::SetParam,
        CommandKind::SetWatchdog,
    ];

    /// The command with this wire value.
    pub const fn from_u8(v: u8) -> Option<CommandKind> {
        match v {
            1 => Some(CommandKind::Start),
            2 => Some(CommandKind::Stop),
            3 => Some(CommandKind::ClearFault),
            4 => Some(CommandKind::SetParam),
            5 => Some(CommandKind::SetWatchdog),
            _ => None,
        }
    }

    /// Name as in the DBC's value table.
    pub const fn name(self) -> &'static str {
        match self {
            CommandKind::Start => "Start",
            CommandKind::Stop => "Stop",
            CommandKind::ClearFault => "ClearFault",
            CommandKind::SetParam => "SetParam",
            CommandKind::SetWatchdog => "SetWatchdog",
        }
    }

    /// Whether the command uses the `index` byte (only [`CommandKind::SetParam`]; the others
    /// require it to be 0).
    pub const fn takes_index(self) -> bool {
        matches!(self, CommandKind::SetParam)
    }
}

/// One sample of one channel from the servo controller.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Measurement {
    /// Channel, 0..8.
    pub channel: u8,
    /// Hub (axle) displacement, m; valid within ±1 m.
    pub position_m: f32,
    /// Road input under this channel, m; valid within ±1 m.
    pub road_m: f32,
    /// Sample sequence number (wraps); the demand echoes it.
    pub counter: u8,
}

/// Auxiliary measurement of one channel (only where the model needs it).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MeasurementAux {
    /// Channel, 0..8.
    pub channel: u8,
    /// Measured interface force, N; valid within ±400 kN.
    pub force_n: f32,
    /// Vehicle speed, m/s; valid 0..=150 m/s.
    pub speed_m_s: f32,
}

/// Status bits sent with every demand.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DemandFlags {
    /// Board mode.
    pub mode: Mode,
    /// A fault is latched.
    pub fault_latched: bool,
    /// This channel's demand was clamped by the amplitude limit.
    pub amplitude_limited: bool,
    /// This channel's demand was held back by the rate limit.
    pub rate_limited: bool,
}

/// Force demand of one channel, board → servo controller.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Demand {
    /// Channel, 0..8.
    pub channel: u8,
    /// Actuator force demand, N; encoding saturates to ±400 kN and refuses NaN and infinities.
    pub demand_n: f32,
    /// Echo of the counter of the measurement this demand answers.
    pub counter: u8,
    /// Mode and limiter bits.
    pub flags: DemandFlags,
}

/// Heartbeat of the board (about 10 Hz).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Status {
    /// Board mode.
    pub mode: Mode,
    /// Where the running calibration came from at boot (0..=3, 4 bits: 0 the build's
    /// defaults, nothing stored; 1 the stored page; 2 defaults, a stored page was refused; 3
    /// defaults, the storage could not be read).
    pub calibration_source: u8,
    /// Latched fault causes, bit flags (`model_core::fault` bits 0–1; the firmware defines
    /// higher bits).
    pub fault_causes: u8,
    /// Samples with no measurement in time since start (saturating).
    pub missed_samples: u16,
    /// Samples whose demand left late since start (saturating).
    pub late_samples: u16,
    /// Frames in the MiL ID range that failed to decode since start (saturating).
    pub malformed_frames: u16,
}

impl Status {
    /// A status from 32-bit event counts, each saturated to `u16::MAX` (calibration source
    /// 0; set the field for another).
    pub fn saturating(
        mode: Mode,
        fault_causes: u8,
        missed_samples: u32,
        late_samples: u32,
        malformed_frames: u32,
    ) -> Self {
        let sat = |v: u32| u16::try_from(v).unwrap_or(u16::MAX);
        Status {
            mode,
            calibration_source: 0,
            fault_causes,
            missed_samples: sat(missed_samples),
            late_samples: sat(late_samples),
            malformed_frames: sat(malformed_frames),
        }
    }
}

/// A command from a tool.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Command {
    /// What to do.
    pub command: CommandKind,
    /// Parameter index ([`CommandKind::SetParam`]; 0 for the other commands).
    pub index: u16,
    /// Argument (SI units of the parameter; watchdog timeout in s); always finite.
    pub value: f32,
}

/// The board's answer to a command.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CommandAck {
    /// Raw command number received (echoed also when unknown).
    pub command: u8,
    /// Raw index received: its low byte.
    pub index: u8,
    /// 0 ok; otherwise an error code (this crate's below 128, the firmware's from 128).
    pub result: u8,
    /// Mode after the command.
    pub mode: Mode,
}

impl CommandAck {
    /// Result code for success.
    pub const OK: u8 = 0;

    /// The answer to a decoded command.
    pub fn answering(command: &Command, result: u8, mode: Mode) -> Self {
        CommandAck {
            command: command.command as u8,
            index: command.index as u8,
            result,
            mode,
        }
    }

    /// The answer to a command frame that did not decode: echoes the raw command and index
    /// bits of the frame (0 where the frame is too short) with the error's code.
    pub fn rejecting(frame: &RawFrame, error: DecodeError, mode: Mode) -> Self {
        let word = frame.word();
        CommandAck {
            command: get(word, &dbc::command::COMMAND) as u8,
            index: get(word, &dbc::command::INDEX) as u8,
            result: error.code(),
            mode,
        }
    }
}

/// Any decoded message.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Message {
    /// See [`Measurement`].
    Measurement(Measurement),
    /// See [`MeasurementAux`].
    MeasurementAux(MeasurementAux),
    /// See [`Demand`].
    Demand(Demand),
    /// See [`Status`].
    Status(Status),
    /// See [`Command`].
    Command(Command),
    /// See [`CommandAck`].
    CommandAck(CommandAck),
}

impl Message {
    /// Which message this is.
    pub const fn kind(&self) -> MessageKind {
        match self {
            Message::Measurement(_) => MessageKind::Measurement,
            Message::MeasurementAux(_) => MessageKind::MeasurementAux,
            Message::Demand(_) => MessageKind::Demand,
            Message::Status(_) => MessageKind::Status,
            Message::Command(_) => MessageKind::Command,
            Message::CommandAck(_) => MessageKind::CommandAck,
        }
    }

    /// Channel of a per-channel message.
    pub const fn channel(&self) -> Option<u8> {
        match self {
            Message::Measurement(m) => Some(m.channel),
            Message::MeasurementAux(m) => Some(m.channel),
            Message::Demand(m) => Some(m.channel),
            _ => None,
        }
    }
}

// ---- bit fields (Intel byte order: bit 8·byte + bit of the little-endian word) ----

const fn mask(len: u8) -> u64 {
    if len >= 64 {
        u64::MAX
    } else {
        (1_u64 << len) - 1
    }
}

/// Unsigned field value.
fn get(word: u64, s: &SignalSpec) -> u64 {
    word.wrapping_shr(u32::from(s.start_bit)) & mask(s.len)
}

/// Field value, sign-extended when the signal is signed.
fn get_int(word: u64, s: &SignalSpec) -> i64 {
    let v = get(word, s);
    if s.signed && s.len > 0 {
        let shift = 64_u32.saturating_sub(u32::from(s.len));
        (v.wrapping_shl(shift) as i64).wrapping_shr(shift)
    } else {
        v as i64
    }
}

fn put(word: &mut u64, s: &SignalSpec, raw: u64) {
    *word |= (raw & mask(s.len)).wrapping_shl(u32::from(s.start_bit));
}

fn put_int(word: &mut u64, s: &SignalSpec, raw: i64) {
    put(word, s, raw as u64);
}

fn get_bool(word: u64, s: &SignalSpec) -> bool {
    get(word, s) != 0
}

fn get_byte(word: u64, s: &SignalSpec) -> u8 {
    get(word, s) as u8
}

fn get_mode(word: u64, s: &SignalSpec) -> Result<Mode, DecodeError> {
    u8::try_from(get(word, s))
        .ok()
        .and_then(Mode::from_u8)
        .ok_or(DecodeError::InvalidMode)
}

fn get_count(word: u64, s: &SignalSpec) -> u16 {
    u16::try_from(get(word, s)).unwrap_or(u16::MAX)
}

fn put_count(word: &mut u64, s: &SignalSpec, v: u16) {
    put(word, s, u64::from(v).min(mask(s.len)));
}

fn frame(id: u16, kind: MessageKind, word: u64) -> RawFrame {
    RawFrame {
        id,
        len: kind.dlc(),
        data: word.to_le_bytes(),
    }
}

fn channel_id(layout: &Layout, kind: MessageKind, channel: u8) -> Result<u16, EncodeError> {
    layout.id(kind, channel).ok_or(EncodeError::BadChannel)
}

/// Decodes a received data frame with a standard ID.
///
/// Checks, in this order: the ID ([`DecodeError::Foreign`] outside the MiL range,
/// [`DecodeError::UnknownId`] for a free ID inside it), the length
/// ([`DecodeError::WrongLength`]), reserved bits ([`DecodeError::ReservedNotZero`]), then
/// each signal in DBC order ([`DecodeError::NotAvailable`], [`DecodeError::OutOfRange`],
/// [`DecodeError::InvalidMode`], [`DecodeError::UnknownCommand`],
/// [`DecodeError::NotFinite`]). Never panics, whatever the frame holds.
pub fn decode(layout: &Layout, frame: &RawFrame) -> Result<Message, DecodeError> {
    let (kind, channel) = layout.classify(frame.id)?;
    let spec = kind.spec();
    if frame.len != spec.dlc {
        return Err(DecodeError::WrongLength);
    }
    let word = frame.word();
    if word & !spec.used_bits != 0 {
        return Err(DecodeError::ReservedNotZero);
    }
    Ok(match kind {
        MessageKind::Measurement => {
            use dbc::measurement as m;
            Message::Measurement(Measurement {
                channel,
                position_m: layout.position.decode(get_int(word, &m::POSITION))?,
                road_m: layout.road.decode(get_int(word, &m::ROAD))?,
                counter: get_byte(word, &m::COUNTER),
            })
        }
        MessageKind::MeasurementAux => {
            use dbc::measurement_aux as m;
            Message::MeasurementAux(MeasurementAux {
                channel,
                force_n: layout.force.decode(get_int(word, &m::FORCE))?,
                speed_m_s: layout.speed.decode(get_int(word, &m::SPEED))?,
            })
        }
        MessageKind::Demand => {
            use dbc::demand as m;
            Message::Demand(Demand {
                channel,
                demand_n: layout.demand.decode(get_int(word, &m::DEMAND))?,
                counter: get_byte(word, &m::COUNTER),
                flags: DemandFlags {
                    mode: get_mode(word, &m::MODE)?,
                    fault_latched: get_bool(word, &m::FAULT_LATCHED),
                    amplitude_limited: get_bool(word, &m::AMPLITUDE_LIMITED),
                    rate_limited: get_bool(word, &m::RATE_LIMITED),
                },
            })
        }
        MessageKind::Status => {
            use dbc::status as m;
            Message::Status(Status {
                mode: get_mode(word, &m::MODE)?,
                calibration_source: get_byte(word, &m::CALIBRATION_SOURCE),
                fault_causes: get_byte(word, &m::FAULT_CAUSES),
                missed_samples: get_count(word, &m::MISSED_SAMPLES),
                late_samples: get_count(word, &m::LATE_SAMPLES),
                malformed_frames: get_count(word, &m::MALFORMED_FRAMES),
            })
        }
        MessageKind::Command => {
            use dbc::command as m;
            let command = CommandKind::from_u8(get_byte(word, &m::COMMAND))
                .ok_or(DecodeError::UnknownCommand)?;
            let index = get(word, &m::INDEX) as u16;
            if index != 0 && !command.takes_index() {
                return Err(DecodeError::ReservedNotZero);
            }
            let value = f32::from_bits(get(word, &m::VALUE) as u32);
            if !value.is_finite() {
                return Err(DecodeError::NotFinite);
            }
            Message::Command(Command {
                command,
                index,
                value,
            })
        }
        MessageKind::CommandAck => {
            use dbc::command_ack as m;
            Message::CommandAck(CommandAck {
                command: get_byte(word, &m::COMMAND),
                index: get_byte(word, &m::INDEX),
                result: get_byte(word, &m::RESULT),
                mode: get_mode(word, &m::MODE)?,
            })
        }
    })
}

/// Decodes any `embedded-can` frame: an extended ID is [`DecodeError::ExtendedId`], a remote
/// frame is [`DecodeError::Foreign`] outside the MiL range and [`DecodeError::RemoteFrame`]
/// inside it; data frames go to [`decode`].
pub fn decode_frame<F: Frame>(layout: &Layout, frame: &F) -> Result<Message, DecodeError> {
    let id = match frame.id() {
        Id::Standard(id) => id.as_raw(),
        Id::Extended(_) => return Err(DecodeError::ExtendedId),
    };
    if frame.is_remote_frame() {
        layout.classify(id)?;
        return Err(DecodeError::RemoteFrame);
    }
    let raw = RawFrame::from_parts(id, frame.data()).ok_or(DecodeError::WrongLength)?;
    decode(layout, &raw)
}

/// Encodes a measurement (servo-controller side; host simulations and tests).
///
/// Errors: [`EncodeError::BadChannel`], [`EncodeError::NotFinite`],
/// [`EncodeError::OutOfRange`] (beyond ±1 m: such a frame would not decode).
pub fn encode_measurement(layout: &Layout, m: &Measurement) -> Result<RawFrame, EncodeError> {
    use dbc::measurement as s;
    let id = channel_id(layout, MessageKind::Measurement, m.channel)?;
    let mut word = 0;
    put_int(
        &mut word,
        &s::POSITION,
        physical(&layout.position, m.position_m)?,
    );
    put_int(&mut word, &s::ROAD, physical(&layout.road, m.road_m)?);
    put(&mut word, &s::COUNTER, u64::from(m.counter));
    Ok(frame(id, MessageKind::Measurement, word))
}

/// Encodes an auxiliary measurement (servo-controller side).
///
/// Errors: [`EncodeError::BadChannel`], [`EncodeError::NotFinite`],
/// [`EncodeError::OutOfRange`] (force beyond ±400 kN, speed outside 0..=150 m/s).
pub fn encode_measurement_aux(
    layout: &Layout,
    m: &MeasurementAux,
) -> Result<RawFrame, EncodeError> {
    use dbc::measurement_aux as s;
    let id = channel_id(layout, MessageKind::MeasurementAux, m.channel)?;
    let mut word = 0;
    put_int(&mut word, &s::FORCE, physical(&layout.force, m.force_n)?);
    put_int(&mut word, &s::SPEED, physical(&layout.speed, m.speed_m_s)?);
    Ok(frame(id, MessageKind::MeasurementAux, word))
}

/// Encodes a demand (board side). A finite demand beyond the DBC limits saturates to the
/// nearest limit (±400 kN); the "not available" pattern is never produced.
///
/// Errors: [`EncodeError::BadChannel`], [`EncodeError::NotFinite`] (NaN or infinite: a
/// non-finite demand cannot be sent).
pub fn encode_demand(layout: &Layout, d: &Demand) -> Result<RawFrame, EncodeError> {
    use dbc::demand as s;
    let id = channel_id(layout, MessageKind::Demand, d.channel)?;
    let raw = layout
        .demand
        .encode(d.demand_n, true)
        .ok_or(EncodeError::NotFinite)?;
    let mut word = 0;
    put_int(&mut word, &s::DEMAND, raw);
    put(&mut word, &s::COUNTER, u64::from(d.counter));
    put(&mut word, &s::MODE, d.flags.mode as u64);
    put(
        &mut word,
        &s::FAULT_LATCHED,
        u64::from(d.flags.fault_latched),
    );
    put(
        &mut word,
        &s::AMPLITUDE_LIMITED,
        u64::from(d.flags.amplitude_limited),
    );
    put(&mut word, &s::RATE_LIMITED, u64::from(d.flags.rate_limited));
    Ok(frame(id, MessageKind::Demand, word))
}

/// Encodes the status heartbeat (board side); counts saturate at the signal width.
pub fn encode_status(layout: &Layout, st: &Status) -> RawFrame {
    use dbc::status as s;
    let mut word = 0;
    put(&mut word, &s::MODE, st.mode as u64);
    put(
        &mut word,
        &s::CALIBRATION_SOURCE,
        u64::from(st.calibration_source),
    );
    put(&mut word, &s::FAULT_CAUSES, u64::from(st.fault_causes));
    put_count(&mut word, &s::MISSED_SAMPLES, st.missed_samples);
    put_count(&mut word, &s::LATE_SAMPLES, st.late_samples);
    put_count(&mut word, &s::MALFORMED_FRAMES, st.malformed_frames);
    let id = layout.base_id() + s::MESSAGE.id_offset;
    frame(id, MessageKind::Status, word)
}

/// Encodes a command (tool side).
///
/// Errors: [`EncodeError::NotFinite`] for a NaN or infinite value; [`EncodeError::OutOfRange`]
/// for a non-zero index on a command that takes none (it would not decode).
pub fn encode_command(layout: &Layout, c: &Command) -> Result<RawFrame, EncodeError> {
    use dbc::command as s;
    if !c.value.is_finite() {
        return Err(EncodeError::NotFinite);
    }
    if c.index != 0 && !c.command.takes_index() {
        return Err(EncodeError::OutOfRange);
    }
    let mut word = 0;
    put(&mut word, &s::COMMAND, c.command as u64);
    put(&mut word, &s::INDEX, u64::from(c.index));
    put(&mut word, &s::VALUE, u64::from(c.value.to_bits()));
    let id = layout.base_id() + s::MESSAGE.id_offset;
    Ok(frame(id, MessageKind::Command, word))
}

/// Encodes a command acknowledgement (board side).
pub fn encode_command_ack(layout: &Layout, a: &CommandAck) -> RawFrame {
    use dbc::command_ack as s;
    let mut word = 0;
    put(&mut word, &s::COMMAND, u64::from(a.command));
    put(&mut word, &s::INDEX, u64::from(a.index));
    put(&mut word, &s::RESULT, u64::from(a.result));
    put(&mut word, &s::MODE, a.mode as u64);
    let id = layout.base_id() + s::MESSAGE.id_offset;
    frame(id, MessageKind::CommandAck, word)
}

/// Encodes any message with the matching `encode_*` function.
pub fn encode(layout: &Layout, message: &Message) -> Result<RawFrame, EncodeError> {
    match message {
        Message::Measurement(m) => encode_measurement(layout, m),
        Message::MeasurementAux(m) => encode_measurement_aux(layout, m),
        Message::Demand(m) => encode_demand(layout, m),
        Message::Status(m) => Ok(encode_status(layout, m)),
        Message::Command(m) => encode_command(layout, m),
        Message::CommandAck(m) => Ok(encode_command_ack(layout, m)),
    }
}

fn physical(q: &crate::layout::Quantity, value: f32) -> Result<i64, EncodeError> {
    if !value.is_finite() {
        return Err(EncodeError::NotFinite);
    }
    q.encode(value, false).ok_or(EncodeError::OutOfRange)
}
