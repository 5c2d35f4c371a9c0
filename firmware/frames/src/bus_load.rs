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
//! [`MeasurementAux`](crate::MeasurementAux) (6 bytes, 115 bits) on the channels that need
//! it; the [`Status`](crate::Status) heartbeat (8 bytes) at 10 Hz. Commands and their
//! acknowledgements are sporadic (230 bits a pair) and left out. [`Schedule::load`] uses the
//! worst case, [`Schedule::load_nominal`] no stuffing.

use crate::layout::MessageKind;

/// Bus-load budget the MiL schedule is designed to (fraction of the bitrate), leaving room for
/// commands, retransmissions after errors and other nodes.
pub const BUDGET: f64 = 0.6;

/// Status heartbeat rate, Hz.
pub const HEARTBEAT_HZ: f64 = 10.0;

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
/// auxiliary measurement on `aux_channels` of them; a heartbeat at `heartbeat_hz`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Schedule {
    /// Sample rate, Hz.
    pub sample_rate_hz: f64,
    /// Channels (each: measurement + demand per sample).
    pub channels: u8,
    /// Channels that also send a [`MeasurementAux`](crate::MeasurementAux) per sample.
    pub aux_channels: u8,
    /// Status heartbeat rate, Hz.
    pub heartbeat_hz: f64,
}

impl Schedule {
    /// `channels` tyre (hub) channels at `sample_rate_hz`, no auxiliary frames, 10 Hz heartbeat.
    pub const fn tyre(channels: u8, sample_rate_hz: f64) -> Self {
        Schedule {
            sample_rate_hz,
            channels,
            aux_channels: 0,
            heartbeat_hz: HEARTBEAT_HZ,
        }
    }

    /// Aero rig: front and rear down-force channels, the vehicle speed on one of them
    /// (one auxiliary frame per sample), 10 Hz heartbeat.
    pub const fn aero(sample_rate_hz: f64) -> Self {
        Schedule {
            sample_rate_hz,
            channels: 2,
            aux_channels: 1,
            heartbeat_hz: HEARTBEAT_HZ,
        }
    }

    fn per_sample_bits(&self, bits: fn(u8) -> u32) -> f64 {
        let pair = bits(MessageKind::Measurement.dlc()) + bits(MessageKind::Demand.dlc());
        f64::from(self.channels) * f64::from(pair)
            + f64::from(self.aux_channels) * f64::from(bits(MessageKind::MeasurementAux.dlc()))
    }

    /// Worst-case bits per sample (all channels).
    pub fn bits_per_sample_worst(&self) -> f64 {
        self.per_sample_bits(frame_bits_worst)
    }

    fn heartbeat_bits(&self, bits: fn(u8) -> u32) -> f64 {
        f64::from(bits(MessageKind::Status.dlc())) * self.heartbeat_hz
    }

    /// Worst-case bus load (fraction) at `bit_per_s`.
    pub fn load(&self, bit_per_s: f64) -> f64 {
        (self.per_sample_bits(frame_bits_worst) * self.sample_rate_hz
            + self.heartbeat_bits(frame_bits_worst))
            / bit_per_s
    }

    /// Bus load (fraction) at `bit_per_s` without stuff bits (the best case).
    pub fn load_nominal(&self, bit_per_s: f64) -> f64 {
        (self.per_sample_bits(frame_bits) * self.sample_rate_hz + self.heartbeat_bits(frame_bits))
            / bit_per_s
    }

    /// Highest sample rate (Hz) at which this schedule's worst-case load stays within
    /// `max_load` at `bit_per_s` (its own `sample_rate_hz` is ignored); 0 when the heartbeat
    /// alone exceeds it.
    pub fn max_sample_rate_hz(&self, bit_per_s: f64, max_load: f64) -> f64 {
        let per_sample = self.per_sample_bits(frame_bits_worst);
        let room = max_load * bit_per_s - self.heartbeat_bits(frame_bits_worst);
        if per_sample <= 0.0 || room <= 0.0 {
            0.0
        } else {
            room / per_sample
        }
    }
}
