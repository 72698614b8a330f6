//! No import cycles between the top-level modules of a library crate (issue 19).
//!
//! The test reads the sources of `crates/core/src` and `crates/gpu/src`: a top-level module is a
//! file `X.rs` or a folder `X/` beside `lib.rs`, and module `A` uses module `B` when some file
//! of `A` names a path `crate::B…` (also `crate::{B, …}`, and `super::B` where `super` is the
//! crate root) outside comments and string literals. Test code counts too: a module's tests
//! that need a higher module are a cycle as well. The graph minus [`TOLERATED`] must have no
//! cycle; on failure the message prints every cycle found and the whole graph
//! (`cargo test --test it module_graph -- --nocapture` prints it on success too).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Edges `(from, to)` of `crates/core` left out of the check, with the reason. They close the
/// cycles identify ↔ report and report ↔ study, which the rework of `report/` removes; empty this
/// list when it lands (an edge listed here that no longer exists is reported by
/// [`module_graph_has_no_cycles`]'s message only, it does not fail the test).
const TOLERATED: &[(&str, &str, &str)] = &[
    (
        "identify",
        "report",
        "identify re-exports the terminal renderers of report::identify",
    ),
    (
        "report",
        "study",
        "report renders the study's tables and pages; study writes through report",
    ),
];

/// The module graph of the crate whose `lib.rs` is in `src`: module → modules it uses.
fn module_graph(src: &Path) -> BTreeMap<String, BTreeSet<String>> {
    let mut modules: BTreeMap<String, Vec<PathBuf>> = BTreeMap::new();
    for entry in std::fs::read_dir(src).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_stem().unwrap().to_string_lossy().into_owned();
        if path.is_dir() {
            let mut files = Vec::new();
            rust_files(&path, &mut files);
            modules.entry(name).or_default().extend(files);
        } else if path.extension().is_some_and(|e| e == "rs") && name != "lib" && name != "main" {
            modules.entry(name).or_default().push(path);
        }
    }
    let names: BTreeSet<String> = modules.keys().cloned().collect();
    modules
        .iter()
        .map(|(name, files)| {
            let mut uses = BTreeSet::new();
            for f in files {
                // `super` is the crate root in a file that declares a top-level module: `X.rs`
                // or `X/mod.rs`.
                let depth = f.strip_prefix(src).unwrap().components().count();
                let top =
                    depth == 1 || (depth == 2 && f.file_name().is_some_and(|n| n == "mod.rs"));
                let code = strip_comments_and_strings(&std::fs::read_to_string(f).unwrap());
                for used in crate_paths(&code, top) {
                    if names.contains(&used) && used != *name {
                        uses.insert(used);
                    }
                }
            }
            (name.clone(), uses)
        })
        .collect()
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The source with comments (line, doc and block) and the contents of string and character
/// literals blanked out, so that only code remains.
fn strip_comments_and_strings(s: &str) -> String {
    let c: Vec<char> = s.chars().collect();
    let mut out = String::with_capacity(s.len());
    let mut i = 0;
    while i < c.len() {
        let next = c.get(i + 1).copied();
        if c[i] == '/' && next == Some('/') {
            while i < c.len() && c[i] != '\n' {
                i += 1;
            }
        } else if c[i] == '/' && next == Some('*') {
            let mut depth = 0;
            while i < c.len() {
                if c[i] == '/' && c.get(i + 1) == Some(&'*') {
                    depth += 1;
                    i += 2;
                } else if c[i] == '*' && c.get(i + 1) == Some(&'/') {
                    depth -= 1;
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    i += 1;
                }
            }
            out.push(' ');
        } else if c[i] == 'r' && (next == Some('"') || next == Some('#')) && !ident_char(&c, i) {
            // Raw string r"…" or r#"…"#.
            let mut j = i + 1;
            let mut hashes = 0;
            while c.get(j) == Some(&'#') {
                hashes += 1;
                j += 1;
            }
            if c.get(j) != Some(&'"') {
                out.push(c[i]);
                i += 1;
                continue;
            }
            j += 1;
            while j < c.len() {
                if c[j] == '"' && (0..hashes).all(|h| c.get(j + 1 + h) == Some(&'#')) {
                    j += 1 + hashes;
                    break;
                }
                j += 1;
            }
            out.push_str("\"\"");
            i = j;
        } else if c[i] == '"' {
            i += 1;
            while i < c.len() && c[i] != '"' {
                i += if c[i] == '\\' { 2 } else { 1 };
            }
            i += 1;
            out.push_str("\"\"");
        } else if c[i] == '\'' {
            // A character literal ('x', '\n', '\u{..}'), else a lifetime.
            if next == Some('\\') {
                let mut j = i + 3;
                while j < c.len() && c[j] != '\'' {
                    j += 1;
                }
                i = j + 1;
                out.push_str("' '");
            } else if c.get(i + 2) == Some(&'\'') {
                i += 3;
                out.push_str("' '");
            } else {
                out.push(c[i]);
                i += 1;
            }
        } else {
            out.push(c[i]);
            i += 1;
        }
    }
    out
}

/// Whether the character before `i` continues an identifier (so `c[i]` does not start a token).
fn ident_char(c: &[char], i: usize) -> bool {
    i > 0 && (c[i - 1].is_alphanumeric() || c[i - 1] == '_')
}

