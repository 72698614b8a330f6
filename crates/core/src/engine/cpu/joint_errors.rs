//! The joint errors in the lanes (docs/METHOD.md §19.2): each lane's draw of the coefficients
//! moves its geometric offsets and gives the factors of its per-point joint-angle offsets, which
//! turn each joint of the chain further ([`chain_lanes_offset`]).

use super::{CpuEvaluator, JeLanes, OffsetLanes, PointPre, Source, LANES};
use crate::engine::joint_errors::JointErrorDraws;
use crate::kinematics::joint_errors::{PointTerms, MAX_COEFFICIENTS};
use crate::kinematics::{Block, InputSpace, MAX_JOINTS};

/// The joint errors of the [`LANES`] evaluations of `src` (counter draws or pick-freeze
/// rows): each lane's geometric offsets `d` (and placement offsets `db`) moved by `A δβ`, and
/// the lane factors of its joint-angle offsets in `jel` (per joint `[f0, f1, δa1, δb1, δa2,
/// δb2]`, [`JointErrorDraws::factors`]).
#[inline(always)]
pub(super) fn term_lanes(
    ev: &CpuEvaluator,
    term: &JointErrorDraws,
    src: Source,
    space: InputSpace,
    d: &mut OffsetLanes,
    mut db: Option<&mut [[f64; LANES]; 6]>,
    jel: &mut JeLanes,
) {
    let mut draws = [[0u64; LANES]; 3];
    for l in 0..LANES {
        let by_group = match src {
            Source::Draws(k) => [k + l as u64; 3],
            Source::PickFreeze(pf, row) if row + l < pf.rows() => pf.joint_error_draws(row + l),
            _ => [0; 3],
        };
        for (g, d) in by_group.into_iter().enumerate() {
            draws[g][l] = d;
        }
    }
    let mut free = [[0.0; LANES]; MAX_COEFFICIENTS];
    let mut mass = [0.0; LANES];
    term.draw_lanes(&draws, &mut free, &mut mass);
    term.shift_lanes(&free, |block, k, v| match block {
        Block::Placement => {
            if let Some(db) = db.as_deref_mut() {
                for l in 0..LANES {
                    db[k][l] += v[l];
                }
            }
        }
        b => {
            if let Some(i) = space.index(b, k) {
                for l in 0..LANES {
                    d[i][l] += v[l];
                }
            }
        }
    });
    for (j, lanes) in jel.iter_mut().enumerate().take(ev.joints) {
        term.factor_lanes(j, &free, &mass, lanes);
    }
}

/// The joint-angle offsets of `LANES` draws at a test point with quantities `t`
/// ([`JointErrorDraws`]) from their lane factors `jel`, for the first `N` joints.
#[inline(always)]
pub(super) fn joint_offsets<const N: usize>(
    jel: &JeLanes,
    t: &PointTerms,
) -> [[f64; LANES]; MAX_JOINTS] {
    let mut o = [[0.0; LANES]; MAX_JOINTS];
    for (i, oi) in o.iter_mut().enumerate().take(N) {
        let [tl, tu, s1, c1, s2, c2] = t[i];
        let f = &jel[i];
        for l in 0..LANES {
            oi[l] = f[0][l] * tl
                + f[1][l] * tu
                + f[2][l] * s1
                + f[3][l] * c1
                + f[4][l] * s2
                + f[5][l] * c2;
        }
    }
    o
}

/// Offsets below this (rad) turn a joint by the short series of [`tiny_sin_cos`]; larger ones
/// take `sin_cos`.
pub(super) const TINY_LIMIT: f64 = 1e-3;

/// `(sin δ, cos δ)` to δ⁵ and δ⁴: for |δ| < [`TINY_LIMIT`] the truncation, δ⁵/120 ≤ 8.4e-18
/// and δ⁶/720 ≤ 1.4e-21, is below half an ulp of either (joint errors' draws are ~1e-5 rad).
#[inline(always)]
pub(super) fn tiny_sin_cos(d: f64) -> (f64, f64) {
    let d2 = d * d;
    (
        d * (1.0 - d2 * (1.0 / 6.0)),
        1.0 - d2 * (0.5 - d2 * (1.0 / 24.0)),
    )
}

/// [`super::chain_lanes`] with each joint turned further by its lane's offset `o[i][l]` (rad): the
/// joint errors' draws. The rotation by the offset uses the series of [`tiny_sin_cos`], exact
/// for |o| < [`TINY_LIMIT`]; larger offsets take `sin_cos`.
#[inline(always)]
pub(super) fn chain_lanes_offset<const N: usize>(
    jl: &[[[f64; LANES]; 8]; N],
    tool: &[[f64; LANES]; 3],
    p: &PointPre,
    o: &[[f64; LANES]; MAX_JOINTS],
) -> ([f64; LANES], [f64; LANES], [f64; LANES]) {
    super::chain_lanes_turned::<N, true>(jl, tool, p, o)
}
