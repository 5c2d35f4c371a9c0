//! `mil design-filter` end to end: the JSON figures, the filter file, the plots, and the
//! filter used by `mil analyze` through `[controller] filter`.

use std::path::PathBuf;
use std::process::Command;

fn example(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("examples")
        .join(name)
}

fn run_json(args: &[&str]) -> serde_json::Value {
    let out = Command::new(env!("CARGO_BIN_EXE_mil"))
        .args(args)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

/// The JSON fields are present and finite, the filter file loads (model-core's own
/// checks), the plots exist, and analysing the set-up with the exported filter gives the
/// same gain margin as the design reports (to 2 %: the design's margin grid is coarser).
#[test]
fn design_filter_writes_a_filter_that_analyze_uses() {
    let dir = tempfile::tempdir().unwrap();
    let filter = dir.path().join("tyre-filter.json");
    let json = run_json(&[
        "design-filter",
        example("tyre.toml").to_str().unwrap(),
        "--out",
        filter.to_str().unwrap(),
        "--json",
    ]);
    for key in [
        "phase_lag_reduction_pct",
        "magnitude_error_db",
        "noise_sensitivity_ratio",
        "gain_margin_with_filter",
    ] {
        assert!(
            json[key].as_f64().is_some_and(f64::is_finite),
            "{key}: {json}"
        );
    }
    assert_eq!(json["stability_with_filter"], "stable");
    let (file, cascade) = mil_analysis::filter_file::FilterFile::read(&filter).unwrap();
    assert_eq!(file.sample_rate_hz, 2000.0);
    assert_eq!(
        cascade.active().len(),
        json["sections"].as_u64().unwrap() as usize
    );
    for plot in [
        "tyre-filter.svg",
        "tyre-filter-response.svg",
        "tyre-filter-noise-sensitivity.svg",
    ] {
        assert!(dir.path().join(plot).is_file(), "{plot}");
    }

    // The same set-up with the filter, analysed.
    let text = std::fs::read_to_string(example("tyre.toml")).unwrap();
    let with_filter = text.replace(
        "sample_rate_hz = 2000.0",
        "sample_rate_hz = 2000.0\nfilter = \"tyre-filter.json\"",
    );
    assert_ne!(text, with_filter);
    let setup = dir.path().join("tyre-with-filter.toml");
    std::fs::write(&setup, with_filter).unwrap();
    std::fs::copy(
        example("tyre-physical.toml"),
        dir.path().join("tyre-physical.toml"),
    )
    .unwrap();
    let analysed = run_json(&[
        "analyze",
        setup.to_str().unwrap(),
        "--out",
        dir.path().join("analyze").to_str().unwrap(),
        "--json",
    ]);
    let (a, d) = (
        analysed["gain_margin"].as_f64().unwrap(),
        json["gain_margin_with_filter"].as_f64().unwrap(),
    );
    assert!((a - d).abs() < 0.02 * d, "analyze {a} vs design {d}");
    assert_eq!(analysed["stability"], "stable");
    // `--filter` gives the shipped set-up the same filter.
    let flagged = run_json(&[
        "analyze",
        example("tyre.toml").to_str().unwrap(),
        "--filter",
        dir.path().join("tyre-filter.json").to_str().unwrap(),
        "--out",
        dir.path().join("analyze-flag").to_str().unwrap(),
        "--json",
    ]);
    assert_eq!(flagged["gain_margin"], analysed["gain_margin"]);
    // The report says which filter and velocity estimate the figures are for.
    let elements = &analysed["mil_loop"];
    let filter = elements["filter"].as_str().unwrap();
    assert!(
        filter.contains("2 biquad section(s) at 2000 Hz"),
        "{filter}"
    );
    let velocity = elements["velocity"].as_str().unwrap();
    assert!(velocity.contains("low-pass 500 Hz"), "{velocity}");
    assert_eq!(elements["control"], "force");
    assert!((elements["loop_delay_s"].as_f64().unwrap() - 7.5e-4).abs() < 1e-12);
}

/// `--method optimal` reports the target and the front and writes the trade-off plot.
#[test]
fn optimal_method_reports_the_front_and_the_target() {
    let dir = tempfile::tempdir().unwrap();
    let filter = dir.path().join("opt.json");
    let json = run_json(&[
        "design-filter",
        example("tyre.toml").to_str().unwrap(),
        "--method",
        "optimal",
        "--weights",
        "0,0.5,0.9",
        "--out",
        filter.to_str().unwrap(),
        "--json",
    ]);
    assert_eq!(json["front"].as_array().unwrap().len(), 3);
    assert_eq!(json["target_met"], true);
    assert!(json["noise_sensitivity_ratio"].as_f64().unwrap() <= 10.0);
    // One label on the trade-off plot, the chosen design's (a label per point collided).
    let pareto = std::fs::read_to_string(dir.path().join("opt-pareto.svg")).unwrap();
    assert_eq!(pareto.matches("chosen: ").count(), 1, "{pareto}");
    assert!(!pareto.contains("w 0.50"), "per-point labels are back");
    // A second design in the same folder keeps its own plots beside the first's.
    let before = std::fs::read(dir.path().join("opt.svg")).unwrap();
    run_json(&[
        "design-filter",
        example("tyre.toml").to_str().unwrap(),
        "--out",
        dir.path().join("ls.json").to_str().unwrap(),
        "--json",
    ]);
    for plot in ["ls.svg", "ls-response.svg", "ls-noise-sensitivity.svg"] {
        assert!(dir.path().join(plot).exists(), "{plot}");
    }
    assert_eq!(std::fs::read(dir.path().join("opt.svg")).unwrap(), before);
}

/// Bad structures are refused with a message, and nothing is written.
#[test]
fn impossible_structure_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let filter = dir.path().join("bad.json");
    let out = Command::new(env!("CARGO_BIN_EXE_mil"))
        .args([
            "design-filter",
            example("tyre.toml").to_str().unwrap(),
            "--poles",
            "2",
            "--zeros",
            "2",
            "--out",
            filter.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("zeros < poles"));
    assert!(!filter.exists());
}

/// The shipped filter files are what `mil design-filter` writes for their set-ups today:
/// the same sections, their `sos` form, poles and zeros, and current figures (to 1e-9
/// relative: the figures are informative, recomputed by other code paths than the
/// coefficients); a change of the design or its figures shows here, not in a user's diff.
#[test]
fn the_shipped_filters_are_current() {
    let dir = tempfile::tempdir().unwrap();
    for (setup, shipped) in [
        ("tyre.toml", "tyre-filter.json"),
        ("aero.toml", "aero-filter.json"),
        ("two-dof.toml", "two-dof-filter.json"),
    ] {
        let out = dir.path().join(shipped);
        run_json(&[
            "design-filter",
            example(setup).to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--json",
        ]);
        let read = |p: &std::path::Path| -> serde_json::Value {
            serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
        };
        let (new, old) = (read(&out), read(&example(shipped)));
        assert_eq!(new["sections"], old["sections"], "{shipped}");
        assert!(old["sections"][0]["sos"].is_array(), "{shipped}: no sos");
        assert!(
            old["sections"][0]["poles"].is_array(),
            "{shipped}: no poles"
        );
        let figures = new["figures"].as_object().unwrap();
        assert_eq!(figures.len(), old["figures"].as_object().unwrap().len());
        for (key, value) in figures {
            match (value.as_f64(), old["figures"][key].as_f64()) {
                (Some(a), Some(b)) => assert!(
                    (a - b).abs() <= 1e-9 * a.abs().max(b.abs()),
                    "{shipped}: {key} {b}, today {a}: regenerate it with mil design-filter"
                ),
                _ => assert_eq!(value, &old["figures"][key], "{shipped}: {key}"),
            }
        }
    }
}
