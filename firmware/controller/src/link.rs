//! The frame layer between the transports and the [`Application`]: decoding received frames
//! with `mil-frames`, encoding the demand, status and CommandAck frames, and the SLCAN
//! session of the QEMU build. Shared by both builds; host-testable.
//!
//! # Received frames (either transport)
//! | frame (`mil_frames::decode`) | action |
//! | --- | --- |
//! | Measurement of a running channel | stored; the one completing its sample steps the controller, and the Demand of every running channel (and every K-th step a Status) is queued at once |
//! | MeasurementAux of a running channel | force and speed stored for the next step |
//! | Measurement or MeasurementAux of a channel the running model does not have | counted as malformed, ignored |
//! | Command | forwarded to the configuration task, which answers with a CommandAck |
//! | a Command frame that fails to decode (NaN value, unknown command, reserved bits, length) | counted as malformed; answered with a CommandAck whose result is the decode error's code (`CommandAck::rejecting`) |
//! | any other frame in the MiL range that fails to decode (length, range, "not available", free ID, remote) | counted as malformed, ignored |
//! | XCP command (standard ID `config::XCP_COMMAND_ID`, default 0x7E0) | forwarded to the XCP task ([`crate::xcp`]), which answers on `config::XCP_RESPONSE_ID`; a build without an XCP secret counts it as foreign |
//! | a frame outside the MiL range, an extended ID, or a board-to-host frame (Demand, Status, CommandAck: another board or an echo) | counted as foreign, ignored |

use mil_frames::bus_load;
use mil_frames::slcan::{self, SlcanLine};
use mil_frames::{
    decode, encode_command_ack, encode_demand, encode_status, CommandAck, CommandKind, DecodeError,
    DemandFlags, Layout, Message, MessageKind, RawFrame, Status,
};
use model_core::Mode;

use crate::application::{
    Application, Command, Demand, Measurement, MeasurementAux, Output, StatusReport,
};
use crate::config::{XCP_COMMAND_ID, XCP_RESPONSE_ID};

/// The measurement counter's modulus (the DBC's `Counter` is 8 bits).
pub const COUNTER_MODULUS: u32 = 256;

/// The frame layout: the DBC's base ID (0x100) and factors.
pub const LAYOUT: Layout = Layout::DEFAULT;

// The XCP frames (`config`'s build-time IDs) lie above the MiL range (lower priority on the
// bus) and differ.
const _: () = {
    let (_, last) = LAYOUT.id_range();
    assert!(XCP_COMMAND_ID > last);
    assert!(XCP_RESPONSE_ID > last);
    assert!(XCP_COMMAND_ID <= 0x7FF && XCP_RESPONSE_ID <= 0x7FF);
    assert!(XCP_COMMAND_ID != XCP_RESPONSE_ID);
};

/// Where frames go: bxCAN on the board, SLCAN lines over USART1 in QEMU.
pub trait Transport {
    /// Queues one frame for transmission; `false` if it could not be queued (dropped).
    fn queue(&mut self, frame: &RawFrame) -> bool;
}

/// A command for the configuration task, with what its CommandAck echoes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Request {
    /// Raw command number received (echoed).
    pub command_raw: u8,
    /// Raw index received: its low byte (echoed).
    pub index_raw: u8,
    /// The decoded command, or the CommandAck result code of a frame that did not decode.
    pub command: Result<Command, u8>,
}

/// What a received frame led to.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Handled {
    /// A measurement stepped the controller; its demand was queued.
    Stepped,
    /// Stored, counted or ignored: nothing to transmit.
    Done,
    /// A command for the configuration task.
    Command(Request),
    /// An XCP command frame (ID [`XCP_COMMAND_ID`]) for the XCP task (a build without an
    /// XCP secret counts it as foreign).
    Xcp(RawFrame),
}

/// The model-core mode as the frames' mode (same values).
pub fn wire_mode(mode: Mode) -> mil_frames::Mode {
    match mode {
        Mode::Idle => mil_frames::Mode::Idle,
        Mode::Running => mil_frames::Mode::Running,
        Mode::Fault => mil_frames::Mode::Fault,
    }
}

