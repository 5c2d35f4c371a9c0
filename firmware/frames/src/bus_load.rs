//! Bus-load budget of the MiL frame schedule on classic CAN.
//!
//! # Frame length
//!
//! A classic CAN data frame with a standard (11-bit) ID and `n` data bytes has
//! `47 + 8n` bits without stuffing: SOF 1, ID 11, RTR 1, IDE 1, r0 1, DLC 4, data `8n`,
//! CRC 15, CRC delimiter 1, ACK slot and delimiter 2, EOF 7 and the 3-bit intermission before
//! the next frame ([`frame_bits`]). Bit stuffing applies to the `34 + 8n` bits from SOF to the
//! end of the CRC; the common worst-case bound is `⌊(34 + 8n − 1) / 4⌋` stuff bits
//! ([`stuff_bits_worst`]), as used in CAN response-time analysis (R. I. Davis, A. Burns,
//! R. J. Bril, J. J. Lukkien, "Controller Area Network (CAN) schedulability analysis: refuted,
//! revisited and revised", Real-Time Systems 35 (2007), frame time
//! `(g + 8n + 13 + ⌊(g + 8n − 1)/4⌋)·τ` with `g = 34` for standard IDs).
//! So: 8 bytes 111 / 135 bits (nominal / worst case), 7 bytes 103 / 125, 6 bytes 95 / 115,
//! 4 bytes 79 / 95.
//!
//! # Schedule
//!
//! Per sample and channel a [`Measurement`](crate::Measurement) (7 bytes) and a
//! [`Demand`](crate::Demand) (6 bytes): 240 bits worst case; a
//! [`MeasurementAux`](crate::MeasurementAux) (6 bytes, 115 bits) every sample on the channels
//! whose model takes a measured force, or at [`SPEED_HZ`] for the vehicle speed alone (the
//! board holds the last speed: it changes over seconds); the [`Status`](crate::Status)
//! heartbeat (8 bytes) at [`HEARTBEAT_HZ`]; and [`XCP_HEADROOM_BIT_PER_S`] kept free for a
//! calibration tool. Commands and their acknowledgements are sporadic (230 bits a pair) and
//! fall within the XCP headroom. [`Schedule::load`] uses the worst case,
//! [`Schedule::load_nominal`] no stuffing.
//!
//! # Two buses
//! The STM32F405 has two bxCAN controllers. A configuration of more channels than one bus
//! carries at its rate puts its channels on both ([`Schedule::buses`] = 2): channel `c` on
//! bus `c mod 2` (CAN1: channels 0, 2, …; CAN2: 1, 3, …), each frame with the same ID on its
//! bus as in `mil.dbc` (the DBC describes each bus; the IDs are per channel, so they never
//! collide). The heartbeat, the speed, commands and XCP stay on CAN1; the budget counts
//! the busier bus, CAN1 (it carries the most channels and everything else).

use crate::layout::MessageKind;

/// Bus-load budget the MiL schedule is designed to (fraction of the bitrate), leaving room for
/// commands, retransmissions after errors and other nodes.
pub const BUDGET: f64 = 0.6;

/// Status heartbeat rate, Hz.
pub const HEARTBEAT_HZ: f64 = 10.0;

/// Rate of the speed-only auxiliary frame (Hz) of a model that takes the vehicle speed but
/// no measured force (the aero model).
pub const SPEED_HZ: f64 = 100.0;

/// Bus capacity kept free for a calibration tool (bit/s): an XCP master polling 100 values a
/// second (SHORT_UPLOAD and its answer, 270 bits worst case each: 27 kbit/s) and one DAQ
/// list of an 8-byte DTO at 100 Hz (13.5 kbit/s), with room for Command frames.
pub const XCP_HEADROOM_BIT_PER_S: f64 = 50_000.0;

/// Bits of a classic CAN data frame, standard ID, `dlc` data bytes (clamped to 8), including
/// the 3-bit intermission, without stuffing: `47 + 8·dlc`.
pub const fn frame_bits(dlc: u8) -> u32 {
    let n = if dlc > 8 { 8 } else { dlc } as u32;
    47 + 8 * n
}

