//! The inputs of a robot's Sobol design by name and in groups: per joint, per kind of MDH
//! parameter, per other block of the input space, and the model's discrepancy term.

use super::InputGroup;
use crate::engine::TermGroup;
use crate::kinematics::{param_joint, param_kind, Block, Layout, ParamKind};

/// Report name of input `i` of the inputs of layout `lay` (positions of
/// [`InputSpace::measured`](crate::kinematics::InputSpace::measured), e.g. `alpha3`, or `tool_x` … `tool_z` for the tool point, indices
/// 30–32 of a six-joint model).
pub fn param_name(lay: Layout, i: usize) -> String {
    lay.measured().name(i)
}

/// The groups of the free inputs `free` (as input columns; positions of [`InputSpace::measured`](crate::kinematics::InputSpace::measured))
/// of layout `lay`: per joint, then per kind, then one group per other block (the tool point's
/// uncertain coordinates, then the base placement's uncertain inputs, when it is drawn).
pub(super) fn robot_groups(lay: Layout, free: &[usize]) -> Vec<InputGroup> {
    let space = lay.measured();
    let select = |name: String, keep: &dyn Fn(usize) -> bool| InputGroup {
        name,
        members: (0..free.len()).filter(|&c| keep(free[c])).collect(),
    };
    let param = move |i: usize| match space.locate(i) {
        (Block::Joints, k) => Some(k),
        _ => None,
    };
    let joints = (0..lay.joints()).map(|j| {
        select(format!("joint {}", j + 1), &move |i| {
            param(i).is_some_and(|k| param_joint(k) == j)
        })
    });
    let kinds: [(&str, &[ParamKind]); 3] = [
        ("joint angles θ", &[ParamKind::Theta]),
        ("twists α/β", &[ParamKind::Alpha, ParamKind::Beta]),
        ("lengths a/d", &[ParamKind::A, ParamKind::D]),
    ];
    let kinds = kinds.into_iter().map(|(name, ks)| {
        select(name.to_string(), &move |i| {
            param(i).is_some_and(|k| ks.contains(&param_kind(k)))
        })
    });
    let blocks = space
        .blocks()
        .skip(1)
        .map(|b| select(b.label().to_string(), &move |i| space.locate(i).0 == b));
    joints
        .chain(kinds)
        .chain(blocks)
        .filter(|g| !g.members.is_empty())
        .collect()
}

/// The name of the discrepancy term's input (the last, when the problem draws the term).
pub const DISCREPANCY_INPUT: &str = "model_discrepancy";

/// [`robot_groups`], then one group per group of the joint errors the problem draws
/// (`joint_errors`, in [`TermGroup::ALL`] order: the columns after the free inputs) and the
/// discrepancy term's ("model discrepancy", the column after those) when it draws one.
pub(super) fn input_groups(
    lay: Layout,
    free: &[usize],
    joint_errors: &[TermGroup],
    discrepancy: bool,
) -> Vec<InputGroup> {
    let mut g = robot_groups(lay, free);
    for (k, t) in joint_errors.iter().enumerate() {
        g.push(InputGroup {
            name: t.label().into(),
            members: vec![free.len() + k],
        });
    }
    if discrepancy {
        g.push(InputGroup {
            name: "model discrepancy".into(),
            members: vec![free.len() + joint_errors.len()],
        });
    }
    g
}
