//! Held-out benchmark of `mil diagnose`: an independent generator of measured records with
//! known hidden effects, and a harness that runs the diagnosis on them and scores it.
//!
//! ```text
//! cargo run --release -p mil-diagnose --example heldout --
//!     [--set dev|untouched|untouched2|untouched3|untouched4|untouched5|untouched6]
//!     [--records N] [--matrix] [--pairs] [--only ID] [--write DIR] [--no-diagnose] [--verbose]
//! ```
//!
//! # What it generates
//!
//! Each record is drawn from its seed (`--set dev`: seeds 1000 + id, `--set untouched`:
//! 900000 + id, `--set untouched2`: 2000000 + id, `--set untouched3`: 3000000 + id,
//! `--set untouched4`: 4000000 + id, `--matrix`: 5000000 + id, `--set untouched5`:
//! 6000000 + id, `--pairs`: 7000000 + id, `--set untouched6`: 8000000 + id,
//! disjoint for any sensible `--records`). `untouched` was run once on the method of the
//! session that first reported it, `untouched2` once on the method that followed,
//! `untouched3` once on the next (the closing margin, stops on both sides), `untouched4`
//! once on the one after (the output-error windows placed by the outputs' power and warmed
//! up over the slowest decay), `untouched5` once on the next (stepwise search, the
//! equation error's blind spots refined while the model misses more than the practical
//! margin), `untouched6` once on the one after (effects kept passive, the replacement
//! step). `--pairs` is a development set of pairs only: every element
//! effect with every partner the random sets pair it with, per topology, the excitation and
//! the model cycling with the index:
//!
//! - a topology: `qc_disp` (quarter car on a road: body `x_s`, hub `x_u`, `suspension`,
//!   `tyre` to the `road` displacement input; outputs `body`, `hub`, `tyre_force`),
//!   `qc_accel` (the same, the body seen by an accelerometer, `body_acc`), or `sdof` (mass
//!   `x` on `spring` to ground, driven by the `force` input, output `x`), with random true
//!   parameters (quarter car around 150 kg / 20-40 kg / 120 kN/m / 2.5 kN s/m / 250 kN/m /
//!   500 N s/m, each × U(0.6, 1.5); sdof 0.5-300 kg, 2-20 Hz, damping ratio 0.03-0.3);
//! - an excitation of 20-60 s: pink noise 0.5-30 Hz, a log sweep up (0.5 → 30 Hz, then
//!   back down to 8-15 Hz) or down (30 → 0.5 Hz, then back up to 2-6 Hz) of constant
//!   amplitude, or haversine / half-sine bumps and pot-holes (20-300 ms) on a small pink
//!   background; 1 s half-cosine fades at both ends, so the record starts at rest. The road
//!   is scaled so the peak linear dynamic tyre force is 0.4-0.85 of the static wheel load;
//!   the sdof force so the displacement RMS is 1-10 mm;
//! - the hidden effects: none (1/6), one (2/3), or a pair (1/6: an element effect plus
//!   lift-off or an input effect). Element effects on `suspension` / `spring`:
//!   `cubic_stiffness` (hardening or softening), `coulomb_friction` (sign law, regularised
//!   by a ramp as steep as the 10 kHz step allows), presliding friction (Dahl, named
//!   `coulomb_friction` or `hysteresis` accepted), `bump_stop` (compression, extension or
//!   both, gap at the 90-98 % quantile of the deflection), `backlash` (free play in the
//!   spring path), `quadratic_damping`, `asymmetric_damping`, `hysteresis` (Bouc-Wen, n = 1).
//!   `lift_off` of the tyre (the road is then scaled up until the tyre leaves it). Input
//!   effects on `road` / `force`: `input_delay` (2-15 ms), `rate_limit`, `saturation`
//!   (symmetric or unequal limits), and for the road a play operator (`backlash` on `road`).
//!   Each effect's strength is set by bisection over simulations so that its visibility,
//!   `max over outputs of rms(y_with − y_without) / noise_std`, is a target drawn from
//!   U(3, 10) (strength ranges are bounded; the truth records the visibility reached);
//! - white noise on every column (input included) of U(0.5, 3) % of its clean std;
//! - the model given: `exact` (true linear parameters) or `off` (each linear parameter,
//!   masses included, × 1 ± U(0.10, 0.20)); effects are never in it.
//!
//! `--write DIR` writes `DIR/NNN/record.csv`, `model.toml`, `truth.json`, so that
//! `mil diagnose --model model.toml --data record.csv` can be run by hand.
//!
//! # How it stays independent
//!
//! The physics is written here from the equations (`heldout/physics.rs`): explicit ODEs of
//! each plant, each effect's law, fixed-step RK4 at 10 kHz with the inputs on a 20 kHz
//! grid, sampled at 1 kHz. It uses nothing of `mil_diagnose::{effects, simulate, equation}`
//! nor `mil-rig`'s plant or effects; only `mil_numerics::rng::SplitMix64` (the project's RNG)
//! and `mil_identify`'s band-limited noise. The model file is TOML text written here and the
//! record CSV text, both parsed by the public API (`Model::from_toml`, `Record::from_reader`);
//! the harness calls `diagnose` with default `Options` and reads only the public fields
//! of the `Diagnosis` (`named`, `recalibrated`, `gap_before`, `gap_after`, `notes`).
//!
//! # What it prints
//!
//! One line per record, then: the exact effect set named (by model, case, excitation,
//! topology, hidden effect), false alarms on clean records, placement, gap after over the
//! noise floor (the NRMSE of a perfect model over the whole record, from the output noise
//! alone, since the diagnosis validates on blocks spread over the record; also over the NRMSE of the true plant driven by the logged, noisy
//! input, "io", which adds the input noise's propagation) when the set is exact, the recalibration of clean records with an `off` model, refusals
//! (`diagnose` returned an error; counted as failures) and the time. Exit code 0 unless
//! the generation fails.

