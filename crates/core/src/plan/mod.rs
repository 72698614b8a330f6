//! Planning a calibration before measuring: which N poses to measure, out of candidate
//! configurations, so that the calibrated robot is reliable at the task's points, and how
//! reliable it will be (docs/METHOD.md §17).
//!
//! A design's predicted covariance is `σ²(JᵀJ)⁻¹`, with J the Jacobian the whole-chain
//! identification uses ([`crate::identify::chain_fit::jacobian`]) at the nominal geometry, over
//! the same free inputs (placement, MDH parameters and target, [`default_free`]) and an isotropic
//! tracker noise σ per coordinate. Its errors at the task points are, to first order,
//! `e_j = J_task,j δ` with `δ ~ N(0, σ²(JᵀJ)⁻¹)`, so `w = max_j ‖e_j‖`.
//!
//! The search:
//! 1. greedy D-optimal: add, one at a time, the candidate that most increases `log det JᵀJ`
//!    (rank-3 updates of the inverse);
//! 2. an exchange on the task's own figure: swap design poses for candidates while the 95 %
//!    quantile of w falls, w computed from the same K standard-normal vectors for every design
//!    (common random numbers: two designs differ by their covariance, not by Monte Carlo noise).
//!
//! The plan's figures beside it: the log-det design alone and the median of random designs of
//! the same size. [`Plan::model`] is the model the plan predicts (nominal geometry, the design's
//! covariance, placement in the measurement frame) for the engine's Monte Carlo at the task
//! points ([`predict`]).

mod report;

pub use report::render_text;

use crate::engine::{BackendInfo, EngineError, Evaluator, Problem, ProblemError, Reference};
use crate::identify::chain::{nominal_state, state_model, Placement};
use crate::identify::chain_fit::{default_free, jacobian, ChainState, Observation};
use crate::kinematics::{transform, Joints, RobotModel};
use crate::mc::stats::Reliability;
use crate::sampling::standard_normal;
use nalgebra::{Cholesky, DMatrix, Matrix3, SymmetricEigen, Vector3};
use rand::{Rng, SeedableRng};
use rayon::prelude::*;
use serde::Serialize;

/// Where the laser tracker stands and what it can see.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TrackerSite {
    /// Position in the measurement frame (the model's base frame for a model without `base`), mm.
    pub position_mm: [f64; 3],
    /// Largest distance to a target, mm.
    pub range_mm: f64,
    /// Largest angle between the target's facing direction (the flange z axis) and the line to
    /// the tracker, degrees.
    pub max_incidence_deg: f64,
}

/// Settings of a plan.
#[derive(Clone, Debug, PartialEq)]
pub struct PlanOptions {
    /// Poses to measure, N.
    pub poses: usize,
    /// Candidate configurations, M.
    pub candidates: usize,
    /// Tracker noise per coordinate, mm (1σ).
    pub sigma_mm: f64,
    /// The tracker's position and limits; `None`: every candidate is visible.
    pub tracker: Option<TrackerSite>,
    /// Margin kept from each joint limit, degrees.
    pub margin_deg: f64,
    /// Largest condition number of the target's 3 × n position Jacobian a candidate may have
    /// (keeps away from singularities).
    pub max_condition: f64,
    /// Thresholds L at which R(L) is reported, mm.
    pub thresholds: Vec<f64>,
    /// Standard-normal vectors of the search's common random numbers, K.
    pub search_draws: usize,
    /// Exchange passes over the design at most.
    pub passes: usize,
    /// Replacement candidates screened per design pose and pass (the best few are judged by
    /// q95).
    pub swaps: usize,
    /// Random designs to compare with.
    pub random_designs: usize,
    /// Smallest design of the curve of the predicted figures against the number of poses.
    pub curve_from: usize,
    /// The target (SMR) on the flange, mm: where the tracker measures. It replaces the model's
    /// `tool` for the plan.
    pub target_mm: [f64; 3],
    /// Seed of the candidates, the search and the comparison.
    pub seed: u64,
}

/// Distance from the last joint's axis below which a model's tool is not taken as the plan's
/// target by default, mm.
pub const MIN_TARGET_OFFSET_MM: f64 = 1.0;

impl PlanOptions {
    /// The target a plan of `model` assumes when none is given: the model's tool unless it lies
    /// on the last joint's axis (within [`MIN_TARGET_OFFSET_MM`]; the flange origin, or an
    /// imported tool0 whose x and y are rounding noise), where it would hide the parameters of
    /// the joint before the last (joint 5 of a six-joint arm), else the default (30, −20, 80) mm, the simulator's design target.
    pub fn default_target(model: &RobotModel) -> [f64; 3] {
        if model.tool[0].hypot(model.tool[1]) >= MIN_TARGET_OFFSET_MM {
            model.tool
        } else {
            PlanOptions::default().target_mm
        }
    }
}

impl Default for PlanOptions {
    fn default() -> Self {
        PlanOptions {
            poses: 30,
            candidates: 2000,
            sigma_mm: 0.01,
            tracker: None,
            margin_deg: 5.0,
            max_condition: 50.0,
            thresholds: Vec::new(),
            search_draws: 2000,
            passes: 3,
            swaps: 200,
            random_designs: 100,
            curve_from: 10,
            target_mm: [30.0, -20.0, 80.0],
            seed: 1,
        }
    }
}

/// The setting a [`PlanError::Setting`] is about.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PlanField {
    /// [`PlanOptions::poses`].
    Poses,
    /// [`PlanOptions::candidates`].
    Candidates,
    /// [`PlanOptions::sigma_mm`].
    Sigma,
    /// [`PlanOptions::tracker`].
    Tracker,
    /// [`PlanOptions::thresholds`].
    Thresholds,
    /// The search settings (draws, passes, swaps, random designs, margin, condition).
    Search,
    /// The task points.
    TaskPoints,
    /// [`PlanOptions::target_mm`].
    Target,
}

