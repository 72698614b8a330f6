//! Which parameters matter: first-order and total Sobol indices of the maximum point error `w`
//! (and of the failure indicators `1[w ≥ l_c]`) for every free parameter, per joint and per
//! kind of parameter.
//!
//! (A little over 600 lines: the estimators' notes below belong with the design that runs
//! them; the groups, the estimators and the bootstrap are submodules.)
//!
//! # Estimators
//!
//! With inputs `X = (X_1 … X_D)` independent and `Y = f(X)`, the first-order index of a set `S`
//! of inputs is `S_S = V[E(Y | X_S)] / V(Y)` and its total index
//! `S_T,S = E[V(Y | X_~S)] / V(Y)`. Two independent N × D sample matrices A and B and, for each
//! set `S`, the matrix `A_B^(S)` (A with the columns of `S` taken from B) give
//!
//! * first order, Saltelli et al. (2010), *Comput. Phys. Commun.* 181, 259–270, Table 2 (b):
//!   `V_S ≈ (1/N) Σ_k (f(B)_k − f̄) (f(A_B^(S))_k − f(A)_k)`;
//! * total, Jansen (1999): `VT_S ≈ (1/2N) Σ_k (f(A)_k − f(A_B^(S))_k)²`;
//! * `V(Y)` the sample variance of the 2N values `f(A) ∪ f(B)`, `f̄` their mean, and
//!   `S = V_S / V(Y)`, `S_T = VT_S / V(Y)`.
//!
//! Centring `f(B)` on `f̄` leaves the expectation of Saltelli's sum unchanged up to O(1/N)
//! (the difference `f(A_B^(S)) − f(A)` has mean zero) and removes the term `f̄ · Σ (f(A_B^(S)) − f(A))`, whose
//! variance would otherwise grow with the square of the mean of `w` (the mean of `w` is several
//! times its standard deviation). For a group, `S` is its closed index (all interactions inside
//! the group included). Both estimators are unbiased up to O(1/N) and need no other matrices,
//! so one input costs N evaluations: the D inputs cost `N · (D + 2)` model evaluations in all,
//! and each group whose member set is not a single input adds N more (reported as
//! [`SobolAnalysis::evaluations`]). Estimates are not clipped: sampling error can make an
//! index slightly negative or above 1, and the interval shows by how much.
//!
//! Confidence intervals: R resamples ([`SensitivityOptions::bootstrap`]) that weight each base
//! sample `k` by a Poisson(1) count (the Poisson bootstrap), shared by every index and quantity
//! so their replicates stay coherent; each resample recomputes `V(Y)`, `f̄` and every index as
//! weighted sums, and the 2.5 % and 97.5 % order statistics of the replicates give the 95 %
//! percentile interval, their standard deviation a standard error. The weights come from Philox
//! keyed by [`SensitivityOptions::bootstrap_seed`], so they are reproducible, and every sum runs
//! in a fixed order, so the results do not depend on the thread count. The whole analysis is
//! O(N): one pass over the outputs per group of resamples, `O(R · N · S)` for `w` and
//! `O(R · (N + L) · S)`, plus a binary search per output and group, for all `L` thresholds
//! together (bootstrap.rs).
//!
//! # Draw definition
//!
//! Row `k` of A is draw `k` of the run (the draw AMCS uses, [`ParamSampler::deltas`]); row `k`
//! of B is draw `2⁶³ + k` ([`B_DRAW_OFFSET`]) of the same counter-based stream, independent of
//! row `k` of A and of every other draw for any N the run can reach. Row `k` of `A_B^(S)` takes
//! the standard normals of the inputs in `S` from B's draw and the others from A's
//! ([`ParamSampler::pick_freeze_deltas`]). The evaluator generates these rows itself from the
//! two counter streams ([`Evaluator::evaluate_pick_freeze`], on the CPU and in the GPU shader
//! alike), chunk by chunk ([`SensitivityOptions::chunk`] base samples, one call of
//! `chunk · (2 + S)` rows, S the pick-freeze matrices): the only input a call carries is one
//! 36-bit mask per matrix, so no input matrix of size `N × D` is built, stored or uploaded, and
//! only the `N · (2 + S)` outputs are kept (for the bootstrap).
//!
//! # Inputs, and correlated parameters
//!
//! Sobol indices are defined for independent inputs. The inputs here are the independent
//! standard normals `u` behind each draw (normal `i` of the draw for free input `i`, in index
//! order), mapped to parameter offsets by `δ = M u` on the free parameters (σ > 0), with `M`
//! the diagonal of the σ for a model with independent parameters and the lower Cholesky factor
//! `L` of the covariance of the free parameters for a correlated model (`docs/METHOD.md §6`).
//!
//! * Independent parameters: `u_i = δ_i / σ_i`, so the index of `u_i` is that of parameter i
//!   ([`InputKind::IndependentParameters`]).
//! * Correlated model: `u = L⁻¹ δ`, and `u_i` is the *innovation* of parameter i in Cholesky
//!   order: the part of parameter i not explained by the parameters before it. Pick-freeze
//!   swaps components of `u`, and the index reported under a parameter's name is that of its
//!   innovation ([`InputKind::CholeskyInnovations`]). These indices depend on the parameter
//!   order (the first parameter's innovation carries everything it shares with the later
//!   ones); they answer "which independent source of variation matters", not "which
//!   parameter" in the sense of Shapley effects. Group
//!   indices of a whole joint or kind are of the innovations of its members.
//!
//! Parameters with σ = 0 are no inputs; they are listed in
//! [`SensitivityResult::skipped_parameters`].
//!
//! # Groups
//!
//! Besides each free parameter: per joint (`joint 1` … `joint n`) and per kind (`joint angles
//! θ`, `twists α/β`, `lengths a/d`), each over its free members; a group without free members
//! is left out.
//!
//! [`ParamSampler::deltas`]: crate::sampling::ParamSampler::deltas
//! [`ParamSampler::pick_freeze_deltas`]: crate::sampling::ParamSampler::pick_freeze_deltas
//!
//! This file holds the robot's inputs, their groups and the correlated-model handling; the
//! generic estimator is in estimator.rs, the weighted sums and the bootstrap in bootstrap.rs.

