//! The controller step: measured interface signals → numerical model → command filter →
//! demand limits → actuator demand, for `CH` actuator channels sized at compile time.
//!
//! # Modes and the safe state
//! - [`Mode::Idle`] (after construction and [`Controller::stop`]): the model does not run;
//!   the demand ramps to the configured safe demand at the safe ramp rate and stays there.
//! - [`Mode::Running`] (after [`Controller::start`]): every step runs the model, the filter
//!   and the limits. The first running step starts the model and the filter from rest
//!   (filter states set to their steady state for the model's first output), and the rate
//!   limiter carries the demand from the safe value to the model's demand.
//! - [`Mode::Fault`] (latched): entered on a non-finite or out-of-range input, or a
//!   non-finite model or filter value. The demand ramps to the safe demand, never holds a
//!   stale or NaN value. Only [`Controller::clear_fault`] leaves it (to `Idle`).
//!
//! The demand is always finite and inside `[min, max]` of its channel's limits (after a
//! swap that narrowed them, inside limits that close in on the new ones at the rate limit).
//!
//! # Bumpless parameter changes
//! A parameter set swapped in while Running ([`Controller::swap_params`]) never steps the
//! demand:
//! - when the model's or the filters' parameters changed, the first step after the swap runs
//!   the model with the new set and restarts the command filters at rest at its output
//!   ([`CascadeState::steady`]; a new filter never starts from the old one's state, which,
//!   read with other coefficients, can mean kilonewtons), and the difference between the
//!   demand and this new target becomes an offset added to the target, fading linearly to
//!   zero over [`BUMPLESS_FADE_S`]: at that step the target is the demand as it was, and
//!   afterwards it moves by at most `|offset| · dt / BUMPLESS_FADE_S` a step beyond what the
//!   new model and filter ask for (then through the limits as always);
//! - a narrowed amplitude limit that would cut the demand starts at the demand and closes in
//!   at the rate limit (the safe ramp rate when not Running): the rate limit has priority
//!   over a new amplitude limit, the demand never jumps to a limit; other limit changes
//!   apply at once.
//!
//! In Idle or Fault the demand is the safe demand behind the rate limiter; a start restarts
//! model and filter from rest, as before.

use crate::biquad::{CascadeCoefficients, CascadeState};
use crate::limits::{DemandLimits, RateLimiter};
use crate::params::{check_sample_period, Field, ParamError, Range};
use crate::MAX_CHANNELS;

/// Allowed ramp rates to the safe demand (demand unit per second).
pub const SAFE_RAMP_RATE: Range = Range::new(1.0e-6, 1.0e12);

/// Time over which the offset of a parameter change fades out (s): see the module docs.
pub const BUMPLESS_FADE_S: f32 = 0.1;

/// The measured and exogenous signals of one sample.
///
/// Which fields a model reads is part of its documentation; unused fields are still checked
/// for finiteness (a NaN anywhere in a frame means the frame is corrupt).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ModelInput<const CH: usize> {
    /// Measured actuator/interface position per channel (m, up positive).
    pub position: [f32; CH],
    /// Measured actuator/interface force per channel (N).
    pub force: [f32; CH],
    /// Road (ground) input per channel (m, up positive).
    pub road: [f32; CH],
    /// Vehicle speed (m/s).
    pub speed: f32,
}

impl<const CH: usize> Default for ModelInput<CH> {
    fn default() -> Self {
        Self {
            position: [0.0; CH],
            force: [0.0; CH],
            road: [0.0; CH],
            speed: 0.0,
        }
    }
}

impl<const CH: usize> ModelInput<CH> {
    /// `true` when every value is finite.
    pub fn is_finite(&self) -> bool {
        self.position
            .iter()
            .chain(&self.force)
            .chain(&self.road)
            .all(|v| v.is_finite())
            && self.speed.is_finite()
    }

    /// Bit mask of the channels with a non-finite position, force or road value (bit `ch`),
    /// all bits when the speed is not finite.
    pub fn invalid_channels(&self) -> u8 {
        if !self.speed.is_finite() {
            return channel_mask(CH);
        }
        let mut mask = 0u8;
        for (ch, ((x, f), z)) in self
            .position
            .iter()
            .zip(&self.force)
            .zip(&self.road)
            .enumerate()
        {
            if !(x.is_finite() && f.is_finite() && z.is_finite()) {
                mask |= 1u8.checked_shl(ch as u32).unwrap_or(0);
            }
        }
        mask
    }
}

