//! `mil param` and `mil daq record` against the firmware itself, in QEMU: the tool talks
//! XCP on the firmware's XCP port (USART2, SLCAN over TCP) with the A2L generated from the
//! very ELF that runs, while a lockstep on USART1 plays the servo controller (road 0, hub
//! 1 mm down), so a written tyre stiffness shows in the demand frames.
//!
//! Needs the QEMU build (`cargo build -p mil-firmware --target thumbv7em-none-eabihf
//! --release --features qemu`, whose XCP secret is `mil-xcp`'s public test secret) and QEMU.

use std::path::Path;
use std::process::Output;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use mil_can::{find_firmware_elf, Qemu, QemuOptions, SlcanTcp, Transport, FIRMWARE_BUILD_COMMAND};
use mil_firmware::link::LAYOUT;
use mil_frames::{
    decode, encode_command, encode_measurement, Command as Cmd, CommandKind, Message,
};
use mil_xcp::mock::TEST_SECRET;

mod common;
use common::text;

fn mil(args: &[&str], secret: &[u8]) -> Output {
    common::mil_with_secret(Path::new("."), args, secret)
}

/// The demands of the lockstep, with the time each arrived.
type Demands = Arc<Mutex<Vec<(Instant, f32)>>>;

/// Lockstep on USART1 until `stop`: one measurement, wait for its demand.
fn lockstep(mut link: SlcanTcp, demands: Demands, stop: Arc<AtomicBool>) -> SlcanTcp {
    let start = Cmd {
        command: CommandKind::Start,
        index: 0,
        value: 0.0,
    };
    link.send(&encode_command(&LAYOUT, &start).unwrap())
        .unwrap();
    let mut counter = 0u8;
    while !stop.load(Ordering::Relaxed) {
        let m = mil_frames::Measurement {
            channel: 0,
            position_m: -1.0e-3,
            road_m: 0.0,
            counter,
        };
        link.send(&encode_measurement(&LAYOUT, &m).unwrap())
            .unwrap();
        loop {
            let f = link
                .recv(Duration::from_secs(5))
                .unwrap()
                .expect("demand within 5 s");
            if let Ok(Message::Demand(d)) = decode(&LAYOUT, &f) {
                if d.counter == counter {
                    demands.lock().unwrap().push((Instant::now(), d.demand_n));
                    break;
                }
            }
        }
        counter = counter.wrapping_add(1);
    }
    link
}

/// The demand once `n` more demands have arrived after now (a change fades in over
/// model-core's `BUMPLESS_FADE_S`, 200 steps at 2 kHz).
fn demand_after(demands: &Demands, n: usize) -> f32 {
    let start = demands.lock().unwrap().len();
    loop {
        {
            let d = demands.lock().unwrap();
            if d.len() >= start + n {
                return d[d.len() - 1].1;
            }
        }
        std::thread::sleep(Duration::from_millis(5));
    }
}

fn last_demand(demands: &Demands) -> f32 {
    let t = Instant::now();
    // A demand that arrived after now.
    loop {
        if let Some(&(at, d)) = demands.lock().unwrap().last() {
            if at > t {
                return d;
            }
        }
        std::thread::sleep(Duration::from_millis(5));
    }
}

