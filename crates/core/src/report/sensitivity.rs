//! Reports of a Sobol sensitivity analysis ([`SensitivityResult`]): a ranked table for the
//! terminal, the indices as CSV, JSON (the result's own serde form) and bar charts; with the
//! page ([`super::html::sensitivity`]) the result is a [`Report`].

use super::html::sensitivity::sensitivity_page;
use super::{Layout, Report};
use crate::mc::sensitivity::{Estimate, Quantity, QuantityIndices, SensitivityResult, SobolIndex};
use std::fmt::Write;

/// The JSON document in a report directory.
const JSON: &str = "sensitivity.json";
/// The indices as CSV.
const CSV: &str = "indices.csv";
/// The bar chart of the parameters.
const INDICES_SVG: &str = "indices.svg";
/// The bar chart of the groups.
pub(crate) const GROUPS_SVG: &str = "groups.svg";

impl SensitivityResult {
    /// The files of a sensitivity report, before it runs.
    pub fn planned_layout() -> Layout {
        Layout::new(JSON, &[CSV], &[INDICES_SVG, GROUPS_SVG], &[])
    }
}

impl Report for SensitivityResult {
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
        sensitivity_page(self, settings, files).render()
    }
}

/// `0.123 [0.101, 0.145]`, or the value alone when the bootstrap gave no interval.
fn with_ci(e: &Estimate) -> String {
    match (e.ci_low, e.ci_high) {
        (Some(lo), Some(hi)) => format!("{:6.3} [{:6.3}, {:6.3}]", e.value, lo, hi),
        _ => format!("{:6.3}", e.value),
    }
}

fn quantity_title(q: &QuantityIndices) -> String {
    match q.quantity {
        Quantity::Value => format!(
            "w = max_j e_j (mm): mean {:.6}, variance {:.4e}",
            q.mean, q.variance
        ),
        Quantity::Exceedance { threshold } => {
            format!(
                "failure indicator 1[w ≥ {} mm]: P = {:.6}",
                super::text::fmt_plain(threshold),
                q.mean
            )
        }
    }
}

fn table(s: &mut String, heading: &str, rows: &[SobolIndex]) {
    let width = rows.iter().map(|r| r.name.len()).max().unwrap_or(4).max(9);
    let _ = writeln!(
        s,
        "  {heading:<width$}  {:<24}  {:<24}",
        "first order S [95 % CI]", "total ST [95 % CI]"
    );
    for r in rows {
        let _ = writeln!(
            s,
            "  {:<width$}  {:<24}  {:<24}",
            r.name,
            with_ci(&r.first_order),
            with_ci(&r.total)
        );
    }
}

/// The terminal table: per quantity, the inputs and the groups ranked by total index.
pub fn render_text(r: &SensitivityResult) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "Sobol indices (first order: Saltelli 2010; total: Jansen), N = {} base samples",
        r.analysis.draws
    );
    let _ = writeln!(
        s,
        "model      {}  |  {} test points  |  seed {}",
        r.model, r.points, r.seed
    );
    let _ = writeln!(
        s,
        "inputs     {} ({}); {} model evaluations = N·(2 + {}), {} bootstrap resamples",
        r.analysis.dimension,
        match r.input_kind {
            crate::mc::sensitivity::InputKind::IndependentParameters => "independent parameters",
            crate::mc::sensitivity::InputKind::CholeskyInnovations =>
                "Cholesky innovations of a correlated model",
        },
        r.analysis.evaluations,
        r.analysis.pick_freeze_matrices,
        r.analysis.bootstrap_resamples
    );
    if !r.skipped_parameters.is_empty() {
        let _ = writeln!(
            s,
            "fixed      {} (σ = 0, not inputs)",
            r.skipped_parameters.join(", ")
        );
    }
    let _ = writeln!(
        s,
        "backend    {} — {} {}",
        r.backend.backend, r.backend.adapter, r.backend.driver
    );
    for q in &r.analysis.quantities {
        let _ = writeln!(s, "\n{}", quantity_title(q));
        if let Some(note) = &q.note {
            let _ = writeln!(s, "  note: {note}");
        }
        if q.inputs.is_empty() {
            continue;
        }
        table(&mut s, "group", &q.groups);
        let _ = writeln!(s);
        table(&mut s, "parameter", &q.inputs);
    }
    s
}

fn opt(x: Option<f64>) -> String {
    x.map(|v| v.to_string()).unwrap_or_default()
}

