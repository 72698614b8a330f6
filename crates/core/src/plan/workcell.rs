//! Where a planned pose may put the robot: above a floor, outside keep-out boxes, clear of its
//! own links, and within the joint limits its controller applies (Method §17).
//!
//! The arm is a chain of capsules built from the kinematic chain itself. Joint `i`'s transform
//! is `Rz(θ+q)·Tz(d)·Tx(a)·Rx(α)·Ry(β)`, so the chain passes from frame `i−1`'s origin along
//! joint `i`'s axis by `d_i` (point `P_i`) and then along the common normal by `a_i` (frame
//! `i`'s origin `O_i`). Link 0, the base, is the segment `O_0 → P_1` (the column up joint 1's
//! axis); link `k` (1 … n) is `P_k → O_k → P_{k+1}`, from joint `k`'s axis to joint `k+1`'s,
//! and the last link ends at the target instead. Every link is a capsule of one radius around
//! its segments ([`Workcell::link_radius_mm`], by default [`default_link_radius`]).
//!
//! A pose is refused when a capsule of a moving link (1 … n) dips below the floor (its lowest
//! surface point below `floor_mm`) or reaches into a keep-out box, or when two links that are
//! joined through links shorter than their radii (`r_i + r_j`, neighbours included) come closer
//! than their radii allow (segment–segment distance below `r_i + r_j`): a 25 mm shoulder offset
//! or a zero-length link (a joint whose `a` and next `d` are both 0) joins its neighbours in one
//! housing. The last link (from joint n's axis to the target: the tool and its reflector, whose
//! mount the chain does not know) is kept above the floor and out of the boxes but not checked
//! against the arm.

use super::{setting, PlanError, PlanField};
use crate::identify::chain_fit::ChainState;
use crate::kinematics::{joint_transform, Joints, RobotModel};
use nalgebra::{Matrix3, Vector3};
use serde::Serialize;

/// An axis-aligned box the robot must stay out of, in the measurement frame, mm.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct KeepOut {
    /// The corner with the smallest coordinates.
    pub min_mm: [f64; 3],
    /// The corner with the largest coordinates.
    pub max_mm: [f64; 3],
}

impl KeepOut {
    /// The box between two opposite corners `x0, y0, z0, x1, y1, z1` (mm), in any order.
    pub fn between(c: [f64; 6]) -> KeepOut {
        KeepOut {
            min_mm: [c[0].min(c[3]), c[1].min(c[4]), c[2].min(c[5])],
            max_mm: [c[0].max(c[3]), c[1].max(c[4]), c[2].max(c[5])],
        }
    }
}

/// Where the robot may be, in the measurement frame (z up).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Workcell {
    /// Height of the floor, mm: no moving link's surface may be below it. `None`: no floor.
    pub floor_mm: Option<f64>,
    /// Boxes no link may reach into.
    pub keep_out: Vec<KeepOut>,
    /// Whether links that are not neighbours must stay apart.
    pub self_collision: bool,
    /// Radius of every link's capsule, mm; `None`: [`default_link_radius`] per link.
    pub link_radius_mm: Option<f64>,
}

impl Default for Workcell {
    fn default() -> Self {
        Workcell {
            floor_mm: None,
            keep_out: Vec::new(),
            self_collision: true,
            link_radius_mm: None,
        }
    }
}

/// The default radius of a link of length `length_mm` (the sum of its segments): 15 % of its
/// length, at least 20 mm and at most 50 mm: about the tubes of a 5 kg arm (a UR5e's upper arm
/// is about 45 mm in radius), small enough that a 100 mm wrist link stays clear of the links
/// two away from it.
pub fn default_link_radius(length_mm: f64) -> f64 {
    (0.15 * length_mm).clamp(20.0, 50.0)
}

/// One capsule of a link: a segment and a radius, mm, in the measurement frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Capsule {
    /// The link (0 the base, 1 … n the moving links).
    pub link: usize,
    /// One end.
    pub a: Vector3<f64>,
    /// The other end.
    pub b: Vector3<f64>,
    /// Radius.
    pub radius: f64,
}

/// Why a pose is refused.
#[derive(Clone, Debug, PartialEq)]
pub enum Clash {
    /// A link's surface is `depth_mm` below the floor.
    Floor {
        /// The link.
        link: usize,
        /// How far below, mm.
        depth_mm: f64,
    },
    /// A link reaches into keep-out box `index` (0-based).
    KeepOut {
        /// The link.
        link: usize,
        /// The box.
        index: usize,
    },
    /// Links `a` and `b` overlap by `depth_mm`.
    SelfCollision {
        /// The lower link.
        a: usize,
        /// The higher link.
        b: usize,
        /// By how much their capsules overlap, mm.
        depth_mm: f64,
    },
}

