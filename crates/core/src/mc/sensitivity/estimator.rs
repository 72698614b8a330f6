//! The generic pick-freeze core: any model of independent inputs, evaluated chunk by chunk on
//! the matrices A, B and A_B^(S), then the Saltelli/Jansen estimates with bootstrap intervals.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::bootstrap::{self, summarise, Bootstrap, Ranks, Replicate};
use super::{SensitivityError, SensitivityOptions, B_DRAW_OFFSET};

/// Fewest rows of A and B on each side of a threshold below which an exceedance's indices get
/// a note: the indicator's variance then has a relative standard error above 1/√100 = 10 %.
pub const MIN_EVENTS: usize = 100;

/// Two-sided level of the bootstrap intervals.
pub const CONFIDENCE: f64 = 0.95;

/// A named set of inputs whose joint (closed) first-order and total indices are wanted.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct InputGroup {
    /// How reports name the group, e.g. `joint 2` or `lengths a/d`.
    pub name: String,
    /// 0-based input columns in the group.
    pub members: Vec<usize>,
}

/// One estimate with its bootstrap spread.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Estimate {
    /// The estimate from all N base samples.
    pub value: f64,
    /// Lower end of the 95 % percentile bootstrap interval (`None` when fewer than two
    /// resamples had a nonzero variance).
    pub ci_low: Option<f64>,
    /// Upper end of the 95 % percentile bootstrap interval.
    pub ci_high: Option<f64>,
    /// Standard deviation of the bootstrap replicates (a standard error of `value`).
    pub std_error: Option<f64>,
}

/// First-order and total index of one input or group.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SobolIndex {
    /// Input or group name.
    pub name: String,
    /// Names of the inputs it covers (one for a single input).
    pub members: Vec<String>,
    /// First-order (closed, for a group) index `S = V[E(Y|X_S)] / V(Y)` (Saltelli 2010).
    pub first_order: Estimate,
    /// Total index `S_T = E[V(Y|X_~S)] / V(Y)` (Jansen).
    pub total: Estimate,
}

/// Which function of the model output the indices describe.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Quantity {
    /// The output itself.
    Value,
    /// The indicator `1[y ≥ threshold]`.
    Exceedance {
        /// The threshold, in the output's unit.
        threshold: f64,
    },
}

/// The indices of one quantity.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct QuantityIndices {
    /// What was analysed.
    pub quantity: Quantity,
    /// Mean of the quantity over the 2N rows of A and B (for an exceedance: its probability).
    pub mean: f64,
    /// Variance of the quantity over the 2N rows of A and B.
    pub variance: f64,
    /// Bootstrap resamples with a nonzero variance, out of the requested count.
    pub bootstrap_valid: usize,
    /// Per input, ranked by decreasing total index. Empty when the variance is zero.
    pub inputs: Vec<SobolIndex>,
    /// Per group, ranked by decreasing total index. Empty when the variance is zero.
    pub groups: Vec<SobolIndex>,
    /// Why there are no indices, when there are none, or why they are unreliable (an
    /// exceedance with fewer than [`MIN_EVENTS`] rows on one side of its threshold).
    pub note: Option<String>,
}

/// Everything the generic estimator computed.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SobolAnalysis {
    /// Base samples N (rows of A and of B).
    pub draws: usize,
    /// Number of inputs D.
    pub dimension: usize,
    /// Pick-freeze matrices A_B^(S) evaluated beyond A and B: D for the inputs plus one per
    /// group whose member set is not already one of them.
    pub pick_freeze_matrices: usize,
    /// Model evaluations, `N · (2 + pick_freeze_matrices)`; `N · (D + 2)` without groups.
    pub evaluations: u64,
    /// Bootstrap resamples requested.
    pub bootstrap_resamples: usize,
    /// Seed of the bootstrap resampling.
    pub bootstrap_seed: u64,
    /// Level of the intervals (0.95).
    pub confidence: f64,
    /// The output first, then one exceedance indicator per threshold.
    pub quantities: Vec<QuantityIndices>,
}

/// Which matrix column sets are evaluated, and which set each input and group uses.
struct Plan {
    /// Member columns of each evaluated A_B^(S), inputs first.
    sets: Vec<Vec<usize>>,
    /// Index into `sets` of each group.
    group_set: Vec<usize>,
}

