//! The standard-normal space of a run: the map `u ↦ δ = L u` to parameter offsets, and the
//! evaluator with its generator and evaluation count ([`Model`]).

use super::joint::JointSpace;
use super::term::TermSpace;
use super::TailError;
use crate::engine::{Evaluator, PlacementSpread, Problem};
use crate::mc::result::Progress;
use crate::sampling::{box_muller, uniform_open, Philox};

/// The map `u ↦ δ = L u` from the standard-normal space to parameter offsets.
pub(super) struct NormalSpace {
    pub(super) free: Vec<usize>,
    /// Standard deviations of the free parameters (independent), or the row-major lower
    /// Cholesky factor (`d²` entries).
    pub(super) factor: Vec<f64>,
    pub(super) diagonal: bool,
    /// Entries of an offset row: the inputs the evaluator takes
    /// ([`crate::engine::Evaluator::offset_space`]: 33 for six joints, 39 when the placement is
    /// drawn).
    pub(super) width: usize,
    /// The model's joint errors, whose normals follow the parameters' (`None`: it has none).
    pub(super) joint: Option<JointSpace>,
    /// The model's discrepancy term, whose normals follow the parameters' and the joint
    /// errors' (`None`: not drawn).
    pub(super) term: Option<TermSpace>,
}

impl NormalSpace {
    /// The space of `problem`'s inputs: its `5n + 3` (33 for six joints), or all `5n + 9` (39)
    /// when its model's placement is uncertain (the measurement frame, docs/METHOD.md §2.8).
    pub(super) fn new(problem: &Problem) -> Result<Self, TailError> {
        let space = if let Some(sp) = PlacementSpread::of(problem)? {
            NormalSpace {
                free: sp.free,
                factor: sp.chol,
                diagonal: false,
                width: sp.space.len(),
                joint: None,
                term: None,
            }
        } else if let Some((free, chol)) = problem.sampler.cholesky() {
            NormalSpace {
                free: free.to_vec(),
                factor: chol.to_vec(),
                diagonal: false,
                width: problem.sampler.n_inputs(),
                joint: None,
                term: None,
            }
        } else {
            let s = problem.sampler.sigmas().unwrap_or(&[]);
            let free: Vec<usize> = (0..problem.sampler.n_inputs().min(s.len()))
                .filter(|&i| s[i] > 0.0)
                .collect();
            NormalSpace {
                factor: free.iter().map(|&i| s[i]).collect(),
                free,
                diagonal: true,
                width: problem.sampler.n_inputs(),
                joint: None,
                term: None,
            }
        };
        let mut space = space;
        space.joint = JointSpace::new(problem)?;
        space.term = problem
            .discrepancy
            .clone()
            .map(|d| TermSpace::new(d, problem.points.len()));
        if space.free.is_empty() && space.joint.is_none() && space.term.is_none() {
            return Err(TailError::NoUncertainty);
        }
        Ok(space)
    }

    /// Normals per state: the free parameters', then the joint errors', then the term's.
    pub(super) fn dim(&self) -> usize {
        self.free.len()
            + self.joint.as_ref().map_or(0, JointSpace::dim)
            + self.term.as_ref().map_or(0, TermSpace::dim)
    }

    /// Writes the offsets of `u` (length [`Self::dim`]; the parameters' normals come first)
    /// into `out` (length [`Self::width`](NormalSpace)).
    pub(super) fn offsets(&self, u: &[f64], out: &mut [f64]) {
        out.fill(0.0);
        let d = self.free.len();
        for (a, &p) in self.free.iter().enumerate() {
            out[p] = if self.diagonal {
                self.factor[a] * u[a]
            } else {
                (0..=a).map(|b| self.factor[a * d + b] * u[b]).sum()
            };
        }
    }
}

/// The evaluator with its standard-normal map, generator and evaluation count.
pub(super) struct Model<'a> {
    pub(super) eval: &'a mut dyn Evaluator,
    pub(super) space: NormalSpace,
    pub(super) gen: Philox,
    pub(super) evaluations: u64,
    pub(super) batch: usize,
    pub(super) progress: Option<Progress<'a>>,
    pub(super) cap: u64,
}

