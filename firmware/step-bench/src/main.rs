//! # step-bench: the embedded speed figure of `model_core::Controller::step`
//!
//! A bare-metal binary for the rig board's MCU (STM32F405RG, Cortex-M4F,
//! `thumbv7em-none-eabihf`) that runs in QEMU's `netduinoplus2` machine and prints how many
//! **instructions** one [`Controller::step`] costs, for eight controller configurations:
//!
//! | name | controller |
//! | --- | --- |
//! | `tyre4` | `Controller<TyreModel<4>, 4>`, [`TyreParams::PAPER`] on each wheel, no command filter |
//! | `aero2` | `Controller<AeroModel, 2>`, [`AeroParams::PAPER`], no command filter |
//! | `tyre4-filter4` | `tyre4` with a 4-section command filter on each channel |
//! | `substructure2` | `Controller<SubstructureModel<2>, 2>`, a 2-DOF quarter car (admittance) |
//! | `substructure2-elements` | `substructure2` with its two road springs as nonlinear elements, every effect on (stops, cubic, asymmetric and quadratic damping, friction, lift-off) |
//! | `board-tyre4-filter4`, `board-aero2`, `board-substructure2-elements` | the same three through the board's run-time controller (`BoardController`: model kind and channels chosen at run time, the firmware's one image) |
//!
//! Each controller is built with [`Controller::with_params`] (parameters hidden from the
//! optimiser, as if they had arrived at run time), started, and stepped [`STEPS`] times at
//! `dt` = 0.2 ms on a synthetic sine road (an incremental rotation, no `libm` in the loop).
//! It also proves that `model-core` builds and links for the board with the workspace's
//! `memory.x`.
//!
//! ## How it measures
//! SysTick runs from the core clock (reload `0xFF_FFFF`, counting down) and is read right
//! before and after each call of an `#[inline(never)]` wrapper of `step`, so one window holds
//! exactly one call and the input generation stays outside. Under QEMU with
//! `-icount shift=S,align=off,sleep=off` the count is a deterministic function of the number
//! of executed instructions, but it is **not** one count per instruction: QEMU's SysTick
//! counts at the machine's 168 MHz in virtual time and one instruction lasts `2^S` ns, so an
//! instruction is `0.168 · 2^S` counts (1.344 at the runner's `S = 3`; at `S = 0` one count
//! is about 5.95 instructions). The binary therefore calibrates itself first: it times
//! `cortex_m::asm::delay(n)`, whose loop is exactly two instructions (`subs`, `bne`) per
//! iteration, for two values of `n`, and converts counts to instructions with that ratio. The
//! cost of an empty window is measured the same way and subtracted. The figures are
//! instructions, not cycles (DWT CYCCNT does not count in QEMU, and QEMU models neither the
//! pipeline nor flash wait states; a `vdiv.f32` counts as one instruction but takes 14 cycles).
//!
//! ## Running
//! From the workspace root: `cargo step-bench` (alias of
//! `run -p step-bench --target thumbv7em-none-eabihf --release`), which runs QEMU through
//! `firmware/step-bench/qemu-run.sh`. Output (semihosting stdout), one line per
//! configuration:
//!
//! ```text
//! step-bench calibration: 2000000 instructions = 2688000 SysTick counts (0.7440 instructions/count), empty window 1.00 instructions
//! step-bench tyre4: 625.0 instructions/step (2000 steps), controller 812 bytes, first step 845, max 625, 841.3 SysTick counts/step
//! ```
//!
//! `first step` is the first call after `start()` (it resets the model and the filter); `max`
//! is the largest later call; both come from single windows and so are only known to about
//! one SysTick count (under one instruction at `S = 3`, about 6 at `S = 0`); the mean is
//! exact to well under one instruction at any shift. `SysTick counts/step` is the raw mean
//! (empty-window cost included): on a real board it is core clock cycles per step, and the
//! calibrated "instructions" figure does not apply there (the calibration loop takes about 3
//! cycles per iteration on silicon). The run ends with `step-bench done` and a semihosting
//! exit with status 0; any failure (panic, HardFault, a controller that left `Running`)
//! prints a `step-bench FAILED` line to semihosting stderr and exits with status 1.
#![no_std]
#![no_main]
// `unsafe` is denied crate-wide; the one exception is the HardFault handler, which
// cortex-m-rt requires to be declared `unsafe fn` (see its local allow below).
#![deny(unsafe_code)]

