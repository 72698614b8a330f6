//! Robot kinematics: the Hayati-extended (modified) DH chain of docs/METHOD.md §1.
//!
//! Each joint contributes five geometric parameters,
//! `T_i(q_i) = Rz(θ_i + q_i) · Tz(d_i) · Tx(a_i) · Rx(α_i) · Ry(β_i)`,
//! and the tracker target (tool point) `p_tool` sits in the flange frame, so the end position is
//! `P(q) = T_1(q_1) · … · T_n(q_n) · p_tool` (paper eqs. 1–2, Hayati's extension for parallel
//! axes), for a serial arm of `n` = 4 to 7 revolute joints (the paper's is the six-joint TX60).
//! For a pair of parallel (or nearly parallel) consecutive axes `d_i` is fixed and `β_i` is free;
//! otherwise `β_i` is fixed at 0.
//!
//! Units: every value a person reads or writes is in millimetres and degrees; inside the crate
//! angles are radians. The `5n` parameters are stored joint-major, `[θ, d, a, α, β]` per joint
//! ([`param_index`]); the [`InputSpace`] says where the tool point and the placement follow them
//! and is the one home of every input's order, name, unit and normal slot.
//!
//! The built-in TX60 is [`tx60`]; the other presets, converted from published tables by the
//! importer, are in [`crate::presets`]. This module uses nothing else of the crate but
//! `crate::input` (reading a model file).

mod capped;
mod check;
mod file;
mod file_discrepancy;
mod file_joint_errors;
mod file_links;
mod fk;
pub mod gravity;
mod index;
mod inputs;
pub mod joint_errors;
pub mod lines;
pub mod mdh;
mod model;
#[cfg(test)]
mod tests;
mod tx60;

pub use capped::Capped;
pub use check::{
    InvalidField, MAX_ANGLE_DEG, MAX_LENGTH_MM, MAX_LIMIT_DEG, MAX_SIGMA_DEG, MAX_SIGMA_MM,
};
pub use file::ModelError;
pub use fk::{
    joint_transform, position, position_deg, position_with_trig, transform, twist_trig, Mat4,
    TwistTrig,
};
pub use index::{
    param_index, param_joint, param_kind, FixedParam, Inputs, Joints, Layout, ParamKind, Params,
    MAX_JOINTS, MAX_PARAMS, MIN_JOINTS, PARAMS_PER_JOINT,
};
pub use inputs::{
    Action, Block, InputSpace, InputSpaceError, Quantity, MAX_INPUTS, MAX_ROBOT_INPUTS,
};
pub use joint_errors::{Backlash, JointErrors, Payload};
pub use model::{rpy_of, BaseTransform, Covariance, FixedParams, Limits, RobotModel, Uncertainty};
pub use tx60::tx60;
