//! Tail probabilities `P_f(L) = Pr[w ≥ L]` down to 1e-9 by subset simulation (Au & Beck 2001),
//! with crude Monte Carlo for comparison, and the reliability index `β = −Φ⁻¹(P_f)`.
//!
//! # The standard-normal space
//!
//! The parameters are Gaussian, so draw `μ = μ̄ + L u` with `u ~ N(0, I_d)` is exact: `d` is the
//! number of free parameters (nonzero variance), `L` the diagonal of their standard deviations
//! (independent model) or the lower Cholesky factor the [`ParamSampler`] already holds (full
//! covariance, `docs/METHOD.md §6`). Subset simulation works on `u`; every evaluation maps `u`
//! to the offsets `δ = L u` and goes through [`Evaluator::evaluate_offsets`], so the CPU and the
//! GPU backends carry it alike.
//!
//! # Subset simulation
//!
//! With `N` samples per level and the level probability `p0` (0.1 by default), `N_c = p0·N`
//! Markov chains of `N_s = N / N_c` states each make a level.
//!
//! * Level 0: `N` independent samples `u ~ N(0, I_d)`.
//! * The next intermediate threshold `b_{j+1}` is the `p0`-quantile from the top of level `j`'s
//!   `w` values: the `N_c`-th largest, so that `p_j = P(w ≥ b_{j+1} | w ≥ b_j)` is estimated by
//!   `p0`. (Counting `#{w ≥ b_{j+1}}` instead would include the repeated states of a chain that
//!   rejected its moves whenever they sit at the quantile, and bias every level upward.)
//! * Level `j + 1`: the `N_c` samples with `w ≥ b_{j+1}` (the largest) seed one chain each; the
//!   seed is the chain's first state and `N_s − 1` steps of the modified Metropolis algorithm
//!   follow. One step of all chains is one batch for the evaluator.
//! * The levels stop at the first level `m − 1` whose `N_c`-th largest `w` reaches the largest
//!   requested threshold. Then
//!   `P_f(L) = p_0 p_1 ⋯ p_{j−1} · #{w ≥ L at level j} / N` for every requested `L`, `j` the
//!   highest level with `b_j ≤ L` (so `P_f = p0^(m−1) · P(F | F_{m−1})` for the largest `L`):
//!   the intermediate thresholds give the probability at every `L` on the way in one run.
//!
//! **Adaptive conditional sampling** ([`ChainProposal::AdaptiveConditional`], the default;
//! Papaioannou et al. 2015, "MCMC algorithms for subset simulation"): from the current state
//! `u`, every component moves to `ξ_k = ρ_k u_k + σ_k ε_k`, `ρ_k = √(1 − σ_k²)`, which keeps
//! `N(0, 1)` invariant, and the chain moves to `ξ` if `w(ξ) ≥ b_j`. The spreads are
//! `σ_k = min(1, λ σ̂_k)`, `σ̂_k` the sample standard deviation of component `k` over the level's
//! seeds, and `λ` adapts after every step towards the acceptance rate [`TARGET_ACCEPTANCE`].
//! **Modified Metropolis** ([`ChainProposal::ModifiedMetropolis`]; component-wise; Au & Beck
//! 2001 §4): for each component `k` a candidate `ξ_k = u_k + s ε_k`, `ε_k ~ N(0, 1)`, is kept
//! with probability `min(1, φ(ξ_k)/φ(u_k))` (else `ξ_k = u_k`); the chain moves to `ξ` if
//! `w(ξ) ≥ b_j` and stays otherwise, with the spread `s` = [`TailOptions::proposal_spread`].
//! On the default TX60 the adaptive proposal's chains are less correlated (γ_j 1.3–3.2 against
//! 1.4–4.6, `docs/METHOD.md §10`), and its levels nearly independent (below).
//!
//! **Coefficient of variation** (Au & Beck 2001 eqs. 27–30): per level
//! `δ_j² = (1 − p_j)/(p_j N) · (1 + γ_j)`, with `γ_0 = 0` (independent samples) and, for the
//! chains of level `j ≥ 1` with the indicator `I = 1[w ≥ b_{j+1}]` (or `1[w ≥ L]` at the level
//! that estimates `L`),
//! `γ_j = 2 Σ_{τ=1}^{N_s−1} (1 − τ N_c / N) ρ_j(τ)`, `ρ_j(τ) = R_j(τ)/R_j(0)`,
//! `R_j(τ) = 1/(N − τ N_c) · Σ_k Σ_{l=1}^{N_s−τ} I_{k,l} I_{k,l+τ} − p_j²`, `R_j(0) = p_j(1 − p_j)`.
//! Au & Beck bound the coefficient of variation of `P̂_f` by
//! `Σ_j δ_j² ≤ δ² ≤ Σ_{i,j} δ_i δ_j`: the lower bound `δ² = Σ_j δ_j²` holds when the level
//! estimates are uncorrelated, the upper `δ = Σ_j δ_j` when they are fully correlated.
//! They are not uncorrelated: the seeds of level `j + 1` are level `j`'s largest states, and a
//! chain that moves little keeps its seed's excess into the next quantile. How far that carries
//! depends on the proposal, so [`ChainProposal::combined_cov`] combines the `δ_j` per proposal,
//! and [`TailEstimate::cov_independent_levels`] always reports the lower bound. Measured over
//! 200 seeds with `N = 500` (empirical coefficient of variation / reported):
//!
//! * Modified Metropolis, fully correlated levels `Σ_j δ_j`: θ1-only TX60 (one normal, two
//!   failure regions) 0.87 / 1.03 at `P_f = 1e-4` and 1.41 / 1.70 at 1e-6 (the lower bound
//!   0.51 and 0.69 would understate it by 2×).
//! * Adaptive conditional sampling, adjacent levels fully correlated and the others not,
//!   `√(Σ δ_j² + 2 Σ δ_j δ_{j+1})`: θ1-only 0.46 / 0.65 at 1e-4 and 0.60 / 0.85 at 1e-6; the
//!   default TX60 (20 normals) 0.52 / 0.67 at 7e-5 and 0.80 / 0.89 at 5e-7. The sum `Σ δ_j`
//!   would overstate these by 1.2–1.5×, the lower bound understate the last by 1.5×.
//!
//! **Bias and the target**: `P̂_f` is biased upward by about `δ²` of its own run, because the
//! estimate divides by the random conditional probabilities of the levels (Jensen), so the bias
//! is `O(1/N)` (Au & Beck 2001 §5) but large for a small `N`: on the θ1-only TX60, 400 seeds gave
//! a mean `P̂/P` of 1.31 ± 0.14 at 1e-6 with `N = 500` and 1.16 ± 0.07 with `N = 2000`. Averaging
//! independent small runs would keep that bias, so [`TailOptions::target_cov`] is met by
//! growing `N` instead: a pilot run with [`TailOptions::samples_per_level`] gives `δ` and the
//! cost per sample; the next run has `N ← N · (δ / target)² · 1.2` (`N_c` grows, the chain
//! length `N_s = 1/p0` stays), as large as the remaining evaluations allow, and so on until
//! every threshold's `δ` is at or below the target. The estimates are those of the last
//! complete run (its bias about `target²`); earlier runs are reported but not mixed in. A level
//! starts only if its `N (1 − p0)` evaluations fit under [`TailOptions::max_evaluations`], and a
//! run only if it can be larger than the last. When the cap ends the run the outcome is
//! [`TailOutcome::EvaluationCapReached`] with the estimates so far (a threshold that no level
//! reached has `p_f = 0` and no `cov`/`beta`), not an error.
//!
//! **Cost** (CPU, release, two shared cores): `P_f ≈ 1e-9` on the default TX60 at 50 points
//! with a reported coefficient of variation ≤ 0.15 took 2.7–3.0·10^5 evaluations (pilot
//! `N` = 1000, then `N` ≈ 3·10^4) and 2–3 s over five seeds with the adaptive proposal; modified
//! Metropolis with the summed bound took 1.1–1.3·10^6. Crude Monte Carlo would need
//! `(1 − P)/(δ² P)` ≈ 5·10^10 draws. `benches/tail.rs` measures it.
//!
//! **Crude Monte Carlo** ([`TailMethod::MonteCarlo`]): draws `0, 1, 2, …` of the run's own
//! counter stream (what [`super::run_mcs`] evaluates), in batches, until
//! `δ = √((1 − P̂)/(P̂ n)) ≤` target for every threshold or the cap; for comparison: it needs
//! about `1/(δ² P_f)` evaluations, 10^11 for `P_f = 1e-9` at `δ = 0.1`.
//!
//! # Why not FORM
//!
//! `w = max_j e_j` is a maximum over the test points: each point (and each sign of a dominant
//! parameter) has its own failure region with its own design point, and a linearisation at one
//! design point misses the others (the TX60 with only `θ_1` uncertain already has two, `u ≥ z`
//! and `u ≤ −z`). Subset simulation needs no design point; its chains populate every region
//! that the intermediate levels reach.
//!
//! # Random numbers
//!
//! All normals and uniforms come from the run's Philox key ([`ParamSampler::key`]) with the
//! counter `[state index, run, block, stream]`: stream [`TAIL_STREAM`] for level 0 and
//! `TAIL_STREAM + j` for the Markov steps of level `j`; blocks `0 … ⌈d/4⌉ − 1` give the normals
//! (Box–Muller, as the parameter draws) and the next `⌈d/4⌉` blocks the uniforms of the
//! component acceptance (modified Metropolis only). The state index of chain `k`, step `t` is `k N_s + t`. So a run depends
//! only on the seed and the options, not on thread count, batch size or backend. The counter
//! layout and the Box–Muller normals are those of the draw definition (`docs/METHOD.md §6`).

