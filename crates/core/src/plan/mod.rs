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
//!
//! The steps live in submodules: `candidates` (the settings' checks and the candidate
//! configurations), `geometry` (the scaled Jacobians and every figure of a design), `search`
//! (greedy D-optimal and the exchange), `compare` (random designs, the bound, the curve),
//! `order` (the visiting order) and `prediction` (the engine's Monte Carlo).

mod approach;
mod candidates;
mod compare;
mod geometry;
mod order;
mod prediction;
pub mod program;
mod report;
mod search;
mod steps;
#[cfg(test)]
mod tests;
pub mod workcell;

pub use approach::{Approach, APPROACH_STEP_DEG};
pub use prediction::{
    model_to_plan, predict, predict_with_progress, prediction_estimate, prediction_problem,
};
pub use report::render_text;
pub use steps::PLAN_STEPS;
pub use workcell::{KeepOut, Workcell};

use crate::engine::{BackendInfo, EngineError, ProblemError};
use crate::identify::chain::{nominal_state, state_model, Placement};
use crate::identify::chain_fit::default_free;
use crate::kinematics::{Joints, RobotModel};
use crate::mc::stats::Reliability;
use geometry::Geometry;
use rand::SeedableRng;
use serde::Serialize;
use steps::Step;

/// The longest range a plan's tracker may have, mm (100 m): laser trackers measure a target
/// from tens of metres at most, and a calibration's tracker stands a few metres from the robot.
pub const MAX_TRACKER_RANGE_MM: f64 = 100_000.0;

/// Where the laser tracker stands and what it can see.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TrackerSite {
    /// Position in the measurement frame (the model's base frame for a model without `base`), mm.
    pub position_mm: [f64; 3],
    /// Largest distance to a target, mm (at most [`MAX_TRACKER_RANGE_MM`]); the tracker must
    /// stand within this range of some pose the target can take.
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
    /// The floor, keep-out boxes and self-collision every candidate must respect
    /// ([`workcell`]).
    pub workcell: Workcell,
    /// The side every joint arrives at each pose from ([`Approach`]); a candidate's approach
    /// pose must then keep within the limits and the workcell too. `None`: each joint arrives
    /// from the previous pose of the visiting order.
    pub approach: Option<Approach>,
    /// Told `(step, done, `[`PLAN_STEPS`]`)` as the plan goes: the steps are shares of its
    /// work, weighted by what each does for these settings, and only ever grow (a listener's
    /// remaining time holds throughout). Changes no result.
    pub progress: crate::progress::ProgressHook,
}

/// Distance from the last joint's axis below which a model's tool is not taken as the plan's
/// target by default, mm.
pub const MIN_TARGET_OFFSET_MM: f64 = 1.0;

/// The thresholds `L` (mm) at which a plan predicts R(L) when none are given: tighter than an
/// analysis's defaults ([`crate::mc::DEFAULT_THRESHOLDS_MM`]), since a plan is about what a
/// calibration achieves. Every front end takes its default from here.
pub const DEFAULT_THRESHOLDS_MM: [f64; 3] = [0.02, 0.03, 0.05];

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
            workcell: Workcell::default(),
            approach: None,
            progress: crate::progress::ProgressHook::none(),
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
    /// [`PlanOptions::tracker`]: its position (and the site as a whole).
    Tracker,
    /// [`TrackerSite::range_mm`].
    TrackerRange,
    /// [`TrackerSite::max_incidence_deg`].
    MaxIncidence,
    /// [`PlanOptions::thresholds`].
    Thresholds,
    /// The search settings (draws, passes, swaps, random designs, margin, condition).
    Search,
    /// The task points.
    TaskPoints,
    /// [`PlanOptions::target_mm`].
    Target,
    /// [`Workcell::floor_mm`].
    Floor,
    /// [`Workcell::keep_out`].
    KeepOut,
    /// [`Workcell::link_radius_mm`].
    LinkRadius,
    /// [`Workcell::self_collision`].
    SelfCollision,
    /// A robot program of the design ([`program::robot_program`]).
    Program,
    /// The side every joint arrives at each pose from ([`Approach`]).
    Approach,
}

