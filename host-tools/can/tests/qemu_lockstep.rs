//! The QEMU build of the firmware in lockstep with the simulated rig, over SLCAN on TCP.
//!
//! Needs the firmware ELF, built by
//! `cargo build -p mil-firmware --target thumbv7em-none-eabihf --release --features qemu`
//! (found under `$CARGO_TARGET_DIR` or `<workspace>/target`), and `qemu-system-arm`. Without
//! either the tests fail and say which command provides it.

use std::path::PathBuf;
use std::time::{Duration, Instant};

use mil_can::{
    find_firmware_elf, Qemu, QemuOptions, RemoteBoard, SlcanTcp, Transport, FIRMWARE_BUILD_COMMAND,
    LAYOUT,
};
use mil_firmware::application::fault::{COMM_TIMEOUT, FIRMWARE_STOPPED};
use mil_firmware::config::{SAFE_DEMAND_N, SAFE_RAMP_N_PER_S, TYRE};
use mil_frames::{encode_command, Command, CommandKind, Message};
use mil_identify::band_limited_noise;
use mil_rig::harness::{run, Board, Histories, Instrumentation};
use mil_rig::metrics::compare;
use mil_rig::rigs::{paper_tyre_part, tyre_input};
use model_core::{Mode, ModelInput};

const FS: f64 = 2000.0;

fn elf() -> PathBuf {
    find_firmware_elf().unwrap_or_else(|| {
        panic!(
            "firmware ELF not found under $CARGO_TARGET_DIR or <workspace>/target \
             (thumbv7em-none-eabihf/release/mil-firmware): build it with `{FIRMWARE_BUILD_COMMAND}`"
        )
    })
}

fn start_qemu() -> (Qemu, RemoteBoard<SlcanTcp>) {
    let elf = elf();
    let (qemu, link) = Qemu::spawn(&elf, &QemuOptions::default()).unwrap_or_else(|e| {
        panic!(
            "QEMU with {}: {e} (install QEMU: `apt-get install -y qemu-system-arm`)",
            elf.display()
        )
    });
    (qemu, RemoteBoard::new(link).unwrap())
}

/// Closes the channel: the firmware prints its report and exits 0.
fn finish(qemu: Qemu, board: RemoteBoard<SlcanTcp>) -> String {
    let mut link = board.into_transport();
    link.close().unwrap();
    let out = qemu.finish(Duration::from_secs(20)).unwrap();
    eprintln!("{}", out.stdout.trim());
    assert!(
        out.status.is_some_and(|s| s.success()),
        "QEMU did not exit 0: {:?}; stderr: {}",
        out.status,
        out.stderr
    );
    assert!(
        out.stdout.contains("mil-firmware report:"),
        "{}",
        out.stdout
    );
    out.stdout
}

/// 3 s of pink road noise (1 mm RMS, 0.5–50 Hz) at 2 kHz: the firmware in QEMU closes the
/// loop around the simulated tyre rig; every demand frame equals the host mirror's bit for
/// bit, the controller runs throughout, and the MiL force tracks the emulated force.
/// The paper's tyre rig (RK4 at 100 µs) driven by `board` over `road` (m) at [`FS`], from rest
/// at the static load.
fn run_tyre_rig<B: Board<1>>(board: &mut B, road: &[Vec<f64>]) -> Histories {
    let mut parts = vec![paper_tyre_part(1e-4).unwrap()];
    let (h, _) = run(
        board,
        &mut parts,
        &Instrumentation::default(),
        FS,
        road,
        &[f64::from(TYRE.static_load)],
        tyre_input,
        |_| {},
    )
    .unwrap();
    h
}

