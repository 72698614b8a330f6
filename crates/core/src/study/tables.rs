//! The paper's tables from a [`StudyResult`], as Markdown and CSV, with the paper's own figures
//! beside ours: Table 1 (R_c at the thresholds, per factor, level and number of points, from the
//! MCS), Table 2 (M1–M4, MRE, draws and time of MCS, AMCS-1, AMCS-2 at 50 points, or the largest
//! point count studied), the correlation comparison (independent σ vs full covariance) and the
//! accuracy before/after calibration.

use super::runner::{LevelResult, RunSummary, StudyResult};
use crate::report::markdown::table;

/// The paper's Table 1 (one column per factor; the paper does not say which level):
/// `(factor, R_c at 0.1…0.8 mm for 10 points, for 50 points)`. Blank cells read as 1.
pub const PAPER_TABLE1: [(&str, [f64; 8], [f64; 8]); 5] = [
    (
        "repeatability",
        [0.0147, 0.3326, 0.7783, 0.9579, 0.9946, 1.0, 1.0, 1.0],
        [0.0034, 0.2105, 0.6747, 0.9273, 0.9891, 1.0, 1.0, 1.0],
    ),
    (
        "range",
        [0.0098, 0.2560, 0.6509, 0.8811, 0.9651, 0.9925, 1.0, 1.0],
        [
            0.0025, 0.1499, 0.5326, 0.8217, 0.9451, 0.9859, 0.9971, 0.9997,
        ],
    ),
    (
        "step",
        [0.1226, 0.8140, 0.9927, 1.0, 1.0, 1.0, 1.0, 1.0],
        [0.0647, 0.7427, 0.9884, 1.0, 1.0, 1.0, 1.0, 1.0],
    ),
    (
        "speed",
        [0.0350, 0.4441, 0.8443, 0.9761, 0.9983, 1.0, 1.0, 1.0],
        [0.0122, 0.3341, 0.7786, 0.9612, 0.9950, 0.9997, 1.0, 1.0],
    ),
    (
        "start",
        [0.2286, 0.9031, 0.9958, 1.0, 1.0, 1.0, 1.0, 1.0],
        [0.1278, 0.8523, 0.9927, 1.0, 1.0, 1.0, 1.0, 1.0],
    ),
];

/// The paper's Table 2: `(factor, [MCS, AMCS-1, AMCS-2] × [M1, M2, M3, M4, MRE %, t s])`.
pub const PAPER_TABLE2: [(&str, [[f64; 6]; 3]); 5] = [
    (
        "repeatability",
        [
            [0.2705, 0.0070, 0.6034, 3.4439, 0.0, 3965.0],
            [0.2704, 0.0070, 0.6041, 3.4541, 0.30, 1205.0],
            [0.2706, 0.0070, 0.6025, 3.4393, 0.15, 494.0],
        ],
    ),
    (
        "range",
        [
            [0.3077, 0.0115, 0.7731, 3.7376, 0.0, 3623.0],
            [0.3078, 0.0115, 0.7770, 3.7507, 0.50, 1400.0],
            [0.3079, 0.0115, 0.7753, 3.7257, 0.32, 631.0],
        ],
    ),
    (
        "step",
        [
            [0.1708, 0.0025, 0.4976, 3.3509, 0.0, 3799.0],
            [0.1708, 0.0025, 0.5029, 3.3513, 1.07, 627.0],
            [0.1708, 0.0025, 0.5070, 3.3614, 1.89, 277.0],
        ],
    ),
    (
        "speed",
        [
            [0.2425, 0.0065, 0.6245, 3.4287, 0.0, 3715.0],
            [0.2426, 0.0065, 0.6264, 3.4321, 0.30, 1076.0],
            [0.2426, 0.0065, 0.6256, 3.4333, 0.18, 477.0],
        ],
    ),
    (
        "start",
        [
            [0.1517, 0.0023, 0.7330, 3.8434, 0.0, 3786.0],
            [0.1518, 0.0023, 0.7356, 3.8447, 0.35, 610.0],
            [0.1519, 0.0023, 0.7441, 3.8907, 1.51, 247.0],
        ],
    ),
];

pub(crate) fn f4(v: f64) -> String {
    format!("{v:.4}")
}

/// Table 1 rows: factor, level, points, R_c per threshold (MCS).
pub fn table1_rows(s: &StudyResult) -> (Vec<String>, Vec<Vec<String>>) {
    let mut header = vec!["factor".to_string(), "level".into(), "points".into()];
    header.extend(s.settings.thresholds.iter().map(|t| format!("R_c({t} mm)")));
    let mut rows = Vec::new();
    for l in &s.levels {
        for p in &l.points {
            let mut r = vec![
                l.factor.name().to_string(),
                l.level.clone(),
                p.points.to_string(),
            ];
            r.extend(p.mcs.reliability.iter().map(|v| f4(*v)));
            rows.push(r);
        }
    }
    (header, rows)
}

/// The point-count result used for Table 2: 50 points if studied, else the largest.
pub fn table2_points(l: &LevelResult) -> Option<&super::runner::PointsResult> {
    l.points
        .iter()
        .find(|p| p.points == 50)
        .or_else(|| l.points.iter().max_by_key(|p| p.points))
}