mod bootstrap;
mod estimator;
mod groups;

pub use bootstrap::THRESHOLD_BATCH_BYTES;

pub use estimator::{
    analyse_outputs, pick_freeze, pick_freeze_chunks, pick_freeze_outputs, rank, Estimate,
    InputGroup, Outputs, Quantity, QuantityIndices, SobolAnalysis, SobolIndex, CONFIDENCE,
    MIN_EVENTS,
};

use serde::{Deserialize, Serialize};

pub use groups::{param_name, DISCREPANCY_INPUT};

use crate::engine::{
    BackendInfo, EngineError, Evaluator, PickFreeze, PlacementSpread, Problem, TermGroup,
    DISCREPANCY_MASK,
};
use crate::kinematics::{Layout, MAX_JOINTS, MIN_JOINTS};
use crate::sampling::ALL_NORMALS;
use groups::input_groups;

/// Draw index offset of matrix B: row `k` of B is draw `B_DRAW_OFFSET + k`.
pub const B_DRAW_OFFSET: u64 = 1 << 63;
/// Smallest accepted number of base samples N.
pub const MIN_DRAWS: usize = 64;
/// Largest accepted number of base samples N: the `N · (2 + S)` outputs are kept for the
/// bootstrap (2²⁰ · 40 values are 336 MB), and each of the bootstrap resamples costs
/// `N · S` operations for `w` and as many for all thresholds together.
pub const MAX_DRAWS: usize = 1 << 20;
/// Fewest bootstrap resamples (the 2.5 % order statistic needs a few values below it).
pub const MIN_BOOTSTRAP: usize = 100;
/// Most bootstrap resamples.
pub const MAX_BOOTSTRAP: usize = 100_000;
/// Most base samples per chunk: a chunk evaluates `chunk · (2 + S)` rows (2¹⁴ · 40 rows, with
/// the generic [`pick_freeze`]'s inputs at D = 40, are 200 MB).
pub const MAX_CHUNK: usize = 1 << 14;