impl std::fmt::Display for PlanField {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            PlanField::Poses => "number of poses",
            PlanField::Candidates => "number of candidates",
            PlanField::Sigma => "tracker noise",
            PlanField::Tracker => "tracker position",
            PlanField::Thresholds => "threshold",
            PlanField::Search => "search setting",
            PlanField::TaskPoints => "task points",
            PlanField::Target => "target",
        })
    }
}

/// Errors of planning.
#[derive(Debug, thiserror::Error)]
pub enum PlanError {
    /// A setting out of range.
    #[error("{field}: {message}")]
    Setting {
        /// Which setting.
        field: PlanField,
        /// What is wrong.
        message: String,
    },
    /// The candidates do not determine the free inputs.
    #[error("the candidates do not identify the model: {0}")]
    NotIdentifiable(String),
    /// The engine's Monte Carlo failed.
    #[error(transparent)]
    Engine(#[from] EngineError),
    /// The planned model's problem could not be built.
    #[error(transparent)]
    Problem(#[from] ProblemError),
}

fn setting(field: PlanField, message: impl Into<String>) -> PlanError {
    PlanError::Setting {
        field,
        message: message.into(),
    }
}

/// A design's figures. `q95_mm` and `reliability` are the linearised Monte Carlo on
/// [`EVAL_DRAWS`] standard-normal vectors shared by every design (not the search's own); the information figures are of the column-scaled Jacobian
/// (each column divided by its RMS over the candidates), so mm and radians weigh alike.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DesignFigures {
    /// 95 % quantile of w at the task points, mm.
    pub q95_mm: f64,
    /// Predicted RMS of the position error over the task points, mm: `σ·√(Σ_j E‖e_j‖² / m)`
    /// from the covariance alone (no Monte Carlo).
    pub rms_mm: f64,
    /// Predicted R(L) per threshold.
    pub reliability: Vec<f64>,
    /// `log det` of the scaled information matrix.
    pub log_det: f64,
    /// Observability index O1 (Borm & Menq): geometric mean of the scaled Jacobian's singular
    /// values over √N.
    pub o1: f64,
    /// Condition number of the scaled Jacobian.
    pub condition: f64,
}

/// One point of the curve of predicted figures against the number of poses.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CurvePoint {
    /// Poses measured (the first `poses` of the design in D-optimal order).
    pub poses: usize,
    /// 95 % quantile of w, mm.
    pub q95_mm: f64,
    /// R(L) per threshold.
    pub reliability: Vec<f64>,
}

/// How the search went.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SearchTrace {
    /// q95 of the greedy D-optimal design, mm.
    pub greedy_q95_mm: f64,
    /// Exchange passes run.
    pub passes: usize,
    /// Swaps judged by q95.
    pub swaps_tried: usize,
    /// Swaps kept.
    pub swaps_accepted: usize,
}

/// The engine's Monte Carlo of the planned model at the task points.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Prediction {
    /// Draws.
    pub draws: usize,
    /// R(L) per threshold with its 95 % interval.
    pub reliability: Vec<Reliability>,
    /// 95 % quantile of w, mm.
    pub q95_mm: f64,
    /// Mean of w, mm.
    pub mean_mm: f64,
    /// Per task point j, `Pr[e_j < L]` per threshold with its 95 % interval: for ISO 9283 test
    /// poses, the probability that pose accuracy AP_j meets L (the certificate, Method §16).
    pub per_point: Vec<Vec<Reliability>>,
    /// The evaluator.
    pub backend: BackendInfo,
}

/// A calibration plan.
#[derive(Clone, Debug, Serialize)]
pub struct Plan {
    /// The robot.
    pub model_name: String,
    /// Poses to measure, joint angles in degrees (one per joint), in visiting order.
    pub design_deg: Vec<Joints>,
    /// Joint travel along the visiting order: Σ max_j |Δq_j| between consecutive poses, degrees.
    pub travel_deg: f64,
    /// The plan's figures.
    pub planned: DesignFigures,
    /// The greedy log-det (D-optimal) design's figures.
    pub log_det_design: DesignFigures,
    /// The log-det design's poses, degrees (greedy order), to measure it for comparison.
    pub log_det_design_deg: Vec<Joints>,
    /// Medians over the random designs, figure by figure.
    pub random_median: DesignFigures,
    /// Random designs compared.
    pub random_designs: usize,
    /// No design of as many poses from these candidates can bring the predicted RMS at the task
    /// points ([`DesignFigures::rms_mm`]) below this, mm: the approximate-design bound of
    /// Method §17.
    pub rms_bound_mm: f64,
    /// Predicted figures against the number of poses.
    pub curve: Vec<CurvePoint>,
    /// Candidates kept.
    pub candidates: usize,
    /// Configurations drawn to find them.
    pub candidates_drawn: usize,
    /// Names of the identified inputs.
    pub identified: Vec<String>,
    /// Tracker noise, mm.
    pub sigma_mm: f64,
    /// The target on the flange, mm.
    pub target_mm: [f64; 3],
    /// Where the tracker stands, if given.
    pub tracker: Option<TrackerSite>,
    /// Task points.
    pub task_points: usize,
    /// Thresholds L, mm.
    pub thresholds: Vec<f64>,
    /// The search.
    pub search: SearchTrace,
    /// Seconds the plan took (without the engine's prediction).
    pub seconds: f64,
    /// The engine's Monte Carlo of the planned model, when run.
    pub prediction: Option<Prediction>,
    /// The planned model's covariance over the fit inputs ([`ChainState::space`]; 39 for six joints),
    /// row-major, internal units.
    #[serde(skip)]
    pub covariance: Vec<f64>,
    /// The nominal model.
    #[serde(skip)]
    pub nominal: RobotModel,
}

