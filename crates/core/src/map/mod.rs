//! Workspace reliability maps (docs/METHOD.md §15): where in the workspace is the robot
//! reliable?
//!
//! A grid of target positions (a plane slice or a 3-D grid in the workspace box) is turned into
//! joint configurations by inverse kinematics on the model ([`ik`]); the configurations that
//! reach their targets become the test points of **one** per-point evaluation, so every cell sees
//! the same parameter draws (one Philox stream, docs/METHOD.md §6). Per cell: the single-point
//! reliability `R_j(l_c) = Pr[e_j < l_c]` (paper eq. 14) with its Wilson 95 % interval, the mean
//! and 95 % quantile of the point error `e_j`, and the condition number of the position
//! Jacobian; over all reached cells, the multi-point reliability `R(l_c) = Pr[w < l_c]` with
//! `w = max_j e_j` (paper eq. 17). Unreachable cells are kept, marked, and take no part in `w`.

pub mod ik;
pub mod shard;

use crate::engine::{BackendInfo, EngineError, Evaluator, ProblemError};
use crate::kinematics::{position, RobotModel, JOINTS};
use crate::mc::Reliability;
use crate::memory::Estimate;
use crate::points::WorkspaceBox;
use ik::{Ik, IkTarget};
use serde::{Deserialize, Serialize};

/// Most cells a map may have (a 500 × 500 plane): every cell costs an inverse-kinematics solve
/// and `draws × 8` bytes of kept errors.
pub const MAX_CELLS: usize = 250_000;

/// The plane of a slice, named by the two axes it spans.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Plane {
    /// Horizontal plane at a given z.
    Xy,
    /// Vertical plane at a given y.
    Xz,
    /// Vertical plane at a given x.
    Yz,
}

impl Plane {
    /// World axes (0 = x, 1 = y, 2 = z): horizontal, vertical and normal of the slice.
    pub fn axes(self) -> [usize; 3] {
        match self {
            Plane::Xy => [0, 1, 2],
            Plane::Xz => [0, 2, 1],
            Plane::Yz => [1, 2, 0],
        }
    }
}

/// Which targets a map covers.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Grid {
    /// A plane slice through the workspace box at `at` mm along the plane's normal, with
    /// `cells` = (horizontal, vertical) cell counts over the box's extent.
    Plane {
        /// The plane.
        plane: Plane,
        /// Coordinate along the normal, mm.
        at: f64,
        /// Cells along the plane's horizontal and vertical axes.
        cells: [usize; 2],
    },
    /// A 3-D grid filling the workspace box: `cells` along x, y, z.
    Volume {
        /// Cells along x, y and z.
        cells: [usize; 3],
    },
}

/// The settings a map checks, named in its errors ([`MapError::Setting`]); a front end maps
/// each to its own option name.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MapSetting {
    /// The cell counts.
    Cells,
    /// The coordinate of a plane slice along its normal.
    PlanePosition,
    /// The workspace box.
    Workspace,
    /// The tool orientation (roll, pitch, yaw).
    Orientation,
    /// The reference configuration.
    ReferenceConfiguration,
    /// The number of extra inverse-kinematics seeds.
    IkSeeds,
    /// The thresholds l_c.
    Thresholds,
    /// The number of draws.
    Draws,
}

impl std::fmt::Display for MapSetting {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            MapSetting::Cells => "cell counts",
            MapSetting::PlanePosition => "plane position",
            MapSetting::Workspace => "workspace box",
            MapSetting::Orientation => "tool orientation",
            MapSetting::ReferenceConfiguration => "reference configuration",
            MapSetting::IkSeeds => "inverse-kinematics seeds",
            MapSetting::Thresholds => "thresholds",
            MapSetting::Draws => "number of draws",
        })
    }
}

