//! The model file (TOML, mm and degrees; see the README, "Model file"): [`RobotModel::from_file`],
//! [`RobotModel::from_toml`] and [`RobotModel::to_toml`]. Every field is checked when read; a
//! bad one gives a [`ModelError`] naming the joint and field.

use serde::{Deserialize, Serialize};
use std::fmt::Write as _;

use super::check::{check_sigmas, check_tool_sigma, input_sigma_field, joint_field, InvalidField};
use super::index::{
    param_index, FixedParam, Inputs, Layout, ParamKind, Params, MAX_JOINTS, MIN_JOINTS,
};
use super::inputs::{Block, InputSpace};
use super::model::{BaseTransform, Covariance, FixedParams, Limits, RobotModel, Uncertainty};

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
    /// The blocks the matrix covers, in order ([`Block::name`]); files written before blocks
    /// were named leave it out ([`legacy_space`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    blocks: Option<Vec<String>>,
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
    #[serde(default, skip_serializing_if = "Option::is_none")]
    discrepancy: Option<crate::discrepancy::Discrepancy>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    links: Option<super::file_links::LinksFile>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    joint_errors: Option<super::file_joint_errors::JointErrorsFile>,
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
    ///
    /// # Examples
    ///
    /// The TX60 preset through its model file text and back:
    ///
    /// ```
    /// use gpu_amcs_core::kinematics::{tx60, ModelError, RobotModel};
    ///
    /// let m = tx60();
    /// let back = RobotModel::from_toml(&m.to_toml(), "tx60.toml")?;
    /// assert_eq!(back.name, m.name);
    /// assert_eq!(back.fixed, m.fixed);
    /// assert_eq!(back.limits_deg, m.limits_deg);
    /// assert_eq!(back.tool, m.tool);
    /// // The file is in mm and degrees: angles come back to within rounding.
    /// for (a, b) in back.params.iter().zip(m.params.iter()) {
    ///     assert!((a - b).abs() < 1e-12);
    /// }
    /// assert_eq!(back.param_sigmas().len(), m.param_sigmas().len());
    /// for (a, b) in back.param_sigmas().iter().zip(m.param_sigmas().iter()) {
    ///     assert!((a - b).abs() < 1e-12);
    /// }
    ///
    /// // Malformed text is a syntax error naming the origin.
    /// let err = RobotModel::from_toml("name = ", "bad.toml").unwrap_err();
    /// assert!(matches!(err, ModelError::Syntax { ref path, .. } if path == "bad.toml"));
    /// # Ok::<(), ModelError>(())
    /// ```
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
                Uncertainty::Covariance(covariance_from_file(lay, c).map_err(invalid)?)
            }
        };
        if let Some(ts) = tool_sigma_file {
            check_tool_sigma(&ts).map_err(invalid)?;
        }
        let discrepancy = match file.discrepancy {
            None => None,
            Some(d) => {
                let d = d.checked().map_err(|e| match e {
                    crate::discrepancy::DiscrepancyError::Invalid { field, message } => {
                        invalid(InvalidField { field, message })
                    }
                })?;
                if let Some(c) = &d.compensation {
                    c.check(fixed.len()).map_err(|(field, message)| {
                        invalid(InvalidField {
                            field: format!("discrepancy.{field}"),
                            message,
                        })
                    })?;
                }
                Some(d)
            }
        };
        let space = match &uncertainty {
            Uncertainty::Covariance(c) => c.space(),
            Uncertainty::Independent(_) => InputSpace::robot(n_joints),
        };
        let links = match file.links {
            None => None,
            Some(l) => Some(
                l.into_model(n_joints)
                    .map_err(|(field, message)| invalid(InvalidField { field, message }))?,
            ),
        };
        let joint_errors = match file.joint_errors {
            None => None,
            Some(j) => Some(
                j.into_model(n_joints, space)
                    .map_err(|(field, message)| invalid(InvalidField { field, message }))?,
            ),
        };
        let mut model = RobotModel {
            discrepancy,
            joint_errors,
            links,
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
        let tool_rows = model.uncertainty.covers(Block::Tool);
        if let Uncertainty::Covariance(c) = model.uncertainty.clone() {
            model.set_covariance(c);
        }
        model.check().map_err(invalid)?;
        // The per-joint sigma (and tool_sigma) must agree with the covariance diagonal so a reader
        // of the file is not misled.
        if let Uncertainty::Covariance(_) = &model.uncertainty {
            let diag = model.input_sigmas();
            let space = model.robot_inputs();
            let given = Inputs::from_fn(space.len(), |i| match space.locate(i) {
                (Block::Tool, k) => tool_sigma_file.map_or(diag[i], |t| t[k]),
                _ => sigma[i],
            });
            let n = if tool_rows {
                space.len()
            } else {
                lay.n_params()
            };
            for i in 0..n {
                if (diag[i] - given[i]).abs() > 1e-6 * diag[i].max(given[i]).max(1e-300) {
                    let f = space.to_internal(i);
                    return Err(bad(
                        &input_sigma_field(space, i),
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
    ///
    /// # Examples
    ///
    /// The text reads back ([`RobotModel::from_toml`]) as the same model, and writing that
    /// model again gives the same text:
    ///
    /// ```
    /// use gpu_amcs_core::kinematics::{tx60, RobotModel};
    ///
    /// let text = tx60().to_toml();
    /// assert!(text.starts_with("# gpu-amcs robot model"));
    /// let back = RobotModel::from_toml(&text, "tx60.toml")?;
    /// assert_eq!(back.joints(), 6);
    /// assert_eq!(back.to_toml(), text);
    /// # Ok::<(), gpu_amcs_core::kinematics::ModelError>(())
    /// ```
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
            let space = c.space();
            let n = space.len();
            let _ = writeln!(
                s,
                "\n# Full covariance of the {} parameters, joint-major [theta, d, a, alpha, beta],",
                lay.n_params()
            );
            for b in space.blocks().skip(1) {
                let _ = writeln!(s, "# then {},", b.description());
            }
            let _ = writeln!(s, "# in file units (mm, deg and their products).");
            let names: Vec<String> = space
                .block_names()
                .iter()
                .map(|b| format!("\"{b}\""))
                .collect();
            let _ = writeln!(
                s,
                "[covariance]\nblocks = [{}]\nmatrix = [",
                names.join(", ")
            );
            let m = c.matrix();
            for i in 0..n {
                let row: Vec<String> = (0..n)
                    .map(|k| {
                        let f = space.to_internal(i) * space.to_internal(k);
                        fnum(m[i * n + k] / f)
                    })
                    .collect();
                let _ = writeln!(s, "  [{}],", row.join(", "));
            }
            let _ = writeln!(s, "]");
        }
        if let Some(d) = &self.discrepancy {
            super::file_discrepancy::write_discrepancy(&mut s, d, "discrepancy");
        }
        if let Some(l) = &self.links {
            super::file_links::write_links(&mut s, l);
        }
        if let Some(e) = &self.joint_errors {
            super::file_joint_errors::write_joint_errors(&mut s, e);
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

/// The blocks of a covariance written before files named them, read from its size as those
/// files meant it: the parameters (`5n` rows), then the tool (`5n + 3`), then the placement
/// (`5n + 9`). The only place a size chooses blocks.
fn legacy_space(lay: Layout, rows: usize) -> Result<InputSpace, InvalidField> {
    [
        InputSpace::parameters(lay.joints()),
        lay.robot(),
        lay.measured(),
    ]
    .into_iter()
    .find(|s| s.len() == rows)
    .ok_or_else(|| {
        let (np, nu, nb) = (lay.n_params(), lay.robot().len(), lay.measured().len());
        InvalidField {
            field: "covariance.matrix".into(),
            message: format!(
                "must have {np} rows (the parameters of {} joints), {nu} (the parameters, then \
                 the tool's x, y, z) or {nb} (then the base's x, y, z, roll, pitch, yaw), found \
                 {rows}; a covariance of other inputs names them in covariance.blocks",
                lay.joints()
            ),
        }
    })
}

/// The covariance of the file (file units) in internal units, over the blocks it names (or, in
/// an older file without `blocks`, [`legacy_space`]).
fn covariance_from_file(lay: Layout, file: &CovarianceFile) -> Result<Covariance, InvalidField> {
    let m = &file.matrix;
    let n = m.len();
    let space = match &file.blocks {
        None => legacy_space(lay, n)?,
        Some(names) => {
            let space = InputSpace::from_names(lay.joints(), names).map_err(|e| InvalidField {
                field: "covariance.blocks".into(),
                message: e.to_string(),
            })?;
            if space.len() != n {
                return Err(InvalidField {
                    field: "covariance.matrix".into(),
                    message: format!(
                        "must have {} rows for the blocks [{}] of {} joints, found {n}",
                        space.len(),
                        space.block_names().join(", "),
                        lay.joints()
                    ),
                });
            }
            space
        }
    };
    let mut c = vec![0.0; n * n];
    for (i, row) in m.iter().enumerate() {
        if row.len() != n {
            return Err(InvalidField {
                field: format!("covariance.matrix[{}]", i + 1),
                message: format!("must have {n} entries, found {}", row.len()),
            });
        }
        for (k, &v) in row.iter().enumerate() {
            c[i * n + k] = v * space.to_internal(i) * space.to_internal(k);
        }
    }
    Ok(Covariance::new(space, c).expect("n rows of n entries"))
}

pub(super) fn fnum(v: f64) -> String {
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
