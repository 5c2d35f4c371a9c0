//! `docs/setup.md` cannot drift from the code: its example blocks pass `mil check` (as every
//! command checks them), and every key the set-up reader accepts, in every table, is named
//! in it. The keys come from the reader itself: an unknown key is put into each table and
//! the refusal lists the table's keys.

use mil::setup::SetUp;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

#[path = "../../structure/tests/common/markdown.rs"]
mod markdown;
use markdown::toml_blocks;

fn manifest() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn reference() -> String {
    std::fs::read_to_string(manifest().join("../../docs/setup.md")).unwrap()
}

/// A scratch folder holding the shipped examples (the structure files and filters the
/// blocks name).
fn folder(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("setup-reference-{name}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    for entry in std::fs::read_dir(manifest().join("examples")).unwrap() {
        let path = entry.unwrap().path();
        std::fs::copy(&path, dir.join(path.file_name().unwrap())).unwrap();
    }
    dir
}

#[test]
fn the_examples_pass_check() {
    let blocks = toml_blocks(&reference());
    assert_eq!(blocks.len(), 2, "a minimal and a full example");
    let dir = folder("examples");
    for (k, b) in blocks.iter().enumerate() {
        let path = dir.join(format!("block-{k}.toml"));
        std::fs::write(&path, b).unwrap();
        let summary = mil::check::check(&path, None).unwrap_or_else(|e| panic!("{e:#}\n{b}"));
        assert!(summary.contains("configuration 4"), "{summary}");
    }
    // The full example has every table of the schema.
    let full: toml::Table = toml::from_str(&blocks[1]).unwrap();
    for table in [
        "controller",
        "numerical",
        "physical",
        "interface",
        "actuator",
        "excitation",
        "sensors",
        "links",
        "simulation",
        "analysis",
        "compare",
    ] {
        assert!(full.contains_key(table), "{table}");
    }
}

/// The keys the reader accepts in the table at `path` of `base` (dotted, `[0]` for the first
/// entry of an array of tables): an unknown key is added there and the refusal lists them.
fn accepted_keys(base: &toml::Table, path: &str, folder: &Path) -> Vec<String> {
    let mut doc = toml::Value::Table(base.clone());
    let mut at = &mut doc;
    for part in path.split('.').filter(|p| !p.is_empty()) {
        let (name, index) = match part.strip_suffix("[0]") {
            Some(name) => (name, true),
            None => (part, false),
        };
        let table = at
            .as_table_mut()
            .unwrap_or_else(|| panic!("{path}: {name}"));
        at = table
            .entry(name)
            .or_insert_with(|| toml::Value::Table(toml::Table::new()));
        if index {
            at = at.as_array_mut().unwrap().get_mut(0).unwrap();
        }
    }
    at.as_table_mut()
        .unwrap()
        .insert("zz_probe".into(), toml::Value::Integer(1));
    let text = toml::to_string(&doc).unwrap();
    let e = match SetUp::from_toml(&text, folder) {
        Ok(_) => panic!("{path}: an unknown key is accepted"),
        Err(e) => format!("{e:#}"),
    };
    assert!(e.contains("zz_probe"), "{path}: {e}");
    let listed = e
        .split_once("expected ")
        .unwrap_or_else(|| panic!("{path}: {e}"))
        .1;
    listed
        .split('`')
        .skip(1)
        .step_by(2)
        .map(str::to_string)
        .collect()
}

#[test]
fn every_key_of_every_table_is_documented() {
    let doc = reference();
    let blocks = toml_blocks(&doc);
    let full: toml::Table = toml::from_str(&blocks[1]).unwrap();
    let minimal: toml::Table = toml::from_str(&blocks[0]).unwrap();
    let dir = folder("keys");
    let mut tables: Vec<(&toml::Table, &str)> = [
        "",
        "controller",
        "controller.limits",
        "numerical",
        "physical",
        "interface",
        "interface.channels[0]",
        "actuator",
        "actuator.reference",
        "actuator.position_servo",
        "actuator.effects",
        "excitation",
        "excitation.road",
        "sensors",
        "sensors.position",
        "links",
        "links.position",
        "simulation",
        "analysis",
        "analysis.responses[0]",
        "compare",
    ]
    .into_iter()
    .map(|p| (&full, p))
    .collect();
    tables.extend([(&minimal, "numerical.tyre")]);
    let mut aero: toml::Table = minimal.clone();
    let numerical = aero["numerical"].as_table_mut().unwrap();
    numerical.remove("tyre");
    numerical.insert(
        "aero".into(),
        toml::from_str("stiffness = [[1.0, 0.0], [0.0, 1.0]]\nnominal_force = [0.0, 0.0]\nreference_speed_m_per_s = 50.0\nfront_axle_m = 1.8\nrear_axle_m = 1.4").unwrap(),
    );
    let physical = aero["physical"].as_table_mut().unwrap();
    physical.insert("structure".into(), "aero-physical.toml".into());
    aero["excitation"]
        .as_table_mut()
        .unwrap()
        .insert("speed_m_per_s".into(), toml::Value::Float(50.0));
    tables.extend([(&aero, "numerical.aero")]);
    let mut all = BTreeSet::new();
    for (base, path) in tables {
        let keys = accepted_keys(base, path, &dir);
        assert!(!keys.is_empty(), "{path}");
        all.extend(keys.into_iter().map(|k| (path.to_string(), k)));
    }
    // The road and speed kinds: each kind's keys.
    for (key, kinds) in [
        (
            "road",
            vec![
                "kind = \"sweep\"\namplitude_m = 0.001\nstart_hz = 1.0\nend_hz = 10.0",
                "kind = \"pink\"\nrms_m = 0.001\nmax_hz = 10.0\nseed = 1",
                "kind = \"bump\"\nheight_m = 0.01\nduration_s = 0.1\nat_s = 1.0",
                "kind = \"csv\"\npath = \"road.csv\"",
            ],
        ),
        (
            "speed",
            vec![
                "kind = \"constant\"\nspeed_m_per_s = 50.0",
                "kind = \"ramp\"\nfrom_m_per_s = 10.0\nto_m_per_s = 50.0\nat_s = 1.0\nduration_s = 2.0",
                "kind = \"step\"\nfrom_m_per_s = 10.0\nto_m_per_s = 50.0\nat_s = 1.0",
                "kind = \"csv\"\npath = \"speed.csv\"",
            ],
        ),
    ] {
        for kind in kinds {
            let mut base = aero.clone();
            let excitation = base["excitation"].as_table_mut().unwrap();
            excitation.remove("speed_m_per_s");
            excitation.insert(key.into(), toml::from_str(kind).unwrap());
            let path = format!("excitation.{key}");
            for k in accepted_keys(&base, &path, &dir) {
                all.insert((format!("{path} ({kind})"), k));
            }
        }
    }
    let word = |k: &str| {
        doc.match_indices(k).any(|(i, _)| {
            let before = doc[..i].chars().next_back();
            let after = doc[i + k.len()..].chars().next();
            let boundary = |c: Option<char>| !c.is_some_and(|c| c.is_alphanumeric() || c == '_');
            boundary(before) && boundary(after)
        })
    };
    let missing: Vec<_> = all.iter().filter(|(_, k)| !word(k)).collect();
    assert!(missing.is_empty(), "undocumented keys: {missing:?}");
    assert!(all.len() > 80, "{} keys found", all.len());
}
