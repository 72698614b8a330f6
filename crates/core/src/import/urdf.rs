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
//!
//! A `<joint>` element is read in `joint`; this file finds the chain and checks it.

mod inertial;
mod joint;

use super::{ImportError, SourceChain, SourceFormat, SourceJoint};
use inertial::{inertial_of, Inertial};
use joint::{joint_el, required, JointEl};
use nalgebra::{Isometry3, Unit};
use std::collections::HashMap;

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
    let text = super::xml::leading_declaration_blanked(text);
    let doc = document(&text, path)?;
    refuse_xacro(&doc, path)?;
    let (robot_name, links, joints, inertials) = elements(&doc, path)?;
    let parent_joint = parent_joints(&joints, &links, path)?;
    let base = base_link(base, &links, &parent_joint, path)?;
    let (tip, tip_note) = tip_link(tip, &links, &joints, &base, path)?;
    let chain_idx = chain_between(&joints, &parent_joint, &base, &tip, path)?;
    let chain = revolute_joints(&joints, &chain_idx, path)?;
    let revolute: Vec<usize> = chain_idx
        .iter()
        .copied()
        .filter(|&k| joints[k].kind != "fixed")
        .collect();
    let bodies = inertial::bodies(&joints, &revolute, &inertials);
    if chain.joints.len() > super::MAX_SOURCE_JOINTS {
        return Err(ImportError::Chain {
            path: path.into(),
            message: format!(
                "the chain from '{base}' to '{tip}' has {} revolute joints; at most {} can be read",
                chain.joints.len(),
                super::MAX_SOURCE_JOINTS
            ),
        });
    }
    // The joint count is checked after any joints are held (`convert`).
    Ok(SourceChain {
        name: robot_name,
        format: SourceFormat::Urdf,
        joints: chain.joints,
        what: format!("the chain from '{base}' to '{tip}'"),
        tip: chain.tip,
        notes: tip_note.into_iter().collect(),
        held: Vec::new(),
        arm_frame: chain.arm_frame,
        bodies,
    })
}

/// 1-based line of the node `n` of `doc`.
fn line_of(doc: &roxmltree::Document, n: &roxmltree::Node) -> usize {
    doc.text_pos_at(n.range().start).row as usize
}

/// The XML document of `text`. Malformed XML is reported as such, at its line, except an
/// element or attribute with a `xacro:` prefix bound to no namespace: that is unexpanded xacro.
fn document<'t>(text: &'t str, path: &str) -> Result<roxmltree::Document<'t>, ImportError> {
    roxmltree::Document::parse(text).map_err(|e| match e {
        roxmltree::Error::UnknownNamespace(prefix, pos) if prefix == "xacro" => {
            ImportError::Xacro {
                path: path.into(),
                line: pos.row as usize,
                what: format!(
                    "unexpanded xacro (the prefix 'xacro:' is bound to no namespace) in a URDF file; {UNEXPANDED}"
                ),
            }
        }
        e => ImportError::Syntax {
            path: path.into(),
            line: e.pos().row as usize,
            message: format!("malformed XML: {e}"),
        },
    })
}

/// Whether `n` is in a xacro namespace ([`super::xacro::XACRO_NAMESPACES`]).
fn in_xacro_namespace(n: &roxmltree::Node) -> bool {
    n.tag_name()
        .namespace()
        .is_some_and(super::xacro::is_xacro_namespace)
}

/// Refuses the first element in a xacro namespace or attribute with a `${...}` expression.
fn refuse_xacro(doc: &roxmltree::Document, path: &str) -> Result<(), ImportError> {
    for n in doc.descendants() {
        let is_xacro = in_xacro_namespace(&n) || n.attributes().any(|a| a.value().contains("${"));
        if is_xacro {
            return Err(ImportError::Xacro {
                path: path.into(),
                line: line_of(doc, &n),
                what: format!(
                    "unexpanded {} in a URDF file; {UNEXPANDED}",
                    if in_xacro_namespace(&n) {
                        format!("<xacro:{}>", n.tag_name().name())
                    } else {
                        "${...} expression".into()
                    }
                ),
            });
        }
    }
    Ok(())
}

/// What [`elements`] reads: the robot's name, its links, its joints and the links' inertial data.
type Elements = (String, Vec<String>, Vec<JointEl>, HashMap<String, Inertial>);

