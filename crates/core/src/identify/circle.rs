//! Plane and circle fit to one joint's sweep (docs/METHOD.md §2, paper §1.3).
//!
//! Two fits, selected by [`CircleFitMethod`]:
//!
//! * [`CircleFitMethod::PointCloud`]: the classic circle-point fit. The plane comes from the SVD of
//!   the centred points (normal = the least singular vector); an algebraic (Kåsa) circle in that
//!   plane seeds a geometric (orthogonal-distance) Levenberg–Marquardt refinement of centre,
//!   normal and radius that minimises `Σ h_k² + (ρ_k − r)²` (`h` the height above the plane, `ρ`
//!   the in-plane distance from the centre). The normal is then signed by the commanded rotation
//!   sense. On a short arc the plane may tilt freely about the chord, so this fit degrades fast as
//!   the arc shrinks.
//! * [`CircleFitMethod::CommandedAngles`] (the default): uses the commanded joint angle of every
//!   point, which is known up to one constant offset: `p_k = c + r (cos q_k u + sin q_k v)` with
//!   `u ⟂ v` unit vectors and the axis `n = u × v` (so the sign of the axis is the rotation sense
//!   by construction; the offset is absorbed in `u`). The seed is the unconstrained linear least
//!   squares `p_k = c + a cos q_k + b sin q_k` (exact for noise-free data, any arc length); the
//!   refinement is Levenberg–Marquardt over `c`, the rotation `[u v n]` and `r`. Knowing where
//!   along the arc each point lies pins the plane and the centre on arcs far too short for the
//!   point cloud alone.
//!
//! Residuals are per point: the orthogonal distance to the fitted circle for the point-cloud fit,
//! the distance to the predicted point `c + r(cos q_k u + sin q_k v)` for the commanded-angle fit.
//!
//! The in-plane basis is built from the world axis least aligned with the normal, so no axis
//! direction (for example the world y axis) degenerates it.

use super::lm::levenberg_marquardt;
use nalgebra::{DMatrix, DVector, Matrix3, Rotation3, Vector3};

/// Fewest points a sweep may have.
pub const MIN_POINTS: usize = 3;
/// Shortest arc (span of the commanded angles of the swept joint) the fit accepts, degrees.
pub const MIN_ARC_DEG: f64 = 5.0;
/// Smallest circle radius accepted, mm: a target this close to the axis carries no direction.
pub const MIN_RADIUS_MM: f64 = 1.0;
/// Points whose spread off their best-fit line (relative to their spread along it) is below this
/// fraction of what an exact arc through the same commanded angles would have are collinear,
/// exactly or within their scatter: such a sweep carries no circle, whatever radius a fit returns.
pub const COLLINEAR_FRACTION: f64 = 0.1;

/// Which circle model to fit (see the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum CircleFitMethod {
    /// Plane by SVD, algebraic circle seed, geometric refinement; the commanded angles only sign
    /// the axis.
    PointCloud,
    /// Circle parametrised by the commanded joint angle (one phase offset): better conditioned
    /// on short arcs.
    #[default]
    CommandedAngles,
}

impl CircleFitMethod {
    /// Both methods, for comparisons.
    pub const ALL: [CircleFitMethod; 2] = [Self::PointCloud, Self::CommandedAngles];
    /// Name for reports.
    pub fn name(self) -> &'static str {
        match self {
            Self::PointCloud => "point-cloud",
            Self::CommandedAngles => "commanded-angles",
        }
    }
}

/// Prior knowledge of a joint axis direction (from the nominal model), added to the fit as two
/// pseudo-observations of the axis tilt, `(n·e₁, n·e₂)/σ` with `e₁, e₂ ⟂` the prior direction.
///
/// A short arc fixes the tilt of its plane about the arc's tangent only through the arc's
/// sagitta, whatever the fit: the information grows with the fourth power of the arc angle, so a
/// 13° arc with 10 µm noise leaves tilt errors of tenths of a degree, far beyond the nominal
/// geometry's own errors. The prior weighs the data by the noise estimated from the fit without
/// the prior (`σ̂² = Σ r² / (m − p)`), so on long arcs (or noise-free data) the data dominate and
/// the prior has no effect, while on short arcs the poorly determined tilt stays near nominal.
/// Opposite directions (an axis measured with the other rotation sense) disable the prior.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AxisPrior {
    /// Expected unit axis direction, signed like the fitted normal.
    pub direction: Vector3<f64>,
    /// Standard deviation of each tilt component, radians (> 0).
    pub sigma_rad: f64,
}