use serde::Serialize;

use super::result::Progress;
use crate::engine::{BackendInfo, EngineError, Evaluator};
use crate::kinematics::N_UNCERTAIN;
use crate::sampling::{box_muller, uniform_open, ParamSampler, Philox};

/// First Philox stream of subset simulation: level 0 uses it, the Markov steps of level `j` use
/// `TAIL_STREAM + j` (the parameter draws use stream 0).
pub const TAIL_STREAM: u32 = 0x7A11_0000;

/// Most levels of one run: `p0^200` is below 1e-60 for every allowed `p0`, so a threshold
/// that needs more lies beyond what `w` can reach (it is bounded for a robot's rotations).
pub const MAX_LEVELS: usize = 200;

/// Largest `N` of a run, given or grown (bounds the memory: two levels of `N · (d + 1)`
/// numbers, 0.5 GB for the 30 parameters of a 6R robot).
pub const MAX_SAMPLES_PER_LEVEL: usize = 1 << 20;

/// Largest accepted [`TailOptions::batch_size`].
pub const MAX_BATCH: usize = 1 << 22;

/// How the Markov chains of a subset level propose their next state.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ChainProposal {
    /// Adaptive conditional sampling (Papaioannou et al. 2015): every component moves by
    /// `ξ_k = ρ_k u_k + σ_k ε_k`, `ρ_k = √(1 − σ_k²)`, which keeps `N(0, 1)` invariant, so the
    /// only rejection is leaving the failure domain; `σ_k = min(1, λ σ̂_k)` with `σ̂_k` the spread
    /// of the level's seeds and `λ` adapted towards an acceptance rate of 0.44 (the default).
    #[default]
    AdaptiveConditional,
    /// Component-wise modified Metropolis (Au & Beck 2001) with the fixed spread
    /// [`TailOptions::proposal_spread`].
    ModifiedMetropolis,
}

