//! Reports of a Sobol sensitivity analysis ([`SensitivityResult`]): a ranked table for the
//! terminal, the indices as CSV, and JSON (the result's own serde form).

use crate::mc::sensitivity::{Estimate, Quantity, QuantityIndices, SensitivityResult, SobolIndex};
use std::fmt::Write;

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
            format!("failure indicator 1[w ≥ {threshold} mm]: P = {:.6}", q.mean)
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