/// Settings of a sensitivity analysis.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SensitivityOptions {
    /// Base samples N: rows of A and of B, a power of 2 from [`MIN_DRAWS`] to [`MAX_DRAWS`].
    pub draws: usize,
    /// Bootstrap resamples for the 95 % intervals, [`MIN_BOOTSTRAP`] to [`MAX_BOOTSTRAP`].
    pub bootstrap: usize,
    /// Seed of the bootstrap resampling.
    pub bootstrap_seed: u64,
    /// Base samples per evaluation call (each call evaluates `chunk · (2 + S)` rows), 1 to
    /// [`MAX_CHUNK`].
    pub chunk: usize,
    /// Thresholds `l_c` of the failure indicators `1[w ≥ l_c]` (mm), each finite and > 0.
    pub thresholds: Vec<f64>,
}

impl Default for SensitivityOptions {
    fn default() -> Self {
        SensitivityOptions {
            draws: 1 << 13,
            bootstrap: 300,
            bootstrap_seed: 1,
            chunk: 1 << 10,
            thresholds: Vec::new(),
        }
    }
}

/// The fields of [`SensitivityOptions`] its check names ([`SensitivityError::Setting`]); a front
/// end maps each to its own option name.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SensitivitySetting {
    /// [`SensitivityOptions::draws`].
    Draws,
    /// [`SensitivityOptions::bootstrap`].
    Bootstrap,
    /// [`SensitivityOptions::chunk`].
    Chunk,
    /// [`SensitivityOptions::thresholds`].
    Thresholds,
}

impl SensitivitySetting {
    /// Every setting.
    pub const ALL: [SensitivitySetting; 4] =
        [Self::Draws, Self::Bootstrap, Self::Chunk, Self::Thresholds];
}

impl std::fmt::Display for SensitivitySetting {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::Draws => "draws",
            Self::Bootstrap => "bootstrap",
            Self::Chunk => "chunk",
            Self::Thresholds => "thresholds",
        })
    }
}

/// Most pick-freeze matrices of a design: A, B and one per free input and per group (every
/// input of a seven-joint model with its placement, 7 joints, 3 kinds, tool and placement).
const MAX_MATRICES: u64 =
    (2 + crate::kinematics::MAX_INPUTS + crate::kinematics::MAX_JOINTS + 3 + 2) as u64;

impl SensitivityOptions {
    /// The memory an analysis with these options keeps, besides its problem's test points: `w`
    /// on every row of every pick-freeze matrix (for the bootstrap), the bootstrap's replicates
    /// of `w`'s two indices per matrix and resample, one batch of threshold replicates
    /// ([`THRESHOLD_BATCH_BYTES`]) when there are thresholds, and one chunk of offset rows and
    /// outputs. `advice` says what to do when it does not fit (the front end's words).
    ///
    /// # Examples
    ///
    /// ```
    /// use gpu_amcs_core::mc::sensitivity::SensitivityOptions;
    ///
    /// let small = SensitivityOptions::default().memory_estimate("use fewer draws");
    /// let large = SensitivityOptions { draws: 1 << 20, ..SensitivityOptions::default() }
    ///     .memory_estimate("use fewer draws");
    /// // w of every row of at most 58 matrices (A, B, 44 inputs, 12 groups), 8 bytes each:
    /// assert_eq!(
    ///     large.bytes.unwrap() - small.bytes.unwrap(),
    ///     ((1 << 20) - (1 << 13)) * 58 * 8
    /// );
    /// assert!(small.what.contains("N = 8192"));
    /// ```
    pub fn memory_estimate(&self, advice: impl Into<String>) -> crate::memory::Estimate {
        let row = 8 * crate::kinematics::MAX_INPUTS as u64 + 8;
        crate::memory::Estimate::new(
            format!("a sensitivity analysis with N = {}", self.draws),
            advice,
        )
        .plus(&[self.draws as u64, MAX_MATRICES, 8])
        .plus(&[self.bootstrap as u64, MAX_MATRICES, 16])
        .plus(&[
            u64::from(!self.thresholds.is_empty()),
            THRESHOLD_BATCH_BYTES as u64,
        ])
        .plus(&[self.chunk as u64, MAX_MATRICES, row])
    }

