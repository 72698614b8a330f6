//! A finished map ([`MapResult`]): the grid's cells with their configurations and statistics,
//! the multi-point reliability and the timings.

use super::{CellIk, CellStats, CellTarget, Evaluation, MapSpec};
use crate::engine::BackendInfo;
use crate::kinematics::{Joints, RobotModel};
use crate::mc::Reliability;
use serde::{Deserialize, Serialize};

/// One cell of a finished map.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MapCell {
    /// Grid index and target.
    #[serde(flatten)]
    pub target: CellTarget,
    /// The configuration, `None` when unreachable.
    pub ik: Option<CellIk>,
    /// The statistics, `None` when unreachable.
    pub stats: Option<CellStats>,
}

/// A finished map: the grid, every cell, the multi-point reliability and how it was computed.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MapResult {
    /// Model name.
    pub model: String,
    /// The origin of the robot's base frame in the frame of the map's positions (the
    /// description's frame), mm.
    pub base_origin_mm: [f64; 3],
    /// What the report should say about the model (a model without spread), one line each.
    pub notes: Vec<String>,
    /// What was asked.
    pub spec: MapSpec,
    /// Seed of the parameter draws.
    pub seed: u64,
    /// Draws.
    pub draws: u64,
    /// Thresholds l_c, mm.
    pub thresholds: Vec<f64>,
    /// Cells reached.
    pub reached: usize,
    /// Multi-point `R(l_c)` over the reached cells.
    pub multi_point: Vec<Reliability>,
    /// Mean of w over the reached cells, mm.
    pub w_mean_mm: f64,
    /// 95 % quantile of w, mm.
    pub w_q95_mm: f64,
    /// Every cell in index order.
    pub cells: Vec<MapCell>,
    /// The evaluator.
    pub backend: BackendInfo,
    /// Wall-clock seconds of each stage.
    pub timings: Timings,
}

/// The reached cells' configurations in degrees, the test points of the evaluation.
pub fn test_points(solutions: &[Option<CellIk>]) -> Vec<Joints> {
    solutions.iter().flatten().map(|s| s.q_deg).collect()
}

/// Wall-clock seconds of the two stages.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Timings {
    /// Inverse kinematics of every cell.
    pub ik_seconds: f64,
    /// The evaluation of the reached cells.
    pub eval_seconds: f64,
}

impl MapResult {
    /// Puts a map together: the cells' targets from `spec`, their configurations from
    /// `solutions` ([`MapSpec::solve`]) and the statistics of the reached ones, in order, from
    /// `eval` ([`evaluate`](super::evaluate()) on the evaluator of [`test_points`]).
    pub fn new(
        model: &str,
        spec: &MapSpec,
        seed: u64,
        solutions: Vec<Option<CellIk>>,
        eval: Evaluation,
        backend: BackendInfo,
        timings: Timings,
    ) -> MapResult {
        let reached = solutions.iter().flatten().count();
        let mut stats = eval.cells.into_iter();
        let cells = spec
            .targets()
            .into_iter()
            .zip(solutions)
            .map(|(target, ik)| MapCell {
                target,
                stats: ik.and_then(|_| stats.next()),
                ik,
            })
            .collect();
        MapResult {
            model: model.to_string(),
            base_origin_mm: [0.0; 3],
            notes: Vec::new(),
            spec: spec.clone(),
            seed,
            draws: eval.draws,
            thresholds: eval.multi_point.iter().map(|r| r.threshold).collect(),
            reached,
            multi_point: eval.multi_point,
            w_mean_mm: eval.w_mean_mm,
            w_q95_mm: eval.w_q95_mm,
            cells,
            backend,
            timings,
        }
    }

    /// The map with the base frame's origin at `origin` (mm, the description's frame;
    /// [`RobotModel::base_origin_mm`]).
    pub fn with_base_origin(mut self, origin: [f64; 3]) -> MapResult {
        self.base_origin_mm = origin;
        self
    }

    /// The map of `model`: its base origin ([`MapResult::with_base_origin`]) and the notes
    /// about it ([`RobotModel::report_notes`]).
    pub fn of_model(self, model: &RobotModel) -> MapResult {
        let mut r = self.with_base_origin(model.base_origin_mm());
        r.notes = model.report_notes();
        r
    }
}

/// The tool-point distance of a reached cell's configuration from its target, mm (for checks).
pub fn round_trip_error(model: &RobotModel, cell: &MapCell) -> Option<f64> {
    let q = cell.ik?.q_deg.map(f64::to_radians);
    // Targets are in the world frame, after the base transform.
    let p = model.world_position(&q);
    let t = cell.target.position;
    Some(((p[0] - t[0]).powi(2) + (p[1] - t[1]).powi(2) + (p[2] - t[2]).powi(2)).sqrt())
}
