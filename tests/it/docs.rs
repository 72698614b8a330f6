//! The documentation holds together: every relative link in README.md and the guide (docs/)
//! reaches an existing file and, with `#anchor`, a heading of that file; every page of docs/ is
//! a chapter of the book (docs/SUMMARY.md); the README stays short and keeps the two commands a
//! newcomer needs. `mdbook build docs` (in `.ci/run`) builds the same pages.

use std::collections::HashSet;
use std::path::PathBuf;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// README.md and every .md under docs/ (not the built book).
fn pages() -> Vec<PathBuf> {
    let mut out = vec![root().join("README.md")];
    let mut stack = vec![root().join("docs")];
    while let Some(dir) = stack.pop() {
        for e in std::fs::read_dir(&dir).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                if p.file_name().is_some_and(|n| n != "book") {
                    stack.push(p);
                }
            } else if p.extension().is_some_and(|x| x == "md") {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

/// The text outside fenced code blocks and inline code, line by line.
fn prose_lines(text: &str) -> Vec<String> {
    let mut fenced = false;
    let mut out = Vec::new();
    for line in text.lines() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
            out.push(String::new());
            continue;
        }
        if fenced {
            out.push(String::new());
            continue;
        }
        let mut kept = String::new();
        let mut in_code = false;
        for c in line.chars() {
            if c == '`' {
                in_code = !in_code;
                kept.push('`');
            } else if !in_code {
                kept.push(c);
            }
        }
        out.push(kept);
    }
    out
}

/// Heading anchors as mdBook and GitHub make them: lower case, spaces to '-', punctuation other
/// than '-' and '_' dropped; a repeated heading gets -1, -2, ….
fn anchors(text: &str) -> HashSet<String> {
    let mut seen = HashSet::new();
    let mut out = HashSet::new();
    for line in prose_lines_keep_code(text) {
        let t = line.trim_start();
        if !t.starts_with('#') {
            continue;
        }
        let title = t.trim_start_matches('#').trim();
        let slug: String = title
            .to_lowercase()
            .chars()
            .filter_map(|c| match c {
                ' ' => Some('-'),
                c if c.is_alphanumeric() || c == '-' || c == '_' => Some(c),
                _ => None,
            })
            .collect();
        let mut s = slug.clone();
        let mut k = 0;
        while seen.contains(&s) {
            k += 1;
            s = format!("{slug}-{k}");
        }
        seen.insert(s.clone());
        out.insert(s);
    }
    out
}

/// Lines outside fenced code blocks, inline code kept (headings may hold code).
fn prose_lines_keep_code(text: &str) -> Vec<String> {
    let mut fenced = false;
    let mut out = Vec::new();
    for line in text.lines() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
            continue;
        }
        if !fenced {
            out.push(line.to_string());
        }
    }
    out
}

/// `(line, target)` of every markdown link `[text](target)` outside code.
fn links(text: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    for (i, line) in prose_lines(text).iter().enumerate() {
        let mut rest = line.as_str();
        while let Some(p) = rest.find("](") {
            let after = &rest[p + 2..];
            let Some(end) = after.find(')') else { break };
            let target = after[..end].trim();
            let target = target.split_whitespace().next().unwrap_or("");
            out.push((i + 1, target.to_string()));
            rest = &after[end..];
        }
    }
    out
}

/// Every broken relative link of the pages, as "file:line: target (why)".
fn broken_links(pages: &[PathBuf]) -> Vec<String> {
    let mut bad = Vec::new();
    for page in pages {
        let text = std::fs::read_to_string(page).unwrap();
        for (line, target) in links(&text) {
            if target.is_empty()
                || target.starts_with("http://")
                || target.starts_with("https://")
                || target.starts_with("mailto:")
            {
                continue;
            }
            let (file, anchor) = match target.split_once('#') {
                Some((f, a)) => (f, Some(a)),
                None => (target.as_str(), None),
            };
            let dest = if file.is_empty() {
                page.clone()
            } else {
                page.parent().unwrap().join(file)
            };
            let at = format!("{}:{line}: {target}", page.display());
            if !dest.exists() {
                bad.push(format!("{at} (no such file)"));
                continue;
            }
            if let Some(a) = anchor {
                let dest_text = std::fs::read_to_string(&dest).unwrap_or_default();
                if !anchors(&dest_text).contains(a) {
                    bad.push(format!("{at} (no heading with this anchor)"));
                }
            }
        }
    }
    bad
}

#[test]
fn relative_links_reach_files_and_headings() {
    let bad = broken_links(&pages());
    assert!(bad.is_empty(), "broken links:\n{}", bad.join("\n"));
}

#[test]
fn the_link_check_catches_a_broken_file_and_anchor() {
    let dir = crate::common::tmpdir("docs-links");
    std::fs::write(dir.join("b.md"), "# Real heading\n\ntext\n").unwrap();
    let a = dir.join("a.md");
    std::fs::write(
        &a,
        "# A\n\n[ok](b.md#real-heading) [gone](c.md) [bad](b.md#nope) `[code](x.md)`\n\
         ```\n[fenced](y.md)\n```\n[self](#a)\n",
    )
    .unwrap();
    let bad = broken_links(&[a]);
    assert_eq!(bad.len(), 2, "{bad:?}");
    assert!(bad[0].ends_with("c.md (no such file)"), "{bad:?}");
    assert!(
        bad[1].ends_with("b.md#nope (no heading with this anchor)"),
        "{bad:?}"
    );
}

