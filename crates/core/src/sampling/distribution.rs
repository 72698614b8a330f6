//! The parameter distribution: independent normals `μ_i + σ_i z_i`, or correlated normals
//! `μ + L z` with `L` the Cholesky factor of the covariance of the free parameters
//! (GUM S1 §6.4.8: multivariate Gaussian via `V = L Lᵀ`).
//!
//! Parameter `i` always uses standard normal number `i` of its draw, so a diagonal covariance and
//! the equivalent σ list give bit-identical draws.
//!
//! # Stream and slot layout (docs/METHOD.md §6 and §14)
//!
//! Draw `k` of a run keyed by the seed is the Philox-4×32-10 counter
//! `(k mod 2³², k div 2³², b, PARAM_STREAM)` for blocks `b = 0 … 8`; block `b` gives the four
//! normals `4b … 4b + 3` (Box–Muller of word pairs 0–1 and 2–3). The uncertain inputs
//! ([`crate::kinematics::InputSpace::robot`]) use normals `0 … 5n + 2` one to one: for a
//! six-joint model the 30 parameters `0 … 29` (blocks 0–7, as before the tool had a spread),
//! then the tool's x, y, z `30, 31, 32` (the last two normals of block 7 and the first of block
//! 8); for seven joints the 35 parameters, then the tool at `35, 36, 37`. Only blocks that feed an input with nonzero spread are computed, so a
//! model whose tool has no spread draws exactly the bits it drew before, and the tool's draws
//! never shift a parameter's normal.

use super::normal::box_muller;
use super::philox::{philox4x32_10_lanes, Philox};
use crate::kinematics::{Block, InputSpace, Params, RobotModel, MAX_INPUTS, MAX_ROBOT_INPUTS};

/// Normals available per draw (11 Philox blocks of 4): one slot per input of every block
/// ([`InputSpace::slot`]): the robot's inputs use the first `5n + 3` (33 for six joints), and a
/// model with an uncertain base placement draws its six inputs from the next six (33–38 for six
/// joints; [`crate::engine::PlacementSpread`]).
pub const MAX_NORMALS: usize = MAX_INPUTS;

/// A pick-freeze mask that takes every normal from the second draw (bits `0 … MAX_NORMALS − 1`).
pub const ALL_NORMALS: u64 = (1 << MAX_NORMALS) - 1;

/// Errors building a sampler.
#[derive(Debug, thiserror::Error)]
pub enum SamplerError {
    /// The covariance of the free parameters has no Cholesky factor.
    #[error("the model's covariance matrix is not positive definite on its free parameters (rows with nonzero variance)")]
    NotPositiveDefinite,
}

#[derive(Clone, Debug)]
#[allow(clippy::large_enum_variant)] // one per run; boxing buys nothing
enum Form {
    /// σ of each input, zero beyond the model's inputs (a plain array, so the loop over the
    /// inputs has a bound known when compiled).
    Independent([f64; MAX_ROBOT_INPUTS]),
    Correlated {
        free: Vec<usize>,
        /// The normal slot of each free input ([`InputSpace::slot`]).
        slots: Vec<usize>,
        /// Lower-triangular factor, row-major `free.len()²`.
        chol: Vec<f64>,
    },
}

/// Draws parameter vectors for one run (one seed).
///
/// # Examples
///
/// Draw `k` is a function of the seed and `k` alone: two samplers with one seed give the same
/// draws in any order, one at a time or in lanes.
///
/// ```
/// use gpu_amcs_core::kinematics::{tx60, MAX_ROBOT_INPUTS};
/// use gpu_amcs_core::sampling::ParamSampler;
///
/// let model = tx60();
/// let a = ParamSampler::new(&model, 2025)?;
/// let b = ParamSampler::new(&model, 2025)?;
/// let later = a.draw(41);
/// assert_eq!(b.draw(3), a.draw(3));
/// assert_eq!(b.draw(41), later); // after other draws, the same
/// assert_ne!(a.draw(3), a.draw(4));
/// assert_ne!(ParamSampler::new(&model, 2026)?.draw(3), a.draw(3));
///
/// // A draw is the mean plus its offsets; a parameter with σ = 0 is never moved.
/// let mut d = [0.0; MAX_ROBOT_INPUTS];
/// a.deltas(3, &mut d);
/// let q = a.draw(3);
/// let sigmas = model.param_sigmas();
/// for i in 0..a.n_params() {
///     assert_eq!(q[i], a.mean[i] + d[i]);
///     if sigmas[i] == 0.0 {
///         assert_eq!(q[i], model.params[i]);
///     }
/// }
///
/// // Draws 1 … 4 in four lanes at once: lane 2 is draw 3, to the bit.
/// let mut lanes = [[0.0; 4]; MAX_ROBOT_INPUTS];
/// a.deltas_lanes::<4>(1, &mut lanes);
/// assert!((0..a.n_inputs()).all(|i| lanes[i][2] == d[i]));
/// # Ok::<(), gpu_amcs_core::sampling::SamplerError>(())
/// ```
#[derive(Clone, Debug)]
pub struct ParamSampler {
    /// Parameter means (the model's values), mm and radians.
    pub mean: Params,
    /// The inputs drawn (parameters, then the tool point: [`RobotModel::robot_inputs`]).
    space: InputSpace,
    gen: Philox,
    form: Form,
    blocks: Vec<u32>,
}

