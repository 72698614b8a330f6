//! What a tail-probability run reports: the estimate at each threshold, the levels and runs of
//! subset simulation, and why the run stopped.

use serde::Serialize;

use super::{normal_quantile, ChainProposal, TailMethod};
use crate::engine::BackendInfo;

/// Why a run stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum TailOutcome {
    /// Every estimate has a coefficient of variation at or below the target.
    TargetReached,
    /// The evaluation cap ended the run first; the estimates are those reached so far.
    EvaluationCapReached,
    /// A run needed more than [`MAX_LEVELS`](super::MAX_LEVELS) levels: the largest threshold is beyond what
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
    pub(super) fn new(
        threshold: f64,
        p_f: f64,
        cov: Option<f64>,
        cov_independent: Option<f64>,
    ) -> Self {
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
    /// The seeds' share of the same indicator's chains (`(1 + Σ_τ ρ_j(τ)) / N_s`, see
    /// [`ChainProposal::combined_cov`]; 0 at level 0 and the final level).
    pub seed_carry: f64,
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

/// The result of [`run_tail`](super::run_tail) (serialisable for reports).
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