impl Plan {
    fn new(dim: usize, groups: &[InputGroup]) -> Result<Plan, SensitivityError> {
        let mut sets: Vec<Vec<usize>> = (0..dim).map(|i| vec![i]).collect();
        let mut group_set = Vec::with_capacity(groups.len());
        for g in groups {
            let mut m = g.members.clone();
            m.sort_unstable();
            m.dedup();
            if m.is_empty() || m[m.len() - 1] >= dim {
                return Err(SensitivityError::Design(format!(
                    "group {}: members must be a non-empty subset of the {dim} inputs",
                    g.name
                )));
            }
            let at = match sets.iter().position(|s| *s == m) {
                Some(at) => at,
                None => {
                    sets.push(m);
                    sets.len() - 1
                }
            };
            group_set.push(at);
        }
        Ok(Plan { sets, group_set })
    }
}

/// Model outputs on A, B and every A_B^(S), in base-sample order (of all base samples, or of
/// a range of them in a shard).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Outputs {
    /// Outputs on the rows of A.
    pub a: Vec<f64>,
    /// Outputs on the rows of B.
    pub b: Vec<f64>,
    /// Outputs on the rows of each A_B^(S), in the order the design evaluates the sets.
    pub sets: Vec<Vec<f64>>,
}

/// Sobol indices of a model of `names.len()` independent inputs (see the module docs).
///
/// * `draw(k, row)` writes input row `k` of the design: matrix A's row `k` is `draw(k)`, B's is
///   `draw(B_DRAW_OFFSET + k)`, so the inputs must be a pure function of `k` (counter-based).
/// * `model(rows)` gets `n × D` row-major inputs and returns the `n` outputs.
///
/// Rows are built and evaluated `opts.chunk` base samples at a time (`chunk · (2 + S)` rows per
/// `model` call, S the pick-freeze matrices), so memory holds the inputs of one chunk and the
/// `N · (2 + S)` outputs. `opts.thresholds` add the exceedance indicators of the output.
///
/// # Errors
///
/// [`SensitivityError::Setting`] for an option out of range, [`SensitivityError::Design`] for no
/// inputs or a group that is not a non-empty subset of them, [`SensitivityError::ModelOutput`] when
/// `model` returns the wrong number of outputs, [`SensitivityError::NonFinite`] for an output that
/// is not finite, and any error `model` returns.
pub fn pick_freeze<S, F>(
    names: &[String],
    groups: &[InputGroup],
    draw: S,
    model: F,
    opts: &SensitivityOptions,
) -> Result<SobolAnalysis, SensitivityError>
where
    S: Fn(u64, &mut [f64]) + Sync,
    F: FnMut(&[f64]) -> Result<Vec<f64>, SensitivityError>,
{
    let out = pick_freeze_outputs(names.len(), groups, draw, model, opts, 0..opts.draws)?;
    analyse_outputs(names, groups, &out, opts)
}

/// The outputs of base samples `range` (of `opts.draws`) of the design of [`pick_freeze`] with
/// `dim` inputs: what a shard of the analysis evaluates. [`analyse_outputs`] takes the
/// outputs of all base samples, in order.
///
/// # Errors
///
/// As [`pick_freeze_chunks`]; and any error `model` returns.
pub fn pick_freeze_outputs<S, F>(
    dim: usize,
    groups: &[InputGroup],
    draw: S,
    mut model: F,
    opts: &SensitivityOptions,
    range: std::ops::Range<usize>,
) -> Result<Outputs, SensitivityError>
where
    S: Fn(u64, &mut [f64]) + Sync,
    F: FnMut(&[f64]) -> Result<Vec<f64>, SensitivityError>,
{
    let model_rows = |k0: usize, c: usize, sets: &[Vec<usize>]| {
        let mut rows = vec![0.0; (2 + sets.len()) * c * dim];
        let (ab, picks) = rows.split_at_mut(2 * c * dim);
        ab.par_chunks_mut(dim).enumerate().for_each(|(r, row)| {
            let k = (k0 + r % c) as u64;
            draw(if r < c { k } else { B_DRAW_OFFSET + k }, row)
        });
        let (a, b) = ab.split_at(c * dim);
        for (set, block) in sets.iter().zip(picks.chunks_mut(c * dim)) {
            block.copy_from_slice(a);
            for r in 0..c {
                for &i in set {
                    block[r * dim + i] = b[r * dim + i];
                }
            }
        }
        model(&rows)
    };
    pick_freeze_chunks(dim, groups, model_rows, opts, range)
}

