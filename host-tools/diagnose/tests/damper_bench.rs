//! Displacement-controlled damper tests as a damper test bench records them: the actuator
//! moves the damper's rod through a programme (with short holds between its steps), a load
//! cell measures the force, an LVDT the displacement. The engineer's model is the usual one for such a record (as for EMPS): one
//! DOF, a rough moving mass on a viscous damper to ground, force in, displacement out.
//!
//! The records are made here by laws written for this file alone (not the diagnosis's effect
//! library nor the simulated rig's): a banded friction damper (dry friction of several kN
//! through a compliant band: an elastic-perfectly-plastic Jenkins element, so the force
//! turns over a pre-sliding displacement at each reversal, plus a little viscous damping),
//! and a magneto-rheological damper at two currents (Spencer et al. 1997's Bouc-Wen
//! phenomenological model, `n = 2`, with its accumulator stiffness). With the load cell at
//! the fixed end, as on most benches, the measured force carries no rod inertia at all and
//! the model's mass is wrong by its whole value; at the moving end it carries the rod's.
//!
//! Each case is drawn from a seed: the damper's size and pre-sliding displacement, the
//! programme (sinusoids, constant-velocity triangles with rounded corners, band-limited
//! random motion), the sample rate, the noise, whether the load cell also sees a moving
//! mass, and how rough the engineer's mass and damping are. What such records must give:
//! the dry friction named (`coulomb_friction` or `hysteresis`), no negative mass, stiffness
//! or damping anywhere (the updated model is a valid model file) and the gap at least 2x
//! smaller. The development seeds were looked at while the diagnosis was changed; the
//! held-out seeds were run once, at the end, and are reported separately.

mod common;

use common::names;
use mil_diagnose::{diagnose, Diagnosis, EffectKind, Model, Options, Record};
use mil_numerics::rng::SplitMix64;

use std::f64::consts::PI;

fn uniform(rng: &mut SplitMix64, lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * rng.uniform()
}

/// The largest magnitude in `s`.
fn peak(s: &[f64]) -> f64 {
    s.iter().fold(0.0_f64, |m, v| m.max(v.abs()))
}

fn log_uniform(rng: &mut SplitMix64, lo: f64, hi: f64) -> f64 {
    (lo.ln() + (hi.ln() - lo.ln()) * rng.uniform()).exp()
}

/// The programmes a damper bench runs.
#[derive(Clone, Copy, Debug)]
enum Programme {
    /// Sinusoids at a few frequencies, each faded in and out over a quarter cycle, with
    /// holds between them.
    Sinusoids,
    /// Constant-velocity strokes (a triangle wave with rounded corners) at a few speeds.
    Triangles,
    /// Band-limited random motion (0.3–`f_hi` Hz).
    Random,
}

/// Window that fades a step of `n` samples in and out over `ramp` samples.
fn fade(i: usize, n: usize, ramp: usize) -> f64 {
    if i < ramp {
        0.5 - 0.5 * (PI * i as f64 / ramp as f64).cos()
    } else if i + ramp > n {
        0.5 - 0.5 * (PI * (n - i) as f64 / ramp as f64).cos()
    } else {
        1.0
    }
}