impl Plan {
    /// The model the plan predicts: the nominal geometry and target, the design's covariance,
    /// the placement drawn in the measurement frame.
    pub fn model(&self) -> RobotModel {
        state_model(
            &self.nominal,
            &nominal_state(&self.nominal),
            &self.covariance,
            Placement::Identify,
            format!("{} (planned calibration)", self.nominal.name),
        )
    }
}

/// The identification geometry the search works on: scaled Jacobian rows of every candidate and
/// of the task points, and the common random numbers.
struct Geometry {
    /// Per candidate, its 3 × p scaled Jacobian.
    cand: Vec<DMatrix<f64>>,
    /// The same rows stacked, 3M × p.
    stacked: DMatrix<f64>,
    /// Per candidate, `JᵀJ` (p × p).
    info: Vec<DMatrix<f64>>,
    /// 3m × p scaled task Jacobian.
    task: DMatrix<f64>,
    /// Per task point j, `J_jᵀ J_j`: `⟨M⁻¹, G_j⟩` is point j's expected ‖e_j‖² under
    /// information M.
    grams: Vec<DMatrix<f64>>,
    /// p × K standard normals of the search.
    z: DMatrix<f64>,
    /// p × K' standard normals of the reported figures, drawn apart from the search's so that
    /// the design chosen on `z` is not judged on the noise it was chosen for.
    z_eval: DMatrix<f64>,
    /// Column scale (RMS over candidates of each input's column).
    scale: Vec<f64>,
    /// Thresholds in units of σ.
    thresholds_sigma: Vec<f64>,
}

impl Geometry {
    fn p(&self) -> usize {
        self.scale.len()
    }

    /// Scaled information of `design` (σ = 1).
    fn information(&self, design: &[usize]) -> DMatrix<f64> {
        let mut m = DMatrix::zeros(self.p(), self.p());
        for &i in design {
            m += &self.info[i];
        }
        m
    }

    /// w of each common random vector of `z` (units of σ) for information `m`; `None` when `m`
    /// is singular.
    fn w(&self, m: &DMatrix<f64>, z: &DMatrix<f64>) -> Option<Vec<f64>> {
        let inv = Cholesky::new(m.clone())?.inverse();
        let l = Cholesky::new(inv)?.l();
        let a = &self.task * l;
        let e = a * z;
        let pts = e.nrows() / 3;
        Some(
            (0..e.ncols())
                .map(|k| {
                    (0..pts)
                        .map(|j| {
                            let (x, y, z) = (e[(3 * j, k)], e[(3 * j + 1, k)], e[(3 * j + 2, k)]);
                            x * x + y * y + z * z
                        })
                        .fold(0.0, f64::max)
                        .sqrt()
                })
                .collect(),
        )
    }

    /// The screen of the exchange, smooth and free of Monte Carlo noise: `Σ_j v_j⁴` of the
    /// task points' expected squared errors `v_j` (units of σ²) under information `m`, which
    /// weighs the worst points as the maximum in w does; +∞ when `m` is singular.
    fn screen(&self, m: &DMatrix<f64>) -> f64 {
        match Cholesky::new(m.clone()) {
            Some(c) => {
                let inv = c.inverse();
                self.grams
                    .iter()
                    .map(|g| inv.dot(g).powi(SCREEN_POWER))
                    .sum()
            }
            None => f64::INFINITY,
        }
    }

    /// Mean over the task points of the expected squared error (units of σ²) under information
    /// `m`; +∞ when `m` is singular.
    fn mean_sq(&self, m: &DMatrix<f64>) -> f64 {
        match Cholesky::new(m.clone()) {
            Some(c) => {
                let inv = c.inverse();
                self.grams.iter().map(|g| inv.dot(g)).sum::<f64>() / self.grams.len() as f64
            }
            None => f64::INFINITY,
        }
    }

    /// A lower bound (units of σ²) on [`Geometry::mean_sq`] of every design of `n` poses
    /// from the candidates, repeats allowed (Method §17): the bound of approximate design
    /// theory for the linear criterion `Φ(M) = tr(A M⁻¹)`, `A = Σ_j G_j / m`. For weights `w`
    /// (`Σ w_i = n`) with `M = Σ w_i I_i` and `d_i = tr(I_i M⁻¹ A M⁻¹)`, convexity and
    /// `Φ(cM) = Φ(M)/c` give `Φ(M*) ≥ Φ(M)² / (n · max_i d_i)` for the best `M*` of any
    /// weights, hence of any exact design. The weights are improved by the multiplicative
    /// algorithm `w_i ← w_i·√(n·d_i/Φ)`; every iterate's bound is valid, the iterations only
    /// tighten it. Returns the bound and the criterion of the best weights found.
    fn mean_sq_bound(&self, n: usize, iterations: usize) -> (f64, f64) {
        let k = self.info.len();
        let p = self.p();
        let a = self
            .grams
            .iter()
            .fold(DMatrix::<f64>::zeros(p, p), |acc, g| acc + g)
            / self.grams.len() as f64;
        let nf = n as f64;
        let mut w = vec![nf / k as f64; k];
        let (mut bound, mut best) = (0.0f64, f64::INFINITY);
        let mut weighted = self.stacked.clone();
        for _ in 0..iterations {
            // M = Σ w_i J_iᵀ J_i as one product of the stacked rows scaled by √w_i.
            for (i, wi) in w.iter().enumerate() {
                let r = wi.sqrt();
                for row in 3 * i..3 * i + 3 {
                    for c in 0..p {
                        weighted[(row, c)] = self.stacked[(row, c)] * r;
                    }
                }
            }
            let m = weighted.tr_mul(&weighted);
            let Some(c) = Cholesky::new(m) else {
                break;
            };
            let minv = c.inverse();
            let b = &minv * &a * &minv;
            let phi = a.dot(&minv);
            // d_i = tr(J_i B J_iᵀ): the row sums of (J B) ∘ J, three rows per candidate.
            let jb = (&self.stacked * &b).component_mul(&self.stacked);
            let rows: Vec<f64> = jb.column_sum().iter().copied().collect();
            let d: Vec<f64> = (0..k)
                .map(|i| rows[3 * i] + rows[3 * i + 1] + rows[3 * i + 2])
                .collect();
            let dmax = d.iter().cloned().fold(0.0, f64::max);
            if !(phi.is_finite() && dmax > 0.0) {
                break;
            }
            bound = bound.max(phi * phi / (nf * dmax));
            best = best.min(phi);
            if bound >= best * (1.0 - BOUND_GAP) {
                break;
            }
            for (wi, di) in w.iter_mut().zip(&d) {
                *wi *= (nf * di / phi).sqrt();
            }
            let total: f64 = w.iter().sum();
            w.iter_mut().for_each(|wi| *wi *= nf / total);
        }
        (bound, best)
    }