fn channel_mask(ch: usize) -> u8 {
    if ch >= 8 {
        u8::MAX
    } else {
        (1u8 << ch).wrapping_sub(1)
    }
}

/// The first `B` entries of `v`, `fill` beyond its `A` (the board's four channels to a
/// configuration's `CH` and back).
pub fn fit<T: Copy, const A: usize, const B: usize>(v: &[T; A], fill: T) -> [T; B] {
    let mut out = [fill; B];
    for (o, x) in out.iter_mut().zip(v) {
        *o = *x;
    }
    out
}

/// A fixed-step numerical model serving `CH` actuator channels.
pub trait Model<const CH: usize>: Sized + Clone {
    /// The model's tunable constants: a plain, fixed-layout struct.
    type Params: Copy + PartialEq + core::fmt::Debug;
    /// Coefficients derived from the parameters and the sample period (validated).
    type Prepared: Copy + core::fmt::Debug;

    /// Validates `params` and derives the run-time coefficients for sample period `dt` (s).
    fn prepare(params: &Self::Params, dt: f32) -> Result<Self::Prepared, ParamError>;

    /// As [`Model::prepare`], into `out` (for coefficients of kilobytes: no temporary of
    /// them on the stack); on error `out` holds no valid coefficients.
    fn prepare_into(
        params: &Self::Params,
        dt: f32,
        out: &mut Self::Prepared,
    ) -> Result<(), ParamError> {
        *out = Self::prepare(params, dt)?;
        Ok(())
    }

    /// The model at rest.
    fn new() -> Self;

    /// Returns the model to rest before its first step with `input`.
    fn reset(&mut self, prepared: &Self::Prepared, input: &ModelInput<CH>);

    /// `true` when `input` is acceptable (finite, and within any model-specific bounds).
    fn input_valid(input: &ModelInput<CH>) -> bool {
        input.is_finite()
    }

    /// One sample: the actuator demands (N or m, per the model's documentation).
    fn step(&mut self, prepared: &Self::Prepared, input: &ModelInput<CH>) -> [f32; CH];

    /// `true` when the model's state is finite.
    fn is_finite(&self) -> bool;
}

/// Every tunable constant of a controller: one plain, fixed-layout struct.
///
/// Validated as a whole by [`PreparedParams::new`] before the step may use it.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct ControllerParams<P, const CH: usize> {
    /// The numerical model's parameters.
    pub model: P,
    /// Command filter per channel (applied to the model's demand).
    pub filter: [CascadeCoefficients; CH],
    /// Amplitude and rate limits per channel.
    pub limits: [DemandLimits; CH],
    /// Demand in the safe state per channel (N or m), inside the amplitude limits.
    pub safe_demand: [f32; CH],
    /// Rate at which the demand moves to the safe demand (unit/s).
    pub safe_ramp_rate: [f32; CH],
}

/// A validated parameter set with its derived coefficients, ready to be swapped in.
#[derive(Clone, Copy, Debug)]
pub struct PreparedParams<M: Model<CH>, const CH: usize> {
    params: ControllerParams<M::Params, CH>,
    model: M::Prepared,
    dt: f32,
}

impl<M: Model<CH>, const CH: usize> PreparedParams<M, CH> {
    /// Validates the whole set for sample period `dt` (s) and derives the coefficients.
    pub fn new(params: &ControllerParams<M::Params, CH>, dt: f32) -> Result<Self, ParamError> {
        Self::check(params, dt)?;
        let model = M::prepare(&params.model, dt)?;
        Ok(Self {
            params: *params,
            model,
            dt,
        })
    }

