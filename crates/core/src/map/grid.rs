//! What a map asks for ([`MapSpec`]): the grid of targets (a plane slice or a volume in the
//! workspace box), the tool orientation and the reference configuration, checked against the
//! model, and the inverse kinematics of every cell ([`MapSpec::solve`]).

use super::ik::{self, Ik, IkTarget};
use super::{setting, MapError, MapSetting, MAX_CELLS};
use crate::kinematics::{Joints, RobotModel};
use crate::points::WorkspaceBox;
use serde::{Deserialize, Serialize};

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
    /// The configuration (degrees, one angle per joint of the model) whose nearest solution
    /// each cell takes.
    pub reference_q_deg: Joints,
    /// Seeds spread over the joint ranges besides the reference and the neighbours.
    pub ik_seeds: usize,
}

/// The default tool orientation of most robots: roll 180°, so the flange z axis points down
/// (−z of the world).
pub const TOOL_DOWN_RPY_DEG: [f64; 3] = [180.0, 0.0, 0.0];

/// The flange orientation (roll, pitch, yaw in degrees, world frame) that points `model`'s tool
/// down. The tool points away from the wrist along the last joint axis: along +z of the last
/// frame when the flange (the last joint's `d`, `d6` of a six-joint arm, plus the tool's z) lies
/// on its positive side, as for the TX60, UR and ABB presets, and along −z when it lies on the
/// negative side, as for a joint axis imported with the opposite sign (the KUKA KR 6's A6 axis
/// is −x of its flange): then the last frame's z axis must point up (roll 0).
pub fn tool_down_rpy_deg(model: &RobotModel) -> [f64; 3] {
    let d_last = model.params[(model.joints() - 1) * crate::kinematics::PARAMS_PER_JOINT + 1];
    if d_last + model.tool[2] < 0.0 {
        [0.0, 0.0, 0.0]
    } else {
        TOOL_DOWN_RPY_DEG
    }
}

/// The flange orientation `rpy_deg` (roll, pitch, yaw in degrees, world frame: the frame `fk`
/// reports in) as a rotation in `model`'s robot base frame, the frame its inverse kinematics
/// works in (the same rotation without a base transform).
pub fn rotation_in_base(model: &RobotModel, rpy_deg: [f64; 3]) -> ik::Rot3 {
    let r = ik::rpy_rotation(rpy_deg);
    match &model.base {
        None => r,
        Some(b) => {
            let m = b.isometry().rotation.inverse().to_rotation_matrix();
            std::array::from_fn(|i| {
                std::array::from_fn(|j| (0..3).map(|k| m[(i, k)] * r[k][j]).sum())
            })
        }
    }
}

/// Most extra inverse-kinematics seeds per cell.
pub const MAX_IK_SEEDS: usize = 1000;

/// The default reference configuration of `model` (degrees): the middle of each joint's range,
/// with the bending joints turned 30° towards their upper limits (clamped), which takes the arm
/// out of the stretched or upright zero pose most models have at mid-range, where elbow and
/// wrist branches tie. The bending joints are 2, 3 and 5 (shoulder, elbow, wrist pitch of a
/// six-joint arm, and those of them an arm of four or five joints has) and, for seven joints,
/// 2, 4 and 6 (the shoulder, elbow and wrist of an arm whose roll and pitch axes alternate,
/// such as the KUKA LBR iiwa or the Franka Panda).
pub fn default_reference_deg(model: &RobotModel) -> Joints {
    let n = model.joints();
    let bends = |i: usize| {
        if n == 7 {
            matches!(i, 1 | 3 | 5)
        } else {
            matches!(i, 1 | 2 | 4)
        }
    };
    Joints::from_fn(n, |i| {
        let (lo, hi) = model.limits_deg[i];
        let mid = 0.5 * (lo + hi);
        let turn = if bends(i) { 30.0 } else { 0.0 };
        (mid + turn).clamp(lo, hi)
    })
}

/// A cell's target.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CellTarget {
    /// Grid index: (horizontal, vertical, layer) for a plane (layer 0), (x, y, z) for a volume.
    pub index: [usize; 3],
    /// Target position in the description's (world) frame, mm.
    pub position: [f64; 3],
}

/// The configuration that reaches a cell.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CellIk {
    /// Joint angles, degrees, one per joint of the model (the test point of the evaluation).
    pub q_deg: Joints,
    /// Distance between the tool point at `q_deg` and the target, mm (≤ 1e-9).
    pub position_residual_mm: f64,
    /// Angle between the flange orientation and the target's, radians (`None` when free).
    pub orientation_residual_rad: Option<f64>,
    /// Condition number of the 3 × n position Jacobian (`None` at a position singularity).
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
    ///
    /// # Errors
    ///
    /// [`MapError::Setting`] naming the first setting out of range: a box that is not finite or has
    /// a non-positive size, a cell count of 0 or more than [`MAX_CELLS`] cells, a plane outside the
    /// box or beyond the robot's reach, an orientation that is not finite or beyond ±360°, a
    /// reference configuration outside the joint limits, or more than [`MAX_IK_SEEDS`] seeds.
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
            // The plane is in the world frame; the reach is counted from the base origin,
            // which a base transform places at its `xyz`.
            let origin = model.base.as_ref().map_or(0.0, |b| b.xyz[a]);
            if (at - origin).abs() > reach {
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

    /// Inverse kinematics for every cell: visited in serpentine order so that each cell is seeded
    /// from its solved neighbours; `None` for a cell no seed reaches.
    ///
    /// # Errors
    ///
    /// [`MapError::Setting`] when the settings are wrong ([`MapSpec::check`]) and
    /// [`MapError::NothingReachable`] when no cell is reachable.
    pub fn solve(&self, model: &RobotModel) -> Result<Vec<Option<CellIk>>, MapError> {
        self.solve_with_progress(model, None)
    }

    /// [`MapSpec::solve`], calling `progress(cells done, cells)` as the grid is visited.
    ///
    /// # Errors
    ///
    /// Those of [`MapSpec::solve`].
    pub fn solve_with_progress(
        &self,
        model: &RobotModel,
        progress: Option<&(dyn Fn(u64, u64) + Sync)>,
    ) -> Result<Vec<Option<CellIk>>, MapError> {
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
        let rotation = self.orientation_rpy_deg.map(|o| rotation_in_base(model, o));
        let in_base = |p: [f64; 3]| match &to_base {
            None => p,
            Some(t) => {
                let v = t * nalgebra::Point3::from(p);
                [v.x, v.y, v.z]
            }
        };
        let mut solved: Vec<Option<Joints>> = vec![None; targets.len()];
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
                    if let Some(p) = progress {
                        let done = (k * n[1] + jj) * n[0] + ii;
                        if done % 16 == 0 {
                            p(done as u64, targets.len() as u64);
                        }
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
                orientation_fixed: self.orientation_rpy_deg.is_some(),
            });
        }
        Ok(out)
    }

    /// The test point of a solution: degrees within the limits, with its residuals recomputed
    /// from the degrees (what the evaluation uses) and checked again.
    fn accept(&self, model: &RobotModel, ik: &Ik, target: &IkTarget, q: &[f64]) -> Option<CellIk> {
        let q_deg = Joints::from_fn(q.len(), |i| {
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
