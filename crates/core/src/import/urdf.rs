//! URDF reader: the serial chain from a base link to a tip link.
//!
//! Joint origins (`xyz`, and `rpy` or URDF 1.1's `quat_xyzw`; both at once is refused as
//! ambiguous) are composed in f64; fixed joints fold into the next joint's origin (or into the tip
//! transform after the last joint); axes keep their sign; limits go from radians to degrees and a
//! `continuous` joint gets ±360°. Lengths go from metres to millimetres.
//!
//! Refused, naming the element and its line: prismatic, floating and planar joints on the chain,
//! mimic joints, revolute joints without `<limit>`, zero or non-finite axes and numbers, a chain
//! of more revolute joints than can be read ([`super::MAX_SOURCE_JOINTS`]; the model's 4 to 7,
//! after any joints held, are checked by [`super::convert`]), a branching tree with no tip named,
//! malformed XML and unexpanded xacro.

use super::{ImportError, SourceChain, SourceFormat, SourceJoint};
use nalgebra::{Isometry3, Quaternion, Translation3, Unit, UnitQuaternion, Vector3};
use std::collections::HashMap;

/// Metres to millimetres.
const MM_PER_M: f64 = 1000.0;

struct JointEl {
    name: String,
    kind: String,
    parent: String,
    child: String,
    origin: Isometry3<f64>,
    axis: Vector3<f64>,
    limits_rad: Option<(f64, f64)>,
    mimic: bool,
    line: usize,
}

