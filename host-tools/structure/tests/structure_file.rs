//! The structure file: static loads stated once (gravity and the preloads it implies, or
//! stated preloads that must balance it), the linearisation, and the round trip through
//! TOML. Expected values are the textbook statics and stiffness matrices of the paper's
//! quarter car and half car, written out by hand here.

use mil_structure::{EffectKind, Model};

const G: f64 = 9.81;

/// The paper's quarter car on the road (Table 2 values), optionally with gravity and extra
/// lines on the tyre element.
fn quarter_car(gravity: bool, tyre_extra: &str, effects: &str) -> String {
    format!(
        r#"
name = "quarter car"
{gravity}

[[dof]]
name = "x_s"
mass = 150.0

[[dof]]
name = "x_u"
mass = 20.0

[[element]]
name = "suspension"
upper = "x_s"
lower = "x_u"
stiffness_n_per_m = 120.0e3
damping_n_s_per_m = 2.5e3

[[element]]
name = "tyre"
upper = "x_u"
lower = "road"
stiffness_n_per_m = 250.0e3
damping_n_s_per_m = 500.0
{tyre_extra}

[[input]]
name = "road"
kind = "displacement"
column = "road"

[[output]]
column = "hub"
kind = "displacement"
of = "x_u"
{effects}
"#,
        gravity = if gravity {
            "gravity_m_per_s2 = 9.81"
        } else {
            ""
        },
    )
}

fn close(a: f64, b: f64, rel: f64) -> bool {
    (a - b).abs() <= rel * b.abs().max(1e-12)
}

#[test]
fn gravity_gives_the_preloads_that_carry_the_weights() {
    let m = Model::from_toml(&quarter_car(true, "", "")).unwrap();
    let p = m.preloads();
    // The suspension carries the body, the tyre the whole car.
    assert!(close(p[0], 150.0 * G, 1e-12), "{p:?}");
    assert!(close(p[1], 170.0 * G, 1e-12), "{p:?}");
    assert_eq!(m.static_force, vec![-150.0 * G, -20.0 * G]);
    // Without gravity nothing is preloaded.
    let free = Model::from_toml(&quarter_car(false, "", "")).unwrap();
    assert_eq!(free.preloads(), vec![0.0, 0.0]);
    assert_eq!(free.static_force, vec![0.0, 0.0]);
}

#[test]
fn lift_off_lifts_off_from_the_derived_preload() {
    let fx = "[[effect]]\neffect = \"lift_off\"\nelement = \"tyre\"\n";
    let m = Model::from_toml(&quarter_car(true, "", fx)).unwrap();
    assert!(close(m.elements[1].law.lift_off.unwrap(), 170.0 * G, 1e-12));
    // The tyre cannot pull: far in extension its force relative to equilibrium is minus
    // the static load.
    let f = m.elements[1].law.force(-0.5, 0.0, 0.0);
    assert!(close(f, -170.0 * G, 1e-12), "{f}");
    // Written back: still derived (no preload_n in the file), same law.
    let text = m.to_toml();
    assert!(!text.contains("preload_n"), "{text}");
    let back = Model::from_toml(&text).unwrap();
    assert_eq!(back.elements, m.elements);
}

#[test]
fn stated_preloads_must_balance_the_weights() {
    // In N, balancing: accepted as stated.
    let text = quarter_car(true, "preload_n = 1667.7", "").replace(
        "damping_n_s_per_m = 2.5e3",
        "damping_n_s_per_m = 2.5e3\npreload_n = 1471.5",
    );
    let m = Model::from_toml(&text).unwrap();
    assert_eq!(m.preloads(), vec![1471.5, 1667.7]);
    // The car's static load in kg: refused, naming the field and the likely unit.
    let kg = quarter_car(true, "preload_n = 170.0", "").replace(
        "damping_n_s_per_m = 2.5e3",
        "damping_n_s_per_m = 2.5e3\npreload_n = 150.0",
    );
    let e = Model::from_toml(&kg).unwrap_err().to_string();
    assert!(e.contains("preload_n") && e.contains("kg"), "{e}");
    // Half the weight: refused, naming the DOF.
    let half = quarter_car(true, "preload_n = 833.9", "");
    let e = Model::from_toml(&half).unwrap_err().to_string();
    assert!(e.contains("preload_n") && e.contains("x_"), "{e}");
    // A negative gravity is refused.
    let e = Model::from_toml(&quarter_car(false, "", "").replace(
        "name = \"quarter car\"",
        "name = \"quarter car\"\ngravity_m_per_s2 = -9.81",
    ))
    .unwrap_err()
    .to_string();
    assert!(e.contains("gravity_m_per_s2"), "{e}");
}

