//! The controller step: modes, faults and the safe state, limits, parameter swaps, and the
//! no-panic / always-finite property over arbitrary f32 inputs.

mod common;
use common::*;
use model_core::{
    fault, AeroModel, AeroParams, CascadeCoefficients, Controller, ControllerParams, DemandLimits,
    Mode, ModelInput, ParamError, SubstructureModel, SubstructureParams, TyreModel,
    TyreModelParams, TyreParams,
};
use proptest::prelude::*;

const DT: f32 = 2.0e-4;

type TyreSet = ControllerParams<TyreModelParams<4>, 4>;
type Change = Box<dyn Fn(&mut TyreSet)>;

fn tyre_params() -> TyreSet {
    ControllerParams {
        model: TyreModelParams {
            tyre: [TyreParams::PAPER; 4],
        },
        filter: [CascadeCoefficients::IDENTITY; 4],
        limits: [DemandLimits {
            min: -5.0e3,
            max: 2.0e4,
            rate: 5.0e6,
        }; 4],
        safe_demand: [1668.0; 4],
        safe_ramp_rate: [1.0e5; 4],
    }
}

fn road(z: f32) -> ModelInput<4> {
    ModelInput {
        road: [z; 4],
        ..ModelInput::default()
    }
}

#[test]
fn idle_holds_safe_demand_until_started() {
    let mut c = Controller::<TyreModel<4>, 4>::with_params(&tyre_params(), DT).unwrap();
    assert_eq!(c.mode(), Mode::Idle);
    for _ in 0..10 {
        assert_eq!(c.step(&road(0.01)), [1668.0; 4]);
    }
    assert!(c.start());
    let d = c.step(&road(0.01));
    // Model: static 1667.7 N + 250 N/mm · 10 mm = 4167.7 N; rate limit 5e6 N/s · 0.2 ms = 1 kN.
    assert!(
        (d[0] - 2668.0).abs() < 1e-2,
        "rate-limited first step: {}",
        d[0]
    );
    assert_eq!(c.status().rate_limited, 0b1111);
    for _ in 0..10 {
        c.step(&road(0.01));
    }
    let d = c.step(&road(0.01));
    let expected = TyreParams::PAPER.static_load + TyreParams::PAPER.stiffness * 0.01;
    assert!((d[0] - expected).abs() < 1e-2, "{} vs {expected}", d[0]);
    assert_eq!(c.status().rate_limited, 0);
}

#[test]
fn nan_input_latches_fault_and_ramps_to_safe_demand() {
    let mut c = Controller::<TyreModel<4>, 4>::with_params(&tyre_params(), DT).unwrap();
    c.start();
    for _ in 0..50 {
        c.step(&road(0.02));
    }
    let before = c.demand()[0];
    let mut bad = road(0.02);
    bad.position[2] = f32::NAN;
    let d = c.step(&bad);
    assert_eq!(c.mode(), Mode::Fault);
    assert_eq!(c.status().fault, fault::INVALID_INPUT);
    assert_eq!(c.status().invalid_input, 0b0100);
    // Ramp at 1e5 N/s: 20 N per sample towards 1668 N, never NaN, never stale.
    assert!((before - d[0] - 20.0).abs() < 1e-2, "{before} -> {}", d[0]);
    // Valid inputs do not restart the model: the fault is latched.
    let mut last = d;
    for _ in 0..1000 {
        let d = c.step(&road(0.02));
        assert!(d.iter().all(|v| v.is_finite()));
        assert!(d[0] <= last[0]);
        last = d;
    }
    assert_eq!(last, [1668.0; 4]);
    assert!(!c.start(), "cannot start while a fault is latched");
    assert!(c.clear_fault());
    assert_eq!(c.mode(), Mode::Idle);
    assert!(c.start());
    c.step(&road(0.0));
    assert_eq!(c.mode(), Mode::Running);
}

/// A finite but impossible displacement (a corrupted or misscaled CAN frame: 2 km) latches
/// the invalid-input fault like a NaN, for the tyre (hub position, road) and the aero model
/// (axle position); values at the bound still run.
#[test]
fn out_of_range_displacement_latches_fault() {
    for (field, value) in [("position", 1.0f32), ("position", 2.0e3), ("road", -1.5)] {
        let mut c = Controller::<TyreModel<4>, 4>::with_params(&tyre_params(), DT).unwrap();
        c.start();
        for _ in 0..10 {
            c.step(&road(0.0));
        }
        let mut input = road(0.0);
        match field {
            "position" => input.position[1] = value,
            _ => input.road[1] = value,
        }
        let d = c.step(&input);
        assert!(d.iter().all(|v| v.is_finite()));
        if value.abs() <= model_core::tyre::TYRE_MAX_DISPLACEMENT {
            assert_eq!(c.mode(), Mode::Running, "{field} {value}");
        } else {
            assert_eq!(c.mode(), Mode::Fault, "{field} {value}");
            assert_eq!(c.status().fault, fault::INVALID_INPUT);
            assert_ne!(c.status().invalid_input, 0);
        }
    }
    let aero = ControllerParams {
        model: AeroParams::PAPER,
        filter: [CascadeCoefficients::IDENTITY; 2],
        limits: [DemandLimits {
            min: -2.0e4,
            max: 2.0e3,
            rate: 1.0e9,
        }; 2],
        safe_demand: [0.0; 2],
        safe_ramp_rate: [1.0e5; 2],
    };
    let mut c = Controller::<AeroModel, 2>::with_params(&aero, DT).unwrap();
    c.start();
    let mut input = ModelInput {
        speed: 50.0,
        ..ModelInput::default()
    };
    c.step(&input);
    assert_eq!(c.mode(), Mode::Running);
    input.position[0] = -2.0e3;
    c.step(&input);
    assert_eq!(c.mode(), Mode::Fault);
    assert_eq!(c.status().fault, fault::INVALID_INPUT);
}

