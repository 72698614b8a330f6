//! The CPU reference evaluator: f64 forward kinematics of every draw at every test point,
//! parallel over draws with rayon.
//!
//! Draws are processed in blocks of [`LANES`]: the per-draw joint trigonometry is laid out
//! lane-wise so the point loop vectorises (SSE2 everywhere, AVX2 when the processor has it,
//! chosen at run time; no fused multiply-add is used, so both give bit-identical results).
//! `cos(θ_i + δ)` is formed from the mean's cos/sin and a Taylor series in the small offset δ
//! (exact to f64 rounding for |δ| < 0.01 rad; larger offsets call `sin_cos`). Each draw depends
//! only on its index, so the output is identical for any thread count or batch split.
//!
//! Explicit offset matrices ([`Evaluator::evaluate_offsets`]) go through the same lane kernel:
//! only the source of the offsets δ differs (drawn or read from the matrix), so a row equal to
//! [`crate::sampling::ParamSampler::deltas`] of draw `k` gives the bits of draw `k`; so do
//! pick-freeze rows ([`Evaluator::evaluate_pick_freeze`]), whose offsets come from
//! [`crate::sampling::ParamSampler::pick_freeze_lanes`] lane by lane.
//!
//! The tool point's offset (the last three inputs of a draw, docs/METHOD.md §14) moves the
//! point the chain starts from: `p_7 = p_tool + δ_tool` in the flange frame. With no tool spread
//! `δ_tool = 0` and `p_tool + 0 = p_tool` exactly, so the results keep their bits.

use super::{BackendInfo, EngineError, Evaluator, PickFreeze, Problem};
use crate::kinematics::{
    param_index, Block, Capped, InputSpace, ParamKind, MAX_JOINTS, MAX_ROBOT_INPUTS,
};
use rayon::prelude::*;

/// Draws per vector block.
pub const LANES: usize = 8;
/// Draws per rayon task.
const CHUNK: usize = 256;

/// Per-point constants: cos/sin of the commanded joint angles and the reference position.
#[derive(Clone, Copy, Debug)]
struct PointPre {
    /// cos/sin of each joint's angle (the slots beyond the model's joints are unused; plain
    /// arrays, so the kernels' joint loops index them without bounds checks).
    cq: [f64; MAX_JOINTS],
    sq: [f64; MAX_JOINTS],
    r: [f64; 3],
}

/// Per-draw joint constants for a block of lanes: `[cθ, sθ, cα, sα, cβ, sβ, a, d][lane]`, for
/// the model's joints (the slots beyond them are unused).
type JointLanes = [[[f64; LANES]; 8]; MAX_JOINTS];

/// Offsets of a block of lanes: `d[input][lane]`, the model's inputs first (zero beyond).
type OffsetLanes = [[f64; LANES]; MAX_ROBOT_INPUTS];

/// Standard normals of a block of lanes: `z[slot][lane]`.
type Normals = [[f64; LANES]; crate::sampling::MAX_NORMALS];