use core::fmt::Write as _;
use core::hint::black_box;
use core::panic::PanicInfo;
use core::sync::atomic::{compiler_fence, Ordering};

use cortex_m::peripheral::syst::SystClkSource;
use cortex_m::peripheral::SYST;
use cortex_m_rt::{entry, exception, ExceptionFrame};
use cortex_m_semihosting::{debug, hio, hprintln};
use model_core::board::fit;
use model_core::{
    AeroModel, AeroParams, BiquadCoefficients, BoardController, BoardParams, CascadeCoefficients,
    Causality, Controller, ControllerParams, DemandLimits, ElementLaw, Mode, Model, ModelInput,
    ModelKind, Status, SubstructureElement, SubstructureModel, SubstructureParams, TyreModel,
    TyreModelParams, TyreParams, BOARD_CHANNELS, MAX_DOF, MAX_SECTIONS,
};

/// Sample period (s): 5 kHz, the rig's control rate.
const DT: f32 = 2.0e-4;
/// Measured steps per configuration (after the first step, which is reported separately).
pub const STEPS: u32 = 2000;
/// SysTick reload value: the full 24-bit range.
const RELOAD: u32 = 0x00FF_FFFF;
/// Loop iterations of the two calibration runs of `cortex_m::asm::delay`.
const CALIBRATION_SHORT: u32 = 1_000;
const CALIBRATION_LONG: u32 = 1_001_000;
/// Empty windows averaged to find the cost of the measurement itself.
const EMPTY_WINDOWS: u32 = 2000;

// ---------------------------------------------------------------------------------------------
// Timing

/// SysTick as a free-running down-counter from the core clock.
struct Timer {
    syst: SYST,
}

impl Timer {
    fn new(mut syst: SYST) -> Self {
        syst.disable_interrupt();
        syst.set_clock_source(SystClkSource::Core);
        syst.set_reload(RELOAD);
        syst.clear_current();
        syst.enable_counter();
        Self { syst }
    }

    /// The counter, fenced so that no memory access moves across the read.
    #[inline(always)]
    fn now() -> u32 {
        compiler_fence(Ordering::SeqCst);
        let t = SYST::get_current();
        compiler_fence(Ordering::SeqCst);
        t
    }

    /// Counts between two reads of the down-counter (correct across one wrap).
    #[inline(always)]
    fn elapsed(start: u32, end: u32) -> u32 {
        start.wrapping_sub(end) & RELOAD
    }

    /// Counts taken by `f`, with the counter restarted first so that any window shorter than
    /// 2^24 counts cannot wrap more than once.
    fn time(&mut self, f: impl FnOnce()) -> u32 {
        self.syst.clear_current();
        let start = Self::now();
        f();
        let end = Self::now();
        Self::elapsed(start, end)
    }
}

/// Exactly `2 (n + 1)` loop instructions plus a fixed call overhead (not inlined, so both
/// calibration runs execute the very same code).
#[inline(never)]
fn spin(n: u32) {
    cortex_m::asm::delay(n);
}

/// How counts convert to instructions, and what an empty measurement window costs.
#[derive(Clone, Copy)]
struct Calibration {
    /// Instructions per SysTick count.
    instructions_per_count: f64,
    /// Instructions of an empty window (two back-to-back counter reads), averaged.
    empty_window: f64,
}