/// Worst-case stuff bits of that frame: `⌊(34 + 8·dlc − 1) / 4⌋`.
pub const fn stuff_bits_worst(dlc: u8) -> u32 {
    let n = if dlc > 8 { 8 } else { dlc } as u32;
    (34 + 8 * n - 1) / 4
}

/// Worst-case bits of that frame: [`frame_bits`] + [`stuff_bits_worst`].
pub const fn frame_bits_worst(dlc: u8) -> u32 {
    frame_bits(dlc) + stuff_bits_worst(dlc)
}

/// The bus (0: CAN1, 1: CAN2) a frame of `kind` for `channel` goes on when the channels
/// are spread over `buses` buses: a per-channel frame on `channel mod buses`, the others
/// (heartbeat, commands and their acknowledgements) on CAN1, as XCP.
pub const fn bus_of(kind: MessageKind, channel: u8, buses: u8) -> u8 {
    if kind.per_channel() && buses > 1 {
        channel % buses
    } else {
        0
    }
}

/// A periodic frame: data length and rate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameRate {
    /// Data length, bytes.
    pub dlc: u8,
    /// Frames per second, 1/s.
    pub per_s: f64,
}

/// Bus load (fraction of `bit_per_s`) of a set of periodic frames; `worst_case` adds the
/// worst-case stuff bits.
pub fn bus_load(frames: &[FrameRate], bit_per_s: f64, worst_case: bool) -> f64 {
    let bits: f64 = frames
        .iter()
        .map(|f| {
            let bits = if worst_case {
                frame_bits_worst(f.dlc)
            } else {
                frame_bits(f.dlc)
            };
            f64::from(bits) * f.per_s
        })
        .sum();
    bits / bit_per_s
}

/// The MiL schedule: per sample, a measurement and a demand on every channel and an
/// auxiliary measurement on `aux_channels` of them; the speed at `speed_hz`; a heartbeat at
/// `heartbeat_hz`; the XCP headroom; the channels over `buses` buses.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Schedule {
    /// Sample rate, Hz.
    pub sample_rate_hz: f64,
    /// Channels (each: measurement + demand per sample).
    pub channels: u8,
    /// Channels that also send a [`MeasurementAux`](crate::MeasurementAux) per sample.
    pub aux_channels: u8,
    /// Rate of a speed-only auxiliary frame, Hz (0: none).
    pub speed_hz: f64,
    /// Status heartbeat rate, Hz.
    pub heartbeat_hz: f64,
    /// Capacity kept free for XCP and commands, bit/s.
    pub xcp_bit_per_s: f64,
    /// Buses the channels are spread over (1 or 2, see the module docs).
    pub buses: u8,
}

impl Schedule {
    /// `channels` tyre (hub) channels at `sample_rate_hz` on one bus.
    pub const fn tyre(channels: u8, sample_rate_hz: f64) -> Self {
        Schedule {
            sample_rate_hz,
            channels,
            aux_channels: 0,
            speed_hz: 0.0,
            heartbeat_hz: HEARTBEAT_HZ,
            xcp_bit_per_s: XCP_HEADROOM_BIT_PER_S,
            buses: 1,
        }
    }

    /// Aero rig: front and rear down-force channels (ride heights in), the vehicle speed at
    /// [`SPEED_HZ`], one bus.
    pub const fn aero(sample_rate_hz: f64) -> Self {
        Schedule {
            channels: 2,
            speed_hz: SPEED_HZ,
            ..Self::tyre(2, sample_rate_hz)
        }
    }

    /// A substructure on `channels` channels; with `measured_force` (the admittance
    /// causalities) every channel also sends its force every sample.
    pub const fn substructure(channels: u8, measured_force: bool, sample_rate_hz: f64) -> Self {
        Schedule {
            aux_channels: if measured_force { channels } else { 0 },
            ..Self::tyre(channels, sample_rate_hz)
        }
    }