    /// Checks every setting; the error names the field.
    ///
    /// # Errors
    ///
    /// [`SensitivityError::Setting`] naming the first field out of range: draws that are not a
    /// power of 2 within [`MIN_DRAWS`] … [`MAX_DRAWS`], bootstrap resamples outside
    /// [`MIN_BOOTSTRAP`] … [`MAX_BOOTSTRAP`], a chunk outside 1 … [`MAX_CHUNK`], or a threshold
    /// that is not a finite length > 0.
    pub fn check(&self) -> Result<(), SensitivityError> {
        use SensitivitySetting as S;
        let bad = |field: S, message: String| Err(SensitivityError::Setting { field, message });
        let n = self.draws;
        if !n.is_power_of_two() {
            return bad(S::Draws, format!("{n} is not a power of 2"));
        }
        if !(MIN_DRAWS..=MAX_DRAWS).contains(&n) {
            return bad(
                S::Draws,
                format!("{n} is outside {MIN_DRAWS} to {MAX_DRAWS} (2^6 to 2^20)"),
            );
        }
        if !(MIN_BOOTSTRAP..=MAX_BOOTSTRAP).contains(&self.bootstrap) {
            return bad(
                S::Bootstrap,
                format!(
                    "{} resamples is outside {MIN_BOOTSTRAP} to {MAX_BOOTSTRAP}",
                    self.bootstrap
                ),
            );
        }
        if !(1..=MAX_CHUNK).contains(&self.chunk) {
            return bad(
                S::Chunk,
                format!("{} is outside 1 to {MAX_CHUNK}", self.chunk),
            );
        }
        for (i, &l) in self.thresholds.iter().enumerate() {
            if !(l.is_finite() && l > 0.0) {
                return bad(
                    S::Thresholds,
                    format!("threshold {} is {l}: it must be a finite length > 0", i + 1),
                );
            }
        }
        Ok(())
    }
}

/// Errors of a sensitivity analysis.
#[derive(Debug, thiserror::Error)]
pub enum SensitivityError {
    /// A setting is out of range; names the field of [`SensitivityOptions`].
    #[error("{field}: {message}")]
    Setting {
        /// The field.
        field: SensitivitySetting,
        /// What is wrong.
        message: String,
    },
    /// Every parameter has σ = 0.
    #[error("model {model}: no parameter has a nonzero standard deviation, so nothing varies")]
    NoFreeParameter {
        /// The model's name.
        model: String,
    },
    /// The inputs or groups of a generic analysis are inconsistent.
    #[error("{0}")]
    Design(String),
    /// The evaluator was built for another problem.
    #[error("the evaluator has {evaluator} test points, the problem {problem}")]
    EvaluatorMismatch {
        /// Points of the problem.
        problem: usize,
        /// Points of the evaluator.
        evaluator: usize,
    },
    /// The model returned the wrong number of outputs.
    #[error("the model returned {got} outputs for {expected} rows")]
    ModelOutput {
        /// Rows given.
        expected: usize,
        /// Outputs returned.
        got: usize,
    },
    /// The model returned a value that is not finite.
    #[error("base sample {sample}, matrix {matrix}: the model gave {value}")]
    NonFinite {
        /// 0-based base sample.
        sample: u64,
        /// Which matrix (A, B or A_B for a set of inputs).
        matrix: String,
        /// The value.
        value: f64,
    },
    /// The evaluator failed.
    #[error(transparent)]
    Engine(#[from] EngineError),
}

/// What the inputs of the indices are.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum InputKind {
    /// Independent parameters: each input is one parameter.
    #[serde(rename = "independent parameters")]
    IndependentParameters,
    /// Correlated model: each input is the Cholesky innovation of one parameter.
    #[serde(rename = "Cholesky innovations (correlated model)")]
    CholeskyInnovations,
}

