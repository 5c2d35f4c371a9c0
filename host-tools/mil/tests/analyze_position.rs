//! `mil analyze` with position-controlled actuators: the paper's 2-DOF example (Lim et al.,
//! Plummer 2006 section 2.5) in configuration 1 (interface impedance `B_i` physical) and
//! configuration 3 (`B_i` numerical), `examples/two-dof-position-*.toml`.
//!
//! Every expected value here is derived by hand from the paper's block diagrams (Figs 5 and
//! 8) and the actuator's physical parameters, not copied from the tool's output:
//!
//! ```text
//! S_n = 1/a_n, S_p = 1/a_p,  a = m s² + c s + k,  B_i = c_i s + k_i,  G = e^{−sτ}
//! configuration 1:  L = G P_d S_n / (B_i⁻¹ + S_p + R_d)
//! configuration 3:  L = G P_d (S_n + B_i⁻¹) / (S_p + R_d)
//! ```
//!
//! (loop broken at the numerical model's summing junction, return difference `1 + L`).

use mil::setup::SetUp;
use mil_analysis::analyze::{analyze, AnalysisReport};
use mil_analysis::poly::{add, mul, Rational};
use mil_analysis::setup::Setup;
use mil_analysis::system::CMatrix;
use mil_analysis::{
    ActuatorControl, ImpedanceLocation, Loop, MilSystem, ResponseSource, Stability,
};
use mil_discretise::polyval;
use num_complex::Complex64;
use std::f64::consts::TAU;
use std::path::PathBuf;

const PHYSICAL: &str = "two-dof-position-physical.toml";
const NUMERICAL: &str = "two-dof-position-numerical.toml";

/// The paper's 2-DOF example (`TwoDofExample` defaults): masses (kg), dampers (N·s/m),
/// springs (N/m).
const M_N: f64 = 10.0;
const C_N: f64 = 20.0;
const K_N: f64 = 4.0e4;
const M_P: f64 = 5.0;
const C_P: f64 = 10.0;
const K_P: f64 = 2.0e4;
const C_I: f64 = 5.0;
const K_I: f64 = 1.0e4;

/// Loop delay of the set-ups: 1.5 samples at 2 kHz (s).
const LOOP_DELAY: f64 = 1.5 / 2000.0;

fn examples() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("examples")
}

fn setup_path(name: &str) -> PathBuf {
    examples().join(name)
}

/// The analysis of a shipped set-up.
fn read(name: &str) -> Setup {
    SetUp::read(&setup_path(name))
        .and_then(|s| s.analysis())
        .unwrap_or_else(|e| panic!("{name}: {e:#}"))
}

// ---------------------------------------------------------------------------------------
// Polynomials (descending powers of s; arithmetic from `mil_analysis::poly`) and hand-made
// checks on them.

/// Number of roots with positive real part, by the Routh–Hurwitz array (s scaled by
/// 1000 rad/s for conditioning). Panics on a zero in the first column (a root on or very
/// near the imaginary axis), which none of the polynomials here should have.
fn rhp_roots(p: &[f64]) -> usize {
    let n = p.len() - 1;
    let scaled: Vec<f64> = p
        .iter()
        .enumerate()
        .map(|(i, c)| c * 1e3f64.powi((n - i) as i32))
        .collect();
    let big = scaled.iter().fold(0.0_f64, |m, c| m.max(c.abs()));
    let q: Vec<f64> = scaled.iter().map(|c| c / big).collect();
    let mut r0: Vec<f64> = q.iter().step_by(2).copied().collect();
    let mut r1: Vec<f64> = q.iter().skip(1).step_by(2).copied().collect();
    let mut first = vec![r0[0]];
    for _ in 0..n {
        r1.resize(r0.len(), 0.0);
        let row_size = r0.iter().fold(0.0_f64, |m, c| m.max(c.abs()));
        assert!(
            r1[0].abs() > 1e-12 * row_size,
            "Routh array: zero in the first column ({p:?})"
        );
        first.push(r1[0]);
        let next: Vec<f64> = (0..r0.len() - 1)
            .map(|j| (r1[0] * r0[j + 1] - r0[0] * r1[j + 1]) / r1[0])
            .collect();
        r0 = std::mem::replace(&mut r1, next);
    }
    first.windows(2).filter(|w| w[0] * w[1] < 0.0).count()
}

#[test]
fn routh_count_of_known_polynomials() {
    // (s + 1)(s + 2)(s + 3): none; (s − 1)(s + 2)(s + 3): one; (s² − s + 4)(s + 3): two.
    assert_eq!(
        rhp_roots(&mul(&mul(&[1.0, 1.0], &[1.0, 2.0]), &[1.0, 3.0])),
        0
    );
    assert_eq!(
        rhp_roots(&mul(&mul(&[1.0, -1.0], &[1.0, 2.0]), &[1.0, 3.0])),
        1
    );
    assert_eq!(rhp_roots(&mul(&[1.0, -1.0, 4.0], &[1.0, 3.0])), 2);
    // Roots at 100 and 2000 rad/s, one pair unstable.
    let p = mul(&[1.0, -20.0, 1e4], &[1.0, 400.0, 4e6]);
    assert_eq!(rhp_roots(&p), 2);
}

// ---------------------------------------------------------------------------------------
// The position-controlled actuator of the set-ups, rebuilt from its physical parameters
// (the derivation is in the comments of two-dof-position-physical.toml).

#[derive(Clone, Copy, Debug)]
struct PositionServo {
    /// Piston annulus area `A` (m²).
    area: f64,
    /// Oil volume `V` (m³).
    volume: f64,
    /// Effective bulk modulus `β` (Pa).
    bulk_modulus: f64,
    /// Moving mass `m_a` (kg).
    moving_mass: f64,
    /// Hydraulic damping ratio `ζ_h` that sets `K_ce`.
    hydraulic_damping: f64,
    /// Servovalve first-order time constant `τ_v` (s).
    valve_lag: f64,
    /// Position-loop (velocity) gain `K_v` (1/s).
    loop_gain: f64,
}

impl PositionServo {
    /// The values documented in the set-up files.
    const FILE: Self = Self {
        area: 5.0e-4,
        volume: 1.0e-4,
        bulk_modulus: 1.0e9,
        moving_mass: 2.0,
        hydraulic_damping: 0.2,
        valve_lag: 1.1e-3,
        loop_gain: TAU * 30.0,
    };

