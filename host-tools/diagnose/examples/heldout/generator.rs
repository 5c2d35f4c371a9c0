//! The held-out scenarios: what each record hides, its excitation, the sizing of the effects
//! by visibility, the noisy record (CSV text), the model file (TOML text) and the truth.

use super::physics::{
    self, ElementEffect, Hidden, InputEffect, Plant, FINE_PER_SAMPLE, INPUT_RATE_HZ, OUT_RATE_HZ,
};
use mil_numerics::rng::SplitMix64;
use serde_json::{json, Value};
use std::collections::BTreeMap;
use std::error::Error;
use std::fmt::Write as _;

/// Result of the generator.
pub type Res<T> = Result<T, Box<dyn Error>>;

/// The plant and its measurements.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Topology {
    /// Quarter car, body displacement measured.
    QcDisp,
    /// Quarter car, body acceleration measured.
    QcAccel,
    /// Force-driven single DOF.
    Sdof,
}

impl Topology {
    /// Every topology.
    pub const ALL: [Topology; 3] = [Topology::QcDisp, Topology::QcAccel, Topology::Sdof];

    /// Identifier.
    pub fn name(self) -> &'static str {
        match self {
            Topology::QcDisp => "qc_disp",
            Topology::QcAccel => "qc_accel",
            Topology::Sdof => "sdof",
        }
    }

    fn is_qc(self) -> bool {
        self != Topology::Sdof
    }

    /// The element carrying the element effects.
    fn element(self) -> &'static str {
        if self.is_qc() {
            "suspension"
        } else {
            "spring"
        }
    }

    /// The input.
    fn input(self) -> &'static str {
        if self.is_qc() {
            "road"
        } else {
            "force"
        }
    }

    /// Effects that apply.
    pub fn effects(self) -> Vec<Effect> {
        Effect::ALL
            .into_iter()
            .filter(|e| self.is_qc() || !matches!(e, Effect::LiftOff | Effect::InputBacklash))
            .collect()
    }

    /// Effects that may pair with an element effect.
    fn partners(self) -> Vec<Effect> {
        self.effects()
            .into_iter()
            .filter(|e| !e.is_element())
            .collect()
    }
}

/// The excitation.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Excitation {
    /// Pink noise 0.5-30 Hz.
    Pink,
    /// Log sweep 0.5 → 30 Hz, then partly back down.
    UpSweep,
    /// Log sweep 30 → 0.5 Hz, then partly back up.
    DownSweep,
    /// Bumps and pot-holes on a small pink background.
    Bumps,
}

impl Excitation {
    /// Every excitation.
    pub const ALL: [Excitation; 4] = [
        Excitation::Pink,
        Excitation::UpSweep,
        Excitation::DownSweep,
        Excitation::Bumps,
    ];

    /// Identifier.
    pub fn name(self) -> &'static str {
        match self {
            Excitation::Pink => "pink",
            Excitation::UpSweep => "up_sweep",
            Excitation::DownSweep => "down_sweep",
            Excitation::Bumps => "bumps",
        }
    }
}

/// The model file given to the diagnosis.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum ModelKind {
    /// True linear parameters.
    Exact,
    /// Every linear parameter 10-20 % off.
    Off,
}

impl ModelKind {
    /// Identifier.
    pub fn name(self) -> &'static str {
        match self {
            ModelKind::Exact => "exact",
            ModelKind::Off => "off",
        }
    }
}

/// A hidden effect.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Effect {
    /// `k3 x³`.
    CubicStiffness,
    /// `F_c sign(v)`.
    CoulombFriction,
    /// Dry friction through a compliant contact (Dahl).
    Presliding,
    /// End stop(s).
    BumpStop,
    /// Free play in the spring path.
    Backlash,
    /// `c2 v |v|`.
    QuadraticDamping,
    /// Bump/rebound damping.
    AsymmetricDamping,
    /// Bouc-Wen.
    Hysteresis,
    /// Tyre only pushes.
    LiftOff,
    /// Input delay.
    InputDelay,
    /// Input rate limit.
    RateLimit,
    /// Input saturation.
    Saturation,
    /// Play between the logged road and the road under the tyre.
    InputBacklash,
}

impl Effect {
    /// Every effect.
    pub const ALL: [Effect; 13] = [
        Effect::CubicStiffness,
        Effect::CoulombFriction,
        Effect::Presliding,
        Effect::BumpStop,
        Effect::Backlash,
        Effect::QuadraticDamping,
        Effect::AsymmetricDamping,
        Effect::Hysteresis,
        Effect::LiftOff,
        Effect::InputDelay,
        Effect::RateLimit,
        Effect::Saturation,
        Effect::InputBacklash,
    ];