/// Errors of a map.
#[derive(Debug, thiserror::Error)]
pub enum MapError {
    /// A setting is out of range.
    #[error("{field}: {message}")]
    Setting {
        /// Which setting.
        field: MapSetting,
        /// What is wrong.
        message: String,
    },
    /// No cell can be reached.
    #[error("none of the {cells} cells is reachable with the {task}: move or shrink the grid, or free the orientation")]
    NothingReachable {
        /// Cells tried.
        cells: usize,
        /// "tool orientation (r, p, y)°" or "position only".
        task: String,
    },
    /// The reached configurations do not make a problem (the model's own checks).
    #[error(transparent)]
    Problem(#[from] ProblemError),
    /// The evaluator failed.
    #[error(transparent)]
    Engine(#[from] EngineError),
}

fn setting(field: MapSetting, message: impl Into<String>) -> MapError {
    MapError::Setting {
        field,
        message: message.into(),
    }
}

/// What a map asks for (everything but the draws).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MapSpec {
    /// The grid.
    pub grid: Grid,
    /// The box the grid spans, mm.
    pub workspace: WorkspaceBox,
    /// Fixed flange orientation as roll, pitch, yaw in degrees about the fixed x, y, z axes, or
    /// `None` for a position-only task.
    pub orientation_rpy_deg: Option<[f64; 3]>,
    /// The configuration (degrees) whose nearest solution each cell takes.
    pub reference_q_deg: [f64; JOINTS],
    /// Seeds spread over the joint ranges besides the reference and the neighbours.
    pub ik_seeds: usize,
}

/// The default tool orientation of most robots: roll 180°, so the flange z axis points down
/// (−z of the world).
pub const TOOL_DOWN_RPY_DEG: [f64; 3] = [180.0, 0.0, 0.0];

/// The flange orientation (roll, pitch, yaw in degrees, world frame) that points `model`'s tool
/// down. The tool points away from the wrist along the last joint axis: along +z of the last
/// frame when the flange (`d6` plus the tool's z) lies on its positive side, as for the TX60,
/// UR and ABB presets, and along −z when it lies on the negative side, as for a joint axis
/// imported with the opposite sign (the KUKA KR 6's A6 axis is −x of its flange): then the
/// last frame's z axis must point up (roll 0).
pub fn tool_down_rpy_deg(model: &RobotModel) -> [f64; 3] {
    let d6 = model.params[(JOINTS - 1) * crate::kinematics::PARAMS_PER_JOINT + 1];
    if d6 + model.tool[2] < 0.0 {
        [0.0, 0.0, 0.0]
    } else {
        TOOL_DOWN_RPY_DEG
    }
}

/// Most extra inverse-kinematics seeds per cell.
pub const MAX_IK_SEEDS: usize = 1000;

/// The default reference configuration of `model`: the middle of each joint's range, with
/// joints 2, 3 and 5 turned 30° towards their upper limits (clamped), which takes the arm out of
/// the stretched or upright zero pose most models have at mid-range, where elbow and wrist
/// branches tie.
pub fn default_reference_deg(model: &RobotModel) -> [f64; JOINTS] {
    std::array::from_fn(|i| {
        let (lo, hi) = model.limits_deg[i];
        let mid = 0.5 * (lo + hi);
        let turn = if matches!(i, 1 | 2 | 4) { 30.0 } else { 0.0 };
        (mid + turn).clamp(lo, hi)
    })
}

/// A cell's target.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CellTarget {
    /// Grid index: (horizontal, vertical, layer) for a plane (layer 0), (x, y, z) for a volume.
    pub index: [usize; 3],
    /// Target position in the base frame, mm.
    pub position: [f64; 3],
}

/// The configuration that reaches a cell.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CellIk {
    /// Joint angles, degrees (the test point of the evaluation).
    pub q_deg: [f64; JOINTS],
    /// Distance between the tool point at `q_deg` and the target, mm (≤ 1e-9).
    pub position_residual_mm: f64,
    /// Angle between the flange orientation and the target's, radians (`None` when free).
    pub orientation_residual_rad: Option<f64>,
    /// Condition number of the 3 × 6 position Jacobian (`None` at a position singularity).
    pub jacobian_condition: Option<f64>,
}

