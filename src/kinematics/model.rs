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

/// Spread of the parameters about their values (internal units: mm, rad).
#[derive(Clone, Debug, PartialEq)]
#[allow(clippy::large_enum_variant)] // one per model; boxing buys nothing
pub enum Uncertainty {
    /// Independent normals with these standard deviations (0 = exactly known).
    Independent([f64; N_PARAMS]),
    /// Full covariance, row-major 30×30.
    Covariance(Vec<f64>),
}

impl Uncertainty {
    /// Standard deviation of each parameter (the covariance's diagonal, square-rooted).
    pub fn sigmas(&self) -> [f64; N_PARAMS] {
        match self {
            Self::Independent(s) => *s,
            Self::Covariance(c) => std::array::from_fn(|i| c[i * N_PARAMS + i].max(0.0).sqrt()),
        }
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
    /// Parameter uncertainty.
    pub uncertainty: Uncertainty,
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
struct ModelFile {
    name: String,
    tool: Vec<f64>,
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
        let model = RobotModel {
            name: file.name,
            params,
            fixed,
            limits_deg: limits,
            tool,
            uncertainty,
        };
        model.check().map_err(invalid)?;
        // The per-joint sigma must agree with the covariance diagonal so a reader of the file is
        // not misled.
        if let Uncertainty::Covariance(_) = &model.uncertainty {
            let diag = model.uncertainty.sigmas();
            for i in 0..N_PARAMS {
                if (diag[i] - sigma[i]).abs() > 1e-6 * diag[i].max(sigma[i]).max(1e-300) {
                    let kind = param_kind(i);
                    return Err(bad(
                        &format!("{}.sigma.{}", joint_field(param_joint(i)), kind.name()),
                        format!(
                            "differs from sqrt of covariance diagonal ({} vs {})",
                            sigma[i] / kind.to_internal(),
                            diag[i] / kind.to_internal()
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
                check_positive_definite(c, &self.free_params())
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
        let _ = writeln!(s, "# tracker target in the flange frame, mm");
        let _ = writeln!(
            s,
            "tool = [{}, {}, {}]",
            fnum(self.tool[0]),
            fnum(self.tool[1]),
            fnum(self.tool[2])
        );
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
            let _ = writeln!(
                s,
                "\n# Full covariance of the 30 parameters, joint-major [theta, d, a, alpha, beta],"
            );
            let _ = writeln!(s, "# in file units (mm, deg and their products).");
            let _ = writeln!(s, "[covariance]\nmatrix = [");
            for i in 0..N_PARAMS {
                let row: Vec<String> = (0..N_PARAMS)
                    .map(|k| {
                        let f = param_kind(i).to_internal() * param_kind(k).to_internal();
                        fnum(c[i * N_PARAMS + k] / f)
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

/// The covariance matrix of the file (30 rows of 30, file units) in internal units.
fn covariance_from_file(m: &[Vec<f64>]) -> Result<Vec<f64>, InvalidField> {
    if m.len() != N_PARAMS {
        return Err(InvalidField {
            field: "covariance.matrix".into(),
            message: format!("must have {N_PARAMS} rows, found {}", m.len()),
        });
    }
    let mut c = vec![0.0; N_PARAMS * N_PARAMS];
    for (i, row) in m.iter().enumerate() {
        if row.len() != N_PARAMS {
            return Err(InvalidField {
                field: format!("covariance.matrix[{}]", i + 1),
                message: format!("must have {N_PARAMS} entries, found {}", row.len()),
            });
        }
        for (k, &v) in row.iter().enumerate() {
            let f = param_kind(i).to_internal() * param_kind(k).to_internal();
            c[i * N_PARAMS + k] = v * f;
        }
    }
    Ok(c)
}

/// A covariance in internal units: finite, symmetric, variances ≥ 0, fixed parameters' rows 0.
fn check_covariance(c: &[f64], fixed: &[FixedParam; JOINTS]) -> Result<(), InvalidField> {
    let cell = |i: usize, k: usize| format!("covariance.matrix[{}][{}]", i + 1, k + 1);
    if c.len() != N_PARAMS * N_PARAMS {
        return Err(InvalidField {
            field: "covariance.matrix".into(),
            message: format!(
                "must have {} entries, found {}",
                N_PARAMS * N_PARAMS,
                c.len()
            ),
        });
    }
    if let Some(x) = c.iter().position(|v| !v.is_finite()) {
        return Err(InvalidField {
            field: cell(x / N_PARAMS, x % N_PARAMS),
            message: format!("must be finite, got {}", c[x]),
        });
    }
    for i in 0..N_PARAMS {
        if c[i * N_PARAMS + i] < 0.0 {
            return Err(InvalidField {
                field: cell(i, i),
                message: "variance must be ≥ 0".into(),
            });
        }
        for k in 0..i {
            let (a, b) = (c[i * N_PARAMS + k], c[k * N_PARAMS + i]);
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
        if (0..N_PARAMS).any(|k| c[i * N_PARAMS + k] != 0.0) {
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
fn check_positive_definite(c: &[f64], free: &[usize]) -> Result<(), InvalidField> {
    let factors = |k: usize| {
        let sub = nalgebra::DMatrix::from_fn(k, k, |a, b| c[free[a] * N_PARAMS + free[b]]);
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
             factorisation fails at row {} ({}.{}), which the rows before it (with nonzero \
             variance) make dependent or indefinite",
            i + 1,
            joint_field(param_joint(i)),
            param_kind(i).name()
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