    /// Identifier of the generator (not necessarily the diagnosis's name).
    pub fn name(self) -> &'static str {
        match self {
            Effect::CubicStiffness => "cubic_stiffness",
            Effect::CoulombFriction => "coulomb_friction",
            Effect::Presliding => "presliding_friction",
            Effect::BumpStop => "bump_stop",
            Effect::Backlash => "backlash",
            Effect::QuadraticDamping => "quadratic_damping",
            Effect::AsymmetricDamping => "asymmetric_damping",
            Effect::Hysteresis => "hysteresis",
            Effect::LiftOff => "lift_off",
            Effect::InputDelay => "input_delay",
            Effect::RateLimit => "rate_limit",
            Effect::Saturation => "saturation",
            Effect::InputBacklash => "input_backlash",
        }
    }

    /// Names of the diagnosis that count as naming this effect.
    pub fn accepted(self) -> Vec<&'static str> {
        match self {
            Effect::Presliding => vec!["coulomb_friction", "hysteresis"],
            Effect::InputBacklash => vec!["backlash"],
            e => vec![e.name()],
        }
    }

    /// Whether it sits in the suspension / spring.
    pub fn is_element(self) -> bool {
        !matches!(
            self,
            Effect::LiftOff
                | Effect::InputDelay
                | Effect::RateLimit
                | Effect::Saturation
                | Effect::InputBacklash
        )
    }

    /// The element or input it is on.
    pub fn on(self, topology: Topology) -> &'static str {
        if self.is_element() {
            topology.element()
        } else if self == Effect::LiftOff {
            "tyre"
        } else {
            topology.input()
        }
    }
}

/// One record to generate.
#[derive(Clone, Debug)]
pub struct Scenario {
    /// Index in the set.
    pub id: usize,
    /// Seed of everything else.
    pub seed: u64,
    /// Plant.
    pub topology: Topology,
    /// Excitation.
    pub excitation: Excitation,
    /// Model given.
    pub model: ModelKind,
    /// Hidden effects (0, 1 or 2).
    pub effects: Vec<Effect>,
}

impl Scenario {
    /// `clean`, `single` or `pair`.
    pub fn case(&self) -> &'static str {
        match self.effects.len() {
            0 => "clean",
            1 => "single",
            _ => "pair",
        }
    }

    /// The hidden effects, e.g. `cubic_stiffness@suspension+input_delay@road`.
    pub fn truth_label(&self) -> String {
        if self.effects.is_empty() {
            return "-".into();
        }
        self.effects
            .iter()
            .map(|e| format!("{}@{}", e.name(), e.on(self.topology)))
            .collect::<Vec<_>>()
            .join("+")
    }
}

fn pick<T: Copy>(rng: &mut SplitMix64, items: &[T]) -> T {
    let i = ((rng.uniform() * items.len() as f64) as usize).min(items.len() - 1);
    items[i]
}

fn uniform(rng: &mut SplitMix64, lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * rng.uniform()
}

fn log_uniform(rng: &mut SplitMix64, lo: f64, hi: f64) -> f64 {
    (lo.ln() + (hi.ln() - lo.ln()) * rng.uniform()).exp()
}

/// Draws the scenario of record `id` from `seed`: about 1/6 clean, 1/6 pairs, the rest
/// single effects; topology, excitation, model and effects uniform.
pub fn draw_scenario(id: usize, seed: u64) -> Scenario {
    let mut rng = SplitMix64::new(seed);
    let topology = pick(&mut rng, &Topology::ALL);
    let excitation = pick(&mut rng, &Excitation::ALL);
    let model = pick(&mut rng, &[ModelKind::Exact, ModelKind::Off]);
    let u = rng.uniform();
    let effects = if u < 1.0 / 6.0 {
        Vec::new()
    } else if u < 2.0 / 6.0 {
        let elements: Vec<Effect> = Effect::ALL.into_iter().filter(|e| e.is_element()).collect();
        vec![
            pick(&mut rng, &elements),
            pick(&mut rng, &topology.partners()),
        ]
    } else {
        vec![pick(&mut rng, &topology.effects())]
    };
    Scenario {
        id,
        seed,
        topology,
        excitation,
        model,
        effects,
    }
}

/// The full matrix: every applicable effect (and none) × excitation × model × topology,
/// one record each, seeds from `base`.
pub fn matrix(base: u64) -> Vec<Scenario> {
    let mut out = Vec::new();
    for topology in Topology::ALL {
        let mut cases: Vec<Vec<Effect>> = vec![Vec::new()];
        cases.extend(topology.effects().into_iter().map(|e| vec![e]));
        for effects in cases {
            for excitation in Excitation::ALL {
                for model in [ModelKind::Exact, ModelKind::Off] {
                    let id = out.len();
                    out.push(Scenario {
                        id,
                        seed: base + id as u64,
                        topology,
                        excitation,
                        model,
                        effects: effects.clone(),
                    });
                }
            }
        }
    }
    out
}

/// The pair matrix: every element effect × every partner the random sets pair it with
/// ([`draw_scenario`]) × topology, one record each, the excitation and the model cycling
/// through their values with the record's index; seeds from `base`.
pub fn pairs(base: u64) -> Vec<Scenario> {
    let mut out = Vec::new();
    for topology in Topology::ALL {
        let elements: Vec<Effect> = topology
            .effects()
            .into_iter()
            .filter(|e| e.is_element())
            .collect();
        for element in elements {
            for partner in topology.partners() {
                let id = out.len();
                out.push(Scenario {
                    id,
                    seed: base + id as u64,
                    topology,
                    excitation: Excitation::ALL[id % Excitation::ALL.len()],
                    model: [ModelKind::Exact, ModelKind::Off][(id / Excitation::ALL.len()) % 2],
                    effects: vec![element, partner],
                });
            }
        }
    }
    out
}

