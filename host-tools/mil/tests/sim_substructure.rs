//! `mil sim` with a general mass-spring-damper specimen: the shipped 2-DOF set-up
//! (`examples/two-dof.toml`, model-core's substructure on the board, the physical mass on a
//! force-controlled actuator) against the set-up's analysis and against the emulated system,
//! the same rig without its command filter, `mil run` and `mil check` on it, and refused
//! set-ups.

use mil::config::Config;
use mil::setup::SetUp;
use mil::sim::{simulate, SimOutput};
use std::path::PathBuf;

fn examples() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("examples")
}

/// `two-dof.toml`'s text with its run shortened to `duration_s` and the replacements applied
/// (each must be present).
fn text(duration_s: f64, replace: &[(&str, &str)]) -> String {
    let mut text = std::fs::read_to_string(examples().join("two-dof.toml")).unwrap();
    let original = "duration_s = 20.0";
    assert!(text.contains(original));
    text = text.replace(original, &format!("duration_s = {duration_s}"));
    for (from, to) in replace {
        assert!(text.contains(from), "{from}");
        text = text.replacen(from, to, 1);
    }
    text
}

/// [`text`] as `mil sim` runs it: the set-up's analysis attached.
fn config(duration_s: f64, replace: &[(&str, &str)]) -> Config {
    SetUp::from_toml(&text(duration_s, replace), &examples())
        .unwrap()
        .sim()
        .unwrap()
}

fn run(duration_s: f64, replace: &[(&str, &str)]) -> SimOutput {
    simulate(&config(duration_s, replace), |_| {}).unwrap()
}

/// With the least-squares command filter the 2-DOF rig runs stably; the interface force
/// response estimated from 12 s of pink road agrees with `mil analyze`'s predictions for
/// the same rig (1 dB / 8° over 1–30 Hz, as for the tyre: Hann-windowed Welch at the
/// lightly damped 13.3 Hz mode sets the size, 2 s segments asked for, where the default
/// rule takes 1 s for a 12 s run; `tests/tests/msd_rig_vs_analysis.rs` checks the rig itself
/// to 0.1 dB / 1°), and the MiL rig is within 2 dB of the emulated system.
#[test]
fn msd_example_agrees_with_the_analysis() {
    let c = config(12.0, &[("[compare]", "[compare]\nsegment = 4096")]);
    // The rig's actuator is the one the analysis describes.
    let analysis = c.analysis.as_ref().unwrap();
    assert_eq!(c.rig.actuator, Some(analysis.reference_actuator));
    assert_eq!(c.analysis_inputs, ["z_n"]);
    let out = simulate(&c, |_| {}).unwrap();
    let s = &out.summary;
    eprintln!("{}", out.table());
    assert_eq!(s.model, "substructure");
    assert_eq!((s.channels, s.samples, s.filter_sections), (1, 24_000, 2));
    assert_eq!((s.fault_at_s, s.speed_m_per_s), (None, None));
    assert_eq!(s.links.frames, 3 * 24_000);
    let r = s.response.as_ref().unwrap();
    assert_eq!(r.name, "interface force / road, channel 0");
    assert!(r.bins > 40, "{r:?}");
    let (mil, emu) = (r.mil_vs_analysis.unwrap(), r.emulated_vs_analysis.unwrap());
    assert!(mil.db < 1.0 && mil.deg < 8.0, "{mil:?}");
    assert!(emu.db < 1.0 && emu.deg < 8.0, "{emu:?}");
    assert!(r.mil_vs_emulated.unwrap().db < 2.0, "{r:?}");
    let c0 = &s.channel[0];
    assert!(c0.force_in_band.nrms_error_pct.unwrap() < 30.0, "{c0:?}");
    assert!(c0.position_in_band.delay_ms.unwrap().abs() < 2.0, "{c0:?}");
    assert_eq!(out.road_names, ["road_0"]);
}

