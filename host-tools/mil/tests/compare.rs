//! `mil compare` on records written here (not by `mil sim`): a MiL column that is the
//! emulated one delayed and scaled gives the J1 and J2 that follow from the delay and the
//! scale; two runs are compared column by column; mistakes are named.

use std::f64::consts::TAU;
use std::io::Write;
use std::path::Path;

mod common;
use common::mil_in as mil;

/// A record at `fs`: `road_0`, `emulated_force_0` (a 3 Hz and a 7 Hz sine, the response
/// to the road), `mil_force_0` = `scale` times it `delay` samples later.
fn write(path: &Path, fs: f64, delay: usize, scale: f64) {
    write_road(path, fs, delay, scale, 1e-3);
}

fn write_road(path: &Path, fs: f64, delay: usize, scale: f64, road: f64) {
    let mut w = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    writeln!(
        w,
        "time [s],road_0 [m],emulated_force_0 [N],mil_force_0 [N]"
    )
    .unwrap();
    let x = |t: f64| 300.0 * (TAU * 3.0 * t).sin() + 100.0 * (TAU * 7.0 * t + 1.0).sin();
    for i in 0..(20.0 * fs) as usize {
        let t = i as f64 / fs;
        let td = (i as f64 - delay as f64) / fs;
        writeln!(w, "{t},{},{},{}", road * x(t) / 300.0, x(t), scale * x(td)).unwrap();
    }
}

#[test]
fn a_delayed_scaled_copy_gives_its_delay_and_error() {
    let dir = tempfile::tempdir().unwrap();
    let fs = 1000.0;
    write(&dir.path().join("run.csv"), fs, 5, 1.1);
    let (code, stdout, stderr) = mil(
        dir.path(),
        &["compare", "run.csv", "--json", "--input", "road_0"],
    );
    assert_eq!(code, Some(0), "{stderr}");
    let v: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    let pair = &v["pairs"][0];
    assert_eq!(pair["column"], "mil_force_0");
    assert_eq!(pair["reference"], "emulated_force_0");
    assert_eq!(pair["unit"], "N");
    let j1 = pair["figures"]["delay_ms"].as_f64().unwrap();
    assert!((j1 - 5.0).abs() < 0.1, "J1 {j1}");
    // J2 from the two sines: |1.1 e^{-jωd} − 1| per component, power-weighted.
    let e = |f: f64, a: f64| {
        let phi = TAU * f * 0.005;
        a * a * ((1.1 * phi.cos() - 1.0).powi(2) + (1.1 * phi.sin()).powi(2))
    };
    let expected =
        100.0 * ((e(3.0, 300.0) + e(7.0, 100.0)) / (300.0f64.powi(2) + 100.0f64.powi(2))).sqrt();
    let j2 = pair["figures"]["nrms_error_pct"].as_f64().unwrap();
    assert!(
        (j2 / expected - 1.0).abs() < 0.02,
        "J2 {j2}, expected {expected}"
    );
    // The responses to the road differ by the scale (0.83 dB) and the delay.
    let (db, deg) = (
        pair["response"]["db"].as_f64().unwrap(),
        pair["response"]["deg"].as_f64().unwrap(),
    );
    assert!((db - 20.0 * 1.1f64.log10()).abs() < 0.05, "{db} dB");
    assert!((deg - 360.0 * 7.0 * 0.005).abs() < 1.0, "{deg} deg");
    assert!(dir.path().join("out/compare/time.svg").is_file());
}

#[test]
fn two_runs_are_compared_column_by_column_and_mistakes_are_named() {
    let dir = tempfile::tempdir().unwrap();
    write(&dir.path().join("a.csv"), 1000.0, 5, 1.1);
    write(&dir.path().join("b.csv"), 1000.0, 5, 1.0);
    write(&dir.path().join("c.csv"), 500.0, 5, 1.0);
    let (code, stdout, stderr) = mil(dir.path(), &["compare", "a.csv", "--against", "b.csv"]);
    assert_eq!(code, Some(0), "{stderr}");
    assert!(
        stdout.contains("equal in both: road_0, emulated_force_0"),
        "{stdout}"
    );
    let line = stdout
        .lines()
        .find(|l| l.starts_with("mil_force_0"))
        .unwrap();
    assert!(line.contains(" 0.00 ") && line.contains(" 10.0 "), "{line}");
    let (code, _, stderr) = mil(dir.path(), &["compare", "a.csv", "--against", "c.csv"]);
    assert_eq!(code, Some(1));
    assert!(
        stderr.contains("c.csv is sampled at 500") && stderr.contains("one rate"),
        "{stderr}"
    );
    let (code, _, stderr) = mil(dir.path(), &["compare", "a.csv", "--input", "road_9"]);
    assert_eq!(code, Some(1));
    assert!(
        stderr.contains("--input road_9: no such column in a.csv"),
        "{stderr}"
    );
    // Runs on different roads are not compared.
    write_road(&dir.path().join("d.csv"), 1000.0, 5, 1.0, 2e-3);
    let (code, _, stderr) = mil(dir.path(), &["compare", "a.csv", "--against", "d.csv"]);
    assert_eq!(code, Some(1));
    assert!(
        stderr.contains("different inputs (column `road_0` differs)"),
        "{stderr}"
    );
    let (code, _, stderr) = mil(dir.path(), &["compare", "a.csv", "--against", "a.csv"]);
    assert_eq!(code, Some(1));
    assert!(stderr.contains("a.csv is compared with itself"), "{stderr}");
    // Two runs equal sample for sample: said so, not an error.
    std::fs::copy(dir.path().join("a.csv"), dir.path().join("a2.csv")).unwrap();
    let (code, stdout, stderr) = mil(dir.path(), &["compare", "a.csv", "--against", "a2.csv"]);
    assert_eq!(code, Some(0), "{stderr}");
    assert!(
        stdout.contains("equal in every shared column, sample for sample: road_0, emulated_force_0, mil_force_0"),
        "{stdout}"
    );
}