/// A generated record with everything the harness compares against.
pub struct Generated {
    /// The record as CSV text (`time` first).
    pub csv: String,
    /// The model file as TOML text.
    pub model_toml: String,
    /// The truth (JSON).
    pub truth: Value,
    /// True linear parameters by the diagnosis's labels (e.g. `suspension.stiffness_n_per_m`).
    pub true_linear: BTreeMap<String, f64>,
    /// NRMSE a perfect model would have over the record (output noise only).
    pub noise_floor: f64,
    /// NRMSE over the record of the true plant driven by the logged (noisy,
    /// 1 kHz, linearly interpolated) input: the floor with the input noise's propagation.
    pub perfect_io: f64,
}

/// Half-cosine fade-in and fade-out of `ramp` samples.
fn taper(x: &mut [f64], ramp: usize) {
    let n = x.len();
    let ramp = ramp.min(n / 2).max(1);
    for i in 0..ramp {
        let w = 0.5 - 0.5 * (std::f64::consts::PI * i as f64 / ramp as f64).cos();
        x[i] *= w;
        x[n - 1 - i] *= w;
    }
}

fn pink(n_fine: usize, rms: f64, seed: u64) -> Res<Vec<f64>> {
    Ok(mil_identify::excitation::try_band_limited_noise(
        0.5,
        30.0,
        n_fine as f64 / INPUT_RATE_HZ,
        INPUT_RATE_HZ,
        rms,
        true,
        seed,
    )?)
}

/// Sine of a phase integrated along a piecewise exponential frequency profile.
fn sweep(n_fine: usize, segments: &[(f64, f64, f64)]) -> Vec<f64> {
    // segments: (f_start, f_end, duration fraction)
    let h = 1.0 / INPUT_RATE_HZ;
    let total = (n_fine - 1) as f64 * h;
    let freq = |t: f64| {
        let mut t0 = 0.0;
        for &(fa, fb, frac) in segments {
            let d = frac * total;
            if t <= t0 + d {
                return fa * (fb / fa).powf(((t - t0) / d).clamp(0.0, 1.0));
            }
            t0 += d;
        }
        segments.last().map_or(1.0, |s| s.1)
    };
    let mut phase: f64 = 0.0;
    let mut out = Vec::with_capacity(n_fine);
    for i in 0..n_fine {
        out.push(phase.sin());
        let t = i as f64 * h;
        phase += 2.0 * std::f64::consts::PI * freq(t + 0.5 * h) * h;
    }
    out
}

/// The unit-scale excitation on the input grid.
fn excitation_shape(
    kind: Excitation,
    n_fine: usize,
    rng: &mut SplitMix64,
    info: &mut BTreeMap<String, Value>,
) -> Res<Vec<f64>> {
    let ramp = INPUT_RATE_HZ as usize; // 1 s
    let mut x = match kind {
        Excitation::Pink => pink(n_fine, 1.0, rng.next_u64())?,
        Excitation::UpSweep | Excitation::DownSweep => {
            let p = uniform(rng, 0.65, 0.85);
            let segs = if kind == Excitation::UpSweep {
                let back = uniform(rng, 8.0, 15.0);
                info.insert("sweep".into(), json!([0.5, 30.0, back]));
                [(0.5, 30.0, p), (30.0, back, 1.0 - p)]
            } else {
                let back = uniform(rng, 2.0, 6.0);
                info.insert("sweep".into(), json!([30.0, 0.5, back]));
                [(30.0, 0.5, p), (0.5, back, 1.0 - p)]
            };
            info.insert("sweep_fraction".into(), json!(p));
            sweep(n_fine, &segs)
        }
        Excitation::Bumps => {
            let bg = uniform(rng, 0.03, 0.1);
            let mut x = pink(n_fine, bg, rng.next_u64())?;
            let h = 1.0 / INPUT_RATE_HZ;
            let end = (n_fine - 1) as f64 * h - 1.0;
            let mut t = 1.0 + uniform(rng, 0.0, 0.5);
            let mut count = 0;
            while t < end {
                let width = uniform(rng, 0.02, 0.3);
                if t + width >= end {
                    break;
                }
                let height = uniform(rng, 0.3, 1.0) * if rng.uniform() < 0.5 { -1.0 } else { 1.0 };
                let haversine = rng.uniform() < 0.5;
                let i0 = (t / h).ceil() as usize;
                let i1 = ((t + width) / h).floor() as usize;
                for (i, v) in x.iter_mut().enumerate().take(i1 + 1).skip(i0) {
                    let s = (i as f64 * h - t) / width;
                    let shape = if haversine {
                        0.5 - 0.5 * (2.0 * std::f64::consts::PI * s).cos()
                    } else {
                        (std::f64::consts::PI * s).sin()
                    };
                    *v += height * shape;
                }
                count += 1;
                t += width + uniform(rng, 0.15, 1.5);
            }
            info.insert("bumps".into(), json!(count));
            info.insert("background_rms".into(), json!(bg));
            x
        }
    };
    taper(&mut x, ramp);
    Ok(x)
}

