//! Markdown tables (for the comparison and the factor study).

use super::text::{finite_or, NA};
use super::{max_relative_error, Comparison};
use std::fmt::Write as _;

/// A Markdown table from a header and rows of cells.
pub fn table(header: &[&str], rows: &[Vec<String>]) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "| {} |", header.join(" | "));
    let _ = writeln!(
        s,
        "|{}|",
        header.iter().map(|_| "---").collect::<Vec<_>>().join("|")
    );
    for r in rows {
        let _ = writeln!(s, "| {} |", r.join(" | "));
    }
    s
}

/// The column headers of the comparison table.
pub const COMPARISON_HEADER: [&str; 8] = [
    "method",
    "M1 (mm)",
    "M2 (mm²)",
    "M3",
    "M4",
    "MRE (%)",
    "draws",
    "time (s)",
];

/// The rows of the comparison table: MCS, then AMCS at each δ.
pub fn comparison_rows(c: &Comparison) -> Vec<Vec<String>> {
    let mut rows = vec![row("MCS", &c.mcs, None)];
    for (d, r, _) in &c.amcs {
        rows.push(row(
            &format!("AMCS δ = {d}"),
            r,
            Some(max_relative_error(r, &c.mcs)),
        ));
    }
    rows
}

/// The comparison as the paper's Table 2 row block.
pub fn render_comparison(c: &Comparison) -> String {
    let notes: String = c.notes.iter().map(|n| format!("> Note: {n}\n\n")).collect();
    format!(
        "### {} — {} test points (seed {})\n\n{notes}{}",
        c.model,
        c.points,
        c.seed,
        table(&COMPARISON_HEADER, &comparison_rows(c))
    )
}

fn row(name: &str, r: &crate::mc::McResult, mre: Option<f64>) -> Vec<String> {
    let m = &r.moments;
    vec![
        name.to_string(),
        format!("{:.4}", m.mean),
        format!("{:.5}", m.variance),
        m.skewness.map_or(NA.into(), |v| format!("{v:.4}")),
        m.kurtosis.map_or(NA.into(), |v| format!("{v:.4}")),
        mre.map_or("—".into(), |v| finite_or(v, NA, |x| format!("{x:.2}"))),
        r.draws.to_string(),
        format!("{:.3}", r.seconds),
    ]
}