/// `indices.csv`: one row per quantity, level (input or group) and name.
pub fn render_csv(r: &SensitivityResult) -> String {
    let mut s = String::from(
        "quantity,threshold_mm,level,name,first_order,first_order_ci_low,first_order_ci_high,\
         total,total_ci_low,total_ci_high\n",
    );
    for q in &r.analysis.quantities {
        let (quantity, threshold) = match q.quantity {
            Quantity::Value => ("w", String::new()),
            Quantity::Exceedance { threshold } => ("exceedance", threshold.to_string()),
        };
        for (level, rows) in [("group", &q.groups), ("input", &q.inputs)] {
            for i in rows.iter() {
                let _ = writeln!(
                    s,
                    "{quantity},{threshold},{level},{},{},{},{},{},{},{}",
                    i.name,
                    i.first_order.value,
                    opt(i.first_order.ci_low),
                    opt(i.first_order.ci_high),
                    i.total.value,
                    opt(i.total.ci_low),
                    opt(i.total.ci_high)
                );
            }
        }
    }
    s
}

/// The result as JSON, with the tool's name and version.
pub fn render_json(r: &SensitivityResult) -> String {
    let v = serde_json::json!({
        "tool": "gpu-amcs",
        "version": env!("CARGO_PKG_VERSION"),
        "schema_version": 1,
        "sensitivity": r,
    });
    serde_json::to_string_pretty(&v).unwrap_or_default() + "\n"
}

/// At most this many rows in a bar chart.
const MAX_BARS: usize = 20;

