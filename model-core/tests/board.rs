//! The board's run-time choice of model (`model_core::board`): every configuration runs; a
//! change of model is refused unless Idle and never steps the demand; after it the next
//! Start runs the new model exactly as a controller built for it would; and any parameter
//! set the board accepts, in any configuration, gives a finite demand inside the limits for
//! any valid measurement, and latches the fault and ramps to the safe demand on an invalid
//! one.

use model_core::board::{BoardController, BoardParams, ModelKind, SwapError, BOARD_CHANNELS};
use model_core::params::Field;
use model_core::{
    AeroModel, AeroParams, CascadeCoefficients, Causality, Controller, ControllerParams,
    DemandLimits, ElementLaw, InterfaceParams, Mode, ModelInput, ParamError, SubstructureElement,
    TyreParams,
};
use proptest::prelude::*;

const DT: f32 = 1.0 / 2000.0;

fn limits(min: f32, max: f32) -> DemandLimits {
    DemandLimits {
        min,
        max,
        rate: 1.0e6,
    }
}

/// Tyres on `channels` hubs: the firmware's defaults.
fn tyres(channels: u32) -> BoardParams {
    BoardParams::tyres(
        TyreParams::PAPER,
        channels,
        limits(-1000.0, 12_000.0),
        1667.7,
        5.0e4,
    )
}

/// Four masses on road springs, channel `c` coupled to DOF `c` by `B_i`.
fn substructure(channels: u32, causality: Causality) -> BoardParams {
    let mut p = tyres(channels);
    p.kind = ModelKind::Substructure as u32;
    let s = &mut p.substructure;
    *s = model_core::SubstructureParams::zeroed(4, causality);
    for j in 0..4 {
        s.mass[j][j] = 10.0 + 5.0 * j as f32;
        s.ground_stiffness[j][j] = 4.0e4;
        s.ground_damping[j][j] = 200.0;
        s.interface[j] = InterfaceParams {
            dof: j as u32,
            stiffness: 1.0e4,
            damping: 5.0,
        };
    }
    s.element_count = 1;
    s.elements[0] = SubstructureElement {
        dof_coefficients: [1.0, -1.0, 0.0, 0.0, 0.0, 0.0],
        road_coefficients: [0.0; BOARD_CHANNELS],
        law: ElementLaw {
            bump_gap: 0.002,
            bump_stiffness: 1.0e5,
            rebound_damping: 300.0,
            ..ElementLaw::linear(2.0e4, 100.0)
        },
    };
    p.limits = [limits(-5000.0, 5000.0); BOARD_CHANNELS];
    p.safe_demand = [0.0; BOARD_CHANNELS];
    p
}

fn aero() -> BoardParams {
    let mut p = tyres(2);
    p.kind = ModelKind::Aero as u32;
    p.limits = [limits(-20_000.0, 5000.0); BOARD_CHANNELS];
    p.safe_demand = [-3000.0, -5000.0, 0.0, 0.0];
    p
}

/// A sample of a road and body motion, forces and speed.
fn input(k: usize) -> ModelInput<BOARD_CHANNELS> {
    let t = k as f32 * DT;
    let s = |f: f32, p: f32| libm::sinf(2.0 * core::f32::consts::PI * f * t + p);
    let mut i = ModelInput::<BOARD_CHANNELS>::default();
    for c in 0..BOARD_CHANNELS {
        let p = c as f32;
        i.position[c] = 0.004 * s(1.3 + p, p);
        i.road[c] = 0.006 * s(2.1 + 0.5 * p, 2.0 * p);
        i.force[c] = 300.0 * s(3.1 + p, p);
    }
    i.speed = 50.0 + 5.0 * s(0.2, 0.0);
    i
}

fn within(d: &[f32; BOARD_CHANNELS], p: &BoardParams, channels: usize) -> bool {
    d.iter()
        .zip(&p.limits)
        .take(channels)
        .all(|(d, l)| d.is_finite() && *d >= l.min && *d <= l.max)
        && d.iter().skip(channels).all(|d| *d == 0.0)
}

