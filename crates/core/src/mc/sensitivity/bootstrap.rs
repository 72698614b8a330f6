//! The indices and their bootstrap replicates in O(N): every estimate is a ratio of weighted
//! sums over the base samples, so one pass over the outputs per group of resamples gives them
//! all, the output `w` in f64 and every failure indicator at once in exact integers.
//!
//! # Weights
//!
//! Resample `r` gives base sample `k` the weight `c_rk ~ Poisson(1)` (the Poisson bootstrap,
//! Hanley & MacGibbon 2006, *Comput. Methods Programs Biomed.* 83, 57–62; Chamandy et al. 2012):
//! Philox word `k mod 4` of block `(r, k / 4, stream 0x50b1)` keyed by the bootstrap seed,
//! through the inverse Poisson(1) distribution function on 32 bits. The weights are independent
//! across base samples and a pure function of `(seed, r, k)`, so a pass can generate those of a
//! block of base samples where it reads their outputs: no index vector, no random access, and
//! the result does not depend on how the passes are split over threads. A resample keeps the
//! pairing of each base sample's outputs (`y^A_k`, `y^B_k` and every `y^S_k` get the same
//! weight), as the multinomial bootstrap does; its size `W_r = Σ_k c_rk` is N on average.
//!
//! # Estimates as weighted sums
//!
//! With `a = y^A − m₀`, `b = y^B − m₀` (m₀ the mean of all 2N values of A and B, a shift that
//! keeps the sums well conditioned) and `d_S = y^S − y^A`, a weighting `c` gives
//!
//! * `Λ = Σ c (a + b)`, `Q = Σ c (a² + b²)`, `W = Σ c`: the mean `m₀ + Λ/2W` and the variance
//!   `V = (Q − Λ²/2W) / (2W − 1)`;
//! * per set, `P_S = Σ c b d_S`, `D_S = Σ c d_S`, `T_S = Σ c d_S²`: the first-order index
//!   `(P_S − (Λ/2W) D_S) / W / V` (Saltelli's sum centred on the weighted mean) and the total
//!   index `T_S / 2W / V` (Jansen).
//!
//! With every weight 1 these are the point estimates of the module docs. Each resample's sums
//! run over the base samples in order, inside one task, so the replicates are the same bits
//! whatever the number of threads.
//!
//! For an indicator `1[y ≥ l]` the same sums are integers, computed exactly: each output is
//! replaced by its rank among the sorted thresholds (the number of thresholds ≤ y, by binary
//! search as the pass reads it), and a base sample adds its weight to a difference array over
//! the thresholds (`d_S` is ±1 exactly for the thresholds between the ranks of `y^A` and
//! `y^S`), so one pass and one prefix sum give the sums of every threshold: `O(N · S + L · S)`
//! per resample for `L` thresholds (and `O(N · S · log L)` per group of resamples for the
//! ranks) instead of `O(N · S · L)`.

use rayon::prelude::*;

use super::estimator::Estimate;
use super::{Outputs, CONFIDENCE};
use crate::sampling::{philox4x32_10_lanes, Philox};

/// Philox stream of the bootstrap weights (the parameter draws use stream 0).
const BOOTSTRAP_STREAM: u32 = 0x50b1;

/// Base samples per block of a pass (the weights and the features of one block are held at a
/// time); a multiple of 32, the samples of one 8-lane Philox call.
const BLOCK: usize = 256;

/// Most resamples per task of a pass over the outputs of `w` (fewer with many threads): each
/// task reads all outputs once.
const GROUP: usize = 16;

/// Bytes of the integer accumulators of one task of a pass over the indicators (kept within
/// a core's L2 cache), which sets its resamples per task.
const LEVEL_CACHE: usize = 256 << 10;

/// Bytes of the replicates of the thresholds analysed in one pass (or of one threshold, if
/// more): the thresholds are analysed in batches that fit.
pub const THRESHOLD_BATCH_BYTES: usize = 8 << 20;