impl std::fmt::Display for Clash {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Clash::Floor { link, depth_mm } => {
                write!(f, "link {link} is {depth_mm:.1} mm below the floor")
            }
            Clash::KeepOut { link, index } => {
                write!(f, "link {link} reaches into keep-out box {}", index + 1)
            }
            Clash::SelfCollision { a, b, depth_mm } => {
                write!(f, "links {a} and {b} overlap by {depth_mm:.1} mm")
            }
        }
    }
}

/// The capsules of `model`'s links at joint angles `q` (radians), placed by `s` in the
/// measurement frame, the target `model.tool` ending the last link. Zero-length links have no
/// capsule.
pub fn capsules(
    model: &RobotModel,
    s: &ChainState,
    q: &[f64],
    radius: Option<f64>,
) -> Vec<Capsule> {
    let r: Matrix3<f64> = s.rotation();
    let origin = Vector3::new(s.base[0], s.base[1], s.base[2]);
    let place = |p: Vector3<f64>| r * p + origin;
    let n = q.len();
    // Frames: rotation and origin of frame i−1 while walking the chain.
    let mut rot = Matrix3::identity();
    let mut o = Vector3::zeros();
    // Per link, its polyline.
    let mut links: Vec<Vec<Vector3<f64>>> = vec![vec![o]; n + 1];
    for (i, qi) in q.iter().enumerate() {
        let p = &model.params[5 * i..5 * i + 5];
        let foot = o + rot.column(2) * p[1];
        links[i].push(foot);
        let t = joint_transform(p[0], p[1], p[2], p[3], p[4], *qi);
        let tr = Matrix3::from_fn(|a, b| t[a][b]);
        o += rot * Vector3::new(t[0][3], t[1][3], t[2][3]);
        rot *= tr;
        links[i + 1] = vec![foot, o];
    }
    links[n].push(o + rot * Vector3::from(model.tool));
    let mut out = Vec::new();
    for (k, pts) in links.iter().enumerate() {
        let length: f64 = pts.windows(2).map(|w| (w[1] - w[0]).norm()).sum();
        if length < 1e-6 {
            continue;
        }
        let radius = radius.unwrap_or_else(|| default_link_radius(length));
        for w in pts.windows(2) {
            if (w[1] - w[0]).norm() >= 1e-9 {
                out.push(Capsule {
                    link: k,
                    a: place(w[0]),
                    b: place(w[1]),
                    radius,
                });
            }
        }
    }
    out
}

