//! `--html DIR`: every reporting command writes a self-contained page with its files beside it.
//!
//! Each test runs one command with small sizes, checks the page as text (no scripts, nothing
//! loaded from elsewhere, every figure titled and described, tables with headers, every link to a
//! file in the directory), then renders it in headless Chromium: the figures and tables must be
//! in the rendered DOM, and the screenshot must not be blank. Without Chromium the browser part
//! is skipped with a note, except under `CI=true` (`.ci/run` installs Debian's `chromium`).

use crate::common;

use common::*;
use std::path::{Path, PathBuf};
use std::process::Command;

/// Chromium, if installed; `None` (with a note) when it is not, a failure under `CI=true`.
fn chromium(test: &str) -> Option<PathBuf> {
    for name in ["chromium", "chromium-browser"] {
        let found = std::env::var_os("PATH").and_then(|paths| {
            std::env::split_paths(&paths)
                .map(|d| d.join(name))
                .find(|p| p.is_file())
        });
        if found.is_some() {
            return found;
        }
    }
    if std::env::var("CI").map(|v| v == "true").unwrap_or(false) {
        panic!("{test}: chromium not found and CI=true (apt-get install chromium)");
    }
    eprintln!("{test}: browser checks skipped, no chromium (set CI=true to make this a failure)");
    None
}

/// Runs headless Chromium on `page` with `extra` arguments; its stdout.
fn headless(browser: &Path, page: &Path, extra: &[&str], scratch: &Path) -> String {
    let url = format!("file://{}", page.canonicalize().unwrap().display());
    let o = Command::new(browser)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--no-first-run",
            "--window-size=1200,2000",
        ])
        .arg(format!("--user-data-dir={}", scratch.display()))
        .args(extra)
        .arg(&url)
        .output()
        .unwrap();
    assert!(o.status.success(), "chromium failed: {}", stderr(&o));
    stdout(&o)
}

/// Fraction of the screenshot's pixels that are not white (any channel below 240).
fn non_white_fraction(png_file: &Path) -> f64 {
    let decoder = png::Decoder::new(std::fs::File::open(png_file).unwrap());
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).unwrap();
    let channels = info.color_type.samples();
    assert_eq!(info.bit_depth, png::BitDepth::Eight, "{png_file:?}");
    assert!(channels >= 3, "{png_file:?}: {:?}", info.color_type);
    let px = &buf[..info.buffer_size()];
    let total = px.len() / channels;
    let dark = px
        .chunks(channels)
        .filter(|p| p[..3].iter().any(|&c| c < 240))
        .count();
    dark as f64 / total as f64
}

/// The values of attribute `attr` of every element `tag` in `html`.
fn attrs<'a>(html: &'a str, tag: &str, attr: &str) -> Vec<&'a str> {
    let open = format!("<{tag} ");
    let key = format!(" {attr}=\"");
    html.match_indices(&open)
        .filter_map(|(i, _)| {
            let el = &html[i..i + html[i..].find('>').unwrap()];
            let at = el.find(&key)? + key.len();
            Some(&el[at..at + el[at..].find('"').unwrap()])
        })
        .collect()
}