#[test]
fn amplitude_limit_clamps_and_reports() {
    let mut p = tyre_params();
    p.limits[1].max = 3000.0;
    let mut c = Controller::<TyreModel<4>, 4>::with_params(&p, DT).unwrap();
    c.start();
    for _ in 0..100 {
        c.step(&road(0.01));
    }
    let d = c.step(&road(0.01));
    assert_eq!(d[1], 3000.0);
    assert_eq!(c.status().amplitude_limited, 0b0010);
}

#[test]
fn rejected_parameters_change_nothing() {
    let mut c = Controller::<TyreModel<4>, 4>::with_params(&tyre_params(), DT).unwrap();
    c.start();
    c.step(&road(0.01));
    let running = *c.params();
    let cases: [(&str, Change); 7] = [
        (
            "NaN stiffness",
            Box::new(|p| p.model.tyre[0].stiffness = f32::NAN),
        ),
        (
            "negative damping",
            Box::new(|p| p.model.tyre[3].damping = -1.0),
        ),
        ("min above max", Box::new(|p| p.limits[0].min = 3.0e4)),
        (
            "safe demand outside limits",
            Box::new(|p| p.safe_demand[2] = 1.0e5),
        ),
        ("zero rate", Box::new(|p| p.limits[1].rate = 0.0)),
        (
            "lift-off flag 2",
            Box::new(|p| p.model.tyre[1].lift_off = 2),
        ),
        (
            "unstable filter",
            Box::new(|p| {
                p.filter[0] = CascadeCoefficients::from_sections(&[section_from_polar(
                    (1.01, 0.2),
                    (0.0, 0.0),
                    1.0,
                )])
                .unwrap()
            }),
        ),
    ];
    for (what, change) in cases {
        let mut p = running;
        change(&mut p);
        let err = c.set_params(&p);
        assert!(err.is_err(), "{what} accepted");
        assert_eq!(*c.params(), running, "{what} changed the running set");
    }
    assert!(matches!(
        c.set_params(&{
            let mut p = running;
            p.filter[0].sections = 9;
            p
        }),
        Err(ParamError::OutOfRange(_))
    ));
    // A valid change is taken.
    let mut p = running;
    p.model.tyre[0].stiffness = 2.0e5;
    c.set_params(&p).unwrap();
    assert_eq!(c.params().model.tyre[0].stiffness, 2.0e5);
}

#[test]
fn model_values_out_of_bounds_latch_a_fault() {
    let p = ControllerParams {
        model: AeroParams::PAPER,
        filter: [CascadeCoefficients::IDENTITY; 2],
        limits: [WIDE; 2],
        safe_demand: [0.0; 2],
        safe_ramp_rate: [1.0e6; 2],
    };
    let mut c = Controller::<AeroModel, 2>::with_params(&p, DT).unwrap();
    c.start();
    c.step(&ModelInput {
        speed: 50.0,
        ..ModelInput::default()
    });
    assert_eq!(c.mode(), Mode::Running);
    c.step(&ModelInput {
        speed: 500.0,
        ..ModelInput::default()
    });
    assert_eq!(c.mode(), Mode::Fault);
    assert_eq!(c.status().invalid_input, 0b11);
}

#[test]
fn numerical_overflow_latches_fault() {
    // A free mass pushed by a huge force for a long time overflows f32: NUMERICAL fault,
    // demand at the safe value.
    let mut s = SubstructureParams::<1>::zeroed(1, model_core::Causality::Admittance);
    s.mass[0][0] = 1.0e-3;
    let p = ControllerParams {
        model: s,
        filter: [CascadeCoefficients::IDENTITY],
        limits: [WIDE],
        safe_demand: [0.0],
        safe_ramp_rate: [1.0e12],
    };
    let mut c = Controller::<SubstructureModel<1>, 1>::with_params(&p, DT).unwrap();
    c.start();
    let push = ModelInput {
        force: [-3.0e38],
        ..ModelInput::default()
    };
    let mut faulted = false;
    for _ in 0..100 {
        let d = c.step(&push);
        assert!(d.iter().all(|v| v.is_finite()));
        if c.mode() == Mode::Fault {
            faulted = true;
            assert_eq!(c.status().fault, fault::NUMERICAL);
            break;
        }
    }
    assert!(faulted);
    c.step(&push);
    assert_eq!(c.demand(), [0.0]);
}