/// The outputs of base samples `range` of a pick-freeze design whose rows the caller generates
/// itself (the robot's evaluators do, from the counter streams): `eval(k0, c, sets)` returns
/// the outputs of base samples `k0 … k0 + c − 1` on A, then B, then `A_B^(S)` for each column
/// set `S` of `sets` (inputs first, then the groups' sets not already among them), `c` values
/// each. Called with at most `opts.chunk` base samples at a time; the outputs are checked
/// (count, finiteness) and gathered as [`pick_freeze_outputs`] gathers them.
///
/// # Errors
///
/// [`SensitivityError::Setting`] for an option out of range, [`SensitivityError::Design`] for no
/// inputs, a bad group or a `range` that is empty or beyond `opts.draws`,
/// [`SensitivityError::ModelOutput`] when `eval` returns the wrong number of outputs,
/// [`SensitivityError::NonFinite`] naming the base sample and matrix of an output that is not
/// finite, and any error `eval` returns.
pub fn pick_freeze_chunks<F>(
    dim: usize,
    groups: &[InputGroup],
    mut eval: F,
    opts: &SensitivityOptions,
    range: std::ops::Range<usize>,
) -> Result<Outputs, SensitivityError>
where
    F: FnMut(usize, usize, &[Vec<usize>]) -> Result<Vec<f64>, SensitivityError>,
{
    opts.check()?;
    if dim == 0 {
        return Err(SensitivityError::Design("no inputs".into()));
    }
    if range.start >= range.end || range.end > opts.draws {
        return Err(SensitivityError::Design(format!(
            "base samples {range:?} must be a non-empty range within the {} base samples",
            opts.draws
        )));
    }
    let plan = Plan::new(dim, groups)?;
    let n = range.end;
    let blocks = 2 + plan.sets.len();
    let len = range.end - range.start;
    let mut out = Outputs {
        a: Vec::with_capacity(len),
        b: Vec::with_capacity(len),
        sets: vec![Vec::with_capacity(len); plan.sets.len()],
    };
    let mut k0 = range.start;
    while k0 < n {
        let c = opts.chunk.min(n - k0);
        let y = eval(k0, c, &plan.sets)?;
        if y.len() != blocks * c {
            return Err(SensitivityError::ModelOutput {
                expected: blocks * c,
                got: y.len(),
            });
        }
        if let Some(r) = y.iter().position(|v| !v.is_finite()) {
            return Err(SensitivityError::NonFinite {
                sample: (k0 + r % c) as u64,
                matrix: match r / c {
                    0 => "A".to_string(),
                    1 => "B".to_string(),
                    s => format!("A_B for inputs {:?}", plan.sets[s - 2]),
                },
                value: y[r],
            });
        }
        let mut blocks_y = y.chunks(c);
        out.a.extend_from_slice(blocks_y.next().unwrap_or_default());
        out.b.extend_from_slice(blocks_y.next().unwrap_or_default());
        for (s, yb) in out.sets.iter_mut().zip(blocks_y) {
            s.extend_from_slice(yb);
        }
        k0 += c;
    }
    Ok(out)
}

/// The indices from the outputs of all `opts.draws` base samples ([`pick_freeze_outputs`],
/// concatenated in base-sample order when evaluated in shards): the same analysis, to the bit,
/// as one [`pick_freeze`] run.
///
/// # Errors
///
/// [`SensitivityError::Setting`] for an option out of range, [`SensitivityError::Design`] for no
/// inputs or a bad group, and [`SensitivityError::ModelOutput`] when `out` does not hold the
/// outputs of `opts.draws` base samples on every matrix.
pub fn analyse_outputs(
    names: &[String],
    groups: &[InputGroup],
    out: &Outputs,
    opts: &SensitivityOptions,
) -> Result<SobolAnalysis, SensitivityError> {
    opts.check()?;
    let dim = names.len();
    let plan = Plan::new(dim, groups)?;
    let n = opts.draws;
    let blocks = 2 + plan.sets.len();
    if out.a.len() != n
        || out.b.len() != n
        || out.sets.len() != plan.sets.len()
        || out.sets.iter().any(|s| s.len() != n)
    {
        return Err(SensitivityError::ModelOutput {
            expected: blocks * n,
            got: out.a.len() + out.b.len() + out.sets.iter().map(Vec::len).sum::<usize>(),
        });
    }
    let boot = Bootstrap::new(opts.bootstrap_seed, opts.bootstrap);
    let indices = Indices {
        plan: &plan,
        names,
        groups,
        rows: 2 * n,
    };
    let mut quantities = vec![value_indices(out, &boot, &indices)];
    quantities.extend(exceedance_indices(out, &opts.thresholds, &boot, &indices));
    Ok(SobolAnalysis {
        draws: n,
        dimension: dim,
        pick_freeze_matrices: plan.sets.len(),
        evaluations: (n * blocks) as u64,
        bootstrap_resamples: opts.bootstrap,
        bootstrap_seed: opts.bootstrap_seed,
        confidence: CONFIDENCE,
        quantities,
    })
}