#[test]
fn lockstep_with_the_rig_is_bit_exact() {
    let (qemu, mut board) = start_qemu();
    let road = vec![band_limited_noise(0.5, 50.0, 3.0, FS, 1e-3, true, 7)];
    let t0 = Instant::now();
    let h = run_tyre_rig(&mut board, &road);
    let wall = t0.elapsed().as_secs_f64();
    let n = h.len();
    let mismatches = board.mismatches();
    let c = compare(&h.mil_force[0], &h.emulated_force[0], FS, 0.01);
    let nrms = c.nrms_error_pct.unwrap();
    eprintln!(
        "lockstep: {n} samples, {mismatches} mismatches, {wall:.2} s wall, {:.0} samples/s; \
         MiL vs emulated force: NRMS {nrms:.2} %, delay {:?} ms, peak error {:.1} N; \
         {} status frames, SLCAN lines {:?}",
        n as f64 / wall,
        c.delay_ms,
        c.peak_error,
        board.statuses().len(),
        board.transport_mut().line_counts()
    );
    assert_eq!(n, road[0].len());
    assert_eq!(board.samples().len(), n);
    assert_eq!(
        mismatches,
        0,
        "first mismatch: {:?}",
        board.samples().iter().find(|s| s.mismatch())
    );
    assert!(h
        .status
        .iter()
        .all(|s| s.mode == Mode::Running && s.fault == 0));
    assert!(
        board.stray_demands().is_empty(),
        "{:?}",
        board.stray_demands()
    );
    let last = board.statuses().last().copied().unwrap();
    assert_eq!(
        (
            last.mode,
            last.fault_causes,
            last.missed_samples,
            last.late_samples,
            last.malformed_frames
        ),
        (mil_frames::Mode::Running, 0, 0, 0, 0)
    );
    // The status of the last 200 steps follows the last demand: not read by `step`.
    assert!((n / 200 - 1..=n / 200).contains(&board.statuses().len()));
    // The same run with the host's own controller (the firmware's defaults): the forces
    // must agree with it (the demands are bit-exact, so the runs are identical).
    let mut host = mil_firmware::config::Controller::with_params(
        &mil_firmware::config::default_params(),
        mil_firmware::config::DT,
    )
    .unwrap();
    let reference = run_tyre_rig(&mut host, &road);
    let host_nrms = compare(
        &reference.mil_force[0],
        &reference.emulated_force[0],
        FS,
        0.01,
    )
    .nrms_error_pct
    .unwrap();
    let max_diff = h.mil_force[0]
        .iter()
        .zip(&reference.mil_force[0])
        .fold(0.0_f64, |m, (a, b)| m.max((a - b).abs()));
    eprintln!("host controller on the same run: NRMS {host_nrms:.2} %, largest MiL force difference {max_diff:.3e} N");
    // (The host controller sees the unquantised position and road, the board the frames'
    // 1 µm counts: a difference of a fraction of a newton.)
    assert!(max_diff < 1.0, "{max_diff}");
    assert!((nrms - host_nrms).abs() < 0.05, "{nrms} vs {host_nrms}");
    let report = finish(qemu, board);
    assert!(
        report.contains(&format!(
            "measurements {n} steps {n} missed 0 late 0 malformed 0"
        )),
        "{report}"
    );
}