    /// As [`PreparedParams::new`] of the set `fill` writes into this one's, in place (no
    /// temporary of the set or of the model's coefficients, kilobytes for a substructure);
    /// on error `self` holds no valid set and must not be swapped in.
    pub fn prepare_in_place(
        &mut self,
        dt: f32,
        fill: impl FnOnce(&mut ControllerParams<M::Params, CH>),
    ) -> Result<(), ParamError> {
        fill(&mut self.params);
        Self::check(&self.params, dt)?;
        M::prepare_into(&self.params.model, dt, &mut self.model)?;
        self.dt = dt;
        Ok(())
    }

    /// A set of `params` with the model's coefficients `model`, not validated: only as a
    /// place to [`PreparedParams::prepare_in_place`].
    pub(crate) const fn unprepared(
        params: ControllerParams<M::Params, CH>,
        model: M::Prepared,
    ) -> Self {
        Self {
            params,
            model,
            dt: 0.0,
        }
    }

    /// Makes this a copy of `other`, field by field into place (no temporary of the whole).
    fn copy_from(&mut self, other: &Self) {
        self.params = other.params;
        self.model = other.model;
        self.dt = other.dt;
    }

    /// Validates everything but the model's parameters.
    fn check(params: &ControllerParams<M::Params, CH>, dt: f32) -> Result<(), ParamError> {
        if CH == 0 || CH > MAX_CHANNELS {
            return Err(ParamError::OutOfRange(Field::SafeDemand));
        }
        check_sample_period(dt)?;
        for (((filter, limits), safe), ramp) in params
            .filter
            .iter()
            .zip(&params.limits)
            .zip(&params.safe_demand)
            .zip(&params.safe_ramp_rate)
        {
            filter.validate()?;
            limits.validate()?;
            Range::new(limits.min, limits.max).check(Field::SafeDemand, *safe)?;
            SAFE_RAMP_RATE.check(Field::SafeRampRate, *ramp)?;
        }
        Ok(())
    }

    /// The parameter set.
    pub fn params(&self) -> &ControllerParams<M::Params, CH> {
        &self.params
    }

    /// The model's derived coefficients.
    pub fn model(&self) -> &M::Prepared {
        &self.model
    }

    /// Sample period (s).
    pub fn dt(&self) -> f32 {
        self.dt
    }
}

/// Operating mode of a [`Controller`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum Mode {
    /// Model stopped, demand at (or ramping to) the safe demand.
    Idle = 0,
    /// Model running.
    Running = 1,
    /// Latched fault: demand at (or ramping to) the safe demand until cleared.
    Fault = 2,
}

/// Causes of a latched fault (bit flags).
pub mod fault {
    /// A non-finite or out-of-range input.
    pub const INVALID_INPUT: u8 = 1 << 0;
    /// A non-finite value inside the model or the command filter.
    pub const NUMERICAL: u8 = 1 << 1;
}

/// What happened in the last step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Status {
    /// Mode after the step.
    pub mode: Mode,
    /// Latched fault causes ([`fault`] bit flags); 0 when no fault is latched.
    pub fault: u8,
    /// Channels whose demand was clamped by the amplitude limit (bit per channel).
    pub amplitude_limited: u8,
    /// Channels whose demand was held back by the rate limit (bit per channel).
    pub rate_limited: u8,
    /// Channels with an invalid input in this step (bit per channel).
    pub invalid_input: u8,
}

impl Status {
    /// Idle, nothing latched or limited (all zero bits).
    pub const IDLE: Self = Self {
        mode: Mode::Idle,
        fault: 0,
        amplitude_limited: 0,
        rate_limited: 0,
        invalid_input: 0,
    };
}

/// The offset that carries the demand target across a parameter change, fading to zero.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Fade {
    /// Added to the new target (demand unit).
    offset: f32,
    /// Magnitude it loses per step.
    per_step: f32,
}

impl Fade {
    /// The offset of this step, then one step less of it.
    fn next(&mut self) -> f32 {
        let now = self.offset;
        self.offset = if now > self.per_step {
            now - self.per_step
        } else if now < -self.per_step {
            now + self.per_step
        } else {
            0.0
        };
        now
    }
}

