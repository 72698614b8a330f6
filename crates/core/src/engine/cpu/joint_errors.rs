//! The joint errors in the lanes (docs/METHOD.md §19.2): each lane's draw of the coefficients
//! moves its geometric offsets and gives the factors of its per-point joint-angle offsets, which
//! turn each joint of the chain further (`super::chain`).

use super::{CpuEvaluator, JeLanes, OffsetLanes, Source, LANES};
use crate::engine::discrepancy::point_word;
use crate::engine::joint_errors::{side, JointErrorDraws};
use crate::kinematics::joint_errors::{PointTerms, MAX_COEFFICIENTS};
use crate::kinematics::{Block, InputSpace, MAX_JOINTS};

/// The joint errors of the [`LANES`] evaluations of `src` (counter draws or pick-freeze
/// rows): each lane's geometric offsets `d` (and placement offsets `db`) moved by `A δβ`, and
/// the lane factors of its joint-angle offsets in `jel` (per joint `[f0, f1, δa1, δb1, δa2,
/// δb2]`, [`JointErrorDraws::factors`]) and, with backlash, the words of its sides in `sides`.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(super) fn term_lanes(
    ev: &CpuEvaluator,
    term: &JointErrorDraws,
    src: Source,
    space: InputSpace,
    d: &mut OffsetLanes,
    mut db: Option<&mut [[f64; LANES]; 6]>,
    jel: &mut JeLanes,
    sides: &mut [[u32; LANES]; 2],
) {
    let mut draws = [[0u64; LANES]; 4];
    for l in 0..LANES {
        let by_group = match src {
            Source::Draws(k) => [k + l as u64; 4],
            Source::PickFreeze(pf, row) if row + l < pf.rows() => pf.joint_error_draws(row + l),
            _ => [0; 4],
        };
        for (g, d) in by_group.into_iter().enumerate() {
            draws[g][l] = d;
        }
    }
    let mut free = [[0.0; LANES]; MAX_COEFFICIENTS];
    let mut mass = [0.0; LANES];
    term.draw_lanes(&[draws[0], draws[1], draws[2]], &mut free, &mut mass);
    if term.backlash {
        *sides = term.side_lanes(&draws[3]);
    }
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

/// The turns of the joints at a test point: per joint `[sin o, cos o][lane]` of its offset.
pub(super) type Turns = [[[f64; LANES]; 2]; MAX_JOINTS];

/// The backlash of a block of lanes, when the model has it: the lanes' words `(a, b)`, per
/// joint its turn `h` ([`JointErrorDraws`]'s module docs) and the term (for the sides known at
/// the points).
pub(super) type Sides<'a> = Option<(
    &'a [[u32; LANES]; 2],
    &'a [f64; MAX_JOINTS],
    &'a JointErrorDraws,
)>;

/// The words of the lanes' sides at test point `pj` (zero without backlash), the sides known
/// there put in.
#[inline(always)]
fn point_sides(sides: Sides, pj: usize) -> [u32; LANES] {
    match sides {
        Some((ab, _, t)) => {
            std::array::from_fn(|l| t.with_known(point_word(ab[0][l], ab[1][l], pj as u32), pj))
        }
        None => [0; LANES],
    }
}

/// [`joint_offset`] of joint `i` with the backlash's `±h_i` of the point's side words `w` added
/// (when the model has backlash), as [`JointErrorDraws::offsets`] adds it.
#[inline(always)]
fn joint_offset_sided(
    f: &[[f64; LANES]; 6],
    t: &[f64; 6],
    payload: bool,
    (sides, w, i): (Sides, &[u32; LANES], usize),
) -> [f64; LANES] {
    let mut o = joint_offset(f, t, payload);
    if let Some((_, h, _)) = sides {
        for l in 0..LANES {
            o[l] += side(w[l], i, h[i]);
        }
    }
    o
}