/// Philox stream used for parameter draws.
pub const PARAM_STREAM: u32 = 0;

impl ParamSampler {
    /// A sampler for `model`'s values and uncertainty (parameters and tool point), keyed by
    /// `seed`.
    ///
    /// # Errors
    ///
    /// [`SamplerError::NotPositiveDefinite`] when the model's covariance, restricted to the inputs
    /// with nonzero variance, has no Cholesky factor.
    pub fn new(model: &RobotModel, seed: u64) -> Result<Self, SamplerError> {
        let free = model.free_inputs();
        let space = model.robot_inputs();
        // The independent form multiplies input i by normal i: the robot's inputs hold the first
        // slots in order.
        debug_assert!((0..space.len()).all(|i| space.slot(i) == i));
        let form = match model.full_covariance() {
            None => {
                let s = model.input_sigmas();
                Form::Independent(std::array::from_fn(|i| s.get(i).copied().unwrap_or(0.0)))
            }
            Some(c) => {
                let n = free.len();
                let nu = space.len();
                let sub = nalgebra::DMatrix::from_fn(n, n, |a, b| c[free[a] * nu + free[b]]);
                let l = nalgebra::linalg::Cholesky::new(sub)
                    .ok_or(SamplerError::NotPositiveDefinite)?
                    .l();
                let chol = (0..n * n).map(|x| l[(x / n, x % n)]).collect();
                Form::Correlated {
                    free: free.clone(),
                    slots: free.iter().map(|&i| space.slot(i)).collect(),
                    chol,
                }
            }
        };
        let mut blocks: Vec<u32> = free.iter().map(|&i| (space.slot(i) / 4) as u32).collect();
        blocks.dedup();
        Ok(ParamSampler {
            mean: model.params,
            space,
            gen: Philox::new(seed),
            form,
            blocks,
        })
    }

    /// The Philox key of this run.
    pub fn key(&self) -> [u32; 2] {
        self.gen.key
    }

    /// Number of uncertain inputs of a draw: the parameters, then the tool point.
    pub fn n_inputs(&self) -> usize {
        self.space.len()
    }

    /// The inputs drawn ([`RobotModel::robot_inputs`]).
    pub fn space(&self) -> InputSpace {
        self.space
    }

    /// Number of parameters.
    pub fn n_params(&self) -> usize {
        self.mean.len()
    }

    /// Independent standard deviations of the [`Self::n_inputs`] inputs, or `None` for a
    /// correlated sampler.
    pub fn sigmas(&self) -> Option<&[f64]> {
        match &self.form {
            Form::Independent(s) => Some(&s[..self.space.len()]),
            Form::Correlated { .. } => None,
        }
    }

    /// Free-input indices (of the [`Self::n_inputs`] inputs) and the row-major lower Cholesky
    /// factor, for a correlated sampler.
    pub fn cholesky(&self) -> Option<(&[usize], &[f64])> {
        match &self.form {
            Form::Independent(_) => None,
            Form::Correlated { free, chol, .. } => Some((free, chol)),
        }
    }

    /// Philox blocks (of 4 normals) that some free parameter uses.
    pub fn blocks(&self) -> &[u32] {
        &self.blocks
    }