/// Every kind on every channel count it runs on: starts, runs 0.5 s, demands finite,
/// inside the limits, moving, and nothing on the channels it does not run.
#[test]
fn every_configuration_runs() {
    let mut configurations = vec![aero()];
    for ch in 1..=4 {
        configurations.push(tyres(ch));
        for causality in [
            Causality::Admittance,
            Causality::Impedance,
            Causality::AdmittanceThroughImpedance,
            Causality::PrescribedMotion,
        ] {
            configurations.push(substructure(ch, causality));
        }
    }
    for p in configurations {
        let label = format!("{:?} x{}", p.model_kind(), p.channels);
        let mut c =
            BoardController::with_params(&p, DT).unwrap_or_else(|e| panic!("{label}: {e:?}"));
        assert_eq!((c.kind() as u32, c.channels() as u32), (p.kind, p.channels));
        assert!(c.start());
        let mut first = None;
        let mut moved = false;
        for k in 0..1000 {
            let d = c.step(&input(k));
            assert_eq!(c.mode(), Mode::Running, "{label} step {k}");
            assert!(within(&d, &p, c.channels()), "{label} step {k}: {d:?}");
            let f = *first.get_or_insert(d);
            moved |= d != f;
        }
        assert!(moved, "{label}: the demand never moved");
    }
}

/// A kind or channel count outside the board's, named by field; nothing else checked of
/// kinds that do not run.
#[test]
fn invalid_configurations_are_refused() {
    let refused = |p: BoardParams| {
        BoardController::with_params(&p, DT)
            .map(|_| ())
            .unwrap_err()
    };
    let mut p = tyres(1);
    p.kind = 7;
    assert_eq!(refused(p), ParamError::OutOfRange(Field::ModelKind));
    for ch in [0, 5] {
        assert_eq!(refused(tyres(ch)), ParamError::OutOfRange(Field::Channels));
    }
    let mut a = aero();
    a.channels = 4;
    assert_eq!(refused(a), ParamError::OutOfRange(Field::Channels));
    // The tyre runs; the substructure's garbage does not matter until it is selected.
    let mut t = tyres(2);
    t.substructure.mass[0][0] = f32::NAN;
    assert!(BoardController::with_params(&t, DT).is_ok());
    t.kind = ModelKind::Substructure as u32;
    assert_eq!(refused(t), ParamError::NotFinite(Field::SubstructureMass));
    // A channel the configuration does not run is not checked either.
    let mut u = tyres(1);
    u.limits[3].min = f32::NAN;
    assert!(BoardController::with_params(&u, DT).is_ok());
    u.channels = 4;
    assert_eq!(refused(u), ParamError::NotFinite(Field::DemandAmplitude));
}

/// Tyre x1 → aero: refused while Running and in Fault (the running model carries on
/// untouched), accepted in Idle; the demand then moves from where it was to the aero safe
/// demand at the safe ramp rate, never by more a step; once there, Start runs the aero
/// model exactly as a controller built for it.
#[test]
fn a_model_change_only_while_idle_and_without_a_step() {
    let tyre = tyres(1);
    let aero = aero();
    let to_aero = aero.prepare(DT).unwrap();
    let mut c = BoardController::with_params(&tyre, DT).unwrap();
    let mut twin = BoardController::with_params(&tyre, DT).unwrap();
    assert!(c.start() && twin.start());
    let mut k = 0;
    for _ in 0..200 {
        c.step(&input(k));
        twin.step(&input(k));
        k += 1;
    }
    assert_eq!(c.swap(&to_aero), Err(SwapError::NotIdle));
    assert_eq!((c.kind(), c.mode()), (ModelKind::Tyre, Mode::Running));
    for _ in 0..50 {
        assert_eq!(c.step(&input(k)), twin.step(&input(k)), "untouched");
        k += 1;
    }
    c.trip(1);
    assert_eq!(c.swap(&to_aero), Err(SwapError::NotIdle));
    assert!(c.clear_fault());
    assert_eq!(c.mode(), Mode::Idle);
    let before = c.demand();
    assert_eq!(c.swap(&to_aero), Ok(()));
    assert_eq!(
        (c.kind(), c.channels(), c.mode()),
        (ModelKind::Aero, 2, Mode::Idle)
    );
    assert_eq!(c.demand()[0], before[0], "the demand carries over");
    // Ramp to the aero safe demand at its ramp rate: no step, arrives, stays.
    let max_step = aero.safe_ramp_rate[0] * DT * 1.0001;
    let mut last = c.demand();
    for _ in 0..4000 {
        let d = c.step(&input(k));
        k += 1;
        for ch in 0..2 {
            assert!(
                (d[ch] - last[ch]).abs() <= max_step,
                "step {:?} -> {:?}",
                last,
                d
            );
        }
        last = d;
    }
    assert_eq!(&last[..2], &aero.safe_demand[..2]);
    // Start: the aero model as a controller built for it, bit for bit.
    let mut reference = Controller::<AeroModel, 2>::with_params(
        &ControllerParams {
            model: AeroParams::PAPER,
            filter: [CascadeCoefficients::IDENTITY; 2],
            limits: [aero.limits[0], aero.limits[1]],
            safe_demand: [aero.safe_demand[0], aero.safe_demand[1]],
            safe_ramp_rate: [aero.safe_ramp_rate[0], aero.safe_ramp_rate[1]],
        },
        DT,
    )
    .unwrap();
    assert!(c.start() && reference.start());
    for _ in 0..1000 {
        let i = input(k);
        let narrow = ModelInput {
            position: [i.position[0], i.position[1]],
            force: [i.force[0], i.force[1]],
            road: [i.road[0], i.road[1]],
            speed: i.speed,
        };
        let d = c.step(&i);
        let r = reference.step(&narrow);
        assert_eq!(
            (d[0].to_bits(), d[1].to_bits()),
            (r[0].to_bits(), r[1].to_bits())
        );
        k += 1;
    }
}