/// Where the parameter offsets δ of a range of evaluations come from.
#[derive(Clone, Copy)]
enum Source<'a> {
    /// Counter draws from this index on.
    Draws(u64),
    /// Rows of an offset matrix of this many entries per row, from the first row on.
    Offsets(&'a [f64], usize),
    /// Rows of a pick-freeze request from this row on.
    PickFreeze(PickFreeze<'a>, usize),
}

impl<'a> Source<'a> {
    /// The source of the evaluations from `n` on.
    #[inline(always)]
    fn skip(self, n: usize) -> Source<'a> {
        match self {
            Source::Draws(k) => Source::Draws(k + n as u64),
            Source::Offsets(rows, width) => {
                Source::Offsets(&rows[(n * width).min(rows.len())..], width)
            }
            Source::PickFreeze(pf, row) => Source::PickFreeze(pf, row + n),
        }
    }

    /// Offsets of the first [`LANES`] evaluations, lane-wise (lanes past the end of an offset
    /// matrix are zero; past the end of a request they are computed and then discarded).
    /// For draws and pick-freeze rows `z` receives the (mixed) standard normals of the sampler's
    /// Philox blocks, for the placement's offsets of the same rows.
    #[inline(always)]
    fn lanes(self, sampler: &crate::sampling::ParamSampler, d: &mut OffsetLanes, z: &mut Normals) {
        match self {
            Source::Draws(k) => sampler.deltas_normals_lanes::<LANES>(k, d, z),
            Source::Offsets(rows, width) => {
                // The robot's inputs lead a row; the placement's, when a row has them, are
                // read by `PlacementLanes::offsets`.
                let nu = width.min(sampler.n_inputs());
                *d = [[0.0; LANES]; MAX_ROBOT_INPUTS];
                for (l, row) in rows.chunks_exact(width).take(LANES).enumerate() {
                    for i in 0..nu {
                        d[i][l] = row[i];
                    }
                }
            }
            Source::PickFreeze(pf, row) => {
                let (mut a, mut b, mut m) = ([0; LANES], [0; LANES], [0; LANES]);
                for l in 0..LANES {
                    if row + l < pf.rows() {
                        (a[l], b[l], m[l]) = pf.row(row + l);
                    }
                }
                sampler.pick_freeze_normals_lanes::<LANES>(&a, &b, &m, d, z);
            }
        }
    }
}

/// The rayon evaluator.
pub struct CpuEvaluator {
    problem: Problem,
    points: Vec<PointPre>,
    /// sin/cos of the mean θ, α, β per joint.
    mean_trig: Capped<[(f64, f64); 3], MAX_JOINTS>,
    /// Number of joints of the model.
    joints: usize,
    avx2: bool,
    /// The base placement's offsets, for a model whose placement is uncertain: counter draws,
    /// pick-freeze rows over all its normals and offset rows with the placement's six.
    placement: Option<PlacementLanes>,
}

/// The placement's offsets of a draw, a pick-freeze row or an offset row, and the transforms
/// `ΔB` they give (docs/METHOD.md §2.8): the measurement frame in the lanes, the f64 lanes' one
/// application of [`Block::Placement`]. With the joint Cholesky factor `L = [[L_aa, 0], [L_ba, L_bb]]` (the other inputs
/// first, as the sampler's factor is the leading block), `δ_b = L_ba z_a + L_bb z_b = M δ_a +
/// L_bb z_b` with `M = L_ba L_aa⁻¹`: the sampler's own δ_a plus the placement's normals (33–38
/// for six joints), so the draws equal [`super::PlacementEvaluator`]'s (to ~1e-11 mm: the lanes
/// compute the chain with shifted sines, the point form with `sin_cos`).
#[derive(Clone, Debug)]
struct PlacementLanes {
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
    space: InputSpace,
    first_at: usize,
}