impl std::fmt::Display for PlanField {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            PlanField::Poses => "number of poses",
            PlanField::Candidates => "number of candidates",
            PlanField::Sigma => "tracker noise",
            PlanField::Tracker => "tracker position",
            PlanField::TrackerRange => "tracker range",
            PlanField::MaxIncidence => "maximum incidence",
            PlanField::Thresholds => "threshold",
            PlanField::Search => "search setting",
            PlanField::TaskPoints => "task points",
            PlanField::Target => "target",
            PlanField::Floor => "floor",
            PlanField::KeepOut => "keep-out box",
            PlanField::LinkRadius => "link radius",
            PlanField::SelfCollision => "self-collision check",
            PlanField::Approach => "approach side",
            PlanField::Program => "robot program",
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
    /// A setting that, with the others as given, would change nothing: it takes effect only
    /// with one of `needs` (a front end names them too).
    #[error("{field}: {message}")]
    Unused {
        /// The setting that would change nothing.
        field: PlanField,
        /// The settings it would take effect with.
        needs: Vec<PlanField>,
        /// Why, and what to do.
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
    /// The same travel in the order the search chose the poses, before ordering, degrees.
    pub travel_unordered_deg: f64,
    /// The joint limits the candidates kept within (the controller's where narrower than the
    /// model's, [`workcell::controller_limits`]), degrees.
    pub limits_deg: Vec<(f64, f64)>,
    /// Where limits narrower than the model's come from, if any.
    pub limits_note: Option<String>,
    /// The floor, keep-out boxes and self-collision the candidates respected.
    pub workcell: Workcell,
    /// The side every joint arrives at each pose from, if one was chosen
    /// ([`PlanOptions::approach`]).
    pub approach: Option<Approach>,
    /// Configurations refused for the workcell: below the floor, into a keep-out box, into
    /// the arm itself.
    pub rejected: candidates::Rejected,
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
    /// The planned model's covariance over the fit inputs
    /// ([`ChainState::space`](crate::identify::chain_fit::ChainState::space); 39 for six joints),
    /// row-major, internal units.
    #[serde(skip)]
    pub covariance: Vec<f64>,
    /// The nominal model.
    #[serde(skip)]
    pub nominal: RobotModel,
}

impl Plan {
    /// The model the plan predicts: the nominal geometry and target, the design's covariance,
    /// the placement drawn in the measurement frame, and the discrepancy term of the given model
    /// when it carries one (an identified model of the robot: what a new geometric calibration
    /// leaves too, [`crate::discrepancy::Discrepancy::for_new_calibration`]).
    pub fn model(&self) -> RobotModel {
        let mut m = state_model(
            &self.nominal,
            &nominal_state(&self.nominal),
            &self.covariance,
            Placement::Identify,
            format!("{} (planned calibration)", self.nominal.name),
        );
        m.discrepancy = self
            .nominal
            .discrepancy
            .as_ref()
            .map(|d| d.for_new_calibration());
        m
    }
}

/// Standard-normal vectors behind every reported linearised figure.
pub const EVAL_DRAWS: usize = 2000;

/// Adds to `e` the bytes [`plan`] keeps for `model` (its free inputs p), `task_points` task
/// points and the settings `o`: per candidate its configuration, its observation, its 3 × p
/// Jacobian rows (stacked, apart and while they are built) and its p × p information matrix;
/// per task point its rows and p × p Gram matrix; the search's and the figures' p-vectors of
/// standard normals.
pub fn plan_estimate(
    model: &RobotModel,
    task_points: usize,
    o: &PlanOptions,
    e: crate::memory::Estimate,
) -> crate::memory::Estimate {
    let p = default_free(&model.fixed, true).len() as u64;
    // A heap matrix's header and the allocator's own bookkeeping.
    const MATRIX: u64 = 64;
    let joints = std::mem::size_of::<Joints>() as u64;
    let rows = 3 * p * 8;
    let gram = p * p * 8 + MATRIX;
    e.plus(&[
        o.candidates as u64,
        2 * joints + 3 * rows + MATRIX + gram + 256,
    ])
    .plus(&[task_points as u64, joints + 2 * rows + gram])
    .plus(&[(o.search_draws + EVAL_DRAWS) as u64, p, 8])
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
    candidates::check(model, task, o)?;
    let mut model = model.clone();
    model.tool = o.target_mm;
    let model = &model;
    let start = std::time::Instant::now();
    let s = nominal_state(model);
    let lay = model.layout();
    let free = default_free(&model.fixed, true);
    let steps = steps::Steps::new(o, free.len(), task.len());
    steps.at(Step::Candidates, 0.0);
    let (limits, limits_note) = workcell::controller_limits(model);
    let (cands, drawn, rejected) = candidates::candidates(model, &s, &limits, o, &steps)?;
    steps.at(Step::Jacobians, 0.0);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(o.seed ^ 0x005E_ED0F_C0DE);
    let g = Geometry::new(&s, &free, &cands, task, o, &mut rng, &|f| {
        steps.at(Step::Jacobians, f)
    });
    steps.at(Step::Greedy, 0.0);
    let (dopt, greedy_q95) =
        search::initial_design(&g, o.poses, &free, lay, &|f| steps.at(Step::Greedy, f))?;
    steps.at(Step::Exchange, 0.0);
    let (design, search) = search::exchange(&g, &dopt, greedy_q95, o, &mut rng, &|f| {
        steps.at(Step::Exchange, f)
    });
    // The comparison: the log-det design and random designs of the same size.
    steps.at(Step::Random, 0.0);
    let planned = g.figures(&design, o.sigma_mm);
    let log_det_design = g.figures(&dopt, o.sigma_mm);
    let random_median = compare::random_median(&g, o, &mut rng, &|f| steps.at(Step::Random, f));
    steps.at(Step::Bound, 0.0);
    let rms_bound_mm = compare::rms_bound_mm(&g, o, &|f| steps.at(Step::Bound, f));
    steps.at(Step::Curve, 0.0);
    let curve = compare::curve(&g, &design, o);
    let covariance = g.covariance(&design, &free, lay.measured().len(), o.sigma_mm)?;
    let design_q: Vec<Joints> = design.iter().map(|&i| cands[i]).collect();
    let travel_unordered_deg = order::travel(&design_q);
    let (design_deg, travel_deg) = order::visiting_order(&design_q, &limits, o.margin_deg);
    steps.finish();
    Ok(Plan {
        model_name: model.name.clone(),
        design_deg,
        travel_deg,
        travel_unordered_deg,
        limits_deg: limits,
        limits_note,
        workcell: o.workcell.clone(),
        approach: o.approach,
        rejected,
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
        search,
        seconds: start.elapsed().as_secs_f64(),
        prediction: None,
        covariance,
        nominal: model.clone(),
    })
}
