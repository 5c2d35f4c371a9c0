//! `mil check FILE` on every kind of file: the shipped examples pass; each unit mistake of
//! issue 20 is refused with a message naming the field and the likely unit; and any
//! structure it accepts runs through `mil sim` (a property test over masses, stiffnesses,
//! dampings and gravity spanning ten decades), any set-up, filter file and record it accepts
//! runs through its commands.

use mil::check::{check, kind_of, FileKind};
use mil::setup::SetUp;
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

/// The 2-DOF set-up (`two-dof.toml`) written into `dir` with its physical structure
/// replaced by `structure` (text), `duration_s` long; returns the set-up's path.
fn two_dof_with(dir: &Path, structure: &str, duration_s: f64) -> PathBuf {
    let examples = manifest().join("examples");
    std::fs::write(dir.join("physical.toml"), structure).unwrap();
    for f in ["two-dof-filter.json", "two-dof-numerical.toml"] {
        std::fs::copy(examples.join(f), dir.join(f)).unwrap();
    }
    let text = std::fs::read_to_string(examples.join("two-dof.toml")).unwrap();
    let edited = text
        .replace(
            "structure = \"two-dof-physical.toml\"",
            "structure = \"physical.toml\"",
        )
        .replace("duration_s = 20.0", &format!("duration_s = {duration_s}"));
    assert_ne!(edited, text);
    let path = dir.join("two-dof.toml");
    std::fs::write(&path, edited).unwrap();
    path
}

