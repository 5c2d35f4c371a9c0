//! The loop forms of all four configurations against a direct solution of the coupled
//! (emulated) system, and the MiL loop against hand-derived special cases.

use mil_analysis::examples::{
    aero_structure, axle_transform, force_actuators, two_dof_structure, tyre_structure,
};
use mil_analysis::metrics::log_grid;
use mil_analysis::poly::Rational;
use mil_analysis::system::{ActuatorControl, Actuators, ImpedanceLocation, Loop, MilSystem};
use mil_analysis::{LinearActuator, ResponseSource};
use mil_params::{AeroExample, ServoHydraulicActuator, TwoDofExample, TyreExample};
use nalgebra::DMatrix;
use num_complex::Complex64;
use std::f64::consts::TAU;

/// The paper's controller sample period (s), 2 kHz.
const DT: f64 = 5e-4;

fn ideal(control: ActuatorControl) -> Actuators {
    Actuators {
        control,
        tracking: ResponseSource::gain(1.0).unwrap(),
        disturbance: ResponseSource::Zero,
        transform: DMatrix::identity(1, 1),
        loop_delay_s: 0.0,
    }
}

fn two_dof(location: ImpedanceLocation, control: ActuatorControl) -> MilSystem {
    two_dof_structure(&TwoDofExample {
        interface_in_numerical: location == ImpedanceLocation::Numerical,
        ..TwoDofExample::default()
    })
    .unwrap()
    .with_actuators(ideal(control))
}

fn max_rel(a: &DMatrix<Complex64>, b: &DMatrix<Complex64>) -> f64 {
    let scale = b.iter().fold(0.0_f64, |m, v| m.max(v.norm()));
    (a - b).iter().fold(0.0_f64, |m, v| m.max(v.norm())) / scale
}

/// With perfect actuators every configuration is the emulated system: the loop form's
/// physical and numerical positions equal the direct solution of the coupled equations to
/// rounding (1e-9 relative), for both inputs, at frequencies around both modes.
#[test]
fn all_four_configurations_reduce_to_the_coupled_system() {
    let cases = [
        (ImpedanceLocation::Physical, ActuatorControl::Position, 1),
        (ImpedanceLocation::Physical, ActuatorControl::Force, 2),
        (ImpedanceLocation::Numerical, ActuatorControl::Position, 3),
        (ImpedanceLocation::Numerical, ActuatorControl::Force, 4),
    ];
    for (location, control, number) in cases {
        let sys = two_dof(location, control);
        sys.validate().unwrap();
        assert_eq!(sys.configuration(), number);
        for f in log_grid(0.5, 200.0, 20) {
            let mil_with_ideal_actuators = sys.point(f, Loop::Mil).unwrap();
            let emulated = sys.point(f, Loop::Emulated).unwrap();
            let (xp, xn) = sys.emulated_direct(f).unwrap();
            for p in [&mil_with_ideal_actuators, &emulated] {
                assert!(max_rel(&p.physical, &xp) < 1e-9, "case {number} at {f} Hz");
                assert!(max_rel(&p.numerical, &xn) < 1e-9, "case {number} at {f} Hz");
            }
        }
    }
}

/// The tyre example's emulated tyre force per road input against the closed-form quarter
/// car: F = B (z − x_u) with the hub and body responding to the tyre force.
#[test]
fn tyre_emulated_force_matches_the_quarter_car() {
    let t = TyreExample::default();
    let sys = tyre_structure(&t, DT)
        .unwrap()
        .with_actuators(ideal(ActuatorControl::Force));
    for f in [0.7, 4.0, 12.0, 30.0] {
        let s = Complex64::new(0.0, TAU * f);
        let b = t.tyre_stiffness + t.tyre_damping * s;
        let susp = t.suspension_stiffness + t.suspension_damping * s;
        // Hub impedance with the body hanging on the suspension.
        let z = t.unsprung_mass_kg * s * s
            + susp * t.sprung_mass_kg * s * s / (t.sprung_mass_kg * s * s + susp);
        let x_u = b / (z + b); // per unit road
        let force = b * (1.0 - x_u);
        let p = sys.point(f, Loop::Emulated).unwrap();
        let got = p.interface_force[(0, 0)];
        assert!(
            (got - force).norm() < 1e-9 * force.norm(),
            "{f} Hz: {got} vs {force}"
        );
    }
}