    fn with_loop_gain_hz(self, hz: f64) -> Self {
        Self {
            loop_gain: TAU * hz,
            ..self
        }
    }

    /// `k_h = 4 β A² / V` (N/m).
    fn hydraulic_stiffness(&self) -> f64 {
        4.0 * self.bulk_modulus * self.area * self.area / self.volume
    }

    /// `ω_h = √(k_h / m_a)` (rad/s).
    fn hydraulic_frequency(&self) -> f64 {
        (self.hydraulic_stiffness() / self.moving_mass).sqrt()
    }

    /// `K_ce = 2 ζ_h A² / (m_a ω_h)` (m³/(s·Pa)).
    fn flow_pressure_coefficient(&self) -> f64 {
        2.0 * self.hydraulic_damping * self.area * self.area
            / (self.moving_mass * self.hydraulic_frequency())
    }

    /// `R_d(0) = K_ce / (A² K_v)` (m/N).
    fn static_compliance(&self) -> f64 {
        self.flow_pressure_coefficient() / (self.area * self.area * self.loop_gain)
    }

    /// `τ_v s + 1`.
    fn valve(&self) -> Vec<f64> {
        vec![self.valve_lag, 1.0]
    }

    /// `D(s) = (s³/ω_h² + (m_a K_ce/A²) s² + s)(τ_v s + 1) + K_v`.
    fn denominator(&self) -> Vec<f64> {
        let wh = self.hydraulic_frequency();
        let hydraulic = [
            1.0 / (wh * wh),
            self.moving_mass * self.flow_pressure_coefficient() / (self.area * self.area),
            1.0,
            0.0,
        ];
        add(&mul(&hydraulic, &self.valve()), &[self.loop_gain])
    }

    fn tracking_numerator(&self) -> Vec<f64> {
        vec![self.loop_gain]
    }

    /// `(s/k_h + K_ce/A²)(τ_v s + 1)`.
    fn disturbance_numerator(&self) -> Vec<f64> {
        mul(
            &[
                1.0 / self.hydraulic_stiffness(),
                self.flow_pressure_coefficient() / (self.area * self.area),
            ],
            &self.valve(),
        )
    }

    fn tracking(&self, s: Complex64) -> Complex64 {
        polyval(&self.tracking_numerator(), s) / polyval(&self.denominator(), s)
    }

    fn disturbance(&self, s: Complex64) -> Complex64 {
        polyval(&self.disturbance_numerator(), s) / polyval(&self.denominator(), s)
    }

    /// Puts this actuator into a system.
    fn install(&self, system: &mut MilSystem) {
        let model = |num: Vec<f64>| ResponseSource::Model {
            transfer_function: Rational::new(num, self.denominator()).unwrap(),
            delay_s: 0.0,
        };
        system.actuators.tracking = model(self.tracking_numerator());
        system.actuators.disturbance = model(self.disturbance_numerator());
    }
}

fn coefficients(source: &ResponseSource) -> (&[f64], &[f64], f64) {
    match source {
        ResponseSource::Model {
            transfer_function,
            delay_s,
        } => (
            &transfer_function.numerator,
            &transfer_function.denominator,
            *delay_s,
        ),
        other => panic!("expected a rational model, got {other:?}"),
    }
}

fn assert_close_coefficients(got: &[f64], expected: &[f64], what: &str) {
    assert_eq!(got.len(), expected.len(), "{what}: {got:?} vs {expected:?}");
    for (g, e) in got.iter().zip(expected) {
        assert!(
            (g - e).abs() <= 1e-6 * e.abs(),
            "{what}: {got:?} vs {expected:?}"
        );
    }
}

/// Both files are the configurations they claim, with the documented actuator.
#[test]
fn setups_are_configurations_1_and_3_with_the_documented_actuator() {
    for (name, config, location) in [
        (PHYSICAL, 1, ImpedanceLocation::Physical),
        (NUMERICAL, 3, ImpedanceLocation::Numerical),
    ] {
        let setup = read(name);
        let system = &setup.system;
        assert_eq!(system.configuration(), config, "{name}");
        assert_eq!(system.interface.location, location, "{name}");
        assert_eq!(system.actuators.control, ActuatorControl::Position);
        assert_eq!(system.channels(), 1);
        assert!((system.actuators.loop_delay_s - LOOP_DELAY).abs() < 1e-15);
        let servo = PositionServo::FILE;
        let (num, den, delay) = coefficients(&system.actuators.tracking);
        assert_close_coefficients(num, &servo.tracking_numerator(), "P_d numerator");
        assert_close_coefficients(den, &servo.denominator(), "P_d denominator");
        assert_eq!(delay, 0.0);
        let (num, den, delay) = coefficients(&system.actuators.disturbance);
        assert_close_coefficients(num, &servo.disturbance_numerator(), "R_d numerator");
        assert_close_coefficients(den, &servo.denominator(), "R_d denominator");
        assert_eq!(delay, 0.0);
        // The structure is the paper's: M, C, K of both parts, B_i, and inputs (c s + k) z.
        let part = |p: &mil_analysis::MechanicalPart| {
            (p.mass[(0, 0)], p.damping[(0, 0)], p.stiffness[(0, 0)])
        };
        assert_eq!(part(&system.numerical), (M_N, C_N, K_N));
        assert_eq!(part(&system.physical), (M_P, C_P, K_P));
        assert_eq!(system.interface.stiffness[(0, 0)], K_I);
        assert_eq!(system.interface.damping[(0, 0)], C_I);
        let z_n = &system.inputs[0];
        let z_p = &system.inputs[1];
        assert_eq!((z_n.name.as_str(), z_p.name.as_str()), ("z_n", "z_p"));
        assert_eq!(
            (z_n.numerical_stiffness[0], z_n.numerical_damping[0]),
            (K_N, C_N)
        );
        assert_eq!(
            (z_p.physical_stiffness[0], z_p.physical_damping[0]),
            (K_P, C_P)
        );
        assert_eq!(
            (z_n.physical_stiffness[0], z_p.numerical_stiffness[0]),
            (0.0, 0.0)
        );
    }
}