/// Sobol indices of `w` for a robot model.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SensitivityResult {
    /// The model's name.
    pub model: String,
    /// Test points m.
    pub points: usize,
    /// Seed of the parameter draws (the problem's).
    pub seed: u64,
    /// What the indices are of.
    pub input_kind: InputKind,
    /// Free parameters, in input (Cholesky) order, e.g. `theta1`.
    pub parameters: Vec<String>,
    /// Parameters with σ = 0, not inputs.
    pub skipped_parameters: Vec<String>,
    /// Which backend evaluated `w`.
    pub backend: BackendInfo,
    /// The indices; [`Quantity::Value`] is `w` (mm), the exceedances are `1[w ≥ l_c]`.
    #[serde(flatten)]
    pub analysis: SobolAnalysis,
}

impl SensitivityResult {
    /// The indices of `w` itself (the first quantity; the exceedances follow).
    pub fn w(&self) -> &QuantityIndices {
        &self.analysis.quantities[0]
    }
}

/// Sobol indices of `w` for every free parameter of `problem`, per joint and per kind, with the
/// evaluator `ev` built for the same problem (CPU or GPU: only its offset path is used).
/// See the module docs for the estimators, the draw definition and correlated models.
///
/// # Errors
///
/// As [`run_outputs`]; and [`SensitivityError::Design`] if the design and the outputs disagree
/// ([`Design::result`]).
///
/// # Examples
///
/// The smallest analysis (64 base samples, 100 bootstrap resamples) of the TX60 at five test
/// points on the CPU evaluator:
///
/// ```
/// use gpu_amcs_core::engine::{CpuEvaluator, Problem, Reference};
/// use gpu_amcs_core::mc::sensitivity::{run_sensitivity, SensitivityOptions};
///
/// let model = gpu_amcs_core::kinematics::tx60();
/// let points = gpu_amcs_core::points::generate(&model, 5, &Default::default(), 1)?;
/// let problem = Problem::new(model, &points, &Reference::Calibrated, 2025)?;
/// let mut ev = CpuEvaluator::new(problem.clone());
/// let opts = SensitivityOptions {
///     draws: 64,
///     bootstrap: 100,
///     ..SensitivityOptions::default()
/// };
/// let result = run_sensitivity(&problem, &mut ev, &opts)?;
/// // One first-order and one total index per free parameter of the model.
/// assert_eq!(result.w().inputs.len(), result.parameters.len());
/// let top = result.w().inputs.iter().max_by(|a, b| a.total.value.total_cmp(&b.total.value));
/// println!("most influential: {}", top.map_or("none", |i| i.name.as_str()));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn run_sensitivity(
    problem: &Problem,
    ev: &mut dyn Evaluator,
    opts: &SensitivityOptions,
) -> Result<SensitivityResult, SensitivityError> {
    let (out, design) = run_outputs(problem, ev, opts, 0..opts.draws)?;
    let model = (problem.model.name.clone(), problem.n_points(), problem.seed);
    design.result(model, ev.info(), &out, opts)
}

