//! Synthetic records with a hidden effect for the effects `synthetic.rs` does not cover,
//! made by the simulated rig (`mil-rig`), and one record with two hidden effects.
//!
//! - Element effects (asymmetric damping, bump stop, free play, Bouc-Wen hysteresis, and
//!   Coulomb friction + cubic stiffness together) are switched on in the `mil_structure`
//!   element of a one-DOF oscillator (2 kg on a 20 kN/m, 20 N·s/m spring-damper to ground)
//!   driven by a prescribed force, as in `synthetic.rs`.
//! - Input effects (`input_delay`, `saturation`, `rate_limit`): `mil-rig` has no such effect
//!   on a prescribed input, so the record is made by applying the effect to the force signal
//!   before it drives the (linear) rig; the record holds the force as commanded (before the
//!   effect), which is what a test system logs.
//! - Lift-off: a 250 kg mass on a preloaded tyre spring (static load `m g`) driven by a
//!   track-like road (random profile plus bumps) through a displacement input; the tyre can
//!   only push (`mil_structure` `lift_off`).
//!
//! Excitations: band-limited random force, a repeated logarithmic sine sweep, and the
//! track-like road. Measurement noise: 0.5 % of the clean signal's RMS on the force (or
//! road) column and 0.7 % on the displacement column. The models handed to the workflow
//! are linear with their parameters 10–15 % off (the lift-off model keeps its mass, which
//! a displacement-driven record cannot recalibrate, see the crate documentation).
//!
//! Every test prints what was named, the fitted parameters against the truth and the gap
//! before → after (NRMSE of the simulated displacement on the validation part).
//!
//! `DIAGNOSE_SEED_OFFSET=N` re-runs every test on other records. Offsets 0–1300 in steps of
//! 100, as measured last (release build): every test passes except the Coulomb friction +
//! cubic stiffness record at offsets 300 and 1100. Before the stand-in check (a one-effect
//! answer against the first round's runner-up continued by a round) it failed at 500 too,
//! where hysteresis stood in for both effects in the first round; that record is now its
//! own test, `a_one_effect_stand_in_gives_way_to_the_two_effects`. At 1100,
//! hysteresis and a saturation are named (the check runs only when one effect is named);
//! at 300 both right effects are named with their sizes (F_c −1.5 %, k3 +4.4 %) but the
//! simulated gap shrinks only 1.5× from the recalibrated model (the output-error
//! refinement of the cubic spring stops at x0.56 of the validation SSE where the
//! equation error reached x0.03): listed under issue 18. The delay record's extra
//! `saturation` at offset 700, the old known failure, no longer occurs.

mod common;

use common::*;
use mil_diagnose::{Diagnosis, EffectKind, Record};
use mil_rig::specimen::GRAVITY_M_PER_S2;

/// The record seed `n`, shifted by the environment variable `DIAGNOSE_SEED_OFFSET` (to
/// re-run the tests on other records).
fn seed(n: u64) -> u64 {
    n + std::env::var("DIAGNOSE_SEED_OFFSET")
        .ok()
        .and_then(|v| v.parse::<u64>().ok())
        .unwrap_or(0)
}

/// Simulates the oscillator with `effects` driven by the force `applied` (N); the record
/// holds `recorded` (N, the commanded force) and the displacement, both with noise.
fn force_record(effects: Effects, applied: &[f64], recorded: &[f64], seed: u64) -> Record {
    let x = oscillator_response(effects, applied);
    noisy_record("force", recorded, &x, seed)
}

/// Band-limited random force, 0.5–60 Hz, `FORCE_RMS`.
fn noise_force(seed: u64) -> Vec<f64> {
    mil_identify::band_limited_noise(0.5, 60.0, DURATION_S, FS, FORCE_RMS, false, seed)
}

/// A logarithmic sine sweep 3–60 Hz of `amplitude` (N), repeated every 4 s (so that
/// both the fitting and the validation part cross the resonance, 15.9 Hz).
fn sweep_force(amplitude: f64) -> Vec<f64> {
    let period = mil_identify::log_sine_sweep(3.0, 60.0, 4.0, FS, amplitude);
    let n = (DURATION_S * FS).round() as usize;
    (0..n).map(|i| period[i % period.len()]).collect()
}