/// The MiL controller for `CH` channels with numerical model `M`.
#[derive(Clone, Debug)]
pub struct Controller<M: Model<CH>, const CH: usize> {
    prepared: PreparedParams<M, CH>,
    model: M,
    filter: [CascadeState; CH],
    limiter: [RateLimiter; CH],
    /// The amplitude limits in force: the configured ones, or narrowed ones closing in.
    active_limits: [DemandLimits; CH],
    fade: [Fade; CH],
    /// A swap while Running: the next running step sets the fade offsets.
    blend: bool,
    /// A change is still settling (a fade runs or the active limits differ from the
    /// configured ones); the steady step skips that work.
    settling: bool,
    mode: Mode,
    fault: u8,
    needs_reset: bool,
    status: Status,
}

impl<M: Model<CH>, const CH: usize> Controller<M, CH> {
    /// A controller in [`Mode::Idle`] with its demand at the safe demand.
    pub fn new(prepared: PreparedParams<M, CH>) -> Self {
        let mut c = Self::blank(prepared, M::new());
        c.restart();
        c
    }

    /// A controller holding `prepared` and `model` with every other field zero (Idle,
    /// demand zero, no reset pending): not one to run, a place to
    /// [`Controller::install`] into. With all-zero arguments it is all zero bits.
    pub(crate) const fn blank(prepared: PreparedParams<M, CH>, model: M) -> Self {
        Self {
            prepared,
            model,
            filter: [CascadeState::ZERO; CH],
            limiter: [RateLimiter::new(0.0); CH],
            active_limits: [DemandLimits {
                min: 0.0,
                max: 0.0,
                rate: 0.0,
            }; CH],
            fade: [Fade {
                offset: 0.0,
                per_step: 0.0,
            }; CH],
            blend: false,
            settling: false,
            mode: Mode::Idle,
            fault: 0,
            needs_reset: false,
            status: Status::IDLE,
        }
    }

    /// Makes this the controller [`Controller::new`] would build of `prepared` (Idle, its
    /// demand at the safe demand), in place: no temporary of the (kilobyte) whole.
    pub fn install(&mut self, prepared: &PreparedParams<M, CH>) {
        self.prepared.copy_from(prepared);
        self.restart();
    }

    /// Everything but the parameters back to a fresh controller's: Idle, the model at
    /// rest, the demand at the safe demand, the configured limits, nothing to settle.
    fn restart(&mut self) {
        self.model = M::new();
        self.filter = [CascadeState::ZERO; CH];
        for (l, safe) in self
            .limiter
            .iter_mut()
            .zip(&self.prepared.params.safe_demand)
        {
            *l = RateLimiter::new(*safe);
        }
        self.active_limits = self.prepared.params.limits;
        self.fade = [Fade::default(); CH];
        self.blend = false;
        self.settling = false;
        self.mode = Mode::Idle;
        self.fault = 0;
        self.needs_reset = true;
        self.status = Status::IDLE;
    }

    /// Validates `params` for sample period `dt` and builds an idle controller.
    pub fn with_params(
        params: &ControllerParams<M::Params, CH>,
        dt: f32,
    ) -> Result<Self, ParamError> {
        PreparedParams::new(params, dt).map(Self::new)
    }

    /// Swaps in a validated parameter set between two steps, bumpless (see the module
    /// docs): the model state is kept; after a change of model or filter parameters the
    /// filters restart at rest at the model's next output and the demand continues from
    /// where it is. The sample period must
    /// match; on error nothing changes.
    pub fn swap_params(&mut self, prepared: &PreparedParams<M, CH>) -> Result<(), ParamError> {
        if prepared.dt.to_bits() != self.prepared.dt.to_bits() {
            return Err(ParamError::Inconsistent(Field::SamplePeriod));
        }
        let old = &self.prepared.params;
        let new = &prepared.params;
        if self.mode == Mode::Running
            && !self.needs_reset
            && (old.model != new.model || old.filter != new.filter)
        {
            self.blend = true;
        }
        // The active limits take the new ones at once where that cuts no demand (as the
        // step's `towards` would, here rather than in the first step after the swap);
        // a bound that would cut a demand starts at it and closes in step by step.
        for ((active, configured), limiter) in self
            .active_limits
            .iter_mut()
            .zip(&new.limits)
            .zip(&self.limiter)
        {
            *active = active.towards(configured, limiter.output, 0.0);
        }
        // Something to settle: a blend to fade, or a bound still closing in (a change that
        // leaves the limits as they are keeps the steady step).
        self.settling = self.settling || self.blend || self.active_limits != new.limits;
        self.prepared.copy_from(prepared);
        Ok(())
    }