fn mean(x: &[f64]) -> f64 {
    x.iter().sum::<f64>() / x.len().max(1) as f64
}

/// Standard deviation (population).
pub fn std(x: &[f64]) -> f64 {
    let m = mean(x);
    (x.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / x.len().max(1) as f64).sqrt()
}

fn rms(x: &[f64]) -> f64 {
    (x.iter().map(|v| v * v).sum::<f64>() / x.len().max(1) as f64).sqrt()
}

fn quantile(x: &[f64], p: f64) -> f64 {
    let mut v = x.to_vec();
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * p).round() as usize]
}

/// Indices of the measured outputs in [`physics::SimOut::outputs`] and their columns.
fn measured(topology: Topology) -> Vec<(usize, &'static str)> {
    match topology {
        Topology::QcDisp => vec![(0, "body"), (1, "hub"), (2, "tyre_force")],
        Topology::QcAccel => vec![(3, "body_acc"), (1, "hub"), (2, "tyre_force")],
        Topology::Sdof => vec![(0, "x")],
    }
}

/// Everything a visibility evaluation needs.
struct Ctx<'a> {
    plant: Plant,
    topology: Topology,
    n_out: usize,
    /// Noise fraction of each measured output.
    frac: &'a [f64],
}

impl Ctx<'_> {
    /// `max over outputs of rms(y − y_lin) / (frac · std(y_lin))`; infinite on divergence.
    fn visibility(&self, hidden: &Hidden, u: &[f64], lin: &physics::SimOut) -> f64 {
        let Ok(sim) = physics::simulate(&self.plant, hidden, u, self.n_out) else {
            return f64::INFINITY;
        };
        measured(self.topology)
            .iter()
            .zip(self.frac)
            .map(|(&(j, _), &f)| {
                let d: Vec<f64> = sim.outputs[j]
                    .iter()
                    .zip(&lin.outputs[j])
                    .map(|(a, b)| a - b)
                    .collect();
                rms(&d) / (f * std(&lin.outputs[j]))
            })
            .fold(0.0, f64::max)
    }
}

/// Finds the strength in `[lo, hi]` (geometric bisection) whose visibility is `target`;
/// the bound when the target is out of reach. Returns (strength, visibility).
fn size(lo: f64, hi: f64, target: f64, mut vis: impl FnMut(f64) -> f64) -> (f64, f64) {
    let v_hi = vis(hi);
    if v_hi.is_finite() && v_hi <= target {
        return (hi, v_hi);
    }
    let v_lo = vis(lo);
    if v_lo >= target {
        return (lo, v_lo);
    }
    let (mut a, mut b) = (lo, hi);
    let mut best = (lo, v_lo);
    for _ in 0..24 {
        let m = (a * b).sqrt();
        let v = vis(m);
        if v.is_finite() && (v / target - 1.0).abs() < (best.1 / target - 1.0).abs() {
            best = (m, v);
        }
        if (v / target - 1.0).abs() < 0.02 {
            break;
        }
        if v > target {
            b = m;
        } else {
            a = m;
        }
    }
    best
}

fn sign(rng: &mut SplitMix64) -> f64 {
    if rng.uniform() < 0.5 {
        -1.0
    } else {
        1.0
    }
}

/// Shape parameters of an effect (drawn once) and its strength → the law.
enum Law {
    Element(Box<dyn Fn(f64) -> ElementEffect>),
    Input(Box<dyn Fn(f64) -> InputEffect>),
}