/// `⌊2³² · P(X ≤ j)⌋` for `X ~ Poisson(1)`, `j = 0 … 11`: the weight of a 32-bit word `u` is
/// the number of entries `≤ u` (at most 12; `P(X > 12) < 2⁻³²`).
const POISSON_CDF: [u32; 12] = [
    1_580_030_168,
    3_160_060_337,
    3_950_075_421,
    4_213_413_783,
    4_279_248_373,
    4_292_415_291,
    4_294_609_777,
    4_294_923_276,
    4_294_962_463,
    4_294_966_817,
    4_294_967_252,
    4_294_967_292,
];

/// The Poisson(1) weight of the uniform 32-bit word `u`.
#[inline(always)]
fn poisson(u: u32) -> u8 {
    POISSON_CDF.iter().map(|&t| u8::from(u >= t)).sum()
}

/// The bootstrap resamples: weights generated on demand from the seed.
pub(super) struct Bootstrap {
    gen: Philox,
    /// Resamples R.
    pub count: usize,
}

impl Bootstrap {
    pub fn new(seed: u64, count: usize) -> Self {
        Bootstrap {
            gen: Philox::new(seed),
            count,
        }
    }

    /// The weights of resample `r` for base samples `k0 … k0 + out.len() − 1` (`k0` and the
    /// length multiples of 4).
    pub fn weights(&self, r: usize, k0: usize, out: &mut [u8]) {
        let r = r as u64;
        let mut blk = (k0 / 4) as u32;
        let mut lanes = out.chunks_exact_mut(32);
        for chunk in &mut lanes {
            let ctr = [
                [r as u32; 8],
                [(r >> 32) as u32; 8],
                std::array::from_fn(|l| blk + l as u32),
                [BOOTSTRAP_STREAM; 8],
            ];
            let w = philox4x32_10_lanes(ctr, self.gen.key);
            for (l, four) in chunk.chunks_exact_mut(4).enumerate() {
                for (j, o) in four.iter_mut().enumerate() {
                    *o = poisson(w[j][l]);
                }
            }
            blk += 8;
        }
        for four in lanes.into_remainder().chunks_mut(4) {
            let w = self.gen.block(r, blk, BOOTSTRAP_STREAM);
            for (o, &x) in four.iter_mut().zip(&w) {
                *o = poisson(x);
            }
            blk += 1;
        }
    }
}

/// Which weighting a pass applies: all ones (the point estimates) or resamples `first …
/// first + count − 1`.
#[derive(Clone, Copy)]
enum Weighting<'a> {
    Ones,
    Resamples(&'a Bootstrap, usize),
}

impl Weighting<'_> {
    /// The weights of `count` weightings for the `len` base samples from `k0`, weighting `g`
    /// at `out[g · BLOCK ..]`.
    fn fill(self, count: usize, k0: usize, len: usize, out: &mut [u8]) {
        for g in 0..count {
            let w = &mut out[g * BLOCK..g * BLOCK + len];
            match self {
                Weighting::Ones => w.fill(1),
                Weighting::Resamples(boot, first) => boot.weights(first + g, k0, w),
            }
        }
    }
}

/// The indices of every level of a quantity (one for `w`, one per threshold of a batch of
/// indicators) under one weighting: level `j` is `None` when the quantity's variance is zero
/// under it, else the first-order indices of the S sets followed by their total indices.
pub(super) struct Replicate {
    valid: Vec<bool>,
    values: Vec<f64>,
}

impl Replicate {
    fn new(levels: usize, sets: usize) -> Self {
        Replicate {
            valid: vec![false; levels],
            values: vec![0.0; levels * 2 * sets],
        }
    }

    /// Level `j`: (first-order, total) of every set, or `None`.
    pub fn level(&self, j: usize, sets: usize) -> Option<(&[f64], &[f64])> {
        self.valid[j].then(|| self.values[j * 2 * sets..(j + 1) * 2 * sets].split_at(sets))
    }

    /// Sets level `j` from `index(s) = (first, total)`, or marks it invalid.
    fn set(&mut self, j: usize, sets: usize, index: Option<impl Fn(usize) -> (f64, f64)>) {
        self.valid[j] = index.is_some();
        if let Some(index) = index {
            let v = &mut self.values[j * 2 * sets..(j + 1) * 2 * sets];
            for s in 0..sets {
                (v[s], v[sets + s]) = index(s);
            }
        }
    }
}

