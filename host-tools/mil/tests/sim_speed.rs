//! `mil sim` and `mil run` with a vehicle speed that varies over the run (`[excitation]
//! speed`): the board and the emulated aero model follow the same speed, the down force
//! scales with `v²` in both, the speed is in the CSV, the analysis comparison is skipped
//! with the reason, and bad speed inputs are refused with clear errors.

use mil::config::Config;
use mil::setup::SetUp;
use mil::sim::simulate;
use mil_params::AeroExample;
use mil_rig::rigs::IdealAero;
use model_core::AeroParams;
use std::path::{Path, PathBuf};

fn examples() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("examples")
}

/// The constant speed of the shipped aero set-up, a line of its `[excitation]`.
const CONSTANT_SPEED: &str =
    "speed_m_per_s = 50.0             # or speed = { kind = \"ramp\", ... } / { kind = \"csv\", ... }\n";

/// The shipped aero set-up's text, `duration_s` long, the constant speed replaced by
/// `speed` (an `[excitation.speed]` table, or "" for none), further replacements applied.
fn aero_text(duration_s: f64, speed: &str, replace: &[(&str, &str)]) -> String {
    let mut text = std::fs::read_to_string(examples().join("aero.toml")).unwrap();
    for (from, to) in [
        (
            "duration_s = 20.0",
            format!("duration_s = {duration_s}").as_str(),
        ),
        (CONSTANT_SPEED, speed),
    ] {
        assert!(text.contains(from), "{from}");
        text = text.replacen(from, to, 1);
    }
    for (from, to) in replace {
        assert!(text.contains(from), "{from}");
        text = text.replace(from, to);
    }
    text
}

/// The aero set-up's physical structure copied into the folder `base` (unless it is the
/// examples').
fn with_physical(base: &Path) -> &Path {
    let target = base.join("aero-physical.toml");
    if !target.exists() {
        std::fs::copy(examples().join("aero-physical.toml"), target).unwrap();
    }
    base
}

/// [`aero_text`] as `mil sim` runs it (the set-up's analysis attached); relative paths
/// resolve against the scratch folder `base`.
fn aero_config(duration_s: f64, speed: &str, replace: &[(&str, &str)], base: &Path) -> Config {
    SetUp::from_toml(&aero_text(duration_s, speed, replace), with_physical(base))
        .unwrap()
        .sim()
        .unwrap()
}

/// The static equilibrium of the paper's half car after a speed change from `from` to `to`
/// (m/s): the suspensions (at the axle points, like the actuators) carry the down force at
/// `from` at `x = 0`, so at `to` each axle settles where `k x = F(x, to) − F(0, from)`.
/// Returns the axle forces (N, up positive) there.
fn settled_forces(from: f64, to: f64) -> [f64; 2] {
    let car = AeroExample::default();
    let aero = IdealAero::new(AeroParams::PAPER, from);
    let start = aero.axle_forces(0.0, 0.0);
    let k = [car.front_stiffness, car.rear_stiffness];
    let mut x = [0.0; 2];
    for _ in 0..200 {
        let f = aero.axle_forces_at(x[0], x[1], to);
        x = [(f[0] - start[0]) / k[0], (f[1] - start[1]) / k[1]];
    }
    aero.axle_forces_at(x[0], x[1], to)
}