/// Which estimator.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum TailMethod {
    /// Subset simulation with modified Metropolis (the default).
    Subset,
    /// Crude Monte Carlo on the run's counter draws.
    MonteCarlo,
}

/// Settings of a tail-probability run.
#[derive(Clone, Debug, PartialEq)]
pub struct TailOptions {
    /// Estimator.
    pub method: TailMethod,
    /// Thresholds `L` (mm), each finite and positive.
    pub thresholds: Vec<f64>,
    /// Target coefficient of variation of every estimate, in (0, 1).
    pub target_cov: f64,
    /// Cap on model evaluations (rows of `w` computed).
    pub max_evaluations: u64,
    /// Subset simulation: samples per level `N`.
    pub samples_per_level: usize,
    /// Subset simulation: level probability `p0` in (0, 0.5]; `p0·N` must be a whole number that
    /// divides `N`.
    pub p0: f64,
    /// Subset simulation: how the chains propose (adaptive conditional sampling by default).
    pub proposal: ChainProposal,
    /// Subset simulation with [`ChainProposal::ModifiedMetropolis`]: standard deviation `s` of
    /// the component proposal, in standard-normal units.
    pub proposal_spread: f64,
    /// Most parameter vectors in one evaluator call (crude MC and level 0).
    pub batch_size: usize,
}

impl Default for TailOptions {
    fn default() -> Self {
        TailOptions {
            method: TailMethod::Subset,
            thresholds: Vec::new(),
            target_cov: 0.1,
            max_evaluations: 1_000_000,
            samples_per_level: 1000,
            p0: 0.1,
            proposal: ChainProposal::default(),
            proposal_spread: 1.0,
            batch_size: 1 << 16,
        }
    }
}

/// The settings [`TailOptions::check`] names in its errors; a front end maps each to its own
/// option name.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum TailSetting {
    /// [`TailOptions::thresholds`].
    Thresholds,
    /// [`TailOptions::target_cov`].
    TargetCov,
    /// [`TailOptions::max_evaluations`].
    MaxEvaluations,
    /// [`TailOptions::samples_per_level`].
    SamplesPerLevel,
    /// [`TailOptions::p0`].
    P0,
    /// [`TailOptions::proposal_spread`].
    ProposalSpread,
    /// [`TailOptions::batch_size`].
    BatchSize,
}

impl std::fmt::Display for TailSetting {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            TailSetting::Thresholds => "thresholds",
            TailSetting::TargetCov => "target coefficient of variation",
            TailSetting::MaxEvaluations => "evaluation cap",
            TailSetting::SamplesPerLevel => "samples per level",
            TailSetting::P0 => "level probability p0",
            TailSetting::ProposalSpread => "proposal spread",
            TailSetting::BatchSize => "batch size",
        })
    }
}

/// Errors of a tail-probability run.
#[derive(Debug, thiserror::Error)]
pub enum TailError {
    /// A setting is out of range; names the field of [`TailOptions`].
    #[error("{field}: {message}")]
    Setting {
        /// The field.
        field: TailSetting,
        /// What is wrong.
        message: String,
    },
    /// No parameter has a nonzero variance: `w` is a constant.
    #[error("the model has no uncertain parameter, so w is a constant and has no tail")]
    NoUncertainty,
    /// The evaluator failed.
    #[error(transparent)]
    Engine(#[from] EngineError),
    /// The evaluator produced a value that is not finite.
    #[error("a parameter vector gave a non-finite maximum point error ({value}): check the model")]
    NonFinite {
        /// The value.
        value: f64,
    },
}

fn setting(field: TailSetting, message: String) -> TailError {
    TailError::Setting { field, message }
}

impl TailOptions {
    /// Checks every field; the error names the first field out of range.
    pub fn check(&self) -> Result<(), TailError> {
        if self.thresholds.is_empty() {
            return Err(setting(
                TailSetting::Thresholds,
                "at least one is needed".into(),
            ));
        }
        if let Some(l) = self
            .thresholds
            .iter()
            .find(|l| !(l.is_finite() && **l > 0.0))
        {
            return Err(setting(
                TailSetting::Thresholds,
                format!("{l} is not a finite positive length (mm)"),
            ));
        }
        if !(self.target_cov > 0.0 && self.target_cov < 1.0) {
            return Err(setting(
                TailSetting::TargetCov,
                format!("{} is outside (0, 1)", self.target_cov),
            ));
        }
        if self.batch_size == 0 || self.batch_size > MAX_BATCH {
            return Err(setting(
                TailSetting::BatchSize,
                format!("{} is outside 1 … {MAX_BATCH}", self.batch_size),
            ));
        }
        if self.max_evaluations == 0 {
            return Err(setting(
                TailSetting::MaxEvaluations,
                "must be positive".into(),
            ));
        }
        if self.method == TailMethod::MonteCarlo {
            return Ok(());
        }
        if !(self.p0 > 0.0 && self.p0 <= 0.5) {
            return Err(setting(
                TailSetting::P0,
                format!("{} is outside (0, 0.5]", self.p0),
            ));
        }
        if !(self.proposal_spread.is_finite() && self.proposal_spread > 0.0) {
            return Err(setting(
                TailSetting::ProposalSpread,
                format!("{} is not a finite positive number", self.proposal_spread),
            ));
        }
        let n = self.samples_per_level;
        if !(2..=MAX_SAMPLES_PER_LEVEL).contains(&n) {
            return Err(setting(
                TailSetting::SamplesPerLevel,
                format!("{n} is outside 2 … {MAX_SAMPLES_PER_LEVEL}"),
            ));
        }
        let nc = self.p0 * n as f64;
        let chains = nc.round() as usize;
        if (nc - chains as f64).abs() > 1e-9 * nc || chains == 0 || !n.is_multiple_of(chains) {
            return Err(setting(
                TailSetting::SamplesPerLevel,
                format!(
                    "p0 · N = {} · {n} = {nc} must be a whole number of chains that divides N",
                    self.p0
                ),
            ));
        }
        if self.max_evaluations < n as u64 {
            return Err(setting(
                TailSetting::MaxEvaluations,
                format!(
                    "{} is too small for one level of {n} samples",
                    self.max_evaluations
                ),
            ));
        }
        Ok(())
    }

