//! model-core's real-time element laws (`f32`, the board's) are the laws of the structure
//! file (`mil_structure`, `f64`, the simulated rig's and diagnosis'): every effect alone and
//! all at once, over a grid of compressions and rates through the stops, lift-off and the
//! friction's smoothing, agree to 2e-6 of the force's scale (the sum of the terms'
//! magnitudes: `f32` rounding of a handful of operations); the structure's export
//! (`to_board`) gives exactly those laws and refuses what the board cannot run by name.

use mil_structure::{EffectKind, Element};
use model_core::ElementLaw;

const K: f64 = 1.2e5;
const C: f64 = 2.5e3;

/// The same element both ways: the structure's law and the board's.
struct Case {
    name: &'static str,
    host: Element,
    board: ElementLaw,
}

fn cases() -> Vec<Case> {
    let linear = || Element::linear(K, C);
    let board = ElementLaw::linear(K as f32, C as f32);
    let cubic = [("stiffness_n_per_m3", 4.0e9)];
    let stops = [
        ("gap_m", 0.01),
        ("stiffness_n_per_m", 5.0e5),
        ("rebound_gap_m", 0.015),
        ("rebound_stiffness_n_per_m", 3.0e5),
    ];
    let asymmetric = [("bump_n_s_per_m", 1.5e3), ("rebound_n_s_per_m", 3.5e3)];
    let quadratic = [("damping_n_s2_per_m2", 8.0e3)];
    let friction = [("force_n", 60.0), ("smoothing_velocity_m_per_s", 2.0e-3)];
    let with_stops = ElementLaw {
        bump_gap: 0.01,
        bump_stiffness: 5.0e5,
        rebound_gap: 0.015,
        rebound_stiffness: 3.0e5,
        ..board
    };
    let with_asymmetric = ElementLaw {
        bump_damping: 1.5e3,
        rebound_damping: 3.5e3,
        ..board
    };
    let everything = ElementLaw {
        cubic_stiffness: 4.0e9,
        quadratic_damping: 8.0e3,
        friction_force: 60.0,
        friction_velocity: 2.0e-3,
        preload: 1471.5,
        lift_off: 1,
        ..ElementLaw {
            bump_damping: 1.5e3,
            rebound_damping: 3.5e3,
            ..with_stops
        }
    };
    vec![
        Case {
            name: "linear",
            host: linear(),
            board,
        },
        Case {
            name: "cubic_stiffness",
            host: linear().with(EffectKind::CubicStiffness, &cubic),
            board: ElementLaw {
                cubic_stiffness: 4.0e9,
                ..board
            },
        },
        Case {
            name: "bump_stop",
            host: linear().with(EffectKind::BumpStop, &stops),
            board: with_stops,
        },
        Case {
            name: "asymmetric_damping",
            host: linear().with(EffectKind::AsymmetricDamping, &asymmetric),
            board: with_asymmetric,
        },
        Case {
            name: "quadratic_damping",
            host: linear().with(EffectKind::QuadraticDamping, &quadratic),
            board: ElementLaw {
                quadratic_damping: 8.0e3,
                ..board
            },
        },
        Case {
            name: "coulomb_friction",
            host: linear().with(EffectKind::CoulombFriction, &friction),
            board: ElementLaw {
                friction_force: 60.0,
                friction_velocity: 2.0e-3,
                ..board
            },
        },
        Case {
            name: "lift_off",
            host: linear().with_preload(1471.5).with(EffectKind::LiftOff, &[]),
            board: ElementLaw {
                preload: 1471.5,
                lift_off: 1,
                ..board
            },
        },
        Case {
            name: "all at once",
            host: linear()
                .with_preload(1471.5)
                .with(EffectKind::CubicStiffness, &cubic)
                .with(EffectKind::BumpStop, &stops)
                .with(EffectKind::AsymmetricDamping, &asymmetric)
                .with(EffectKind::QuadraticDamping, &quadratic)
                .with(EffectKind::CoulombFriction, &friction)
                .with(EffectKind::LiftOff, &[]),
            board: everything,
        },
    ]
}

#[test]
fn the_board_s_element_laws_are_the_structure_file_s() {
    for case in cases() {
        case.board.validate().unwrap();
        // The structure's export is the board's law written out by hand above.
        let exported = case.host.law().unwrap().to_board().unwrap();
        assert_eq!(exported, case.board, "{}", case.name);
        let b = &case.board;
        let mut worst = 0.0_f64;
        for i in -40..=40 {
            // Through both stops (±10 mm, ±15 mm) and lift-off (−12 mm at rest).
            let x = f64::from(i) * 0.5e-3;
            for v in [
                -0.5, -0.05, -5e-3, -2e-3, -5e-4, 0.0, 5e-4, 2e-3, 5e-3, 0.05, 0.5,
            ] {
                let host = case.host.force(x, v, 0.0).unwrap();
                let board = f64::from(b.force(x as f32, v as f32)) + f64::from(b.preload);
                let scale = f64::from(b.stiffness) * x.abs()
                    + f64::from(b.bump_damping.max(b.rebound_damping)) * v.abs()
                    + f64::from(b.cubic_stiffness).abs() * x.abs().powi(3)
                    + f64::from(b.quadratic_damping) * v * v
                    + f64::from(b.friction_force)
                    + f64::from(b.bump_stiffness + b.rebound_stiffness) * x.abs()
                    + f64::from(b.preload)
                    + 1.0;
                let error = (host - board).abs() / scale;
                assert!(
                    error <= 2e-6,
                    "{}: at x = {x} m, v = {v} m/s the structure's law gives {host} N, the \
                     board's {board} N",
                    case.name
                );
                worst = worst.max(error);
            }
        }
        eprintln!(
            "{}: worst difference {worst:.2e} of the force's scale",
            case.name
        );
    }
}

/// What the board cannot run is refused by name: backlash and hysteresis (no real-time form
/// yet), and values outside the board's ranges.
#[test]
fn what_the_board_cannot_run_is_refused_by_name() {
    let linear = || Element::linear(K, C);
    for (element, name) in [
        (
            linear().with(EffectKind::Backlash, &[("half_gap_m", 1e-3)]),
            "backlash",
        ),
        (
            linear().with(
                EffectKind::Hysteresis,
                &[("alpha", 0.5), ("beta_per_m", 100.0), ("gamma_per_m", 50.0)],
            ),
            "hysteresis",
        ),
        (
            linear().with(EffectKind::CubicStiffness, &[("stiffness_n_per_m3", 1e20)]),
            "range",
        ),
    ] {
        let e = element.law().unwrap().to_board().unwrap_err().to_string();
        assert!(e.contains(name), "{e}");
    }
}