/// Parameter `key` of named effect `kind`.
fn param(d: &Diagnosis, kind: EffectKind, key: &str) -> f64 {
    d.named
        .iter()
        .find(|n| n.named.effect == kind)
        .unwrap_or_else(|| panic!("{kind} not named"))
        .named
        .parameters[key]
}

/// Prints and checks `value` against `truth` within relative tolerance `rel`.
fn check_rel(what: &str, value: f64, truth: f64, rel: f64) {
    println!(
        "  {what}: fitted {value:.5e}, truth {truth:.5e} ({:+.1} %, tolerance {:.0} %)",
        100.0 * (value - truth) / truth,
        100.0 * rel
    );
    assert!(
        (value - truth).abs() <= rel * truth.abs(),
        "{what}: {value} vs truth {truth} (tolerance {rel})"
    );
}

/// Checks that the gap shrinks by at least `factor` against the model as given and against
/// the recalibrated linear model (so that the named effect, not only the recalibration,
/// accounts for the factor).
fn check_gap(d: &Diagnosis, factor: f64) {
    println!(
        "  gap: {:.4} as given, {:.4} recalibrated -> {:.4} updated (required: {factor}x less than both)",
        d.gap_before.nrmse, d.gap_recalibrated.nrmse, d.gap_after.nrmse
    );
    assert!(
        d.gap_after.nrmse * factor <= d.gap_before.nrmse,
        "gap {:.4} -> {:.4}: less than {factor}x",
        d.gap_before.nrmse,
        d.gap_after.nrmse
    );
    assert!(
        d.gap_after.nrmse * factor <= d.gap_recalibrated.nrmse,
        "gap of the recalibrated model {:.4} -> {:.4}: less than {factor}x",
        d.gap_recalibrated.nrmse,
        d.gap_after.nrmse
    );
}

#[test]
fn hidden_asymmetric_damping_is_named() {
    // A damper three times as strong in rebound as in bump, mean equal to `C`.
    let (bump, rebound) = (10.0, 30.0);
    let f = noise_force(seed(11));
    let record = force_record(
        effects(&[(
            EffectKind::AsymmetricDamping,
            &[("bump_n_s_per_m", bump), ("rebound_n_s_per_m", rebound)],
        )]),
        &f,
        &f,
        seed(11),
    );
    let d = run("asymmetric damping (noise)", &oscillator_model(), &record);
    assert_eq!(names(&d), [EffectKind::AsymmetricDamping]);
    // Damping coefficients within 15 % (the recalibration of linear damping is held to
    // 10 % in `synthetic.rs`; each side here sees only half the data).
    let k = EffectKind::AsymmetricDamping;
    check_rel("c_bump", param(&d, k, "bump_n_s_per_m"), bump, 0.15);
    check_rel(
        "c_rebound",
        param(&d, k, "rebound_n_s_per_m"),
        rebound,
        0.15,
    );
    check_gap(&d, 2.0);
}

/// The oscillator with a stop of stiffness `kb` at `gap` (compression) and, if given, at
/// `rebound` (extension) under the sweep, diagnosed as `what`: a bump stop must be named
/// alone, its gaps within 10 % (0.3 mm, a small fraction of the displacement's range) and
/// its stiffness within 15 %, and the gap must shrink.
fn stop_named(what: &str, gap: f64, rebound: Option<f64>, kb: f64, seed: u64) {
    let f = sweep_force(30.0);
    let mut stop = vec![("gap_m", gap), ("stiffness_n_per_m", kb)];
    if let Some(rebound) = rebound {
        stop.push(("rebound_gap_m", rebound));
    }
    let record = force_record(effects(&[(EffectKind::BumpStop, &stop)]), &f, &f, seed);
    let d = run(what, &oscillator_model(), &record);
    assert_eq!(names(&d), [EffectKind::BumpStop]);
    let k = EffectKind::BumpStop;
    check_rel("gap", param(&d, k, "gap_m"), gap, 0.10);
    check_rel("k_b", param(&d, k, "stiffness_n_per_m"), kb, 0.15);
    if let Some(rebound) = rebound {
        check_rel("rebound gap", param(&d, k, "rebound_gap_m"), rebound, 0.10);
        // Its own stiffness when it differs from the compression side's.
        let kr = d
            .named
            .iter()
            .find(|n| n.named.effect == k)
            .and_then(|n| n.named.parameters.get("rebound_stiffness_n_per_m").copied())
            .unwrap_or(kb);
        check_rel("rebound k_b", kr, kb, 0.15);
    }
    check_gap(&d, 2.0);
}

