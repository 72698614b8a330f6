//! Reports of a tail-probability run ([`TailResult`]): a table for the terminal, the estimates
//! as CSV, and JSON (the result's own serde form).

use crate::mc::tail::{TailMethod, TailOutcome, TailResult};
use std::fmt::Write;

fn opt(x: Option<f64>, f: impl Fn(f64) -> String) -> String {
    x.map(f).unwrap_or_else(|| "n/a".into())
}

/// The terminal table: P_f, its coefficient of variation and β per threshold, then the levels of
/// the last subset-simulation run.
pub fn render_text(r: &TailResult) -> String {
    let mut s = String::new();
    let method = match r.method {
        TailMethod::Subset => "subset simulation (modified Metropolis; CoV after Au & Beck)",
        TailMethod::MonteCarlo => "crude Monte Carlo",
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
            e.threshold,
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