/// Draws the shape of `effect` and returns its law in terms of the strength, the strength
/// range and a description of the shape.
fn law_of(
    effect: Effect,
    plant: &Plant,
    lin: &physics::SimOut,
    u: &[f64],
    rng: &mut SplitMix64,
) -> (Law, f64, f64, Value) {
    let (k, c) = plant.effect_element_kc();
    let x_rms = rms(&lin.compression);
    let v_rms = rms(&lin.rate);
    match effect {
        Effect::CubicStiffness => {
            let s = sign(rng);
            let hi = if s > 0.0 { 3.0 } else { 0.1 };
            let law = move |a: f64| ElementEffect::Cubic {
                k3: s * a * k / (x_rms * x_rms),
            };
            let shape = json!({"hardening": s > 0.0});
            (Law::Element(Box::new(law)), 1e-4, hi, shape)
        }
        Effect::CoulombFriction => {
            let law = move |a: f64| ElementEffect::Coulomb { fc: a * k * x_rms };
            (Law::Element(Box::new(law)), 1e-4, 1.0, json!({}))
        }
        Effect::Presliding => {
            let delta = uniform(rng, 0.05, 0.3);
            let law = move |a: f64| {
                let fc = a * k * x_rms;
                ElementEffect::Dahl {
                    fc,
                    sigma: fc / (delta * x_rms),
                }
            };
            let shape = json!({"presliding_deflection_over_x_rms": delta});
            (Law::Element(Box::new(law)), 1e-4, 1.0, shape)
        }
        Effect::BumpStop => {
            let side = pick(rng, &["compression", "extension", "both"]);
            let q = uniform(rng, 0.90, 0.98);
            let gap = quantile(&lin.compression, q).max(0.1 * x_rms);
            let rebound = (-quantile(&lin.compression, 1.0 - q)).max(0.1 * x_rms);
            let (g, r) = match side {
                "compression" => (Some(gap), None),
                "extension" => (None, Some(rebound)),
                _ => (Some(gap), Some(rebound)),
            };
            let law = move |a: f64| ElementEffect::BumpStop {
                k_b: a * k,
                gap: g,
                rebound_gap: r,
            };
            let shape = json!({"side": side, "quantile": q});
            (Law::Element(Box::new(law)), 1e-3, 30.0, shape)
        }
        Effect::Backlash => {
            let law = move |a: f64| ElementEffect::Backlash { b: a * x_rms };
            (Law::Element(Box::new(law)), 1e-4, 2.0, json!({}))
        }
        Effect::QuadraticDamping => {
            let law = move |a: f64| ElementEffect::Quadratic { c2: a * c / v_rms };
            (Law::Element(Box::new(law)), 1e-4, 20.0, json!({}))
        }
        Effect::AsymmetricDamping => {
            let s = sign(rng);
            let law = move |a: f64| ElementEffect::Asymmetric {
                c_bump: c * (1.0 - s * a),
                c_rebound: c * (1.0 + s * a),
            };
            let shape = json!({"rebound_stronger": s > 0.0});
            (Law::Element(Box::new(law)), 1e-4, 0.9, shape)
        }
        Effect::Hysteresis => {
            let r = uniform(rng, 0.1, 0.5);
            let share = uniform(rng, 0.55, 0.9);
            let sum = 1.0 / (r * x_rms);
            let (beta, gamma) = (share * sum, (1.0 - share) * sum);
            let law = move |a: f64| ElementEffect::BoucWen {
                alpha: 1.0 - a,
                beta,
                gamma,
            };
            let shape = json!({"z_max_over_x_rms": r, "beta_share": share});
            (Law::Element(Box::new(law)), 1e-4, 0.95, shape)
        }
        Effect::InputDelay => {
            let law = move |a: f64| InputEffect::Delay { tau: a };
            (Law::Input(Box::new(law)), 2e-3, 15e-3, json!({}))
        }
        Effect::RateLimit => {
            let h = 1.0 / INPUT_RATE_HZ;
            let max_rate = u
                .windows(2)
                .map(|w| (w[1] - w[0]).abs() / h)
                .fold(0.0, f64::max);
            let law = move |a: f64| InputEffect::RateLimit {
                rate: (1.0 - a) * max_rate,
            };
            (
                Law::Input(Box::new(law)),
                1e-4,
                0.97,
                json!({"max_rate": max_rate}),
            )
        }
        Effect::Saturation => {
            let symmetric = rng.uniform() < 0.5;
            let top = u.iter().copied().fold(f64::MIN, f64::max);
            let bottom = u.iter().copied().fold(f64::MAX, f64::min);
            let peak = top.max(-bottom);
            // Unequal: one side clips `ratio` times as deep (relative to its own peak).
            let ratio = if symmetric {
                1.0
            } else {
                uniform(rng, 0.2, 0.6)
            };
            let upper_tight = rng.uniform() < 0.5;
            let law = move |a: f64| {
                if symmetric {
                    InputEffect::Saturation {
                        lower: -(1.0 - a) * peak,
                        upper: (1.0 - a) * peak,
                    }
                } else if upper_tight {
                    InputEffect::Saturation {
                        lower: (1.0 - ratio * a) * bottom,
                        upper: (1.0 - a) * top,
                    }
                } else {
                    InputEffect::Saturation {
                        lower: (1.0 - a) * bottom,
                        upper: (1.0 - ratio * a) * top,
                    }
                }
            };
            let shape =
                json!({"symmetric": symmetric, "ratio": ratio, "upper_tighter": upper_tight});
            (Law::Input(Box::new(law)), 1e-4, 0.95, shape)
        }
        Effect::InputBacklash => {
            let u_rms = rms(u);
            let law = move |a: f64| InputEffect::Play {
                half_gap: a * u_rms,
            };
            (Law::Input(Box::new(law)), 1e-4, 2.0, json!({}))
        }
        Effect::LiftOff => unreachable!("lift-off is sized through the excitation scale"),
    }
}