#[test]
fn hidden_bump_stop_is_named() {
    // A stop as stiff as the spring, engaging at 3 mm compression.
    stop_named("bump stop (sweep)", 3.0e-3, None, 2.0e4, seed(12));
}

#[test]
fn hidden_stops_on_both_sides_are_named() {
    // A stop at each end of the travel, as stiff as the spring: 3 mm in compression, 2 mm
    // in extension. One stop alone cannot fit it (a cubic spring was named before).
    stop_named(
        "stops on both sides (sweep)",
        3.0e-3,
        Some(2.0e-3),
        2.0e4,
        seed(16),
    );
}

#[test]
fn hidden_backlash_is_named() {
    // Free play of ±0.4 mm in the spring path.
    let b = 0.4e-3;
    let f = noise_force(seed(13));
    let record = force_record(
        effects(&[(EffectKind::Backlash, &[("half_gap_m", b)])]),
        &f,
        &f,
        seed(13),
    );
    let d = run("backlash (noise)", &oscillator_model(), &record);
    assert_eq!(names(&d), [EffectKind::Backlash]);
    // Half gap within 15 %; the spring behind it within 5 % (as `check_linear` in
    // `synthetic.rs`).
    check_rel(
        "half gap",
        param(&d, EffectKind::Backlash, "half_gap_m"),
        b,
        0.15,
    );
    check_rel(
        "stiffness",
        d.recalibrated["spring.stiffness_n_per_m"],
        K,
        0.05,
    );
    check_gap(&d, 2.0);
}

#[test]
fn hidden_hysteresis_is_named() {
    let record = hysteresis_record(&noise_force(seed(14)), seed(14));
    let d = run("hysteresis (noise)", &oscillator_model(), &record);
    check_hysteresis(&d, &HYSTERESIS);
}

/// A hidden Bouc-Wen loop: the parameters of `hysteresis` (see
/// [`EffectKind::Hysteresis`]).
#[derive(Clone, Copy, Debug)]
struct BoucWen {
    /// Ratio `α` of post-yield to elastic stiffness (-).
    alpha: f64,
    /// `A` (-).
    a: f64,
    /// `β` (1/m^n).
    beta_per_m: f64,
    /// `γ` (1/m^n).
    gamma_per_m: f64,
    /// `n` (-).
    n: f64,
}

impl BoucWen {
    /// Yield deflection `z_y = (A / (β + γ))^(1/n)` (m): the value `z` saturates at under
    /// monotonic loading.
    fn yield_deflection_m(&self) -> f64 {
        (self.a / (self.beta_per_m + self.gamma_per_m)).powf(1.0 / self.n)
    }

    /// The element effects with this loop on.
    fn effects(&self) -> Effects {
        effects(&[(
            EffectKind::Hysteresis,
            &[
                ("alpha", self.alpha),
                ("a", self.a),
                ("beta_per_m", self.beta_per_m),
                ("gamma_per_m", self.gamma_per_m),
                ("n", self.n),
            ],
        )])
    }
}

/// Bouc-Wen: half the stiffness hysteretic, yield deflection 1/(β+γ) = 1 mm.
const HYSTERESIS: BoucWen = BoucWen {
    alpha: 0.5,
    a: 1.0,
    beta_per_m: 700.0,
    gamma_per_m: 300.0,
    n: 1.0,
};

/// The oscillator with [`HYSTERESIS`] driven by the force `f`.
fn hysteresis_record(f: &[f64], seed: u64) -> Record {
    force_record(HYSTERESIS.effects(), f, f, seed)
}

/// Checks that hysteresis alone is named, like `bw`. β and γ separately are weakly
/// determined by a random excitation (many pairs give nearly the same loop); what the loop
/// shows is the hysteretic fraction and the yield deflection: α within ±0.1 (absolute), z_y
/// within 25 %, the total stiffness within 5 %; the gap shrinks 2x.
fn check_hysteresis(d: &Diagnosis, bw: &BoucWen) {
    assert_eq!(names(d), [EffectKind::Hysteresis]);
    let k = EffectKind::Hysteresis;
    let alpha = param(d, k, "alpha");
    let zy = param(d, k, "a") / (param(d, k, "beta_per_m") + param(d, k, "gamma_per_m"));
    println!(
        "  alpha: fitted {alpha:.3}, truth {} (tolerance ±0.1)",
        bw.alpha
    );
    assert!((alpha - bw.alpha).abs() <= 0.1, "alpha {alpha}");
    check_rel("yield deflection", zy, bw.yield_deflection_m(), 0.25);
    check_rel(
        "total stiffness",
        d.recalibrated["spring.stiffness_n_per_m"],
        K,
        0.05,
    );
    check_gap(d, 2.0);
}