/// A horizontal bar chart of first-order and total indices with their 95 % intervals.
fn bar_chart(title: &str, what: &str, rows: &[SobolIndex], note: Option<&str>) -> String {
    use super::svg::{begin, esc, nice_step, tick_label, COLORS};
    const W: f64 = 720.0;
    const T: f64 = 76.0;
    const B: f64 = 50.0;
    const R: f64 = 24.0;
    const ROW: f64 = 26.0;
    let shown = &rows[..rows.len().min(MAX_BARS)];
    let longest = shown
        .iter()
        .map(|r| r.name.chars().count())
        .max()
        .unwrap_or(0);
    let left = (longest as f64 * 7.0 + 16.0).clamp(90.0, 240.0);
    let finite = |x: Option<f64>| x.filter(|v| v.is_finite());
    let ends = shown.iter().flat_map(|r| {
        [&r.first_order, &r.total]
            .into_iter()
            .flat_map(|e| [Some(e.value), e.ci_low, e.ci_high])
            .filter_map(finite)
    });
    let (mut lo, mut hi) = (0.0f64, 0.0f64);
    for v in ends {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    let (lo, hi) = (lo.max(-1.0), hi.clamp(0.05, 2.0));
    let step = nice_step(hi - lo, 8);
    let (x0, x1) = ((lo / step).floor() * step, (hi / step).ceil() * step);
    let sx = |x: f64| left + (x.clamp(x0, x1) - x0) / (x1 - x0) * (W - left - R);
    let mut notes: Vec<String> = Vec::new();
    if rows.len() > shown.len() {
        notes.push(format!(
            "the {} {what}s with the largest total index of {}",
            shown.len(),
            rows.len()
        ));
    }
    if shown
        .iter()
        .any(|r| r.first_order.value < 0.0 || r.total.value < 0.0)
    {
        notes.push("negative estimates are drawn as 0; their intervals are shown".into());
    }
    if let Some(n) = note {
        notes.push(n.to_string());
    }
    if shown.is_empty() {
        notes.push(format!("no {what} indices"));
    }
    let plot_h = ROW * shown.len().max(1) as f64;
    let h = T + plot_h + B + 16.0 * notes.len() as f64;
    let mut s = String::new();
    begin(&mut s, W, h, title);
    // Legend, one row under the title.
    let ly = 44.0;
    let _ = writeln!(
        s,
        r##"<rect x="{left}" y="{}" width="{}" height="22" fill="white" stroke="#bbb"/>"##,
        ly - 13.0,
        W - left - R
    );
    let mut lx = left + 10.0;
    for (k, label) in ["first order S", "total ST"].iter().enumerate() {
        let _ = writeln!(
            s,
            r#"<rect x="{lx}" y="{}" width="18" height="9" fill="{}"/>"#,
            ly - 7.0,
            COLORS[k]
        );
        let _ = writeln!(
            s,
            r#"<text x="{}" y="{}">{label}</text>"#,
            lx + 24.0,
            ly + 2.0
        );
        lx += 130.0;
    }
    let _ = writeln!(
        s,
        r#"<line x1="{lx}" y1="{}" x2="{}" y2="{}" stroke="black"/>"#,
        ly - 2.5,
        lx + 18.0,
        ly - 2.5
    );
    for cx in [lx, lx + 18.0] {
        let _ = writeln!(
            s,
            r#"<line x1="{cx}" y1="{}" x2="{cx}" y2="{}" stroke="black"/>"#,
            ly - 6.0,
            ly + 1.0
        );
    }
    let _ = writeln!(
        s,
        r#"<text x="{}" y="{}">95 % bootstrap interval</text>"#,
        lx + 24.0,
        ly + 2.0
    );
    // Axes box and x ticks.
    let _ = writeln!(
        s,
        r#"<rect x="{left}" y="{T}" width="{}" height="{plot_h}" fill="none" stroke="black"/>"#,
        W - left - R
    );
    let mut x = x0;
    while x <= x1 + 1e-9 * step {
        let px = sx(x);
        let _ = writeln!(
            s,
            r##"<line x1="{px:.1}" y1="{T}" x2="{px:.1}" y2="{}" stroke="#ddd"/>"##,
            T + plot_h
        );
        let _ = writeln!(
            s,
            r#"<text x="{px:.1}" y="{}" text-anchor="middle">{}</text>"#,
            T + plot_h + 16.0,
            tick_label(x)
        );
        x += step;
    }
    if x0 < 0.0 {
        let px = sx(0.0);
        let _ = writeln!(
            s,
            r#"<line x1="{px:.1}" y1="{T}" x2="{px:.1}" y2="{}" stroke="black"/>"#,
            T + plot_h
        );
    }
    let _ = writeln!(
        s,
        r#"<text x="{}" y="{}" text-anchor="middle">Sobol index</text>"#,
        (left + W - R) / 2.0,
        T + plot_h + 36.0
    );
    for (i, r) in shown.iter().enumerate() {
        let top = T + ROW * i as f64;
        let _ = writeln!(
            s,
            r#"<text x="{}" y="{:.1}" text-anchor="end">{}</text>"#,
            left - 6.0,
            top + ROW / 2.0 + 4.0,
            esc(&r.name)
        );
        for (k, (class, e)) in [("bar-s", &r.first_order), ("bar-st", &r.total)]
            .into_iter()
            .enumerate()
        {
            let y = top + 4.0 + 9.5 * k as f64;
            let v = if e.value.is_finite() {
                e.value.max(0.0)
            } else {
                0.0
            };
            let _ = writeln!(
                s,
                r#"<rect class="{class}" x="{:.1}" y="{y:.1}" width="{:.1}" height="8.5" fill="{}"/>"#,
                sx(0.0),
                sx(v) - sx(0.0),
                COLORS[k]
            );
            if let (Some(a), Some(b)) = (finite(e.ci_low), finite(e.ci_high)) {
                let cy = y + 4.25;
                let (pa, pb) = (sx(a), sx(b));
                let _ = writeln!(
                    s,
                    r#"<line class="ci" x1="{pa:.1}" y1="{cy:.2}" x2="{pb:.1}" y2="{cy:.2}" stroke="black"/>"#
                );
                for px in [pa, pb] {
                    let _ = writeln!(
                        s,
                        r#"<line x1="{px:.1}" y1="{:.2}" x2="{px:.1}" y2="{:.2}" stroke="black"/>"#,
                        cy - 3.0,
                        cy + 3.0
                    );
                }
            }
        }
    }
    for (i, n) in notes.iter().enumerate() {
        let _ = writeln!(
            s,
            r##"<text class="note" x="{left}" y="{}" fill="#555">note: {}</text>"##,
            T + plot_h + B + 8.0 + 16.0 * i as f64,
            esc(n)
        );
    }
    let _ = writeln!(s, "</svg>");
    s
}

/// `indices.svg` (the parameters ranked by total index, at most 20) and `groups.svg` (the
/// groups): first-order and total indices of the first quantity (w) as horizontal bars with
/// their 95 % bootstrap intervals as error bars. `(file name, svg)`.
pub fn render_svg(r: &SensitivityResult) -> Vec<(String, String)> {
    let empty = Vec::new();
    let (inputs, groups, note, what) = match r.analysis.quantities.first() {
        Some(q) => (
            &q.inputs,
            &q.groups,
            q.note.as_deref(),
            match q.quantity {
                Quantity::Value => "w".to_string(),
                Quantity::Exceedance { threshold } => {
                    format!("1[w ≥ {} mm]", super::text::fmt_plain(threshold))
                }
            },
        ),
        None => (&empty, &empty, None, "w".to_string()),
    };
    let tail = format!("{}, {} points, N = {}", r.model, r.points, r.analysis.draws);
    vec![
        (
            INDICES_SVG.to_string(),
            bar_chart(
                &format!("Sobol indices of {what} per parameter — {tail}"),
                "parameter",
                inputs,
                note,
            ),
        ),
        (
            GROUPS_SVG.to_string(),
            bar_chart(
                &format!("Sobol indices of {what} per group — {tail}"),
                "group",
                groups,
                note,
            ),
        ),
    ]
}
