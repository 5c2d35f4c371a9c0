//! No cycles between the top-level modules of any crate of the workspace.
//!
//! For every member of the root `Cargo.toml` (firmware crates included) this reads the source
//! files, without compiling anything, and maps each top-level module (`src/x.rs`, or the folder
//! `src/x/`, as module `x`; `lib.rs` and `main.rs` are the crate roots and are not modules) to
//! the other top-level modules its code names through a `crate::` path: `crate::x::Item`,
//! `use crate::x;` and each branch of `use crate::{a, b::c};`. A `crate::Name` that the root
//! brings in with a `use` of its own (`pub use system::MilSystem;` in `lib.rs`) counts as a
//! reference to the module it comes from, so a re-export does not hide a dependency. It then
//! finds the strongly connected components of that graph and fails naming every component of
//! more than one module, with one place in the source for each edge inside it.
//!
//! What is read and what is not:
//! - Comments (including `///` and `//!` doc comments with their rustdoc links), string,
//!   raw-string and character literals are skipped.
//! - Unit-test modules are left out: a `#[cfg(test)]` attribute (possibly among other
//!   attributes) on `mod name { ... }` removes that block, and a top-level module that its
//!   root declares as `#[cfg(test)] mod name;` is left out whole. Other items under
//!   `#[cfg(test)]` (a lone `use` or `fn`) still count; test code rarely needs them.
//! - `super::` paths are not followed (at the top level of `src/x.rs` they would name the root,
//!   which is no module), nor glob re-exports in the root (`pub use x::*`), nor macros reached
//!   by textual scope (`#[macro_use]`).
//! - When `src/` holds both `lib.rs` and `main.rs` (two crates sharing one folder), a module
//!   belongs to the binary if `main.rs` declares it with `mod x;`, otherwise to the library;
//!   each crate gets its own graph.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;
use std::fs;
use std::path::{Path, PathBuf};

/// One token of Rust source with comments and literals removed: an identifier (or keyword,
/// or number) or a single punctuation character, with its 1-based line.
#[derive(Debug, Clone, PartialEq)]
enum Tok {
    Ident(String),
    Punct(char),
}

#[derive(Debug, Clone)]
struct Token {
    tok: Tok,
    line: usize,
}

impl Token {
    fn is_ident(&self, s: &str) -> bool {
        matches!(&self.tok, Tok::Ident(i) if i == s)
    }
    fn is_punct(&self, c: char) -> bool {
        self.tok == Tok::Punct(c)
    }
    fn ident(&self) -> Option<&str> {
        match &self.tok {
            Tok::Ident(i) => Some(i),
            Tok::Punct(_) => None,
        }
    }
}

fn is_ident_start(c: char) -> bool {
    c == '_' || c.is_alphabetic()
}

fn is_ident_continue(c: char) -> bool {
    c == '_' || c.is_alphanumeric()
}

