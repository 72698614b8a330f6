//! The generic pick-freeze core: any model of independent inputs, evaluated chunk by chunk on
//! the matrices A, B and A_B^(S), then the Saltelli/Jansen estimates with bootstrap intervals.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::{SensitivityError, SensitivityOptions, B_DRAW_OFFSET};
use crate::sampling::Philox;

/// Philox stream of the bootstrap resampling indices (the parameter draws use stream 0).
const BOOTSTRAP_STREAM: u32 = 0x50b1;

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

impl Quantity {
    /// The quantity of model output `y`.
    #[inline]
    fn of(self, y: f64) -> f64 {
        match self {
            Quantity::Value => y,
            Quantity::Exceedance { threshold } => f64::from(u8::from(y >= threshold)),
        }
    }
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
    let boot = Bootstrap {
        gen: Philox::new(opts.bootstrap_seed),
        count: opts.bootstrap,
    };
    let quantities = std::iter::once(Quantity::Value)
        .chain(
            opts.thresholds
                .iter()
                .map(|&threshold| Quantity::Exceedance { threshold }),
        )
        .map(|q| analyse(q, out, &boot, &plan, names, groups))
        .collect();
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

/// The bootstrap resamples: generated on demand from the seed, so only the resamples in
/// flight (one per thread) are held in memory.
struct Bootstrap {
    gen: Philox,
    count: usize,
}

impl Bootstrap {
    /// Resample `r`: base sample `p_k` drawn uniformly from `0 … n − 1` (n a power of 2) as the
    /// top `log2 n` bits of Philox word `k` of resample `r`, so it depends only on the seed.
    fn indices(&self, r: usize, n: usize) -> Vec<u32> {
        let shift = 32 - n.trailing_zeros();
        let mut idx = Vec::with_capacity(n + 3);
        for blk in 0..n.div_ceil(4) {
            let w = self.gen.block(r as u64, blk as u32, BOOTSTRAP_STREAM);
            idx.extend(w.iter().map(|&x| x.checked_shr(shift).unwrap_or(0)));
        }
        idx.truncate(n);
        idx
    }
}

/// First-order and total indices of every set from the rows `pick` (all rows when `None`):
/// `None` when the variance of those rows is zero.
fn estimate(y: &Outputs, q: Quantity, pick: Option<&[u32]>) -> Option<(Vec<f64>, Vec<f64>)> {
    let n = y.a.len();
    let row = |k: usize| pick.map_or(k, |p| p[k] as usize);
    let (fa, fb) = (|k: usize| q.of(y.a[row(k)]), |k: usize| q.of(y.b[row(k)]));
    let mean = (0..n).map(|k| fa(k) + fb(k)).sum::<f64>() / (2 * n) as f64;
    let ss: f64 = (0..n)
        .map(|k| (fa(k) - mean).powi(2) + (fb(k) - mean).powi(2))
        .sum();
    let var = ss / (2 * n - 1) as f64;
    if var.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return None;
    }
    let (first, total) = y
        .sets
        .iter()
        .map(|s| {
            let (mut f, mut t) = (0.0, 0.0);
            for k in 0..n {
                let (a, b, ab) = (fa(k), fb(k), q.of(s[row(k)]));
                f += (b - mean) * (ab - a);
                t += (a - ab) * (a - ab);
            }
            (f / n as f64 / var, t / (2 * n) as f64 / var)
        })
        .unzip();
    Some((first, total))
}

/// The mean and variance of a quantity over the rows of A and B.
fn mean_variance(y: &Outputs, q: Quantity) -> (f64, f64) {
    let n = (2 * y.a.len()) as f64;
    let all = || y.a.iter().chain(&y.b).map(|&v| q.of(v));
    let mean = all().sum::<f64>() / n;
    let var = all().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, var)
}

