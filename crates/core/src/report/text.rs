//! The table printed on stdout.

use super::{max_relative_error, Comparison, RunReport};
use crate::mc::{McResult, Method};
use std::fmt::Write as _;

/// Renders a run for the terminal.
pub fn render(rep: &RunReport) -> String {
    let r = &rep.result;
    let mut s = String::new();
    let method = match r.method {
        Method::Mcs => "Monte Carlo (MCS)".to_string(),
        Method::Amcs => format!(
            "Adaptive Monte Carlo (AMCS, GUM S1 §7.9), δ = {} mm{}",
            fmt_g(r.numerical_tolerance.unwrap_or(f64::NAN)),
            r.ndig.map_or(String::new(), |n| format!(
                " (from u(w) with ndig = {n}, GUM S1 §7.9.2)"
            ))
        ),
    };
    let _ = writeln!(s, "{method}");
    let _ = writeln!(
        s,
        "model      {}  |  {} test points  |  reference: {}  |  seed {}",
        rep.model, rep.points, rep.reference, rep.seed
    );
    let _ = writeln!(
        s,
        "backend    {} — {} ({})",
        r.backend.backend, r.backend.adapter, r.backend.driver
    );
    for n in &rep.notes {
        let _ = writeln!(s, "note       {n}");
    }
    let status = match (r.method, r.converged) {
        (Method::Amcs, true) => "converged",
        (Method::Amcs, false) => "NOT CONVERGED (draw cap reached)",
        _ => "fixed number of draws",
    };
    let _ = writeln!(
        s,
        "draws      {}  in {} batches of {}  ({status}, {:.3} s)",
        r.draws, r.batches, r.batch_size, r.seconds
    );
    let _ = writeln!(s);
    let _ = writeln!(s, "maximum position error w = max_j e_j (mm)");
    let _ = writeln!(s, "  estimate (mean)        {:.6}", r.estimate);
    let _ = writeln!(s, "  standard uncertainty   {:.6}", r.std_uncertainty);
    let _ = writeln!(
        s,
        "  {:.0} % coverage interval [{:.6}, {:.6}]  ({:?})",
        r.settings.coverage_probability * 100.0,
        r.coverage_interval.low,
        r.coverage_interval.high,
        r.settings.interval
    );
    let _ = writeln!(s, "  min / max              {:.6} / {:.6}", r.min, r.max);
    let m = &r.moments;
    let se = &r.moment_standard_errors;
    let rows = [
        ("M1 mean    ", Some(m.mean).map(|v| format!("{v:.6}"))),
        ("M2 variance", Some(m.variance).map(|v| format!("{v:.6e}"))),
        ("M3 skewness", m.skewness.map(|v| format!("{v:.4}"))),
        ("M4 kurtosis", m.kurtosis.map(|v| format!("{v:.4}"))),
    ];
    for ((name, value), se) in rows.into_iter().zip(se) {
        // An undefined moment (zero variance) has no standard error either.
        let line = match value {
            Some(v) => format!("{v} ± {}", finite_or(*se, "n/a", |x| format!("{x:.1e}"))),
            None => NA.to_string(),
        };
        let _ = writeln!(s, "  {name}            {line}");
    }
    let _ = writeln!(s);
    let _ = writeln!(
        s,
        "reliability R(l_c) = Pr[w < l_c]   (95 % binomial confidence interval)"
    );
    for rel in &r.reliability {
        let _ = writeln!(
            s,
            "  l_c = {:<7} R = {:.6}   [{:.6}, {:.6}]",
            fmt_g(rel.threshold),
            rel.r,
            rel.ci_low,
            rel.ci_high
        );
    }
    if let Some(pp) = &r.per_point_reliability {
        let _ = writeln!(s);
        let _ = writeln!(
            s,
            "single-point reliability R_j(l_c) = Pr[e_j < l_c] (paper eq. 14)"
        );
        let head: Vec<String> = r
            .settings
            .thresholds
            .iter()
            .map(|t| format!("{:>8}", fmt_g(*t)))
            .collect();
        let _ = writeln!(s, "  point {}", head.join(""));
        for (j, row) in pp.iter().enumerate() {
            let cells: Vec<String> = row.iter().map(|x| format!("{:>8.4}", x.r)).collect();
            let _ = writeln!(s, "  {:>5} {}", j + 1, cells.join(""));
        }
    }
    if r.method == Method::Amcs {
        let _ = writeln!(s);
        let _ = writeln!(
            s,
            "convergence (2s of batch estimates, mm; stop when all ≤ δ)"
        );
        let _ = writeln!(
            s,
            "      h    draws      2s_w     2s_u(w)    2s_wlow   2s_whigh        δ"
        );
        for t in &r.trace {
            // The first batch has no spread of batch estimates yet.
            let f = t
                .fluctuation
                .map(|v| finite_or(v, "—", |x| format!("{x:.2e}")));
            let _ = writeln!(
                s,
                "  {:>5} {:>8} {:>10} {:>10} {:>10} {:>10} {:>10.2e}",
                t.h, t.draws, f[0], f[1], f[2], f[3], t.delta
            );
        }
    }
    s
}

/// Renders the MCS/AMCS comparison (the paper's Table 2 for one model).
pub fn render_comparison(c: &Comparison) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "MCS vs AMCS — {} — {} test points — seed {}",
        c.model, c.points, c.seed
    );
    for n in &c.notes {
        let _ = writeln!(s, "note: {n}");
    }
    let _ = writeln!(
        s,
        "{:<14} {:>10} {:>12} {:>9} {:>9} {:>8} {:>10} {:>10}",
        "method", "M1 (mm)", "M2 (mm²)", "M3", "M4", "MRE %", "draws", "time (s)"
    );
    let row = |s: &mut String, name: &str, r: &McResult, mre: Option<f64>| {
        let m = &r.moments;
        let mre = mre.map_or("—".to_string(), |v| {
            finite_or(v, NA, |x| format!("{x:.3}"))
        });
        let [m3, m4] = [m.skewness, m.kurtosis].map(|v| v.map_or(NA.into(), |x| format!("{x:.4}")));
        let _ = writeln!(
            s,
            "{:<14} {:>10.6} {:>12.5e} {:>9} {:>9} {:>8} {:>10} {:>10.3}",
            name, m.mean, m.variance, m3, m4, mre, r.draws, r.seconds
        );
    };
    row(&mut s, "MCS", &c.mcs, None);
    for (d, r, _) in &c.amcs {
        row(
            &mut s,
            &format!("AMCS δ={}", fmt_g(*d)),
            r,
            Some(max_relative_error(r, &c.mcs)),
        );
    }
    s
}

/// What the reports print for an undefined number (a moment of a zero-variance result).
pub const NA: &str = "n/a";

/// `f(v)` for a finite `v`, else `other`.
pub fn finite_or(v: f64, other: &str, f: impl Fn(f64) -> String) -> String {
    if v.is_finite() {
        f(v)
    } else {
        other.to_string()
    }
}

pub use crate::number::fmt_plain;

/// Short general number format (no trailing zeros).
pub fn fmt_g(v: f64) -> String {
    if v.abs() >= 1e7 || !v.is_finite() {
        return fmt_plain(v);
    }
    let v = if v.abs() < 5e-7 { 0.0 } else { v };
    let s = format!("{v:.6}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s.is_empty() || s == "-" {
        "0".into()
    } else {
        s.to_string()
    }
}