/// A displacement programme (m) at `fs` with peak speeds up to about `v_peak` (m/s) and
/// strokes up to `stroke` (m, amplitude).
fn programme(kind: Programme, fs: f64, v_peak: f64, stroke: f64, rng: &mut SplitMix64) -> Vec<f64> {
    let hold = (uniform(rng, 0.2, 1.0) * fs) as usize;
    let mut x = vec![0.0; hold];
    match kind {
        Programme::Sinusoids | Programme::Triangles => {
            let steps = 3 + (rng.uniform() * 3.0) as usize;
            for s in 0..steps {
                // Speeds spread over a decade below the peak, in a random order.
                let v = v_peak * 10f64.powf(-(s as f64 + rng.uniform()) / steps as f64);
                let a = (stroke * uniform(rng, 0.3, 1.0)).max(1e-4);
                let (f, shape): (f64, fn(f64) -> f64) = match kind {
                    // Peak speed 2π f a.
                    Programme::Sinusoids => ((v / (2.0 * PI * a)).clamp(0.1, 15.0), |p| {
                        (2.0 * PI * p).sin()
                    }),
                    // Stroke speed 4 f a; corners rounded by the clipped sine.
                    _ => ((v / (4.0 * a)).clamp(0.05, 10.0), |p| {
                        (1.25 * (2.0 * PI * p).sin()).clamp(-1.0, 1.0)
                    }),
                };
                let cycles = (2.0 + 3.0 * rng.uniform()).round().min((20.0 * f).ceil());
                let n = (cycles / f * fs).round() as usize;
                let ramp = ((0.25 / f * fs) as usize).max(1);
                x.extend((0..n).map(|i| fade(i, n, ramp) * a * shape(f * i as f64 / fs)));
                x.extend(std::iter::repeat_n(0.0, hold));
            }
        }
        Programme::Random => {
            let n = (uniform(rng, 15.0, 40.0) * fs) as usize;
            let f_hi = uniform(rng, 3.0, 12.0);
            // A sum of sinusoids with random phases and a flat velocity spectrum.
            let comps: Vec<(f64, f64)> = (0..60)
                .map(|_| (log_uniform(rng, 0.3, f_hi), 2.0 * PI * rng.uniform()))
                .collect();
            let raw: Vec<f64> = (0..n)
                .map(|i| {
                    let t = i as f64 / fs;
                    comps
                        .iter()
                        .map(|&(f, p)| (2.0 * PI * f * t + p).sin() / f)
                        .sum()
                })
                .collect();
            let rms = (raw.iter().map(|v| v * v).sum::<f64>() / n as f64).sqrt();
            let speed: Vec<f64> = raw.windows(2).map(|w| (w[1] - w[0]) * fs).collect();
            let v_max = peak(&speed);
            let scale = (v_peak / v_max).min(stroke / (3.0 * rms));
            let ramp = (fs as usize).min(n / 4);
            x.extend((0..n).map(|i| fade(i, n, ramp) * scale * raw[i]));
            x.extend(std::iter::repeat_n(0.0, hold));
        }
    }
    x
}

/// Sub-steps per sample (at least) over which the laws below follow the displacement,
/// linearly interpolated between samples; the rate in each sample interval is constant.
const SUB: usize = 10;

/// Banded friction damper: Jenkins element (band stiffness `k_band` N/m, slip force `f_slip`
/// N) in parallel with viscous damping `c` (N·s/m). Returns the force (N) at each sample.
fn friction_damper(x: &[f64], fs: f64, k_band: f64, f_slip: f64, c: f64) -> Vec<f64> {
    let mut slip = x[0];
    let mut out = Vec::with_capacity(x.len());
    out.push(0.0);
    for w in x.windows(2) {
        let mut f_band = 0.0;
        for s in 1..=SUB {
            let xs = w[0] + (w[1] - w[0]) * s as f64 / SUB as f64;
            f_band = k_band * (xs - slip);
            if f_band > f_slip {
                slip = xs - f_slip / k_band;
                f_band = f_slip;
            } else if f_band < -f_slip {
                slip = xs + f_slip / k_band;
                f_band = -f_slip;
            }
        }
        let v = (w[1] - w[0]) * fs;
        out.push(f_band + c * v);
    }
    out
}

/// Spencer et al. (1997) Bouc-Wen MR damper: `F = c0 v + k0 (x − x0) + α z`,
/// `ż = −γ |v| z |z| − β v z² + A v` (`n = 2`), integrated by RK4 on the fine grid.
struct MrDamper {
    c0: f64,
    k0: f64,
    alpha: f64,
    gamma: f64,
    beta: f64,
    a: f64,
}