#[test]
fn external_trip_drives_safe_state() {
    let mut c = Controller::<TyreModel<4>, 4>::with_params(&tyre_params(), DT).unwrap();
    c.start();
    for _ in 0..100 {
        c.step(&road(0.03));
    }
    c.trip(0x80);
    for _ in 0..2000 {
        c.step(&road(0.03));
    }
    assert_eq!(c.demand(), [1668.0; 4]);
    assert_eq!(c.status().fault, 0x80);
}

fn any_f32() -> impl Strategy<Value = f32> {
    prop_oneof![
        any::<u32>().prop_map(f32::from_bits),
        Just(f32::NAN),
        Just(f32::INFINITY),
        Just(f32::NEG_INFINITY),
        -0.1f32..0.1,
    ]
}

fn any_input<const CH: usize>() -> impl Strategy<Value = ModelInput<CH>> {
    (
        prop::array::uniform::<_, CH>(any_f32()),
        prop::array::uniform::<_, CH>(any_f32()),
        prop::array::uniform::<_, CH>(any_f32()),
        any_f32(),
    )
        .prop_map(|(position, force, road, speed)| ModelInput {
            position,
            force,
            road,
            speed,
        })
}

fn check_demand<const CH: usize>(
    d: &[f32; CH],
    limits: &[DemandLimits; CH],
) -> Result<(), TestCaseError> {
    for (v, l) in d.iter().zip(limits) {
        prop_assert!(
            v.is_finite() && *v >= l.min && *v <= l.max,
            "demand {v} outside [{}, {}]",
            l.min,
            l.max
        );
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn tyre_step_never_panics_and_stays_in_limits(inputs in prop::collection::vec(any_input::<4>(), 1..40)) {
        let p = tyre_params();
        let mut c = Controller::<TyreModel<4>, 4>::with_params(&p, DT).unwrap();
        c.start();
        for i in &inputs {
            let d = c.step(i);
            check_demand(&d, &p.limits)?;
            if !i.is_finite() {
                prop_assert_eq!(c.mode(), Mode::Fault);
            }
        }
    }

    #[test]
    fn aero_step_never_panics_and_stays_in_limits(inputs in prop::collection::vec(any_input::<2>(), 1..40), use_map in 0u32..2) {
        let p = ControllerParams {
            model: AeroParams { use_map, ..AeroParams::PAPER },
            filter: [CascadeCoefficients::IDENTITY; 2],
            limits: [DemandLimits { min: -3.0e4, max: 3.0e4, rate: 1.0e7 }; 2],
            safe_demand: [0.0; 2],
            safe_ramp_rate: [1.0e6; 2],
        };
        let mut c = Controller::<AeroModel, 2>::with_params(&p, DT).unwrap();
        c.start();
        for i in &inputs {
            check_demand(&c.step(i), &p.limits)?;
        }
    }

    #[test]
    fn substructure_step_never_panics_and_stays_in_limits(inputs in prop::collection::vec(any_input::<2>(), 1..40), causality in 0u32..4) {
        let mut s = SubstructureParams::<2>::zeroed(2, model_core::Causality::Admittance);
        s.causality = causality;
        s.mass[0][0] = 10.0;
        s.mass[1][1] = 5.0;
        s.stiffness[0][0] = 5e4;
        s.stiffness[1][1] = 3e4;
        s.stiffness[0][1] = -1e4;
        s.stiffness[1][0] = -1e4;
        s.interface[0] = model_core::InterfaceParams { dof: 0, stiffness: 2e4, damping: 0.0 };
        s.interface[1] = model_core::InterfaceParams { dof: 1, stiffness: 1e4, damping: 10.0 };
        let p = ControllerParams {
            model: s,
            filter: [CascadeCoefficients::IDENTITY; 2],
            limits: [DemandLimits { min: -1.0, max: 1.0e3, rate: 1.0e7 }; 2],
            safe_demand: [0.0; 2],
            safe_ramp_rate: [1.0e6; 2],
        };
        let mut c = Controller::<SubstructureModel<2>, 2>::with_params(&p, DT).unwrap();
        c.start();
        for i in &inputs {
            check_demand(&c.step(i), &p.limits)?;
        }
    }

    /// Random parameter values (any bits) are either rejected or run without panics and with
    /// finite demands inside the limits.
    #[test]
    fn arbitrary_tyre_parameters_are_rejected_or_safe(k in any_f32(), c_t in any_f32(), fs in any_f32(), cutoff in any_f32(), lo in any_f32(), hi in any_f32()) {
        let mut p = tyre_params();
        p.model.tyre[0] = TyreParams { stiffness: k, damping: c_t, static_load: fs, lift_off: 1, velocity_cutoff_hz: cutoff };
        p.limits[0].min = lo.min(0.0);
        p.limits[0].max = hi.max(1.0);
        p.safe_demand[0] = 0.0;
        if let Ok(mut ctl) = Controller::<TyreModel<4>, 4>::with_params(&p, DT) {
            ctl.start();
            for k in 0..50 {
                let d = ctl.step(&road(0.001 * (k as f32).sin()));
                check_demand(&d, &p.limits)?;
            }
        }
    }
}
