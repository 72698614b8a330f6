//! Where a summary or shard comes from ([`Provenance`]), and the check that named parts are one
//! run's ranges, tiling it exactly once ([`in_range_order`]).

use super::fnv::Fnv;
use super::SummaryError;
use crate::engine::Problem;
use serde::{Deserialize, Serialize};

/// Where a summary comes from: a merge accepts only summaries whose provenance agrees apart
/// from the draw range.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Provenance {
    /// Version of the tool that wrote the summary.
    pub version: String,
    /// Model name.
    pub model: String,
    /// FNV-1a hash of the model's TOML text, hex.
    pub model_hash: String,
    /// What the errors are measured from (e.g. "calibrated model").
    pub reference: String,
    /// Number of test points.
    pub points: usize,
    /// FNV-1a hash of the test points and their reference positions, hex.
    pub points_hash: String,
    /// Seed of the parameter draws.
    pub seed: u64,
    /// Draws of the whole run.
    pub draws: u64,
    /// First draw of this summary.
    pub first: u64,
    /// One past the last draw of this summary.
    pub end: u64,
}

impl Provenance {
    /// The provenance of draws `[first, end)` of a run of `draws` draws of `problem`, whose
    /// errors are measured from `reference` (a label for the reports).
    pub fn new(problem: &Problem, reference: &str, draws: u64, first: u64, end: u64) -> Provenance {
        let mut h = Fnv::new();
        for q in &problem.points {
            q.iter().for_each(|x| h.write(&x.to_le_bytes()));
        }
        for r in &problem.reference {
            r.iter().for_each(|x| h.write(&x.to_le_bytes()));
        }
        // The model as drawn: a discrepancy term the run leaves out is not part of it, so
        // shards with and without the term never merge.
        let mut drawn = problem.model.clone();
        if problem.discrepancy.is_none() {
            drawn.discrepancy = None;
        }
        let mut mh = Fnv::new();
        mh.write(drawn.to_toml().as_bytes());
        Provenance {
            version: env!("CARGO_PKG_VERSION").to_string(),
            model: problem.model.name.clone(),
            model_hash: mh.hex(),
            reference: reference.to_string(),
            points: problem.n_points(),
            points_hash: h.hex(),
            seed: problem.seed,
            draws,
            first,
            end,
        }
    }
}

/// `named` in draw order, after checking that they are parts of one run: provenance (apart
/// from the range) and `settings` agree with the first's, and the ranges tile `[0, draws)`.
pub(super) fn in_draw_order<T>(
    named: &[(String, T)],
    provenance: impl Fn(&T) -> &Provenance,
    settings: impl Fn(&T) -> Vec<(&'static str, String)>,
) -> Result<Vec<(&str, &T)>, SummaryError> {
    in_range_order(
        named,
        "draws",
        |s| {
            let p = provenance(s);
            (p.first, p.end, p.draws)
        },
        |s| {
            let mut v = provenance_fields(provenance(s));
            v.extend(settings(s));
            v
        },
    )
}

/// The fields of a provenance that every part of one run shares, by name (all but the range).
pub(crate) fn provenance_fields(p: &Provenance) -> Vec<(&'static str, String)> {
    vec![
        ("version", p.version.clone()),
        ("model", p.model.clone()),
        ("model_hash", p.model_hash.clone()),
        ("reference", p.reference.clone()),
        ("points", p.points.to_string()),
        ("points_hash", p.points_hash.clone()),
        ("seed", p.seed.to_string()),
        ("draws", p.draws.to_string()),
    ]
}

/// `named` in the order of their ranges, after checking that they are parts of one run:
/// `fields` agree with the first's, and the ranges (`range` gives first, end and the total, in
/// `unit`s) tile `[0, total)`.
pub(crate) fn in_range_order<'a, T>(
    named: &'a [(String, T)],
    unit: &'static str,
    range: impl Fn(&T) -> (u64, u64, u64),
    fields: impl Fn(&T) -> Vec<(&'static str, String)>,
) -> Result<Vec<(&'a str, &'a T)>, SummaryError> {
    let mut order: Vec<(&str, &T)> = named.iter().map(|(f, s)| (f.as_str(), s)).collect();
    order.sort_by_key(|(_, s)| {
        let (a, b, _) = range(s);
        (a, b)
    });
    let Some(&(first_file, first)) = order.first() else {
        return Err(SummaryError::Empty);
    };
    let expected = fields(first);
    let mut covered = 0;
    for &(file, s) in &order {
        let mismatch = expected.iter().zip(fields(s)).find(|(x, y)| x.1 != y.1);
        if let Some(((field, want), (_, found))) = mismatch {
            return Err(SummaryError::Mismatch {
                file: file.to_string(),
                field,
                found,
                first_file: first_file.to_string(),
                expected: want.clone(),
            });
        }
        let (a, b, _) = range(s);
        if a != covered {
            let problem = if a < covered {
                format!("overlap {unit} before {covered} of another summary")
            } else {
                format!("leave {unit} [{covered}, {a}) missing")
            };
            return Err(SummaryError::Range {
                file: file.to_string(),
                unit,
                first: a,
                end: b,
                problem,
            });
        }
        covered = b;
    }
    let (_, _, total) = range(first);
    if covered != total {
        let (file, s) = order[order.len() - 1];
        let (a, b, _) = range(s);
        return Err(SummaryError::Range {
            file: file.to_string(),
            unit,
            first: a,
            end: b,
            problem: format!("leave {unit} [{covered}, {total}) missing"),
        });
    }
    Ok(order)
}