/// Case 4 with a pure-gain actuator `p` and no disturbance: the open loop is `p B_i H`
/// where `H` is the physical part's interface compliance, so it scales with `p`.
#[test]
fn open_loop_scales_with_the_actuator_gain() {
    let base = tyre_structure(&TyreExample::default(), DT).unwrap();
    let mut a = ideal(ActuatorControl::Force);
    let l1 = base
        .clone()
        .with_actuators(a.clone())
        .point(10.0, Loop::Mil)
        .unwrap();
    a.tracking = ResponseSource::gain(2.5).unwrap();
    let l2 = base.with_actuators(a).point(10.0, Loop::Mil).unwrap();
    let ratio = l2.open_loop[(0, 0)] / l1.open_loop[(0, 0)];
    assert!((ratio - Complex64::new(2.5, 0.0)).norm() < 1e-12);
}

/// A loop delay only rotates the open loop: |L| unchanged, phase −360 f τ degrees.
#[test]
fn loop_delay_rotates_the_open_loop() {
    let base = tyre_structure(&TyreExample::default(), DT).unwrap();
    let mut a = ideal(ActuatorControl::Force);
    let l0 = base
        .clone()
        .with_actuators(a.clone())
        .point(20.0, Loop::Mil)
        .unwrap();
    a.loop_delay_s = 1e-3;
    let l1 = base.with_actuators(a).point(20.0, Loop::Mil).unwrap();
    let r = l1.open_loop[(0, 0)] / l0.open_loop[(0, 0)];
    assert!((r.norm() - 1.0).abs() < 1e-12);
    assert!((r.arg().to_degrees() + 7.2).abs() < 1e-9);
}

/// The aero example's two actuators through the axle transform: with the reference actuator
/// the disturbance matrix is `r Lᵀ L` (brief section 3), checked through the physical
/// response with the command path open (zero tracking).
#[test]
fn aero_disturbance_acts_through_the_axle_transform() {
    let aero = AeroExample::default();
    let act = ServoHydraulicActuator::REFERENCE;
    let mut actuators = force_actuators(&act, 0.0).unwrap();
    actuators.tracking = ResponseSource::Model {
        transfer_function: Rational::new(vec![0.0], vec![1.0]).unwrap(),
        delay_s: 0.0,
    };
    let sys = aero_structure(&aero).unwrap().with_actuators(actuators);
    let f = 8.0;
    let s = Complex64::new(0.0, TAU * f);
    let r = act.disturbance().unwrap().response(f);
    let l = axle_transform(&aero).map(|v| Complex64::new(v, 0.0));
    let ap = sys.physical.dynamic_stiffness(s) - l.transpose() * &l * r;
    // Heave road input only: F_p = (C s + K)[1; 0].
    let c = sys.physical.damping.map(|v| Complex64::new(v, 0.0));
    let k = sys.physical.stiffness.map(|v| Complex64::new(v, 0.0));
    let fp = (c * s + k).column(0).into_owned();
    let x = ap.lu().solve(&fp).unwrap();
    let p = sys.point(f, Loop::Mil).unwrap();
    for j in 0..2 {
        assert!((p.physical[(j, 0)] - x[j]).norm() < 1e-9 * x.norm());
    }
}

/// Configurations that cannot exist are refused with a reason.
#[test]
fn impossible_configurations_are_refused() {
    // Case 2 needs masses in the numerical part (the tyre's numerical part has none).
    let mut sys = tyre_structure(&TyreExample::default(), DT)
        .unwrap()
        .with_actuators(ideal(ActuatorControl::Force));
    sys.interface.location = ImpedanceLocation::Physical;
    let e = sys.validate().unwrap_err().to_string();
    assert!(e.contains("configuration 2"), "{e}");
}