    /// q95 (units of σ) for information `m`, +∞ when singular.
    fn q95(&self, m: &DMatrix<f64>) -> f64 {
        match self.w(m, &self.z) {
            Some(mut w) => {
                w.sort_by(f64::total_cmp);
                quantile(&w, 0.95)
            }
            None => f64::INFINITY,
        }
    }

    /// Every figure of `design`; `sigma` converts to mm.
    fn figures(&self, design: &[usize], sigma: f64) -> DesignFigures {
        let m = self.information(design);
        let mut w = self.w(&m, &self.z_eval).unwrap_or_default();
        w.sort_by(f64::total_cmp);
        let reliability = self
            .thresholds_sigma
            .iter()
            .map(|&t| {
                if w.is_empty() {
                    0.0
                } else {
                    w.partition_point(|&v| v < t) as f64 / w.len() as f64
                }
            })
            .collect();
        let rms_mm = self.mean_sq(&m).sqrt() * sigma;
        let ev = SymmetricEigen::new(m).eigenvalues;
        let (lo, hi) = ev
            .iter()
            .fold((f64::INFINITY, 0.0f64), |(a, b), &v| (a.min(v), b.max(v)));
        let p = self.p() as f64;
        let log_det: f64 = ev.iter().map(|v| v.max(f64::MIN_POSITIVE).ln()).sum();
        DesignFigures {
            q95_mm: if w.is_empty() {
                f64::INFINITY
            } else {
                quantile(&w, 0.95) * sigma
            },
            rms_mm,
            reliability,
            log_det,
            o1: (log_det / (2.0 * p)).exp() / (design.len() as f64).sqrt(),
            condition: if lo > 0.0 {
                (hi / lo).sqrt()
            } else {
                f64::INFINITY
            },
        }
    }
}

/// Draws per evaluation call of the prediction.
const PREDICTION_CHUNK: usize = 1 << 16;

/// Swaps per design pose judged by q95 after the screen.
const JUDGED: usize = 8;
/// Power of the task points' expected squared errors in the screen.
const SCREEN_POWER: i32 = 4;

/// Iterations of the multiplicative algorithm behind [`Plan::rms_bound_mm`].
const BOUND_ITERATIONS: usize = 200;
/// Relative gap between the bound and the best weights' criterion at which the algorithm stops.
const BOUND_GAP: f64 = 2e-3;

/// Standard-normal vectors behind every reported linearised figure.
pub const EVAL_DRAWS: usize = 2000;

/// The value of rank ⌈q·n⌉ of ascending values.
fn quantile(sorted: &[f64], q: f64) -> f64 {
    let k = ((q * sorted.len() as f64).ceil() as usize).clamp(1, sorted.len());
    sorted[k - 1]
}

fn check(model: &RobotModel, task: &[Joints], o: &PlanOptions) -> Result<(), PlanError> {
    if !(o.sigma_mm.is_finite() && o.sigma_mm > 0.0) {
        return Err(setting(
            PlanField::Sigma,
            format!("must be a positive number of mm, got {}", o.sigma_mm),
        ));
    }
    if let Some(t) = o.thresholds.iter().find(|t| !(t.is_finite() && **t > 0.0)) {
        return Err(setting(
            PlanField::Thresholds,
            format!("must be positive, got {t}"),
        ));
    }
    if o.candidates == 0 || o.candidates > 1_000_000 {
        return Err(setting(
            PlanField::Candidates,
            format!("must be 1 … 1000000, got {}", o.candidates),
        ));
    }
    if o.poses > o.candidates {
        return Err(setting(
            PlanField::Poses,
            format!(
                "{} poses cannot be chosen from {} candidates",
                o.poses, o.candidates
            ),
        ));
    }
    let p = default_free(&model.fixed, true).len();
    if 3 * o.poses <= p {
        return Err(setting(
            PlanField::Poses,
            format!(
                "{} poses give {} coordinates, not more than the {p} inputs to identify: at least {}",
                o.poses,
                3 * o.poses,
                p / 3 + 1
            ),
        ));
    }
    if o.search_draws < 20 || o.search_draws > 100_000 {
        return Err(setting(
            PlanField::Search,
            format!("search draws must be 20 … 100000, got {}", o.search_draws),
        ));
    }
    if !(o.margin_deg.is_finite()
        && o.margin_deg >= 0.0
        && o.max_condition.is_finite()
        && o.max_condition > 1.0)
    {
        return Err(setting(
            PlanField::Search,
            format!(
                "the joint-limit margin must be ≥ 0° and the condition bound > 1, got {}° and {}",
                o.margin_deg, o.max_condition
            ),
        ));
    }
    if task.is_empty() {
        return Err(setting(PlanField::TaskPoints, "none given"));
    }
    if let Some((k, q)) = task
        .iter()
        .enumerate()
        .find(|(_, q)| q.len() != model.joints())
    {
        return Err(setting(
            PlanField::TaskPoints,
            format!(
                "point {} has {} joint angles, the model has {} joints",
                k + 1,
                q.len(),
                model.joints()
            ),
        ));
    }
    if let Some(t) = &o.tracker {
        if !(t.position_mm.iter().all(|v| v.is_finite())
            && t.range_mm.is_finite()
            && t.range_mm > 0.0
            && t.max_incidence_deg > 0.0
            && t.max_incidence_deg <= 90.0)
        {
            return Err(setting(
                PlanField::Tracker,
                format!(
                    "position {:?} must be finite, range {} mm positive and incidence {}° in (0, 90]",
                    t.position_mm, t.range_mm, t.max_incidence_deg
                ),
            ));
        }
    }
    Ok(())
}

