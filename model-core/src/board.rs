//! The board's controller with its model chosen at run time: the tyre on 1 to
//! [`BOARD_CHANNELS`] hub channels, the aero model on its front and rear channels, or a
//! substructure on 1 to [`BOARD_CHANNELS`] channels, all in one image.
//!
//! [`BoardParams`] is one fixed-layout parameter set holding every model's parameters, the
//! [`ModelKind`] that runs and its number of channels, and per-channel filters, limits and
//! safe state for up to [`BOARD_CHANNELS`] channels. Only the running configuration (its
//! kind's parameters, its channels) is validated and used: the other kinds' parameters are
//! kept as written and validated when a configuration selects them.
//!
//! [`BoardController`] runs one [`Controller`] of the selected configuration (an enum of the
//! nine, so its size is the largest one's; no heap). [`BoardController::swap`] installs a new
//! validated set ([`BoardPrepared`]) between two steps:
//! - the same kind and channel count: [`Controller::swap_params`], bumpless in any mode;
//! - another kind, channel count or sample period, or a substructure's other causality (its
//!   demand another quantity): only in [`Mode::Idle`] (refused in
//!   Running and in Fault with [`SwapError::NotIdle`], nothing changes); the new controller is Idle and continues
//!   the demand of every channel both configurations have ([`Controller::continue_demand`]),
//!   ramping from there to its own safe demand at its safe ramp rate, so a change of model
//!   never steps the force. The next Start runs the new model from rest.
//!
//! Inputs and demands are always [`BOARD_CHANNELS`] wide; the channels beyond the running
//! configuration's are ignored on input and zero on output.

use crate::aero::{AeroModel, AeroParams};
use crate::biquad::CascadeCoefficients;
pub use crate::controller::fit;
use crate::controller::{Controller, ControllerParams, Mode, ModelInput, PreparedParams, Status};
use crate::limits::DemandLimits;
use crate::params::{Field, ParamError};
use crate::substructure::{
    InterfaceParams, SubstructureModel, SubstructureParams, SubstructurePrepared,
};
use crate::tyre::{TyreModel, TyreModelParams, TyreParams};

/// Most actuator channels of a board configuration.
pub const BOARD_CHANNELS: usize = 4;
const _: () = assert!(BOARD_CHANNELS <= crate::substructure::MAX_SUBSTRUCTURE_CHANNELS);

/// The numerical model the board runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub enum ModelKind {
    /// Point-follower tyres, one per hub channel (1 to 4): force demand.
    Tyre = 0,
    /// The aerodynamic model: front and rear down-force channels (exactly 2).
    Aero = 1,
    /// A substructure (model-core's mass-spring-damper with nonlinear elements), 1 to 4
    /// channels, any of its causalities.
    Substructure = 2,
}

impl ModelKind {
    /// Every kind, by value.
    pub const ALL: [ModelKind; 3] = [ModelKind::Tyre, ModelKind::Aero, ModelKind::Substructure];

    /// The kind of selector value `v`.
    pub fn from_u32(v: u32) -> Option<Self> {
        Self::ALL.into_iter().find(|k| *k as u32 == v)
    }

    /// The channel counts the kind runs on (inclusive).
    pub const fn channel_range(self) -> (u32, u32) {
        match self {
            ModelKind::Tyre | ModelKind::Substructure => (1, BOARD_CHANNELS as u32),
            ModelKind::Aero => (2, 2),
        }
    }

    /// Lower-case name, as in the set-up and the A2L.
    pub const fn name(self) -> &'static str {
        match self {
            ModelKind::Tyre => "tyre",
            ModelKind::Aero => "aero",
            ModelKind::Substructure => "substructure",
        }
    }
}

