//! CSV files of a run: the reliability curve (CDF of w on a fine grid), the PDF (histogram),
//! the reliability at the thresholds, the AMCS convergence trace and the single-point
//! reliabilities.

use super::RunReport;
use crate::mc::stats::{ecdf_grid, histogram};
use std::fmt::Write as _;

/// Points of the CDF grid.
pub const CDF_POINTS: usize = 1001;
/// Bins of the histogram.
pub const PDF_BINS: usize = 200;

const CDF: &str = "cdf.csv";
const PDF: &str = "pdf.csv";
const RELIABILITY: &str = "reliability.csv";
const TRACE: &str = "trace.csv";
const PER_POINT: &str = "per_point.csv";

/// The files of a run, in the order [`files`] writes them: the CDF, the PDF, the reliability at
/// the thresholds, the AMCS trace (AMCS only) and the single-point reliabilities (when asked for).
pub const NAMES: [&str; 5] = [CDF, PDF, RELIABILITY, TRACE, PER_POINT];

/// CSV of a header and rows (cells quoted when needed).
pub fn table(header: &[String], rows: &[Vec<String>]) -> String {
    let q = |c: &String| {
        if c.contains([',', '"', '\n']) {
            format!("\"{}\"", c.replace('"', "\"\""))
        } else {
            c.clone()
        }
    };
    let mut s = header.iter().map(q).collect::<Vec<_>>().join(",");
    s.push('\n');
    for r in rows {
        s.push_str(&r.iter().map(q).collect::<Vec<_>>().join(","));
        s.push('\n');
    }
    s
}

/// `(file name, contents)` for every CSV of a run.
pub fn files(rep: &RunReport) -> Vec<(String, String)> {
    let r = &rep.result;
    let mut out = Vec::new();
    let mut s = String::from("w_mm,cdf\n");
    for (x, f) in ecdf_grid(&r.sorted_values, CDF_POINTS) {
        let _ = writeln!(s, "{x:.9},{f:.9}");
    }
    out.push((CDF.to_string(), s));
    let mut s = String::from("w_mm,density_per_mm\n");
    for (x, d) in histogram(&r.sorted_values, PDF_BINS) {
        let _ = writeln!(s, "{x:.9},{d:.9}");
    }
    out.push((PDF.to_string(), s));
    let mut s = String::from("threshold_mm,reliability,ci_low,ci_high\n");
    for x in &r.reliability {
        let _ = writeln!(
            s,
            "{},{:.9},{:.9},{:.9}",
            x.threshold, x.r, x.ci_low, x.ci_high
        );
    }
    out.push((RELIABILITY.to_string(), s));
    if !r.trace.is_empty() {
        let mut s = String::from(
            "h,draws,mean,std_uncertainty,low,high,two_s_mean,two_s_u,two_s_low,two_s_high,delta\n",
        );
        for t in &r.trace {
            let f = t.fluctuation.map(|v| {
                if v.is_nan() {
                    String::new()
                } else {
                    format!("{v:.9e}")
                }
            });
            let _ = writeln!(
                s,
                "{},{},{:.9},{:.9},{:.9},{:.9},{},{},{},{},{:.9e}",
                t.h,
                t.draws,
                t.mean,
                t.std_uncertainty,
                t.low,
                t.high,
                f[0],
                f[1],
                f[2],
                f[3],
                t.delta
            );
        }
        out.push((TRACE.to_string(), s));
    }
    if let Some(pp) = &r.per_point_reliability {
        let mut s = String::from("point,threshold_mm,reliability,ci_low,ci_high\n");
        for (j, row) in pp.iter().enumerate() {
            for x in row {
                let _ = writeln!(
                    s,
                    "{},{},{:.9},{:.9},{:.9}",
                    j + 1,
                    x.threshold,
                    x.r,
                    x.ci_low,
                    x.ci_high
                );
            }
        }
        out.push((PER_POINT.to_string(), s));
    }
    out
}
