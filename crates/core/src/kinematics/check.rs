//! The checks of a model's values (README, "Model file"): [`RobotModel::check`] and the ranges it
//! enforces. An error names the field as the model file spells it ([`InvalidField`]).

use super::index::{
    param_index, param_joint, param_kind, FixedParam, ParamKind, MAX_JOINTS, MIN_JOINTS,
    PARAMS_PER_JOINT,
};
use super::inputs::{Block, InputSpace, Quantity};
use super::model::{RobotModel, Uncertainty};

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

/// The field of input `i` of `space` as the model file spells its spread: `joint[2].sigma.d`,
/// `tool_sigma[1]` (0-based coordinate, as TOML arrays are read), or the covariance's row for
/// the placement (which has no σ field of its own).
pub(super) fn input_sigma_field(space: InputSpace, i: usize) -> String {
    match space.locate(i) {
        (Block::Joints, k) => format!(
            "{}.sigma.{}",
            joint_field(param_joint(k)),
            param_kind(k).name()
        ),
        (Block::Tool, k) => format!("tool_sigma[{k}]"),
        (Block::Placement, _) => input_field(space, i),
    }
}

impl RobotModel {
    /// Checks every value against the model file's rules (README, "Model file"): finite
    /// parameters, lengths within ±[`MAX_LENGTH_MM`], angles within ±[`MAX_ANGLE_DEG`], limits
    /// `min < max` within ±[`MAX_LIMIT_DEG`], standard deviations ≥ 0 and at most
    /// [`MAX_SIGMA_MM`] / [`MAX_SIGMA_DEG`], zero spread on each joint's fixed parameter, and a
    /// covariance that is symmetric and positive definite on the parameters with nonzero
    /// variance. The error names the field as the file spells it.
    ///
    /// # Errors
    ///
    /// [`InvalidField`] for the first value that breaks a rule above, naming its field
    /// (`joint[2].sigma.d`, `tool[0]`, `covariance.matrix[3][1]`, …).
    pub fn check(&self) -> Result<(), InvalidField> {
        let n_joints = self.fixed.len();
        if !(MIN_JOINTS..=MAX_JOINTS).contains(&n_joints) {
            return Err(InvalidField {
                field: "joint".into(),
                message: format!(
                    "{n_joints} joints: a model has {MIN_JOINTS} to {MAX_JOINTS} [[joint]] tables"
                ),
            });
        }
        let lay = self.layout();
        if self.params.len() != lay.n_params() || self.limits_deg.len() != n_joints {
            return Err(InvalidField {
                field: "joint".into(),
                message: format!(
                    "{} parameters and {} limits for {n_joints} joints (expected {} and \
                     {n_joints})",
                    self.params.len(),
                    self.limits_deg.len(),
                    lay.n_params()
                ),
            });
        }
        if let Uncertainty::Covariance(c) = &self.uncertainty {
            if c.space().joints() != n_joints {
                return Err(InvalidField {
                    field: "covariance.matrix".into(),
                    message: format!(
                        "covers the inputs of {} joints, the model has {n_joints}",
                        c.space().joints()
                    ),
                });
            }
        }
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
        for j in 0..n_joints {
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
            Uncertainty::Covariance(cov) => {
                let (space, c) = (cov.space(), cov.matrix());
                check_covariance(c, &self.fixed)?;
                check_sigmas(&self.param_sigmas(), &self.fixed)?;
                let n = space.len();
                if let Some(r) = space.range(Block::Tool) {
                    let diag: [f64; 3] = std::array::from_fn(|k| c[(r.start + k) * (n + 1)].sqrt());
                    check_tool_sigma(&diag)?;
                    for (k, (&d, &t)) in diag.iter().zip(&self.tool_sigma).enumerate() {
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
                let robot = self.robot_inputs();
                let mut free: Vec<usize> = self
                    .free_inputs()
                    .into_iter()
                    .filter_map(|i| space.position_of(robot, i))
                    .collect();
                for i in space.range(Block::Placement).into_iter().flatten() {
                    let v = c[i * n + i];
                    if v > 0.0 {
                        let (max, unit) = match space.quantity(i) {
                            Quantity::Length => (MAX_SIGMA_MM, "mm"),
                            Quantity::Angle => (MAX_SIGMA_DEG.to_radians(), "rad"),
                        };
                        check_magnitude(&input_field(space, i), v.sqrt(), max, unit)?;
                        free.push(i);
                    }
                }
                check_positive_definite(space, c, n, &free)
            }
        }
    }
}

/// Input `i` of `space` as the file names it: `joint[2].d`, `tool[0]`, or the covariance's row
/// for the placement.
fn input_field(space: InputSpace, i: usize) -> String {
    match space.locate(i) {
        (Block::Joints, k) => format!("{}.{}", joint_field(param_joint(k)), param_kind(k).name()),
        (Block::Tool, k) => format!("tool[{k}]"),
        (Block::Placement, _) => format!("covariance.matrix[{}] ({})", i + 1, space.name(i)),
    }
}

/// `joint[n]` with the 1-based joint number of 0-based `j`.
pub(super) fn joint_field(j: usize) -> String {
    format!("joint[{}]", j + 1)
}

/// A value as the file would show it: rounded to 12 significant digits, which undoes the
/// degree/radian round trip, in exponent form when large.
fn show(v: f64) -> String {
    let r: f64 = format!("{v:.12e}").parse().unwrap_or(v);
    if r.abs() >= 1e7 {
        crate::number::fmt_plain(r)
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
pub(super) fn check_sigmas(s: &[f64], fixed: &[FixedParam]) -> Result<(), InvalidField> {
    if s.len() != PARAMS_PER_JOINT * fixed.len() {
        return Err(InvalidField {
            field: "joint".into(),
            message: format!(
                "{} standard deviations for {} joints (expected {})",
                s.len(),
                fixed.len(),
                PARAMS_PER_JOINT * fixed.len()
            ),
        });
    }
    for j in 0..fixed.len() {
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

/// Tool standard deviations (mm): finite, ≥ 0, at most [`MAX_SIGMA_MM`].
pub(super) fn check_tool_sigma(s: &[f64; 3]) -> Result<(), InvalidField> {
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
fn check_covariance(c: &[f64], fixed: &[FixedParam]) -> Result<(), InvalidField> {
    let cell = |i: usize, k: usize| format!("covariance.matrix[{}][{}]", i + 1, k + 1);
    let n = (c.len() as f64).sqrt().round() as usize;
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
fn check_positive_definite(
    space: InputSpace,
    c: &[f64],
    n: usize,
    free: &[usize],
) -> Result<(), InvalidField> {
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
            input_field(space, i)
        ),
    })
}
