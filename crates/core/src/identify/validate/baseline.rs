//! The fair nominal baseline on data in a measurement (tracker) frame: the nominal geometry
//! with its own best-fit placement. The identified model's placement was fitted together with
//! the identified geometry; put under the nominal geometry it leaves the nominal model
//! millimetres off where a placement of its own would fit, and the improvement reads larger than
//! it is. So the base pose (3 rotations, 3 translations) and, when the data determine it, the
//! target on the flange (3 offsets) are re-registered for the nominal geometry by least squares
//! on the measured positions before its errors are computed.

use super::Measurement;
use crate::kinematics::{position, rpy_of, BaseTransform, RobotModel};
use nalgebra::{DMatrix, Matrix3, UnitQuaternion, Vector3};
use serde::Serialize;

/// Ratio of the smallest to the largest singular value of the column-scaled Jacobian below which
/// the target offset counts as not determined by the data (it is then held at the model's).
const DETERMINED_RATIO: f64 = 1e-6;

/// How the nominal model was placed for the comparison on measurement-frame data.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Registration {
    /// The placement found for the nominal geometry: translation (mm) and roll, pitch, yaw
    /// (degrees), `p_measured = Trans · Rz(yaw) · Ry(pitch) · Rx(roll) · p_base`.
    pub base_xyz_mm: [f64; 3],
    /// Roll, pitch, yaw, degrees.
    pub base_rpy_deg: [f64; 3],
    /// The target in the flange frame the nominal errors use, mm.
    pub tool_mm: [f64; 3],
    /// Whether the target was fitted too (else it is the validated model's: the data do not
    /// determine it).
    pub tool_fitted: bool,
    /// Quantities fitted: 6 (placement) or 9 (placement and target).
    pub parameters: usize,
}

impl Registration {
    /// The method in one sentence.
    pub fn method(&self) -> String {
        if self.tool_fitted {
            "nominal geometry with its own placement and target offset (9 quantities) fitted to \
             the measured positions by least squares"
                .into()
        } else {
            "nominal geometry with its own placement (6 quantities) fitted to the measured \
             positions by least squares; target offset the model's (not determined by the data)"
                .into()
        }
    }
}

/// A placement and target during the fit.
#[derive(Clone, Copy)]
struct State {
    rotation: UnitQuaternion<f64>,
    translation: Vector3<f64>,
    tool: [f64; 3],
}

/// The positions of `nominal`'s geometry with `state` at the measurements.
fn residuals(nominal: &RobotModel, m: &[Measurement], s: &State) -> Vec<f64> {
    let mut r = Vec::with_capacity(3 * m.len());
    for p in m {
        let q = p.q_deg.map(f64::to_radians);
        let x = Vector3::from(position(&nominal.params, &s.tool, &q));
        let w = s.rotation * x + s.translation;
        for k in 0..3 {
            r.push(w[k] - p.position_mm[k]);
        }
    }
    r
}

/// Local update: a rotation vector about the current rotation (no Euler-angle singularity),
/// a translation step, and (with 9 components) a target step.
fn apply(s: &State, d: &[f64]) -> State {
    let mut t = *s;
    t.rotation = UnitQuaternion::from_scaled_axis(Vector3::new(d[0], d[1], d[2])) * s.rotation;
    t.translation += Vector3::new(d[3], d[4], d[5]);
    if d.len() == 9 {
        for k in 0..3 {
            t.tool[k] += d[6 + k];
        }
    }
    t
}

/// Step sizes of the central differences: radians, then mm.
const STEPS: [f64; 9] = [1e-6, 1e-6, 1e-6, 1e-4, 1e-4, 1e-4, 1e-4, 1e-4, 1e-4];

/// The rigid motion (rotation, translation) that best maps points `a` onto `b` (Kabsch).
fn kabsch(a: &[Vector3<f64>], b: &[Vector3<f64>]) -> (UnitQuaternion<f64>, Vector3<f64>) {
    let n = a.len().max(1) as f64;
    let ca = a.iter().sum::<Vector3<f64>>() / n;
    let cb = b.iter().sum::<Vector3<f64>>() / n;
    let mut h = Matrix3::zeros();
    for (x, y) in a.iter().zip(b) {
        h += (x - ca) * (y - cb).transpose();
    }
    let svd = h.svd(true, true);
    let rotation = match (svd.u, svd.v_t) {
        (Some(u), Some(vt)) => {
            let v = vt.transpose();
            let sign = (v * u.transpose()).determinant().signum();
            let fix = Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, sign));
            UnitQuaternion::from_matrix(&(v * fix * u.transpose()))
        }
        _ => UnitQuaternion::identity(),
    };
    (rotation, cb - rotation * ca)
}

/// Whether the target offset is determined by `m` beside the placement: the 9-column Jacobian at
/// `s`, columns scaled to unit length, has full rank to [`DETERMINED_RATIO`].
fn tool_determined(nominal: &RobotModel, m: &[Measurement], s: &State) -> bool {
    let rows = 3 * m.len();
    if rows < 9 {
        return false;
    }
    let mut j = DMatrix::<f64>::zeros(rows, 9);
    for (col, &h) in STEPS.iter().enumerate() {
        let mut d = [0.0; 9];
        d[col] = h;
        let rp = residuals(nominal, m, &apply(s, &d));
        d[col] = -h;
        let rm = residuals(nominal, m, &apply(s, &d));
        let mut norm = 0.0;
        for row in 0..rows {
            let v = (rp[row] - rm[row]) / (2.0 * h);
            j[(row, col)] = v;
            norm += v * v;
        }
        let norm = norm.sqrt();
        if !(norm > 0.0 && norm.is_finite()) {
            return false;
        }
        for row in 0..rows {
            j[(row, col)] /= norm;
        }
    }
    let sv = j.singular_values();
    let (lo, hi) = sv.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), &v| {
        (lo.min(v), hi.max(v))
    });
    hi > 0.0 && lo / hi > DETERMINED_RATIO
}