impl MrDamper {
    fn force(&self, x: &[f64], fs: f64) -> Vec<f64> {
        let x0 = x[0];
        let zdot = |z: f64, v: f64| {
            -self.gamma * v.abs() * z * z.abs() - self.beta * v * z * z + self.a * v
        };
        // The pre-yield displacement z_max / A, of which each sub-step moves at most a
        // fifth (the law is stiff there).
        let z_max = (self.a / (self.beta + self.gamma)).sqrt();
        let pre_yield = z_max / self.a;
        let mut z = 0.0;
        let mut out = Vec::with_capacity(x.len());
        out.push(0.0);
        for w in x.windows(2) {
            let v = (w[1] - w[0]) * fs;
            let sub = ((w[1] - w[0]).abs() / (0.2 * pre_yield))
                .ceil()
                .max(SUB as f64) as usize;
            let h = 1.0 / (fs * sub as f64);
            for _ in 0..sub {
                let k1 = zdot(z, v);
                let k2 = zdot(z + 0.5 * h * k1, v);
                let k3 = zdot(z + 0.5 * h * k2, v);
                let k4 = zdot(z + h * k3, v);
                z += h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
            }
            out.push(self.c0 * v + self.k0 * (w[1] - x0) + self.alpha * z);
        }
        out
    }
}

/// The engineer's model: one DOF of `mass` kg on a viscous damper of `c` N·s/m to ground.
fn damper_model(mass: f64, c: f64) -> Model {
    Model::from_toml(&format!(
        r#"
name = "damper on the bench"
[[dof]]
name = "rod"
mass = {mass}
[[element]]
name = "damper"
upper = "rod"
lower = "ground"
damping_n_s_per_m = {c}
[[input]]
name = "force"
kind = "force"
column = "force"
at = "rod"
[[output]]
column = "displacement"
kind = "displacement"
of = "rod"
"#
    ))
    .expect("model")
}

/// A drawn bench test: the record, the engineer's model, and what it is.
struct Case {
    label: String,
    record: Record,
    model: Model,
}

/// Noise and tare as a bench records them: the force with load-cell noise
/// (`force_noise` × its peak, RMS) and a tare offset, the displacement with LVDT noise
/// (`x_noise` × its peak) around a mid-stroke reading, both at `fs`.
fn bench_record(
    x: &[f64],
    f: &[f64],
    fs: f64,
    force_noise: f64,
    x_noise: f64,
    rng: &mut SplitMix64,
) -> Record {
    let (f_peak, x_peak) = (peak(f), peak(x));
    let t: Vec<f64> = (0..x.len()).map(|i| i as f64 / fs).collect();
    let tare = uniform(rng, -0.02, 0.02) * f_peak;
    let mid = uniform(rng, 0.0, 0.1);
    let f: Vec<f64> = f
        .iter()
        .map(|v| v + tare + force_noise * f_peak * rng.normal())
        .collect();
    let x: Vec<f64> = x
        .iter()
        .map(|v| mid + v + x_noise * x_peak * rng.normal())
        .collect();
    Record::new(&t, vec!["force".into(), "displacement".into()], vec![f, x]).expect("record")
}

