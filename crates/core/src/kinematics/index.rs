//! Indexing of a draw's inputs: the 30 MDH parameters joint-major `[θ, d, a, α, β]`
//! ([`param_index`]), then the tool point's x, y, z ([`tool_index`]); and which of `d`/`β`
//! each joint keeps fixed ([`FixedParam`]).

use serde::{Deserialize, Serialize};

/// Number of joints of the arm.
pub const JOINTS: usize = 6;
/// Parameters per joint: θ, d, a, α, β.
pub const PARAMS_PER_JOINT: usize = 5;
/// Total number of geometric parameters.
pub const N_PARAMS: usize = JOINTS * PARAMS_PER_JOINT;
/// Coordinates of the tool point (x, y, z in the flange frame).
pub const TOOL_COORDS: usize = 3;
/// Number of uncertain inputs of a draw: the [`N_PARAMS`] parameters, then the tool point's x,
/// y, z ([`tool_index`]). Offset vectors, offset-matrix rows and a full covariance have this
/// length (docs/METHOD.md §14).
pub const N_UNCERTAIN: usize = N_PARAMS + TOOL_COORDS;

/// Coordinates of the placement (base x, y, z in mm; roll, pitch, yaw).
pub const BASE_COORDS: usize = 6;
/// Rows of a covariance that includes the placement: the [`N_UNCERTAIN`] inputs, then the
/// base's x, y, z (mm) and roll, pitch, yaw in the `base` field's convention
/// ([`base_index`]; docs/METHOD.md §2.7).
pub const N_WITH_BASE: usize = N_UNCERTAIN + BASE_COORDS;

/// Index of placement coordinate `k` (0–2 x, y, z; 3–5 roll, pitch, yaw) in a covariance of
/// [`N_WITH_BASE`] rows.
pub const fn base_index(k: usize) -> usize {
    N_UNCERTAIN + k
}

/// Index of tool coordinate `k` (0 = x, 1 = y, 2 = z) among the [`N_UNCERTAIN`] inputs.
pub const fn tool_index(k: usize) -> usize {
    N_PARAMS + k
}

/// The name of input `i` of the [`N_UNCERTAIN`] inputs as reports spell it: `theta2`, `d1`, …
/// (1-based joint), or `tool_x`, `tool_y`, `tool_z`.
pub fn input_name(i: usize) -> String {
    if i >= N_UNCERTAIN {
        format!(
            "base_{}",
            ["x", "y", "z", "roll", "pitch", "yaw"][i - N_UNCERTAIN]
        )
    } else if i >= N_PARAMS {
        format!("tool_{}", ["x", "y", "z"][i - N_PARAMS])
    } else {
        format!("{}{}", param_kind(i).name(), param_joint(i) + 1)
    }
}

/// Factor from file units to internal units of input `i` (degrees → radians for the angles;
/// 1 for lengths and the tool coordinates).
pub fn input_to_internal(i: usize) -> f64 {
    if i >= N_UNCERTAIN + 3 {
        std::f64::consts::PI / 180.0
    } else if i >= N_PARAMS {
        1.0
    } else {
        param_kind(i).to_internal()
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

/// Index of parameter `kind` of joint `joint` (0-based) in the 30-vector.
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

/// The kind of parameter at index `i` of the 30-vector (the inverse of [`param_index`]).
pub const fn param_kind(i: usize) -> ParamKind {
    ParamKind::ALL[i % PARAMS_PER_JOINT]
}

/// The 0-based joint of parameter index `i` of the 30-vector.
pub const fn param_joint(i: usize) -> usize {
    i / PARAMS_PER_JOINT
}

/// Which of `d` and `β` a joint keeps fixed (docs/METHOD.md §1).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FixedParam {
    /// `d` fixed (this axis and the next are parallel: β is free).
    D,
    /// `β` fixed at its value (the usual case).
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
