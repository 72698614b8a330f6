//! The robot model: 30 MDH parameters, which of `d`/`β` is fixed per joint, joint limits, the
//! tool point and the parameter uncertainty, with its hand-writable TOML file format.
//!
//! The file is in millimetres and degrees (see the README, "Model file"). Every field is checked
//! when read; a bad one gives a [`ModelError`] naming the joint and field.

use serde::{Deserialize, Serialize};
use std::fmt::Write as _;

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

/// Index of tool coordinate `k` (0 = x, 1 = y, 2 = z) among the [`N_UNCERTAIN`] inputs.
pub const fn tool_index(k: usize) -> usize {
    N_PARAMS + k
}

/// The name of input `i` of the [`N_UNCERTAIN`] inputs as reports spell it: `theta2`, `d1`, …
/// (1-based joint), or `tool_x`, `tool_y`, `tool_z`.
pub fn input_name(i: usize) -> String {
    if i >= N_PARAMS {
        format!("tool_{}", ["x", "y", "z"][i - N_PARAMS])
    } else {
        format!("{}{}", param_kind(i).name(), param_joint(i) + 1)
    }
}

/// Factor from file units to internal units of input `i` (degrees → radians for the angles;
/// 1 for lengths and the tool coordinates).
pub fn input_to_internal(i: usize) -> f64 {
    if i >= N_PARAMS {
        1.0
    } else {
        param_kind(i).to_internal()
    }
}

