//! Tail probabilities `P_f(L) = Pr[w ≥ L]` down to 1e-9 by subset simulation (Au & Beck 2001),
//! with crude Monte Carlo for comparison, and the reliability index `β = −Φ⁻¹(P_f)`.
//!
//! # The standard-normal space
//!
//! The parameters are Gaussian, so draw `μ = μ̄ + L u` with `u ~ N(0, I_d)` is exact: `d` is the
//! number of free parameters (nonzero variance), `L` the diagonal of their standard deviations
//! (independent model) or the lower Cholesky factor the
//! [`ParamSampler`](crate::sampling::ParamSampler) already holds (full covariance,
//! `docs/METHOD.md §6`). A model of `n` joints has `5n + 3` inputs (33 for six joints: the `5n`
//! parameters, then the tool point); one with an uncertain base placement analysed in the
//! measurement frame has `5n + 9` (39), the placement's six after those, and `L` is the factor
//! of their covariance on its free inputs ([`PlacementSpread`](crate::engine::PlacementSpread),
//! `docs/METHOD.md §2.8`). Subset simulation works on `u`; every evaluation maps `u` to the
//! offsets `δ = L u` and goes through [`Evaluator::evaluate_offsets`], so the CPU and the GPU
//! backends carry it alike. A model's discrepancy term adds `2m + 1` normals after the
//! parameters' (a radius and a direction per test point, the draw's size; `term.rs`), applied
//! to the offset rows' per-point errors.
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
//! depends on the proposal and the problem, so [`ChainProposal::combined_cov`] combines the `δ_j`
//! per proposal, and [`TailEstimate::cov_independent_levels`] always reports the lower bound.
//! Measured with `N = 500` (empirical coefficient of variation / mean reported, ratio):
//!
//! * Adaptive conditional sampling, levels `i < k` correlated by the product of the levels'
//!   seed carries `c_m = (1 + Σ_τ ρ_m(τ))/N_s` in between (measured in the run): θ1-only TX60
//!   (one normal, two failure regions) 0.50 / 0.48 (1.05) at `P_f = 1e-4` and 0.67 / 0.62
//!   (1.07) at 1e-6 over 200 seeds; the default TX60 (20 normals, 5 points) 0.49 / 0.50 (0.98)
//!   at 6e-5 over 1000 seeds. Adjacent levels taken as fully correlated gave 0.72–0.82, the
//!   lower bound 1.17–1.36.
//! * Modified Metropolis, fully correlated levels `Σ_j δ_j`: θ1-only 1.01 / 1.03 at 1e-4 and
//!   1.71 / 1.70 at 1e-6 over 200 seeds (over 1000 seeds the heavy tail of its estimates at 1e-6
//!   gives 2.75 / 1.70).
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
//! All normals and uniforms come from the run's Philox key ([`ParamSampler::key`](crate::sampling::ParamSampler::key)) with the
//! counter `[state index, run, block, stream]`: stream [`TAIL_STREAM`] for level 0 and
//! `TAIL_STREAM + j` for the Markov steps of level `j`; blocks `0 … ⌈d/4⌉ − 1` give the normals
//! (Box–Muller, as the parameter draws) and the next `⌈d/4⌉` blocks the uniforms of the
//! component acceptance (modified Metropolis only). The state index of chain `k`, step `t` is `k N_s + t`. So a run depends
//! only on the seed and the options, not on thread count, batch size or backend. The counter
//! layout and the Box–Muller normals are those of the draw definition (`docs/METHOD.md §6`).

mod crude;
mod joint;
mod mcmc;
mod options;
mod result;
mod space;
mod subset;
mod term;

pub use crate::normal::normal_quantile;
pub use mcmc::{INITIAL_SCALE, TARGET_ACCEPTANCE};
pub use options::{ChainProposal, TailError, TailMethod, TailOptions, TailSetting, MIN_CHAINS};
pub use result::{LevelSummary, SubsetRun, SubsetSettings, TailEstimate, TailOutcome, TailResult};
pub use subset::gamma;

