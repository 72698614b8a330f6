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
                for a in 0..n {
                    let mut acc = [0.0; L];
                    for (b, &sb) in slots.iter().enumerate().take(a + 1) {
                        let lab = chol[a * n + b];
                        for l in 0..L {
                            acc[l] += lab * z[sb][l];
                        }
                    }
                    out[free[a]] = acc;
                }
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
mod tests {
    use super::*;
    use crate::kinematics::{tx60, Layout, Uncertainty};

    // The TX60's counts: six joints.
    const N_PARAMS: usize = Layout::SIX.n_params();
    const N_UNCERTAIN: usize = 33;

    /// A tool spread adds draws without touching the parameters' bits (existing seeds keep
    /// their results), and the tool's offsets have the stated σ: 4·10^4 draws, the relative
    /// standard error of a σ estimate is 1/√(2n) ≈ 3.5e-3, bound 5 standard errors.
    #[test]
    fn tool_spread_keeps_parameter_draws_and_has_its_sigma() {
        let m = tx60();
        let mut mt = m.clone();
        mt.tool_sigma = [0.002, 0.0, 0.005];
        let (a, b) = (
            ParamSampler::new(&m, 11).unwrap(),
            ParamSampler::new(&mt, 11).unwrap(),
        );
        // tool x and y are the last normals of block 7, tool z the first of block 8
        assert_eq!(b.blocks()[b.blocks().len() - 2..], [7, 8]);
        assert!(!a.blocks().contains(&8));
        let n = 40_000u64;
        let mut ss = [0.0; 3];
        let (mut da, mut db) = ([0.0; N_UNCERTAIN], [0.0; N_UNCERTAIN]);
        for k in 0..n {
            a.deltas(k, &mut da);
            b.deltas(k, &mut db);
            assert_eq!(da[..N_PARAMS], db[..N_PARAMS], "draw {k}");
            assert_eq!(da[N_PARAMS..], [0.0; 3]);
            assert_eq!(b.tool_deltas(k), [db[30], db[31], db[32]]);
            for (s, d) in ss.iter_mut().zip(&db[N_PARAMS..]) {
                *s += d * d;
            }
        }
        assert_eq!(ss[1], 0.0);
        for (k, want) in [(0, 0.002), (2, 0.005)] {
            let got = (ss[k] / n as f64).sqrt();
            assert!((got / want - 1.0).abs() < 5.0 * 3.5e-3, "{k}: {got}");
        }
    }

    /// A 33 × 33 covariance correlates the tool with a parameter (ρ = −0.7; standard error of
    /// the estimate (1−ρ²)/√n ≈ 2.5e-3 at n = 8·10^4, bound 5 standard errors), and a 30 × 30
    /// covariance with `tool_sigma` draws the tool independently with that σ.
    #[test]
    fn full_covariance_correlates_the_tool() {
        let mut m = tx60();
        let s = m.param_sigmas();
        let n = N_UNCERTAIN;
        let mut c = vec![0.0; n * n];
        for i in 0..N_PARAMS {
            c[i * n + i] = s[i] * s[i];
        }
        let (t, st) = (N_PARAMS + 1, 0.004);
        c[t * n + t] = st * st;
        c[t * n + 2] = -0.7 * st * s[2];
        c[2 * n + t] = c[t * n + 2];
        m.uncertainty = Uncertainty::from_matrix(InputSpace::robot(6), c);
        m.tool_sigma = [0.0, st, 0.0];
        m.check().unwrap();
        let g = ParamSampler::new(&m, 5).unwrap();
        let draws = 80_000;
        let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
        let mut d = [0.0; N_UNCERTAIN];
        for k in 0..draws {
            g.deltas(k, &mut d);
            sxy += d[t] * d[2];
            sxx += d[t] * d[t];
            syy += d[2] * d[2];
            assert_eq!((d[N_PARAMS], d[N_PARAMS + 2]), (0.0, 0.0));
        }
        let rho = sxy / (sxx * syy).sqrt();
        assert!((rho + 0.7).abs() < 5.0 * 2.5e-3, "rho {rho}");
        assert!(((sxx / draws as f64).sqrt() / st - 1.0).abs() < 0.02);
    }