/// The case drawn from `seed`: a banded friction damper (even seeds) or an MR damper at
/// one of two currents (odd seeds).
fn draw(seed: u64) -> Case {
    let mut rng = SplitMix64::new(0x5EED_DA3F ^ seed.wrapping_mul(0x9E37_79B9_7F4A_7C15));
    let fs = [500.0, 1000.0, 2000.0][(rng.uniform() * 3.0) as usize];
    let kind = [
        Programme::Sinusoids,
        Programme::Triangles,
        Programme::Random,
    ][(rng.uniform() * 3.0) as usize];
    let stroke = uniform(&mut rng, 0.005, 0.04);
    let v_peak = log_uniform(&mut rng, 0.05, 0.6);
    let x = programme(kind, fs, v_peak, stroke, &mut rng);
    let v: Vec<f64> = x.windows(2).map(|w| (w[1] - w[0]) * fs).collect();
    let v_max = peak(&v);
    let (label, mut f, c_nominal) = if seed % 2 == 0 {
        let f_slip = log_uniform(&mut rng, 1e3, 15e3);
        let presliding = log_uniform(&mut rng, 5e-5, 1.5e-3);
        let c = uniform(&mut rng, 0.0, 0.3) * f_slip / v_max;
        let f = friction_damper(&x, fs, f_slip / presliding, f_slip, c);
        let label = format!(
            "friction damper {:.1} kN, pre-sliding {:.2} mm, c {:.0} N·s/m",
            f_slip / 1e3,
            presliding * 1e3,
            c
        );
        (label, f, f_slip / v_max)
    } else {
        // Spencer's law with n = 2; a yield force α z_max, reached after a pre-yield
        // displacement z_max / A.
        let f_yield = log_uniform(&mut rng, 50.0, 2000.0);
        let current = if rng.uniform() < 0.5 {
            1.0
        } else {
            uniform(&mut rng, 2.5, 4.0)
        };
        let a = uniform(&mut rng, 100.0, 400.0);
        let prey = log_uniform(&mut rng, 1e-5, 3e-4);
        let z_max = prey * a;
        let beta_gamma = a / (z_max * z_max);
        let share = uniform(&mut rng, 0.3, 0.7);
        let damper = MrDamper {
            c0: uniform(&mut rng, 0.3, 1.5) * f_yield / v_max * current.sqrt(),
            k0: uniform(&mut rng, 0.0, 0.05) * f_yield / stroke,
            alpha: current * f_yield / z_max,
            gamma: share * beta_gamma,
            beta: (1.0 - share) * beta_gamma,
            a,
        };
        let label = format!(
            "MR damper, yield {:.0} N, current x{current:.1}, pre-yield {:.3} mm, c0 {:.0} N·s/m",
            current * f_yield,
            prey * 1e3,
            damper.c0
        );
        (label, damper.force(&x, fs), current * f_yield / v_max)
    };
    // The load cell on the moving end sees the rod's inertia too.
    if rng.uniform() < 0.5 {
        let m_rod = uniform(&mut rng, 1.0, 10.0);
        for (i, fi) in f.iter_mut().enumerate().skip(1).take(x.len() - 2) {
            *fi += m_rod * (x[i + 1] - 2.0 * x[i] + x[i - 1]) * fs * fs;
        }
    }
    let force_noise = log_uniform(&mut rng, 0.002, 0.01);
    let x_noise = log_uniform(&mut rng, 2e-4, 2e-3);
    let record = bench_record(&x, &f, fs, force_noise, x_noise, &mut rng);
    let mass = log_uniform(&mut rng, 0.5, 20.0);
    let c = c_nominal * log_uniform(&mut rng, 0.3, 3.0);
    Case {
        label: format!(
            "seed {seed}: {label}; {kind:?} at {fs} Hz, {:.0} s; noise: force {:.2} %, LVDT {:.3} mm",
            x.len() as f64 / fs,
            force_noise * 100.0,
            x_noise * peak(&x) * 1e3
        ),
        record,
        model: damper_model(mass, c),
    }
}

/// Why a diagnosis of a bench test falls short: (what it must never do, what it must do on
/// almost every record).
fn verdict(d: &Diagnosis) -> (Vec<String>, Vec<String>) {
    let (mut never, mut almost) = (Vec::new(), Vec::new());
    let n = names(d);
    if !(n.contains(&EffectKind::CoulombFriction) || n.contains(&EffectKind::Hysteresis)) {
        almost.push(format!("no dry friction named: {n:?}"));
    }
    let shrink = d.gap_before.nrmse / d.gap_after.nrmse;
    if shrink.is_nan() || shrink < 2.0 {
        almost.push(format!("gap only {shrink:.2}x smaller"));
    }
    let text = d.updated.to_toml();
    match Model::from_toml(&text) {
        Err(e) => never.push(format!("the updated model is not a valid model file: {e}")),
        Ok(m) => {
            for (i, dof) in m.mass.iter().enumerate() {
                if *dof <= 0.0 {
                    never.push(format!("mass {i} = {dof}"));
                }
            }
            for el in &m.elements {
                if el.law.k < 0.0 || el.law.c < 0.0 || el.law.k_h < 0.0 {
                    never.push(format!("{}: negative k, k_h or c: {:?}", el.name, el.law));
                }
            }
        }
    }
    for (k, v) in &d.recalibrated {
        if *v < 0.0 && !k.ends_with("bias_n") {
            never.push(format!("recalibrated {k} = {v}"));
        }
    }
    (never, almost)
}

