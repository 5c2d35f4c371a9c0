//! The firmware's budgets, measured: instructions per control step in QEMU, flash and static
//! RAM from the ELF, and the stack high-water mark.
//!
//! ```sh
//! cargo run -p mil-can --example qemu_budget [-- --samples N] [--no-build]
//! ```
//!
//! 1. Builds the board and the QEMU firmware (`cargo build -p mil-firmware --target
//!    thumbv7em-none-eabihf --release [--features qemu]`, always release, whatever profile
//!    this example runs in; `--no-build` uses the QEMU ELF that is there and skips the
//!    board's sizes) and reads both ELFs' section headers.
//! 2. Starts the QEMU build on `netduinoplus2` with `-icount shift=0,align=off,sleep=off`:
//!    every instruction advances QEMU's virtual time by exactly 1 ns, and virtual time does
//!    not follow the host's clock while the guest waits. The firmware times its control
//!    path with TIM5, which QEMU clocks at 1 GHz of virtual time: one count per instruction.
//!    QEMU counts instructions, not cycles (no pipeline, flash wait states or FPU latency).
//! 3. Switches the firmware's communication watchdog off (parameter `watchdog_limit` = 0, accepted by the
//!    QEMU build only): under `sleep=off` virtual time jumps from timer deadline to timer
//!    deadline while the guest waits for the host, so its ticks would trip between samples.
//! 4. Drives the paper's tyre example (the simulated hub rig, `mil-rig`) through N samples
//!    (default 4000, 2 s at 2 kHz) of pink road (0.5–40 Hz, 0.5 mm RMS, as `mil sim`'s
//!    built-in example, with 2 µm of position-sensor noise) in lockstep over SLCAN, checking
//!    every demand frame against the host mirror of the firmware's controller bit for bit.
//! 5. Closes the channel; the firmware reports its figures and exits.
//! 6. Runs 2–5 once more with an XCP DAQ list running (connect and unlock with the QEMU
//!    build's public test secret, one list of demand, position, road and step count on the
//!    control-step event, with timestamps: five DTOs per step): the control step's
//!    instructions with DAQ running, and what the receive task spends after the demand is
//!    queued (the measurement block store, plus the copy of it queued for the DAQ task).
//!    The host waits for each step's five DTOs before it sends the next measurement, as the
//!    bus would pace it: QEMU's USART spends host time per byte and none of virtual time, so
//!    an unpaced host outruns the emulated link and the count of dropped DAQ samples would
//!    measure the host's load, not the firmware. Every DTO must arrive and none be dropped.
//!
//! 7. Runs every other configuration the board serves, each in its own QEMU (a quarter of N
//!    samples): the firmware configured over XCP (`mil_can::configure`, the mirror replaying
//!    the writes), then sinusoidal road, body motion, forces and speed; every demand frame
//!    compared with the mirror's, the control step's instructions from the firmware's report.
//!
//! Prints the budget table and exits non-zero if a check failed or a control step of the
//! default configuration took more than 1000 instructions, with or without DAQ.
//!
//! The instruction figures are deterministic: two runs print the same numbers. The stack
//! high-water mark is not quite: how deep the receive interrupt finds the lower-priority
//! tasks when it preempts them depends on host timing.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};
use std::time::{Duration, Instant};

use mil_can::footprint::{footprint, Footprint};
use mil_can::{find_firmware_elf, Qemu, QemuOptions, RemoteBoard, SlcanTcp};
use mil_firmware::calibration::SLOT_WATCHDOG;
use mil_firmware::config::{TYRE, WATCHDOG_OFF};
use mil_frames::CommandKind;
use mil_identify::band_limited_noise;
use mil_rig::harness::{run, Instrumentation};
use mil_rig::rigs::{paper_tyre_part, tyre_input};
use mil_rig::sensors::SensorSpec;
use model_core::Mode;

/// Sample rate of the measurement frames (Hz).
const FS: f64 = 2000.0;
/// The budget: instructions per control step, CAN frame received to demand frame encoded
/// (ready to queue; the transport's own receive and queue are QEMU's SLCAN stand-ins here,
/// reported separately).
const TARGET: f64 = 1000.0;
/// The line of the firmware's report with its figures as `key=value` pairs.
const FIGURES: &str = "mil-firmware figures:";

/// Command-line options.
struct Options {
    samples: usize,
    build: bool,
}

