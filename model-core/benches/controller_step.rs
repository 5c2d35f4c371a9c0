//! Host benchmark: nanoseconds per `Controller::step` for the tyre (4 channels) and aero
//! (2 channels) configurations, with and without a 4-section command filter.
//!
//! Run with `cargo bench -p model-core`. Embedded figures (QEMU instruction counts) come
//! from `cargo step-bench`.

use criterion::{criterion_group, criterion_main, Criterion};
use model_core::{
    AeroModel, AeroParams, BiquadCoefficients, CascadeCoefficients, Controller, ControllerParams,
    DemandLimits, ModelInput, SubstructureModel, SubstructureParams, TyreModel, TyreModelParams,
    TyreParams,
};
use std::hint::black_box;

const DT: f32 = 2.0e-4;

/// A stable 4-section cascade (lightly damped poles at several angles).
fn four_sections() -> CascadeCoefficients {
    let sec = |r: f64, th: f64, rz: f64, thz: f64| {
        let s = |r: f64, th: f64| 2.0 - 2.0 * r * th.cos();
        let p = |r: f64, th: f64| 1.0 - 2.0 * r * th.cos() + r * r;
        BiquadCoefficients {
            beta0: 1.0,
            beta1: s(rz, thz) as f32,
            beta2: p(rz, thz) as f32,
            alpha1: s(r, th) as f32,
            alpha2: p(r, th) as f32,
        }
    };
    CascadeCoefficients::from_sections(&[
        sec(0.99, 0.02, 0.98, 0.03),
        sec(0.95, 0.1, 0.9, 0.12),
        sec(0.9, 0.3, 0.5, 1.0),
        sec(0.8, 0.6, 0.3, 2.0),
    ])
    .unwrap_or_default()
}

fn limits() -> DemandLimits {
    DemandLimits {
        min: -1.0e5,
        max: 1.0e5,
        rate: 1.0e9,
    }
}

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("controller_step");
    for (name, filter) in [
        ("no_filter", CascadeCoefficients::IDENTITY),
        ("filter4", four_sections()),
    ] {
        let tyre = ControllerParams {
            model: TyreModelParams {
                tyre: [TyreParams::PAPER; 4],
            },
            filter: [filter; 4],
            limits: [limits(); 4],
            safe_demand: [0.0; 4],
            safe_ramp_rate: [1.0e6; 4],
        };
        if let Ok(mut ctl) = Controller::<TyreModel<4>, 4>::with_params(&tyre, DT) {
            ctl.start();
            let mut k = 0u32;
            group.bench_function(format!("tyre4_{name}"), |b| {
                b.iter(|| {
                    k = k.wrapping_add(1);
                    let z = 1.0e-3 * ((k % 1000) as f32 * 6.283e-3).sin();
                    black_box(ctl.step(black_box(&ModelInput {
                        road: [z; 4],
                        ..ModelInput::default()
                    })))
                })
            });
        }
        let aero = ControllerParams {
            model: AeroParams::PAPER,
            filter: [filter; 2],
            limits: [limits(); 2],
            safe_demand: [0.0; 2],
            safe_ramp_rate: [1.0e6; 2],
        };
        if let Ok(mut ctl) = Controller::<AeroModel, 2>::with_params(&aero, DT) {
            ctl.start();
            let mut k = 0u32;
            group.bench_function(format!("aero2_{name}"), |b| {
                b.iter(|| {
                    k = k.wrapping_add(1);
                    let x = 1.0e-3 * ((k % 1000) as f32 * 6.283e-3).sin();
                    black_box(ctl.step(black_box(&ModelInput {
                        position: [x, -x],
                        speed: 50.0,
                        ..ModelInput::default()
                    })))
                })
            });
        }
    }
    // A 6-DOF substructure serving 2 channels (the largest model).
    let mut s = SubstructureParams::<2>::zeroed(6, model_core::Causality::Impedance);
    for i in 0..6 {
        s.mass[i][i] = 10.0;
        s.stiffness[i][i] = 2.0e4;
        if i + 1 < 6 {
            s.stiffness[i][i + 1] = -5.0e3;
            s.stiffness[i + 1][i] = -5.0e3;
        }
    }
    s.interface[1].dof = 5;
    s.interface[0].stiffness = 1.0e4;
    s.interface[1].stiffness = 1.0e4;
    let sub = ControllerParams {
        model: s,
        filter: [CascadeCoefficients::IDENTITY; 2],
        limits: [limits(); 2],
        safe_demand: [0.0; 2],
        safe_ramp_rate: [1.0e6; 2],
    };
    if let Ok(mut ctl) = Controller::<SubstructureModel<2>, 2>::with_params(&sub, DT) {
        ctl.start();
        let mut k = 0u32;
        group.bench_function("substructure6dof2_no_filter", |b| {
            b.iter(|| {
                k = k.wrapping_add(1);
                let x = 1.0e-3 * ((k % 1000) as f32 * 6.283e-3).sin();
                black_box(ctl.step(black_box(&ModelInput {
                    position: [x, -x],
                    ..ModelInput::default()
                })))
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