impl Calibration {
    fn measure(timer: &mut Timer) -> Self {
        let short = timer.time(|| spin(black_box(CALIBRATION_SHORT)));
        let long = timer.time(|| spin(black_box(CALIBRATION_LONG)));
        let instructions = 2.0 * f64::from(CALIBRATION_LONG - CALIBRATION_SHORT);
        let counts = f64::from(long.saturating_sub(short));
        if counts < 1.0 {
            fail(format_args!(
                "SysTick does not count (calibration {short} -> {long})"
            ));
        }
        let instructions_per_count = instructions / counts;
        let mut empty: u64 = 0;
        for _ in 0..EMPTY_WINDOWS {
            let t0 = Timer::now();
            let t1 = Timer::now();
            empty += u64::from(Timer::elapsed(t0, t1));
        }
        let empty_window = empty as f64 * instructions_per_count / f64::from(EMPTY_WINDOWS);
        hprintln!(
            "step-bench calibration: {} instructions = {} SysTick counts ({:.4} instructions/count), empty window {:.2} instructions",
            instructions,
            long - short,
            instructions_per_count,
            empty_window
        );
        Self {
            instructions_per_count,
            empty_window,
        }
    }

    /// Instructions of a single window of `counts` counts, empty-window cost removed.
    fn window(&self, counts: u32) -> f64 {
        (f64::from(counts) * self.instructions_per_count - self.empty_window).max(0.0)
    }
}

// ---------------------------------------------------------------------------------------------
// Synthetic inputs

/// A sine/cosine pair advanced by a rotation each sample: no `libm` in the loop.
struct Oscillator {
    sin: f32,
    cos: f32,
    step_sin: f32,
    step_cos: f32,
}

impl Oscillator {
    fn new(frequency_hz: f64) -> Self {
        let w = 2.0 * core::f64::consts::PI * frequency_hz * f64::from(DT);
        Self {
            sin: 0.0,
            cos: 1.0,
            step_sin: libm::sin(w) as f32,
            step_cos: libm::cos(w) as f32,
        }
    }

    #[inline(always)]
    fn advance(&mut self) {
        let (s, c) = (self.sin, self.cos);
        self.sin = s * self.step_cos + c * self.step_sin;
        self.cos = c * self.step_cos - s * self.step_sin;
    }
}

// ---------------------------------------------------------------------------------------------
// The benchmark

/// What the benchmark steps: a model's [`Controller`], or the board's run-time
/// [`BoardController`] (the firmware's one image).
trait Stepped<const CH: usize> {
    fn start(&mut self) -> bool;
    /// One step behind a real call (`#[inline(never)]`): the measured unit, like the call the
    /// firmware's control task makes, and a frame that shows in the disassembly.
    fn step_once(&mut self, input: &ModelInput<CH>) -> [f32; CH];
    fn mode(&self) -> Mode;
    fn status(&self) -> Status;
}

impl<M: Model<CH>, const CH: usize> Stepped<CH> for Controller<M, CH> {
    fn start(&mut self) -> bool {
        Controller::start(self)
    }
    #[inline(never)]
    fn step_once(&mut self, input: &ModelInput<CH>) -> [f32; CH] {
        self.step(input)
    }
    fn mode(&self) -> Mode {
        Controller::mode(self)
    }
    fn status(&self) -> Status {
        Controller::status(self)
    }
}

impl Stepped<BOARD_CHANNELS> for BoardController {
    fn start(&mut self) -> bool {
        BoardController::start(self)
    }
    #[inline(never)]
    fn step_once(&mut self, input: &ModelInput<BOARD_CHANNELS>) -> [f32; BOARD_CHANNELS] {
        self.step(input)
    }
    fn mode(&self) -> Mode {
        BoardController::mode(self)
    }
    fn status(&self) -> Status {
        BoardController::status(self)
    }
}

