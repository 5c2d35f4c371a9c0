//! `mil sim` with a general mass-spring-damper specimen: the shipped 2-DOF configuration
//! (`examples/sim/msd.toml`, model-core's substructure on the board, the physical mass on a
//! force-controlled actuator) against the analysis and against the emulated system, the
//! same rig without its command filter, `mil run` and `mil check` on it, and refused
//! configurations.

use mil::config::Config;
use mil::sim::{simulate, SimOutput};
use mil_analysis::setup::Setup;
use std::path::PathBuf;

fn examples() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("examples/sim")
}

/// `msd.toml` with its run shortened to `duration_s` and the replacements applied.
fn config(duration_s: f64, replace: &[(&str, &str)]) -> Config {
    let mut text = std::fs::read_to_string(examples().join("msd.toml")).unwrap();
    let original = "duration_s = 20.0";
    assert!(text.contains(original));
    text = text.replace(original, &format!("duration_s = {duration_s}"));
    for (from, to) in replace {
        assert!(text.contains(from), "{from}");
        text = text.replacen(from, to, 1);
    }
    Config::from_toml(&text, &examples()).unwrap()
}

fn run(duration_s: f64, replace: &[(&str, &str)]) -> SimOutput {
    simulate(&config(duration_s, replace), |_| {}).unwrap()
}

