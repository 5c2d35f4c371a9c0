//! The model file: the paper's examples and a one-DOF oscillator are expressible, unknown
//! keys and names are errors, the updated model writes back and reads again.

use mil_diagnose::model::{OutputKind, Target};
use mil_diagnose::simulate::{prepare_inputs, simulate};
use mil_diagnose::{EffectKind, Model, Record};
use std::path::PathBuf;

fn example(name: &str) -> Model {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("examples")
        .join(name);
    Model::read(&p).unwrap_or_else(|e| panic!("{name}: {e}"))
}

#[test]
fn every_example_reads_and_round_trips() {
    for name in [
        "oscillator.toml",
        "quarter-car.toml",
        "half-car.toml",
        "emps.toml",
        "silverbox.toml",
        "boucwen.toml",
    ] {
        let m = example(name);
        let back = Model::from_toml(&m.to_toml()).unwrap();
        assert_eq!(back.to_file(), m.to_file(), "{name}");
    }
}

#[test]
fn paper_examples_have_the_paper_structure() {
    let tyre = example("quarter-car.toml");
    assert_eq!(tyre.dofs, ["x_s", "x_u"]);
    // Suspension compression = x_u - x_s; tyre compression = road - x_u.
    assert_eq!(tyre.elements[0].a, [-1.0, 1.0]);
    assert_eq!(tyre.elements[1].a, [0.0, -1.0]);
    assert_eq!(tyre.elements[1].b, [1.0]);
    assert!(tyre.is_restrained());
    assert!(matches!(tyre.outputs[2].target, Target::Element(1)));
    let aero = example("half-car.toml");
    // Front axle point z - l_f θ: compression road_front - (z - 1.8 θ).
    assert_eq!(aero.elements[0].a, [-1.0, 1.8]);
    assert_eq!(aero.elements[1].a, [-1.0, -1.4]);
    assert_eq!(aero.inputs[2].t, [1.0, -1.8]);
    assert!(aero.is_restrained());
    assert!(!example("emps.toml").is_restrained());
}

#[test]
fn unknown_keys_and_names_are_errors() {
    let base = std::fs::read_to_string(
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("examples/oscillator.toml"),
    )
    .unwrap();
    let err = |text: &str| Model::from_toml(text).unwrap_err().to_string();
    let e = err(&base.replace("mass = 2.0", "mass = 2.0\nmas = 1.0"));
    assert!(e.contains("mas"), "{e}");
    let e = err(&base.replace("lower = \"ground\"", "lower = \"floor\""));
    assert!(e.contains("floor"), "{e}");
    let e = err(&base.replace("mass = 2.0", "mass = -2.0"));
    assert!(e.contains("mass must be > 0"), "{e}");
    let with_effect = format!(
        "{base}\n[[effect]]\neffect = \"cubic_stiffness\"\nelement = \"spring\"\nparameters = {{ stifness = 1.0 }}\n"
    );
    let e = err(&with_effect);
    assert!(e.contains("stifness"), "{e}");
    let e = err(&base.replace("kind = \"displacement\"", "kind = \"strain\""));
    assert!(e.contains("strain"), "{e}");
}

