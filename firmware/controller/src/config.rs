//! The configuration defaults of the firmware, in one place.
//!
//! The model is the paper's tyre example on one hub actuator: `Controller<TyreModel<1>, 1>`
//! with [`TyreParams::PAPER`] (k_t 250 N/mm, c_t 0.5 N s/mm, static load (150 + 20) kg ·
//! 9.81 m/s², lift-off, 500 Hz velocity low-pass), no command filter, at 2 kHz, and the limits
//! and safe state of `host-tools/mil/examples/tyre.toml`. Everything here can be changed
//! at run time through Command frames (see [`crate::params`] for the parameter indices), except
//! the sample period, which is fixed by the servo controller's measurement rate.

use model_core::{
    CascadeCoefficients, ControllerParams, DemandLimits, TyreModel, TyreModelParams, TyreParams,
};

/// Number of actuator channels this firmware serves.
pub const CHANNELS: usize = 1;

/// The numerical model.
pub type Model = TyreModel<CHANNELS>;

/// The controller type of the firmware.
pub type Controller = model_core::Controller<Model, CHANNELS>;

/// The full parameter set.
pub type Params = ControllerParams<TyreModelParams<CHANNELS>, CHANNELS>;

/// Validated parameters, ready to be swapped in.
pub type Prepared = model_core::PreparedParams<Model, CHANNELS>;

/// Sample rate of the servo controller's measurement frames (Hz): one tyre channel per
/// 1 Mbit/s CAN bus sustains 2 kHz.
pub const SAMPLE_RATE_HZ: u32 = 2000;

/// Sample period `dt` (s) of the controller step.
pub const DT: f32 = 1.0 / SAMPLE_RATE_HZ as f32;

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

/// Watchdog tick period of the board build (µs): one sample period.
pub const BOARD_TICK_US: u32 = 1_000_000 / SAMPLE_RATE_HZ;

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

/// The default parameter set: the paper's tyre, no command filter, `tyre.toml`'s limits.
pub const fn default_params() -> Params {
    ControllerParams {
        model: TyreModelParams {
            tyre: [TYRE; CHANNELS],
        },
        filter: [CascadeCoefficients::IDENTITY; CHANNELS],
        limits: [LIMITS; CHANNELS],
        safe_demand: [SAFE_DEMAND_N; CHANNELS],
        safe_ramp_rate: [SAFE_RAMP_N_PER_S; CHANNELS],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid_and_match_the_paper() {
        let p = default_params();
        assert!(Prepared::new(&p, DT).is_ok());
        // The static load differs from `TyreParams::PAPER`'s 170 · 9.81 only by rounding.
        assert!((TYRE.static_load - TyreParams::PAPER.static_load).abs() < 0.01);
        assert_eq!(TYRE.stiffness, TyreParams::PAPER.stiffness);
        assert_eq!(TYRE.damping, TyreParams::PAPER.damping);
        assert_eq!(STATUS_PERIOD_SAMPLES, 200);
        assert_eq!(BOARD_TICK_US, 500);
    }
}
