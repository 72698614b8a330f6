//! The measurement frame in the lanes: the placement's offsets of counter draws, pick-freeze
//! rows and offset rows, and the transforms `ΔB` that move each lane's end position
//! (docs/METHOD.md §2.8).

use super::{Normals, OffsetLanes, Source, LANES};
use crate::engine::Problem;
use crate::kinematics::{Block, InputSpace};

/// The placement's offsets of a draw, a pick-freeze row or an offset row, and the transforms
/// `ΔB` they give (docs/METHOD.md §2.8): the measurement frame in the lanes, the f64 lanes' one
/// application of [`Block::Placement`]. With the joint Cholesky factor `L = [[L_aa, 0], [L_ba, L_bb]]` (the other inputs
/// first, as the sampler's factor is the leading block), `δ_b = L_ba z_a + L_bb z_b = M δ_a +
/// L_bb z_b` with `M = L_ba L_aa⁻¹`: the sampler's own δ_a plus the placement's normals (33–38
/// for six joints), so the draws equal [`super::PlacementEvaluator`]'s (to ~1e-11 mm: the lanes
/// compute the chain with shifted sines, the point form with `sin_cos`).
#[derive(Clone, Debug)]
pub(super) struct PlacementLanes {
    /// `M` as (base input k, input i, coefficient), nonzero entries only.
    m: Vec<(usize, usize, f64)>,
    /// `L_bb` as (base input k, base input k', coefficient), k' ≤ k.
    lbb: Vec<(usize, usize, f64)>,
    /// Philox blocks holding the placement's normals that the sampler does not compute (a
    /// block shared with the tool's normals is the sampler's).
    blocks: Vec<u32>,
    /// Mean placement: x, y, z (mm), roll, pitch, yaw (rad).
    base: [f64; 6],
    /// `R̂ᵀ`, row-major.
    r_mean_t: [[f64; 3]; 3],
    gen: crate::sampling::Philox,
    /// The normal slot of the placement's first input ([`InputSpace::slot_range`]).
    first_slot: usize,
    /// The inputs of an offset row ([`InputSpace::measured`]) and where the placement's lie.
    pub(super) space: InputSpace,
    first_at: usize,
}

impl PlacementLanes {
    pub(super) fn new(problem: &Problem) -> Option<PlacementLanes> {
        let sp = crate::engine::PlacementSpread::of(problem).ok()??;
        let p = sp.free.len();
        // The placement's inputs follow the robot's (positions and slots alike).
        let nu = sp.space.range(Block::Placement)?.start;
        let na = sp.free.iter().filter(|&&i| i < nu).count();
        let l = nalgebra::DMatrix::from_fn(p, p, |a, b| sp.chol[a * p + b]);
        let laa = l.view((0, 0), (na, na)).into_owned();
        let lba = l.view((na, 0), (p - na, na)).into_owned();
        // M = L_ba L_aa⁻¹: solve L_aaᵀ Mᵀ = L_baᵀ.
        let mt = laa
            .transpose()
            .solve_upper_triangular(&lba.transpose())
            .unwrap_or_else(|| nalgebra::DMatrix::zeros(na, p - na));
        let mut m = Vec::new();
        let mut lbb = Vec::new();
        for (kb, &ib) in sp.free[na..].iter().enumerate() {
            for (ka, &ia) in sp.free[..na].iter().enumerate() {
                let v = mt[(ka, kb)];
                if v != 0.0 {
                    m.push((ib - nu, ia, v));
                }
            }
            for (kb2, &ib2) in sp.free[na..].iter().enumerate().take(kb + 1) {
                lbb.push((ib - nu, ib2 - nu, l[(na + kb, na + kb2)]));
            }
        }
        let mut blocks: Vec<u32> = sp.free[na..]
            .iter()
            .map(|&i| (sp.space.slot(i) / 4) as u32)
            .collect();
        blocks.dedup();
        blocks.retain(|b| !problem.sampler.blocks().contains(b));
        let rt =
            nalgebra::Rotation3::from_euler_angles(sp.base[3], sp.base[4], sp.base[5]).inverse();
        Some(PlacementLanes {
            m,
            lbb,
            blocks,
            base: sp.base,
            r_mean_t: std::array::from_fn(|r| std::array::from_fn(|c| rt[(r, c)])),
            gen: crate::sampling::Philox::new(problem.seed),
            first_slot: sp.space.slot_range(Block::Placement).start,
            space: sp.space,
            first_at: nu,
        })
    }

    /// The placement's offsets `δ_b` (x, y, z mm; roll, pitch, yaw rad) of the [`LANES`]
    /// evaluations of `src`, whose other offsets are `d` and whose sampler's normals are `z`:
    /// read from an offset row, or `M δ_a + L_bb z_b` with the placement's normals of a counter
    /// draw or of a pick-freeze row (normal `s` from draw `b` where bit `s` of the mask is set),
    /// the blocks the sampler did not compute added to `z`.
    #[inline(always)]
    pub(super) fn offsets(
        &self,
        src: Source,
        d: &OffsetLanes,
        z: &mut Normals,
    ) -> [[f64; LANES]; 6] {
        let mut db = [[0.0; LANES]; 6];
        match src {
            Source::Offsets(rows, width) => {
                for (l, row) in rows.chunks_exact(width).take(LANES).enumerate() {
                    for (k, v) in db.iter_mut().enumerate() {
                        v[l] = row[self.first_at + k];
                    }
                }
                return db;
            }
            Source::Draws(k) => {
                let draws = std::array::from_fn(|l| k + l as u64);
                crate::sampling::normals_lanes(&self.gen, &self.blocks, &draws, |_| true, z);
            }
            Source::PickFreeze(pf, row) => {
                let (mut a, mut b, mut m) = ([0; LANES], [0; LANES], [0u64; LANES]);
                for l in 0..LANES {
                    if row + l < pf.rows() {
                        (a[l], b[l], m[l]) = pf.row(row + l);
                    }
                }
                crate::sampling::pick_freeze_normals(&self.gen, &self.blocks, &a, &b, &m, z);
            }
        }
        for &(kb, i, v) in &self.m {
            for l in 0..LANES {
                db[kb][l] += v * d[i][l];
            }
        }
        for &(kb, kb2, v) in &self.lbb {
            for l in 0..LANES {
                db[kb][l] += v * z[self.first_slot + kb2][l];
            }
        }
        db
    }

    /// `ΔB = B̂⁻¹B'` of the [`LANES`] placements `B̂ + δ_b` ([`Self::offsets`]): per lane the
    /// rows of `[ΔR | Δt]`.
    pub(super) fn transforms(&self, db: &[[f64; LANES]; 6]) -> [[[f64; LANES]; 4]; 3] {
        let mut out = [[[0.0; LANES]; 4]; 3];
        for l in 0..LANES {
            let r = nalgebra::Rotation3::from_euler_angles(
                self.base[3] + db[3][l],
                self.base[4] + db[4][l],
                self.base[5] + db[5][l],
            );
            let rt = &self.r_mean_t;
            for row in 0..3 {
                for c in 0..3 {
                    out[row][c][l] = (0..3).map(|k| rt[row][k] * r[(k, c)]).sum();
                }
                out[row][3][l] = (0..3).map(|k| rt[row][k] * db[k][l]).sum();
            }
        }
        out
    }
}
