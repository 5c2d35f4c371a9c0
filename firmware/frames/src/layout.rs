//! Where the frames are on the bus (base ID) and how the physical quantities are scaled.

use crate::dbc::{self, MessageSpec, SignalSpec};
use crate::error::{DecodeError, LayoutError};
use crate::limits;

/// The six messages.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum MessageKind {
    /// Servo controller → board, per channel, every sample.
    Measurement,
    /// Servo controller → board, per channel, only where the model needs it.
    MeasurementAux,
    /// Board → servo controller, per channel, one per measurement.
    Demand,
    /// Board → bus, heartbeat (about 10 Hz).
    Status,
    /// Tool → board.
    Command,
    /// Board → tool.
    CommandAck,
}

impl MessageKind {
    /// Every kind, in ID order.
    pub const ALL: [MessageKind; 6] = [
        MessageKind::Measurement,
        MessageKind::MeasurementAux,
        MessageKind::Demand,
        MessageKind::Status,
        MessageKind::Command,
        MessageKind::CommandAck,
    ];

    /// The message's layout from the DBC.
    pub const fn spec(self) -> MessageSpec {
        match self {
            MessageKind::Measurement => dbc::measurement::MESSAGE,
            MessageKind::MeasurementAux => dbc::measurement_aux::MESSAGE,
            MessageKind::Demand => dbc::demand::MESSAGE,
            MessageKind::Status => dbc::status::MESSAGE,
            MessageKind::Command => dbc::command::MESSAGE,
            MessageKind::CommandAck => dbc::command_ack::MESSAGE,
        }
    }

    /// Data length, bytes.
    pub const fn dlc(self) -> u8 {
        self.spec().dlc
    }

    /// One message per channel.
    pub const fn per_channel(self) -> bool {
        self.spec().per_channel
    }
}

/// Scale factors (physical units per count) of the fixed-point quantities. [`Scales::DBC`] are
/// the DBC's factors; a rig whose servo controller scales differently overrides them (the
/// DBC's physical limits still apply).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Scales {
    /// Measurement `Position`, m per count (DBC: 1e-6 m).
    pub position_m: f32,
    /// Measurement `Road`, m per count (DBC: 1e-6 m).
    pub road_m: f32,
    /// MeasurementAux `Force`, N per count (DBC: 0.1 N).
    pub force_n: f32,
    /// MeasurementAux `Speed`, m/s per count (DBC: 0.01 m/s).
    pub speed_m_s: f32,
    /// Demand `Demand`, N per count (DBC: 0.1 N).
    pub demand_n: f32,
}

impl Scales {
    /// The factors written in `mil.dbc`.
    pub const DBC: Scales = Scales {
        position_m: dbc::measurement::POSITION.factor as f32,
        road_m: dbc::measurement::ROAD.factor as f32,
        force_n: dbc::measurement_aux::FORCE.factor as f32,
        speed_m_s: dbc::measurement_aux::SPEED.factor as f32,
        demand_n: dbc::demand::DEMAND.factor as f32,
    };
}

impl Default for Scales {
    fn default() -> Self {
        Scales::DBC
    }
}

/// A fixed-point physical quantity as the codec uses it: the DBC signal, the factor and offset
/// in f32, and the valid raw range ("not available" excluded).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Quantity {
    pub(crate) spec: SignalSpec,
    pub(crate) factor: f32,
    pub(crate) offset: f32,
    pub(crate) raw_min: i64,
    pub(crate) raw_max: i64,
}

impl Quantity {
    /// At the DBC's own factor (limits from the generated table).
    const fn from_dbc(spec: SignalSpec) -> Self {
        Quantity {
            spec,
            factor: spec.factor as f32,
            offset: spec.offset as f32,
            raw_min: spec.raw_min,
            raw_max: spec.raw_max,
        }
    }