    /// Offsets `δ = μ_k − μ` of draw `k` from the mean (mm, radians): the parameters, then
    /// the tool's x, y, z (mm); `out` has at least [`Self::n_inputs`] entries (those beyond are
    /// set to 0).
    #[inline]
    pub fn deltas(&self, k: u64, out: &mut [f64]) {
        let mut lanes = [[0.0; 1]; MAX_ROBOT_INPUTS];
        self.deltas_lanes::<1>(k, &mut lanes);
        for (o, l) in out.iter_mut().zip(&lanes) {
            *o = l[0];
        }
    }

    /// Offsets of draws `first … first + L − 1` at once, `out[i][l]` = parameter i of draw
    /// `first + l` (the lane layout vectorises; [`Self::deltas`] is the one-lane case, so both
    /// give the same bits).
    #[inline(always)]
    pub fn deltas_lanes<const L: usize>(&self, first: u64, out: &mut [[f64; L]; MAX_ROBOT_INPUTS]) {
        let mut z = [[0.0; L]; MAX_NORMALS];
        self.deltas_normals_lanes(first, out, &mut z);
    }

    /// [`Self::deltas_lanes`], leaving in `z` (zeroed first) the standard normals of the Philox
    /// blocks this sampler uses ([`Self::blocks`]), for an evaluator that draws more inputs from
    /// other blocks of the same draws.
    #[inline(always)]
    pub fn deltas_normals_lanes<const L: usize>(
        &self,
        first: u64,
        out: &mut [[f64; L]; MAX_ROBOT_INPUTS],
        z: &mut [[f64; L]; MAX_NORMALS],
    ) {
        let draws: [u64; L] = std::array::from_fn(|l| first + l as u64);
        *z = [[0.0; L]; MAX_NORMALS];
        self.normals_lanes(&draws, |_| true, z);
        self.spread_lanes(z, out);
    }

    /// Offsets of one pick-freeze row: standard normal `i` is normal `i` of draw `b` where bit
    /// `i` of `mask` is set and of draw `a` elsewhere, then mapped like a draw (`σ_i z_i`, or
    /// `L z` on the free inputs). `mask = 0` gives [`Self::deltas`] of `a` and a mask with every
    /// free input's bit (e.g. [`ALL_NORMALS`]) that of `b`, to the bit.
    pub fn pick_freeze_deltas(&self, a: u64, b: u64, mask: u64, out: &mut [f64]) {
        let mut lanes = [[0.0; 1]; MAX_ROBOT_INPUTS];
        self.pick_freeze_lanes::<1>(&[a], &[b], &[mask], &mut lanes);
        for (o, l) in out.iter_mut().zip(&lanes) {
            *o = l[0];
        }
    }

    /// [`Self::pick_freeze_deltas`] of `L` rows at once (lane `l`: draws `a[l]`, `b[l]`, mask
    /// `masks[l]`). A Philox block is computed for `a` (or `b`) only when some lane takes one
    /// of its four normals from it.
    #[inline(always)]
    pub fn pick_freeze_lanes<const L: usize>(
        &self,
        a: &[u64; L],
        b: &[u64; L],
        masks: &[u64; L],
        out: &mut [[f64; L]; MAX_ROBOT_INPUTS],
    ) {
        let mut z = [[0.0; L]; MAX_NORMALS];
        self.pick_freeze_normals_lanes(a, b, masks, out, &mut z);
    }

    /// [`Self::pick_freeze_lanes`], leaving in `z` the mixed standard normals of the Philox
    /// blocks this sampler uses (0 elsewhere).
    #[inline(always)]
    pub fn pick_freeze_normals_lanes<const L: usize>(
        &self,
        a: &[u64; L],
        b: &[u64; L],
        masks: &[u64; L],
        out: &mut [[f64; L]; MAX_ROBOT_INPUTS],
        z: &mut [[f64; L]; MAX_NORMALS],
    ) {
        *z = [[0.0; L]; MAX_NORMALS];
        pick_freeze_normals(&self.gen, &self.blocks, a, b, masks, z);
        self.spread_lanes(z, out);
    }

    /// The standard normals of draws `draws[l]` in the Philox blocks this sampler uses and
    /// `wanted` accepts (the other entries of `z` are left as they are).
    #[inline(always)]
    fn normals_lanes<const L: usize>(
        &self,
        draws: &[u64; L],
        wanted: impl Fn(u32) -> bool,
        z: &mut [[f64; L]; MAX_NORMALS],
    ) {
        normals_lanes(&self.gen, &self.blocks, draws, wanted, z);
    }