/// The robot's name, its links and its joints, in file order, and the links' `<inertial>` data,
/// from the root `<robot>`.
fn elements(doc: &roxmltree::Document, path: &str) -> Result<Elements, ImportError> {
    let root = doc.root_element();
    if root.tag_name().name() != "robot" {
        return Err(ImportError::Element {
            path: path.into(),
            line: line_of(doc, &root),
            element: format!("<{}>", root.tag_name().name()),
            message: "the root element of a URDF must be <robot>".into(),
        });
    }
    let robot_name = root.attribute("name").unwrap_or("robot").to_string();
    let mut links = Vec::new();
    let mut joints = Vec::new();
    let mut inertials = HashMap::new();
    for n in root.children().filter(|n| n.is_element()) {
        match n.tag_name().name() {
            "link" => {
                let name = required(&n, "name", "link", path, line_of(doc, &n))?;
                if links.contains(&name) {
                    return Err(ImportError::Element {
                        path: path.into(),
                        line: line_of(doc, &n),
                        element: format!("link '{name}'"),
                        message: "a second link of this name".into(),
                    });
                }
                if let Some(i) = inertial_of(&n, &name, path, line_of(doc, &n))? {
                    inertials.insert(name.clone(), i);
                }
                links.push(name);
            }
            "joint" => joints.push(joint_el(&n, path, line_of(doc, &n))?),
            _ => {}
        }
    }
    Ok((robot_name, links, joints, inertials))
}

/// Child link → index of its parent joint; refuses a second joint of one name, a second parent
/// joint of one link and a joint naming a link that is not defined.
fn parent_joints<'j>(
    joints: &'j [JointEl],
    links: &[String],
    path: &str,
) -> Result<HashMap<&'j str, usize>, ImportError> {
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
    Ok(parent_joint)
}

/// The base link: the one named, which must be in the file, else the single root link.
fn base_link(
    base: Option<&str>,
    links: &[String],
    parent_joint: &HashMap<&str, usize>,
    path: &str,
) -> Result<String, ImportError> {
    Ok(match base {
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
    })
}

/// The tip link: the one named, which must be in the file, else [`default_tip`] with the note
/// saying why when it chose among several leaves.
fn tip_link(
    tip: Option<&str>,
    links: &[String],
    joints: &[JointEl],
    base: &str,
    path: &str,
) -> Result<(String, Option<String>), ImportError> {
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
            let (t, why) = default_tip(joints, base).ok_or_else(|| {
                let mut leaves = leaves_below(joints, base);
                leaves.sort();
                ImportError::Branching {
                    path: path.into(),
                    base: base.to_string(),
                    leaves,
                }
            })?;
            // A single leaf is the tip without a choice; a choice among several is said.
            tip_note = why.map(|why| format!("tip link '{t}' ({why})"));
            t
        }
    };
    Ok((tip, tip_note))
}

/// The joints from `base` to `tip` (indices into `joints`, base to tip), walking up from the tip.
fn chain_between(
    joints: &[JointEl],
    parent_joint: &HashMap<&str, usize>,
    base: &str,
    tip: &str,
    path: &str,
) -> Result<Vec<usize>, ImportError> {
    let mut chain_idx = Vec::new();
    let mut link = tip;
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
    Ok(chain_idx)
}

/// The revolute joints of a chain and the fixed transforms around them.
struct ChainJoints {
    /// The revolute and continuous joints, base to tip, each fixed joint before one folded into
    /// its origin.
    joints: Vec<SourceJoint>,
    /// The fixed transform after the last revolute joint.
    tip: Isometry3<f64>,
    /// UR's arm base frame (the fixed joints to `base_link_inertia` before joint 1), if any.
    arm_frame: Option<Isometry3<f64>>,
}

/// The joints `chain_idx` (indices into `joints`, base to tip) as source joints: fixed joints
/// fold into the next joint's origin (or the tip); mimic, prismatic, floating, planar and
/// unknown joints are refused.
fn revolute_joints(
    joints: &[JointEl],
    chain_idx: &[usize],
    path: &str,
) -> Result<ChainJoints, ImportError> {
    let mut out = Vec::new();
    let mut pending = Isometry3::identity();
    let mut arm_frame = None;
    for &k in chain_idx {
        let j = &joints[k];
        let refuse = |message: String| refusal(j, path, message);
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
        let limits_deg = axis_and_limits(j, path)?;
        out.push(SourceJoint {
            name: j.name.clone(),
            origin: pending * j.origin,
            axis: Unit::new_normalize(j.axis),
            limits_deg,
        });
        pending = Isometry3::identity();
    }
    Ok(ChainJoints {
        joints: out,
        tip: pending,
        arm_frame,
    })
}

/// The error refusing the joint `j` of the file `path` with `message`.
fn refusal(j: &JointEl, path: &str, message: String) -> ImportError {
    ImportError::Element {
        path: path.into(),
        line: j.line,
        element: format!("joint '{}'", j.name),
        message,
    }
}

/// Checks the axis of the revolute or continuous joint `j` and returns its limits in degrees
/// (±360° for a continuous joint).
fn axis_and_limits(j: &JointEl, path: &str) -> Result<(f64, f64), ImportError> {
    let refuse = |message: String| refusal(j, path, message);
    let n = j.axis.norm();
    if !(n.is_finite() && n > 1e-12) {
        return Err(refuse(format!(
            "axis ({}, {}, {}) cannot be normalised",
            j.axis.x, j.axis.y, j.axis.z
        )));
    }
    Ok(if j.kind == "continuous" {
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