#[path = "heldout/generator.rs"]
mod generator;
#[path = "heldout/physics.rs"]
mod physics;

use generator::{Generated, Scenario};
use mil_diagnose::{diagnose, Diagnosis, Model, Options, Record};
use std::collections::BTreeMap;
use std::error::Error;
use std::path::PathBuf;
use std::time::Instant;

/// Seeds of the sets (kept disjoint).
const DEV_SEED: u64 = 1000;
const UNTOUCHED_SEED: u64 = 900_000;
/// A second untouched set, for the method as it stands after the first was run (once).
const UNTOUCHED2_SEED: u64 = 2_000_000;
/// A third, for the method after the second was run (once).
const UNTOUCHED3_SEED: u64 = 3_000_000;
/// A fourth, for the method after the third was run (once).
const UNTOUCHED4_SEED: u64 = 4_000_000;
const MATRIX_SEED: u64 = 5_000_000;
/// A fifth, for the method after the fourth was run (once).
const UNTOUCHED5_SEED: u64 = 6_000_000;
/// The pair matrix (every element effect with every partner, once).
const PAIRS_SEED: u64 = 7_000_000;
/// A sixth, for the method after the fifth was run (once).
const UNTOUCHED6_SEED: u64 = 8_000_000;

/// The `--set` names and their seeds.
const SETS: [(&str, u64); 7] = [
    ("dev", DEV_SEED),
    ("untouched", UNTOUCHED_SEED),
    ("untouched2", UNTOUCHED2_SEED),
    ("untouched3", UNTOUCHED3_SEED),
    ("untouched4", UNTOUCHED4_SEED),
    ("untouched5", UNTOUCHED5_SEED),
    ("untouched6", UNTOUCHED6_SEED),
];

/// The base seed of the set called `name`.
fn set_seed(name: &str) -> Option<u64> {
    SETS.iter().find(|(n, _)| *n == name).map(|(_, s)| *s)
}

