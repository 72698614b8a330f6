//! Subset simulation (Au & Beck 2001): the levels of one run, the estimate at each threshold
//! with its coefficient of variation, and the runs that grow `N` until the target is met.

use super::mcmc::{mcmc_level, INITIAL_SCALE};
use super::space::Model;
use super::{
    ChainProposal, LevelSummary, SubsetRun, TailError, TailEstimate, TailOptions, TailOutcome,
    MAX_LEVELS, MAX_SAMPLES_PER_LEVEL, TAIL_STREAM,
};

/// The samples of one level: `N_c'` chains of `N_s'` consecutive states (level 0: `N` chains of
/// one state).
pub(super) struct Level {
    pub(super) u: Vec<f64>,
    pub(super) w: Vec<f64>,
    pub(super) chains: usize,
    pub(super) lower: Option<f64>,
}

impl Level {
    /// The level without its states `u`, which the estimates do not need (a run keeps only
    /// two levels' states at a time).
    pub(super) fn without_states(self) -> Level {
        Level {
            u: Vec::new(),
            ..self
        }
    }

    /// `#{w ≥ l}/N`, `γ` and the [`seed_carry`] of the indicator `1[w ≥ l]` over the chains.
    pub(super) fn fraction(&self, l: f64) -> (f64, f64, f64) {
        let ind: Vec<bool> = self.w.iter().map(|&v| v >= l).collect();
        let n = ind.len();
        let p = ind.iter().filter(|&&b| b).count() as f64 / n as f64;
        (p, gamma(&ind, self.chains), seed_carry(&ind, self.chains))
    }
}

/// `ρ(τ)` for `τ = 1 … N_s − 1` of the indicator `ind` over `chains` chains of consecutive
/// entries (Au & Beck 2001 eq. 28–29): `ρ(τ) = R(τ)/R(0)`,
/// `R(τ) = 1/(N − τ N_c) Σ_k Σ_l I_{k,l} I_{k,l+τ} − p²`; empty for one state per chain, zeros
/// when all or none of the entries are set.
fn autocorrelation(ind: &[bool], chains: usize) -> Vec<f64> {
    let n = ind.len();
    let ns = n / chains;
    let p = ind.iter().filter(|&&b| b).count() as f64 / n as f64;
    let r0 = p * (1.0 - p);
    (1..ns)
        .map(|tau| {
            if r0 <= 0.0 {
                return 0.0;
            }
            let mut s = 0usize;
            for c in ind.chunks(ns) {
                s += c.iter().zip(&c[tau..]).filter(|(a, b)| **a && **b).count();
            }
            (s as f64 / (n - tau * chains) as f64 - p * p) / r0
        })
        .collect()
}

/// Au & Beck (2001) eq. 29: `γ = 2 Σ_{τ=1}^{N_s−1} (1 − τ N_c/N) ρ(τ)` for `chains` chains of
/// consecutive entries of `ind`.
pub fn gamma(ind: &[bool], chains: usize) -> f64 {
    let n = ind.len() as f64;
    autocorrelation(ind, chains)
        .iter()
        .enumerate()
        .map(|(i, r)| 2.0 * (1.0 - ((i + 1) * chains) as f64 / n) * r)
        .sum()
}

/// How much of a Markov level's estimate its seeds carry over from the level before: the mean
/// correlation of a chain's `N_s` states with its first state (the seed),
/// `(1 + Σ_{τ=1}^{N_s−1} ρ(τ)) / N_s`, clamped to [0, 1]: 1 for chains that never move (the
/// level repeats its seeds' indicator), `1/N_s` for chains that forget the seed after one step
/// (only the seed itself is shared). Level 0 (one state per chain) has no seeds: 0.
pub fn seed_carry(ind: &[bool], chains: usize) -> f64 {
    let ns = ind.len() / chains;
    if ns < 2 {
        return 0.0;
    }
    ((1.0 + autocorrelation(ind, chains).iter().sum::<f64>()) / ns as f64).clamp(0.0, 1.0)
}

