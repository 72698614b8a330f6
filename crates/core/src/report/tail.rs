//! Reports of a tail-probability run ([`TailResult`]): a table for the terminal, the estimates
//! as CSV, JSON (the result's own serde form) and the figure; with the page
//! ([`super::html::tail`]) the result is a [`Report`].

use super::html::tail::tail_page;
use super::{Layout, Report};
use crate::mc::tail::{ChainProposal, TailMethod, TailOutcome, TailResult};
use std::fmt::Write;

/// The JSON document in a report directory.
const JSON: &str = "tail.json";
/// The estimates as CSV.
const CSV: &str = "tail.csv";
/// `P_f` against the threshold.
const SVG: &str = "tail.svg";

impl TailResult {
    /// The files of a tail report, before it runs.
    pub fn planned_layout() -> Layout {
        Layout::new(JSON, &[CSV], &[SVG], &[])
    }
}

impl Report for TailResult {
    fn layout(&self) -> Layout {
        Self::planned_layout()
    }

    fn text(&self) -> String {
        render_text(self)
    }

    fn json(&self) -> String {
        render_json(self)
    }

    fn csv(&self) -> Vec<(String, String)> {
        vec![(CSV.to_string(), render_csv(self))]
    }

    fn svg(&self) -> Vec<(String, String)> {
        render_svg(self)
    }

    fn page(&self, settings: &[(String, String)], files: &[(String, String)]) -> String {
        tail_page(self, settings, files).render()
    }
}

fn opt(x: Option<f64>, f: impl Fn(f64) -> String) -> String {
    x.map(f).unwrap_or_else(|| "n/a".into())
}

/// The terminal table: P_f, its coefficient of variation and β per threshold, then the levels of
/// the last subset-simulation run.
pub fn render_text(r: &TailResult) -> String {
    let mut s = String::new();
    let method = match (r.method, r.subset.as_ref().map(|s| s.proposal)) {
        (TailMethod::Subset, Some(ChainProposal::ModifiedMetropolis)) => {
            "subset simulation (modified Metropolis; CoV after Au & Beck, levels summed)"
        }
        (TailMethod::Subset, _) => {
            "subset simulation (adaptive conditional sampling; CoV after Au & Beck, levels correlated by the seed carry)"
        }
        (TailMethod::MonteCarlo, _) => "crude Monte Carlo",
    };
    let _ = writeln!(s, "Tail probability P_f = Pr[w ≥ L], {method}");
    let outcome = match r.outcome {
        TailOutcome::TargetReached => "target CoV reached".to_string(),
        TailOutcome::EvaluationCapReached => format!(
            "NOT reached: the cap of {} evaluations ended the run",
            r.max_evaluations
        ),
        TailOutcome::LevelLimitReached => {
            "NOT reached: the largest threshold needs more levels than allowed".to_string()
        }
    };
    let _ = writeln!(
        s,
        "inputs     {} standard normals  |  target CoV {}  |  {outcome}",
        r.dimension, r.target_cov
    );
    let _ = writeln!(
        s,
        "cost       {} evaluations of w in {:.2} s",
        r.evaluations, r.seconds
    );
    let _ = writeln!(
        s,
        "backend    {} — {} {}",
        r.backend.backend, r.backend.adapter, r.backend.driver
    );
    let _ = writeln!(
        s,
        "\n  {:>12}  {:>12}  {:>8}  {:>8}",
        "L (mm)", "P_f", "CoV", "β"
    );
    for e in &r.estimates {
        let _ = writeln!(
            s,
            "  {:>12}  {:>12.4e}  {:>8}  {:>8}",
            super::text::fmt_plain(e.threshold),
            e.p_f,
            opt(e.cov, |c| format!("{c:.3}")),
            opt(e.beta, |b| format!("{b:.3}"))
        );
    }
    if let Some(run) = r.runs.last() {
        let _ = writeln!(
            s,
            "\nlevels of the last run (N = {} per level{})",
            run.samples_per_level,
            if run.complete { "" } else { ", cut short" }
        );
        let _ = writeln!(
            s,
            "  {:>5}  {:>12}  {:>8}  {:>8}  {:>10}",
            "level", "threshold", "p", "γ", "acceptance"
        );
        for (j, l) in run.levels.iter().enumerate() {
            let _ = writeln!(
                s,
                "  {:>5}  {:>12}  {:>8}  {:>8.2}  {:>10}",
                j,
                opt(l.next, |b| format!("{b:.6}")),
                opt(l.p, |p| format!("{p:.4}")),
                l.gamma,
                opt(l.acceptance, |a| format!("{a:.3}"))
            );
        }
    }
    s
}

/// `tail.csv`: one row per threshold.
pub fn render_csv(r: &TailResult) -> String {
    let mut s = String::from("threshold_mm,p_f,cov,cov_independent_levels,beta\n");
    let o = |x: Option<f64>| x.map(|v| v.to_string()).unwrap_or_default();
    for e in &r.estimates {
        let _ = writeln!(
            s,
            "{},{},{},{},{}",
            e.threshold,
            e.p_f,
            o(e.cov),
            o(e.cov_independent_levels),
            o(e.beta)
        );
    }
    s
}