/// The Demand frame of channel `ch`. A non-finite demand (which model-core never produces)
/// is replaced by the safe demand with the fault flag set: a NaN is never transmitted.
///
/// This is the control path's encoder: the same bytes as `mil_frames::encode_demand` (a host
/// test compares them over the whole f32 range), but in f32 and 32-bit integer arithmetic
/// only. `encode_demand` rounds through f64, which the Cortex-M4F emulates in software (about
/// 600 instructions against about 60 here). Bit positions, factor and limits still come from
/// the DBC table (`mil_frames::dbc::demand`); the build fails if they change shape.
pub fn demand_frame(d: &Demand, ch: usize) -> RawFrame {
    let force = d.force_n.get(ch).copied().unwrap_or(f32::NAN);
    let counter = (d.counter % COUNTER_MODULUS) as u8;
    let bit = |mask: u8| u64::from(mask.checked_shr(ch as u32).unwrap_or(0) & 1);
    match demand_raw(force) {
        Some(raw) => {
            use mil_frames::dbc::demand as s;
            let word = u64::from(raw as u32) << s::DEMAND.start_bit
                | u64::from(counter) << s::COUNTER.start_bit
                | (wire_mode(d.mode) as u64) << s::MODE.start_bit
                | u64::from(d.fault_latched) << s::FAULT_LATCHED.start_bit
                | bit(d.amplitude_limited) << s::AMPLITUDE_LIMITED.start_bit
                | bit(d.rate_limited) << s::RATE_LIMITED.start_bit;
            RawFrame {
                id: DEMAND_ID + ch as u16,
                len: s::MESSAGE.dlc,
                data: word.to_le_bytes(),
            }
        }
        None => safe_demand_frame(ch, counter),
    }
}

/// The Demand ID of channel 0 (channel `c`: this plus `c`).
const DEMAND_ID: u16 = LAYOUT.base_id() + mil_frames::dbc::demand::MESSAGE.id_offset;

// The fast demand encoder relies on this shape of the DBC's Demand message.
const _: () = {
    use mil_frames::dbc::demand as s;
    assert!(s::DEMAND.start_bit == 0 && s::DEMAND.len == 32 && s::DEMAND.signed);
    assert!(s::DEMAND.offset == 0.0);
    assert!(s::DEMAND.raw_min >= i32::MIN as i64 && s::DEMAND.raw_max <= i32::MAX as i64);
    assert!(s::COUNTER.len == 8 && s::MODE.len == 2 && s::FAULT_LATCHED.len == 1);
    assert!(s::AMPLITUDE_LIMITED.len == 1 && s::RATE_LIMITED.len == 1);
    assert!(s::MESSAGE.dlc <= 8);
};

/// The raw Demand count of `value` (N) as `encode_demand` computes it with the default
/// layout: `round((value - offset) / factor)`, ties away from zero, saturated to the DBC's
/// raw limits; `None` when `value` is not finite.
pub fn demand_raw(value: f32) -> Option<i32> {
    use mil_frames::dbc::demand::DEMAND as S;
    if !value.is_finite() {
        return None;
    }
    let x = (value - S.offset as f32) / S.factor as f32;
    // `roundf` without libm: `as i32` truncates (saturating beyond ±2^31); below 2^24 both
    // `t as f32` and `x - t` are exact, at or above it `x` is an integer and `frac` is 0.
    let t = x as i32;
    let frac = x - t as f32;
    let r = if frac >= 0.5 {
        t.saturating_add(1)
    } else if frac <= -0.5 {
        t.saturating_sub(1)
    } else {
        t
    };
    Some(r.clamp(S.raw_min as i32, S.raw_max as i32))
}

/// A Demand frame of channel 0 with the configured default safe demand, mode Fault and the
/// fault flag: what the panic and HardFault handlers send. Always encodable (a finite
/// constant); should encoding ever fail, an all-zero payload on the demand ID is returned
/// (0 N, mode Idle), still a valid, finite frame.
/// The Status frame of the fatal path, after its safe Demand frame: mode Fault, fault bits
/// [`crate::application::fault::FIRMWARE_STOPPED`] plus those latched at the last step, the
/// missed and malformed counts of the last step and the calibration source, all read from
/// the measurement block (atomics: nothing the stopped tasks hold is touched).
pub fn fatal_status_frame() -> RawFrame {
    let w = crate::calibration::measurement_words();
    let at = |slot: usize| w.get(slot).copied().unwrap_or(0);
    use crate::calibration::meas;
    let latched = u8::try_from(at(meas::FAULT)).unwrap_or(0);
    encode_status(
        &LAYOUT,
        &Status {
            calibration_source: u8::try_from(at(meas::CAL_SOURCE)).unwrap_or(0),
            ..Status::saturating(
                mil_frames::Mode::Fault,
                latched | crate::application::fault::FIRMWARE_STOPPED,
                at(meas::MISSED),
                0,
                at(meas::MALFORMED),
            )
        },
    )
}