/// A loop `L = (k/c) e^{−sτ}/s` built from a physical damper `c` to ground and a numerical
/// spring `k` with a loop delay `τ`: gain margin `π c/(2 k τ)` at `1/(4τ)`. The stability
/// count must switch from stable to one unstable pair exactly when the gain margin passes 1.
#[test]
fn stability_count_agrees_with_the_delay_integrator_margin() {
    use mil_analysis::metrics::{characteristic_loci, margins, Stability};
    use mil_analysis::system::{ExternalInput, Interface, MechanicalPart, VelocityEstimate};
    let build = |k: f64| {
        let physical = MechanicalPart::new(
            vec!["x".into()],
            DMatrix::zeros(1, 1),
            DMatrix::from_element(1, 1, 100.0),
            DMatrix::zeros(1, 1),
        )
        .unwrap();
        let mut input = ExternalInput::new("w", "m", 0, 1, 1);
        input.interface_position[0] = 1.0;
        let mut act = ideal(ActuatorControl::Force);
        act.loop_delay_s = 0.01;
        MilSystem {
            numerical: MechanicalPart::massless(),
            physical,
            interface: Interface {
                location: ImpedanceLocation::Numerical,
                numerical_select: DMatrix::zeros(1, 0),
                physical_select: DMatrix::identity(1, 1),
                stiffness: DMatrix::from_element(1, 1, k),
                damping: DMatrix::zeros(1, 1),
                velocity: VelocityEstimate::Continuous,
            },
            inputs: vec![input],
            actuators: act,
            filter: None,
        }
    };
    // k/c = ω_gm/GM with ω_gm = π/(2τ) = 157 rad/s.
    for (gm, expected) in [(1.25, Stability::Stable), (0.8, Stability::Unstable(2))] {
        let k = 100.0 * std::f64::consts::PI / (2.0 * 0.01) / gm;
        let sys = build(k);
        let f = log_grid(1.0, 100.0, 2000);
        let pts: Vec<_> = f
            .iter()
            .map(|&x| sys.point(x, Loop::Mil).unwrap().open_loop)
            .collect();
        let m = margins(&f, &characteristic_loci(&pts));
        let stability = sys.stability(Loop::Mil);
        assert_eq!(stability, expected, "GM {gm}");
        // Above 1 it is the upper margin, below 1 (unstable) the gain-reduction margin.
        let (reported, hz) = m.reported_gain_margin(stability);
        assert!((reported.unwrap() - gm).abs() < 1e-3 * gm);
        assert!((hz.unwrap() - 25.0).abs() < 1e-2);
        if gm < 1.0 {
            assert_eq!(m.gain_margin, None);
        } else {
            assert_eq!(m.gain_reduction_margin, None);
        }
        assert_eq!(sys.stability(Loop::Emulated), Stability::Stable);
    }
}

