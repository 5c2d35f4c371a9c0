//! `mil check FILE` on every kind of file: the shipped examples pass; each unit mistake of
//! issue 20 is refused with a message naming the field and the likely unit; and any
//! structure it accepts runs through `mil sim` (a property test over masses, stiffnesses,
//! dampings and gravity spanning ten decades).

use mil::check::{check, kind_of, FileKind};
use mil::config::Config;
use mil::sim::simulate;
use proptest::prelude::*;
use std::path::{Path, PathBuf};

fn manifest() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn scratch(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("check-{name}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// `msd.toml` written into `dir` with its physical structure replaced by `structure` (text),
/// `duration_s` long; returns the configuration's path.
fn msd_with(dir: &Path, structure: &str, duration_s: f64) -> PathBuf {
    let sim = manifest().join("examples/sim");
    std::fs::write(dir.join("physical.toml"), structure).unwrap();
    std::fs::copy(sim.join("msd-filter.json"), dir.join("msd-filter.json")).unwrap();
    let text = std::fs::read_to_string(sim.join("msd.toml"))
        .unwrap()
        .replace("file = \"msd-physical.toml\"", "file = \"physical.toml\"")
        .replace("duration_s = 20.0", &format!("duration_s = {duration_s}"))
        .replace(
            "analysis = \"../analyze/two-dof-small-actuator.toml\"",
            &format!(
                "analysis = {:?}",
                manifest()
                    .join("examples/analyze/two-dof-small-actuator.toml")
                    .display()
                    .to_string()
            ),
        );
    let path = dir.join("msd.toml");
    std::fs::write(&path, text).unwrap();
    path
}

fn refused(path: &Path) -> String {
    match check(path, None) {
        Ok(s) => panic!("accepted: {s}"),
        Err(e) => format!("{e:#}"),
    }
}

#[test]
fn every_shipped_file_is_recognised_and_valid() {
    let mut files = Vec::new();
    for dir in [
        "examples",
        "examples/sim",
        "examples/analyze",
        "../diagnose/examples",
        "../diagnose/data",
    ] {
        for entry in std::fs::read_dir(manifest().join(dir)).unwrap() {
            let path = entry.unwrap().path();
            let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
            if ["toml", "json", "csv"].contains(&ext) {
                files.push(path);
            }
        }
    }
    let mut kinds = std::collections::BTreeMap::new();
    for f in &files {
        let summary = check(f, None).unwrap_or_else(|e| panic!("{}: {e:#}", f.display()));
        eprintln!("{summary}");
        *kinds
            .entry(format!("{:?}", kind_of(f).unwrap()))
            .or_insert(0) += 1;
    }
    // Every kind is among them.
    assert_eq!(kinds.len(), 5, "{kinds:?}");
}

#[test]
fn a_tyre_stiffness_in_n_per_mm_is_refused_in_a_run_configuration() {
    let dir = scratch("tyre-n-per-mm");
    let path = dir.join("tyre.toml");
    let text = std::fs::read_to_string(manifest().join("examples/sim/tyre.toml"))
        .unwrap()
        .replace("stiffness_n_per_m = 2.5e5", "stiffness_n_per_m = 250.0")
        .replace("analysis = \"../analyze/tyre.toml\"", "");
    std::fs::write(&path, text).unwrap();
    let e = refused(&path);
    assert!(
        e.contains("tyre.stiffness_n_per_m") && e.contains("N/mm"),
        "{e}"
    );
}

#[test]
fn a_static_load_in_kg_is_refused_by_check_as_by_sim() {
    let dir = scratch("load-kg");
    let path = dir.join("tyre.toml");
    let text = std::fs::read_to_string(manifest().join("examples/sim/tyre.toml"))
        .unwrap()
        .replace("static_load_n = 1667.7", "static_load_n = 170.0")
        .replace("safe_demand = 1667.7", "safe_demand = 170.0")
        .replace("analysis = \"../analyze/tyre.toml\"", "");
    std::fs::write(&path, &text).unwrap();
    let e = refused(&path);
    assert!(e.contains("tyre.static_load_n") && e.contains("kg"), "{e}");
    // `mil sim` refuses it with the same message.
    let c = Config::from_toml(&text, &dir).unwrap();
    let sim = format!("{:#}", simulate(&c, |_| {}).err().unwrap());
    assert!(
        sim.contains("tyre.static_load_n") && sim.contains("kg"),
        "{sim}"
    );
}

#[test]
fn structure_unit_mistakes_are_refused_naming_the_field() {
    let dir = scratch("structure-units");
    let physical =
        std::fs::read_to_string(manifest().join("examples/sim/msd-physical.toml")).unwrap();
    let cases = [
        // The spring in N/mm: 2.5 m of static compression.
        (
            ("stiffness_n_per_m = 2.0e4", "stiffness_n_per_m = 20.0"),
            ["stiffness_n_per_m", "N/mm"],
        ),
        // The mass in g.
        (
            ("mass = 5.0 ", "mass = 5000.0 "),
            ["mass in g", "\"k_p, c_p to the bed\""],
        ),
        // The spring's preload stated in kg.
        (
            (
                "damping_n_s_per_m = 10.0",
                "damping_n_s_per_m = 10.0\npreload_n = 5.0",
            ),
            ["preload_n", "kg"],
        ),
    ];
    for ((from, to), needles) in cases {
        assert!(physical.contains(from), "{from}");
        let structure = dir.join("physical.toml");
        std::fs::write(&structure, physical.replacen(from, to, 1)).unwrap();
        let e = refused(&structure);
        for n in needles {
            assert!(e.contains(n), "{to}: {e}");
        }
        // The run configuration on it is refused as well, as `mil sim` refuses it.
        let config = msd_with(&dir, &physical.replacen(from, to, 1), 1.0);
        let e = refused(&config);
        assert!(e.contains("rig.structure"), "{e}");
    }
}

#[test]
fn a_record_in_mm_is_refused_against_its_structure() {
    let dir = scratch("record-mm");
    let physical =
        std::fs::read_to_string(manifest().join("examples/sim/msd-physical.toml")).unwrap();
    let config = msd_with(&dir, &physical, 4.0);
    let out = simulate(&Config::from_file(&config).unwrap(), |_| {}).unwrap();
    let record = dir.join("record.csv");
    out.write_csv(&record).unwrap();
    let structure = manifest().join("examples/sim/msd-physical.toml");
    check(&record, Some(&structure)).unwrap();
    // The position column in mm.
    let text = std::fs::read_to_string(&record).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap();
    let at = header
        .split(',')
        .position(|c| c == "mil_position_0")
        .unwrap();
    let mut mm = header.to_string() + "\n";
    for line in lines {
        let mut fields: Vec<String> = line.split(',').map(str::to_string).collect();
        fields[at] = format!("{:e}", fields[at].parse::<f64>().unwrap() * 1e3);
        mm += &(fields.join(",") + "\n");
    }
    let in_mm = dir.join("record-mm.csv");
    std::fs::write(&in_mm, mm).unwrap();
    let e = format!("{:#}", check(&in_mm, Some(&structure)).unwrap_err());
    assert!(
        e.contains("mil_position_0") && e.contains("mm for m") && e.contains("gain = 1e3"),
        "{e}"
    );
    // A record alone is valid: its scale needs the structure.
    check(&in_mm, None).unwrap();
}

#[test]
fn a_tracking_table_far_from_unity_gain_is_refused() {
    let dir = scratch("tracking-table");
    let table = |gain: f64| -> String {
        let mut t = "frequency_hz,magnitude,phase_deg\n".to_string();
        for k in 1..=1000 {
            let f = 0.5 * k as f64;
            // A first-order 60 Hz loop.
            let h = gain / (1.0 + (f / 60.0).powi(2)).sqrt();
            t += &format!("{f},{h},{}\n", -(f / 60.0).atan().to_degrees());
        }
        t
    };
    let setup = std::fs::read_to_string(manifest().join("examples/analyze/tyre.toml"))
        .unwrap()
        .replace(
            "tracking = \"reference\"",
            "tracking = { table = \"t.csv\" }",
        );
    let path = dir.join("setup.toml");
    std::fs::write(&path, setup).unwrap();
    std::fs::write(dir.join("t.csv"), table(1.0)).unwrap();
    assert_eq!(kind_of(&path).unwrap(), FileKind::Setup);
    check(&path, None).unwrap();
    // Demand in kN, response in N.
    std::fs::write(dir.join("t.csv"), table(1000.0)).unwrap();
    let e = refused(&path);
    assert!(e.contains("tracking table") && e.contains("kN"), "{e}");
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    /// Whatever `mil check` accepts, `mil sim` runs: masses, stiffnesses and dampings over
    /// many decades, with and without gravity.
    #[test]
    fn any_structure_check_accepts_runs_in_sim(
        log_mass in -3.0f64..4.0,
        log_stiffness in -2.0f64..9.0,
        damping in 0.0f64..2000.0,
        gravity in proptest::bool::ANY,
    ) {
        let dir = scratch("property");
        let physical =
            std::fs::read_to_string(manifest().join("examples/sim/msd-physical.toml")).unwrap();
        let structure = physical
            .replace("mass = 5.0 ", &format!("mass = {:e} ", 10f64.powf(log_mass)))
            .replace(
                "stiffness_n_per_m = 2.0e4",
                &format!("stiffness_n_per_m = {:e}", 10f64.powf(log_stiffness)),
            )
            .replace("damping_n_s_per_m = 10.0", &format!("damping_n_s_per_m = {damping:e}"))
            .replace(
                "gravity_m_per_s2 = 9.81\n",
                if gravity { "gravity_m_per_s2 = 9.81\n" } else { "" },
            );
        let config = msd_with(&dir, &structure, 0.25);
        if check(&config, None).is_ok() {
            let c = Config::from_file(&config).unwrap();
            let run = simulate(&c, |_| {});
            prop_assert!(run.is_ok(), "accepted but not run: {:#}", run.err().unwrap());
        }
    }
}

/// `mil sim … | head -1`: when stdout is closed early the command ends quietly with status
/// 0 instead of panicking on the broken pipe.
#[test]
fn a_closed_stdout_pipe_ends_quietly() {
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_mil"))
        .args(["sim", "--out"])
        .arg(scratch("pipe"))
        .arg(manifest().join("examples/sim/msd.toml"))
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // Closed long before the 20 s run has anything to print.
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(out.status.code(), Some(0), "{err}");
}