    fn chains(&self) -> usize {
        (self.p0 * self.samples_per_level as f64).round() as usize
    }
}

/// Why a run stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum TailOutcome {
    /// Every estimate has a coefficient of variation at or below the target.
    TargetReached,
    /// The evaluation cap ended the run first; the estimates are those reached so far.
    EvaluationCapReached,
    /// A run needed more than [`MAX_LEVELS`] levels: the largest threshold is beyond what
    /// `w` reaches (or has a probability below `p0^MAX_LEVELS`).
    LevelLimitReached,
}

/// The estimate at one threshold.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TailEstimate {
    /// `L`, mm.
    pub threshold: f64,
    /// `P̂_f = Pr[w ≥ L]`; 0 when no sample reached `L`.
    pub p_f: f64,
    /// Estimated coefficient of variation of `p_f`; `None` when `p_f = 0`.
    pub cov: Option<f64>,
    /// Subset simulation: Au & Beck's `√(Σ_j δ_j²)`, which treats the levels as independent (a
    /// lower bound of the coefficient of variation); crude MC: equal to `cov`.
    pub cov_independent_levels: Option<f64>,
    /// `β = −Φ⁻¹(p_f)`; `None` when `p_f` is 0 or 1 (β = ±∞).
    pub beta: Option<f64>,
}

impl TailEstimate {
    fn new(threshold: f64, p_f: f64, cov: Option<f64>, cov_independent: Option<f64>) -> Self {
        let ok = p_f > 0.0 && cov.is_some();
        TailEstimate {
            threshold,
            p_f: if ok { p_f } else { 0.0 },
            cov: cov.filter(|_| ok),
            cov_independent_levels: cov_independent.filter(|_| ok),
            beta: (ok && p_f < 1.0).then(|| -normal_quantile(p_f)),
        }
    }
}

/// One level of one subset-simulation run.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LevelSummary {
    /// `b_j`, the threshold the level's samples exceed (mm); `None` for level 0.
    pub lower: Option<f64>,
    /// `b_{j+1}`, the `N_c`-th largest `w` of the level; `None` for the final level.
    pub next: Option<f64>,
    /// `p_j = #{w ≥ b_{j+1}} / N`; `None` for the final level.
    pub p: Option<f64>,
    /// `γ_j` of the indicator `1[w ≥ b_{j+1}]` (0 at level 0 and the final level).
    pub gamma: f64,
    /// Fraction of Markov steps that moved the chain (`None` for level 0).
    pub acceptance: Option<f64>,
    /// Adaptive conditional sampling: the scale `λ` at the level's first step (`None` for level
    /// 0 and for modified Metropolis).
    pub scale: Option<f64>,
    /// Evaluations spent on this level.
    pub evaluations: u64,
}

/// One subset-simulation run.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SubsetRun {
    /// Samples per level `N` of this run.
    pub samples_per_level: usize,
    /// Levels, from level 0.
    pub levels: Vec<LevelSummary>,
    /// Whether the levels reached the largest threshold.
    pub complete: bool,
    /// Evaluations of this run.
    pub evaluations: u64,
    /// This run's estimate at each threshold, in the order given.
    pub estimates: Vec<TailEstimate>,
}

/// The result of [`run_tail`] (serialisable for reports).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TailResult {
    /// Estimator.
    pub method: TailMethod,
    /// Why the run stopped.
    pub outcome: TailOutcome,
    /// The estimate at each threshold, in the order given (for subset simulation those of the
    /// last complete run, else of the first, cut-short run).
    pub estimates: Vec<TailEstimate>,
    /// Model evaluations spent.
    pub evaluations: u64,
    /// Target coefficient of variation.
    pub target_cov: f64,
    /// Evaluation cap.
    pub max_evaluations: u64,
    /// Dimension `d` of the standard-normal space (free parameters).
    pub dimension: usize,
    /// Subset simulation: `p0`, the proposal spread (`None` for crude MC).
    pub subset: Option<SubsetSettings>,
    /// Subset simulation: every run, the pilot first (empty for crude MC).
    pub runs: Vec<SubsetRun>,
    /// Backend that evaluated `w`.
    pub backend: BackendInfo,
    /// Wall-clock seconds.
    pub seconds: f64,
}

/// The subset-simulation settings of a run, as reported.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SubsetSettings {
    /// Samples per level `N` of the pilot run.
    pub pilot_samples_per_level: usize,
    /// Level probability `p0`.
    pub p0: f64,
    /// How the chains propose.
    pub proposal: ChainProposal,
    /// Proposal spread `s` (modified Metropolis only).
    pub proposal_spread: f64,
}

