//! SVG figures of the study, drawn with [`crate::report::svg::LinePlot`]: the PDF of w at 50 test
//! points, one curve per level of a factor (paper Fig. 4); the reliability curves R_c(l_c)
//! (Fig. 5); the convergence of the four fluctuation indices at each δ (Figs. 6–9: the paper
//! shows repeatability and step at δ = 0.01 and 0.02; we draw every factor, at the level closest
//! to the baseline).

use super::runner::StudyResult;
use super::settings::{Factor, StudySettings};
use super::tables::table2_points;
use crate::report::svg::{convergence_plot, LinePlot, Series};

/// Fig. 4 of factor `f`: the PDF of w per level.
fn pdf_name(f: Factor) -> String {
    format!("fig4_pdf_{}.svg", f.name())
}

/// Fig. 5 of factor `f`: the reliability curve per level.
fn reliability_name(f: Factor) -> String {
    format!("fig5_reliability_{}.svg", f.name())
}

/// Figs. 6–9 of factor `f` at tolerance `delta`: the AMCS convergence at the baseline level.
fn convergence_name(f: Factor, delta: f64) -> String {
    format!("fig6-9_convergence_{}_delta{delta}.svg", f.name())
}

/// The figures a study with `settings` may draw, before it runs (as [`figures`] names them).
pub fn names(settings: &StudySettings) -> Vec<String> {
    let mut out = Vec::new();
    for f in Factor::ALL {
        if !settings.factors.contains(&f) {
            continue;
        }
        out.push(pdf_name(f));
        out.push(reliability_name(f));
        out.extend(settings.deltas.iter().map(|&d| convergence_name(f, d)));
    }
    out
}

/// All figures: `(file name, svg)`.
pub fn figures(s: &StudyResult) -> Vec<(String, String)> {
    let mut out = Vec::new();
    for f in Factor::ALL {
        let levels: Vec<_> = s.levels.iter().filter(|l| l.factor == f).collect();
        if levels.is_empty() {
            continue;
        }
        let m = table2_points(levels[0]).map_or(0, |p| p.points);
        let curves = |pick: &dyn Fn(&super::runner::RunSummary) -> Vec<(f64, f64)>| {
            levels
                .iter()
                .filter_map(|l| {
                    table2_points(l).map(|p| Series {
                        name: l.level.clone(),
                        points: pick(&p.amcs[0]),
                        dashed: false,
                    })
                })
                .collect::<Vec<_>>()
        };
        out.push((
            pdf_name(f),
            LinePlot {
                title: format!("PDF of w, {m} points, AMCS-1 — factor: {}", f.name()),
                x_label: "w (mm)".into(),
                y_label: "density (1/mm)".into(),
                series: curves(&|r| r.pdf.clone()),
                log_y: false,
            }
            .render(),
        ));
        out.push((
            reliability_name(f),
            LinePlot {
                title: format!(
                    "Reliability R_c(l_c), {m} points, AMCS-1 — factor: {}",
                    f.name()
                ),
                x_label: "threshold l_c (mm)".into(),
                y_label: "R_c = Pr[w < l_c]".into(),
                series: curves(&|r| r.cdf.clone()),
                log_y: false,
            }
            .render(),
        ));
        let base = levels
            .iter()
            .find(|l| l.factors == s.settings.baseline)
            .unwrap_or(&levels[0]);
        if let Some(p) = table2_points(base) {
            for a in &p.amcs {
                let d = a.delta.unwrap_or(0.0);
                out.push((
                    convergence_name(f, d),
                    convergence_plot(
                        &format!(
                            "AMCS convergence, δ = {d} mm, {} points — {} {}",
                            p.points,
                            f.name(),
                            base.level
                        ),
                        &a.trace,
                    )
                    .render(),
                ));
            }
        }
    }
    out
}