/// The checks of a report directory `dir` whose page shows `figures` figures and at least
/// `tables` tables, as text and, with Chromium, rendered.
fn check_report(dir: &Path, figures: usize, tables: usize, test: &str) {
    let page = dir.join("index.html");
    let html = std::fs::read_to_string(&page).unwrap();
    // Self-contained: nothing runs, nothing is fetched. `url(#id)` is a reference inside the
    // page (an SVG pattern), not a request.
    for bad in [
        "<script", "http://", "https://", "@import", "<link", "<img", "<iframe",
    ] {
        assert!(!html.contains(bad), "{test}: page contains {bad}");
    }
    assert!(
        html.match_indices("url(")
            .all(|(i, _)| html[i..].starts_with("url(#")),
        "{test}: url() outside the page"
    );
    assert!(!html.contains("NaN"), "{test}: NaN on the page");
    // Figures: each a <figure> with a caption, its SVG an image labelled by a title and a
    // description.
    assert_eq!(html.matches("<figure ").count(), figures, "{test}: figures");
    assert_eq!(html.matches("<figcaption>").count(), figures, "{test}");
    assert_eq!(
        html.matches("<svg role=\"img\" aria-labelledby=\"fig")
            .count(),
        figures
    );
    for n in 1..=figures {
        let t = format!("<title id=\"fig{n}-title\">");
        let title_at = html
            .find(&t)
            .unwrap_or_else(|| panic!("{test}: figure {n} title"));
        let title = &html[title_at + t.len()..][..html[title_at + t.len()..].find('<').unwrap()];
        assert!(title.len() > 5, "{test}: figure {n} title {title:?}");
        assert!(
            html.contains(&format!("<desc id=\"fig{n}-desc\">")),
            "{test}"
        );
    }
    // Tables, every one with column headers.
    assert!(html.matches("<table").count() >= tables, "{test}: tables");
    assert_eq!(
        html.matches("<table").count(),
        html.matches("<thead><tr><th scope=\"col\">").count(),
        "{test}: a table without headers"
    );
    // Every link is a file of the directory, and every JSON and CSV file there is linked.
    let links = attrs(&html, "a", "href");
    assert!(!links.is_empty(), "{test}: no links");
    for l in &links {
        let name = l
            .strip_prefix("./")
            .unwrap_or_else(|| panic!("{test}: link {l}"));
        assert!(dir.join(name).is_file(), "{test}: broken link {l}");
    }
    for e in std::fs::read_dir(dir).unwrap() {
        let name = e.unwrap().file_name().to_string_lossy().into_owned();
        if name.ends_with(".json") || name.ends_with(".csv") {
            assert!(
                links.contains(&format!("./{name}").as_str()),
                "{test}: {name} not linked"
            );
        }
    }
    assert!(html.contains("Model and settings") && html.contains("gpu-amcs version"));
    // The SVG files the page shows are written beside it.
    let svgs = std::fs::read_dir(dir)
        .unwrap()
        .filter(|e| {
            e.as_ref()
                .unwrap()
                .path()
                .extension()
                .is_some_and(|x| x == "svg")
        })
        .count();
    assert_eq!(svgs, figures, "{test}: SVG files beside the page");

    let Some(browser) = chromium(test) else {
        return;
    };
    let scratch = tmpdir(&format!("{test}-chromium"));
    let dom = headless(&browser, &page, &["--dump-dom"], &scratch);
    assert_eq!(
        dom.matches("<svg").count(),
        figures,
        "{test}: rendered <svg>"
    );
    assert_eq!(dom.matches("<figcaption>").count(), figures, "{test}");
    assert!(
        dom.matches("<table").count() >= tables,
        "{test}: rendered tables"
    );
    assert!(dom.matches("<th scope=\"col\">").count() >= 2 * tables);
    // Every figure title made it into the rendered document.
    for t in attrs(&html, "title", "id") {
        let at = html.find(&format!("<title id=\"{t}\">")).unwrap();
        let title = &html[at..][..html[at..].find("</title>").unwrap()];
        assert!(dom.contains(title), "{test}: {title} not rendered");
    }
    let shot = scratch.join("page.png");
    let shot_arg = format!("--screenshot={}", shot.display());
    headless(&browser, &page, &[&shot_arg], &scratch);
    // A blank (white) page has no dark pixel; the text, tables and plots of these reports
    // cover 7.7–12.1 % of the 1200 × 2000 window (measured with Debian's chromium 156), so
    // 3 % leaves room for fonts and still fails a page that did not draw.
    let f = non_white_fraction(&shot);
    eprintln!("{test}: {:.1} % of the screenshot is not white", 100.0 * f);
    assert!(
        f > 0.03,
        "{test}: screenshot is nearly blank ({:.2} % non-white)",
        100.0 * f
    );
}

/// Runs `args` on the CPU, quietly, with `--html DIR/name`; the report directory and its page.
fn report(d: &Path, name: &str, args: &[&str]) -> (PathBuf, String) {
    let out = d.join(name);
    let tail = ["--backend", "cpu", "-q", "--html", out.to_str().unwrap()];
    let o = run(&[args, &tail[..]].concat());
    assert!(o.status.success(), "{args:?}: {}", stderr(&o));
    let html = std::fs::read_to_string(out.join("index.html")).unwrap();
    (out, html)
}

#[test]
fn amcs_report_escapes_the_model_path_and_renders() {
    let d = tmpdir("amcs");
    // A model file whose name is markup: the page must show it as text.
    let model = d.join("tx60 <b>&'x'.toml");
    let o = run(&["model", "--preset", "tx60"]);
    assert!(o.status.success(), "{}", stderr(&o));
    std::fs::write(&model, &o.stdout).unwrap();
    let m = model.to_str().unwrap();
    let (out, html) = report(&d, "r", &["--model", m, "--points", "5", "--delta", "0.02"]);
    assert!(
        html.contains("tx60 &lt;b&gt;&amp;&#39;x&#39;.toml"),
        "path not escaped"
    );
    assert!(!html.contains("<b>"));
    // Headline numbers carry units; the page's numbers are the JSON report's.
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    let mean = json["result"]["estimate"].as_f64().unwrap();
    assert!(
        html.contains(&format!("<dd>{mean:.6} mm</dd>")),
        "mean of w"
    );
    let draws = json["result"]["draws"].as_u64().unwrap();
    assert!(html.contains(&format!("<dd>{draws}</dd>")));
    assert!(html.contains("<th scope=\"col\">l_c (mm)</th>"));
    check_report(&out, 3, 3, "amcs");
}

