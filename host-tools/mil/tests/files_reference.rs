//! `docs/files.md` cannot drift from the code: its filter-file and record examples pass `mil
//! check` (the readers every command uses), its frequency-response table is read by the
//! table reader, every key of the filter file is named in it, and the numbers it quotes are
//! the readers' constants.

use mil_analysis::filter_file::FilterFile;
use std::path::PathBuf;

#[path = "../../structure/tests/common/markdown.rs"]
mod markdown;
use markdown::code_blocks;

fn reference() -> String {
    std::fs::read_to_string(PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../docs/files.md"))
        .unwrap()
}

#[test]
fn the_examples_pass_check() {
    let text = reference();
    let dir = tempfile::tempdir().unwrap();
    let json = code_blocks(&text, "json");
    assert_eq!(json.len(), 2, "a minimal and a full filter file");
    for (k, block) in json.iter().enumerate() {
        let path = dir.path().join(format!("filter-{k}.json"));
        std::fs::write(&path, block).unwrap();
        let summary = mil::check::check(&path, None).unwrap_or_else(|e| panic!("{e:#}\n{block}"));
        assert!(summary.contains("filter"), "{summary}");
    }
    // The full example is the shipped tyre filter, coefficient for coefficient.
    let shipped = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("examples/tyre-filter.json");
    let (shipped, _) = FilterFile::read(&shipped).unwrap();
    let path = dir.path().join("filter-1.json");
    let (documented, _) = FilterFile::read(&path).unwrap();
    assert_eq!(documented.sections, shipped.sections);
    let csv = code_blocks(&text, "csv");
    assert_eq!(csv.len(), 3, "two records and a frequency-response table");
    for (k, block) in csv[..2].iter().enumerate() {
        let path = dir.path().join(format!("record-{k}.csv"));
        std::fs::write(&path, block).unwrap();
        let summary = mil::check::check(&path, None).unwrap_or_else(|e| panic!("{e:#}\n{block}"));
        assert!(summary.contains("record"), "{summary}");
    }
    // Both records say the same thing, whatever their form.
    let tables: Vec<_> = (0..2)
        .map(|k| mil_numerics::record::read(&dir.path().join(format!("record-{k}.csv"))).unwrap())
        .collect();
    assert_eq!(tables[0].names, tables[1].names);
    assert_eq!(tables[1].units[0].as_deref(), Some("s"));
    let path = dir.path().join("table.csv");
    std::fs::write(&path, &csv[2]).unwrap();
    let table = mil_identify::FrfTable::read_csv(&path).unwrap();
    assert_eq!(table.points().len(), 4);
    assert!(table.has_coherence());
}

#[test]
fn every_key_and_constant_is_documented() {
    let text = reference();
    let file = FilterFile {
        figures: Some(serde_json::json!({})),
        ..FilterFile::new(&model_core::CascadeCoefficients::IDENTITY, 2000.0)
    };
    let mut value = serde_json::to_value(&file).unwrap();
    let section = serde_json::to_value(mil_analysis::filter_file::SectionRecord::of(
        &model_core::BiquadCoefficients::IDENTITY,
    ))
    .unwrap();
    let mut keys: Vec<String> = value.as_object_mut().unwrap().keys().cloned().collect();
    keys.extend(section.as_object().unwrap().keys().cloned());
    for key in keys {
        assert!(
            text.contains(&format!("`{key}`")),
            "{key} is not documented"
        );
    }
    assert!(text.contains(&format!(
        "at most {} (model-core's `MAX_SECTIONS`)",
        model_core::MAX_SECTIONS
    )));
    assert!(text.contains(&format!(
        "within {} sample intervals",
        mil_numerics::record::JITTER_TOLERANCE
    )));
    assert!(text.contains(&format!(
        "more than a factor of {} from 1",
        mil_analysis::setup::MAX_TRACKING_DC_FACTOR
    )));
    for column in mil_identify::CSV_COLUMNS {
        assert!(text.contains(&format!("`{column}`")), "{column}");
    }
}
