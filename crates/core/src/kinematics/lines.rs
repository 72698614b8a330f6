//! Axis-line geometry: the common normal of two lines in space (docs/METHOD.md §2).
//!
//! A joint axis is a [`Line`] (a point and a unit direction). Two consecutive axes are related by
//! their common normal: the shortest segment between them, its length (the MDH `a`) and the
//! angle between the directions (the MDH `α`). [`common_normal`] classifies the pair as skew,
//! intersecting, parallel or identical and returns the feet of the normal on each line. For
//! parallel lines the common normal is not unique (any point of the first line has one); the
//! foot on the first line is then the projection of the first line's given point, which is why the
//! identification uses Hayati's `β` instead of `d` for such a pair.

use nalgebra::Vector3;

/// Below this sine of the angle between two directions the lines are treated as parallel.
pub const PARALLEL_SINE_EPS: f64 = 1e-12;
/// Below this distance (mm) two lines are treated as meeting (intersecting or identical).
pub const DISTANCE_EPS_MM: f64 = 1e-9;

/// A line through `point` with unit direction `dir`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Line {
    /// A point of the line (mm).
    pub point: Vector3<f64>,
    /// Unit direction; for a joint axis its sign is the positive rotation sense (right hand).
    pub dir: Vector3<f64>,
}

impl Line {
    /// A line through `point` along `dir` (normalised here). `None` if `dir` is zero or not
    /// finite.
    pub fn new(point: Vector3<f64>, dir: Vector3<f64>) -> Option<Self> {
        let n = dir.norm();
        if !(n.is_finite() && n > 0.0 && point.iter().all(|v| v.is_finite())) {
            return None;
        }
        Some(Line {
            point,
            dir: dir / n,
        })
    }

    /// The point of the line nearest to `p`.
    pub fn project(&self, p: &Vector3<f64>) -> Vector3<f64> {
        self.point + self.dir * (p - self.point).dot(&self.dir)
    }

    /// Distance of `p` from the line (mm).
    pub fn distance_to(&self, p: &Vector3<f64>) -> f64 {
        (p - self.project(p)).norm()
    }

    /// The line under the rigid motion `x ↦ r·x + t` (`r` a rotation matrix).
    pub fn transformed(&self, r: &nalgebra::Matrix3<f64>, t: &Vector3<f64>) -> Line {
        Line {
            point: r * self.point + t,
            dir: r * self.dir,
        }
    }
}

/// How two lines lie relative to each other.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LineRelation {
    /// Not parallel and not meeting: a unique common normal of nonzero length.
    Skew,
    /// Not parallel, meeting in one point: the common normal has zero length and its direction
    /// is the cross product of the directions.
    Intersecting,
    /// Parallel (or antiparallel) and apart: the normal direction is unique, its position is not.
    Parallel,
    /// The same line: neither the normal's direction nor its position is defined.
    Identical,
}

/// The common normal of two lines.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CommonNormal {
    /// How the lines lie.
    pub relation: LineRelation,
    /// Foot of the normal on the first line.
    pub foot1: Vector3<f64>,
    /// Foot of the normal on the second line.
    pub foot2: Vector3<f64>,
    /// Length of the normal, mm (≥ 0).
    pub distance: f64,
    /// Angle between the directions, radians in [0, π].
    pub angle: f64,
    /// Unit direction of the normal from line 1 towards line 2 (for intersecting lines
    /// `dir1 × dir2` normalised); `None` for identical lines.
    pub direction: Option<Vector3<f64>>,
}

