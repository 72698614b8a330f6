//! The measurement frame in the lanes: the placement's offsets of counter draws, pick-freeze
//! rows and offset rows, and the transforms `ΔB` that move each lane's end position
//! (docs/METHOD.md §2.8).

use super::{shifted, shifted_exact, Normals, OffsetLanes, Source, LANES, SERIES_LIMIT};
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
    /// The rows of `M` and `L_bb` of each drawn placement input `k`: `(k, m, lbb)` with
    /// `m` the nonzero `(input i, M_ki)` and `lbb` the `(placement input k', L_bb,kk')`, k' ≤ k.
    rows: Vec<Row>,
    /// Philox blocks holding the placement's normals that the sampler does not compute (a
    /// block shared with the tool's normals is the sampler's).
    blocks: Vec<u32>,
    /// `(sin, cos)` of the mean roll, pitch and yaw.
    trig: [(f64, f64); 3],
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
        let rows = sp.free[na..]
            .iter()
            .enumerate()
            .map(|(kb, &ib)| Row {
                k: ib - nu,
                m: (sp.free[..na].iter().enumerate())
                    .map(|(ka, &ia)| (ia, mt[(ka, kb)]))
                    .filter(|&(_, v)| v != 0.0)
                    .collect(),
                lbb: (sp.free[na..].iter().enumerate().take(kb + 1))
                    .map(|(kb2, &ib2)| (ib2 - nu, l[(na + kb, na + kb2)]))
                    .collect(),
            })
            .collect();
        let mut blocks: Vec<u32> = sp.free[na..]
            .iter()
            .map(|&i| (sp.space.slot(i) / 4) as u32)
            .collect();
        blocks.dedup();
        blocks.retain(|b| !problem.sampler.blocks().contains(b));
        let rt =
            nalgebra::Rotation3::from_euler_angles(sp.base[3], sp.base[4], sp.base[5]).inverse();
        Some(PlacementLanes {
            rows,
            blocks,
            trig: std::array::from_fn(|k| sp.base[3 + k].sin_cos()),
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
        // One accumulator per row, kept in registers: the terms are added in the order of
        // `M`'s columns, then `L_bb`'s.
        for row in &self.rows {
            let mut acc = [0.0; LANES];
            for &(i, v) in &row.m {
                for l in 0..LANES {
                    acc[l] += v * d[i][l];
                }
            }
            for &(k2, v) in &row.lbb {
                for l in 0..LANES {
                    acc[l] += v * z[self.first_slot + k2][l];
                }
            }
            db[row.k] = acc;
        }
        db
    }

    /// `ΔB = B̂⁻¹B'` of the [`LANES`] placements `B̂ + δ_b` ([`Self::offsets`]): per lane the
    /// rows of `[ΔR | Δt]`, `ΔR = R̂ᵀR(rpy + δ)`, `Δt = R̂ᵀδ_xyz`, lane-wise so that it
    /// vectorises.
    ///
    /// The sines and cosines of the drawn angles come from those of the mean and the series of
    /// `small_sin_cos` (`engine::cpu`) in the offset, as the joints' do: for |δ| < `SERIES_LIMIT` =
    /// 0.01 rad the truncation after δ⁷ (sine) and δ⁸ (cosine) is below |δ|⁹/9! ≤ 2.8e-24
    /// (2.8e-22 of sin δ) and δ¹⁰/10! ≤ 2.8e-27, far below half an ulp of either, so the values
    /// differ from `sin_cos(mean + δ)` only by the rounding of the mean's `sin_cos` and of
    /// the few products and sums (a few 1e-16 absolute). An
    /// offset at or above the limit takes `sin_cos` (placement offsets are ~1e-4 rad).
    #[inline(always)]
    pub(super) fn transforms(&self, db: &[[f64; LANES]; 6]) -> [[[f64; LANES]; 4]; 3] {
        // sin and cos of roll, pitch and yaw per lane.
        let mut s = [[0.0; LANES]; 3];
        let mut c = [[0.0; LANES]; 3];
        let mut big = [0.0f64; LANES];
        for k in 0..3 {
            for l in 0..LANES {
                (s[k][l], c[k][l]) = shifted(self.trig[k], db[3 + k][l]);
                let a = db[3 + k][l].abs();
                big[l] = if a > big[l] { a } else { big[l] };
            }
        }
        // One check for all lanes and angles; the rare large offsets are fixed out of line.
        if big.iter().any(|&a| a >= SERIES_LIMIT) {
            self.large_angles(db, &mut s, &mut c);
        }
        let rt = &self.r_mean_t;
        let mut out = [[[0.0; LANES]; 4]; 3];
        for l in 0..LANES {
            let ([sr, sp, sy], [cr, cp, cy]) =
                ([s[0][l], s[1][l], s[2][l]], [c[0][l], c[1][l], c[2][l]]);
            // R = Rz(yaw) Ry(pitch) Rx(roll) (nalgebra's `Rotation3::from_euler_angles`).
            let r = [
                [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                [-sp, cp * sr, cp * cr],
            ];
            for row in 0..3 {
                for col in 0..3 {
                    out[row][col][l] =
                        rt[row][0] * r[0][col] + rt[row][1] * r[1][col] + rt[row][2] * r[2][col];
                }
                out[row][3][l] =
                    rt[row][0] * db[0][l] + rt[row][1] * db[1][l] + rt[row][2] * db[2][l];
            }
        }
        out
    }

    /// The lanes of [`Self::transforms`] whose angle offset is at least `SERIES_LIMIT`:
    /// `shifted_exact` (`sin_cos`).
    #[cold]
    #[inline(never)]
    fn large_angles(
        &self,
        db: &[[f64; LANES]; 6],
        s: &mut [[f64; LANES]; 3],
        c: &mut [[f64; LANES]; 3],
    ) {
        for k in 0..3 {
            for l in 0..LANES {
                if db[3 + k][l].abs() >= SERIES_LIMIT {
                    (s[k][l], c[k][l]) = shifted_exact(self.trig[k], db[3 + k][l]);
                }
            }
        }
    }
}

/// One drawn placement input's row of `M` and of `L_bb` ([`PlacementLanes::offsets`]).
#[derive(Clone, Debug)]
struct Row {
    /// The placement input (0–5: x, y, z, roll, pitch, yaw).
    k: usize,
    /// `(input i, M_ki)`, the nonzero entries.
    m: Vec<(usize, f64)>,
    /// `(placement input k', L_bb,kk')`, k' ≤ k.
    lbb: Vec<(usize, f64)>,
}