/// The joint-angle offsets of `LANES` draws at joint `i` of a test point with quantities `t`
/// ([`JointErrorDraws`]) from their lane factors `f`: `f0 tl + f1 tu + f2 s1 + f3 c1 + f4 s2 +
/// f5 c2`, summed in that order. Without a payload term (`payload` false) `f1` is an exact zero
/// in every lane ([`JointErrorDraws::payload_term`]) and its term is left out: adding `±0`
/// changes no bit of a nonzero sum, and an offset of `±0` turns by `(±0, 1)`, which leaves every
/// nonzero `cos/sin` as it is.
#[inline(always)]
fn joint_offset(f: &[[f64; LANES]; 6], t: &[f64; 6], payload: bool) -> [f64; LANES] {
    let [tl, tu, s1, c1, s2, c2] = *t;
    let mut o = [0.0; LANES];
    if payload {
        for l in 0..LANES {
            o[l] = f[0][l] * tl
                + f[1][l] * tu
                + f[2][l] * s1
                + f[3][l] * c1
                + f[4][l] * s2
                + f[5][l] * c2;
        }
    } else {
        for l in 0..LANES {
            o[l] = f[0][l] * tl + f[2][l] * s1 + f[3][l] * c1 + f[4][l] * s2 + f[5][l] * c2;
        }
    }
    o
}

/// The joint-angle offsets of a block of lanes at a test point: `[joint][lane]`.
pub(super) type PointOffsets = [[f64; LANES]; MAX_JOINTS];

/// A rayon task's room for [`point_offsets`], allocated once: each point's offsets and, with
/// backlash, each point's side words.
pub(super) struct PointScratch {
    /// Per test point its offsets.
    pub offsets: Vec<PointOffsets>,
    /// Per test point the lanes' side words (empty without backlash).
    words: Vec<[u32; LANES]>,
}

impl PointScratch {
    /// Room for `points` test points of `term` (none without a term).
    pub fn new(points: usize, term: Option<&JointErrorDraws>) -> PointScratch {
        PointScratch {
            offsets: vec![[[0.0; LANES]; MAX_JOINTS]; if term.is_some() { points } else { 0 }],
            words: vec![
                [0; LANES];
                if term.is_some_and(|t| t.backlash) {
                    points
                } else {
                    0
                }
            ],
        }
    }
}

/// The joint-angle offsets of `LANES` draws at every test point (quantities `terms`), from their
/// lane factors `jel`, into `out.offsets[point]`: joint by joint, so that a joint's factors stay
/// in registers while the points stream past ([`joint_offset_sided`] of each, the same products
/// and sums, so the same bits as one point at a time).
#[inline(always)]
pub(super) fn point_offsets<const N: usize>(
    jel: &JeLanes,
    terms: &[PointTerms],
    payload: bool,
    sides: Sides,
    out: &mut PointScratch,
) {
    const NONE: [u32; LANES] = [0; LANES];
    if sides.is_some() {
        for (pj, w) in out.words.iter_mut().enumerate() {
            *w = point_sides(sides, pj);
        }
    }
    // Points at the centre of the gaps take no side ([`JointErrorDraws::set_centre`]).
    let centre = sides.map_or(&[][..], |(_, _, t)| t.centre.as_slice());
    for i in 0..N {
        let f = &jel[i];
        for (pj, (t, o)) in terms.iter().zip(out.offsets.iter_mut()).enumerate() {
            let w = out.words.get(pj).unwrap_or(&NONE);
            let s = if centre.get(pj).copied().unwrap_or(false) {
                None
            } else {
                sides
            };
            o[i] = joint_offset_sided(f, &t[i], payload, (s, w, i));
        }
    }
}

/// The turns of the first `N` joints of `LANES` draws at a test point from their offsets `o`
/// ([`point_offsets`]): `(sin o, cos o)` by [`tiny_sin_cos`] for |o| < [`TINY_LIMIT`],
/// `sin_cos` beyond. All joints and lanes are checked at once and the rare large offsets fixed
/// outside the hot path ([`large_turns`]), so the chain's loop holds no call.
#[inline(always)]
pub(super) fn joint_turns<const N: usize>(o: &PointOffsets, out: &mut Turns) {
    let mut big = [0.0f64; LANES];
    for i in 0..N {
        for l in 0..LANES {
            (out[i][0][l], out[i][1][l]) = tiny_sin_cos(o[i][l]);
            let a = o[i][l].abs();
            big[l] = if a > big[l] { a } else { big[l] };
        }
    }
    if big.iter().any(|&a| a >= TINY_LIMIT) {
        large_turns::<N>(o, out);
    }
}

/// The lanes of [`joint_turns`] whose offset is at least [`TINY_LIMIT`]: `sin_cos` of the same
/// offset.
#[cold]
#[inline(never)]
fn large_turns<const N: usize>(o: &PointOffsets, out: &mut Turns) {
    for i in 0..N {
        for l in 0..LANES {
            if o[i][l].abs() >= TINY_LIMIT {
                (out[i][0][l], out[i][1][l]) = o[i][l].sin_cos();
            }
        }
    }
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