/// Splits Rust source into identifiers and punctuation, dropping whitespace, comments (line,
/// doc and nested block comments) and string, byte-string, raw-string and character literals.
/// Lifetimes and labels (`'a`) are dropped too.
fn lex(src: &str) -> Vec<Token> {
    let c: Vec<char> = src.chars().collect();
    let n = c.len();
    let mut out = Vec::new();
    let mut i = 0;
    let mut line = 1;
    let at = |i: usize| c.get(i).copied().unwrap_or('\0');
    while i < n {
        let ch = c[i];
        if ch == '\n' {
            line += 1;
            i += 1;
        } else if ch.is_whitespace() {
            i += 1;
        } else if ch == '/' && at(i + 1) == '/' {
            while i < n && c[i] != '\n' {
                i += 1;
            }
        } else if ch == '/' && at(i + 1) == '*' {
            let mut depth = 0usize;
            while i < n {
                if c[i] == '/' && at(i + 1) == '*' {
                    depth += 1;
                    i += 2;
                } else if c[i] == '*' && at(i + 1) == '/' {
                    depth -= 1;
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    if c[i] == '\n' {
                        line += 1;
                    }
                    i += 1;
                }
            }
        } else if ch == '"' {
            i = skip_string(&c, i + 1, &mut line);
        } else if ch == '\'' {
            if at(i + 1) == '\\' {
                // An escaped character literal: '\n', '\'', '\u{..}'.
                i += 3;
                while i < n && c[i] != '\'' {
                    i += 1;
                }
                i += 1;
            } else if at(i + 2) == '\'' {
                // A plain character literal: 'x' (also '"' and '{').
                i += 3;
            } else {
                // A lifetime or label: 'a, 'static, 'outer.
                i += 1;
                while i < n && is_ident_continue(c[i]) {
                    i += 1;
                }
            }
        } else if is_ident_start(ch) || ch.is_ascii_digit() {
            let start = i;
            while i < n && is_ident_continue(c[i]) {
                i += 1;
            }
            let word: String = c[start..i].iter().collect();
            let prefix = matches!(word.as_str(), "r" | "br" | "cr");
            if prefix && (at(i) == '#' || at(i) == '"') {
                let mut hashes = 0;
                while at(i + hashes) == '#' {
                    hashes += 1;
                }
                if at(i + hashes) == '"' {
                    // A raw string: ends at '"' followed by as many '#'.
                    i += hashes + 1;
                    while i < n {
                        if c[i] == '"' && (1..=hashes).all(|k| at(i + k) == '#') {
                            i += hashes + 1;
                            break;
                        }
                        if c[i] == '\n' {
                            line += 1;
                        }
                        i += 1;
                    }
                    continue;
                }
                if hashes == 1 && word == "r" && is_ident_start(at(i + 1)) {
                    // A raw identifier: r#type.
                    let s = i + 1;
                    i = s;
                    while i < n && is_ident_continue(c[i]) {
                        i += 1;
                    }
                    out.push(Token {
                        tok: Tok::Ident(c[s..i].iter().collect()),
                        line,
                    });
                    continue;
                }
            }
            if matches!(word.as_str(), "b" | "c") && at(i) == '"' {
                i = skip_string(&c, i + 1, &mut line);
                continue;
            }
            if word == "b" && at(i) == '\'' {
                // A byte literal: b'x', b'\n'.
                i += 1;
                if at(i) == '\\' {
                    i += 1;
                }
                i += 1;
                while i < n && c[i] != '\'' {
                    i += 1;
                }
                i += 1;
                continue;
            }
            out.push(Token {
                tok: Tok::Ident(word),
                line,
            });
        } else {
            out.push(Token {
                tok: Tok::Punct(ch),
                line,
            });
            i += 1;
        }
    }
    out
}

/// Skips a (byte or C) string's body from just after its opening quote; returns the index
/// after the closing quote.
fn skip_string(c: &[char], mut i: usize, line: &mut usize) -> usize {
    while i < c.len() {
        match c[i] {
            '\\' => {
                // An escape; `\` before a line break continues the string on the next line.
                if c.get(i + 1) == Some(&'\n') {
                    *line += 1;
                }
                i += 2;
            }
            '"' => return i + 1,
            '\n' => {
                *line += 1;
                i += 1;
            }
            _ => i += 1,
        }
    }
    i
}

/// Whether the tokens at `i` are `#[cfg(test)]`.
fn is_cfg_test(t: &[Token], i: usize) -> bool {
    let want = |k: usize, f: &dyn Fn(&Token) -> bool| t.get(i + k).is_some_and(f);
    want(0, &|x| x.is_punct('#'))
        && want(1, &|x| x.is_punct('['))
        && want(2, &|x| x.is_ident("cfg"))
        && want(3, &|x| x.is_punct('('))
        && want(4, &|x| x.is_ident("test"))
        && want(5, &|x| x.is_punct(')'))
        && want(6, &|x| x.is_punct(']'))
}

/// The index just after the bracket group that opens at `i` (`(`, `[` or `{`), counting all
/// three kinds; `t.len()` when it never closes.
fn skip_group(t: &[Token], i: usize) -> usize {
    let mut depth = 0i32;
    let mut k = i;
    while k < t.len() {
        match t[k].tok {
            Tok::Punct('(' | '[' | '{') => depth += 1,
            Tok::Punct(')' | ']' | '}') => {
                depth -= 1;
                if depth == 0 {
                    return k + 1;
                }
            }
            _ => {}
        }
        k += 1;
    }
    t.len()
}

