//! The free-running counter that times the control path ([`Clock`]), the instruction
//! calibration of the QEMU build, and the stack high-water mark.
//!
//! - Board: SysTick from the core clock, counting down: core cycles.
//! - QEMU: TIM5 with prescaler 0, counting up. QEMU 7.2 clocks its STM32 timers at 1 GHz of
//!   its virtual time whatever RCC says, and under `-icount shift=S` every instruction
//!   advances virtual time by exactly 2^S ns, so TIM5 counts 2^S per instruction: exactly
//!   one per instruction at `shift=0`. SysTick is left off in the QEMU build: QEMU runs it
//!   at 168 MHz of virtual time, 0.168 · 2^S counts per instruction (one count per 5.95
//!   instructions at `shift=0`), too coarse for per-step figures, and the phase of that
//!   coarse count at the start of a window depends on host timing under `sleep=off` (two
//!   runs then differ by a count in their extremes). Without SysTick and with the watchdog
//!   off QEMU also has no periodic timer to race through while the guest waits for the host.

use core::sync::atomic::{compiler_fence, Ordering};

use mil_firmware::stats::{self, Timing};

/// SysTick reload: the full 24-bit range (about 100 ms at 168 MHz).
#[cfg(not(feature = "qemu"))]
const RELOAD: u32 = 0x00FF_FFFF;

/// The free-running counter of the control-path timings.
pub struct Clock {
    /// TIM5, prescaler 0 (QEMU: one count per nanosecond of virtual time).
    #[cfg(feature = "qemu")]
    timer: stm32f4xx_hal::timer::Counter<stm32f4xx_hal::pac::TIM5, { Clock::TIM5_HZ }>,
}

#[cfg(not(feature = "qemu"))]
impl Clock {
    /// Starts SysTick from the core clock, counting down, no interrupt (RTIC does not use it:
    /// the app has no monotonic).
    pub fn start(mut syst: cortex_m::peripheral::SYST) -> Self {
        use cortex_m::peripheral::syst::SystClkSource;
        syst.disable_interrupt();
        syst.set_clock_source(SystClkSource::Core);
        syst.set_reload(RELOAD);
        syst.clear_current();
        syst.enable_counter();
        Self {}
    }

    /// Another handle on the same counter (SysTick, started once), for a second task.
    pub fn another(&self) -> Self {
        Self {}
    }

    /// The counter, fenced so that no memory access moves across the read.
    #[inline(always)]
    pub fn now(&self) -> u32 {
        compiler_fence(Ordering::SeqCst);
        let t = cortex_m::peripheral::SYST::get_current();
        compiler_fence(Ordering::SeqCst);
        t
    }
}

/// Counts from `start` to `end` (correct across one wrap of the down-counter).
#[cfg(not(feature = "qemu"))]
#[inline(always)]
pub fn elapsed(start: u32, end: u32) -> u32 {
    start.wrapping_sub(end) & RELOAD
}

#[cfg(feature = "qemu")]
impl Clock {
    /// TIM5's nominal counter rate: its whole input clock (HSI 16 MHz on APB1), i.e.
    /// prescaler 0. QEMU counts at 1 GHz of virtual time instead ([`QEMU_COUNT_HZ`]).
    pub const TIM5_HZ: u32 = 16_000_000;

    /// Starts TIM5 free-running, no interrupt: auto-reload after 268 s at the nominal rate
    /// (nearly the full 32-bit range; QEMU's counter wraps at 2^32 and the windows are
    /// short). `None` if the timer refuses the configuration.
    pub fn start(
        tim5: stm32f4xx_hal::pac::TIM5,
        rcc: &mut stm32f4xx_hal::rcc::Rcc,
    ) -> Option<Self> {
        use stm32f4xx_hal::prelude::*;
        let mut timer = tim5.counter::<{ Clock::TIM5_HZ }>(rcc);
        timer.start(268.secs()).ok()?;
        Some(Self { timer })
    }

    /// The counter, fenced so that no memory access moves across the read.
    #[inline(always)]
    pub fn now(&self) -> u32 {
        compiler_fence(Ordering::SeqCst);
        let t = self.timer.now().ticks();
        compiler_fence(Ordering::SeqCst);
        t
    }
}

/// QEMU's rate of [`Clock`] in its virtual time: 1 GHz (its STM32 timers' input clock).
#[cfg(feature = "qemu")]
pub const QEMU_COUNT_HZ: f64 = 1.0e9;

/// Counts from `start` to `end` (correct across one wrap of the up-counter).
#[cfg(feature = "qemu")]
#[inline(always)]
pub fn elapsed(start: u32, end: u32) -> u32 {
    end.wrapping_sub(start)
}

/// Timings of the control path, kept by the receive task ([`Clock`] counts).
#[derive(Clone, Copy, Debug, Default)]
pub struct Timings {
    /// The control path proper: the frame available as a CAN frame (board: read from the
    /// FIFO; QEMU: SLCAN line parsed) → the demand frame encoded, ready for the transport.
    pub core: Timing,
    /// The whole path inside the receive task: last byte / FIFO entry → demand queued in the
    /// transport (QEMU: SLCAN line formatted; board: in a bxCAN mailbox).
    pub path: Timing,
    /// The parts of `path`: transport receive (QEMU: SLCAN line parse; board: FIFO read),
    /// frame decode, controller step (with the counters), demand encode, transport queue
    /// (QEMU: SLCAN formatting; board: mailbox write).
    pub parts: [Timing; 5],
    /// After the demand is queued: the step's signals stored in the measurement block and,
    /// while an XCP DAQ list runs, the block copied into the DAQ task's queue (what DAQ
    /// costs the receive task).
    pub post: Timing,
}