#[test]
fn every_guide_page_is_a_chapter() {
    let summary = std::fs::read_to_string(root().join("docs/SUMMARY.md")).unwrap();
    let listed: HashSet<PathBuf> = links(&summary)
        .into_iter()
        .map(|(_, t)| root().join("docs").join(t))
        .collect();
    let missing: Vec<String> = pages()
        .into_iter()
        .filter(|p| p.starts_with(root().join("docs")) && !p.ends_with("SUMMARY.md"))
        .filter(|p| !listed.contains(p))
        .map(|p| p.display().to_string())
        .collect();
    assert!(missing.is_empty(), "not in docs/SUMMARY.md: {missing:?}");
}

#[test]
fn readme_is_short_and_keeps_the_two_commands() {
    let readme = std::fs::read_to_string(root().join("README.md")).unwrap();
    let lines = readme.lines().count();
    assert!(lines <= 300, "README.md has {lines} lines (at most 300)");
    for command in [
        "cargo run --release -- --points 50 --delta 0.01",
        "cargo test --release",
    ] {
        assert!(
            readme.lines().any(|l| l.trim() == command),
            "README.md lacks the line `{command}`"
        );
    }
}

/// The README's examples call `gpu-amcs` by name: it says how to put it on the PATH (issue 34).
#[test]
fn readme_says_how_to_put_gpu_amcs_on_the_path() {
    let readme = std::fs::read_to_string(root().join("README.md")).unwrap();
    assert!(
        readme.contains("`cargo install --path .` puts `gpu-amcs` on the PATH"),
        "README.md does not say how to install the binary"
    );
    let manifest = std::fs::read_to_string(root().join("Cargo.toml")).unwrap();
    assert!(
        manifest.contains("name = \"gpu-amcs\""),
        "the root package is gpu-amcs"
    );
}

#[test]
fn nothing_points_outside_the_repository() {
    // The folder beside a checkout where the project's notes live, spelled so that this file
    // itself names no path outside the repository.
    let outside = ["..", "shared"].join("/");
    for page in pages() {
        let text = std::fs::read_to_string(&page).unwrap();
        for (i, line) in text.lines().enumerate() {
            assert!(
                !line.contains(&outside) && !line.contains("/work/"),
                "{}:{}: points outside the repository: {line}",
                page.display(),
                i + 1
            );
        }
    }
}

/// The `sh` blocks of a page, each with the `text` block that follows it (empty if none).
fn command_blocks(text: &str) -> Vec<(String, Vec<String>)> {
    let mut out: Vec<(String, Vec<String>)> = Vec::new();
    let mut lines = text.lines().peekable();
    while let Some(line) = lines.next() {
        let fence = line.trim();
        if fence != "```sh" && fence != "```text" {
            continue;
        }
        let mut body = Vec::new();
        for l in lines.by_ref() {
            if l.trim() == "```" {
                break;
            }
            body.push(l.to_string());
        }
        if fence == "```sh" {
            out.push((body.join("\n"), Vec::new()));
        } else if let Some(last) = out.last_mut().filter(|b| b.1.is_empty()) {
            last.1 = body;
        }
    }
    out
}

/// Whether `got` is the line `want` with its numbers equal to within two units of the last
/// digit `want` prints (machines may round a last digit differently).
fn same_line(want: &str, got: &str) -> bool {
    let (w, g): (Vec<&str>, Vec<&str>) = (
        want.split_whitespace().collect(),
        got.split_whitespace().collect(),
    );
    w.len() == g.len()
        && w.iter().zip(&g).all(|(a, b)| {
            let trim = |s: &str| {
                s.trim_matches(|c: char| !(c.is_ascii_digit() || c == '-' || c == '.'))
                    .to_string()
            };
            let (ta, tb) = (trim(a), trim(b));
            match (ta.parse::<f64>(), tb.parse::<f64>()) {
                _ if a == b => true,
                (Ok(x), Ok(y)) => {
                    let decimals = ta.split_once('.').map_or(0, |(_, d)| d.len()) as i32;
                    (x - y).abs() <= 2.0 * 10f64.powi(-decimals) + 1e-12
                        && a.replace(&ta, "") == b.replace(&tb, "")
                }
                _ => false,
            }
        })
}

#[test]
fn the_line_comparison_allows_a_last_digit_only() {
    assert!(same_line(
        "R = 0.088000   [0.086260,",
        "R = 0.088001   [0.086260,"
    ));
    assert!(!same_line("R = 0.088000", "R = 0.088100"));
    assert!(!same_line("rms 0.0163 mm", "rms 0.0163 m"));
    assert!(!same_line("a b", "a b c"));
}

/// The start-to-finish chapter runs as printed: its commands in order in an empty folder, each
/// printing the lines its page shows (in order; `…` leaves lines out).
#[test]
fn the_calibration_loop_runs_as_printed() {
    let page = std::fs::read_to_string(root().join("docs/guide/calibration-loop.md")).unwrap();
    let blocks = command_blocks(&page);
    assert!(blocks.len() >= 6, "{} command blocks", blocks.len());
    let dir = crate::common::tmpdir("calibration-loop");
    let bin = std::path::PathBuf::from(crate::common::bin_path());
    let path = format!(
        "{}:{}",
        bin.parent().unwrap().display(),
        std::env::var("PATH").unwrap_or_default()
    );
    for (commands, expected) in blocks {
        let o = std::process::Command::new("bash")
            .arg("-ec")
            .arg(&commands)
            .env("PATH", &path)
            .current_dir(&dir)
            .output()
            .unwrap();
        let stdout = String::from_utf8_lossy(&o.stdout).to_string();
        assert!(
            o.status.success(),
            "{commands}\n{}",
            String::from_utf8_lossy(&o.stderr)
        );
        let mut got = stdout.lines();
        for want in expected
            .iter()
            .filter(|l| !l.trim().is_empty() && l.trim() != "…")
        {
            assert!(
                got.any(|g| same_line(want, g)),
                "{commands}\nmissing (or out of order): {want}\nprinted:\n{stdout}"
            );
        }
    }
}