/// A `#[cfg(test)]` module found at `i`: the module's name and the index after its end
/// (after its `}` or its `;`).
fn cfg_test_module(t: &[Token], i: usize) -> Option<(String, usize)> {
    if !is_cfg_test(t, i) {
        return None;
    }
    let mut k = i + 7;
    // Further attributes, then an optional visibility: `pub`, `pub(crate)`, `pub(in path)`.
    while t.get(k).is_some_and(|x| x.is_punct('#')) && t.get(k + 1).is_some_and(|x| x.is_punct('['))
    {
        k = skip_group(t, k + 1);
    }
    if t.get(k).is_some_and(|x| x.is_ident("pub")) {
        k += 1;
        if t.get(k).is_some_and(|x| x.is_punct('(')) {
            k = skip_group(t, k);
        }
    }
    if !t.get(k).is_some_and(|x| x.is_ident("mod")) {
        return None;
    }
    let name = t.get(k + 1)?.ident()?.to_string();
    let next = t.get(k + 2)?;
    if next.is_punct(';') {
        Some((name, k + 3))
    } else if next.is_punct('{') {
        Some((name, skip_group(t, k + 2)))
    } else {
        None
    }
}

/// The tokens without the `#[cfg(test)]` modules (their bodies and their declarations), and
/// the names of the modules declared `#[cfg(test)] mod name;`.
fn without_test_modules(t: &[Token]) -> (Vec<Token>, BTreeSet<String>) {
    let mut kept = Vec::with_capacity(t.len());
    let mut test_files = BTreeSet::new();
    let mut i = 0;
    while i < t.len() {
        if let Some((name, end)) = cfg_test_module(t, i) {
            if t[end - 1].is_punct(';') {
                test_files.insert(name);
            }
            i = end;
        } else {
            kept.push(t[i].clone());
            i += 1;
        }
    }
    (kept, test_files)
}

/// Every path that starts with `crate::` (or `$crate::`): the first segment after it and its
/// line. A group `crate::{a, b::{c, d}, self}` gives `a` and `b` (and `self`).
fn crate_paths(t: &[Token]) -> Vec<(String, usize)> {
    let mut out = Vec::new();
    for i in 0..t.len() {
        if !(t[i].is_ident("crate")
            && t.get(i + 1).is_some_and(|x| x.is_punct(':'))
            && t.get(i + 2).is_some_and(|x| x.is_punct(':')))
        {
            continue;
        }
        let Some(next) = t.get(i + 3) else { continue };
        if let Some(name) = next.ident() {
            out.push((name.to_string(), next.line));
        } else if next.is_punct('{') {
            // Each element's first segment, also inside a group that itself starts an
            // element (`crate::{a, {b, c}}`), but not inside `a::{b, c}`.
            let end = skip_group(t, i + 3);
            let mut firsts: Vec<bool> = Vec::new();
            let mut expect_first = true;
            for x in &t[i + 3..end] {
                match &x.tok {
                    Tok::Punct('{') => {
                        firsts.push(expect_first);
                    }
                    Tok::Punct(',') => {
                        expect_first = firsts.last().copied().unwrap_or(false);
                    }
                    Tok::Punct('}') => {
                        firsts.pop();
                        expect_first = false;
                    }
                    Tok::Ident(name) if expect_first => {
                        out.push((name.clone(), x.line));
                        expect_first = false;
                    }
                    _ => expect_first = false,
                }
            }
        }
    }
    out
}

/// The module declarations at the top level of a root (`mod x;`, not inline `mod x { }`).
fn declared_modules(root: &[Token]) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    let mut depth = 0i32;
    for (i, x) in root.iter().enumerate() {
        match x.tok {
            Tok::Punct('{') => depth += 1,
            Tok::Punct('}') => depth -= 1,
            _ => {}
        }
        if depth == 0 && x.is_ident("mod") && root.get(i + 2).is_some_and(|y| y.is_punct(';')) {
            if let Some(name) = root.get(i + 1).and_then(Token::ident) {
                out.insert(name.to_string());
            }
        }
    }
    out
}

