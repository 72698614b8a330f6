//! The settings of a tail-probability run ([`TailOptions`]), their checks and errors, and how
//! the Markov chains propose ([`ChainProposal`]).

use serde::Serialize;

use super::{MAX_BATCH, MAX_SAMPLES_PER_LEVEL};
use crate::engine::EngineError;

/// Fewest Markov chains a subset level may have (`p0 · N`): the coefficient of variation comes
/// from the correlation within and between the chains, which a handful of chains cannot give
/// (one chain: γ = −1 and a CoV of NaN; two or five: every chain stuck and P_f = 0 with the
/// default TX60).
pub const MIN_CHAINS: usize = 10;

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
    /// The memory a run with these options keeps, besides its problem's test points: two levels
    /// of states (each its normals, its offsets and `w`), four rows a state, for the larger of
    /// the samples per level and the batch size. `advice` says what to do when it does not fit
    /// (the front end's words).
    pub fn memory_estimate(&self, advice: impl Into<String>) -> crate::memory::Estimate {
        let states = (self.samples_per_level as u64).max(self.batch_size as u64);
        let state = 8 * (crate::kinematics::MAX_INPUTS as u64 + 2);
        crate::memory::Estimate::new(
            format!(
                "tail probabilities with {} samples per level",
                self.samples_per_level
            ),
            advice,
        )
        .plus(&[states, 4, state])
    }

    /// Checks every field; the error names the first field out of range.
    ///
    /// # Errors
    ///
    /// [`TailError::Setting`] naming the first field out of range: no thresholds or one that is not
    /// a finite positive length, a target coefficient of variation outside (0, 1), a batch size
    /// outside 1 … [`MAX_BATCH`], an evaluation cap of 0 or below one level, and for subset
    /// simulation `p0` outside (0, 0.5], a proposal spread that is not finite and positive, or
    /// samples per level outside 2 … [`MAX_SAMPLES_PER_LEVEL`], not divisible into `p0 · N`
    /// chains or giving fewer than [`MIN_CHAINS`] of them.
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
        if chains < MIN_CHAINS {
            return Err(setting(
                TailSetting::SamplesPerLevel,
                format!(
                    "{n} at p0 = {} gives {chains} Markov chain(s) per level; the estimate and its coefficient of variation need at least {MIN_CHAINS}: N ≥ {}",
                    self.p0,
                    (MIN_CHAINS as f64 / self.p0).ceil()
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

    pub(super) fn chains(&self) -> usize {
        (self.p0 * self.samples_per_level as f64).round() as usize
    }
}

impl ChainProposal {
    /// The coefficient of variation of `P̂_f` from the levels' `δ_j` (Au & Beck 2001 eq. 27–30,
    /// in level order, the final level's fraction last) and their seed carries `c_j`
    /// ([`LevelSummary::seed_carry`](super::LevelSummary::seed_carry), the final level's for its
    /// threshold, `c_0` unused).
    ///
    /// Adaptive conditional sampling takes the correlation of levels `i < k` as the share of
    /// level `i` that the chains carry down the lineage, `ρ_ik = Π_{m=i+1}^{k} c_m`:
    /// `δ² = Σ_j δ_j² + 2 Σ_{i<k} ρ_ik δ_i δ_k`. Chains that never move (`c = 1`) give the fully
    /// correlated `Σ_j δ_j`, chains that forget their seeds at once the nearly independent
    /// `√(Σ_j δ_j²)`; the measured carry lies between and adapts the figure to the problem
    /// (θ1-only TX60 with one normal and the default TX60 with 20: both within 0.97–1.13 of the
    /// empirical spread over 1000 seeds, where adjacent levels taken as fully correlated gave
    /// 0.72–0.82 and independent levels 1.17–1.36; see the module docs).
    ///
    /// Modified Metropolis takes the fully correlated `Σ_j δ_j`: its chains' measured carry
    /// (about 0.4 on the θ1-only TX60) understates how far their seeds' excess reaches (the
    /// lineage formula reports half the empirical spread there), while the sum is honest on
    /// average at `P_f = 1e-4`.
    pub fn combined_cov(self, deltas: &[f64], carries: &[f64]) -> f64 {
        match self {
            ChainProposal::ModifiedMetropolis => deltas.iter().sum(),
            ChainProposal::AdaptiveConditional => {
                let mut v: f64 = deltas.iter().map(|d| d * d).sum();
                for i in 0..deltas.len() {
                    let mut rho = 1.0;
                    for k in i + 1..deltas.len() {
                        rho *= carries[k];
                        v += 2.0 * rho * deltas[i] * deltas[k];
                    }
                }
                v.sqrt()
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn combined_cov_of_the_two_proposals() {
        let d = [0.1, 0.2, 0.3];
        let c = [0.0, 0.5, 0.4];
        let mma = ChainProposal::ModifiedMetropolis.combined_cov(&d, &c);
        assert!((mma - 0.6).abs() < 1e-15);
        // 0.01 + 0.04 + 0.09 + 2 (0.5·0.02 + 0.5·0.4·0.03 + 0.4·0.06) = 0.22.
        let acs = ChainProposal::AdaptiveConditional.combined_cov(&d, &c);
        assert!((acs - 0.22f64.sqrt()).abs() < 1e-15);
        // Chains that never move: fully correlated; that forget at once: independent.
        let stuck = ChainProposal::AdaptiveConditional.combined_cov(&d, &[0.0, 1.0, 1.0]);
        assert!((stuck - 0.6).abs() < 1e-14);
        let free = ChainProposal::AdaptiveConditional.combined_cov(&d, &[0.0; 3]);
        assert!((free - 0.14f64.sqrt()).abs() < 1e-14);
        // One level: both are δ_0.
        for p in [
            ChainProposal::ModifiedMetropolis,
            ChainProposal::AdaptiveConditional,
        ] {
            assert!((p.combined_cov(&[0.25], &[0.0]) - 0.25).abs() < 1e-15);
        }
    }
}
