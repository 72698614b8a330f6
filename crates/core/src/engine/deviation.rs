//! The f32 deviation form: the constants an f32 evaluator needs so that it only ever handles
//! small quantities (`docs/METHOD.md §7`). Used by the WGSL
//! evaluator (the `gpu-amcs-gpu` crate); a SIMD-f32 CPU or a CUDA evaluator would upload the same words.
//!
//! # Formulation (why f32 is enough)
//!
//! Positions are ~1000 mm and errors ~0.1 mm: subtracting two f32 positions would lose about
//! 1e-4 mm to cancellation. Instead the kernel propagates the *deviation* from the chain of the
//! mean parameters. With `u_i = Rx(α_i)Ry(β_i)p_{i+1} + (a_i, 0, d_i)` and
//! `p_i = Rz(θ_i + q_i) u_i` (tool → base), and `p0`, `u0` the mean-parameter intermediate
//! points of each test point (computed here in f64 once, stored as f32 by [`point_constants`]):
//!
//! ```text
//! Δ_7  = δ_tool   (the tool point's offset in the flange frame; 0 without a tool spread)
//! Δu_i = Rx(α')Ry(β') Δ_{i+1} + (Rx(α')Ry(β') − Rx(α)Ry(β)) p0_{i+1} + (δa, 0, δd)
//! Δ_i  = Rz(φ') Δu_i + (Rz(φ') − Rz(φ)) u0_i,          φ = θ + q, φ' = φ + δθ
//! e_j  = |Δ_1 + o_j|,  o_j = P(mean, q_j) − P_ref,j (f64; 0 for the calibrated reference)
//! ```
//!
//! Rotation differences use `cos(x+δ) − cos x = −2 sin(δ/2) sin(x+δ/2)` and
//! `sin(x+δ) − sin x = 2 sin(δ/2) cos(x+δ/2)` with `sin/cos(δ/2)` from a series and
//! `sin/cos(x)` of the mean precomputed ([`joint_trig`]; per point for `φ`), so the kernel only
//! handles small quantities. The ~1000 mm constants enter only multiplied by differences of
//! order δ.
//!
//! # Error budget (f32 unit roundoff `u = 2^-24 ≈ 6e-8`)
//!
//! * normals (counter draws): series truncation < 2e-9; f32 rounding gives
//!   `|Δz| ≲ 1e-6·(1+|z|)`, so the offsets δ have relative error ≲ 1e-6 and `e_j` a relative
//!   error of the same order; the spread ([`SpreadPacking`]: σ or the Cholesky factor) rounded
//!   to f32 adds u relative;
//! * explicit offsets (the offset path): δ rounded from f64 to f32, relative error ≤ u, so `e_j`
//!   gets ≲ u·e_j; smaller than the counter path's. The half-angle series is used for
//!   `|δ/2| ≤ π/4`, which the seam's angle bound (`MAX_ANGLE_OFFSET` = π/2) guarantees;
//! * constants: `p0`, `u0` rounded to f32 (≤ u·1000 mm ≈ 6e-5 mm) times rotation differences
//!   (≲ 1e-3) → ≲ 6e-8 mm per joint; `cos φ`, `sin φ` rounded (u) times `|Δu|` (≲ 1 mm) →
//!   ≲ 6e-8 mm per joint;
//! * arithmetic: ~25 f32 operations per joint on quantities of size `|Δ|` → ≲ 1e-6·|Δ|;
//! * offsets `o_j` rounded to f32: ≤ u·|o_j| (6e-7 mm for a 10 mm nominal-reference offset).
//!
//! * the base placement (mode 2, docs/METHOD.md §2.8): three rotation increments
//!   `sin δ (a×v) + 2 sin²(δ/2) a×(a×v)` with `v = x0 + Δ` (`x0` rebuilt in f32 from the
//!   point's first two words, ≤ 6e-5 mm off) and `|δ| ≲ 1e-4`: ≲ 1e-8 mm from `x0`, ≲ 1e-6
//!   relative from the arithmetic; the unit axes and `R̂ᵀ` rounded to f32 add u relative to the
//!   increments. Measured against the f64 placement evaluator: 2.7e-8 mm (`tests/it/gpu.rs`).
//!
//! * the joint errors (docs/METHOD.md §19.2): a joint's half-angle offset becomes `(δθ +
//!   Δ_ij)/2` with `Δ_ij` ≲ 1e-4 rad formed in f32 from the draw's factors and the point's torques
//!   and sines (relative error ≲ 1e-6 of Δ, so ≲ 1e-10 rad); the coefficients' offsets `L z`
//!   and their shift of the geometric inputs `A δβ` carry the relative error of the normals.
//!   Measured against the f64 lanes: 5.6e-8 mm (`tests/it/joint_errors.rs`).
//!
//! Together `|e_f32 − e_f64| ≲ 2e-6·e_j + 1e-6 mm + u·|o_j|`, i.e. well under 1e-5 mm for the
//! TX60 at the paper's spreads (e ≈ 0.1–1 mm). Measured on lavapipe (`tests/it/gpu.rs`, 50 test
//! points, 4–6·10^4 draws): max `|w_gpu − w_cpu|` = 9.6e-8 mm (independent), 6.9e-8 mm
//! (correlated), 2.0e-7 mm (nominal reference, `|o_j|` ≈ 1.3 mm); moments agree to ≤ 2e-8
//! relative; the normals to 1.1e-7·(1+|z|). The tests assert 1e-5 mm per sample.

