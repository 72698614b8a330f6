//! The heat maps of a map: per plane (layer) of cells, the 95 % quantile of the point error and
//! the single-point reliability at the first threshold, in the viridis colour map, unreachable
//! cells hatched, the robot's base marked.

use super::{at, svg_names, CellValue, AXIS};
use crate::map::{MapCell, MapResult};
use crate::report::svg::{esc, nice_step, tick_label};
use crate::report::text::fmt_g;
use std::fmt::Write as _;

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
    // The base frame's origin, projected onto the plane.
    let base_h = r.base_origin_mm[axes[0]];
    let base_v = r.base_origin_mm[axes[1]];
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
    // The base frame's origin, projected onto the plane.
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
}
