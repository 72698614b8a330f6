//! The robot model: 5 MDH parameters per joint (4 to 7 joints), which of `d`/`β` is fixed per
//! joint, joint limits, the tool point and the parameter uncertainty. Its TOML file format is in `file`, the checks of
//! its values in `check`.

use super::index::{FixedParam, Inputs, Joints, Layout, Params, MAX_JOINTS};
use super::inputs::{Block, InputSpace};

/// Joint limits in degrees, `(min, max)`, one per joint.
pub type Limits = super::Capped<(f64, f64), MAX_JOINTS>;
/// Which of `d`/`β` each joint keeps fixed.
pub type FixedParams = super::Capped<FixedParam, MAX_JOINTS>;

/// A covariance over the inputs of an [`InputSpace`]: the blocks it covers travel with the
/// matrix, so no reader infers them from its size.
///
/// # Examples
///
/// ```
/// use gpu_amcs_core::kinematics::{Block, Covariance, InputSpace};
///
/// let space = InputSpace::parameters(4); // 20 parameters of a four-joint arm
/// let mut m = vec![0.0; 20 * 20];
/// for i in 0..20 {
///     m[i * 21] = 1e-4;
/// }
/// let c = Covariance::new(space, m).unwrap();
/// assert_eq!(c.dim(), 20);
/// // The same covariance over the parameters and the tool (23 inputs), the tool's variances
/// // given independently:
/// let full = c.in_space(InputSpace::robot(4), |_| 0.25);
/// assert_eq!(full[20 * 23 + 20], 0.25);
/// assert_eq!(full[19 * 23 + 19], 1e-4);
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct Covariance {
    space: InputSpace,
    /// Row-major `space.len()²`, internal units (mm, rad).
    matrix: Vec<f64>,
}

impl Covariance {
    /// The covariance `matrix` (row-major, internal units) of the inputs of `space`, or `None`
    /// when it does not have `space.len()²` entries.
    pub fn new(space: InputSpace, matrix: Vec<f64>) -> Option<Covariance> {
        (matrix.len() == space.len() * space.len()).then_some(Covariance { space, matrix })
    }

    /// The inputs the matrix covers.
    pub fn space(&self) -> InputSpace {
        self.space
    }

    /// The row-major matrix, internal units.
    pub fn matrix(&self) -> &[f64] {
        &self.matrix
    }

    /// Rows of the matrix.
    pub fn dim(&self) -> usize {
        self.space.len()
    }

    /// Entry `(i, k)`, positions of [`Covariance::space`].
    pub fn entry(&self, i: usize, k: usize) -> f64 {
        self.matrix[i * self.dim() + k]
    }

    /// The covariance of the inputs of `target` (same joint count), row-major: the entries of the
    /// inputs this one covers, independent variances `variance(i)` (position `i` of `target`) on
    /// the diagonal of the others, zero elsewhere.
    pub fn in_space(&self, target: InputSpace, variance: impl Fn(usize) -> f64) -> Vec<f64> {
        let n = target.len();
        let at: Vec<Option<usize>> = (0..n).map(|i| self.space.position_of(target, i)).collect();
        let mut c = vec![0.0; n * n];
        for i in 0..n {
            for k in 0..n {
                c[i * n + k] = match (at[i], at[k]) {
                    (Some(a), Some(b)) => self.entry(a, b),
                    _ if i == k => variance(i),
                    _ => 0.0,
                };
            }
        }
        c
    }

    /// The marginal covariance of the blocks of `target` this one covers (rows and columns of
    /// the other blocks dropped).
    pub fn restricted(&self, target: InputSpace) -> Covariance {
        let kept: Vec<Block> = target.blocks().filter(|b| self.space.has(*b)).collect();
        let space = InputSpace::new(self.space.joints(), &kept)
            .expect("a subset of a space's blocks keeps their order");
        let matrix = self.in_space(space, |_| 0.0);
        Covariance { space, matrix }
    }
}

/// Spread of the inputs about their values (internal units: mm, rad). The tool point's
/// spread is [`RobotModel::tool_sigma`], except with a covariance that covers the tool block.
#[derive(Clone, Debug, PartialEq)]
#[allow(clippy::large_enum_variant)] // one per model; boxing buys nothing
pub enum Uncertainty {
    /// Independent normals with these standard deviations (0 = exactly known), one per
    /// parameter.
    Independent(Params),
    /// Full covariance of the blocks it names: the parameters (the tool's spread is then
    /// [`RobotModel::tool_sigma`], independent of them), optionally the tool's x, y, z, and the
    /// placement, as identified from data in a tracker frame ([`InputSpace::measured`]).
    Covariance(Covariance),
}