impl AxisPrior {
    /// The weight (mm per radian of tilt) for a fit whose residuals have scale `noise_mm`, and the
    /// basis `e₁, e₂`; `None` when the prior does not apply.
    fn weighting(
        &self,
        fitted: &Vector3<f64>,
        noise_mm: f64,
    ) -> Option<(f64, Vector3<f64>, Vector3<f64>)> {
        if self.sigma_rad.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater)
            || fitted.dot(&self.direction) <= 0.0
            || !noise_mm.is_finite()
        {
            return None;
        }
        let d = self.direction.normalize();
        let e1 = perpendicular(&d);
        let e2 = d.cross(&e1);
        Some((noise_mm / self.sigma_rad, e1, e2))
    }
}

/// Refits with the prior's pseudo-observations appended (see [`AxisPrior`]).
fn with_prior<S: Clone + Sync>(
    fitted: S,
    prior: Option<&AxisPrior>,
    normal: impl Fn(&S) -> Vector3<f64> + Sync,
    steps: &[f64],
    apply: impl Fn(&S, &[f64]) -> S + Sync,
    residuals: impl Fn(&S) -> Vec<f64> + Sync,
) -> S {
    let Some(prior) = prior else { return fitted };
    let r = residuals(&fitted);
    let dof = r.len().saturating_sub(steps.len()).max(1) as f64;
    let noise = (r.iter().map(|v| v * v).sum::<f64>() / dof).sqrt();
    let Some((w, e1, e2)) = prior.weighting(&normal(&fitted), noise) else {
        return fitted;
    };
    let extended = |s: &S| {
        let mut r = residuals(s);
        let n = normal(s);
        r.push(w * n.dot(&e1));
        r.push(w * n.dot(&e2));
        r
    };
    levenberg_marquardt(fitted, steps, apply, extended)
}

/// A fitted circle in space.
#[derive(Clone, Debug, PartialEq)]
pub struct CircleFit {
    /// Centre, mm.
    pub center: Vector3<f64>,
    /// Unit axis direction, signed so that increasing commanded angle is a positive (right-hand)
    /// rotation about it.
    pub normal: Vector3<f64>,
    /// Radius, mm.
    pub radius: f64,
    /// Per-point fit residual, mm (see the module docs), in input order.
    pub residuals: Vec<f64>,
    /// Root mean square of the residuals, mm.
    pub rms_residual: f64,
    /// Largest residual, mm.
    pub max_residual: f64,
    /// Span of the commanded angles, degrees.
    pub arc_span_deg: f64,
}

/// Why a circle could not be fitted.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CircleFitError {
    /// Fewer than [`MIN_POINTS`] points.
    #[error("only {points} points; at least {MIN_POINTS} are needed")]
    TooFewPoints {
        /// Number given.
        points: usize,
    },
    /// A coordinate or angle is NaN or infinite.
    #[error("a point or angle is not a finite number")]
    NotFinite,
    /// Points and angles differ in number.
    #[error("{points} points but {angles} angles")]
    LengthMismatch {
        /// Points given.
        points: usize,
        /// Angles given.
        angles: usize,
    },
    /// The commanded angles span less than [`MIN_ARC_DEG`].
    #[error("the arc spans {span_deg:.3} deg of commanded angle; at least MIN_ARC_DEG = {MIN_ARC_DEG} deg is needed")]
    ArcTooShort {
        /// The span, degrees.
        span_deg: f64,
    },
    /// The points lie on a line or coincide, exactly or within their scatter (see
    /// [`COLLINEAR_FRACTION`]).
    #[error("the points are collinear or coincide (their spread off a straight line is under {COLLINEAR_FRACTION} of an arc's through the same angles): the target is on the axis, the joint did not move, or the positions are not this sweep's")]
    Collinear,
    /// The fitted radius is below [`MIN_RADIUS_MM`].
    #[error("circle radius {radius_mm:.4} mm is below MIN_RADIUS_MM = {MIN_RADIUS_MM} mm: the target is too close to the axis")]
    RadiusTooSmall {
        /// The fitted radius.
        radius_mm: f64,
    },
    /// The fit produced a non-finite result.
    #[error("the circle fit did not converge")]
    NoConvergence,
}

