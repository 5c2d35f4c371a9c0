//! The substructure's nonlinear elements: plumbing (a linear element is the same spring as
//! the matrices', in every causality; a massless interface's demand is the element's force),
//! the explicit part's stability check, and validation. Accuracy against an `f64`
//! integration of the same structure is in the workspace's `tests/substructure_elements.rs`.

use model_core::params::Field;
use model_core::substructure::{SubstructureElement, MAX_ELEMENTS};
use model_core::{
    Causality, ElementLaw, InterfaceParams, Model, ModelInput, ParamError, SubstructureModel,
    SubstructureParams,
};

const DT: f32 = 5.0e-4;

/// Two masses: DOF 0 (20 kg) on a road spring of channel 0, DOF 1 (5 kg) on a spring between
/// the masses; the interface at DOF 1 (channel 0) or DOF 0 (channel 1).
fn two_masses(causality: Causality) -> SubstructureParams<2> {
    let mut p = SubstructureParams::<2>::zeroed(2, causality);
    p.mass[0][0] = 20.0;
    p.mass[1][1] = 5.0;
    p.ground_stiffness[0][0] = 8.0e4;
    p.ground_damping[0][0] = 300.0;
    p.stiffness[1][1] = 1.0e3;
    p.damping[1][1] = 10.0;
    p.interface[0] = InterfaceParams {
        dof: 1,
        stiffness: 2.0e5,
        damping: 500.0,
    };
    p.interface[1] = InterfaceParams {
        dof: 0,
        stiffness: 1.0e5,
        damping: 200.0,
    };
    p
}

/// For prescribed motion: DOF 1 (5 kg) imposed by channel 0, a massless DOF 2 imposed by
/// channel 1 and tied to the free DOF 0 (20 kg, on its road spring) by a spring-damper.
fn prescribed() -> SubstructureParams<2> {
    let mut p = SubstructureParams::<2>::zeroed(3, Causality::PrescribedMotion);
    p.mass[0][0] = 20.0;
    p.mass[1][1] = 5.0;
    p.ground_stiffness[0][0] = 8.0e4;
    p.ground_damping[0][0] = 300.0;
    for (i, j, s) in [(0, 0, 1.0), (2, 2, 1.0), (0, 2, -1.0), (2, 0, -1.0)] {
        p.stiffness[i][j] += s * 2.0e4;
        p.damping[i][j] += s * 40.0;
    }
    p.interface[0].dof = 1;
    p.interface[1].dof = 2;
    p.velocity_cutoff_hz = 200.0;
    p
}

/// The spring-damper between the masses (compression `x_1 − x_0`).
const K_BETWEEN: f32 = 3.0e4;
const C_BETWEEN: f32 = 150.0;

fn in_matrices(mut p: SubstructureParams<2>) -> SubstructureParams<2> {
    for (i, j, s) in [(0, 0, 1.0), (1, 1, 1.0), (0, 1, -1.0), (1, 0, -1.0)] {
        p.stiffness[i][j] += s * K_BETWEEN;
        p.damping[i][j] += s * C_BETWEEN;
    }
    p
}

fn as_element(mut p: SubstructureParams<2>, law: ElementLaw) -> SubstructureParams<2> {
    p.element_count = 1;
    p.elements[0] = SubstructureElement {
        dof_coefficients: [-1.0, 1.0, 0.0, 0.0, 0.0, 0.0],
        road_coefficients: [0.0; 2],
        law,
    };
    p
}

/// A deterministic, broadband input sequence (sums of incommensurate sines).
fn input(k: usize) -> ModelInput<2> {
    let t = k as f32 * DT;
    let w = |f: f32, a: f32| a * libm::sinf(2.0 * core::f32::consts::PI * f * t);
    let road = [w(1.3, 0.01) + w(7.1, 0.002), w(2.9, 0.004)];
    let position = [w(3.7, 0.006) + w(17.3, 0.0005), w(5.3, 0.003)];
    let force = [w(4.1, 300.0) + w(23.0, 40.0), w(1.7, 200.0)];
    ModelInput {
        position,
        force,
        road,
        speed: 0.0,
    }
}