/// The QEMU test build's line that forces a HardFault (`!HARDFAULT`, not SLCAN), so that a
/// test can watch the fatal path: the safe Demand frame, then [`fatal_status_frame`], then
/// QEMU exits with status 1. The board build has no such line.
pub const QEMU_FORCE_HARDFAULT: &[u8] = b"!HARDFAULT";

/// The Demand frame of channel `ch` on the fatal path (panic, HardFault): that channel's
/// safe demand of the set installed last ([`crate::calibration::running_safe_demand`]; the
/// build's default until a set is installed), mode Fault, fault flag set.
pub fn safe_demand_frame(ch: usize, counter: u8) -> RawFrame {
    let frame = mil_frames::Demand {
        channel: ch as u8,
        demand_n: crate::calibration::running_safe_demand(ch),
        counter,
        flags: DemandFlags {
            mode: mil_frames::Mode::Fault,
            fault_latched: true,
            amplitude_limited: false,
            rate_limited: false,
        },
    };
    match encode_demand(&LAYOUT, &frame) {
        Ok(f) => f,
        Err(_) => RawFrame {
            id: DEMAND_ID + ch as u16,
            len: MessageKind::Demand.dlc(),
            data: [0; 8],
        },
    }
}

/// The Status frame. Late samples include the demand frames that could not be queued.
pub fn status_frame(s: &StatusReport) -> RawFrame {
    let c = &s.counters;
    encode_status(
        &LAYOUT,
        &Status {
            calibration_source: s.calibration_source,
            ..Status::saturating(wire_mode(s.mode), s.fault, c.missed, c.late, c.malformed)
        },
    )
}

/// The CommandAck frame.
pub fn ack_frame(command_raw: u8, index_raw: u8, result: u8, mode: Mode) -> RawFrame {
    encode_command_ack(
        &LAYOUT,
        &CommandAck {
            command: command_raw,
            index: index_raw,
            result,
            mode: wire_mode(mode),
        },
    )
}

/// The Demand frames of one step, one per running channel (the first `demand.channels`;
/// the others are left empty, never sent).
pub fn demand_frames(demand: &Demand) -> [RawFrame; crate::config::CHANNELS] {
    let mut frames = [RawFrame {
        id: DEMAND_ID,
        len: 0,
        data: [0; 8],
    }; crate::config::CHANNELS];
    for (ch, f) in frames
        .iter_mut()
        .enumerate()
        .take(usize::from(demand.channels))
    {
        *f = demand_frame(demand, ch);
    }
    frames
}

/// Queues the Demand frames of one step (counted late when one cannot be queued).
fn queue_demands<T: Transport>(
    app: &mut Application,
    demand: &Demand,
    frames: &[RawFrame; crate::config::CHANNELS],
    tx: &mut T,
) {
    for frame in frames.iter().take(usize::from(demand.channels)) {
        if !tx.queue(frame) {
            app.count_tx_dropped();
            app.count_late_demand();
        }
    }
}

/// Queues the frames of one step: the demands first (counted late when one cannot be
/// queued), then the status.
pub fn transmit<T: Transport>(app: &mut Application, out: &Output, tx: &mut T) {
    queue_demands(app, &out.demand, &demand_frames(&out.demand), tx);
    if let Some(status) = &out.status {
        if !tx.queue(&status_frame(status)) {
            app.count_tx_dropped();
        }
    }
}

/// A decoded command as the application's command.
fn command(c: &mil_frames::Command) -> Command {
    match c.command {
        CommandKind::Start => Command::Start,
        CommandKind::Stop => Command::Stop,
        CommandKind::ClearFault => Command::ClearFault,
        CommandKind::SetParam => Command::SetParam {
            index: c.index,
            value: c.value,
        },
        CommandKind::SetWatchdog => Command::SetWatchdog { seconds: c.value },
    }
}

/// Handles one received frame (see the module docs).
pub fn on_frame<T: Transport>(app: &mut Application, frame: &RawFrame, tx: &mut T) -> Handled {
    on_frame_probed(app, frame, tx, &mut |_| {})
}

/// Where [`on_frame_probed`] calls its probe on a measurement.
pub mod stage {
    /// The frame is decoded.
    pub const DECODED: usize = 0;
    /// The controller has stepped.
    pub const STEPPED: usize = 1;
    /// The demand frames are encoded.
    pub const ENCODED: usize = 2;
    /// The demand frames are queued (the status, if any, follows).
    pub const DEMAND_QUEUED: usize = 3;
}