/// Point estimate and percentile interval of one index from its replicates.
fn summarise(value: f64, mut reps: Vec<f64>) -> Estimate {
    if reps.len() < 2 {
        return Estimate {
            value,
            ci_low: None,
            ci_high: None,
            std_error: None,
        };
    }
    reps.sort_by(f64::total_cmp);
    let q = |p: f64| reps[((p * (reps.len() - 1) as f64).round() as usize).min(reps.len() - 1)];
    let m = reps.iter().sum::<f64>() / reps.len() as f64;
    let sd = (reps.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (reps.len() - 1) as f64).sqrt();
    let tail = (1.0 - CONFIDENCE) / 2.0;
    Estimate {
        value,
        ci_low: Some(q(tail)),
        ci_high: Some(q(1.0 - tail)),
        std_error: Some(sd),
    }
}

/// Indices of one quantity with bootstrap intervals, ranked by total index.
fn analyse(
    quantity: Quantity,
    y: &Outputs,
    boot: &Bootstrap,
    plan: &Plan,
    names: &[String],
    groups: &[InputGroup],
) -> QuantityIndices {
    let (mean, variance) = mean_variance(y, quantity);
    let mut q = QuantityIndices {
        quantity,
        mean,
        variance,
        bootstrap_valid: 0,
        inputs: Vec::new(),
        groups: Vec::new(),
        note: None,
    };
    let Some((first, total)) = estimate(y, quantity, None) else {
        q.note = Some(format!(
            "the quantity is constant ({mean}) on all {} rows of A and B: its indices are undefined",
            2 * y.a.len()
        ));
        return q;
    };
    let n = y.a.len();
    let reps: Vec<(Vec<f64>, Vec<f64>)> = (0..boot.count)
        .into_par_iter()
        .filter_map(|r| estimate(y, quantity, Some(&boot.indices(r, n))))
        .collect();
    q.bootstrap_valid = reps.len();
    if let Quantity::Exceedance { .. } = quantity {
        let rows = 2 * y.a.len();
        let hits = (mean * rows as f64).round() as usize;
        let fewer = hits.min(rows - hits);
        if fewer < MIN_EVENTS {
            q.note = Some(format!(
                "only {fewer} of the {rows} rows of A and B are on one side of the threshold: \
                 the indices rest on few events and their intervals are wide (more draws help)"
            ));
        }
    }
    let index = |s: usize, name: &str, members: Vec<String>| SobolIndex {
        name: name.to_string(),
        members,
        first_order: summarise(first[s], reps.iter().map(|r| r.0[s]).collect()),
        total: summarise(total[s], reps.iter().map(|r| r.1[s]).collect()),
    };
    q.inputs = names
        .iter()
        .enumerate()
        .map(|(i, nm)| index(i, nm, vec![nm.clone()]))
        .collect();
    q.groups = groups
        .iter()
        .zip(&plan.group_set)
        .map(|(g, &s)| {
            index(
                s,
                &g.name,
                plan.sets[s].iter().map(|&i| names[i].clone()).collect(),
            )
        })
        .collect();
    rank(&mut q.inputs);
    rank(&mut q.groups);
    q
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
    fn bootstrap_indices_are_uniform_and_seeded() {
        let all = |seed| {
            let b = Bootstrap {
                gen: Philox::new(seed),
                count: 200,
            };
            (0..b.count).map(|r| b.indices(r, 64)).collect::<Vec<_>>()
        };
        let a = all(9);
        assert_eq!(a, all(9));
        assert_ne!(a, all(10));
        let mut counts = [0u32; 64];
        for r in &a {
            assert_eq!(r.len(), 64);
            for &k in r {
                counts[k as usize] += 1;
            }
        }
        // 12 800 picks, 200 per index expected, binomial sd ≈ 14: all within 6 sd.
        assert!(
            counts
                .iter()
                .all(|&c| (c as f64 - 200.0).abs() < 6.0 * 14.0),
            "{counts:?}"
        );
    }

    #[test]
    fn constant_quantity_has_no_indices() {
        let y = Outputs {
            a: vec![1.0; 8],
            b: vec![1.0; 8],
            sets: vec![vec![1.0; 8]],
        };
        assert!(estimate(&y, Quantity::Value, None).is_none());
        let q = Quantity::Exceedance { threshold: 2.0 };
        assert!(estimate(&y, q, None).is_none());
    }
}