impl Uncertainty {
    /// The covariance `matrix` (row-major, internal units) of the inputs of `space`.
    ///
    /// # Panics
    ///
    /// When `matrix` does not have `space.len()²` entries (a caller's mistake; a file's matrix is
    /// checked when read).
    pub fn from_matrix(space: InputSpace, matrix: Vec<f64>) -> Uncertainty {
        let n = matrix.len();
        Uncertainty::Covariance(Covariance::new(space, matrix).unwrap_or_else(|| {
            panic!(
                "a covariance of {n} entries for the {} inputs of [{}]",
                space.len(),
                space.block_names().join(", ")
            )
        }))
    }

    /// Rows of the covariance (the number of parameters for independent σ).
    pub fn dim(&self) -> usize {
        match self {
            Self::Independent(s) => s.len(),
            Self::Covariance(c) => c.dim(),
        }
    }

    /// The covariance, for a correlated model.
    pub fn covariance(&self) -> Option<&Covariance> {
        match self {
            Self::Independent(_) => None,
            Self::Covariance(c) => Some(c),
        }
    }

    /// Whether the uncertainty covers `block` with its own entries (independent σ cover the
    /// parameters only).
    pub fn covers(&self, block: Block) -> bool {
        match self {
            Self::Independent(_) => block == Block::Joints,
            Self::Covariance(c) => c.space().has(block),
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
            Self::Covariance(c) => c.entry(i, k),
        }
    }