/// With the least-squares command filter the 2-DOF rig runs stably; the interface force
/// response estimated from 12 s of pink road agrees with `mil analyze`'s predictions for
/// the same rig (1 dB / 8° over 1–30 Hz, as for the tyre: Hann-windowed Welch at the
/// lightly damped 13.3 Hz mode sets the size; `tests/tests/msd_rig_vs_analysis.rs` checks the
/// rig itself to 0.1 dB / 1°), and the MiL rig is within 2 dB of the emulated system.
#[test]
fn msd_example_agrees_with_the_analysis() {
    let c = config(12.0, &[]);
    // The rig's actuator is the one the analysis set-up describes.
    let setup = Setup::read(&examples().join(c.compare.analysis.as_ref().unwrap())).unwrap();
    assert_eq!(c.rig.actuator, Some(setup.reference_actuator));
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
    let out = run(6.0, &[("filter = \"msd-filter.json\"", "")]);
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
        .args(["check", examples().join("msd.toml").to_str().unwrap()])
        .output()
        .unwrap();
    assert!(status.status.success(), "{status:?}");
    assert!(String::from_utf8_lossy(&status.stdout).contains("valid"));
    let out = mil::run(&config(4.0, &[]), |_| {}).unwrap();
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

/// Configurations the rig cannot run are refused with the reason, before running.
#[test]
fn bad_substructure_configurations_are_refused() {
    // The first error: parsing (unknown keys), then validation and the rig's checks.
    let error = |replace: &[(&str, &str)]| -> String {
        let mut text = std::fs::read_to_string(examples().join("msd.toml"))
            .unwrap()
            .replace("duration_s = 20.0", "duration_s = 1.0");
        for (from, to) in replace {
            assert!(text.contains(from), "{from}");
            text = text.replacen(from, to, 1);
        }
        let parsed = Config::from_toml(&text, &examples()).and_then(|c| simulate(&c, |_| {}));
        match parsed {
            Ok(_) => panic!("accepted {replace:?}"),
            Err(e) => format!("{e:#}"),
        }
    };
    // Structure files the rig cannot run, next to the configuration.
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("bad-substructure");
    std::fs::create_dir_all(&dir).unwrap();
    let physical = std::fs::read_to_string(examples().join("msd-physical.toml")).unwrap();
    let bad_structure = |name: &str, from: &str, to: &str| -> String {
        assert!(physical.contains(from), "{from}");
        let path = dir.join(name);
        std::fs::write(&path, physical.replacen(from, to, 1)).unwrap();
        format!("file = {:?}", path.display().to_string())
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
    let text = std::fs::read_to_string(&weightless_path).unwrap().replace(
        "damping_n_s_per_m = 10.0",
        "damping_n_s_per_m = 10.0\npreload_n = 49.05",
    );
    std::fs::write(&weightless_path, text).unwrap();
    // The mass on a post (a displacement input) instead of the bed.
    let on_post = bad_structure("post.toml", "lower = \"ground\"", "lower = \"post\"");
    let post_path = dir.join("post.toml");
    let text = std::fs::read_to_string(&post_path).unwrap()
        + "\n[[input]]\nname = \"post\"\nkind = \"displacement\"\ncolumn = \"road_0\"\n";
    std::fs::write(&post_path, text).unwrap();
    let file = "file = \"msd-physical.toml\"";
    let cases: &[(&[(&str, &str)], &str)] = &[
        (
            &[(file, &unbalanced)],
            "preload_n carry 40.0 N at dof \"x_p\", but its weight is 49.1 N",
        ),
        (&[(file, &weightless)], "not at rest"),
        (
            &[(file, &on_post)],
            "rig.structure.roads: say which run road the structure's input \"post\" follows",
        ),
        (
            &[
                (file, &on_post),
                (
                    "attach = [\"x_p\"]",
                    "attach = [\"x_p\"]\nroads = { post = \"road_1\" }",
                ),
            ],
            "post = \"road_1\": name the run's road input it follows, road_0 to road_0",
        ),
        (
            &[("attach = [\"x_p\"]", "attach = [\"x_q\"]")],
            "attachment \"x_q\" is no DOF or point",
        ),
        (
            &[("attach = [\"x_p\"]", "attached = [\"x_p\"]")],
            "unknown field `attached`",
        ),
        (&[(file, "file = \"missing.toml\"")], "rig.structure.file"),
        (&[("dof = \"x_n\"", "dof = \"x_m\"")], "no DOF \"x_m\""),
        (
            &[("mass = [[10.0]]", "mass = [[10.0, 0.0]]")],
            "substructure.mass must be 1 x 1",
        ),
        (
            &[("mass = [[10.0]]", "mass = [[-10.0]]")],
            "SubstructureMass",
        ),
        (
            &[("attach = [\"x_p\"]", "attach = [\"x_p\", \"x_p\"]")],
            "2 attachment(s)",
        ),
        (
            &[("analysis_inputs = [\"z_n\"]", "analysis_inputs = [\"z\"]")],
            "has no input \"z\" (inputs: [\"z_n\", \"z_p\"])",
        ),
        (
            &[("analysis_inputs = [\"z_n\"]", "")],
            "compare.analysis_inputs: name the inputs",
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
                "\n[limits]",
                "\n[speed]\nkind = \"constant\"\nspeed_m_per_s = 40.0\n\n[limits]",
            )],
            "[speed] is for the aero model",
        ),
    ];
    for (replace, expected) in cases {
        let e = error(replace);
        assert!(e.contains(expected), "{replace:?}: {e}");
    }
    // No physical specimen at all.
    let mut t = std::fs::read_to_string(examples().join("msd.toml")).unwrap();
    let start = t.find("[rig.structure]").unwrap();
    let end = t.find("[sensors]").unwrap();
    t.replace_range(start..end, "");
    let c = Config::from_toml(&t, &examples()).unwrap();
    let e = format!("{:#}", simulate(&c, |_| {}).err().unwrap());
    assert!(
        e.contains("needs the physical specimen on the rig: [rig.structure]"),
        "{e}"
    );
    // No channels.
    let start = t.find("[[substructure.channels]]").unwrap();
    let end = t.find("[limits]").unwrap();
    t.replace_range(start..end, "channels = []\n");
    let c = Config::from_toml(&t, &examples()).unwrap();
    let e = format!("{:#}", c.validate().unwrap_err());
    assert!(e.contains("substructure.channels: 0 given"), "{e}");
}
