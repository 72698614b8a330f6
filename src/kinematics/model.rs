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

/// Which of `d` and `β` a joint keeps fixed (METHOD.md §1).
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

/// Errors reading or checking a model.
#[derive(Debug, thiserror::Error)]
pub enum ModelError {
    /// The model file could not be read.
    #[error("cannot read model file {path}: {source}")]
    Io {
        /// The path given.
        path: String,
        /// The OS error.
        source: std::io::Error,
    },
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
    limits: [f64; 2],
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
    tool: [f64; 3],
    joint: Vec<JointFile>,
    #[serde(skip_serializing_if = "Option::is_none")]
    covariance: Option<CovarianceFile>,
}

impl RobotModel {
    /// Reads and checks a model file.
    pub fn from_file(path: &std::path::Path) -> Result<Self, ModelError> {
        let p = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|source| ModelError::Io {
            path: p.clone(),
            source,
        })?;
        Self::from_toml(&text, &p)
    }

    /// Parses and checks a model from TOML text; `origin` names the source in errors.
    pub fn from_toml(text: &str, origin: &str) -> Result<Self, ModelError> {
        let file: ModelFile = toml::from_str(text).map_err(|e| ModelError::Syntax {
            path: origin.to_string(),
            message: e.to_string().trim().replace('\n', " "),
        })?;
        let invalid = |field: String, message: String| ModelError::Invalid {
            path: origin.to_string(),
            field,
            message,
        };
        if file.joint.len() != JOINTS {
            return Err(invalid(
                "joint".into(),
                format!(
                    "expected {JOINTS} [[joint]] tables, found {}",
                    file.joint.len()
                ),
            ));
        }
        for (k, v) in file.tool.iter().enumerate() {
            if !v.is_finite() {
                return Err(invalid(
                    format!("tool[{k}]"),
                    format!("must be finite, got {v}"),
                ));
            }
        }
        let mut params = [0.0; N_PARAMS];
        let mut sigma = [0.0; N_PARAMS];
        let mut fixed = [FixedParam::Beta; JOINTS];
        let mut limits = [(0.0, 0.0); JOINTS];
        for (j, jf) in file.joint.iter().enumerate() {
            let n = j + 1;
            let vals = [jf.theta, jf.d, jf.a, jf.alpha, jf.beta];
            let sig = [
                jf.sigma.theta,
                jf.sigma.d,
                jf.sigma.a,
                jf.sigma.alpha,
                jf.sigma.beta,
            ];
            for (k, kind) in ParamKind::ALL.iter().enumerate() {
                if !vals[k].is_finite() {
                    return Err(invalid(
                        format!("joint[{n}].{}", kind.name()),
                        format!("must be finite, got {}", vals[k]),
                    ));
                }
                if !sig[k].is_finite() || sig[k] < 0.0 {
                    return Err(invalid(
                        format!("joint[{n}].sigma.{}", kind.name()),
                        format!("must be a finite number ≥ 0, got {}", sig[k]),
                    ));
                }
                params[j * 5 + k] = vals[k] * kind.to_internal();
                sigma[j * 5 + k] = sig[k] * kind.to_internal();
            }
            let fixed_kind = match jf.fixed {
                FixedParam::D => ParamKind::D,
                FixedParam::Beta => ParamKind::Beta,
            };
            if sigma[param_index(j, fixed_kind)] != 0.0 {
                return Err(invalid(
                    format!("joint[{n}].sigma.{}", fixed_kind.name()),
                    format!(
                        "must be 0: {} is the fixed parameter of this joint",
                        fixed_kind.name()
                    ),
                ));
            }
            fixed[j] = jf.fixed;
            let [lo, hi] = jf.limits;
            if !(lo.is_finite() && hi.is_finite() && lo < hi) {
                return Err(invalid(
                    format!("joint[{n}].limits"),
                    format!("must be [min, max] with min < max (deg), got [{lo}, {hi}]"),
                ));
            }
            limits[j] = (lo, hi);
        }
        let uncertainty = match &file.covariance {
            None => Uncertainty::Independent(sigma),
            Some(c) => {
                let cov = check_covariance(&c.matrix, &fixed)
                    .map_err(|(field, msg)| invalid(field, msg))?;
                // The per-joint sigma must agree with the covariance diagonal so a reader of the
                // file is not misled.
                let diag = Uncertainty::Covariance(cov.clone()).sigmas();
                for i in 0..N_PARAMS {
                    if (diag[i] - sigma[i]).abs() > 1e-6 * diag[i].max(sigma[i]).max(1e-300) {
                        let kind = ParamKind::ALL[i % 5];
                        return Err(invalid(
                            format!("joint[{}].sigma.{}", i / 5 + 1, kind.name()),
                            format!(
                                "differs from sqrt of covariance diagonal ({} vs {})",
                                sigma[i] / kind.to_internal(),
                                diag[i] / kind.to_internal()
                            ),
                        ));
                    }
                }
                Uncertainty::Covariance(cov)
            }
        };
        Ok(RobotModel {
            name: file.name,
            params,
            fixed,
            limits_deg: limits,
            tool: file.tool,
            uncertainty,
        })
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
            let fixed = match self.fixed[j] {
                FixedParam::D => "d",
                FixedParam::Beta => "beta",
            };
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
                        let f = ParamKind::ALL[i % 5].to_internal()
                            * ParamKind::ALL[k % 5].to_internal();
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

/// Checks a covariance given in file units; returns it in internal units.
fn check_covariance(
    m: &[Vec<f64>],
    fixed: &[FixedParam; JOINTS],
) -> Result<Vec<f64>, (String, String)> {
    if m.len() != N_PARAMS {
        return Err((
            "covariance.matrix".into(),
            format!("must have {N_PARAMS} rows, found {}", m.len()),
        ));
    }
    let mut c = vec![0.0; N_PARAMS * N_PARAMS];
    for (i, row) in m.iter().enumerate() {
        if row.len() != N_PARAMS {
            return Err((
                format!("covariance.matrix[{}]", i + 1),
                format!("must have {N_PARAMS} entries, found {}", row.len()),
            ));
        }
        for (k, &v) in row.iter().enumerate() {
            if !v.is_finite() {
                return Err((
                    format!("covariance.matrix[{}][{}]", i + 1, k + 1),
                    format!("must be finite, got {v}"),
                ));
            }
            let f = ParamKind::ALL[i % 5].to_internal() * ParamKind::ALL[k % 5].to_internal();
            c[i * N_PARAMS + k] = v * f;
        }
    }
    for i in 0..N_PARAMS {
        if c[i * N_PARAMS + i] < 0.0 {
            return Err((
                format!("covariance.matrix[{}][{}]", i + 1, i + 1),
                "variance must be ≥ 0".into(),
            ));
        }
        for k in 0..i {
            let (a, b) = (c[i * N_PARAMS + k], c[k * N_PARAMS + i]);
            if (a - b).abs() > 1e-9 * a.abs().max(b.abs()).max(1e-300) {
                return Err((
                    format!("covariance.matrix[{}][{}]", i + 1, k + 1),
                    "matrix must be symmetric".into(),
                ));
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
            return Err((
                format!("covariance.matrix[{}]", i + 1),
                format!(
                    "row of joint {} {} must be 0: it is the fixed parameter",
                    j + 1,
                    kind.name()
                ),
            ));
        }
    }
    Ok(c)
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