/// The smallest distance between segments `p1 q1` and `p2 q2` (Ericson, *Real-Time Collision
/// Detection*, §5.1.9).
pub fn segment_distance(
    p1: &Vector3<f64>,
    q1: &Vector3<f64>,
    p2: &Vector3<f64>,
    q2: &Vector3<f64>,
) -> f64 {
    let (d1, d2, r) = (q1 - p1, q2 - p2, p1 - p2);
    let (a, e, f) = (d1.dot(&d1), d2.dot(&d2), d2.dot(&r));
    let eps = 1e-12;
    let (s, t) = if a <= eps && e <= eps {
        (0.0, 0.0)
    } else if a <= eps {
        (0.0, (f / e).clamp(0.0, 1.0))
    } else {
        let c = d1.dot(&r);
        if e <= eps {
            ((-c / a).clamp(0.0, 1.0), 0.0)
        } else {
            let b = d1.dot(&d2);
            let denom = a * e - b * b;
            let mut s = if denom > eps {
                ((b * f - c * e) / denom).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let mut t = (b * s + f) / e;
            if t < 0.0 {
                t = 0.0;
                s = (-c / a).clamp(0.0, 1.0);
            } else if t > 1.0 {
                t = 1.0;
                s = ((b - c) / a).clamp(0.0, 1.0);
            }
            (s, t)
        }
    };
    ((p1 + d1 * s) - (p2 + d2 * t)).norm()
}

/// Distance from point `p` to the box `k` (0 inside).
fn box_distance(k: &KeepOut, p: &Vector3<f64>) -> f64 {
    (0..3)
        .map(|i| {
            (k.min_mm[i] - p[i])
                .max(p[i] - k.max_mm[i])
                .max(0.0)
                .powi(2)
        })
        .sum::<f64>()
        .sqrt()
}

/// Distance from segment `a b` to box `k`: the distance is convex along the segment, so a
/// golden-section search finds its minimum.
fn segment_box_distance(k: &KeepOut, a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    let at = |t: f64| box_distance(k, &(a + (b - a) * t));
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let (mut lo, mut hi) = (0.0, 1.0);
    for _ in 0..60 {
        let (x1, x2) = (hi - g * (hi - lo), lo + g * (hi - lo));
        if at(x1) <= at(x2) {
            hi = x2;
        } else {
            lo = x1;
        }
    }
    at(0.5 * (lo + hi)).min(at(0.0)).min(at(1.0))
}

/// The first reason the pose `q` (radians) of `model` placed by `s` breaks the workcell `w`,
/// if any: the floor, then the keep-out boxes, then (when `self_collision`, and `w` asks for it)
/// the links' own clearance.
pub fn clash(
    model: &RobotModel,
    s: &ChainState,
    q: &[f64],
    w: &Workcell,
    self_collision: bool,
) -> Option<Clash> {
    if w.floor_mm.is_none() && w.keep_out.is_empty() && !(self_collision && w.self_collision) {
        return None;
    }
    let caps = capsules(model, s, q, w.link_radius_mm);
    for c in caps.iter().filter(|c| c.link > 0) {
        if let Some(floor) = w.floor_mm {
            let depth = floor - (c.a.z.min(c.b.z) - c.radius);
            if depth > 1e-9 {
                return Some(Clash::Floor {
                    link: c.link,
                    depth_mm: depth,
                });
            }
        }
        for (index, k) in w.keep_out.iter().enumerate() {
            if segment_box_distance(k, &c.a, &c.b) < c.radius {
                return Some(Clash::KeepOut {
                    link: c.link,
                    index,
                });
            }
        }
    }
    if !(self_collision && w.self_collision) {
        return None;
    }
    // Per link, its length: links joined through links shorter than their radii may touch.
    let mut length = vec![0.0; q.len() + 1];
    for c in &caps {
        length[c.link] += (c.b - c.a).norm();
    }
    for (i, c1) in caps.iter().enumerate() {
        for c2 in &caps[i + 1..] {
            let between: f64 = length[c1.link + 1..c2.link.max(c1.link + 1)].iter().sum();
            if between < c1.radius + c2.radius || c2.link == q.len() {
                continue;
            }
            let d = segment_distance(&c1.a, &c1.b, &c2.a, &c2.b);
            let depth = c1.radius + c2.radius - d;
            if depth > 0.0 {
                return Some(Clash::SelfCollision {
                    a: c1.link,
                    b: c2.link,
                    depth_mm: depth,
                });
            }
        }
    }
    None
}

/// The largest link radius (mm) at which `model`'s self-collision check still compares two of
/// its links: half the length of the arm between its base column and its last link (links
/// 1 … n−2). Two links are compared only when the links between them are at least as long as
/// their two radii; a larger radius joins every link to every other, and the check would
/// compare none. 0 for an arm with no links between (every radius compares nothing).
pub fn max_link_radius(model: &RobotModel) -> f64 {
    let s = crate::identify::chain::nominal_state(model);
    let q = vec![0.0; model.joints()];
    let mut length = vec![0.0; model.joints() + 1];
    for c in capsules(model, &s, &q, Some(1.0)) {
        length[c.link] += (c.b - c.a).norm();
    }
    let n = model.joints();
    0.5 * length[1..n.saturating_sub(1).max(1)].iter().sum::<f64>()
}

impl Workcell {
    /// Checks the workcell's own figures: a finite floor, boxes with finite corners (min ≤
    /// max), a positive finite link radius, and a radius only where something checks the
    /// capsules (the self-collision check, a floor or a keep-out box).
    ///
    /// # Errors
    ///
    /// [`PlanError::Setting`] naming [`PlanField::Floor`], [`PlanField::KeepOut`] or
    /// [`PlanField::LinkRadius`]; [`PlanError::Unused`] for a radius nothing checks.
    pub fn check(&self) -> Result<(), PlanError> {
        if let Some(f) = self.floor_mm {
            if !f.is_finite() {
                return Err(setting(
                    PlanField::Floor,
                    format!("must be finite, got {f}"),
                ));
            }
        }
        for (i, k) in self.keep_out.iter().enumerate() {
            let ok = (0..3).all(|c| {
                k.min_mm[c].is_finite() && k.max_mm[c].is_finite() && k.min_mm[c] <= k.max_mm[c]
            });
            if !ok {
                return Err(setting(
                    PlanField::KeepOut,
                    format!(
                        "box {} from {:?} to {:?} mm must have finite corners, the first not above the second",
                        i + 1,
                        k.min_mm,
                        k.max_mm
                    ),
                ));
            }
        }
        let Some(r) = self.link_radius_mm else {
            return Ok(());
        };
        if !self.self_collision && self.floor_mm.is_none() && self.keep_out.is_empty() {
            return Err(PlanError::Unused {
                field: PlanField::LinkRadius,
                needs: vec![
                    PlanField::SelfCollision,
                    PlanField::Floor,
                    PlanField::KeepOut,
                ],
                message: "with neither the self-collision check nor a floor nor a keep-out \
                          box no capsule is checked against anything; leave the link radius \
                          out, or give a floor or a keep-out box"
                    .into(),
            });
        }
        if !(r.is_finite() && r > 0.0) {
            return Err(setting(
                PlanField::LinkRadius,
                format!("must be positive, got {}", crate::number::fmt_plain(r)),
            ));
        }
        Ok(())
    }
}

/// Checks the workcell's own figures ([`Workcell::check`]) and a link radius no larger than
/// [`max_link_radius`] of `model` (with or without the self-collision check: no link of the arm
/// is thicker).
pub(super) fn check(model: &RobotModel, w: &Workcell) -> Result<(), PlanError> {
    w.check()?;
    if let Some(r) = w.link_radius_mm {
        let max = max_link_radius(model);
        if max > 0.0 && r > max {
            return Err(setting(
                PlanField::LinkRadius,
                format!(
                    "{} mm is more than half the length of {} between its base column and its last link ({:.0} mm): no link of it is that thick, and the self-collision check, which compares two links only when the links between them are at least as long as their two radii, would compare none; at most {:.0} mm",
                    crate::number::fmt_plain(r),
                    model.name,
                    2.0 * max,
                    max.floor()
                ),
            ));
        }
    }
    Ok(())
}

/// Checks the task points (degrees) of `model` (its base the placement in the measurement
/// frame, its tool the target) against the floor and the keep-out boxes of `w`: a task the robot
/// cannot reach there cannot be planned for (an ISO 9283 cube below the floor, say). Self-
/// collision is not checked: the capsules are a planning margin, not the robot's shape.
///
/// # Errors
///
/// [`PlanError::Setting`] ([`PlanField::TaskPoints`]) naming the first point that breaks the
/// workcell and how.
pub fn check_task(model: &RobotModel, task: &[Joints], w: &Workcell) -> Result<(), PlanError> {
    let s = crate::identify::chain::nominal_state(model);
    let s = &s;
    for (k, q) in task.iter().enumerate() {
        let q = q.map(f64::to_radians);
        if let Some(c) = clash(model, s, &q, w, false) {
            return Err(setting(
                PlanField::TaskPoints,
                format!("point {} cannot be reached: {c}", k + 1),
            ));
        }
    }
    Ok(())
}

/// The joint limits a robot's controller applies, degrees, where they are narrower than the
/// model's, and where they come from. Universal Robots arms (a six-joint model named
/// "Universal Robots …" or `ur` followed by a digit): the elbow (joint 3) is ±180°, though the
/// description says ±360°: "due to the physical construction of the robot, it's impossible to
/// rotate the 'elbow_joint' over more than approx +- 1 pi" (Universal Robots' ROS 2
/// description, `config/ur5e/joint_limits.yaml`, and likewise for the other e-Series arms).
pub fn controller_limits(model: &RobotModel) -> (Vec<(f64, f64)>, Option<String>) {
    let mut limits: Vec<(f64, f64)> = model.limits_deg.iter().copied().collect();
    if is_universal_robots(model)
        && limits.len() == 6
        && (limits[2].0 < -180.0 || limits[2].1 > 180.0)
    {
        limits[2] = (limits[2].0.max(-180.0), limits[2].1.min(180.0));
        return (
            limits,
            Some("UR elbow (joint 3) within ±180°, as the arm is built (Universal Robots' ROS 2 description, config/ur5e/joint_limits.yaml)".into()),
        );
    }
    (limits, None)
}

/// Whether `model` is a Universal Robots arm: named "Universal Robots …" (the presets) or
/// `ur` followed by a digit (UR's descriptions), with six joints.
pub fn is_universal_robots(model: &RobotModel) -> bool {
    let name = model.name.to_ascii_lowercase();
    let ur = name.starts_with("universal robots")
        || (name.starts_with("ur") && name[2..].starts_with(|c: char| c.is_ascii_digit()));
    ur && model.joints() == 6
}