/// The names a root brings in with `use` at its top level (`pub use system::{Loop, MilSystem
/// as System};`), each with the top-level module it comes from (`use crate::x::..`,
/// `use self::x::..` or `use x::..`). Glob imports are not resolved.
fn root_imports(root: &[Token], modules: &BTreeSet<String>) -> BTreeMap<String, String> {
    let mut out = BTreeMap::new();
    let mut depth = 0i32;
    let mut i = 0;
    while i < root.len() {
        match root[i].tok {
            Tok::Punct('{') => depth += 1,
            Tok::Punct('}') => depth -= 1,
            _ => {}
        }
        if depth != 0 || !root[i].is_ident("use") {
            i += 1;
            continue;
        }
        let start = i + 1;
        let mut end = start;
        while end < root.len() && !root[end].is_punct(';') {
            end += 1;
        }
        let mut tree: Vec<&Token> = root[start..end].iter().collect();
        if tree
            .first()
            .is_some_and(|x| x.is_ident("crate") || x.is_ident("self"))
            && tree.get(1).is_some_and(|x| x.is_punct(':'))
        {
            tree.drain(..3);
        }
        if let Some(module) = tree.first().and_then(|x| x.ident()) {
            if modules.contains(module) {
                for name in use_tree_names(&tree) {
                    if name != module {
                        out.insert(name, module.to_string());
                    }
                }
            }
        }
        i = end;
    }
    out
}

/// The names a use tree binds: the last segment of each branch, or its `as` alias.
fn use_tree_names(tree: &[&Token]) -> Vec<String> {
    let mut names = Vec::new();
    let mut last: Option<String> = None;
    let mut prev_segment: Option<String> = None;
    let mut alias = false;
    let mut flush = |last: &mut Option<String>, prev: &Option<String>| {
        if let Some(name) = last.take() {
            if name == "self" {
                names.extend(prev.clone());
            } else if name != "_" {
                names.push(name);
            }
        }
    };
    for x in tree {
        match &x.tok {
            Tok::Ident(s) if s == "as" => alias = true,
            Tok::Ident(s) => {
                if !alias {
                    prev_segment = last.clone().or(prev_segment);
                }
                last = Some(s.clone());
                alias = false;
            }
            Tok::Punct(',' | '}') => flush(&mut last, &prev_segment),
            Tok::Punct('*') => last = None,
            _ => {}
        }
    }
    flush(&mut last, &prev_segment);
    names
}

/// One crate's module graph: for each module, the modules it names, each with the first
/// place (file and line) that names it.
type Graph = BTreeMap<String, BTreeMap<String, (PathBuf, usize)>>;

/// A crate of the workspace: the member folder, its root file and its module graph.
struct CrateGraph {
    label: String,
    graph: Graph,
}

/// The `.rs` files of one top-level module: `src/x.rs` and everything under `src/x/`.
fn module_files(src: &Path, name: &str) -> Vec<PathBuf> {
    let mut files = Vec::new();
    let file = src.join(format!("{name}.rs"));
    if file.is_file() {
        files.push(file);
    }
    let mut stack = vec![src.join(name)];
    while let Some(dir) = stack.pop() {
        let Ok(entries) = fs::read_dir(&dir) else {
            continue;
        };
        for entry in entries.flatten() {
            let p = entry.path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|e| e == "rs") {
                files.push(p);
            }
        }
    }
    files.sort();
    files
}

fn read_tokens(path: &Path) -> Vec<Token> {
    let src = fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    lex(&src)
}

/// The module graphs of one workspace member (one, or two when `src/` holds both a library
/// and a binary root).
fn member_graphs(workspace: &Path, member: &str) -> Vec<CrateGraph> {
    let src = workspace.join(member).join("src");
    let mut names = BTreeSet::new();
    for entry in fs::read_dir(&src)
        .unwrap_or_else(|e| panic!("{}: {e}", src.display()))
        .flatten()
    {
        let p = entry.path();
        let stem = p.file_stem().and_then(|s| s.to_str()).unwrap_or_default();
        if p.is_dir() {
            // `src/bin/` holds binaries, not a module.
            if stem != "bin" {
                names.insert(stem.to_string());
            }
        } else if p.extension().is_some_and(|e| e == "rs") && stem != "lib" && stem != "main" {
            names.insert(stem.to_string());
        }
    }
    let roots: Vec<&str> = ["lib.rs", "main.rs"]
        .into_iter()
        .filter(|r| src.join(r).is_file())
        .collect();
    let both = roots.len() == 2;
    let bin_modules = if both {
        declared_modules(&without_test_modules(&read_tokens(&src.join("main.rs"))).0)
    } else {
        BTreeSet::new()
    };
    let mut graphs = Vec::new();
    for root in roots {
        let (root_tokens, test_files) = without_test_modules(&read_tokens(&src.join(root)));
        let modules: BTreeSet<String> = names
            .iter()
            .filter(|m| !both || (root == "main.rs") == bin_modules.contains(*m))
            .filter(|m| !test_files.contains(*m))
            .cloned()
            .collect();
        let imports = root_imports(&root_tokens, &modules);
        let mut graph = Graph::new();
        for module in &modules {
            let edges = graph.entry(module.clone()).or_default();
            for file in module_files(&src, module) {
                let (tokens, _) = without_test_modules(&read_tokens(&file));
                for (name, line) in crate_paths(&tokens) {
                    let target = if modules.contains(&name) {
                        Some(name)
                    } else {
                        imports.get(&name).cloned()
                    };
                    if let Some(target) = target.filter(|t| t != module) {
                        let rel = file.strip_prefix(workspace).unwrap_or(&file).to_path_buf();
                        edges.entry(target).or_insert((rel, line));
                    }
                }
            }
        }
        let label = if both {
            format!("{member} ({root})")
        } else {
            member.to_string()
        };
        graphs.push(CrateGraph { label, graph });
    }
    graphs
}