/// The indices of `w`: mean and variance of A ∪ B, then the point estimates and replicates
/// of one pass per group of resamples ([`bootstrap::value`]).
fn value_indices(y: &Outputs, boot: &Bootstrap, ix: &Indices) -> QuantityIndices {
    let rows = ix.rows as f64;
    let all = || y.a.iter().chain(&y.b);
    let mean = all().sum::<f64>() / rows;
    let variance = all().map(|v| (v - mean).powi(2)).sum::<f64>() / (rows - 1.0);
    let (point, reps) = bootstrap::value(y, mean, boot);
    ix.quantity(Quantity::Value, (mean, variance), &point, 0, &reps)
}

/// The indices of the indicators `1[w ≥ l]` at every threshold `l`, in the order given. A
/// threshold at or below the least of the 2N outputs of A and B, or above the largest, gives a
/// constant indicator (no pass needed); the others are analysed together, sorted, in batches
/// whose replicates fit [`bootstrap::THRESHOLD_BATCH_BYTES`], one pass per group of resamples each.
fn exceedance_indices(
    y: &Outputs,
    thresholds: &[f64],
    boot: &Bootstrap,
    ix: &Indices,
) -> Vec<QuantityIndices> {
    let (lo, hi) =
        y.a.iter()
            .chain(&y.b)
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
                (l.min(v), h.max(v))
            });
    let mut levels: Vec<f64> = thresholds
        .iter()
        .copied()
        .filter(|&l| l > lo && l <= hi)
        .collect();
    levels.sort_by(f64::total_cmp);
    levels.dedup();
    let per_level = 16 * boot.count * ix.plan.sets.len();
    let batch = (bootstrap::THRESHOLD_BATCH_BYTES / per_level).clamp(1, bootstrap::MAX_LEVELS);
    let batches = levels.len().div_ceil(batch);
    let batch = levels.len().div_ceil(batches.max(1)).max(1);
    let mut done: Vec<Option<QuantityIndices>> = vec![None; thresholds.len()];
    for (b, chunk) in levels.chunks(batch).enumerate() {
        let ranks = Ranks::new(y, chunk);
        let (point, reps) = bootstrap::indicators(&ranks, boot);
        let hits = ranks.hits();
        let analysed: Vec<(usize, QuantityIndices)> = thresholds
            .par_iter()
            .enumerate()
            .filter_map(|(i, &threshold)| {
                let j = chunk.binary_search_by(|l| l.total_cmp(&threshold)).ok()?;
                debug_assert_eq!(levels[b * batch + j], threshold);
                let rows = ix.rows as f64;
                let m = hits[j] as f64;
                let moments = (m / rows, m * (rows - m) / rows / (rows - 1.0));
                let q = Quantity::Exceedance { threshold };
                Some((i, ix.quantity(q, moments, &point, j, &reps)))
            })
            .collect();
        for (i, q) in analysed {
            done[i] = Some(q);
        }
    }
    thresholds
        .iter()
        .zip(done)
        .map(|(&threshold, q)| {
            q.unwrap_or_else(|| {
                let mean = f64::from(u8::from(threshold <= lo));
                ix.constant(Quantity::Exceedance { threshold }, mean)
            })
        })
        .collect()
}

/// What turns the replicates into reported indices: the plan, the names, the rows of A ∪ B.
struct Indices<'a> {
    plan: &'a Plan,
    names: &'a [String],
    groups: &'a [InputGroup],
    rows: usize,
}

