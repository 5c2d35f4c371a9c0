//! The board behind a transport as a `Board` of the rig harness.

use std::time::{Duration, Instant};

use mil_firmware::config::{default_params, Controller, DT};
use mil_firmware::link::wire_mode;
use mil_frames::{
    decode, encode_command, encode_demand, encode_measurement, Command, CommandAck, CommandKind,
    DemandFlags, Message, RawFrame, Status as StatusFrame,
};
use model_core::{Mode, ModelInput, Status};

use crate::transport::Transport;
use crate::LAYOUT;

/// How long [`RemoteBoard`] waits for a demand or an acknowledgement by default.
pub const DEFAULT_REPLY_TIMEOUT: Duration = Duration::from_secs(5);

/// One lockstep sample as it went over the wire.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Sample {
    /// The measurement frame sent.
    pub measurement: RawFrame,
    /// The demand frame the board answered with.
    pub firmware: RawFrame,
    /// The demand frame of the host mirror (`mil_frames::encode_demand`).
    pub mirror: RawFrame,
}

impl Sample {
    /// The board's demand frame differs from the mirror's (any byte: demand or flags).
    pub fn mismatch(&self) -> bool {
        self.firmware != self.mirror
    }
}

/// The board (one tyre channel, as `mil-firmware`) behind a [`Transport`], as a
/// `mil_rig::harness::Board<1>`.
///
/// `step` sends the input's position and road as a Measurement frame (counter incrementing
/// modulo 256) and waits for the Demand frame echoing that counter; Status frames,
/// CommandAcks and demands with another counter seen meanwhile are kept. The **mirror**, a
/// host `model_core` controller with the firmware's defaults
/// (`mil_firmware::config::default_params()` at `DT`), is fed with the *decoded*
/// measurement frame (exactly the values the firmware sees; no force or speed, as no
/// MeasurementAux frames are sent) and its demand encoded with `mil_frames::encode_demand`;
/// [`RemoteBoard::mismatches`] counts the samples whose frames differ.
pub struct RemoteBoard<T: Transport> {
    transport: T,
    timeout: Duration,
    counter: u8,
    mirror: Controller,
    status: Status,
    samples: Vec<Sample>,
    statuses: Vec<StatusFrame>,
    acks: Vec<CommandAck>,
    stray_demands: Vec<mil_frames::Demand>,
    undecodable: u64,
    followers: usize,
}

fn mode_of(m: mil_frames::Mode) -> Mode {
    match m {
        mil_frames::Mode::Idle => Mode::Idle,
        mil_frames::Mode::Running => Mode::Running,
        mil_frames::Mode::Fault => Mode::Fault,
    }
}

impl<T: Transport> RemoteBoard<T> {
    /// A board behind `transport`, mirror Idle, next counter 0.
    ///
    /// # Errors
    /// The firmware's default parameters were refused by model-core (never, unless the
    /// firmware's configuration is broken).
    pub fn new(transport: T) -> Result<Self, String> {
        let mirror = Controller::with_params(&default_params(), DT)
            .map_err(|e| format!("mirror parameters: {e:?}"))?;
        let status = mirror.status();
        Ok(Self {
            transport,
            timeout: DEFAULT_REPLY_TIMEOUT,
            counter: 0,
            mirror,
            status,
            samples: Vec::new(),
            statuses: Vec::new(),
            acks: Vec::new(),
            stray_demands: Vec::new(),
            undecodable: 0,
            followers: 0,
        })
    }

    /// Sets how long to wait for a demand or an acknowledgement.
    pub fn with_timeout(mut self, timeout: Duration) -> Self {
        self.timeout = timeout;
        self
    }

    /// After each step's demand, also waits for `n` frames that are not MiL messages (the
    /// step's XCP DAQ packets, which the board sends right after the demand) before the next
    /// measurement goes out: the host then paces the run as a bus would, instead of sending
    /// measurements faster than the emulated board's link can carry the step's traffic.
    /// They are counted in [`RemoteBoard::undecodable`].
    pub fn with_followers(mut self, n: usize) -> Self {
        self.followers = n;
        self
    }

    /// The transport (e.g. to send malformed lines).
    pub fn transport_mut(&mut self) -> &mut T {
        &mut self.transport
    }

