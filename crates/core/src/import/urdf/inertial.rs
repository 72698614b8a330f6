//! A link's `<inertial>` element (mass and centre of mass; the inertia tensor is not used) and
//! the moving bodies of a chain: each revolute joint's child link with every link fixed to it,
//! whose masses load the joints (joint compliance, docs/METHOD.md §19).

use super::joint::{origin_of, JointEl};
use super::ImportError;
use crate::import::SourceBody;
use nalgebra::{Isometry3, Point3, Vector3};
use std::collections::HashMap;

/// A link's mass and centre of mass (mm, in the link's frame).
#[derive(Clone, Copy, Debug)]
pub(super) struct Inertial {
    pub(super) mass_kg: f64,
    pub(super) com_mm: Vector3<f64>,
}

/// The `<inertial>` of the `<link>` element `n` named `name` (line `line` of `path`); `None`
/// without one. A mass that is missing, not a finite number or negative is refused.
pub(super) fn inertial_of(
    n: &roxmltree::Node,
    name: &str,
    path: &str,
    line: usize,
) -> Result<Option<Inertial>, ImportError> {
    let Some(i) = n.children().find(|c| c.has_tag_name("inertial")) else {
        return Ok(None);
    };
    let il = i.document().text_pos_at(i.range().start).row as usize;
    let bad = |line: usize, message: String| ImportError::Element {
        path: path.into(),
        line,
        element: format!("link '{name}'"),
        message,
    };
    let mass = i
        .children()
        .find(|c| c.has_tag_name("mass"))
        .ok_or_else(|| bad(il, "<inertial> without <mass value=\"..\"/>".into()))?;
    let ml = mass.document().text_pos_at(mass.range().start).row as usize;
    let text = mass.attribute("value").unwrap_or("");
    let mass_kg = match text.trim().parse::<f64>() {
        Ok(m) if m.is_finite() && (0.0..=1e4).contains(&m) => m,
        _ => {
            return Err(bad(
                ml,
                format!("mass value=\"{text}\" is not a mass (a number of 0 to 10000 kg)"),
            ))
        }
    };
    let com_mm = match i.children().find(|c| c.has_tag_name("origin")) {
        None => Vector3::zeros(),
        Some(o) => origin_of(&o, &bad)?.translation.vector,
    };
    let _ = line;
    Ok(Some(Inertial { mass_kg, com_mm }))
}

/// The moving bodies of the chain whose revolute joints are `revolute` (indices into
/// `joints`, base to tip): body j is joint j's child link and every link below it through fixed
/// joints (on the chain up to the next revolute joint, and off it), with its mass and centre of
/// mass in joint j's frame (after its rotation). `None` when no link of any body has a mass.
pub(super) fn bodies(
    joints: &[JointEl],
    revolute: &[usize],
    inertials: &HashMap<String, Inertial>,
) -> Option<Vec<SourceBody>> {
    let out: Vec<SourceBody> = revolute
        .iter()
        .map(|&k| {
            let (mut mass, mut moment) = (0.0, Vector3::zeros());
            let mut stack = vec![(joints[k].child.as_str(), Isometry3::identity())];
            while let Some((link, at)) = stack.pop() {
                if let Some(i) = inertials.get(link) {
                    mass += i.mass_kg;
                    moment += (at * Point3::from(i.com_mm)).coords * i.mass_kg;
                }
                for j in joints
                    .iter()
                    .filter(|j| j.parent == link && j.kind == "fixed")
                {
                    stack.push((j.child.as_str(), at * j.origin));
                }
            }
            SourceBody {
                mass_kg: mass,
                com_mm: if mass > 0.0 {
                    moment / mass
                } else {
                    Vector3::zeros()
                },
            }
        })
        .collect();
    out.iter().any(|b| b.mass_kg > 0.0).then_some(out)
}