/// Every model's parameters and the running configuration: the board's whole parameter set
/// (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct BoardParams {
    /// The running model, a [`ModelKind`] as its `u32` value.
    pub kind: u32,
    /// Number of actuator channels, within the kind's [`ModelKind::channel_range`].
    pub channels: u32,
    /// The tyre of each hub channel.
    pub tyre: TyreModelParams<BOARD_CHANNELS>,
    /// The aero model.
    pub aero: AeroParams,
    /// The substructure (its channels beyond `channels` unused).
    pub substructure: SubstructureParams<BOARD_CHANNELS>,
    /// Command filter per channel.
    pub filter: [CascadeCoefficients; BOARD_CHANNELS],
    /// Demand limits per channel.
    pub limits: [DemandLimits; BOARD_CHANNELS],
    /// Safe demand per channel.
    pub safe_demand: [f32; BOARD_CHANNELS],
    /// Ramp rate to the safe demand per channel.
    pub safe_ramp_rate: [f32; BOARD_CHANNELS],
}

impl BoardParams {
    /// Every field zero (the tyre kind on no channels: not a valid set). A place to read a
    /// page into ([`crate::page::from_words_into`] writes every field).
    pub const ZERO: Self = Self {
        kind: 0,
        channels: 0,
        tyre: TyreModelParams {
            tyre: [TyreParams {
                stiffness: 0.0,
                damping: 0.0,
                static_load: 0.0,
                lift_off: 0,
                velocity_cutoff_hz: 0.0,
            }; BOARD_CHANNELS],
        },
        aero: AeroParams::ZERO,
        substructure: SubstructureParams::ZERO,
        filter: [CascadeCoefficients::ZERO; BOARD_CHANNELS],
        limits: [ZERO_LIMITS; BOARD_CHANNELS],
        safe_demand: [0.0; BOARD_CHANNELS],
        safe_ramp_rate: [0.0; BOARD_CHANNELS],
    };

    /// `channels` tyres `tyre` with the same limits and safe state on every channel, no
    /// command filter; the aero model at [`AeroParams::PAPER`] and a one-DOF substructure
    /// of 1 kg on nothing as the other kinds' starting values.
    pub const fn tyres(
        tyre: TyreParams,
        channels: u32,
        limits: DemandLimits,
        safe_demand: f32,
        safe_ramp_rate: f32,
    ) -> Self {
        let mut substructure = SubstructureParams::zeroed(1, crate::Causality::Impedance);
        substructure.mass[0][0] = 1.0;
        Self {
            kind: ModelKind::Tyre as u32,
            channels,
            tyre: TyreModelParams {
                tyre: [tyre; BOARD_CHANNELS],
            },
            aero: AeroParams::PAPER,
            substructure,
            filter: [CascadeCoefficients::IDENTITY; BOARD_CHANNELS],
            limits: [limits; BOARD_CHANNELS],
            safe_demand: [safe_demand; BOARD_CHANNELS],
            safe_ramp_rate: [safe_ramp_rate; BOARD_CHANNELS],
        }
    }

    /// The board's set that runs the tyre controller `p` (its `CH` channels); the other
    /// kinds' parameters at [`BoardParams::tyres`]' starting values.
    pub fn of_tyres<const CH: usize>(p: &ControllerParams<TyreModelParams<CH>, CH>) -> Self {
        let mut b = Self::with_channels(ModelKind::Tyre, p);
        b.tyre.tyre = fit(&p.model.tyre, TyreParams::PAPER);
        b
    }

    /// The board's set that runs the aero controller `p`.
    pub fn of_aero(p: &ControllerParams<AeroParams, 2>) -> Self {
        let mut b = Self::with_channels(ModelKind::Aero, p);
        b.aero = p.model;
        b
    }

    /// The board's set that runs the substructure controller `p` (its `CH` channels; the
    /// board's further channels unconnected).
    pub fn of_substructure<const CH: usize>(
        p: &ControllerParams<SubstructureParams<CH>, CH>,
    ) -> Self {
        let mut b = Self::with_channels(ModelKind::Substructure, p);
        b.substructure = p.model.first_channels::<BOARD_CHANNELS>();
        // The page holds a DOF for every channel; the channel count leaves these unconnected.
        for i in b.substructure.interface.iter_mut().skip(CH) {
            *i = InterfaceParams {
                dof: 0,
                stiffness: 0.0,
                damping: 0.0,
            };
        }
        b
    }

