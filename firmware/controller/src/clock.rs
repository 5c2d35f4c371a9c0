//! SysTick as a free-running core-clock counter (timing of the control path), the
//! instruction calibration of the QEMU build, and the stack high-water mark.

use core::sync::atomic::{compiler_fence, Ordering};

use cortex_m::peripheral::syst::SystClkSource;
use cortex_m::peripheral::SYST;
use mil_firmware::stats::{self, Timing};

/// SysTick reload: the full 24-bit range (about 100 ms at 168 MHz).
const RELOAD: u32 = 0x00FF_FFFF;

/// Starts SysTick from the core clock, counting down, no interrupt (RTIC does not use it:
/// the app has no monotonic).
pub fn start(mut syst: SYST) {
    syst.disable_interrupt();
    syst.set_clock_source(SystClkSource::Core);
    syst.set_reload(RELOAD);
    syst.clear_current();
    syst.enable_counter();
}

/// The counter, fenced so that no memory access moves across the read.
#[inline(always)]
pub fn now() -> u32 {
    compiler_fence(Ordering::SeqCst);
    let t = SYST::get_current();
    compiler_fence(Ordering::SeqCst);
    t
}

/// Counts from `start` to `end` (correct across one wrap of the down-counter).
#[inline(always)]
pub fn elapsed(start: u32, end: u32) -> u32 {
    start.wrapping_sub(end) & RELOAD
}

/// Timings of the control path, kept by the receive task (SysTick counts).
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

/// Instructions per SysTick count in QEMU (`-icount shift=S`: `1 / (0.168 · 2^S)`), measured
/// as in step-bench: `cortex_m::asm::delay(n)` is exactly two instructions per iteration.
#[cfg(feature = "qemu")]
#[derive(Clone, Copy, Debug)]
pub struct Calibration {
    /// Instructions per SysTick count.
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
    pub fn measure() -> Self {
        const SHORT: u32 = 1_000;
        const LONG: u32 = 501_000;
        let time = |n: u32| {
            let t0 = now();
            spin(core::hint::black_box(n));
            elapsed(t0, now())
        };
        let short = time(SHORT);
        let long = time(LONG);
        let counts = f64::from(long.saturating_sub(short)).max(1.0);
        let instructions_per_count = 2.0 * f64::from(LONG - SHORT) / counts;
        let mut empty = 0u64;
        for _ in 0..1000 {
            let t0 = now();
            empty += u64::from(elapsed(t0, now()));
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