/// The actuator is a realistic position servo: unit static gain, a well-damped lag with a
/// −3 dB bandwidth in 30–60 Hz, no resonant overshoot, stable; its compliance is the
/// position loop's static compliance `K_ce/(A² K_v)` at low frequency, near the oil column
/// `1/k_h` above the loop bandwidth and the rod inertia `1/(m_a ω²)` above `ω_h`.
#[test]
fn actuator_is_a_realistic_position_servo() {
    let servo = PositionServo::FILE;
    let system = read(PHYSICAL).system;
    let p = |f: f64| system.actuators.tracking.response(f).unwrap();
    let r = |f: f64| system.actuators.disturbance.response(f).unwrap();
    assert!((p(1e-7) - 1.0).norm() < 1e-6, "P_d(0) = {}", p(1e-7));
    let r0 = servo.static_compliance();
    assert!((r(1e-7) - r0).norm() < 1e-6 * r0, "R_d(0) = {}", r(1e-7));
    // Documented: 4.7e-7 m/N, 1/k_h = 1e-7 m/N.
    assert!((r0 - 4.745e-7).abs() < 1e-9, "{r0}");
    assert!((servo.hydraulic_stiffness() - 1.0e7).abs() < 1.0);
    let grid = mil_analysis::metrics::log_grid(0.1, 2000.0, 400);
    let bandwidth = grid
        .iter()
        .copied()
        .find(|&f| p(f).norm() < std::f64::consts::FRAC_1_SQRT_2)
        .unwrap();
    assert!((30.0..60.0).contains(&bandwidth), "−3 dB at {bandwidth} Hz");
    assert!(
        grid.iter().all(|&f| p(f).norm() <= 1.0 + 1e-9),
        "P_d overshoots"
    );
    // All closed-loop poles of the actuator in the left half plane, where the set-up file
    // says: real at 45 and 100 Hz, the oil column at 350 Hz with ζ 0.2 (eigenvalues of the
    // companion matrix of D, in units of 1000 rad/s).
    assert_eq!(rhp_roots(&servo.denominator()), 0);
    let d = servo.denominator();
    let n = d.len() - 1;
    let companion = CMatrix::from_fn(n, n, |i, j| {
        let c = if i == 0 {
            -d[j + 1] * 1e-3f64.powi(j as i32 + 1) / d[0]
        } else if i == j + 1 {
            1.0
        } else {
            0.0
        };
        Complex64::new(c, 0.0)
    });
    let mut poles: Vec<(f64, f64)> = mil_analysis::metrics::eigenvalues(&companion)
        .iter()
        .map(|p| (p.norm() * 1e3 / TAU, -p.re / p.norm()))
        .collect();
    poles.sort_by(|a, b| a.0.total_cmp(&b.0));
    let expected = [(45.0, 1.0), (100.0, 1.0), (350.0, 0.2), (350.0, 0.2)];
    assert_eq!(poles.len(), expected.len());
    for ((hz, zeta), (want_hz, want_zeta)) in poles.iter().zip(expected) {
        assert!((hz / want_hz - 1.0).abs() < 0.02, "{poles:?}");
        assert!((zeta - want_zeta).abs() < 0.01, "{poles:?}");
    }
    // Compliance asymptotes (hand: between K_v and ω_h the loop has given up and the oil
    // column acts, |R_d| within a factor 3 of 1/k_h; far above ω_h the rod mass).
    let mid = r(250.0).norm() * servo.hydraulic_stiffness();
    assert!((1.0 / 3.0..3.0).contains(&mid), "|R_d(250 Hz)| k_h = {mid}");
    let w = TAU * 5000.0;
    let inertia = r(5000.0).norm() * servo.moving_mass * w * w;
    assert!((inertia - 1.0).abs() < 0.05, "|R_d| m_a ω² = {inertia}");
}

// ---------------------------------------------------------------------------------------
// Perfect actuators: MiL = emulated = the coupled system solved directly.

/// The set-up text with other actuator responses (`[actuator]`) and loop delay
/// (`[controller]`).
fn variant(name: &str, tracking: &str, disturbance: &str, loop_delay_s: f64) -> String {
    let text = std::fs::read_to_string(setup_path(name)).unwrap();
    let mut out = String::new();
    let mut edits = 0;
    for line in text.lines() {
        if line.starts_with("tracking = ") {
            out += &format!("tracking = {tracking}\n");
            edits += 1;
        } else if line.starts_with("disturbance = ") {
            out += &format!("disturbance = {disturbance}\n");
            edits += 1;
        } else if line.starts_with("sample_rate_hz = ") {
            out += &format!("{line}\nloop_delay_s = {loop_delay_s:e}\n");
            edits += 1;
        } else {
            out += line;
            out.push('\n');
        }
    }
    assert_eq!(
        edits, 3,
        "{name}: tracking, disturbance and sample rate lines"
    );
    out
}

/// The analysis of a set-up text, its relative file names in the examples folder.
fn read_text(file: &str, text: &str) -> Setup {
    SetUp::from_toml(text, &examples())
        .and_then(|s| s.analysis())
        .unwrap_or_else(|e| panic!("{file}: {e:#}"))
}

fn perfect(name: &str) -> Setup {
    let text = variant(
        name,
        "{ numerator = [1.0], denominator = [1.0] }",
        "\"none\"",
        0.0,
    );
    read_text(name, &text)
}

/// The coupled 2-DOF system at `s`: `[a_n + b, −b; −b, a_p + b] x = E w`, for the inputs
/// `z_n` (column 0) and `z_p` (column 1): `(x_n, x_p)` per input, by Cramer's rule.
fn coupled(s: Complex64) -> [(Complex64, Complex64); 2] {
    let a_n = M_N * s * s + C_N * s + K_N;
    let a_p = M_P * s * s + C_P * s + K_P;
    let b = C_I * s + K_I;
    let det = (a_n + b) * (a_p + b) - b * b;
    let solve = |r_n: Complex64, r_p: Complex64| {
        (
            ((a_p + b) * r_n + b * r_p) / det,
            (b * r_n + (a_n + b) * r_p) / det,
        )
    };
    let zero = Complex64::new(0.0, 0.0);
    [solve(C_N * s + K_N, zero), solve(zero, C_P * s + K_P)]
}

fn assert_rel(got: Complex64, expected: Complex64, tol: f64, what: &str) {
    assert!(
        (got - expected).norm() <= tol * expected.norm().max(1e-300),
        "{what}: {got} vs {expected}"
    );
}

