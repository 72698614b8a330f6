//! Uniform and standard-normal variates from Philox words.
//!
//! Uniform: `u = (x + ½)·2⁻³²` lies strictly inside (0, 1). Normal pairs by the Box–Muller
//! transform `r = √(−2 ln u₁)`, `φ = π·(s₂ + ½)·2⁻³¹` with `s₂` the second word read as a signed
//! integer (so φ ∈ (−π, π), which keeps the f32 shader's sin/cos arguments small), `z₁ = r cos φ`,
//! `z₂ = r sin φ`. Draw `k`'s normal `i` comes from block `i / 4`, words `2⌊(i mod 4)/2⌋` and the
//! next; the WGSL shader uses the same layout.

use super::philox::Philox;

/// Uniform in (0, 1) from one 32-bit word.
#[inline(always)]
pub fn uniform_open(x: u32) -> f64 {
    (f64::from(x) + 0.5) * (1.0 / 4_294_967_296.0)
}

/// Two standard normals from two words (Box–Muller).
#[inline(always)]
pub fn box_muller(x0: u32, x1: u32) -> (f64, f64) {
    let r = (-2.0 * uniform_open(x0).ln()).sqrt();
    let phi = std::f64::consts::PI * (f64::from(x1 as i32) + 0.5) * (1.0 / 2_147_483_648.0);
    let (s, c) = phi.sin_cos();
    (r * c, r * s)
}

/// The four normals of block `block` of draw `draw`, stream `stream`.
#[inline]
pub fn normals_block(g: &Philox, draw: u64, block: u32, stream: u32) -> [f64; 4] {
    let w = g.block(draw, block, stream);
    let (a, b) = box_muller(w[0], w[1]);
    let (c, d) = box_muller(w[2], w[3]);
    [a, b, c, d]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uniform_is_open() {
        assert!(uniform_open(0) > 0.0);
        assert!(uniform_open(u32::MAX) < 1.0);
    }

    #[test]
    fn normals_have_unit_moments() {
        // 4·10^5 normals: the mean's standard error is 1.6e-3, the variance's 2.2e-3;
        // bounds are 5 standard errors.
        let g = Philox::new(12345);
        let n = 100_000u64;
        let (mut s1, mut s2, mut s4) = (0.0, 0.0, 0.0);
        for k in 0..n {
            for z in normals_block(&g, k, 0, 0) {
                s1 += z;
                s2 += z * z;
                s4 += z * z * z * z;
            }
        }
        let m = (4 * n) as f64;
        assert!((s1 / m).abs() < 5.0 * 1.6e-3);
        assert!((s2 / m - 1.0).abs() < 5.0 * 2.2e-3);
        // E z⁴ = 3, sd of the estimate √(96/m) ≈ 0.0155
        assert!((s4 / m - 3.0).abs() < 5.0 * 0.0155);
    }
}
