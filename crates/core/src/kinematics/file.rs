//! The model file (TOML, mm and degrees; see the README, "Model file"): [`RobotModel::from_file`],
//! [`RobotModel::from_toml`] and [`RobotModel::to_toml`]. Every field is checked when read; a
//! bad one gives a [`ModelError`] naming the joint and field.

use serde::{Deserialize, Serialize};
use std::fmt::Write as _;

use super::check::{check_sigmas, check_tool_sigma, input_sigma_field, joint_field, InvalidField};
use super::index::{
    param_index, FixedParam, Inputs, Layout, ParamKind, Params, MAX_JOINTS, MIN_JOINTS,
};
use super::model::{BaseTransform, FixedParams, Limits, RobotModel, Uncertainty};

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
    /// Unknown preset name (`crate::presets::preset`).
    #[error("unknown preset '{name}' (known: {})", .known.join(", "))]
    UnknownPreset {
        /// The name given.
        name: String,
        /// The names of the built-in presets.
        known: &'static [&'static str],
    },
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
    /// Where an identified model came from (data hash, fit figures): written by the
    /// identification after the model, read and ignored here.
    #[serde(default, skip_serializing)]
    #[allow(dead_code)]
    provenance: Option<toml::Table>,
}

impl RobotModel {
    /// Reads and checks a model file (at most [`crate::input::MODEL_FILE_LIMIT`] bytes).
    ///
    /// # Errors
    ///
    /// [`ModelError::Read`] when the file cannot be read, is too large or is not UTF-8; otherwise
    /// as [`RobotModel::from_toml`].
    pub fn from_file(path: &std::path::Path) -> Result<Self, ModelError> {
        let text = crate::input::read_text(path, crate::input::MODEL_FILE_LIMIT, "model file")?;
        Self::from_toml(&text, &path.display().to_string())
    }

    /// Parses and checks a model from TOML text; `origin` names the source in errors.
    ///
    /// # Errors
    ///
    /// [`ModelError::Syntax`] for malformed TOML or unknown, missing or mistyped keys (naming line
    /// and column), and [`ModelError::Invalid`] for a value out of range, a wrong count (4 to 7
    /// joints, 3 tool coordinates, 2 limits), a covariance that is not symmetric and positive definite, or
    /// per-joint `sigma` (and `tool_sigma`) that differ from the covariance's diagonal; the error
    /// names the field.
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
        let n_joints = file.joint.len();
        if !(MIN_JOINTS..=MAX_JOINTS).contains(&n_joints) {
            return Err(bad(
                "joint",
                format!(
                    "expected {MIN_JOINTS} to {MAX_JOINTS} [[joint]] tables (one per joint), \
                     found {n_joints}"
                ),
            ));
        }
        let lay = Layout::new(n_joints);
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
        let mut params = Params::filled(lay.n_params(), 0.0);
        let mut sigma = Params::filled(lay.n_params(), 0.0);
        let mut fixed = FixedParams::filled(n_joints, FixedParam::Beta);
        let mut limits = Limits::filled(n_joints, (0.0, 0.0));
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
                Uncertainty::Covariance(covariance_from_file(lay, &c.matrix).map_err(invalid)?)
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
        // A covariance with the tool carries the tool's spread; `tool_sigma`, when given, must
        // repeat its diagonal.
        let full = model.uncertainty.dim() >= lay.n_uncertain();
        if full {
            model.tool_sigma = std::array::from_fn(|k| {
                let i = lay.tool_index(k);
                model.uncertainty.entry(i, i).max(0.0).sqrt()
            });
        }
        model.check().map_err(invalid)?;
        // The per-joint sigma (and tool_sigma) must agree with the covariance diagonal so a reader
        // of the file is not misled.
        if let Uncertainty::Covariance(_) = &model.uncertainty {
            let diag = model.input_sigmas();
            let np = lay.n_params();
            let given = Inputs::from_fn(lay.n_uncertain(), |i| {
                if i < np {
                    sigma[i]
                } else {
                    tool_sigma_file.map_or(diag[i], |t| t[i - np])
                }
            });
            let n = if full { lay.n_uncertain() } else { np };
            for i in 0..n {
                if (diag[i] - given[i]).abs() > 1e-6 * diag[i].max(given[i]).max(1e-300) {
                    let f = lay.input_to_internal(i);
                    return Err(bad(
                        &input_sigma_field(lay, i),
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

    /// Writes the model as TOML (mm, degrees) with explanatory comments.
    pub fn to_toml(&self) -> String {
        let sig = self.param_sigmas();
        let lay = self.layout();
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
        for j in 0..self.joints() {
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
                "\n# Full covariance of the {} parameters, joint-major [theta, d, a, alpha, beta],",
                lay.n_params()
            );
            if n >= lay.n_uncertain() {
                let _ = writeln!(s, "# then the tool's x, y, z,");
            }
            if n == lay.n_with_base() {
                let _ = writeln!(
                    s,
                    "# then the base placement's x, y, z and roll, pitch, yaw (the `base` field's convention),"
                );
            }
            let _ = writeln!(s, "# in file units (mm, deg and their products).");
            let _ = writeln!(s, "[covariance]\nmatrix = [");
            for i in 0..n {
                let row: Vec<String> = (0..n)
                    .map(|k| {
                        let f = lay.input_to_internal(i) * lay.input_to_internal(k);
                        fnum(c[i * n + k] / f)
                    })
                    .collect();
                let _ = writeln!(s, "  [{}],", row.join(", "));
            }
            let _ = writeln!(s, "]");
        }
        s
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

/// The covariance matrix of the file (the parameters: 30 rows of 30 for six joints; 33 of 33
/// with the tool; 39 of 39 with the tool and the base placement; file units) in internal units.
fn covariance_from_file(lay: Layout, m: &[Vec<f64>]) -> Result<Vec<f64>, InvalidField> {
    let n = m.len();
    let (np, nu, nb) = (lay.n_params(), lay.n_uncertain(), lay.n_with_base());
    if n != np && n != nu && n != nb {
        return Err(InvalidField {
            field: "covariance.matrix".into(),
            message: format!(
                "must have {np} rows (the parameters of {} joints), {nu} (the parameters, then \
                 the tool's x, y, z) or {nb} (then the base's x, y, z, roll, pitch, yaw), found {n}",
                lay.joints()
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
            c[i * n + k] = v * lay.input_to_internal(i) * lay.input_to_internal(k);
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