    /// Kind `kind` on the channels of `p` with their filters, limits and safe state.
    fn with_channels<P, const CH: usize>(kind: ModelKind, p: &ControllerParams<P, CH>) -> Self {
        let first = |v: &[f32]| v.first().copied().unwrap_or(0.0);
        let limits = p.limits.first().copied().unwrap_or(UNUSED_LIMITS);
        let mut b = Self::tyres(
            TyreParams::PAPER,
            CH as u32,
            limits,
            first(&p.safe_demand),
            first(&p.safe_ramp_rate),
        );
        b.kind = kind as u32;
        b.filter = fit(&p.filter, CascadeCoefficients::IDENTITY);
        b.limits = fit(&p.limits, limits);
        b.safe_demand = fit(&p.safe_demand, first(&p.safe_demand));
        b.safe_ramp_rate = fit(&p.safe_ramp_rate, first(&p.safe_ramp_rate));
        b
    }

    /// The model kind, if the selector is valid.
    pub fn model_kind(&self) -> Option<ModelKind> {
        ModelKind::from_u32(self.kind)
    }

    /// The running configuration's controller parameters with model parameters `model`:
    /// the first `CH` channels' filters, limits and safe state; channels from
    /// `self.channels` on (a substructure wider than its configuration) get no filter,
    /// [`UNUSED_LIMITS`] and a safe demand of zero, whatever the page holds for them.
    fn controller<P, const CH: usize>(&self, model: P) -> ControllerParams<P, CH> {
        let mut p = ControllerParams {
            model,
            filter: [CascadeCoefficients::IDENTITY; CH],
            limits: [UNUSED_LIMITS; CH],
            safe_demand: [0.0; CH],
            safe_ramp_rate: [UNUSED_RAMP_RATE; CH],
        };
        self.channels_into(&mut p);
        p
    }

    /// The per-channel part of [`BoardParams::controller`] (filters, limits, safe state)
    /// into `p`, in place; its model is left as it is.
    fn channels_into<P, const CH: usize>(&self, p: &mut ControllerParams<P, CH>) {
        let used = (self.channels as usize).min(CH);
        /// Channel `k`'s value of `v` when it runs, else `unused`.
        fn pick<T: Copy>(v: &[T], k: usize, used: usize, unused: T) -> T {
            v.get(k).filter(|_| k < used).copied().unwrap_or(unused)
        }
        for (k, f) in p.filter.iter_mut().enumerate() {
            *f = pick(&self.filter, k, used, CascadeCoefficients::IDENTITY);
        }
        for (k, l) in p.limits.iter_mut().enumerate() {
            *l = pick(&self.limits, k, used, UNUSED_LIMITS);
        }
        for (k, d) in p.safe_demand.iter_mut().enumerate() {
            *d = pick(&self.safe_demand, k, used, 0.0);
        }
        for (k, r) in p.safe_ramp_rate.iter_mut().enumerate() {
            *r = pick(&self.safe_ramp_rate, k, used, UNUSED_RAMP_RATE);
        }
    }

    /// Validates the running configuration for sample period `dt` (s) and derives its
    /// coefficients; on error the field at fault. (On the board, prepare in place with
    /// [`BoardPrepared::prepare`]: the result is kilobytes.)
    pub fn prepare(&self, dt: f32) -> Result<BoardPrepared, ParamError> {
        let mut out = BoardPrepared::BLANK;
        out.params = *self;
        out.prepare(dt)?;
        Ok(out)
    }

    /// The substructure as the board runs it: [`BOARD_CHANNELS`] wide, the channels from
    /// `channels` on [`UNCONNECTED`](crate::substructure::UNCONNECTED) (no coupling, no
    /// road input).
    pub fn running_substructure(&self) -> SubstructureParams<BOARD_CHANNELS> {
        let mut s = SubstructureParams::ZERO;
        self.running_substructure_into(&mut s);
        s
    }

    /// [`BoardParams::running_substructure`] into `s`, in place.
    fn running_substructure_into(&self, s: &mut SubstructureParams<BOARD_CHANNELS>) {
        *s = self.substructure;
        let used = self.channels as usize;
        s.interface
            .iter_mut()
            .skip(used)
            .for_each(|i| *i = InterfaceParams::NONE);
        for row in s.ground_stiffness.iter_mut().chain(&mut s.ground_damping) {
            row.iter_mut().skip(used).for_each(|v| *v = 0.0);
        }
        for e in &mut s.elements {
            e.road_coefficients
                .iter_mut()
                .skip(used)
                .for_each(|v| *v = 0.0);
        }
    }
}