    fn with_factor(spec: SignalSpec, factor: f32) -> Result<Self, LayoutError> {
        let offset = spec.offset as f32;
        let (raw_min, raw_max) = limits::raw_limits(
            f64::from(factor),
            f64::from(offset),
            spec.min,
            spec.max,
            spec.len,
            spec.signed,
        )
        .ok_or(LayoutError::BadFactor)?;
        Ok(Quantity {
            spec,
            factor,
            offset,
            raw_min,
            raw_max,
        })
    }

    /// The "not available" raw value.
    pub(crate) const fn not_available(&self) -> i64 {
        limits::not_available(self.spec.len, self.spec.signed)
    }

    /// Physical value of a raw value read from the bus.
    pub(crate) fn decode(&self, raw: i64) -> Result<f32, DecodeError> {
        if raw == self.not_available() {
            Err(DecodeError::NotAvailable)
        } else if raw < self.raw_min || raw > self.raw_max {
            Err(DecodeError::OutOfRange)
        } else {
            Ok(raw as f32 * self.factor + self.offset)
        }
    }

    /// Raw value of a physical value, rounded to the nearest count (ties away from zero).
    /// `None` when it is not finite or outside the valid range and `saturate` is false; with
    /// `saturate` a finite value beyond the range gives the nearest limit.
    pub(crate) fn encode(&self, value: f32, saturate: bool) -> Option<i64> {
        if !value.is_finite() {
            return None;
        }
        // May overflow to ±inf for huge values and tiny factors: handled by the comparisons.
        let counts = f64::from(libm::roundf((value - self.offset) / self.factor));
        if counts < self.raw_min as f64 {
            saturate.then_some(self.raw_min)
        } else if counts > self.raw_max as f64 {
            saturate.then_some(self.raw_max)
        } else {
            // Inside [raw_min, raw_max] ⊂ ±2^32: exact.
            Some(counts as i64)
        }
    }

    /// Smallest valid physical value at this factor.
    pub(crate) fn min(&self) -> f32 {
        self.raw_min as f32 * self.factor + self.offset
    }

    /// Largest valid physical value at this factor.
    pub(crate) fn max(&self) -> f32 {
        self.raw_max as f32 * self.factor + self.offset
    }
}

/// Base ID and scaling of the MiL frames: everything the codec needs beyond the DBC table.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Layout {
    base_id: u16,
    pub(crate) position: Quantity,
    pub(crate) road: Quantity,
    pub(crate) force: Quantity,
    pub(crate) speed: Quantity,
    pub(crate) demand: Quantity,
}

impl Layout {
    /// The DBC's base ID (0x100) and factors.
    pub const DEFAULT: Layout = Layout {
        base_id: dbc::DEFAULT_BASE_ID,
        position: Quantity::from_dbc(dbc::measurement::POSITION),
        road: Quantity::from_dbc(dbc::measurement::ROAD),
        force: Quantity::from_dbc(dbc::measurement_aux::FORCE),
        speed: Quantity::from_dbc(dbc::measurement_aux::SPEED),
        demand: Quantity::from_dbc(dbc::demand::DEMAND),
    };

    /// A layout at `base_id` with the given scale factors.
    ///
    /// Errors: [`LayoutError::BaseIdTooHigh`] when `base_id` + the highest offset in use
    /// ([`dbc::HIGHEST_OFFSET`], 0x22) exceeds 0x7FF; [`LayoutError::BadFactor`] when a factor
    /// is not finite and positive or leaves no valid raw value.
    pub fn new(base_id: u16, scales: Scales) -> Result<Self, LayoutError> {
        if u32::from(base_id) + u32::from(dbc::HIGHEST_OFFSET) > 0x7FF {
            return Err(LayoutError::BaseIdTooHigh);
        }
        let finite = [
            scales.position_m,
            scales.road_m,
            scales.force_n,
            scales.speed_m_s,
            scales.demand_n,
        ]
        .iter()
        .all(|f| f.is_finite() && *f > 0.0);
        if !finite {
            return Err(LayoutError::BadFactor);
        }
        Ok(Layout {
            base_id,
            position: Quantity::with_factor(dbc::measurement::POSITION, scales.position_m)?,
            road: Quantity::with_factor(dbc::measurement::ROAD, scales.road_m)?,
            force: Quantity::with_factor(dbc::measurement_aux::FORCE, scales.force_n)?,
            speed: Quantity::with_factor(dbc::measurement_aux::SPEED, scales.speed_m_s)?,
            demand: Quantity::with_factor(dbc::demand::DEMAND, scales.demand_n)?,
        })
    }