/// The common normal of `l1` and `l2` (see the module docs for the parallel case).
pub fn common_normal(l1: &Line, l2: &Line) -> CommonNormal {
    let cross = l1.dir.cross(&l2.dir);
    let sin = cross.norm();
    let cos = l1.dir.dot(&l2.dir);
    let angle = sin.atan2(cos);
    let w = l2.point - l1.point;
    if sin > PARALLEL_SINE_EPS {
        // Closest points: solve for s, t in foot1 = p1 + s d1, foot2 = p2 + t d2 with
        // (foot2 - foot1) ⟂ d1, d2.
        let b = cos;
        let d = l1.dir.dot(&w);
        let e = l2.dir.dot(&w);
        let den = 1.0 - b * b;
        let s = (d - b * e) / den;
        let t = (b * d - e) / den;
        let foot1 = l1.point + l1.dir * s;
        let foot2 = l2.point + l2.dir * t;
        let axis = cross / sin;
        // The distance along the (unique) normal direction is the exact part of foot2 - foot1.
        let signed = (foot2 - foot1).dot(&axis);
        let distance = signed.abs();
        let (relation, direction) = if distance > DISTANCE_EPS_MM {
            (LineRelation::Skew, axis * signed.signum())
        } else {
            (LineRelation::Intersecting, axis)
        };
        CommonNormal {
            relation,
            foot1,
            foot2,
            distance,
            angle,
            direction: Some(direction),
        }
    } else {
        let foot1 = l1.point;
        let foot2 = l2.project(&foot1);
        let v = foot2 - foot1;
        let distance = v.norm();
        if distance > DISTANCE_EPS_MM {
            CommonNormal {
                relation: LineRelation::Parallel,
                foot1,
                foot2,
                distance,
                angle,
                direction: Some(v / distance),
            }
        } else {
            CommonNormal {
                relation: LineRelation::Identical,
                foot1,
                foot2,
                distance,
                angle,
                direction: None,
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line(p: [f64; 3], d: [f64; 3]) -> Line {
        Line::new(Vector3::from(p), Vector3::from(d)).unwrap()
    }

    #[test]
    fn skew_lines() {
        // x axis and a line along y through (0, 0, 5).
        let n = common_normal(
            &line([3.0, 0.0, 0.0], [1.0, 0.0, 0.0]),
            &line([0.0, 7.0, 5.0], [0.0, 2.0, 0.0]),
        );
        assert_eq!(n.relation, LineRelation::Skew);
        assert!((n.distance - 5.0).abs() < 1e-12);
        assert!((n.foot1 - Vector3::zeros()).norm() < 1e-12);
        assert!((n.foot2 - Vector3::new(0.0, 0.0, 5.0)).norm() < 1e-12);
        assert!((n.angle - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        assert!((n.direction.unwrap() - Vector3::z()).norm() < 1e-12);
    }

    #[test]
    fn skew_lines_general() {
        let l1 = line([1.0, 2.0, 3.0], [0.3, -0.4, 0.8]);
        let l2 = line([-4.0, 0.5, 7.0], [0.9, 0.1, -0.2]);
        let n = common_normal(&l1, &l2);
        assert_eq!(n.relation, LineRelation::Skew);
        let v = n.foot2 - n.foot1;
        assert!(v.dot(&l1.dir).abs() < 1e-12 && v.dot(&l2.dir).abs() < 1e-12);
        assert!(l1.distance_to(&n.foot1) < 1e-12 && l2.distance_to(&n.foot2) < 1e-12);
        assert!((v.norm() - n.distance).abs() < 1e-12);
        assert!((v / v.norm() - n.direction.unwrap()).norm() < 1e-12);
    }

    #[test]
    fn intersecting_lines() {
        let n = common_normal(
            &line([0.0, 0.0, 10.0], [0.0, 0.0, 1.0]),
            &line([1.0, 1.0, 4.0], [1.0, 1.0, 0.0]),
        );
        assert_eq!(n.relation, LineRelation::Intersecting);
        assert!(n.distance < 1e-12);
        assert!((n.foot1 - Vector3::new(0.0, 0.0, 4.0)).norm() < 1e-12);
        let want = Vector3::new(-1.0, 1.0, 0.0).normalize();
        assert!((n.direction.unwrap() - want).norm() < 1e-12);
    }

    #[test]
    fn parallel_lines() {
        let n = common_normal(
            &line([0.0, 0.0, 2.0], [0.0, 1.0, 0.0]),
            &line([3.0, -9.0, 6.0], [0.0, -1.0, 0.0]),
        );
        assert_eq!(n.relation, LineRelation::Parallel);
        assert!((n.distance - 5.0).abs() < 1e-12);
        assert!((n.foot1 - Vector3::new(0.0, 0.0, 2.0)).norm() < 1e-12);
        assert!((n.foot2 - Vector3::new(3.0, 0.0, 6.0)).norm() < 1e-12);
        assert!((n.angle - std::f64::consts::PI).abs() < 1e-12);
    }

    #[test]
    fn identical_lines() {
        let n = common_normal(
            &line([1.0, 1.0, 1.0], [1.0, 1.0, 1.0]),
            &line([3.0, 3.0, 3.0], [1.0, 1.0, 1.0]),
        );
        assert_eq!(n.relation, LineRelation::Identical);
        assert!(n.direction.is_none());
        assert!(n.distance < 1e-12);
    }

    #[test]
    fn zero_direction_is_rejected() {
        assert!(Line::new(Vector3::zeros(), Vector3::zeros()).is_none());
    }
}