/// A change to limits that do not contain the demand: the demand does not jump to the new
/// limits, it closes in at the safe ramp rate. A change of channel count keeps the shared
/// channels' demand and starts the new ones at their safe demand.
#[test]
fn a_change_of_configuration_closes_in_on_new_limits() {
    let mut c = BoardController::with_params(&tyres(2), DT).unwrap();
    assert_eq!(c.demand()[..2], [1667.7, 1667.7]);
    let mut narrow = tyres(4);
    narrow.limits = [limits(-100.0, 100.0); BOARD_CHANNELS];
    narrow.safe_demand = [0.0; BOARD_CHANNELS];
    c.swap(&narrow.prepare(DT).unwrap()).unwrap();
    assert_eq!(c.demand(), [1667.7, 1667.7, 0.0, 0.0]);
    let step = narrow.safe_ramp_rate[0] * DT * 1.0001;
    let mut last = c.demand();
    for k in 0..2000 {
        let d = c.step(&input(k));
        for ch in 0..4 {
            assert!(
                (d[ch] - last[ch]).abs() <= step,
                "channel {ch}: {last:?} -> {d:?}"
            );
        }
        last = d;
    }
    assert_eq!(last, [0.0; 4]);
}

/// Parameter changes within one configuration go through while Running (bumpless, as
/// model-core's controller does them).
#[test]
fn a_parameter_change_within_a_configuration_while_running() {
    let p = tyres(4);
    let mut c = BoardController::with_params(&p, DT).unwrap();
    assert!(c.start());
    for k in 0..100 {
        c.step(&input(k));
    }
    let mut q = p;
    q.tyre.tyre[2].stiffness *= 1.2;
    q.aero.reference_speed = 60.0; // another kind's value: kept, not used
    assert_eq!(c.swap(&q.prepare(DT).unwrap()), Ok(()));
    assert_eq!(c.mode(), Mode::Running);
    assert_eq!(c.params(), &q);
    // Another sample period is another configuration: only while Idle.
    let other = q.prepare(2.0 * DT).unwrap();
    assert_eq!(c.swap(&other), Err(SwapError::NotIdle));
    c.stop();
    assert_eq!(c.swap(&other), Ok(()));
    assert_eq!(c.dt(), 2.0 * DT);
}

/// A substructure's causality decides whether its demand is a force or a position: another
/// causality is another configuration, refused while Running, taken while Idle; its other
/// parameters change while Running.
#[test]
fn a_substructure_changes_causality_only_while_idle() {
    let p = substructure(2, Causality::Impedance);
    let mut c = BoardController::with_params(&p, DT).unwrap();
    assert!(c.start());
    for k in 0..100 {
        c.step(&input(k));
    }
    let mut stiffer = p;
    stiffer.substructure.interface[0].stiffness *= 1.5;
    assert_eq!(c.swap(&stiffer.prepare(DT).unwrap()), Ok(()));
    let admittance = substructure(2, Causality::Admittance).prepare(DT).unwrap();
    assert_eq!(c.swap(&admittance), Err(SwapError::NotIdle));
    assert_eq!(c.params(), &stiffer);
    assert_eq!(c.mode(), Mode::Running);
    c.stop();
    assert_eq!(c.swap(&admittance), Ok(()));
    assert_eq!(c.params(), admittance.params());
}