/// Without the command filter the analysis finds this MiL loop unstable (two poles, gain
/// margin 0.82 at 12.9 Hz); on the rig the physical mass ends up in a large oscillation
/// near that frequency, several times the emulated system's motion.
#[test]
fn without_the_filter_the_msd_rig_oscillates_as_the_analysis_predicts() {
    let out = run(6.0, &[("filter = \"two-dof-filter.json\"", "")]);
    let s = &out.summary;
    eprintln!("{}", out.table());
    assert_eq!(s.filter_sections, 0);
    let c0 = &s.channel[0];
    assert!(
        c0.position_in_band.nrms_error_pct.unwrap() > 100.0,
        "{c0:?}"
    );
    // The growth: the last second's MiL motion far exceeds the first second's.
    let y = &out.histories.mil_position[0];
    let rms = |v: &[f64]| (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt();
    let (early, late) = (rms(&y[1000..3000]), rms(&y[10_000..]));
    assert!(late > 3.0 * early, "{early} -> {late}");
}

/// `mil check` accepts the example; `mil run` drives its substructure open-loop on a rigid
/// rig (the physical mass held at 0): the demand is then `B_i x_n` with `x_n` on its road.
#[test]
fn check_and_open_loop_run_accept_the_example() {
    let status = std::process::Command::new(env!("CARGO_BIN_EXE_mil"))
        .args(["check", examples().join("two-dof.toml").to_str().unwrap()])
        .output()
        .unwrap();
    assert!(status.status.success(), "{status:?}");
    assert!(String::from_utf8_lossy(&status.stdout).contains("valid"));
    let c = SetUp::from_toml(&text(4.0, &[]), &examples())
        .unwrap()
        .run()
        .unwrap();
    let out = mil::run(&c, |_| {}).unwrap();
    assert_eq!((out.summary.channels, out.summary.fault_at_s), (1, None));
    assert!(out.speed.is_none());
    // Static check at low frequency: held still, m_n on k_n + k_i from its road gives
    // F = k_i x_n ≈ k_i k_n / (k_n + k_i) z = 8000 z (N/m) below the 11 Hz mode.
    let d: Vec<f64> = out.demand.iter().map(|d| d[0]).collect();
    let z: Vec<f64> = out.road.iter().map(|z| z[0]).collect();
    let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
    let gain = dot(&d[2000..], &z[2000..]) / dot(&z[2000..], &z[2000..]);
    assert!((6000.0..12_000.0).contains(&gain), "{gain}");
}

/// Set-ups the rig cannot run are refused with the reason, before running.
#[test]
fn bad_substructure_configurations_are_refused() {
    // The first error: parsing (unknown keys), then building the run and the analysis,
    // validation and the rig's checks.
    let error = |replace: &[(&str, &str)]| -> String {
        let parsed = SetUp::from_toml(&text(1.0, replace), &examples())
            .and_then(|s| s.sim())
            .and_then(|c| simulate(&c, |_| {}));
        match parsed {
            Ok(_) => panic!("accepted {replace:?}"),
            Err(e) => format!("{e:#}"),
        }
    };
    // Structure files the rig or the board cannot run, next to the set-up.
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("bad-substructure");
    std::fs::create_dir_all(&dir).unwrap();
    let write = |name: &str, contents: String| -> String {
        let path = dir.join(name);
        std::fs::write(&path, contents).unwrap();
        format!("{:?}", path.display().to_string())
    };
    let physical = std::fs::read_to_string(examples().join("two-dof-physical.toml")).unwrap();
    let bad_structure = |name: &str, from: &str, to: &str| -> String {
        assert!(physical.contains(from), "{from}");
        format!(
            "structure = {}",
            write(name, physical.replacen(from, to, 1))
        )
    };
    // Its spring holding a preload that does not carry the mass (40 N of 49.05 N).
    let unbalanced = bad_structure(
        "unbalanced.toml",
        "damping_n_s_per_m = 10.0",
        "damping_n_s_per_m = 10.0\npreload_n = 40.0",
    );
    // No gravity, and a preload: not at rest with zero actuator force.
    let weightless = bad_structure("weightless.toml", "gravity_m_per_s2 = 9.81\n", "");
    let weightless_path = dir.join("weightless.toml");
    let edited = std::fs::read_to_string(&weightless_path).unwrap().replace(
        "damping_n_s_per_m = 10.0",
        "damping_n_s_per_m = 10.0\npreload_n = 49.05",
    );
    std::fs::write(&weightless_path, edited).unwrap();
    // The mass on a post (a displacement input) instead of the bed.
    let on_post = bad_structure("post.toml", "lower = \"ground\"", "lower = \"post\"");
    let post_path = dir.join("post.toml");
    let edited = std::fs::read_to_string(&post_path).unwrap()
        + "\n[[input]]\nname = \"post\"\nkind = \"displacement\"\ncolumn = \"road_0\"\n";
    std::fs::write(&post_path, edited).unwrap();
    // A numerical mass below zero.
    let numerical = std::fs::read_to_string(examples().join("two-dof-numerical.toml")).unwrap();
    let from = "mass = 10.0";
    assert!(numerical.contains(from));
    let negative = format!(
        "structure = {}",
        write("negative.toml", numerical.replacen(from, "mass = -10.0", 1))
    );
    let file = "structure = \"two-dof-physical.toml\"";
    let numerical_file = "structure = \"two-dof-numerical.toml\"";
    let cases: &[(&[(&str, &str)], &str)] = &[
        (
            &[(file, &unbalanced)],
            "preload_n carry 40.0 N at dof \"x_p\", but the static load there is 49.1 N",
        ),
        (&[(file, &weightless)], "not at rest"),
        (
            &[(file, &on_post)],
            "physical.roads: say which run road the structure's input \"post\" follows",
        ),
        (
            &[
                (file, &on_post),
                (
                    "\n[[interface.channels]]",
                    "roads = { post = \"road_1\" }\n\n[[interface.channels]]",
                ),
            ],
            "post = \"road_1\": name the run's road it follows, road_0 to road_0",
        ),
        // The analysis finds it first; the rig's own check is below.
        (
            &[("physical = \"x_p\"", "physical = \"x_q\"")],
            "no DOF or point \"x_q\"",
        ),
        (
            &[(
                "physical = \"x_p\"",
                "physical = \"x_p\"\nattached = \"x_p\"",
            )],
            "unknown field `attached`",
        ),
        // The analysis finds it first; the rig's own check is below.
        (
            &[(file, "structure = \"missing.toml\"")],
            "physical.structure: ",
        ),
        // The analysis finds it first; the board's own check is below.
        (
            &[("numerical = \"x_n\"", "numerical = \"x_m\"")],
            "no DOF or point \"x_m\"",
        ),
        (&[(numerical_file, &negative)], "mass must be > 0, got -10"),
        (
            &[(
                "roads = { z_n = \"road_0\" }",
                "roads = { z_n = \"fixed\" }",
            )],
            "no input of the analysis follows the run's road_0",
        ),
        (
            &[(
                "velocity_cutoff_hz = 0.0",
                "velocity_cutoff_hz = 0.0\ncausality = 1",
            )],
            "unknown field `causality`",
        ),
        (
            &[(
                "road = { kind = \"pink\"",
                "speed = { kind = \"constant\", speed_m_per_s = 40.0 }\nroad = { kind = \"pink\"",
            )],
            "excitation.speed is for the aero model",
        ),
    ];
    for (replace, expected) in cases {
        let e = error(replace);
        assert!(e.contains(expected), "{replace:?}: {e}");
    }
    // The rig refuses an attachment that is no DOF or point of the physical structure, and
    // a missing structure file, on its own (the run without the analysis).
    let c = SetUp::from_toml(
        &text(1.0, &[("physical = \"x_p\"", "physical = \"x_q\"")]),
        &examples(),
    )
    .unwrap()
    .run()
    .unwrap();
    let e = format!("{:#}", simulate(&c, |_| {}).err().unwrap());
    assert!(e.contains("attachment \"x_q\" is no DOF or point"), "{e}");
    let c = SetUp::from_toml(
        &text(1.0, &[(file, "structure = \"missing.toml\"")]),
        &examples(),
    )
    .unwrap()
    .run()
    .unwrap();
    let e = format!("{:#}", simulate(&c, |_| {}).err().unwrap());
    assert!(
        e.contains("physical.structure") && e.contains("missing.toml"),
        "{e}"
    );
    // The board refuses an interface on a DOF its substructure does not have.
    let c = SetUp::from_toml(
        &text(1.0, &[("numerical = \"x_n\"", "numerical = \"x_m\"")]),
        &examples(),
    )
    .unwrap()
    .run()
    .unwrap();
    let e = format!("{:#}", c.validate().unwrap_err());
    assert!(e.contains("interface.channels[0]: no DOF \"x_m\""), "{e}");
    // No physical part, or an empty one: the reason, naming the table.
    let mut t = std::fs::read_to_string(examples().join("two-dof.toml")).unwrap();
    let start = t.find("[physical]").unwrap();
    let end = t.find("[[interface.channels]]").unwrap();
    for (part, expected) in [
        ("", "[physical]: give the structure on the rig"),
        (
            "[physical]\n\n",
            "[physical]: give the structure on the rig",
        ),
    ] {
        let mut edited = t.clone();
        edited.replace_range(start..end, part);
        let e = format!(
            "{:#}",
            SetUp::from_toml(&edited, &examples())
                .and_then(|s| s.sim())
                .err()
                .unwrap()
        );
        assert!(e.contains(expected), "{e}");
    }
    // No channels (and so no road for the numerical input).
    let start = t.find("[[interface.channels]]").unwrap();
    let end = t.find("# A small servo-hydraulic force actuator").unwrap();
    t.replace_range(start..end, "[interface]\nchannels = []\n\n");
    let fixed = t.replace(
        "roads = { z_n = \"road_0\" }",
        "roads = { z_n = \"fixed\" }",
    );
    assert_ne!(fixed, t);
    let c = SetUp::from_toml(&fixed, &examples())
        .unwrap()
        .run()
        .unwrap();
    let e = format!("{:#}", c.validate().unwrap_err());
    assert!(e.contains("interface.channels: 0 given"), "{e}");
}

/// `mil check` states what the board's bus budget says of a set-up: the two-DOF example
/// (one channel at 2 kHz) fits one bus; the tyre example (four wheels) at 2 kHz would be
/// refused, with the highest rate the board runs it at. By hand: two channels on the
/// busier of the two buses, 125 + 115 worst-case bits (7- and 6-byte frames) each per
/// sample, plus 10 Hz of 135-bit heartbeat and 50 kbit/s kept for XCP, within 60 % of
/// 1 Mbit/s: (600 000 - 1 350 - 50 000) / 480 = 1143 Hz.
#[test]
fn check_states_the_bus_budget() {
    let check = |file: &str| {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_mil"))
            .args(["check", examples().join(file).to_str().unwrap()])
            .output()
            .unwrap();
        assert!(out.status.success(), "{out:?}");
        String::from_utf8_lossy(&out.stdout).into_owned()
    };
    let fits = check("two-dof.toml");
    assert!(fits.contains("% of one 1 Mbit/s bus at 2000 Hz"), "{fits}");
    let refused = check("tyre.toml");
    assert!(
        refused.contains("the board would refuse it at 2000 Hz")
            && refused.contains("up to 1143 Hz"),
        "{refused}"
    );
}