/// Starts and steps `controller`; prints its line.
fn run<C: Stepped<CH>, const CH: usize>(
    name: &str,
    mut controller: C,
    calibration: Calibration,
    road_hz: f64,
    fill: impl Fn(f32, f32, &mut ModelInput<CH>),
) {
    if !controller.start() {
        fail(format_args!("{name}: start() refused"));
    }
    let mut osc = Oscillator::new(road_hz);
    let mut input = ModelInput::<CH>::default();
    let mut first = 0u32;
    let mut max = 0u32;
    let mut total: u64 = 0;
    for k in 0..=STEPS {
        fill(osc.sin, osc.cos, &mut input);
        osc.advance();
        let input = black_box(&input);
        let t0 = Timer::now();
        let demand = controller.step_once(input);
        let t1 = Timer::now();
        black_box(demand);
        let counts = Timer::elapsed(t0, t1);
        if k == 0 {
            first = counts;
        } else {
            total += u64::from(counts);
            max = max.max(counts);
        }
    }
    let status = controller.status();
    if controller.mode() != Mode::Running || status.fault != 0 {
        fail(format_args!(
            "{name}: controller left Running (mode {:?}, status {:?}): the figure would time the fault path",
            controller.mode(),
            status
        ));
    }
    let mean = total as f64 * calibration.instructions_per_count / f64::from(STEPS)
        - calibration.empty_window;
    hprintln!(
        "step-bench {}: {:.1} instructions/step ({} steps), controller {} bytes, first step {:.0}, max {:.0}, {:.1} SysTick counts/step",
        name,
        mean,
        STEPS,
        core::mem::size_of::<C>(),
        calibration.window(first),
        calibration.window(max),
        total as f64 / f64::from(STEPS)
    );
}

/// Builds one model's controller (parameters through `black_box`, so that the optimiser
/// cannot specialise the step on known coefficients: on the rig they arrive at run time)
/// and runs it.
fn bench<M: Model<CH>, const CH: usize>(
    name: &str,
    params: &ControllerParams<M::Params, CH>,
    calibration: Calibration,
    road_hz: f64,
    fill: impl Fn(f32, f32, &mut ModelInput<CH>),
) {
    match Controller::<M, CH>::with_params(black_box(params), black_box(DT)) {
        Ok(c) => run(name, c, calibration, road_hz, fill),
        Err(e) => fail(format_args!("{name}: parameters rejected: {e:?}")),
    }
}

/// Builds the board's run-time controller in the configuration `params` selects and runs
/// it (`name` starts with `board-`).
fn bench_board(
    name: &str,
    params: &BoardParams,
    calibration: Calibration,
    road_hz: f64,
    fill: impl Fn(f32, f32, &mut ModelInput<BOARD_CHANNELS>),
) {
    match BoardController::with_params(black_box(params), black_box(DT)) {
        Ok(c) => run(name, c, calibration, road_hz, fill),
        Err(e) => fail(format_args!("{name}: parameters rejected: {e:?}")),
    }
}

/// The board page of a `Controller` configuration: its model kind and channels, its model
/// parameters and its per-channel filters, limits and safe state (`CH` of the board's four).
fn board_params<const CH: usize>(
    kind: ModelKind,
    common: &ControllerParams<impl Copy, CH>,
    model: impl FnOnce(&mut BoardParams),
) -> BoardParams {
    let mut p = BoardParams::tyres(TyreParams::PAPER, CH as u32, common.limits[0], 0.0, 1.0);
    p.kind = kind as u32;
    p.filter = fit(&common.filter, CascadeCoefficients::IDENTITY);
    p.limits = fit(&common.limits, common.limits[0]);
    p.safe_demand = fit(&common.safe_demand, 0.0);
    p.safe_ramp_rate = fit(&common.safe_ramp_rate, 1.0);
    model(&mut p);
    p
}

/// Widens a `CH`-channel input generator to the board's channels.
fn widen<const CH: usize>(
    fill: impl Fn(f32, f32, &mut ModelInput<CH>),
) -> impl Fn(f32, f32, &mut ModelInput<BOARD_CHANNELS>) {
    move |s, c, wide| {
        let mut narrow = ModelInput::<CH>::default();
        fill(s, c, &mut narrow);
        *wide = ModelInput {
            position: fit(&narrow.position, 0.0),
            force: fit(&narrow.force, 0.0),
            road: fit(&narrow.road, 0.0),
            speed: narrow.speed,
        };
    }
}