fn element_params(e: &ElementEffect) -> Value {
    match *e {
        ElementEffect::Cubic { k3 } => json!({"stiffness_n_per_m3": k3}),
        ElementEffect::Coulomb { fc } => json!({"force_n": fc}),
        ElementEffect::Dahl { fc, sigma } => {
            json!({"force_n": fc, "contact_stiffness_n_per_m": sigma})
        }
        ElementEffect::BumpStop {
            k_b,
            gap,
            rebound_gap,
        } => json!({"stiffness_n_per_m": k_b, "gap_m": gap, "rebound_gap_m": rebound_gap}),
        ElementEffect::Backlash { b } => json!({"half_gap_m": b}),
        ElementEffect::Quadratic { c2 } => json!({"damping_n_s2_per_m2": c2}),
        ElementEffect::Asymmetric { c_bump, c_rebound } => {
            json!({"bump_n_s_per_m": c_bump, "rebound_n_s_per_m": c_rebound})
        }
        ElementEffect::BoucWen { alpha, beta, gamma } => {
            json!({"alpha": alpha, "beta_per_m": beta, "gamma_per_m": gamma, "a": 1.0, "n": 1.0})
        }
    }
}

fn input_params(e: &InputEffect) -> Value {
    match *e {
        InputEffect::Delay { tau } => json!({"delay_s": tau}),
        InputEffect::RateLimit { rate } => json!({"rate_per_s": rate}),
        InputEffect::Saturation { lower, upper } => json!({"lower": lower, "upper": upper}),
        InputEffect::Play { half_gap } => json!({"half_gap_m": half_gap}),
    }
}

/// Labels of the linear parameters (the diagnosis's `recalibrated` keys) and values.
fn linear_params(plant: &Plant) -> BTreeMap<String, f64> {
    let pairs: Vec<(&str, f64)> = match *plant {
        Plant::QuarterCar {
            m_s,
            m_u,
            k_c,
            c_c,
            k_t,
            c_t,
        } => vec![
            ("x_s.mass", m_s),
            ("x_u.mass", m_u),
            ("suspension.stiffness_n_per_m", k_c),
            ("suspension.damping_n_s_per_m", c_c),
            ("tyre.stiffness_n_per_m", k_t),
            ("tyre.damping_n_s_per_m", c_t),
        ],
        Plant::Sdof { m, k, c } => vec![
            ("x.mass", m),
            ("spring.stiffness_n_per_m", k),
            ("spring.damping_n_s_per_m", c),
        ],
    };
    pairs.into_iter().map(|(k, v)| (k.to_string(), v)).collect()
}

fn model_toml(topology: Topology, given: &Plant, name: &str) -> String {
    let mut t = String::new();
    let _ = writeln!(
        t,
        "# Held-out record {name}: the given linear model (no effects)."
    );
    let _ = writeln!(t, "name = \"{name}\"\n");
    match *given {
        Plant::QuarterCar {
            m_s,
            m_u,
            k_c,
            c_c,
            k_t,
            c_t,
        } => {
            let body = if topology == Topology::QcAccel {
                "column = \"body_acc\"\nkind = \"acceleration\"\nof = \"x_s\""
            } else {
                "column = \"body\"\nkind = \"displacement\"\nof = \"x_s\""
            };
            let _ = write!(
                t,
                "[[dof]]\nname = \"x_s\"\nmass = {m_s:?}\n\n\
                 [[dof]]\nname = \"x_u\"\nmass = {m_u:?}\n\n\
                 [[element]]\nname = \"suspension\"\nupper = \"x_s\"\nlower = \"x_u\"\n\
                 stiffness_n_per_m = {k_c:?}\ndamping_n_s_per_m = {c_c:?}\n\n\
                 [[element]]\nname = \"tyre\"\nupper = \"x_u\"\nlower = \"road\"\n\
                 stiffness_n_per_m = {k_t:?}\ndamping_n_s_per_m = {c_t:?}\n\n\
                 [[input]]\nname = \"road\"\nkind = \"displacement\"\ncolumn = \"road\"\n\n\
                 [[output]]\n{body}\n\n\
                 [[output]]\ncolumn = \"hub\"\nkind = \"displacement\"\nof = \"x_u\"\n\n\
                 [[output]]\ncolumn = \"tyre_force\"\nkind = \"force\"\nof = \"tyre\"\n"
            );
        }
        Plant::Sdof { m, k, c } => {
            let _ = write!(
                t,
                "[[dof]]\nname = \"x\"\nmass = {m:?}\n\n\
                 [[element]]\nname = \"spring\"\nupper = \"x\"\nlower = \"ground\"\n\
                 stiffness_n_per_m = {k:?}\ndamping_n_s_per_m = {c:?}\n\n\
                 [[input]]\nname = \"force\"\nkind = \"force\"\ncolumn = \"force\"\nat = \"x\"\n\n\
                 [[output]]\ncolumn = \"x\"\nkind = \"displacement\"\nof = \"x\"\n"
            );
        }
    }
    t
}