/// A weak Bouc-Wen loop (1 % of the stiffness hysteretic, yielding at the linear
/// response's RMS deflection) in a heavy, lightly damped oscillator (80 kg on 50 kN/m and
/// 160 N·s/m: 4 Hz, 4 % damping, initial states ring for a second) under one logarithmic
/// sweep down from 30 to 0.5 Hz over 60 s: the resonance and most of what tells the loop
/// apart lie in a few seconds of the record. The model is the linear part exact. Hysteresis
/// alone is named and the gap falls below the recalibrated linear model's. (This record is
/// refined by output error on the whole of it, so the method before the refinement's
/// windows followed the outputs' power passes too; `window_tests` in `diagnose/windows.rs` test
/// the windows.)
#[test]
fn a_weak_loop_in_a_ringing_oscillator_under_one_down_sweep_is_named() {
    let (mass, k, c) = (80.0, 5.0e4, 160.0);
    let f = mil_identify::log_sine_sweep(30.0, 0.5, 60.0, FS, 100.0);
    let linear = plant_response(oscillator_plant_of(mass, k, c, Effects::default()), &f);
    let zy = rms(&linear);
    let bw = BoucWen {
        alpha: 0.99,
        a: 1.0,
        beta_per_m: 0.7 / zy,
        gamma_per_m: 0.3 / zy,
        n: 1.0,
    };
    let x = plant_response(oscillator_plant_of(mass, k, c, bw.effects()), &f);
    let record = noisy_record("force", &f, &x, seed(17));
    let model = oscillator_model_of(mass, k, c);
    let d = run("weak hysteresis (one down sweep, ringing)", &model, &record);
    assert_eq!(names(&d), [EffectKind::Hysteresis]);
    println!(
        "  gap: {:.4} recalibrated -> {:.4} updated",
        d.gap_recalibrated.nrmse, d.gap_after.nrmse
    );
    assert!(d.gap_after.nrmse < d.gap_recalibrated.nrmse);
}

/// Five minutes of record (300 000 samples): the candidates are searched on the middle of
/// each block (`SELECTION_SAMPLES`), each piece filtered on its own after a warm-up, and the
/// hidden effect with a memory (Bouc-Wen hysteresis, whose state the pieces restart) is
/// still named with its parameters, as on the whole of a short record.
#[test]
fn a_long_record_is_searched_on_pieces_and_names_the_hidden_hysteresis() {
    let f = mil_identify::band_limited_noise(0.5, 60.0, 300.0, FS, FORCE_RMS, false, seed(16));
    let record = hysteresis_record(&f, seed(16));
    let d = run("hysteresis (5 min of noise)", &oscillator_model(), &record);
    let pieces = d
        .notes
        .iter()
        .find(|n| n.starts_with("candidate effects ranked and fitted (equation error) on "));
    println!("  {pieces:?}");
    assert!(pieces.is_some(), "the search ran on the whole record");
    check_hysteresis(&d, &HYSTERESIS);
}

#[test]
fn hidden_input_delay_is_named() {
    // The force acts 6.5 ms after it is logged (transport delay of a drive).
    let tau = 6.5e-3;
    let f = noise_force(seed(15));
    let applied = delayed(&f, tau);
    let record = force_record(Effects::default(), &applied, &f, seed(15));
    let d = run("input delay (noise)", &oscillator_model(), &record);
    assert_eq!(names(&d), [EffectKind::InputDelay]);
    // Delay within 0.5 ms (half a sample).
    let v = param(&d, EffectKind::InputDelay, "delay_s");
    println!("  delay: fitted {v:.5} s, truth {tau} s (tolerance 0.5 ms)");
    assert!((v - tau).abs() <= 0.5e-3, "delay {v}");
    check_gap(&d, 2.0);
}