/// `name` of the examples with `edits` made (each must apply), written into `dir` (with the
/// examples' files beside it).
fn example_with(dir: &Path, name: &str, edits: &[(&str, &str)]) -> PathBuf {
    let examples = manifest().join("examples");
    for entry in std::fs::read_dir(&examples).unwrap() {
        let path = entry.unwrap().path();
        std::fs::copy(&path, dir.join(path.file_name().unwrap())).unwrap();
    }
    let mut text = std::fs::read_to_string(examples.join(name)).unwrap();
    for (from, to) in edits {
        assert!(text.contains(from), "{name}: {from}");
        text = text.replace(from, to);
    }
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

/// `file` in `dir` with `edits` made (each must apply).
fn edit_in(dir: &Path, file: &str, edits: &[(&str, &str)]) {
    let path = dir.join(file);
    let mut text = std::fs::read_to_string(&path).unwrap();
    for (from, to) in edits {
        assert!(text.contains(from), "{file}: {from}");
        text = text.replace(from, to);
    }
    std::fs::write(&path, text).unwrap();
}

/// Runs the set-up at `path` through `mil analyze` (outputs into `dir`), `mil run` and
/// `mil sim`; the first failure, named.
fn runs_through_every_command(path: &Path, dir: &Path) -> Result<(), String> {
    let s = SetUp::read(path).map_err(|e| format!("read: {e:#}"))?;
    mil::analyze::run_analyze(&s, &dir.join("analyze")).map_err(|e| format!("analyze: {e:#}"))?;
    let run = s.run().map_err(|e| format!("run: {e:#}"))?;
    mil::run(&run, |_| {}).map_err(|e| format!("run: {e:#}"))?;
    let sim = s.sim().map_err(|e| format!("sim: {e:#}"))?;
    simulate(&sim, |_| {}).map_err(|e| format!("sim: {e:#}"))?;
    Ok(())
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
    for dir in ["examples", "../diagnose/examples", "../diagnose/data"] {
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
fn a_tyre_stiffness_in_n_per_mm_is_refused_in_a_set_up() {
    let dir = scratch("tyre-n-per-mm");
    let path = example_with(
        &dir,
        "tyre.toml",
        &[("stiffness_n_per_m = 2.5e5", "stiffness_n_per_m = 250.0")],
    );
    let e = refused(&path);
    assert!(
        e.contains("numerical.tyre.stiffness_n_per_m") && e.contains("N/mm"),
        "{e}"
    );
}

#[test]
fn a_static_load_in_kg_is_refused_by_check_as_by_sim() {
    let dir = scratch("load-kg");
    let path = example_with(
        &dir,
        "tyre.toml",
        &[
            (
                "# static_load_n: the hub actuator's static_n",
                "static_load_n = 170.0\n# the hub actuator's static_n",
            ),
            ("safe_demand = 1667.7", "safe_demand = 170.0"),
        ],
    );
    let e = refused(&path);
    assert!(
        e.contains("numerical.tyre.static_load_n") && e.contains("kg"),
        "{e}"
    );
    // `mil sim` refuses it with the same message.
    let sim = match SetUp::read(&path).unwrap().sim() {
        Ok(c) => format!("{:#}", simulate(&c, |_| {}).err().unwrap()),
        Err(e) => format!("{e:#}"),
    };
    assert!(
        sim.contains("numerical.tyre.static_load_n") && sim.contains("kg"),
        "{sim}"
    );
}

#[test]
fn structure_unit_mistakes_are_refused_naming_the_field() {
    let dir = scratch("structure-units");
    let physical =
        std::fs::read_to_string(manifest().join("examples/two-dof-physical.toml")).unwrap();
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
        // The set-up on it is refused as well, as `mil sim` refuses it.
        let config = two_dof_with(&dir, &physical.replacen(from, to, 1), 1.0);
        let e = refused(&config);
        assert!(e.contains("physical"), "{e}");
    }
}

#[test]
fn a_record_in_mm_is_refused_against_its_structure() {
    let dir = scratch("record-mm");
    let record = dir.join("record.csv");
    std::fs::write(&record, two_dof_record()).unwrap();
    let structure = manifest().join("examples/two-dof-physical.toml");
    check(&record, Some(&structure)).unwrap();
    // The position column in mm.
    let text = std::fs::read_to_string(&record).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap();
    let at = header
        .split(',')
        .position(|c| c == "mil_position_0 [m]")
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
    let path = example_with(
        &dir,
        "tyre.toml",
        &[(
            "control = \"force\"",
            "control = \"force\"\ntracking = { table = \"t.csv\" }",
        )],
    );
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
            std::fs::read_to_string(manifest().join("examples/two-dof-physical.toml")).unwrap();
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
        let config = two_dof_with(&dir, &structure, 0.25);
        if check(&config, None).is_ok() {
            let c = SetUp::read(&config).unwrap().sim().unwrap();
            let run = simulate(&c, |_| {});
            prop_assert!(run.is_ok(), "accepted but not run: {:#}", run.err().unwrap());
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    /// Whatever tyre set-up `mil check` accepts, `mil analyze`, `mil run` and `mil sim` run:
    /// tyre, masses, suspension, rate, cut-off, static load and filter drawn over wide
    /// ranges (many of them implausible, which check must then refuse).
    #[test]
    fn any_set_up_check_accepts_runs_through_every_command(
        log_k_t in 2.0f64..8.0,
        c_t in 0.0f64..5000.0,
        sprung in 1.0f64..1000.0,
        unsprung in 1.0f64..200.0,
        log_k_c in 3.0f64..7.0,
        rate in prop::sample::select(vec![500.0, 2000.0, 5000.0]),
        cutoff in 0.0f64..2000.0,
        load_factor in prop::sample::select(vec![None, None, Some(1.0), Some(1.3), Some(1.0 / 9.81)]),
        filter in proptest::bool::ANY,
    ) {
        let dir = scratch("property-set-up");
        let weight = (sprung + unsprung) * 9.81;
        let load = match load_factor {
            Some(f) => format!("static_load_n = {:e}\n", weight * f),
            None => String::new(),
        };
        let path = example_with(&dir, "tyre.toml", &[
            ("stiffness_n_per_m = 2.5e5", &format!("stiffness_n_per_m = {:e}", 10f64.powf(log_k_t))),
            ("damping_n_s_per_m = 500.0", &format!("damping_n_s_per_m = {c_t:e}")),
            ("velocity_cutoff_hz = 500.0", &format!("velocity_cutoff_hz = {cutoff:e}\n{load}")),
            ("sample_rate_hz = 2000.0", &format!("sample_rate_hz = {rate:e}")),
            ("safe_demand = 1667.7", &format!("safe_demand = {weight:e}")),
            // The shipped filter is for 2 kHz (at another rate check refuses it, rightly).
            ("# filter = \"tyre-filter.json\"", if filter && rate == 2000.0 { "filter = \"tyre-filter.json\"" } else { "" }),
            ("duration_s = 20.0", "duration_s = 0.25"),
        ]);
        edit_in(&dir, "tyre-physical.toml", &[
            ("mass = 150.0", &format!("mass = {sprung:e}")),
            ("mass = 20.0", &format!("mass = {unsprung:e}")),
            ("stiffness_n_per_m = 1.2e5", &format!("stiffness_n_per_m = {:e}", 10f64.powf(log_k_c))),
            ("static_n = 1667.7", &format!("static_n = {weight:e}")),
        ]);
        if check(&path, None).is_ok() {
            let ran = runs_through_every_command(&path, &dir);
            prop_assert!(ran.is_ok(), "{}", ran.err().unwrap_or_default());
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    /// Whatever command-filter file `mil check` accepts, a set-up at its rate runs with it
    /// through `mil analyze`, `mil run` and `mil sim`: the shipped tyre filter with its
    /// coefficients scaled over two decades either way, signs flipped, sections dropped and
    /// its rate changed (many of them unstable or inconsistent, which check must refuse).
    #[test]
    fn any_filter_check_accepts_runs_through_every_command(
        scales in prop::collection::vec(prop::sample::select(vec![1.0, 1.0, 0.1, 0.5, 2.0, 10.0, -1.0]), 10),
        keep in 1usize..=2,
        rate in prop::sample::select(vec![500.0, 2000.0, 5000.0]),
    ) {
        let dir = scratch("property-filter");
        let shipped = std::fs::read_to_string(manifest().join("examples/tyre-filter.json")).unwrap();
        let mut json: serde_json::Value = serde_json::from_str(&shipped).unwrap();
        json["sample_rate_hz"] = serde_json::json!(rate);
        let sections = json["sections"].as_array_mut().unwrap();
        sections.truncate(keep);
        for (k, section) in sections.iter_mut().enumerate() {
            for (j, key) in ["beta0", "beta1", "beta2", "alpha1", "alpha2"].iter().enumerate() {
                let v = section[*key].as_f64().unwrap() * scales[(5 * k + j) % scales.len()];
                section[*key] = serde_json::json!(v);
            }
        }
        let filter = dir.join("filter.json");
        std::fs::write(&filter, serde_json::to_string_pretty(&json).unwrap()).unwrap();
        if check(&filter, None).is_ok() {
            let path = example_with(&dir, "tyre.toml", &[
                ("sample_rate_hz = 2000.0", &format!("sample_rate_hz = {rate:e}")),
                ("# filter = \"tyre-filter.json\"", "filter = \"filter.json\""),
                ("duration_s = 20.0", "duration_s = 0.25"),
            ]);
            let ran = runs_through_every_command(&path, &dir);
            prop_assert!(ran.is_ok(), "{}", ran.err().unwrap_or_default());
        }
    }
}

/// A 4 s `mil sim` record of the 2-DOF set-up (CSV text), made once.
fn two_dof_record() -> &'static str {
    static RECORD: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    RECORD.get_or_init(|| {
        let dir = scratch("record-source");
        let physical =
            std::fs::read_to_string(manifest().join("examples/two-dof-physical.toml")).unwrap();
        let config = two_dof_with(&dir, &physical, 4.0);
        let out = simulate(&SetUp::read(&config).unwrap().sim().unwrap(), |_| {}).unwrap();
        let record = dir.join("record.csv");
        out.write_csv(&record).unwrap();
        std::fs::read_to_string(&record).unwrap()
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 12, ..ProptestConfig::default() })]

    /// Whatever record `mil check --against` a structure accepts, `mil diagnose` runs on:
    /// a `mil sim` record rewritten as DAQ exports look (separators, `time [s]`-style
    /// headers, times rounded to a few decimals or jittered by a fraction of a sample),
    /// shortened, or with a column scaled 1000x (many of them off, which check must refuse).
    #[test]
    fn any_record_check_accepts_runs_through_diagnose(
        separator in prop::sample::select(vec![",", ";", "\t"]),
        time_header in prop::sample::select(vec!["time", "time [s]", "t (s)", "Time_s"]),
        decimals in prop::sample::select(vec![None, Some(3usize), Some(4), Some(6)]),
        jitter in prop::sample::select(vec![0.0, 0.0, 0.05, 0.3, 0.7]),
        seconds in prop::sample::select(vec![4.0, 1.0, 0.2, 0.02]),
        scale in prop::sample::select(vec![1.0, 1.0, 1e3, 1e-3]),
        seed in any::<u64>(),
    ) {
        let dir = scratch("property-record");
        let text = two_dof_record();
        let mut lines = text.lines();
        let header: Vec<&str> = lines.next().unwrap().split(',').collect();
        let force = header.iter().position(|c| *c == "mil_force_0 [N]").unwrap();
        let dt = 1.0 / 2000.0;
        let mut rng = mil_numerics::rng::SplitMix64::new(seed);
        let mut out = std::iter::once(time_header)
            .chain(header[1..].iter().copied())
            .collect::<Vec<_>>()
            .join(separator)
            + "\n";
        for line in lines.take((seconds / dt) as usize) {
            let mut fields: Vec<String> = line.split(',').map(str::to_string).collect();
            let t = fields[0].parse::<f64>().unwrap() + jitter * dt * (rng.uniform() - 0.5);
            fields[0] = match decimals {
                Some(d) => format!("{t:.d$}"),
                None => format!("{t:e}"),
            };
            fields[force] = format!("{:e}", fields[force].parse::<f64>().unwrap() * scale);
            out += &(fields.join(separator) + "\n");
        }
        let record = dir.join("record.csv");
        std::fs::write(&record, out).unwrap();
        let structure = manifest().join("examples/two-dof-physical.toml");
        if check(&record, Some(&structure)).is_ok() {
            let request = mil::diagnose::DiagnoseRequest {
                model: structure,
                data: record,
                out: dir.join("diagnose"),
                tyre: None,
            };
            let ran = mil::diagnose::run_diagnose(&request, &|_, _| {});
            prop_assert!(ran.is_ok(), "accepted but not diagnosed: {:#}", ran.err().unwrap());
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
        .arg(manifest().join("examples/two-dof.toml"))
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
