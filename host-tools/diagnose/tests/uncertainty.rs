//! Coverage of the reported uncertainties when the model is wrong. The one-DOF oscillator
//! of `synthetic.rs` (made by the simulated rig, `mil-rig`) hides a strong cubic stiffness
//! (about a third of the linear spring force at the record's RMS deflection); the
//! diagnosis is asked to name nothing (`max_effects = 0`), so the linear model it
//! recalibrates stays wrong. Over 24 records, each with its own random force and noise,
//! the recalibrated mass, stiffness and damping scatter around their pseudo-true values
//! (the best linear fit to this kind of record); the standard deviations the diagnosis
//! reports must describe that scatter (a median within a factor 2 of it) and ±2σ must
//! cover at least 80 % of the records. The classical `σ² (JᵀJ)⁻¹` understates such
//! scatter many times over (`uncertainty.rs`'s own test shows it on a line fitted to a
//! parabola).

mod common;

use common::*;
use mil_diagnose::{diagnose, EffectKind, Options};

#[test]
fn recalibrated_uncertainties_cover_their_scatter_when_an_effect_is_missing() {
    let records = 24u64;
    let keys = [
        "x.mass",
        "spring.stiffness_n_per_m",
        "spring.damping_n_s_per_m",
    ];
    let mut values: Vec<Vec<f64>> = vec![Vec::new(); keys.len()];
    let mut stds: Vec<Vec<f64>> = vec![Vec::new(); keys.len()];
    for r in 0..records {
        let seed = 700 + r;
        let f = mil_identify::band_limited_noise(0.5, 60.0, 8.0, FS, FORCE_RMS, false, seed);
        let cubic = effects(&[(EffectKind::CubicStiffness, &[("stiffness_n_per_m3", 6.0e9)])]);
        let x = oscillator_response(cubic, &f);
        let record = noisy_record("force", &f, &x, seed);
        let options = Options {
            max_effects: 0,
            ..Options::default()
        };
        let d = diagnose(&oscillator_model(), &record, &options).expect("diagnose");
        assert!(d.named.is_empty());
        for (k, key) in keys.iter().enumerate() {
            values[k].push(d.recalibrated[*key]);
            stds[k].push(d.recalibrated_std[*key]);
        }
    }
    for (k, key) in keys.iter().enumerate() {
        let n = values[k].len() as f64;
        let mean = values[k].iter().sum::<f64>() / n;
        let spread = (values[k].iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
        let mut sorted = stds[k].clone();
        sorted.sort_by(f64::total_cmp);
        let reported = sorted[sorted.len() / 2];
        let covered = values[k]
            .iter()
            .zip(&stds[k])
            .filter(|(v, sd)| (*v - mean).abs() <= 2.0 * *sd)
            .count();
        println!(
            "{key}: mean {mean:.5e}, scatter {spread:.3e}, reported (median) {reported:.3e} \
             (ratio {:.2}); ±2σ covers {covered}/{records}",
            reported / spread
        );
        assert!(
            reported / spread > 0.5 && reported / spread < 2.0,
            "{key}: reported {reported} vs scatter {spread}"
        );
        assert!(
            covered as f64 >= 0.8 * records as f64,
            "{key}: ±2σ covers {covered}/{records}"
        );
    }
}
