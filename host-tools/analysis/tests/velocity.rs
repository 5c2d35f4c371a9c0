//! The board's velocity estimator in the analysis (`VelocityEstimate::Board`): its response is
//! that of model-core's `VelocityEstimator` stepped in `f32`, the stability count stays
//! consistent with the gain margin, and the tyre set-up uses it by default (validated).

use mil_analysis::examples::{force_actuators, tyre_structure};
use mil_analysis::metrics::{characteristic_loci, log_grid, margins};
use mil_analysis::setup::{Setup, SetupFile};
use mil_analysis::system::{ActuatorControl, Loop, MilSystem, VelocityEstimate};
use mil_analysis::Stability;
use mil_params::ServoHydraulicActuator;
use mil_params::TyreExample;
use model_core::{TyreParams, VelocityEstimator, VelocityFilterCoefficients};
use num_complex::Complex64;
use std::f64::consts::TAU;
use std::path::Path;

/// The paper's controller rate (Hz).
const FS: f64 = 2000.0;

/// The estimator's response at `frequency_hz` measured by stepping model-core's
/// `VelocityEstimator` (f32) on a sampled cosine: one second of transient discarded, then
/// the DFT bin of one second (an integer number of periods).
fn stepped_response(cutoff_hz: f64, frequency_hz: f64) -> Complex64 {
    let dt = 1.0 / FS;
    let c = VelocityFilterCoefficients::new(cutoff_hz as f32, dt as f32).unwrap();
    let mut e = VelocityEstimator::new();
    let n = FS as usize;
    let (mut num, mut den) = (Complex64::default(), Complex64::default());
    for k in 0..2 * n {
        let phase = TAU * frequency_hz * k as f64 * dt;
        let x = phase.cos();
        let v = f64::from(e.step(&c, x as f32));
        if k >= n {
            let w = Complex64::from_polar(1.0, -phase);
            num += v * w;
            den += x * w;
        }
    }
    num / den
}

/// `V(e^{jωT})` of the analysis equals the board's estimator stepped in `f32`, for the
/// model-core tyre's default cut-off, the `mil run` example's and a plain backward
/// difference, from 1 Hz to near Nyquist, to `f32` rounding (1e-6 relative; measured 6e-8).
#[test]
fn board_velocity_response_is_the_stepped_estimator() {
    for cutoff in [f64::from(TyreParams::PAPER.velocity_cutoff_hz), 200.0, 0.0] {
        let v = VelocityEstimate::Board {
            sample_period_s: 1.0 / FS,
            cutoff_hz: cutoff,
        };
        for f in [1.0, 17.0, 100.0, 400.0, 999.0] {
            let want = v.response(f).unwrap();
            let got = stepped_response(cutoff, f);
            assert!(
                (got - want).norm() <= 1e-6 * want.norm(),
                "cut-off {cutoff} Hz, {f} Hz: stepped {got} vs analysis {want}"
            );
        }
        // Low frequencies: a derivative with the estimator's lag.
        let r = v.response(1.0).unwrap() / Complex64::new(0.0, TAU);
        assert!((r.norm() - 1.0).abs() < 1e-3 && r.arg().abs() < 0.01, "{r}");
    }
    let continuous = VelocityEstimate::Continuous;
    let s = Complex64::new(-3.0, 40.0);
    assert_eq!(continuous.response_s(s).unwrap(), s);
}

/// The tyre example with the reference actuator.
fn tyre(example: TyreExample, delay_s: f64) -> MilSystem {
    tyre_structure(&example, 1.0 / FS)
        .unwrap()
        .with_actuators(force_actuators(&ServoHydraulicActuator::REFERENCE, delay_s).unwrap())
}

fn gain_margin(system: &MilSystem) -> f64 {
    let f = log_grid(5.0, 100.0, 2000);
    let pts: Vec<_> = f
        .iter()
        .map(|&x| system.point(x, Loop::Mil).unwrap().open_loop)
        .collect();
    margins(&f, &characteristic_loci(&pts)).gain_margin.unwrap()
}