/// The field of input `i` as the model file spells its spread: `joint[2].sigma.d` or
/// `tool_sigma[1]` (0-based coordinate, as TOML arrays are read).
fn input_sigma_field(i: usize) -> String {
    if i >= N_PARAMS {
        format!("tool_sigma[{}]", i - N_PARAMS)
    } else {
        format!(
            "{}.sigma.{}",
            joint_field(param_joint(i)),
            param_kind(i).name()
        )
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

/// Spread of the parameters about their values (internal units: mm, rad). The tool point's
/// spread is [`RobotModel::tool_sigma`], except with a 33 × 33 covariance, which covers it.
#[derive(Clone, Debug, PartialEq)]
#[allow(clippy::large_enum_variant)] // one per model; boxing buys nothing
pub enum Uncertainty {
    /// Independent normals with these standard deviations (0 = exactly known).
    Independent([f64; N_PARAMS]),
    /// Full covariance, row-major, either 30 × 30 (the parameters; the tool's spread is then
    /// [`RobotModel::tool_sigma`], independent of them) or 33 × 33 ([`N_UNCERTAIN`]: the
    /// parameters, then the tool's x, y, z in mm).
    Covariance(Vec<f64>),
}

impl Uncertainty {
    /// Rows of the covariance: [`N_UNCERTAIN`] for a 33 × 33 matrix, else [`N_PARAMS`] (also
    /// for independent σ).
    pub fn dim(&self) -> usize {
        match self {
            Self::Covariance(c) if c.len() == N_UNCERTAIN * N_UNCERTAIN => N_UNCERTAIN,
            _ => N_PARAMS,
        }
    }

    /// Covariance entry `(i, k)` of the parameters (`i, k <` [`Self::dim`]); for independent σ
    /// the diagonal `σ_i²`.
    pub fn entry(&self, i: usize, k: usize) -> f64 {
        match self {
            Self::Independent(s) => {
                if i == k {
                    s[i] * s[i]
                } else {
                    0.0
                }
            }
            Self::Covariance(c) => c[i * self.dim() + k],
        }
    }

    /// Standard deviation of each parameter (the covariance's diagonal, square-rooted).
    pub fn sigmas(&self) -> [f64; N_PARAMS] {
        match self {
            Self::Independent(s) => *s,
            Self::Covariance(_) => std::array::from_fn(|i| self.entry(i, i).max(0.0).sqrt()),
        }
    }
}

/// A rigid placement of the model's base frame in the frame a description uses (a cell or
/// world frame): `p_world = Trans(xyz) · Rz(yaw) · Ry(pitch) · Rx(roll) · p_base`, as a URDF
/// `<origin>`. It lets a robot whose first axis is not the base +z axis (ROS-Industrial's KUKA KR 6
/// has joint A1 about −z) keep its own frame. Positions and errors are invariant to it: `w` and
/// every `e_j` compare two positions moved by the same rigid transform, so the evaluators ignore
/// it; forward kinematics (`fk`), import and export apply it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BaseTransform {
    /// Translation, mm.
    pub xyz: [f64; 3],
    /// Roll, pitch, yaw, radians (the file writes degrees).
    pub rpy: [f64; 3],
}

impl BaseTransform {
    /// The transform as an isometry (mm).
    pub fn isometry(&self) -> nalgebra::Isometry3<f64> {
        nalgebra::Isometry3::from_parts(
            nalgebra::Translation3::new(self.xyz[0], self.xyz[1], self.xyz[2]),
            nalgebra::UnitQuaternion::from_euler_angles(self.rpy[0], self.rpy[1], self.rpy[2]),
        )
    }

    /// `p` (base frame, mm) in the outer frame.
    pub fn apply(&self, p: [f64; 3]) -> [f64; 3] {
        let v = self.isometry() * nalgebra::Point3::from(p);
        [v.x, v.y, v.z]
    }
}

/// A robot model: parameter values (the calibrated means), structure, limits, tool and spread.
#[derive(Clone, Debug, PartialEq)]
pub struct RobotModel {
    /// Name shown in reports.
    pub name: String,
    /// The 30 parameters, joint-major `[θ, d, a, α, β]`, mm and radians.
    pub params: [f64; N_PARAMS],
    /// Per joint, which of d / β is fixed.
    pub fixed: [FixedParam; JOINTS],
    /// Joint limits in degrees, `(min, max)`.
    pub limits_deg: [(f64, f64); JOINTS],
    /// Tracker target in the flange frame, mm.
    pub tool: [f64; 3],
    /// Standard deviation of the tool point's coordinates in the flange frame, mm (0 = exactly
    /// known), independent of the parameters. With a 33 × 33 covariance it equals the square
    /// roots of the covariance's last three diagonal entries ([`RobotModel::check`] says so).
    pub tool_sigma: [f64; 3],
    /// Parameter uncertainty.
    pub uncertainty: Uncertainty,
    /// Placement of the base frame in the description's frame; `None` = identity.
    pub base: Option<BaseTransform>,
}

/// Largest magnitude of a length in a model (`d`, `a`, the tool's coordinates), mm: 100 m, far
/// beyond any arm; a larger value is a unit mistake (see the README, "Model file").
pub const MAX_LENGTH_MM: f64 = 1e5;
/// Largest magnitude of an angle parameter (`theta`, `alpha`, `beta`), degrees.
pub const MAX_ANGLE_DEG: f64 = 360.0;
/// Largest magnitude of a joint limit, degrees: two turns, room for multi-turn wrist joints.
pub const MAX_LIMIT_DEG: f64 = 720.0;
/// Largest standard deviation of a length, mm. Calibration spreads are micrometres; a tenth of
/// the arm's reach is a unit mistake, not an uncertainty.
pub const MAX_SIGMA_MM: f64 = 100.0;
/// Largest standard deviation of an angle, degrees. The normal model of an angle only makes
/// sense while the draws stay well inside one turn (a spread of 1e6° is a uniform angle, not a
/// calibration result), and the GPU's deviation form evaluates `sin`/`cos` of half the offset by
/// its series for |δ/2| ≤ 45°: draws reach at most 6.8 σ (the Box–Muller bound for 32-bit
/// uniforms), so σ ≤ 10° keeps every independent offset under 68° (docs/METHOD.md §7).
pub const MAX_SIGMA_DEG: f64 = 10.0;

/// A model field that is out of range: the TOML field path (`joint[3].sigma.d`, 1-based joint)
/// and what is wrong, in file units (mm, degrees).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{field}: {message}")]
pub struct InvalidField {
    /// The field, e.g. `joint[2].sigma.d` or `covariance.matrix[3][1]`.
    pub field: String,
    /// What is wrong.
    pub message: String,
}

/// Errors reading or checking a model.
#[derive(Debug, thiserror::Error)]
pub enum ModelError {
    /// The model file could not be read, is too large or is not UTF-8.
    #[error(transparent)]
    Read(#[from] crate::input::ReadError),
    /// The TOML is malformed or has unknown or missing keys (the message names line and key).
    #[error("model file {path}: {message}")]
    Syntax {
        /// The path given.
        path: String,
        /// The parser's message, with line and column.
        message: String,
    },
    /// A value is out of range; the message names the joint and field.
    #[error("model file {path}: {field}: {message}")]
    Invalid {
        /// The path given.
        path: String,
        /// The field, e.g. `joint[2].sigma.d`.
        field: String,
        /// What is wrong.
        message: String,
    },
    /// Unknown preset name.
    #[error("unknown preset '{0}' (known: {known})", known = super::PRESETS.join(", "))]
    UnknownPreset(String),
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct SigmaFile {
    theta: f64,
    d: f64,
    a: f64,
    alpha: f64,
    beta: f64,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct JointFile {
    theta: f64,
    d: f64,
    a: f64,
    alpha: f64,
    beta: f64,
    fixed: FixedParam,
    limits: Vec<f64>,
    sigma: SigmaFile,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct CovarianceFile {
    matrix: Vec<Vec<f64>>,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct BaseFile {
    xyz: Vec<f64>,
    rpy: Vec<f64>,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ModelFile {
    name: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    base: Option<BaseFile>,
    tool: Vec<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    tool_sigma: Option<Vec<f64>>,
    joint: Vec<JointFile>,
    #[serde(skip_serializing_if = "Option::is_none")]
    covariance: Option<CovarianceFile>,
}

impl RobotModel {
    /// Reads and checks a model file (at most [`crate::input::MODEL_FILE_LIMIT`] bytes).
    pub fn from_file(path: &std::path::Path) -> Result<Self, ModelError> {
        let text = crate::input::read_text(path, crate::input::MODEL_FILE_LIMIT, "model file")?;
        Self::from_toml(&text, &path.display().to_string())
    }

    /// Parses and checks a model from TOML text; `origin` names the source in errors.
    pub fn from_toml(text: &str, origin: &str) -> Result<Self, ModelError> {
        let file: ModelFile = toml::from_str(text).map_err(|e| ModelError::Syntax {
            path: origin.to_string(),
            message: toml_error_line(text, &e),
        })?;
        let invalid = |e: InvalidField| ModelError::Invalid {
            path: origin.to_string(),
            field: e.field,
            message: e.message,
        };
        let bad = |field: &str, message: String| {
            invalid(InvalidField {
                field: field.into(),
                message,
            })
        };
        if file.joint.len() != JOINTS {
            return Err(bad(
                "joint",
                format!(
                    "expected {JOINTS} [[joint]] tables, found {}",
                    file.joint.len()
                ),
            ));
        }
        let tool: [f64; 3] = file.tool.as_slice().try_into().map_err(|_| {
            bad(
                "tool",
                format!(
                    "must be exactly 3 numbers [x, y, z] (mm), found {}",
                    file.tool.len()
                ),
            )
        })?;
        let tool_sigma_file: Option<[f64; 3]> = match &file.tool_sigma {
            None => None,
            Some(v) => Some(v.as_slice().try_into().map_err(|_| {
                bad(
                    "tool_sigma",
                    format!(
                        "must be exactly 3 numbers [sx, sy, sz] (mm), found {}",
                        v.len()
                    ),
                )
            })?),
        };
        let base = match &file.base {
            None => None,
            Some(b) => {
                let three = |v: &[f64], field: &str, unit: &str| -> Result<[f64; 3], ModelError> {
                    v.try_into().map_err(|_| {
                        bad(
                            field,
                            format!("must be exactly 3 numbers ({unit}), found {}", v.len()),
                        )
                    })
                };
                let xyz = three(&b.xyz, "base.xyz", "mm")?;
                let rpy = three(&b.rpy, "base.rpy", "roll, pitch, yaw in deg")?;
                Some(BaseTransform {
                    xyz,
                    rpy: rpy.map(f64::to_radians),
                })
            }
        };
        let mut params = [0.0; N_PARAMS];
        let mut sigma = [0.0; N_PARAMS];
        let mut fixed = [FixedParam::Beta; JOINTS];
        let mut limits = [(0.0, 0.0); JOINTS];
        for (j, jf) in file.joint.iter().enumerate() {
            let vals = [jf.theta, jf.d, jf.a, jf.alpha, jf.beta];
            let s = &jf.sigma;
            let sig = [s.theta, s.d, s.a, s.alpha, s.beta];
            for (k, kind) in ParamKind::ALL.iter().enumerate() {
                params[param_index(j, *kind)] = vals[k] * kind.to_internal();
                sigma[param_index(j, *kind)] = sig[k] * kind.to_internal();
            }
            fixed[j] = jf.fixed;
            limits[j] = match jf.limits[..] {
                [lo, hi] => (lo, hi),
                _ => {
                    return Err(bad(
                        &format!("{}.limits", joint_field(j)),
                        format!(
                            "must be exactly 2 numbers [min, max] (deg), found {}",
                            jf.limits.len()
                        ),
                    ))
                }
            };
        }
        let uncertainty = match &file.covariance {
            None => Uncertainty::Independent(sigma),
            Some(c) => {
                // The `sigma` tables are checked on their own: the model keeps only the matrix.
                check_sigmas(&sigma, &fixed).map_err(invalid)?;
                Uncertainty::Covariance(covariance_from_file(&c.matrix).map_err(invalid)?)
            }
        };
        if let Some(ts) = tool_sigma_file {
            check_tool_sigma(&ts).map_err(invalid)?;
        }
        let mut model = RobotModel {
            name: file.name,
            params,
            fixed,
            limits_deg: limits,
            tool,
            tool_sigma: tool_sigma_file.unwrap_or([0.0; 3]),
            uncertainty,
            base,
        };
        // A 33 × 33 covariance carries the tool's spread; `tool_sigma`, when given, must repeat
        // its diagonal.
        let full = model.uncertainty.dim() == N_UNCERTAIN;
        if full {
            model.tool_sigma = std::array::from_fn(|k| {
                let i = tool_index(k);
                model.uncertainty.entry(i, i).max(0.0).sqrt()
            });
        }
        model.check().map_err(invalid)?;
        // The per-joint sigma (and tool_sigma) must agree with the covariance diagonal so a reader
        // of the file is not misled.
        if let Uncertainty::Covariance(_) = &model.uncertainty {
            let diag = model.input_sigmas();
            let given: [f64; N_UNCERTAIN] = std::array::from_fn(|i| {
                if i < N_PARAMS {
                    sigma[i]
                } else {
                    tool_sigma_file.map_or(diag[i], |t| t[i - N_PARAMS])
                }
            });
            let n = if full { N_UNCERTAIN } else { N_PARAMS };
            for i in 0..n {
                if (diag[i] - given[i]).abs() > 1e-6 * diag[i].max(given[i]).max(1e-300) {
                    let f = input_to_internal(i);
                    return Err(bad(
                        &input_sigma_field(i),
                        format!(
                            "differs from sqrt of covariance diagonal ({} vs {})",
                            given[i] / f,
                            diag[i] / f
                        ),
                    ));
                }
            }
        }
        Ok(model)
    }

    /// Checks every value against the model file's rules (README, "Model file"): finite
    /// parameters, lengths within ±[`MAX_LENGTH_MM`], angles within ±[`MAX_ANGLE_DEG`], limits
    /// `min < max` within ±[`MAX_LIMIT_DEG`], standard deviations ≥ 0 and at most
    /// [`MAX_SIGMA_MM`] / [`MAX_SIGMA_DEG`], zero spread on each joint's fixed parameter, and a
    /// covariance that is symmetric and positive definite on the parameters with nonzero
    /// variance. The error names the field as the file spells it.
    pub fn check(&self) -> Result<(), InvalidField> {
        for (k, &v) in self.tool.iter().enumerate() {
            check_magnitude(&format!("tool[{k}]"), v, MAX_LENGTH_MM, "mm")?;
        }
        check_tool_sigma(&self.tool_sigma)?;
        if let Some(b) = &self.base {
            for k in 0..3 {
                check_magnitude(&format!("base.xyz[{k}]"), b.xyz[k], MAX_LENGTH_MM, "mm")?;
                let deg = b.rpy[k].to_degrees();
                check_magnitude(&format!("base.rpy[{k}]"), deg, MAX_ANGLE_DEG, "deg")?;
            }
        }
        for j in 0..JOINTS {
            for kind in ParamKind::ALL {
                let v = self.params[param_index(j, kind)] / kind.to_internal();
                let (max, unit) = if kind.is_angle() {
                    (MAX_ANGLE_DEG, "deg")
                } else {
                    (MAX_LENGTH_MM, "mm")
                };
                check_magnitude(&format!("{}.{}", joint_field(j), kind.name()), v, max, unit)?;
            }
            let (lo, hi) = self.limits_deg[j];
            let field = format!("{}.limits", joint_field(j));
            if !(lo.is_finite() && hi.is_finite() && lo < hi) {
                return Err(InvalidField {
                    field,
                    message: format!("must be [min, max] with min < max (deg), got [{lo}, {hi}]"),
                });
            }
            check_magnitude(&field, lo, MAX_LIMIT_DEG, "deg")?;
            check_magnitude(&field, hi, MAX_LIMIT_DEG, "deg")?;
        }
        match &self.uncertainty {
            Uncertainty::Independent(s) => check_sigmas(s, &self.fixed),
            Uncertainty::Covariance(c) => {
                check_covariance(c, &self.fixed)?;
                check_sigmas(&self.uncertainty.sigmas(), &self.fixed)?;
                let n = self.uncertainty.dim();
                if n == N_UNCERTAIN {
                    let diag: [f64; 3] = std::array::from_fn(|k| {
                        let i = tool_index(k);
                        self.uncertainty.entry(i, i).sqrt()
                    });
                    check_tool_sigma(&diag)?;
                    for k in 0..TOOL_COORDS {
                        let d = diag[k];
                        let t = self.tool_sigma[k];
                        if (d - t).abs() > 1e-6 * d.max(t).max(1e-300) {
                            return Err(InvalidField {
                                field: format!("tool_sigma[{k}]"),
                                message: format!(
                                    "differs from sqrt of covariance diagonal ({t} vs {d})"
                                ),
                            });
                        }
                    }
                }
                let free: Vec<usize> = self.free_inputs().into_iter().filter(|&i| i < n).collect();
                check_positive_definite(c, n, &free)
            }
        }
    }

    /// Tool-point position (mm) at joint angles `q` (radians) in the description's frame: the
    /// MDH chain's [`super::position`], then the [`RobotModel::base`] transform.
    pub fn world_position(&self, q: &[f64; JOINTS]) -> [f64; 3] {
        let p = super::position(&self.params, &self.tool, q);
        match &self.base {
            None => p,
            Some(b) => b.apply(p),
        }
    }

    /// The tool point's standard deviations, mm ([`RobotModel::tool_sigma`]).
    pub fn tool_sigmas(&self) -> [f64; 3] {
        self.tool_sigma
    }

    /// Whether the tool point is uncertain (some tool σ > 0).
    pub fn tool_uncertain(&self) -> bool {
        self.tool_sigma.iter().any(|&s| s > 0.0)
    }

    /// Standard deviations of all [`N_UNCERTAIN`] inputs: the 30 parameters, then the tool.
    pub fn input_sigmas(&self) -> [f64; N_UNCERTAIN] {
        let p = self.uncertainty.sigmas();
        std::array::from_fn(|i| {
            if i < N_PARAMS {
                p[i]
            } else {
                self.tool_sigma[i - N_PARAMS]
            }
        })
    }

    /// Indices (of the [`N_UNCERTAIN`] inputs) with nonzero spread: [`Self::free_params`],
    /// then the uncertain tool coordinates.
    pub fn free_inputs(&self) -> Vec<usize> {
        let s = self.input_sigmas();
        (0..N_UNCERTAIN).filter(|&i| s[i] > 0.0).collect()
    }

    /// The covariance of all [`N_UNCERTAIN`] inputs, row-major 33 × 33, for a correlated model
    /// (a 30 × 30 matrix is extended by the independent tool variances `tool_sigma²`); `None`
    /// for independent σ.
    pub fn full_covariance(&self) -> Option<Vec<f64>> {
        match &self.uncertainty {
            Uncertainty::Independent(_) => None,
            Uncertainty::Covariance(_) => {
                let n = self.uncertainty.dim();
                let mut c = vec![0.0; N_UNCERTAIN * N_UNCERTAIN];
                for i in 0..N_UNCERTAIN {
                    for k in 0..N_UNCERTAIN {
                        c[i * N_UNCERTAIN + k] = if i < n && k < n {
                            self.uncertainty.entry(i, k)
                        } else if i == k {
                            self.tool_sigma[i - N_PARAMS].powi(2)
                        } else {
                            0.0
                        };
                    }
                }
                Some(c)
            }
        }
    }

    /// Writes the model as TOML (mm, degrees) with explanatory comments.
    pub fn to_toml(&self) -> String {
        let sig = self.uncertainty.sigmas();
        let mut s = String::new();
        let _ = writeln!(
            s,
            "# gpu-amcs robot model: MDH (Hayati) parameters, mm and degrees."
        );
        let _ = writeln!(
            s,
            "# T_i = Rz(theta_i + q_i) Tz(d_i) Tx(a_i) Rx(alpha_i) Ry(beta_i)."
        );
        let _ = writeln!(
            s,
            "# fixed: which of d / beta is held fixed for the joint; its sigma must be 0."
        );
        let _ = writeln!(
            s,
            "# sigma: standard deviation of each parameter (0 = exactly known)."
        );
        let _ = writeln!(s, "name = {}", toml_string(&self.name));
        if let Some(b) = &self.base {
            let _ = writeln!(
                s,
                "# base frame in the description's frame: Trans(xyz, mm) Rz(yaw) Ry(pitch) Rx(roll), deg"
            );
            let r = b.rpy.map(f64::to_degrees);
            let _ = writeln!(
                s,
                "base = {{ xyz = [{}, {}, {}], rpy = [{}, {}, {}] }}",
                fnum(b.xyz[0]),
                fnum(b.xyz[1]),
                fnum(b.xyz[2]),
                fnum(r[0]),
                fnum(r[1]),
                fnum(r[2])
            );
        }
        let _ = writeln!(s, "# tracker target in the flange frame, mm");
        let _ = writeln!(
            s,
            "tool = [{}, {}, {}]",
            fnum(self.tool[0]),
            fnum(self.tool[1]),
            fnum(self.tool[2])
        );
        if self.tool_uncertain() {
            let _ = writeln!(
                s,
                "# standard deviation of the tracker target's coordinates in the flange frame, mm"
            );
            let _ = writeln!(
                s,
                "tool_sigma = [{}, {}, {}]",
                fnum(self.tool_sigma[0]),
                fnum(self.tool_sigma[1]),
                fnum(self.tool_sigma[2])
            );
        }
        for j in 0..JOINTS {
            let v = |k: ParamKind| self.params[param_index(j, k)] / k.to_internal();
            let sv = |k: ParamKind| sig[param_index(j, k)] / k.to_internal();
            let _ = writeln!(s, "\n[[joint]] # J{}", j + 1);
            for k in ParamKind::ALL {
                let _ = writeln!(s, "{} = {}", k.name(), fnum(v(k)));
            }
            let fixed = self.fixed[j].kind().name();
            let _ = writeln!(s, "fixed = \"{fixed}\"");
            let (lo, hi) = self.limits_deg[j];
            let _ = writeln!(s, "limits = [{}, {}]", fnum(lo), fnum(hi));
            let _ = writeln!(
                s,
                "sigma = {{ theta = {}, d = {}, a = {}, alpha = {}, beta = {} }}",
                fnum(sv(ParamKind::Theta)),
                fnum(sv(ParamKind::D)),
                fnum(sv(ParamKind::A)),
                fnum(sv(ParamKind::Alpha)),
                fnum(sv(ParamKind::Beta))
            );
        }
        if let Uncertainty::Covariance(c) = &self.uncertainty {
            let n = self.uncertainty.dim();
            let _ = writeln!(
                s,
                "\n# Full covariance of the 30 parameters, joint-major [theta, d, a, alpha, beta],"
            );
            if n == N_UNCERTAIN {
                let _ = writeln!(s, "# then the tool's x, y, z,");
            }
            let _ = writeln!(s, "# in file units (mm, deg and their products).");
            let _ = writeln!(s, "[covariance]\nmatrix = [");
            for i in 0..n {
                let row: Vec<String> = (0..n)
                    .map(|k| {
                        let f = input_to_internal(i) * input_to_internal(k);
                        fnum(c[i * n + k] / f)
                    })
                    .collect();
                let _ = writeln!(s, "  [{}],", row.join(", "));
            }
            let _ = writeln!(s, "]");
        }
        s
    }

    /// Indices of the parameters with nonzero spread.
    pub fn free_params(&self) -> Vec<usize> {
        let s = self.uncertainty.sigmas();
        (0..N_PARAMS).filter(|&i| s[i] > 0.0).collect()
    }

    /// Checks a joint configuration (degrees) against the limits; names the joint if outside.
    pub fn check_limits(&self, q_deg: &[f64; JOINTS]) -> Result<(), String> {
        for (j, (&q, &(lo, hi))) in q_deg.iter().zip(&self.limits_deg).enumerate() {
            if !q.is_finite() {
                return Err(format!("q{} = {q} is not a finite number", j + 1));
            }
            if q < lo || q > hi {
                return Err(format!(
                    "q{} = {q} deg is outside the joint limits [{lo}, {hi}]",
                    j + 1
                ));
            }
        }
        Ok(())
    }
}

/// The parser's error as one line, `line L, column C: message` (the parser's own text spans
/// several lines with a source excerpt).
fn toml_error_line(text: &str, e: &toml::de::Error) -> String {
    let message = e.message().trim().replace('\n', " ");
    match e.span().and_then(|sp| text.get(..sp.start)) {
        Some(before) => {
            let line = 1 + before.matches('\n').count();
            let column = 1 + before.rsplit('\n').next().map_or(0, |l| l.chars().count());
            format!("line {line}, column {column}: {message}")
        }
        None => message,
    }
}

/// Input `i` as the file names it: `joint[2].d` or `tool[0]`.
fn input_field(i: usize) -> String {
    if i >= N_PARAMS {
        format!("tool[{}]", i - N_PARAMS)
    } else {
        format!("{}.{}", joint_field(param_joint(i)), param_kind(i).name())
    }
}

/// `joint[n]` with the 1-based joint number of 0-based `j`.
fn joint_field(j: usize) -> String {
    format!("joint[{}]", j + 1)
}

/// A value as the file would show it: rounded to 12 significant digits, which undoes the
/// degree/radian round trip, in exponent form when large.
fn show(v: f64) -> String {
    let r: f64 = format!("{v:.12e}").parse().unwrap_or(v);
    if r.abs() >= 1e6 {
        format!("{r:e}")
    } else {
        format!("{r}")
    }
}

/// Whether `v` (converted back from internal units) exceeds `max`, allowing for the rounding of
/// the degree/radian round trip so that a file value of exactly `max` passes.
fn exceeds(v: f64, max: f64) -> bool {
    v.abs() > max * (1.0 + 1e-12)
}

/// `v` finite and `|v| ≤ max`.
fn check_magnitude(field: &str, v: f64, max: f64, unit: &str) -> Result<(), InvalidField> {
    if !v.is_finite() {
        return Err(InvalidField {
            field: field.into(),
            message: format!("must be finite, got {v}"),
        });
    }
    if exceeds(v, max) {
        return Err(InvalidField {
            field: field.into(),
            message: format!(
                "{} {unit} is out of range: the magnitude must be at most {max} {unit}",
                show(v)
            ),
        });
    }
    Ok(())
}

/// Standard deviations (internal units): finite, ≥ 0, within the limits, 0 on fixed parameters.
fn check_sigmas(s: &[f64; N_PARAMS], fixed: &[FixedParam; JOINTS]) -> Result<(), InvalidField> {
    for j in 0..JOINTS {
        for kind in ParamKind::ALL {
            let v = s[param_index(j, kind)] / kind.to_internal();
            let field = format!("{}.sigma.{}", joint_field(j), kind.name());
            if !v.is_finite() || v < 0.0 {
                return Err(InvalidField {
                    field,
                    message: format!("must be a finite number ≥ 0, got {}", show(v)),
                });
            }
            let (max, unit, why) = if kind.is_angle() {
                (
                    MAX_SIGMA_DEG,
                    "deg",
                    "the normal model and the small-offset evaluation of an angle assume offsets \
                     well inside one turn",
                )
            } else {
                (
                    MAX_SIGMA_MM,
                    "mm",
                    "a spread this large is a unit mistake, not a calibration uncertainty",
                )
            };
            if exceeds(v, max) {
                return Err(InvalidField {
                    field,
                    message: format!(
                        "{} {unit} is too large: a standard deviation must be at most {max} \
                         {unit} ({why})",
                        show(v)
                    ),
                });
            }
        }
        let fixed_kind = fixed[j].kind();
        if s[param_index(j, fixed_kind)] != 0.0 {
            return Err(InvalidField {
                field: format!("{}.sigma.{}", joint_field(j), fixed_kind.name()),
                message: format!(
                    "must be 0: {} is the fixed parameter of this joint",
                    fixed_kind.name()
                ),
            });
        }
    }
    Ok(())
}

/// The covariance matrix of the file (30 rows of 30, or 33 of 33 with the tool; file units) in
/// internal units.
fn covariance_from_file(m: &[Vec<f64>]) -> Result<Vec<f64>, InvalidField> {
    let n = m.len();
    if n != N_PARAMS && n != N_UNCERTAIN {
        return Err(InvalidField {
            field: "covariance.matrix".into(),
            message: format!(
                "must have {N_PARAMS} rows (the parameters) or {N_UNCERTAIN} (the parameters, \
                 then the tool's x, y, z), found {n}"
            ),
        });
    }
    let mut c = vec![0.0; n * n];
    for (i, row) in m.iter().enumerate() {
        if row.len() != n {
            return Err(InvalidField {
                field: format!("covariance.matrix[{}]", i + 1),
                message: format!("must have {n} entries, found {}", row.len()),
            });
        }
        for (k, &v) in row.iter().enumerate() {
            c[i * n + k] = v * input_to_internal(i) * input_to_internal(k);
        }
    }
    Ok(c)
}

/// Tool standard deviations (mm): finite, ≥ 0, at most [`MAX_SIGMA_MM`].
fn check_tool_sigma(s: &[f64; 3]) -> Result<(), InvalidField> {
    for (k, &v) in s.iter().enumerate() {
        let field = format!("tool_sigma[{k}]");
        if !v.is_finite() || v < 0.0 {
            return Err(InvalidField {
                field,
                message: format!("must be a finite number ≥ 0, got {}", show(v)),
            });
        }
        if exceeds(v, MAX_SIGMA_MM) {
            return Err(InvalidField {
                field,
                message: format!(
                    "{} mm is too large: a standard deviation must be at most {MAX_SIGMA_MM} mm \
                     (a spread this large is a unit mistake, not a calibration uncertainty)",
                    show(v)
                ),
            });
        }
    }
    Ok(())
}

/// A covariance in internal units: finite, symmetric, variances ≥ 0, fixed parameters' rows 0.
fn check_covariance(c: &[f64], fixed: &[FixedParam; JOINTS]) -> Result<(), InvalidField> {
    let cell = |i: usize, k: usize| format!("covariance.matrix[{}][{}]", i + 1, k + 1);
    let n = if c.len() == N_UNCERTAIN * N_UNCERTAIN {
        N_UNCERTAIN
    } else {
        N_PARAMS
    };
    if c.len() != n * n {
        return Err(InvalidField {
            field: "covariance.matrix".into(),
            message: format!(
                "must have {} or {} entries, found {}",
                N_PARAMS * N_PARAMS,
                N_UNCERTAIN * N_UNCERTAIN,
                c.len()
            ),
        });
    }
    if let Some(x) = c.iter().position(|v| !v.is_finite()) {
        return Err(InvalidField {
            field: cell(x / n, x % n),
            message: format!("must be finite, got {}", c[x]),
        });
    }
    for i in 0..n {
        if c[i * n + i] < 0.0 {
            return Err(InvalidField {
                field: cell(i, i),
                message: "variance must be ≥ 0".into(),
            });
        }
        for k in 0..i {
            let (a, b) = (c[i * n + k], c[k * n + i]);
            if (a - b).abs() > 1e-9 * a.abs().max(b.abs()).max(1e-300) {
                return Err(InvalidField {
                    field: cell(i, k),
                    message: "matrix must be symmetric".into(),
                });
            }
        }
    }
    for (j, f) in fixed.iter().enumerate() {
        let kind = if *f == FixedParam::D {
            ParamKind::D
        } else {
            ParamKind::Beta
        };
        let i = param_index(j, kind);
        if (0..n).any(|k| c[i * n + k] != 0.0) {
            return Err(InvalidField {
                field: format!("covariance.matrix[{}]", i + 1),
                message: format!(
                    "row of joint {} {} must be 0: it is the fixed parameter",
                    j + 1,
                    kind.name()
                ),
            });
        }
    }
    Ok(())
}

/// The covariance restricted to the `free` parameters has a Cholesky factor (the same test the
/// sampler makes); otherwise names the first row where the factorisation fails.
fn check_positive_definite(c: &[f64], n: usize, free: &[usize]) -> Result<(), InvalidField> {
    let factors = |k: usize| {
        let sub = nalgebra::DMatrix::from_fn(k, k, |a, b| c[free[a] * n + free[b]]);
        nalgebra::linalg::Cholesky::new(sub).is_some()
    };
    if factors(free.len()) {
        return Ok(());
    }
    // The factorisation proceeds row by row, so the first leading block without a factor ends
    // at the row where it fails.
    let k = (1..=free.len())
        .find(|&k| !factors(k))
        .unwrap_or(free.len());
    let i = free[k - 1];
    Err(InvalidField {
        field: "covariance.matrix".into(),
        message: format!(
            "not positive definite on the parameters with nonzero variance: the Cholesky \
             factorisation fails at row {} ({}), which the rows before it (with nonzero \
             variance) make dependent or indefinite",
            i + 1,
            input_field(i)
        ),
    })
}

fn fnum(v: f64) -> String {
    // Shortest round-trip representation, always with a decimal point (valid TOML float).
    let s = format!("{v:?}");
    if s.contains('.') || s.contains('e') || s.contains("inf") || s.contains("NaN") {
        s
    } else {
        format!("{s}.0")
    }
}

fn toml_string(s: &str) -> String {
    toml::Value::String(s.to_string()).to_string()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::tx60;

    #[test]
    fn toml_round_trip() {
        let m = tx60();
        let back = RobotModel::from_toml(&m.to_toml(), "x").unwrap();
        assert_eq!(m.fixed, back.fixed);
        for i in 0..N_PARAMS {
            assert!((m.params[i] - back.params[i]).abs() < 1e-15);
        }
        assert_eq!(
            m.uncertainty.sigmas().map(|v| (v * 1e12).round()),
            back.uncertainty.sigmas().map(|v| (v * 1e12).round())
        );
    }

    #[test]
    fn covariance_round_trip() {
        let mut m = tx60();
        let s = m.uncertainty.sigmas();
        let mut c = vec![0.0; N_PARAMS * N_PARAMS];
        for i in 0..N_PARAMS {
            c[i * N_PARAMS + i] = s[i] * s[i];
        }
        c[1] = 0.3 * s[0] * s[1];
        c[N_PARAMS] = c[1];
        m.uncertainty = Uncertainty::Covariance(c.clone());
        let back = RobotModel::from_toml(&m.to_toml(), "x").unwrap();
        match back.uncertainty {
            Uncertainty::Covariance(b) => {
                for i in 0..c.len() {
                    assert!((b[i] - c[i]).abs() <= 1e-12 * c[i].abs().max(1e-20));
                }
            }
            _ => panic!("lost covariance"),
        }
    }

    fn err_of(text: &str) -> String {
        RobotModel::from_toml(text, "m.toml")
            .unwrap_err()
            .to_string()
    }

    #[test]
    fn values_exactly_at_the_limits_pass_and_just_past_fail() {
        // The file's degrees go through radians and back: the check must not reject a value of
        // exactly the limit by a rounding ulp, for any joint or parameter.
        let mut m = tx60();
        for (i, p) in m.params.iter_mut().enumerate() {
            let kind = param_kind(i);
            let sign = if i % 2 == 0 { 1.0 } else { -1.0 };
            let max = if kind.is_angle() {
                MAX_ANGLE_DEG
            } else {
                MAX_LENGTH_MM
            };
            *p = sign * max * kind.to_internal();
        }
        let mut s = [0.0; N_PARAMS];
        for (i, v) in s.iter_mut().enumerate() {
            let kind = param_kind(i);
            let fixed = match m.fixed[param_joint(i)] {
                FixedParam::D => ParamKind::D,
                FixedParam::Beta => ParamKind::Beta,
            };
            if kind != fixed {
                *v = if kind.is_angle() {
                    MAX_SIGMA_DEG
                } else {
                    MAX_SIGMA_MM
                } * kind.to_internal();
            }
        }
        m.uncertainty = Uncertainty::Independent(s);
        m.limits_deg = [(-MAX_LIMIT_DEG, MAX_LIMIT_DEG); JOINTS];
        m.tool = [MAX_LENGTH_MM, -MAX_LENGTH_MM, 0.0];
        m.check().unwrap();
        RobotModel::from_toml(&m.to_toml(), "m.toml").unwrap();
        let mut past = m.clone();
        past.params[3] *= 1.000_001;
        assert_eq!(past.check().unwrap_err().field, "joint[1].alpha");
        let mut past = m.clone();
        s[2] *= 1.000_001;
        past.uncertainty = Uncertainty::Independent(s);
        assert_eq!(past.check().unwrap_err().field, "joint[1].sigma.a");
    }

    /// `tool_sigma` is optional (absent: the file and the model are as before), round-trips,
    /// and a bad value is named; a 33 × 33 covariance carries the tool and must agree with a
    /// given `tool_sigma`.
    #[test]
    fn tool_sigma_in_the_file() {
        let m = tx60();
        assert!(!m.to_toml().contains("tool_sigma"));
        let mut t = m.clone();
        t.tool_sigma = [0.002, 0.0, 0.0035];
        let text = t.to_toml();
        assert!(text.contains("tool_sigma = [0.002, 0.0, 0.0035]"), "{text}");
        assert_eq!(
            RobotModel::from_toml(&text, "x").unwrap().tool_sigma,
            t.tool_sigma
        );
        let neg = text.replace("tool_sigma = [0.002,", "tool_sigma = [-0.002,");
        assert!(err_of(&neg).contains("tool_sigma[0]"), "{}", err_of(&neg));
        let two = text.replace("tool_sigma = [0.002, 0.0,", "tool_sigma = [0.002,");
        assert!(
            err_of(&two).contains("tool_sigma: must be exactly 3"),
            "{}",
            err_of(&two)
        );
        // 33 × 33: the tool's variances from the matrix
        let n = N_UNCERTAIN;
        let s = m.uncertainty.sigmas();
        let mut c = vec![0.0; n * n];
        for i in 0..N_PARAMS {
            c[i * n + i] = s[i] * s[i];
        }
        for k in 0..3 {
            c[tool_index(k) * (n + 1)] = t.tool_sigma[k].powi(2);
        }
        c[tool_index(2) * n + 1] = 0.5 * t.tool_sigma[2] * s[1];
        c[n + tool_index(2)] = c[tool_index(2) * n + 1];
        t.uncertainty = Uncertainty::Covariance(c);
        t.check().unwrap();
        let text = t.to_toml();
        assert!(text.contains("then the tool's x, y, z"));
        let back = RobotModel::from_toml(&text, "x").unwrap();
        assert_eq!(back.uncertainty.dim(), N_UNCERTAIN);
        for k in 0..3 {
            assert!((back.tool_sigma[k] - t.tool_sigma[k]).abs() < 1e-15);
        }
        assert_eq!(back.full_covariance().unwrap().len(), n * n);
        let off = text.replace("tool_sigma = [0.002,", "tool_sigma = [0.003,");
        assert!(
            err_of(&off).contains("tool_sigma[0]: differs from sqrt of covariance diagonal"),
            "{}",
            err_of(&off)
        );
        // a 30 × 30 matrix keeps tool_sigma as the tool's independent spread
        let mut p = m.clone();
        p.uncertainty = Uncertainty::Covariance(
            (0..N_PARAMS * N_PARAMS)
                .map(|x| {
                    if x % (N_PARAMS + 1) == 0 {
                        s[x / N_PARAMS].powi(2)
                    } else {
                        0.0
                    }
                })
                .collect(),
        );
        p.tool_sigma = [0.0, 0.001, 0.0];
        let full = p.full_covariance().unwrap();
        assert_eq!(full[tool_index(1) * (n + 1)], 1e-6);
        assert_eq!(p.free_inputs().last(), Some(&tool_index(1)));
    }

    #[test]
    fn bad_fields_are_named() {
        let good = tx60().to_toml();
        let neg = good.replacen(
            "sigma = { theta = 0.003216, d = 0.005056",
            "sigma = { theta = 0.003216, d = -0.005056",
            1,
        );
        assert_ne!(neg, good);
        assert!(
            err_of(&neg).contains("joint[1].sigma.d"),
            "{}",
            err_of(&neg)
        );
        let nan = good.replacen("\na = 0.0", "\na = nan", 1);
        assert!(err_of(&nan).contains("joint[1].a"), "{}", err_of(&nan));
        let unknown = good.replacen("fixed = \"beta\"", "fixed = \"beta\"\nfoo = 1", 1);
        assert!(err_of(&unknown).contains("foo"), "{}", err_of(&unknown));
        let line = 1
            + good[..good.find("fixed = \"beta\"").unwrap()]
                .matches('\n')
                .count()
            + 1;
        assert!(
            err_of(&unknown).starts_with(&format!("model file m.toml: line {line}, column 1: ")),
            "{}",
            err_of(&unknown)
        );
        assert!(!err_of("x = ").contains('|'), "{}", err_of("x = "));
        let missing = good.replacen(
            "sigma = { theta = 0.003216, d = 0.005056,",
            "sigma = { d = 0.005056,",
            1,
        );
        assert!(err_of(&missing).contains("theta"), "{}", err_of(&missing));
        let lim = good.replacen("limits = [-180.0, 180.0]", "limits = [180.0, -180.0]", 1);
        assert!(err_of(&lim).contains("joint[1].limits"), "{}", err_of(&lim));
    }
}
