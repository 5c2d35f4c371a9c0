//! README.md's figures, checked where README.md cites the test that computes them, so the
//! README cannot drift from the code.

use std::path::PathBuf;

/// Panics unless README.md cites `` `test_file` `` at least once and every citation's
/// sentence states `figure`: the text before the citation, back to the previous citation of
/// a file or the paragraph's start.
pub fn assert_states(test_file: &str, figure: &str) {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../README.md");
    let text = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .replace('\n', " ");
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