fn run(p: &SubstructureParams<2>, steps: usize) -> Vec<[f32; 2]> {
    let prepared = SubstructureModel::<2>::prepare(p, DT).expect("valid parameters");
    let mut m = SubstructureModel::<2>::new();
    (0..steps).map(|k| m.step(&prepared, &input(k))).collect()
}

/// A linear element is the same spring-damper as written into the matrices, in each of the
/// four causalities: the outputs agree to `f32` rounding (1e-5 of their RMS) over 2 s.
#[test]
fn a_linear_element_is_the_same_spring_as_the_matrices() {
    for causality in [
        Causality::Admittance,
        Causality::Impedance,
        Causality::AdmittanceThroughImpedance,
        Causality::PrescribedMotion,
    ] {
        let base = if causality == Causality::PrescribedMotion {
            prescribed()
        } else {
            two_masses(causality)
        };
        let a = run(&in_matrices(base), 4000);
        let b = run(
            &as_element(base, ElementLaw::linear(K_BETWEEN, C_BETWEEN)),
            4000,
        );
        for ch in 0..2 {
            let rms = (a.iter().map(|y| y[ch] * y[ch]).sum::<f32>() / a.len() as f32).sqrt();
            let worst = a
                .iter()
                .zip(&b)
                .map(|(x, y)| (x[ch] - y[ch]).abs())
                .fold(0.0f32, f32::max);
            println!("{causality:?} channel {ch}: RMS {rms:.4e}, worst difference {worst:.3e}");
            assert!(rms > 0.0, "{causality:?}: channel {ch} silent");
            assert!(
                worst <= 1e-5 * rms,
                "{causality:?} channel {ch}: {worst} against RMS {rms}"
            );
        }
    }
}

