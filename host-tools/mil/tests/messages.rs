//! What `mil` says when a file is missing, for every command that reads one: one line
//! `Error: ...` naming the file, the operating system's reason once (not "...(os error 2):
//! ...(os error 2)"), exit status 1, no panic.

mod common;

#[test]
fn a_missing_file_is_named_once_with_its_reason_once() {
    let dir = tempfile::tempdir().unwrap();
    // The operating system's own text for a missing file.
    let reason = std::fs::File::open(dir.path().join("nothing"))
        .unwrap_err()
        .to_string();
    let port = ["--port", "tcp:127.0.0.1:1"];
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["sim", "gone.toml"], "gone.toml"),
        (vec!["run", "gone.toml"], "gone.toml"),
        (vec!["analyze", "gone.toml"], "gone.toml"),
        (vec!["design-filter", "gone.toml"], "gone.toml"),
        (vec!["actuator-test", "gone.toml"], "gone.toml"),
        (vec!["check", "gone.csv"], "gone.csv"),
        (
            vec![
                "identify", "--data", "gone.csv", "--input", "u", "--output", "y",
            ],
            "gone.csv",
        ),
        (vec!["compare", "gone.csv"], "gone.csv"),
        (
            vec!["diagnose", "--model", "gone.toml", "--data", "gone.csv"],
            "gone.toml",
        ),
        (
            vec!["a2l", "--elf", "gone.elf", "--out", "x.a2l"],
            "gone.elf",
        ),
        (
            [
                &["filter", "upload", "gone.json", "--a2l", "gone.a2l"][..],
                &port,
            ]
            .concat(),
            "gone",
        ),
        (
            [&["param", "set", "--a2l", "gone.a2l", "k_t=1"][..], &port].concat(),
            "gone.a2l",
        ),
        (
            [
                &[
                    "daq",
                    "record",
                    "--a2l",
                    "gone.a2l",
                    "--signals",
                    "road",
                    "--out",
                    "d.csv",
                ][..],
                &port,
            ]
            .concat(),
            "gone.a2l",
        ),
    ];
    for (args, file) in cases {
        let (code, stdout, stderr) = common::mil_in(dir.path(), &args);
        assert_eq!(code, Some(1), "mil {args:?}: {stdout}{stderr}");
        let line = stderr.trim_end();
        assert!(
            line.starts_with("Error: ") && !line.contains('\n'),
            "mil {args:?}: {stderr}"
        );
        assert!(
            line.contains(file),
            "mil {args:?} does not name {file}: {line}"
        );
        assert_eq!(
            line.matches(reason.as_str()).count(),
            1,
            "mil {args:?}: the reason once: {line}"
        );
    }
}

/// What the tools print names things in words, never Rust's names for them: a refused
/// filter is "command filter: unstable", not `Unstable(CommandFilter)`; the design method
/// and a loop's stability in lower-case words, not `Ls` / `Stable` / `Unstable(2)`.
#[test]
fn no_internal_type_names_reach_the_user() {
    let dir = tempfile::tempdir().unwrap();
    let examples = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("examples");
    let mut filter: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(examples.join("tyre-filter.json")).unwrap())
            .unwrap();
    // A section with both poles outside the unit circle (its delta form only).
    let section = filter["sections"][0].as_object_mut().unwrap();
    section.retain(|key, _| key.starts_with("alpha") || key.starts_with("beta"));
    section.insert("alpha1".into(), (-3.0).into());
    section.insert("alpha2".into(), (-2.0).into());
    std::fs::write(dir.path().join("bad.json"), filter.to_string()).unwrap();
    let tyre = examples.join("tyre.toml");
    let tyre = tyre.to_str().unwrap();
    let internal = ["Unstable(", "CommandFilter", "Stable", "Unknown", "(Ls"];
    let clean = |text: &str| !internal.iter().any(|n| text.contains(n));
    for args in [
        vec!["check", "bad.json"],
        vec!["sim", tyre, "--filter", "bad.json", "--duration", "1"],
        vec!["analyze", tyre, "--filter", "bad.json"],
    ] {
        let (code, stdout, stderr) = common::mil_in(dir.path(), &args);
        assert_eq!(code, Some(1), "mil {args:?}: {stdout}");
        assert!(
            stderr.contains("command filter: unstable") && clean(&stderr),
            "mil {args:?}: {stderr}"
        );
    }
    let (code, stdout, stderr) =
        common::mil_in(dir.path(), &["design-filter", tyre, "--out", "f.json"]);
    assert_eq!(code, Some(0), "{stderr}");
    assert!(
        stdout.contains("(least squares, 2 sections")
            && stdout.contains("closed loop with filter: stable")
            && clean(&stdout),
        "{stdout}"
    );
    let two_dof = examples.join("two-dof-hub-actuator.toml");
    let (_, stdout, _) = common::mil_in(dir.path(), &["analyze", two_dof.to_str().unwrap()]);
    assert!(
        stdout.contains("unstable (2)") && clean(&stdout),
        "{stdout}"
    );
}

/// A measured disturbance table was taken and then failed deep in the analysis ("0.5 Hz is
/// outside the table's frequency range", naming neither the table nor the fix); it is
/// refused when the set-up is read, naming the key, the file, its band and what to give.
#[test]
fn a_disturbance_table_is_refused_naming_the_key_and_the_fix() {
    let dir = tempfile::tempdir().unwrap();
    let examples = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("examples");
    for file in ["tyre-physical.toml", "tyre-tracking.csv"] {
        std::fs::copy(examples.join(file), dir.path().join(file)).unwrap();
    }
    std::fs::copy(
        examples.join("tyre-tracking.csv"),
        dir.path().join("compliance.csv"),
    )
    .unwrap();
    let setup = std::fs::read_to_string(examples.join("tyre-board.toml")).unwrap();
    let line = "tracking = { table = \"tyre-tracking.csv\" }";
    assert!(setup.contains(line));
    let setup = setup.replace(
        line,
        &format!("{line}\ndisturbance = {{ table = \"compliance.csv\" }}"),
    );
    std::fs::write(dir.path().join("rig.toml"), setup).unwrap();
    for command in ["analyze", "design-filter", "sim", "check"] {
        let (code, _, stderr) = common::mil_in(dir.path(), &[command, "rig.toml"]);
        assert_eq!(code, Some(1), "{command}: {stderr}");
        for part in [
            "actuator.disturbance",
            "compliance.csv",
            "0.73-175.3 Hz",
            "numerator",
        ] {
            assert!(stderr.contains(part), "{command}: {part}: {stderr}");
        }
    }
}
