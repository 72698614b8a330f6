//! Minimal SVG line plots: the PDF of w (paper Fig. 4), reliability curves (Fig. 5) and the
//! convergence of the four fluctuation indices against δ (Figs. 6–9). Plain SVG 1.1 text with
//! axes, "nice" ticks, an optional log-scale y axis and a legend.

use std::fmt::Write as _;

/// One curve.
#[derive(Clone, Debug)]
pub struct Series {
    /// Legend label.
    pub name: String,
    /// `(x, y)` points, drawn in order.
    pub points: Vec<(f64, f64)>,
    /// Dashed line (e.g. a tolerance level).
    pub dashed: bool,
}

/// A plot of several series.
#[derive(Clone, Debug)]
pub struct LinePlot {
    /// Title above the plot.
    pub title: String,
    /// x-axis label.
    pub x_label: String,
    /// y-axis label.
    pub y_label: String,
    /// Curves.
    pub series: Vec<Series>,
    /// Logarithmic y axis (non-positive values are dropped).
    pub log_y: bool,
}

const W: f64 = 720.0;
const H: f64 = 450.0;
const L: f64 = 80.0;
const R: f64 = 20.0;
const T: f64 = 40.0;
const B: f64 = 60.0;
/// Series with at most this many points also get a marker at each point.
const MARKER_LIMIT: usize = 40;
pub(crate) const COLORS: [&str; 8] = [
    "#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#17becf",
];

/// A 1–2–5 step that cuts `range` into about `target` intervals.
pub(crate) fn nice_step(range: f64, target: usize) -> f64 {
    let raw = range / target as f64;
    let mag = 10f64.powf(raw.log10().floor());
    let f = raw / mag;
    let nf = if f < 1.5 {
        1.0
    } else if f < 3.0 {
        2.0
    } else if f < 7.0 {
        5.0
    } else {
        10.0
    };
    nf * mag
}

/// Escapes text content for XML.
pub(crate) fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// Opens a `width` × `height` SVG document: the XML declaration, the root element, a white
/// background and the centred title (as [`LinePlot::render`] does).
pub(crate) fn begin(s: &mut String, width: f64, height: f64, title: &str) {
    let _ = writeln!(s, r#"<?xml version="1.0" encoding="UTF-8"?>"#);
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" viewBox="0 0 {width} {height}" font-family="sans-serif" font-size="12">"#
    );
    let _ = writeln!(
        s,
        r#"<rect x="0" y="0" width="{width}" height="{height}" fill="white"/>"#
    );
    let _ = writeln!(
        s,
        r#"<text x="{}" y="24" text-anchor="middle" font-size="15">{}</text>"#,
        width / 2.0,
        esc(title)
    );
}

/// Short tick label (no trailing zeros).
pub(crate) fn tick_label(v: f64) -> String {
    super::text::fmt_g(v)
}