/// A configuration drawn over the board's kinds, channel counts and documented ranges.
fn any_params() -> impl Strategy<Value = BoardParams> {
    let kind = 0u32..3;
    let channels = 1u32..=4;
    let tyre = (
        0.0f32..1.0e7,
        0.0f32..1.0e4,
        0.0f32..2.0e4,
        0u32..2,
        0.0f32..2000.0,
    );
    let aero = (
        prop::array::uniform4(-3.0e5f32..3.0e5),
        prop::array::uniform2(-2.0e4f32..2.0e4),
        10.0f32..100.0,
        0.5f32..3.0,
        0.5f32..3.0,
    );
    let structure = (
        0u32..4,
        prop::array::uniform4(0.5f32..100.0),
        prop::array::uniform4(1.0e3f32..1.0e6),
        prop::array::uniform4(0.0f32..1.0e3),
        (1.0e3f32..1.0e6, 0.0f32..1.0e3),
        (
            0u32..2,
            0.0f32..1.0e9,
            0.0f32..1.0e5,
            0.0f32..50.0,
            0.0f32..5.0e3,
        ),
    );
    let common = (
        -1.0e5f32..0.0,
        1.0f32..1.0e5,
        1.0e3f32..1.0e7,
        0.0f32..1.0,
        1.0e2f32..1.0e6,
    );
    (kind, channels, tyre, aero, structure, common).prop_map(|(kind, channels, t, a, s, l)| {
        let mut p = tyres(channels);
        p.kind = kind;
        p.channels = if kind == ModelKind::Aero as u32 {
            2
        } else {
            channels
        };
        p.tyre.tyre = [TyreParams {
            stiffness: t.0,
            damping: t.1,
            static_load: t.2,
            lift_off: t.3,
            velocity_cutoff_hz: t.4,
        }; BOARD_CHANNELS];
        p.aero = AeroParams {
            stiffness: [[a.0[0], a.0[1]], [a.0[2], a.0[3]]],
            nominal_force: a.1,
            reference_speed: a.2,
            front_axle: a.3,
            rear_axle: a.4,
            ..AeroParams::PAPER
        };
        let causality = match s.0 {
            0 => Causality::Admittance,
            1 => Causality::Impedance,
            2 => Causality::AdmittanceThroughImpedance,
            _ => Causality::PrescribedMotion,
        };
        let mut sub = model_core::SubstructureParams::zeroed(4, causality);
        for j in 0..4 {
            sub.mass[j][j] = s.1[j];
            sub.ground_stiffness[j][j] = s.2[j];
            sub.ground_damping[j][j] = s.3[j];
            sub.interface[j] = InterfaceParams {
                dof: j as u32,
                stiffness: s.4 .0,
                damping: s.4 .1,
            };
        }
        let (on, cubic, stop, friction, rebound) = s.5;
        sub.element_count = on;
        sub.elements[0] = SubstructureElement {
            dof_coefficients: [1.0, -1.0, 0.0, 0.0, 0.0, 0.0],
            road_coefficients: [0.0; BOARD_CHANNELS],
            law: ElementLaw {
                cubic_stiffness: cubic,
                bump_gap: 0.001,
                bump_stiffness: stop,
                friction_force: friction,
                friction_velocity: 0.05,
                rebound_damping: rebound,
                ..ElementLaw::linear(1.0e4, 50.0)
            },
        };
        p.substructure = sub;
        let (min, max, rate, safe, ramp) = l;
        p.limits = [DemandLimits { min, max, rate }; BOARD_CHANNELS];
        p.safe_demand = [min + safe * (max - min); BOARD_CHANNELS];
        p.safe_ramp_rate = [ramp; BOARD_CHANNELS];
        p
    })
}