impl Indices<'_> {
    /// A quantity constant on all rows of A and B: no indices.
    fn constant(&self, quantity: Quantity, mean: f64) -> QuantityIndices {
        QuantityIndices {
            quantity,
            mean,
            variance: 0.0,
            bootstrap_valid: 0,
            inputs: Vec::new(),
            groups: Vec::new(),
            note: Some(format!(
                "the quantity is constant ({mean}) on all {} rows of A and B: its indices are undefined",
                self.rows
            )),
        }
    }

    /// The indices of level `j` of a quantity with `(mean, variance)` over A ∪ B, from its
    /// point estimates and replicates, ranked by total index.
    fn quantity(
        &self,
        quantity: Quantity,
        (mean, variance): (f64, f64),
        point: &Replicate,
        j: usize,
        reps: &[Replicate],
    ) -> QuantityIndices {
        let sets = self.plan.sets.len();
        let Some((first, total)) = point.level(j, sets) else {
            return self.constant(quantity, mean);
        };
        let valid = || reps.iter().filter_map(|r| r.level(j, sets));
        let mut q = QuantityIndices {
            quantity,
            mean,
            variance,
            bootstrap_valid: valid().count(),
            inputs: Vec::new(),
            groups: Vec::new(),
            note: None,
        };
        if let Quantity::Exceedance { .. } = quantity {
            let hits = (mean * self.rows as f64).round() as usize;
            let fewer = hits.min(self.rows - hits);
            if fewer < MIN_EVENTS {
                q.note = Some(format!(
                    "only {fewer} of the {} rows of A and B are on one side of the threshold: \
                     the indices rest on few events and their intervals are wide (more draws help)",
                    self.rows
                ));
            }
        }
        let index = |s: usize, name: &str, members: Vec<String>| SobolIndex {
            name: name.to_string(),
            members,
            first_order: summarise(first[s], valid().map(|r| r.0[s])),
            total: summarise(total[s], valid().map(|r| r.1[s])),
        };
        q.inputs = self
            .names
            .iter()
            .enumerate()
            .map(|(i, nm)| index(i, nm, vec![nm.clone()]))
            .collect();
        q.groups = self
            .groups
            .iter()
            .zip(&self.plan.group_set)
            .map(|(g, &s)| {
                let members = self.plan.sets[s].iter().map(|&i| self.names[i].clone());
                index(s, &g.name, members.collect())
            })
            .collect();
        rank(&mut q.inputs);
        rank(&mut q.groups);
        q
    }
}

/// Sorts by decreasing total index (ties: decreasing first order, then name).
pub fn rank(v: &mut [SobolIndex]) {
    v.sort_by(|x, y| {
        y.total
            .value
            .total_cmp(&x.total.value)
            .then(y.first_order.value.total_cmp(&x.first_order.value))
            .then(x.name.cmp(&y.name))
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn groups_reuse_equal_sets_and_reject_bad_members() {
        let g = |m: &[usize]| InputGroup {
            name: "g".into(),
            members: m.to_vec(),
        };
        let p = Plan::new(3, &[g(&[1]), g(&[2, 0]), g(&[0, 2, 2])]).unwrap();
        assert_eq!(p.sets.len(), 4);
        assert_eq!(p.group_set, [1, 3, 3]);
        assert!(Plan::new(3, &[g(&[3])]).is_err());
        assert!(Plan::new(3, &[g(&[])]).is_err());
    }

    #[test]
    fn constant_quantity_has_no_indices() {
        let y = Outputs {
            a: vec![1.0; 64],
            b: vec![1.0; 64],
            sets: vec![vec![1.0; 64]],
        };
        let opts = SensitivityOptions {
            draws: 64,
            bootstrap: 100,
            thresholds: vec![2.0, 1.0],
            ..SensitivityOptions::default()
        };
        let r = analyse_outputs(&["x".to_string()], &[], &y, &opts).unwrap();
        let moments: Vec<(f64, f64)> = r.quantities.iter().map(|q| (q.mean, q.variance)).collect();
        assert_eq!(moments, [(1.0, 0.0), (0.0, 0.0), (1.0, 0.0)]);
        for q in &r.quantities {
            assert!(q.inputs.is_empty() && q.note.is_some(), "{q:?}");
            assert_eq!(q.bootstrap_valid, 0);
        }
    }
}