/// Runs `task(first, count)` over the R resamples in groups of at most `group`, in parallel;
/// the replicates come back in resample order. Groups shrink (to 4) so that every thread gets
/// about four: a resample's sums do not depend on its group, so neither do the bits.
fn over_resamples<F>(boot: &Bootstrap, group: usize, task: F) -> Vec<Replicate>
where
    F: Fn(Weighting, usize) -> Vec<Replicate> + Sync,
{
    let spread = boot.count / (4 * rayon::current_num_threads());
    let group = group.min(spread.max(4)).max(1);
    (0..boot.count.div_ceil(group))
        .into_par_iter()
        .map(|t| {
            let first = t * group;
            task(
                Weighting::Resamples(boot, first),
                group.min(boot.count - first),
            )
        })
        .collect::<Vec<_>>()
        .into_iter()
        .flatten()
        .collect()
}

/// The replicates of `w` (one level): the point estimate (`None` when the variance of A ∪ B
/// is zero) and the R bootstrap replicates. `m0` is the mean of A ∪ B.
pub(super) fn value(y: &Outputs, m0: f64, boot: &Bootstrap) -> (Replicate, Vec<Replicate>) {
    let point = value_pass(y, m0, Weighting::Ones, 1).remove(0);
    if point.level(0, y.sets.len()).is_none() {
        return (point, Vec::new());
    }
    let reps = over_resamples(boot, GROUP, |w, count| value_pass(y, m0, w, count));
    (point, reps)
}

/// One pass over the outputs of `w` for `count` weightings: the sums of the module docs, then
/// each weighting's indices.
fn value_pass(y: &Outputs, m0: f64, weighting: Weighting, count: usize) -> Vec<Replicate> {
    let (n, sets) = (y.a.len(), y.sets.len());
    let f = 2 + 3 * sets;
    let mut acc = vec![0.0; count * f];
    let mut total = vec![0u64; count];
    let mut wts = vec![0u8; count * BLOCK];
    let mut feat = vec![0.0; BLOCK * f];
    let mut nz = vec![(0u32, 0.0); count * BLOCK];
    let mut nnz = vec![0usize; count];
    for k0 in (0..n).step_by(BLOCK) {
        let len = BLOCK.min(n - k0);
        weighting.fill(count, k0, len, &mut wts);
        for (k, row) in feat.chunks_exact_mut(f).take(len).enumerate() {
            let (a, b) = (y.a[k0 + k] - m0, y.b[k0 + k] - m0);
            row[0] = a + b;
            row[1] = a * a + b * b;
            for (s, x) in y.sets.iter().zip(row[2..].chunks_exact_mut(3)) {
                let d = s[k0 + k] - y.a[k0 + k];
                x[0] = b * d;
                x[1] = d;
                x[2] = d * d;
            }
        }
        // The nonzero weights of each weighting (about 1 − 1/e of them), in base-sample order.
        for g in 0..count {
            let mut m = 0;
            for (k, &c) in wts[g * BLOCK..g * BLOCK + len].iter().enumerate() {
                nz[g * BLOCK + m] = (k as u32, f64::from(c));
                m += usize::from(c != 0);
                total[g] += u64::from(c);
            }
            nnz[g] = m;
        }
        accumulate(&mut acc, &feat, f, &nz, &nnz);
    }
    acc.chunks_exact(f)
        .zip(total)
        .map(|(sum, w)| {
            let mut rep = Replicate::new(1, sets);
            let (w, two) = (w as f64, 2.0 * w as f64);
            let shift = sum[0] / two;
            let var = (sum[1] - sum[0] * shift) / (two - 1.0);
            let ok = w > 0.0 && var > 0.0;
            rep.set(
                0,
                sets,
                ok.then_some(|s: usize| {
                    let x = &sum[2 + 3 * s..5 + 3 * s];
                    ((x[0] - shift * x[1]) / w / var, x[2] / two / var)
                }),
            );
            rep
        })
        .collect()
}

/// Features summed at once per weighting (held in registers).
const LANES: usize = 16;