    /// Offsets from standard normals: `σ_i z_i`, or `L z` on the free inputs.
    #[inline(always)]
    fn spread_lanes<const L: usize>(
        &self,
        z: &[[f64; L]; MAX_NORMALS],
        out: &mut [[f64; L]; MAX_ROBOT_INPUTS],
    ) {
        match &self.form {
            Form::Independent(s) => {
                // σ = 0 beyond the model's inputs: their offsets are ±0 and never read.
                for i in 0..MAX_ROBOT_INPUTS {
                    for l in 0..L {
                        out[i][l] = s[i] * z[i][l];
                    }
                }
            }
            Form::Correlated { free, slots, chol } => {
                *out = [[0.0; L]; MAX_ROBOT_INPUTS];
                let n = free.len();
                let mut x = [[0.0; L]; MAX_NORMALS];
                for (xb, &sb) in x.iter_mut().zip(slots) {
                    *xb = z[sb];
                }
                super::matvec::rows_times_lanes(chol, n, true, &x[..n], |a, acc| {
                    out[free[a]] = *acc;
                });
            }
        }
    }

    /// The full parameter vector of draw `k` (the tool's offsets are
    /// [`Self::tool_deltas`]).
    pub fn draw(&self, k: u64) -> Params {
        let mut d = [0.0; MAX_ROBOT_INPUTS];
        self.deltas(k, &mut d);
        Params::from_fn(self.mean.len(), |i| self.mean[i] + d[i])
    }

    /// The tool point's offsets (mm, flange frame) of draw `k`.
    pub fn tool_deltas(&self, k: u64) -> [f64; 3] {
        let mut d = [0.0; MAX_ROBOT_INPUTS];
        self.deltas(k, &mut d);
        let t = self.space.range(Block::Tool).map_or(0, |r| r.start);
        std::array::from_fn(|i| d[t + i])
    }
}

/// The standard normals of draws `draws[l]` in the Philox `blocks` that `wanted` accepts, into
/// `z` (normals `4b … 4b + 3` of block `b`; the other entries are left as they are). Lane `l`
/// holds the bits [`super::normals_block`] gives for draw `draws[l]`.
#[inline(always)]
pub fn normals_lanes<const L: usize>(
    gen: &Philox,
    blocks: &[u32],
    draws: &[u64; L],
    wanted: impl Fn(u32) -> bool,
    z: &mut [[f64; L]; MAX_NORMALS],
) {
    let lo: [u32; L] = std::array::from_fn(|l| draws[l] as u32);
    let hi: [u32; L] = std::array::from_fn(|l| (draws[l] >> 32) as u32);
    for &b in blocks.iter().filter(|&&b| wanted(b)) {
        let w = philox4x32_10_lanes([lo, hi, [b; L], [PARAM_STREAM; L]], gen.key);
        let base = 4 * b as usize;
        for l in 0..L {
            let (a, bb) = box_muller(w[0][l], w[1][l]);
            let (c, d) = box_muller(w[2][l], w[3][l]);
            z[base][l] = a;
            z[base + 1][l] = bb;
            z[base + 2][l] = c;
            z[base + 3][l] = d;
        }
    }
}

/// The standard normals of `L` pick-freeze rows in the Philox `blocks` into `z` (the other
/// entries are left as they are): normal `i` of draw `b[l]` where bit `i` of `masks[l]` is set,
/// of draw `a[l]` elsewhere. A block is computed for `a` (or `b`) only when some lane takes one
/// of its four normals from it.
#[inline(always)]
pub fn pick_freeze_normals<const L: usize>(
    gen: &Philox,
    blocks: &[u32],
    a: &[u64; L],
    b: &[u64; L],
    masks: &[u64; L],
    z: &mut [[f64; L]; MAX_NORMALS],
) {
    let nibble = |m: u64, block: u32| (m >> (4 * block)) & 0xf;
    let mut zb = [[0.0; L]; MAX_NORMALS];
    normals_lanes(
        gen,
        blocks,
        a,
        |k| masks.iter().any(|&m| nibble(m, k) != 0xf),
        z,
    );
    normals_lanes(
        gen,
        blocks,
        b,
        |k| masks.iter().any(|&m| nibble(m, k) != 0),
        &mut zb,
    );
    for &blk in blocks {
        for i in 4 * blk as usize..4 * blk as usize + 4 {
            for l in 0..L {
                if (masks[l] >> i) & 1 == 1 {
                    z[i][l] = zb[i][l];
                }
            }
        }
    }
}

#[cfg(test)]
mod tests;