/// A valid measurement for any model: positions and roads within ±0.3 m, forces within
/// ±1e4 N, speeds 0–100 m/s.
fn any_input() -> impl Strategy<Value = ModelInput<BOARD_CHANNELS>> {
    (
        prop::array::uniform4(-0.3f32..0.3),
        prop::array::uniform4(-1.0e4f32..1.0e4),
        prop::array::uniform4(-0.3f32..0.3),
        0.0f32..100.0,
    )
        .prop_map(|(position, force, road, speed)| ModelInput {
            position,
            force,
            road,
            speed,
        })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 200, ..ProptestConfig::default() })]

    /// Any accepted set, any configuration, any valid measurements: a finite demand inside
    /// the limits every step; then one invalid measurement (non-finite, or a position out
    /// of the model's range) latches the fault and the demand ramps to the safe demand at
    /// the safe ramp rate, and stays inside the limits.
    #[test]
    fn any_accepted_set_gives_a_safe_demand(
        p in any_params(),
        inputs in prop::collection::vec(any_input(), 50),
        bad in 0usize..3,
    ) {
        let Ok(mut c) = BoardController::with_params(&p, DT) else {
            return Ok(()); // refused: nothing runs
        };
        let channels = c.channels();
        prop_assert!(c.start());
        for i in &inputs {
            let d = c.step(i);
            prop_assert!(within(&d, &p, channels), "{:?}", d);
        }
        let was_running = c.mode() == Mode::Running;
        let mut invalid = inputs[0];
        match bad {
            0 => invalid.position[0] = f32::NAN,
            1 => invalid.speed = f32::INFINITY,
            _ => invalid.position[0] = 1.0e6,
        }
        let before = c.demand();
        let d = c.step(&invalid);
        // A substructure takes any finite position (no range of its own): only
        // non-finite values fault it.
        let must_fault = bad < 2 || p.kind != ModelKind::Substructure as u32;
        if must_fault || !was_running {
            prop_assert_ne!(c.mode(), Mode::Running);
        }
        prop_assert!(within(&d, &p, channels));
        if c.mode() == Mode::Fault {
            let step = p.safe_ramp_rate[0] * DT * 1.0001;
            let mut last = before;
            let mut d = d;
            for _ in 0..20 {
                for ch in 0..channels {
                    let safe = p.safe_demand[ch];
                    prop_assert!((d[ch] - last[ch]).abs() <= step.max(p.limits[ch].rate * DT * 1.0001));
                    prop_assert!((d[ch] - safe).abs() <= (last[ch] - safe).abs() + 1e-3 * safe.abs().max(1.0));
                }
                last = d;
                d = c.step(&inputs[1]);
                prop_assert_eq!(c.mode(), Mode::Fault);
                prop_assert!(within(&d, &p, channels));
            }
        }
    }
}

/// The property above is only as good as the sets it draws that the board accepts: at
/// least a third of them, of every kind.
#[test]
fn the_drawn_sets_are_mostly_accepted() {
    use proptest::strategy::ValueTree;
    use proptest::test_runner::TestRunner;
    let mut runner = TestRunner::deterministic();
    let mut drawn = [0usize; 3];
    let mut accepted = [0usize; 3];
    let mut reasons = std::collections::BTreeMap::new();
    for _ in 0..600 {
        let p = any_params().new_tree(&mut runner).unwrap().current();
        let k = p.kind as usize;
        drawn[k] += 1;
        match p.prepare(DT) {
            Ok(_) => accepted[k] += 1,
            Err(e) => *reasons.entry(format!("{e:?}")).or_insert(0) += 1,
        }
    }
    println!("drawn {drawn:?}, accepted {accepted:?}, refusals {reasons:?}");
    for k in 0..3 {
        assert!(
            3 * accepted[k] >= drawn[k],
            "kind {k}: {accepted:?} of {drawn:?}: {reasons:?}"
        );
    }
}

/// The substructure of `p` on its first `C` channels as a controller of that width: what
/// the host runs for a `C`-channel set-up.
fn narrow<const C: usize>(p: &BoardParams) -> Controller<model_core::SubstructureModel<C>, C> {
    use model_core::board::fit;
    let params = ControllerParams {
        model: p.substructure.first_channels::<C>(),
        filter: fit(&p.filter, CascadeCoefficients::IDENTITY),
        limits: fit(&p.limits, limits(-1.0, 1.0)),
        safe_demand: fit(&p.safe_demand, 0.0),
        safe_ramp_rate: fit(&p.safe_ramp_rate, 1.0),
    };
    Controller::with_params(&params, DT).unwrap()
}