    /// The same schedule over `buses` buses (1 or 2).
    pub const fn on_buses(self, buses: u8) -> Self {
        Schedule { buses, ..self }
    }

    /// Channels on the busiest bus (CAN1): `⌈channels / buses⌉`.
    pub const fn channels_on_busiest(&self) -> u8 {
        let buses = if self.buses == 0 { 1 } else { self.buses };
        self.channels.div_ceil(buses)
    }

    fn per_sample_bits(&self, bits: fn(u8) -> u32) -> f64 {
        let pair = bits(MessageKind::Measurement.dlc()) + bits(MessageKind::Demand.dlc());
        let share = |n: u8| {
            let buses = if self.buses == 0 { 1 } else { self.buses };
            n.div_ceil(buses)
        };
        f64::from(share(self.channels)) * f64::from(pair)
            + f64::from(share(self.aux_channels))
                * f64::from(bits(MessageKind::MeasurementAux.dlc()))
    }

    /// Worst-case bits per sample on the busiest bus.
    pub fn bits_per_sample_worst(&self) -> f64 {
        self.per_sample_bits(frame_bits_worst)
    }

    /// Bits per second on the busiest bus that do not scale with the sample rate: the
    /// heartbeat, the speed and the XCP headroom.
    fn fixed_bits(&self, bits: fn(u8) -> u32) -> f64 {
        f64::from(bits(MessageKind::Status.dlc())) * self.heartbeat_hz
            + f64::from(bits(MessageKind::MeasurementAux.dlc())) * self.speed_hz
            + self.xcp_bit_per_s
    }

    /// Worst-case load (fraction) of the busiest bus at `bit_per_s`.
    pub fn load(&self, bit_per_s: f64) -> f64 {
        (self.per_sample_bits(frame_bits_worst) * self.sample_rate_hz
            + self.fixed_bits(frame_bits_worst))
            / bit_per_s
    }

    /// Load (fraction) of the busiest bus at `bit_per_s` without stuff bits (the best case).
    pub fn load_nominal(&self, bit_per_s: f64) -> f64 {
        (self.per_sample_bits(frame_bits) * self.sample_rate_hz + self.fixed_bits(frame_bits))
            / bit_per_s
    }

    /// Highest sample rate (Hz) at which this schedule's worst-case load stays within
    /// `max_load` at `bit_per_s` (its own `sample_rate_hz` is ignored); 0 when the fixed
    /// traffic alone exceeds it.
    pub fn max_sample_rate_hz(&self, bit_per_s: f64, max_load: f64) -> f64 {
        let per_sample = self.per_sample_bits(frame_bits_worst);
        let room = max_load * bit_per_s - self.fixed_bits(frame_bits_worst);
        if per_sample <= 0.0 || room <= 0.0 {
            0.0
        } else {
            room / per_sample
        }
    }

    /// The schedule on as few buses as carry it at `bit_per_s` within [`BUDGET`]: one bus
    /// when it fits there (a rig with one bus wired runs it), else both of the board's when
    /// it has several channels (channel `c` on bus `c mod 2`); one channel stays on one bus.
    pub fn fitting(self, bit_per_s: f64) -> Self {
        let one = self.on_buses(1);
        if one.check(bit_per_s).is_ok() || self.channels < 2 {
            one
        } else {
            self.on_buses(2)
        }
    }

    /// `Ok` when the worst-case load at `bit_per_s` is within [`BUDGET`]; otherwise the
    /// load and the highest rate that fits, for the refusal's message.
    pub fn check(&self, bit_per_s: f64) -> Result<(), OverBudget> {
        let load = self.load(bit_per_s);
        if load <= BUDGET {
            Ok(())
        } else {
            Err(OverBudget {
                load,
                max_sample_rate_hz: self.max_sample_rate_hz(bit_per_s, BUDGET),
            })
        }
    }
}

/// A schedule beyond the bus budget.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OverBudget {
    /// Its worst-case load of the busiest bus (fraction).
    pub load: f64,
    /// The highest sample rate within the budget (Hz).
    pub max_sample_rate_hz: f64,
}