/// The strongly connected components of more than one module (Tarjan's algorithm), each
/// sorted, in a stable order.
fn cycles(graph: &Graph) -> Vec<Vec<String>> {
    struct State<'a> {
        graph: &'a Graph,
        index: BTreeMap<&'a str, usize>,
        low: BTreeMap<&'a str, usize>,
        stack: Vec<&'a str>,
        on_stack: BTreeSet<&'a str>,
        out: Vec<Vec<String>>,
    }
    fn visit<'a>(s: &mut State<'a>, v: &'a str) {
        let i = s.index.len();
        s.index.insert(v, i);
        s.low.insert(v, i);
        s.stack.push(v);
        s.on_stack.insert(v);
        let graph = s.graph;
        for w in graph.get(v).into_iter().flat_map(|e| e.keys()) {
            let w = w.as_str();
            if !graph.contains_key(w) {
                continue;
            }
            if !s.index.contains_key(w) {
                visit(s, w);
                let lw = s.low[w];
                let lv = s.low.get_mut(v).expect("visited");
                *lv = (*lv).min(lw);
            } else if s.on_stack.contains(w) {
                let iw = s.index[w];
                let lv = s.low.get_mut(v).expect("visited");
                *lv = (*lv).min(iw);
            }
        }
        if s.low[v] == s.index[v] {
            let mut component = Vec::new();
            while let Some(w) = s.stack.pop() {
                s.on_stack.remove(w);
                component.push(w.to_string());
                if w == v {
                    break;
                }
            }
            if component.len() > 1 {
                component.sort();
                s.out.push(component);
            }
        }
    }
    let mut s = State {
        graph,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on_stack: BTreeSet::new(),
        out: Vec::new(),
    };
    for v in graph.keys() {
        if !s.index.contains_key(v.as_str()) {
            visit(&mut s, v);
        }
    }
    s.out.sort();
    s.out
}

/// The `members` list of the `[workspace]` table of the root `Cargo.toml`.
fn workspace_members(manifest: &str) -> Vec<String> {
    let mut in_workspace = false;
    let mut in_members = false;
    let mut members = Vec::new();
    for line in manifest.lines() {
        let line = line.split('#').next().unwrap_or_default().trim();
        if line.starts_with('[') && !in_members {
            in_workspace = line == "[workspace]";
            continue;
        }
        if in_workspace && !in_members && line.starts_with("members") {
            in_members = true;
        }
        if in_members {
            members.extend(line.split('"').skip(1).step_by(2).map(str::to_string));
            if line.ends_with(']') {
                break;
            }
        }
    }
    members
}

fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("the tests crate sits in the workspace")
        .to_path_buf()
}

#[test]
fn no_module_cycles_in_any_workspace_crate() {
    let root = workspace_root();
    let manifest = fs::read_to_string(root.join("Cargo.toml")).expect("root Cargo.toml");
    let members = workspace_members(&manifest);
    assert!(
        members.len() >= 10 && members.iter().any(|m| m.starts_with("firmware/")),
        "read too few workspace members from Cargo.toml: {members:?}"
    );
    let mut report = String::new();
    let mut found = 0;
    let mut modules = 0;
    for member in &members {
        for krate in member_graphs(&root, member) {
            modules += krate.graph.len();
            for component in cycles(&krate.graph) {
                found += 1;
                let _ = writeln!(report, "{}: {}", krate.label, component.join(", "));
                for from in &component {
                    for (to, (file, line)) in &krate.graph[from] {
                        if component.contains(to) {
                            let _ =
                                writeln!(report, "    {from} -> {to}  ({}:{line})", file.display());
                        }
                    }
                }
            }
        }
    }
    assert!(modules > 50, "found only {modules} top-level modules");
    assert!(
        found == 0,
        "{found} module cycle(s) (strongly connected components; each edge with its first \
         `crate::` reference):\n{report}"
    );
}

