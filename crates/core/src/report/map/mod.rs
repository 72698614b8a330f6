//! The reports of a workspace reliability map ([`crate::map`]): a summary for the terminal, one
//! CSV row and one JSON object per cell, SVG heat maps per plane (the 95 % quantile of the
//! point error and the single-point reliability at the first threshold, `heatmap.rs`) and the
//! page (`page.rs`); [`MapResult`] is a [`Report`] of them.

mod heatmap;
mod page;

pub use heatmap::{colour, render_svgs};

use super::text::fmt_g;
use super::{Layout, Report};
use crate::map::{Grid, MapCell, MapResult};
use std::fmt::Write as _;

/// The CSV file of a map: one row per cell.
pub const CSV_NAME: &str = "map.csv";

/// The name of the JSON document in a report directory.
pub const HTML_JSON: &str = "map.json";

/// A value of a cell, `None` where it has none (unreachable).
type CellValue = fn(&MapCell) -> Option<f64>;

/// Axis names.
const AXIS: [&str; 3] = ["x", "y", "z"];

/// The grid in words: `"xz plane at y = 0 mm, 50 × 40 cells"` or `"3-D grid, 10 × 10 × 8 cells"`.
pub fn grid_label(r: &MapResult) -> String {
    match r.spec.grid {
        Grid::Plane { plane, at, cells } => {
            let a = plane.axes();
            format!(
                "{}{} plane at {} = {} mm, {} × {} cells",
                AXIS[a[0]],
                AXIS[a[1]],
                AXIS[a[2]],
                fmt_g(at),
                cells[0],
                cells[1]
            )
        }
        Grid::Volume { cells } => format!(
            "3-D grid, {} × {} × {} cells (x × y × z)",
            cells[0], cells[1], cells[2]
        ),
    }
}

/// The reference configuration's angles (degrees), comma-separated, one per joint.
fn reference_q(r: &MapResult) -> String {
    r.spec
        .reference_q_deg
        .iter()
        .map(|&v| fmt_g(v))
        .collect::<Vec<_>>()
        .join(", ")
}

fn reached(r: &MapResult) -> impl Iterator<Item = &MapCell> {
    r.cells.iter().filter(|c| c.stats.is_some())
}

/// The cell with the least and the most of `f` among the reached cells.
fn extremes(r: &MapResult, f: impl Fn(&MapCell) -> Option<f64>) -> Option<[(f64, &MapCell); 2]> {
    let mut it = reached(r).filter_map(|c| f(c).map(|v| (v, c)));
    let first = it.next()?;
    Some(it.fold([first, first], |[lo, hi], x| {
        [
            if x.0 < lo.0 { x } else { lo },
            if x.0 > hi.0 { x } else { hi },
        ]
    }))
}

fn at(c: &MapCell) -> String {
    let p = c.target.position;
    format!("({}, {}, {}) mm", fmt_g(p[0]), fmt_g(p[1]), fmt_g(p[2]))
}

/// The terminal summary.
pub fn render_text(r: &MapResult) -> String {
    let mut s = String::new();
    let n = r.cells.len();
    let _ = writeln!(s, "Workspace reliability map — {}", r.model);
    let _ = writeln!(s, "grid       {}", grid_label(r));
    let _ = writeln!(s, "task       {}", r.spec.task());
    for n in &r.notes {
        let _ = writeln!(s, "note       {n}");
    }
    let q = reference_q(r);
    let _ = writeln!(
        s,
        "reference  q = [{q}] deg (each cell takes the solution nearest it)"
    );
    let worst_ik = reached(r)
        .filter_map(|c| c.ik.map(|k| k.position_residual_mm))
        .fold(0.0, f64::max);
    let _ = writeln!(
        s,
        "reached    {} of {n} cells ({} unreachable); largest IK residual {:.1e} mm",
        r.reached,
        n - r.reached,
        worst_ik
    );
    let _ = writeln!(
        s,
        "backend    {} — {} ({})",
        r.backend.backend, r.backend.adapter, r.backend.driver
    );
    let _ = writeln!(
        s,
        "draws      {} (seed {}), one evaluation of all reached cells; IK {:.2} s, evaluation {:.2} s",
        r.draws, r.seed, r.timings.ik_seconds, r.timings.eval_seconds
    );
    let _ = writeln!(
        s,
        "\nper cell (over the reached cells)              least                         most"
    );
    let rows: [(&str, CellValue); 3] = [
        ("mean point error e_j (mm)", |c| {
            c.stats.as_ref().map(|s| s.mean_mm)
        }),
        ("95 % quantile of e_j (mm)", |c| {
            c.stats.as_ref().map(|s| s.q95_mm)
        }),
        ("position Jacobian condition", |c| {
            c.ik.and_then(|k| k.jacobian_condition)
        }),
    ];
    for (label, f) in rows {
        if let Some([(lo, cl), (hi, ch)]) = extremes(r, f) {
            let _ = writeln!(
                s,
                "  {label:<29} {:>10} at {:<24} {:>10} at {}",
                fmt_g(lo),
                at(cl),
                fmt_g(hi),
                at(ch)
            );
        }
    }
    let _ = writeln!(
        s,
        "\nsingle-point reliability R_j(l_c) = Pr[e_j < l_c] (paper eq. 14)"
    );
    let _ = writeln!(
        s,
        "  {:>8}  {:>10}  {:>10}  {:>18}",
        "l_c (mm)", "least R_j", "median R_j", "cells R_j ≥ 0.99"
    );
    for (t, l) in r.thresholds.iter().enumerate() {
        let mut v: Vec<f64> = reached(r)
            .filter_map(|c| c.stats.as_ref().map(|s| s.reliability[t].r))
            .collect();
        v.sort_by(f64::total_cmp);
        let good = v.iter().filter(|&&x| x >= 0.99).count();
        let _ = writeln!(
            s,
            "  {:>8}  {:>10.6}  {:>10.6}  {:>11} of {:<4}",
            fmt_g(*l),
            v.first().copied().unwrap_or(0.0),
            v.get(v.len() / 2).copied().unwrap_or(0.0),
            good,
            v.len()
        );
    }
    let _ = writeln!(
        s,
        "\nmulti-point reliability over the {} reached cells, w = max_j e_j (mean {} mm, 95 % quantile {} mm)",
        r.reached,
        fmt_g(r.w_mean_mm),
        fmt_g(r.w_q95_mm)
    );
    for rel in &r.multi_point {
        let _ = writeln!(
            s,
            "  l_c = {:<6} R = {:.6}   [{:.6}, {:.6}]",
            fmt_g(rel.threshold),
            rel.r,
            rel.ci_low,
            rel.ci_high
        );
    }
    s
}