/// The board runs the substructure four channels wide with the unused ones unconnected
/// (one copy of its code in the image): on 1 to 3 channels, in every causality, its
/// demands are bit for bit those of a controller of the configuration's own width, and
/// whatever the page holds for the unused channels (here garbage interfaces, road springs
/// and limits) changes nothing.
#[test]
fn a_narrow_substructure_runs_as_a_controller_of_its_width() {
    fn check<const C: usize>(causality: Causality) {
        let mut p = substructure(C as u32, causality);
        let mut board = BoardController::with_params(&p, DT).unwrap();
        for ch in C..BOARD_CHANNELS {
            p.substructure.interface[ch].dof = 17;
            p.substructure.ground_stiffness[0][ch] = 1.0e6;
            p.substructure.elements[0].road_coefficients[ch] = 5.0;
            p.limits[ch] = limits(3.0, 2.0);
        }
        let garbage = BoardController::with_params(&p, DT).unwrap();
        assert_eq!(garbage.params(), &p);
        let mut with_garbage = garbage;
        let mut host = narrow::<C>(&p);
        assert!(board.start() && with_garbage.start() && host.start());
        for k in 0..2000 {
            let i = input(k);
            let narrow_input = ModelInput {
                position: model_core::board::fit(&i.position, 0.0),
                force: model_core::board::fit(&i.force, 0.0),
                road: model_core::board::fit(&i.road, 0.0),
                speed: i.speed,
            };
            let want = host.step(&narrow_input);
            let d = board.step(&i);
            assert_eq!(with_garbage.step(&i), d, "{causality:?} x{C} step {k}");
            for (ch, w) in want.iter().enumerate() {
                assert_eq!(d[ch].to_bits(), w.to_bits(), "{causality:?} x{C} step {k}");
            }
            assert!(d.iter().skip(C).all(|v| *v == 0.0));
        }
        assert_eq!(board.mode(), Mode::Running);
    }
    for causality in [
        Causality::Admittance,
        Causality::Impedance,
        Causality::AdmittanceThroughImpedance,
        Causality::PrescribedMotion,
    ] {
        check::<1>(causality);
        check::<2>(causality);
        check::<3>(causality);
    }
}

/// A controller of any configuration, as the board's set: the board runs it bit for bit
/// (what `mil sim --board qemu` relies on to configure the firmware for a set-up).
#[test]
fn a_controllers_set_runs_on_the_board_bit_for_bit() {
    let s = substructure(2, Causality::Impedance);
    let sub = ControllerParams {
        model: s.substructure.first_channels::<2>(),
        filter: [CascadeCoefficients::IDENTITY; 2],
        limits: [limits(-5000.0, 5000.0), limits(-4000.0, 6000.0)],
        safe_demand: [0.0, 10.0],
        safe_ramp_rate: [1.0e4, 2.0e4],
    };
    let a = aero();
    let aero_params = ControllerParams {
        model: AeroParams::PAPER,
        filter: [CascadeCoefficients::IDENTITY; 2],
        limits: [limits(-20_000.0, 5000.0); 2],
        safe_demand: [-3000.0, -5000.0],
        safe_ramp_rate: [5.0e4; 2],
    };
    let mut host_sub =
        Controller::<model_core::SubstructureModel<2>, 2>::with_params(&sub, DT).unwrap();
    let mut host_aero = Controller::<AeroModel, 2>::with_params(&aero_params, DT).unwrap();
    let board_sub = BoardParams::of_substructure(&sub);
    let board_aero = BoardParams::of_aero(&aero_params);
    // Both fit the board's page word for word (what XCP writes).
    for p in [&board_sub, &board_aero] {
        assert_eq!(
            model_core::page::from_words(&model_core::page::to_words(p)),
            Ok(*p)
        );
    }
    assert_eq!((board_aero.kind, board_aero.channels), (a.kind, 2));
    let mut on_board = [
        BoardController::with_params(&board_sub, DT).unwrap(),
        BoardController::with_params(&board_aero, DT).unwrap(),
    ];
    assert!(host_sub.start() && host_aero.start());
    assert!(on_board.iter_mut().all(BoardController::start));
    for k in 0..1000 {
        let i = input(k);
        let two = ModelInput {
            position: model_core::board::fit(&i.position, 0.0),
            force: model_core::board::fit(&i.force, 0.0),
            road: model_core::board::fit(&i.road, 0.0),
            speed: i.speed,
        };
        let want = [host_sub.step(&two), host_aero.step(&two)];
        for (board, want) in on_board.iter_mut().zip(want) {
            let got = board.step(&i);
            assert_eq!(
                [got[0].to_bits(), got[1].to_bits()],
                want.map(f32::to_bits),
                "step {k}"
            );
        }
    }
}