/// One run of `n` samples per level, number `r`: levels until the `N_c`-th largest `w` reaches `l_max`, the cap, or
/// [`MAX_LEVELS`].
fn subset_run(
    m: &mut Model,
    opts: &TailOptions,
    n: usize,
    r: u32,
) -> Result<(SubsetRun, TailOutcome), TailError> {
    let (nc, d) = ((opts.p0 * n as f64).round() as usize, m.space.dim());
    let ns = n / nc;
    let nb = d.div_ceil(4) as u32;
    let l_max = opts.thresholds.iter().copied().fold(0.0, f64::max);
    let hi = u64::from(r) << 32;
    let start = m.evaluations;

    let mut u = vec![0.0; n * d];
    for (i, row) in u.chunks_mut(d).enumerate() {
        m.normals(hi | i as u64, TAIL_STREAM, 0, row);
    }
    let mut w = vec![0.0; n];
    m.eval_u(&u, &mut w)?;
    let mut level = Level {
        u,
        w,
        chains: n,
        lower: None,
    };
    let mut levels = Vec::new();
    let mut summaries: Vec<LevelSummary> = Vec::new();
    let mut level_evals = n as u64;
    let mut acceptance = None;
    let (mut scale, mut start_scale) = (INITIAL_SCALE, None);
    let outcome = loop {
        let mut order: Vec<usize> = (0..n).collect();
        order.sort_by(|&a, &b| level.w[b].total_cmp(&level.w[a]));
        let b_next = level.w[order[nc - 1]];
        let mut summary = LevelSummary {
            lower: level.lower,
            next: None,
            p: None,
            gamma: 0.0,
            seed_carry: 0.0,
            acceptance,
            scale: start_scale,
            evaluations: level_evals,
        };
        if b_next >= l_max {
            summaries.push(summary);
            levels.push(level.without_states());
            break TailOutcome::TargetReached;
        }
        // p_j = p0 exactly: the count #{w ≥ b} would include the repeats of a stuck chain at
        // the quantile and bias every level upward (measured: +20 % at P_f = 1e-6, N = 500).
        let p = nc as f64 / n as f64;
        let (_, g, carry) = level.fraction(b_next);
        summary.next = Some(b_next);
        summary.p = Some(p);
        summary.gamma = g;
        summary.seed_carry = carry;
        summaries.push(summary);
        let j = levels.len() + 1;
        if j >= MAX_LEVELS {
            levels.push(level.without_states());
            break TailOutcome::LevelLimitReached;
        }
        if m.evaluations + (n - nc) as u64 > opts.max_evaluations {
            levels.push(level.without_states());
            break TailOutcome::EvaluationCapReached;
        }
        let before = m.evaluations;
        start_scale = (opts.proposal == ChainProposal::AdaptiveConditional).then_some(scale);
        let (next, acc) = mcmc_level(m, opts, &level, &order[..nc], b_next, j, hi, nb, &mut scale)?;
        level_evals = m.evaluations - before;
        acceptance = Some(acc as f64 / (nc * (ns - 1)).max(1) as f64);
        levels.push(level.without_states());
        level = next;
    };
    let estimates = opts
        .thresholds
        .iter()
        .map(|&l| level_estimate(&levels, &summaries, n, l, opts.proposal))
        .collect();
    let rep = SubsetRun {
        samples_per_level: n,
        levels: summaries,
        complete: outcome == TailOutcome::TargetReached,
        evaluations: m.evaluations - start,
        estimates,
    };
    Ok((rep, outcome))
}

/// The estimate at `l` from the highest level whose lower threshold is at most `l`, with its
/// coefficient of variation combined over the levels as [`ChainProposal::combined_cov`] says.
fn level_estimate(
    levels: &[Level],
    summaries: &[LevelSummary],
    n: usize,
    l: f64,
    proposal: ChainProposal,
) -> TailEstimate {
    let j = levels
        .iter()
        .rposition(|lv| lv.lower.is_none_or(|b| b <= l))
        .unwrap_or(0);
    let delta = |p: f64, g: f64| ((1.0 - p) / (p * n as f64) * (1.0 + g)).sqrt();
    let mut p_f = 1.0;
    let mut deltas = Vec::with_capacity(j + 1);
    let mut carries = Vec::with_capacity(j + 1);
    for s in &summaries[..j] {
        let p = s.p.unwrap_or(1.0);
        p_f *= p;
        deltas.push(delta(p, s.gamma));
        carries.push(s.seed_carry);
    }
    let (p, g, carry) = levels[j].fraction(l);
    if p == 0.0 {
        return TailEstimate::new(l, 0.0, None, None);
    }
    deltas.push(delta(p, g));
    carries.push(carry);
    let independent = deltas.iter().map(|d| d * d).sum::<f64>().sqrt();
    TailEstimate::new(
        l,
        p_f * p,
        Some(proposal.combined_cov(&deltas, &carries)),
        Some(independent),
    )
}

type SubsetOutput = (TailOutcome, Vec<TailEstimate>, Vec<SubsetRun>);

/// Safety factor on the predicted `N` of the next run: the coefficient of variation is itself
/// estimated.
const N_MARGIN: f64 = 1.2;

