//! `mil sim SETUP --board qemu`: the firmware image in QEMU instead of the host controller,
//! configured over XCP for the set-up, driven sample for sample by the same simulated rig,
//! every demand frame compared with the host mirror of the firmware's controller. One run
//! per configuration the board serves: the aero four-poster (two channels, speed and ride
//! heights), the tyre on four hubs at 1 kHz (two buses) and a substructure with nonlinear
//! elements (stops, cubic spring, asymmetric damping, friction); and a rate beyond the bus
//! budget refused with its figure; each run's record equals the host's run of the same
//! set-up, sample for sample. Short runs (QEMU steps a few hundred samples a second).
//!
//! Needs the QEMU build (`cargo build -p mil-firmware --target thumbv7em-none-eabihf
//! --release --features qemu`) and QEMU.

use std::path::{Path, PathBuf};
use std::process::Command;

fn examples() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("examples")
}

/// Runs `mil sim SETUP --board qemu --duration S --json`; the summary, or the error text.
fn sim_qemu(setup: &Path, seconds: f64, out: &Path) -> Result<serde_json::Value, String> {
    let o = Command::new(env!("CARGO_BIN_EXE_mil"))
        .args(["sim", setup.to_str().unwrap(), "--board", "qemu", "--json"])
        .args(["--duration", &seconds.to_string()])
        .args(["--out", out.to_str().unwrap()])
        .env_remove("MIL_XCP_SECRET")
        .output()
        .expect("run mil");
    let text = String::from_utf8_lossy(&o.stdout).to_string();
    if !o.status.success() {
        return Err(format!("{text}{}", String::from_utf8_lossy(&o.stderr)));
    }
    serde_json::from_str(text.trim()).map_err(|e| format!("{e}: {text}"))
}

/// `mil sim SETUP --duration S` on the host: its sim.csv equals the board's `board_csv`
/// sample for sample, every column (the host's run sees the inputs and sends the demand as
/// the board's frames carry them, and runs what the firmware runs).
fn host_run_equals(setup: &Path, seconds: f64, out: &Path, board_csv: &Path, what: &str) {
    let o = Command::new(env!("CARGO_BIN_EXE_mil"))
        .args(["sim", setup.to_str().unwrap(), "--json"])
        .args(["--duration", &seconds.to_string()])
        .args(["--out", out.to_str().unwrap()])
        .output()
        .expect("run mil");
    assert!(
        o.status.success(),
        "{what}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    let host = std::fs::read_to_string(out.join("sim.csv")).unwrap();
    let board = std::fs::read_to_string(board_csv).unwrap();
    assert_eq!(host.lines().count(), board.lines().count(), "{what}");
    if let Some((k, (h, b))) = host
        .lines()
        .zip(board.lines())
        .enumerate()
        .find(|(_, (h, b))| h != b)
    {
        panic!("{what}: the host's run differs from the board's at line {k}:\n{h}\n{b}");
    }
}

/// The run compared every demand frame of every channel with the mirror: none differs, the
/// controller never faulted, and the MiL forces moved.
fn check(summary: &serde_json::Value, channels: u64, samples: u64, what: &str) {
    let q = &summary["qemu"];
    assert_eq!(summary["channels"], channels, "{what}: {summary}");
    assert_eq!(summary["samples"], samples, "{what}: {summary}");
    assert_eq!(q["demand_frames"], channels * samples, "{what}: {summary}");
    assert_eq!(q["mismatches"], 0, "{what}: {summary}");
    assert!(summary["fault_at_s"].is_null(), "{what}: {summary}");
    for c in summary["channel"].as_array().unwrap() {
        let [lo, hi] = [&c["demand_range"][0], &c["demand_range"][1]].map(|v| v.as_f64().unwrap());
        assert!(
            hi - lo > 1.0,
            "{what}: channel {} demand stood still: {c}",
            c["channel"]
        );
    }
    eprintln!(
        "{what}: {} demand frames, {} mismatches, {} slots written",
        q["demand_frames"], q["mismatches"], q["slots_written"]
    );
}

/// The tyre example at `rate` Hz, written into `dir` (its structure file referenced by its
/// absolute path: file references resolve against the set-up's folder).
fn tyre_at(rate: f64, dir: &Path) -> PathBuf {
    let physical = format!(
        "{:?}",
        examples().join("tyre-physical.toml").display().to_string()
    );
    let text = std::fs::read_to_string(examples().join("tyre.toml"))
        .unwrap()
        .replace("\"tyre-physical.toml\"", &physical)
        .replace(
            "sample_rate_hz = 2000.0",
            &format!("sample_rate_hz = {rate:.1}"),
        );
    let path = dir.join("tyre.toml");
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn every_configuration_runs_on_the_firmware_as_on_the_host() {
    let dir = tempfile::tempdir().unwrap();
    // Aero on the four-poster: front and rear down force from speed and ride heights.
    let aero = sim_qemu(&examples().join("aero.toml"), 0.6, &dir.path().join("aero"))
        .unwrap_or_else(|e| panic!("aero: {e}"));
    check(&aero, 2, 1200, "aero x2 at 2 kHz");
    // The board, configured from its defaults (the tyre, its static load as safe demand),
    // steps Idle before the run until its demand is the set-up's safe demand, where the
    // host's controller starts: the runs are equal.
    host_run_equals(
        &examples().join("aero.toml"),
        0.6,
        &dir.path().join("aero-host"),
        &dir.path().join("aero/sim.csv"),
        "aero",
    );

    // The tyre on four hubs: at 2 kHz the bus cannot carry it, at 1 kHz (two buses) it runs.
    let tyre = examples().join("tyre.toml");
    let refused = sim_qemu(&tyre, 0.1, &dir.path().join("tyre2k")).unwrap_err();
    assert!(
        refused.contains("at 2000 Hz") && refused.contains("% of a 1 Mbit/s bus"),
        "{refused}"
    );
    let tyre_1k = tyre_at(1000.0, dir.path());
    let tyre = sim_qemu(&tyre_1k, 0.6, &dir.path().join("tyre1k"))
        .unwrap_or_else(|e| panic!("tyre x4: {e}"));
    check(&tyre, 4, 600, "tyre x4 at 1 kHz");
    host_run_equals(
        &tyre_1k,
        0.6,
        &dir.path().join("tyre1k-host"),
        &dir.path().join("tyre1k/sim.csv"),
        "tyre x4",
    );

    // The 2-DOF example with its numerical suspension nonlinear.
    let nonlinear = examples().join("two-dof-nonlinear.toml");
    let sub = sim_qemu(&nonlinear, 0.6, &dir.path().join("nonlinear"))
        .unwrap_or_else(|e| panic!("nonlinear substructure: {e}"));
    check(&sub, 1, 1200, "substructure with nonlinear elements");
    host_run_equals(
        &nonlinear,
        0.6,
        &dir.path().join("nonlinear-host"),
        &dir.path().join("nonlinear/sim.csv"),
        "substructure",
    );
}
