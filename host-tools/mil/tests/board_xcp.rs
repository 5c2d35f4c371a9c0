//! The engineer's board path on the firmware in QEMU, with the tools a rig engineer uses on a
//! real board: `mil sim --board qemu --xcp ADDRESS` serves the board's XCP port and holds the
//! rig still; `mil param set --setup` configures the board for the set-up over XCP, `mil daq
//! record` records the board's own signals and starts the rig's road with it; `mil compare`
//! compares the recording with the rig's record. And what goes wrong: a board configured
//! otherwise than the set-up (the run fails, naming it), no recording ever started (the rig
//! gives up after --wait, naming the command that starts it).
//!
//! Needs the QEMU build (`cargo build -p mil-firmware --target thumbv7em-none-eabihf
//! --release --features qemu`, whose XCP secret is `mil-xcp`'s public test secret) and QEMU.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};

use mil_xcp::mock::TEST_SECRET;

mod common;
use common::text;

fn setup() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/tyre-board.toml")
}

fn mil(dir: &Path, args: &[&str]) -> Output {
    common::mil_with_secret(dir, args, TEST_SECRET)
}

/// A local port free at the time of asking.
fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// `mil sim tyre-board.toml --filter none --board qemu --xcp 127.0.0.1:PORT` in the
/// background, with `extra` arguments.
fn serve(dir: &Path, port: u16, extra: &[&str]) -> Child {
    Command::new(env!("CARGO_BIN_EXE_mil"))
        .args(["sim", setup().to_str().unwrap(), "--filter", "none"])
        .args(["--board", "qemu", "--xcp", &format!("127.0.0.1:{port}")])
        .args(["--out", "out/board"])
        .args(extra)
        .current_dir(dir)
        .env_remove("MIL_XCP_SECRET")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run mil sim")
}

/// The board's A2L file in `dir`.
fn a2l(dir: &Path) -> String {
    let o = mil(dir, &["a2l", "--out", "mil.a2l"]);
    assert!(o.status.success(), "{}", text(&o));
    "mil.a2l".to_string()
}

fn board_args(port: u16) -> Vec<String> {
    vec![
        "--a2l".into(),
        "mil.a2l".into(),
        "--port".into(),
        format!("tcp:127.0.0.1:{port}"),
    ]
}

fn run_with(dir: &Path, args: &[&str], port: u16) -> Output {
    let mut v: Vec<String> = args.iter().map(|s| s.to_string()).collect();
    v.extend(board_args(port));
    let refs: Vec<&str> = v.iter().map(String::as_str).collect();
    mil(dir, &refs)
}

/// The board served for `duration` s in `dir` (its A2L written there), configured for the
/// set-up with `mil param set --setup`: its port, the serving `mil sim` and param set's
/// output.
fn configured(dir: &Path, duration: &str) -> (u16, Child, Output) {
    a2l(dir);
    let port = free_port();
    let rig = serve(dir, port, &["--duration", duration]);
    let o = run_with(
        dir,
        &["param", "set", "--setup", setup().to_str().unwrap()],
        port,
    );
    assert!(o.status.success(), "{}", text(&o));
    (port, rig, o)
}

fn read_csv(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let names = lines
        .next()
        .unwrap()
        .split(',')
        .map(|s| s.split(' ').next().unwrap().to_string())
        .collect();
    let rows = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    (names, rows)
}

