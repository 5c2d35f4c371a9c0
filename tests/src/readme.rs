//! README.md's figures, checked where README.md cites the test that computes them or in the
//! row of its table that states them, so the README cannot drift from the code. The one
//! reader of README.md for the tests.

use std::path::PathBuf;

/// README.md's text.
fn text() -> String {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../README.md");
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// Panics unless README.md cites `` `test_file` `` at least once and every citation's
/// sentence states `figure`: the text before the citation, back to the previous citation of
/// a file or the paragraph's start.
pub fn assert_states(test_file: &str, figure: &str) {
    let text = text().replace('\n', " ");
    let citation = format!("`{test_file}`");
    let mut cited = 0;
    for (at, _) in text.match_indices(&citation) {
        cited += 1;
        let before = &text[..at];
        // Paragraphs are separated by an empty line ("\n\n", now two spaces after a
        // line's end), citations by a closing backtick of a `.rs` path.
        let start = [before.rfind("  "), before.rfind(".rs`")]
            .into_iter()
            .flatten()
            .max()
            .unwrap_or(0);
        let sentence = &before[start..];
        assert!(
            sentence.contains(figure),
            "README.md cites {citation} after {sentence:?}, which does not state the computed \
             figure {figure:?}"
        );
    }
    assert!(cited > 0, "README.md does not cite {citation}");
}

/// README.md's section under `heading`: from it to the next heading.
fn section(heading: &str) -> String {
    let text = text();
    let start = text
        .find(heading)
        .unwrap_or_else(|| panic!("README.md has no heading {heading:?}"));
    let rest = &text[start + heading.len()..];
    rest[..rest.find("\n## ").unwrap_or(rest.len())].to_string()
}

/// The row of the table under `heading` whose first cell is `first` (exactly one).
fn row(heading: &str, first: &str) -> String {
    let rows: Vec<String> = section(heading)
        .lines()
        .skip_while(|l| !l.starts_with('|'))
        .take_while(|l| l.starts_with('|'))
        .map(str::to_string)
        .collect();
    let found: Vec<&String> = rows
        .iter()
        .filter(|r| r.split('|').nth(1).map(str::trim) == Some(first))
        .collect();
    assert_eq!(
        found.len(),
        1,
        "README.md's table has {} row(s) whose first cell is {first:?}; rows:\n{}",
        found.len(),
        rows.join("\n")
    );
    found[0].clone()
}

/// Panics unless the third cell ("here") of the row `first` of the table under `heading`
/// holds every `(what, text)`, naming each one it does not hold, with the row.
pub fn assert_cell_holds(heading: &str, first: &str, figures: &[(&str, String)]) {
    let row = row(heading, first);
    let cell = row.split('|').nth(3).map_or("", str::trim);
    let missing: Vec<String> = figures
        .iter()
        .filter(|(_, text)| !cell.contains(text.as_str()))
        .map(|(what, text)| format!("  {what}: computed {text:?}"))
        .collect();
    assert!(
        missing.is_empty(),
        "README.md row {first:?} does not hold the computed figure(s):\n{}\nrow: {row}",
        missing.join("\n")
    );
}

/// Panics unless README.md's section under `heading` states `figure` (its prose wrapped:
/// line breaks read as spaces).
pub fn assert_section_states(heading: &str, figure: &str) {
    let prose = section(heading).replace('\n', " ");
    assert!(
        prose.contains(figure),
        "README.md's section {heading:?} does not hold the computed figure: {figure:?}"
    );
}

/// Panics unless README.md's text from the first `start` up to the next `end` states
/// `figure` (whitespace, line breaks included, read as single spaces).
pub fn assert_paragraph_states(start: &str, end: &str, figure: &str) {
    let text = text();
    let from = text
        .find(start)
        .unwrap_or_else(|| panic!("README.md has no {start:?}"));
    let to = text[from..]
        .find(end)
        .unwrap_or_else(|| panic!("README.md has no {end:?} after {start:?}"));
    let paragraph = text[from..from + to]
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ");
    assert!(
        paragraph.contains(figure),
        "README states another figure than the code's {figure:?}:\n{paragraph}"
    );
}