/// The first segments after `crate::` (and, in a file whose `super` is the crate root, after
/// `super::`) in `code`, with groups `crate::{a, b::c}` giving `a` and `b`.
fn crate_paths(code: &str, super_is_root: bool) -> Vec<String> {
    let mut prefixes = vec!["crate"];
    if super_is_root {
        prefixes.push("super");
    }
    let c: Vec<char> = code.chars().collect();
    let mut found = Vec::new();
    let mut i = 0;
    while i < c.len() {
        let Some(p) = prefixes.iter().find(|p| {
            let n = p.len();
            c[i..].iter().take(n).copied().eq(p.chars())
                && !ident_char(&c, i)
                && c.get(i + n) == Some(&':')
                && c.get(i + n + 1) == Some(&':')
        }) else {
            i += 1;
            continue;
        };
        let mut j = i + p.len() + 2;
        while c.get(j).is_some_and(|x| x.is_whitespace()) {
            j += 1;
        }
        if c.get(j) == Some(&'{') {
            // A group: the first identifier of every item at the group's own level.
            let mut depth = 0;
            let mut at_item = true;
            while j < c.len() {
                match c[j] {
                    '{' => {
                        depth += 1;
                        at_item = depth == 1;
                        j += 1;
                    }
                    '}' => {
                        depth -= 1;
                        j += 1;
                        if depth == 0 {
                            break;
                        }
                    }
                    ',' => {
                        at_item = depth == 1;
                        j += 1;
                    }
                    x if x.is_alphabetic() || x == '_' => {
                        let start = j;
                        while j < c.len() && (c[j].is_alphanumeric() || c[j] == '_') {
                            j += 1;
                        }
                        if at_item {
                            found.push(c[start..j].iter().collect());
                            at_item = false;
                        }
                    }
                    _ => j += 1,
                }
            }
        } else {
            let start = j;
            while j < c.len() && (c[j].is_alphanumeric() || c[j] == '_') {
                j += 1;
            }
            found.push(c[start..j].iter().collect());
        }
        i = j.max(i + 1);
    }
    found
}

/// Every elementary cycle's first occurrence as a path of modules (a depth-first search from
/// each module, in name order), at most `limit` of them.
fn cycles(graph: &BTreeMap<String, BTreeSet<String>>, limit: usize) -> Vec<Vec<String>> {
    fn visit(
        graph: &BTreeMap<String, BTreeSet<String>>,
        start: &str,
        path: &mut Vec<String>,
        out: &mut Vec<Vec<String>>,
        limit: usize,
    ) {
        let last = path.last().unwrap().clone();
        for next in graph.get(&last).into_iter().flatten() {
            if out.len() >= limit {
                return;
            }
            if next == start {
                let mut c = path.clone();
                c.push(start.to_string());
                out.push(c);
            } else if next.as_str() > start && !path.contains(next) {
                // Each cycle is found once, from its smallest module.
                path.push(next.clone());
                visit(graph, start, path, out, limit);
                path.pop();
            }
        }
    }
    let mut out = Vec::new();
    for start in graph.keys() {
        visit(graph, start, &mut vec![start.clone()], &mut out, limit);
    }
    out
}

fn show(graph: &BTreeMap<String, BTreeSet<String>>) -> String {
    graph
        .iter()
        .map(|(m, uses)| {
            let list: Vec<&str> = uses.iter().map(String::as_str).collect();
            format!("  {m} -> {}\n", list.join(", "))
        })
        .collect()
}

fn src(krate: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("crates")
        .join(krate)
        .join("src")
}

/// The check of one crate: its graph minus `tolerated` has no cycle.
fn check(krate: &str, tolerated: &[(&str, &str, &str)]) {
    let full = module_graph(&src(krate));
    let mut graph = full.clone();
    let mut stale = Vec::new();
    for (from, to, _) in tolerated {
        let removed = graph.get_mut(*from).is_some_and(|s| s.remove(*to));
        if !removed {
            stale.push(format!("{from} -> {to}"));
        }
    }
    println!("crates/{krate} module graph:\n{}", show(&full));
    if !stale.is_empty() {
        println!("tolerated edges that no longer exist (remove them): {stale:?}");
    }
    let found = cycles(&graph, 20);
    assert!(
        found.is_empty(),
        "import cycles between the modules of crates/{krate}:\n{}\nmodule graph (tolerated \
         edges {:?} left out):\n{}",
        found
            .iter()
            .map(|c| format!("  {}\n", c.join(" -> ")))
            .collect::<String>(),
        tolerated
            .iter()
            .map(|(a, b, _)| format!("{a} -> {b}"))
            .collect::<Vec<_>>(),
        show(&graph)
    );
}

#[test]
fn module_graph_has_no_cycles() {
    check("core", TOLERATED);
    check("gpu", &[]);
}

/// The parser and the cycle search themselves: a planted cycle is found, comments, strings and
/// groups are read as the compiler reads them.
#[test]
fn module_graph_parser_and_cycle_search() {
    let code = strip_comments_and_strings(
        "use crate::{a::X, b, c::{d, e}};\n\
         /// [`crate::doc`] // crate::comment\n\
         let s = \"crate::string\"; let r = r#\"crate::raw\"#; let ch = '\"'; let q = '\\'';\n\
         /* crate::block */ fn f<'a>(x: &'a crate::f::T) { super::g::h(); }",
    );
    assert_eq!(crate_paths(&code, false), ["a", "b", "c", "f"]);
    assert_eq!(crate_paths(&code, true), ["a", "b", "c", "f", "g"]);
    let graph: BTreeMap<String, BTreeSet<String>> = [
        ("a", vec!["b"]),
        ("b", vec!["c"]),
        ("c", vec!["a", "d"]),
        ("d", vec![]),
    ]
    .into_iter()
    .map(|(m, u)| (m.to_string(), u.into_iter().map(String::from).collect()))
    .collect();
    assert_eq!(cycles(&graph, 20), [["a", "b", "c", "a"]]);
    let mut acyclic = graph.clone();
    acyclic.get_mut("c").unwrap().remove("a");
    assert!(cycles(&acyclic, 20).is_empty());
}