/// `acc[g·f + j] += c · feat[k·f + j]` for each nonzero weight `(k, c)` of weighting `g`
/// (`nz[g · BLOCK ..][..nnz[g]]`), in order of k. Each sum runs over k in order whatever the
/// blocking into [`LANES`] features or the instruction set, so neither changes the bits.
fn accumulate(acc: &mut [f64], feat: &[f64], f: usize, nz: &[(u32, f64)], nnz: &[usize]) {
    #[cfg(target_arch = "x86_64")]
    if std::is_x86_feature_detected!("avx2") {
        // SAFETY: the processor supports AVX2 (just checked).
        unsafe { accumulate_avx2(acc, feat, f, nz, nnz) };
        return;
    }
    accumulate_impl(acc, feat, f, nz, nnz);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn accumulate_avx2(
    acc: &mut [f64],
    feat: &[f64],
    f: usize,
    nz: &[(u32, f64)],
    nnz: &[usize],
) {
    accumulate_impl(acc, feat, f, nz, nnz);
}

#[inline(always)]
fn accumulate_impl(acc: &mut [f64], feat: &[f64], f: usize, nz: &[(u32, f64)], nnz: &[usize]) {
    let mut j0 = 0;
    while j0 < f {
        let width = LANES.min(f - j0);
        for (g, &m) in nnz.iter().enumerate() {
            let sums = &mut acc[g * f + j0..g * f + j0 + width];
            let weights = &nz[g * BLOCK..g * BLOCK + m];
            if width == LANES {
                let mut r = [0.0; LANES];
                r.copy_from_slice(sums);
                for &(k, c) in weights {
                    let at = k as usize * f + j0;
                    let x: &[f64; LANES] = feat[at..at + LANES].try_into().expect("LANES features");
                    for (s, &x) in r.iter_mut().zip(x) {
                        *s += c * x;
                    }
                }
                sums.copy_from_slice(&r);
            } else {
                for &(k, c) in weights {
                    let at = k as usize * f + j0;
                    for (s, &x) in sums.iter_mut().zip(&feat[at..at + width]) {
                        *s += c * x;
                    }
                }
            }
        }
        j0 += width;
    }
}

/// The outputs and a batch of sorted thresholds `levels`: the rank of an output is the number
/// of levels ≤ it, so `1[y ≥ levels[j]] = 1[j < rank(y)]`. Ranks are computed block by block
/// where a pass reads them (a binary search each), so nothing of size N is added to the outputs.
pub(super) struct Ranks<'a> {
    y: &'a Outputs,
    levels: &'a [f64],
}

/// Most thresholds in one batch (ranks are u16).
pub(super) const MAX_LEVELS: usize = u16::MAX as usize - 1;

impl<'a> Ranks<'a> {
    /// The ranks of the outputs `y` among `levels` (sorted, at most [`MAX_LEVELS`]).
    pub fn new(y: &'a Outputs, levels: &'a [f64]) -> Self {
        Ranks { y, levels }
    }

    #[inline]
    fn rank(&self, v: f64) -> u16 {
        self.levels.partition_point(|&t| t <= v) as u16
    }

    /// The ranks of base samples `k0 … k0 + len − 1`, `2 + S` per base sample: A, B, then the
    /// sets.
    fn block(&self, k0: usize, len: usize, out: &mut [u16]) {
        let w = 2 + self.y.sets.len();
        for (k, r) in out.chunks_exact_mut(w).take(len).enumerate() {
            r[0] = self.rank(self.y.a[k0 + k]);
            r[1] = self.rank(self.y.b[k0 + k]);
            for (r, s) in r[2..].iter_mut().zip(&self.y.sets) {
                *r = self.rank(s[k0 + k]);
            }
        }
    }

    /// Per threshold, how many of the 2N outputs of A and B are at or above it.
    pub fn hits(&self) -> Vec<usize> {
        let levels = self.levels.len();
        let mut at = vec![0usize; levels + 1];
        for &v in self.y.a.iter().chain(&self.y.b) {
            at[usize::from(self.rank(v))] += 1;
        }
        let mut above = 0;
        let mut hits = vec![0; levels];
        for j in (0..levels).rev() {
            above += at[j + 1];
            hits[j] = above;
        }
        hits
    }
}

