//! The example blocks of a Markdown reference (shared by the schema reference tests of
//! `docs/structure.md`, `docs/setup.md` and `docs/files.md`).

/// The bodies of the ```` ```toml ```` blocks of `text`, in order.
#[allow(dead_code)]
pub fn toml_blocks(text: &str) -> Vec<String> {
    code_blocks(text, "toml")
}

/// The bodies of the ```` ```<language> ```` blocks of `text`, in order.
pub fn code_blocks(text: &str, language: &str) -> Vec<String> {
    let fence = format!("```{language}");
    let mut blocks = Vec::new();
    let mut current: Option<String> = None;
    for line in text.lines() {
        match (&mut current, line.trim_start()) {
            (None, l) if l == fence => current = Some(String::new()),
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
