//! The reports of a workspace reliability map ([`crate::map`]): a summary for the terminal, one
//! CSV row and one JSON object per cell, and SVG heat maps per plane (the 95 % quantile of the
//! point error and the single-point reliability at the first threshold).

use super::svg::{esc, nice_step, tick_label};
use super::text::fmt_g;
use crate::map::{Grid, MapCell, MapResult};
use std::fmt::Write as _;

/// The CSV file `--csv DIR` writes.
pub const CSV_NAME: &str = "map.csv";

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
    let q = r.spec.reference_q_deg.map(fmt_g).join(", ");
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
    let mut s = String::from(
        "i,j,k,x_mm,y_mm,z_mm,reachable,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,ik_residual_mm,orientation_residual_rad,jacobian_condition,mean_e_mm,q95_e_mm",
    );
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
                s.push_str(&",".repeat(11 + 3 * r.thresholds.len()));
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

/// Colour stops of the viridis colour map (perceptually uniform, readable in grey and by
/// colour-blind readers; S. van der Walt and N. Smith, matplotlib 2.0), at 0, 1/8, …, 1.
const VIRIDIS: [[f64; 3]; 9] = [
    [68.0, 1.0, 84.0],
    [71.0, 44.0, 122.0],
    [59.0, 81.0, 139.0],
    [44.0, 113.0, 142.0],
    [33.0, 144.0, 141.0],
    [39.0, 173.0, 129.0],
    [92.0, 200.0, 99.0],
    [170.0, 220.0, 50.0],
    [253.0, 231.0, 37.0],
];

/// The viridis colour of `t` in [0, 1] as `#rrggbb`.
pub fn colour(t: f64) -> String {
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let x = t * (VIRIDIS.len() - 1) as f64;
    let i = (x.floor() as usize).min(VIRIDIS.len() - 2);
    let f = x - i as f64;
    let c: Vec<u8> = (0..3)
        .map(|k| (VIRIDIS[i][k] + f * (VIRIDIS[i + 1][k] - VIRIDIS[i][k])).round() as u8)
        .collect();
    format!("#{:02x}{:02x}{:02x}", c[0], c[1], c[2])
}

/// One heat map: which value of a cell, its label with units, and the colour range.
struct Quantity {
    name: String,
    unit_label: String,
    value: CellValue,
    range: Option<(f64, f64)>,
}

/// The heat maps of every plane (layer) of the map, named as [`svg_names`] says.
pub fn render_svgs(r: &MapResult) -> Vec<(String, String)> {
    let (axes, n, range) = r.spec.layout();
    let names = svg_names(n[2]);
    let l0 = r.thresholds.first().copied().unwrap_or(0.0);
    let mut out = Vec::new();
    for k in 0..n[2] {
        let layer: Vec<&MapCell> = r.cells.iter().filter(|c| c.target.index[2] == k).collect();
        let at = layer.first().map_or(0.0, |c| c.target.position[axes[2]]);
        let qs = [
            Quantity {
                name: "95 % quantile of the point error e_j".into(),
                unit_label: "e_j, 95 % quantile (mm)".into(),
                value: |c: &MapCell| c.stats.as_ref().map(|s| s.q95_mm),
                range: None,
            },
            Quantity {
                name: format!("single-point reliability R_j({} mm)", fmt_g(l0)),
                unit_label: format!("R_j = Pr[e_j < {} mm]", fmt_g(l0)),
                value: |c: &MapCell| {
                    c.stats
                        .as_ref()
                        .and_then(|s| s.reliability.first())
                        .map(|x| x.r)
                },
                range: Some((0.0, 1.0)),
            },
        ];
        for (qi, q) in qs.iter().enumerate() {
            let plane = format!(
                "{}{} plane at {} = {} mm",
                AXIS[axes[0]],
                AXIS[axes[1]],
                AXIS[axes[2]],
                fmt_g(at)
            );
            let svg = heat_map(
                r,
                &layer,
                axes,
                [n[0], n[1]],
                [range[0], range[1]],
                &plane,
                q,
            );
            out.push((names[2 * k + qi].clone(), svg));
        }
    }
    out
}

