//! A URDF `<joint>` element read into its name, type, links, origin, axis and limits.

use super::ImportError;
use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion, Vector3};

/// Metres to millimetres.
const MM_PER_M: f64 = 1000.0;

/// A `<joint>` element as read (lengths in mm).
pub(super) struct JointEl {
    pub(super) name: String,
    pub(super) kind: String,
    pub(super) parent: String,
    pub(super) child: String,
    pub(super) origin: Isometry3<f64>,
    pub(super) axis: Vector3<f64>,
    pub(super) limits_rad: Option<(f64, f64)>,
    pub(super) mimic: bool,
    pub(super) line: usize,
}

/// The attribute `attr` of the element `n` (a `<what>` on line `line` of `path`).
pub(super) fn required(
    n: &roxmltree::Node,
    attr: &str,
    what: &str,
    path: &str,
    line: usize,
) -> Result<String, ImportError> {
    n.attribute(attr)
        .map(str::to_string)
        .ok_or_else(|| ImportError::Element {
            path: path.into(),
            line,
            element: format!("<{what}>"),
            message: format!("missing attribute '{attr}'"),
        })
}

/// Parses `count` whitespace-separated finite numbers.
fn numbers<const N: usize>(s: &str) -> Option<[f64; N]> {
    let v: Vec<f64> = s
        .split_whitespace()
        .map(|t| t.parse::<f64>())
        .collect::<Result<_, _>>()
        .ok()?;
    if v.len() != N || !v.iter().all(|x| x.is_finite()) {
        return None;
    }
    Some(std::array::from_fn(|k| v[k]))
}

/// Reads the `<joint>` element `n` on line `line` of the file `path`.
pub(super) fn joint_el(
    n: &roxmltree::Node,
    path: &str,
    line: usize,
) -> Result<JointEl, ImportError> {
    let name = required(n, "name", "joint", path, line)?;
    let element = format!("joint '{name}'");
    let bad = |line: usize, message: String| ImportError::Element {
        path: path.into(),
        line,
        element: element.clone(),
        message,
    };
    let kind = n
        .attribute("type")
        .ok_or_else(|| bad(line, "missing attribute 'type'".into()))?
        .to_string();
    let child_el = |tag: &str| n.children().find(|c| c.has_tag_name(tag));
    let link_of = |tag: &str| -> Result<String, ImportError> {
        child_el(tag)
            .and_then(|c| c.attribute("link"))
            .map(str::to_string)
            .ok_or_else(|| bad(line, format!("missing <{tag} link=\"..\"/>")))
    };
    let parent = link_of("parent")?;
    let child = link_of("child")?;
    let mut origin = Isometry3::identity();
    if let Some(o) = child_el("origin") {
        origin = origin_of(&o, &bad)?;
    }
    // URDF's default axis is x.
    let axis =
        match child_el("axis") {
            None => Vector3::x(),
            Some(a) => {
                let al = a.document().text_pos_at(a.range().start).row as usize;
                let s = a.attribute("xyz").unwrap_or("1 0 0");
                Vector3::from(numbers::<3>(s).ok_or_else(|| {
                    bad(al, format!("axis xyz=\"{s}\" is not three finite numbers"))
                })?)
            }
        };
    let limits_rad = match child_el("limit") {
        None => None,
        Some(l) => limits_of(&l, &kind, &bad)?,
    };
    Ok(JointEl {
        name,
        kind,
        parent,
        child,
        origin,
        axis,
        limits_rad,
        mimic: child_el("mimic").is_some(),
        line,
    })
}

/// The transform of the `<origin>` element `o` (lengths in mm): `xyz`, and `rpy` or
/// `quat_xyzw` (not both). `bad` makes the error for a line and a message.
pub(super) fn origin_of(
    o: &roxmltree::Node,
    bad: &dyn Fn(usize, String) -> ImportError,
) -> Result<Isometry3<f64>, ImportError> {
    let ol = o.document().text_pos_at(o.range().start).row as usize;
    let attr3 = |a: &str| -> Result<[f64; 3], ImportError> {
        match o.attribute(a) {
            None => Ok([0.0; 3]),
            Some(s) => numbers::<3>(s).ok_or_else(|| {
                bad(
                    ol,
                    format!("origin {a}=\"{s}\" is not three finite numbers"),
                )
            }),
        }
    };
    let xyz = attr3("xyz")?.map(|v| v * MM_PER_M);
    if o.attribute("quat_xyzw").is_some() && o.attribute("rpy").is_some() {
        return Err(bad(
            ol,
            "origin has both rpy and quat_xyzw: give one rotation".into(),
        ));
    }
    let rotation = match o.attribute("quat_xyzw") {
        Some(s) => {
            let q = numbers::<4>(s).ok_or_else(|| {
                bad(
                    ol,
                    format!("origin quat_xyzw=\"{s}\" is not four finite numbers"),
                )
            })?;
            let quat = Quaternion::new(q[3], q[0], q[1], q[2]);
            if quat.norm() <= 1e-12 {
                return Err(bad(ol, "origin quat_xyzw is zero".into()));
            }
            UnitQuaternion::from_quaternion(quat)
        }
        None => {
            let rpy = attr3("rpy")?;
            UnitQuaternion::from_euler_angles(rpy[0], rpy[1], rpy[2])
        }
    };
    Ok(Isometry3::from_parts(
        Translation3::new(xyz[0], xyz[1], xyz[2]),
        rotation,
    ))
}

/// The limits (radians) of the `<limit>` element `l` of a joint of type `kind`: `None` when
/// lower or upper is missing, which a revolute joint may not. `bad` makes the error for a line
/// and a message.
fn limits_of(
    l: &roxmltree::Node,
    kind: &str,
    bad: &dyn Fn(usize, String) -> ImportError,
) -> Result<Option<(f64, f64)>, ImportError> {
    let ll = l.document().text_pos_at(l.range().start).row as usize;
    let num = |a: &str| -> Result<Option<f64>, ImportError> {
        match l.attribute(a) {
            None => Ok(None),
            Some(s) => match s.trim().parse::<f64>() {
                Ok(v) if v.is_finite() => Ok(Some(v)),
                _ => Err(bad(ll, format!("limit {a}=\"{s}\" is not a finite number"))),
            },
        }
    };
    match (num("lower")?, num("upper")?) {
        (Some(lo), Some(hi)) => Ok(Some((lo, hi))),
        _ if kind == "revolute" => Err(bad(
            ll,
            "revolute joint's <limit> needs lower and upper".into(),
        )),
        _ => Ok(None),
    }
}