impl MapSpec {
    /// The three axes (world indices) the grid's index runs along, their cell counts and ranges.
    pub fn layout(&self) -> ([usize; 3], [usize; 3], [(f64, f64); 3]) {
        let b = &self.workspace;
        let range = |a: usize| (b.center[a] - 0.5 * b.size[a], b.center[a] + 0.5 * b.size[a]);
        match self.grid {
            Grid::Plane { plane, at, cells } => {
                let ax = plane.axes();
                (
                    ax,
                    [cells[0], cells[1], 1],
                    [range(ax[0]), range(ax[1]), (at, at)],
                )
            }
            Grid::Volume { cells } => ([0, 1, 2], cells, [range(0), range(1), range(2)]),
        }
    }

    /// Number of cells (saturating).
    pub fn n_cells(&self) -> usize {
        let (_, n, _) = self.layout();
        n.iter().fold(1usize, |a, &b| a.saturating_mul(b))
    }

    /// Checks the grid against the model: cell counts, the box, the plane position (inside the
    /// box and within the robot's reach), the orientation, the reference configuration, seeds.
    pub fn check(&self, model: &RobotModel) -> Result<(), MapError> {
        let b = &self.workspace;
        if !(0..3).all(|k| b.center[k].is_finite() && b.size[k].is_finite() && b.size[k] > 0.0) {
            return Err(setting(
                MapSetting::Workspace,
                format!(
                    "centre and sizes must be finite and sizes > 0 mm, got centre {:?} size {:?}",
                    b.center, b.size
                ),
            ));
        }
        let (_, n, _) = self.layout();
        if n.contains(&0) {
            return Err(setting(MapSetting::Cells, "every count must be at least 1"));
        }
        let total = self.n_cells();
        if total > MAX_CELLS {
            return Err(setting(
                MapSetting::Cells,
                format!("at most {MAX_CELLS} cells in all, got {total}"),
            ));
        }
        if let Grid::Plane { plane, at, .. } = self.grid {
            let a = plane.axes()[2];
            let (lo, hi) = (b.center[a] - 0.5 * b.size[a], b.center[a] + 0.5 * b.size[a]);
            let name = ["x", "y", "z"][a];
            if !at.is_finite() || at < lo || at > hi {
                return Err(setting(
                    MapSetting::PlanePosition,
                    format!("{name} = {at} mm is outside the workspace box ({lo} to {hi} mm)"),
                ));
            }
            let reach = ik::reach_bound(model);
            if at.abs() > reach {
                return Err(setting(
                    MapSetting::PlanePosition,
                    format!(
                        "{name} = {at} mm is beyond the reach of {} (at most {reach:.0} mm from the base)",
                        model.name
                    ),
                ));
            }
        }
        if let Some(o) = self.orientation_rpy_deg {
            if o.iter().any(|v| !v.is_finite() || v.abs() > 360.0) {
                return Err(setting(
                    MapSetting::Orientation,
                    format!("roll, pitch and yaw must be finite angles within ±360°, got {o:?}"),
                ));
            }
        }
        model
            .check_limits(&self.reference_q_deg)
            .map_err(|m| setting(MapSetting::ReferenceConfiguration, m))?;
        if self.ik_seeds > MAX_IK_SEEDS {
            return Err(setting(
                MapSetting::IkSeeds,
                format!("at most {MAX_IK_SEEDS}, got {}", self.ik_seeds),
            ));
        }
        Ok(())
    }

    /// The cells' targets in index order (horizontal fastest, then vertical, then layer).
    pub fn targets(&self) -> Vec<CellTarget> {
        let (axes, n, range) = self.layout();
        let centre = |d: usize, i: usize| {
            let (lo, hi) = range[d];
            if n[d] == 1 && lo == hi {
                lo
            } else {
                lo + (i as f64 + 0.5) * (hi - lo) / n[d] as f64
            }
        };
        let mut out = Vec::with_capacity(self.n_cells());
        for k in 0..n[2] {
            for j in 0..n[1] {
                for i in 0..n[0] {
                    let mut p = [0.0; 3];
                    p[axes[0]] = centre(0, i);
                    p[axes[1]] = centre(1, j);
                    p[axes[2]] = centre(2, k);
                    out.push(CellTarget {
                        index: [i, j, k],
                        position: p,
                    });
                }
            }
        }
        out
    }