/// Faults: malformed and foreign lines are counted and ignored; a NaN command value is
/// refused with the decoder's code; when measurements stop, demand frames keep coming on
/// the watchdog tick, the status reports COMM_TIMEOUT and the demand ramps to the safe value.
#[test]
fn faults_are_contained() {
    let (qemu, mut board) = start_qemu();
    board.start().unwrap();
    let input = |road: f32| ModelInput {
        road: [road],
        ..ModelInput::default()
    };
    for _ in 0..100 {
        board.step(&input(0.0)).unwrap();
    }
    // Malformed (wrong length, free ID in the range), foreign, and a line that is no SLCAN.
    let link = board.transport_mut();
    link.send_line(b"t1006000000000000\r").unwrap();
    link.send_line(b"t1182AAAA\r").unwrap();
    link.send_line(b"t0503010203\r").unwrap();
    link.send_line(b"hello\r").unwrap();
    for _ in 0..100 {
        board.step(&input(0.0)).unwrap();
    }
    assert_eq!(board.mismatches(), 0);
    assert!(
        board.transport_mut().line_counts().error >= 1,
        "{:?}",
        board.transport_mut().line_counts()
    );
    // A NaN parameter value: refused by the decoder (code 11), nothing changed.
    let mut nan = encode_command(
        &LAYOUT,
        &Command {
            command: CommandKind::SetParam,
            index: 1,
            value: 600.0,
        },
    )
    .unwrap();
    nan.data[4..8].copy_from_slice(&f32::NAN.to_bits().to_le_bytes());
    let ack = board.command_frame(&nan).unwrap();
    assert_eq!(
        (ack.command, ack.index, ack.result),
        (4, 1, mil_frames::DecodeError::NotFinite.code())
    );
    // Status every 5 steps (parameter 0, the status period), to see COMM_TIMEOUT soon.
    assert_eq!(
        board
            .command(
                CommandKind::SetParam,
                mil_firmware::calibration::SLOT_STATUS_PERIOD as u16,
                5.0,
            )
            .unwrap()
            .result,
        0
    );
    // Road +20 mm: the demand climbs to about 6.7 kN.
    for _ in 0..40 {
        board.step(&input(0.02)).unwrap();
    }
    assert_eq!(board.mismatches(), 0, "{} samples", board.samples().len());
    let status = *board.statuses().last().unwrap();
    assert_eq!(
        status.malformed_frames, 3,
        "wrong length, free ID, NaN command: {status:?}"
    );
    let before = board.samples().last().map(|s| s.firmware).unwrap();
    let Ok(Message::Demand(before)) = mil_frames::decode(&LAYOUT, &before) else {
        panic!()
    };
    assert!(before.demand_n > 6000.0, "{before:?}");
    // Silence.
    let quiet = Instant::now();
    let mut ramp = Vec::new();
    let mut comm_timeout_at = None;
    while ramp.len() < 40 {
        match board.recv_message(Duration::from_secs(10)).unwrap() {
            Some(Message::Demand(d)) => ramp.push(d),
            Some(Message::Status(s)) if s.fault_causes & COMM_TIMEOUT != 0 => {
                comm_timeout_at.get_or_insert(ramp.len());
            }
            Some(_) => {}
            None => panic!("no demand on the watchdog tick after {} ticks", ramp.len()),
        }
    }
    let seconds = quiet.elapsed().as_secs_f64();
    let first = ramp[0];
    assert_eq!(
        first.counter,
        before.counter.wrapping_add(1),
        "tick demands count on"
    );
    assert!(ramp
        .iter()
        .all(|d| d.flags.mode == mil_frames::Mode::Fault && d.flags.fault_latched));
    let per_tick = SAFE_RAMP_N_PER_S * mil_firmware::config::DT;
    for pair in ramp.windows(2) {
        let step = pair[0].demand_n - pair[1].demand_n;
        assert!(
            (step - per_tick).abs() < 0.2,
            "ramp step {step} N, expected {per_tick}"
        );
    }
    assert!(
        ramp.last().unwrap().demand_n > SAFE_DEMAND_N,
        "still ramping after 40 ticks"
    );
    let at = comm_timeout_at.expect("no status with COMM_TIMEOUT");
    assert!(
        at <= 5,
        "COMM_TIMEOUT reported after {at} ticks (status every 5)"
    );
    eprintln!(
        "faults: NaN refused with code {}; malformed counted {}; first tick demand {:.1} N after \
         {:.2} s of silence, 40 ticks in {seconds:.2} s, {per_tick} N per tick down to {:.1} N; \
         COMM_TIMEOUT in the status after {at} ticks; SLCAN lines {:?}",
        ack.result,
        status.malformed_frames,
        first.demand_n,
        seconds,
        ramp.last().unwrap().demand_n,
        board.transport_mut().line_counts()
    );
    let ack = board.command(CommandKind::ClearFault, 0, 0.0).unwrap();
    assert_eq!((ack.result, ack.mode), (0, mil_frames::Mode::Idle));
    let report = finish(qemu, board);
    assert!(report.contains("comm_timeouts 1"), "{report}");
}