    /// Continues the demand of another controller that this one replaces (a change of
    /// model while idle): each channel given a finite value starts its demand there instead
    /// of at the safe demand, and moves on from it at the safe ramp rate (in Idle, to the
    /// safe demand); amplitude limits that do not contain it close in on the configured
    /// ones at that rate, as after a narrowing swap. Channels given `None` keep the safe
    /// demand.
    pub fn continue_demand(&mut self, demand: &[Option<f32>; CH]) {
        for (((limiter, active), configured), d) in self
            .limiter
            .iter_mut()
            .zip(self.active_limits.iter_mut())
            .zip(&self.prepared.params.limits)
            .zip(demand)
        {
            if let Some(d) = d.filter(|d| d.is_finite()) {
                limiter.output = d;
                *active = DemandLimits {
                    min: configured.min.min(d),
                    max: configured.max.max(d),
                    rate: configured.rate,
                };
                // Limits widened to hold the demand close in on the configured ones; a
                // demand inside them leaves nothing to settle.
                if *active != *configured {
                    self.settling = true;
                }
            }
        }
    }

    /// Validates `params` and swaps them in; on error nothing changes.
    pub fn set_params(
        &mut self,
        params: &ControllerParams<M::Params, CH>,
    ) -> Result<(), ParamError> {
        let prepared = PreparedParams::new(params, self.prepared.dt)?;
        self.swap_params(&prepared)
    }

    /// The running parameter set.
    pub fn params(&self) -> &ControllerParams<M::Params, CH> {
        &self.prepared.params
    }

    /// The running prepared parameters.
    pub fn prepared(&self) -> &PreparedParams<M, CH> {
        &self.prepared
    }

    /// Starts the model from `Idle`; returns `false` (and does nothing) in another mode.
    pub fn start(&mut self) -> bool {
        if self.mode == Mode::Idle {
            self.mode = Mode::Running;
            self.needs_reset = true;
            true
        } else {
            false
        }
    }

    /// Stops the model: back to `Idle`, demand ramps to the safe demand. No effect in `Fault`.
    pub fn stop(&mut self) {
        if self.mode == Mode::Running {
            self.mode = Mode::Idle;
        }
    }

    /// Clears a latched fault: `Fault` → `Idle`. Returns `false` if no fault was latched.
    pub fn clear_fault(&mut self) -> bool {
        if self.mode == Mode::Fault {
            self.mode = Mode::Idle;
            self.fault = 0;
            true
        } else {
            false
        }
    }

    /// Latches a fault from outside (e.g. the firmware's communication watchdog).
    pub fn trip(&mut self, cause: u8) {
        self.mode = Mode::Fault;
        self.fault |= cause;
    }

    /// Current mode.
    pub fn mode(&self) -> Mode {
        self.mode
    }

    /// Status of the last step.
    pub fn status(&self) -> Status {
        self.status
    }

    /// The last demand per channel.
    pub fn demand(&self) -> [f32; CH] {
        let mut d = [0.0; CH];
        for (o, l) in d.iter_mut().zip(&self.limiter) {
            *o = l.output;
        }
        d
    }

    /// The model state (for inspection and tests).
    pub fn model_state(&self) -> &M {
        &self.model
    }