use super::Problem;
use crate::kinematics::{param_index, ParamKind};

/// Vec4 words per test point in [`point_constants`] for an `n`-joint model: `2n + 1` (13 for
/// six joints).
pub const fn words_per_point(joints: usize) -> usize {
    2 * joints + 1
}

/// Per-point constants of the mean-parameter chain (f64, then f32), [`words_per_point`] vec4
/// per point: for joint `i` (0-based) word `2i` is `(u0_i, cos φ_i)` and word `2i+1` is
/// `(p0_{i+1}, sin φ_i)`; word `2n` (12 for six joints) is `(o_j, 0)` with
/// `o_j = P(mean, q_j) − P_ref,j`.
pub fn point_constants(problem: &Problem) -> Vec<[f32; 4]> {
    let mean = &problem.sampler.mean;
    let n = problem.model.joints();
    let wpp = words_per_point(n);
    let mut out = Vec::with_capacity(problem.points.len() * wpp);
    for (q, r) in problem.chain_points.iter().zip(&problem.reference) {
        let mut words = vec![[0f32; 4]; wpp];
        let mut p = problem.model.tool;
        for i in (0..n).rev() {
            let [th, d, a, al, be] = [
                mean[5 * i],
                mean[5 * i + 1],
                mean[5 * i + 2],
                mean[5 * i + 3],
                mean[5 * i + 4],
            ];
            let (sb, cb) = be.sin_cos();
            let (sa, ca) = al.sin_cos();
            let x1 = cb * p[0] + sb * p[2];
            let z1 = -sb * p[0] + cb * p[2];
            let u0 = [x1 + a, ca * p[1] - sa * z1, sa * p[1] + ca * z1 + d];
            let (sp, cp) = (th + q[i]).sin_cos();
            words[2 * i] = [u0[0] as f32, u0[1] as f32, u0[2] as f32, cp as f32];
            words[2 * i + 1] = [p[0] as f32, p[1] as f32, p[2] as f32, sp as f32];
            p = [cp * u0[0] - sp * u0[1], sp * u0[0] + cp * u0[1], u0[2]];
        }
        words[2 * n] = [
            (p[0] - r[0]) as f32,
            (p[1] - r[1]) as f32,
            (p[2] - r[2]) as f32,
            0.0,
        ];
        out.extend_from_slice(&words);
    }
    out
}