fn options() -> Result<Options, String> {
    let mut o = Options {
        samples: 4000,
        build: true,
    };
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--samples" => {
                o.samples = args
                    .next()
                    .and_then(|v| v.parse().ok())
                    .filter(|&n| n >= 100)
                    .ok_or("--samples needs a number of at least 100")?;
            }
            "--no-build" => o.build = false,
            "-h" | "--help" => {
                return Err("usage: qemu_budget [--samples N] [--no-build]".into());
            }
            other => return Err(format!("unknown argument {other:?} (see --help)")),
        }
    }
    Ok(o)
}

/// The workspace root (for the nested cargo builds).
fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Builds the firmware (board or QEMU build) and returns the ELF's contents.
fn build(qemu: bool) -> Result<Vec<u8>, String> {
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let mut cmd = Command::new(cargo);
    cmd.current_dir(workspace()).args([
        "build",
        "-p",
        "mil-firmware",
        "--target",
        "thumbv7em-none-eabihf",
        "--release",
        "--locked",
    ]);
    if qemu {
        cmd.args(["--features", "qemu"]);
    }
    let status = cmd.status().map_err(|e| format!("cannot run cargo: {e}"))?;
    if !status.success() {
        return Err(format!("firmware build failed ({status})"));
    }
    read_elf()
}

fn read_elf() -> Result<Vec<u8>, String> {
    let path = find_firmware_elf().ok_or(
        "firmware ELF not found under $CARGO_TARGET_DIR or <workspace>/target \
         (thumbv7em-none-eabihf/release/mil-firmware)",
    )?;
    std::fs::read(&path).map_err(|e| format!("{}: {e}", path.display()))
}

fn contains(haystack: &[u8], needle: &[u8]) -> bool {
    haystack.windows(needle.len()).any(|w| w == needle)
}

/// The issue's memory targets for the board image (bytes): 256 KiB flash, 64 KiB RAM.
const FLASH_TARGET: u64 = 256 * 1024;
const RAM_TARGET: u64 = 64 * 1024;
/// Initialised data of the board build (bytes): the RTT control block and a few atomics;
/// anything of kilobytes is a blank that is not all zero bits.
const DATA_LIMIT: u32 = 1024;

fn sizes(f: &Footprint) -> String {
    let sections: Vec<String> = f
        .sections
        .iter()
        .filter(|s| s.size > 0)
        .map(|s| format!("{} {}", s.name, s.size))
        .collect();
    format!(
        "flash {} B, static RAM {} B ({})",
        f.flash,
        f.static_ram,
        sections.join(", ")
    )
}

fn qemu_version() -> String {
    Command::new("qemu-system-arm")
        .arg("--version")
        .output()
        .ok()
        .and_then(|o| String::from_utf8(o.stdout).ok())
        .and_then(|s| s.lines().next().map(str::to_owned))
        .unwrap_or_else(|| "qemu-system-arm (version unknown)".into())
}

/// The `key=value` pairs of the firmware's figures line.
fn figures(report: &str) -> Result<HashMap<String, f64>, String> {
    let line = report
        .lines()
        .find_map(|l| l.strip_prefix(FIGURES))
        .ok_or_else(|| format!("no `{FIGURES}` line in the firmware's report:\n{report}"))?;
    Ok(line
        .split_whitespace()
        .filter_map(|kv| {
            let (k, v) = kv.split_once('=')?;
            Some((k.to_owned(), v.parse().ok()?))
        })
        .collect())
}

/// One XCP command on the link that must succeed; its positive response.
fn xcp(link: &mut SlcanTcp, cto: &[u8]) -> Result<Vec<u8>, String> {
    mil_can::XcpLink::new(link).ok(cto)
}

/// The DAQ list of the budget run: the demand, position, road and step count (four ODTs
/// after the timestamp's), sampled at every control step; returns the signals.
const DAQ_SIGNALS: [&str; 4] = ["demand", "position", "road", "steps"];