/// Relative tolerance of a recalibrated linear parameter.
const RECAL_TOLERANCE: f64 = 0.05;

struct Args {
    set: String,
    records: usize,
    matrix: bool,
    pairs: bool,
    only: Option<usize>,
    write: Option<PathBuf>,
    diagnose: bool,
    verbose: bool,
}

fn parse_args() -> Result<Args, Box<dyn Error>> {
    let mut a = Args {
        set: "dev".into(),
        records: 60,
        matrix: false,
        pairs: false,
        only: None,
        write: None,
        diagnose: true,
        verbose: false,
    };
    let mut it = std::env::args().skip(1);
    while let Some(arg) = it.next() {
        let mut value = || it.next().ok_or_else(|| format!("{arg}: value missing"));
        match arg.as_str() {
            "--set" => a.set = value()?,
            "--records" => a.records = value()?.parse()?,
            "--matrix" => a.matrix = true,
            "--pairs" => a.pairs = true,
            "--only" => a.only = Some(value()?.parse()?),
            "--write" => a.write = Some(PathBuf::from(value()?)),
            "--no-diagnose" => a.diagnose = false,
            "--verbose" => a.verbose = true,
            "-h" | "--help" => {
                println!(
                    "heldout [--set dev|untouched|untouched2|untouched3|untouched4|untouched5|untouched6] [--records N] [--matrix] [--pairs] [--only ID] \
                     [--write DIR] [--no-diagnose] [--verbose]"
                );
                std::process::exit(0);
            }
            other => return Err(format!("unknown argument {other:?}").into()),
        }
    }
    if set_seed(&a.set).is_none() {
        let names: Vec<&str> = SETS.iter().map(|(n, _)| *n).collect();
        return Err(format!("--set {}: one of {}", a.set, names.join(", ")).into());
    }
    Ok(a)
}

/// What the diagnosis returned, reduced to what is scored.
struct Found {
    named: Vec<(String, String)>,
    gap_before: f64,
    gap_after: f64,
    recalibrated: BTreeMap<String, f64>,
    /// Why the model reader refuses the updated model (its `updated.toml`), if it does: a
    /// negative parameter anywhere.
    unreadable: Option<String>,
    notes: Vec<String>,
    /// Every candidate's equation-error score, best first per round (`--verbose`).
    candidates: Vec<String>,
}

struct Outcome {
    sc: Scenario,
    noise_floor: f64,
    perfect_io: f64,
    true_linear: BTreeMap<String, f64>,
    gen_s: f64,
    diag_s: f64,
    /// `None` with `--no-diagnose`.
    result: Option<Result<Found, String>>,
}

/// Scores of one diagnosed record.
struct Score {
    exact: bool,
    /// (right element, matched) over named effects of a right kind.
    placed: (usize, usize),
}

fn found_of(d: &Diagnosis) -> Found {
    let named = d
        .named
        .iter()
        .map(|n| {
            let kind = serde_json::to_value(n.named.effect)
                .ok()
                .and_then(|v| v.as_str().map(str::to_string))
                .unwrap_or_else(|| format!("{:?}", n.named.effect));
            (kind, n.named.element.clone())
        })
        .collect();
    Found {
        named,
        gap_before: d.gap_before.nrmse,
        gap_after: d.gap_after.nrmse,
        recalibrated: d.recalibrated.clone(),
        unreadable: Model::from_toml(&d.updated.to_toml())
            .err()
            .map(|e| e.to_string()),
        notes: d.notes.clone(),
        candidates: {
            let mut c = d.candidates.clone();
            c.sort_by(|a, b| {
                a.round
                    .cmp(&b.round)
                    .then(a.criterion.total_cmp(&b.criterion))
            });
            c.iter()
                .map(|c| {
                    format!(
                        "round {}: {} on {:?}: criterion {:.1}, SSE x{:.4}",
                        c.round, c.effect, c.element, c.criterion, c.sse_ratio
                    )
                })
                .collect()
        },
    }
}

