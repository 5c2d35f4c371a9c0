//! The board behind a transport as a `Board` of the rig harness.

use std::time::{Duration, Instant};

use mil_firmware::config::{default_params, Controller, DT};
use mil_firmware::link::wire_mode;
use mil_frames::{
    decode, encode_command, encode_demand, encode_measurement, encode_measurement_aux, Command,
    CommandAck, CommandKind, DemandFlags, Message, RawFrame, Status as StatusFrame,
};
use model_core::board::{BoardParams, ModelKind, BOARD_CHANNELS};
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

/// The board (`mil-firmware`, any configuration) behind a [`Transport`], as a
/// `mil_rig::harness::Board<CH>` for the running configuration's `CH` channels.
///
/// `step` sends, for each channel, a MeasurementAux frame with its force and the speed
/// (only where the running model reads them: aero, and a substructure that takes forces)
/// and its Measurement frame with position and road (counter incrementing modulo 256), and
/// waits for the `CH` Demand frames echoing that counter; Status frames, CommandAcks and
/// demands with another counter seen meanwhile are kept. The **mirror**, a host
/// `model_core` board controller with the firmware's defaults
/// (`mil_firmware::config::default_params()` at `DT`, or the set given to
/// [`RemoteBoard::set_mirror`]), is fed with the *decoded* frames (exactly the values the
/// firmware sees, kept between samples as the firmware keeps them) and its demands encoded
/// with `mil_frames::encode_demand`; [`RemoteBoard::mismatches`] counts the demand frames
/// that differ.
pub struct RemoteBoard<T: Transport> {
    transport: T,
    timeout: Duration,
    counter: u8,
    mirror: Controller,
    /// The mirror's input as the firmware holds it (updated by each frame sent).
    input: ModelInput<BOARD_CHANNELS>,
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
            .map_err(|e| format!("mirror parameters: {e}"))?;
        let status = mirror.status();
        Ok(Self {
            transport,
            timeout: DEFAULT_REPLY_TIMEOUT,
            counter: 0,
            mirror,
            input: ModelInput::default(),
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

    /// Makes the mirror an idle controller of `params` at sample period `dt` (s): after the
    /// firmware was configured with the same set (e.g. [`crate::configure`]).
    ///
    /// # Errors
    /// The set is refused by model-core (the firmware refuses it too).
    pub fn set_mirror(&mut self, params: &BoardParams, dt: f32) -> Result<(), String> {
        self.mirror =
            Controller::with_params(params, dt).map_err(|e| format!("mirror parameters: {e}"))?;
        self.status = self.mirror.status();
        Ok(())
    }

    /// Sends Start and waits for its acknowledgement (the mirror starts with it).
    ///
    /// # Errors
    /// A transport error, no acknowledgement, or the board refused.
    pub fn start(&mut self) -> Result<(), String> {
        let ack = self.command(CommandKind::Start, 0, 0.0)?;
        if ack.result != 0 {
            return Err(format!("Start refused with code {}", ack.result));
        }
        self.status.mode = mode_of(ack.mode);
        Ok(())
    }

    /// Replays on the mirror the page writes the board accepted (e.g.
    /// [`crate::Configured::writes`]), starting from its working page `start`: each write
    /// is installed as the firmware installs it (the whole page decoded, the set swapped in
    /// between two steps), so the mirror's demand follows the firmware's across a change
    /// of configuration (which continues the demand rather than stepping it). The watchdog
    /// slot is not replayed (it does not touch the controller).
    ///
    /// # Errors
    /// A write the mirror refuses where the board accepted it (the two disagree).
    pub fn replay(
        &mut self,
        start: &[u32; mil_firmware::calibration::SLOTS],
        writes: &[(usize, u32)],
    ) -> Result<(), String> {
        let mut page = *start;
        for &(slot, word) in writes {
            let w = page
                .get_mut(slot)
                .ok_or_else(|| format!("slot {slot} beyond the page"))?;
            // The watchdog does not touch the controller, and the QEMU build may switch it
            // off where this (host) build refuses to: the mirror keeps its own.
            if slot != mil_firmware::calibration::SLOT_WATCHDOG {
                *w = word;
            }
            let (prepared, _) = mil_firmware::calibration::decode_page(&page).map_err(|code| {
                format!("the mirror refuses the write of slot {slot} (code {code}) the board took")
            })?;
            self.mirror.swap(&prepared).map_err(|e| {
                format!("the mirror refuses to install slot {slot} ({e}) where the board did")
            })?;
        }
        self.status = self.mirror.status();
        Ok(())
    }

    /// The running model reads the channels' forces and the speed (MeasurementAux frames).
    fn sends_aux(&self) -> bool {
        match self.mirror.kind() {
            ModelKind::Tyre => false,
            ModelKind::Aero => true,
            ModelKind::Substructure => {
                self.mirror
                    .params()
                    .substructure
                    .causality()
                    .is_some_and(|c| {
                        matches!(
                            c,
                            model_core::Causality::Admittance
                                | model_core::Causality::AdmittanceThroughImpedance
                        )
                    })
            }
        }
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
        index: u16,
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
        .map_err(|e| format!("encode command: {e}"))?;
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

    /// The mirror's step on its input: the demand frame of each of the first `channels`
    /// channels, echoing `counter`.
    fn mirror_step(&mut self, channels: usize, counter: u8) -> Result<Vec<RawFrame>, String> {
        let demand = self.mirror.step(&self.input);
        let s = self.mirror.status();
        (0..channels)
            .map(|ch| {
                let bit = |mask: u8| mask.checked_shr(ch as u32).unwrap_or(0) & 1 != 0;
                encode_demand(
                    &LAYOUT,
                    &mil_frames::Demand {
                        channel: ch as u8,
                        demand_n: demand.get(ch).copied().unwrap_or(0.0),
                        counter,
                        flags: DemandFlags {
                            mode: wire_mode(s.mode),
                            fault_latched: s.mode == Mode::Fault,
                            amplitude_limited: bit(s.amplitude_limited),
                            rate_limited: bit(s.rate_limited),
                        },
                    },
                )
                .map_err(|e| format!("mirror demand: {e}"))
            })
            .collect()
    }

    /// The frames of one sample of `input` (aux frames where the model reads them, then
    /// the measurements), with the mirror's input updated from their decoded values.
    fn sample_frames<const CH: usize>(
        &mut self,
        input: &ModelInput<CH>,
        counter: u8,
    ) -> Result<(Vec<RawFrame>, Vec<RawFrame>), String> {
        let aux = self.sends_aux();
        let mut frames = Vec::with_capacity(2 * CH);
        let mut measurements = Vec::with_capacity(CH);
        for ch in 0..CH {
            if aux {
                let frame = encode_measurement_aux(
                    &LAYOUT,
                    &mil_frames::MeasurementAux {
                        channel: ch as u8,
                        force_n: input.force[ch],
                        speed_m_s: input.speed,
                    },
                )
                .map_err(|e| format!("encode aux measurement: {e}"))?;
                let Ok(Message::MeasurementAux(d)) = decode(&LAYOUT, &frame) else {
                    return Err("the aux measurement frame does not decode".into());
                };
                self.input.force[ch] = d.force_n;
                self.input.speed = d.speed_m_s;
                frames.push(frame);
            }
            let frame = encode_measurement(
                &LAYOUT,
                &mil_frames::Measurement {
                    channel: ch as u8,
                    position_m: input.position[ch],
                    road_m: input.road[ch],
                    counter,
                },
            )
            .map_err(|e| format!("encode measurement: {e}"))?;
            let Ok(Message::Measurement(d)) = decode(&LAYOUT, &frame) else {
                return Err("the measurement frame does not decode".into());
            };
            self.input.position[ch] = d.position_m;
            self.input.road[ch] = d.road_m;
            frames.push(frame);
            measurements.push(frame);
        }
        Ok((frames, measurements))
    }
}

impl<T: Transport, const CH: usize> mil_rig::harness::Board<CH> for RemoteBoard<T> {
    fn start(&mut self) -> Result<(), String> {
        RemoteBoard::start(self)
    }

    fn step(&mut self, input: &ModelInput<CH>) -> Result<[f32; CH], String> {
        if CH != self.mirror.channels() {
            return Err(format!(
                "a {CH}-channel rig on a {}-channel configuration",
                self.mirror.channels()
            ));
        }
        let counter = self.counter;
        let (frames, measurements) = self.sample_frames(input, counter)?;
        let mirror = self.mirror_step(CH, counter)?;
        for frame in &frames {
            self.transport
                .send(frame)
                .map_err(|e| format!("send measurement: {e}"))?;
        }
        self.counter = counter.wrapping_add(1);
        let deadline = Instant::now() + self.timeout;
        let mut replies: [Option<(RawFrame, mil_frames::Demand)>; CH] = [None; CH];
        while replies.iter().any(Option::is_none) {
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
                Ok(Message::Demand(d))
                    if d.counter == counter
                        && replies
                            .get(usize::from(d.channel))
                            .is_some_and(Option::is_none) =>
                {
                    if let Some(r) = replies.get_mut(usize::from(d.channel)) {
                        *r = Some((reply, d));
                    }
                }
                Ok(Message::Demand(d)) => self.stray_demands.push(d),
                Ok(Message::Status(s)) => self.statuses.push(s),
                Ok(Message::CommandAck(a)) => self.acks.push(a),
                Ok(_) | Err(_) => self.undecodable += 1,
            }
        }
        let mut out = [0.0; CH];
        let mut status = Status {
            mode: Mode::Idle,
            fault: 0,
            amplitude_limited: 0,
            rate_limited: 0,
            invalid_input: 0,
        };
        for (ch, ((reply, measurement), mirror)) in
            replies.iter().zip(&measurements).zip(&mirror).enumerate()
        {
            let Some((firmware, d)) = reply else {
                return Err(format!("no demand of channel {ch}"));
            };
            self.samples.push(Sample {
                measurement: *measurement,
                firmware: *firmware,
                mirror: *mirror,
            });
            out[ch] = d.demand_n;
            status.mode = mode_of(d.flags.mode);
            status.amplitude_limited |= u8::from(d.flags.amplitude_limited) << ch;
            status.rate_limited |= u8::from(d.flags.rate_limited) << ch;
        }
        if status.mode == Mode::Fault {
            status.fault = self.statuses.last().map_or(0, |s| s.fault_causes);
        }
        self.status = status;
        self.await_followers()?;
        Ok(out)
    }

    fn status(&self) -> Status {
        self.status
    }
}