    /// Pick-freeze rows: mask 0 is draw `a` and a full mask draw `b`, to the bit; a mask
    /// takes exactly its normals from `b` (independent: δ_i = σ_i z_i of the draw it names;
    /// correlated: `L` times the mixed normals, recomputed here from the Philox blocks).
    #[test]
    fn pick_freeze_rows_mix_two_draws_by_mask() {
        let mut mc = tx60();
        let s = mc.param_sigmas();
        let mut c = vec![0.0; N_PARAMS * N_PARAMS];
        for i in 0..N_PARAMS {
            c[i * N_PARAMS + i] = s[i] * s[i];
        }
        c[N_PARAMS + 7] = 0.5 * s[1] * s[7];
        c[7 * N_PARAMS + 1] = c[N_PARAMS + 7];
        mc.uncertainty = Uncertainty::from_matrix(InputSpace::parameters(6), c);
        mc.tool_sigma = [0.002, 0.0, 0.003];
        let mut mi = tx60();
        mi.tool_sigma = [0.002, 0.0, 0.003];
        let (a, b) = (12_345u64, (1u64 << 63) + 12_345);
        for model in [mi, mc] {
            let g = ParamSampler::new(&model, 9).unwrap();
            let (mut da, mut db, mut d) = ([0.0; N_UNCERTAIN], [0.0; N_UNCERTAIN], [0.0; 33]);
            g.deltas(a, &mut da);
            g.deltas(b, &mut db);
            g.pick_freeze_deltas(a, b, 0, &mut d);
            assert_eq!(d, da);
            g.pick_freeze_deltas(a, b, ALL_NORMALS, &mut d);
            assert_eq!(d, db);
            let normals = |k: u64| -> Vec<f64> {
                (0..(MAX_NORMALS / 4) as u32)
                    .flat_map(|blk| crate::sampling::normals_block(&g.gen, k, blk, PARAM_STREAM))
                    .collect()
            };
            let (za, zb) = (normals(a), normals(b));
            for mask in [1u64 << 7, (1 << 1) | (1 << 31) | (1 << 32), 0x5_5555_5555] {
                g.pick_freeze_deltas(a, b, mask, &mut d);
                let z: Vec<f64> = (0..MAX_NORMALS)
                    .map(|i| if mask >> i & 1 == 1 { zb[i] } else { za[i] })
                    .collect();
                let want: Vec<f64> = match g.cholesky() {
                    None => (0..N_UNCERTAIN)
                        .map(|i| g.sigmas().unwrap()[i] * z[i])
                        .collect(),
                    Some((free, l)) => {
                        let n = free.len();
                        let mut out = vec![0.0; N_UNCERTAIN];
                        for r in 0..n {
                            out[free[r]] = (0..=r).map(|q| l[r * n + q] * z[free[q]]).sum();
                        }
                        out
                    }
                };
                for i in 0..N_UNCERTAIN {
                    assert!(
                        (d[i] - want[i]).abs() <= 1e-15 * want[i].abs().max(1e-3),
                        "{i}"
                    );
                }
                if g.cholesky().is_none() {
                    // one normal, one input: its offset is the B draw's, the others A's
                    for i in 0..N_UNCERTAIN {
                        let from = if mask >> i & 1 == 1 { db[i] } else { da[i] };
                        assert_eq!(d[i], from, "input {i}, mask {mask:#x}");
                    }
                }
            }
        }
    }

    #[test]
    fn diagonal_covariance_equals_sigma_list() {
        let m = tx60();
        let s = m.param_sigmas();
        let mut mc = m.clone();
        let mut c = vec![0.0; N_PARAMS * N_PARAMS];
        for i in 0..N_PARAMS {
            c[i * N_PARAMS + i] = s[i] * s[i];
        }
        mc.uncertainty = Uncertainty::from_matrix(InputSpace::parameters(6), c);
        let (a, b) = (
            ParamSampler::new(&m, 7).unwrap(),
            ParamSampler::new(&mc, 7).unwrap(),
        );
        for k in [0u64, 1, 99, 1 << 40] {
            let (da, db) = (a.draw(k), b.draw(k));
            for i in 0..N_PARAMS {
                assert!((da[i] - db[i]).abs() <= 1e-15 * da[i].abs().max(1.0));
            }
        }
    }

    #[test]
    fn correlated_draws_reproduce_covariance() {
        // Two correlated parameters, ρ = 0.8; 2·10^5 draws: the correlation estimate's standard
        // error is (1−ρ²)/√n ≈ 8e-4, bound 5 standard errors.
        let mut m = tx60();
        let s = m.param_sigmas();
        let mut c = vec![0.0; N_PARAMS * N_PARAMS];
        for i in 0..N_PARAMS {
            c[i * N_PARAMS + i] = s[i] * s[i];
        }
        c[N_PARAMS + 2] = 0.8 * s[1] * s[2];
        c[2 * N_PARAMS + 1] = c[N_PARAMS + 2];
        m.uncertainty = Uncertainty::from_matrix(InputSpace::parameters(6), c);
        let g = ParamSampler::new(&m, 3).unwrap();
        let n = 200_000;
        let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
        let mut d = [0.0; N_UNCERTAIN];
        for k in 0..n {
            g.deltas(k, &mut d);
            sxy += d[1] * d[2];
            sxx += d[1] * d[1];
            syy += d[2] * d[2];
        }
        let rho = sxy / (sxx * syy).sqrt();
        assert!((rho - 0.8).abs() < 5.0 * 8e-4, "rho {rho}");
        assert!(((sxx / n as f64).sqrt() / s[1] - 1.0).abs() < 0.01);
    }

    #[test]
    fn indefinite_covariance_is_an_error() {
        let mut m = tx60();
        let mut c = vec![0.0; N_PARAMS * N_PARAMS];
        c[0] = 1e-8;
        c[2 * N_PARAMS + 2] = 1e-8;
        c[2] = 2e-8;
        c[2 * N_PARAMS] = 2e-8;
        m.uncertainty = Uncertainty::from_matrix(InputSpace::parameters(6), c);
        assert!(ParamSampler::new(&m, 1).is_err());
    }
}
