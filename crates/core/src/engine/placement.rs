//! Reliability in the measurement frame: draws that include the robot's placement
//! (docs/METHOD.md §2.8).
//!
//! A model identified from data in a tracker's frame carries a covariance with the placement
//! (39 × 39 for six joints): the inputs of every draw (33), then the placement's x, y, z and
//! roll, pitch, yaw, correlated with them. A
//! target given in the measurement frame is missed by
//!
//! ```text
//! e_j = |B' · P(θ', t', q_j) − B̂ · P_ref,j| = |ΔB · P(θ', t', q_j) − P_ref,j|,  ΔB = B̂⁻¹ B'
//! ```
//!
//! with `B'` the drawn placement. [`PlacementEvaluator`] evaluates this exactly in f64, one draw
//! at a time (rayon over draws): the reference of the vectorised [`super::CpuEvaluator`], which
//! applies the placement in its lanes for draws, pick-freeze rows and offset rows alike, and of
//! the GPU kernel's f32 deviation form (mode 2 of
//! `shaders/mdh_max_error.wgsl`, [`super::deviation::SpreadPacking::with_placement`]). Draw
//! `k`'s normals are those of the standard sampler (Philox block `b` gives normals
//! `4b … 4b + 3`), extended by blocks 8–9 for the placement's normals 33–38, so a model whose
//! placement has no spread gives the standard evaluator's draws. Choosing the frame
//! [`Frame::Base`] leaves the placement out (the marginal 33 × 33 block), as for a model without
//! one.

use super::joint_errors::TermDraw;
use super::{BackendInfo, EngineError, Evaluator, PickFreeze, Problem};
use crate::kinematics::{
    position_with_trig, twist_trig, Block, InputSpace, Layout, Params, MAX_INPUTS,
};
use crate::sampling::{normals_block, Philox, MAX_NORMALS, PARAM_STREAM};
use nalgebra::{Matrix3, Rotation3, Vector3};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// The frame the test points' targets are given in.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Frame {
    /// The measurement (tracker, cell) frame: the placement's uncertainty is drawn when the
    /// model has one.
    #[default]
    Measurement,
    /// The robot's own base frame: the placement is left out.
    Base,
}

impl Frame {
    /// How reports name the frame of an analysis of a model with (`drawn`) or without an
    /// uncertain placement.
    pub fn label(self, drawn: bool) -> &'static str {
        match (self, drawn) {
            (Frame::Measurement, true) => "measurement frame (base placement drawn: 6 more inputs)",
            (Frame::Measurement, false) => "measurement frame (the placement is exactly known)",
            (Frame::Base, _) => "robot base frame",
        }
    }
}

impl Problem {
    /// The problem with the model's base placement uncertainty left out (the robot base frame;
    /// the 33 × 33 block).
    pub fn without_placement(mut self) -> Problem {
        self.model = self.model.without_base_uncertainty();
        self.sided = self.sided.map(|m| Box::new(m.without_base_uncertainty()));
        self
    }

    /// The problem an analysis of targets in `frame` runs: in the robot base frame the
    /// placement's uncertainty is left out, in the measurement frame the problem is kept.
    pub fn in_frame(self, frame: Frame) -> Problem {
        match frame {
            Frame::Base => self.without_placement(),
            Frame::Measurement => self,
        }
    }
}

/// The joint distribution of all inputs (39 for six joints) of a model with an uncertain
/// placement.
#[derive(Clone, Debug, PartialEq)]
pub struct PlacementSpread {
    /// The inputs drawn: the robot's and the placement ([`InputSpace::measured`]). Their normal
    /// slots are their positions ([`InputSpace::slot`]).
    pub space: InputSpace,
    /// Inputs (positions in [`Self::space`]) with nonzero variance.
    pub free: Vec<usize>,
    /// Lower Cholesky factor of their covariance, row-major.
    pub chol: Vec<f64>,
    /// The placement's mean: x, y, z (mm), roll, pitch, yaw (rad).
    pub base: [f64; 6],
}