/// The map as JSON: the settings, the multi-point result and every cell.
pub fn render_json(r: &MapResult) -> String {
    let v = serde_json::json!({
        "tool": "gpu-amcs",
        "version": env!("CARGO_PKG_VERSION"),
        "schema_version": 1,
        "map": r,
    });
    serde_json::to_string_pretty(&v).unwrap_or_default() + "\n"
}

/// One row per cell (index order); an unreachable cell has `reachable` 0 and empty fields.
pub fn render_csv(r: &MapResult) -> String {
    // One angle column per joint of the model (q1_deg … q6_deg for six joints).
    let joints = r.spec.reference_q_deg.len();
    let mut s = String::from("i,j,k,x_mm,y_mm,z_mm,reachable");
    for j in 1..=joints {
        let _ = write!(s, ",q{j}_deg");
    }
    s.push_str(",ik_residual_mm,orientation_residual_rad,jacobian_condition,mean_e_mm,q95_e_mm");
    for l in &r.thresholds {
        let _ = write!(s, ",R_{l},R_{l}_low,R_{l}_high");
    }
    s.push('\n');
    let opt = |v: Option<f64>| v.map(|v| v.to_string()).unwrap_or_default();
    for c in &r.cells {
        let [i, j, k] = c.target.index;
        let [x, y, z] = c.target.position;
        let _ = write!(s, "{i},{j},{k},{x},{y},{z}");
        match (&c.ik, &c.stats) {
            (Some(ik), Some(st)) => {
                let _ = write!(s, ",1");
                for q in ik.q_deg {
                    let _ = write!(s, ",{q}");
                }
                let _ = write!(
                    s,
                    ",{},{},{},{},{}",
                    ik.position_residual_mm,
                    opt(ik.orientation_residual_rad),
                    opt(ik.jacobian_condition),
                    st.mean_mm,
                    st.q95_mm
                );
                for rel in &st.reliability {
                    let _ = write!(s, ",{},{},{}", rel.r, rel.ci_low, rel.ci_high);
                }
            }
            _ => {
                s.push_str(",0");
                s.push_str(&",".repeat(joints + 5 + 3 * r.thresholds.len()));
            }
        }
        s.push('\n');
    }
    s
}

/// The SVG files the heat maps of a map with `layers` layers are written to: for a plane
/// `map_e95.svg` and `map_r.svg`, for a 3-D grid the same per z layer (`map_e95_z03.svg`).
pub fn svg_names(layers: usize) -> Vec<String> {
    if layers <= 1 {
        return vec!["map_e95.svg".into(), "map_r.svg".into()];
    }
    let w = (layers - 1).to_string().len();
    (0..layers)
        .flat_map(|k| {
            [
                format!("map_e95_z{k:0w$}.svg"),
                format!("map_r_z{k:0w$}.svg"),
            ]
        })
        .collect()
}

impl MapResult {
    /// The files of the report of a map with `layers` layers (planes of cells), before it runs.
    pub fn planned_layout(layers: usize) -> Layout {
        Layout {
            svg: svg_names(layers),
            ..Layout::new(HTML_JSON, &[CSV_NAME], &[], &[])
        }
    }
}

impl Report for MapResult {
    fn layout(&self) -> Layout {
        let (_, n, _) = self.spec.layout();
        Self::planned_layout(n[2])
    }

    fn text(&self) -> String {
        render_text(self)
    }

    fn json(&self) -> String {
        render_json(self)
    }

    fn csv(&self) -> Vec<(String, String)> {
        vec![(CSV_NAME.to_string(), render_csv(self))]
    }

    fn svg(&self) -> Vec<(String, String)> {
        render_svgs(self)
    }

    fn page(&self, settings: &[(String, String)], files: &[(String, String)]) -> String {
        page::map_page(self, settings, files).render()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_per_layer() {
        assert_eq!(svg_names(1), ["map_e95.svg", "map_r.svg"]);
        let v = svg_names(12);
        assert_eq!(v.len(), 24);
        assert_eq!(v[2], "map_e95_z01.svg");
    }
}