/// Diagnoses the cases of `seeds`; returns how many give everything, and the failures of
/// each kind ([`verdict`]).
fn bench(seeds: std::ops::Range<u64>) -> (usize, Vec<String>, Vec<String>) {
    let (mut never, mut almost) = (Vec::new(), Vec::new());
    let mut ok = 0;
    for seed in seeds {
        let case = draw(seed);
        let d = diagnose(&case.model, &case.record, &Options::default()).expect("diagnose");
        let (n, a) = verdict(&d);
        let why: Vec<String> = n.iter().chain(&a).cloned().collect();
        println!(
            "{}\n  named {:?}; gap {:.4} -> {:.4} ({:.1}x){}",
            case.label,
            names(&d),
            d.gap_before.nrmse,
            d.gap_after.nrmse,
            d.gap_before.nrmse / d.gap_after.nrmse,
            if why.is_empty() {
                String::new()
            } else {
                format!("; FAILS: {}", why.join("; "))
            }
        );
        if std::env::var_os("DAMPER_VERBOSE").is_some() {
            println!("{}", d.summary());
            for c in &d.candidates {
                println!(
                    "  round {} candidate {} on {}: criterion {:.1}, SSE x{:.4}",
                    c.round, c.effect, c.element, c.criterion, c.sse_ratio
                );
            }
        }
        if why.is_empty() {
            ok += 1;
        }
        never.extend(n.into_iter().map(|w| format!("{}: {w}", case.label)));
        almost.extend(a.into_iter().map(|w| format!("{}: {w}", case.label)));
    }
    (ok, never, almost)
}

/// Of 24 records, every updated model physical, and the friction named with the gap halved
/// in at least 22 (the bar was set before the held-out seeds were run).
fn check(set: &str, seeds: std::ops::Range<u64>) {
    let total = seeds.end - seeds.start;
    let (ok, never, almost) = bench(seeds);
    println!("damper bench, {set} seeds: {ok}/{total} named the dry friction with the gap at least 2x smaller and every parameter physical");
    assert!(never.is_empty(), "{never:#?}");
    assert!(almost.len() <= 2, "{almost:#?}");
}

/// Development seeds (looked at while the diagnosis was changed).
#[test]
fn damper_bench_development_seeds() {
    // DAMPER_SEED=N runs that seed alone; DAMPER_VERBOSE=1 prints the reports.
    let only = std::env::var("DAMPER_SEED")
        .ok()
        .and_then(|s| s.parse::<u64>().ok());
    check("development", only.map_or(0..24, |s| s..s + 1));
}

/// Held-out seeds (run once the method was settled; see the module documentation).
#[test]
fn damper_bench_held_out_seeds() {
    check("held-out", 1000..1024);
}

/// A load cell read with the opposite sign convention (tension positive against a DOF
/// positive in compression) is refused with the fix, not diagnosed into a 65 t mass; the same
/// records with the right sign are diagnosed.
#[test]
fn a_force_of_the_opposite_sign_is_refused_with_the_fix() {
    for seed in [2, 3, 8, 9] {
        let case = draw(seed);
        let mut cols = case.record.columns.clone();
        cols[0].iter_mut().for_each(|v| *v = -*v);
        let t: Vec<f64> = (0..cols[0].len())
            .map(|i| i as f64 * case.record.dt)
            .collect();
        let flipped = Record::new(&t, case.record.names.clone(), cols).expect("record");
        let err = diagnose(&case.model, &flipped, &Options::default())
            .err()
            .map(|e| e.to_string());
        println!("{}: {err:?}", case.label);
        let err = err.expect("a flipped force is refused");
        assert!(
            err.contains("\"force\"") && err.contains("gain = -1"),
            "{err}"
        );
    }
}