#[test]
fn perfect_actuators_give_the_emulated_system_which_is_the_coupled_2dof_system() {
    for (name, config) in [(PHYSICAL, 1), (NUMERICAL, 3)] {
        let setup = perfect(name);
        let system = &setup.system;
        assert_eq!(system.configuration(), config);
        assert_eq!(system.actuators.loop_delay_s, 0.0);
        for f in [0.7, 5.0, 10.066, 12.4, 13.316, 40.0, 300.0] {
            let s = Complex64::new(0.0, TAU * f);
            let mil = system.point(f, Loop::Mil).unwrap();
            let emu = system.point(f, Loop::Emulated).unwrap();
            let b = C_I * s + K_I;
            for (k, (x_n, x_p)) in coupled(s).into_iter().enumerate() {
                let what = |signal: &str| format!("{name} {f} Hz input {k} {signal}");
                let force = b * (x_n - x_p);
                // The actuator is commanded the position it must take: the numerical
                // interface position (configuration 1) or the physical one (configuration 3).
                let command = if config == 1 { x_n } else { x_p };
                for p in [&mil, &emu] {
                    assert_rel(p.numerical[(0, k)], x_n, 1e-9, &what("x_n"));
                    assert_rel(p.physical[(0, k)], x_p, 1e-9, &what("x_p"));
                    assert_rel(p.interface_force[(0, k)], force, 1e-9, &what("F_i"));
                    // The load cell measures the interface force in both configurations.
                    assert_rel(p.measured[(0, k)], force, 1e-9, &what("measured"));
                    assert_rel(p.command[(0, k)], command, 1e-9, &what("command"));
                }
            }
            assert_rel(
                mil.open_loop[(0, 0)],
                emu.open_loop[(0, 0)],
                1e-12,
                &format!("{name} {f} Hz open loop"),
            );
        }
        // The full analysis then reports identical MiL and emulated responses: zero band
        // errors and the same resonances, at the coupled modes.
        let report = analyze(system, &setup.options).unwrap();
        let (f1, f2) = coupled_modes_hz();
        for resp in &report.responses {
            for b in &resp.band_errors {
                assert!(b.max_magnitude_db < 1e-9 && b.max_phase_deg < 1e-7, "{b:?}");
            }
            assert_eq!(resp.mil_resonances.len(), resp.emulated_resonances.len());
            for (m, e) in resp.mil_resonances.iter().zip(&resp.emulated_resonances) {
                assert!((m.hz - e.hz).abs() < 1e-6 * e.hz, "{m:?} vs {e:?}");
            }
        }
        // x_p / z_n peaks at the two lightly damped coupled modes (damping ratios ≈ 0.02,
        // so peaks within 1 % of the undamped frequencies).
        let peaks = &report.responses[0].emulated_resonances;
        assert_eq!(peaks.len(), 2, "{peaks:?}");
        assert!((peaks[0].hz / f1 - 1.0).abs() < 0.01, "{peaks:?} vs {f1}");
        assert!((peaks[1].hz / f2 - 1.0).abs() < 0.01, "{peaks:?} vs {f2}");
    }
}

/// Undamped natural frequencies (Hz) of the coupled system: `det(K − ω² M) = 0`.
fn coupled_modes_hz() -> (f64, f64) {
    // (k_n + k_i − m_n λ)(k_p + k_i − m_p λ) − k_i² = 0
    let (a, b, c) = (
        M_N * M_P,
        -(M_N * (K_P + K_I) + M_P * (K_N + K_I)),
        (K_N + K_I) * (K_P + K_I) - K_I * K_I,
    );
    let d = (b * b - 4.0 * a * c).sqrt();
    let hz = |lambda: f64| lambda.sqrt() / TAU;
    (hz((-b - d) / (2.0 * a)), hz((-b + d) / (2.0 * a)))
}

/// Where `B_i` sits does not change the emulated system: both files emulate the same
/// coupled 2-DOF system (with the realistic actuator in place, which the emulated loop
/// ignores).
#[test]
fn both_configurations_emulate_the_same_system() {
    let a = read(PHYSICAL).system;
    let b = read(NUMERICAL).system;
    for f in [1.0, 10.066, 13.316, 60.0] {
        let (pa, pb) = (
            a.point(f, Loop::Emulated).unwrap(),
            b.point(f, Loop::Emulated).unwrap(),
        );
        for k in 0..2 {
            assert_rel(pa.physical[(0, k)], pb.physical[(0, k)], 1e-9, "x_p");
            assert_rel(pa.numerical[(0, k)], pb.numerical[(0, k)], 1e-9, "x_n");
        }
    }
}

/// The configuration-1 file is the analysis library's built-in 2-DOF example
/// (`TwoDofExample` defaults) with the interface in the physical part, as its header says,
/// on the built-in position servo with the set-up's loop delay.
#[test]
fn physical_file_equals_the_built_in_example() {
    use mil_analysis::examples::two_dof_structure;
    use mil_analysis::{Actuators, LinearActuator};
    use mil_params::{PositionServoActuator, TwoDofExample};
    let a = read(PHYSICAL).system;
    let servo = PositionServoActuator::REFERENCE;
    let model = |transfer_function| ResponseSource::Model {
        transfer_function,
        delay_s: 0.0,
    };
    let b = two_dof_structure(&TwoDofExample {
        interface_in_numerical: false,
        ..TwoDofExample::default()
    })
    .unwrap()
    .with_actuators(Actuators {
        control: ActuatorControl::Position,
        tracking: model(servo.tracking().unwrap()),
        disturbance: model(servo.disturbance().unwrap()),
        // Replaced by the structure's (identity, one channel).
        transform: a.actuators.transform.clone(),
        loop_delay_s: LOOP_DELAY,
    });
    assert_eq!(b.configuration(), 1);
    for f in [1.0, 10.066, 12.4, 50.0] {
        for which in [Loop::Mil, Loop::Emulated] {
            let (pa, pb) = (a.point(f, which).unwrap(), b.point(f, which).unwrap());
            let d = (&pa.physical - &pb.physical).norm() / pb.physical.norm();
            assert!(d < 1e-12, "{f} Hz: {d}");
        }
    }
}

// ---------------------------------------------------------------------------------------
// The realistic actuator: open loop, stability, gain margin.