/// The target's position in the measurement frame and the direction it faces (flange z).
fn target_and_facing(
    model: &RobotModel,
    s: &ChainState,
    q_deg: &[f64],
) -> (Vector3<f64>, Vector3<f64>) {
    let q = Joints::from_fn(q_deg.len(), |j| q_deg[j].to_radians());
    let p = Vector3::from(s.predict(&q));
    let t = transform(&model.params, &q);
    let z = Vector3::new(t[0][2], t[1][2], t[2][2]);
    (p, s.rotation() * z)
}

/// Draws the candidates: configurations within the limits less the margin, away from
/// singularities and, with a tracker, within its range and incidence. Returns them and how many
/// were drawn.
fn candidates(
    model: &RobotModel,
    s: &ChainState,
    o: &PlanOptions,
) -> Result<(Vec<Joints>, usize), PlanError> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(o.seed);
    let ranges: Vec<(f64, f64)> = model
        .limits_deg
        .iter()
        .map(|&(lo, hi)| {
            let (lo, hi) = (lo.max(-360.0), hi.min(360.0));
            let m = o.margin_deg.min((hi - lo) / 4.0);
            (lo + m, hi - m)
        })
        .collect();
    if let Some(t) = &o.tracker {
        // A tracker within the robot's reach would be in its way (and in danger).
        let origin = Vector3::new(s.base[0], s.base[1], s.base[2]);
        let reach = (0..200)
            .map(|_| {
                let q = Joints::from_fn(ranges.len(), |j| {
                    rng.random_range(ranges[j].0..=ranges[j].1)
                });
                (target_and_facing(model, s, &q).0 - origin).norm()
            })
            .fold(0.0, f64::max);
        let d = (Vector3::from(t.position_mm) - origin).norm();
        if d < reach {
            return Err(setting(
                PlanField::Tracker,
                format!(
                    "{:?} mm is {d:.0} mm from the robot's base, within its reach (about {reach:.0} mm): the tracker must stand outside it",
                    t.position_mm
                ),
            ));
        }
    }
    let max_draws = 200 * o.candidates + 10_000;
    let mut out = Vec::with_capacity(o.candidates);
    let mut drawn = 0;
    let cos_max = o
        .tracker
        .as_ref()
        .map(|t| t.max_incidence_deg.to_radians().cos());
    while out.len() < o.candidates && drawn < max_draws {
        drawn += 1;
        let q = Joints::from_fn(ranges.len(), |j| {
            rng.random_range(ranges[j].0..=ranges[j].1)
        });
        match crate::map::ik::position_condition(model, &q.map(f64::to_radians)) {
            Some(c) if c <= o.max_condition => {}
            _ => continue,
        }
        if let (Some(t), Some(cmax)) = (&o.tracker, cos_max) {
            let (p, facing) = target_and_facing(model, s, &q);
            let to = Vector3::from(t.position_mm) - p;
            let d = to.norm();
            if d > t.range_mm || facing.dot(&to) < cmax * d {
                continue;
            }
        }
        out.push(q);
    }
    if out.len() < o.candidates {
        return Err(setting(
            PlanField::Candidates,
            format!(
                "only {} of {} configurations met the limits, the singularity bound{} after {drawn} draws",
                out.len(),
                o.candidates,
                if o.tracker.is_some() {
                    " and the tracker's range and incidence"
                } else {
                    ""
                }
            ),
        ));
    }
    Ok((out, drawn))
}

/// Unit-weight observations of the nominal chain's own predictions at `q_deg`.
fn observations(s: &ChainState, q_deg: &[Joints]) -> Vec<Observation> {
    q_deg
        .iter()
        .map(|q| {
            let q = q.map(f64::to_radians);
            Observation {
                q,
                p: s.predict(&q),
                whiten: Matrix3::identity(),
            }
        })
        .collect()
}

/// Greedy D-optimal order of `n` poses out of `pool` (indices into the geometry's candidates),
/// starting from `start` (may be empty).
fn greedy(g: &Geometry, pool: &[usize], start: &[usize], n: usize) -> Vec<usize> {
    let p = g.p();
    // A tiny ridge makes the empty design invertible; it is far below one pose's information.
    let mut m = DMatrix::<f64>::identity(p, p) * 1e-9;
    for &i in start {
        m += &g.info[i];
    }
    let mut pinv = match Cholesky::new(m) {
        Some(c) => c.inverse(),
        None => return start.to_vec(),
    };
    let mut chosen: Vec<usize> = start.to_vec();
    let mut used = vec![false; g.cand.len()];
    for &i in start {
        used[i] = true;
    }
    while chosen.len() < n {
        let best = pool
            .par_iter()
            .filter(|&&c| !used[c])
            .map(|&c| {
                let j = &g.cand[c];
                let s = DMatrix::<f64>::identity(3, 3) + j * &pinv * j.transpose();
                (s.determinant().max(f64::MIN_POSITIVE).ln(), c)
            })
            .max_by(|a, b| a.0.total_cmp(&b.0).then(b.1.cmp(&a.1)));
        let Some((_, c)) = best else {
            break;
        };
        let j = &g.cand[c];
        let pj = &pinv * j.transpose();
        let s = DMatrix::<f64>::identity(3, 3) + j * &pj;
        if let Some(si) = s.try_inverse() {
            pinv -= &pj * si * pj.transpose();
        }
        used[c] = true;
        chosen.push(c);
    }
    chosen
}

