//! Calibration aid for the reference actuator: prints the tyre example's MiL figures
//! (gain margin, resonances, noise) for the reference actuator, optionally with
//! `K_p K_i f_valve κ loop_delay` given as arguments, or with `scan` for a grid of force-loop
//! gains and valve frequencies around it (the scan that chose the reference values):
//! `cargo run --release -p mil-analysis --example calibrate_reference_actuator -- scan`.
use mil_analysis::analyze::{analyze, AnalysisOptions, ResponseSpec, Signal};
use mil_analysis::examples::{force_actuators, tyre_structure};
use mil_analysis::LinearActuator;
use mil_params::{ServoHydraulicActuator, TyreExample};

fn figures(
    act: &ServoHydraulicActuator,
    delay: f64,
) -> Option<mil_analysis::analyze::AnalysisReport> {
    let sys = tyre_structure(&TyreExample::default(), 1.0 / 2000.0)
        .ok()?
        .with_actuators(force_actuators(act, delay).ok()?);
    analyze(&sys, &options()).ok()
}

fn options() -> AnalysisOptions {
    AnalysisOptions {
        f_min_hz: 0.5,
        f_max_hz: 300.0,
        points_per_decade: 200,
        bands: vec![(0.5, 5.0), (5.0, 10.0), (10.0, 30.0)],
        responses: vec![ResponseSpec {
            name: "tyre force".into(),
            input: 0,
            output: Signal::InterfaceForce(0),
            display_scale: 1e-3,
            display_unit: "N/mm".into(),
        }],
        min_prominence_db: 1.0,
        noise_rms: 2e-6,
        nyquist_hz: 1000.0,
    }
}

fn scan() {
    let base = ServoHydraulicActuator::REFERENCE;
    for fv in [60.0, 80.0, 100.0, 120.0, 150.0] {
        for ki in [2e-4, 2.5e-4, 3e-4, 3.5e-4, 4e-4, 5e-4] {
            for kp in [7e-6, 8e-6, 9e-6, 1e-5, 1.1e-5, 1.2e-5, 1.4e-5] {
                let zv = 0.7;
                let act = ServoHydraulicActuator {
                    valve_frequency_hz: fv,
                    integral_gain_per_n_s: ki,
                    proportional_gain_per_n: kp,
                    ..base
                };
                let Some(r) = figures(&act, 0.75e-3) else {
                    continue;
                };
                let Some(gm) = r.mil.gain_margin else {
                    continue;
                };
                if !(1.3..1.5).contains(&gm) {
                    continue;
                }
                let res: Vec<String> = r
                    .mil
                    .resonances
                    .iter()
                    .map(|x| format!("{:.1}Hz/{:.1}/ζ{:.3}", x.hz, x.magnitude, x.damping_ratio))
                    .collect();
                let p = act.tracking().unwrap();
                println!("fv {fv} zv {zv} ki {ki:e} kp {kp:e}: GM {gm:.2}@{:.1} PM {:?} res {res:?} p4 {:.1}° p17 {:.2}",
                    r.mil.gain_margin_hz.unwrap_or(0.0), r.mil.phase_margin_deg.map(|x| (x*10.0).round()/10.0),
                    p.response(4.0).arg().to_degrees(), p.response(17.0).norm());
            }
        }
    }
}

fn main() {
    if std::env::args().nth(1).as_deref() == Some("scan") {
        scan();
        return;
    }
    let args: Vec<f64> = std::env::args()
        .skip(1)
        .map(|a| a.parse().unwrap())
        .collect();
    let base = ServoHydraulicActuator::REFERENCE;
    let act = ServoHydraulicActuator {
        proportional_gain_per_n: args
            .first()
            .copied()
            .unwrap_or(base.proportional_gain_per_n),
        integral_gain_per_n_s: args.get(1).copied().unwrap_or(base.integral_gain_per_n_s),
        valve_frequency_hz: args.get(2).copied().unwrap_or(base.valve_frequency_hz),
        velocity_feedforward: args.get(3).copied().unwrap_or(base.velocity_feedforward),
        ..base
    };
    let delay = args.get(4).copied().unwrap_or(0.75e-3);
    let r = figures(&act, delay).expect("valid actuator and set-up");
    let p = act.tracking().unwrap();
    for f in [4.0, 10.0, 17.0, 20.0, 30.0, 100.0] {
        let h = p.response(f);
        print!("p({f})={:.3}∠{:.1} ", h.norm(), h.arg().to_degrees());
    }
    println!();
    println!("mil {:?}", r.mil);
    println!("emu {:?}", r.emulated);
    println!("noise {:?}", r.noise);
}
