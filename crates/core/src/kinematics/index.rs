//! Indexing of a draw's inputs ([`Layout`]): the `5n` MDH parameters of an `n`-joint model
//! joint-major `[θ, d, a, α, β]` ([`param_index`]), then the tool point's x, y, z; the storage
//! sized by the joint count ([`Joints`], [`Params`]); and which of `d`/`β` each joint keeps
//! fixed ([`FixedParam`]).

use serde::{Deserialize, Serialize};

/// Most joints a model may have (a seven-axis arm).
pub const MAX_JOINTS: usize = 7;
/// Fewest joints a model may have.
pub const MIN_JOINTS: usize = 4;
/// Parameters per joint: θ, d, a, α, β.
pub const PARAMS_PER_JOINT: usize = 5;
/// Coordinates of the tool point (x, y, z in the flange frame).
pub const TOOL_COORDS: usize = 3;
/// Coordinates of the placement (base x, y, z in mm; roll, pitch, yaw).
pub const BASE_COORDS: usize = 6;
/// Most geometric parameters of a model ([`MAX_JOINTS`] joints).
pub const MAX_PARAMS: usize = MAX_JOINTS * PARAMS_PER_JOINT;
/// Most uncertain inputs of a draw (parameters and tool point).
pub const MAX_UNCERTAIN: usize = MAX_PARAMS + TOOL_COORDS;
/// Most inputs with the placement.
pub const MAX_WITH_BASE: usize = MAX_UNCERTAIN + BASE_COORDS;

/// Joint angles of one configuration (one per joint of the model).
pub type Joints = super::Capped<f64, MAX_JOINTS>;
/// The geometric parameters of a model, joint-major `[θ, d, a, α, β]` ([`param_index`]).
pub type Params = super::Capped<f64, MAX_PARAMS>;
/// One value per uncertain input (parameters, then the tool point; [`Layout::n_uncertain`]).
pub type Inputs = super::Capped<f64, MAX_WITH_BASE>;

/// How the inputs of a draw of an `n`-joint model are laid out: the `5n` MDH parameters
/// joint-major `[θ, d, a, α, β]` ([`param_index`]), then the tool point's x, y, z
/// ([`Layout::tool_index`]), then, where a covariance includes it, the placement's x, y, z, roll,
/// pitch, yaw ([`Layout::base_index`]). A six-joint model has 30 parameters, 33 uncertain inputs
/// and 39 with the placement.
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

    /// Number of uncertain inputs of a draw: the parameters, then the tool point. Offset
    /// vectors, offset-matrix rows and a full covariance have this length (docs/METHOD.md §14).
    pub const fn n_uncertain(self) -> usize {
        self.n_params() + TOOL_COORDS
    }

    /// Rows of a covariance that includes the placement ([`Self::base_index`]; docs/METHOD.md
    /// §2.7).
    pub const fn n_with_base(self) -> usize {
        self.n_uncertain() + BASE_COORDS
    }

    /// Index of tool coordinate `k` (0 = x, 1 = y, 2 = z) among the inputs.
    pub const fn tool_index(self, k: usize) -> usize {
        self.n_params() + k
    }

    /// Index of placement coordinate `k` (0–2 x, y, z; 3–5 roll, pitch, yaw) in a covariance
    /// of [`Self::n_with_base`] rows.
    pub const fn base_index(self, k: usize) -> usize {
        self.n_uncertain() + k
    }

    /// The name of input `i` as reports spell it: `theta2`, `d1`, … (1-based joint),
    /// `tool_x`, `tool_y`, `tool_z`, or `base_x` … `base_yaw`.
    pub fn input_name(self, i: usize) -> String {
        if i >= self.n_uncertain() {
            format!(
                "base_{}",
                ["x", "y", "z", "roll", "pitch", "yaw"][i - self.n_uncertain()]
            )
        } else if i >= self.n_params() {
            format!("tool_{}", ["x", "y", "z"][i - self.n_params()])
        } else {
            format!("{}{}", param_kind(i).name(), param_joint(i) + 1)
        }
    }

    /// Factor from file units to internal units of input `i` (degrees → radians for the
    /// angles; 1 for lengths and the tool coordinates).
    pub fn input_to_internal(self, i: usize) -> f64 {
        if i >= self.n_uncertain() + 3 {
            std::f64::consts::PI / 180.0
        } else if i >= self.n_params() {
            1.0
        } else {
            param_kind(i).to_internal()
        }
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