/// The visiting order: nearest neighbour in joint space (largest joint move), then 2-opt.
fn visiting_order(q: &[Joints]) -> (Vec<usize>, f64) {
    let n = q.len();
    let d = |a: usize, b: usize| {
        (0..q[a].len())
            .map(|j| (q[a][j] - q[b][j]).abs())
            .fold(0.0, f64::max)
    };
    if n < 2 {
        return ((0..n).collect(), 0.0);
    }
    let origin = |a: usize| q[a].iter().map(|v| v.abs()).fold(0.0, f64::max);
    let first = (0..n)
        .min_by(|&a, &b| origin(a).total_cmp(&origin(b)))
        .unwrap_or(0);
    let mut order = vec![first];
    let mut left: Vec<usize> = (0..n).filter(|&i| i != first).collect();
    while !left.is_empty() {
        let last = *order.last().unwrap_or(&first);
        let (k, _) = left
            .iter()
            .enumerate()
            .min_by(|a, b| d(last, *a.1).total_cmp(&d(last, *b.1)))
            .unwrap_or((0, &0));
        order.push(left.swap_remove(k));
    }
    // 2-opt on the open path.
    let mut improved = true;
    let mut rounds = 0;
    while improved && rounds < 50 {
        improved = false;
        rounds += 1;
        for i in 0..n - 2 {
            for k in i + 2..n {
                let before = d(order[i], order[i + 1])
                    + if k + 1 < n {
                        d(order[k], order[k + 1])
                    } else {
                        0.0
                    };
                let after = d(order[i], order[k])
                    + if k + 1 < n {
                        d(order[i + 1], order[k + 1])
                    } else {
                        0.0
                    };
                if after + 1e-9 < before {
                    order[i + 1..=k].reverse();
                    improved = true;
                }
            }
        }
    }
    let travel = order.windows(2).map(|w| d(w[0], w[1])).sum();
    (order, travel)
}