/// The emulated system's stability comes from the zeros of its coupled dynamic stiffness.
/// It agrees with the argument principle on the emulated loop wherever that loop is proper
/// (configurations 1 and 4, the tyre and the aero examples), decides configurations 2 and 3
/// too (whose emulated loop gains grow with frequency, so the loop count is "unknown"), and
/// counts the right-half-plane poles of parts made unstable on purpose: negative damping
/// (one complex pair) and a negative stiffness that outweighs the rest (one real pole).
#[test]
fn emulated_stability_from_the_coupled_dynamic_stiffness() {
    use mil_analysis::Stability;
    for (location, control, number) in [
        (ImpedanceLocation::Physical, ActuatorControl::Position, 1),
        (ImpedanceLocation::Physical, ActuatorControl::Force, 2),
        (ImpedanceLocation::Numerical, ActuatorControl::Position, 3),
        (ImpedanceLocation::Numerical, ActuatorControl::Force, 4),
    ] {
        let sys = two_dof(location, control);
        assert_eq!(sys.stability(Loop::Emulated), Stability::Stable, "{number}");
        let by_loop = sys.loop_stability(Loop::Emulated);
        if number == 2 || number == 3 {
            // Improper emulated loops: the numerical mass's inertia (2) or the physical
            // one's (3) over the interface damping, |L| ∝ ω.
            assert_eq!(by_loop, Stability::Unknown, "{number}");
        } else {
            assert_eq!(by_loop, Stability::Stable, "{number}");
        }
    }
    let tyre = tyre_structure(&TyreExample::default(), DT)
        .unwrap()
        .with_actuators(ideal(ActuatorControl::Force));
    let aero = aero_structure(&AeroExample::default())
        .unwrap()
        .with_actuators(ideal(ActuatorControl::Force));
    for (name, sys) in [("tyre", tyre), ("aero", aero)] {
        assert_eq!(sys.stability(Loop::Emulated), Stability::Stable, "{name}");
        assert_eq!(
            sys.loop_stability(Loop::Emulated),
            Stability::Stable,
            "{name}"
        );
    }

    let unstable = |edit: &dyn Fn(&mut MilSystem)| {
        let mut sys = two_dof(ImpedanceLocation::Numerical, ActuatorControl::Position);
        edit(&mut sys);
        sys.stability(Loop::Emulated)
    };
    // Slight negative damping on the physical mass: its mode (one complex pair) grows.
    assert_eq!(
        unstable(&|s| s.physical.damping[(0, 0)] = -20.0),
        Stability::Unstable(2)
    );
    // A negative stiffness larger than the interface and numerical springs in series: one
    // real pole.
    assert_eq!(
        unstable(&|s| s.physical.stiffness[(0, 0)] = -3.0e4),
        Stability::Unstable(1)
    );
    // Independent check: the quartic det A(s) expanded by hand, its roots from the
    // companion matrix, over a spread of (possibly negative) dampings and stiffnesses.
    let mul = |a: &[f64], b: &[f64]| {
        let mut out = vec![0.0; a.len() + b.len() - 1];
        for (i, x) in a.iter().enumerate() {
            for (j, y) in b.iter().enumerate() {
                out[i + j] += x * y;
            }
        }
        out
    };
    let mut counts = std::collections::BTreeSet::new();
    for (c_n, k_n, c_p, k_p) in [
        (20.0, 4.0e4, -200.0, 2.0e4),
        (-400.0, 4.0e4, -200.0, -3.0e4),
        (-400.0, -6.0e4, 10.0, -3.0e4),
        (30.0, -2.0e3, 10.0, 2.0e4),
        (5.0, 4.0e4, -18.0, 2.0e4),
        (20.0, 4.0e4, 10.0, -3.0e4),
        (20.0, 4.0e4, -6.0, 2.0e4),
    ] {
        let e = TwoDofExample::default();
        let (m_n, m_p, c_i, k_i) = (
            e.numerical_mass_kg,
            e.physical_mass_kg,
            e.interface_damping,
            e.interface_stiffness,
        );
        // Ascending powers: det = (a_n + b)(a_p + b) − b² = a_n a_p + b (a_n + a_p).
        let a_n = [k_n, c_n, m_n];
        let a_p = [k_p, c_p, m_p];
        let b = [k_i, c_i];
        let sum: Vec<f64> = a_n.iter().zip(&a_p).map(|(x, y)| x + y).collect();
        let det: Vec<f64> = mul(&a_n, &a_p)
            .iter()
            .zip(mul(&b, &sum).iter().chain(std::iter::repeat(&0.0)))
            .map(|(x, y)| x + y)
            .collect();
        let lead = det[4];
        let mut companion = DMatrix::<f64>::zeros(4, 4);
        for k in 0..4 {
            companion[(0, k)] = -det[3 - k] / lead;
        }
        for k in 1..4 {
            companion[(k, k - 1)] = 1.0;
        }
        let right = companion
            .complex_eigenvalues()
            .iter()
            .filter(|r| r.re > TAU * 1e-3)
            .count() as u32;
        let got = unstable(&|s| {
            s.numerical.damping[(0, 0)] = c_n;
            s.numerical.stiffness[(0, 0)] = k_n;
            s.physical.damping[(0, 0)] = c_p;
            s.physical.stiffness[(0, 0)] = k_p;
        });
        let expected = if right == 0 {
            Stability::Stable
        } else {
            Stability::Unstable(right)
        };
        assert_eq!(got, expected, "c_n {c_n} k_n {k_n} c_p {c_p} k_p {k_p}");
        counts.insert(right);
    }
    // The cases span every possible count of a quartic (a strongly negative-damped physical
    // mass drags the numerical mode across through the interface too).
    assert_eq!(counts.into_iter().collect::<Vec<_>>(), [0, 1, 2, 3, 4]);
}