fn summary_row(l: &LevelResult, r: &RunSummary) -> Vec<String> {
    vec![
        l.factor.name().to_string(),
        l.level.clone(),
        r.label.clone(),
        f4(r.moments[0]),
        format!("{:.6}", r.moments[1]),
        f4(r.moments[2]),
        f4(r.moments[3]),
        r.mre_percent.map_or("0".into(), |v| format!("{v:.2}")),
        r.draws.to_string(),
        format!("{:.3}", r.seconds),
    ]
}

/// Table 2 rows: factor, level, method, M1–M4, MRE %, draws, time.
pub fn table2_rows(s: &StudyResult) -> (Vec<String>, Vec<Vec<String>>) {
    let header = ["factor", "level"]
        .into_iter()
        .chain(crate::report::markdown::COMPARISON_HEADER)
        .map(String::from)
        .collect();
    let mut rows = Vec::new();
    for l in &s.levels {
        if let Some(p) = table2_points(l) {
            rows.push(summary_row(l, &p.mcs));
            for a in &p.amcs {
                rows.push(summary_row(l, a));
            }
        }
    }
    (header, rows)
}

/// Correlation rows: independent σ vs full covariance (AMCS at the first δ).
pub fn correlation_rows(s: &StudyResult) -> (Vec<String>, Vec<Vec<String>>) {
    let t = &s.settings.thresholds;
    let header = [
        "factor",
        "level",
        "points",
        "mean |ρ|",
        "M1 indep (mm)",
        "M1 cov (mm)",
        "ΔM1 (%)",
        "w_high indep (mm)",
        "w_high cov (mm)",
        "max |ΔR_c|",
        "at l_c (mm)",
    ]
    .map(String::from)
    .to_vec();
    let mut rows = Vec::new();
    for l in &s.levels {
        for p in &l.points {
            let (a, c) = (&p.amcs[0], &p.amcs_covariance);
            let (k, d) = a
                .reliability
                .iter()
                .zip(&c.reliability)
                .map(|(x, y)| (y - x).abs())
                .enumerate()
                .fold((0, 0.0), |acc, (k, d)| if d > acc.1 { (k, d) } else { acc });
            rows.push(vec![
                l.factor.name().into(),
                l.level.clone(),
                p.points.to_string(),
                format!("{:.3}", l.mean_abs_correlation),
                f4(a.moments[0]),
                f4(c.moments[0]),
                format!("{:+.1}", 100.0 * (c.moments[0] / a.moments[0] - 1.0)),
                f4(a.coverage_interval[1]),
                f4(c.coverage_interval[1]),
                f4(d),
                t.get(k).map_or(String::new(), |v| v.to_string()),
            ]);
        }
    }
    (header, rows)
}

/// Accuracy rows: mean positioning error before/after calibration.
pub fn accuracy_rows(s: &StudyResult) -> (Vec<String>, Vec<Vec<String>>) {
    let header = [
        "factor",
        "level",
        "runs",
        "before (mm)",
        "after (mm)",
        "improvement (%)",
        "calibration time (s)",
    ]
    .map(String::from)
    .to_vec();
    let rows = s
        .levels
        .iter()
        .map(|l| {
            vec![
                l.factor.name().into(),
                l.level.clone(),
                l.factors.runs.to_string(),
                f4(l.accuracy_before_mm),
                f4(l.accuracy_after_mm),
                format!(
                    "{:.1}",
                    100.0 * (1.0 - l.accuracy_after_mm / l.accuracy_before_mm)
                ),
                format!("{:.2}", l.calibration_seconds),
            ]
        })
        .collect();
    (header, rows)
}

/// Markdown of a header and rows.
pub fn markdown((h, rows): &(Vec<String>, Vec<Vec<String>>)) -> String {
    let h: Vec<&str> = h.iter().map(String::as_str).collect();
    table(&h, rows)
}

/// CSV of a header and rows (cells quoted when needed).
pub fn csv((h, rows): &(Vec<String>, Vec<Vec<String>>)) -> String {
    crate::report::csv::table(h, rows)
}

/// The paper's Table 1 as Markdown.
pub fn paper_table1() -> String {
    let mut header = vec!["factor", "points"];
    let th = ["0.1", "0.2", "0.3", "0.4", "0.5", "0.6", "0.7", "0.8"];
    header.extend(th);
    let mut rows = Vec::new();
    for (f, r10, r50) in PAPER_TABLE1 {
        for (m, r) in [("10", r10), ("50", r50)] {
            let mut row = vec![f.to_string(), m.to_string()];
            row.extend(r.iter().map(|v| f4(*v)));
            rows.push(row);
        }
    }
    table(&header, &rows)
}

/// The paper's Table 2 as Markdown.
pub fn paper_table2() -> String {
    let mut rows = Vec::new();
    for (f, block) in PAPER_TABLE2 {
        for (name, r) in ["MCS", "AMCS-1", "AMCS-2"].iter().zip(block) {
            rows.push(vec![
                f.to_string(),
                name.to_string(),
                f4(r[0]),
                f4(r[1]),
                f4(r[2]),
                f4(r[3]),
                format!("{:.2}", r[4]),
                format!("{}", r[5]),
            ]);
        }
    }
    table(
        &[
            "factor",
            "method",
            "M1 (mm)",
            "M2 (mm²)",
            "M3",
            "M4",
            "MRE (%)",
            "time (s)",
        ],
        &rows,
    )
}