impl PlacementSpread {
    /// The spread of `problem`'s model, when its covariance includes an uncertain placement.
    ///
    /// # Errors
    ///
    /// [`EngineError::Placement`] when the 39 × 39 covariance is not positive definite on its
    /// inputs with nonzero variance.
    pub fn of(problem: &Problem) -> Result<Option<PlacementSpread>, EngineError> {
        let m = &problem.model;
        if !m.base_uncertain() {
            return Ok(None);
        }
        let space = m.layout().measured();
        debug_assert!((0..space.len()).all(|i| space.slot(i) == i));
        let n = space.len();
        let cov = m.covariance_in(space);
        let c = |i: usize, k: usize| cov[i * n + k];
        let free: Vec<usize> = (0..n).filter(|&i| c(i, i) > 0.0).collect();
        let p = free.len();
        let sub = nalgebra::DMatrix::from_fn(p, p, |a, b| c(free[a], free[b]));
        let l = nalgebra::linalg::Cholesky::new(sub)
            .ok_or_else(|| EngineError::Placement(
                "the covariance with the base placement is not positive definite on its inputs with nonzero variance".into(),
            ))?
            .l();
        let base = m
            .base
            .map(|b| [b.xyz[0], b.xyz[1], b.xyz[2], b.rpy[0], b.rpy[1], b.rpy[2]])
            .unwrap_or([0.0; 6]);
        Ok(Some(PlacementSpread {
            space,
            free,
            chol: (0..p * p).map(|x| l[(x / p, x % p)]).collect(),
            base,
        }))
    }

    /// The offsets of draw `k` (internal units; one per input of [`Self::space`], zero beyond).
    pub fn deltas(&self, gen: &Philox, k: u64) -> [f64; MAX_INPUTS] {
        self.pick_freeze_deltas(gen, k, k, 0)
    }

    /// The offsets of a pick-freeze row: normal `i` from draw `b` where bit `i` of `mask` is
    /// set, from draw `a` elsewhere (mask 0 is draw `a` itself, as [`Self::deltas`]).
    pub fn pick_freeze_deltas(&self, gen: &Philox, a: u64, b: u64, mask: u64) -> [f64; MAX_INPUTS] {
        let mut z = [0.0; MAX_NORMALS];
        let mut done = [false; MAX_NORMALS / 4];
        for &i in &self.free {
            let blk = i / 4;
            if done[blk] {
                continue;
            }
            done[blk] = true;
            let nib = (mask >> (4 * blk)) & 15;
            let va = (nib != 15).then(|| normals_block(gen, a, blk as u32, PARAM_STREAM));
            let vb = (nib != 0).then(|| normals_block(gen, b, blk as u32, PARAM_STREAM));
            for t in 0..4 {
                let from_b = nib & (1 << t) != 0;
                z[4 * blk + t] = match (from_b, va, vb) {
                    (true, _, Some(v)) | (false, Some(v), _) => v[t],
                    _ => 0.0,
                };
            }
        }
        self.offsets_of_normals(&z)
    }

    /// The offsets `δ_free[a] = Σ_{b ≤ a} L[a][b] z[free[b]]` of the normals `z`.
    fn offsets_of_normals(&self, z: &[f64; MAX_NORMALS]) -> [f64; MAX_INPUTS] {
        let mut d = [0.0; MAX_INPUTS];
        let p = self.free.len();
        for a in 0..p {
            let mut acc = 0.0;
            for (b, &fb) in self.free.iter().enumerate().take(a + 1) {
                acc += self.chol[a * p + b] * z[fb];
            }
            d[self.free[a]] = acc;
        }
        d
    }
}

fn rotation(rpy: &[f64]) -> Matrix3<f64> {
    *Rotation3::from_euler_angles(rpy[0], rpy[1], rpy[2]).matrix()
}

