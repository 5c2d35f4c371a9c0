//! `docs/structure.md` cannot drift from the code: its example blocks are read by the
//! validator, every key the schema serialises and every effect name and parameter the laws
//! report appear in it, and the limits it quotes are the plausibility checks' constants.

use mil_structure::effects::{EffectKind, ElementLaw, InputLaw};
use mil_structure::plausible::{
    MAX_NATURAL_FREQUENCY_HZ, MAX_STATIC_COMPRESSION_M, MIN_NATURAL_FREQUENCY_HZ,
};
use mil_structure::Model;
use std::collections::{BTreeMap, BTreeSet};

#[path = "common/markdown.rs"]
mod markdown;
use markdown::toml_blocks;

fn reference() -> String {
    std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/structure.md"),
    )
    .unwrap()
}

/// Every key of a TOML value, recursively.
fn keys(value: &toml::Value, out: &mut BTreeSet<String>) {
    match value {
        toml::Value::Table(t) => {
            for (k, v) in t {
                out.insert(k.clone());
                keys(v, out);
            }
        }
        toml::Value::Array(a) => a.iter().for_each(|v| keys(v, out)),
        _ => {}
    }
}

#[test]
fn the_examples_are_valid_structures() {
    let blocks = toml_blocks(&reference());
    assert_eq!(blocks.len(), 2, "a minimal and a full example");
    for b in &blocks {
        Model::from_toml(b).unwrap_or_else(|e| panic!("{e}\n{b}"));
    }
    // The full example uses every table of the schema.
    let full: toml::Table = toml::from_str(&blocks[1]).unwrap();
    for table in ["dof", "point", "element", "input", "output", "effect"] {
        assert!(full.contains_key(table), "{table}");
    }
}

#[test]
fn every_key_effect_and_parameter_is_documented() {
    let doc = reference();
    let blocks = toml_blocks(&doc);
    // Every key the schema writes, from the full example written back with every optional
    // field set.
    let mut m = Model::from_toml(&blocks[1]).unwrap();
    m.bias[1] = 0.5;
    let mut file = m.to_file();
    file.elements[1].preload_n = 1.0;
    file.dofs[0].bias_n = 0.25;
    let value = toml::Value::try_from(&file).unwrap();
    let mut all = BTreeSet::new();
    keys(&value, &mut all);
    for key in ["kind", "bias_n", "preload_n", "gain", "at", "description"] {
        assert!(all.contains(key), "{key} not written: {all:?}");
    }
    for key in &all {
        // DOF names inside `position` are data.
        if m.dofs.contains(key) {
            continue;
        }
        assert!(
            doc.contains(&format!("`{key}`")),
            "key {key} is not in the reference"
        );
    }
    // Every effect by name, and every parameter the laws report.
    let mut law = ElementLaw::linear(1e5, 100.0);
    let mut input = InputLaw::default();
    let p = |pairs: &[(&str, f64)]| -> BTreeMap<String, f64> {
        pairs.iter().map(|(k, v)| (k.to_string(), *v)).collect()
    };
    for kind in EffectKind::ALL {
        assert!(doc.contains(&format!("`{}`", kind.name())), "{kind}");
    }
    law.apply(EffectKind::LiftOff, &p(&[("preload_n", 10.0)]))
        .unwrap();
    law.apply(
        EffectKind::CoulombFriction,
        &p(&[("force_n", 1.0), ("smoothing_velocity_m_per_s", 1e-3)]),
    )
    .unwrap();
    law.apply(
        EffectKind::CubicStiffness,
        &p(&[("stiffness_n_per_m3", 1e9)]),
    )
    .unwrap();
    law.apply(
        EffectKind::BumpStop,
        &p(&[
            ("gap_m", 0.01),
            ("rebound_gap_m", 0.02),
            ("stiffness_n_per_m", 1e5),
            ("rebound_stiffness_n_per_m", 2e5),
        ]),
    )
    .unwrap();
    law.apply(EffectKind::Backlash, &p(&[("half_gap_m", 1e-3)]))
        .unwrap();
    law.apply(
        EffectKind::QuadraticDamping,
        &p(&[("damping_n_s2_per_m2", 5.0)]),
    )
    .unwrap();
    law.apply(
        EffectKind::AsymmetricDamping,
        &p(&[("bump_n_s_per_m", 80.0), ("rebound_n_s_per_m", 120.0)]),
    )
    .unwrap();
    law.apply(
        EffectKind::Hysteresis,
        &p(&[
            ("alpha", 0.5),
            ("a", 1.0),
            ("beta_per_m", 500.0),
            ("gamma_per_m", 100.0),
            ("n", 1.0),
        ]),
    )
    .unwrap();
    input
        .apply(EffectKind::InputDelay, &p(&[("delay_s", 1e-3)]))
        .unwrap();
    input
        .apply(EffectKind::RateLimit, &p(&[("rate_per_s", 1.0)]))
        .unwrap();
    input
        .apply(
            EffectKind::Saturation,
            &p(&[("lower_limit", -1.0), ("upper_limit", 1.0)]),
        )
        .unwrap();
    let mut parameters = BTreeSet::new();
    for kind in EffectKind::ALL {
        for source in [law.parameters(kind), input.parameters(kind)] {
            parameters.extend(source.into_iter().flat_map(|m| m.into_keys()));
        }
    }
    parameters.insert("limit".into());
    assert!(parameters.len() >= 20, "{parameters:?}");
    for name in &parameters {
        assert!(
            doc.contains(&format!("`{name}`")),
            "parameter {name} is not in the reference"
        );
    }
}

#[test]
fn the_quoted_limits_are_the_checks_constants() {
    let doc = reference();
    assert!(doc.contains(&format!("{MAX_STATIC_COMPRESSION_M} m")));
    assert!(doc.contains(&format!(
        "{MIN_NATURAL_FREQUENCY_HZ} Hz–{} kHz",
        MAX_NATURAL_FREQUENCY_HZ / 1e3
    )));
    assert!(doc.contains("1–30 m/s²"));
}