    /// The task of every cell, in words.
    pub fn task(&self) -> String {
        match self.orientation_rpy_deg {
            Some([r, p, y]) => format!("tool orientation (roll {r}°, pitch {p}°, yaw {y}°)"),
            None => "position only (free orientation)".to_string(),
        }
    }

    /// Inverse kinematics for every cell: visited in serpentine order so that each cell is
    /// seeded from its solved neighbours; `None` for a cell no seed reaches. Errors when the
    /// settings are wrong or no cell is reachable.
    pub fn solve(&self, model: &RobotModel) -> Result<Vec<Option<CellIk>>, MapError> {
        self.check(model)?;
        let targets = self.targets();
        let (_, n, _) = self.layout();
        let ik = Ik::new(
            model,
            self.reference_q_deg.map(f64::to_radians),
            self.ik_seeds,
        );
        // Targets and the tool orientation are given in the world frame (the frame `fk` reports
        // in); the IK works in the robot's base frame, which a model's base transform moves.
        let to_base = model.base.as_ref().map(|b| b.isometry().inverse());
        let rotation = self.orientation_rpy_deg.map(|o| {
            let r = ik::rpy_rotation(o);
            match &to_base {
                None => r,
                Some(t) => {
                    let m = t.rotation.to_rotation_matrix();
                    std::array::from_fn(|i| {
                        std::array::from_fn(|j| (0..3).map(|k| m[(i, k)] * r[k][j]).sum())
                    })
                }
            }
        });
        let in_base = |p: [f64; 3]| match &to_base {
            None => p,
            Some(t) => {
                let v = t * nalgebra::Point3::from(p);
                [v.x, v.y, v.z]
            }
        };
        let mut solved: Vec<Option<[f64; JOINTS]>> = vec![None; targets.len()];
        let mut out: Vec<Option<CellIk>> = vec![None; targets.len()];
        let flat = |i: usize, j: usize, k: usize| (k * n[1] + j) * n[0] + i;
        for k in 0..n[2] {
            for jj in 0..n[1] {
                let j = if k % 2 == 0 { jj } else { n[1] - 1 - jj };
                for ii in 0..n[0] {
                    let i = if (jj + k) % 2 == 0 { ii } else { n[0] - 1 - ii };
                    let c = flat(i, j, k);
                    let mut neighbours = Vec::new();
                    let mut near = |d: usize, idx: [usize; 3]| {
                        if idx[d] < n[d] {
                            if let Some(q) = solved[flat(idx[0], idx[1], idx[2])] {
                                neighbours.push(q);
                            }
                        }
                    };
                    for d in 0..3 {
                        let mut a = [i, j, k];
                        a[d] = a[d].wrapping_sub(1);
                        near(d, a);
                        let mut b = [i, j, k];
                        b[d] += 1;
                        near(d, b);
                    }
                    let target = IkTarget {
                        position: in_base(targets[c].position),
                        rotation,
                    };
                    let Some(s) = ik.solve(&target, &neighbours) else {
                        continue;
                    };
                    out[c] = self.accept(model, &ik, &target, &s.q);
                    if out[c].is_some() {
                        solved[c] = Some(s.q);
                    }
                }
            }
        }
        if out.iter().all(Option::is_none) {
            return Err(MapError::NothingReachable {
                cells: out.len(),
                task: self.task(),
            });
        }
        Ok(out)
    }

    /// The test point of a solution: degrees within the limits, with its residuals recomputed
    /// from the degrees (what the evaluation uses) and checked again.
    fn accept(
        &self,
        model: &RobotModel,
        ik: &Ik,
        target: &IkTarget,
        q: &[f64; JOINTS],
    ) -> Option<CellIk> {
        let q_deg: [f64; JOINTS] = std::array::from_fn(|i| {
            q[i].to_degrees()
                .clamp(model.limits_deg[i].0, model.limits_deg[i].1)
        });
        let q_rad = q_deg.map(f64::to_radians);
        let (p, o) = ik.residuals(target, &q_rad);
        let ok = p <= ik::POSITION_TOL_MM && o.is_none_or(|o| o <= ik::ORIENTATION_TOL_RAD);
        ok.then(|| CellIk {
            q_deg,
            position_residual_mm: p,
            orientation_residual_rad: o,
            jacobian_condition: ik::position_condition(model, &q_rad),
        })
    }
}