/// Per joint `(cos α, sin α, cos β, sin β)` of the mean parameters, f32.
pub fn joint_trig(problem: &Problem) -> Vec<[f32; 4]> {
    let mean = &problem.sampler.mean;
    (0..problem.model.joints())
        .map(|j| {
            let (sa, ca) = mean[param_index(j, ParamKind::Alpha)].sin_cos();
            let (sb, cb) = mean[param_index(j, ParamKind::Beta)].sin_cos();
            [ca as f32, sa as f32, cb as f32, sb as f32]
        })
        .collect()
}

/// How a kernel turns the normals `z` of a counter draw into offsets δ (`docs/METHOD.md §6`),
/// packed for f32.
#[derive(Clone, Debug, PartialEq)]
pub struct SpreadPacking {
    /// `false`: independent, `δ_i = spread[i]·z_i` (one entry per uncertain input: the
    /// parameters, then the tool's x, y, z); `true`: correlated,
    /// `δ_free[a] = Σ_{b≤a} spread[a·n + b]·z_free[b]` with `n` = `free.len()` (row-major lower
    /// Cholesky factor).
    pub correlated: bool,
    /// σ per parameter, or the Cholesky factor of the free parameters.
    pub spread: Vec<f32>,
    /// Free-input indices of the uncertain inputs (correlated); `[0]` otherwise, so the
    /// buffer is never empty.
    pub free: Vec<u32>,
    /// Bit `b` set: Philox block `b` (normals `4b … 4b+3`, `b ≤ 10`) feeds some free input.
    pub block_mask: u32,
    /// The draws include the base placement (correlated over all inputs with the placement, 39
    /// for six joints, §2.8): `spread`
    /// then ends with [`PLACEMENT_WORDS`] constants after the Cholesky factor.
    pub placement: bool,
}

/// f32 words of the placement constants after a placement packing's Cholesky factor: the unit
/// axes `a_y = Rx(r)ᵀRy(p)ᵀẑ` and `a_p = Rx(r)ᵀŷ` of the yaw and pitch increments, then the
/// rows of `R̂ᵀ` (the mean placement's rotation, transposed), 3 each.
pub const PLACEMENT_WORDS: usize = 15;

/// Kernel mode of a packing: 0 independent, 1 correlated, 2 correlated with the placement.
pub fn kernel_mode(p: &SpreadPacking) -> u32 {
    match (p.correlated, p.placement) {
        (_, true) => 2,
        (true, false) => 1,
        (false, false) => 0,
    }
}

impl SpreadPacking {
    /// The packing of `problem`'s sampler.
    pub fn new(problem: &Problem) -> Self {
        let sampler = &problem.sampler;
        let mut block_mask = 0u32;
        match (sampler.sigmas(), sampler.cholesky()) {
            (Some(s), _) => {
                for (i, v) in s.iter().enumerate() {
                    if *v != 0.0 {
                        block_mask |= 1 << (i / 4);
                    }
                }
                SpreadPacking {
                    correlated: false,
                    spread: s.iter().map(|v| *v as f32).collect(),
                    free: vec![0],
                    block_mask,
                    placement: false,
                }
            }
            (None, Some((free, l))) => {
                for &i in free {
                    block_mask |= 1 << (i / 4);
                }
                SpreadPacking {
                    correlated: true,
                    spread: l.iter().map(|v| *v as f32).collect(),
                    free: free.iter().map(|&i| i as u32).collect(),
                    block_mask,
                    placement: false,
                }
            }
            (None, None) => SpreadPacking {
                correlated: false,
                spread: vec![0.0; sampler.n_inputs()],
                free: vec![0],
                block_mask,
                placement: false,
            },
        }
    }

