//! Indexing of the MDH parameters ([`Layout`]): the `5n` parameters of an `n`-joint model
//! joint-major `[θ, d, a, α, β]` ([`param_index`]); the storage sized by the joint count
//! ([`Joints`], [`Params`]); and which of `d`/`β` each joint keeps fixed ([`FixedParam`]). The
//! other inputs of a draw are the [`InputSpace`](super::InputSpace)'s.

use super::inputs::MAX_INPUTS;
use serde::{Deserialize, Serialize};

/// Most joints a model may have (a seven-axis arm).
pub const MAX_JOINTS: usize = 7;
/// Fewest joints a model may have.
pub const MIN_JOINTS: usize = 4;
/// Parameters per joint: θ, d, a, α, β.
pub const PARAMS_PER_JOINT: usize = 5;
/// Most geometric parameters of a model ([`MAX_JOINTS`] joints).
pub const MAX_PARAMS: usize = MAX_JOINTS * PARAMS_PER_JOINT;

/// Joint angles of one configuration (one per joint of the model).
pub type Joints = super::Capped<f64, MAX_JOINTS>;
/// The geometric parameters of a model, joint-major `[θ, d, a, α, β]` ([`param_index`]).
pub type Params = super::Capped<f64, MAX_PARAMS>;
/// One value per input of an [`InputSpace`](super::InputSpace).
pub type Inputs = super::Capped<f64, MAX_INPUTS>;

/// The joint count of an `n`-joint model, and so where its `5n` MDH parameters lie:
/// joint-major `[θ, d, a, α, β]` ([`param_index`]). Every other input (tool, placement) and every
/// question of order, names and units is the [`InputSpace`](super::InputSpace)'s.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Layout {
    joints: usize,
}

impl Layout {
    /// The six-joint layout.
    pub const SIX: Layout = Layout { joints: 6 };

    /// The layout of an `joints`-joint model.
    ///
    /// # Panics
    ///
    /// When `joints` is not within [`MIN_JOINTS`]..=[`MAX_JOINTS`] (checked where a model is read).
    pub fn new(joints: usize) -> Layout {
        assert!(
            (MIN_JOINTS..=MAX_JOINTS).contains(&joints),
            "{joints} joints: a model has {MIN_JOINTS} to {MAX_JOINTS}"
        );
        Layout { joints }
    }

    /// Number of joints.
    pub const fn joints(self) -> usize {
        self.joints
    }

    /// Number of geometric parameters, `5n`.
    pub const fn n_params(self) -> usize {
        self.joints * PARAMS_PER_JOINT
    }

    /// The inputs of a draw in the robot's base frame: the parameters, then the tool point
    /// ([`InputSpace::robot`](super::InputSpace::robot); 33 for six joints).
    pub fn robot(self) -> super::InputSpace {
        super::InputSpace::robot(self.joints)
    }

    /// The inputs in a measurement frame: the parameters, the tool point, then the placement
    /// ([`InputSpace::measured`](super::InputSpace::measured); 39 for six joints).
    pub fn measured(self) -> super::InputSpace {
        super::InputSpace::measured(self.joints)
    }
}

/// One of the five MDH parameters of a joint.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ParamKind {
    /// Joint-angle offset θ (angle).
    Theta,
    /// Offset along the previous z axis, d (length).
    D,
    /// Common-normal length a (length).
    A,
    /// Twist α about x (angle).
    Alpha,
    /// Hayati twist β about y (angle).
    Beta,
}

impl ParamKind {
    /// All five in storage order.
    pub const ALL: [ParamKind; 5] = [Self::Theta, Self::D, Self::A, Self::Alpha, Self::Beta];
    /// The name used in files and reports.
    pub fn name(self) -> &'static str {
        match self {
            Self::Theta => "theta",
            Self::D => "d",
            Self::A => "a",
            Self::Alpha => "alpha",
            Self::Beta => "beta",
        }
    }
    /// Whether the parameter is an angle (stored in radians, written in degrees).
    pub fn is_angle(self) -> bool {
        matches!(self, Self::Theta | Self::Alpha | Self::Beta)
    }
    /// Factor from file units (mm, deg) to internal units (mm, rad).
    pub fn to_internal(self) -> f64 {
        if self.is_angle() {
            std::f64::consts::PI / 180.0
        } else {
            1.0
        }
    }
}

/// Index of parameter `kind` of joint `joint` (0-based) in the parameter vector.
pub const fn param_index(joint: usize, kind: ParamKind) -> usize {
    joint * PARAMS_PER_JOINT
        + match kind {
            ParamKind::Theta => 0,
            ParamKind::D => 1,
            ParamKind::A => 2,
            ParamKind::Alpha => 3,
            ParamKind::Beta => 4,
        }
}

/// The kind of parameter at index `i` of the parameter vector (the inverse of [`param_index`]).
pub const fn param_kind(i: usize) -> ParamKind {
    ParamKind::ALL[i % PARAMS_PER_JOINT]
}

/// The 0-based joint of parameter index `i` of the parameter vector.
pub const fn param_joint(i: usize) -> usize {
    i / PARAMS_PER_JOINT
}

/// Which of `d` and `β` a joint keeps fixed (docs/METHOD.md §1).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FixedParam {
    /// `d` fixed (this axis and the next are parallel: β is free).
    D,
    /// `β` fixed at its value (the usual case).
    #[default]
    Beta,
}

impl FixedParam {
    /// The parameter this variant holds fixed.
    pub const fn kind(self) -> ParamKind {
        match self {
            FixedParam::D => ParamKind::D,
            FixedParam::Beta => ParamKind::Beta,
        }
    }
}