/// The transport on its own: sending a frame the board ignores gets no reply.
#[test]
fn foreign_frame_gets_no_reply() {
    let (qemu, mut board) = start_qemu();
    let link = board.transport_mut();
    link.send(&mil_frames::RawFrame::from_parts(0x050, &[1, 2, 3]).unwrap())
        .unwrap();
    assert_eq!(link.recv(Duration::from_millis(300)).unwrap(), None);
    finish(qemu, board);
}

/// Issue 19: a forced HardFault in the QEMU build (the test build's `!HARDFAULT` line, an
/// undefined instruction) while Running with the demand well above the safe value: the
/// fatal path sends the safe Demand frame (mode Fault, fault flag) and then a Status frame
/// that says why (fault bit 5, FIRMWARE_STOPPED), and QEMU exits with status 1 naming the
/// HardFault.
#[test]
fn a_hardfault_leaves_the_safe_demand_and_says_why() {
    let (qemu, mut board) = start_qemu();
    board.start().unwrap();
    let input = |road: f32| ModelInput {
        road: [road],
        ..ModelInput::default()
    };
    for _ in 0..60 {
        board.step(&input(0.02)).unwrap();
    }
    assert_eq!(board.mismatches(), 0);
    let link = board.transport_mut();
    link.send_line(b"!HARDFAULT\r").unwrap();
    let mut demand = None;
    let mut status = None;
    while status.is_none() {
        match board.recv_message(Duration::from_secs(10)).unwrap() {
            Some(Message::Demand(d)) => demand = Some(d),
            Some(Message::Status(s)) if s.fault_causes & FIRMWARE_STOPPED != 0 => status = Some(s),
            Some(_) => {}
            None => panic!("no fatal frames within 10 s (demand {demand:?})"),
        }
    }
    let (d, s) = (demand.expect("safe demand first"), status.unwrap());
    assert!((d.demand_n - SAFE_DEMAND_N).abs() < 0.1, "{d:?}");
    assert!(d.flags.mode == mil_frames::Mode::Fault && d.flags.fault_latched);
    assert_eq!(s.mode, mil_frames::Mode::Fault);
    let mut link = board.into_transport();
    let _ = link.close();
    let out = qemu.finish(Duration::from_secs(20)).unwrap();
    assert_eq!(out.status.and_then(|s| s.code()), Some(1), "{}", out.stderr);
    assert!(out.stderr.contains("HardFault at pc"), "{}", out.stderr);
    eprintln!(
        "forced HardFault: safe demand {:.1} N (mode {:?}), status fault bits {:#04x}; {}",
        d.demand_n,
        d.flags.mode,
        s.fault_causes,
        out.stderr
            .lines()
            .find(|l| l.contains("HardFault"))
            .unwrap_or("")
    );
}

/// The bit-for-bit comparison can fail: a mirror given a tyre 4 % stiffer than the
/// firmware's (the firmware keeps its defaults) differs from the firmware's demand frames
/// as soon as the road moves the tyre, and the differing frames are counted (what makes
/// `mil sim --board qemu` fail), while the frames at rest still agree.
#[test]
fn a_mirror_that_differs_is_caught() {
    let (qemu, mut board) = start_qemu();
    let mut other = mil_firmware::config::default_params();
    other.tyre.tyre[0].stiffness *= 1.04;
    board.set_mirror(&other, (1.0 / FS) as f32).unwrap();
    board.start().unwrap();
    let at = |road: f32| ModelInput {
        road: [road],
        ..ModelInput::default()
    };
    for _ in 0..20 {
        board.step(&at(0.0)).unwrap();
    }
    assert_eq!(board.mismatches(), 0, "at rest the stiffness plays no part");
    for _ in 0..20 {
        board.step(&at(0.005)).unwrap();
    }
    assert!(
        board.mismatches() > 0,
        "a 4 % stiffer mirror went unnoticed"
    );
    let first = board.samples().iter().position(|s| s.mismatch()).unwrap();
    assert!(
        first >= 20,
        "the first differing frame is at sample {first}"
    );
    finish(qemu, board);
}