/// A pilot run with `N` = [`TailOptions::samples_per_level`], then runs with `N` grown by
/// `(δ/target)²` until every threshold meets the target or the cap.
pub(super) fn subset_simulation(
    m: &mut Model,
    opts: &TailOptions,
) -> Result<SubsetOutput, TailError> {
    // N = N_c · N_s with N_s = 1/p0 fixed: N_c scales.
    let ns = opts.samples_per_level / opts.chains();
    let mut n = opts.samples_per_level;
    let mut runs: Vec<SubsetRun> = Vec::new();
    let outcome = loop {
        let (run, outcome) = subset_run(m, opts, n, runs.len() as u32)?;
        // A CoV that is not a number is never within the target (`f64::max` would drop it).
        let worst = run
            .estimates
            .iter()
            .map(|e| e.cov.filter(|c| !c.is_nan()).unwrap_or(f64::INFINITY))
            .fold(0.0, f64::max);
        let cost = run.evaluations as f64 / n as f64;
        let complete = run.complete;
        if complete || runs.iter().all(|r| !r.complete) {
            runs.push(run);
        }
        if !complete {
            break outcome;
        }
        if worst <= opts.target_cov {
            break TailOutcome::TargetReached;
        }
        let want = n as f64 * (worst / opts.target_cov).powi(2) * N_MARGIN;
        let fit = opts.max_evaluations.saturating_sub(m.evaluations) as f64 / (cost * N_MARGIN);
        let limit = (MAX_SAMPLES_PER_LEVEL / ns * ns) as f64;
        let next = ((want.min(fit).min(limit) / ns as f64).floor() as usize) * ns;
        if next <= n {
            break TailOutcome::EvaluationCapReached;
        }
        n = next;
    };
    let est = runs
        .iter()
        .rev()
        .find(|r| r.complete)
        .unwrap_or(&runs[0])
        .estimates
        .clone();
    Ok((outcome, est, runs))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gamma_of_independent_and_constant_chains() {
        // One state per chain (level 0): no correlation term.
        assert_eq!(gamma(&[true, false, true, false], 4), 0.0);
        // Chains that never move: every lag has ρ = 1, so
        // γ = 2 Σ_{τ=1}^{Ns−1} (1 − τ/Ns) = Ns − 1.
        let ns = 10;
        let ind: Vec<bool> = (0..5 * ns).map(|i| (i / ns) % 2 == 0).collect();
        assert!((gamma(&ind, 5) - (ns - 1) as f64).abs() < 1e-12);
        // Alternating states within each chain: ρ(τ) = (−1)^τ exactly here (p = ½).
        let ind: Vec<bool> = (0..4 * 4).map(|i| i % 2 == 0).collect();
        let expected: f64 = (1..4)
            .map(|t| 2.0 * (1.0 - t as f64 / 4.0) * if t % 2 == 0 { 1.0 } else { -1.0 })
            .sum();
        assert!((gamma(&ind, 4) - expected).abs() < 1e-12);
        // All or none failing: no variance, γ = 0.
        assert_eq!(gamma(&[true; 20], 2), 0.0);
    }

    #[test]
    fn seed_carry_from_stuck_to_forgetful_chains() {
        // One state per chain (level 0): no seeds.
        assert_eq!(seed_carry(&[true, false, true, false], 4), 0.0);
        // Chains that never move carry their seed in full.
        let ind: Vec<bool> = (0..5 * 10).map(|i| (i / 10) % 2 == 0).collect();
        assert!((seed_carry(&ind, 5) - 1.0).abs() < 1e-12);
        // Alternating states (p = ½, ρ(τ) = (−1)^τ, N_s = 4): 1 − 1 + 1 − 1 = 0, clamped at 0;
        // N_s = 5 adds ρ(4) = 1: (1 − 1 + 1 − 1 + 1)/5.
        let ind: Vec<bool> = (0..4 * 4).map(|i| i % 2 == 0).collect();
        assert!(seed_carry(&ind, 4).abs() < 1e-12);
        let ind: Vec<bool> = (0..4 * 5).map(|i| (i % 5) % 2 == 0).collect();
        let p = 12.0 / 20.0;
        let r0 = p * (1.0 - p);
        // Per lag: the pairs (both set) over N − τ N_c, less p², over p(1 − p).
        let rho: Vec<f64> = [(0.0, 16.0), (8.0, 12.0), (0.0, 8.0), (4.0, 4.0)]
            .iter()
            .map(|(s, m)| (s / m - p * p) / r0)
            .collect();
        let expected = ((1.0 + rho.iter().sum::<f64>()) / 5.0).clamp(0.0, 1.0);
        assert!((seed_carry(&ind, 4) - expected).abs() < 1e-12);
    }
}
