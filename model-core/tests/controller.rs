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

/// `install` in place is `new`: a controller that ran, filtered and latched a fault, given
/// another set in place, steps bit for bit as a fresh one of that set, from Idle through a
/// Start (the board swaps configurations this way, without a kilobyte temporary).
#[test]
fn install_in_place_is_a_fresh_controller() {
    let mut other = tyre_params();
    let section = section_with_gain(0.9, 0.3, 0.5, 1.0, 1.2);
    other.filter = [CascadeCoefficients::from_sections(&[section]).unwrap(); 4];
    other.safe_demand = [900.0; 4];
    other.model.tyre[2].stiffness = 1.5e5;
    let prepared = model_core::PreparedParams::<TyreModel<4>, 4>::new(&other, DT).unwrap();
    let mut used = Controller::<TyreModel<4>, 4>::with_params(&tyre_params(), DT).unwrap();
    used.start();
    for k in 0..300 {
        used.step(&road(0.02 * (k as f32 * 0.05).sin()));
    }
    used.trip(0x40);
    used.step(&road(0.01));
    used.install(&prepared);
    let mut fresh = Controller::<TyreModel<4>, 4>::new(prepared);
    for k in 0..400 {
        if k == 20 {
            assert!(used.start() && fresh.start());
        }
        let input = road(0.015 * (k as f32 * 0.07).sin());
        let (a, b) = (used.step(&input), fresh.step(&input));
        assert_eq!(a.map(f32::to_bits), b.map(f32::to_bits), "step {k}");
        assert_eq!(used.status(), fresh.status(), "step {k}");
    }
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

/// The steady demand of a fresh controller with `p`, started and run on a constant `input`
/// until it settles: what the model and filter ask for, computed without any swap.
fn settled_demand(p: &TyreSet, input: &ModelInput<4>) -> [f32; 4] {
    let mut c = Controller::<TyreModel<4>, 4>::with_params(p, DT).unwrap();
    c.start();
    let mut d = c.step(input);
    for _ in 0..20_000 {
        d = c.step(input);
    }
    d
}

/// The largest step of a fresh controller with `p` started at rest on a constant `input`
/// (its filters start in their steady state) over its first 2000 steps: the f32 rounding
/// its filters make at rest (hundredths of a newton at kilonewtons through four sections).
fn rounding_noise(p: &TyreSet, input: &ModelInput<4>) -> [f32; 4] {
    let mut c = Controller::<TyreModel<4>, 4>::with_params(p, DT).unwrap();
    c.start();
    c.step(input); // from the safe demand to the model's
    let mut last = c.demand();
    let mut worst = [0.0f32; 4];
    for _ in 0..2000 {
        let d = c.step(input);
        for ch in 0..4 {
            worst[ch] = worst[ch].max((d[ch] - last[ch]).abs());
        }
        last = d;
    }
    worst
}

/// A stable section with poles at radius `r` and angle `theta` and zeros elsewhere inside
/// the circle, scaled to DC gain `gain`.
fn section_with_gain(
    r: f64,
    theta: f64,
    zr: f64,
    ztheta: f64,
    gain: f64,
) -> model_core::BiquadCoefficients {
    let unit = section_from_polar((r, theta), (zr, ztheta), 1.0);
    section_from_polar((r, theta), (zr, ztheta), gain / f64::from(unit.dc_gain()))
}

/// Runs `c` on the constant `input` after a swap to `next`, for `steps` steps: the largest
/// step of the demand and the last demand.
fn after_swap(
    c: &mut Controller<TyreModel<4>, 4>,
    next: &TyreSet,
    input: &ModelInput<4>,
    steps: usize,
) -> ([f32; 4], [f32; 4]) {
    let mut last = c.demand();
    c.set_params(next).unwrap();
    let mut worst = [0.0f32; 4];
    for _ in 0..steps {
        let d = c.step(input);
        for ch in 0..4 {
            worst[ch] = worst[ch].max((d[ch] - last[ch]).abs());
        }
        last = d;
    }
    (worst, last)
}

/// Issue 19, point 1: the project's own least-squares command filter for the tyre example
/// (`host-tools/mil/examples/tyre-filter.json`, 2 kHz) uploaded while Running at the
/// static wheel load (1.7 kN). Before: the new coefficients ran on the old filter's state and
/// the demand moved by kilonewtons (in QEMU 1667.7 → 7667.7 N, held back only by the rate
/// limit). Now the demand moves by at most 1/200 of the change in steady demand a step
/// (0.1 s fade at 2 kHz) and settles where a fresh controller with that filter settles.
#[test]
fn a_filter_uploaded_while_running_does_not_step_the_demand() {
    const DT_2K: f32 = 5.0e-4;
    let section = |b: [f32; 3], a: [f32; 2]| model_core::BiquadCoefficients {
        beta0: b[0],
        beta1: b[1],
        beta2: b[2],
        alpha1: a[0],
        alpha2: a[1],
    };
    let lsq = CascadeCoefficients::from_sections(&[
        section(
            [0.12752286, 0.2748732, 0.03965497],
            [0.35244778, 0.084786706],
        ),
        section([26.709831, 2.208521, 0.18128331], [0.35244778, 0.0847867]),
    ])
    .unwrap();
    let settle = |p: &TyreSet, input: &ModelInput<4>| {
        let mut c = Controller::<TyreModel<4>, 4>::with_params(p, DT_2K).unwrap();
        c.start();
        let mut d = c.step(input);
        for _ in 0..4000 {
            d = c.step(input);
        }
        d
    };
    let input = road(0.0);
    let mut c = Controller::<TyreModel<4>, 4>::with_params(&tyre_params(), DT_2K).unwrap();
    c.start();
    for _ in 0..2000 {
        c.step(&input);
    }
    let before = c.demand();
    assert!((before[0] - 1667.7).abs() < 0.1, "{before:?}");
    let mut next = tyre_params();
    next.filter = [lsq; 4];
    let want = settle(&next, &input);
    let n = (model_core::BUMPLESS_FADE_S / DT_2K).round() as usize;
    let mut last = before;
    c.set_params(&next).unwrap();
    let mut worst = 0.0f32;
    for _ in 0..n + 2000 {
        let d = c.step(&input);
        worst = worst.max((d[0] - last[0]).abs());
        last = d;
    }
    let bound = (want[0] - before[0]).abs() / n as f32 * 1.001 + 0.01;
    assert!(worst <= bound, "step {worst} N > {bound} N");
    assert!(
        (last[0] - want[0]).abs() < 0.05,
        "{} vs {}",
        last[0],
        want[0]
    );
    println!(
        "least-squares filter uploaded while running: worst demand step {worst:.4} N (steady demand {:.1} → {:.1} N over {n} steps)",
        before[0], want[0]
    );
}

/// Issue 19, point 6: narrowing the demand maximum below the running demand moves the
/// demand down at the rate limit (the rate limit has priority), never in one jump.
#[test]
fn a_narrowed_limit_closes_in_at_the_rate_limit() {
    let input = road(0.02); // 1667.7 + 250 N/mm · 20 mm = 6667.7 N
    let mut c = Controller::<TyreModel<4>, 4>::with_params(&tyre_params(), DT).unwrap();
    c.start();
    for _ in 0..100 {
        c.step(&input);
    }
    assert!((c.demand()[0] - 6667.7).abs() < 1.0);
    let mut next = tyre_params();
    next.limits[0].max = 2000.0;
    next.limits[0].rate = 1.0e6; // 200 N a step at 5 kHz
    let (worst, last) = after_swap(&mut c, &next, &input, 40);
    assert!(worst[0] <= 200.0 * 1.0001, "step {}", worst[0]);
    assert_eq!(last[0], 2000.0);
    assert_eq!(c.status().amplitude_limited & 1, 1);
    // The other channels: unchanged limits, no step at all.
    assert!(worst[1] < 1e-3, "{}", worst[1]);
}

fn stable_section() -> impl Strategy<Value = model_core::BiquadCoefficients> {
    (
        0.0f64..0.995,
        0.0f64..3.0,
        0.0f64..0.999,
        0.0f64..3.0,
        0.3f64..3.0,
    )
        .prop_map(|(r, th, zr, zth, g)| section_with_gain(r, th, zr, zth, g))
        // Command filters as the project designs them: at most about 30 dB of gain at high
        // frequency a section (beta0 is the gain at z = ∞; the tyre example's least-squares
        // filter has a section of beta0 = 26.7). A section of beta0 = 777 runs at rest with
        // f32 rounding noise of newtons; that is the filter, not the swap.
        .prop_filter("finite DC gain, |beta0| <= 30", |s| {
            s.dc_gain().is_finite() && s.beta0.abs() <= 30.0
        })
}

fn tyre_set() -> impl Strategy<Value = TyreSet> {
    (
        1.0e5f32..5.0e5,
        0.0f32..2.0e3,
        500.0f32..4000.0,
        prop::collection::vec(stable_section(), 0..=4),
    )
        .prop_map(|(k, c_t, load, sections)| {
            let mut p = tyre_params();
            for t in &mut p.model.tyre {
                t.stiffness = k;
                t.damping = c_t;
                t.static_load = load;
            }
            p.filter = [CascadeCoefficients::from_sections(&sections).unwrap(); 4];
            p.safe_demand = [0.0; 4];
            p
        })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    /// Any pair of valid sets (stiffness, damping, static load, command filters of 0-4
    /// sections with DC gains 0.3-3), swapped while Running at rest on a road input, limits
    /// out of reach: the demand moves by at most |new steady demand − demand before| / fade
    /// steps a step (plus rounding) and settles where a fresh controller with the new set
    /// settles.
    #[test]
    fn a_parameter_change_at_rest_fades_to_the_new_demand(
        first in tyre_set(),
        second in tyre_set(),
        hold in -0.004f32..0.004,
    ) {
        // Limits out of reach: the fade alone (a clamped target fades at the rate its
        // unclamped offset sets; `a_narrowed_limit_closes_in_at_the_rate_limit` covers limits).
        let wide = |mut p: TyreSet| { p.limits = [WIDE; 4]; p };
        let (first, second) = (wide(first), wide(second));
        let input = road(hold);
        let mut c = Controller::<TyreModel<4>, 4>::with_params(&first, DT).unwrap();
        c.start();
        for _ in 0..20_000 {
            c.step(&input);
        }
        let before = c.demand();
        let want = settled_demand(&second, &input);
        let noise = rounding_noise(&second, &input);
        let n = (model_core::BUMPLESS_FADE_S / DT).round() as usize;
        let (worst, last) = after_swap(&mut c, &second, &input, n + 20_000);
        for ch in 0..4 {
            // Plus the f32 rounding of the sum target + offset (a few ulp of the demand).
            let ulps = 4.0 * f32::EPSILON * want[ch].abs().max(before[ch].abs());
            let bound = (want[ch] - before[ch]).abs() / n as f32 * 1.001 + 2.0 * noise[ch] + ulps + 1e-4;
            prop_assert!(worst[ch] <= bound, "channel {}: step {} N > {} N", ch, worst[ch], bound);
            prop_assert!(
                (last[ch] - want[ch]).abs() < 1e-2 + 5e-5 * want[ch].abs() + 5.0 * noise[ch],
                "channel {}: {} vs {}", ch, last[ch], want[ch]
            );
        }
    }

    /// Any pair of valid sets swapped while Running in the middle of a random road history
    /// (model and filters moving, rate limit out of reach): the step right after the swap
    /// leaves the demand exactly where it was, whatever the new set asks for.
    #[test]
    fn the_step_after_a_parameter_change_holds_the_demand(
        first in tyre_set(),
        second in tyre_set(),
        history in prop::collection::vec(-0.004f32..0.004, 1..300),
        next in -0.004f32..0.004,
    ) {
        let wide = |mut p: TyreSet| { p.limits = [WIDE; 4]; p };
        let (first, second) = (wide(first), wide(second));
        let mut c = Controller::<TyreModel<4>, 4>::with_params(&first, DT).unwrap();
        c.start();
        for z in &history {
            c.step(&road(*z));
        }
        let before = c.demand();
        c.set_params(&second).unwrap();
        let d = c.step(&road(next));
        for ch in 0..4 {
            prop_assert_eq!(d[ch], before[ch], "channel {}", ch);
        }
    }
}

/// Limits moved entirely past the demand (both bounds above it): the lower bound closes in
/// from the demand at the rate limit, the upper one applies at once, and the demand climbs
/// at the rate limit into the new range.
#[test]
fn limits_moved_past_the_demand_close_in_at_the_rate_limit() {
    let l = DemandLimits {
        min: -1000.0,
        max: 12_000.0,
        rate: 1.0,
    };
    let target = DemandLimits {
        min: 20_000.0,
        max: 30_000.0,
        rate: 1.0,
    };
    let next = l.towards(&target, 5000.0, 100.0);
    assert_eq!((next.min, next.max), (5100.0, 30_000.0));
    let next = l.towards(&target, 29_990.0, 100.0);
    assert_eq!((next.min, next.max), (20_000.0, 30_000.0));
    // Narrowing that does not cut the demand applies at once.
    let narrow = DemandLimits {
        min: 0.0,
        max: 3000.0,
        rate: 1.0,
    };
    let next = l.towards(&narrow, 1000.0, 100.0);
    assert_eq!((next.min, next.max), (0.0, 3000.0));
}