#[test]
fn mil_param_and_daq_record_against_the_firmware() {
    let elf = find_firmware_elf().unwrap_or_else(|| {
        panic!("firmware ELF not found: build it with `{FIRMWARE_BUILD_COMMAND}`")
    });
    let dir = tempfile::tempdir().unwrap();
    let image = std::fs::read(&elf).unwrap();
    let layout = mil_a2l::layout(&image).unwrap();
    let a2l = dir.path().join("mil.a2l");
    std::fs::write(&a2l, mil_a2l::generate(&layout, "qemu")).unwrap();
    let a2l = a2l.to_str().unwrap().to_string();

    let options = QemuOptions {
        xcp_port: true,
        ..QemuOptions::default()
    };
    let (qemu, link) = Qemu::spawn(&elf, &options)
        .unwrap_or_else(|e| panic!("QEMU: {e} (apt-get install -y qemu-system-arm)"));
    let port = format!("tcp:127.0.0.1:{}", qemu.xcp_port().unwrap());
    let demands: Demands = Arc::default();
    let stop = Arc::new(AtomicBool::new(false));
    let runner = {
        let (d, s) = (demands.clone(), stop.clone());
        std::thread::spawn(move || lockstep(link, d, s))
    };
    let with = |args: &[&str]| -> Vec<String> {
        let mut v: Vec<String> = args.iter().map(|s| s.to_string()).collect();
        v.extend(["--a2l".into(), a2l.clone(), "--port".into(), port.clone()]);
        v
    };
    let run = |args: &[&str], secret: &[u8]| {
        let v = with(args);
        let refs: Vec<&str> = v.iter().map(String::as_str).collect();
        mil(&refs, secret)
    };

    // Read: the running default.
    let o = run(
        &["param", "get", "tyre_stiffness_0", "tyre_damping_0"],
        TEST_SECRET,
    );
    assert!(o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("250000"), "{}", text(&o));

    // A wrong secret: one clear line, nothing changes.
    let o = run(
        &["param", "set", "tyre_stiffness_0=300000"],
        b"not-the-secret-of-this-build",
    );
    assert!(!o.status.success());
    let e = String::from_utf8_lossy(&o.stderr).to_string();
    assert_eq!(e.lines().count(), 1, "{e}");
    assert!(e.contains("refused the key"), "{e}");

    // A write reaches the running model: +50 N at 1 mm for 2.5e5 → 3.0e5 N/m.
    let before = last_demand(&demands);
    let o = run(&["param", "set", "tyre_stiffness_0=300000"], TEST_SECRET);
    assert!(o.status.success(), "{}", text(&o));
    let after = demand_after(&demands, 300);
    assert!(
        (after - before - 50.0).abs() < 0.2,
        "demand {before} → {after} N: {}",
        text(&o)
    );

    // Refusals: by the tool (outside the A2L limits, before sending) and by the board
    // (inconsistent set); the model is unchanged.
    let o = run(&["param", "set", "tyre_stiffness_0=1e12"], TEST_SECRET);
    assert!(!o.status.success(), "{}", text(&o));
    let o = run(&["param", "set", "limits_demand_min_0=20000"], TEST_SECRET);
    assert!(!o.status.success());
    assert!(text(&o).contains("ERR_GENERIC"), "{}", text(&o));
    assert_eq!(last_demand(&demands), after);

    // DAQ while the lockstep runs: 100 consecutive steps, the demand of the new stiffness.
    let csv = dir.path().join("daq.csv");
    let o = run(
        &[
            "daq",
            "record",
            "--signals",
            "demand,steps",
            "--samples",
            "100",
            "--out",
            csv.to_str().unwrap(),
        ],
        TEST_SECRET,
    );
    assert!(o.status.success(), "{}", text(&o));
    let rows = read_csv(&csv);
    assert!(rows.len() >= 100, "{} rows", rows.len());
    for w in rows.windows(2) {
        assert!((w[1][0] - w[0][0] - 5.0e-4 * (w[1][2] - w[0][2])).abs() < 1e-9);
        assert!(w[1][2] > w[0][2], "steps not increasing");
    }
    let lost: f64 = rows.windows(2).map(|w| w[1][2] - w[0][2] - 1.0).sum();
    assert!(lost <= 2.0, "{lost} samples lost");
    assert!(rows.iter().all(|r| (r[1] as f32 - after).abs() < 0.05));

    // Issue 19, point 1: the tyre example's least-squares filter uploaded while Running
    // (before: the demand moved by up to 6 kN, 1000 N a step). At this constant input the
    // filter (DC gain 1) asks for no change: every step between two demand frames stays
    // within the frame's 0.1 N resolution plus the fade of what the filter's gain changes.
    let mark = demands.lock().unwrap().len();
    let filter = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/tyre-filter.json");
    let o = run(&["filter", "upload", filter.to_str().unwrap()], TEST_SECRET);
    assert!(o.status.success(), "{}", text(&o));
    let settled = demand_after(&demands, 400);
    let seen: Vec<f32> = demands.lock().unwrap()[mark..]
        .iter()
        .map(|d| d.1)
        .collect();
    let worst = seen
        .windows(2)
        .map(|w| (w[1] - w[0]).abs())
        .fold(0.0f32, f32::max);
    println!(
        "filter upload while running (QEMU): worst demand step {worst:.2} N over {} steps, {:.1} → {settled:.1} N",
        seen.len(),
        seen[0]
    );
    assert!(worst <= 0.25, "demand step {worst} N");
    assert!((settled - after).abs() < 1.0, "{after} → {settled} N");

    // Issue 19, point 7: `mil param store` is refused while the controller runs, with the
    // reason; after a Stop it stores the working page (the QEMU build keeps it in RAM: QEMU
    // emulates no flash controller) and the board counts it.
    let o = run(&["param", "store"], TEST_SECRET);
    assert!(!o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("stop it first"), "{}", text(&o));

    stop.store(true, Ordering::Relaxed);
    let mut link = runner.join().unwrap();
    let stop_cmd = Cmd {
        command: CommandKind::Stop,
        index: 0,
        value: 0.0,
    };
    link.send(&encode_command(&LAYOUT, &stop_cmd).unwrap())
        .unwrap();
    let o = run(&["param", "store"], TEST_SECRET);
    assert!(o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("stored the working page"), "{}", text(&o));
    let o = run(
        &[
            "param",
            "get",
            "calibration_stores",
            "calibration_store_error",
            "tyre_stiffness_0",
        ],
        TEST_SECRET,
    );
    assert!(o.status.success(), "{}", text(&o));
    let t = text(&o);
    assert!(t.contains("calibration_stores      = 1"), "{t}");
    assert!(t.contains("calibration_store_error = 0"), "{t}");
    println!("mil param store (QEMU): {t}");
    link.close().unwrap();
    let out = qemu.finish(Duration::from_secs(20)).unwrap();
    assert!(out.status.is_some_and(|s| s.success()), "{}", out.stderr);
}

/// The CSV's rows as numbers (header skipped).
fn read_csv(path: &Path) -> Vec<Vec<f64>> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|x| x.trim().parse().unwrap()).collect())
        .collect()
}
