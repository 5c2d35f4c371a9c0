//! Demand limits: amplitude clamp and rate limiter.

use crate::params::{Field, ParamError, Range};

/// Allowed demand magnitudes for a limit, in the demand's unit (N for force-controlled
/// actuators, m for position-controlled ones).
pub const DEMAND_AMPLITUDE: Range = Range::new(-1.0e7, 1.0e7);
/// Allowed rate limits, demand unit per second (N/s or m/s).
pub const DEMAND_RATE: Range = Range::new(1.0e-6, 1.0e12);

/// Amplitude and rate limits of one channel's actuator demand.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct DemandLimits {
    /// Lowest demand (N or m).
    pub min: f32,
    /// Highest demand (N or m).
    pub max: f32,
    /// Largest rate of change of the demand in normal running (unit/s).
    pub rate: f32,
}

impl DemandLimits {
    /// Validates: finite, in range, `min < max`, rate positive.
    pub fn validate(&self) -> Result<(), ParamError> {
        DEMAND_AMPLITUDE.check(Field::DemandAmplitude, self.min)?;
        DEMAND_AMPLITUDE.check(Field::DemandAmplitude, self.max)?;
        DEMAND_RATE.check(Field::DemandRate, self.rate)?;
        if self.min >= self.max {
            return Err(ParamError::Inconsistent(Field::DemandAmplitude));
        }
        Ok(())
    }

    /// These limits one step closer to `target`'s amplitude limits, for a demand now at
    /// `demand`: a bound that widens, or narrows without cutting the demand, goes there at
    /// once; a bound that would cut the demand starts at the demand and closes in by at most
    /// `max_step` a step (the rate limit's step). The rate is `target`'s.
    #[inline]
    pub fn towards(&self, target: &Self, demand: f32, max_step: f32) -> Self {
        // Compares, not `f32::min`/`max` (calls to `fminf`/`fmaxf` on the Cortex-M4): every
        // value here is finite (validated limits, a demand the controller keeps finite).
        let lesser = |a: f32, b: f32| if a < b { a } else { b };
        let greater = |a: f32, b: f32| if a > b { a } else { b };
        let upper = lesser(self.max, demand);
        let max = if target.max >= upper {
            target.max
        } else {
            greater(upper - max_step, target.max)
        };
        let lower = greater(self.min, demand);
        let min = if target.min <= lower {
            target.min
        } else {
            lesser(lower + max_step, target.min)
        };
        Self {
            // A bound still closing in never crosses the other bound's new value.
            min: lesser(min, target.max),
            max: greater(max, target.min),
            rate: target.rate,
        }
    }

    /// Clamps `x` into `[min, max]`; the flag says whether the clamp acted. A NaN `x` maps to
    /// `min`'s side deterministically (never returned as NaN).
    #[inline]
    pub fn clamp(&self, x: f32) -> (f32, bool) {
        if x > self.max {
            (self.max, true)
        } else if x >= self.min {
            (x, false)
        } else {
            // Below the minimum, or NaN.
            (self.min, true)
        }
    }
}

/// Rate limiter: the output moves towards its target by at most `rate · dt` per sample.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RateLimiter {
    /// The last output.
    pub output: f32,
}

impl RateLimiter {
    /// A limiter whose output starts at `initial`.
    pub const fn new(initial: f32) -> Self {
        Self { output: initial }
    }

    /// Moves the output towards `target` by at most `max_step`; returns the output and
    /// whether the limit acted. A non-finite target leaves the output where it is.
    #[inline]
    pub fn step(&mut self, target: f32, max_step: f32) -> (f32, bool) {
        let delta = target - self.output;
        let (next, limited) = if delta > max_step {
            (self.output + max_step, true)
        } else if delta < -max_step {
            (self.output - max_step, true)
        } else if delta.is_finite() {
            (target, false)
        } else {
            (self.output, true)
        };
        self.output = next;
        (next, limited)
    }
}