/// Plans the calibration of `model` (its nominal geometry and target; its base, if any, is the
/// nominal placement in the measurement frame) for the task configurations `task` (degrees).
///
/// # Errors
///
/// [`PlanError::Setting`] for a setting out of range (too few poses for the inputs, more poses
/// than candidates, σ or a threshold ≤ 0, a tracker within the robot's reach, too few
/// candidates found), [`PlanError::NotIdentifiable`] when no design of the candidates
/// determines every input.
pub fn plan(model: &RobotModel, task: &[Joints], o: &PlanOptions) -> Result<Plan, PlanError> {
    check(model, task, o)?;
    if !o.target_mm.iter().all(|v| v.is_finite()) {
        return Err(setting(
            PlanField::Target,
            format!("{:?} must be finite", o.target_mm),
        ));
    }
    let mut model = model.clone();
    model.tool = o.target_mm;
    let model = &model;
    let start = std::time::Instant::now();
    let s = nominal_state(model);
    let lay = model.layout();
    let free = default_free(&model.fixed, true);
    let p = free.len();
    let (cands, drawn) = candidates(model, &s, o)?;
    let cj = jacobian(&observations(&s, &cands), &s, &free);
    let tj = jacobian(&observations(&s, task), &s, &free);
    let scale: Vec<f64> = (0..p)
        .map(|c| {
            let n = cj.column(c).norm() / (cands.len() as f64).sqrt();
            if n > 0.0 {
                n
            } else {
                1.0
            }
        })
        .collect();
    let scaled = |mut j: DMatrix<f64>| {
        for (c, sc) in scale.iter().enumerate() {
            j.column_mut(c).unscale_mut(*sc);
        }
        j
    };
    let cj = scaled(cj);
    let cand: Vec<DMatrix<f64>> = (0..cands.len())
        .map(|i| cj.rows(3 * i, 3).into_owned())
        .collect();
    let info = cand.iter().map(|j| j.transpose() * j).collect();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(o.seed ^ 0x005E_ED0F_C0DE);
    let z = DMatrix::from_fn(p, o.search_draws, |_, _| standard_normal(&mut rng));
    let z_eval = DMatrix::from_fn(p, EVAL_DRAWS, |_, _| standard_normal(&mut rng));
    let task_j = scaled(tj);
    let g = Geometry {
        cand,
        stacked: cj,
        info,
        grams: (0..task.len())
            .map(|j| {
                let r = task_j.rows(3 * j, 3);
                r.transpose() * r
            })
            .collect(),
        task: task_j,
        z,
        z_eval,
        scale,
        thresholds_sigma: o.thresholds.iter().map(|t| t / o.sigma_mm).collect(),
    };
    let all: Vec<usize> = (0..cands.len()).collect();

    // 1. Greedy D-optimal.
    let dopt = greedy(&g, &all, &[], o.poses);
    let m = g.information(&dopt);
    if dopt.len() < o.poses || Cholesky::new(m.clone()).is_none() {
        return Err(PlanError::NotIdentifiable(format!(
            "{} poses chosen from {} candidates leave the {p} inputs' information singular",
            dopt.len(),
            cands.len()
        )));
    }
    // Directions the best design still barely sees: inputs the candidates cannot separate.
    let eig = SymmetricEigen::new(m.clone());
    let top = eig.eigenvalues.max();
    if let Some((k, lo)) = eig
        .eigenvalues
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.total_cmp(b.1))
        .filter(|(_, lo)| **lo < top * 1e-12)
    {
        let v = eig.eigenvectors.column(k);
        let mut names: Vec<(f64, String)> = free
            .iter()
            .enumerate()
            .map(|(a, &i)| (v[a].abs(), lay.measured().name(i)))
            .filter(|(x, _)| *x > 0.1)
            .collect();
        names.sort_by(|a, b| b.0.total_cmp(&a.0));
        return Err(PlanError::NotIdentifiable(format!(
            "{} move the target together (condition {:.1e}): this target does not separate them \
             (one on the flange origin or on the last joint's axis never does); place it elsewhere \
             on the flange",
            names
                .iter()
                .map(|n| n.1.as_str())
                .collect::<Vec<_>>()
                .join(", "),
            (top / lo.max(f64::MIN_POSITIVE)).sqrt()
        )));
    }
    let greedy_q95 = g.q95(&m);

    // 2. Exchange on q95 with common random numbers: per design pose, `swaps` candidates are
    // screened by the task points' expected squared errors (smooth, no Monte Carlo noise), the
    // best few
    // are judged by q95, and the best of those replaces the pose if q95 falls. Judging few swaps
    // on the noisy figure keeps the search from choosing designs for their luck on the draws.
    let mut design = dopt.clone();
    let mut current = greedy_q95;
    let (mut passes, mut tried, mut accepted) = (0, 0, 0);
    for _ in 0..o.passes {
        passes += 1;
        let mut improved = false;
        for pos in 0..design.len() {
            let m = g.information(&design);
            let mut in_design = vec![false; cands.len()];
            for &i in &design {
                in_design[i] = true;
            }
            let free_left = cands.len() - design.len();
            let pool: Vec<usize> = if o.swaps >= free_left {
                (0..cands.len()).filter(|&c| !in_design[c]).collect()
            } else {
                (0..o.swaps)
                    .map(|_| loop {
                        let c = rng.random_range(0..cands.len());
                        if !in_design[c] {
                            break c;
                        }
                    })
                    .collect()
            };
            let base = &m - &g.info[design[pos]];
            let mut screened: Vec<(f64, usize)> = pool
                .par_iter()
                .map(|&c| (g.screen(&(&base + &g.info[c])), c))
                .collect();
            screened.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            screened.truncate(JUDGED);
            tried += screened.len();
            let best = screened
                .par_iter()
                .map(|&(_, c)| (g.q95(&(&base + &g.info[c])), c))
                .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            if let Some((q, c)) = best {
                if q < current * (1.0 - 1e-6) {
                    design[pos] = c;
                    current = q;
                    accepted += 1;
                    improved = true;
                }
            }
        }
        if !improved {
            break;
        }
    }

    // The comparison: the log-det design and random designs of the same size.
    let planned = g.figures(&design, o.sigma_mm);
    let log_det_design = g.figures(&dopt, o.sigma_mm);
    let randoms: Vec<DesignFigures> = (0..o.random_designs)
        .map(|_| {
            let mut idx: Vec<usize> = (0..cands.len()).collect();
            for i in 0..o.poses {
                let k = rng.random_range(i..idx.len());
                idx.swap(i, k);
            }
            idx.truncate(o.poses);
            idx
        })
        .collect::<Vec<_>>()
        .par_iter()
        .map(|d| g.figures(d, o.sigma_mm))
        .collect();
    let random_median = median_figures(&randoms, o.thresholds.len());
    let rms_bound_mm = g.mean_sq_bound(o.poses, BOUND_ITERATIONS).0.sqrt() * o.sigma_mm;

    // The curve: prefixes of the design in its own D-optimal order.
    let ordered = greedy(&g, &design, &[], design.len());
    let from = o.curve_from.clamp(p / 3 + 1, o.poses);
    let curve = (from..=o.poses)
        .into_par_iter()
        .map(|n| {
            let f = g.figures(&ordered[..n], o.sigma_mm);
            CurvePoint {
                poses: n,
                q95_mm: f.q95_mm,
                reliability: f.reliability,
            }
        })
        .collect::<Vec<CurvePoint>>()
        .into_iter()
        // Designs too small to determine every input have no prediction.
        .filter(|c| c.q95_mm.is_finite())
        .collect();

    // The covariance in internal units: σ² · S⁻¹ M⁻¹ S⁻¹ on the free inputs.
    let minv = Cholesky::new(g.information(&design))
        .map(|c| c.inverse())
        .ok_or_else(|| PlanError::NotIdentifiable("the planned design is singular".into()))?;
    let nf = lay.measured().len();
    let mut covariance = vec![0.0; nf * nf];
    let s2 = o.sigma_mm * o.sigma_mm;
    for (a, &ia) in free.iter().enumerate() {
        for (b, &ib) in free.iter().enumerate() {
            // Symmetric to the last bit, as a model file's covariance must be.
            let v = 0.5 * (minv[(a, b)] + minv[(b, a)]);
            covariance[ia * nf + ib] = s2 * v / (g.scale[a] * g.scale[b]);
        }
    }
    let design_q: Vec<Joints> = design.iter().map(|&i| cands[i]).collect();
    let (order, travel_deg) = visiting_order(&design_q);
    Ok(Plan {
        model_name: model.name.clone(),
        design_deg: order.iter().map(|&i| design_q[i]).collect(),
        travel_deg,
        planned,
        log_det_design,
        log_det_design_deg: dopt.iter().map(|&i| cands[i]).collect(),
        random_median,
        random_designs: o.random_designs,
        rms_bound_mm,
        curve,
        candidates: cands.len(),
        candidates_drawn: drawn,
        identified: free.iter().map(|&i| lay.measured().name(i)).collect(),
        sigma_mm: o.sigma_mm,
        target_mm: o.target_mm,
        tracker: o.tracker.clone(),
        task_points: task.len(),
        thresholds: o.thresholds.clone(),
        search: SearchTrace {
            greedy_q95_mm: greedy_q95 * o.sigma_mm,
            passes,
            swaps_tried: tried,
            swaps_accepted: accepted,
        },
        seconds: start.elapsed().as_secs_f64(),
        prediction: None,
        covariance,
        nominal: model.clone(),
    })
}