/// Estimates `Pr[w ≥ L]` for each threshold of `opts` on `eval`, whose problem's parameter
/// distribution is `sampler` (use the sampler of the [`crate::engine::Problem`] the evaluator
/// was built from: it gives the map `u ↦ L u` and the Philox key). See the module docs.
pub fn run_tail(
    eval: &mut dyn Evaluator,
    sampler: &ParamSampler,
    opts: &TailOptions,
    progress: Option<Progress>,
) -> Result<TailResult, TailError> {
    opts.check()?;
    let start = std::time::Instant::now();
    let space = NormalSpace::new(sampler)?;
    let backend = eval.info();
    let mut m = Model {
        eval,
        space,
        gen: Philox { key: sampler.key() },
        evaluations: 0,
        batch: opts.batch_size,
        progress,
        cap: opts.max_evaluations,
    };
    let (outcome, estimates, runs, subset) = match opts.method {
        TailMethod::MonteCarlo => {
            let (o, e) = crude_mc(&mut m, opts)?;
            (o, e, Vec::new(), None)
        }
        TailMethod::Subset => {
            let (o, e, r) = subset_simulation(&mut m, opts)?;
            let s = SubsetSettings {
                pilot_samples_per_level: opts.samples_per_level,
                p0: opts.p0,
                proposal: opts.proposal,
                proposal_spread: opts.proposal_spread,
            };
            (o, e, r, Some(s))
        }
    };
    Ok(TailResult {
        method: opts.method,
        outcome,
        estimates,
        evaluations: m.evaluations,
        target_cov: opts.target_cov,
        max_evaluations: opts.max_evaluations,
        dimension: m.space.dim(),
        subset,
        runs,
        backend,
        seconds: start.elapsed().as_secs_f64(),
    })
}

/// The map `u ↦ δ = L u` from the standard-normal space to parameter offsets.
struct NormalSpace {
    free: Vec<usize>,
    /// Standard deviations of the free parameters (independent), or the row-major lower
    /// Cholesky factor (`d²` entries).
    factor: Vec<f64>,
    diagonal: bool,
}

impl NormalSpace {
    fn new(sampler: &ParamSampler) -> Result<Self, TailError> {
        let space = if let Some((free, chol)) = sampler.cholesky() {
            NormalSpace {
                free: free.to_vec(),
                factor: chol.to_vec(),
                diagonal: false,
            }
        } else {
            let s = sampler.sigmas().copied().unwrap_or([0.0; N_UNCERTAIN]);
            let free: Vec<usize> = (0..N_UNCERTAIN).filter(|&i| s[i] > 0.0).collect();
            NormalSpace {
                factor: free.iter().map(|&i| s[i]).collect(),
                free,
                diagonal: true,
            }
        };
        if space.free.is_empty() {
            return Err(TailError::NoUncertainty);
        }
        Ok(space)
    }

    fn dim(&self) -> usize {
        self.free.len()
    }

    /// Writes the offsets of `u` (length d) into `out` (length `N_UNCERTAIN`).
    fn offsets(&self, u: &[f64], out: &mut [f64]) {
        out.fill(0.0);
        let d = self.dim();
        for (a, &p) in self.free.iter().enumerate() {
            out[p] = if self.diagonal {
                self.factor[a] * u[a]
            } else {
                (0..=a).map(|b| self.factor[a * d + b] * u[b]).sum()
            };
        }
    }
}

/// The evaluator with its standard-normal map, generator and evaluation count.
struct Model<'a> {
    eval: &'a mut dyn Evaluator,
    space: NormalSpace,
    gen: Philox,
    evaluations: u64,
    batch: usize,
    progress: Option<Progress<'a>>,
    cap: u64,
}

impl Model<'_> {
    /// `w` of the rows of `u` (`w.len()` rows of `d`), in evaluator calls of at most `batch`
    /// rows.
    fn eval_u(&mut self, u: &[f64], w: &mut [f64]) -> Result<(), TailError> {
        let d = self.space.dim();
        let mut offsets = Vec::new();
        for (uc, wc) in u.chunks(self.batch * d).zip(w.chunks_mut(self.batch)) {
            offsets.resize(wc.len() * N_UNCERTAIN, 0.0);
            for (row, o) in uc.chunks(d).zip(offsets.chunks_mut(N_UNCERTAIN)) {
                self.space.offsets(row, o);
            }
            self.eval.evaluate_offsets(&offsets, wc, None)?;
            self.account(wc)?;
        }
        Ok(())
    }

    /// Counts evaluated rows, rejects non-finite values and reports progress.
    fn account(&mut self, w: &[f64]) -> Result<(), TailError> {
        if let Some(&value) = w.iter().find(|v| !v.is_finite()) {
            return Err(TailError::NonFinite { value });
        }
        self.evaluations += w.len() as u64;
        if let Some(cb) = self.progress {
            cb(self.evaluations, self.cap);
        }
        Ok(())
    }

    /// Fills `out` with standard normals of counter `(state, run, block, stream)`, blocks
    /// from `first_block` on.
    fn normals(&self, state: u64, stream: u32, first_block: u32, out: &mut [f64]) {
        for (b, chunk) in out.chunks_mut(4).enumerate() {
            let w = self.block(state, first_block + b as u32, stream);
            let (a, bb) = box_muller(w[0], w[1]);
            let (c, dd) = box_muller(w[2], w[3]);
            for (o, z) in chunk.iter_mut().zip([a, bb, c, dd]) {
                *o = z;
            }
        }
    }

    /// Fills `out` with uniforms in (0, 1), as [`Self::normals`].
    fn uniforms(&self, state: u64, stream: u32, first_block: u32, out: &mut [f64]) {
        for (b, chunk) in out.chunks_mut(4).enumerate() {
            let w = self.block(state, first_block + b as u32, stream);
            for (o, x) in chunk.iter_mut().zip(w) {
                *o = uniform_open(x);
            }
        }
    }

    /// `state` carries the state index in its low and the run number in its high word.
    fn block(&self, state: u64, block: u32, stream: u32) -> [u32; 4] {
        self.gen.block(state, block, stream)
    }
}