/// With the board's estimator the open loop is proportional to the tyre impedance (a
/// numerical part without masses), so scaling `k_t` and `c_t` by `α` scales `L` by `α`: the
/// argument-principle count on the discrete `V(e^{sT})` must report a stable loop just below
/// the gain margin and one unstable pair just above it. The estimator lowers the margin
/// below the continuous `c_t s` one.
#[test]
fn stability_count_with_the_board_estimator_agrees_with_the_gain_margin() {
    let delay = 1.5 / FS;
    let board = tyre(TyreExample::default(), delay);
    assert!(matches!(
        board.interface.velocity,
        VelocityEstimate::Board { cutoff_hz, sample_period_s }
            if cutoff_hz == 500.0 && sample_period_s == 1.0 / FS
    ));
    board.validate().unwrap();
    let gm = gain_margin(&board);
    let mut continuous = board.clone();
    continuous.interface.velocity = VelocityEstimate::Continuous;
    let gm_continuous = gain_margin(&continuous);
    println!("gain margin: board estimator {gm:.4}, continuous c_t s {gm_continuous:.4}");
    assert!(gm < gm_continuous - 0.01, "{gm} vs {gm_continuous}");
    assert_eq!(board.stability(Loop::Mil), Stability::Stable);
    for (alpha, expected) in [
        (0.98 * gm, Stability::Stable),
        (1.02 * gm, Stability::Unstable(2)),
    ] {
        let mut scaled = board.clone();
        scaled.interface.stiffness *= alpha;
        scaled.interface.damping *= alpha;
        assert_eq!(scaled.stability(Loop::Mil), expected, "k_t, c_t × {alpha}");
        assert_eq!(scaled.stability(Loop::Emulated), Stability::Stable);
    }
}

/// The board's estimator is a property of the MiL loop only: the emulated loop keeps
/// `c_t s` (the direct solution of the coupled system).
#[test]
fn emulated_loop_keeps_the_continuous_velocity() {
    let board = tyre(TyreExample::default(), 1.5 / FS);
    let mut continuous = board.clone();
    continuous.interface.velocity = VelocityEstimate::Continuous;
    for f in [2.0, 17.0, 300.0] {
        let a = board.point(f, Loop::Emulated).unwrap().interface_force;
        let b = continuous.point(f, Loop::Emulated).unwrap().interface_force;
        assert_eq!(a, b);
    }
    // Near the MiL resonance the estimator's lag moves the response by tenths of a dB.
    let a = board.point(17.0, Loop::Mil).unwrap().interface_force[(0, 0)];
    let b = continuous.point(17.0, Loop::Mil).unwrap().interface_force[(0, 0)];
    assert!((a / b).norm().log10().abs() * 20.0 > 0.1, "{a} vs {b}");
}

fn read(text: &str) -> Result<Setup, String> {
    let file: SetupFile = toml::from_str(text).map_err(|e| e.to_string())?;
    Setup::from_file(&file, Path::new(".")).map_err(|e| e.to_string())
}

const TYRE: &str = "[model]\nexample = \"tyre\"\n{tyre}\
    [actuator]\ncontrol = \"{control}\"\ntracking = {tracking}\ndisturbance = {disturbance}\n\
    [controller]\nsample_rate_hz = {fs}\n\
    [[analysis.responses]]\nname = \"tyre\"\ninput = \"road\"\noutput = \"interface_force\"\n";

fn tyre_text(tyre: &str, position: bool, fs: f64) -> String {
    let (control, tracking, disturbance) = if position {
        (
            "position",
            "{ numerator = [1.0], denominator = [1.0] }",
            "\"none\"",
        )
    } else {
        ("force", "\"reference\"", "\"reference\"")
    };
    TYRE.replace("{tyre}", tyre)
        .replace("{control}", control)
        .replace("{tracking}", tracking)
        .replace("{disturbance}", disturbance)
        .replace("{fs}", &format!("{fs:?}"))
}