// The reader itself, on small sources.

fn names(src: &str) -> Vec<String> {
    let (tokens, _) = without_test_modules(&lex(src));
    crate_paths(&tokens).into_iter().map(|(n, _)| n).collect()
}

#[test]
fn comments_and_literals_are_not_code() {
    let src = r####"
        //! See [`crate::a::X`].
        /// Uses [`crate::b`].
        // crate::c
        /* crate::d /* nested crate::e */ crate::f */
        const S: &str = "crate::g \" crate::h";
        const R: &str = r#"crate::i " crate::j"#;
        const B: &[u8] = b"crate::k";
        const C: char = '"';
        fn f<'a>(x: &'a str) -> char { let _ = crate::l::m(); '{' }
        const Q: char = '\'';
        use crate::n;
    "####;
    assert_eq!(names(src), ["l", "n"]);
}

#[test]
fn lines_count_through_comments_and_literals() {
    let src = r###"const A: &str = "one \
    two";
/* a
 b */ const B: &str = r#"
"#; const C: char = '\n';
use crate::x;"###;
    let (tokens, _) = without_test_modules(&lex(src));
    assert_eq!(crate_paths(&tokens), [("x".to_string(), 6)]);
}

#[test]
fn use_groups_give_each_first_segment() {
    let src = "use crate::{a, b::{c, d}, e::f as g, self, {h, i::j}};\n\
               type T = crate::k::L<crate::m::N>;";
    assert_eq!(names(src), ["a", "b", "e", "self", "h", "i", "k", "m"]);
}

#[test]
fn test_modules_are_left_out() {
    let src = "use crate::a;\n\
               #[cfg(test)]\n#[allow(unused)]\n\
               mod tests { use crate::b; fn f() { crate::c::d(); } }\n\
               #[cfg(test)] pub(crate) mod more;\n\
               fn g() { crate::e::f(); }";
    let (tokens, test_files) = without_test_modules(&lex(src));
    let found: Vec<String> = crate_paths(&tokens).into_iter().map(|(n, _)| n).collect();
    assert_eq!(found, ["a", "e"]);
    assert_eq!(test_files.into_iter().collect::<Vec<_>>(), ["more"]);
}

#[test]
fn root_reexports_resolve_to_their_module() {
    let modules: BTreeSet<String> = ["system", "error", "metrics"].map(String::from).into();
    let root = lex("mod system;\npub use error::{AnalysisError, Result};\n\
                    pub use system::{Loop, MilSystem as System, self};\n\
                    pub use crate::metrics::margins;\nuse num_complex::Complex64;\n\
                    pub use metrics::*;\nmod inner { pub use system::Hidden; }");
    let imports = root_imports(&root, &modules);
    let got: Vec<(&str, &str)> = imports
        .iter()
        .map(|(k, v)| (k.as_str(), v.as_str()))
        .collect();
    assert_eq!(
        got,
        [
            ("AnalysisError", "error"),
            ("Loop", "system"),
            ("Result", "error"),
            ("System", "system"),
            ("margins", "metrics"),
        ]
    );
    assert_eq!(
        declared_modules(&root).into_iter().collect::<Vec<_>>(),
        ["system"]
    );
}

#[test]
fn components_of_a_small_graph() {
    let mut graph = Graph::new();
    let edge = |g: &mut Graph, a: &str, b: &str| {
        g.entry(a.into())
            .or_default()
            .insert(b.into(), (PathBuf::new(), 0));
        g.entry(b.into()).or_default();
    };
    edge(&mut graph, "a", "b");
    edge(&mut graph, "b", "c");
    edge(&mut graph, "c", "a");
    edge(&mut graph, "c", "d");
    edge(&mut graph, "d", "e");
    edge(&mut graph, "e", "d");
    edge(&mut graph, "f", "a");
    assert_eq!(cycles(&graph), [vec!["a", "b", "c"], vec!["d", "e"]]);
}