/// The result as JSON, with the tool's name and version.
pub fn render_json(r: &TailResult) -> String {
    let v = serde_json::json!({
        "tool": "gpu-amcs",
        "version": env!("CARGO_PKG_VERSION"),
        "schema_version": 1,
        "tail": r,
    });
    serde_json::to_string_pretty(&v).unwrap_or_default() + "\n"
}

/// An estimate as plotted: `L`, `P_f` and the ends of its ±2·CoV bar.
type Mark = (f64, f64, Option<(f64, f64)>);

/// `tail.svg`: `P_f` against the threshold `L` on a logarithmic axis — the estimates as markers
/// with ±2·CoV error bars (the lower end clipped at the axis floor), and for subset simulation
/// the level thresholds `b_{j+1}` of the last run at `P = p0^(j+1)` as a line (the curve
/// `1 − R(L)` from `p0` down). Estimates with `P_f = 0` are left out and named in a note.
/// `(file name, svg)`.
pub fn render_svg(r: &TailResult) -> Vec<(String, String)> {
    use super::svg::{begin, esc, nice_step, tick_label, COLORS};
    const W: f64 = 720.0;
    const H: f64 = 450.0;
    const L: f64 = 80.0;
    const R: f64 = 20.0;
    const T: f64 = 40.0;
    const B: f64 = 60.0;
    let ok = |x: f64| x.is_finite() && x > 0.0;
    // Level curve of the last run.
    let mut curve: Vec<(f64, f64)> = match (r.runs.last(), &r.subset) {
        (Some(run), Some(set)) => run
            .levels
            .iter()
            .enumerate()
            .filter_map(|(j, l)| Some((l.next?, set.p0.powi(j as i32 + 1))))
            .filter(|&(x, p)| x.is_finite() && ok(p))
            .collect(),
        _ => Vec::new(),
    };
    // Estimates with P_f > 0; no bar without a CoV.
    let marks: Vec<Mark> = r
        .estimates
        .iter()
        .filter(|e| e.threshold.is_finite() && ok(e.p_f))
        .map(|e| {
            let bar = e
                .cov
                .filter(|c| c.is_finite() && *c > 0.0)
                .map(|c| (e.p_f * (1.0 - 2.0 * c), (e.p_f * (1.0 + 2.0 * c)).min(1.0)));
            (e.threshold, e.p_f, bar)
        })
        .collect();
    // The curve down to one level below the smallest estimate: a run that hit the level limit
    // has levels far beyond any estimate.
    let p0 = r.subset.as_ref().map_or(0.1, |set| set.p0);
    let cutoff = match marks.iter().map(|m| m.1).reduce(f64::min) {
        Some(smallest) => smallest * p0 * (1.0 - 1e-9),
        None => 1e-12,
    };
    let levels = curve.len();
    curve.retain(|&(_, p)| p >= cutoff);
    let trimmed = levels - curve.len();
    let zero: Vec<String> = r
        .estimates
        .iter()
        .filter(|e| !ok(e.p_f))
        .map(|e| tick_label(e.threshold))
        .collect();
    let (mut x0, mut x1, mut y0, mut y1) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    let mut grow = |x: f64, p: f64| {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(p.log10());
        y1 = y1.max(p.log10());
    };
    for &(x, p) in &curve {
        grow(x, p);
    }
    for &(x, p, bar) in &marks {
        grow(x, p);
        if let Some((_, hi)) = bar {
            grow(x, hi);
        }
    }
    if !x0.is_finite() {
        (x0, x1, y0, y1) = (0.0, 1.0, -3.0, 0.0);
    }
    // Half a decade of room under the smallest point for the lower error bars, whole decades.
    let y0 = (y0 - 0.3).floor();
    let y1 = y1.ceil().min(0.0).max(y0 + 1.0);
    let floor = 10f64.powf(y0);
    let pad = if x1 > x0 {
        0.05 * (x1 - x0)
    } else {
        0.05 * x0.abs().max(1e-3)
    };
    let (x0, x1) = (x0 - pad, x1 + pad);
    let sx = |x: f64| L + (x - x0) / (x1 - x0) * (W - L - R);
    let sy = |p: f64| H - B - (p.max(floor).log10() - y0) / (y1 - y0) * (H - T - B);
    let mut notes: Vec<String> = Vec::new();
    if !zero.is_empty() {
        notes.push(format!(
            "P_f = 0 (no sample reached L) at L = {} mm: not shown on the log axis",
            zero.join(", ")
        ));
    }
    if marks
        .iter()
        .any(|(_, _, b)| b.is_some_and(|(lo, _)| lo < floor))
    {
        notes.push(format!(
            "error bars below {} are clipped at the axis floor",
            format_args!("1e{y0}")
        ));
    }
    if trimmed > 0 {
        notes.push(format!(
            "{trimmed} deeper levels of the last run (P below {:.1e}) are not drawn",
            cutoff
        ));
    }
    if r.method == TailMethod::MonteCarlo {
        notes.push("crude Monte Carlo: no subset levels".into());
    }
    let h = H + 16.0 * notes.len() as f64;
    let method = match r.method {
        TailMethod::Subset => "subset simulation",
        TailMethod::MonteCarlo => "crude Monte Carlo",
    };
    let mut s = String::new();
    begin(
        &mut s,
        W,
        h,
        &format!("Tail probability P_f = Pr[w ≥ L] — {method}"),
    );
    let _ = writeln!(
        s,
        r#"<rect x="{L}" y="{T}" width="{}" height="{}" fill="none" stroke="black"/>"#,
        W - L - R,
        H - T - B
    );
    let step = nice_step(x1 - x0, 8);
    let mut x = (x0 / step).ceil() * step;
    while x <= x1 + 1e-9 * step {
        let px = sx(x);
        let _ = writeln!(
            s,
            r##"<line x1="{px:.1}" y1="{T}" x2="{px:.1}" y2="{}" stroke="#ddd"/>"##,
            H - B
        );
        let _ = writeln!(
            s,
            r#"<text x="{px:.1}" y="{}" text-anchor="middle">{}</text>"#,
            H - B + 16.0,
            tick_label(x)
        );
        x += step;
    }
    let mut e = y0 as i32;
    while f64::from(e) <= y1 {
        let py = sy(10f64.powi(e));
        let _ = writeln!(
            s,
            r##"<line x1="{L}" y1="{py:.1}" x2="{}" y2="{py:.1}" stroke="#ddd"/>"##,
            W - R
        );
        let _ = writeln!(
            s,
            r#"<text class="ytick" x="{}" y="{:.1}" text-anchor="end">1e{e}</text>"#,
            L - 6.0,
            py + 4.0
        );
        e += 1;
    }
    let _ = writeln!(
        s,
        r#"<text x="{}" y="{}" text-anchor="middle">threshold L (mm)</text>"#,
        (L + W - R) / 2.0,
        H - 18.0
    );
    let mid = (T + H - B) / 2.0;
    let _ = writeln!(
        s,
        r#"<text x="18" y="{mid}" text-anchor="middle" transform="rotate(-90 18 {mid})">P_f = Pr[w ≥ L] = 1 − R(L)</text>"#
    );
    if !curve.is_empty() {
        let pts: Vec<String> = curve
            .iter()
            .map(|&(x, p)| format!("{:.2},{:.2}", sx(x), sy(p)))
            .collect();
        let _ = writeln!(
            s,
            r#"<polyline class="levels" fill="none" stroke="{}" stroke-width="1.6" points="{}"/>"#,
            COLORS[0],
            pts.join(" ")
        );
    }
    for &(x, p, bar) in &marks {
        let (px, py) = (sx(x), sy(p));
        if let Some((lo, hi)) = bar {
            let (a, b) = (sy(lo), sy(hi));
            let _ = writeln!(
                s,
                r#"<line class="err" x1="{px:.2}" y1="{a:.2}" x2="{px:.2}" y2="{b:.2}" stroke="{}"/>"#,
                COLORS[1]
            );
            for cy in [a, b] {
                let _ = writeln!(
                    s,
                    r#"<line x1="{:.2}" y1="{cy:.2}" x2="{:.2}" y2="{cy:.2}" stroke="{}"/>"#,
                    px - 4.0,
                    px + 4.0,
                    COLORS[1]
                );
            }
        }
        let _ = writeln!(
            s,
            r#"<circle class="estimate" cx="{px:.2}" cy="{py:.2}" r="4" fill="{}"/>"#,
            COLORS[1]
        );
    }
    // Legend.
    let mut entries = vec!["P_f estimate ± 2·CoV"];
    if !curve.is_empty() {
        entries.push("level thresholds, P = p0^(j+1)");
    }
    let lx = W - R - 250.0;
    let _ = writeln!(
        s,
        r##"<rect x="{}" y="{}" width="240" height="{}" fill="white" fill-opacity="0.85" stroke="#bbb"/>"##,
        lx - 6.0,
        T + 4.0,
        16.0 * entries.len() as f64 + 8.0
    );
    for (i, label) in entries.iter().enumerate() {
        let ly = T + 16.0 + 16.0 * i as f64;
        if i == 0 {
            let _ = writeln!(
                s,
                r#"<circle cx="{}" cy="{ly}" r="4" fill="{}"/>"#,
                lx + 12.0,
                COLORS[1]
            );
        } else {
            let _ = writeln!(
                s,
                r#"<line x1="{lx}" y1="{ly}" x2="{}" y2="{ly}" stroke="{}" stroke-width="2"/>"#,
                lx + 24.0,
                COLORS[0]
            );
        }
        let _ = writeln!(
            s,
            r#"<text x="{}" y="{}">{label}</text>"#,
            lx + 30.0,
            ly + 4.0
        );
    }
    for (i, n) in notes.iter().enumerate() {
        let _ = writeln!(
            s,
            r##"<text class="note" x="{L}" y="{}" fill="#555">note: {}</text>"##,
            H + 4.0 + 16.0 * i as f64,
            esc(n)
        );
    }
    let _ = writeln!(s, "</svg>");
    vec![(SVG.to_string(), s)]
}