/// Connects over XCP with the QEMU build's public test secret, unlocks DAQ and starts one
/// list with [`DAQ_SIGNALS`] on the control-step event, with timestamps.
fn start_daq(link: &mut SlcanTcp) -> Result<(), String> {
    use mil_firmware::calibration::MEAS_ITEMS;
    let daq = 0x04; // the DAQ resource
    mil_can::XcpLink::new(link).connect_unlock(mil_xcp::mock::TEST_SECRET, daq)?;
    // The measurement block's address: from the ELF, as the A2L file gives it.
    let elf = find_firmware_elf().ok_or("the QEMU ELF vanished")?;
    let image = std::fs::read(&elf).map_err(|e| e.to_string())?;
    let layout = mil_a2l::layout(&image).map_err(|e| e.to_string())?;
    let odts = u8::try_from(DAQ_SIGNALS.len() + 1).map_err(|e| e.to_string())?;
    xcp(link, &[0xD6])?;
    xcp(link, &[0xD5, 0, 1, 0])?;
    xcp(link, &[0xD4, 0, 0, 0, odts])?;
    xcp(link, &[0xD3, 0, 0, 0, 0, 0])?;
    for (k, name) in DAQ_SIGNALS.iter().enumerate() {
        let odt = u8::try_from(k + 1).map_err(|e| e.to_string())?;
        xcp(link, &[0xD3, 0, 0, 0, odt, 1])?;
        let slot = MEAS_ITEMS
            .iter()
            .position(|m| m.name == *name)
            .ok_or_else(|| format!("no measurement {name}"))?;
        let a = mil_a2l::measurement_address(&layout, slot).to_le_bytes();
        xcp(link, &[0xE2, 0, 0, 0, odt, 0])?;
        xcp(link, &[0xE1, 0xFF, 4, 0, a[0], a[1], a[2], a[3]])?;
    }
    xcp(link, &[0xE0, 0x10, 0, 0, 0, 0, 1, 0])?;
    xcp(link, &[0xDE, 0x02, 0, 0])?;
    xcp(link, &[0xDD, 0x01])?;
    Ok(())
}

/// Runs the lockstep benchmark on the QEMU ELF at `elf` (with a DAQ list running when
/// `daq`); returns the firmware's report.
fn lockstep(
    elf: &Path,
    samples: usize,
    daq: bool,
    failures: &mut Vec<String>,
) -> Result<String, String> {
    let options = QemuOptions {
        icount_shift: Some(0),
        icount_sleep: false,
        ..QemuOptions::default()
    };
    let (qemu, link) = Qemu::spawn(elf, &options)
        .map_err(|e| format!("QEMU: {e} (install it: apt-get install -y qemu-system-arm)"))?;
    let mut board = RemoteBoard::new(link)?;
    let index = u16::try_from(SLOT_WATCHDOG).map_err(|e| e.to_string())?;
    let ack = board.command(CommandKind::SetParam, index, f32::from(WATCHDOG_OFF))?;
    if ack.result != 0 {
        return Err(format!(
            "the firmware refused to switch its watchdog off (code {}): not the QEMU build?",
            ack.result
        ));
    }
    if daq {
        start_daq(board.transport_mut())?;
        // The board sends the step's DAQ packets right after its demand; QEMU's USART costs
        // host time per byte, not virtual time, so a host that sends the next measurement at
        // once outruns the link (on the rig the bus paces it). Wait for them, as a bus would.
        board = board.with_followers(DAQ_SIGNALS.len() + 1);
    }
    let duration = samples as f64 / FS;
    let road = vec![band_limited_noise(0.5, 40.0, duration, FS, 0.5e-3, true, 1)];
    let instrumentation = Instrumentation {
        position_sensor: SensorSpec {
            noise_rms: 2e-6,
            ..SensorSpec::default()
        },
        ..Instrumentation::default()
    };
    let mut parts = vec![paper_tyre_part(1e-4).map_err(|e| e.to_string())?];
    let t0 = Instant::now();
    let (h, _) = run(
        &mut board,
        &mut parts,
        &instrumentation,
        FS,
        &road,
        &[f64::from(TYRE.static_load)],
        tyre_input,
        |_| {},
    )
    .map_err(|e| format!("lockstep run: {e}"))?;
    let wall = t0.elapsed().as_secs_f64();
    let mismatches = board.mismatches();
    let running = h
        .status
        .iter()
        .filter(|s| s.mode == Mode::Running && s.fault == 0)
        .count();
    println!(
        "run{}: {} lockstep samples of the tyre example over SLCAN in {wall:.1} s ({:.0} samples/s); \
         demand frames bit-identical to the host mirror's: {} of {}; Running without fault: {running}",
        if daq { " with DAQ" } else { "" },
        h.len(),
        h.len() as f64 / wall,
        board.samples().len() - mismatches,
        board.samples().len(),
    );
    if mismatches != 0 {
        failures.push(format!(
            "{mismatches} demand frames differ from the mirror's"
        ));
    }
    if running != h.len() || h.len() != samples {
        failures.push(format!(
            "{running} of {} samples Running without fault (expected {samples})",
            h.len()
        ));
    }
    let expected_packets = if daq {
        h.len() * (DAQ_SIGNALS.len() + 1)
    } else {
        0
    };
    if board.undecodable() != expected_packets as u64 {
        failures.push(format!(
            "{} DAQ packets or other frames received, expected {expected_packets}",
            board.undecodable()
        ));
    }
    if !board.stray_demands().is_empty() {
        failures.push(format!(
            "{} demand frames answered no measurement (watchdog ticks?)",
            board.stray_demands().len()
        ));
    }
    finish(qemu, board.into_transport())
}

