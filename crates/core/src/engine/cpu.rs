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
//!
//! (A little over 600 lines: the block driver and the point kernels share the private lane
//! types and must inline into one AVX2 entry point; the placement's and the joint errors' lanes
//! are the submodules `placement` and `joint_errors`.)

use super::DiscrepancyDraws;
use super::{BackendInfo, EngineError, Evaluator, PickFreeze, Problem};
use crate::kinematics::joint_errors::PointTerms;
use crate::kinematics::{
    param_index, Block, Capped, InputSpace, ParamKind, MAX_JOINTS, MAX_ROBOT_INPUTS,
};
use rayon::prelude::*;

mod chain;
mod joint_errors;
mod placement;
use chain::block_kernel;
use joint_errors::{term_lanes, PointScratch, Sides};
use placement::PlacementLanes;

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

/// The discrepancy term of a block of counter draws: the term and the lanes' draw indices.
type Disc<'a> = Option<(&'a DiscrepancyDraws, &'a [u64; LANES])>;

/// The joint errors' lane factors of a block (per joint `[f0, f1, δa1, δb1, δa2, δb2][lane]`,
/// [`joint_errors::term_lanes`]).
type JeLanes = [[[f64; LANES]; 6]; MAX_JOINTS];

/// The joint errors of a block of lanes: their factors, the test points' quantities, whether
/// the payload's factor can be nonzero ([`crate::engine::JointErrorDraws::payload_term`]) and
/// the backlash's sides.
type Je<'a> = Option<(&'a JeLanes, &'a [PointTerms], bool, Sides<'a>)>;

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
            .chain_points
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
        let space = self.problem.sampler.space();
        // The joint errors are drawn for counter draws and pick-freeze rows, not offset rows.
        let term = match src {
            Source::Offsets(..) => None,
            _ => self.problem.joint_errors.as_ref(),
        };
        let mut jel: JeLanes = [[[0.0; LANES]; 6]; MAX_JOINTS];
        let mut sides = [[0u32; LANES]; 2];
        // The joint errors' offsets of a block at every point (`point_offsets`).
        let mut offs = PointScratch::new(m, term);
        for (b, wb) in w.chunks_mut(LANES).enumerate() {
            src.skip(b * LANES)
                .lanes(&self.problem.sampler, &mut d, &mut z);
            let mut db = self
                .placement
                .as_ref()
                .map(|p| p.offsets(src.skip(b * LANES), &d, &mut z));
            if let Some(t) = term {
                term_lanes(
                    self,
                    t,
                    src.skip(b * LANES),
                    space,
                    &mut d,
                    db.as_mut(),
                    &mut jel,
                    &mut sides,
                );
            }
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
            let place = match (&self.placement, &db) {
                (Some(p), Some(db)) => Some(p.transforms(db)),
                _ => None,
            };
            // The discrepancy term is drawn for counter draws and pick-freeze rows (from the
            // row's `a` or `b` draw by its mask; see `crate::discrepancy`), not for offset rows.
            let draws: [u64; LANES] = match src {
                Source::Draws(k) => std::array::from_fn(|l| k + (b * LANES + l) as u64),
                Source::PickFreeze(pf, row) => std::array::from_fn(|l| {
                    let r = row + b * LANES + l;
                    if r < pf.rows() {
                        pf.discrepancy_draw(r)
                    } else {
                        0
                    }
                }),
                Source::Offsets(..) => [0; LANES],
            };
            let disc = match (src, &self.problem.discrepancy) {
                (Source::Draws(_) | Source::PickFreeze(..), Some(dd)) => Some((dd, &draws)),
                _ => None,
            };
            let je = term.map(|t| {
                let s = t.backlash.then_some((&sides, &t.half_gap, t));
                (&jel, t.terms.as_slice(), t.payload_term(), s)
            });
            match &place {
                None => with_joints!(self.joints, &jl, |j| block_kernel::<_, false>(
                    j,
                    &tl,
                    (&self.points, &[[[0.0; LANES]; 4]; 3]),
                    &mut w2,
                    el,
                    (disc, je, &mut offs)
                )),
                Some(t) => with_joints!(self.joints, &jl, |j| block_kernel::<_, true>(
                    j,
                    &tl,
                    (&self.points, t),
                    &mut w2,
                    el,
                    (disc, je, &mut offs)
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
mod tests;