/// [`on_frame`] with a probe called at the [`stage`] boundaries of a measurement (the
/// firmware reads its clock there to time the parts of the control path).
pub fn on_frame_probed<T: Transport, P: FnMut(usize)>(
    app: &mut Application,
    frame: &RawFrame,
    tx: &mut T,
    probe: &mut P,
) -> Handled {
    if frame.id == XCP_COMMAND_ID {
        return Handled::Xcp(*frame);
    }
    match decode(&LAYOUT, frame) {
        Ok(Message::Measurement(m)) => {
            probe(stage::DECODED);
            let m = Measurement {
                channel: m.channel,
                position_m: m.position_m,
                road_m: m.road_m,
                counter: u32::from(m.counter),
            };
            match app.on_measurement(&m) {
                Ok(out) => {
                    probe(stage::STEPPED);
                    let frames = demand_frames(&out.demand);
                    probe(stage::ENCODED);
                    queue_demands(app, &out.demand, &frames, tx);
                    probe(stage::DEMAND_QUEUED);
                    if let Some(status) = &out.status {
                        if !tx.queue(&status_frame(status)) {
                            app.count_tx_dropped();
                        }
                    }
                    Handled::Stepped
                }
                Err(_) => Handled::Done,
            }
        }
        Ok(Message::MeasurementAux(a)) => {
            let _ = app.on_aux(&MeasurementAux {
                channel: a.channel,
                force_n: a.force_n,
                speed_m_per_s: a.speed_m_s,
            });
            Handled::Done
        }
        Ok(Message::Command(c)) => Handled::Command(Request {
            command_raw: c.command as u8,
            index_raw: c.index as u8,
            command: Ok(command(&c)),
        }),
        Ok(Message::Demand(_) | Message::Status(_) | Message::CommandAck(_)) => {
            app.count_foreign();
            Handled::Done
        }
        Err(e) => rejected(app, frame, e),
    }
}

/// A frame that did not decode: counted; a command frame gets a rejecting CommandAck.
fn rejected(app: &mut Application, frame: &RawFrame, e: DecodeError) -> Handled {
    if e.is_foreign() {
        app.count_foreign();
        return Handled::Done;
    }
    app.count_malformed();
    match LAYOUT.classify(frame.id) {
        Ok((MessageKind::Command, _)) => {
            let ack = CommandAck::rejecting(frame, e, mil_frames::Mode::Idle);
            Handled::Command(Request {
                command_raw: ack.command,
                index_raw: ack.index,
                command: Err(ack.result),
            })
        }
        _ => Handled::Done,
    }
}

/// Handles any `embedded-can` frame (bxCAN's): a standard data frame goes to [`on_frame`],
/// an extended or remote frame is counted ([`on_other_frame`]).
pub fn on_any_frame<F: mil_frames::embedded_can::Frame, T: Transport, P: FnMut(usize)>(
    app: &mut Application,
    frame: &F,
    tx: &mut T,
    probe: &mut P,
) -> Handled {
    match RawFrame::try_from_frame(frame) {
        Ok(raw) => on_frame_probed(app, &raw, tx, probe),
        Err(_) if frame.is_remote_frame() => {
            on_other_frame(app, remote_error(frame.id()));
            Handled::Done
        }
        Err(e) => {
            on_other_frame(app, e);
            Handled::Done
        }
    }
}

/// A remote or extended frame from an SLCAN line (bxCAN gives them too): counted like
/// `mil_frames::decode_frame` classifies it.
pub fn on_other_frame(app: &mut Application, e: DecodeError) {
    if e.is_foreign() {
        app.count_foreign();
    } else {
        app.count_malformed();
    }
}

/// SLCAN version reply digits (hardware, software) of the QEMU build's `V`.
pub const SLCAN_VERSION: (u8, u8) = (1, 1);
/// SLCAN serial number of the QEMU build's `N`.
pub const SLCAN_SERIAL: u16 = 0x0405;

/// The SLCAN side of the QEMU build: what a received line asks for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LineAction {
    /// Send these reply bytes (`\r`, BEL, a version line).
    Reply {
        /// The reply buffer.
        bytes: [u8; 8],
        /// Bytes of `bytes` in use.
        len: usize,
    },
    /// A standard data frame: handle it with [`on_frame`] (no reply: the board's answer is
    /// its own frames).
    Frame(RawFrame),
    /// A remote or extended frame: count it with [`on_other_frame`] (no reply).
    Other(DecodeError),
    /// `C` after the channel had been open: reply OK; the QEMU build then prints its report
    /// and ends the run.
    Closed,
}