/// `L(s)` by hand from the paper's block diagrams (see the module documentation).
fn hand_loop(config: u8, servo: &PositionServo, delay: f64, s: Complex64) -> Complex64 {
    let a_n = M_N * s * s + C_N * s + K_N;
    let a_p = M_P * s * s + C_P * s + K_P;
    let b = C_I * s + K_I;
    let (p, r) = (servo.tracking(s), servo.disturbance(s));
    let g = (-s * delay).exp();
    match config {
        1 => g * p / a_n / (1.0 / b + 1.0 / a_p + r),
        3 => g * p * (1.0 / a_n + 1.0 / b) / (1.0 / a_p + r),
        _ => unreachable!(),
    }
}

#[test]
fn open_loop_is_the_hand_derived_loop() {
    for (name, config) in [(PHYSICAL, 1), (NUMERICAL, 3)] {
        let system = read(name).system;
        for f in [0.5, 3.0, 10.0, 12.4, 13.3, 45.0, 200.0, 800.0] {
            let s = Complex64::new(0.0, TAU * f);
            let got = system.point(f, Loop::Mil).unwrap().open_loop[(0, 0)];
            let expected = hand_loop(config, &PositionServo::FILE, LOOP_DELAY, s);
            assert_rel(got, expected, 1e-6, &format!("{name} MiL L at {f} Hz"));
            // Emulated: P_d = 1, R_d = 0, no delay.
            let got = system.point(f, Loop::Emulated).unwrap().open_loop[(0, 0)];
            let a_n = M_N * s * s + C_N * s + K_N;
            let a_p = M_P * s * s + C_P * s + K_P;
            let b = C_I * s + K_I;
            let expected = if config == 1 {
                1.0 / a_n / (1.0 / b + 1.0 / a_p)
            } else {
                (1.0 / a_n + 1.0 / b) * a_p
            };
            assert_rel(got, expected, 1e-9, &format!("{name} emulated L at {f} Hz"));
        }
    }
}

/// Every MiL signal with the realistic actuator obeys its block of the paper's diagrams
/// (Figs 5 and 8): each part's equation of motion, the numerical model's output delayed by
/// the loop, and the actuator's `x = P_d y + R_d F_load` with `F_load = −F_i`.
#[test]
fn mil_signals_obey_the_block_diagrams() {
    let servo = PositionServo::FILE;
    for (name, config) in [(PHYSICAL, 1), (NUMERICAL, 3)] {
        let system = read(name).system;
        for f in [0.8, 10.066, 12.4, 13.316, 45.0, 200.0] {
            let s = Complex64::new(0.0, TAU * f);
            let p = system.point(f, Loop::Mil).unwrap();
            let a_n = M_N * s * s + C_N * s + K_N;
            let a_p = M_P * s * s + C_P * s + K_P;
            let b = C_I * s + K_I;
            let g = (-s * LOOP_DELAY).exp();
            // Forces of the inputs z_n and z_p on (m_n, m_p).
            let zero = Complex64::new(0.0, 0.0);
            let inputs = [(C_N * s + K_N, zero), (zero, C_P * s + K_P)];
            for (k, (e_n, e_p)) in inputs.into_iter().enumerate() {
                let what = |signal: &str| format!("{name} {f} Hz input {k}: {signal}");
                let (x_n, x_p) = (p.numerical[(0, k)], p.physical[(0, k)]);
                let (f_i, measured, y) = (
                    p.interface_force[(0, k)],
                    p.measured[(0, k)],
                    p.command[(0, k)],
                );
                // Noise-free load cell.
                assert_rel(measured, f_i, 1e-9, &what("measured force"));
                // m_p is moved by its ground input and the interface force only.
                assert_rel(a_p * x_p, e_p + f_i, 1e-9, &what("physical part"));
                // The numerical model integrates m_n under its input and the measured force.
                assert_rel(a_n * x_n, e_n - measured, 1e-9, &what("numerical part"));
                // Its output, delayed: x_n (configuration 1) or x_n − B_i⁻¹ F̂ (3).
                let v = if config == 1 { x_n } else { x_n - measured / b };
                assert_rel(y, g * v, 1e-9, &what("command"));
                // The rod: B_i between rod and m_p (1), or the rod is m_p's interface (3).
                let rod = servo.tracking(s) * y - servo.disturbance(s) * f_i;
                if config == 1 {
                    assert_rel(f_i, b * (rod - x_p), 1e-6, &what("physical B_i"));
                } else {
                    assert_rel(x_p, rod, 1e-6, &what("rod position"));
                }
            }
        }
    }
}

/// Closed-loop poles right of the imaginary axis, by the Nyquist criterion applied to the
/// hand-derived loop with its exact delay: the open loop is stable (checked by Routh on
/// its denominators), so the count is the number of clockwise encirclements of −1, twice
/// the net upward crossings of the real axis left of −1 for ω > 0 (`L(0)` is real and
/// positive and `L → 0` at high frequency, checked).
fn nyquist_count(config: u8, servo: &PositionServo, delay: f64) -> usize {
    // Open-loop poles: of a_n, B_i, and the physical side with the actuator.
    let a_n = [M_N, C_N, K_N];
    let a_p = [M_P, C_P, K_P];
    let b = [C_I, K_I];
    let d = servo.denominator();
    let n_r = servo.disturbance_numerator();
    let side = if config == 1 {
        // a_p D + b D + b a_p N_r
        add(
            &add(&mul(&a_p, &d), &mul(&b, &d)),
            &mul(&mul(&b, &a_p), &n_r),
        )
    } else {
        // D + a_p N_r
        add(&d, &mul(&a_p, &n_r))
    };
    for p in [&a_n[..], &b[..], &side[..]] {
        assert_eq!(
            rhp_roots(p),
            0,
            "open-loop pole in the right half plane: {p:?}"
        );
    }
    let l = |f: f64| hand_loop(config, servo, delay, Complex64::new(0.0, TAU * f));
    let at_zero = l(1e-6);
    assert!(at_zero.re > 0.0 && at_zero.im.abs() < 1e-3 * at_zero.re);
    assert!(l(1e5).norm() < 1e-3);
    let grid = mil_analysis::metrics::log_grid(1e-6, 1e5, 4000);
    let mut net = 0_i64;
    for w in grid.windows(2) {
        let (a, b) = (l(w[0]), l(w[1]));
        if a.im * b.im < 0.0 {
            let t = a.im / (a.im - b.im);
            if a.re + t * (b.re - a.re) < -1.0 {
                net += if b.im > a.im { 1 } else { -1 };
            }
        }
    }
    assert!(net >= 0, "counter-clockwise encirclement of −1: {net}");
    2 * net as usize
}