/// Demand limits of a channel the running configuration does not use (its demand is zero).
const UNUSED_LIMITS: DemandLimits = DemandLimits {
    min: -1.0,
    max: 1.0,
    rate: 1.0,
};
/// Safe ramp rate of a channel the running configuration does not use.
const UNUSED_RAMP_RATE: f32 = 1.0;

/// The running configuration's validated parameters, one variant per kind and tyre
/// channel count (the substructure runs [`BOARD_CHANNELS`] wide, its unused channels
/// unconnected: one copy of its code). An explicit tag with the (largest) substructure
/// variant at zero, so that [`SUB_BLANK`] is all zero bits.
#[derive(Clone, Copy, Debug)]
#[allow(clippy::large_enum_variant)] // one lives at a time; no heap on the board
#[repr(u32)]
enum Prepared {
    Sub(PreparedParams<SubstructureModel<BOARD_CHANNELS>, BOARD_CHANNELS>) = 0,
    Tyre1(PreparedParams<TyreModel<1>, 1>),
    Tyre2(PreparedParams<TyreModel<2>, 2>),
    Tyre3(PreparedParams<TyreModel<3>, 3>),
    Tyre4(PreparedParams<TyreModel<4>, 4>),
    Aero(PreparedParams<AeroModel, 2>),
}

/// A substructure variant with no valid coefficients: the place its set is prepared into.
/// Every field zero (tag, counts, coefficients, the discriminant-0 causality), so a static
/// holding it is zero-initialised memory (`.bss`) and writing it is a fill, not a copy of
/// a kilobyte image kept in flash.
const SUB_BLANK: Prepared = Prepared::Sub(SUB_PREPARED);

/// The substructure's set of [`SUB_BLANK`].
const SUB_PREPARED: PreparedParams<SubstructureModel<BOARD_CHANNELS>, BOARD_CHANNELS> =
    PreparedParams::unprepared(
        ControllerParams {
            model: SubstructureParams::ZERO,
            filter: [CascadeCoefficients::ZERO; BOARD_CHANNELS],
            limits: [ZERO_LIMITS; BOARD_CHANNELS],
            safe_demand: [0.0; BOARD_CHANNELS],
            safe_ramp_rate: [0.0; BOARD_CHANNELS],
        },
        SubstructurePrepared::ZERO,
    );

/// Demand limits of all zero bits (a place holder of [`SUB_BLANK`], never validated).
const ZERO_LIMITS: DemandLimits = DemandLimits {
    min: 0.0,
    max: 0.0,
    rate: 0.0,
};

/// A [`BoardParams`] with the running configuration's derived coefficients. Prepared in
/// place ([`BoardPrepared::prepare`]: on the board it is kilobytes, so it lives in one
/// place and is never returned by value there); only a successfully prepared one is
/// [`BoardPrepared::is_ready`] and can be swapped in.
#[derive(Clone, Copy, Debug)]
pub struct BoardPrepared {
    params: BoardParams,
    prepared: Prepared,
    ready: bool,
}

impl BoardPrepared {
    /// Not prepared, holding [`BoardParams::ZERO`]: a place to prepare into. All zero
    /// bits, so a static one costs no flash (`.bss`, not a kilobyte `.data` image).
    pub const BLANK: Self = Self {
        params: BoardParams::ZERO,
        prepared: SUB_BLANK,
        ready: false,
    };

    /// The parameter set it holds.
    pub fn params(&self) -> &BoardParams {
        &self.params
    }

    /// The parameter set to change before [`BoardPrepared::prepare`]; no longer ready.
    pub fn params_mut(&mut self) -> &mut BoardParams {
        self.ready = false;
        &mut self.params
    }

    /// `true` when the set it holds was prepared successfully.
    pub fn is_ready(&self) -> bool {
        self.ready
    }