/// A speed step from 40 to 50 m/s on a flat road: before it both the MiL rig (load cells)
/// and the emulated car hold the down force at 40 m/s; after it both settle where the
/// static equilibrium computed independently puts them (within 0.1 %), with forces
/// `(50/40)² = 1.5625` times what the 40 m/s law gives at the same ride height.
#[test]
fn a_speed_step_scales_the_down_force_with_v_squared_in_mil_and_emulated() {
    let config = aero_config(
        5.0,
        "[excitation.speed]\nkind = \"step\"\nfrom_m_per_s = 40.0\nto_m_per_s = 50.0\nat_s = 2.0\n",
        &[("rms_m = 0.001", "rms_m = 0.0")],
        &examples(),
    );
    let out = simulate(&config, |_| {}).unwrap();
    let s = &out.summary;
    eprintln!("{}", out.table());
    assert_eq!(s.fault_at_s, None);
    assert_eq!(s.speed_m_per_s, Some([40.0, 50.0]));
    let h = &out.histories;
    assert_eq!(out.road_names, ["road_front", "road_rear", "speed"]);
    // Sample 4000 (t = 2 s) is the first at the new speed.
    assert_eq!((h.road[2][3999], h.road[2][4000]), (40.0, 50.0));
    let params = AeroParams::PAPER;
    let before = params.forces(0.0, 0.0, 40.0).map(f64::from);
    let after = settled_forces(40.0, 50.0);
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    for c in 0..2 {
        // At rest at 40 m/s (the rig starts at the static equilibrium of the first speed).
        for (what, v) in [("MiL", &h.mil_force[c]), ("emulated", &h.emulated_force[c])] {
            let f = mean(&v[3000..3999]);
            assert!(
                (f - before[c]).abs() < 1e-3 * before[c].abs(),
                "{what} {c}: {f} vs {}",
                before[c]
            );
            let f = mean(&v[9000..]);
            assert!(
                (f - after[c]).abs() < 1e-3 * after[c].abs(),
                "{what} {c}: {f} vs {}",
                after[c]
            );
        }
    }
    // The v² law itself: at the settled ride height, the forces over the 40 m/s law's
    // forces at the same axle displacements are (50/40)², in the MiL rig (load cells and
    // transducers) and in the emulated car.
    let at_40 = IdealAero::new(params, 40.0);
    for (what, force, position) in [
        ("MiL", &h.mil_force, &h.mil_position),
        ("emulated", &h.emulated_force, &h.emulated_position),
    ] {
        let x = [mean(&position[0][9000..]), mean(&position[1][9000..])];
        let law = at_40.axle_forces(x[0], x[1]);
        for c in 0..2 {
            let ratio = mean(&force[c][9000..]) / law[c];
            eprintln!(
                "{what} axle {c}: settled at {:.3} mm, force / 40 m/s law {ratio:.5}",
                x[c] * 1e3
            );
            assert!((ratio - 1.5625).abs() < 1e-3, "{what} {c}: {ratio}");
        }
    }
    // A level road: no response to estimate (not an error).
    assert!(s.response.is_none());
    assert!(out.table().contains("vehicle speed 40.0 to 50.0 m/s"));
}