/// The point estimates and the R replicates of the indicators at every threshold of `ranks`.
pub(super) fn indicators(ranks: &Ranks, boot: &Bootstrap) -> (Replicate, Vec<Replicate>) {
    let point = indicator_pass(ranks, Weighting::Ones, 1).remove(0);
    let per = 4 * (1 + 3 * ranks.y.sets.len()) * (ranks.levels.len() + 1);
    let group = (LEVEL_CACHE / per).clamp(1, GROUP);
    let reps = over_resamples(boot, group, |w, count| indicator_pass(ranks, w, count));
    (point, reps)
}

/// One pass over the ranks for `count` weightings: per weighting, difference arrays over the
/// L + 1 ranks of `Σ c (I_A + I_B)` (a histogram, summed from the top) and, per set, of
/// `T_S`, `D_S` and `P_S`; their prefix sums are the integer sums at every threshold.
fn indicator_pass(ranks: &Ranks, weighting: Weighting, count: usize) -> Vec<Replicate> {
    let (n, sets, levels) = (ranks.y.a.len(), ranks.y.sets.len(), ranks.levels.len());
    let l = levels + 1;
    let per = (1 + 3 * sets) * l;
    let mut acc = vec![0i32; count * per];
    let mut total = vec![0i64; count];
    let mut wts = vec![0u8; count * BLOCK];
    let mut block = vec![0u16; (2 + sets) * BLOCK];
    for k0 in (0..n).step_by(BLOCK) {
        let len = BLOCK.min(n - k0);
        weighting.fill(count, k0, len, &mut wts);
        ranks.block(k0, len, &mut block);
        for (k, r) in block.chunks_exact(2 + sets).take(len).enumerate() {
            let (ra, rb) = (usize::from(r[0]), usize::from(r[1]));
            let rs = &r[2..];
            for (g, acc) in acc.chunks_exact_mut(per).enumerate() {
                let c = wts[g * BLOCK + k];
                if c == 0 {
                    continue;
                }
                total[g] += i64::from(c);
                let c = i32::from(c);
                acc[ra] += c;
                acc[rb] += c;
                for (&r, arr) in rs.iter().zip(acc[l..].chunks_exact_mut(3 * l)) {
                    let r = usize::from(r);
                    if r == ra {
                        continue;
                    }
                    let (lo, hi, sg) = if r > ra { (ra, r, c) } else { (r, ra, -c) };
                    arr[lo] += c;
                    arr[hi] -= c;
                    arr[l + lo] += sg;
                    arr[l + hi] -= sg;
                    let end = hi.min(rb);
                    if lo < end {
                        arr[2 * l + lo] += sg;
                        arr[2 * l + end] -= sg;
                    }
                }
            }
        }
    }
    acc.chunks_exact(per)
        .zip(total)
        .map(|(acc, w)| {
            let mut rep = Replicate::new(levels, sets);
            let two = 2 * w;
            // Prefix sums: the histogram's from the top, the difference arrays' from the bottom.
            let mut hist = vec![0i64; levels];
            let mut above = 0i64;
            for j in (0..levels).rev() {
                above += i64::from(acc[j + 1]);
                hist[j] = above;
            }
            let mut run = vec![0i64; 3 * sets];
            for (j, &m) in hist.iter().enumerate() {
                for (s, arr) in acc[l..].chunks_exact(3 * l).enumerate() {
                    for q in 0..3 {
                        run[3 * s + q] += i64::from(arr[q * l + j]);
                    }
                }
                let ok = m > 0 && m < two;
                let var = m as f64 * (two - m) as f64 / two as f64 / (two - 1) as f64;
                rep.set(
                    j,
                    sets,
                    ok.then_some(|s: usize| {
                        let (t, d, p) = (run[3 * s], run[3 * s + 1], run[3 * s + 2]);
                        let first = (p * two - m * d) as f64 / two as f64 / w as f64 / var;
                        (first, t as f64 / two as f64 / var)
                    }),
                );
            }
            rep
        })
        .collect()
}

/// Point estimate and percentile interval of one index from its replicates.
pub(super) fn summarise(value: f64, reps: impl Iterator<Item = f64>) -> Estimate {
    let mut reps: Vec<f64> = reps.collect();
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

#[cfg(test)]
mod tests;