// ---------------------------------------------------------------------------------------------
// Configurations

/// A conjugate pair `r e^{±jθ}` in the z-plane, stored as `1 - r` and `sin(θ/2)` so that
/// pairs close to `z = 1` keep their precision.
#[derive(Clone, Copy)]
struct Pair {
    one_minus_r: f64,
    sin_half_angle: f64,
}

impl Pair {
    /// The pair of a continuous mode at `frequency_hz` with damping ratio `zeta` (< 1),
    /// mapped by `z = e^{sT}`: `r = e^{-ζωT}`, `θ = ωT sqrt(1 - ζ²)`.
    fn mode(frequency_hz: f64, zeta: f64) -> Self {
        let w = 2.0 * core::f64::consts::PI * frequency_hz * f64::from(DT);
        Self {
            one_minus_r: -libm::expm1(-zeta * w),
            sin_half_angle: libm::sin(0.5 * w * libm::sqrt(1.0 - zeta * zeta)),
        }
    }

    /// A double zero at `z = -1` (Nyquist), the zeros of a low-pass section.
    const NYQUIST: Self = Self {
        one_minus_r: 0.0,
        sin_half_angle: 1.0,
    };

    /// A pair on the unit circle at `frequency_hz` (the zeros of a notch).
    fn notch(frequency_hz: f64) -> Self {
        let w = 2.0 * core::f64::consts::PI * frequency_hz * f64::from(DT);
        Self {
            one_minus_r: 0.0,
            sin_half_angle: libm::sin(0.5 * w),
        }
    }

    /// The delta-form coefficients of `1 - 2 r cos θ q + r²` written around `z = 1`:
    /// `(2 - 2 r cos θ, 1 - 2 r cos θ + r²)`, evaluated as
    /// `(2 (1 - r) + 4 r sin²(θ/2), (1 - r)² + 4 r sin²(θ/2))`.
    fn delta(&self) -> (f64, f64) {
        let r = 1.0 - self.one_minus_r;
        let q = 4.0 * r * self.sin_half_angle * self.sin_half_angle;
        (
            2.0 * self.one_minus_r + q,
            self.one_minus_r * self.one_minus_r + q,
        )
    }
}

/// A section with the given poles and zeros, scaled to unity gain at DC.
fn section(poles: Pair, zeros: Pair) -> BiquadCoefficients {
    let (alpha1, alpha2) = poles.delta();
    let (n1, n2) = zeros.delta();
    let gain = alpha2 / n2;
    BiquadCoefficients {
        beta0: gain as f32,
        beta1: (gain * n1) as f32,
        beta2: (gain * n2) as f32,
        alpha1: alpha1 as f32,
        alpha2: alpha2 as f32,
    }
}

/// A 4-section command filter: two low-passes, a 50 Hz notch and a lightly damped 8 Hz
/// anti-resonance (poles close to `z = 1`, where the delta form matters).
fn command_filter() -> CascadeCoefficients {
    let sections: [BiquadCoefficients; MAX_SECTIONS] = [
        section(Pair::mode(1000.0, 0.7), Pair::NYQUIST),
        section(Pair::mode(1400.0, 0.9), Pair::NYQUIST),
        section(Pair::mode(50.0, 0.3), Pair::notch(50.0)),
        section(Pair::mode(8.0, 0.2), Pair::mode(8.0, 0.05)),
    ];
    match CascadeCoefficients::from_sections(&sections) {
        Some(c) => c,
        None => fail(format_args!("command filter: too many sections")),
    }
}

fn tyre_params(filter: CascadeCoefficients) -> ControllerParams<TyreModelParams<4>, 4> {
    ControllerParams {
        model: TyreModelParams {
            tyre: [TyreParams::PAPER; 4],
        },
        filter: [filter; 4],
        limits: [DemandLimits {
            min: -1.0e3,
            max: 1.0e4,
            rate: 1.0e6,
        }; 4],
        safe_demand: [0.0; 4],
        safe_ramp_rate: [1.0e5; 4],
    }
}