/// Generates the record of `sc`.
///
/// # Errors
/// The excitation cannot be made, or the final simulation diverged.
pub fn generate(sc: &Scenario, set: &str) -> Res<Generated> {
    let mut rng = SplitMix64::new(sc.seed ^ 0x05EE_D0F4_E1D0_u64);
    let topology = sc.topology;
    let n_out = (uniform(&mut rng, 20.0, 60.0) * OUT_RATE_HZ).round() as usize + 1;
    let n_fine = FINE_PER_SAMPLE * (n_out - 1) + 1;

    let plant = if topology.is_qc() {
        Plant::QuarterCar {
            m_s: 150.0 * uniform(&mut rng, 0.6, 1.5),
            m_u: uniform(&mut rng, 20.0, 40.0),
            k_c: 120e3 * uniform(&mut rng, 0.6, 1.5),
            c_c: 2.5e3 * uniform(&mut rng, 0.6, 1.5),
            k_t: 250e3 * uniform(&mut rng, 0.6, 1.5),
            c_t: 500.0 * uniform(&mut rng, 0.6, 1.5),
        }
    } else {
        let m = log_uniform(&mut rng, 0.5, 300.0);
        let f_n = log_uniform(&mut rng, 2.0, 20.0);
        let zeta = uniform(&mut rng, 0.03, 0.3);
        let k = m * (2.0 * std::f64::consts::PI * f_n).powi(2);
        Plant::Sdof {
            m,
            k,
            c: 2.0 * zeta * (k * m).sqrt(),
        }
    };
    let outs = measured(topology);
    let input_col = topology.input();
    let frac_out: Vec<f64> = outs
        .iter()
        .map(|_| uniform(&mut rng, 0.005, 0.03))
        .collect();
    let frac_in = uniform(&mut rng, 0.005, 0.03);

    // Excitation: unit shape, scaled by the linear response.
    let mut exc_info = BTreeMap::new();
    let shape = excitation_shape(sc.excitation, n_fine, &mut rng, &mut exc_info)?;
    let none = Hidden::default();
    let lin_unit = physics::simulate(&plant, &none, &shape, n_out)?;
    let preload = plant.static_tyre_load();
    let ctx = Ctx {
        plant,
        topology,
        n_out,
        frac: &frac_out,
    };
    let scale_of = |s: f64, lin: &physics::SimOut| -> (Vec<f64>, physics::SimOut) {
        let u: Vec<f64> = shape.iter().map(|v| v * s).collect();
        let mut l = lin.clone();
        for o in l
            .outputs
            .iter_mut()
            .chain([&mut l.compression, &mut l.rate])
        {
            for v in o.iter_mut() {
                *v *= s;
            }
        }
        (u, l)
    };
    let mut effects_truth = Vec::new();
    let mut hidden = Hidden::default();
    let peak_tyre = lin_unit
        .outputs
        .get(2)
        .map_or(0.0, |f| f.iter().fold(0.0, |a: f64, v| a.max(v.abs())));
    let (scale, scale_note) = if topology.is_qc() {
        if sc.effects.contains(&Effect::LiftOff) {
            let target = uniform(&mut rng, 3.0, 10.0);
            let (rho, v) = size(1.0, 8.0, target, |rho| {
                let (u, l) = scale_of(rho * preload / peak_tyre, &lin_unit);
                let h = Hidden {
                    lift_off: true,
                    ..Hidden::default()
                };
                ctx.visibility(&h, &u, &l)
            });
            hidden.lift_off = true;
            effects_truth.push(json!({
                "effect": "lift_off", "on": "tyre", "accepted": ["lift_off"],
                "parameters": {"preload_n": preload},
                "strength": rho, "strength_meaning": "peak linear dynamic tyre force / static load",
                "target_visibility": target, "visibility": v,
            }));
            (rho * preload / peak_tyre, rho)
        } else {
            let rho = uniform(&mut rng, 0.4, 0.85);
            (rho * preload / peak_tyre, rho)
        }
    } else {
        let target = log_uniform(&mut rng, 1e-3, 1e-2);
        (target / rms(&lin_unit.outputs[0]), target)
    };
    let (u_clean, lin) = scale_of(scale, &lin_unit);

    for &effect in sc.effects.iter().filter(|e| **e != Effect::LiftOff) {
        let target = uniform(&mut rng, 3.0, 10.0);
        let (law, lo, hi, shape_info) = law_of(effect, &plant, &lin, &u_clean, &mut rng);
        let with = |a: f64| match &law {
            Law::Element(f) => Hidden {
                element: Some(f(a)),
                ..Hidden::default()
            },
            Law::Input(f) => Hidden {
                input: Some(f(a)),
                ..Hidden::default()
            },
        };
        let (a, v) = size(lo, hi, target, |a| ctx.visibility(&with(a), &u_clean, &lin));
        let h = with(a);
        let params = if let Some(e) = h.element {
            hidden.element = Some(e);
            element_params(&e)
        } else if let Some(e) = h.input {
            hidden.input = Some(e);
            input_params(&e)
        } else {
            json!({})
        };
        effects_truth.push(json!({
            "effect": effect.name(), "on": effect.on(topology), "accepted": effect.accepted(),
            "parameters": params, "shape": shape_info, "strength": a,
            "strength_range": [lo, hi], "target_visibility": target, "visibility": v,
        }));
    }

    let sim = physics::simulate(&plant, &hidden, &u_clean, n_out)?;

    // The record: logged input (the command before any input effect) and outputs, with noise.
    let u_log: Vec<f64> = (0..n_out).map(|i| u_clean[i * FINE_PER_SAMPLE]).collect();
    let mut columns: Vec<(String, Vec<f64>, f64, f64)> = Vec::new(); // name, values, frac, noise std
    let mut add = |name: &str, clean: &[f64], frac: f64, rng: &mut SplitMix64| {
        let s = frac * std(clean);
        let noisy: Vec<f64> = clean.iter().map(|v| v + s * rng.normal()).collect();
        columns.push((name.to_string(), noisy, frac, s));
    };
    add(input_col, &u_log, frac_in, &mut rng);
    for (&(j, name), &f) in outs.iter().zip(&frac_out) {
        add(name, &sim.outputs[j], f, &mut rng);
    }

    // Noise floor over the whole record: the diagnosis validates on interleaved blocks
    // spread over the record (or on its end, with an older split); the whole record
    // approximates the former and does not depend on the diagnosis's choice.
    let floor = (columns[1..]
        .iter()
        .map(|(_, y, _, s)| (s / std(y)).powi(2))
        .sum::<f64>()
        / (columns.len() - 1) as f64)
        .sqrt();

    // A perfect model (the true plant and effects) driven by the logged, noisy input,
    // linearly interpolated: its NRMSE adds the input noise's propagation to the floor.
    let u_noisy = &columns[0].1;
    let u_interp: Vec<f64> = (0..n_fine)
        .map(|j| {
            let i = j / FINE_PER_SAMPLE;
            let f = (j % FINE_PER_SAMPLE) as f64 / FINE_PER_SAMPLE as f64;
            let a = u_noisy[i];
            a + f * (u_noisy.get(i + 1).copied().unwrap_or(a) - a)
        })
        .collect();
    let floor_io = physics::simulate(&plant, &hidden, &u_interp, n_out).map_or(f64::NAN, |p| {
        (outs
            .iter()
            .zip(&columns[1..])
            .map(|(&(j, _), (_, y, _, _))| {
                let e: Vec<f64> = p.outputs[j].iter().zip(y).map(|(a, b)| a - b).collect();
                (rms(&e) / std(y)).powi(2)
            })
            .sum::<f64>()
            / outs.len() as f64)
            .sqrt()
    });

    let mut csv = String::with_capacity(n_out * 16 * (columns.len() + 1));
    csv.push_str("time");
    for (name, ..) in &columns {
        csv.push(',');
        csv.push_str(name);
    }
    csv.push('\n');
    for i in 0..n_out {
        let _ = write!(csv, "{:.3}", i as f64 / OUT_RATE_HZ);
        for (_, y, ..) in &columns {
            let _ = write!(csv, ",{:.9e}", y[i]);
        }
        csv.push('\n');
    }

    // The given model.
    let true_linear = linear_params(&plant);
    let mut off = |v: f64| {
        if sc.model == ModelKind::Off {
            v * (1.0 + sign(&mut rng) * uniform(&mut rng, 0.10, 0.20))
        } else {
            v
        }
    };
    let given = match plant {
        Plant::QuarterCar {
            m_s,
            m_u,
            k_c,
            c_c,
            k_t,
            c_t,
        } => Plant::QuarterCar {
            m_s: off(m_s),
            m_u: off(m_u),
            k_c: off(k_c),
            c_c: off(c_c),
            k_t: off(k_t),
            c_t: off(c_t),
        },
        Plant::Sdof { m, k, c } => Plant::Sdof {
            m: off(m),
            k: off(k),
            c: off(c),
        },
    };
    let name = format!("heldout-{set}-{:03}", sc.id);
    let toml = model_toml(topology, &given, &name);

    let x_rms = rms(&sim.compression);
    let truth = json!({
        "id": sc.id,
        "set": set,
        "seed": sc.seed,
        "topology": topology.name(),
        "excitation": sc.excitation.name(),
        "excitation_info": exc_info,
        "model": sc.model.name(),
        "case": sc.case(),
        "duration_s": (n_out - 1) as f64 / OUT_RATE_HZ,
        "samples": n_out,
        "effects": effects_truth,
        "true_linear": true_linear,
        "given_linear": linear_params(&given),
        "input_scale": scale,
        "input_scale_meaning": if topology.is_qc() {
            "road scale so that the peak linear dynamic tyre force is `scale_target` times the static load"
        } else {
            "force scale so that the linear displacement RMS is `scale_target` (m)"
        },
        "scale_target": scale_note,
        "static_tyre_load_n": preload,
        "airborne_fraction": sim.airborne,
        "element_compression_rms_m": x_rms,
        "element_compression_peak_m": sim.compression.iter().fold(0.0, |a: f64, v| a.max(v.abs())),
        "noise": columns.iter().map(|(n, _, f, s)| (n.clone(), json!({"fraction_of_clean_std": f, "std": s}))).collect::<BTreeMap<_, _>>(),
        "noise_floor": floor,
        "perfect_model_nrmse": floor_io,
        "generator": "host-tools/diagnose/examples/heldout (own RK4 at 10 kHz, inputs on a 20 kHz grid, sampled at 1 kHz)",
    });
    Ok(Generated {
        csv,
        model_toml: toml,
        truth,
        true_linear,
        noise_floor: floor,
        perfect_io: floor_io,
    })
}
