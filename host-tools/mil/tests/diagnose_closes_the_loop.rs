//! Diagnosis closes the loop, through the `mil` binary as an engineer runs it: the 2-DOF
//! example's physical part (`examples/two-dof-physical.toml`, a structure file) carries a
//! hidden effect on the simulated rig; `mil sim` records it; `mil diagnose` with the linear
//! structure names the effect from that record (measurement noise added here) and writes
//! `updated.toml`; `mil sim` with `updated.toml` as the physical part then reproduces the
//! record far better than the linear structure does.
//!
//! The same for the aero example's half car on the four-poster
//! (`examples/aero-physical.toml`): a hidden effect on one suspension, the record's two
//! axle positions and load cells, `updated.toml` back into the aero set-up.
//!
//! The hidden effects are sized from the linear run's own amplitudes (a rule, not tuned per
//! case), and each case runs on a road seed used nowhere else.

use mil_numerics::record::Table;
use mil_numerics::rng::SplitMix64;
use std::path::{Path, PathBuf};
use std::process::Command;

fn examples() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("examples")
}

/// A scratch folder for one case (cleared first).
fn scratch(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("closes-the-loop-{name}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn mil(args: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_mil"))
        .args(args)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout).to_string();
    assert!(
        out.status.success(),
        "mil {args:?} failed:\n{text}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    text
}