/// Smallest `1/|L|` where the loop crosses the negative real axis (the classical gain
/// margin), from the analysis' own open-loop trace.
fn smallest_gain_margin(report: &AnalysisReport) -> f64 {
    let locus = &report.traces.mil_open_loop[0];
    locus
        .windows(2)
        .filter(|w| w[0].im * w[1].im < 0.0)
        .filter_map(|w| {
            let t = w[0].im / (w[0].im - w[1].im);
            let re = w[0].re + t * (w[1].re - w[0].re);
            (re < 0.0).then(|| -1.0 / re)
        })
        .fold(f64::INFINITY, f64::min)
}

fn count(stability: Stability) -> usize {
    match stability {
        Stability::Stable => 0,
        Stability::Unstable(n) => n as usize,
        Stability::Unknown => panic!("stability not determined"),
    }
}

/// With the realistic actuator the analysis' closed-loop verdict agrees with an independent
/// Nyquist count on the hand-derived loop, for the shipped actuator and for faster position
/// loops (K_v from 2π·30 to 2π·80 1/s). Configuration 1 crosses the stability boundary in
/// that range (the lightly damped 12–13 Hz mode of m_p held by the rod through k_i puts
/// |L| ≈ 4 where the actuator lags by ~20°): there GM > 1 ⇔ stable, the single relevant
/// phase crossover being near 13 Hz. Configuration 3 stays unstable throughout: its loop
/// gain reaches ~100 (the actuator pushes the inertia of m_p, and the numerical side's
/// compliance includes the soft B_i), so the classical gain margin (the crossover with
/// |L| > 1 near 200 Hz) is far below 1.
#[test]
fn stability_agrees_with_nyquist_and_the_gain_margin() {
    let mut config_1_outcomes = Vec::new();
    for (name, config) in [(PHYSICAL, 1_u8), (NUMERICAL, 3)] {
        let setup = read(name);
        for hz in [30.0, 40.0, 50.0, 55.0, 60.0, 80.0] {
            let servo = PositionServo::FILE.with_loop_gain_hz(hz);
            let mut system = setup.system.clone();
            servo.install(&mut system);
            let report = analyze(&system, &setup.options).unwrap();
            let poles = count(report.mil.stability);
            let expected = nyquist_count(config, &servo, LOOP_DELAY);
            assert_eq!(poles, expected, "{name}, K_v = 2π·{hz}");
            let classical = smallest_gain_margin(&report);
            assert_eq!(
                classical > 1.0,
                poles == 0,
                "{name}, K_v = 2π·{hz}: classical GM {classical}, {poles} poles"
            );
            if config == 1 {
                let gm = report.mil.gain_margin.unwrap();
                assert_eq!(gm > 1.0, poles == 0, "K_v = 2π·{hz}: GM {gm}");
                // Same crossing, interpolated differently (log magnitude against phase here,
                // the real-axis crossing of the complex locus in the test).
                assert!((gm / classical - 1.0).abs() < 0.02, "{gm} vs {classical}");
                let hz_gm = report.mil.gain_margin_hz.unwrap();
                assert!((11.0..15.0).contains(&hz_gm), "phase crossover {hz_gm} Hz");
                config_1_outcomes.push(poles == 0);
            } else {
                assert!(poles > 0, "configuration 3 stable with K_v = 2π·{hz}");
                assert!(classical < 0.1, "configuration 3 classical GM {classical}");
            }
        }
    }
    // The sweep straddles configuration 1's boundary, between 2π·55 and 2π·60 1/s (as the
    // set-up file says): the shipped actuator (2π·30) is unstable.
    assert_eq!(
        config_1_outcomes,
        [false, false, false, false, true, true],
        "configuration 1 stable for K_v = 2π·[30, 40, 50, 55, 60, 80]"
    );
}

/// Without the loop delay the closed loop is rational: Routh–Hurwitz on the closed-loop
/// characteristic polynomial gives the count exactly, and the analysis agrees.
#[test]
fn delay_free_stability_agrees_with_routh() {
    let a_n = [M_N, C_N, K_N];
    let a_p = [M_P, C_P, K_P];
    let b = [C_I, K_I];
    for (name, config) in [(PHYSICAL, 1_u8), (NUMERICAL, 3)] {
        let mut system = read(name).system;
        system.actuators.loop_delay_s = 0.0;
        for hz in [30.0, 60.0] {
            let servo = PositionServo::FILE.with_loop_gain_hz(hz);
            servo.install(&mut system);
            let d = servo.denominator();
            let n_p = servo.tracking_numerator();
            let n_r = servo.disturbance_numerator();
            // 1 + L = 0 multiplied out (module documentation):
            // 1: a_n (a_p D + b D + b a_p N_r) + b a_p N_p
            // 3: a_n b (D + a_p N_r) + (a_n + b) a_p N_p
            let chi = if config == 1 {
                let side = add(
                    &add(&mul(&a_p, &d), &mul(&b, &d)),
                    &mul(&mul(&b, &a_p), &n_r),
                );
                add(&mul(&a_n, &side), &mul(&mul(&b, &a_p), &n_p))
            } else {
                let side = add(&d, &mul(&a_p, &n_r));
                add(
                    &mul(&mul(&a_n, &b), &side),
                    &mul(&mul(&add(&a_n, &b), &a_p), &n_p),
                )
            };
            let expected = rhp_roots(&chi);
            assert_eq!(
                count(system.stability(Loop::Mil)),
                expected,
                "{name}, K_v = 2π·{hz}, no delay"
            );
            assert_eq!(nyquist_count(config, &servo, 0.0), expected);
        }
    }
}

// ---------------------------------------------------------------------------------------
// The paper's sensitivity: position control and where B_i sits.