    /// The DBC's factors at another base ID.
    pub fn with_base_id(base_id: u16) -> Result<Self, LayoutError> {
        Self::new(base_id, Scales::DBC)
    }

    /// Base ID (11-bit).
    pub const fn base_id(&self) -> u16 {
        self.base_id
    }

    /// Scale factors in use.
    pub const fn scales(&self) -> Scales {
        Scales {
            position_m: self.position.factor,
            road_m: self.road.factor,
            force_n: self.force.factor,
            speed_m_s: self.speed.factor,
            demand_n: self.demand.factor,
        }
    }

    /// Standard ID of a message (`channel` is ignored by the single messages; `None` for a
    /// per-channel message with `channel >= CHANNELS`).
    pub const fn id(&self, kind: MessageKind, channel: u8) -> Option<u16> {
        let spec = kind.spec();
        if spec.per_channel {
            if channel >= dbc::CHANNELS {
                return None;
            }
            Some(self.base_id + spec.id_offset + channel as u16)
        } else {
            Some(self.base_id + spec.id_offset)
        }
    }

    /// First and last standard ID (inclusive) of the MiL range, for acceptance filters:
    /// `base .. base + ID_RANGE`, cut at 0x7FF.
    pub const fn id_range(&self) -> (u16, u16) {
        let last = self.base_id + dbc::ID_RANGE - 1;
        (self.base_id, if last > 0x7FF { 0x7FF } else { last })
    }

    /// Which message a standard ID carries, with its channel (0 for single messages).
    ///
    /// Errors: [`DecodeError::Foreign`] outside the MiL range (or beyond 0x7FF),
    /// [`DecodeError::UnknownId`] for a free ID inside it.
    pub fn classify(&self, id: u16) -> Result<(MessageKind, u8), DecodeError> {
        if id > 0x7FF || id < self.base_id || id - self.base_id >= dbc::ID_RANGE {
            return Err(DecodeError::Foreign);
        }
        let offset = id - self.base_id;
        for kind in MessageKind::ALL {
            let spec = kind.spec();
            if spec.per_channel {
                if let Some(ch) = offset.checked_sub(spec.id_offset) {
                    if ch < u16::from(dbc::CHANNELS) {
                        return Ok((kind, ch as u8));
                    }
                }
            } else if offset == spec.id_offset {
                return Ok((kind, 0));
            }
        }
        Err(DecodeError::UnknownId)
    }

    /// Valid range `[min, max]` of the hub position at this layout's factor, m.
    pub fn position_range_m(&self) -> (f32, f32) {
        (self.position.min(), self.position.max())
    }

    /// Valid range `[min, max]` of the road input, m.
    pub fn road_range_m(&self) -> (f32, f32) {
        (self.road.min(), self.road.max())
    }

    /// Valid range `[min, max]` of the measured force, N.
    pub fn force_range_n(&self) -> (f32, f32) {
        (self.force.min(), self.force.max())
    }

    /// Valid range `[min, max]` of the vehicle speed, m/s.
    pub fn speed_range_m_s(&self) -> (f32, f32) {
        (self.speed.min(), self.speed.max())
    }

    /// Range `[min, max]` a demand saturates to, N.
    pub fn demand_range_n(&self) -> (f32, f32) {
        (self.demand.min(), self.demand.max())
    }
}

impl Default for Layout {
    fn default() -> Self {
        Layout::DEFAULT
    }
}