impl Model<'_> {
    /// `w` of the rows of `u` (`w.len()` rows of `d`), in evaluator calls of at most `batch`
    /// rows.
    pub(super) fn eval_u(&mut self, u: &[f64], w: &mut [f64]) -> Result<(), TailError> {
        let d = self.space.dim();
        let mut offsets = Vec::new();
        let mut per_point = Vec::new();
        let width = self.space.width;
        let m = self.eval.n_points();
        let params = self.space.free.len();
        // The discrepancy term's normals follow the joint errors'.
        let term_at = params + self.space.joint.as_ref().map_or(0, JointSpace::dim);
        for (uc, wc) in u.chunks(self.batch * d).zip(w.chunks_mut(self.batch)) {
            offsets.resize(wc.len() * width, 0.0);
            for (row, o) in uc.chunks(d).zip(offsets.chunks_mut(width)) {
                self.space.offsets(row, o);
            }
            match (&self.space.joint, &self.space.term) {
                (None, None) => self.eval.evaluate_offsets(&offsets, wc, None)?,
                (joint, term) => {
                    per_point.resize(wc.len() * m, 0.0);
                    match joint {
                        Some(j) => j.errors(&offsets, width, (uc, d, params), &mut per_point),
                        None => self
                            .eval
                            .evaluate_offsets(&offsets, wc, Some(&mut per_point))?,
                    }
                    for ((row, e), v) in uc.chunks(d).zip(per_point.chunks(m)).zip(wc.iter_mut()) {
                        *v = match term {
                            Some(t) => t.max_error(e, &row[term_at..]),
                            None => e.iter().copied().fold(0.0, f64::max),
                        };
                    }
                }
            }
            self.account(wc)?;
        }
        Ok(())
    }

    /// Counts evaluated rows, rejects non-finite values and reports progress.
    pub(super) fn account(&mut self, w: &[f64]) -> Result<(), TailError> {
        if let Some(&value) = w.iter().find(|v| !v.is_finite()) {
            return Err(TailError::NonFinite { value });
        }
        self.evaluations += w.len() as u64;
        if let Some(cb) = self.progress {
            cb(self.evaluations, self.cap);
        }
        Ok(())
    }

    /// Fills `out` with standard normals of counter `(state, run, block, stream)`, blocks
    /// from `first_block` on.
    pub(super) fn normals(&self, state: u64, stream: u32, first_block: u32, out: &mut [f64]) {
        for (b, chunk) in out.chunks_mut(4).enumerate() {
            let w = self.block(state, first_block + b as u32, stream);
            let (a, bb) = box_muller(w[0], w[1]);
            let (c, dd) = box_muller(w[2], w[3]);
            for (o, z) in chunk.iter_mut().zip([a, bb, c, dd]) {
                *o = z;
            }
        }
    }

    /// Fills `out` with uniforms in (0, 1), as [`Self::normals`].
    pub(super) fn uniforms(&self, state: u64, stream: u32, first_block: u32, out: &mut [f64]) {
        for (b, chunk) in out.chunks_mut(4).enumerate() {
            let w = self.block(state, first_block + b as u32, stream);
            for (o, x) in chunk.iter_mut().zip(w) {
                *o = uniform_open(x);
            }
        }
    }

    /// `state` carries the state index in its low and the run number in its high word.
    fn block(&self, state: u64, block: u32, stream: u32) -> [u32; 4] {
        self.gen.block(state, block, stream)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::{tx60, Uncertainty};
    use crate::sampling::normals_block;
    use crate::sampling::ParamSampler;

    /// The map `u ↦ L u` reproduces the sampler's draw `k` from that draw's normals, for the
    /// σ list and for a full covariance with correlations.
    #[test]
    fn normal_space_reproduces_the_sampler() {
        let mut corr = tx60();
        let s = corr.param_sigmas();
        let np = corr.layout().n_params();
        let mut c = vec![0.0; np * np];
        for i in 0..np {
            c[i * np + i] = s[i] * s[i];
        }
        c[np + 2] = 0.6 * s[1] * s[2];
        c[2 * np + 1] = c[np + 2];
        corr.uncertainty =
            Uncertainty::from_matrix(crate::kinematics::InputSpace::parameters(6), c);
        for model in [tx60(), corr] {
            let sampler = ParamSampler::new(&model, 17).unwrap();
            let points = crate::points::generate(&model, 2, &Default::default(), 1).unwrap();
            let problem = Problem::new(
                model.clone(),
                &points,
                &crate::engine::Reference::Calibrated,
                17,
            )
            .unwrap();
            let space = NormalSpace::new(&problem).unwrap();
            let g = Philox { key: sampler.key() };
            for k in [0u64, 5, 1 << 33] {
                let z: Vec<f64> = (0..9).flat_map(|b| normals_block(&g, k, b, 0)).collect();
                let u: Vec<f64> = space.free.iter().map(|&i| z[i]).collect();
                let nu = model.robot_inputs().len();
                let mut mine = vec![0.0; nu];
                space.offsets(&u, &mut mine);
                let mut theirs = vec![0.0; nu];
                sampler.deltas(k, &mut theirs);
                for i in 0..nu {
                    assert!((mine[i] - theirs[i]).abs() <= 1e-15 * theirs[i].abs().max(1e-3));
                }
            }
        }
    }
}