impl Timings {
    /// Records one measurement: `t0` when the task saw the frame, `received` when it was a
    /// CAN frame, `stamps` at the link's stages ([`mil_firmware::link::stage`]).
    pub fn record(&mut self, t0: u32, received: u32, stamps: [u32; 4]) {
        let [decoded, stepped, encoded, queued] = stamps;
        self.core.record(elapsed(received, encoded));
        self.path.record(elapsed(t0, queued));
        let bounds = [t0, received, decoded, stepped, encoded, queued];
        for (part, w) in self.parts.iter_mut().zip(bounds.windows(2)) {
            if let [a, b] = w {
                part.record(elapsed(*a, *b));
            }
        }
    }
}

/// Instructions per [`Clock`] count in QEMU (`-icount shift=S`: `2^-S`), measured at start-up
/// as in step-bench: `cortex_m::asm::delay(n)` is exactly two instructions per iteration.
#[cfg(feature = "qemu")]
#[derive(Clone, Copy, Debug)]
pub struct Calibration {
    /// Instructions per clock count.
    pub instructions_per_count: f64,
    /// Instructions of an empty window (two back-to-back reads).
    pub empty_window: f64,
}

#[cfg(feature = "qemu")]
#[inline(never)]
fn spin(n: u32) {
    cortex_m::asm::delay(n);
}

#[cfg(feature = "qemu")]
impl Calibration {
    /// Measures the conversion (a few million instructions at start-up).
    pub fn measure(clock: &Clock) -> Self {
        const SHORT: u32 = 1_000;
        const LONG: u32 = 501_000;
        let time = |n: u32| {
            let t0 = clock.now();
            spin(core::hint::black_box(n));
            elapsed(t0, clock.now())
        };
        let short = time(SHORT);
        let long = time(LONG);
        let counts = f64::from(long.saturating_sub(short)).max(1.0);
        let instructions_per_count = 2.0 * f64::from(LONG - SHORT) / counts;
        let mut empty = 0u64;
        for _ in 0..1000 {
            let t0 = clock.now();
            empty += u64::from(elapsed(t0, clock.now()));
        }
        Self {
            instructions_per_count,
            empty_window: empty as f64 * instructions_per_count / 1000.0,
        }
    }

    /// Instructions of a window of `counts` counts, empty-window cost removed.
    pub fn instructions(&self, counts: f64) -> f64 {
        (counts * self.instructions_per_count - self.empty_window).max(0.0)
    }
}

// The linker symbols of cortex-m-rt's stack region: `_stack_start` is its top (the initial
// stack pointer), `_stack_end` its bottom (the end of .bss/.uninit).
extern "C" {
    static _stack_start: u32;
    static _stack_end: u32;
}

/// The stack region: (bottom address, size in bytes).
pub fn stack_region() -> (usize, usize) {
    let top = core::ptr::addr_of!(_stack_start) as usize;
    let bottom = core::ptr::addr_of!(_stack_end) as usize;
    (bottom, top.saturating_sub(bottom))
}

/// The deepest stack use so far (bytes), from the paint cortex-m-rt's `paint-stack` feature
/// laid over the region before `main`. Scans from the bottom up to the first word that lost
/// its paint: run it where its duration (up to one read per free word) does not matter.
pub fn stack_used() -> usize {
    let (bottom, size) = stack_region();
    let words = size / 4;
    let word = |i: usize| -> u32 {
        let address = bottom + 4 * i;
        // `unsafe`: reading the stack region below the live stack. Sound because the address
        // lies inside the RAM region cortex-m-rt reserves for the stack (between
        // `_stack_end` and `_stack_start`, 4-byte aligned by its linker script), is always
        // mapped and initialised (painted at reset), and a volatile u32 read of it has no
        // side effects; a word being written concurrently by an interrupt only makes the
        // result larger, which is the conservative direction.
        #[allow(unsafe_code)]
        unsafe {
            core::ptr::read_volatile(address as *const u32)
        }
    };
    stats::stack_used((0..words).map(word), words)
}

/// The last stack high-water mark the idle loop measured (bytes).
#[cfg(not(feature = "qemu"))]
static STACK_USED: core::sync::atomic::AtomicUsize = core::sync::atomic::AtomicUsize::new(0);

/// Measures the stack high-water mark now and keeps it for [`stack_used_cached`] (called
/// by the board's idle loop, where the scan's duration does not matter).
#[cfg(not(feature = "qemu"))]
pub fn refresh_stack_used() {
    STACK_USED.store(stack_used(), Ordering::Relaxed);
}

/// The high-water mark of the last [`refresh_stack_used`] (bytes; 0 before the first).
#[cfg(not(feature = "qemu"))]
pub fn stack_used_cached() -> usize {
    STACK_USED.load(Ordering::Relaxed)
}
