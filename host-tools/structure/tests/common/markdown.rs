//! The TOML example blocks of a Markdown reference (shared by the schema reference tests of
//! `docs/structure.md` and `docs/setup.md`).

/// The bodies of the ```` ```toml ```` blocks of `text`, in order.
pub fn toml_blocks(text: &str) -> Vec<String> {
    let mut blocks = Vec::new();
    let mut current: Option<String> = None;
    for line in text.lines() {
        match (&mut current, line.trim_start()) {
            (None, "```toml") => current = Some(String::new()),
            (Some(block), "```") => {
                blocks.push(std::mem::take(block));
                current = None;
            }
            (Some(block), _) => {
                block.push_str(line);
                block.push('\n');
            }
            (None, _) => {}
        }
    }
    blocks
}