/// Plot geometry.
const LEFT: f64 = 80.0;
const TOP: f64 = 50.0;
const PLOT_W: f64 = 520.0;
const PLOT_H: f64 = 440.0;
const LEGEND_W: f64 = 150.0;
const BOTTOM: f64 = 70.0;

#[allow(clippy::too_many_arguments)]
fn heat_map(
    r: &MapResult,
    layer: &[&MapCell],
    axes: [usize; 3],
    n: [usize; 2],
    range: [(f64, f64); 2],
    plane: &str,
    q: &Quantity,
) -> String {
    let (hx, vx) = (range[0], range[1]);
    let (wx, wy) = (hx.1 - hx.0, vx.1 - vx.0);
    // Equal mm per pixel on both axes.
    let scale = (PLOT_W / wx).min(PLOT_H / wy);
    let (pw, ph) = (wx * scale, wy * scale);
    let width = LEFT + pw + LEGEND_W;
    let height = TOP + ph + BOTTOM;
    let sx = |x: f64| LEFT + (x - hx.0) * scale;
    let sy = |y: f64| TOP + ph - (y - vx.0) * scale;
    let values: Vec<f64> = layer.iter().filter_map(|c| (q.value)(c)).collect();
    let (lo, hi) = q.range.unwrap_or_else(|| {
        let lo = values.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        if !lo.is_finite() {
            (0.0, 1.0)
        } else if hi > lo {
            (lo, hi)
        } else {
            (lo, lo + lo.abs().max(1e-9))
        }
    });
    let norm = |v: f64| (v - lo) / (hi - lo);
    let title = format!("{} — {}", r.model, q.name);
    let unreachable = layer.iter().filter(|c| c.stats.is_none()).count();
    let base_h = 0.0;
    let base_v = 0.0;
    let base_in = (hx.0..=hx.1).contains(&base_h) && (vx.0..=vx.1).contains(&base_v);
    let mut desc = format!(
        "Heat map of the {} over the {}, {} × {} cells of {} × {} mm; {} of {} cells reached ({}); hatched cells are unreachable.",
        q.name,
        plane,
        n[0],
        n[1],
        fmt_g(wx),
        fmt_g(wy),
        layer.len() - unreachable,
        layer.len(),
        r.spec.task()
    );
    if let (Some(a), Some(b)) = (
        layer
            .iter()
            .filter_map(|c| (q.value)(c).map(|v| (v, *c)))
            .min_by(|a, b| a.0.total_cmp(&b.0)),
        layer
            .iter()
            .filter_map(|c| (q.value)(c).map(|v| (v, *c)))
            .max_by(|a, b| a.0.total_cmp(&b.0)),
    ) {
        let _ = write!(
            desc,
            " Values from {} at {} to {} at {}.",
            fmt_g(a.0),
            at(a.1),
            fmt_g(b.0),
            at(b.1)
        );
    }
    let _ = write!(
        desc,
        " The origin of the robot's base frame is {}.",
        if base_in {
            "marked by a cross in a circle labelled base"
        } else {
            "outside this plane's extent"
        }
    );
    let mut s = String::new();
    let _ = writeln!(s, r#"<?xml version="1.0" encoding="UTF-8"?>"#);
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{width:.0}" height="{height:.0}" viewBox="0 0 {width:.0} {height:.0}" font-family="sans-serif" font-size="12">"#
    );
    let _ = writeln!(
        s,
        "<title>{}</title><desc>{}</desc>",
        esc(&title),
        esc(&desc)
    );
    let _ = writeln!(
        s,
        r##"<defs><pattern id="hatch" width="6" height="6" patternUnits="userSpaceOnUse" patternTransform="rotate(45)"><rect width="6" height="6" fill="#eeeeee"/><line x1="0" y1="0" x2="0" y2="6" stroke="#888888" stroke-width="2"/></pattern></defs>"##
    );
    let _ = writeln!(
        s,
        r#"<rect x="0" y="0" width="{width:.0}" height="{height:.0}" fill="white"/>"#
    );
    let _ = writeln!(
        s,
        r#"<text x="{:.1}" y="22" text-anchor="middle" font-size="15">{}</text>"#,
        width / 2.0,
        esc(&title)
    );
    let _ = writeln!(
        s,
        r#"<text x="{:.1}" y="40" text-anchor="middle">{}</text>"#,
        width / 2.0,
        esc(&format!("{plane}, {}, {} draws", r.spec.task(), r.draws))
    );
    // Cells.
    let (cw, ch) = (pw / n[0] as f64, ph / n[1] as f64);
    let _ = writeln!(s, r#"<g shape-rendering="crispEdges">"#);
    for c in layer {
        let [i, j, _] = c.target.index;
        let x = LEFT + i as f64 * cw;
        let y = TOP + ph - (j as f64 + 1.0) * ch;
        let fill = match (q.value)(c) {
            Some(v) => colour(norm(v)),
            None => "url(#hatch)".to_string(),
        };
        let _ = writeln!(
            s,
            r#"<rect x="{x:.2}" y="{y:.2}" width="{:.2}" height="{:.2}" fill="{fill}"/>"#,
            cw + 0.05,
            ch + 0.05
        );
    }
    let _ = writeln!(s, "</g>");
    let _ = writeln!(
        s,
        r#"<rect x="{LEFT}" y="{TOP}" width="{pw:.2}" height="{ph:.2}" fill="none" stroke="black"/>"#
    );
    // Axes with ticks, mm.
    let ticks = |a: f64, b: f64| {
        let step = nice_step(b - a, 6);
        let mut t = (a / step).ceil() * step;
        let mut v = Vec::new();
        while t <= b + 1e-9 * step {
            v.push(if t.abs() < 1e-9 * step { 0.0 } else { t });
            t += step;
        }
        v
    };
    for t in ticks(hx.0, hx.1) {
        let x = sx(t);
        let y = TOP + ph;
        let _ = writeln!(
            s,
            r#"<line x1="{x:.2}" y1="{y:.2}" x2="{x:.2}" y2="{:.2}" stroke="black"/><text x="{x:.2}" y="{:.2}" text-anchor="middle">{}</text>"#,
            y + 5.0,
            y + 18.0,
            tick_label(t)
        );
    }
    for t in ticks(vx.0, vx.1) {
        let y = sy(t);
        let _ = writeln!(
            s,
            r#"<line x1="{:.2}" y1="{y:.2}" x2="{LEFT}" y2="{y:.2}" stroke="black"/><text x="{:.2}" y="{:.2}" text-anchor="end">{}</text>"#,
            LEFT - 5.0,
            LEFT - 8.0,
            y + 4.0,
            tick_label(t)
        );
    }
    let _ = writeln!(
        s,
        r#"<text x="{:.2}" y="{:.2}" text-anchor="middle">{} (mm)</text>"#,
        LEFT + pw / 2.0,
        TOP + ph + 38.0,
        AXIS[axes[0]]
    );
    let _ = writeln!(
        s,
        r#"<text x="20" y="{:.2}" text-anchor="middle" transform="rotate(-90 20 {:.2})">{} (mm)</text>"#,
        TOP + ph / 2.0,
        TOP + ph / 2.0,
        AXIS[axes[1]]
    );
    // The base: where the first joint axis meets the plane's origin coordinates.
    if base_in {
        let (x, y) = (sx(base_h), sy(base_v));
        let _ = writeln!(
            s,
            r#"<g stroke="white" stroke-width="2" fill="none"><circle cx="{x:.2}" cy="{y:.2}" r="8"/><line x1="{:.2}" y1="{y:.2}" x2="{:.2}" y2="{y:.2}"/><line x1="{x:.2}" y1="{:.2}" x2="{x:.2}" y2="{:.2}"/></g><g stroke="black" stroke-width="1" fill="none"><circle cx="{x:.2}" cy="{y:.2}" r="8"/><line x1="{:.2}" y1="{y:.2}" x2="{:.2}" y2="{y:.2}"/><line x1="{x:.2}" y1="{:.2}" x2="{x:.2}" y2="{:.2}"/></g><text x="{:.2}" y="{:.2}" font-weight="bold">base</text>"#,
            x - 8.0,
            x + 8.0,
            y - 8.0,
            y + 8.0,
            x - 8.0,
            x + 8.0,
            y - 8.0,
            y + 8.0,
            x + 11.0,
            y - 9.0
        );
    }
    // Legend: the colour scale with ticks and units, and the hatch.
    let lx = LEFT + pw + 30.0;
    let (ly0, ly1) = (TOP + 10.0, TOP + ph.min(300.0));
    let steps = 64;
    for i in 0..steps {
        let t0 = i as f64 / steps as f64;
        let y = ly1 - (t0 + 1.0 / steps as f64) * (ly1 - ly0);
        let _ = writeln!(
            s,
            r#"<rect x="{lx:.2}" y="{y:.2}" width="18" height="{:.2}" fill="{}"/>"#,
            (ly1 - ly0) / steps as f64 + 0.3,
            colour(t0 + 0.5 / steps as f64)
        );
    }
    let _ = writeln!(
        s,
        r#"<rect x="{lx:.2}" y="{ly0:.2}" width="18" height="{:.2}" fill="none" stroke="black"/>"#,
        ly1 - ly0
    );
    for t in ticks(lo, hi) {
        let y = ly1 - norm(t) * (ly1 - ly0);
        let _ = writeln!(
            s,
            r#"<line x1="{:.2}" y1="{y:.2}" x2="{:.2}" y2="{y:.2}" stroke="black"/><text x="{:.2}" y="{:.2}">{}</text>"#,
            lx + 18.0,
            lx + 22.0,
            lx + 25.0,
            y + 4.0,
            tick_label(t)
        );
    }
    let _ = writeln!(
        s,
        r#"<text x="{:.2}" y="{:.2}" font-size="11">{}</text>"#,
        lx - 10.0,
        ly0 - 8.0,
        esc(&q.unit_label)
    );
    let hy = ly1 + 20.0;
    let _ = writeln!(
        s,
        r#"<rect x="{lx:.2}" y="{hy:.2}" width="18" height="14" fill="url(#hatch)" stroke="black"/><text x="{:.2}" y="{:.2}" font-size="11">unreachable</text>"#,
        lx + 24.0,
        hy + 11.0
    );
    let _ = writeln!(s, "</svg>");
    s
}

/// The name of the JSON file in an HTML report directory.
pub const HTML_JSON: &str = "map.json";

/// Every file of the `--html DIR` report of a map with `layers` layers, `index.html` last.
pub fn html_names(layers: usize) -> Vec<String> {
    let mut v = vec![HTML_JSON.to_string(), CSV_NAME.to_string()];
    v.extend(svg_names(layers));
    v.push(super::html::pages::INDEX.to_string());
    v
}

/// A heat map's `<title>` and `<desc>` (as [`render_svgs`] writes them): the description, and
/// the document without them, for a page that gives the figure its own.
fn split_text_alternative(svg: &str) -> (String, String) {
    match (svg.find("<title>"), svg.find("<desc>"), svg.find("</desc>")) {
        (Some(t), Some(d), Some(e)) if t < d && d < e => {
            let desc = svg[d + "<desc>".len()..e]
                .replace("&lt;", "<")
                .replace("&gt;", ">")
                .replace("&amp;", "&");
            (
                desc,
                format!("{}{}", &svg[..t], &svg[e + "</desc>".len()..]),
            )
        }
        _ => (String::new(), svg.to_string()),
    }
}

/// The `--html DIR` report: the JSON and CSV of every cell, the heat maps, and the page (the
/// summary, the multi-point and single-point reliability tables, the heat maps inline, the
/// model and settings); `settings` are rows only the caller knows (where the model came from).
pub fn html_files(r: &MapResult, settings: &[(String, String)]) -> Vec<(String, String)> {
    use super::html::{Figure, Page, Table};
    let svgs = render_svgs(r);
    let mut files = vec![
        (HTML_JSON.to_string(), render_json(r)),
        (CSV_NAME.to_string(), render_csv(r)),
    ];
    files.extend(svgs.iter().cloned());
    let mut page = Page::new(&format!("Workspace reliability map of {}", r.model));
    page.summary("grid", &grid_label(r))
        .summary("task", &r.spec.task())
        .summary(
            "cells reached",
            &format!("{} of {}", r.reached, r.cells.len()),
        )
        .summary("draws", &r.draws.to_string())
        .summary(
            "mean of w over the reached cells",
            &format!("{} mm", fmt_g(r.w_mean_mm)),
        )
        .summary("95 % quantile of w", &format!("{} mm", fmt_g(r.w_q95_mm)))
        .summary(
            "run time",
            &format!(
                "inverse kinematics {:.2} s, evaluation {:.2} s",
                r.timings.ik_seconds, r.timings.eval_seconds
            ),
        );
    page.paragraph(
        "Each cell is a target position; inverse kinematics on the model gives the configuration \
         nearest the reference configuration, and all reached cells are evaluated on the same \
         parameter draws. Hatched cells cannot be reached with the task's orientation within the \
         joint limits.",
    );
    page.heading("Reliability over all reached cells");
    page.table(Table::new(
        "Multi-point reliability R(l_c) = Pr[w < l_c], w = max_j e_j over the reached cells, with the 95 % Wilson interval",
        &["l_c (mm)", "R (1)", "95 % interval low (1)", "95 % interval high (1)"],
        r.multi_point
            .iter()
            .map(|x| {
                vec![
                    fmt_g(x.threshold),
                    format!("{:.6}", x.r),
                    format!("{:.6}", x.ci_low),
                    format!("{:.6}", x.ci_high),
                ]
            })
            .collect(),
    ));
    page.table(Table::new(
        "Single-point reliability R_j(l_c) = Pr[e_j < l_c] across the reached cells (paper eq. 14)",
        &[
            "l_c (mm)",
            "least R_j (1)",
            "median R_j (1)",
            "cells with R_j ≥ 0.99 (count)",
        ],
        r.thresholds
            .iter()
            .enumerate()
            .map(|(t, l)| {
                let mut v: Vec<f64> = reached(r)
                    .filter_map(|c| c.stats.as_ref().map(|s| s.reliability[t].r))
                    .collect();
                v.sort_by(f64::total_cmp);
                vec![
                    fmt_g(*l),
                    format!("{:.6}", v.first().copied().unwrap_or(0.0)),
                    format!("{:.6}", v.get(v.len() / 2).copied().unwrap_or(0.0)),
                    format!(
                        "{} of {}",
                        v.iter().filter(|&&x| x >= 0.99).count(),
                        v.len()
                    ),
                ]
            })
            .collect(),
    ));
    page.heading("Heat maps");
    for (name, svg) in &svgs {
        let (desc, body) = split_text_alternative(svg);
        let mut f = Figure::from_svg(name, &body, &desc);
        f.svg = body;
        page.figure(f);
    }
    for (n, v) in settings {
        page.setting(n, v);
    }
    let q = r.spec.reference_q_deg.map(fmt_g).join(", ");
    page.setting("seed", &r.seed.to_string())
        .setting(
            "thresholds",
            &format!(
                "{} mm",
                r.thresholds
                    .iter()
                    .map(|l| fmt_g(*l))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        )
        .setting("reference configuration", &format!("{q} deg"))
        .setting("inverse-kinematics seeds", &r.spec.ik_seeds.to_string())
        .setting(
            "workspace box",
            &format!(
                "centre ({}) mm, edges ({}) mm",
                r.spec.workspace.center.map(fmt_g).join(", "),
                r.spec.workspace.size.map(fmt_g).join(", ")
            ),
        );
    page.backend(&r.backend);
    page.link(HTML_JSON, "every cell and the settings as JSON");
    page.link(CSV_NAME, "one row per cell as CSV");
    files.push((super::html::pages::INDEX.to_string(), page.render()));
    files
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colour_scale_ends() {
        assert_eq!(colour(0.0), "#440154");
        assert_eq!(colour(1.0), "#fde725");
        assert_eq!(colour(f64::NAN), "#440154");
        assert_eq!(colour(0.5), "#21908d");
    }

    #[test]
    fn names_per_layer() {
        assert_eq!(svg_names(1), ["map_e95.svg", "map_r.svg"]);
        let v = svg_names(12);
        assert_eq!(v.len(), 24);
        assert_eq!(v[2], "map_e95_z01.svg");
    }
}