    /// Standard deviation of each of the `n_params` parameters (the covariance's diagonal,
    /// square-rooted).
    pub fn sigmas(&self, n_params: usize) -> Params {
        match self {
            Self::Independent(s) => *s,
            Self::Covariance(_) => Params::from_fn(n_params, |i| self.entry(i, i).max(0.0).sqrt()),
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

/// Roll, pitch, yaw (radians) of a rotation, `R = Rz(yaw)·Ry(pitch)·Rx(roll)`, accurate to
/// rounding near pitch ±90° too: the pitch from `atan2` (not `asin`) and, of roll and yaw, the
/// combination that fixes the rotation there (yaw − roll at +90°, yaw + roll at −90°) from
/// entries that stay large, so that the rotation the angles give back differs from `rotation`
/// by rounding only (a plain Euler extraction loses up to about 1e-8 rad near ±90°).
pub fn rpy_of(rotation: &nalgebra::UnitQuaternion<f64>) -> [f64; 3] {
    let m = rotation.to_rotation_matrix();
    let r = |a: usize, b: usize| m[(a, b)];
    let pitch = (-r(2, 0)).atan2(r(0, 0).hypot(r(1, 0)));
    let yaw = r(1, 0).atan2(r(0, 0));
    let roll = if pitch >= 0.0 {
        // (1 + sin p)·(sin, cos)(yaw − roll)
        yaw - (r(1, 2) - r(0, 1)).atan2(r(0, 2) + r(1, 1))
    } else {
        // (1 − sin p)·(sin, cos)(yaw + roll)
        (-(r(1, 2) + r(0, 1))).atan2(-(r(0, 2) - r(1, 1))) - yaw
    };
    // Into (−π, π].
    let tau = std::f64::consts::TAU;
    let roll = roll - tau * ((roll + std::f64::consts::PI) / tau).ceil() + tau;
    [roll, pitch, yaw]
}

/// A robot model: parameter values (the calibrated means), structure, limits, tool and spread.
#[derive(Clone, Debug, PartialEq)]
pub struct RobotModel {
    /// Name shown in reports.
    pub name: String,
    /// The `5n` parameters, joint-major `[θ, d, a, α, β]`, mm and radians.
    pub params: Params,
    /// Per joint, which of d / β is fixed.
    pub fixed: FixedParams,
    /// Joint limits in degrees, `(min, max)`, one per joint.
    pub limits_deg: Limits,
    /// Tracker target in the flange frame, mm.
    pub tool: [f64; 3],
    /// Standard deviation of the tool point's coordinates in the flange frame, mm (0 = exactly
    /// known), independent of the parameters. With a covariance that includes the tool it
    /// equals the square roots of the tool's diagonal entries ([`RobotModel::check`] says so).
    pub tool_sigma: [f64; 3],
    /// Parameter uncertainty.
    pub uncertainty: Uncertainty,
    /// Placement of the base frame in the description's frame; `None` = identity.
    pub base: Option<BaseTransform>,
    /// What the geometric model does not explain, from an identification's residuals: drawn at
    /// every test point by every analysis ([`crate::discrepancy`]); `None` for a model without
    /// a lack of fit found (presets, design models, fits that explain the data).
    pub discrepancy: Option<crate::discrepancy::Discrepancy>,
    /// Joint compliance and gear harmonics beyond the geometry, from an identification that
    /// kept them ([`super::JointErrors`], docs/METHOD.md §19); `None` for a geometric model.
    pub joint_errors: Option<super::JointErrors>,
    /// The masses and centres of mass of the moving links, when known (imported from a
    /// description's `<inertial>` data; else joint compliance assumes
    /// [`super::gravity::default_link_masses`]).
    pub links: Option<super::gravity::LinkMasses>,
}

impl RobotModel {
    /// Number of joints.
    pub fn joints(&self) -> usize {
        self.fixed.len()
    }

    /// How the inputs of this model's draws are laid out.
    pub fn layout(&self) -> Layout {
        Layout::new(self.joints())
    }

    /// A configuration of this model with every joint at `value` (radians or degrees, as the
    /// caller uses).
    pub fn joints_at(&self, value: f64) -> Joints {
        Joints::filled(self.joints(), value)
    }

    /// Standard deviation of each parameter ([`Uncertainty::sigmas`]).
    pub fn param_sigmas(&self) -> Params {
        self.uncertainty.sigmas(self.params.len())
    }

    /// Where the base frame's origin lies in the description's frame, mm (the origin itself
    /// without a [`RobotModel::base`]).
    pub fn base_origin_mm(&self) -> [f64; 3] {
        self.base.map_or([0.0; 3], |b| b.xyz)
    }

    /// The note for a model without any spread (every σ of the parameters, the tool and the
    /// placement 0, as in an imported description or a preset from a published table): its
    /// draws all equal the calibrated model, so w = 0 and R = 1 at every threshold say nothing
    /// about the robot. `None` when some input is uncertain.
    pub fn no_uncertainty_note(&self) -> Option<String> {
        let base = self.base_sigmas().iter().any(|&s| s > 0.0);
        (self.free_inputs().is_empty() && !base).then(|| {
            format!(
                "the model '{}' carries no uncertainty (every σ is 0, as in an imported description or a published table): every draw is the model itself, so w = 0 and R = 1 say nothing about the robot; identify it from measurements or give σ in the model file",
                self.name
            )
        })
    }

    /// What a report should say about the analysed model beyond its name: that it has no
    /// spread at all ([`RobotModel::no_uncertainty_note`]), or an uncertain tool point (its σ
    /// enters every draw, docs/METHOD.md §14).
    pub fn report_notes(&self) -> Vec<String> {
        if let Some(n) = self.no_uncertainty_note() {
            return vec![n];
        }
        if !self.tool_uncertain() {
            return Vec::new();
        }
        let t = self.tool_sigma;
        // Four significant digits: σ is an uncertainty, its 17th digit says nothing.
        let g = |v: f64| format!("{v:.4e}").parse::<f64>().unwrap_or(v);
        vec![format!(
            "tool point uncertain: σ = ({}, {}, {}) mm{}",
            g(t[0]),
            g(t[1]),
            g(t[2]),
            match self.uncertainty.covariance().map(Covariance::space) {
                Some(c) if c.has(Block::Tool) && c.has(Block::Placement) => format!(
                    ", correlated with the parameters and the base placement ({n} × {n} covariance)",
                    n = c.len()
                ),
                Some(c) if c.has(Block::Tool) => format!(
                    ", correlated with the parameters ({n} × {n} covariance)",
                    n = c.len()
                ),
                _ => String::new(),
            }
        )]
    }

    /// Whether the model carries a compensation ([`crate::discrepancy::Compensation`]).
    pub fn compensated(&self) -> bool {
        self.discrepancy
            .as_ref()
            .is_some_and(|d| d.compensation.is_some())
    }

    /// The tool point's standard deviations, mm ([`RobotModel::tool_sigma`]).
    pub fn tool_sigmas(&self) -> [f64; 3] {
        self.tool_sigma
    }

    /// Whether the tool point is uncertain (some tool σ > 0).
    pub fn tool_uncertain(&self) -> bool {
        self.tool_sigma.iter().any(|&s| s > 0.0)
    }

    /// The inputs a draw of this model perturbs in the robot's base frame: the parameters and
    /// the tool point ([`InputSpace::robot`]).
    pub fn robot_inputs(&self) -> InputSpace {
        InputSpace::robot(self.joints())
    }

    /// The inputs a draw perturbs in the measurement frame: [`Self::robot_inputs`], with the
    /// placement when the uncertainty covers it.
    pub fn drawn_inputs(&self) -> InputSpace {
        if self.uncertainty.covers(Block::Placement) {
            self.robot_inputs().with(Block::Placement)
        } else {
            self.robot_inputs()
        }
    }

    /// Makes `c` the model's uncertainty. A covariance that covers the tool carries the tool's
    /// spread: `tool_sigma` becomes the square roots of its tool diagonal; otherwise
    /// `tool_sigma` stays the tool's independent spread.
    pub fn set_covariance(&mut self, c: Covariance) {
        if let Some(r) = c.space().range(Block::Tool) {
            self.tool_sigma =
                std::array::from_fn(|k| c.entry(r.start + k, r.start + k).max(0.0).sqrt());
        }
        self.uncertainty = Uncertainty::Covariance(c);
    }

    /// Standard deviations of the [`Self::robot_inputs`]: the parameters, then the tool.
    pub fn input_sigmas(&self) -> Inputs {
        let p = self.param_sigmas();
        let space = self.robot_inputs();
        Inputs::from_fn(space.len(), |i| match space.locate(i) {
            (Block::Tool, k) => self.tool_sigma[k],
            _ => p[i],
        })
    }

    /// Indices (of the [`Self::robot_inputs`]) with nonzero spread: [`Self::free_params`], then
    /// the uncertain tool coordinates.
    pub fn free_inputs(&self) -> Vec<usize> {
        let s = self.input_sigmas();
        (0..s.len()).filter(|&i| s[i] > 0.0).collect()
    }

    /// The covariance of the inputs of `space` (row-major, internal units): the model's own
    /// entries where its covariance covers a block, independent variances elsewhere (the
    /// parameters' σ², the tool's `tool_sigma²`, zero for a placement it does not cover).
    pub fn covariance_in(&self, space: InputSpace) -> Vec<f64> {
        let variance = |i: usize| match space.locate(i) {
            (Block::Joints, k) => self.uncertainty.entry(k, k),
            (Block::Tool, k) => self.tool_sigma[k].powi(2),
            (Block::Placement, _) => 0.0,
        };
        match &self.uncertainty {
            Uncertainty::Covariance(c) => c.in_space(space, variance),
            Uncertainty::Independent(_) => {
                let n = space.len();
                let mut c = vec![0.0; n * n];
                for i in 0..n {
                    c[i * n + i] = variance(i);
                }
                c
            }
        }
    }

    /// The covariance of the [`Self::robot_inputs`], row-major, for a correlated model (a
    /// matrix of the parameters alone is extended by the independent tool variances
    /// `tool_sigma²`, one with the placement cut to its marginal); `None` for independent σ.
    pub fn full_covariance(&self) -> Option<Vec<f64>> {
        self.uncertainty
            .covariance()
            .map(|_| self.covariance_in(self.robot_inputs()))
    }

    /// Standard deviations of the placement (x, y, z mm; roll, pitch, yaw rad): the diagonal of
    /// a covariance that covers the placement, else zeros.
    pub fn base_sigmas(&self) -> [f64; 6] {
        match self.uncertainty.covariance() {
            Some(c) if c.space().has(Block::Placement) => std::array::from_fn(|k| {
                let i = c.space().index(Block::Placement, k).unwrap_or(0);
                c.entry(i, i).max(0.0).sqrt()
            }),
            _ => [0.0; 6],
        }
    }

    /// Whether the placement is uncertain (some base σ > 0).
    pub fn base_uncertain(&self) -> bool {
        self.base_sigmas().iter().any(|&s| s > 0.0)
    }

    /// The model in the robot's base frame: a covariance with the placement cut to the
    /// marginal of its other blocks (the placement's spread and its correlations dropped); any
    /// other model unchanged.
    pub fn without_base_uncertainty(&self) -> RobotModel {
        let mut m = self.clone();
        if let Uncertainty::Covariance(c) = &self.uncertainty {
            if c.space().has(Block::Placement) {
                m.uncertainty =
                    Uncertainty::Covariance(c.restricted(c.space().without(Block::Placement)));
            }
        }
        m
    }

    /// Indices of the parameters with nonzero spread.
    pub fn free_params(&self) -> Vec<usize> {
        let s = self.param_sigmas();
        (0..s.len()).filter(|&i| s[i] > 0.0).collect()
    }

    /// Checks a joint configuration (degrees) against the limits; names the joint if outside.
    ///
    /// # Errors
    ///
    /// A message naming the first joint whose angle is not finite or lies outside its limits.
    pub fn check_limits(&self, q_deg: &[f64]) -> Result<(), String> {
        if q_deg.len() != self.joints() {
            return Err(format!(
                "has {} joint angles, the model has {} joints",
                q_deg.len(),
                self.joints()
            ));
        }
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

mod prediction;
#[cfg(test)]
mod tests;