/// The SLCAN session: open/closed state and the replies to Lawicel commands.
///
/// Replies: `\r` to `O`, `L`, `C`, `S0`–`S9`, `sXXYY`, `Z0`/`Z1` and an empty line; `V` →
/// `V0101\r`, `v` → `v0101\r`, `N` → `N0405\r`, `F` → `F00\r`; BEL to a line that does not
/// parse. Frame lines are not acknowledged (no `z\r`: python-can ignores it and each byte
/// costs QEMU time); they are answered by the board's own frames. A frame line is accepted
/// also before `O` (the channel counts as open from the first frame on), because bytes sent
/// before the firmware enabled its USART are lost.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SlcanSession {
    open: bool,
}

impl SlcanSession {
    /// A closed session.
    pub const fn new() -> Self {
        Self { open: false }
    }

    /// `true` once `O`/`L` or a frame was received (until `C`).
    pub fn is_open(&self) -> bool {
        self.open
    }

    /// The action for one line (without its `\r`).
    pub fn on_line(&mut self, line: &[u8]) -> LineAction {
        let mut bytes = [0u8; 8];
        let written = match slcan::parse_line(line) {
            Ok(SlcanLine::Frame(f)) => {
                self.open = true;
                return match RawFrame::try_from_frame(&f) {
                    Ok(raw) => LineAction::Frame(raw),
                    Err(_) if f.remote => LineAction::Other(remote_error(f.id)),
                    Err(e) => LineAction::Other(e),
                };
            }
            Ok(SlcanLine::Open | SlcanLine::ListenOnly) => {
                self.open = true;
                copy(slcan::OK, &mut bytes)
            }
            Ok(SlcanLine::Close) => {
                if self.open {
                    self.open = false;
                    return LineAction::Closed;
                }
                copy(slcan::OK, &mut bytes)
            }
            Ok(
                SlcanLine::Empty
                | SlcanLine::SetBitrate { .. }
                | SlcanLine::SetBtr { .. }
                | SlcanLine::Timestamps(_),
            ) => copy(slcan::OK, &mut bytes),
            Ok(SlcanLine::Version) => {
                slcan::format_version(SLCAN_VERSION.0, SLCAN_VERSION.1, &mut bytes).ok()
            }
            Ok(SlcanLine::FirmwareVersion) => {
                slcan::format_version(SLCAN_VERSION.0, SLCAN_VERSION.1, &mut bytes)
                    .ok()
                    .inspect(|_| {
                        if let Some(b) = bytes.first_mut() {
                            *b = b'v';
                        }
                    })
            }
            Ok(SlcanLine::SerialNumber) => {
                slcan::format_serial_number(SLCAN_SERIAL, &mut bytes).ok()
            }
            Ok(SlcanLine::StatusFlags) => slcan::format_status_flags(0, &mut bytes).ok(),
            Err(_) => None,
        };
        match written {
            Some(len) => LineAction::Reply { bytes, len },
            None => {
                let len = copy(slcan::ERROR, &mut bytes).unwrap_or(0);
                LineAction::Reply { bytes, len }
            }
        }
    }
}

/// The decode error of a remote frame: foreign outside the MiL range, else RemoteFrame.
fn remote_error(id: mil_frames::embedded_can::Id) -> DecodeError {
    match id {
        mil_frames::embedded_can::Id::Standard(id) => match LAYOUT.classify(id.as_raw()) {
            Err(e) => e,
            Ok(_) => DecodeError::RemoteFrame,
        },
        mil_frames::embedded_can::Id::Extended(_) => DecodeError::ExtendedId,
    }
}

fn copy(src: &[u8], dst: &mut [u8; 8]) -> Option<usize> {
    let slot = dst.get_mut(..src.len())?;
    slot.copy_from_slice(src);
    Some(src.len())
}

/// The demand frame of the ack-less paths as an SLCAN line into `out`; the number of bytes.
pub fn slcan_line(frame: &RawFrame, out: &mut [u8]) -> Option<usize> {
    slcan::format_frame(frame, out).ok()
}