#[test]
fn configured_over_xcp_recorded_by_daq_and_compared() {
    let dir = tempfile::tempdir().unwrap();
    let dir = dir.path();
    let (port, rig, o) = configured(dir, "1");
    // The set-up runs four wheels at 1 kHz; the board boots with one at 2 kHz.
    assert!(text(&o).contains("sample_rate"), "{}", text(&o));
    assert!(
        text(&o).contains("the board is configured for"),
        "{}",
        text(&o)
    );
    // Written again, nothing differs.
    let o = run_with(
        dir,
        &["param", "set", "--setup", setup().to_str().unwrap()],
        port,
    );
    assert!(o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("(0 of "), "{}", text(&o));

    let o = run_with(
        dir,
        &[
            "daq",
            "record",
            "--signals",
            "position,road,demand",
            "--samples",
            "500",
            "--out",
            "daq.csv",
        ],
        port,
    );
    assert!(o.status.success(), "{}", text(&o));
    let rig = rig.wait_with_output().unwrap();
    assert!(rig.status.success(), "{}", text(&rig));
    let report = text(&rig);
    assert!(
        report.contains("4000 compared with the host mirror of the set-up, 0 mismatches"),
        "{report}"
    );
    assert!(report.contains("configured by 3 XCP client(s)"), "{report}");

    // The recording starts with the run: its road is the rig's, sample for sample, to the
    // frame's 1 µm.
    let (names, daq) = read_csv(&dir.join("daq.csv"));
    assert_eq!(names, ["time", "position", "road", "demand"]);
    assert_eq!(daq.len(), 500);
    let (sim_names, sim) = read_csv(&dir.join("out/board/sim.csv"));
    let road = sim_names.iter().position(|n| n == "road_0").unwrap();
    let demand = sim_names.iter().position(|n| n == "demand_0").unwrap();
    let peak = daq.iter().map(|r| r[2].abs()).fold(0.0, f64::max);
    assert!(peak > 1e-4, "the road did not move: {peak}");
    for (k, (d, s)) in daq.iter().zip(&sim).enumerate() {
        assert!(
            (d[0] - k as f64 * 1e-3).abs() < 1e-9,
            "time at {k}: {}",
            d[0]
        );
        assert!(
            (d[2] - s[road]).abs() <= 0.51e-6,
            "road at {k}: {} vs {}",
            d[2],
            s[road]
        );
        // The board's demand, and the same demand as its frame carried it (0.1 N).
        assert!(
            (d[3] - s[demand]).abs() <= 0.051,
            "demand at {k}: {} vs {}",
            d[3],
            s[demand]
        );
    }

    // mil compare pairs the board's signals with the run's columns.
    let o = mil(
        dir,
        &[
            "compare",
            "daq.csv",
            "--against",
            "out/board/sim.csv",
            "--skip",
            "0",
            "--json",
            "--out",
            "cmp",
        ],
    );
    assert!(o.status.success(), "{}", text(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let pairs: Vec<(String, String)> = v["pairs"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| {
            (
                p["column"].as_str().unwrap().into(),
                p["reference"].as_str().unwrap().into(),
            )
        })
        .collect();
    assert_eq!(
        pairs,
        [
            ("position", "mil_position_0"),
            ("road", "road_0"),
            ("demand", "demand_0")
        ]
        .map(|(a, b)| (a.to_string(), b.to_string()))
    );
    let j2 = |k: usize| v["pairs"][k]["figures"]["nrms_error_pct"].as_f64().unwrap();
    assert!(j2(2) < 0.1, "demand J2 {} %", j2(2));
}

#[test]
fn a_board_configured_otherwise_fails_the_run_and_no_recording_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let dir = dir.path();
    a2l(dir);
    let port = free_port();
    let rig = serve(dir, port, &["--duration", "0.3"]);
    // The set-up, but a stiffer tyre on wheel 0.
    let o = run_with(
        dir,
        &[
            "param",
            "set",
            "--setup",
            setup().to_str().unwrap(),
            "tyre_stiffness_0=300000",
        ],
        port,
    );
    assert!(o.status.success(), "{}", text(&o));
    let o = run_with(
        dir,
        &[
            "daq",
            "record",
            "--signals",
            "demand",
            "--samples",
            "100",
            "--out",
            "daq.csv",
        ],
        port,
    );
    assert!(o.status.success(), "{}", text(&o));
    let rig = rig.wait_with_output().unwrap();
    assert!(!rig.status.success(), "{}", text(&rig));
    let e = String::from_utf8_lossy(&rig.stderr);
    assert!(
        e.contains("the board was not configured as the set-up says"),
        "{e}"
    );

    // Nobody records: the rig gives up, naming the command that starts it.
    let port = free_port();
    let rig = serve(dir, port, &["--duration", "0.3", "--wait", "2"]);
    let rig = rig.wait_with_output().unwrap();
    assert!(!rig.status.success());
    let e = String::from_utf8_lossy(&rig.stderr);
    assert!(
        e.contains("no DAQ measurement started on the board within 2 s"),
        "{e}"
    );
    assert!(
        e.contains(&format!("mil daq record --port tcp:127.0.0.1:{port}")),
        "{e}"
    );
}

/// A recording asked for longer than the served run: the board's samples stop when the run
/// ends; `mil daq record` keeps what came (the whole run, complete), says why it is short
/// and how, and fails; the run itself succeeds.
#[test]
fn a_recording_longer_than_the_run_keeps_the_run_and_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let dir = dir.path();
    let (port, rig, _) = configured(dir, "0.4");
    let o = run_with(
        dir,
        &[
            "daq",
            "record",
            "--signals",
            "road,demand",
            "--duration",
            "5",
            "--out",
            "daq.csv",
        ],
        port,
    );
    assert!(!o.status.success(), "{}", text(&o));
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        e.contains("the board's samples stopped after") && e.contains("5 s asked for"),
        "{e}"
    );
    assert!(e.contains("daq.csv holds the"), "{e}");
    // One line: no panic, no warning about the link the board's side closed.
    assert_eq!(e.trim_end().lines().count(), 1, "{e}");
    let rig = rig.wait_with_output().unwrap();
    assert!(rig.status.success(), "{}", text(&rig));
    // The run's 400 steps at 1 kHz, each line whole.
    let (names, rows) = read_csv(&dir.join("daq.csv"));
    assert_eq!(names, ["time", "road", "demand"]);
    assert!((350..=400).contains(&rows.len()), "{} samples", rows.len());
    assert!(rows.iter().all(|r| r.len() == 3));
}

#[test]
fn xcp_needs_the_board_in_qemu() {
    let dir = tempfile::tempdir().unwrap();
    let o = mil(
        dir.path(),
        &["sim", setup().to_str().unwrap(), "--xcp", "127.0.0.1:5555"],
    );
    assert!(!o.status.success());
    assert!(text(&o).contains("add --board qemu"), "{}", text(&o));
}
