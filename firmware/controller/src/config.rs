//! The configuration defaults of the firmware, in one place.
//!
//! One image runs every model (model-core's [`BoardController`]): the tyre on 1 to 4 hub
//! channels, the aero model on its two channels, or a substructure on 1 to 4 channels,
//! chosen at run time by the calibration page's `board_model_kind` and `board_channels`
//! (changed only while Idle) at the page's `sample_rate` (likewise). The board boots into
//! the stored page or these defaults: the paper's tyre example on one hub actuator
//! ([`TyreParams::PAPER`]: k_t 250 N/mm, c_t 0.5 N s/mm, static load (150 + 20) kg ·
//! 9.81 m/s², lift-off, 500 Hz velocity low-pass), no command filter, at 2 kHz, and the
//! limits and safe state of `host-tools/mil/examples/tyre.toml`.

use model_core::board::BOARD_CHANNELS;
use model_core::{BoardController, BoardParams, BoardPrepared, DemandLimits, TyreParams};

/// Most actuator channels this firmware serves.
pub const CHANNELS: usize = BOARD_CHANNELS;

/// The controller type of the firmware.
pub type Controller = BoardController;

/// The full parameter set.
pub type Params = BoardParams;

/// Validated parameters, ready to be swapped in.
pub type Prepared = BoardPrepared;

/// Default sample rate of the servo controller's measurement frames (Hz): one tyre channel
/// per 1 Mbit/s CAN bus sustains 2 kHz. The running rate is the page's `sample_rate`.
pub const SAMPLE_RATE_HZ: u32 = 2000;

/// Allowed sample rates (Hz).
pub const SAMPLE_RATE_RANGE: (u16, u16) = (100, 10_000);

/// Default sample period `dt` (s) of the controller step.
pub const DT: f32 = 1.0 / SAMPLE_RATE_HZ as f32;

/// The watchdog tick rate of the board build (Hz): the default sample rate, whatever the
/// running one (the watchdog counts ticks, see [`WATCHDOG_SAMPLES`]).
pub const TICK_RATE_HZ: u32 = SAMPLE_RATE_HZ;

/// Lowest force demand (N).
pub const DEMAND_MIN_N: f32 = -1000.0;
/// Highest force demand (N).
pub const DEMAND_MAX_N: f32 = 12_000.0;
/// Demand rate limit in normal running (N/s).
pub const DEMAND_RATE_N_PER_S: f32 = 2.0e6;
/// Demand in the safe state (N): the static load, so the car rests on its hubs.
pub const SAFE_DEMAND_N: f32 = 1667.7;
/// Rate at which the demand moves to the safe demand (N/s).
pub const SAFE_RAMP_N_PER_S: f32 = 5.0e4;

/// Default communication watchdog: a trip after this many sample periods (watchdog ticks)
/// without a valid measurement. Settable by command within [`WATCHDOG_SAMPLES_RANGE`].
pub const WATCHDOG_SAMPLES: u16 = 10;
/// Allowed watchdog settings (ticks): at least 2 (one tick of jitter between an
/// unsynchronised timer and the measurement stream must not trip), at most 10 000.
pub const WATCHDOG_SAMPLES_RANGE: (u16, u16) = (2, 10_000);

/// The watchdog limit that switches the communication watchdog off (parameter index 101 =
/// 0), accepted only where [`WATCHDOG_OFF_ALLOWED`]. Off means: the ticks count nothing and
/// never trip or step the controller, the QEMU build stops its tick timer at the next tick,
/// and the limit cannot be changed again until reset.
pub const WATCHDOG_OFF: u16 = 0;

/// Whether [`WATCHDOG_OFF`] is accepted: only in the QEMU build (feature `qemu`), for the
/// instruction benchmark under `-icount ...,sleep=off`, where QEMU's virtual time jumps from
/// timer deadline to timer deadline while the guest waits for the host, so any tick-counting
/// watchdog trips between lockstep samples (and counts every measurement late). The board
/// build refuses 0 (out of range): its watchdog cannot be switched off.
pub const WATCHDOG_OFF_ALLOWED: bool = cfg!(feature = "qemu");

/// Default status period K: one status frame every K controller steps (10 Hz at 2 kHz).
pub const STATUS_PERIOD_SAMPLES: u16 = (SAMPLE_RATE_HZ / 10) as u16;
/// Allowed status periods (steps).
pub const STATUS_PERIOD_RANGE: (u16, u16) = (1, 60_000);

/// Watchdog tick period of the board build (µs): one default sample period.
pub const BOARD_TICK_US: u32 = 1_000_000 / TICK_RATE_HZ;

/// Watchdog tick period of the QEMU build, in QEMU's virtual time (µs): 50 ms, 100 times the
/// sample period. QEMU exchanges about 900 SLCAN lines per second of wall time in lockstep
/// (a few hundred samples per second), far slower than the real 2 kHz, so a tick of one
/// sample period would trip on every sample. With 50 ms ticks and the default N = 10 the
/// watchdog trips after half a second of silence, long after any normal lockstep gap, and a
/// test counts ticks (demand frames sent while the link is down), not time.
pub const QEMU_TICK_US: u32 = 50_000;

// The build-time XCP settings: `XCP_COMMAND_ID`, `XCP_RESPONSE_ID`, `XCP_SECRET` (see
// `build.rs`: environment variables `MIL_XCP_CAN_IDS` and `MIL_XCP_SECRET`).
include!(concat!(env!("OUT_DIR"), "/xcp_build.rs"));

/// XCP GET_ID answer: the A2L file's name without extension (`mil a2l` writes `mil.a2l`).
pub const XCP_ID: &[u8] = b"mil";

/// Frames of XCP commands waiting for the XCP task: a master's block download (up to
/// MAX_BS = 42 DOWNLOAD_NEXT frames sent back to back) fits.
pub const XCP_QUEUE: usize = 48;

/// The paper's tyre parameters for every channel, as in `tyre.toml`.
pub const TYRE: TyreParams = TyreParams {
    stiffness: 2.5e5,
    damping: 500.0,
    static_load: 1667.7,
    lift_off: 1,
    velocity_cutoff_hz: 500.0,
};

/// Demand limits of every channel.
pub const LIMITS: DemandLimits = DemandLimits {
    min: DEMAND_MIN_N,
    max: DEMAND_MAX_N,
    rate: DEMAND_RATE_N_PER_S,
};

/// The default parameter set: the paper's tyre on one hub channel, no command filter,
/// `tyre.toml`'s limits (on every channel).
pub const fn default_params() -> Params {
    BoardParams::tyres(TYRE, 1, LIMITS, SAFE_DEMAND_N, SAFE_RAMP_N_PER_S)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid_and_match_the_paper() {
        let p = default_params();
        assert!(p.prepare(DT).is_ok());
        // The static load differs from `TyreParams::PAPER`'s 170 · 9.81 only by rounding.
        assert!((TYRE.static_load - TyreParams::PAPER.static_load).abs() < 0.01);
        assert_eq!(TYRE.stiffness, TyreParams::PAPER.stiffness);
        assert_eq!(TYRE.damping, TyreParams::PAPER.damping);
        assert_eq!(STATUS_PERIOD_SAMPLES, 200);
        assert_eq!(BOARD_TICK_US, 500);
    }
}