/// A unit vector perpendicular to unit `n`, built from the world axis least aligned with `n`.
pub fn perpendicular(n: &Vector3<f64>) -> Vector3<f64> {
    let a = n.abs();
    let e = if a.x <= a.y && a.x <= a.z {
        Vector3::x()
    } else if a.y <= a.z {
        Vector3::y()
    } else {
        Vector3::z()
    };
    (e - n * n.dot(&e)).normalize()
}

/// Least-squares plane through the points: (centroid, unit normal, singular values descending).
/// The normal's sign is arbitrary.
pub fn fit_plane(points: &[Vector3<f64>]) -> (Vector3<f64>, Vector3<f64>, [f64; 3]) {
    let n = points.len().max(1) as f64;
    let centroid = points.iter().fold(Vector3::zeros(), |s, p| s + p) / n;
    let mut m = DMatrix::<f64>::zeros(points.len(), 3);
    for (k, p) in points.iter().enumerate() {
        let d = p - centroid;
        m[(k, 0)] = d.x;
        m[(k, 1)] = d.y;
        m[(k, 2)] = d.z;
    }
    // Scatter matrix eigen-decomposition is enough for a 3×3 and always has 3 values.
    let s: Matrix3<f64> = {
        let mt = m.transpose() * &m;
        Matrix3::from_fn(|i, j| mt[(i, j)])
    };
    let eig = s.symmetric_eigen();
    let mut idx = [0usize, 1, 2];
    idx.sort_by(|&a, &b| eig.eigenvalues[b].total_cmp(&eig.eigenvalues[a]));
    let sv = idx.map(|i| eig.eigenvalues[i].max(0.0).sqrt());
    let normal = eig.eigenvectors.column(idx[2]).into_owned().normalize();
    (centroid, normal, sv)
}

/// Fits a circle to `points` swept at commanded angles `angles_rad` (same order) by `method`.
///
/// With a `prior`, the axis direction is also pulled towards [`AxisPrior::direction`] (see
/// there); without one the fit uses the points and angles alone.
///
/// # Errors
///
/// [`CircleFitError::LengthMismatch`] when points and angles differ in number,
/// [`CircleFitError::TooFewPoints`] below [`MIN_POINTS`], [`CircleFitError::NotFinite`] for a NaN
/// or infinite coordinate or angle, [`CircleFitError::ArcTooShort`] when the commanded angles span
/// less than [`MIN_ARC_DEG`], [`CircleFitError::Collinear`] when the points lie on a line or
/// coincide, [`CircleFitError::NoConvergence`] when the fit gives a non-finite result, and
/// [`CircleFitError::RadiusTooSmall`] below [`MIN_RADIUS_MM`].
pub fn fit_circle(
    points: &[Vector3<f64>],
    angles_rad: &[f64],
    method: CircleFitMethod,
    prior: Option<&AxisPrior>,
) -> Result<CircleFit, CircleFitError> {
    if points.len() != angles_rad.len() {
        return Err(CircleFitError::LengthMismatch {
            points: points.len(),
            angles: angles_rad.len(),
        });
    }
    if points.len() < MIN_POINTS {
        return Err(CircleFitError::TooFewPoints {
            points: points.len(),
        });
    }
    if !points.iter().all(|p| p.iter().all(|v| v.is_finite()))
        || !angles_rad.iter().all(|q| q.is_finite())
    {
        return Err(CircleFitError::NotFinite);
    }
    let (qmin, qmax) = angles_rad
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &q| {
            (a.min(q), b.max(q))
        });
    let arc_span_deg = (qmax - qmin).to_degrees();
    if arc_span_deg < MIN_ARC_DEG {
        return Err(CircleFitError::ArcTooShort {
            span_deg: arc_span_deg,
        });
    }
    let (centroid, plane_normal, sv) = fit_plane(points);
    let scale = points
        .iter()
        .map(|p| (p - centroid).norm())
        .fold(0.0, f64::max);
    // The shape of an exact arc through these angles, on the unit circle: the ratio of the
    // spreads across and along the best-fit line does not depend on the radius or position.
    let unit_arc: Vec<Vector3<f64>> = angles_rad
        .iter()
        .map(|q| Vector3::new(q.cos(), q.sin(), 0.0))
        .collect();
    let (_, _, sv_arc) = fit_plane(&unit_arc);
    if scale < 1e-9 || sv[1] <= COLLINEAR_FRACTION * sv[0] * sv_arc[1] / sv_arc[0] {
        return Err(CircleFitError::Collinear);
    }
    let (center, normal, radius, residuals) = match method {
        CircleFitMethod::PointCloud => {
            point_cloud(points, angles_rad, centroid, plane_normal, prior)?
        }
        CircleFitMethod::CommandedAngles => commanded(points, angles_rad, prior)?,
    };
    if !(radius.is_finite() && center.iter().all(|v| v.is_finite())) {
        return Err(CircleFitError::NoConvergence);
    }
    if radius < MIN_RADIUS_MM {
        return Err(CircleFitError::RadiusTooSmall { radius_mm: radius });
    }
    let rms_residual =
        (residuals.iter().map(|r| r * r).sum::<f64>() / residuals.len() as f64).sqrt();
    let max_residual = residuals.iter().fold(0.0, |m: f64, &r| m.max(r));
    Ok(CircleFit {
        center,
        normal,
        radius,
        residuals,
        rms_residual,
        max_residual,
        arc_span_deg,
    })
}