/// A configuration of the board for its own budget run.
struct Configuration {
    name: &'static str,
    params: model_core::BoardParams,
    rate_hz: u16,
}

/// The configurations beside the default tyre ×1: the full car's tyres on four hubs and the
/// aero four-poster at 1 kHz (the rates their buses carry), and a two-channel substructure
/// with nonlinear elements (a bump stop and a cubic spring) at 2 kHz.
fn configurations() -> Vec<Configuration> {
    use model_core::board::ModelKind;
    use model_core::{AeroParams, Causality, ElementLaw, InterfaceParams, SubstructureElement};
    let base = mil_firmware::config::default_params();
    let limits = |min: f32, max: f32| model_core::DemandLimits {
        min,
        max,
        rate: 1.0e7,
    };
    let mut tyre4 = base;
    tyre4.channels = 4;
    let mut aero = base;
    aero.kind = ModelKind::Aero as u32;
    aero.channels = 2;
    aero.limits = [limits(-20_000.0, 20_000.0); 4];
    let rest = AeroParams::PAPER.forces(0.0, 0.0, AeroParams::PAPER.reference_speed);
    aero.safe_demand = [rest[0], rest[1], 0.0, 0.0];
    let mut sub = base;
    sub.kind = ModelKind::Substructure as u32;
    sub.channels = 2;
    sub.limits = [limits(-5000.0, 5000.0); 4];
    sub.safe_demand = [0.0; 4];
    let s = &mut sub.substructure;
    *s = model_core::SubstructureParams::zeroed(2, Causality::Impedance);
    for (j, (m, k)) in [(40.0, 4.0e4), (30.0, 3.0e4)].into_iter().enumerate() {
        s.mass[j][j] = m;
        s.ground_stiffness[j][j] = k;
        s.ground_damping[j][j] = 0.005 * k;
        s.interface[j] = InterfaceParams {
            dof: j as u32,
            stiffness: 1.0e4,
            damping: 50.0,
        };
    }
    s.element_count = 2;
    s.elements[0] = SubstructureElement {
        dof_coefficients: [-1.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        road_coefficients: [1.0, 0.0, 0.0, 0.0],
        law: ElementLaw {
            bump_gap: 1.0e-3,
            bump_stiffness: 1.0e5,
            ..ElementLaw::NONE
        },
    };
    s.elements[1] = SubstructureElement {
        dof_coefficients: [1.0, -1.0, 0.0, 0.0, 0.0, 0.0],
        road_coefficients: [0.0; 4],
        law: ElementLaw {
            cubic_stiffness: 1.0e8,
            ..ElementLaw::NONE
        },
    };
    vec![
        Configuration {
            name: "tyre x4 at 1 kHz (two buses)",
            params: tyre4,
            rate_hz: 1000,
        },
        Configuration {
            name: "aero x2 at 1 kHz",
            params: aero,
            rate_hz: 1000,
        },
        Configuration {
            name: "substructure x2 with a bump stop and a cubic spring at 2 kHz",
            params: sub,
            rate_hz: 2000,
        },
    ]
}

/// Runs configuration `c` in QEMU (configured over XCP, `CH` channels) for `samples`
/// samples of road, body motion, forces and speed; returns the firmware's figures.
fn configuration_run<const CH: usize>(
    elf: &Path,
    c: &Configuration,
    samples: usize,
    failures: &mut Vec<String>,
) -> Result<HashMap<String, f64>, String> {
    use mil_firmware::calibration::{page_values, reference_words, Settings, DEFAULT_SETTINGS};
    use mil_rig::harness::Board;
    let image = std::fs::read(elf).map_err(|e| e.to_string())?;
    let working = mil_a2l::symbols(&image)
        .map_err(|e| e.to_string())?
        .get(mil_a2l::WORKING_SYMBOL)
        .map(|(a, _)| *a as u32)
        .ok_or("no working page in the ELF")?;
    let options = QemuOptions {
        icount_shift: Some(0),
        icount_sleep: false,
        ..QemuOptions::default()
    };
    let (qemu, link) = Qemu::spawn(elf, &options).map_err(|e| format!("QEMU: {e}"))?;
    let mut board = RemoteBoard::new(link)?;
    let settings = Settings {
        sample_rate_hz: c.rate_hz,
        watchdog: WATCHDOG_OFF,
        ..DEFAULT_SETTINGS
    };
    let target = page_values(&c.params, &settings).map(f32::to_bits);
    let done = mil_can::configure(
        board.transport_mut(),
        working,
        mil_xcp::mock::TEST_SECRET,
        &reference_words(),
        &target,
    )
    .map_err(|e| format!("{}: {e}", c.name))?;
    board.replay(&reference_words(), &done.writes)?;
    Board::<CH>::start(&mut board)?;
    let dt = 1.0 / f32::from(c.rate_hz);
    for k in 0..samples {
        let t = k as f32 * dt;
        let wave = |f: f32, phase: f32| (2.0 * std::f32::consts::PI * f * t + phase).sin();
        let mut input = model_core::ModelInput::<CH>::default();
        for ch in 0..CH {
            let p = ch as f32;
            input.position[ch] = 2.0e-3 * wave(1.3 + p, p);
            input.road[ch] = 3.0e-3 * wave(2.1 + 0.5 * p, 2.0 * p);
            input.force[ch] = 300.0 * wave(3.1 + p, p);
        }
        input.speed = 50.0 + 10.0 * wave(0.2, 0.0);
        Board::<CH>::step(&mut board, &input)?;
    }
    if board.mismatches() != 0 {
        failures.push(format!(
            "{}: {} of {} demand frames differ from the mirror's",
            c.name,
            board.mismatches(),
            board.samples().len()
        ));
    }
    let report = finish(qemu, board.into_transport())?;
    let f = figures(&report)?;
    if f.get("steps").copied() != Some(samples as f64) {
        failures.push(format!(
            "{}: the firmware stepped {:?} times",
            c.name,
            f.get("steps")
        ));
    }
    Ok(f)
}

fn finish(qemu: Qemu, mut link: SlcanTcp) -> Result<String, String> {
    link.close()
        .map_err(|e| format!("closing the channel: {e}"))?;
    let out = qemu
        .finish(Duration::from_secs(30))
        .map_err(|e| format!("waiting for QEMU: {e}"))?;
    if !out.status.is_some_and(|s| s.success()) {
        return Err(format!(
            "QEMU did not exit 0 ({:?}): {}\n{}",
            out.status, out.stdout, out.stderr
        ));
    }
    Ok(out.stdout)
}

fn main() -> ExitCode {
    match budget() {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::FAILURE,
        Err(e) => {
            eprintln!("qemu_budget: {e}");
            ExitCode::FAILURE
        }
    }
}

/// Everything; `Ok(false)` when a check failed.
fn budget() -> Result<bool, String> {
    let o = options()?;
    let board_elf = if o.build { Some(build(false)?) } else { None };
    let qemu_elf = if o.build { build(true)? } else { read_elf()? };
    if !contains(&qemu_elf, FIGURES.as_bytes()) {
        return Err(format!(
            "the firmware ELF is not the QEMU build: build it with `{}`",
            mil_can::FIRMWARE_BUILD_COMMAND
        ));
    }
    let elf_path = find_firmware_elf().ok_or("the QEMU ELF vanished")?;
    let mut failures = Vec::new();
    let report = lockstep(&elf_path, o.samples, false, &mut failures)?;
    let daq_report = lockstep(&elf_path, o.samples, true, &mut failures)?;
    let mut per_configuration = Vec::new();
    for c in configurations() {
        let n = (o.samples / 4).max(100);
        let f = match c.params.channels {
            4 => configuration_run::<4>(&elf_path, &c, n, &mut failures)?,
            _ => configuration_run::<2>(&elf_path, &c, n, &mut failures)?,
        };
        per_configuration.push((c, f, n));
    }
    let f = figures(&report)?;
    let fd = figures(&daq_report)?;
    let get_daq = |k: &str| {
        fd.get(k)
            .copied()
            .ok_or_else(|| format!("`{k}` missing from the DAQ run's figures"))
    };
    let get = |k: &str| {
        f.get(k)
            .copied()
            .ok_or_else(|| format!("`{k}` missing from the firmware's figures"))
    };
    let (steps, min, mean, max, first) = (
        get("core_count")?,
        get("core_min")?,
        get("core_mean")?,
        get("core_max")?,
        get("core_first")?,
    );
    for k in ["missed", "late", "malformed", "comm_timeouts"] {
        if get(k)? != 0.0 {
            failures.push(format!("firmware counted {k} = {}", get(k)?));
        }
    }
    if get("measurements")? != o.samples as f64 || steps != o.samples as f64 {
        failures.push(format!(
            "firmware saw {} measurements, timed {steps} steps (sent {})",
            get("measurements")?,
            o.samples
        ));
    }
    if max > TARGET {
        failures.push(format!(
            "control step took up to {max:.0} instructions (target {TARGET:.0})"
        ));
    }
    let daq_max = get_daq("core_max")?;
    if daq_max > TARGET {
        failures.push(format!(
            "with DAQ running the control step took up to {daq_max:.0} instructions (target {TARGET:.0})"
        ));
    }
    if get_daq("daq_running")? != 1.0 || get_daq("daq_dropped")? != 0.0 {
        failures.push(format!(
            "DAQ run: daq_running = {}, daq_dropped = {}",
            get_daq("daq_running")?,
            get_daq("daq_dropped")?
        ));
    }

    println!();
    println!("mil-firmware budgets: tyre example (one hub channel, 2 kHz), QEMU netduinoplus2");
    println!("  {}, -icount shift=0,align=off,sleep=off", qemu_version());
    println!(
        "  QEMU counts instructions, not cycles: no pipeline, flash wait states or FPU latency."
    );
    println!(
        "  Timed with TIM5 = QEMU virtual nanoseconds = instructions at shift=0 (calibrated: {:.6} instructions per count; {:.0} of each window is the timer read itself, subtracted).",
        get("instructions_per_count")?,
        get("empty_window")?
    );
    println!();
    println!(
        "instructions per control step, CAN frame received -> demand frame encoded, ready to queue (decode, controller step, encode):"
    );
    println!(
        "  min {min:.0}, mean {mean:.1}, max {max:.0} over {steps:.0} steps (first step {first:.0}); target <= {TARGET:.0}: {}",
        if max <= TARGET {
            format!("met, max at {:.0} % of it", 100.0 * max / TARGET)
        } else {
            "NOT MET".to_string()
        }
    );
    println!(
        "  parts (mean): decode {:.1}, step (controller + counters) {:.1}, encode {:.1}",
        get("decode")?,
        get("step")?,
        get("encode")?
    );
    println!(
        "  with QEMU's SLCAN transport (last byte read -> demand line queued; SLCAN parse {:.1} and format {:.1} stand in for the bxCAN FIFO read and mailbox write): min {:.0}, mean {:.1}, max {:.0}",
        get("parse")?,
        get("format")?,
        get("path_min")?,
        get("path_mean")?,
        get("path_max")?
    );
    println!(
        "  after the demand is queued: measurement block stored: mean {:.1}, max {:.0}",
        get("post_mean")?,
        get("post_max")?
    );
    println!(
        "with a DAQ list running ({} on the control-step event, timestamps; {} ODTs sent per step):",
        DAQ_SIGNALS.join(", "),
        DAQ_SIGNALS.len() + 1
    );
    println!(
        "  control step: min {:.0}, mean {:.1}, max {daq_max:.0} (target <= {TARGET:.0}: {}); after the demand: measurement block stored + DAQ sample copied and queued: mean {:.1}, max {:.0} (the DAQ copy costs {:.1} mean); DAQ samples or packets dropped: {:.0}",
        get_daq("core_min")?,
        get_daq("core_mean")?,
        if daq_max <= TARGET { "met" } else { "NOT MET" },
        get_daq("post_mean")?,
        get_daq("post_max")?,
        get_daq("post_mean")? - get("post_mean")?,
        get_daq("daq_dropped")?
    );
    println!(
        "  for scale only: {max:.0} instructions at one cycle each would be {:.1} us at 168 MHz, {:.1} % of the 500 us sample (the board's cycles per instruction are above one: it logs SysTick core cycles over defmt)",
        max / 168.0,
        100.0 * max / 168.0 / 500.0
    );
    println!("every other configuration (configured over XCP, sinusoidal road, motion, forces and speed; demand frames compared with the host mirror):");
    for (c, f, n) in &per_configuration {
        let get = |k: &str| f.get(k).copied().unwrap_or(f64::NAN);
        let cycles = 168.0e6 / f64::from(c.rate_hz);
        println!(
            "  {}: control step min {:.0}, mean {:.1}, max {:.0} (first step {:.0}) over {n} steps (the frame that completes the sample -> every demand frame encoded); max = {:.1} % of the {:.0} cycles of a sample at 168 MHz if each instruction took one cycle (target 5 %); stack high-water {:.0} B (configured over XCP: the page prepared in place)",
            c.name,
            get("core_min"),
            get("core_mean"),
            get("core_max"),
            get("core_first"),
            100.0 * get("core_max") / cycles,
            cycles,
            get("stack_used")
        );
    }
    // The deepest stack of every run: the configuration runs prepare their set over XCP.
    let deepest_stack = per_configuration
        .iter()
        .filter_map(|(_, f, _)| f.get("stack_used").copied())
        .chain([get("stack_used")?, get_daq("stack_used")?])
        .fold(0.0f64, f64::max);
    println!();
    println!("memory (ELF section headers; flash: sections with contents, static RAM: sections in SRAM):");
    if let Some(b) = &board_elf {
        println!("  board build: {}", sizes(&footprint(b)?));
    }
    println!("  QEMU build:  {}", sizes(&footprint(&qemu_elf)?));
    println!(
        "  of 1 MiB flash and 128 KiB RAM (STM32F405RG); the stack takes the rest of RAM ({:.0} B)",
        get("stack_region")?
    );
    println!(
        "stack high-water mark (stack painting, this QEMU run, up to the report): {:.0} B of {:.0} B; deepest of every run above: {deepest_stack:.0} B",
        get("stack_used")?,
        get("stack_region")?
    );
    if let Some(b) = &board_elf {
        let fp = footprint(b)?;
        // Every kilobyte static (the candidate, the application) starts from a blank of zero
        // bits, i.e. `.bss`: a non-zero field in one moves its whole image into flash.
        let data = fp
            .sections
            .iter()
            .filter(|s| s.name == ".data")
            .map(|s| s.size)
            .sum::<u32>();
        if data > DATA_LIMIT {
            failures.push(format!(
                "board build: .data is {data} B (limit {DATA_LIMIT}): a static's initial value \
                 is not all zero bits, and its image costs flash"
            ));
        }
        let ram = fp.static_ram as f64 + deepest_stack;
        let verdict = |ok: bool| if ok { "met" } else { "NOT met" };
        println!(
            "targets, board image with every configuration linked: flash {} B of {FLASH_TARGET} ({}); RAM {ram:.0} B of {RAM_TARGET} ({}): static {} B + the deepest stack above (the QEMU build's; the board's control and configuration paths are the same code)",
            fp.flash,
            verdict(fp.flash <= FLASH_TARGET),
            verdict(ram <= RAM_TARGET as f64),
            fp.static_ram,
        );
    }
    println!();
    println!("the firmware's own report (semihosting):");
    for line in report.lines().filter(|l| l.starts_with("mil-firmware")) {
        println!("  {line}");
    }
    println!("the firmware's own report of the DAQ run:");
    for line in daq_report
        .lines()
        .filter(|l| l.starts_with("mil-firmware") && !l.contains("figures"))
    {
        println!("  {line}");
    }
    println!();
    if failures.is_empty() {
        println!("all checks passed");
        Ok(true)
    } else {
        for f in &failures {
            println!("FAILED: {f}");
        }
        Ok(false)
    }
}