/// Matches the hidden effects to the named ones by kind.
fn score(sc: &Scenario, f: &Found) -> Score {
    let mut used = vec![false; f.named.len()];
    let mut matched = 0;
    let mut placed = (0, 0);
    for e in &sc.effects {
        let accepted = e.accepted();
        let on = e.on(sc.topology);
        let kind_ok = |i: usize| !used[i] && accepted.contains(&f.named[i].0.as_str());
        // Prefer a named effect of an accepted kind on the right element.
        let hit = (0..f.named.len())
            .find(|&i| kind_ok(i) && f.named[i].1 == on)
            .or_else(|| (0..f.named.len()).find(|&i| kind_ok(i)));
        if let Some(i) = hit {
            used[i] = true;
            matched += 1;
            placed.1 += 1;
            if f.named[i].1 == on {
                placed.0 += 1;
            }
        }
    }
    Score {
        exact: matched == sc.effects.len() && matched == f.named.len(),
        placed,
    }
}

fn run_one(sc: &Scenario, set: &str, args: &Args) -> Result<Outcome, Box<dyn Error>> {
    let t = Instant::now();
    let g: Generated = generator::generate(sc, set)?;
    let gen_s = t.elapsed().as_secs_f64();
    if let Some(dir) = &args.write {
        let d = dir.join(format!("{:03}", sc.id));
        std::fs::create_dir_all(&d)?;
        std::fs::write(d.join("record.csv"), &g.csv)?;
        std::fs::write(d.join("model.toml"), &g.model_toml)?;
        std::fs::write(
            d.join("truth.json"),
            serde_json::to_string_pretty(&g.truth)?,
        )?;
    }
    let mut diag_s = 0.0;
    let result = if args.diagnose {
        let t = Instant::now();
        let r = Model::from_toml(&g.model_toml)
            .map_err(mil_diagnose::Error::from)
            .and_then(|m| Record::from_reader(g.csv.as_bytes()).map(|r| (m, r)))
            .and_then(|(m, r)| diagnose(&m, &r, &Options::default()))
            .map(|d| found_of(&d))
            .map_err(|e| e.to_string());
        diag_s = t.elapsed().as_secs_f64();
        Some(r)
    } else {
        None
    };
    Ok(Outcome {
        sc: sc.clone(),
        noise_floor: g.noise_floor,
        perfect_io: g.perfect_io,
        true_linear: g.true_linear,
        gen_s,
        diag_s,
        result,
    })
}

fn named_label(f: &Found) -> String {
    if f.named.is_empty() {
        "-".into()
    } else {
        f.named
            .iter()
            .map(|(k, e)| format!("{k}@{e}"))
            .collect::<Vec<_>>()
            .join("+")
    }
}

fn print_line(o: &Outcome, verbose: bool) {
    let sc = &o.sc;
    let head = format!(
        "{:>3} {:<8} {:<10} {:<5} {:<45}",
        sc.id,
        sc.topology.name(),
        sc.excitation.name(),
        sc.model.name(),
        sc.truth_label()
    );
    match &o.result {
        None => println!(
            "{head} (not diagnosed)  floor {:.4} (io {:.4})  gen {:.1} s",
            o.noise_floor, o.perfect_io, o.gen_s
        ),
        Some(Err(e)) => println!(
            "{head} REFUSED: {}  floor {:.4} (io {:.4})  {:.1} s",
            e.lines().next().unwrap_or(""),
            o.noise_floor,
            o.perfect_io,
            o.diag_s
        ),
        Some(Ok(f)) => {
            let s = score(sc, f);
            println!(
                "{head} {:<4} named {:<45} gap {:.4} -> {:.4}  floor {:.4} (io {:.4})  {:.1} s",
                if s.exact { "OK" } else { "MISS" },
                named_label(f),
                f.gap_before,
                f.gap_after,
                o.noise_floor,
                o.perfect_io,
                o.diag_s
            );
            if let Some(why) = &f.unreadable {
                println!("      UNREADABLE updated model: {why}");
            }
            if verbose {
                for n in &f.notes {
                    println!("      note: {n}");
                }
                for c in &f.candidates {
                    println!("      candidate {c}");
                }
                for (k, v) in &f.recalibrated {
                    let truth = o.true_linear.get(k).map_or(String::new(), |t| {
                        format!(" (true {t:.4e}, {:+.1} %)", (v / t - 1.0) * 100.0)
                    });
                    println!("      recal {k} = {v:.4e}{truth}");
                }
            }
        }
    }
}