#[test]
fn hidden_input_saturation_is_named() {
    // The drive clips the commanded force at ±1.6 × its RMS (about 11 % of the samples).
    let limit = 1.6 * FORCE_RMS;
    let f = noise_force(seed(16));
    let applied = clipped(&f, limit);
    let record = force_record(Effects::default(), &applied, &f, seed(16));
    let d = run("saturation (noise)", &oscillator_model(), &record);
    assert_eq!(names(&d), [EffectKind::Saturation]);
    // Each limit within 10 %.
    for (key, truth) in [("lower_limit", -limit), ("upper_limit", limit)] {
        check_rel(key, param(&d, EffectKind::Saturation, key), truth, 0.10);
    }
    check_gap(&d, 2.0);
}

#[test]
fn hidden_unequal_input_saturation_is_named() {
    // The drive clips the commanded force at -1.2 and +2.0 × its RMS (a one-sided clip in
    // effect: about 11 % of the samples below, 2 % above).
    let (lower, upper) = (-1.2 * FORCE_RMS, 2.0 * FORCE_RMS);
    let f = noise_force(seed(20));
    let applied: Vec<f64> = f.iter().map(|v| v.clamp(lower, upper)).collect();
    let record = force_record(Effects::default(), &applied, &f, seed(20));
    let d = run("unequal saturation (noise)", &oscillator_model(), &record);
    assert_eq!(names(&d), [EffectKind::Saturation]);
    for (key, truth) in [("lower_limit", lower), ("upper_limit", upper)] {
        check_rel(key, param(&d, EffectKind::Saturation, key), truth, 0.10);
    }
    check_gap(&d, 2.0);
}

/// The wheel on the road `applied` (what reaches the wheel pan), recorded with the logged
/// `road` (before the input effect) and noise, diagnosed; checks that exactly `kind` is
/// named, on the road input.
fn road_effect_named(
    what: &str,
    applied: &[f64],
    road: &[f64],
    seed: u64,
    kind: EffectKind,
) -> Diagnosis {
    let (x, _) = wheel_response(applied, false);
    let record = noisy_record("road", road, &x, seed);
    let d = run(what, &wheel_model(), &record);
    assert_eq!(names(&d), [kind]);
    assert_eq!(d.named[0].named.element, "road", "placed on the input");
    d
}

#[test]
fn hidden_road_play_is_named_on_the_input() {
    // The road actuator reaches the wheel pan through a linkage with 1.5 mm of free play
    // each way (a play operator on the road, about half the road's 2 mm RMS profile); the
    // record logs the actuator's road, before the play.
    let half_gap = 1.5e-3;
    let road = track_road(seed(21));
    let mut held = road[0];
    let played: Vec<f64> = road
        .iter()
        .map(|&w| {
            held = held.clamp(w - half_gap, w + half_gap);
            held
        })
        .collect();
    let d = road_effect_named(
        "free play on the road (track-like road)",
        &played,
        &road,
        seed(21),
        EffectKind::Backlash,
    );
    check_rel(
        "half gap",
        param(&d, EffectKind::Backlash, "half_gap_m"),
        half_gap,
        0.10,
    );
    check_gap(&d, 2.0);
}

#[test]
fn hidden_road_rate_limit_is_named_on_the_noisy_logged_road() {
    // The road actuator's velocity saturates at 0.5 m/s (its valve's flow limit): the kerb
    // strikes (25 mm in 100 ms, 0.79 m/s at their steepest) come out slower than commanded,
    // the random profile (about 0.1 m/s RMS) passes. The record logs the commanded road
    // with its noise, whose sample-to-sample rate the limit must not act on.
    let rate = 0.5;
    let road = track_road(seed(23));
    let d = road_effect_named(
        "rate limit on the road (track-like road)",
        &rate_limited(&road, rate),
        &road,
        seed(23),
        EffectKind::RateLimit,
    );
    check_rel(
        "rate",
        param(&d, EffectKind::RateLimit, "rate_per_s"),
        rate,
        0.15,
    );
    check_gap(&d, 2.0);
}

#[test]
fn hidden_input_rate_limit_is_named() {
    // The drive's force rate is limited to 6 kN/s (the commanded force's rate has an RMS
    // of about 4.3 kN/s).
    let rate = 6000.0;
    let f = noise_force(seed(17));
    let applied = rate_limited(&f, rate);
    let record = force_record(Effects::default(), &applied, &f, seed(17));
    let d = run("rate limit (noise)", &oscillator_model(), &record);
    check_rate_limit_alone(&d, rate);
}