/// A massless imposed DOF on a nonlinear element to the road: the demand is the element's
/// force, `F_i = −a F_e(x_e, v_e)`, sample for sample (the velocity is the backward
/// difference the model estimates), through the stop, the asymmetric damping and the
/// friction.
#[test]
fn a_massless_interface_demands_the_element_force() {
    let law = ElementLaw {
        bump_gap: 0.004,
        bump_stiffness: 4.0e5,
        rebound_damping: 900.0,
        friction_force: 30.0,
        friction_velocity: 5.0e-3,
        cubic_stiffness: 2.0e8,
        ..ElementLaw::linear(5.0e4, 300.0)
    };
    let mut p = SubstructureParams::<1>::zeroed(1, Causality::PrescribedMotion);
    p.element_count = 1;
    // Compression: road minus DOF (the element holds the DOF up from the road).
    p.elements[0] = SubstructureElement {
        dof_coefficients: [-1.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        road_coefficients: [1.0],
        law,
    };
    let prepared = SubstructureModel::<1>::prepare(&p, DT).expect("valid");
    let mut m = SubstructureModel::<1>::new();
    let (mut x_prev, mut z_prev) = (0.0f32, 0.0f32);
    let mut engaged = 0;
    for k in 0..4000 {
        let t = k as f32 * DT;
        let x = -0.008 * libm::sinf(2.0 * core::f32::consts::PI * 2.3 * t);
        let z = 0.002 * libm::sinf(2.0 * core::f32::consts::PI * 0.7 * t);
        let input = ModelInput {
            position: [x],
            road: [z],
            ..ModelInput::default()
        };
        let demand = m.step(&prepared, &input)[0];
        let (xe, ve) = (z - x, ((z - z_prev) - (x - x_prev)) / DT);
        let expected = law.force(xe, ve);
        engaged += usize::from(xe > law.bump_gap);
        // The DOF's coefficient is −1: F_i = F_e.
        assert!(
            (demand - expected).abs() <= 2e-4 * expected.abs().max(100.0),
            "sample {k}: demand {demand}, element force {expected}"
        );
        (x_prev, z_prev) = (x, z);
    }
    assert!(engaged > 100, "the stop was never engaged ({engaged})");
}

/// An element whose explicit part is too stiff or too sharp for the step is refused by
/// name; the same element on a heavier mass, or with a smoother friction, is accepted.
#[test]
fn an_element_too_stiff_for_the_step_is_refused() {
    let mut p = SubstructureParams::<1>::zeroed(1, Causality::Impedance);
    p.mass[0][0] = 2.0;
    p.interface[0] = InterfaceParams {
        dof: 0,
        stiffness: 1.0e4,
        damping: 10.0,
    };
    p.element_count = 1;
    let element = |law| SubstructureElement {
        dof_coefficients: [-1.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        road_coefficients: [1.0],
        law,
    };
    let unstable = Err(ParamError::Unstable(Field::SubstructureElement));
    // k_b T²/m = 1e7 · 2.5e-7 / 2 = 1.25 > 1.
    let stiff_stop = ElementLaw {
        bump_gap: 0.01,
        bump_stiffness: 1.0e7,
        ..ElementLaw::linear(1.0e4, 10.0)
    };
    p.elements[0] = element(stiff_stop);
    assert_eq!(
        SubstructureModel::<1>::prepare(&p, DT).map(|_| ()),
        unstable
    );
    p.mass[0][0] = 3.0;
    assert_eq!(SubstructureModel::<1>::prepare(&p, DT).map(|_| ()), Ok(()));
    // F_c/v_eps T/m = 50/1e-3 · 5e-4 / 3 = 8.3 > 1; with v_eps = 0.01 m/s, 0.83.
    let sharp = ElementLaw {
        friction_force: 50.0,
        friction_velocity: 1.0e-3,
        ..ElementLaw::linear(1.0e4, 10.0)
    };
    p.elements[0] = element(sharp);
    assert_eq!(
        SubstructureModel::<1>::prepare(&p, DT).map(|_| ()),
        unstable
    );
    p.elements[0] = element(ElementLaw {
        friction_velocity: 1.0e-2,
        ..sharp
    });
    assert_eq!(SubstructureModel::<1>::prepare(&p, DT).map(|_| ()), Ok(()));
}

/// Element sets validation refuses: too many elements, a compression along a DOF the model
/// lacks, a lever arm beyond the range, an invalid law; each names the element field.
#[test]
fn bad_element_sets_are_refused() {
    let mut p = SubstructureParams::<1>::zeroed(2, Causality::Admittance);
    p.mass[0][0] = 1.0;
    p.mass[1][1] = 1.0;
    p.element_count = 1;
    p.elements[0].dof_coefficients[0] = 1.0;
    p.elements[0].law = ElementLaw::linear(1.0e3, 1.0);
    assert_eq!(p.validate(), Ok(()));
    let f = Field::SubstructureElement;
    let mut too_many = p;
    too_many.element_count = MAX_ELEMENTS as u32 + 1;
    assert_eq!(too_many.validate(), Err(ParamError::OutOfRange(f)));
    let mut beyond = p;
    beyond.elements[0].dof_coefficients[2] = 1.0;
    assert_eq!(beyond.validate(), Err(ParamError::Inconsistent(f)));
    let mut lever = p;
    lever.elements[0].dof_coefficients[1] = 1.0e3;
    assert_eq!(lever.validate(), Err(ParamError::OutOfRange(f)));
    let mut law = p;
    law.elements[0].law.bump_stiffness = -1.0;
    assert_eq!(law.validate(), Err(ParamError::OutOfRange(f)));
    let mut nan = p;
    nan.elements[0].road_coefficients[0] = f32::NAN;
    assert_eq!(nan.validate(), Err(ParamError::NotFinite(f)));
    // Unused slots are not checked: garbage past the count changes nothing.
    let mut unused = p;
    unused.elements[3].law.stiffness = f32::NAN;
    assert_eq!(unused.validate(), Ok(()));
}