/// Tyre inputs: road and hub heave differ per wheel; the deflection swings ±8 mm, beyond the
/// 6.7 mm static deflection, so each wheel lifts off for part of the cycle.
fn tyre_input(s: f32, c: f32, input: &mut ModelInput<4>) {
    let gains = [1.0f32, 0.9, 0.8, 0.7];
    for (((z, x), f), g) in input
        .road
        .iter_mut()
        .zip(input.position.iter_mut())
        .zip(input.force.iter_mut())
        .zip(gains)
    {
        *z = 0.010 * g * s;
        *x = 0.006 * g * c + 0.002 * s;
        *f = 1500.0 * c;
    }
    input.speed = 30.0;
}

fn aero_params() -> ControllerParams<AeroParams, 2> {
    ControllerParams {
        model: AeroParams::PAPER,
        filter: [CascadeCoefficients::IDENTITY; 2],
        limits: [DemandLimits {
            min: -2.0e4,
            max: 2.0e4,
            rate: 1.0e6,
        }; 2],
        safe_demand: [0.0; 2],
        safe_ramp_rate: [1.0e5; 2],
    }
}

/// Aero inputs: body heave and pitch of a few mm at the actuators, speed 50 ± 5 m/s.
fn aero_input(s: f32, c: f32, input: &mut ModelInput<2>) {
    input.position = [0.005 * s, 0.004 * c];
    input.road = [0.0; 2];
    input.force = [-3.0e3 + 100.0 * c, -5.0e3 + 100.0 * s];
    input.speed = 50.0 + 5.0 * s;
}

/// The 2-DOF quarter car of the model-core tests (masses 10 kg and 5 kg, road springs
/// 40 kN/m and 20 kN/m, coupling 10 kN/m), measured interface force in, position demand out.
fn substructure_params() -> ControllerParams<SubstructureParams<2>, 2> {
    let mut p = SubstructureParams::<2>::zeroed(2, Causality::Admittance);
    p.mass[0][0] = 10.0;
    p.mass[1][1] = 5.0;
    p.stiffness[0][0] = 1.0e4;
    p.stiffness[1][1] = 1.0e4;
    p.stiffness[0][1] = -1.0e4;
    p.stiffness[1][0] = -1.0e4;
    p.damping[0][0] = 5.0;
    p.damping[1][1] = 5.0;
    p.damping[0][1] = -5.0;
    p.damping[1][0] = -5.0;
    p.ground_stiffness[0][0] = 4.0e4;
    p.ground_damping[0][0] = 20.0;
    p.ground_stiffness[1][1] = 2.0e4;
    p.ground_damping[1][1] = 10.0;
    p.interface[0].dof = 0;
    p.interface[1].dof = 1;
    p.velocity_cutoff_hz = 500.0;
    ControllerParams {
        model: p,
        filter: [CascadeCoefficients::IDENTITY; 2],
        limits: [DemandLimits {
            min: -0.1,
            max: 0.1,
            rate: 1.0,
        }; 2],
        safe_demand: [0.0; 2],
        safe_ramp_rate: [0.1; 2],
    }
}

/// `substructure2` with its road springs and dampers as nonlinear elements carrying every
/// effect the board runs (the friction's `tanh` included), so the step pays for all of them.
fn substructure_elements_params() -> ControllerParams<SubstructureParams<2>, 2> {
    let mut p = substructure_params();
    let m = &mut p.model;
    m.element_count = 2;
    for (i, (k, c)) in [(4.0e4, 20.0), (2.0e4, 10.0)].into_iter().enumerate() {
        m.ground_stiffness[i][i] = 0.0;
        m.ground_damping[i][i] = 0.0;
        let mut dof_coefficients = [0.0; MAX_DOF];
        dof_coefficients[i] = -1.0;
        let mut road_coefficients = [0.0; 2];
        road_coefficients[i] = 1.0;
        m.elements[i] = SubstructureElement {
            dof_coefficients,
            road_coefficients,
            law: ElementLaw {
                rebound_damping: 2.0 * c,
                cubic_stiffness: 1.0e9,
                quadratic_damping: 100.0,
                bump_gap: 0.002,
                bump_stiffness: 2.0e5,
                rebound_gap: 0.003,
                rebound_stiffness: 1.0e5,
                friction_force: 5.0,
                friction_velocity: 0.01,
                preload: 100.0,
                lift_off: 1,
                ..ElementLaw::linear(k, c)
            },
        };
    }
    p
}

