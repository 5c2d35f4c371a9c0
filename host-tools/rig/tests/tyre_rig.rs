//! The tyre example on the simulated hub-coupled rig: integration accuracy of the internal
//! step, and the closed loop behaving as the analysis predicts.

use mil_identify::band_limited_noise;
use mil_rig::harness::{run, Histories, Instrumentation};
use mil_rig::rigs::{paper_tyre_part, tyre_controller, tyre_input};
use model_core::{Controller, DemandLimits, TyreModel, TyreParams};

const FS: f64 = 2000.0;

fn controller() -> Controller<TyreModel<1>, 1> {
    let limits = DemandLimits {
        min: -20_000.0,
        max: 20_000.0,
        rate: 1.0e9,
    };
    tyre_controller(TyreParams::PAPER, limits, FS).unwrap()
}

fn simulate(road: &[f64], internal_step_s: f64) -> Histories {
    let mut parts = vec![paper_tyre_part(internal_step_s).unwrap()];
    let road = vec![road.to_vec()];
    let mut c = controller();
    let (h, stats) = run(
        &mut c,
        &mut parts,
        &Instrumentation::default(),
        FS,
        &road,
        &[f64::from(TyreParams::PAPER.static_load)],
        tyre_input,
        |_| {},
    )
    .unwrap();
    assert_eq!(stats.dropped + stats.corrupted, 0);
    h
}

fn rms(v: impl Iterator<Item = f64>) -> f64 {
    let (s, n) = v.fold((0.0, 0usize), |(s, n), x| (s + x * x, n + 1));
    (s / n.max(1) as f64).sqrt()
}

/// The default internal step (100 µs, 5 RK4 steps per 2 kHz control sample) against a
/// reference integration at 2 µs, on 2 s of pink road noise (1 mm RMS, 0.5–50 Hz): the
/// load-cell force differs by less than 1e-4 of its RMS variation.
#[test]
fn internal_step_is_accurate() {
    let road = band_limited_noise(0.5, 50.0, 2.0, FS, 1e-3, true, 7);
    let coarse = simulate(&road, 100e-6);
    let fine = simulate(&road, 2e-6);
    let (coarse, fine) = (&coarse.mil_force[0], &fine.mil_force[0]);
    let mean = coarse.iter().sum::<f64>() / road.len() as f64;
    let variation = rms(coarse.iter().map(|f| f - mean));
    let error = rms(coarse.iter().zip(fine).map(|(a, b)| a - b));
    eprintln!("force RMS variation {variation:.1} N, RK4 100 us vs 2 us: {error:.3e} N");
    assert!(
        variation > 100.0,
        "the road must excite the rig: {variation}"
    );
    assert!(error < 1e-4 * variation, "{error} vs {variation}");
}

/// At rest with a static road the rig holds the car's weight: the load cell reads the
/// static load and nothing moves (the harness starts at the static equilibrium).
#[test]
fn rig_starts_and_stays_at_rest() {
    let h = simulate(&vec![0.0; 2000], 100e-6);
    let load = f64::from(TyreParams::PAPER.static_load);
    assert_eq!(h.len(), 2000);
    for (f, y) in h.mil_force[0].iter().zip(&h.mil_position[0]) {
        assert!((f - load).abs() < 1e-3, "{f}");
        assert!(y.abs() < 1e-8, "{y}");
    }
    // (The f32 static load differs from the f64 weight by 7e-5 N.)
    for f in &h.emulated_force[0] {
        assert!((f - load).abs() < 1e-3, "{f}");
    }
}

/// The MiL rig's DOF histories are the specimen's DOFs, named per part: the hub's is the
/// hub actuator's attachment position, sample for sample; the body moves, less than the
/// hub above the wheel-hop frequency's band.
#[test]
fn every_dof_is_recorded() {
    let road = band_limited_noise(0.5, 50.0, 1.0, FS, 1e-3, true, 9);
    let h = simulate(&road, 100e-6);
    let names: Vec<&str> = h.mil_dofs.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(names, ["x_s_0", "x_u_0"]);
    assert_eq!(h.mil_dofs[1].1, h.mil_position[0]);
    let (body, hub) = (&h.mil_dofs[0].1, &h.mil_dofs[1].1);
    assert_eq!(body.len(), h.len());
    let moved = rms(body.iter().copied());
    assert!(moved > 0.0 && moved < rms(hub.iter().copied()), "{moved}");
}