/// `nominal` placed (and its target offset set) by least squares on `m`, starting from the
/// target `tool` (the validated model's); returns the placed model and how it was placed.
pub fn register_nominal(
    nominal: &RobotModel,
    m: &[Measurement],
    tool: [f64; 3],
) -> (RobotModel, Registration) {
    // Seed: the rigid motion that best maps the nominal positions onto the measured ones.
    let pts: Vec<Vector3<f64>> = m
        .iter()
        .map(|p| {
            Vector3::from(position(
                &nominal.params,
                &tool,
                &p.q_deg.map(f64::to_radians),
            ))
        })
        .collect();
    let meas: Vec<Vector3<f64>> = m.iter().map(|p| Vector3::from(p.position_mm)).collect();
    let (rotation, translation) = kabsch(&pts, &meas);
    let seed = State {
        rotation,
        translation,
        tool,
    };
    let cost = |r: Vec<f64>| r.iter().map(|v| v * v).sum::<f64>();
    let placed = super::super::lm::levenberg_marquardt(seed, &STEPS[..6], apply, |s| {
        residuals(nominal, m, s)
    });
    let tool_fitted = tool_determined(nominal, m, &placed);
    let mut best = placed;
    if tool_fitted {
        let full = super::super::lm::levenberg_marquardt(placed, &STEPS, apply, |s| {
            residuals(nominal, m, s)
        });
        if cost(residuals(nominal, m, &full)) <= cost(residuals(nominal, m, &placed)) {
            best = full;
        }
    }
    let mut out = nominal.clone();
    out.tool = best.tool;
    let rpy = rpy_of(&best.rotation);
    out.base = Some(BaseTransform {
        xyz: best.translation.into(),
        rpy,
    });
    let registration = Registration {
        base_xyz_mm: best.translation.into(),
        base_rpy_deg: rpy.map(f64::to_degrees),
        tool_mm: best.tool,
        tool_fitted,
        parameters: if tool_fitted { 9 } else { 6 },
    };
    (out, registration)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::{tx60, Joints};

    /// Measurements of `model` placed at `b` with target `tool` at a spread of poses.
    fn data(model: &RobotModel, b: &BaseTransform, tool: [f64; 3]) -> Vec<Measurement> {
        (0..30)
            .map(|i| {
                let f = i as f64;
                let q = Joints::from([
                    -60.0 + 4.0 * f,
                    -30.0 + 2.0 * f,
                    40.0 - 2.5 * f,
                    (7.0 * f) % 90.0 - 45.0,
                    20.0 + 1.5 * f,
                    (13.0 * f) % 120.0 - 60.0,
                ]);
                let p = position(&model.params, &tool, &q.map(f64::to_radians));
                Measurement {
                    payload_kg: None,
                    q_deg: q,
                    position_mm: b.apply(p),
                    line: i as u64 + 2,
                    target: None,
                    on_base: false,
                    sides: None,
                }
            })
            .collect()
    }

    /// Exact data of the nominal geometry in a turned, shifted frame with another target: the
    /// placement and target are found and the errors vanish, also at pitch 90°.
    #[test]
    fn finds_the_placement_and_target() {
        let nominal = tx60();
        for rpy in [[0.3, -0.2, 1.1], [0.4, std::f64::consts::FRAC_PI_2, -0.7]] {
            let b = BaseTransform {
                xyz: [1800.0, -350.0, 120.0],
                rpy,
            };
            let tool = [25.0, -15.0, 90.0];
            let m = data(&nominal, &b, tool);
            let (placed, reg) = register_nominal(&nominal, &m, [0.0, 0.0, 70.0]);
            assert!(reg.tool_fitted && reg.parameters == 9, "{reg:?}");
            for k in 0..3 {
                assert!((reg.tool_mm[k] - tool[k]).abs() < 1e-6, "{reg:?}");
                assert!((reg.base_xyz_mm[k] - b.xyz[k]).abs() < 1e-6, "{reg:?}");
            }
            let worst = m
                .iter()
                .map(|p| {
                    let x = placed.world_position(&p.q_deg.map(f64::to_radians));
                    (0..3)
                        .map(|k| (x[k] - p.position_mm[k]).powi(2))
                        .sum::<f64>()
                        .sqrt()
                })
                .fold(0.0, f64::max);
            assert!(worst < 1e-6, "{worst}");
        }
    }

    /// Poses that never turn the flange leave the target offset to the placement: it is held
    /// at the given one and said so.
    #[test]
    fn holds_an_undetermined_target() {
        let nominal = tx60();
        let b = BaseTransform {
            xyz: [1000.0, 0.0, 0.0],
            rpy: [0.0, 0.0, 0.5],
        };
        let m: Vec<Measurement> = (0..10)
            .map(|i| {
                let q = Joints::from([0.0; 6]);
                let mut p = position(&nominal.params, &[0.0; 3], &q.map(f64::to_radians));
                p[0] += i as f64 * 1e-9;
                Measurement {
                    payload_kg: None,
                    q_deg: q,
                    position_mm: b.apply(p),
                    line: i + 2,
                    target: None,
                    on_base: false,
                    sides: None,
                }
            })
            .collect();
        let (_, reg) = register_nominal(&nominal, &m, [1.0, 2.0, 3.0]);
        assert!(!reg.tool_fitted && reg.parameters == 6, "{reg:?}");
        assert_eq!(reg.tool_mm, [1.0, 2.0, 3.0]);
        assert!(reg.method().contains("not determined"));
    }
}