/// Bytes kept per cell besides its errors: target, configuration, statistics.
pub const BYTES_PER_CELL: u64 = 512;

/// Memory a map evaluation keeps: the errors of every evaluated cell and draw (8 bytes each,
/// kept for the exact 95 % quantile), one batch of per-point errors in the driver and as much in
/// the evaluator, the multi-point w of every draw, and the cells of the whole grid. A map split
/// into shards ([`shard`]) evaluates only a shard's cells in each, so `evaluated` may be fewer
/// than the grid's `cells`.
pub fn memory_estimate(cells: usize, evaluated: usize, draws: u64, batch: u64) -> Estimate {
    let what = if evaluated < cells {
        format!("a shard of {evaluated} of the {cells} cells of a map with {draws} draws")
    } else {
        format!("a map of {cells} cells with {draws} draws")
    };
    Estimate::new(what, "use fewer cells or draws, or raise the memory limit")
        .plus(&[evaluated as u64, draws, 8])
        .plus(&[batch, evaluated as u64, 2 * 8])
        .plus(&[draws, 8])
        .plus(&[cells as u64, BYTES_PER_CELL])
}

/// Draws evaluated at a time for `cells` reached cells: about 4·10^6 errors (32 MB) a batch.
pub fn batch_size(cells: usize, draws: u64) -> u64 {
    (4_000_000 / cells.max(1) as u64).clamp(1, draws.max(1))
}

/// The statistics of one reached cell over the draws.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CellStats {
    /// Mean of the point error e_j, mm.
    pub mean_mm: f64,
    /// 95 % quantile of e_j (the ⌈0.95 N⌉-th smallest value), mm.
    pub q95_mm: f64,
    /// `R_j(l_c)` at each threshold, with the Wilson 95 % interval.
    pub reliability: Vec<Reliability>,
}

/// The evaluation of the reached cells.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Evaluation {
    /// Draws.
    pub draws: u64,
    /// Per reached cell, in the order of the evaluator's test points.
    pub cells: Vec<CellStats>,
    /// Multi-point `R(l_c) = Pr[w < l_c]`, `w = max_j e_j` over the reached cells.
    pub multi_point: Vec<Reliability>,
    /// Mean of w, mm.
    pub w_mean_mm: f64,
    /// 95 % quantile of w, mm.
    pub w_q95_mm: f64,
}

/// Checks thresholds and draws.
pub fn check_run(thresholds: &[f64], draws: u64) -> Result<(), MapError> {
    if thresholds.is_empty() {
        return Err(setting(MapSetting::Thresholds, "at least one is needed"));
    }
    if let Some(t) = thresholds.iter().find(|t| !t.is_finite() || **t <= 0.0) {
        return Err(setting(
            MapSetting::Thresholds,
            format!("each must be a positive number of mm, got {t}"),
        ));
    }
    if draws == 0 {
        return Err(setting(MapSetting::Draws, "at least 1 is needed"));
    }
    Ok(())
}

/// The ⌈p·n⌉-th smallest of `v` (reorders `v`).
fn quantile(v: &mut [f64], p: f64) -> f64 {
    let k = ((p * v.len() as f64).ceil() as usize).clamp(1, v.len()) - 1;
    *v.select_nth_unstable_by(k, f64::total_cmp).1
}

/// The statistics of one set of errors over the draws, in draw order: a cell's `e_j` or the
/// multi-point `w` (reorders `v`, which must not be empty).
pub fn statistics(v: &mut [f64], thresholds: &[f64]) -> CellStats {
    let n = v.len() as u64;
    let mean_mm = v.iter().sum::<f64>() / n as f64;
    let reliability = thresholds
        .iter()
        .map(|&l| Reliability::from_count(l, v.iter().filter(|&&e| e < l).count() as u64, n))
        .collect();
    CellStats {
        mean_mm,
        q95_mm: quantile(v, 0.95),
        reliability,
    }
}