#[derive(Default, Clone, Copy)]
struct Tally {
    ok: usize,
    n: usize,
}

impl Tally {
    fn add(&mut self, ok: bool) {
        self.n += 1;
        if ok {
            self.ok += 1;
        }
    }
}

impl std::fmt::Display for Tally {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.n == 0 {
            write!(f, "    -")
        } else {
            write!(
                f,
                "{:>3}/{:<3} ({:5.1} %)",
                self.ok,
                self.n,
                100.0 * self.ok as f64 / self.n as f64
            )
        }
    }
}

fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

fn summary(outcomes: &[Outcome], wall_s: f64) {
    let diagnosed: Vec<&Outcome> = outcomes.iter().filter(|o| o.result.is_some()).collect();
    let gen_total: f64 = outcomes.iter().map(|o| o.gen_s).sum();
    let diag_total: f64 = outcomes.iter().map(|o| o.diag_s).sum();
    println!();
    println!("=== summary: {} records ===", outcomes.len());
    if diagnosed.is_empty() {
        println!(
            "wall time {wall_s:.1} s (generation {gen_total:.1} s, {:.2} s per record)",
            gen_total / outcomes.len().max(1) as f64
        );
        return;
    }
    let mut all = Tally::default();
    let mut by: BTreeMap<(&str, String), Tally> = BTreeMap::new();
    let mut clean_fa = Tally::default();
    let mut placed = Tally::default();
    let mut ratios = Vec::new();
    let mut ratios_io = Vec::new();
    let mut recal_params = Tally::default();
    let mut recal_records = Tally::default();
    let mut refusals: BTreeMap<String, usize> = BTreeMap::new();
    let mut refused = 0;
    let mut unreadable = Tally::default();
    for o in &diagnosed {
        let sc = &o.sc;
        let exact = match &o.result {
            Some(Ok(f)) => {
                let s = score(sc, f);
                unreadable.add(f.unreadable.is_some());
                placed.ok += s.placed.0;
                placed.n += s.placed.1;
                if sc.effects.is_empty() {
                    clean_fa.add(!f.named.is_empty());
                }
                if s.exact && o.noise_floor > 0.0 {
                    ratios.push(f.gap_after / o.noise_floor);
                    if o.perfect_io.is_finite() && o.perfect_io > 0.0 {
                        ratios_io.push(f.gap_after / o.perfect_io);
                    }
                }
                if sc.effects.is_empty() && sc.model == generator::ModelKind::Off {
                    let mut all_in = true;
                    for (k, t) in &o.true_linear {
                        let ok = f
                            .recalibrated
                            .get(k)
                            .is_some_and(|v| (v / t - 1.0).abs() <= RECAL_TOLERANCE);
                        // Masses count only when reported.
                        if f.recalibrated.contains_key(k) || !k.ends_with(".mass") {
                            recal_params.add(ok);
                            all_in &= ok;
                        }
                    }
                    recal_records.add(all_in);
                }
                s.exact
            }
            Some(Err(e)) => {
                refused += 1;
                *refusals
                    .entry(e.lines().next().unwrap_or("").to_string())
                    .or_default() += 1;
                false
            }
            None => false,
        };
        all.add(exact);
        by.entry(("model", sc.model.name().into()))
            .or_default()
            .add(exact);
        by.entry(("case", sc.case().into())).or_default().add(exact);
        by.entry(("excitation", sc.excitation.name().into()))
            .or_default()
            .add(exact);
        by.entry(("topology", sc.topology.name().into()))
            .or_default()
            .add(exact);
        for e in &sc.effects {
            by.entry(("hidden effect", e.name().into()))
                .or_default()
                .add(exact);
        }
        if sc.effects.is_empty() {
            by.entry(("hidden effect", "(none)".into()))
                .or_default()
                .add(exact);
        }
    }
    println!("exact effect set named (refused records count as failures)");
    println!("  {:<28} {all}", "overall");
    let mut last = "";
    for ((group, key), t) in &by {
        if *group != last {
            println!("  by {group}:");
            last = group;
        }
        println!("    {key:<26} {t}");
    }
    println!("false alarms on clean records (something named): {clean_fa}   [fewer is better]");
    println!("placement (named on the right element/input, kind right): {placed}");
    let n_ratio = ratios.len();
    let within = ratios.iter().filter(|r| **r <= 1.5).count();
    println!(
        "gap after / noise floor when the set is exact: median {:.3}, <= 1.5 in {within}/{n_ratio}",
        median(&mut ratios)
    );
    let within_io = ratios_io.iter().filter(|r| **r <= 1.5).count();
    println!(
        "  same over the perfect-model NRMSE with the noisy logged input (io): median {:.3}, <= 1.5 in {within_io}/{}",
        median(&mut ratios_io),
        ratios_io.len()
    );
    println!(
        "recalibration within {:.0} % (clean records, model off): parameters {recal_params}, records all within {recal_records}",
        RECAL_TOLERANCE * 100.0
    );
    println!("refused: {refused}/{}", diagnosed.len());
    println!("updated model refused by the model reader (a negative parameter): {unreadable}   [0 expected]");
    for (msg, n) in &refusals {
        println!("  {n:>3} x {msg}");
    }
    let mut times: Vec<f64> = diagnosed.iter().map(|o| o.diag_s).collect();
    let max_t = times.iter().copied().fold(0.0, f64::max);
    println!(
        "time: wall {wall_s:.1} s; diagnosis {diag_total:.1} s ({:.2} s per record, median {:.2} s, max {max_t:.2} s); generation {gen_total:.1} s ({:.2} s per record)",
        diag_total / diagnosed.len() as f64,
        median(&mut times),
        gen_total / outcomes.len() as f64
    );
}