/// The set-up file: `[model.tyre]` defaults to the board's estimator at the controller's
/// sample period with the model-core tyre's cut-off; `velocity_cutoff_hz` and
/// `velocity_estimate` override it; invalid values are refused with the key named; a custom
/// interface is continuous unless it gives `velocity_cutoff_hz`, which needs the tyre's form.
#[test]
fn setup_file_velocity_keys() {
    let velocity = |tyre: &str, position: bool, fs: f64| {
        read(&tyre_text(tyre, position, fs)).map(|s| s.system.interface.velocity)
    };
    assert_eq!(
        velocity("", false, 2000.0),
        Ok(VelocityEstimate::Board {
            sample_period_s: 5e-4,
            cutoff_hz: f64::from(TyreParams::PAPER.velocity_cutoff_hz),
        })
    );
    assert_eq!(
        velocity("[model.tyre]\nvelocity_cutoff_hz = 200.0\n", false, 5000.0),
        Ok(VelocityEstimate::Board {
            sample_period_s: 2e-4,
            cutoff_hz: 200.0,
        })
    );
    assert_eq!(
        velocity(
            "[model.tyre]\nvelocity_estimate = \"continuous\"\n",
            false,
            2000.0
        ),
        Ok(VelocityEstimate::Continuous)
    );
    // Position control: the numerical tyre integrates B_i⁻¹, no velocity estimate.
    assert_eq!(velocity("", true, 2000.0), Ok(VelocityEstimate::Continuous));
    for (tyre, fs) in [
        ("[model.tyre]\nvelocity_cutoff_hz = -1.0\n", 2000.0),
        ("[model.tyre]\nvelocity_cutoff_hz = 3e4\n", 2000.0),
        ("[model.tyre]\nvelocity_cutoff_hz = nan\n", 2000.0),
        ("", 50.0),
    ] {
        let e = velocity(tyre, false, fs).unwrap_err();
        assert!(e.contains("velocity_cutoff_hz"), "{tyre:?} at {fs} Hz: {e}");
    }
    let e = velocity(
        "[model.tyre]\nvelocity_estimate = \"exact\"\n",
        false,
        2000.0,
    );
    assert!(e.unwrap_err().contains("velocity_estimate"));

    // Custom: the tyre in matrix form.
    let custom = |extra: &str, control: &str| {
        format!(
            "[model]\nexample = \"custom\"\n\
             [physical]\ndofs = [\"x_s\", \"x_u\"]\nmass = [[150.0, 0.0], [0.0, 20.0]]\n\
             damping = [[2500.0, -2500.0], [-2500.0, 2500.0]]\n\
             stiffness = [[1.2e5, -1.2e5], [-1.2e5, 1.2e5]]\n\
             [interface]\nlocation = \"numerical\"\nphysical_dofs = [\"x_u\"]\n\
             stiffness = [[2.5e5]]\ndamping = [[500.0]]\n{extra}\
             [[inputs]]\nname = \"road\"\nunit = \"m\"\ninterface_position = [1.0]\n\
             [actuator]\ncontrol = \"{control}\"\n\
             tracking = {{ numerator = [1.0], denominator = [1.0] }}\ndisturbance = \"none\"\n\
             [controller]\nsample_rate_hz = 2000.0\n\
             [[analysis.responses]]\nname = \"tyre\"\ninput = \"road\"\n\
             output = \"interface_force\"\n"
        )
    };
    let v = |extra: &str, control: &str| {
        read(&custom(extra, control)).map(|s| s.system.interface.velocity)
    };
    assert_eq!(v("", "force"), Ok(VelocityEstimate::Continuous));
    assert_eq!(
        v("velocity_cutoff_hz = 0.0\n", "force"),
        Ok(VelocityEstimate::Board {
            sample_period_s: 5e-4,
            cutoff_hz: 0.0
        })
    );
    let e = v("velocity_cutoff_hz = 100.0\n", "position").unwrap_err();
    assert!(e.contains("configuration 4"), "{e}");
    let e = v("velocity_cutoff_hz = -5.0\n", "force").unwrap_err();
    assert!(e.contains("velocity_cutoff_hz"), "{e}");
}

/// The structure's own validation: the board's estimator only where the board computes the
/// interface force from a sampled deflection.
#[test]
fn board_estimator_only_in_the_tyre_form() {
    let mut system = tyre(TyreExample::default(), 0.0);
    system.actuators.control = ActuatorControl::Position;
    let e = system.validate().unwrap_err().to_string();
    assert!(e.contains("configuration 4"), "{e}");
    let mut system = tyre(TyreExample::default(), 0.0);
    system.interface.velocity = VelocityEstimate::Board {
        sample_period_s: 0.0,
        cutoff_hz: 500.0,
    };
    assert!(system.validate().is_err());
    assert!(system.point(10.0, Loop::Mil).is_err());
    assert!(system.point(10.0, Loop::Emulated).is_ok());
}