/// Crude Monte Carlo on the counter draws `0, 1, …`.
fn crude_mc(
    m: &mut Model,
    opts: &TailOptions,
) -> Result<(TailOutcome, Vec<TailEstimate>), TailError> {
    let ls = &opts.thresholds;
    let mut counts = vec![0u64; ls.len()];
    let mut w = vec![0.0; opts.batch_size];
    let cov = |c: u64, n: u64| {
        let p = c as f64 / n as f64;
        (c > 0).then(|| ((1.0 - p) / c as f64).sqrt())
    };
    let outcome = loop {
        let n = m.evaluations;
        let reached = n > 0
            && counts
                .iter()
                .all(|&c| cov(c, n).is_some_and(|d| d <= opts.target_cov));
        if reached {
            break TailOutcome::TargetReached;
        }
        if n >= opts.max_evaluations {
            break TailOutcome::EvaluationCapReached;
        }
        let k = (opts.max_evaluations - n).min(opts.batch_size as u64) as usize;
        m.eval.evaluate(n, &mut w[..k], None)?;
        m.account(&w[..k])?;
        for (c, &l) in counts.iter_mut().zip(ls) {
            *c += w[..k].iter().filter(|&&v| v >= l).count() as u64;
        }
    };
    let n = m.evaluations;
    let est = counts
        .iter()
        .zip(ls)
        .map(|(&c, &l)| TailEstimate::new(l, c as f64 / n as f64, cov(c, n), cov(c, n)))
        .collect();
    Ok((outcome, est))
}

/// The samples of one level: `N_c'` chains of `N_s'` consecutive states (level 0: `N` chains of
/// one state).
struct Level {
    u: Vec<f64>,
    w: Vec<f64>,
    chains: usize,
    lower: Option<f64>,
}

impl Level {
    /// The level without its states `u`, which the estimates do not need (a run keeps only
    /// two levels' states at a time).
    fn without_states(self) -> Level {
        Level {
            u: Vec::new(),
            ..self
        }
    }

    /// `#{w ≥ l}/N` and `γ` of the indicator `1[w ≥ l]` over the chains.
    fn fraction(&self, l: f64) -> (f64, f64) {
        let ind: Vec<bool> = self.w.iter().map(|&v| v >= l).collect();
        let n = ind.len();
        let p = ind.iter().filter(|&&b| b).count() as f64 / n as f64;
        (p, gamma(&ind, self.chains))
    }
}