#[test]
fn recalibrated_masses_drop_stated_preloads_that_no_longer_balance() {
    let text = quarter_car(true, "preload_n = 1667.7", "").replace(
        "damping_n_s_per_m = 2.5e3",
        "damping_n_s_per_m = 2.5e3\npreload_n = 1471.5",
    );
    let mut m = Model::from_toml(&text).unwrap();
    m.mass[0] = 165.0;
    let back = Model::from_toml(&m.to_toml()).unwrap();
    assert!(close(back.preloads()[0], 165.0 * G, 1e-12));
    assert!(close(back.preloads()[1], 185.0 * G, 1e-12));
}

#[test]
fn the_linearisation_is_the_quarter_car_of_the_textbook() {
    let m = Model::from_toml(&quarter_car(true, "", "")).unwrap();
    let l = m.linearised();
    let (kc, cc, kt, ct) = (120.0e3, 2.5e3, 250.0e3, 500.0);
    assert_eq!(l.mass[(0, 0)], 150.0);
    assert_eq!(l.mass[(1, 1)], 20.0);
    assert_eq!(l.mass[(0, 1)], 0.0);
    let k = [[kc, -kc], [-kc, kc + kt]];
    let c = [[cc, -cc], [-cc, cc + ct]];
    for i in 0..2 {
        for j in 0..2 {
            assert_eq!(l.stiffness[(i, j)], k[i][j], "K[{i}][{j}]");
            assert_eq!(l.damping[(i, j)], c[i][j], "C[{i}][{j}]");
        }
    }
    // The road pushes the hub through the tyre: + k_t w + c_t ẇ on x_u.
    assert_eq!(l.input_stiffness.shape(), (2, 1));
    assert_eq!(l.input_stiffness[(0, 0)], 0.0);
    assert_eq!(l.input_stiffness[(1, 0)], kt);
    assert_eq!(l.input_damping[(1, 0)], ct);
    assert!(l.force_input.iter().all(|v| *v == 0.0));
}

#[test]
fn the_half_car_axle_loads_follow_from_the_lever_arms() {
    // Statically determinate: the axle loads are W l_r / L and W l_f / L whatever the
    // stiffnesses. Heave and pitch DOFs, the suspensions at axle points.
    let (lf, lr, mb) = (1.8, 1.4, 550.0);
    let text = format!(
        r#"
name = "half car"
gravity_m_per_s2 = 9.81
[[dof]]
name = "z_b"
mass = {mb}
[[dof]]
name = "theta_b"
kind = "rotation"
mass = 350.0
[[point]]
name = "front_axle"
position = {{ z_b = 1.0, theta_b = -{lf} }}
[[point]]
name = "rear_axle"
position = {{ z_b = 1.0, theta_b = {lr} }}
[[element]]
name = "front"
upper = "front_axle"
lower = "road_front"
stiffness_n_per_m = 300.0e3
damping_n_s_per_m = 2.0e3
[[element]]
name = "rear"
upper = "rear_axle"
lower = "road_rear"
stiffness_n_per_m = 240.0e3
damping_n_s_per_m = 4.0e3
[[input]]
name = "road_front"
kind = "displacement"
column = "road_front"
[[input]]
name = "road_rear"
kind = "displacement"
column = "road_rear"
[[input]]
name = "downforce"
kind = "force"
column = "downforce"
at = "front_axle"
"#
    );
    let m = Model::from_toml(&text).unwrap();
    let w = mb * G;
    let p = m.preloads();
    assert!(close(p[0], w * lr / (lf + lr), 1e-9), "{p:?}");
    assert!(close(p[1], w * lf / (lf + lr), 1e-9), "{p:?}");
    // No gravity moment on the pitch DOF; the down force enters at the front axle point.
    assert_eq!(m.static_force[1], 0.0);
    let l = m.linearised();
    assert_eq!(l.force_input[(0, 2)], 1.0);
    assert_eq!(l.force_input[(1, 2)], -lf);
    assert_eq!(l.input_stiffness[(1, 0)], -300.0e3 * lf);
    assert_eq!(l.input_stiffness[(0, 2)], 0.0);
    // A structure with no outputs is a valid structure (the rig needs none).
    assert!(m.outputs.is_empty());
    assert_eq!(m.elements[0].law.kinds(), Vec::<EffectKind>::new());
}