/// Static loop gains by hand (`s → 0`: `S_n = 1/k_n`, `S_p = 1/k_p`, `B_i⁻¹ = 1/k_i`,
/// `P_d = 1`, `R_d = r_0`):
/// configuration 1: `L(0) = (1/k_n) / (1/k_i + 1/k_p + r_0)`, at most `k_i/k_n`;
/// configuration 3: `L(0) = (1/k_n + 1/k_i) / (1/k_p + r_0)`, which grows with the physical
/// stiffness (capped only by the actuator's own compliance) and without bound as the
/// interface stiffness falls: the paper's reason (section 3.1) not to use position control
/// when `B_i` is numerical and may become small.
#[test]
fn position_loop_gain_grows_with_physical_stiffness_only_when_b_i_is_numerical() {
    let r0 = PositionServo::FILE.static_compliance();
    let dc = |system: &MilSystem| system.point(1e-5, Loop::Mil).unwrap().open_loop[(0, 0)];
    let hand_1 = |k_p: f64, k_i: f64| (1.0 / K_N) / (1.0 / k_i + 1.0 / k_p + r0);
    let hand_3 = |k_p: f64, k_i: f64| (1.0 / K_N + 1.0 / k_i) / (1.0 / k_p + r0);
    let base_1 = read(PHYSICAL).system;
    let base_3 = read(NUMERICAL).system;
    // The shipped set-ups: 0.17 and 2.5 (hand values with r_0 = 4.7e-7 m/N).
    assert!((dc(&base_1).re - hand_1(K_P, K_I)).abs() < 1e-6 * hand_1(K_P, K_I));
    assert!((dc(&base_3).re - hand_3(K_P, K_I)).abs() < 1e-6 * hand_3(K_P, K_I));
    assert!(dc(&base_1).re < 1.0 && dc(&base_3).re > 1.0);

    let (mut last_1, mut last_3) = (0.0, 0.0);
    for k_p in [K_P, 2e5, 2e6, 2e7, 2e8] {
        let (mut s1, mut s3) = (base_1.clone(), base_3.clone());
        s1.physical.stiffness[(0, 0)] = k_p;
        s3.physical.stiffness[(0, 0)] = k_p;
        let (l1, l3) = (dc(&s1).re, dc(&s3).re);
        assert!((l1 / hand_1(k_p, K_I) - 1.0).abs() < 1e-6, "{k_p}: {l1}");
        assert!((l3 / hand_3(k_p, K_I) - 1.0).abs() < 1e-6, "{k_p}: {l3}");
        assert!(l1 > last_1 && l3 > last_3, "loop gains rise with k_p");
        assert!(l1 < K_I / K_N, "configuration 1 bounded by k_i/k_n: {l1}");
        (last_1, last_3) = (l1, l3);
    }
    // Stiff specimen: configuration 3's loop gain is set by the actuator compliance alone.
    let cap = (1.0 / K_N + 1.0 / K_I) / r0;
    assert!(last_3 > 0.9 * cap && last_3 < cap, "{last_3} vs {cap}");
    assert!(last_3 > 100.0 * last_1);

    let (mut last_1, mut last_3) = (f64::INFINITY, 0.0);
    for k_i in [K_I, 1e3, 1e2, 1e1] {
        let (mut s1, mut s3) = (base_1.clone(), base_3.clone());
        s1.interface.stiffness[(0, 0)] = k_i;
        s3.interface.stiffness[(0, 0)] = k_i;
        let (l1, l3) = (dc(&s1).re, dc(&s3).re);
        assert!((l1 / hand_1(K_P, k_i) - 1.0).abs() < 1e-6, "{k_i}: {l1}");
        assert!((l3 / hand_3(K_P, k_i) - 1.0).abs() < 1e-6, "{k_i}: {l3}");
        assert!(
            l1 < last_1 && l3 > last_3,
            "soft interface: 1 falls, 3 rises"
        );
        (last_1, last_3) = (l1, l3);
    }
    // k_i = 10 N/m: configuration 3's static loop gain ≈ k_p/k_i = 2000.
    assert!(last_3 > 1000.0 && last_1 < 1e-3, "{last_3}, {last_1}");
}

// ---------------------------------------------------------------------------------------
// The command-line tool on the new examples.

fn finite(v: &serde_json::Value, what: &str) -> f64 {
    let x = v
        .as_f64()
        .unwrap_or_else(|| panic!("{what} is not a number: {v}"));
    assert!(x.is_finite(), "{what} = {x}");
    x
}

#[test]
fn cli_prints_finite_figures_for_the_position_examples() {
    for (name, config) in [(PHYSICAL, 1), (NUMERICAL, 3)] {
        let out = tempfile::tempdir().unwrap();
        let run = |json: bool| {
            let mut cmd = std::process::Command::new(env!("CARGO_BIN_EXE_mil"));
            cmd.arg("analyze")
                .arg(setup_path(name))
                .arg("--out")
                .arg(out.path());
            if json {
                cmd.arg("--json");
            }
            let o = cmd.output().unwrap();
            assert!(
                o.status.success(),
                "{name}: {}",
                String::from_utf8_lossy(&o.stderr)
            );
            String::from_utf8(o.stdout).unwrap()
        };
        let json: serde_json::Value = serde_json::from_str(&run(true)).unwrap();
        assert_eq!(json["configuration"], config);
        assert_eq!(json["name"], name.trim_end_matches(".toml"));
        for key in [
            "gain_margin",
            "gain_margin_hz",
            "phase_margin_deg",
            "phase_margin_hz",
        ] {
            finite(&json[key], key);
            let emulated = json["emulated"]
                .get(key)
                .unwrap_or_else(|| panic!("emulated {key} missing"));
            if !emulated.is_null() {
                finite(emulated, key);
            }
        }
        for list in [&json["resonances"], &json["emulated"]["resonances"]] {
            let list = list.as_array().unwrap();
            assert!(!list.is_empty());
            for r in list {
                for key in ["hz", "magnitude", "damping_ratio"] {
                    finite(&r[key], key);
                }
            }
        }
        let responses = json["responses"].as_array().unwrap();
        assert_eq!(responses.len(), 3);
        for resp in responses {
            for b in resp["band_errors"].as_array().unwrap() {
                for key in ["max_magnitude_db", "rms_magnitude_db", "max_phase_deg"] {
                    finite(&b[key], key);
                }
            }
        }
        for key in ["peak", "peak_hz", "command_rms"] {
            assert!(finite(&json["noise"][key], key) > 0.0, "{key}");
        }
        // The verdict is the library's, and agrees with the Nyquist count on the hand loop.
        let poles = nyquist_count(config, &PositionServo::FILE, LOOP_DELAY);
        let expected = if poles == 0 {
            serde_json::json!("stable")
        } else {
            serde_json::json!({ "unstable": poles })
        };
        assert_eq!(json["stability"], expected, "{name}");
        let table = run(false);
        assert!(
            table.contains(&format!("configuration {config}")),
            "{table}"
        );
        assert_eq!(table.contains("WARNING"), poles > 0, "{table}");
        for f in ["responses.svg", "open-loop.svg", "responses.csv"] {
            assert!(out.path().join(f).exists(), "{f}");
        }
    }
}

