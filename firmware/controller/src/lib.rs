//! # mil-firmware: the MiL rig controller board's firmware
//!
//! An RTIC v2 application for the rig controller board's STM32F405RG (Cortex-M4F,
//! `thumbv7em-none-eabihf`): the paper's tyre example on one hub actuator,
//! `Controller<TyreModel<1>, 1>` at 2 kHz. Each measurement frame from the servo controller
//! drives one [`model_core::Controller::step`]; the force demand goes back in the same
//! interrupt. The cargo feature `qemu` builds the same application for QEMU's
//! `netduinoplus2` machine, where CAN frames travel as SLCAN (Lawicel ASCII) lines over
//! USART1. Only the transport, the clocks and the watchdog tick period differ between the
//! two builds (the binary's `port` module); everything else is this library, which also
//! builds and runs its unit tests on the host (`cargo test -p mil-firmware --lib`).
//!
//! ## Building, flashing, running
//!
//! ```sh
//! # board
//! cargo build -p mil-firmware --target thumbv7em-none-eabihf --release
//! probe-rs run --chip STM32F405RGTx target/thumbv7em-none-eabihf/release/mil-firmware
//! # QEMU
//! cargo build -p mil-firmware --target thumbv7em-none-eabihf --release --features qemu
//! qemu-system-arm -machine netduinoplus2 -nographic -monitor none \
//!     -semihosting-config enable=on,target=native \
//!     -serial tcp:127.0.0.1:PORT,server=on,wait=on,nodelay=on \
//!     -icount shift=3,align=off -kernel target/thumbv7em-none-eabihf/release/mil-firmware
//! python3 firmware/controller/qemu/smoke.py --build   # the SLCAN smoke test (qemu/README.md)
//! # the budgets: instructions per control step, flash / static RAM, stack high-water mark
//! cargo run -p mil-can --example qemu_budget
//! ```
//!
//! `probe-rs run` (from `cargo install probe-rs-tools --locked`) flashes the ELF and prints
//! the defmt log (RTT). `memory.x` (the workspace's) is copied by `build.rs`, which also
//! links `defmt.x` into the board build (`cargo:rustc-link-arg-bins`); the QEMU build has no
//! defmt at all. With `-icount shift=S,align=off` every instruction advances QEMU's virtual
//! time by 2^S ns; the QEMU build times its control path with TIM5, which QEMU clocks at
//! 1 GHz of virtual time, so the instruction figures are exact (2^S counts per instruction,
//! calibrated at start-up); without `-icount` the firmware runs the same, only the figures
//! become timing-dependent. The budget run uses `-icount shift=0,align=off,sleep=off` (one
//! count per instruction; virtual time independent of the host): there guest time jumps to
//! the next timer deadline whenever the CPU waits for the host, which would trip the
//! watchdog between lockstep samples, so it first switches the watchdog off (parameter 101 =
//! 0, accepted by the QEMU build only; see [the watchdog](#the-communication-watchdog)).
//!
//! Why not SysTick in QEMU: QEMU 7.2 runs SysTick at 168 MHz of virtual time, i.e. 0.168 ·
//! 2^S counts per instruction (measured: 5.9524 instructions per count at `shift=0`, not
//! one), too coarse for per-step figures; and under `sleep=off` the phase of that count at
//! the start of a window depends on host timing, so two runs differed by a count in their
//! extremes. The board build uses SysTick (core cycles).
//!
//! ## Tasks and priorities
//!
//! | task | priority | trigger | does |
//! | --- | --- | --- | --- |
//! | `can_rx` (board) / `usart_rx` (QEMU) | 3 (highest) | bxCAN FIFO 0 message pending (`CAN1_RX0`) / USART1 RXNE | decodes the frame; a measurement runs one controller step and queues the Demand frame (and every K-th step the Status frame) before returning; commands go to `configure` through a 4-deep channel (full: CommandAck `BUSY`) |
//! | `watchdog` | 2 | TIM2 update | the communication watchdog tick (below) |
//! | `aux_rx` (QEMU only) | 2 | USART2 RXNE | the XCP port's SLCAN lines: XCP command frames go to `xcp` |
//! | `daq` | 2 (software task) | a step sample in its 16-deep channel | samples the running XCP DAQ lists on the copy of the measurement block the receive task queued after the step, sends the DTOs |
//! | `configure` | 1 (software task) | a command in the channel | one command: Start/Stop/ClearFault to the controller, parameter writes through [`xcp::Target::command_frame`] (with the slave's ECU page and unlock state); answers with a CommandAck |
//! | `xcp` | 1 (software task) | an XCP command frame in its 48-deep channel | one command through `mil_xcp::Slave` and [`xcp::Target`]: calibration writes validated on a copy, swapped in under the application's short lock; answers on the link the command came from |
//! | `idle` | – | – | `wfi`; on the board it refreshes the stack high-water mark about once a second |
//!
//! The application state ([`application::Application`]: controller, counters, watchdog) and
//! the transmit half of the transport are RTIC shared resources; priority 3 owns their
//! ceiling, so the control path never waits for a lock, and the lower tasks hold them only
//! for a step or a swap. Every parameter change, by XCP or by Command frame, goes through
//! the one calibration authority, [`xcp::Target`]: a write of the working page validated as a
//! whole page outside any lock (`PreparedParams::new`) and installed with
//! [`application::Application::install`] under a short lock, i.e. between two steps, or
//! refused with nothing changed; the controller always runs the page GET_CAL_PAGE names.
//! Command-frame writes need the XCP session's CAL/PAG unlock unless they cannot raise the
//! force ([`xcp::safe_without_unlock`]).
//!
//! ## XCP on CAN (calibration and measurement)
//!
//! CANape, INCA, pyxcp or `mil param` / `mil daq` reach the calibration page and the
//! measurement block ([`calibration`]) through the XCP slave of `mil-xcp`, described by the A2L
//! file `mil a2l --elf FIRMWARE --out mil.a2l` generates from this build's ELF:
//! - **CAN IDs** (build-time `MIL_XCP_CAN_IDS=CMD,RES`, default `0x7E0,0x7E1`; `build.rs`
//!   refuses IDs inside or below the MiL range, so measurement, demand, status and command
//!   frames always win arbitration). Board: CAN1, hardware filter bank 1 passes the command
//!   ID. QEMU: the XCP frames work on USART1 (the same link as the lockstep) and on USART2
//!   (QEMU `-serial` 1, a second SLCAN port on the same virtual bus for a master such as
//!   pyxcp); answers go back to the port the command came from, DAQ packets to the port of
//!   the last CONNECT.
//! - **Seed & key secret** (build-time `MIL_XCP_SECRET`, text or `hex:...`, at least 16
//!   bytes; never committed). Unset: the QEMU build uses `mil-xcp`'s public test secret
//!   (`FAKE-TEST-SECRET-do-not-use-0000`: the QEMU build is a test build), the board build has
//!   none and answers no XCP command at all (the build prints a warning; XCP frames are
//!   counted as foreign).
//! - **Calibration**: a write (DOWNLOAD, a block, COPY_CAL_PAGE or an ECU page switch) is
//!   validated in the `xcp` task as a whole parameter set on a copy (finite, within the A2L
//!   limits, command filter stable with margin: every pole within 1 − `model_core::POLE_MARGIN`
//!   = 1 − 1e-6 of the origin, consistent) and swapped in under the application's lock, i.e.
//!   between two control steps; a refused write answers the XCP error (ERR_OUT_OF_RANGE,
//!   ERR_GENERIC, ERR_ACCESS_DENIED outside the page, ERR_WRITE_PROTECTED into the reference
//!   page) and changes nothing. The measurement block's `calibration_changes` counts applied
//!   changes, `calibration_last_rejection` keeps the reason code of the last refusal (XCP and
//!   Command frames alike).
//! - **DAQ**: event channel 0 is the control step (its cycle the running sample period:
//!   500 µs at the default 2 kHz, 1 ms for a configuration at 1 kHz); the DAQ timestamp is
//!   the step's board time (measurement `time_us`: every step's sample period summed, each
//!   at the rate it ran, exact at any whole rate), as is GET_DAQ_CLOCK. After each step, once the demand frame
//!   is queued, the receive task stores the step's signals into the measurement block and,
//!   while a list runs, queues a copy of it (60 bytes) for the `daq` task; the DTOs are built
//!   from that copy, so a sample is consistent even when the `daq` task runs late. A sample
//!   that finds the queue full is dropped and counted (`daq_dropped`), as is a DTO the
//!   transport refuses (on the board a demand frame displaces a pending lower-priority XCP
//!   frame from a busy mailbox, never the reverse). The control step never waits on XCP: the
//!   `xcp` task holds the slave (shared with `daq`, ceiling 2) and the application's lock
//!   only for the swap.
//! - Tests: `cargo test -p mil-firmware --lib` (the target through the slave; a proptest of
//!   random XCP sessions: the running parameters always equal the validated ECU page);
//!   `cargo test -p mil-can --test qemu_xcp` (QEMU, USART1: the A2L of the real ELF, unlock,
//!   writes reaching the demand from a step boundary on, bumpless, refusals, pages, DAQ in step with the
//!   demand frames); `firmware/controller/qemu/xcp_pyxcp.py --elf ELF --a2l A2L` (pyxcp
//!   0.29 on USART2 through python-can's slcan, in CI); `cargo run -p mil-can --example
//!   qemu_budget` (the control step with a DAQ list running).
//!
//! ## Frame flow
//!
//! Frames are `mil-frames`' (DBC `firmware/frames/mil.dbc`, base ID 0x100), see [`link`] for
//! what happens to each received frame:
//!
//! ```text
//! servo  --Measurement (0x100), [MeasurementAux (0x108)]-->  board  --Demand (0x110)-->  servo
//! tool   --Command (0x121)-->  board  --CommandAck (0x122)-->  tool
//!                              board  --Status (0x120), every K steps (default 200: 10 Hz)-->
//! ```
//!
//! - Demand: force (0.1 N), the measurement's counter echoed, mode, fault-latched,
//!   amplitude- and rate-limited bits of that step. Encoded by [`link::demand_frame`] (the
//!   same bytes as `mil_frames::encode_demand`, f32 only); a non-finite value is replaced by
//!   the safe demand, so a NaN can never be transmitted (model-core never produces one).
//! - Status: mode, fault causes, missed / late / malformed counts (saturating u16).
//! - CommandAck: command and index echoed, result ([`params::code`]: 0 ok, below 128 a
//!   `mil-frames` decode error such as 11 for a NaN value, from 128 the firmware's codes),
//!   mode after the command.
//! - Counters ([`application::Counters`]): *missed* from the measurement counter (a jump of k
//!   counts k − 1); *late*: a measurement more than one tick later than its counter
//!   implies, out of order (counter repeated or going back), or a demand frame that could not
//!   be queued; *malformed*: frames in the MiL range that fail to decode (wrong length,
//!   "not available" or out-of-range values, free IDs, remote frames, NaN commands) or carry
//!   a channel other than 0: counted and ignored; *foreign*: frames outside the range,
//!   extended IDs, board-to-host frames (ignored; only in the QEMU report).
//!
//! Board transport: CAN1 (PB9 TX, PB8 RX) through bxCAN at 1 Mbit/s (42 MHz APB1, 14 time
//! quanta, sample point 85.7 %), hardware filter on base..base+0x3F into FIFO 0, three
//! transmit mailboxes (when all are busy bxCAN replaces a pending lower-priority frame:
//! counted). QEMU transport: SLCAN over USART1 (QEMU `-serial` 0), RX by the RXNE interrupt,
//! TX by blocking writes at the end of each handler (QEMU 7.2 never raises TXE).
//!
//! ## SLCAN (QEMU build)
//!
//! The host talks Lawicel ASCII over the TCP socket (`\r`-terminated lines; python-can's
//! `slcan` interface with `channel="socket://127.0.0.1:PORT"` works too):
//!
//! 1. Handshake: bytes sent before the firmware enables USART1 are lost, so repeat a
//!    command until it is answered, e.g. `V\r` every 200 ms until `V0101\r` arrives (then
//!    drain the extra answers), then `O\r` (answer `\r`). A frame line also opens the
//!    channel, so python-can 4.6's `slcan` interface works even when its opening lines are
//!    lost (checked: Start, 20 lockstep samples, `shutdown()` → report, exit 0; its
//!    `get_version()` right after opening may then return `(None, None)`).
//! 2. Frames: `tIIILDD..\r` (standard data frames, upper- or lower-case hex). Measurement
//!    lines are not acknowledged (no `z\r`); the firmware answers each with its Demand line
//!    `t1106DDDDDDDDCCFF\r`, followed every K steps by a Status line `t1208...\r`, and each
//!    Command line with a CommandAck line `t1224...\r`. In lockstep the host sends one
//!    measurement and reads lines until the Demand with its counter arrives.
//! 3. Other commands: `C`, `S0`–`S9`, `sXXYY`, `Z0`/`Z1`, `L` and an empty line → `\r`;
//!    `v` → `v0101\r`; `N` → `N0405\r`; `F` → `F00\r`; a line that does not parse → BEL
//!    (`\x07`). Remote and extended frames are counted, not answered.
//! 4. End of run: `C\r` while the channel is open (python-can's shutdown) answers `\r`,
//!    prints the report on semihosting stdout (counters, instructions per control step,
//!    stack high-water mark, watchdog tick) and exits QEMU with status 0. A `C` before `O`
//!    (python-can sends one while opening) is only answered.
//!
//! ## The communication watchdog
//!
//! A periodic tick counts the ticks since the last valid measurement (channel 0, decoded
//! without error). After N ticks without one (N = 10 by default; `SetWatchdog` with the
//! timeout in seconds of sample time, N = round(s · 2000), 2 ≤ N ≤ 10 000, so 0 is refused;
//! or parameter index 101 with N itself) the link is lost: a Running controller is tripped
//! with [`application::fault::COMM_TIMEOUT`] (bit 4, latched until ClearFault), and from then
//! on every tick steps the controller itself, so its demand ramps to the safe demand at the
//! safe ramp rate, and transmits that Demand frame (counter counting on), until measurements
//! return. In Idle a lost link only ramps (no trip). The watchdog is armed once a
//! measurement has been seen or the controller runs, so a board on a silent bus stays
//! quiet after boot.
//!
//! - Board: TIM2 ticks at the sample period (500 µs), so N samples = N · 0.5 ms (5 ms by
//!   default), unsynchronised with the servo controller's clock (hence N ≥ 2).
//! - QEMU: QEMU clocks its timers at a fixed rate whatever RCC says, emulates far slower
//!   than real time in lockstep (about 360 samples/s over SLCAN, two lines per sample), and
//!   its virtual time is not the rig's time. A tick of one sample period would trip on
//!   every lockstep sample. So the tick period is a build constant,
//!   [`config::QEMU_TICK_US`] = 50 ms of QEMU virtual time (100 sample periods), with TIM2's
//!   actual rate measured against TIM5 at start-up (QEMU's STM32 timers count at 1 GHz of
//!   virtual time before their prescaler). With N = 10 the trip comes after 0.5 s of virtual time without a
//!   measurement (about 0.8 s of wall time at `-icount shift=3`), far beyond any lockstep
//!   gap. Everything the watchdog does is counted in ticks, not time: a test stops the
//!   measurements and counts the Demand frames the ticks send (the N-th silent tick trips
//!   and sends the first one; each further tick ramps by `safe_ramp_rate · dt` = 25 N).
//!   The logic itself is tick-exact and unit-tested on the host
//!   ([`application::Application::on_tick`]).
//! - QEMU build only: parameter 101 = 0 switches the watchdog off until reset
//!   ([`config::WATCHDOG_OFF`]): the ticks count nothing, the next tick stops TIM2, and a
//!   later watchdog setting is refused (WRONG_MODE). For the budget run under
//!   `-icount ...,sleep=off`, where virtual time leaps while the guest waits for the host.
//!   The board build refuses 0 (out of range): its watchdog cannot be switched off.
//!
//! ## Safe state on panic and HardFault
//!
//! There is no `unwrap`, `expect`, indexing or division that can panic in the control path
//! (clippy denies them crate-wide), and no heap. Should a panic or a HardFault happen anyway,
//! the binary's `fatal` module disables interrupts, writes one Demand frame with the running
//! safe demand (default 1667.7 N; mode Fault, fault flag) and one Status frame saying why (mode
//! Fault, fault bit 5 `FIRMWARE_STOPPED` plus the bits latched at the last step, counters
//! and calibration source from the measurement block) straight into bxCAN mailboxes
//! (aborting pending frames if all three are busy) or, in QEMU, as SLCAN lines on USART1,
//! then:
//! - board: logs the cause over defmt-rtt and halts. No further demand frames come, so the
//!   servo controller's own watchdog (missing demands) takes the actuator to its safe
//!   state; the last demand it received is the safe one. A reset restarts the board in Idle
//!   with the demand at the safe value.
//! - QEMU: prints `mil-firmware FAILED: <cause>` on semihosting stderr and exits QEMU with
//!   status 1 (never hangs, unlike panic-probe). The QEMU test build takes the line
//!   `!HARDFAULT` as an order to execute an undefined instruction, so that
//!   `cargo test -p mil-can --test qemu_lockstep a_hardfault` can watch the path: the safe
//!   demand, the Status frame with bit 5, exit status 1 naming the HardFault's pc.
//!
//! The safe demand it sends is the one of the set installed last (a tuned `safe_demand`
//! included), kept in an atomic ([`calibration::SAFE_DEMAND`]) because the running
//! parameters belong to a task the fault may have interrupted.
//!
//! ## Fault bits (Status `FaultCauses`, [`application::fault`])
//!
//! | bit | name | source |
//! | --- | --- | --- |
//! | 0 | `INVALID_INPUT` | model-core: a non-finite input, or a position/road beyond ±1 m |
//! | 1 | `NUMERICAL` | model-core: a non-finite value in the model or the command filter |
//! | 2, 3 | reserved | left free for model-core |
//! | 4 | `COMM_TIMEOUT` | firmware: no valid measurement for N watchdog ticks while Running |
//! | 5 | `FIRMWARE_STOPPED` | firmware: a panic or HardFault; only in the last Status frame, after which the board halts |
//!
//! All are latched (mode Fault, demand ramps to the safe demand) until a ClearFault command
//! (Fault → Idle); a Start then runs the model again from rest.
//!
//! ## Configuration defaults ([`config`])
//!
//! Tyre: k_t 2.5e5 N/m, c_t 500 N s/m, static load 1667.7 N, lift-off, 500 Hz velocity
//! low-pass (`TyreParams::PAPER`); no command filter; dt = 1/2000 s; demand limits −1000 N ..
//! 12 000 N, rate 2e6 N/s; safe demand 1667.7 N, safe ramp 5e4 N/s (as
//! `host-tools/mil/examples/tyre.toml`); watchdog N = 10; status every K = 200 steps.
//! Commands: 1 Start (Idle → Running), 2 Stop, 3 ClearFault, 4 SetParam (index and value as
//! in [`params`]), 5 SetWatchdog (seconds).
//!
//! ## Measured (`cargo run -p mil-can --example qemu_budget`)
//!
//! QEMU 7.2, `-icount shift=0,align=off,sleep=off`, Rust 1.95, release; the paper's tyre on
//! the simulated rig, 4000 lockstep samples of pink road (0.5 mm RMS), demand frames
//! bit-identical to the host mirror's. Instructions, not cycles (QEMU models no pipeline,
//! flash wait states or FPU latency); identical in every run.
//!
//! | figure | value |
//! | --- | --- |
//! | control path: CAN frame received → Demand frame encoded, ready to queue (decode, step with counters, encode) | 522.1 instructions mean (518–543 over 4000 steps; target ≤ 1000); the same with an XCP DAQ list running |
//! | parts | decode 183.0, step 285.1, encode 55.0 |
//! | after the Demand is queued (same task): measurement block stored / + DAQ sample copied and queued for the `daq` task | 264.0 / 387.6 mean (max 468 / 592): DAQ costs the receive task 123.6 instructions a step, after the demand |
//! | with QEMU's SLCAN transport (last byte read → Demand line queued) | 1085.6 mean (1050–1136; SLCAN parse 412.4 and format 151.0 stand in for the bxCAN FIFO read and mailbox write) |
//! | stack high-water mark (stack painting, QEMU run, measured before the report formats anything) | 7 760 B of the 123 KiB region (1.0–1.5 KB before XCP): `init`, which builds the application and the XCP slave (about 2 KiB) by value and returns them as RTIC resources (7 004 B in use at its end, measured with a throw-away print in the smoke test; its return of the resources or a task makes up the rest) |
//! | board ELF: flash (vector table + .text + .rodata + .data) | 62 060 B of 1 MiB (built without `MIL_XCP_SECRET`; the XCP slave's code is linked all the same) |
//! | board ELF: static RAM (.data + .bss + .uninit, incl. the 1 KiB RTT buffer) | 6 040 B of 128 KiB (the slave's DAQ tables, the 48-deep XCP and 16-deep DAQ queues) |
//! | QEMU ELF: flash / static RAM | 107 988 B / 5 332 B (core::fmt for the report) |
//!
//! Sizes from the ELF section headers (`mil_can::footprint`; the same as
//! `llvm-size -A`). On the board the clock is SysTick, which counts core cycles; the board
//! logs the control path's cycles over defmt every 20 000 samples.
//!
//! ## `unsafe`
//!
//! Denied crate-wide (`#![deny(unsafe_code)]`); the exceptions, each justified where it is:
//! the HardFault handler (cortex-m-rt requires an `unsafe fn`), the stack scan (volatile
//! reads of the painted stack region), and the fatal path's register access (stealing CAN1
//! or USART1 after interrupts are off, raw register field writes).
#![no_std]
#![deny(unsafe_code)]
#![cfg_attr(
    not(test),
    deny(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::indexing_slicing,
        clippy::panic
    )
)]

#[cfg(test)]
extern crate std;

pub mod application;
pub mod calibration;
pub mod config;
pub mod link;
pub mod params;
pub mod stats;
pub mod store;
pub mod xcp;