/// The outputs of base samples `range` of the analysis of [`run_sensitivity`] (a shard), and
/// the design that analyses them once all are gathered.
///
/// # Errors
///
/// [`SensitivityError::Setting`] for an option out of range,
/// [`SensitivityError::EvaluatorMismatch`] when `ev` has another number of test points than
/// `problem`, [`SensitivityError::NoFreeParameter`] when no input has a nonzero standard deviation,
/// [`SensitivityError::Design`] for a `range` that is empty or beyond `opts.draws`,
/// [`SensitivityError::Engine`] when the evaluator fails (or cannot generate pick-freeze rows),
/// and [`SensitivityError::NonFinite`] for an output that is not finite.
pub fn run_outputs(
    problem: &Problem,
    ev: &mut dyn Evaluator,
    opts: &SensitivityOptions,
    range: std::ops::Range<usize>,
) -> Result<(Outputs, Design), SensitivityError> {
    opts.check()?;
    if ev.n_points() != problem.n_points() {
        return Err(SensitivityError::EvaluatorMismatch {
            problem: problem.n_points(),
            evaluator: ev.n_points(),
        });
    }
    let sampler = &problem.sampler;
    let lay = problem.model.layout();
    // With an uncertain base placement (the measurement frame) the inputs are the 5n + 9 (39 for
    // six joints) of the joint covariance, the placement's six last.
    let placed = PlacementSpread::of(problem)?.map(|sp| sp.free);
    let (free, input_kind) = match (placed, sampler.cholesky()) {
        (Some(free), _) => (free, InputKind::CholeskyInnovations),
        (None, Some((free, _))) => (free.to_vec(), InputKind::CholeskyInnovations),
        (None, None) => {
            // An independent sampler always has its σ; none would mean no free parameter.
            let s = sampler.sigmas().unwrap_or(&[]);
            let free = (0..sampler.n_inputs().min(s.len()))
                .filter(|&i| s[i] > 0.0)
                .collect();
            (free, InputKind::IndependentParameters)
        }
    };
    if free.is_empty() {
        return Err(SensitivityError::NoFreeParameter {
            model: problem.model.name.clone(),
        });
    }
    let discrepancy = problem.discrepancy.is_some();
    let joint_errors: Vec<TermGroup> = problem
        .joint_errors
        .as_ref()
        .map_or(Vec::new(), |t| t.groups());
    let groups = input_groups(lay, &free, &joint_errors, discrepancy);
    // Input column c is the standard normal free[c] of a draw; then, when drawn, the groups of
    // the joint errors (their mask bits, TermGroup::mask) and the discrepancy term
    // (DISCREPANCY_MASK): A takes none from the B draw, B all, A_B^(S) those of the columns in S.
    let bit = |col: usize| {
        if col < free.len() {
            1 << free[col]
        } else if let Some(g) = joint_errors.get(col - free.len()) {
            g.mask()
        } else {
            DISCREPANCY_MASK
        }
    };
    let all = ALL_NORMALS
        | if discrepancy { DISCREPANCY_MASK } else { 0 }
        | joint_errors.iter().fold(0, |m, g| m | g.mask());
    let eval = |k0: usize, c: usize, sets: &[Vec<usize>]| {
        let masks: Vec<u64> = [0, all]
            .into_iter()
            .chain(
                sets.iter()
                    .map(|set| set.iter().fold(0u64, |m, &col| m | bit(col))),
            )
            .collect();
        let request = PickFreeze {
            first: k0 as u64,
            b_first: B_DRAW_OFFSET + k0 as u64,
            count: c,
            masks: &masks,
        };
        let mut w = vec![0.0; request.rows()];
        ev.evaluate_pick_freeze(&request, &mut w)?;
        Ok(w)
    };
    let columns = free.len() + joint_errors.len() + usize::from(discrepancy);
    let out = pick_freeze_chunks(columns, &groups, eval, opts, range)?;
    Ok((
        out,
        Design {
            input_kind,
            free,
            joints: lay.joints(),
            joint_errors: joint_errors
                .iter()
                .map(|g| g.input_name().to_string())
                .collect(),
            discrepancy,
        },
    ))
}

