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

//!
//! One concept per file: `grid` (what a map asks for: the grid, its targets and their inverse
//! kinematics), `evaluate` (the per-cell and multi-point statistics over the draws), `result`
//! (the finished map), [`ik`] (the solver) and [`shard`] (a map split over processes).

mod evaluate;
mod grid;
pub mod ik;
mod result;
pub mod shard;

pub use evaluate::{
    batch_size, check_run, evaluate, evaluate_cells, memory_estimate, memory_estimate_with_reports,
    report_bytes_per_cell, statistics, CellErrors, CellStats, Evaluation, ReportKinds,
    BYTES_PER_CELL,
};
pub use grid::{
    default_reference_deg, rotation_in_base, tool_down_rpy_deg, CellIk, CellTarget, Grid, MapSpec,
    Plane, MAX_IK_SEEDS, TOOL_DOWN_RPY_DEG,
};
pub use result::{round_trip_error, test_points, MapCell, MapResult, Timings};

use crate::engine::{EngineError, ProblemError};

/// Most cells a map may have (a 500 × 500 plane): every cell costs an inverse-kinematics solve
/// and `draws × 8` bytes of kept errors.
pub const MAX_CELLS: usize = 250_000;

/// The settings a map checks, named in its errors ([`MapError::Setting`]); a front end maps
/// each to its own option name.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MapSetting {
    /// The cell counts.
    Cells,
    /// The plane of a slice.
    Plane,
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
            MapSetting::Plane => "plane",
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
    #[error("none of the {cells} cells is reachable with the {task}: move or shrink the grid{}", if *.orientation_fixed { ", or free the orientation" } else { " into the arm's reach" })]
    NothingReachable {
        /// Cells tried.
        cells: usize,
        /// "tool orientation (r, p, y)°" or "position only".
        task: String,
        /// Whether the flange orientation was prescribed (freeing it could help).
        orientation_fixed: bool,
    },
    /// The reached configurations do not make a problem (the model's own checks).
    #[error(transparent)]
    Problem(#[from] ProblemError),
    /// The evaluator failed.
    #[error(transparent)]
    Engine(#[from] EngineError),
}

pub(super) fn setting(field: MapSetting, message: impl Into<String>) -> MapError {
    MapError::Setting {
        field,
        message: message.into(),
    }
}