use super::result::Progress;
use crate::engine::{EngineError, Evaluator, Problem};
use crate::sampling::Philox;
use crude::crude_mc;
use space::{Model, NormalSpace};
use subset::subset_simulation;

/// First Philox stream of subset simulation: level 0 uses it, the Markov steps of level `j` use
/// `TAIL_STREAM + j` (the parameter draws use stream 0).
pub const TAIL_STREAM: u32 = 0x7A11_0000;

/// Most levels of one run: `p0^200` is below 1e-60 for every allowed `p0`, so a threshold
/// that needs more lies beyond what `w` can reach (it is bounded for a robot's rotations).
pub const MAX_LEVELS: usize = 200;

/// Largest `N` of a run, given or grown (bounds the memory: two levels of `N · (d + 1)`
/// numbers, 0.5 GB for the 30 parameters of a 6R robot, 0.6 GB for the 35 of a 7R one).
pub const MAX_SAMPLES_PER_LEVEL: usize = 1 << 20;

/// Largest accepted [`TailOptions::batch_size`].
pub const MAX_BATCH: usize = 1 << 22;

/// Estimates `Pr[w ≥ L]` for each threshold of `opts` on `eval`, built for `problem` (whose
/// distribution gives the map `u ↦ L u` and the Philox key; with an uncertain base placement
/// the `5n + 9` inputs of the measurement frame, else the `5n + 3`; 39 and 33 for six joints).
/// See the module docs.
///
/// # Errors
///
/// [`TailError::Setting`] for an option out of range ([`TailOptions::check`]),
/// [`TailError::NoUncertainty`] when no parameter has a nonzero variance, [`TailError::Engine`]
/// when the evaluator fails, and [`TailError::NonFinite`] when it returns a `w` that is not finite.
/// Reaching the evaluation cap or [`MAX_LEVELS`] is not an error: see [`TailResult::outcome`].
///
/// # Examples
///
/// `Pr[w ≥ 0.2 mm]` (about 1e-4) of the TX60 at five test points by subset simulation on the
/// CPU evaluator, with a loose target and a small cap (a few thousand evaluations):
///
/// ```
/// use gpu_amcs_core::engine::{CpuEvaluator, Problem, Reference};
/// use gpu_amcs_core::mc::tail::{run_tail, TailOptions};
///
/// let model = gpu_amcs_core::kinematics::tx60();
/// let points = gpu_amcs_core::points::generate(&model, 5, &Default::default(), 1)?;
/// let problem = Problem::new(model, &points, &Reference::Calibrated, 2025)?;
/// let opts = TailOptions {
///     thresholds: vec![0.2],
///     target_cov: 0.5,
///     samples_per_level: 200,
///     max_evaluations: 20_000,
///     ..TailOptions::default()
/// };
/// let result = run_tail(&mut CpuEvaluator::new(problem.clone()), &problem, &opts, None)?;
/// let e = &result.estimates[0];
/// assert!(e.p_f > 1e-6 && e.p_f < 1e-2 && result.evaluations <= 20_000);
/// println!("P_f = {:.2e} (cov {:?}, beta {:?})", e.p_f, e.cov, e.beta);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn run_tail(
    eval: &mut dyn Evaluator,
    problem: &Problem,
    opts: &TailOptions,
    progress: Option<Progress>,
) -> Result<TailResult, TailError> {
    opts.check()?;
    let start = std::time::Instant::now();
    let space = NormalSpace::new(problem)?;
    if space.width != eval.offset_width() {
        return Err(TailError::Engine(EngineError::Placement(format!(
            "the evaluator takes {} inputs per row and the problem draws {}: build both from the same problem",
            eval.offset_width(),
            space.width
        ))));
    }
    let sampler = &problem.sampler;
    // A model with joint errors has its rows evaluated by the exact point form (joint.rs).
    // Subset simulation evaluates the rows of a model with joint errors by the exact point
    // form (joint.rs); crude Monte Carlo takes the evaluator's counter draws, which draw them.
    let backend = match (&space.joint, opts.method) {
        (Some(_), TailMethod::Subset) => joint::JointSpace::backend(),
        _ => eval.info(),
    };
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
