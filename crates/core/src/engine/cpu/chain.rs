//! The chain of a block of lanes at every test point: each lane's end position (turned by its
//! joint errors' offsets when the model has them), its squared error against the point's
//! reference and the block's maximum ([`block_kernel`]).

use super::joint_errors::{joint_turns, point_offsets, PointScratch, Turns};
use super::{Disc, Je, PointPre, LANES};
use crate::kinematics::MAX_JOINTS;

/// The end positions of `LANES` draws at point `p` (the chain from the tool to the base; one
/// entry of `jl` per joint, `N` of them, so that the joint loop's bound is known when compiled).
#[inline(always)]
fn chain_lanes<const N: usize>(
    jl: &[[[f64; LANES]; 8]; N],
    tool: &[[f64; LANES]; 3],
    p: &PointPre,
) -> ([f64; LANES], [f64; LANES], [f64; LANES]) {
    chain_lanes_turned::<N, false>(jl, tool, p, &[[[0.0; LANES]; 2]; MAX_JOINTS])
}

/// The chain of [`chain_lanes`], each joint turned by `turns` (`[sin, cos]` of its offset per
/// lane) when `TURN` (compiled out otherwise, so the plain chain keeps its instructions and bits).
#[inline(always)]
fn chain_lanes_turned<const N: usize, const TURN: bool>(
    jl: &[[[f64; LANES]; 8]; N],
    tool: &[[f64; LANES]; 3],
    p: &PointPre,
    turns: &Turns,
) -> ([f64; LANES], [f64; LANES], [f64; LANES]) {
    let mut x = tool[0];
    let mut y = tool[1];
    let mut z = tool[2];
    for i in (0..N).rev() {
        let [ct, st, ca, sa, cb, sb, a, d] = &jl[i];
        let (cq, sq) = (p.cq[i], p.sq[i]);
        let [so, co] = &turns[i];
        for l in 0..LANES {
            // Ry(β)
            let x1 = cb[l] * x[l] + sb[l] * z[l];
            let z1 = cb[l] * z[l] - sb[l] * x[l];
            // Rx(α), Tx(a), Tz(d)
            let y2 = ca[l] * y[l] - sa[l] * z1;
            let z2 = sa[l] * y[l] + ca[l] * z1 + d[l];
            let x2 = x1 + a[l];
            // Rz(θ+q), then turned by the offset
            let mut c = ct[l] * cq - st[l] * sq;
            let mut s = st[l] * cq + ct[l] * sq;
            if TURN {
                (c, s) = (c * co[l] - s * so[l], s * co[l] + c * so[l]);
            }
            x[l] = c * x2 - s * y2;
            y[l] = s * x2 + c * y2;
            z[l] = z2;
        }
    }
    (x, y, z)
}

/// The placement offsets `ΔB` of a block of lanes: rows of `[ΔR | Δt]` per lane.
pub(super) type Placed = [[[f64; LANES]; 4]; 3];

/// Squared maximum point error of `LANES` draws (and per-point errors, lane-major); `tool` is
/// each lane's tool point in the flange frame. With `PLACED` each lane's end position is moved
/// by its placement offset `t` before it is compared with the reference (compiled out
/// otherwise, so the kernel in the base frame keeps its instructions and bits).
#[inline(always)]
pub(super) fn block_kernel<const N: usize, const PLACED: bool>(
    jl: &[[[f64; LANES]; 8]; N],
    tool: &[[f64; LANES]; 3],
    (pts, t): (&[PointPre], &Placed),
    w2: &mut [f64; LANES],
    mut e: Option<&mut [f64]>,
    (disc, je, offs): (Disc, Je, &mut PointScratch),
) {
    let m = pts.len();
    let mut words = [[0u32; LANES]; 4];
    let mut turns: Turns = [[[0.0; LANES]; 2]; MAX_JOINTS];
    if let Some((jel, terms, payload, sides)) = je {
        point_offsets::<N>(jel, terms, payload, sides, offs);
    }
    for (pj, p) in pts.iter().enumerate() {
        let (mut x, mut y, mut z) = match je {
            None => chain_lanes(jl, tool, p),
            Some(_) => {
                joint_turns::<N>(&offs.offsets[pj], &mut turns);
                chain_lanes_turned::<N, true>(jl, tool, p, &turns)
            }
        };
        if PLACED {
            for l in 0..LANES {
                let px = t[0][0][l] * x[l] + t[0][1][l] * y[l] + t[0][2][l] * z[l] + t[0][3][l];
                let py = t[1][0][l] * x[l] + t[1][1][l] * y[l] + t[1][2][l] * z[l] + t[1][3][l];
                let pz = t[2][0][l] * x[l] + t[2][1][l] * y[l] + t[2][2][l] * z[l] + t[2][3][l];
                (x[l], y[l], z[l]) = (px, py, pz);
            }
        }
        let mut e2 = [0.0; LANES];
        for l in 0..LANES {
            let (dx, dy, dz) = (x[l] - p.r[0], y[l] - p.r[1], z[l] - p.r[2]);
            e2[l] = dx * dx + dy * dy + dz * dz;
        }
        if let Some((dd, draws)) = disc {
            dd.apply_squared_lanes(&mut e2, draws, pj, &mut words);
        }
        for l in 0..LANES {
            w2[l] = if e2[l] > w2[l] { e2[l] } else { w2[l] };
        }
        if let Some(e) = e.as_deref_mut() {
            for l in 0..LANES {
                e[l * m + pj] = e2[l].sqrt();
            }
        }
    }
}
