//! Uniform and standard-normal variates from Philox words.
//!
//! The logarithm and sine/cosine of the Box–Muller transform are computed here by branch-free
//! polynomials rather than by the C library: they vectorise across draws and give the same bits
//! on every machine.
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

/// `ln((x + ½)·2⁻³²)`, branch-free (so it vectorises) and bit-reproducible on every machine:
/// `x + ½ = 2^e·m` with `m ∈ [√½, √2)`, `ln m = 2 atanh((m−1)/(m+1))` by its series to s²³
/// (truncation < 1e-18 for |s| ≤ 0.1716), `ln 2` split in a high and a low part.
#[inline(always)]
pub fn ln_open_unit(x: u32) -> f64 {
    const LN2_HI: f64 = 0.693_147_180_369_123_8;
    const LN2_LO: f64 = 1.908_214_929_270_587_7e-10;
    let v = f64::from(x) + 0.5;
    let bits = v.to_bits();
    let mut e = ((bits >> 52) & 0x7ff) as i32 - 1023;
    let mut m = f64::from_bits((bits & 0x000f_ffff_ffff_ffff) | 0x3ff0_0000_0000_0000);
    let big = m > std::f64::consts::SQRT_2;
    m = if big { 0.5 * m } else { m };
    e += i32::from(big);
    let s = (m - 1.0) / (m + 1.0);
    let s2 = s * s;
    let mut p = 1.0 / 23.0;
    for k in (0..11).rev() {
        p = p * s2 + 1.0 / f64::from(2 * k + 1);
    }
    let n = f64::from(e - 32);
    n * LN2_HI + (2.0 * s * p + n * LN2_LO)
}

/// `(sin φ, cos φ)` for `φ = 2π·(x + ½)·2⁻³²` (mod 2π), branch-free: the quadrant comes from the
/// top bits of `x`, the remainder `|r| ≤ π/4` goes through Taylor polynomials to r¹⁷ and r¹⁸
/// (truncation < 1e-19).
#[inline(always)]
pub fn sincos_turns(x: u32) -> (f64, f64) {
    let shifted = x.wrapping_add(1 << 29);
    let q = shifted >> 30;
    let rem = (shifted & ((1 << 30) - 1)) as i32 - (1 << 29);
    let r = std::f64::consts::TAU * ((f64::from(rem) + 0.5) * (1.0 / 4_294_967_296.0));
    let r2 = r * r;
    // sin r = r Σ (−r²)^k / (2k+1)!, cos r = Σ (−r²)^k / (2k)!
    let mut sp = 1.0 / 355_687_428_096_000.0; // 1/17!
    let mut cp = 1.0 / 6_402_373_705_728_000.0; // 1/18!
    const FACT: [f64; 18] = [
        1.0,
        1.0,
        2.0,
        6.0,
        24.0,
        120.0,
        720.0,
        5040.0,
        40320.0,
        362_880.0,
        3_628_800.0,
        39_916_800.0,
        479_001_600.0,
        6_227_020_800.0,
        87_178_291_200.0,
        1_307_674_368_000.0,
        20_922_789_888_000.0,
        355_687_428_096_000.0,
    ];
    for k in (0..8).rev() {
        sp = -sp * r2 + 1.0 / FACT[2 * k + 1];
        cp = -cp * r2 + 1.0 / FACT[2 * k + 2];
    }
    let (sr, cr) = (r * sp, -cp * r2 + 1.0);
    let swap = q & 1 == 1;
    let (s, c) = if swap { (cr, sr) } else { (sr, cr) };
    let s = if q & 2 != 0 { -s } else { s };
    let c = if (q + 1) & 2 != 0 { -c } else { c };
    (s, c)
}

/// Two standard normals from two words (Box–Muller).
#[inline(always)]
pub fn box_muller(x0: u32, x1: u32) -> (f64, f64) {
    let r = (-2.0 * ln_open_unit(x0)).sqrt();
    let (s, c) = sincos_turns(x1);
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
    fn own_ln_and_sincos_are_accurate() {
        let mut worst: f64 = 0.0;
        for i in 0..200_000u64 {
            let x = (i.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 32) as u32;
            let x = if i < 10 {
                i as u32
            } else if i < 20 {
                u32::MAX - i as u32
            } else {
                x
            };
            let ln_ref = uniform_open(x).ln();
            worst = worst.max((ln_open_unit(x) - ln_ref).abs() / ln_ref.abs().max(1e-300));
            let phi = std::f64::consts::PI * (f64::from(x as i32) + 0.5) * (1.0 / 2_147_483_648.0);
            let (s, c) = sincos_turns(x);
            let (sr, cr) = phi.sin_cos();
            assert!(
                (s - sr).abs() < 4e-16 && (c - cr).abs() < 4e-16,
                "{x}: {s} {sr} {c} {cr}"
            );
        }
        assert!(worst < 4e-16, "ln relative error {worst}");
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