/// A recorded speed (a 10 Hz log, ramping 45 -> 57 m/s) is interpolated linearly per
/// sample; the CSV carries it in its `speed` column. The analysis holds at the reference
/// speed only: with a varying speed, or a constant one away from the reference, the
/// comparison with it is skipped with the reason instead of failing the run.
#[test]
fn a_recorded_speed_is_interpolated_and_written_to_the_csv() {
    let dir = tempfile::tempdir().unwrap();
    let mut log = String::from("time,gps_speed_m_per_s,other\n");
    for k in 0..=30 {
        let t = 0.1 * k as f64;
        log += &format!("{t:.1},{},7\n", 45.0 + 4.0 * t);
    }
    std::fs::write(dir.path().join("speed.csv"), log).unwrap();
    let config = aero_config(
        3.0,
        "[excitation.speed]\nkind = \"csv\"\npath = \"speed.csv\"\ncolumn = \"gps_speed_m_per_s\"\n",
        &[],
        dir.path(),
    );
    let out = simulate(&config, |_| {}).unwrap();
    assert_eq!(out.summary.fault_at_s, None);
    let speed = &out.histories.road[2];
    for (k, v) in speed.iter().enumerate() {
        let t = k as f64 / 2000.0;
        assert!((v - (45.0 + 4.0 * t)).abs() < 1e-9, "{k}: {v}");
    }
    let csv = dir.path().join("sim.csv");
    out.write_csv(&csv).unwrap();
    let text = std::fs::read_to_string(&csv).unwrap();
    let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
    assert_eq!(
        header[..4],
        ["time [s]", "road_front [m]", "road_rear [m]", "speed [m/s]"]
    );
    // The half car's heave and pitch.
    assert!(header.contains(&"mil_dof_z_b_0 [m]"), "{header:?}");
    assert!(header.contains(&"mil_dof_theta_b_0 [rad]"), "{header:?}");
    let row: Vec<f64> = text
        .lines()
        .nth(1 + 1000)
        .unwrap()
        .split(',')
        .map(|v| v.parse().unwrap())
        .collect();
    assert_eq!(row[0], 0.5);
    assert!((row[3] - 47.0).abs() < 1e-9, "{row:?}");
    let r = out.summary.response.as_ref().unwrap();
    assert!(r.analysis.is_none() && r.mil_vs_analysis.is_none());
    assert!(r.mil_vs_emulated.is_some());
    let note = r.analysis_skipped.as_deref().unwrap();
    assert!(
        note.contains("reference speed (50 m/s)") && note.contains("varies from 45 to 56.998"),
        "{note}"
    );
    assert!(out.table().contains("analysis comparison skipped"));

    // Constant, but not the reference speed: skipped with the reason, not an error.
    let constant = aero_config(
        3.0,
        "[excitation.speed]\nkind = \"constant\"\nspeed_m_per_s = 40.0\n",
        &[],
        &examples(),
    );
    let out = simulate(&constant, |_| {}).unwrap();
    assert_eq!(out.summary.speed_m_per_s, Some([40.0, 40.0]));
    let r = out.summary.response.as_ref().unwrap();
    let note = r.analysis_skipped.as_deref().unwrap();
    assert!(note.contains("the run is at 40 m/s"), "{note}");
    assert!(r.mil_vs_emulated.is_some());
}

/// `mil run` (open loop) follows the speed too, and writes it.
#[test]
fn mil_run_follows_the_speed() {
    let dir = tempfile::tempdir().unwrap();
    let text = aero_text(
        2.0,
        "[excitation.speed]\nkind = \"ramp\"\nfrom_m_per_s = 30.0\nto_m_per_s = 60.0\nat_s = 0.5\nduration_s = 1.0\n",
        &[("rms_m = 0.001", "rms_m = 0.0")],
    );
    let config = SetUp::from_toml(&text, with_physical(dir.path()))
        .unwrap()
        .run()
        .unwrap();
    let out = mil::run(&config, |_| {}).unwrap();
    let speed = out.speed.as_ref().unwrap();
    assert_eq!((speed[0], speed[2000], speed[3999]), (30.0, 45.0, 60.0));
    // Rigid rig, level road: the demand is the static down force at each sample's speed
    // (after the controller's start-up ramp from its safe demand).
    let params = AeroParams::PAPER;
    for k in [2000, 3999] {
        let expected = params.forces(0.0, 0.0, speed[k] as f32);
        for (d, e) in out.demand[k].iter().zip(expected) {
            assert!((d - f64::from(e)).abs() < 1e-2, "{k}: {d} vs {e}");
        }
    }
    let csv = dir.path().join("run.csv");
    out.write_csv(&csv).unwrap();
    let text = std::fs::read_to_string(&csv).unwrap();
    assert!(
        text.starts_with("time [s],road_0 [m],road_1 [m],speed [m/s],demand_0 [N],demand_1 [N],")
    );
}

