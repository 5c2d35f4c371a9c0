//! `diagnose_with_progress` reports a non-decreasing fraction from the first phase to 1 and
//! gives the same diagnosis as `diagnose`.

use mil_diagnose::{diagnose, diagnose_with_progress, Model, Options, Record};
use std::cell::RefCell;
use std::path::PathBuf;

#[test]
fn progress_is_monotone_and_ends_at_one() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let model = Model::read(&dir.join("examples/emps.toml")).unwrap();
    let full = Record::read(&dir.join("data/emps_estimation.csv")).unwrap();
    let record = full.slice(0..8000);
    let seen = RefCell::new(Vec::new());
    let d = diagnose_with_progress(&model, &record, &Options::default(), &|f, m| {
        seen.borrow_mut().push((f, m.to_string()));
    })
    .unwrap();
    let seen = seen.into_inner();
    assert!(seen.len() >= 3, "{seen:?}");
    assert!(seen.windows(2).all(|w| w[0].0 <= w[1].0), "{seen:?}");
    assert!(seen.iter().all(|(f, _)| (0.0..=1.0).contains(f)));
    assert_eq!(seen.last().map(|s| s.0), Some(1.0));
    let plain = diagnose(&model, &record, &Options::default()).unwrap();
    assert_eq!(
        plain.json_report("m.toml").named_effects,
        d.json_report("m.toml").named_effects
    );
}