/// The 2-DOF set-up (`two-dof.toml`) in `dir` with the physical part `structure` (a file
/// name in `dir`) and road seed `seed`, 12 s long; returns its path.
fn sim_config(dir: &Path, name: &str, structure: &str, seed: u64) -> PathBuf {
    let shipped = |f: &str| format!("{:?}", examples().join(f).display().to_string());
    let mut text = std::fs::read_to_string(examples().join("two-dof.toml")).unwrap();
    for (from, to) in [
        (
            "structure = \"two-dof-physical.toml\"",
            format!("structure = \"{structure}\""),
        ),
        (
            "structure = \"two-dof-numerical.toml\"",
            format!("structure = {}", shipped("two-dof-numerical.toml")),
        ),
        ("seed = 1", format!("seed = {seed}")),
        ("duration_s = 20.0", "duration_s = 12.0".to_string()),
        (
            "filter = \"two-dof-filter.json\"",
            format!("filter = {}", shipped("two-dof-filter.json")),
        ),
    ] {
        assert!(text.contains(from), "{from}");
        text = text.replace(from, &to);
    }
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

/// Runs `mil sim` on `config` into `dir/out`, returns the CSV's path.
fn sim(config: &Path, out: &Path) -> PathBuf {
    mil(&[
        "sim",
        config.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    out.join("sim.csv")
}

/// A `mil sim` CSV, through the workspace's record reader.
fn read_csv(path: &Path) -> Table {
    mil_numerics::record::read(path).unwrap()
}

fn column<'a>(csv: &'a Table, name: &str) -> &'a [f64] {
    &csv.columns[csv.index(name).unwrap()]
}

fn rms(x: &[f64]) -> f64 {
    (x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64).sqrt()
}

fn rms_diff(a: &[f64], b: &[f64]) -> f64 {
    let d: Vec<f64> = a.iter().zip(b).map(|(x, y)| x - y).collect();
    rms(&d)
}

/// The record with white measurement noise of `fraction` of each channel's RMS on the
/// load cell and position columns (every channel's), written next to it.
fn noisy(path: &Path, fraction: f64, seed: u64) -> PathBuf {
    let Table {
        names,
        columns: mut cols,
        ..
    } = read_csv(path);
    let mut rng = SplitMix64::new(seed);
    for (name, col) in names.iter().zip(cols.iter_mut()) {
        if name.starts_with("mil_force_") || name.starts_with("mil_position_") {
            let sigma = fraction * rms(col);
            for v in col.iter_mut() {
                *v += sigma * rng.normal();
            }
        }
    }
    let mut text = names.join(",") + "\n";
    for k in 0..cols[0].len() {
        let row: Vec<String> = cols.iter().map(|c| format!("{:e}", c[k])).collect();
        text.push_str(&row.join(","));
        text.push('\n');
    }
    let out = path.with_file_name("noisy.csv");
    std::fs::write(&out, text).unwrap();
    out
}

/// One case: the effect `effect` with the parameters `params(x_rms, v_rms)` (from the
/// linear run) on the physical element, road seed `seed`.
fn closes_the_loop(effect: &str, params: impl Fn(f64, f64) -> String, seed: u64) {
    let dir = scratch(effect);
    let linear = std::fs::read_to_string(examples().join("two-dof-physical.toml")).unwrap();
    std::fs::write(dir.join("linear.toml"), &linear).unwrap();
    let config = sim_config(&dir, "linear-sim.toml", "linear.toml", seed);
    let b = read_csv(&sim(&config, &dir.join("linear-run")));
    let x = column(&b, "mil_position_0");
    let v: Vec<f64> = x.windows(2).map(|w| (w[1] - w[0]) * 2000.0).collect();
    let (x_rms, v_rms) = (rms(x), rms(&v));
    let parameters = params(x_rms, v_rms);
    let truth = format!(
        "{linear}\n[[effect]]\neffect = \"{effect}\"\nelement = \"k_p, c_p to the bed\"\n\
         parameters = {{ {parameters} }}\n"
    );
    std::fs::write(dir.join("truth.toml"), truth).unwrap();
    let config = sim_config(&dir, "truth-sim.toml", "truth.toml", seed);
    let record = sim(&config, &dir.join("truth-run"));
    let a = read_csv(&record);
    let data = noisy(&record, 0.005, seed ^ 0x5eed);
    let report = mil(&[
        "diagnose",
        "--model",
        dir.join("linear.toml").to_str().unwrap(),
        "--data",
        data.to_str().unwrap(),
        "--out",
        dir.join("diagnosis").to_str().unwrap(),
        "--json",
    ]);
    let json: serde_json::Value = serde_json::from_str(&report).unwrap();
    let named: Vec<&str> = json["named_effects"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e["effect"].as_str().unwrap())
        .collect();
    assert_eq!(named, vec![effect], "{report}");
    let config = sim_config(&dir, "updated-sim.toml", "diagnosis/updated.toml", seed);
    let c = read_csv(&sim(&config, &dir.join("updated-run")));
    let (truth_x, truth_f) = (column(&a, "mil_position_0"), column(&a, "mil_force_0"));
    let before = rms_diff(truth_x, column(&b, "mil_position_0"));
    let after = rms_diff(truth_x, column(&c, "mil_position_0"));
    let before_f = rms_diff(truth_f, column(&b, "mil_force_0"));
    let after_f = rms_diff(truth_f, column(&c, "mil_force_0"));
    eprintln!(
        "{effect} {{ {parameters} }}, seed {seed}: record vs MiL with the linear structure \
         {:.3} mm / {before_f:.3} N RMS, with updated.toml {:.4} mm / {after_f:.4} N: the gap \
         {:.0}x / {:.0}x smaller",
        before * 1e3,
        after * 1e3,
        before / after,
        before_f / after_f
    );
    assert!(before / after > 10.0, "{before} -> {after}");
    assert!(before_f / after_f > 10.0, "{before_f} -> {after_f}");
}

#[test]
fn a_hidden_cubic_spring_is_named_and_the_updated_structure_closes_the_gap() {
    // Hardening: +15 % stiffness at the linear run's RMS deflection.
    closes_the_loop(
        "cubic_stiffness",
        |x, _| format!("stiffness_n_per_m3 = {:e}", 0.15 * 2.0e4 / (x * x)),
        11,
    );
}

#[test]
fn a_hidden_orifice_damper_is_named_and_the_updated_structure_closes_the_gap() {
    // Quadratic damping as large as the linear damping at the RMS velocity.
    closes_the_loop(
        "quadratic_damping",
        |_, v| format!("damping_n_s2_per_m2 = {:e}", 10.0 / v),
        12,
    );
}

#[test]
fn a_hidden_bump_stop_is_named_and_the_updated_structure_closes_the_gap() {
    // A stop as stiff as the spring, engaging at 1.5 x the RMS deflection.
    closes_the_loop(
        "bump_stop",
        |x, _| format!("gap_m = {:e}, stiffness_n_per_m = 2.0e4", 1.5 * x),
        13,
    );
}

/// The aero set-up (`aero.toml`) in `dir` with the physical part `structure` (a file name
/// in `dir`) and road seed `seed`, 12 s long; returns its path.
fn aero_config(dir: &Path, name: &str, structure: &str, seed: u64) -> PathBuf {
    let mut text = std::fs::read_to_string(examples().join("aero.toml")).unwrap();
    for (from, to) in [
        (
            "structure = \"aero-physical.toml\"",
            format!("structure = \"{structure}\""),
        ),
        ("seed = 1", format!("seed = {seed}")),
        ("duration_s = 20.0", "duration_s = 12.0".to_string()),
    ] {
        assert!(text.contains(from), "{from}");
        text = text.replace(from, &to);
    }
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

/// The aero example's half car with a hidden hardening front suspension (+15 % stiffness at
/// the linear run's RMS front compression): named from the record, and `updated.toml` as
/// the physical part closes the gap on both axles.
#[test]
fn the_half_car_s_hidden_cubic_spring_is_named_and_the_updated_structure_closes_the_gap() {
    let dir = scratch("aero-cubic");
    let linear = std::fs::read_to_string(examples().join("aero-physical.toml")).unwrap();
    std::fs::write(dir.join("linear.toml"), &linear).unwrap();
    let seed = 14;
    let b = read_csv(&sim(
        &aero_config(&dir, "linear-sim.toml", "linear.toml", seed),
        &dir.join("linear-run"),
    ));
    let compression: Vec<f64> = column(&b, "road_front")
        .iter()
        .zip(column(&b, "mil_position_0"))
        .map(|(r, x)| r - x)
        .collect();
    let x_rms = rms(&compression);
    let k3 = 0.15 * 3.0e5 / (x_rms * x_rms);
    let truth = format!(
        "{linear}\n[[effect]]\neffect = \"cubic_stiffness\"\nelement = \"front suspension\"\n\
         parameters = {{ stiffness_n_per_m3 = {k3:e} }}\n"
    );
    std::fs::write(dir.join("truth.toml"), truth).unwrap();
    let record = sim(
        &aero_config(&dir, "truth-sim.toml", "truth.toml", seed),
        &dir.join("truth-run"),
    );
    let a = read_csv(&record);
    let data = noisy(&record, 0.005, seed ^ 0x5eed);
    let report = mil(&[
        "diagnose",
        "--model",
        dir.join("linear.toml").to_str().unwrap(),
        "--data",
        data.to_str().unwrap(),
        "--out",
        dir.join("diagnosis").to_str().unwrap(),
        "--json",
    ]);
    let json: serde_json::Value = serde_json::from_str(&report).unwrap();
    let named: Vec<(&str, &str)> = json["named_effects"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| {
            (
                e["effect"].as_str().unwrap(),
                e["element"].as_str().unwrap_or_default(),
            )
        })
        .collect();
    assert_eq!(
        named,
        vec![("cubic_stiffness", "front suspension")],
        "{report}"
    );
    let c = read_csv(&sim(
        &aero_config(&dir, "updated-sim.toml", "diagnosis/updated.toml", seed),
        &dir.join("updated-run"),
    ));
    for channel in ["0", "1"] {
        let (x, f) = (
            format!("mil_position_{channel}"),
            format!("mil_force_{channel}"),
        );
        let before = rms_diff(column(&a, &x), column(&b, &x));
        let after = rms_diff(column(&a, &x), column(&c, &x));
        let before_f = rms_diff(column(&a, &f), column(&b, &f));
        let after_f = rms_diff(column(&a, &f), column(&c, &f));
        eprintln!(
            "aero cubic_stiffness {k3:.3e} N/m^3, seed {seed}, axle {channel}: record vs MiL \
             with the linear structure {:.3} mm / {before_f:.3} N RMS, with updated.toml \
             {:.4} mm / {after_f:.4} N: the gap {:.0}x / {:.0}x smaller",
            before * 1e3,
            after * 1e3,
            before / after,
            before_f / after_f
        );
        assert!(before / after > 10.0, "{x}: {before} -> {after}");
        assert!(before_f / after_f > 10.0, "{f}: {before_f} -> {after_f}");
    }
}