    /// Validates the running configuration of the set it holds for sample period `dt` (s)
    /// and derives its coefficients, in place; on error the field at fault, and not ready.
    pub fn prepare(&mut self, dt: f32) -> Result<(), ParamError> {
        self.ready = false;
        let p = &self.params;
        let kind = p
            .model_kind()
            .ok_or(ParamError::OutOfRange(Field::ModelKind))?;
        let (lo, hi) = kind.channel_range();
        if !(lo..=hi).contains(&p.channels) {
            return Err(ParamError::OutOfRange(Field::Channels));
        }
        match (kind, p.channels) {
            (ModelKind::Substructure, _) => prepare_substructure(p, dt, &mut self.prepared)?,
            _ => prepare_small(p, kind, dt, &mut self.prepared)?,
        }
        self.ready = true;
        Ok(())
    }
}

/// Prepares the tyre and aero configurations (hundreds of bytes: built by value).
#[inline(never)]
fn prepare_small(
    p: &BoardParams,
    kind: ModelKind,
    dt: f32,
    out: &mut Prepared,
) -> Result<(), ParamError> {
    macro_rules! tyre {
        ($ch:literal, $v:ident) => {
            Prepared::$v(PreparedParams::new(
                &p.controller::<_, $ch>(TyreModelParams {
                    tyre: fit(&p.tyre.tyre, TyreParams::PAPER),
                }),
                dt,
            )?)
        };
    }
    *out = match (kind, p.channels) {
        (ModelKind::Aero, _) => {
            Prepared::Aero(PreparedParams::new(&p.controller::<_, 2>(p.aero), dt)?)
        }
        (_, 1) => tyre!(1, Tyre1),
        (_, 2) => tyre!(2, Tyre2),
        (_, 3) => tyre!(3, Tyre3),
        _ => tyre!(4, Tyre4),
    };
    Ok(())
}

/// Makes `out` the substructure variant (not inlined: a copy of the blank variant, if the
/// compiler makes one, stays out of the preparing frame).
#[inline(never)]
fn to_substructure(out: &mut Prepared) {
    *out = SUB_BLANK;
}

/// Prepares the substructure in place (kilobytes of coefficients: no copy of them).
#[inline(never)]
fn prepare_substructure(p: &BoardParams, dt: f32, out: &mut Prepared) -> Result<(), ParamError> {
    if !matches!(out, Prepared::Sub(_)) {
        to_substructure(out);
    }
    match out {
        Prepared::Sub(s) => s.prepare_in_place(dt, |c| {
            p.channels_into(c);
            p.running_substructure_into(&mut c.model);
        }),
        _ => Err(ParamError::OutOfRange(Field::ModelKind)),
    }
}

/// One controller of the running configuration. An explicit tag with the (largest)
/// substructure variant at zero, as [`Prepared`]: [`SUB_RUNNING`] is all zero bits.
#[derive(Clone, Debug)]
#[allow(clippy::large_enum_variant)] // one lives at a time; no heap on the board
#[repr(u32)]
enum Running {
    Sub(Controller<SubstructureModel<BOARD_CHANNELS>, BOARD_CHANNELS>) = 0,
    Tyre1(Controller<TyreModel<1>, 1>),
    Tyre2(Controller<TyreModel<2>, 2>),
    Tyre3(Controller<TyreModel<3>, 3>),
    Tyre4(Controller<TyreModel<4>, 4>),
    Aero(Controller<AeroModel, 2>),
}

/// A substructure controller with no parameters (all zero bits): the place one is
/// installed into.
const SUB_RUNNING: Running = Running::Sub(Controller::blank(SUB_PREPARED, SubstructureModel::ZERO));

/// Applies `$body` to the controller `$c` of whichever variant `$running` holds.
macro_rules! each {
    ($running:expr, $c:ident => $body:expr) => {
        match $running {
            Running::Tyre1($c) => $body,
            Running::Tyre2($c) => $body,
            Running::Tyre3($c) => $body,
            Running::Tyre4($c) => $body,
            Running::Aero($c) => $body,
            Running::Sub($c) => $body,
        }
    };
}

/// Why [`BoardController::swap`] refused a parameter set; nothing changed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SwapError {
    /// The model kind, channel count, sample period or a substructure's causality changes,
    /// and the controller is not Idle.
    NotIdle,
    /// The set was not prepared successfully ([`BoardPrepared::is_ready`]).
    NotPrepared,
}