/// Figure-by-figure medians.
fn median_figures(v: &[DesignFigures], thresholds: usize) -> DesignFigures {
    let med = |f: &dyn Fn(&DesignFigures) -> f64| {
        let mut x: Vec<f64> = v.iter().map(f).collect();
        x.sort_by(f64::total_cmp);
        if x.is_empty() {
            f64::NAN
        } else if x.len() % 2 == 1 {
            x[x.len() / 2]
        } else {
            0.5 * (x[x.len() / 2 - 1] + x[x.len() / 2])
        }
    };
    DesignFigures {
        q95_mm: med(&|f| f.q95_mm),
        rms_mm: med(&|f| f.rms_mm),
        reliability: (0..thresholds)
            .map(|t| med(&|f| f.reliability[t]))
            .collect(),
        log_det: med(&|f| f.log_det),
        o1: med(&|f| f.o1),
        condition: med(&|f| f.condition),
    }
}

/// The engine's Monte Carlo of the planned model ([`Plan::model`]) at the task points:
/// `draws` draws on `ev` (an evaluator of that model's problem), R(L) at `thresholds`.
///
/// # Errors
///
/// [`PlanError::Engine`] when the evaluator fails; [`PlanError::Setting`] for no draws.
pub fn predict(
    ev: &mut dyn Evaluator,
    draws: usize,
    thresholds: &[f64],
) -> Result<Prediction, PlanError> {
    if draws < 100 {
        return Err(setting(
            PlanField::Search,
            format!("the prediction needs at least 100 draws, got {draws}"),
        ));
    }
    let m = ev.n_points();
    let mut w = vec![0.0; draws];
    // Per-point errors chunk by chunk (one chunk's m errors a draw kept at a time).
    let chunk = PREDICTION_CHUNK.min(draws);
    let mut e = vec![0.0; chunk * m];
    let mut below = vec![0u64; m * thresholds.len()];
    let mut first = 0;
    while first < draws {
        let n = chunk.min(draws - first);
        ev.evaluate(
            first as u64,
            &mut w[first..first + n],
            Some(&mut e[..n * m]),
        )?;
        for row in e[..n * m].chunks(m) {
            for (j, x) in row.iter().enumerate() {
                for (t, l) in thresholds.iter().enumerate() {
                    below[j * thresholds.len() + t] += u64::from(x < l);
                }
            }
        }
        first += n;
    }
    w.par_sort_unstable_by(f64::total_cmp);
    let per_point = (0..m)
        .map(|j| {
            thresholds
                .iter()
                .enumerate()
                .map(|(t, &l)| {
                    Reliability::from_count(l, below[j * thresholds.len() + t], draws as u64)
                })
                .collect()
        })
        .collect();
    Ok(Prediction {
        draws,
        reliability: thresholds
            .iter()
            .map(|&t| Reliability::from_sorted(t, &w))
            .collect(),
        q95_mm: quantile(&w, 0.95),
        mean_mm: w.iter().sum::<f64>() / draws as f64,
        per_point,
        backend: ev.info(),
    })
}

/// The problem [`predict`] evaluates: the planned model at the task points.
///
/// # Errors
///
/// [`PlanError::Problem`] when the problem cannot be built.
pub fn prediction_problem(plan: &Plan, task: &[Joints], seed: u64) -> Result<Problem, PlanError> {
    Ok(Problem::new(
        plan.model(),
        task,
        &Reference::Calibrated,
        seed,
    )?)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A geometry of `k` random 3 × p candidate blocks and `m` random task blocks.
    fn toy(k: usize, m: usize, p: usize, seed: u64) -> Geometry {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let stacked = DMatrix::from_fn(3 * k, p, |_, _| standard_normal(&mut rng));
        let task = DMatrix::from_fn(3 * m, p, |_, _| standard_normal(&mut rng));
        let cand: Vec<DMatrix<f64>> = (0..k)
            .map(|i| stacked.rows(3 * i, 3).into_owned())
            .collect();
        Geometry {
            info: cand.iter().map(|j| j.transpose() * j).collect(),
            cand,
            stacked,
            grams: (0..m)
                .map(|j| {
                    let r = task.rows(3 * j, 3);
                    r.transpose() * r
                })
                .collect(),
            task,
            z: DMatrix::zeros(p, 1),
            z_eval: DMatrix::zeros(p, 1),
            scale: vec![1.0; p],
            thresholds_sigma: Vec::new(),
        }
    }

    /// Every multiset of `n` of `0..k`, in order.
    fn multisets(k: usize, n: usize) -> Vec<Vec<usize>> {
        if n == 0 {
            return vec![Vec::new()];
        }
        let mut out = Vec::new();
        for rest in multisets(k, n - 1) {
            let from = rest.last().copied().unwrap_or(0);
            for i in from..k {
                let mut d = rest.clone();
                d.push(i);
                out.push(d);
            }
        }
        out
    }

    #[test]
    fn the_design_bound_is_below_every_exact_design_and_near_the_best() {
        for seed in 1..=5 {
            let (k, n) = (8, 6);
            let g = toy(k, 4, 5, seed);
            let (bound, best_weights) = g.mean_sq_bound(n, 2000);
            // Brute force over every design of n poses, repeats allowed (1716 of them).
            let best_exact = multisets(k, n)
                .iter()
                .map(|d| g.mean_sq(&g.information(d)))
                .fold(f64::INFINITY, f64::min);
            eprintln!("seed {seed}: bound {bound:.5}, best weights {best_weights:.5}, best exact {best_exact:.5}");
            assert!(bound.is_finite() && bound > 0.0);
            assert!(
                bound <= best_exact * (1.0 + 1e-12),
                "seed {seed}: bound {bound} above the best exact design {best_exact}"
            );
            assert!(bound <= best_weights * (1.0 + 1e-12));
            // Rounding n = 6 weights to whole poses costs little here: the bound is not vacuous.
            assert!(
                bound >= 0.8 * best_exact,
                "seed {seed}: bound {bound}, best exact {best_exact}"
            );
        }
    }
}