#[test]
fn mcs_and_merged_shards_reports_render() {
    let d = tmpdir("mcs");
    let base = ["mcs", "--points", "3", "--draws", "20000"];
    let (out, html) = report(&d, "mcs", &[&base[..], &["--per-point"]].concat());
    assert!(html.contains("Single-point reliability R_j(l_c)"));
    check_report(&out, 2, 3, "mcs");

    let mut shards = Vec::new();
    for k in 0..2 {
        let s = arg(&d, &format!("s{k}.json"));
        let shard = format!("{k}/2");
        let o = run(&[&base[..], &["--shard", &shard, "--summary-out", &s, "-q"]].concat());
        assert!(o.status.success(), "{}", stderr(&o));
        shards.push(s);
    }
    let o = run(&[
        "merge",
        &shards[0],
        &shards[1],
        "-q",
        "--html",
        &arg(&d, "m"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let html = std::fs::read_to_string(d.join("m/index.html")).unwrap();
    assert!(html.contains("shard summaries") && html.contains("s1.json"));
    check_report(&d.join("m"), 2, 2, "merge");
}

#[test]
fn compare_report_renders() {
    let d = tmpdir("compare");
    let args = [
        "compare", "--points", "3", "--draws", "20000", "--deltas", "0.05",
    ];
    let (out, html) = report(&d, "c", &[&args[..], &["--batch", "2000"]].concat());
    assert!(html.contains("<th scope=\"row\">AMCS δ = 0.05</th>"));
    check_report(&out, 2, 2, "compare");
}

#[test]
fn study_report_renders_beside_out_or_apart() {
    let d = tmpdir("study");
    let base = ["study", "--quick", "--factors", "step", "--runs", "3"];
    let base = [&base[..], &["--mcs-draws", "20000", "--points", "5"]].concat();
    // PDF, reliability and one convergence figure per δ (two) of the one factor.
    let figures = 4;
    // Into the --out directory: only index.html is added.
    let (out, _) = report(&d, "s", &[&base[..], &["--out", &arg(&d, "s")]].concat());
    check_report(&out, figures, 4, "study");
    // Apart: the page and copies of the files it links.
    let (apart, _) = report(&d, "h", &[&base[..], &["--out", &arg(&d, "s2")]].concat());
    assert_eq!(tree(&apart), tree(&out));
    check_report(&apart, figures, 4, "study-apart");
}

#[test]
fn sensitivity_and_tail_reports_render() {
    let d = tmpdir("sens");
    let args = [
        "sensitivity",
        "--points",
        "3",
        "--draws",
        "256",
        "--bootstrap",
        "100",
    ];
    let (out, _) = report(&d, "s", &args);
    check_report(&out, 2, 2, "sensitivity");
    let args = ["tail", "--points", "3", "--threshold", "0.12"];
    let more = ["--samples-per-level", "200", "--max-evaluations", "20000"];
    let (out, html) = report(&d, "t", &[&args[..], &more[..]].concat());
    assert!(html.contains("P_f = Pr[w ≥ 0.12 mm]"));
    check_report(&out, 1, 1, "tail");
}

#[test]
fn html_on_a_file_or_an_unwritable_place_is_refused_before_any_work() {
    let d = tmpdir("bad");
    std::fs::write(d.join("file"), "x").unwrap();
    let file = arg(&d, "file");
    let under_file = arg(&d, "file/sub");
    for target in [&file, &under_file] {
        for cmd in [
            &["--points", "3"][..],
            &["mcs", "--draws", "2000"],
            &["compare", "--draws", "2000"],
            &["sensitivity", "--draws", "256"],
            &["tail", "--threshold", "0.2"],
            &["study", "--quick", "--out", &arg(&d, "s")],
        ] {
            fails_leaving_nothing(&d, &[cmd, &["--html", target]].concat(), "--html");
        }
    }
    // Not even root can create a file in /proc.
    fails_naming(
        &["--points", "3", "--html", "/proc/gpu-amcs-html"],
        "--html",
    );
    // The report directory may not overwrite an input.
    let pts = d.join("pts");
    std::fs::create_dir_all(&pts).unwrap();
    std::fs::write(pts.join("pdf.csv"), "q1,q2,q3,q4,q5,q6\n0,0,0,0,0,0\n").unwrap();
    fails_leaving_nothing(
        &d,
        &[
            "--points-file",
            &arg(&d, "pts/pdf.csv"),
            "--html",
            pts.to_str().unwrap(),
        ],
        "--points-file",
    );
}

#[test]
fn map_report_shows_both_heat_maps_and_renders() {
    let d = tmpdir("map");
    let args = [
        "map", "--plane", "xz", "--at", "0", "--cells", "12,10", "--draws", "300",
    ];
    let (out, html) = report(&d, "m", &args);
    assert!(html.contains("Workspace reliability map of Staubli TX60"));
    assert!(
        html.contains("R(l_c) = Pr[w &lt; l_c]"),
        "multi-point table"
    );
    check_report(&out, 2, 2, "map");
}

#[test]
fn identify_report_renders_and_writes_every_part() {
    let d = tmpdir("identify");
    let sweeps = arg(&d, "sweeps.csv");
    let o = run(&["simulate", "--runs", "3", "--step", "5", "--out", &sweeps]);
    assert!(o.status.success(), "{}", stderr(&o));
    let (json, csv, svg, html) = (
        arg(&d, "id.json"),
        arg(&d, "csv"),
        arg(&d, "svg"),
        arg(&d, "h"),
    );
    let o = run(&[
        "identify", &sweeps, "-q", "--json", &json, "--csv", &csv, "--svg", &svg, "--html", &html,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).is_empty(), "-q prints nothing: {}", stdout(&o));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(v["identify"]["runs"].as_array().unwrap().len(), 3);
    // The parts are the files of the report directory.
    let h = d.join("h");
    assert_eq!(
        std::fs::read_to_string(&json).unwrap(),
        std::fs::read_to_string(h.join("identify.json")).unwrap()
    );
    for (dir, name) in [
        ("csv", "joints.csv"),
        ("csv", "runs.csv"),
        ("csv", "parameters.csv"),
        ("svg", "residuals.svg"),
        ("svg", "correlation.svg"),
        ("svg", "pose_residuals.svg"),
    ] {
        assert_eq!(
            std::fs::read_to_string(d.join(dir).join(name)).unwrap(),
            std::fs::read_to_string(h.join(name)).unwrap(),
            "{name}"
        );
    }
    let page = std::fs::read_to_string(h.join("index.html")).unwrap();
    assert!(
        page.contains("sweeps.csv"),
        "the sweeps file is a settings row"
    );
    // Circle-fit residuals, the correlation heat map and the residual of each point; the circle
    // fits, the parameters, the tool point, the whole-chain fit per run and its quantities.
    check_report(&h, 3, 5, "identify");
}

#[test]
fn compare_and_study_write_every_report_flag() {
    let d = tmpdir("flags");
    let args = [
        "compare", "--points", "3", "--draws", "20000", "--deltas", "0.05", "--batch", "2000",
    ];
    let more = ["--csv", &arg(&d, "c/csv"), "--svg", &arg(&d, "c/svg")];
    let (out, _) = report(&d, "c/h", &[&args[..], &more[..]].concat());
    for (dir, name) in [
        ("csv", "comparison.csv"),
        ("svg", "pdf.svg"),
        ("svg", "reliability.svg"),
    ] {
        assert_eq!(
            std::fs::read_to_string(d.join("c").join(dir).join(name)).unwrap(),
            std::fs::read_to_string(out.join(name)).unwrap(),
            "{name}"
        );
    }
    let base = ["study", "--quick", "--factors", "step", "--runs", "3"];
    let more = [
        "--mcs-draws",
        "20000",
        "--points",
        "5",
        "--out",
        &arg(&d, "s/out"),
        "--json",
        &arg(&d, "s/study.json"),
        "--csv",
        &arg(&d, "s/csv"),
        "--svg",
        &arg(&d, "s/svg"),
    ];
    let (out, _) = report(&d, "s/h", &[&base[..], &more[..]].concat());
    let s = d.join("s");
    assert_eq!(
        std::fs::read_to_string(s.join("study.json")).unwrap(),
        std::fs::read_to_string(s.join("out/study.json")).unwrap()
    );
    let listing = |p: &Path| -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(p)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    };
    assert_eq!(
        listing(&s.join("csv")),
        [
            "accuracy.csv",
            "correlation.csv",
            "ranking.csv",
            "table1.csv",
            "table2.csv"
        ]
    );
    // Figs. 4 and 5 of the factor, and one convergence figure per δ.
    assert_eq!(listing(&s.join("svg")).len(), 4);
    for f in listing(&s.join("svg")) {
        assert_eq!(
            std::fs::read_to_string(s.join("svg").join(&f)).unwrap(),
            std::fs::read_to_string(out.join(&f)).unwrap(),
            "{f}"
        );
    }
}