    /// One control step: returns the actuator demand per channel (always finite, inside
    /// the amplitude limits) and records [`Status`].
    pub fn step(&mut self, input: &ModelInput<CH>) -> [f32; CH] {
        let mut invalid_input = 0u8;
        let mut target = self.prepared.params.safe_demand;
        let mut running = false;
        if self.mode == Mode::Running {
            if M::input_valid(input) {
                match self.run_model(input) {
                    Some(demand) => {
                        target = demand;
                        running = true;
                    }
                    None => self.enter_fault(fault::NUMERICAL),
                }
            } else {
                invalid_input = match input.invalid_channels() {
                    0 => channel_mask(CH), // finite but out of the model's bounds
                    mask => mask,
                };
                self.enter_fault(fault::INVALID_INPUT);
            }
        }
        if !running && self.settling {
            // Out of Running a fade has nothing to carry (a start restarts from rest).
            self.blend = false;
            self.fade = [Fade::default(); CH];
        }
        let dt = self.prepared.dt;
        let mut demand = [0.0; CH];
        let mut amplitude_limited = 0u8;
        let mut rate_limited = 0u8;
        for (ch, (((((out, limiter), goal), configured), active), ramp)) in demand
            .iter_mut()
            .zip(self.limiter.iter_mut())
            .zip(target)
            .zip(&self.prepared.params.limits)
            .zip(self.active_limits.iter_mut())
            .zip(&self.prepared.params.safe_ramp_rate)
            .enumerate()
        {
            let bit = 1u8.checked_shl(ch as u32).unwrap_or(0);
            let rate = if running { configured.rate } else { *ramp };
            let max_step = rate * dt;
            if self.settling {
                *active = active.towards(configured, limiter.output, max_step);
            }
            let (clamped, a) = active.clamp(goal);
            let (limited, r) = limiter.step(clamped, max_step);
            // The limiter starts inside the limits and moves towards a clamped target; the
            // active limits narrow by at most one step, so this clamp only catches rounding.
            let (value, a2) = active.clamp(limited);
            limiter.output = value;
            *out = value;
            if a || a2 {
                amplitude_limited |= bit;
            }
            if r {
                rate_limited |= bit;
            }
        }
        if self.settling {
            self.settling = self.active_limits != self.prepared.params.limits
                || self.blend
                || self.fade.iter().any(|f| f.offset != 0.0);
        }
        self.status = Status {
            mode: self.mode,
            fault: self.fault,
            amplitude_limited,
            rate_limited,
            invalid_input,
        };
        demand
    }

    fn enter_fault(&mut self, cause: u8) {
        self.mode = Mode::Fault;
        self.fault |= cause;
        self.needs_reset = true;
    }

    /// Runs model and filter; `None` on a non-finite value anywhere.
    fn run_model(&mut self, input: &ModelInput<CH>) -> Option<[f32; CH]> {
        let prepared = &self.prepared;
        if self.needs_reset {
            self.model.reset(&prepared.model, input);
        }
        let raw = self.model.step(&prepared.model, input);
        if core::mem::take(&mut self.needs_reset) {
            // The filter starts at rest at the model's first output (bumpless start).
            for ((state, coeffs), u) in self.filter.iter_mut().zip(&prepared.params.filter).zip(raw)
            {
                *state = CascadeState::steady(coeffs, u);
            }
            self.fade = [Fade::default(); CH];
            self.blend = false;
        }
        // The first step after a swap restarts the filters at rest at the model's output.
        let blend = core::mem::take(&mut self.blend);
        let mut out = [0.0; CH];
        for (((o, state), coeffs), u) in out
            .iter_mut()
            .zip(self.filter.iter_mut())
            .zip(&prepared.params.filter)
            .zip(raw)
        {
            if blend {
                *state = CascadeState::steady(coeffs, u);
            }
            *o = coeffs.step(state, u);
        }
        if blend {
            // The first step after a swap: the target carries on from the demand as it is,
            // the difference fades.
            let steps = (BUMPLESS_FADE_S / prepared.dt).max(1.0);
            for ((fade, o), limiter) in self.fade.iter_mut().zip(&mut out).zip(&self.limiter) {
                let offset = limiter.output - *o;
                *fade = if offset.is_finite() {
                    Fade {
                        offset,
                        per_step: offset.abs() / steps,
                    }
                } else {
                    Fade::default()
                };
                // Exactly the demand (not `o + offset`, which rounds at large values).
                *o = limiter.output;
                fade.next();
            }
        } else if self.settling {
            for (o, fade) in out.iter_mut().zip(self.fade.iter_mut()) {
                *o += fade.next();
            }
        }
        let finite = out.iter().all(|v| v.is_finite())
            && self.model.is_finite()
            && self.filter.iter().all(CascadeState::is_finite);
        if finite {
            Some(out)
        } else {
            None
        }
    }
}
