//! Velocity estimation from sampled positions: backward difference followed by an optional
//! first-order low-pass (exact zero-order-hold discretisation).
//!
//! The numerical models need velocities (tyre damping `c_t`, interface damping `C_i`, road
//! velocity for damped ground connections) but the rig measures positions. A pure backward
//! difference amplifies measurement noise by `2/dt` at Nyquist; the low-pass trades that for
//! a phase lag of about `atan(f / f_c)` at frequency `f`. The lag is part of the numerical
//! model. Its exact discrete response,
//!
//! ```text
//! V(z) = inv_dt · gain · (1 − z⁻¹) / (1 − (1 − gain) z⁻¹)      (1/s)
//! ```
//!
//! built from these `f32` coefficients, is what the loop analysis (`mil-analysis`,
//! `VelocityEstimate::Board`) uses for the tyre's damping velocity (a numerical interface
//! impedance over a numerical part without masses, force control); the velocities of the
//! [`crate::substructure`] model are analysed as continuous derivatives.

use crate::params::{Field, ParamError, Range};

/// Allowed low-pass cut-off (Hz); 0 disables the low-pass (pure backward difference).
pub const VELOCITY_CUTOFF: Range = Range::new(0.0, 20_000.0);

/// Coefficients of a [`VelocityEstimator`], derived from a cut-off and the sample period.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VelocityFilterCoefficients {
    /// `1 / dt` (1/s).
    pub inv_dt: f32,
    /// Low-pass update gain `1 - exp(-2π f_c dt)`, in `(0, 1]`; 1 means no filtering.
    pub gain: f32,
}

impl VelocityFilterCoefficients {
    /// Coefficients for cut-off `cutoff_hz` (0: no low-pass) at sample period `dt` (s).
    pub fn new(cutoff_hz: f32, dt: f32) -> Result<Self, ParamError> {
        crate::params::check_sample_period(dt)?;
        VELOCITY_CUTOFF.check(Field::VelocityCutoff, cutoff_hz)?;
        let gain = if cutoff_hz == 0.0 {
            1.0
        } else {
            -libm::expm1f(-2.0 * core::f32::consts::PI * cutoff_hz * dt)
        };
        if !(gain > 0.0 && gain <= 1.0) {
            return Err(ParamError::OutOfRange(Field::VelocityCutoff));
        }
        Ok(Self {
            inv_dt: 1.0 / dt,
            gain,
        })
    }
}

/// State of a velocity estimator.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct VelocityEstimator {
    last_position: f32,
    velocity: f32,
    primed: bool,
}

impl VelocityEstimator {
    /// A fresh estimator: its first sample reports zero velocity.
    pub const fn new() -> Self {
        Self {
            last_position: 0.0,
            velocity: 0.0,
            primed: false,
        }
    }

    /// Feeds position `x` (m); returns the velocity estimate (m/s).
    #[inline]
    pub fn step(&mut self, c: &VelocityFilterCoefficients, x: f32) -> f32 {
        if self.primed {
            let raw = (x - self.last_position) * c.inv_dt;
            self.velocity += c.gain * (raw - self.velocity);
        } else {
            self.primed = true;
            self.velocity = 0.0;
        }
        self.last_position = x;
        self.velocity
    }

    /// The last estimate (m/s).
    pub fn velocity(&self) -> f32 {
        self.velocity
    }

    /// Sum of the state values: finite exactly when the state is (up to overflow of the
    /// sum itself), for branch-free checks over many estimators.
    #[inline]
    pub fn sum(&self) -> f32 {
        self.last_position + self.velocity
    }

    /// `true` when the state is finite.
    pub fn is_finite(&self) -> bool {
        self.last_position.is_finite() && self.velocity.is_finite()
    }
}