/// The evaluated cells' statistics and the multi-point `w = max_j e_j` over them of every draw,
/// before its statistics: the part of an evaluation a shard of a map keeps ([`shard`]).
#[derive(Clone, Debug, PartialEq)]
pub struct CellErrors {
    /// Per evaluated cell, in the order of the evaluator's test points.
    pub cells: Vec<CellStats>,
    /// `w` of draws `0 … draws − 1`, mm.
    pub w: Vec<f64>,
}

/// Evaluates draws `0 … draws − 1` at every test point of `ev` (the reached cells, or a shard's
/// part of them) in batches of `batch`, keeping each cell's errors for its statistics;
/// `progress` gets (done, total).
pub fn evaluate_cells(
    ev: &mut dyn Evaluator,
    draws: u64,
    batch: u64,
    thresholds: &[f64],
    progress: Option<&(dyn Fn(u64, u64) + Sync)>,
) -> Result<CellErrors, MapError> {
    check_run(thresholds, draws)?;
    let m = ev.n_points();
    let n = draws as usize;
    let batch = batch.clamp(1, draws) as usize;
    // Cell-major: errors of cell j are values[j·n .. (j+1)·n], in draw order.
    let mut values = vec![0.0f64; m * n];
    let mut w = vec![0.0f64; n];
    let mut buf = vec![0.0f64; batch * m];
    let mut first = 0usize;
    while first < n {
        let len = batch.min(n - first);
        let e = &mut buf[..len * m];
        ev.evaluate(first as u64, &mut w[first..first + len], Some(e))?;
        for (i, row) in e.chunks(m).enumerate() {
            for (j, v) in row.iter().enumerate() {
                values[j * n + first + i] = *v;
            }
        }
        first += len;
        if let Some(p) = progress {
            p(first as u64, draws);
        }
    }
    let cells = values
        .chunks_mut(n)
        .map(|v| statistics(v, thresholds))
        .collect();
    Ok(CellErrors { cells, w })
}

impl Evaluation {
    /// The evaluation of the reached cells from their statistics and `w` of every draw (one
    /// run's, or the elementwise maximum of its shards'): the multi-point statistics are those
    /// of `w` ([`statistics`]).
    pub fn new(cells: Vec<CellStats>, mut w: Vec<f64>, thresholds: &[f64]) -> Evaluation {
        let multi = statistics(&mut w, thresholds);
        Evaluation {
            draws: w.len() as u64,
            cells,
            multi_point: multi.reliability,
            w_mean_mm: multi.mean_mm,
            w_q95_mm: multi.q95_mm,
        }
    }
}

/// Evaluates draws `0 … draws − 1` at every test point of `ev` (the reached cells) in batches of
/// `batch` ([`evaluate_cells`]) and adds the multi-point statistics.
pub fn evaluate(
    ev: &mut dyn Evaluator,
    draws: u64,
    batch: u64,
    thresholds: &[f64],
    progress: Option<&(dyn Fn(u64, u64) + Sync)>,
) -> Result<Evaluation, MapError> {
    let e = evaluate_cells(ev, draws, batch, thresholds, progress)?;
    Ok(Evaluation::new(e.cells, e.w, thresholds))
}

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
pub fn test_points(solutions: &[Option<CellIk>]) -> Vec<[f64; JOINTS]> {
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
    /// `eval` ([`evaluate`] on the evaluator of [`test_points`]).
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
}

/// The tool-point distance of a reached cell's configuration from its target, mm (for checks).
pub fn round_trip_error(model: &RobotModel, cell: &MapCell) -> Option<f64> {
    let q = cell.ik?.q_deg.map(f64::to_radians);
    let p = position(&model.params, &model.tool, &q);
    let t = cell.target.position;
    Some(((p[0] - t[0]).powi(2) + (p[1] - t[1]).powi(2) + (p[2] - t[2]).powi(2)).sqrt())
}