impl core::fmt::Display for SwapError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            SwapError::NotIdle => {
                "the model kind, channel count, sample period or causality changes while the \
                 controller is not Idle"
            }
            SwapError::NotPrepared => "the parameter set was not prepared successfully",
        })
    }
}

/// The board's controller: the running configuration's [`Controller`] (see the module
/// docs).
#[derive(Clone, Debug)]
pub struct BoardController {
    params: BoardParams,
    running: Running,
}

impl BoardController {
    /// Idle on no channels, its demand zero, all zero bits: the place a configuration is
    /// swapped into ([`BoardController::swap`] installs any, as it is Idle), e.g. the
    /// initial value of a static, which then costs no flash.
    pub const BLANK: Self = Self {
        params: BoardParams::ZERO,
        running: SUB_RUNNING,
    };

    /// An idle controller of the configuration `prepared`, its demand at the safe demand;
    /// [`SwapError::NotPrepared`] if the set is not [`BoardPrepared::is_ready`]. (On the
    /// board, swap into a [`BoardController::BLANK`] in place: this is kilobytes.)
    pub fn new(prepared: &BoardPrepared) -> Result<Self, SwapError> {
        let mut c = Self::BLANK;
        c.swap(prepared)?;
        Ok(c)
    }

    /// Validates `params` for `dt` and builds an idle controller.
    pub fn with_params(params: &BoardParams, dt: f32) -> Result<Self, ParamError> {
        let prepared = params.prepare(dt)?;
        Self::new(&prepared).map_err(|_| ParamError::OutOfRange(Field::ModelKind))
    }

    /// The running parameter set.
    pub fn params(&self) -> &BoardParams {
        &self.params
    }

    /// The running model kind.
    pub fn kind(&self) -> ModelKind {
        match self.running {
            Running::Tyre1(_) | Running::Tyre2(_) | Running::Tyre3(_) | Running::Tyre4(_) => {
                ModelKind::Tyre
            }
            Running::Aero(_) => ModelKind::Aero,
            Running::Sub(_) => ModelKind::Substructure,
        }
    }

    /// The running number of channels.
    pub fn channels(&self) -> usize {
        match self.running {
            Running::Tyre1(_) => 1,
            Running::Tyre2(_) | Running::Aero(_) => 2,
            Running::Tyre3(_) => 3,
            Running::Tyre4(_) => 4,
            Running::Sub(_) => (self.params.channels as usize).min(BOARD_CHANNELS),
        }
    }

    /// The sample period the running set was prepared for (s).
    pub fn dt(&self) -> f32 {
        each!(&self.running, c => c.prepared().dt())
    }

    /// Installs `prepared` between two steps (see the module docs): bumpless for the same
    /// configuration; another kind, channel count or sample period only while Idle,
    /// continuing the demand. On error nothing changes.
    pub fn swap(&mut self, prepared: &BoardPrepared) -> Result<(), SwapError> {
        if !prepared.ready {
            return Err(SwapError::NotPrepared);
        }
        let same_dt = prepared_dt(&prepared.prepared).to_bits() == self.dt().to_bits();
        // A substructure's causality says what its demand is (a force or a position): another
        // one is another configuration, as another kind is.
        let same_causality = self.kind() != ModelKind::Substructure
            || prepared.params.substructure.causality == self.params.substructure.causality;
        let same = same_dt
            && same_causality
            && prepared.params.channels == self.params.channels
            && match (&mut self.running, &prepared.prepared) {
                (Running::Tyre1(c), Prepared::Tyre1(p)) => c.swap_params(p).is_ok(),
                (Running::Tyre2(c), Prepared::Tyre2(p)) => c.swap_params(p).is_ok(),
                (Running::Tyre3(c), Prepared::Tyre3(p)) => c.swap_params(p).is_ok(),
                (Running::Tyre4(c), Prepared::Tyre4(p)) => c.swap_params(p).is_ok(),
                (Running::Aero(c), Prepared::Aero(p)) => c.swap_params(p).is_ok(),
                (Running::Sub(c), Prepared::Sub(p)) => c.swap_params(p).is_ok(),
                _ => false,
            };
        if same {
            self.params = prepared.params;
            return Ok(());
        }
        if self.mode() != Mode::Idle {
            return Err(SwapError::NotIdle);
        }
        let demand = self.demand();
        let channels = self.channels();
        // Built in place (the controllers are kilobytes: no copy of the whole on the stack).
        self.params = prepared.params;
        install(&mut self.running, &prepared.prepared);
        let mut carried = [None; BOARD_CHANNELS];
        for (c, d) in carried.iter_mut().zip(demand).take(channels) {
            *c = Some(d);
        }
        each!(&mut self.running, c => c.continue_demand(&fit(&carried, None)));
        Ok(())
    }