impl PlacementLanes {
    fn new(problem: &Problem) -> Option<PlacementLanes> {
        let sp = super::PlacementSpread::of(problem).ok()??;
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
    fn offsets(&self, src: Source, d: &OffsetLanes, z: &mut Normals) -> [[f64; LANES]; 6] {
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
    fn transforms(&self, db: &[[f64; LANES]; 6]) -> [[[f64; LANES]; 4]; 3] {
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

/// Runs `$f` with the first `$n` joints' lanes of `$jl` as an array of that length (the kernels
/// are compiled once per joint count, 4 to 7).
macro_rules! with_joints {
    ($n:expr, $jl:expr, |$j:ident| $f:expr) => {
        match $n {
            4 => {
                let $j: &[[[f64; LANES]; 8]; 4] = first_joints($jl);
                $f
            }
            5 => {
                let $j: &[[[f64; LANES]; 8]; 5] = first_joints($jl);
                $f
            }
            6 => {
                let $j: &[[[f64; LANES]; 8]; 6] = first_joints($jl);
                $f
            }
            _ => {
                let $j: &[[[f64; LANES]; 8]; 7] = first_joints($jl);
                $f
            }
        }
    };
}

/// The first `N` joints of `jl`.
#[inline(always)]
fn first_joints<const N: usize>(jl: &JointLanes) -> &[[[f64; LANES]; 8]; N] {
    const { assert!(N <= MAX_JOINTS) };
    jl[..N].try_into().expect("N ≤ MAX_JOINTS")
}

/// Offsets at or above this (radians) use `sin_cos` instead of the series.
const SERIES_LIMIT: f64 = 0.01;

/// `(sin δ, cos δ)` by Taylor series to δ⁷ and δ⁸: exact to f64 rounding for |δ| < 0.01 rad,
/// the size of calibration spreads. Branch-free so it vectorises; see [`shifted_exact`].
#[inline(always)]
fn small_sin_cos(d: f64) -> (f64, f64) {
    let d2 = d * d;
    let s = d * (1.0 - d2 / 6.0 * (1.0 - d2 / 20.0 * (1.0 - d2 / 42.0)));
    let c = 1.0 - d2 / 2.0 * (1.0 - d2 / 12.0 * (1.0 - d2 / 30.0 * (1.0 - d2 / 56.0)));
    (s, c)
}

/// `(sin(x0+δ), cos(x0+δ))` from `(sin x0, cos x0)`, for |δ| < [`SERIES_LIMIT`].
#[inline(always)]
fn shifted((s0, c0): (f64, f64), d: f64) -> (f64, f64) {
    let (sd, cd) = small_sin_cos(d);
    (s0 * cd + c0 * sd, c0 * cd - s0 * sd)
}

/// The same for any δ (large offsets: `sin_cos`).
fn shifted_exact((s0, c0): (f64, f64), d: f64) -> (f64, f64) {
    let (sd, cd) = d.sin_cos();
    (s0 * cd + c0 * sd, c0 * cd - s0 * sd)
}

impl CpuEvaluator {
    /// Prepares the per-point constants.
    pub fn new(problem: Problem) -> Self {
        let points = problem
            .points
            .iter()
            .zip(&problem.reference)
            .map(|(q, r)| PointPre {
                cq: std::array::from_fn(|j| q.get(j).map_or(1.0, |v| v.cos())),
                sq: std::array::from_fn(|j| q.get(j).map_or(0.0, |v| v.sin())),
                r: *r,
            })
            .collect();
        let p = &problem.sampler.mean;
        let joints = problem.model.joints();
        let mean_trig = Capped::from_fn(joints, |j| {
            [
                p[param_index(j, ParamKind::Theta)].sin_cos(),
                p[param_index(j, ParamKind::Alpha)].sin_cos(),
                p[param_index(j, ParamKind::Beta)].sin_cos(),
            ]
        });
        #[cfg(target_arch = "x86_64")]
        let avx2 = std::is_x86_feature_detected!("avx2");
        #[cfg(not(target_arch = "x86_64"))]
        let avx2 = false;
        let placement = PlacementLanes::new(&problem);
        CpuEvaluator {
            problem,
            points,
            mean_trig,
            joints,
            avx2,
            placement,
        }
    }

    /// The problem evaluated.
    pub fn problem(&self) -> &Problem {
        &self.problem
    }

    /// Joint constants of the [`LANES`] parameter vectors `mean + d[..][l]`.
    #[inline(always)]
    fn fill_lanes(&self, d: &OffsetLanes, jl: &mut JointLanes) {
        let mean = &self.problem.sampler.mean;
        for (j, lanes) in jl.iter_mut().enumerate().take(self.joints) {
            let t = &self.mean_trig[j];
            for (slot, (idx, base)) in [
                (0, (param_index(j, ParamKind::Theta), t[0])),
                (2, (param_index(j, ParamKind::Alpha), t[1])),
                (4, (param_index(j, ParamKind::Beta), t[2])),
            ] {
                for l in 0..LANES {
                    let (s, c) = shifted(base, d[idx][l]);
                    lanes[slot][l] = c;
                    lanes[slot + 1][l] = s;
                }
                for l in 0..LANES {
                    if d[idx][l].abs() >= SERIES_LIMIT {
                        let (s, c) = shifted_exact(base, d[idx][l]);
                        lanes[slot][l] = c;
                        lanes[slot + 1][l] = s;
                    }
                }
            }
            for l in 0..LANES {
                lanes[6][l] =
                    mean[param_index(j, ParamKind::A)] + d[param_index(j, ParamKind::A)][l];
                lanes[7][l] =
                    mean[param_index(j, ParamKind::D)] + d[param_index(j, ParamKind::D)][l];
            }
        }
    }

    fn eval_chunk(&self, src: Source, w: &mut [f64], e: Option<&mut [f64]>) {
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: the processor supports AVX2 (checked at construction).
            unsafe { self.eval_chunk_avx2(src, w, e) };
            return;
        }
        self.eval_chunk_impl(src, w, e);
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn eval_chunk_avx2(&self, src: Source, w: &mut [f64], e: Option<&mut [f64]>) {
        self.eval_chunk_impl(src, w, e);
    }

    /// Offsets (drawn or given) and kinematics of one rayon task, inlined into the AVX2 or the
    /// portable entry so that both the per-draw work and the point loop vectorise.
    #[inline(always)]
    fn eval_chunk_impl(&self, src: Source, w: &mut [f64], mut e: Option<&mut [f64]>) {
        let m = self.points.len();
        let mut jl: JointLanes = [[[0.0; LANES]; 8]; MAX_JOINTS];
        let mut d: OffsetLanes = [[0.0; LANES]; MAX_ROBOT_INPUTS];
        let mut z: Normals = [[0.0; LANES]; crate::sampling::MAX_NORMALS];
        // Block::Tool: the point the flange carries (Block::Joints fill the link lanes).
        let tp = self
            .problem
            .sampler
            .space()
            .range(Block::Tool)
            .map_or(0, |r| r.start);
        let mut e_lanes = vec![0.0; if e.is_some() { LANES * m } else { 0 }];
        for (b, wb) in w.chunks_mut(LANES).enumerate() {
            src.skip(b * LANES)
                .lanes(&self.problem.sampler, &mut d, &mut z);
            self.fill_lanes(&d, &mut jl);
            let tool = &self.problem.model.tool;
            let tl: [[f64; LANES]; 3] =
                std::array::from_fn(|k| std::array::from_fn(|l| tool[k] + d[tp + k][l]));
            let mut w2 = [0.0f64; LANES];
            let el = if e.is_some() {
                Some(e_lanes.as_mut_slice())
            } else {
                None
            };
            let place = self
                .placement
                .as_ref()
                .map(|p| p.transforms(&p.offsets(src.skip(b * LANES), &d, &mut z)));
            match &place {
                None => self.run_block(&jl, &tl, &mut w2, el),
                Some(t) => with_joints!(self.joints, &jl, |j| block_kernel_placed(
                    j,
                    &tl,
                    &self.points,
                    t,
                    &mut w2,
                    el
                )),
            }
            for (l, v) in wb.iter_mut().enumerate() {
                *v = w2[l].sqrt();
            }
            if let Some(e) = e.as_deref_mut() {
                let n = wb.len();
                e[b * LANES * m..(b * LANES + n) * m].copy_from_slice(&e_lanes[..n * m]);
            }
        }
    }

    #[inline(always)]
    fn run_block(
        &self,
        jl: &JointLanes,
        tool: &[[f64; LANES]; 3],
        w2: &mut [f64; LANES],
        e: Option<&mut [f64]>,
    ) {
        with_joints!(self.joints, jl, |j| block_kernel(
            j,
            tool,
            &self.points,
            w2,
            e
        ));
    }
}

/// [`block_kernel`] with each lane's end position moved by its placement offset `ΔB` (rows of
/// `[ΔR | Δt]` per lane) before it is compared with the reference.
#[inline(always)]
fn block_kernel_placed<const N: usize>(
    jl: &[[[f64; LANES]; 8]; N],
    tool: &[[f64; LANES]; 3],
    pts: &[PointPre],
    t: &[[[f64; LANES]; 4]; 3],
    w2: &mut [f64; LANES],
    mut e: Option<&mut [f64]>,
) {
    let m = pts.len();
    for (pj, p) in pts.iter().enumerate() {
        let (x, y, z) = chain_lanes(jl, tool, p);
        let mut e2 = [0.0; LANES];
        for l in 0..LANES {
            let px = t[0][0][l] * x[l] + t[0][1][l] * y[l] + t[0][2][l] * z[l] + t[0][3][l];
            let py = t[1][0][l] * x[l] + t[1][1][l] * y[l] + t[1][2][l] * z[l] + t[1][3][l];
            let pz = t[2][0][l] * x[l] + t[2][1][l] * y[l] + t[2][2][l] * z[l] + t[2][3][l];
            let (dx, dy, dz) = (px - p.r[0], py - p.r[1], pz - p.r[2]);
            e2[l] = dx * dx + dy * dy + dz * dz;
            w2[l] = if e2[l] > w2[l] { e2[l] } else { w2[l] };
        }
        if let Some(e) = e.as_deref_mut() {
            for l in 0..LANES {
                e[l * m + pj] = e2[l].sqrt();
            }
        }
    }
}

/// The end positions of `LANES` draws at point `p` (the chain from the tool to the base; one
/// entry of `jl` per joint, `N` of them, so that the joint loop's bound is known when compiled).
#[inline(always)]
fn chain_lanes<const N: usize>(
    jl: &[[[f64; LANES]; 8]; N],
    tool: &[[f64; LANES]; 3],
    p: &PointPre,
) -> ([f64; LANES], [f64; LANES], [f64; LANES]) {
    let mut x = tool[0];
    let mut y = tool[1];
    let mut z = tool[2];
    for i in (0..N).rev() {
        let [ct, st, ca, sa, cb, sb, a, d] = &jl[i];
        let (cq, sq) = (p.cq[i], p.sq[i]);
        for l in 0..LANES {
            // Ry(β)
            let x1 = cb[l] * x[l] + sb[l] * z[l];
            let z1 = cb[l] * z[l] - sb[l] * x[l];
            // Rx(α), Tx(a), Tz(d)
            let y2 = ca[l] * y[l] - sa[l] * z1;
            let z2 = sa[l] * y[l] + ca[l] * z1 + d[l];
            let x2 = x1 + a[l];
            // Rz(θ+q)
            let c = ct[l] * cq - st[l] * sq;
            let s = st[l] * cq + ct[l] * sq;
            x[l] = c * x2 - s * y2;
            y[l] = s * x2 + c * y2;
            z[l] = z2;
        }
    }
    (x, y, z)
}

/// Squared maximum point error of `LANES` draws (and per-point errors, lane-major); `tool` is
/// each lane's tool point in the flange frame.
#[inline(always)]
fn block_kernel<const N: usize>(
    jl: &[[[f64; LANES]; 8]; N],
    tool: &[[f64; LANES]; 3],
    pts: &[PointPre],
    w2: &mut [f64; LANES],
    mut e: Option<&mut [f64]>,
) {
    let m = pts.len();
    for (pj, p) in pts.iter().enumerate() {
        let (x, y, z) = chain_lanes(jl, tool, p);
        let mut e2 = [0.0; LANES];
        for l in 0..LANES {
            let (dx, dy, dz) = (x[l] - p.r[0], y[l] - p.r[1], z[l] - p.r[2]);
            e2[l] = dx * dx + dy * dy + dz * dz;
            w2[l] = if e2[l] > w2[l] { e2[l] } else { w2[l] };
        }
        if let Some(e) = e.as_deref_mut() {
            for l in 0..LANES {
                e[l * m + pj] = e2[l].sqrt();
            }
        }
    }
}

impl Evaluator for CpuEvaluator {
    fn info(&self) -> BackendInfo {
        BackendInfo {
            backend: "cpu".into(),
            adapter: format!(
                "rayon f64{}{}",
                if self.avx2 { " (AVX2)" } else { "" },
                if self.placement.is_some() {
                    ", with the base placement"
                } else {
                    ""
                }
            ),
            driver: format!("{} threads", rayon::current_num_threads()),
        }
    }

    fn n_points(&self) -> usize {
        self.points.len()
    }

    fn eval_draws(
        &mut self,
        first: u64,
        w: &mut [f64],
        per_point: Option<&mut [f64]>,
    ) -> Result<(), EngineError> {
        self.run(Source::Draws(first), w, per_point);
        Ok(())
    }

    fn layout(&self) -> crate::kinematics::Layout {
        self.problem.model.layout()
    }

    fn offset_space(&self) -> InputSpace {
        match &self.placement {
            Some(p) => p.space,
            None => self.problem.sampler.space(),
        }
    }

    fn eval_offsets(
        &mut self,
        offsets: &[f64],
        w: &mut [f64],
        per_point: Option<&mut [f64]>,
    ) -> Result<(), EngineError> {
        let width = self.offset_space().len();
        self.run(Source::Offsets(offsets, width), w, per_point);
        Ok(())
    }

    fn eval_pick_freeze(&mut self, request: &PickFreeze, w: &mut [f64]) -> Result<(), EngineError> {
        self.run(Source::PickFreeze(*request, 0), w, None);
        Ok(())
    }
}

impl CpuEvaluator {
    /// Evaluates `w.len()` parameter vectors from `src` in parallel tasks of [`CHUNK`].
    fn run(&self, src: Source, w: &mut [f64], per_point: Option<&mut [f64]>) {
        let m = self.points.len();
        match per_point {
            None => w.par_chunks_mut(CHUNK).enumerate().for_each(|(c, wc)| {
                self.eval_chunk(src.skip(c * CHUNK), wc, None);
            }),
            Some(e) => w
                .par_chunks_mut(CHUNK)
                .zip(e.par_chunks_mut(CHUNK * m))
                .enumerate()
                .for_each(|(c, (wc, ec))| self.eval_chunk(src.skip(c * CHUNK), wc, Some(ec))),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    const NP: usize = 30;
    const NU: usize = 33;
    use crate::engine::Reference;
    use crate::kinematics::tx60;

    fn problem() -> Problem {
        let pts = [
            [10.0, -20.0, 30.0, 40.0, 50.0, 60.0],
            [-100.0, 45.0, 90.0, -30.0, 20.0, 10.0],
            [0.0; 6],
        ];
        Problem::new(tx60(), &pts, &Reference::Calibrated, 42).unwrap()
    }

    /// A base transform moves both the analysed and the reference positions rigidly, so the
    /// errors the evaluator computes in the base frame equal those of the positions in the
    /// description's frame (KUKA KR 6 with its base Rx(180°); f64 rounding of 1000 mm values
    /// through one rotation, 1e-9 mm).
    #[test]
    fn errors_are_invariant_to_the_base_transform() {
        let mut m = crate::presets::kr6r700sixx();
        assert!(m.base.is_some());
        let mut s = crate::kinematics::Params::filled(NP, 0.0);
        for (i, v) in s.iter_mut().enumerate() {
            if m.fixed[i / 5].kind() != crate::kinematics::param_kind(i) {
                *v = if crate::kinematics::param_kind(i).is_angle() {
                    1e-4
                } else {
                    0.02
                };
            }
        }
        m.uncertainty = crate::kinematics::Uncertainty::Independent(s);
        m.tool_sigma = [0.01; 3];
        let pts = [[10.0, -20.0, 30.0, 40.0, 50.0, 60.0], [0.0; 6]];
        let pb = Problem::new(m.clone(), &pts, &Reference::Calibrated, 3).unwrap();
        let mut ev = CpuEvaluator::new(pb.clone());
        let (mut w, mut e) = (vec![0.0; 9], vec![0.0; 18]);
        ev.evaluate(0, &mut w, Some(&mut e)).unwrap();
        for k in 0..9 {
            let mut drawn = m.clone();
            drawn.params = pb.sampler.draw(k as u64);
            let t = pb.sampler.tool_deltas(k as u64);
            drawn.tool = std::array::from_fn(|c| m.tool[c] + t[c]);
            for (j, q) in pb.points.iter().enumerate() {
                let (a, b) = (drawn.world_position(q), m.world_position(q));
                let d =
                    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt();
                assert!(
                    (d - e[k * 2 + j]).abs() < 1e-9,
                    "{k} {j}: {d} vs {}",
                    e[k * 2 + j]
                );
                assert!(d > 1e-3);
            }
        }
    }

    /// A tool spread: every draw's errors equal direct forward kinematics of the drawn
    /// parameters with the drawn tool point (f64 throughout; 1e-10 mm covers the series and
    /// summation order), and the tool's offset changes them.
    #[test]
    fn tool_spread_matches_direct_forward_kinematics() {
        let mut m = tx60();
        m.tool = [40.0, -10.0, 120.0];
        m.tool_sigma = [0.01, 0.02, 0.005];
        let pts = [[10.0, -20.0, 30.0, 40.0, 50.0, 60.0], [0.0; 6]];
        let pb = Problem::new(m, &pts, &Reference::Calibrated, 9).unwrap();
        let mut ev = CpuEvaluator::new(pb.clone());
        let n = 21;
        let (mut w, mut e) = (vec![0.0; n], vec![0.0; 2 * n]);
        ev.evaluate(77, &mut w, Some(&mut e)).unwrap();
        for i in 0..n {
            let k = 77 + i as u64;
            let (params, tool) = (pb.sampler.draw(k), pb.sampler.tool_deltas(k));
            let direct = pb.point_errors_at(&params, &tool);
            let without = pb.point_errors(&params);
            for j in 0..2 {
                assert!((direct[j] - e[i * 2 + j]).abs() < 1e-10, "{i} {j}");
                assert!((without[j] - e[i * 2 + j]).abs() > 1e-6, "{i} {j}");
            }
        }
    }

    #[test]
    fn matches_direct_forward_kinematics() {
        let pb = problem();
        let mut ev = CpuEvaluator::new(pb.clone());
        let n = 37; // not a multiple of the lane count
        let mut w = vec![0.0; n];
        let mut e = vec![0.0; n * 3];
        ev.evaluate(1000, &mut w, Some(&mut e)).unwrap();
        for i in 0..n {
            let direct = pb.point_errors(&pb.sampler.draw(1000 + i as u64));
            for j in 0..3 {
                assert!((direct[j] - e[i * 3 + j]).abs() < 1e-10, "{i} {j}");
            }
            let wmax = direct.iter().cloned().fold(0.0, f64::max);
            assert!((wmax - w[i]).abs() < 1e-10);
        }
    }

    #[test]
    fn batch_split_and_simd_do_not_change_results() {
        let mut ev = CpuEvaluator::new(problem());
        let mut all = vec![0.0; 1000];
        ev.evaluate(0, &mut all, None).unwrap();
        let mut parts = vec![0.0; 1000];
        ev.evaluate(0, &mut parts[..333], None).unwrap();
        ev.evaluate(333, &mut parts[333..], None).unwrap();
        assert_eq!(all, parts);
        if ev.avx2 {
            ev.avx2 = false; // the portable kernel must give the same bits
            let mut other = vec![0.0; 1000];
            ev.evaluate(0, &mut other, None).unwrap();
            assert_eq!(all, other);
        }
    }

    /// Rows equal to the sampler's own offsets give the bits of the counter draws, per point
    /// too, for any row count (not a multiple of the lane or task size).
    #[test]
    fn offset_rows_of_the_draws_equal_the_draws() {
        let pb = problem();
        let mut ev = CpuEvaluator::new(pb.clone());
        let (first, n, m) = (5_000u64, 2 * CHUNK + 13, 3);
        let mut rows = vec![0.0; n * NU];
        for (i, row) in rows.chunks_exact_mut(NU).enumerate() {
            let mut d = [0.0; NU];
            pb.sampler.deltas(first + i as u64, &mut d);
            row.copy_from_slice(&d);
        }
        let (mut w1, mut e1) = (vec![0.0; n], vec![0.0; n * m]);
        let (mut w2, mut e2) = (vec![0.0; n], vec![0.0; n * m]);
        ev.evaluate(first, &mut w1, Some(&mut e1)).unwrap();
        ev.evaluate_offsets(&rows, &mut w2, Some(&mut e2)).unwrap();
        assert_eq!(w1, w2);
        assert_eq!(e1, e2);
        let mut w3 = vec![0.0; n];
        ev.evaluate_offsets(&rows, &mut w3, None).unwrap();
        assert_eq!(w1, w3);
    }

    /// Pick-freeze rows equal the offset rows of the sampler's pick-freeze offsets, to the
    /// bit, for matrices that straddle lane blocks and tasks; mask 0 gives the draws.
    #[test]
    fn pick_freeze_rows_equal_their_offset_rows() {
        use crate::engine::PickFreeze;
        use crate::sampling::ALL_NORMALS;
        let pb = problem();
        let mut ev = CpuEvaluator::new(pb.clone());
        let masks = [0, ALL_NORMALS, 1 << 5, (1 << 12) | (1 << 17), 0xff_0000];
        let request = PickFreeze {
            first: (1 << 32) - 100, // the draw index carries into the high word
            b_first: (1 << 63) + (1 << 32) - 100,
            count: CHUNK + 5,
            masks: &masks,
        };
        let n = request.rows();
        let mut rows = vec![0.0; n * NU];
        for (r, row) in rows.chunks_exact_mut(NU).enumerate() {
            let (a, b, m) = request.row(r);
            let mut d = [0.0; NU];
            pb.sampler.pick_freeze_deltas(a, b, m, &mut d);
            row.copy_from_slice(&d);
        }
        let (mut w1, mut w2) = (vec![0.0; n], vec![0.0; n]);
        ev.evaluate_pick_freeze(&request, &mut w1).unwrap();
        ev.evaluate_offsets(&rows, &mut w2, None).unwrap();
        assert_eq!(w1, w2);
        let mut wa = vec![0.0; request.count];
        ev.evaluate(request.first, &mut wa, None).unwrap();
        assert_eq!(w1[..request.count], wa[..]);
        ev.evaluate(request.b_first, &mut wa, None).unwrap();
        assert_eq!(w1[request.count..2 * request.count], wa[..]);
        assert_ne!(w1[2 * request.count..3 * request.count], wa[..]);
    }

    /// A large angular offset (beyond the series range) against direct forward kinematics.
    #[test]
    fn large_offsets_match_direct_forward_kinematics() {
        let pb = problem();
        let mut ev = CpuEvaluator::new(pb.clone());
        let mut rows = vec![0.0; 2 * NU];
        rows[5] = 0.3; // θ2, rad
        rows[NU + 13] = -0.02; // α3, rad
        rows[NU + 7] = 1.5; // a2, mm
        rows[NU + NP + 1] = -0.7; // tool y, mm
        let (mut w, mut e) = (vec![0.0; 2], vec![0.0; 6]);
        ev.evaluate_offsets(&rows, &mut w, Some(&mut e)).unwrap();
        for (i, row) in rows.chunks_exact(NU).enumerate() {
            let params: [f64; NP] = std::array::from_fn(|p| pb.sampler.mean[p] + row[p]);
            let tool = std::array::from_fn(|k| row[NP + k]);
            let direct = pb.point_errors_at(&params, &tool);
            for j in 0..3 {
                assert!((direct[j] - e[i * 3 + j]).abs() < 1e-9, "{i} {j}");
            }
            assert!(w[i] > 1.0, "the offsets move the tool by over a millimetre");
        }
    }
}