/// Bad speed inputs are refused before running, with the file, line (and column) and reason.
#[test]
fn bad_speed_inputs_are_refused_with_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let error = |csv: &str, speed: &str| -> String {
        std::fs::write(dir.path().join("speed.csv"), csv).unwrap();
        let config = aero_config(1.0, speed, &[], dir.path());
        match config.validate() {
            Ok(_) => panic!("accepted {csv:?} {speed:?}"),
            Err(e) => format!("{e:#}"),
        }
    };
    let csv = "[excitation.speed]\nkind = \"csv\"\npath = \"speed.csv\"\n";
    let cases = [
        (
            "time,speed\n0,50\n0.5,50\n0.5,51\n1,50\n",
            "line 4: time 0.5 s does not increase",
        ),
        (
            "time,speed\n0,50\n0.5,151\n1,50\n",
            "line 3: speed 151 m/s is outside [0, 150]",
        ),
        (
            "time,speed\n0,50\n0.5,-1\n1,50\n",
            "line 3: speed -1 m/s is outside",
        ),
        (
            "time,speed\n0,50\n0.5,NaN\n1,50\n",
            "line 3, column 2: column `speed`: NaN is not finite",
        ),
        (
            "time,speed\n0,50\n0.5,fast\n1,50\n",
            "line 3, column 2: column `speed`: `fast` is not a number",
        ),
        (
            "time,speed\n0,50\n0.5,50\n",
            "covers 0 to 0.5 s, the run needs 0 to 0.9995 s",
        ),
        ("time,speed\n0.1,50\n2,50\n", "covers 0.1 to 2 s"),
        ("t,speed\n0,50\n1,50\n", "the first column must be `time`"),
        (
            "time,a,b\n0,50,1\n1,50,1\n",
            "2 columns after `time`: name the speed column",
        ),
        ("time,speed\n", "no rows"),
    ];
    for (file, expected) in cases {
        let e = error(file, csv);
        assert!(
            e.contains(expected) && e.contains("speed.csv"),
            "{file:?}: {e}"
        );
    }
    let e = error(
        "time,speed\n0,50\n1,50\n",
        "[excitation.speed]\nkind = \"csv\"\npath = \"speed.csv\"\ncolumn = \"v\"\n",
    );
    assert!(e.contains("no column \"v\""), "{e}");
    let e = error(
        "",
        "[excitation.speed]\nkind = \"csv\"\npath = \"missing.csv\"\n",
    );
    assert!(e.contains("cannot read speed profile"), "{e}");
    let e = error(
        "",
        "[excitation.speed]\nkind = \"step\"\nfrom_m_per_s = 40.0\nto_m_per_s = 200.0\nat_s = 1.0\n",
    );
    assert!(
        e.contains("excitation.speed.to_m_per_s must be in [0, 150] m/s"),
        "{e}"
    );
    let e = error(
        "",
        "[excitation.speed]\nkind = \"ramp\"\nfrom_m_per_s = 40.0\nto_m_per_s = 50.0\nat_s = 1.0\nduration_s = 0.0\n",
    );
    assert!(e.contains("excitation.speed.duration_s must be > 0"), "{e}");
    // The speed given twice, or not at all.
    let e = error("", "");
    assert!(e.contains("needs a speed"), "{e}");
    let both = aero_config(
        1.0,
        "[excitation.speed]\nkind = \"constant\"\nspeed_m_per_s = 40.0\n",
        &[(
            "road = { kind = \"pink\"",
            "speed_m_per_s = 50.0\nroad = { kind = \"pink\"",
        )],
        &examples(),
    );
    let e = format!("{:#}", both.validate().unwrap_err());
    assert!(e.contains("given twice"), "{e}");
    // Unknown keys are errors, as everywhere in the set-up.
    let text = aero_text(
        1.0,
        "[excitation.speed]\nkind = \"step\"\nfrom_m_per_s = 40.0\nto_m_per_s = 50.0\nat = 1.0\n",
        &[],
    );
    assert!(SetUp::from_toml(&text, &examples()).is_err());
    // A speed for the tyre model is a mistake, not ignored.
    let tyre = std::fs::read_to_string(examples().join("tyre.toml")).unwrap();
    let road = "road = { kind = \"pink\"";
    assert!(tyre.contains(road));
    let tyre = tyre.replace(
        road,
        &format!("speed = {{ kind = \"constant\", speed_m_per_s = 40.0 }}\n{road}"),
    );
    let e = format!(
        "{:#}",
        SetUp::from_toml(&tyre, &examples())
            .unwrap()
            .run()
            .unwrap_err()
    );
    assert!(e.contains("excitation.speed is for the aero model"), "{e}");
}