/// The bus (0: CAN1, 1: CAN2) the frame with ID `id` goes on while the running
/// configuration spreads its channels over `buses` buses (`mil_frames::bus_load::bus_of`:
/// a channel's frames on bus `channel mod buses`; the heartbeat, acknowledgements and XCP
/// on CAN1).
pub fn bus_of_frame(id: u16, buses: u8) -> u8 {
    if buses < 2 {
        return 0; // one bus: no frame to classify (the common case, per demand frame)
    }
    match LAYOUT.classify(id) {
        Ok((kind, channel)) => bus_load::bus_of(kind, channel, buses),
        Err(_) => 0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::SAFE_DEMAND_N;
    use crate::config::XCP_COMMAND_ID;
    use crate::params::code;
    use mil_frames::{encode_command, encode_measurement};
    use std::vec::Vec;

    /// On one bus everything on CAN1. On two: each channel's frames on bus
    /// `channel mod 2`, whatever their kind; the heartbeat, acknowledgements and XCP on CAN1.
    #[test]
    fn frames_take_their_channels_bus() {
        use mil_frames::MessageKind;
        let id = |kind, ch| LAYOUT.id(kind, ch).unwrap();
        for ch in 0..4 {
            for kind in [
                MessageKind::Measurement,
                MessageKind::MeasurementAux,
                MessageKind::Demand,
            ] {
                assert_eq!(bus_of_frame(id(kind, ch), 1), 0, "{kind:?} {ch}");
                assert_eq!(bus_of_frame(id(kind, ch), 2), ch % 2, "{kind:?} {ch}");
            }
        }
        for buses in 1..=2 {
            assert_eq!(bus_of_frame(id(MessageKind::Status, 0), buses), 0);
            assert_eq!(bus_of_frame(id(MessageKind::CommandAck, 0), buses), 0);
            assert_eq!(bus_of_frame(XCP_RESPONSE_ID, buses), 0);
            assert_eq!(bus_of_frame(XCP_COMMAND_ID, buses), 0);
        }
    }

    #[derive(Default)]
    struct Sink {
        frames: [Option<RawFrame>; 4],
        n: usize,
        refuse: bool,
    }

    impl Transport for Sink {
        fn queue(&mut self, frame: &RawFrame) -> bool {
            if self.refuse {
                return false;
            }
            if let Some(slot) = self.frames.get_mut(self.n) {
                *slot = Some(*frame);
                self.n += 1;
            }
            true
        }
    }

    fn measurement(counter: u8, road_m: f32) -> RawFrame {
        encode_measurement(
            &LAYOUT,
            &mil_frames::Measurement {
                channel: 0,
                position_m: 0.0,
                road_m,
                counter,
            },
        )
        .unwrap()
    }

    #[test]
    fn measurement_to_demand() {
        let mut app = Application::new(COUNTER_MODULUS).unwrap();
        let mut sink = Sink::default();
        assert_eq!(
            on_frame(&mut app, &measurement(7, 0.001), &mut sink),
            Handled::Stepped
        );
        assert_eq!(sink.n, 1);
        let Ok(Message::Demand(d)) = decode(&LAYOUT, &sink.frames[0].unwrap()) else {
            panic!("not a demand");
        };
        assert_eq!(d.counter, 7);
        assert_eq!(d.flags.mode, mil_frames::Mode::Idle);
        assert!((d.demand_n - SAFE_DEMAND_N).abs() < 0.1);
        // A refused demand counts as late (and dropped).
        sink.refuse = true;
        on_frame(&mut app, &measurement(8, 0.001), &mut sink);
        assert_eq!((app.counters().late, app.counters().tx_dropped), (1, 1));
    }

    #[test]
    fn malformed_foreign_and_commands() {
        let mut app = Application::new(COUNTER_MODULUS).unwrap();
        let mut sink = Sink::default();
        let mut short = measurement(0, 0.0);
        short.len = 6;
        assert_eq!(on_frame(&mut app, &short, &mut sink), Handled::Done);
        let mut na = measurement(0, 0.0);
        na.data[0..3].copy_from_slice(&[0, 0, 0x80]); // "not available" position
        assert_eq!(on_frame(&mut app, &na, &mut sink), Handled::Done);
        let foreign = RawFrame::from_parts(0x050, &[1, 2]).unwrap();
        assert_eq!(on_frame(&mut app, &foreign, &mut sink), Handled::Done);
        assert_eq!((app.counters().malformed, app.counters().foreign), (2, 1));
        assert_eq!(sink.n, 0);
        // A decodable command is forwarded.
        let cmd = encode_command(
            &LAYOUT,
            &mil_frames::Command {
                command: CommandKind::SetParam,
                index: 1,
                value: 600.0,
            },
        )
        .unwrap();
        assert_eq!(
            on_frame(&mut app, &cmd, &mut sink),
            Handled::Command(Request {
                command_raw: 4,
                index_raw: 1,
                command: Ok(Command::SetParam {
                    index: 1,
                    value: 600.0
                }),
            })
        );
        // Any slot of the page: the index has 16 bits (byte 2, reserved before), the
        // acknowledgement echoes its low byte.
        let high = crate::calibration::slot_named("limits_safe_ramp_rate_3").unwrap();
        assert!(high > 255, "{high}");
        let far = encode_command(
            &LAYOUT,
            &mil_frames::Command {
                command: CommandKind::SetParam,
                index: high as u16,
                value: 2.5,
            },
        )
        .unwrap();
        assert_eq!(far.data[1..3], (high as u16).to_le_bytes());
        assert_eq!(
            on_frame(&mut app, &far, &mut sink),
            Handled::Command(Request {
                command_raw: 4,
                index_raw: high as u8,
                command: Ok(Command::SetParam {
                    index: high as u16,
                    value: 2.5
                }),
            })
        );
        // A NaN value is refused by the decoder and answered with its code.
        let mut nan = cmd;
        nan.data[4..8].copy_from_slice(&f32::NAN.to_bits().to_le_bytes());
        assert_eq!(
            on_frame(&mut app, &nan, &mut sink),
            Handled::Command(Request {
                command_raw: 4,
                index_raw: 1,
                command: Err(DecodeError::NotFinite.code()),
            })
        );
        assert_eq!(app.counters().malformed, 3);
        let ack = ack_frame(4, 1, code::OUT_OF_RANGE, Mode::Idle);
        let Ok(Message::CommandAck(a)) = decode(&LAYOUT, &ack) else {
            panic!("not an ack");
        };
        assert_eq!((a.command, a.index, a.result), (4, 1, code::OUT_OF_RANGE));
    }

    /// The fast demand encoder gives `encode_demand`'s bytes everywhere: a sweep over every
    /// 997th f32 bit pattern (both signs, all exponents), ties and values near the limits.
    #[test]
    fn fast_demand_encoder_matches_mil_frames() {
        // The fallback frame carries the running safe demand (a static other tests set).
        let _turn = crate::calibration::test_lock();
        let mut values: Vec<f32> = (0..=u32::MAX / 997)
            .map(|i| f32::from_bits(i * 997))
            .collect();
        for k in -5000..5000 {
            let base = k as f32 * 0.1;
            values.extend([base, base + 0.05, base - 0.05, k as f32 * 80.0 + 0.05]);
        }
        values.extend([
            400_000.0,
            400_000.04,
            400_000.06,
            -400_000.06,
            1.0e30,
            -1.0e30,
            f32::MAX,
            f32::MIN,
            0.0,
            -0.0,
            f32::MIN_POSITIVE,
            1.5e-45,
            0.049999997,
            0.05,
            -0.05,
            0.15,
            2.5e6,
        ]);
        let mut checked = 0;
        for (i, v) in values.iter().enumerate() {
            let ch = i % 4;
            let mut force_n = [0.0; crate::config::CHANNELS];
            force_n[ch] = *v;
            let d = Demand {
                force_n,
                channels: 4,
                counter: i as u32,
                mode: [Mode::Idle, Mode::Running, Mode::Fault][i % 3],
                fault_latched: i % 2 == 0,
                amplitude_limited: ((i % 5 == 0) as u8) << ch,
                rate_limited: ((i % 7 == 0) as u8) << ch,
            };
            let reference = encode_demand(
                &LAYOUT,
                &mil_frames::Demand {
                    channel: ch as u8,
                    demand_n: *v,
                    counter: (i % 256) as u8,
                    flags: DemandFlags {
                        mode: wire_mode(d.mode),
                        fault_latched: d.fault_latched,
                        amplitude_limited: d.amplitude_limited != 0,
                        rate_limited: d.rate_limited != 0,
                    },
                },
            );
            match reference {
                Ok(f) => {
                    assert_eq!(
                        demand_frame(&d, ch),
                        f,
                        "value {v:e} ({:#010x})",
                        v.to_bits()
                    );
                    checked += 1;
                }
                Err(_) => {
                    assert!(!v.is_finite());
                    assert_eq!(demand_frame(&d, ch), safe_demand_frame(ch, (i % 256) as u8));
                }
            }
        }
        assert!(checked > 4_000_000);
    }

    #[test]
    fn safe_frame_and_nan_never_sent() {
        let _turn = crate::calibration::test_lock();
        let mut app = Application::new(256).unwrap();
        let f = safe_demand_frame(0, 3);
        let Ok(Message::Demand(d)) = decode(&LAYOUT, &f) else {
            panic!("not a demand");
        };
        assert!((d.demand_n - SAFE_DEMAND_N).abs() < 0.1);
        assert!(d.flags.fault_latched);
        // A tuned safe demand is the one the fatal path sends.
        let mut p = *app.params();
        p.safe_demand = [2500.0, 0.0, 0.0, 0.0];
        let prepared = p.prepare(crate::config::DT).unwrap();
        let settings = crate::calibration::DEFAULT_SETTINGS;
        assert_eq!(app.install(&prepared, settings), crate::params::code::OK);
        let Ok(Message::Demand(d)) = decode(&LAYOUT, &safe_demand_frame(0, 4)) else {
            panic!("not a demand");
        };
        assert!((d.demand_n - 2500.0).abs() < 0.1, "{d:?}");
        let defaults = Application::new(256).unwrap();
        let reset = defaults.params().prepare(crate::config::DT).unwrap();
        assert_eq!(app.install(&reset, settings), crate::params::code::OK);
        let nan = Demand {
            force_n: [f32::NAN; crate::config::CHANNELS],
            channels: 1,
            counter: 3,
            mode: Mode::Running,
            fault_latched: false,
            amplitude_limited: 0,
            rate_limited: 0,
        };
        assert_eq!(demand_frame(&nan, 0), f);
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig { cases: 2000, ..Default::default() })]

        /// Random frames (IDs across the whole 11-bit range, the MiL range and the XCP
        /// command ID; any length and payload) and random SLCAN lines: nothing panics,
        /// every frame is stepped, counted, forwarded or answered, the only frames sent are
        /// finite demands and statuses, and only the XCP command ID reaches the XCP task.
        #[test]
        fn random_frames_and_lines_are_handled(
            frames in proptest::collection::vec(
                (
                    proptest::prop_oneof![0u16..0x800, 0x100u16..0x140, proptest::strategy::Just(XCP_COMMAND_ID)],
                    0usize..=8,
                    proptest::prelude::any::<[u8; 8]>(),
                ),
                1..50,
            ),
            lines in proptest::collection::vec(proptest::collection::vec(proptest::prelude::any::<u8>(), 0..30), 0..20),
        ) {
            let mut app = Application::new(COUNTER_MODULUS).unwrap();
            let mut sink = Sink::default();
            for (id, len, data) in frames {
                let Some(frame) = RawFrame::from_parts(id, &data[..len]) else {
                    continue;
                };
                sink.n = 0;
                match on_frame(&mut app, &frame, &mut sink) {
                    Handled::Xcp(f) => proptest::prop_assert_eq!(f.id, XCP_COMMAND_ID),
                    _ => proptest::prop_assert_ne!(frame.id, XCP_COMMAND_ID),
                }
                for sent in sink.frames.iter().take(sink.n).flatten() {
                    match decode(&LAYOUT, sent) {
                        Ok(Message::Demand(d)) => proptest::prop_assert!(d.demand_n.is_finite()),
                        Ok(Message::Status(_)) => {}
                        other => proptest::prop_assert!(false, "sent {:?}", other),
                    }
                }
            }
            let mut session = SlcanSession::new();
            for line in lines {
                if let LineAction::Frame(f) = session.on_line(&line) {
                    let _ = on_frame(&mut app, &f, &mut sink);
                }
            }
        }
    }

    #[test]
    fn slcan_session() {
        let mut s = SlcanSession::new();
        let reply = |a: LineAction| match a {
            LineAction::Reply { bytes, len } => bytes[..len].to_vec(),
            other => panic!("{other:?}"),
        };
        assert_eq!(reply(s.on_line(b"C")), b"\r"); // closed: just OK
        assert_eq!(reply(s.on_line(b"S8")), b"\r");
        assert_eq!(reply(s.on_line(b"")), b"\r");
        assert_eq!(reply(s.on_line(b"V")), b"V0101\r");
        assert_eq!(reply(s.on_line(b"v")), b"v0101\r");
        assert_eq!(reply(s.on_line(b"N")), b"N0405\r");
        assert_eq!(reply(s.on_line(b"F")), b"F00\r");
        assert_eq!(reply(s.on_line(b"?")), b"\x07");
        assert_eq!(reply(s.on_line(b"t10")), b"\x07");
        assert!(!s.is_open());
        assert_eq!(reply(s.on_line(b"O")), b"\r");
        assert_eq!(reply(s.on_line(b"O")), b"\r");
        let f = measurement(1, 0.0);
        let mut line = [0u8; 32];
        let n = slcan_line(&f, &mut line).unwrap();
        assert_eq!(s.on_line(&line[..n - 1]), LineAction::Frame(f));
        assert_eq!(
            s.on_line(b"r1003"),
            LineAction::Other(DecodeError::RemoteFrame)
        );
        assert_eq!(s.on_line(b"r0503"), LineAction::Other(DecodeError::Foreign));
        assert_eq!(
            s.on_line(b"T0000010021122"),
            LineAction::Other(DecodeError::ExtendedId)
        );
        assert_eq!(s.on_line(b"C"), LineAction::Closed);
        assert_eq!(reply(s.on_line(b"C")), b"\r");
    }
}