/// The CPU evaluator of draws that include the placement (see the module docs).
pub struct PlacementEvaluator {
    problem: Problem,
    spread: PlacementSpread,
    gen: Philox,
    r_mean_t: Matrix3<f64>,
}

impl PlacementEvaluator {
    /// The evaluator of `problem` with `spread` ([`PlacementSpread::of`]).
    pub fn new(problem: Problem, spread: PlacementSpread) -> Self {
        let gen = Philox::new(problem.seed);
        let r_mean_t = rotation(&spread.base[3..]).transpose();
        PlacementEvaluator {
            problem,
            spread,
            gen,
            r_mean_t,
        }
    }

    /// `e_j` of draw `k` at every test point.
    pub fn point_errors(&self, k: u64) -> Vec<f64> {
        let mut e = vec![0.0; self.problem.points.len()];
        let term = self.problem.joint_errors.as_ref().map(|t| t.draw(k));
        self.errors_of_draw(&self.spread.deltas(&self.gen, k), &mut e, Some(k), term);
        e
    }

    /// `e_j` at every test point of the inputs `mean + d` (the parameters and the tool, then
    /// the placement's six; internal units) into `e`; returns their maximum `w`. These are the
    /// kinematic errors alone: the discrepancy term belongs to counter draws ([`Self::point_errors`]).
    pub fn errors_of(&self, d: &[f64], e: &mut [f64]) -> f64 {
        self.errors_of_draw(d, e, None, None)
    }

    /// [`Self::errors_of`] with the joint errors' draw `term` (the exact point form the tail
    /// analysis evaluates a model with joint errors by).
    pub fn errors_with_joint_errors(&self, d: &[f64], term: &TermDraw, e: &mut [f64]) -> f64 {
        self.errors_of_draw(d, e, None, Some(*term))
    }

    /// [`Self::errors_of`], with the discrepancy term of counter draw `draw` and the joint
    /// errors' draw `term` when given.
    fn errors_of_draw(
        &self,
        d: &[f64],
        e: &mut [f64],
        draw: Option<u64>,
        term: Option<TermDraw>,
    ) -> f64 {
        let m = &self.problem.model;
        let sp = self.spread.space;
        // The joint errors move the geometric inputs by A δβ (their correlation with them).
        let mut moved = [0.0; MAX_INPUTS];
        moved[..d.len().min(MAX_INPUTS)].copy_from_slice(&d[..d.len().min(MAX_INPUTS)]);
        if let (Some(t), Some(td)) = (&self.problem.joint_errors, &term) {
            t.shift_each(td, |block, k, v| {
                if let Some(i) = sp.index(block, k) {
                    moved[i] += v;
                }
            });
        }
        let d = &moved;
        let at = |b: Block| sp.range(b).map_or(0, |r| r.start);
        // Block::Joints: the link transforms.
        let params = Params::from_fn(m.params.len(), |i| m.params[i] + d[at(Block::Joints) + i]);
        // Block::Tool: the point the flange carries.
        let tool: [f64; 3] = std::array::from_fn(|i| m.tool[i] + d[at(Block::Tool) + i]);
        // Block::Placement: the base transform.
        let b = &self.spread.base;
        let drawn: [f64; 6] = std::array::from_fn(|i| b[i] + d[at(Block::Placement) + i]);
        // ΔB = B̂⁻¹ B': rotation R̂ᵀR', translation R̂ᵀ(t' − t̂).
        let dr = self.r_mean_t * rotation(&drawn[3..]);
        let dt = self.r_mean_t * Vector3::new(drawn[0] - b[0], drawn[1] - b[1], drawn[2] - b[2]);
        // The α, β rotations are the same at every point: their sines and cosines once per draw.
        let trig = twist_trig(&params);
        let disc = draw.zip(self.problem.discrepancy.as_ref());
        let mut w = 0.0f64;
        for (j, ((q, r), ej)) in self
            .problem
            .chain_points
            .iter()
            .zip(&self.problem.reference)
            .zip(e)
            .enumerate()
        {
            // The joint errors' draw turns each joint further (exactly, with `sin_cos`).
            let q = match (&self.problem.joint_errors, &term) {
                (Some(t), Some(td)) => {
                    let o = t.offsets(td, j);
                    q.iter().zip(o.iter()).map(|(a, b)| a + b).collect()
                }
                _ => *q,
            };
            let p = dr * Vector3::from(position_with_trig(&params, &trig, &tool, &q)) + dt;
            *ej = (p - Vector3::from(*r)).norm();
            if let Some((k, dd)) = disc {
                *ej = dd.apply(*ej, k, j);
            }
            w = w.max(*ej);
        }
        w
    }