/// Au & Beck (2001) eq. 29: `γ = 2 Σ_{τ=1}^{N_s−1} (1 − τ N_c/N) ρ(τ)` for `chains` chains of
/// consecutive entries of `ind`.
pub fn gamma(ind: &[bool], chains: usize) -> f64 {
    let n = ind.len();
    let ns = n / chains;
    let p = ind.iter().filter(|&&b| b).count() as f64 / n as f64;
    let r0 = p * (1.0 - p);
    if ns < 2 || r0 <= 0.0 {
        return 0.0;
    }
    let mut g = 0.0;
    for tau in 1..ns {
        let mut s = 0usize;
        for c in ind.chunks(ns) {
            s += c.iter().zip(&c[tau..]).filter(|(a, b)| **a && **b).count();
        }
        let r = s as f64 / (n - tau * chains) as f64 - p * p;
        g += 2.0 * (1.0 - (tau * chains) as f64 / n as f64) * r / r0;
    }
    g
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
        let (_, g) = level.fraction(b_next);
        summary.next = Some(b_next);
        summary.p = Some(p);
        summary.gamma = g;
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

/// Target acceptance rate of [`ChainProposal::AdaptiveConditional`] (Papaioannou et al. 2015
/// §4.2, after the optimal rate of random-walk proposals in one dimension).
pub const TARGET_ACCEPTANCE: f64 = 0.44;

/// Initial scale `λ` of [`ChainProposal::AdaptiveConditional`] at the first Markov level
/// (Papaioannou et al. 2015); later levels start from the previous level's last `λ`.
pub const INITIAL_SCALE: f64 = 0.6;

/// The proposal of one Markov step of every component of one chain.
enum Step {
    /// Modified Metropolis with spread `s`.
    Metropolis(f64),
    /// Conditional sampling with `σ_k` and `ρ_k = √(1 − σ_k²)` per component.
    Conditional(Vec<(f64, f64)>),
}

impl Step {
    /// Writes the candidate from `x` with the normals `eps` and the uniforms `unif` into `row`;
    /// false when modified Metropolis rejected every component (the chain stays without an
    /// evaluation).
    fn candidate(&self, x: &[f64], eps: &[f64], unif: &[f64], row: &mut Vec<f64>) -> bool {
        row.clear();
        match self {
            Step::Metropolis(s) => {
                let mut changed = false;
                for c in 0..x.len() {
                    let xi = x[c] + s * eps[c];
                    let ratio = (0.5 * (x[c] * x[c] - xi * xi)).exp();
                    if unif[c] < ratio {
                        changed = true;
                        row.push(xi);
                    } else {
                        row.push(x[c]);
                    }
                }
                changed
            }
            Step::Conditional(sr) => {
                row.extend(
                    x.iter()
                        .zip(eps)
                        .zip(sr)
                        .map(|((x, e), (s, r))| r * x + s * e),
                );
                true
            }
        }
    }
}

/// The per-component spread `σ̂_k` of the seed rows `seeds` of `u` (`d` columns); 1 (the
/// unconditional spread) for a single seed, which has none.
fn seed_spread(u: &[f64], seeds: &[usize], d: usize) -> Vec<f64> {
    if seeds.len() < 2 {
        return vec![1.0; d];
    }
    let n = seeds.len() as f64;
    (0..d)
        .map(|c| {
            let mean = seeds.iter().map(|&i| u[i * d + c]).sum::<f64>() / n;
            let ss = seeds
                .iter()
                .map(|&i| (u[i * d + c] - mean).powi(2))
                .sum::<f64>();
            (ss / (n - 1.0)).sqrt()
        })
        .collect()
}

/// The Markov chains of level `j`, seeded by the rows `seeds` of `prev`, conditioned on
/// `w ≥ b`; returns the level and the number of moves. `scale` is the adaptive `λ` of
/// [`ChainProposal::AdaptiveConditional`], carried from level to level.
///
/// All chains take step `t` together (one evaluator batch). With the adaptive proposal every
/// chain uses the same `λ_t` at step `t`, and after the step `λ_{t+1} = λ_t exp((â_t − a*)/√t)`
/// from the step's acceptance rate `â_t` over the chains (Papaioannou et al. 2015 adapt after
/// groups of chains; here the groups are the steps, which keeps the batches `N_c` rows large).
#[allow(clippy::too_many_arguments)]
fn mcmc_level(
    m: &mut Model,
    opts: &TailOptions,
    prev: &Level,
    seeds: &[usize],
    b: f64,
    j: usize,
    hi: u64,
    nb: u32,
    scale: &mut f64,
) -> Result<(Level, usize), TailError> {
    let (n, nc, d) = (prev.w.len(), seeds.len(), m.space.dim());
    let ns = n / nc;
    let stream = TAIL_STREAM + j as u32;
    let spread = seed_spread(&prev.u, seeds, d);
    let mut u = vec![0.0; n * d];
    let mut w = vec![0.0; n];
    for (k, &i) in seeds.iter().enumerate() {
        u[k * ns * d..][..d].copy_from_slice(&prev.u[i * d..][..d]);
        w[k * ns] = prev.w[i];
    }
    let (mut eps, mut unif) = (vec![0.0; d], vec![0.0; d]);
    let mut cand = Vec::with_capacity(nc * d);
    let mut row = Vec::with_capacity(d);
    let mut moved = Vec::with_capacity(nc);
    let mut wc = Vec::with_capacity(nc);
    let mut accepted = 0;
    for t in 1..ns {
        let step = match opts.proposal {
            ChainProposal::ModifiedMetropolis => Step::Metropolis(opts.proposal_spread),
            ChainProposal::AdaptiveConditional => Step::Conditional(
                spread
                    .iter()
                    .map(|s| {
                        let sigma = (*scale * s).min(1.0);
                        (sigma, (1.0 - sigma * sigma).sqrt())
                    })
                    .collect(),
            ),
        };
        cand.clear();
        moved.clear();
        for k in 0..nc {
            let (cur, dst) = (k * ns + t - 1, k * ns + t);
            let state = hi | dst as u64;
            m.normals(state, stream, 0, &mut eps);
            if matches!(step, Step::Metropolis(_)) {
                m.uniforms(state, stream, nb, &mut unif);
            }
            if step.candidate(&u[cur * d..][..d], &eps, &unif, &mut row) {
                cand.extend_from_slice(&row);
                moved.push(k);
            }
            // Start from the current state; overwritten below when the candidate is accepted.
            u.copy_within(cur * d..(cur + 1) * d, dst * d);
            w[dst] = w[cur];
        }
        wc.resize(moved.len(), 0.0);
        m.eval_u(&cand, &mut wc)?;
        let mut step_accepted = 0;
        for (x, &k) in moved.iter().enumerate() {
            if wc[x] >= b {
                let dst = k * ns + t;
                u[dst * d..][..d].copy_from_slice(&cand[x * d..][..d]);
                w[dst] = wc[x];
                step_accepted += 1;
            }
        }
        accepted += step_accepted;
        if matches!(step, Step::Conditional(_)) {
            let rate = step_accepted as f64 / nc as f64;
            *scale *= ((rate - TARGET_ACCEPTANCE) / (t as f64).sqrt()).exp();
        }
    }
    Ok((
        Level {
            u,
            w,
            chains: nc,
            lower: Some(b),
        },
        accepted,
    ))
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
    for s in &summaries[..j] {
        let p = s.p.unwrap_or(1.0);
        p_f *= p;
        deltas.push(delta(p, s.gamma));
    }
    let (p, g) = levels[j].fraction(l);
    if p == 0.0 {
        return TailEstimate::new(l, 0.0, None, None);
    }
    deltas.push(delta(p, g));
    let independent = deltas.iter().map(|d| d * d).sum::<f64>().sqrt();
    TailEstimate::new(
        l,
        p_f * p,
        Some(proposal.combined_cov(&deltas)),
        Some(independent),
    )
}

impl ChainProposal {
    /// The coefficient of variation of `P̂_f` from the levels' `δ_j` (Au & Beck 2001 eq. 27–30,
    /// in level order, the final level's fraction last): modified Metropolis, whose chains move
    /// little and carry their seeds' excess on through many levels, takes the fully correlated
    /// bound `Σ_j δ_j`; adaptive conditional sampling, whose chains forget their seeds within a
    /// level, takes adjacent levels as fully correlated and the others as uncorrelated,
    /// `√(Σ_j δ_j² + 2 Σ_j δ_j δ_{j+1})`. Both were measured honest (within a factor 1.5 of the
    /// spread over 200 seeds, on the conservative side) where the other is not; see the module
    /// docs.
    pub fn combined_cov(self, deltas: &[f64]) -> f64 {
        match self {
            ChainProposal::ModifiedMetropolis => deltas.iter().sum(),
            ChainProposal::AdaptiveConditional => {
                let squares: f64 = deltas.iter().map(|d| d * d).sum();
                let adjacent: f64 = deltas.windows(2).map(|w| w[0] * w[1]).sum();
                (squares + 2.0 * adjacent).sqrt()
            }
        }
    }
}

type SubsetOutput = (TailOutcome, Vec<TailEstimate>, Vec<SubsetRun>);

/// Safety factor on the predicted `N` of the next run: the coefficient of variation is itself
/// estimated.
const N_MARGIN: f64 = 1.2;

/// A pilot run with `N` = [`TailOptions::samples_per_level`], then runs with `N` grown by
/// `(δ/target)²` until every threshold meets the target or the cap.
fn subset_simulation(m: &mut Model, opts: &TailOptions) -> Result<SubsetOutput, TailError> {
    // N = N_c · N_s with N_s = 1/p0 fixed: N_c scales.
    let ns = opts.samples_per_level / opts.chains();
    let mut n = opts.samples_per_level;
    let mut runs: Vec<SubsetRun> = Vec::new();
    let outcome = loop {
        let (run, outcome) = subset_run(m, opts, n, runs.len() as u32)?;
        let worst = run
            .estimates
            .iter()
            .map(|e| e.cov.unwrap_or(f64::INFINITY))
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

/// The standard normal quantile `Φ⁻¹(p)` for `p ∈ (0, 1)` (Acklam's rational approximation,
/// relative error below 1.2e-9 over the whole range); ±∞ at 0 and 1, NaN outside.
pub fn normal_quantile(p: f64) -> f64 {
    const A: [f64; 6] = [
        -3.969_683_028_665_376e1,
        2.209_460_984_245_205e2,
        -2.759_285_104_469_687e2,
        1.383_577_518_672_69e2,
        -3.066_479_806_614_716e1,
        2.506_628_277_459_239,
    ];
    const B: [f64; 5] = [
        -5.447_609_879_822_406e1,
        1.615_858_368_580_409e2,
        -1.556_989_798_598_866e2,
        6.680_131_188_771_972e1,
        -1.328_068_155_288_572e1,
    ];
    const C: [f64; 6] = [
        -7.784_894_002_430_293e-3,
        -3.223_964_580_411_365e-1,
        -2.400_758_277_161_838,
        -2.549_732_539_343_734,
        4.374_664_141_464_968,
        2.938_163_982_698_783,
    ];
    const D: [f64; 4] = [
        7.784_695_709_041_462e-3,
        3.224_671_290_700_398e-1,
        2.445_134_137_142_996,
        3.754_408_661_907_416,
    ];
    const P_LOW: f64 = 0.024_25;
    if !(0.0..=1.0).contains(&p) {
        return f64::NAN;
    }
    if p == 0.0 {
        return f64::NEG_INFINITY;
    }
    if p == 1.0 {
        return f64::INFINITY;
    }
    let tail = |q: f64| {
        let q = (-2.0 * q.ln()).sqrt();
        (((((C[0] * q + C[1]) * q + C[2]) * q + C[3]) * q + C[4]) * q + C[5])
            / ((((D[0] * q + D[1]) * q + D[2]) * q + D[3]) * q + 1.0)
    };
    if p < P_LOW {
        tail(p)
    } else if p > 1.0 - P_LOW {
        -tail(1.0 - p)
    } else {
        let q = p - 0.5;
        let r = q * q;
        (((((A[0] * r + A[1]) * r + A[2]) * r + A[3]) * r + A[4]) * r + A[5]) * q
            / (((((B[0] * r + B[1]) * r + B[2]) * r + B[3]) * r + B[4]) * r + 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::{tx60, Uncertainty, N_PARAMS};
    use crate::sampling::normals_block;

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

    /// The map `u ↦ L u` reproduces the sampler's draw `k` from that draw's normals, for the
    /// σ list and for a full covariance with correlations.
    #[test]
    fn normal_space_reproduces_the_sampler() {
        let mut corr = tx60();
        let s = corr.uncertainty.sigmas();
        let mut c = vec![0.0; N_PARAMS * N_PARAMS];
        for i in 0..N_PARAMS {
            c[i * N_PARAMS + i] = s[i] * s[i];
        }
        c[N_PARAMS + 2] = 0.6 * s[1] * s[2];
        c[2 * N_PARAMS + 1] = c[N_PARAMS + 2];
        corr.uncertainty = Uncertainty::Covariance(c);
        for model in [tx60(), corr] {
            let sampler = ParamSampler::new(&model, 17).unwrap();
            let space = NormalSpace::new(&sampler).unwrap();
            let g = Philox { key: sampler.key() };
            for k in [0u64, 5, 1 << 33] {
                let z: Vec<f64> = (0..9).flat_map(|b| normals_block(&g, k, b, 0)).collect();
                let u: Vec<f64> = space.free.iter().map(|&i| z[i]).collect();
                let mut mine = [0.0; N_UNCERTAIN];
                space.offsets(&u, &mut mine);
                let mut theirs = [0.0; N_UNCERTAIN];
                sampler.deltas(k, &mut theirs);
                for i in 0..N_UNCERTAIN {
                    assert!((mine[i] - theirs[i]).abs() <= 1e-15 * theirs[i].abs().max(1e-3));
                }
            }
        }
    }

    #[test]
    fn combined_cov_of_the_two_proposals() {
        let d = [0.1, 0.2, 0.3];
        assert!((ChainProposal::ModifiedMetropolis.combined_cov(&d) - 0.6).abs() < 1e-15);
        // 0.01 + 0.04 + 0.09 + 2 (0.02 + 0.06) = 0.30.
        let acs = ChainProposal::AdaptiveConditional.combined_cov(&d);
        assert!((acs - 0.3f64.sqrt()).abs() < 1e-15);
        // One level: both are δ_0.
        for p in [
            ChainProposal::ModifiedMetropolis,
            ChainProposal::AdaptiveConditional,
        ] {
            assert!((p.combined_cov(&[0.25]) - 0.25).abs() < 1e-15);
        }
    }

    #[test]
    fn quantile_edges_and_symmetry() {
        assert_eq!(normal_quantile(0.5), 0.0);
        assert_eq!(normal_quantile(0.0), f64::NEG_INFINITY);
        assert_eq!(normal_quantile(1.0), f64::INFINITY);
        assert!(normal_quantile(-0.1).is_nan() && normal_quantile(f64::NAN).is_nan());
        // Φ⁻¹(0.975) = 1.959963984540054 (tables).
        assert!((normal_quantile(0.975) - 1.959_963_984_540_054).abs() < 3e-9);
        for p in [1e-4, 0.01, 0.3] {
            assert!((normal_quantile(p) + normal_quantile(1.0 - p)).abs() < 1e-9);
        }
    }
}