    /// The transport back.
    pub fn into_transport(self) -> T {
        self.transport
    }

    /// Every lockstep sample so far.
    pub fn samples(&self) -> &[Sample] {
        &self.samples
    }

    /// Samples whose demand frame differs from the mirror's.
    pub fn mismatches(&self) -> usize {
        self.samples.iter().filter(|s| s.mismatch()).count()
    }

    /// Status frames received so far.
    pub fn statuses(&self) -> &[StatusFrame] {
        &self.statuses
    }

    /// CommandAcks received so far.
    pub fn acks(&self) -> &[CommandAck] {
        &self.acks
    }

    /// Demand frames that echoed no pending measurement (watchdog ticks, late answers).
    pub fn stray_demands(&self) -> &[mil_frames::Demand] {
        &self.stray_demands
    }

    /// Frames received that did not decode, or host-to-board frames (an echo).
    pub fn undecodable(&self) -> u64 {
        self.undecodable
    }

    /// The counter the next measurement carries.
    pub fn next_counter(&self) -> u8 {
        self.counter
    }

    /// The host mirror of the firmware's controller.
    pub fn mirror(&self) -> &Controller {
        &self.mirror
    }

    /// Receives the next decoded board-to-host message within `timeout` (`None` on
    /// timeout), recording Status frames, acks and demands like `step` does.
    ///
    /// # Errors
    /// A transport error.
    pub fn recv_message(&mut self, timeout: Duration) -> Result<Option<Message>, String> {
        let deadline = Instant::now() + timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            let Some(frame) = self
                .transport
                .recv(left)
                .map_err(|e| format!("receive: {e}"))?
            else {
                return Ok(None);
            };
            match decode(&LAYOUT, &frame) {
                Ok(m @ Message::Status(s)) => {
                    self.statuses.push(s);
                    return Ok(Some(m));
                }
                Ok(m @ Message::CommandAck(a)) => {
                    self.acks.push(a);
                    return Ok(Some(m));
                }
                Ok(m @ Message::Demand(d)) => {
                    self.stray_demands.push(d);
                    return Ok(Some(m));
                }
                Ok(_) | Err(_) => self.undecodable += 1,
            }
        }
    }

    /// Receives until [`RemoteBoard::with_followers`] non-MiL frames arrived (MiL messages
    /// met meanwhile are recorded as in `step`).
    fn await_followers(&mut self) -> Result<(), String> {
        let deadline = Instant::now() + self.timeout;
        let mut seen = 0;
        while seen < self.followers {
            let left = deadline.saturating_duration_since(Instant::now());
            let Some(frame) = self
                .transport
                .recv(left)
                .map_err(|e| format!("receive: {e}"))?
            else {
                return Err(format!(
                    "{seen} of the {} frames that follow a demand arrived within {:?}",
                    self.followers, self.timeout
                ));
            };
            match decode(&LAYOUT, &frame) {
                Ok(Message::Demand(d)) => self.stray_demands.push(d),
                Ok(Message::Status(s)) => self.statuses.push(s),
                Ok(Message::CommandAck(a)) => self.acks.push(a),
                Ok(_) | Err(_) => {
                    self.undecodable += 1;
                    seen += 1;
                }
            }
        }
        Ok(())
    }

    /// Sends a Command frame and waits for the CommandAck echoing its command number.
    ///
    /// # Errors
    /// The command could not be encoded, a transport error, or no ack within the timeout.
    pub fn command(
        &mut self,
        command: CommandKind,
        index: u8,
        value: f32,
    ) -> Result<CommandAck, String> {
        let frame = encode_command(
            &LAYOUT,
            &Command {
                command,
                index,
                value,
            },
        )
        .map_err(|e| format!("encode command: {e:?}"))?;
        self.command_frame(&frame)
    }

    /// Sends any frame on the Command ID (e.g. with a NaN value) and waits for the
    /// CommandAck echoing its first byte (the raw command number). Applies an accepted
    /// Start, Stop or ClearFault to the mirror as well.
    ///
    /// # Errors
    /// A transport error, or no ack within the timeout.
    pub fn command_frame(&mut self, frame: &RawFrame) -> Result<CommandAck, String> {
        self.transport
            .send(frame)
            .map_err(|e| format!("send command: {e}"))?;
        let deadline = Instant::now() + self.timeout;
        let raw = frame.data[0];
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.recv_message(left)? {
                None => {
                    return Err(format!(
                        "no CommandAck for command {raw} within {:?}",
                        self.timeout
                    ))
                }
                Some(Message::CommandAck(a)) if a.command == raw => {
                    if a.result == 0 {
                        match CommandKind::from_u8(raw) {
                            Some(CommandKind::Start) => {
                                self.mirror.start();
                            }
                            Some(CommandKind::Stop) => self.mirror.stop(),
                            Some(CommandKind::ClearFault) => {
                                self.mirror.clear_fault();
                            }
                            _ => {}
                        }
                    }
                    return Ok(a);
                }
                Some(_) => {}
            }
        }
    }

    /// The demand of the mirror for the decoded measurement, as a frame.
    fn mirror_step(&mut self, m: &mil_frames::Measurement) -> Result<RawFrame, String> {
        let mut input = ModelInput::default();
        input.position[0] = m.position_m;
        input.road[0] = m.road_m;
        let force = self.mirror.step(&input)[0];
        let s = self.mirror.status();
        encode_demand(
            &LAYOUT,
            &mil_frames::Demand {
                channel: 0,
                demand_n: force,
                counter: m.counter,
                flags: DemandFlags {
                    mode: wire_mode(s.mode),
                    fault_latched: s.mode == Mode::Fault,
                    amplitude_limited: s.amplitude_limited & 1 != 0,
                    rate_limited: s.rate_limited & 1 != 0,
                },
            },
        )
        .map_err(|e| format!("mirror demand: {e:?}"))
    }
}