type Fit = (Vector3<f64>, Vector3<f64>, f64, Vec<f64>);

fn point_cloud(
    points: &[Vector3<f64>],
    angles: &[f64],
    centroid: Vector3<f64>,
    plane_normal: Vector3<f64>,
    prior: Option<&AxisPrior>,
) -> Result<Fit, CircleFitError> {
    // Algebraic (Kåsa) circle in the plane: x² + y² + D x + E y + F = 0.
    let u = perpendicular(&plane_normal);
    let v = plane_normal.cross(&u);
    let n = points.len();
    let mut a = DMatrix::<f64>::zeros(n, 3);
    let mut b = DVector::<f64>::zeros(n);
    for (k, p) in points.iter().enumerate() {
        let d = p - centroid;
        let (x, y) = (d.dot(&u), d.dot(&v));
        a[(k, 0)] = x;
        a[(k, 1)] = y;
        a[(k, 2)] = 1.0;
        b[k] = -(x * x + y * y);
    }
    let sol = a
        .svd(true, true)
        .solve(&b, 1e-14)
        .map_err(|_| CircleFitError::NoConvergence)?;
    let (cx, cy) = (-sol[0] / 2.0, -sol[1] / 2.0);
    let r2 = cx * cx + cy * cy - sol[2];
    if !(r2.is_finite() && r2 > 0.0) {
        return Err(CircleFitError::Collinear);
    }
    let seed = CloudState {
        c: centroid + u * cx + v * cy,
        n: plane_normal,
        r: r2.sqrt(),
    };
    let residuals = |s: &CloudState| -> Vec<f64> {
        let mut out = Vec::with_capacity(2 * points.len());
        for p in points {
            let w = p - s.c;
            let h = w.dot(&s.n);
            let rho = (w - s.n * h).norm();
            out.push(h);
            out.push(rho - s.r);
        }
        out
    };
    let apply = |s: &CloudState, d: &[f64]| -> CloudState {
        let e1 = perpendicular(&s.n);
        let e2 = s.n.cross(&e1);
        CloudState {
            c: s.c + Vector3::new(d[0], d[1], d[2]),
            n: (s.n + e1 * d[3] + e2 * d[4]).normalize(),
            r: s.r + d[5],
        }
    };
    let steps = [1e-5, 1e-5, 1e-5, 1e-8, 1e-8, 1e-5];
    let mut s = levenberg_marquardt(seed, &steps, apply, residuals);
    // Sign the normal by the commanded rotation sense.
    let mut turn = 0.0;
    for k in 1..points.len() {
        let t = (points[k - 1] - s.c).cross(&(points[k] - s.c)).dot(&s.n);
        turn += t * (angles[k] - angles[k - 1]).signum();
    }
    if turn < 0.0 {
        s.n = -s.n;
    }
    let s = with_prior(s, prior, |s| s.n, &steps, apply, residuals);
    let normal = s.n;
    let res = points
        .iter()
        .map(|p| {
            let w = p - s.c;
            let h = w.dot(&s.n);
            let rho = (w - s.n * h).norm();
            h.hypot(rho - s.r)
        })
        .collect();
    Ok((s.c, normal, s.r, res))
}