/// Checks that a rate limit alone is named, its rate within 15 % of `rate`, and that the
/// gap shrinks at least 2x.
fn check_rate_limit_alone(d: &Diagnosis, rate: f64) {
    assert_eq!(names(d), [EffectKind::RateLimit]);
    check_rel(
        "rate",
        param(d, EffectKind::RateLimit, "rate_per_s"),
        rate,
        0.15,
    );
    check_gap(d, 2.0);
}

#[test]
fn a_rate_limit_most_of_a_sweep_reaches_is_named() {
    // A 60 kg oscillator (resonance 3.1 Hz) under one up-sweep 0.5-30 Hz of 150 N, its
    // drive's force rate limited to a thirteenth of the sweep's highest: the force passes
    // as commanded only below 2.3 Hz and comes out as a shrinking triangle above, through
    // the resonance; the limit lies below the rate of more than half of the record's
    // samples (a valve far too small for the test).
    let (mass, k, c) = (60.0, 2.26e4, 650.0);
    let amplitude = 150.0;
    let f = mil_identify::log_sine_sweep(0.5, 30.0, 40.0, FS, amplitude);
    let rate = amplitude * std::f64::consts::TAU * 30.0 / 13.0;
    let applied = rate_limited(&f, rate);
    let x = plant_response(
        oscillator_plant_of(mass, k, c, Effects::default()),
        &applied,
    );
    let record = noisy_record("force", &f, &x, seed(28));
    let model = oscillator_model_of(mass, k, c);
    let d = run("strong rate limit (one up-sweep)", &model, &record);
    check_rate_limit_alone(&d, rate);
}

/// The oscillator with Coulomb friction (2 N) and a hardening cubic spring (6e9 N/m³)
/// driven by the noise force of `seed`, diagnosed; checks that both are named with their
/// sizes and that the gap shrinks.
fn friction_and_cubic(what: &str, seed: u64) -> Diagnosis {
    let (fc, k3) = (2.0, 6.0e9);
    let f = noise_force(seed);
    let record = force_record(
        effects(&[
            (
                EffectKind::CoulombFriction,
                &[("force_n", fc), ("smoothing_velocity_m_per_s", 1e-3)],
            ),
            (EffectKind::CubicStiffness, &[("stiffness_n_per_m3", k3)]),
        ]),
        &f,
        &f,
        seed,
    );
    let d = run(what, &oscillator_model(), &record);
    // As the single-effect tests in `synthetic.rs`: F_c within 15 %, k3 within 10 %.
    check_both(
        &d,
        (EffectKind::CoulombFriction, "force_n", fc, 0.15),
        (EffectKind::CubicStiffness, "stiffness_n_per_m3", k3, 0.10),
    );
    d
}

/// Checks that exactly the two effects are named, each's parameter `(effect, key, truth,
/// relative tolerance)` within its tolerance, and that the gap shrinks at least 2x.
fn check_both(d: &Diagnosis, a: (EffectKind, &str, f64, f64), b: (EffectKind, &str, f64, f64)) {
    let mut n = names(d);
    n.sort();
    let mut want = [a.0, b.0];
    want.sort();
    assert_eq!(n, want, "both effects, nothing else");
    for (kind, key, truth, rel) in [a, b] {
        check_rel(key, param(d, kind, key), truth, rel);
    }
    check_gap(d, 2.0);
}

#[test]
fn hidden_friction_and_cubic_stiffness_are_both_named() {
    friction_and_cubic("Coulomb friction + cubic stiffness (noise)", seed(18));
}

/// A record of the same two effects where a Bouc-Wen loop explains more than either alone
/// and is named first (its small yield deflection is friction-like and its loop bends
/// like the cubic), and neither effect refined on top of it pays off: the stand-in check
/// continues the first round's runner-up (the cubic spring), finds the friction with it,
/// and names the pair. (Without the check, hysteresis alone was named here.) The record is
/// fixed, not shifted by `DIAGNOSE_SEED_OFFSET`: the check is exercised on this one. Which
/// route a record takes is sensitive: seed 27 took it until the rig's element laws became
/// `mil-structure`'s, whose different summation order changed the record by 1e-14 relative
/// and let the cubic spring beat the loop in the first round (the pair was still named,
/// directly); seed 36 (one of the first two of 0–79 that take this route now) is used.
#[test]
fn a_one_effect_stand_in_gives_way_to_the_two_effects() {
    let d = friction_and_cubic(
        "Coulomb friction + cubic stiffness, hysteresis first (noise)",
        36,
    );
    assert!(
        d.notes
            .iter()
            .any(|n| n.starts_with("stand-in check:") && n.contains("the pair is named")),
        "the pair comes from the stand-in check: {:#?}",
        d.notes
    );
}

