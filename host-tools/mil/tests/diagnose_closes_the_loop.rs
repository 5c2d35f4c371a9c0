//! Diagnosis closes the loop, through the `mil` binary as an engineer runs it: the 2-DOF
//! example's physical part (`examples/two-dof-physical.toml`, a structure file) carries a
//! hidden effect on the simulated rig; `mil sim` records it; `mil diagnose` with the linear
//! structure names the effect from that record (measurement noise added here) and writes
//! `updated.toml`; `mil sim` with `updated.toml` as the physical part then reproduces the
//! record far better than the linear structure does.
//!
//! The same for the aero example's half car on the four-poster
//! (`examples/aero-physical.toml`: a hidden effect on one suspension, the record's two axle
//! positions and load cells) and for the tyre example's quarter car
//! (`examples/tyre-physical.toml`: the body's displacement, which `mil sim` records, beside
//! the hub's), `updated.toml` back into their set-ups.
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
/// load cell, position and DOF columns (every channel's), written next to it.
fn noisy(path: &Path, fraction: f64, seed: u64) -> PathBuf {
    let Table {
        names,
        columns: mut cols,
        ..
    } = read_csv(path);
    let mut rng = SplitMix64::new(seed);
    for (name, col) in names.iter().zip(cols.iter_mut()) {
        if ["mil_force_", "mil_position_", "mil_dof_"]
            .iter()
            .any(|p| name.starts_with(p))
        {
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

/// The 2-DOF example's physical part with `effect` sized by `params(x_rms, v_rms)` from the
/// linear run's RMS position and velocity of `x_p`.
fn two_dof_closes_the_loop(effect: &str, params: impl Fn(f64, f64) -> String, seed: u64) {
    vehicle_closes_the_loop(
        ("two-dof.toml", "two-dof-physical.toml"),
        ("k_p, c_p to the bed", effect),
        |b| {
            let x = column(b, "mil_position_0");
            let v: Vec<f64> = x.windows(2).map(|w| (w[1] - w[0]) * 2000.0).collect();
            params(rms(x), rms(&v))
        },
        seed,
        &["0"],
    );
}

#[test]
fn a_hidden_cubic_spring_is_named_and_the_updated_structure_closes_the_gap() {
    // Hardening: +15 % stiffness at the linear run's RMS deflection.
    two_dof_closes_the_loop(
        "cubic_stiffness",
        |x, _| format!("stiffness_n_per_m3 = {:e}", 0.15 * 2.0e4 / (x * x)),
        11,
    );
}

#[test]
fn a_hidden_orifice_damper_is_named_and_the_updated_structure_closes_the_gap() {
    // Quadratic damping as large as the linear damping at the RMS velocity.
    two_dof_closes_the_loop(
        "quadratic_damping",
        |_, v| format!("damping_n_s2_per_m2 = {:e}", 10.0 / v),
        12,
    );
}

#[test]
fn a_hidden_bump_stop_is_named_and_the_updated_structure_closes_the_gap() {
    // A stop as stiff as the spring, engaging at 1.5 x the RMS deflection.
    two_dof_closes_the_loop(
        "bump_stop",
        |x, _| format!("gap_m = {:e}, stiffness_n_per_m = 2.0e4", 1.5 * x),
        13,
    );
}

/// A set-up of the examples (`set_up`, whose physical part is `physical`) in `dir` (the
/// examples' files copied beside it) with the physical part `structure` (a file name in
/// `dir`) and road seed `seed`, 12 s long; returns its path.
fn vehicle_config(
    dir: &Path,
    (set_up, physical): (&str, &str),
    name: &str,
    structure: &str,
    seed: u64,
) -> PathBuf {
    for entry in std::fs::read_dir(examples()).unwrap() {
        let path = entry.unwrap().path();
        let copy = dir.join(path.file_name().unwrap());
        if !copy.exists() {
            std::fs::copy(&path, copy).unwrap();
        }
    }
    let mut text = std::fs::read_to_string(examples().join(set_up)).unwrap();
    for (from, to) in [
        (
            format!("structure = \"{physical}\""),
            format!("structure = \"{structure}\""),
        ),
        ("seed = 1".into(), format!("seed = {seed}")),
        ("duration_s = 20.0".into(), "duration_s = 12.0".to_string()),
    ] {
        assert!(text.contains(&from), "{from}");
        text = text.replace(&from, &to);
    }
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

/// One vehicle case: the shipped set-up `example` = (set-up, physical part) with the hidden
/// `effect` on `element`, its parameters `params(linear run)`; named from the record (noise
/// added) and `updated.toml` as the physical part closes the gap on every channel.
fn vehicle_closes_the_loop(
    example: (&str, &str),
    (element, effect): (&str, &str),
    params: impl Fn(&Table) -> String,
    seed: u64,
    channels: &[&str],
) {
    let dir = scratch(&format!("{}-{effect}", example.0));
    let linear = std::fs::read_to_string(examples().join(example.1)).unwrap();
    std::fs::write(dir.join("linear.toml"), &linear).unwrap();
    let b = read_csv(&sim(
        &vehicle_config(&dir, example, "linear-sim.toml", "linear.toml", seed),
        &dir.join("linear-run"),
    ));
    let parameters = params(&b);
    let truth = format!(
        "{linear}\n[[effect]]\neffect = \"{effect}\"\nelement = \"{element}\"\n\
         parameters = {{ {parameters} }}\n"
    );
    std::fs::write(dir.join("truth.toml"), truth).unwrap();
    let record = sim(
        &vehicle_config(&dir, example, "truth-sim.toml", "truth.toml", seed),
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
    assert_eq!(named, vec![(effect, element)], "{report}");
    let c = read_csv(&sim(
        &vehicle_config(
            &dir,
            example,
            "updated-sim.toml",
            "diagnosis/updated.toml",
            seed,
        ),
        &dir.join("updated-run"),
    ));
    for channel in channels {
        let (x, f) = (
            format!("mil_position_{channel}"),
            format!("mil_force_{channel}"),
        );
        let before = rms_diff(column(&a, &x), column(&b, &x));
        let after = rms_diff(column(&a, &x), column(&c, &x));
        let before_f = rms_diff(column(&a, &f), column(&b, &f));
        let after_f = rms_diff(column(&a, &f), column(&c, &f));
        eprintln!(
            "{} {effect} {{ {parameters} }} on {element:?}, seed {seed}, channel {channel}: \
             record vs MiL with the linear structure {:.3} mm / {before_f:.3} N RMS, with \
             updated.toml {:.4} mm / {after_f:.4} N: the gap {:.0}x / {:.0}x smaller",
            example.0,
            before * 1e3,
            after * 1e3,
            before / after,
            before_f / after_f
        );
        assert!(before / after > 10.0, "{x}: {before} -> {after}");
        assert!(before_f / after_f > 10.0, "{f}: {before_f} -> {after_f}");
    }
}

/// The aero example's half car with a hidden hardening front suspension (+15 % stiffness at
/// the linear run's RMS front compression).
#[test]
fn the_half_car_s_hidden_cubic_spring_is_named_and_the_updated_structure_closes_the_gap() {
    vehicle_closes_the_loop(
        ("aero.toml", "aero-physical.toml"),
        ("front suspension", "cubic_stiffness"),
        |b| {
            let compression: Vec<f64> = column(b, "road_front")
                .iter()
                .zip(column(b, "mil_position_0"))
                .map(|(r, x)| r - x)
                .collect();
            let x = rms(&compression);
            format!("stiffness_n_per_m3 = {:e}", 0.15 * 3.0e5 / (x * x))
        },
        14,
        &["0", "1"],
    );
}

/// The tyre example's quarter car (the body's displacement recorded beside the hub's) with
/// a hidden orifice damper in the suspension, as large as its linear damping at the linear
/// run's RMS suspension velocity.
#[test]
fn the_quarter_car_s_hidden_orifice_damper_is_named_and_the_updated_structure_closes_the_gap() {
    vehicle_closes_the_loop(
        ("tyre.toml", "tyre-physical.toml"),
        ("suspension", "quadratic_damping"),
        |b| {
            let stroke: Vec<f64> = column(b, "mil_dof_x_u_0")
                .iter()
                .zip(column(b, "mil_dof_x_s_0"))
                .map(|(u, s)| u - s)
                .collect();
            let v: Vec<f64> = stroke.windows(2).map(|w| (w[1] - w[0]) * 2000.0).collect();
            format!("damping_n_s2_per_m2 = {:e}", 2500.0 / rms(&v))
        },
        15,
        &["0"],
    );
}