/// Unit mistakes a file cannot show by itself are refused by physics, naming the field and
/// the likely unit.
#[test]
fn unit_mistakes_are_refused_naming_the_field_and_the_unit() {
    let refused = |text: &str| Model::from_toml(text).unwrap_err().to_string();
    // The tyre in N/mm: 6.7 m of static compression under the car.
    let e = refused(
        &quarter_car(true, "", "")
            .replace("stiffness_n_per_m = 250.0e3", "stiffness_n_per_m = 250.0"),
    );
    assert!(
        e.contains("\"tyre\"") && e.contains("stiffness_n_per_m") && e.contains("N/mm"),
        "{e}"
    );
    // The body's mass in g.
    let e = refused(&quarter_car(true, "", "").replace("mass = 150.0", "mass = 150000.0"));
    assert!(e.contains("mass in g"), "{e}");
    // Gravity in mm/s².
    let e = refused(&quarter_car(true, "", "").replace("9.81", "9810.0"));
    assert!(e.contains("gravity_m_per_s2") && e.contains("mm/s"), "{e}");
    // Without gravity the natural frequencies still catch gross mistakes: both springs in
    // N/km (1e-3 of N/m) put the body mode at 2 mHz.
    let e = refused(
        &quarter_car(false, "", "")
            .replace("stiffness_n_per_m = 250.0e3", "stiffness_n_per_m = 0.25")
            .replace("stiffness_n_per_m = 120.0e3", "stiffness_n_per_m = 0.12"),
    );
    assert!(e.contains("natural frequency") && e.contains("x_s"), "{e}");
    // The paper's values pass, with and without gravity; a free mass (no spring) has no
    // natural frequency to check.
    Model::from_toml(&quarter_car(true, "", "")).unwrap();
    Model::from_toml(&quarter_car(false, "", "")).unwrap();
    Model::from_toml(
        "name = \"free\"\n[[dof]]\nname = \"q\"\nmass = 80.0\n[[input]]\nname = \"f\"\n\
         kind = \"force\"\ncolumn = \"f\"\nat = \"q\"\n",
    )
    .unwrap();
}

/// The quarter car of the tyre rig: no tyre, the hub hanging on its actuator (a force
/// input at the hub with the static force it holds).
fn quarter_car_on_its_hub_actuator(static_n: &str) -> String {
    let text = quarter_car(true, "", "");
    let (head, _) = text.split_once("[[element]]\nname = \"tyre\"").unwrap();
    format!(
        "{head}[[input]]\nname = \"hub actuator\"\nkind = \"force\"\ncolumn = \"force\"\n\
         at = \"x_u\"\n{static_n}\n"
    )
}

#[test]
fn a_force_input_holding_the_structure_carries_its_weight() {
    // Held by the actuator alone: the suspension carries the body, the actuator the car.
    let m = Model::from_toml(&quarter_car_on_its_hub_actuator("static_n = 1667.7")).unwrap();
    assert!(
        close(m.preloads()[0], 150.0 * G, 1e-3),
        "{:?}",
        m.preloads()
    );
    assert_eq!(m.inputs[0].static_n, 1667.7);
    // Without the actuator's static force nothing holds it up.
    let e = Model::from_toml(&quarter_car_on_its_hub_actuator(""))
        .unwrap_err()
        .to_string();
    assert!(e.contains("static_n") && e.contains("x_"), "{e}");
    // The car's mass in kg as the static force: refused, naming the DOF left unbalanced.
    let e = Model::from_toml(&quarter_car_on_its_hub_actuator("static_n = 170.0"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("static_n") && e.contains("dof \"x_"), "{e}");
    // A static force on a displacement input is refused.
    let e = Model::from_toml(
        &quarter_car(true, "", "")
            .replace("column = \"road\"", "column = \"road\"\nstatic_n = 10.0"),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("static_n"), "{e}");
    // Set again (the tyre's static load): the preloads follow; written back, the same.
    let m = m.with_static_n("hub actuator", 170.0 * G).unwrap();
    assert!(close(m.preloads()[0], 150.0 * G, 1e-12));
    assert!(m.with_static_n("road", 1.0).is_err());
    let back = Model::from_toml(&m.to_toml()).unwrap();
    assert_eq!(back.elements, m.elements);
    // A recalibrated body mass: the actuator holds the new weight.
    let mut heavier = m.clone();
    heavier.mass[0] = 165.0;
    let back = Model::from_toml(&heavier.to_toml()).unwrap();
    assert!(close(back.inputs[0].static_n, 185.0 * G, 1e-12));
    assert!(close(back.preloads()[0], 165.0 * G, 1e-12));
}

#[test]
fn a_static_force_on_sprung_structure_compresses_its_springs() {
    // The whole quarter car on the road, pushed down by 1 kN at the body: the suspension
    // carries the body and the push, the tyre the car and the push.
    let text = quarter_car(true, "", "")
        + "\n[[input]]\nname = \"push\"\nkind = \"force\"\ncolumn = \"push\"\nat = \"x_s\"\n\
           static_n = -1000.0\n";
    let p = Model::from_toml(&text).unwrap().preloads();
    assert!(close(p[0], 150.0 * G + 1000.0, 1e-12), "{p:?}");
    assert!(close(p[1], 170.0 * G + 1000.0, 1e-12), "{p:?}");
}