    /// Starts the model from Idle; `false` (nothing done) in another mode.
    pub fn start(&mut self) -> bool {
        each!(&mut self.running, c => c.start())
    }

    /// Stops the model (Running → Idle).
    pub fn stop(&mut self) {
        each!(&mut self.running, c => c.stop())
    }

    /// Clears a latched fault (Fault → Idle); `false` if none was latched.
    pub fn clear_fault(&mut self) -> bool {
        each!(&mut self.running, c => c.clear_fault())
    }

    /// Latches a fault from outside (e.g. the communication watchdog).
    pub fn trip(&mut self, cause: u8) {
        each!(&mut self.running, c => c.trip(cause))
    }

    /// Current mode.
    pub fn mode(&self) -> Mode {
        each!(&self.running, c => c.mode())
    }

    /// Status of the last step.
    pub fn status(&self) -> Status {
        each!(&self.running, c => c.status())
    }

    /// The last demand per board channel (zero beyond the running channels).
    pub fn demand(&self) -> [f32; BOARD_CHANNELS] {
        let mut demand = each!(&self.running, c => fit(&c.demand(), 0.0));
        demand
            .iter_mut()
            .skip(self.channels())
            .for_each(|d| *d = 0.0);
        demand
    }

    /// One control step on the first channels of `input`: the demand per board channel
    /// (zero beyond the running channels), always finite and inside the limits.
    pub fn step(&mut self, input: &ModelInput<BOARD_CHANNELS>) -> [f32; BOARD_CHANNELS] {
        let used = self.channels();
        let mut demand = each!(&mut self.running, c => {
            let mut narrow = ModelInput {
                position: fit(&input.position, 0.0),
                force: fit(&input.force, 0.0),
                road: fit(&input.road, 0.0),
                speed: input.speed,
            };
            // A substructure wider than its configuration: the unused channels read zero.
            for signal in [&mut narrow.position, &mut narrow.force, &mut narrow.road] {
                signal.iter_mut().skip(used).for_each(|v| *v = 0.0);
            }
            fit(&c.step(&narrow), 0.0)
        });
        demand.iter_mut().skip(used).for_each(|d| *d = 0.0);
        demand
    }
}

/// Makes `running` an idle controller of `p`, in place: the substructure's (kilobytes)
/// into a zero-filled [`SUB_RUNNING`], the others (hundreds of bytes) by value.
#[inline(never)]
fn install(running: &mut Running, p: &Prepared) {
    match p {
        Prepared::Tyre1(p) => *running = Running::Tyre1(Controller::new(*p)),
        Prepared::Tyre2(p) => *running = Running::Tyre2(Controller::new(*p)),
        Prepared::Tyre3(p) => *running = Running::Tyre3(Controller::new(*p)),
        Prepared::Tyre4(p) => *running = Running::Tyre4(Controller::new(*p)),
        Prepared::Aero(p) => *running = Running::Aero(Controller::new(*p)),
        Prepared::Sub(p) => {
            if !matches!(running, Running::Sub(_)) {
                *running = SUB_RUNNING;
            }
            if let Running::Sub(c) = running {
                c.install(p);
            }
        }
    }
}

fn prepared_dt(p: &Prepared) -> f32 {
    match p {
        Prepared::Tyre1(p) => p.dt(),
        Prepared::Tyre2(p) => p.dt(),
        Prepared::Tyre3(p) => p.dt(),
        Prepared::Tyre4(p) => p.dt(),
        Prepared::Aero(p) => p.dt(),
        Prepared::Sub(p) => p.dt(),
    }
}