#[derive(Clone)]
struct CloudState {
    c: Vector3<f64>,
    n: Vector3<f64>,
    r: f64,
}

#[derive(Clone)]
struct CommandedState {
    c: Vector3<f64>,
    /// Columns u, v, n.
    rot: Rotation3<f64>,
    r: f64,
}

fn commanded(
    points: &[Vector3<f64>],
    angles: &[f64],
    prior: Option<&AxisPrior>,
) -> Result<Fit, CircleFitError> {
    // Linear seed: p = c + a cos q + b sin q, per coordinate. Angles are taken relative to their
    // mean for conditioning and restored below.
    let n = points.len();
    let q0 = angles.iter().sum::<f64>() / n as f64;
    let mut m = DMatrix::<f64>::zeros(n, 3);
    let mut rhs = DMatrix::<f64>::zeros(n, 3);
    for (k, (p, q)) in points.iter().zip(angles).enumerate() {
        let (s, c) = (q - q0).sin_cos();
        m[(k, 0)] = 1.0;
        m[(k, 1)] = c;
        m[(k, 2)] = s;
        for j in 0..3 {
            rhs[(k, j)] = p[j];
        }
    }
    let sol = m
        .svd(true, true)
        .solve(&rhs, 1e-15)
        .map_err(|_| CircleFitError::NoConvergence)?;
    let c = Vector3::new(sol[(0, 0)], sol[(0, 1)], sol[(0, 2)]);
    let a = Vector3::new(sol[(1, 0)], sol[(1, 1)], sol[(1, 2)]);
    let b = Vector3::new(sol[(2, 0)], sol[(2, 1)], sol[(2, 2)]);
    let axis = a.cross(&b);
    if !(axis.norm() > 0.0 && axis.norm().is_finite()) {
        return Err(CircleFitError::Collinear);
    }
    let nn = axis.normalize();
    let u = a.normalize();
    let v = nn.cross(&u);
    let seed = CommandedState {
        c,
        rot: Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[u, v, nn])),
        r: (a.norm() + b.norm()) / 2.0,
    };
    let model = |s: &CommandedState, q: f64| -> Vector3<f64> {
        let (sn, cs) = (q - q0).sin_cos();
        s.c + s.rot * Vector3::new(s.r * cs, s.r * sn, 0.0)
    };
    let residuals = |s: &CommandedState| -> Vec<f64> {
        let mut out = Vec::with_capacity(3 * n);
        for (p, &q) in points.iter().zip(angles) {
            let d = p - model(s, q);
            out.extend_from_slice(d.as_slice());
        }
        out
    };
    let apply = |s: &CommandedState, d: &[f64]| -> CommandedState {
        CommandedState {
            c: s.c + Vector3::new(d[0], d[1], d[2]),
            rot: s.rot * Rotation3::new(Vector3::new(d[3], d[4], d[5])),
            r: s.r + d[6],
        }
    };
    let steps = [1e-5, 1e-5, 1e-5, 1e-8, 1e-8, 1e-8, 1e-5];
    let s = levenberg_marquardt(seed, &steps, apply, residuals);
    let s = with_prior(s, prior, |s| s.rot * Vector3::z(), &steps, apply, residuals);
    let res = points
        .iter()
        .zip(angles)
        .map(|(p, &q)| (p - model(&s, q)).norm())
        .collect();
    let normal = s.rot * Vector3::z();
    Ok((s.c, normal, s.r, res))
}

#[cfg(test)]
mod tests;