// --- Lift-off: a mass on a tyre spring over a track-like road -------------------------

/// A track-like road (m): a random profile (pink, 0.5–20 Hz, 2 mm RMS) with a 25 mm
/// half-sine bump of 100 ms every 1.3 s.
fn track_road(seed: u64) -> Vec<f64> {
    let mut w = mil_identify::band_limited_noise(0.5, 20.0, DURATION_S, FS, 2e-3, true, seed);
    let (height, len) = (25e-3, (0.1 * FS) as usize);
    let every = (1.3 * FS) as usize;
    let mut start = (0.5 * FS) as usize;
    while start + len < w.len() {
        for k in 0..len {
            let s = k as f64 / len as f64;
            w[start + k] += height * (std::f64::consts::PI * s).sin();
        }
        start += every;
    }
    w
}

fn lift_off_record(road: &[f64], seed: u64) -> Record {
    let (x, pulling) = wheel_response(road, true);
    let (xmin, xmax) = x
        .iter()
        .fold((f64::MAX, f64::MIN), |a, v| (a.0.min(*v), a.1.max(*v)));
    println!("x in [{xmin:.4}, {xmax:.4}] m");
    println!(
        "lift-off record: tyre unloaded in {:.1} % of the samples",
        100.0 * pulling
    );
    noisy_record("road", road, &x, seed)
}

#[test]
fn hidden_lift_off_is_named() {
    let record = lift_off_record(&track_road(seed(19)), seed(19));
    let model = wheel_model();
    let d = run("lift-off (track-like road)", &model, &record);
    assert_eq!(names(&d), [EffectKind::LiftOff]);
    // The preload is the static wheel load m g: within 10 %.
    check_rel(
        "preload",
        param(&d, EffectKind::LiftOff, "preload_n"),
        WHEEL_MASS * GRAVITY_M_PER_S2,
        0.10,
    );
    check_rel(
        "tyre stiffness",
        d.recalibrated["tyre.stiffness_n_per_m"],
        TYRE_K,
        0.05,
    );
    check_gap(&d, 2.0);
}

/// A hardening cubic spring (4e9 N/m³) under a drive whose force rate is limited, one
/// logarithmic down-sweep 60-3 Hz of 30 N (the limit, a third of the sweep's highest
/// rate, acts above 20 Hz, down to the resonance's neighbourhood): checks that both are
/// named, the cubic's size within 15 % and the rate within 15 %, and that the gap
/// shrinks. The pair of the development set's pairs 2 and 81 (there with effects of 3-10x
/// the noise, where a Bouc-Wen loop can explain more than the cubic spring while the rate
/// limit's lag is not modelled); sized as here, the cubic spring is named first (the
/// replacement step that undoes such a loop is exercised by `tests/development_pairs.rs`).
#[test]
fn a_hardening_spring_behind_a_rate_limited_drive_is_named_as_such() {
    let (k3, amplitude) = (4.0e9, 30.0);
    let mut f = mil_identify::log_sine_sweep(3.0, 60.0, DURATION_S, FS, amplitude);
    f.reverse();
    let rate = amplitude * std::f64::consts::TAU * 60.0 / 3.0;
    let applied = rate_limited(&f, rate);
    let record = force_record(
        effects(&[(EffectKind::CubicStiffness, &[("stiffness_n_per_m3", k3)])]),
        &applied,
        &f,
        seed(29),
    );
    let d = run(
        "cubic stiffness behind a rate-limited drive (down-sweep)",
        &oscillator_model(),
        &record,
    );
    for n in &d.notes {
        println!("  note: {n}");
    }
    check_both(
        &d,
        (EffectKind::CubicStiffness, "stiffness_n_per_m3", k3, 0.15),
        (EffectKind::RateLimit, "rate_per_s", rate, 0.15),
    );
}