// ---------------------------------------------------------------------------------------
// Why the tyre is not a position-control example (the comment in the 2-DOF files).

/// The actuator lines of the shipped position set-ups.
fn actuator_lines() -> String {
    let text = std::fs::read_to_string(setup_path(PHYSICAL)).unwrap();
    text.lines()
        .filter(|l| l.starts_with("tracking = ") || l.starts_with("disturbance = "))
        .map(|l| format!("{l}\n"))
        .collect()
}

/// The paper's tyre example (`tyre.toml`: the numerical tyre on the physical quarter car,
/// paper values) under position control with the actuator lines of the position set-ups:
/// configuration 3.
fn tyre_position_text() -> String {
    let text = std::fs::read_to_string(setup_path("tyre.toml")).unwrap();
    for key in ["configuration = 4", "control = \"force\""] {
        assert_eq!(text.matches(key).count(), 1, "tyre.toml: {key}");
    }
    text.replace("configuration = 4", "configuration = 3")
        .replace(
            "control = \"force\"",
            &format!("control = \"position\"\n{}", actuator_lines()),
        )
}

/// Configuration 3 with the paper's tyre: the numerical tyre turns the measured hub force
/// into a hub position through `B_t⁻¹`, and the actuator pushes the unsprung mass:
/// `L = G P_d B_t⁻¹ / (S_p + R_d)` with `S_p` the hub compliance of the free quarter car.
/// Above the wheel-hop frequency `|L| ≈ m_u ω² / k_t > 1` where the servo lags by far more
/// than 90°: unstable, and the gain grows without bound as `k_t → 0` (lift-off).
#[test]
fn tyre_with_position_control_is_unstable() {
    let system = read_text("tyre-position.toml", &tyre_position_text()).system;
    assert_eq!(system.configuration(), 3);
    let (m_s, c_c, k_c, m_u, c_t, k_t) = (150.0, 2.5e3, 120e3, 20.0, 500.0, 250e3);
    let servo = PositionServo::FILE;
    let hand = |f: f64| {
        let s = Complex64::new(0.0, TAU * f);
        let body = m_s * s * s + c_c * s + k_c;
        let hub = m_u * s * s + c_c * s + k_c;
        let coupling = c_c * s + k_c;
        let s_p = body / (body * hub - coupling * coupling);
        (-s * LOOP_DELAY).exp() * servo.tracking(s) / (c_t * s + k_t) / (s_p + servo.disturbance(s))
    };
    for f in [1.0, 5.0, 20.0, 60.0, 150.0] {
        let got = system.point(f, Loop::Mil).unwrap().open_loop[(0, 0)];
        assert_rel(got, hand(f), 1e-6, &format!("tyre L at {f} Hz"));
    }
    for f in mil_analysis::metrics::log_grid(20.0, 150.0, 50) {
        assert!(hand(f).norm() > 1.0, "|L({f} Hz)| = {}", hand(f).norm());
        let lag = -servo
            .tracking(Complex64::new(0.0, TAU * f))
            .arg()
            .to_degrees();
        assert!(lag > 25.0, "servo lag {lag}° at {f} Hz");
    }
    assert!(matches!(
        system.stability(Loop::Mil),
        Stability::Unstable(_)
    ));
}

/// Configuration 1 with the tyre would put the real tyre between the actuator and the hub,
/// and the numerical part has no masses left: it only prescribes the road, and there is no
/// loop (`L ≡ 0`) -- a conventional tyre-coupled road simulator, not MiL. (A MiL set-up
/// file cannot say this: its tyre is numerical; so the tyre set-up of configuration 3 is
/// taken with `B_t` moved to the physical part: the road then commands the actuator
/// directly.)
#[test]
fn tyre_with_physical_interface_has_no_loop() {
    let mut system = read_text("tyre-position.toml", &tyre_position_text()).system;
    assert!(system.numerical.is_empty());
    assert_eq!(system.inputs.len(), 1);
    assert_eq!(system.inputs[0].interface_position[0], 1.0, "the road");
    system.interface.location = ImpedanceLocation::Physical;
    system.validate().unwrap();
    assert_eq!(system.configuration(), 1);
    for f in [1.0, 10.0, 100.0] {
        let p = system.point(f, Loop::Mil).unwrap();
        assert_eq!(p.open_loop[(0, 0)].norm(), 0.0, "{f} Hz");
        // The actuator is simply commanded the (delayed) road.
        let s = Complex64::new(0.0, TAU * f);
        assert_rel(p.command[(0, 0)], (-s * LOOP_DELAY).exp(), 1e-12, "command");
    }
}

/// `[actuator.position_servo]` changes the built-in servo's parameters: with a 60 Hz loop
/// gain the set-up's responses are the hand derivation's with that gain, and an invalid
/// value is refused with its name.
#[test]
fn position_servo_parameters_can_be_overridden_in_the_setup() {
    let text = std::fs::read_to_string(setup_path(PHYSICAL)).unwrap();
    let section = |gain: f64| {
        format!(
            "{text}\n[actuator.position_servo]\npiston_area_m2 = 5.0e-4\noil_volume_m3 = 1.0e-4\n\
             bulk_modulus_pa = 1.0e9\nmoving_mass_kg = 2.0\nhydraulic_damping_ratio = 0.2\n\
             valve_time_constant_s = 1.1e-3\nloop_gain_per_s = {gain:e}\n"
        )
    };
    let setup = read_text("fast.toml", &section(TAU * 60.0));
    let servo = PositionServo::FILE.with_loop_gain_hz(60.0);
    let (num, den, _) = coefficients(&setup.system.actuators.tracking);
    assert_close_coefficients(num, &servo.tracking_numerator(), "P_d numerator");
    assert_close_coefficients(den, &servo.denominator(), "P_d denominator");
    let (num, _, _) = coefficients(&setup.system.actuators.disturbance);
    assert_close_coefficients(num, &servo.disturbance_numerator(), "R_d numerator");

    let e = SetUp::from_toml(&section(-1.0), &examples())
        .and_then(|s| s.analysis())
        .map(|_| ())
        .unwrap_err();
    let e = format!("{e:#}");
    assert!(e.contains("loop_gain_per_s"), "{e}");
}