fn main() -> Result<(), Box<dyn Error>> {
    let args = parse_args()?;
    let (label, scenarios): (String, Vec<Scenario>) = if args.matrix {
        ("matrix".into(), generator::matrix(MATRIX_SEED))
    } else if args.pairs {
        ("pairs".into(), generator::pairs(PAIRS_SEED))
    } else {
        let base = set_seed(&args.set).ok_or("unknown set")?;
        let n = args.records;
        (
            args.set.clone(),
            (0..n)
                .map(|i| generator::draw_scenario(i, base + i as u64))
                .collect(),
        )
    };
    let scenarios: Vec<Scenario> = match args.only {
        Some(id) => scenarios.into_iter().filter(|s| s.id == id).collect(),
        None => scenarios,
    };
    if scenarios.is_empty() {
        return Err("no record selected".into());
    }
    println!(
        "held-out set {label}: {} records (effects sized to visibility U(3, 10) x noise)",
        scenarios.len()
    );
    println!(
        "{:>3} {:<8} {:<10} {:<5} {:<45}",
        "id", "topology", "excitation", "model", "hidden"
    );
    let t = Instant::now();
    let mut outcomes = Vec::new();
    for sc in &scenarios {
        let o = run_one(sc, &label, &args)?;
        print_line(&o, args.verbose || args.only.is_some());
        outcomes.push(o);
    }
    summary(&outcomes, t.elapsed().as_secs_f64());
    Ok(())
}