    /// `w` (and, when `per_point` is given, every `e_j`) of row `i` of `rows`, in parallel.
    fn eval_rows(
        &self,
        rows: impl Fn(usize) -> [f64; MAX_INPUTS] + Sync,
        draw: impl Fn(usize) -> Option<u64> + Sync,
        term: impl Fn(usize) -> Option<TermDraw> + Sync,
        w: &mut [f64],
        per_point: Option<&mut [f64]>,
    ) {
        let m = self.problem.points.len();
        match per_point {
            None => w.par_iter_mut().enumerate().for_each_init(
                || vec![0.0; m],
                |e, (i, wi)| *wi = self.errors_of_draw(&rows(i), e, draw(i), term(i)),
            ),
            Some(e) => w
                .par_iter_mut()
                .zip(e.par_chunks_mut(m.max(1)))
                .enumerate()
                .for_each(|(i, (wi, ei))| {
                    *wi = self.errors_of_draw(&rows(i), ei, draw(i), term(i))
                }),
        }
    }
}

impl Evaluator for PlacementEvaluator {
    fn info(&self) -> BackendInfo {
        BackendInfo {
            backend: "cpu".into(),
            adapter: "rayon f64 (with the base placement)".into(),
            driver: format!("{} threads", rayon::current_num_threads()),
        }
    }

    fn n_points(&self) -> usize {
        self.problem.points.len()
    }

    fn eval_draws(
        &mut self,
        first: u64,
        w: &mut [f64],
        per_point: Option<&mut [f64]>,
    ) -> Result<(), EngineError> {
        self.eval_rows(
            |i| self.spread.deltas(&self.gen, first + i as u64),
            |i| Some(first + i as u64),
            |i| {
                let t = self.problem.joint_errors.as_ref();
                t.map(|t| t.draw(first + i as u64))
            },
            w,
            per_point,
        );
        Ok(())
    }

    fn layout(&self) -> Layout {
        Layout::new(self.spread.space.joints())
    }

    fn offset_space(&self) -> InputSpace {
        self.spread.space
    }

    fn eval_offsets(
        &mut self,
        offsets: &[f64],
        w: &mut [f64],
        per_point: Option<&mut [f64]>,
    ) -> Result<(), EngineError> {
        let nb = self.spread.space.len();
        let row = |i: usize| -> [f64; MAX_INPUTS] {
            std::array::from_fn(|p| if p < nb { offsets[i * nb + p] } else { 0.0 })
        };
        self.eval_rows(row, |_| None, |_| None, w, per_point);
        Ok(())
    }

    fn eval_pick_freeze(&mut self, request: &PickFreeze, w: &mut [f64]) -> Result<(), EngineError> {
        let row = |i: usize| {
            let (a, b, mask) = request.row(i);
            self.spread.pick_freeze_deltas(&self.gen, a, b, mask)
        };
        let term = |i: usize| {
            let t = self.problem.joint_errors.as_ref();
            t.map(|t| t.draw_mixed(request.joint_error_draws(i)))
        };
        self.eval_rows(row, |i| Some(request.discrepancy_draw(i)), term, w, None);
        Ok(())
    }
}