impl<T: Transport> mil_rig::harness::Board<1> for RemoteBoard<T> {
    fn start(&mut self) -> Result<(), String> {
        let ack = self.command(CommandKind::Start, 0, 0.0)?;
        if ack.result != 0 {
            return Err(format!("Start refused with code {}", ack.result));
        }
        self.status.mode = mode_of(ack.mode);
        Ok(())
    }

    fn step(&mut self, input: &ModelInput<1>) -> Result<[f32; 1], String> {
        let counter = self.counter;
        let frame = encode_measurement(
            &LAYOUT,
            &mil_frames::Measurement {
                channel: 0,
                position_m: input.position[0],
                road_m: input.road[0],
                counter,
            },
        )
        .map_err(|e| format!("encode measurement: {e:?}"))?;
        let Ok(Message::Measurement(decoded)) = decode(&LAYOUT, &frame) else {
            return Err("the measurement frame does not decode".into());
        };
        let mirror = self.mirror_step(&decoded)?;
        self.transport
            .send(&frame)
            .map_err(|e| format!("send measurement: {e}"))?;
        self.counter = counter.wrapping_add(1);
        let deadline = Instant::now() + self.timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            let Some(reply) = self
                .transport
                .recv(left)
                .map_err(|e| format!("receive: {e}"))?
            else {
                return Err(format!(
                    "no demand for counter {counter} within {:?}",
                    self.timeout
                ));
            };
            match decode(&LAYOUT, &reply) {
                Ok(Message::Demand(d)) if d.counter == counter => {
                    self.samples.push(Sample {
                        measurement: frame,
                        firmware: reply,
                        mirror,
                    });
                    let fault = if d.flags.mode == mil_frames::Mode::Fault {
                        self.statuses.last().map_or(0, |s| s.fault_causes)
                    } else {
                        0
                    };
                    self.status = Status {
                        mode: mode_of(d.flags.mode),
                        fault,
                        amplitude_limited: u8::from(d.flags.amplitude_limited),
                        rate_limited: u8::from(d.flags.rate_limited),
                        invalid_input: 0,
                    };
                    self.await_followers()?;
                    return Ok([d.demand_n]);
                }
                Ok(Message::Demand(d)) => self.stray_demands.push(d),
                Ok(Message::Status(s)) => self.statuses.push(s),
                Ok(Message::CommandAck(a)) => self.acks.push(a),
                Ok(_) | Err(_) => self.undecodable += 1,
            }
        }
    }

    fn status(&self) -> Status {
        self.status
    }
}