#[test]
fn effects_in_the_file_are_simulated() {
    // The tyre with lift-off: a road bump that throws the wheel off the road gives a tyre
    // force that never drops below minus the static load.
    let text = std::fs::read_to_string(
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("examples/quarter-car.toml"),
    )
    .unwrap();
    let preload = 170.0 * 9.81;
    // The static load is the tyre element's preload, stated once; lift-off takes none.
    let text = text.replace(
        "damping_n_s_per_m = 500.0",
        &format!("damping_n_s_per_m = 500.0\npreload_n = {preload}"),
    );
    let twice = format!(
        "{text}\n[[effect]]\neffect = \"lift_off\"\nelement = \"tyre\"\nparameters = {{ preload_n = {preload} }}\n"
    );
    let e = Model::from_toml(&twice).unwrap_err().to_string();
    assert!(
        e.contains("takes no parameters") && e.contains("preload_n"),
        "{e}"
    );
    let m = Model::from_toml(&format!(
        "{text}\n[[effect]]\neffect = \"lift_off\"\nelement = \"tyre\"\n"
    ))
    .unwrap();
    assert_eq!(m.effect_specs()[0].effect, EffectKind::LiftOff);
    assert_eq!(m.elements[1].law.lift_off, Some(preload));
    // Written back: the preload on the element, the effect without parameters.
    let back = Model::from_toml(&m.to_toml()).unwrap();
    assert_eq!(back.elements[1].law, m.elements[1].law);
    assert_eq!(back.file.elements[1].preload_n, preload);
    let dt = 1e-3;
    let n = 2000;
    let t: Vec<f64> = (0..n).map(|i| i as f64 * dt).collect();
    // A 5 cm step down of the road at 0.5 s.
    let road: Vec<f64> = t
        .iter()
        .map(|&t| if t > 0.5 { -0.05 } else { 0.0 })
        .collect();
    let zeros = vec![0.0; n];
    let rec = Record::new(
        &t,
        vec![
            "road".into(),
            "body".into(),
            "hub".into(),
            "tyre_force".into(),
        ],
        vec![road, zeros.clone(), zeros.clone(), zeros],
    )
    .unwrap();
    let inputs = prepare_inputs(&m, &rec).unwrap();
    let sim = simulate(&m, &rec, &inputs, 0..n, None).unwrap();
    let force = &sim.outputs[2];
    assert_eq!(m.outputs[2].kind, OutputKind::Force);
    let min = force.iter().cloned().fold(f64::INFINITY, f64::min);
    assert!((min + preload).abs() < 1e-6, "min tyre force {min}");
    // Without lift-off the tyre pulls the wheel down far harder.
    let linear = example("quarter-car.toml");
    let sim = simulate(
        &linear,
        &rec,
        &prepare_inputs(&linear, &rec).unwrap(),
        0..n,
        None,
    )
    .unwrap();
    let min_linear = sim.outputs[2].iter().cloned().fold(f64::INFINITY, f64::min);
    assert!(min_linear < -2.0 * preload, "{min_linear}");
}

#[test]
fn effects_attach_only_where_they_mean_something() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("examples");
    let osc = std::fs::read_to_string(dir.join("oscillator.toml")).unwrap();
    let tyre = std::fs::read_to_string(dir.join("quarter-car.toml")).unwrap();
    let with = |base: &str, effect: &str, on: &str, params: &str| {
        Model::from_toml(&format!(
            "{base}\n[[effect]]\neffect = \"{effect}\"\nelement = \"{on}\"\nparameters = {{ {params} }}\n"
        ))
    };
    // Free play on a displacement input is the linkage's play operator; on a force input
    // it means nothing and is refused, naming the input.
    let m = with(&tyre, "backlash", "road", "half_gap_m = 0.002").unwrap();
    assert_eq!(m.inputs[0].law.backlash, Some(0.002));
    assert_eq!(m.effect_specs()[0].element, "road");
    let e = with(&osc, "backlash", "force", "half_gap_m = 0.002")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("force") && e.contains("displacement input"),
        "{e}"
    );
    // Input-only effects on an element, and misspelt targets, are refused by name.
    let e = with(&osc, "saturation", "spring", "limit = 1.0")
        .unwrap_err()
        .to_string();
    assert!(e.contains("spring") && e.contains("input"), "{e}");
    let e = with(&osc, "input_delay", "forse", "delay_s = 0.01")
        .unwrap_err()
        .to_string();
    assert!(e.contains("forse"), "{e}");
    // Saturation with its own limits reads and writes back as such.
    let m = with(
        &osc,
        "saturation",
        "force",
        "lower_limit = -5.0, upper_limit = 9.0",
    )
    .unwrap();
    assert_eq!(m.inputs[0].law.saturation, Some((-5.0, 9.0)));
    let back = Model::from_toml(&m.to_toml()).unwrap();
    assert_eq!(back.inputs[0].law.saturation, Some((-5.0, 9.0)));
}