/// Substructure inputs: interface forces of ±50 N and a road of ±5 mm.
fn substructure_input(s: f32, c: f32, input: &mut ModelInput<2>) {
    input.force = [50.0 * s, -30.0 * c];
    input.road = [0.005 * s, 0.004 * c];
    input.position = [0.001 * s, 0.001 * c];
    input.speed = 20.0;
}

#[entry]
fn main() -> ! {
    let Some(peripherals) = cortex_m::Peripherals::take() else {
        fail(format_args!("core peripherals already taken"));
    };
    let mut timer = Timer::new(peripherals.SYST);
    let calibration = Calibration::measure(&mut timer);

    bench::<TyreModel<4>, 4>(
        "tyre4",
        &tyre_params(CascadeCoefficients::IDENTITY),
        calibration,
        5.0,
        tyre_input,
    );
    bench::<AeroModel, 2>("aero2", &aero_params(), calibration, 2.0, aero_input);
    bench::<TyreModel<4>, 4>(
        "tyre4-filter4",
        &tyre_params(command_filter()),
        calibration,
        5.0,
        tyre_input,
    );
    bench::<SubstructureModel<2>, 2>(
        "substructure2",
        &substructure_params(),
        calibration,
        3.0,
        substructure_input,
    );
    bench::<SubstructureModel<2>, 2>(
        "substructure2-elements",
        &substructure_elements_params(),
        calibration,
        3.0,
        substructure_input,
    );

    // The same configurations through the board's run-time controller (the firmware's one
    // image): the cost of choosing the model at run time.
    let tyres = tyre_params(command_filter());
    bench_board(
        "board-tyre4-filter4",
        &board_params(ModelKind::Tyre, &tyres, |_| {}),
        calibration,
        5.0,
        widen(tyre_input),
    );
    let aero = aero_params();
    bench_board(
        "board-aero2",
        &board_params(ModelKind::Aero, &aero, |p| p.aero = aero.model),
        calibration,
        2.0,
        widen(aero_input),
    );
    let sub = substructure_elements_params();
    bench_board(
        "board-substructure2-elements",
        &board_params(ModelKind::Substructure, &sub, |p| {
            p.substructure = sub.model.first_channels::<BOARD_CHANNELS>();
        }),
        calibration,
        3.0,
        widen(substructure_input),
    );

    hprintln!("step-bench done");
    debug::exit(debug::EXIT_SUCCESS);
    // Only reached when no debugger handles semihosting (then the exit above faults first).
    loop {
        cortex_m::asm::wfi();
    }
}

// ---------------------------------------------------------------------------------------------
// Failure paths: print through a fresh semihosting handle (the `hprintln!` one may be the
// one in use when the failure happened) and exit QEMU with a non-zero status.

fn fail(args: core::fmt::Arguments) -> ! {
    if let Ok(mut stderr) = hio::hstderr() {
        let _ = writeln!(stderr, "step-bench FAILED: {args}");
    }
    debug::exit(debug::EXIT_FAILURE);
    loop {
        cortex_m::asm::wfi();
    }
}

#[panic_handler]
fn panic(info: &PanicInfo) -> ! {
    fail(format_args!("panic: {info}"))
}

// `unsafe` is required here: cortex-m-rt only accepts the HardFault handler as an
// `unsafe fn` (running it is only sound as the exception handler). It does nothing unsafe itself.
#[allow(unsafe_code)]
#[exception]
unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
    fail(format_args!("HardFault at pc {:#010x}", frame.pc()))
}
