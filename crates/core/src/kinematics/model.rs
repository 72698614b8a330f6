//! The robot model: 5 MDH parameters per joint (4 to 7 joints), which of `d`/`β` is fixed per
//! joint, joint limits, the tool point and the parameter uncertainty. Its TOML file format is in `file`, the checks of
//! its values in `check`.

use super::index::{FixedParam, Inputs, Joints, Layout, Params, BASE_COORDS, MAX_JOINTS};

/// Joint limits in degrees, `(min, max)`, one per joint.
pub type Limits = super::Capped<(f64, f64), MAX_JOINTS>;
/// Which of `d`/`β` each joint keeps fixed.
pub type FixedParams = super::Capped<FixedParam, MAX_JOINTS>;

/// Spread of the parameters about their values (internal units: mm, rad). The tool point's
/// spread is [`RobotModel::tool_sigma`], except with a covariance that includes the tool point
/// ([`Layout::n_uncertain`] rows), which covers it.
#[derive(Clone, Debug, PartialEq)]
#[allow(clippy::large_enum_variant)] // one per model; boxing buys nothing
pub enum Uncertainty {
    /// Independent normals with these standard deviations (0 = exactly known), one per
    /// parameter.
    Independent(Params),
    /// Full covariance, row-major, of either the parameters (the tool's spread is then
    /// [`RobotModel::tool_sigma`], independent of them; 30 × 30 for six joints), the
    /// parameters and then the tool's x, y, z in mm ([`Layout::n_uncertain`], 33 × 33), or
    /// those and then the placement's x, y, z in mm and roll, pitch, yaw in rad, as identified
    /// from data in a tracker frame ([`Layout::n_with_base`], 39 × 39).
    Covariance(Vec<f64>),
}

impl Uncertainty {
    /// Rows of the covariance (the number of parameters for independent σ).
    pub fn dim(&self) -> usize {
        match self {
            Self::Independent(s) => s.len(),
            Self::Covariance(c) => {
                let n = (c.len() as f64).sqrt().round() as usize;
                debug_assert_eq!(n * n, c.len());
                n
            }
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
        let s = self.input_sigmas();
        let lay = self.layout();
        let t = &s[lay.n_params()..];
        // Four significant digits: σ is an uncertainty, its 17th digit says nothing.
        let g = |v: f64| format!("{v:.4e}").parse::<f64>().unwrap_or(v);
        vec![format!(
            "tool point uncertain: σ = ({}, {}, {}) mm{}",
            g(t[0]),
            g(t[1]),
            g(t[2]),
            match self.uncertainty.dim() {
                n if n == lay.n_uncertain() => {
                    format!(", correlated with the parameters ({n} × {n} covariance)")
                }
                n if n == lay.n_with_base() => format!(
                    ", correlated with the parameters and the base placement ({n} × {n} covariance)"
                ),
                _ => String::new(),
            }
        )]
    }

    /// Tool-point position (mm) at joint angles `q` (radians) in the description's frame: the
    /// MDH chain's [`super::position`], then the [`RobotModel::base`] transform.
    pub fn world_position(&self, q: &[f64]) -> [f64; 3] {
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

    /// Standard deviations of all [`Layout::n_uncertain`] inputs: the parameters, then the
    /// tool.
    pub fn input_sigmas(&self) -> Inputs {
        let p = self.param_sigmas();
        let np = p.len();
        Inputs::from_fn(self.layout().n_uncertain(), |i| {
            if i < np {
                p[i]
            } else {
                self.tool_sigma[i - np]
            }
        })
    }

    /// Indices (of the [`Layout::n_uncertain`] inputs) with nonzero spread:
    /// [`Self::free_params`], then the uncertain tool coordinates.
    pub fn free_inputs(&self) -> Vec<usize> {
        let s = self.input_sigmas();
        (0..s.len()).filter(|&i| s[i] > 0.0).collect()
    }

    /// The covariance of all [`Layout::n_uncertain`] inputs, row-major, for a correlated model
    /// (a matrix of the parameters alone is extended by the independent tool variances
    /// `tool_sigma²`, one with the placement cut to its first rows); `None` for independent σ.
    pub fn full_covariance(&self) -> Option<Vec<f64>> {
        match &self.uncertainty {
            Uncertainty::Independent(_) => None,
            Uncertainty::Covariance(_) => {
                let nu = self.layout().n_uncertain();
                let np = self.layout().n_params();
                let n = self.uncertainty.dim().min(nu);
                let mut c = vec![0.0; nu * nu];
                for i in 0..nu {
                    for k in 0..nu {
                        c[i * nu + k] = if i < n && k < n {
                            self.uncertainty.entry(i, k)
                        } else if i == k {
                            self.tool_sigma[i - np].powi(2)
                        } else {
                            0.0
                        };
                    }
                }
                Some(c)
            }
        }
    }

    /// Standard deviations of the placement (x, y, z mm; roll, pitch, yaw rad): the last six
    /// diagonal entries of a covariance with the placement, else zeros.
    pub fn base_sigmas(&self) -> [f64; BASE_COORDS] {
        let lay = self.layout();
        if self.uncertainty.dim() == lay.n_with_base() {
            std::array::from_fn(|k| {
                let i = lay.base_index(k);
                self.uncertainty.entry(i, i).max(0.0).sqrt()
            })
        } else {
            [0.0; BASE_COORDS]
        }
    }

    /// Whether the placement is uncertain (some base σ > 0).
    pub fn base_uncertain(&self) -> bool {
        self.base_sigmas().iter().any(|&s| s > 0.0)
    }

    /// The model in the robot's base frame: a covariance with the placement cut to its first
    /// [`Layout::n_uncertain`] rows (the placement's spread and its correlations dropped); any
    /// other model unchanged.
    pub fn without_base_uncertainty(&self) -> RobotModel {
        let mut m = self.clone();
        let lay = self.layout();
        if let Uncertainty::Covariance(c) = &self.uncertainty {
            if self.uncertainty.dim() == lay.n_with_base() {
                let n = lay.n_uncertain();
                let nb = lay.n_with_base();
                let cut = (0..n * n).map(|x| c[(x / n) * nb + x % n]).collect();
                m.uncertainty = Uncertainty::Covariance(cut);
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

#[cfg(test)]
mod tests {
    use super::rpy_of;
    use nalgebra::{UnitQuaternion, Vector3};

    /// The angles give the rotation back to rounding, also at and near pitch ±90° (where a plain
    /// Euler extraction loses about 1e-8 rad at pitch 90° + 3.7e-6 rad, a URDF's 1.5708).
    #[test]
    fn rpy_gives_the_rotation_back_near_gimbal_lock() {
        let h = std::f64::consts::FRAC_PI_2;
        for (r, p, y) in [
            (0.0, h + 3.67e-6, 0.0),
            (0.3, h, -0.2),
            (-2.0, -h, 1.0),
            (0.1, -h + 1e-4, 3.0),
            (3.0, 0.4, -3.1),
            (std::f64::consts::PI, 0.0, 0.0),
        ] {
            let q = UnitQuaternion::from_euler_angles(r, p, y);
            let a = rpy_of(&q);
            let back = UnitQuaternion::from_euler_angles(a[0], a[1], a[2]);
            let err = (0..3)
                .map(|k| {
                    let e = Vector3::ith(k, 1.0);
                    (q * e - back * e).norm()
                })
                .fold(0.0, f64::max);
            assert!(err < 1e-15, "({r}, {p}, {y}) -> {a:?}: {err}");
        }
    }
}