/// Parses URDF text into the chain from `base` (default: the root link) to `tip` (default: the
/// single leaf below the base). `path` names the file in errors.
///
/// # Errors
///
/// [`ImportError::Syntax`] for XML that is not well-formed, [`ImportError::Xacro`] for unexpanded
/// xacro macros, [`ImportError::Element`] for a wrong or unsupported element or attribute (naming
/// it and its line), [`ImportError::Branching`] when the chain branches below the base and no tip
/// was named, and [`ImportError::Chain`] when base or tip is not in the file, the tip is not below
/// the base, or the chain between them has more than [`super::MAX_SOURCE_JOINTS`] revolute joints.
pub fn parse(
    text: &str,
    path: &str,
    base: Option<&str>,
    tip: Option<&str>,
) -> Result<SourceChain, ImportError> {
    let doc = roxmltree::Document::parse(text).map_err(|e| {
        let pos = e.pos();
        if text.contains("xmlns:xacro") || text.contains("<xacro:") {
            return xacro(path, text);
        }
        ImportError::Syntax {
            path: path.into(),
            line: pos.row as usize,
            message: format!("malformed XML: {e}"),
        }
    })?;
    let line_of = |n: &roxmltree::Node| doc.text_pos_at(n.range().start).row as usize;
    for n in doc.descendants() {
        let is_xacro = n
            .tag_name()
            .namespace()
            .is_some_and(|ns| ns.contains("xacro"))
            || n.attributes().any(|a| a.value().contains("${"));
        if is_xacro {
            return Err(ImportError::Xacro {
                path: path.into(),
                line: line_of(&n),
                what: format!(
                    "unexpanded {} in a URDF file; {UNEXPANDED}",
                    if n.tag_name()
                        .namespace()
                        .is_some_and(|ns| ns.contains("xacro"))
                    {
                        format!("<xacro:{}>", n.tag_name().name())
                    } else {
                        "${...} expression".into()
                    }
                ),
            });
        }
    }
    let root = doc.root_element();
    if root.tag_name().name() != "robot" {
        return Err(ImportError::Element {
            path: path.into(),
            line: line_of(&root),
            element: format!("<{}>", root.tag_name().name()),
            message: "the root element of a URDF must be <robot>".into(),
        });
    }
    let robot_name = root.attribute("name").unwrap_or("robot").to_string();
    let mut links = Vec::new();
    let mut joints = Vec::new();
    for n in root.children().filter(|n| n.is_element()) {
        match n.tag_name().name() {
            "link" => {
                let name = required(&n, "name", "link", path, line_of(&n))?;
                if links.contains(&name) {
                    return Err(ImportError::Element {
                        path: path.into(),
                        line: line_of(&n),
                        element: format!("link '{name}'"),
                        message: "a second link of this name".into(),
                    });
                }
                links.push(name);
            }
            "joint" => joints.push(joint_el(&n, path, line_of(&n))?),
            _ => {}
        }
    }
    // child link → joint index
    let mut parent_joint: HashMap<&str, usize> = HashMap::new();
    let mut names: HashMap<&str, usize> = HashMap::new();
    for (k, j) in joints.iter().enumerate() {
        if let Some(first) = names.insert(j.name.as_str(), j.line) {
            return Err(ImportError::Element {
                path: path.into(),
                line: j.line,
                element: format!("joint '{}'", j.name),
                message: format!("a second joint of this name (the first is on line {first})"),
            });
        }
        if parent_joint.insert(j.child.as_str(), k).is_some() {
            return Err(ImportError::Element {
                path: path.into(),
                line: j.line,
                element: format!("joint '{}'", j.name),
                message: format!("link '{}' has a second parent joint", j.child),
            });
        }
        for l in [&j.parent, &j.child] {
            if !links.contains(l) {
                return Err(ImportError::Element {
                    path: path.into(),
                    line: j.line,
                    element: format!("joint '{}'", j.name),
                    message: format!("link '{l}' is not defined"),
                });
            }
        }
    }
    let base = match base {
        Some(b) => {
            if !links.iter().any(|l| l == b) {
                return Err(ImportError::Chain {
                    path: path.into(),
                    message: format!("base link '{b}' is not in the file"),
                });
            }
            b.to_string()
        }
        None => {
            let roots: Vec<&String> = links
                .iter()
                .filter(|l| !parent_joint.contains_key(l.as_str()))
                .collect();
            match roots.as_slice() {
                [r] => r.to_string(),
                _ => {
                    return Err(ImportError::Chain {
                        path: path.into(),
                        message: if roots.is_empty() {
                            "expected one root link, found none: the joints form a cycle (every \
                             link has a parent joint)"
                                .to_string()
                        } else {
                            format!(
                                "expected one root link, found {}: {}",
                                roots.len(),
                                roots
                                    .iter()
                                    .map(|s| s.as_str())
                                    .collect::<Vec<_>>()
                                    .join(", ")
                            )
                        },
                    })
                }
            }
        }
    };
    let mut tip_note = None;
    let tip = match tip {
        Some(t) => {
            if !links.iter().any(|l| l == t) {
                return Err(ImportError::Chain {
                    path: path.into(),
                    message: format!("tip link '{t}' is not in the file"),
                });
            }
            t.to_string()
        }
        None => {
            let (t, why) = default_tip(&joints, &base).ok_or_else(|| {
                let mut leaves = leaves_below(&joints, &base);
                leaves.sort();
                ImportError::Branching {
                    path: path.into(),
                    base: base.clone(),
                    leaves,
                }
            })?;
            // A single leaf is the tip without a choice; a choice among several is said.
            tip_note = why.map(|why| format!("tip link '{t}' ({why})"));
            t
        }
    };
    // Walk up from the tip.
    let mut chain_idx = Vec::new();
    let mut link = tip.as_str();
    while link != base {
        match parent_joint.get(link) {
            Some(&k) => {
                if chain_idx.len() > joints.len() {
                    break;
                }
                chain_idx.push(k);
                link = joints[k].parent.as_str();
            }
            None => {
                return Err(ImportError::Chain {
                    path: path.into(),
                    message: format!("tip link '{tip}' is not below base link '{base}'"),
                })
            }
        }
    }
    chain_idx.reverse();
    let mut out = Vec::new();
    let mut pending = Isometry3::identity();
    let mut arm_frame = None;
    for &k in &chain_idx {
        let j = &joints[k];
        let el = || format!("joint '{}'", j.name);
        let refuse = |message: String| ImportError::Element {
            path: path.into(),
            line: j.line,
            element: el(),
            message,
        };
        if j.mimic {
            return Err(refuse(
                "mimic joints are not supported: the model's joints move independently".into(),
            ));
        }
        match j.kind.as_str() {
            "fixed" => {
                pending *= j.origin;
                // UR's arm base frame, before joint 1: what its calibration files are relative to.
                if out.is_empty() && j.child.ends_with("base_link_inertia") {
                    arm_frame = Some(pending);
                }
                continue;
            }
            "revolute" | "continuous" => {}
            "prismatic" | "floating" | "planar" => {
                return Err(refuse(format!(
                    "{} joints are not supported: the model has revolute joints only",
                    j.kind
                )))
            }
            other => return Err(refuse(format!("unknown joint type '{other}'"))),
        }
        let n = j.axis.norm();
        if !(n.is_finite() && n > 1e-12) {
            return Err(refuse(format!(
                "axis ({}, {}, {}) cannot be normalised",
                j.axis.x, j.axis.y, j.axis.z
            )));
        }
        let limits_deg = if j.kind == "continuous" {
            (-360.0, 360.0)
        } else {
            let (lo, hi) = j
                .limits_rad
                .ok_or_else(|| refuse("revolute joint without <limit lower=.. upper=..>".into()))?;
            if lo >= hi {
                return Err(refuse(format!(
                    "limit lower = {lo} must be below upper = {hi} (rad)"
                )));
            }
            (lo.to_degrees(), hi.to_degrees())
        };
        out.push(SourceJoint {
            name: j.name.clone(),
            origin: pending * j.origin,
            axis: Unit::new_normalize(j.axis),
            limits_deg,
        });
        pending = Isometry3::identity();
    }
    if out.len() > super::MAX_SOURCE_JOINTS {
        return Err(ImportError::Chain {
            path: path.into(),
            message: format!(
                "the chain from '{base}' to '{tip}' has {} revolute joints; at most {} can be read",
                out.len(),
                super::MAX_SOURCE_JOINTS
            ),
        });
    }
    // The joint count is checked after any joints are held (`convert`).
    Ok(SourceChain {
        name: robot_name,
        format: SourceFormat::Urdf,
        joints: out,
        what: format!("the chain from '{base}' to '{tip}'"),
        tip: pending,
        notes: tip_note.into_iter().collect(),
        held: Vec::new(),
        arm_frame,
    })
}

