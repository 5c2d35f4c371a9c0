//! The nonlinear actuator, linearised about rest (no load, rod still), is the reference
//! actuator of the analysis: its tracking `p_f(s)` and disturbance `r_f(s)` responses.
//!
//! The Jacobian of [`ForceActuator::derivative`] and of the load-cell force is taken by
//! central differences; the rod motion `y` enters through `ẏ` and `ÿ`, so that
//! `F = p_f F_c + r_f y` follows from the linear state-space model at `s = jω`.
//! Tolerance: 1e-4 relative over 0.1–500 Hz (finite-difference error; the models are the
//! same physics, so any larger gap is a modelling difference).

use mil_analysis::LinearActuator;
use mil_params::ServoHydraulicActuator;
use mil_rig::actuator::{ActuatorEffects, ForceActuator, ACTUATOR_STATES};
use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;
use std::f64::consts::TAU;

/// Inputs of the linearisation: demand F_c (N), rod velocity ẏ (m/s), rod acceleration ÿ
/// (m/s²).
const INPUTS: usize = 3;

struct Linear {
    a: DMatrix<f64>,
    b: DMatrix<f64>,
    /// Load-cell force row: F = c x + d u.
    c: DVector<f64>,
    d: DVector<f64>,
}

fn linearise(act: &ForceActuator) -> Linear {
    let rest = act.equilibrium(0.0);
    // Load-cell force with the rod's inertia: F = F_p(x, ẏ) − m_a ÿ.
    let force = |x: &[f64; ACTUATOR_STATES], u: &[f64; INPUTS]| {
        act.piston_force(x, u[1]) - act.moving_mass_kg() * u[2]
    };
    let f =
        |x: &[f64; ACTUATOR_STATES], u: &[f64; INPUTS]| act.derivative(x, u[0], force(x, u), u[1]);
    let scale_x = [1e-6, 1e-4, 1.0, 1e-3];
    let scale_u = [1e-2, 1e-6, 1e-4];
    let mut lin = Linear {
        a: DMatrix::zeros(ACTUATOR_STATES, ACTUATOR_STATES),
        b: DMatrix::zeros(ACTUATOR_STATES, INPUTS),
        c: DVector::zeros(ACTUATOR_STATES),
        d: DVector::zeros(INPUTS),
    };
    let u0 = [0.0; INPUTS];
    for j in 0..ACTUATOR_STATES {
        let (mut p, mut m) = (rest, rest);
        p[j] += scale_x[j];
        m[j] -= scale_x[j];
        let (fp, fm) = (f(&p, &u0), f(&m, &u0));
        for i in 0..ACTUATOR_STATES {
            lin.a[(i, j)] = (fp[i] - fm[i]) / (2.0 * scale_x[j]);
        }
        lin.c[j] = (force(&p, &u0) - force(&m, &u0)) / (2.0 * scale_x[j]);
    }
    for j in 0..INPUTS {
        let (mut p, mut m) = (u0, u0);
        p[j] += scale_u[j];
        m[j] -= scale_u[j];
        let (fp, fm) = (f(&rest, &p), f(&rest, &m));
        for i in 0..ACTUATOR_STATES {
            lin.b[(i, j)] = (fp[i] - fm[i]) / (2.0 * scale_u[j]);
        }
        lin.d[j] = (force(&rest, &p) - force(&rest, &m)) / (2.0 * scale_u[j]);
    }
    lin
}

/// `(p_f, r_f)` of the linear model at `f` Hz.
fn responses(lin: &Linear, f: f64) -> (Complex64, Complex64) {
    let s = Complex64::new(0.0, TAU * f);
    let c = |x: f64| Complex64::new(x, 0.0);
    let m = DMatrix::<Complex64>::identity(ACTUATOR_STATES, ACTUATOR_STATES) * s - lin.a.map(c);
    let lu = m.lu();
    let through = |u: &DVector<Complex64>| {
        let x = lu.solve(&(lin.b.map(c) * u)).expect("regular");
        (lin.c.map(c).transpose() * x)[(0, 0)] + (lin.d.map(c).transpose() * u)[(0, 0)]
    };
    // Demand 1 N, rod still.
    let p = through(&DVector::from_vec(vec![c(1.0), c(0.0), c(0.0)]));
    // Rod y = 1 m (ẏ = s, ÿ = s²), demand 0.
    let r = through(&DVector::from_vec(vec![c(0.0), s, s * s]));
    (p, r)
}

#[test]
fn linearised_actuator_is_the_reference_actuator() {
    let reference = ServoHydraulicActuator::REFERENCE;
    let act = ForceActuator::new(reference, ActuatorEffects::default()).unwrap();
    let lin = linearise(&act);
    let (pf, rf) = (
        reference.tracking().unwrap(),
        reference.disturbance().unwrap(),
    );
    let mut worst: f64 = 0.0;
    for k in 0..=60 {
        let f = 0.1 * 10f64.powf(k as f64 / 60.0 * (500f64 / 0.1).log10());
        let (p, r) = responses(&lin, f);
        let (pe, re) = (pf.response(f), rf.response(f));
        let ep = (p - pe).norm() / pe.norm();
        let er = (r - re).norm() / re.norm().max(1e-300);
        worst = worst.max(ep).max(er);
        assert!(ep < 1e-4, "p_f at {f} Hz: {p} vs {pe}");
        assert!(er < 1e-4, "r_f at {f} Hz: {r} vs {re}");
    }
    eprintln!("worst relative difference 0.1-500 Hz: {worst:.2e}");
}

/// The effects are off at rest: switching on a lower spool limit, a rate limit and seal
/// friction leaves the linearisation's tracking response unchanged for small signals except
/// for the friction's smoothing slope, and the saturation bites for large ones.
#[test]
fn effects_change_large_signals_only() {
    let reference = ServoHydraulicActuator::REFERENCE;
    let limited = ForceActuator::new(
        reference,
        ActuatorEffects {
            spool_limit: Some(0.3),
            spool_rate_limit_per_s: Some(50.0),
            coulomb_friction_n: None,
            uncompensated_orifice: false,
        },
    )
    .unwrap();
    let (p0, _) = responses(&linearise(&limited), 10.0);
    let pe = reference.tracking().unwrap().response(10.0);
    assert!((p0 - pe).norm() < 1e-4 * pe.norm(), "{p0} vs {pe}");
    // A large force error saturates the valve command at the limit: the spool settles at
    // 0.3, not at the unlimited 1.
    let rest = limited.equilibrium(0.0);
    let d = limited.derivative(&rest, 1e6, 0.0, 0.0);
    let wv = TAU * reference.valve_frequency_hz;
    assert!((d[1] - wv * wv * 0.3).abs() < 1e-6 * wv * wv, "{d:?}");
    // Invalid effects are refused.
    for bad in [
        ActuatorEffects {
            spool_limit: Some(1.5),
            ..ActuatorEffects::default()
        },
        ActuatorEffects {
            coulomb_friction_n: Some(-1.0),
            ..ActuatorEffects::default()
        },
    ] {
        assert!(ForceActuator::new(reference, bad).is_err());
    }
}