/// What the analysis of a robot's outputs needs besides the outputs: the inputs (free
/// parameters, in input order) and what they are.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Design {
    /// What the inputs are.
    pub input_kind: InputKind,
    /// Indices of the free inputs: positions of [`InputSpace::measured`](crate::kinematics::InputSpace::measured) (the `5n` parameters,
    /// the tool point, then the base placement when it is drawn; 39 for six joints), in input
    /// order. They are also the inputs' normal slots ([`InputSpace::slot`](crate::kinematics::InputSpace::slot)).
    pub free: Vec<usize>,
    /// Joints of the model, which lays the inputs out (six when a file leaves it out; written
    /// only when not six, so a six-joint design reads as before).
    #[serde(default = "six_joints", skip_serializing_if = "is_six")]
    pub joints: usize,
    /// The model's discrepancy term is the last input ([`DISCREPANCY_INPUT`]; written only
    /// when true, so a design without one reads as before).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub discrepancy: bool,
    /// The groups of the model's joint errors drawn, inputs after the free ones
    /// ([`TermGroup::input_name`]: `joint_compliance`, `gear_harmonics`, `payload`, `backlash`;
    /// written only when there are some).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub joint_errors: Vec<String>,
}

fn six_joints() -> usize {
    6
}

fn is_six(n: &usize) -> bool {
    *n == 6
}

impl Design {
    /// The indices from the outputs of all base samples (`out`, in base-sample order) of the
    /// model named `model` with `points` test points and draw seed `seed`: the model itself is
    /// not needed, so a merge of shards can run anywhere.
    ///
    /// # Errors
    ///
    /// [`SensitivityError::Design`] when the design's joint count is not 4 to 7 or its free
    /// inputs are not a non-empty set of the [`InputSpace::measured`](crate::kinematics::InputSpace::measured) inputs; otherwise as
    /// [`analyse_outputs`] (an option out of range, outputs of the wrong count).
    pub fn result(
        &self,
        (model, points, seed): (String, usize, u64),
        backend: BackendInfo,
        out: &Outputs,
        opts: &SensitivityOptions,
    ) -> Result<SensitivityResult, SensitivityError> {
        if !(MIN_JOINTS..=MAX_JOINTS).contains(&self.joints) {
            return Err(SensitivityError::Design(format!(
                "{} joints: a model has {MIN_JOINTS} to {MAX_JOINTS}",
                self.joints
            )));
        }
        let lay = Layout::new(self.joints);
        let n = lay.measured().len();
        if self.free.is_empty() || self.free.iter().any(|&i| i >= n) {
            return Err(SensitivityError::Design(format!(
                "free inputs {:?} must be a non-empty set of 0 … {}",
                self.free,
                n - 1
            )));
        }
        let mut names: Vec<String> = self.free.iter().map(|&i| param_name(lay, i)).collect();
        let term_groups = self
            .joint_errors
            .iter()
            .map(|n| {
                TermGroup::ALL
                    .into_iter()
                    .find(|g| g.input_name() == n)
                    .ok_or_else(|| {
                        SensitivityError::Design(format!(
                            "unknown joint-error group '{n}' (known: joint_compliance, gear_harmonics, payload, backlash)"
                        ))
                    })
            })
            .collect::<Result<Vec<_>, _>>()?;
        names.extend(self.joint_errors.iter().cloned());
        if self.discrepancy {
            names.push(DISCREPANCY_INPUT.to_string());
        }
        let skipped = (0..lay.n_params())
            .filter(|i| !self.free.contains(i))
            .map(|i| param_name(lay, i))
            .collect();
        let groups = input_groups(lay, &self.free, &term_groups, self.discrepancy);
        let analysis = analyse_outputs(&names, &groups, out, opts)?;
        Ok(SensitivityResult {
            model,
            points,
            seed,
            input_kind: self.input_kind,
            parameters: names,
            skipped_parameters: skipped,
            backend,
            analysis,
        })
    }
}

#[cfg(test)]
mod tests;