/// The leaf links below `base`.
fn leaves_below(joints: &[JointEl], base: &str) -> Vec<String> {
    let mut leaves = Vec::new();
    let mut stack = vec![base.to_string()];
    while let Some(l) = stack.pop() {
        let kids: Vec<String> = joints
            .iter()
            .filter(|j| j.parent == l)
            .map(|j| j.child.clone())
            .collect();
        if kids.is_empty() {
            leaves.push(l);
        } else {
            stack.extend(kids);
        }
    }
    leaves
}

/// The tip when none is named, and why (`None` for the single leaf below `base`); else a link named
/// `tool0` (ROS-Industrial's tool flange), then one named `flange`, below the base; else the
/// single deepest leaf among those with the most revolute joints on their path from the base
/// (the arm, not a sensor or a `base` frame hanging off the base link). `None` when the choice
/// is ambiguous.
fn default_tip(joints: &[JointEl], base: &str) -> Option<(String, Option<&'static str>)> {
    let leaves = leaves_below(joints, base);
    if leaves.len() == 1 {
        return Some((leaves[0].clone(), None));
    }
    // Every link below the base with (revolute joints, links) on its path from the base.
    let mut below: Vec<(String, usize, usize)> = Vec::new();
    let mut stack = vec![(base.to_string(), 0usize, 0usize)];
    while let Some((l, rev, depth)) = stack.pop() {
        for j in joints.iter().filter(|j| j.parent == l) {
            let r = rev + usize::from(j.kind == "revolute" || j.kind == "continuous");
            below.push((j.child.clone(), r, depth + 1));
            stack.push((j.child.clone(), r, depth + 1));
        }
    }
    for (name, why) in [("tool0", "named tool0"), ("flange", "named flange")] {
        if below.iter().any(|(l, _, _)| l == name) {
            return Some((name.to_string(), Some(why)));
        }
    }
    let score = |l: &String| {
        below
            .iter()
            .find(|(b, _, _)| b == l)
            .map_or((0, 0), |&(_, r, d)| (r, d))
    };
    let best = leaves.iter().map(score).max()?;
    let mut top = leaves.iter().filter(|l| score(l) == best);
    let first = top.next()?;
    if top.next().is_some() {
        return None;
    }
    Some((
        first.clone(),
        Some("the deepest leaf of the longest revolute chain"),
    ))
}

/// The advice for xacro found in a URDF file.
const UNEXPANDED: &str =
    "import the .xacro file itself to have it expanded, or run xacro first and import the URDF it writes";

fn xacro(path: &str, text: &str) -> ImportError {
    let line = text
        .lines()
        .position(|l| l.contains("xacro"))
        .map_or(1, |k| k + 1);
    ImportError::Xacro {
        path: path.into(),
        line,
        what: format!("unexpanded xacro namespace or macro in a URDF file; {UNEXPANDED}"),
    }
}

fn required(
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

fn joint_el(n: &roxmltree::Node, path: &str, line: usize) -> Result<JointEl, ImportError> {
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
        origin = Isometry3::from_parts(Translation3::new(xyz[0], xyz[1], xyz[2]), rotation);
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
        Some(l) => {
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
                (Some(lo), Some(hi)) => Some((lo, hi)),
                _ if kind == "revolute" => {
                    return Err(bad(
                        ll,
                        "revolute joint's <limit> needs lower and upper".into(),
                    ))
                }
                _ => None,
            }
        }
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