    /// The packing of a model whose draws include the placement: the Cholesky factor over all
    /// its free inputs (indices up to 38), then the [`PLACEMENT_WORDS`] constants.
    pub fn with_placement(spread: &super::PlacementSpread) -> Self {
        use nalgebra::{Rotation3, Vector3};
        let mut block_mask = 0u32;
        for &i in &spread.free {
            block_mask |= 1 << (i / 4);
        }
        let [r, p, y] = [spread.base[3], spread.base[4], spread.base[5]];
        let rx = Rotation3::from_axis_angle(&Vector3::x_axis(), r);
        let ry = Rotation3::from_axis_angle(&Vector3::y_axis(), p);
        let a_y = rx.inverse() * (ry.inverse() * Vector3::z());
        let a_p = rx.inverse() * Vector3::y();
        let rt = Rotation3::from_euler_angles(r, p, y).inverse();
        let mut words: Vec<f32> = spread.chol.iter().map(|v| *v as f32).collect();
        words.extend([a_y.x, a_y.y, a_y.z, a_p.x, a_p.y, a_p.z].map(|v| v as f32));
        for row in 0..3 {
            for c in 0..3 {
                words.push(rt[(row, c)] as f32);
            }
        }
        SpreadPacking {
            correlated: true,
            spread: words,
            free: spread.free.iter().map(|&i| i as u32).collect(),
            block_mask,
            placement: true,
        }
    }

    /// Number of free parameters of a correlated packing (0 when independent).
    pub fn n_free(&self) -> usize {
        if self.correlated {
            self.free.len()
        } else {
            0
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::engine::Reference;
    use crate::kinematics::{position, tx60};

    fn problem(reference: Reference) -> Problem {
        let pts = [[10.0, -20.0, 30.0, 40.0, 50.0, 60.0], [0.0; 6]];
        let mut m = tx60();
        m.params[7] += 0.35;
        Problem::new(m, &pts, &reference, 1).unwrap()
    }

    /// The words rebuild the mean chain: `p_i = Rz(φ_i) u0_i` is `p0_i` of the next word pair
    /// and `p_1 − P_ref = o_j` (f32 rounding of ~1000 mm values: a few 1e-4 mm).
    #[test]
    fn point_words_rebuild_the_mean_chain() {
        let pb = problem(Reference::Nominal(Box::new(tx60())));
        let words = point_constants(&pb);
        let wpp = words_per_point(6);
        assert_eq!(words.len(), 2 * wpp);
        for (j, q) in pb.points.iter().enumerate() {
            let w = &words[j * wpp..(j + 1) * wpp];
            for i in 0..6 {
                let (u, (c, s)) = (w[2 * i], (w[2 * i][3], w[2 * i + 1][3]));
                assert!((f64::from(c).hypot(f64::from(s)) - 1.0).abs() < 1e-6);
                let p = [c * u[0] - s * u[1], s * u[0] + c * u[1], u[2]];
                let next = if i == 0 {
                    let pm = position(&pb.model.params, &pb.model.tool, q);
                    [pm[0] as f32, pm[1] as f32, pm[2] as f32]
                } else {
                    [w[2 * i - 1][0], w[2 * i - 1][1], w[2 * i - 1][2]]
                };
                for k in 0..3 {
                    assert!((p[k] - next[k]).abs() < 1e-3, "point {j} joint {i}");
                }
            }
            let pm = position(&pb.model.params, &pb.model.tool, q);
            for k in 0..3 {
                let o = pm[k] - pb.reference[j][k];
                assert!((f64::from(w[12][k]) - o).abs() < 1e-6 * (1.0 + o.abs()));
            }
        }
        // The calibrated reference has no offset.
        let cal = point_constants(&problem(Reference::Calibrated));
        assert!(cal[12][..3].iter().all(|v| v.abs() < 1e-3));
    }

    #[test]
    fn independent_spread_packs_sigmas_and_blocks() {
        let pb = problem(Reference::Calibrated);
        let p = SpreadPacking::new(&pb);
        let s = pb.model.input_sigmas();
        assert!(!p.correlated);
        assert_eq!(p.n_free(), 0);
        assert_eq!(p.spread, s.map(|v| v as f32).to_vec());
        assert_eq!(p.block_mask & (1 << 8), 0, "no tool spread, no block 8");
        for b in 0..9 {
            let used = (4 * b..(4 * b + 4).min(s.len())).any(|i| s[i] != 0.0);
            assert_eq!(p.block_mask & (1 << b) != 0, used, "block {b}");
        }
    }
}