impl LinePlot {
    /// Renders the SVG document.
    pub fn render(&self) -> String {
        let ty = |y: f64| if self.log_y { y.log10() } else { y };
        let pts: Vec<(f64, f64)> = self
            .series
            .iter()
            .flat_map(|s| s.points.iter().copied())
            .filter(|(x, y)| x.is_finite() && y.is_finite() && (!self.log_y || *y > 0.0))
            .map(|(x, y)| (x, ty(y)))
            .collect();
        let (mut x0, mut x1, mut y0, mut y1) = (
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
        );
        for (x, y) in &pts {
            x0 = x0.min(*x);
            x1 = x1.max(*x);
            y0 = y0.min(*y);
            y1 = y1.max(*y);
        }
        if pts.is_empty() {
            (x0, x1, y0, y1) = (0.0, 1.0, 0.0, 1.0);
        }
        if x1 <= x0 {
            x1 = x0 + 1.0;
        }
        if y1 <= y0 {
            y1 = y0 + 1.0;
        }
        if self.log_y {
            y0 = y0.floor();
            y1 = y1.ceil();
        } else {
            let pad = 0.05 * (y1 - y0);
            let non_negative = y0 >= 0.0;
            y0 -= pad;
            y1 += pad;
            if non_negative && (y0 < 0.0 || y0 < 0.3 * y1) {
                y0 = 0.0;
            }
        }
        // Integer abscissae (batch numbers): keep the end points off the frame.
        let integer_x = pts.iter().all(|(x, _)| x.fract() == 0.0);
        if integer_x {
            x0 -= 0.25;
            x1 += 0.25;
        }
        let sx = |x: f64| L + (x - x0) / (x1 - x0) * (W - L - R);
        let sy = |y: f64| H - B - (y - y0) / (y1 - y0) * (H - T - B);
        let mut s = String::new();
        let _ = writeln!(s, r#"<?xml version="1.0" encoding="UTF-8"?>"#);
        let _ = writeln!(
            s,
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{H}" viewBox="0 0 {W} {H}" font-family="sans-serif" font-size="12">"#
        );
        let _ = writeln!(
            s,
            r#"<rect x="0" y="0" width="{W}" height="{H}" fill="white"/>"#
        );
        let _ = writeln!(
            s,
            r#"<text x="{}" y="24" text-anchor="middle" font-size="15">{}</text>"#,
            W / 2.0,
            esc(&self.title)
        );
        // Axes box
        let _ = writeln!(
            s,
            r#"<rect x="{L}" y="{T}" width="{}" height="{}" fill="none" stroke="black"/>"#,
            W - L - R,
            H - T - B
        );
        // x ticks
        let mut step = nice_step(x1 - x0, 8);
        if integer_x {
            step = step.max(1.0);
        }
        let mut x = (x0 / step).ceil() * step;
        while x <= x1 + 1e-9 * step {
            let px = sx(x);
            let _ = writeln!(
                s,
                r##"<line x1="{px:.1}" y1="{}" x2="{px:.1}" y2="{}" stroke="#ddd"/>"##,
                T,
                H - B
            );
            let _ = writeln!(
                s,
                r#"<text x="{px:.1}" y="{}" text-anchor="middle">{}</text>"#,
                H - B + 16.0,
                super::text::fmt_g(x)
            );
            x += step;
        }
        // y ticks
        if self.log_y {
            let mut e = y0 as i32;
            while f64::from(e) <= y1 {
                let py = sy(f64::from(e));
                let _ = writeln!(
                    s,
                    r##"<line x1="{L}" y1="{py:.1}" x2="{}" y2="{py:.1}" stroke="#ddd"/>"##,
                    W - R
                );
                let _ = writeln!(
                    s,
                    r#"<text x="{}" y="{:.1}" text-anchor="end">1e{e}</text>"#,
                    L - 6.0,
                    py + 4.0
                );
                e += 1;
            }
        } else {
            let step = nice_step(y1 - y0, 6);
            let mut y = (y0 / step).ceil() * step;
            while y <= y1 + 1e-9 * step {
                let py = sy(y);
                let _ = writeln!(
                    s,
                    r##"<line x1="{L}" y1="{py:.1}" x2="{}" y2="{py:.1}" stroke="#ddd"/>"##,
                    W - R
                );
                let _ = writeln!(
                    s,
                    r#"<text x="{}" y="{:.1}" text-anchor="end">{}</text>"#,
                    L - 6.0,
                    py + 4.0,
                    super::text::fmt_g(y)
                );
                y += step;
            }
        }
        let _ = writeln!(
            s,
            r#"<text x="{}" y="{}" text-anchor="middle">{}</text>"#,
            (L + W - R) / 2.0,
            H - 18.0,
            esc(&self.x_label)
        );
        let _ = writeln!(
            s,
            r#"<text x="18" y="{}" text-anchor="middle" transform="rotate(-90 18 {})">{}</text>"#,
            (T + H - B) / 2.0,
            (T + H - B) / 2.0,
            esc(&self.y_label)
        );
        let legend_h = 16.0 * self.series.len() as f64 + 8.0;
        let _ = writeln!(
            s,
            r##"<rect x="{}" y="{}" width="196" height="{legend_h}" fill="white" fill-opacity="0.85" stroke="#bbb"/>"##,
            W - R - 206.0,
            T + 4.0
        );
        for (i, ser) in self.series.iter().enumerate() {
            let color = COLORS[i % COLORS.len()];
            let path: Vec<String> = ser
                .points
                .iter()
                .filter(|(x, y)| x.is_finite() && y.is_finite() && (!self.log_y || *y > 0.0))
                .map(|&(x, y)| format!("{:.2},{:.2}", sx(x), sy(ty(y))))
                .collect();
            if !path.is_empty() {
                let dash = if ser.dashed {
                    r#" stroke-dasharray="6,4""#
                } else {
                    ""
                };
                let _ = writeln!(
                    s,
                    r#"<polyline fill="none" stroke="{color}" stroke-width="1.6"{dash} points="{}"/>"#,
                    path.join(" ")
                );
            }
            if !ser.dashed && path.len() <= MARKER_LIMIT {
                for p in &path {
                    let (cx, cy) = p.split_once(',').unwrap_or(("0", "0"));
                    let _ = writeln!(s, r#"<circle cx="{cx}" cy="{cy}" r="3" fill="{color}"/>"#);
                }
            }
            let ly = T + 16.0 + 16.0 * i as f64;
            let lx = W - R - 200.0;
            let _ = writeln!(
                s,
                r#"<line x1="{lx}" y1="{ly}" x2="{}" y2="{ly}" stroke="{color}" stroke-width="2"/>"#,
                lx + 24.0
            );
            let _ = writeln!(
                s,
                r#"<text x="{}" y="{}">{}</text>"#,
                lx + 30.0,
                ly + 4.0,
                esc(&ser.name)
            );
        }
        let _ = writeln!(s, "</svg>");
        s
    }
}

/// The PDF of w.
pub(crate) const PDF_SVG: &str = "pdf.svg";
/// The reliability curve.
pub(crate) const RELIABILITY_SVG: &str = "reliability.svg";
/// The AMCS convergence.
const CONVERGENCE_SVG: &str = "convergence.svg";

/// The plots of a run, in the order [`run_plots`] draws them (convergence for AMCS only).
pub const RUN_PLOTS: [&str; 3] = [PDF_SVG, RELIABILITY_SVG, CONVERGENCE_SVG];

/// The plots of a comparison: PDF and reliability of MCS and each AMCS run, overlaid.
pub const COMPARISON_PLOTS: [&str; 2] = [PDF_SVG, RELIABILITY_SVG];

/// PDF, reliability curve and (AMCS) convergence plots of one run: `(file name, svg)`.
pub fn run_plots(rep: &super::RunReport) -> Vec<(String, String)> {
    use crate::mc::stats::{ecdf_grid, histogram};
    let r = &rep.result;
    let label = format!("{} points", rep.points);
    let mut out = vec![
        (
            PDF_SVG.to_string(),
            LinePlot {
                title: format!("PDF of the maximum position error w — {}", rep.model),
                x_label: "w (mm)".into(),
                y_label: "density (1/mm)".into(),
                series: vec![Series {
                    name: label.clone(),
                    points: histogram(&r.sorted_values, 100),
                    dashed: false,
                }],
                log_y: false,
            }
            .render(),
        ),
        (
            RELIABILITY_SVG.to_string(),
            LinePlot {
                title: format!("Positioning accuracy reliability R(l_c) — {}", rep.model),
                x_label: "threshold l_c (mm)".into(),
                y_label: "R = Pr[w < l_c]".into(),
                series: vec![Series {
                    name: label,
                    points: ecdf_grid(&r.sorted_values, 400),
                    dashed: false,
                }],
                log_y: false,
            }
            .render(),
        ),
    ];
    if !r.trace.is_empty() {
        out.push((
            CONVERGENCE_SVG.to_string(),
            convergence_plot(&format!("AMCS convergence — {}", rep.model), &r.trace).render(),
        ));
    }
    out
}

/// The four fluctuation indices of an AMCS trace against h, with δ dashed.
pub fn convergence_plot(title: &str, trace: &[crate::mc::BatchTrace]) -> LinePlot {
    let names = ["2s of mean w", "2s of u(w)", "2s of w_low", "2s of w_high"];
    let mut series: Vec<Series> = (0..4)
        .map(|k| Series {
            name: names[k].into(),
            points: trace
                .iter()
                .filter(|t| t.h >= 2)
                .map(|t| (t.h as f64, t.fluctuation[k]))
                .collect(),
            dashed: false,
        })
        .collect();
    series.push(Series {
        name: "δ".into(),
        points: trace.iter().map(|t| (t.h as f64, t.delta)).collect(),
        dashed: true,
    });
    LinePlot {
        title: title.into(),
        x_label: "batch h".into(),
        y_label: "mm".into(),
        series,
        log_y: true,
    }
}
