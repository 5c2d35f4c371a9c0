//! Point-follower tyre: a radial spring-damper between the road and the hub.
//!
//! Per channel (one wheel), with road height `z` and measured hub position `x` (both m, up
//! positive, relative to the static equilibrium), deflection `δ = z - x` and its velocity
//! `δ̇` estimated from samples ([`crate::velocity`]):
//!
//! ```text
//! F = F_static + k_t δ + c_t δ̇          (N, force of the tyre on the hub, up positive)
//! F = max(F, 0)                           (with lift-off: a tyre cannot pull the hub down)
//! ```
//!
//! This is the paper's numerical tyre `F'_i = -B_i(s) x_pi + F_np`, `B_i = c_t s + k_t`,
//! `F_np = B_i z`, plus the static load and lift-off. The output is the force demand of the
//! hub's force-controlled actuator.

use crate::controller::{Model, ModelInput};
use crate::params::{Field, ParamError, Range};
use crate::velocity::{VelocityEstimator, VelocityFilterCoefficients, VELOCITY_CUTOFF};

/// Largest hub position and road displacement accepted as input (m, either sign, from the
/// static position): far beyond any hub rig's travel, so a larger value is a corrupt or
/// misscaled frame and latches an invalid-input fault.
pub const TYRE_MAX_DISPLACEMENT: f32 = 1.0;
/// Allowed tyre radial stiffness (N/m).
pub const TYRE_STIFFNESS: Range = Range::new(0.0, 1.0e8);
/// Allowed tyre radial damping (N s/m).
pub const TYRE_DAMPING: Range = Range::new(0.0, 1.0e6);
/// Allowed static wheel load (N).
pub const TYRE_STATIC_LOAD: Range = Range::new(0.0, 1.0e6);

/// Parameters of one tyre.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct TyreParams {
    /// Radial stiffness `k_t` (N/m). Paper: 250 N/mm = 2.5e5 N/m.
    pub stiffness: f32,
    /// Radial damping `c_t` (N s/m). Paper: 0.5 N s/mm = 500 N s/m.
    pub damping: f32,
    /// Static wheel load (N) added to the dynamic force.
    pub static_load: f32,
    /// 1: the tyre force cannot pull (wheel lift-off); 0: linear tyre.
    pub lift_off: u32,
    /// Cut-off of the deflection-velocity low-pass (Hz); 0: plain backward difference.
    pub velocity_cutoff_hz: f32,
}

impl TyreParams {
    /// The paper's quarter-car tyre (k_t 250 N/mm, c_t 0.5 N s/mm), static load of the
    /// quarter car (150 kg + 20 kg) · 9.81 m/s², lift-off on, 500 Hz velocity low-pass.
    pub const PAPER: Self = Self {
        stiffness: 2.5e5,
        damping: 500.0,
        static_load: 170.0 * 9.81,
        lift_off: 1,
        velocity_cutoff_hz: 500.0,
    };

    /// Validates the ranges.
    pub fn validate(&self) -> Result<(), ParamError> {
        TYRE_STIFFNESS.check(Field::TyreStiffness, self.stiffness)?;
        TYRE_DAMPING.check(Field::TyreDamping, self.damping)?;
        TYRE_STATIC_LOAD.check(Field::TyreStaticLoad, self.static_load)?;
        VELOCITY_CUTOFF.check(Field::VelocityCutoff, self.velocity_cutoff_hz)?;
        if self.lift_off > 1 {
            return Err(ParamError::OutOfRange(Field::TyreLiftOff));
        }
        Ok(())
    }

    /// The tyre force (N) for deflection `delta` (m) and deflection velocity `delta_rate`
    /// (m/s), with lift-off applied if enabled.
    #[inline]
    pub fn force(&self, delta: f32, delta_rate: f32) -> f32 {
        let f = self.static_load + self.stiffness * delta + self.damping * delta_rate;
        if self.lift_off == 1 && (f.is_nan() || f <= 0.0) {
            0.0
        } else {
            f
        }
    }
}

/// Parameters of `CH` tyres (one per actuator channel).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct TyreModelParams<const CH: usize> {
    /// One tyre per channel.
    pub tyre: [TyreParams; CH],
}

/// Derived coefficients of the tyre model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TyrePrepared<const CH: usize> {
    params: TyreModelParams<CH>,
    velocity: [VelocityFilterCoefficients; CH],
}

/// State of `CH` tyre models.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TyreModel<const CH: usize> {
    deflection_rate: [VelocityEstimator; CH],
}

impl<const CH: usize> Model<CH> for TyreModel<CH> {
    type Params = TyreModelParams<CH>;
    type Prepared = TyrePrepared<CH>;

    fn prepare(params: &Self::Params, dt: f32) -> Result<Self::Prepared, ParamError> {
        let mut velocity = [VelocityFilterCoefficients {
            inv_dt: 1.0,
            gain: 1.0,
        }; CH];
        for (v, t) in velocity.iter_mut().zip(&params.tyre) {
            t.validate()?;
            *v = VelocityFilterCoefficients::new(t.velocity_cutoff_hz, dt)?;
        }
        Ok(TyrePrepared {
            params: *params,
            velocity,
        })
    }

    fn new() -> Self {
        Self {
            deflection_rate: [VelocityEstimator::new(); CH],
        }
    }

    fn reset(&mut self, _prepared: &Self::Prepared, _input: &ModelInput<CH>) {
        *self = Self::new();
    }

    /// Finite, and every hub position and road displacement within
    /// ±[`TYRE_MAX_DISPLACEMENT`] (the force and speed are not used, only checked finite).
    fn input_valid(input: &ModelInput<CH>) -> bool {
        input.is_finite()
            && input
                .position
                .iter()
                .chain(&input.road)
                .all(|v| v.abs() <= TYRE_MAX_DISPLACEMENT)
    }

    #[inline]
    fn step(&mut self, prepared: &Self::Prepared, input: &ModelInput<CH>) -> [f32; CH] {
        let mut force = [0.0; CH];
        for ((((f, est), coeff), tyre), (z, x)) in force
            .iter_mut()
            .zip(self.deflection_rate.iter_mut())
            .zip(&prepared.velocity)
            .zip(&prepared.params.tyre)
            .zip(input.road.iter().zip(&input.position))
        {
            let delta = z - x;
            let delta_rate = est.step(coeff, delta);
            *f = tyre.force(delta, delta_rate);
        }
        force
    }

    fn is_finite(&self) -> bool {
        self.deflection_rate
            .iter()
            .all(VelocityEstimator::is_finite)
    }
}