/// A board recording as `mil daq record` writes it (`time, position, road, demand`: the
/// A2L's names, the road quantised to 1 µm as the board receives it) against a run with
/// `road_0`, `mil_position_0`, `demand_0`: the board's signals are paired with the run's
/// columns, the quantised road is the same input, a road 5 % larger is not.
#[test]
fn a_board_recording_pairs_with_the_run_and_its_quantised_road_is_the_same_input() {
    let dir = tempfile::tempdir().unwrap();
    let fs = 1000.0;
    let road = |t: f64| 2e-3 * (TAU * 2.0 * t).sin() + 5e-4 * (TAU * 11.0 * t).sin();
    let demand =
        |t: f64| 1667.7 + 400.0 * (TAU * 2.0 * t + 0.3).sin() + 150.0 * (TAU * 17.0 * t).sin();
    let position = |t: f64| 1e-3 * (TAU * 2.0 * t + 0.5).sin();
    let write_daq = |name: &str, road_scale: f64| {
        let mut w = std::io::BufWriter::new(std::fs::File::create(dir.path().join(name)).unwrap());
        writeln!(w, "time [s],position [m],road [m],demand [N]").unwrap();
        for i in 0..(5.0 * fs) as usize {
            let t = i as f64 / fs;
            let r = (road_scale * road(t) / 1e-6).round() * 1e-6;
            // The board's demand 2 ms later than the run's.
            writeln!(w, "{t},{},{r},{}", position(t), demand(t - 0.002)).unwrap();
        }
    };
    write_daq("daq.csv", 1.0);
    write_daq("other-road.csv", 1.05);
    let mut w = std::io::BufWriter::new(std::fs::File::create(dir.path().join("run.csv")).unwrap());
    writeln!(
        w,
        "time [s],road_0 [m],demand_0 [N],mil_position_0 [m],emulated_position_0 [m]"
    )
    .unwrap();
    for i in 0..(5.0 * fs) as usize {
        let t = i as f64 / fs;
        writeln!(
            w,
            "{t},{},{},{},{}",
            road(t),
            demand(t),
            position(t),
            position(t)
        )
        .unwrap();
    }
    drop(w);
    let (code, stdout, stderr) = mil(
        dir.path(),
        &[
            "compare",
            "daq.csv",
            "--against",
            "run.csv",
            "--json",
            "--out",
            "cmp",
        ],
    );
    assert_eq!(code, Some(0), "{stderr}");
    let v: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    let pairs: Vec<(&str, &str)> = v["pairs"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| {
            (
                p["column"].as_str().unwrap(),
                p["reference"].as_str().unwrap(),
            )
        })
        .collect();
    // The position is equal in both: named once, not tabled.
    assert_eq!(pairs, [("road", "road_0"), ("demand", "demand_0")], "{v}");
    assert_eq!(v["identical"], serde_json::json!(["position"]));
    let j1 = v["pairs"][1]["figures"]["delay_ms"].as_f64().unwrap();
    assert!((j1 - 2.0).abs() < 0.1, "J1 {j1}");
    // The demand per road in dB with its unit, force per displacement in N/mm as every
    // command shows it.
    let (code, _, stderr) = mil(
        dir.path(),
        &[
            "compare",
            "daq.csv",
            "--against",
            "run.csv",
            "--input",
            "road",
            "--out",
            "cmp-road",
        ],
    );
    assert_eq!(code, Some(0), "{stderr}");
    let svg = std::fs::read_to_string(dir.path().join("cmp-road/response-demand.svg")).unwrap();
    assert!(svg.contains("demand / road [dB re 1 N/mm]"), "{svg}");

    let (code, _, stderr) = mil(
        dir.path(),
        &[
            "compare",
            "other-road.csv",
            "--against",
            "run.csv",
            "--out",
            "cmp",
        ],
    );
    assert_eq!(code, Some(1));
    assert!(
        stderr.contains("different inputs (column `road`"),
        "{stderr}"
    );

    // A road of a few µm: its 1 µm frames differ from it by far more than 1 % of its RMS,
    // by no more than the rounding; 5 % more road is still another input.
    let small = |t: f64, scale: f64| scale * 5e-6 * (TAU * 2.0 * t).sin();
    let write_small = |name: &str, scale: f64, quantised: bool| {
        let mut w = std::io::BufWriter::new(std::fs::File::create(dir.path().join(name)).unwrap());
        writeln!(w, "time [s],road_0 [m],demand_0 [N]").unwrap();
        for i in 0..(5.0 * fs) as usize {
            let t = i as f64 / fs;
            let mut r = small(t, scale);
            if quantised {
                r = (r / 1e-6).round() * 1e-6;
            }
            writeln!(w, "{t},{r},{}", demand(t)).unwrap();
        }
    };
    write_small("small-run.csv", 1.0, false);
    write_small("small-board.csv", 1.0, true);
    write_small("small-other.csv", 1.05, true);
    let compare = |record: &str| {
        mil(
            dir.path(),
            &[
                "compare",
                record,
                "--against",
                "small-run.csv",
                "--out",
                "cmp",
            ],
        )
    };
    let (code, stdout, stderr) = compare("small-board.csv");
    assert_eq!(code, Some(0), "{stdout}{stderr}");
    let (code, _, stderr) = compare("small-other.csv");
    assert_eq!(code, Some(1));
    assert!(stderr.contains("different inputs"), "{stderr}");
}
