//! The model's discrepancy term as a run draws it at every test point of every counter draw:
//! the rule of [`crate::discrepancy`] (one 32-bit word per point: radius index from its high
//! half, direction cosine from its low half), in the scalar form and over lanes of draws.
//!
//! The words: one Philox block per draw, `(a, b, c, _) = Philox(draw, 0, DISCREPANCY_STREAM)`,
//! the draw's size factor from `c`'s top 8 bits (one of [`SIZE_DRAWS`] quantiles of the size's
//! posterior, [`crate::discrepancy::size`]),
//! then per point `w_j = h(a ⊕ h(b + j))` with `h` the integer finaliser "lowbias32" (C.
//! Wellons, public domain; a bijection of u32 with a measured bias of 0.17, better than
//! MurmurHash3's). Distinct points of a draw get distinct words, every draw its own
//! 64 bits from Philox; a Philox block per point cost 1.4× the kernel, this costs a few integer
//! operations per point and is as exact in WGSL's u32 arithmetic.

use crate::discrepancy::size::SIZE_DRAWS;
use crate::discrepancy::MAX_SAMPLES;
use crate::sampling::Philox;

/// The Philox stream of the discrepancy's uniforms (the parameter draws use stream 0).
pub const DISCREPANCY_STREAM: u32 = 0xD15C_0000;

/// The integer hash "lowbias32": `x ⊕= x ≫ 16; x ·= 0x7feb352d; x ⊕= x ≫ 15; x ·= 0x846ca68b;
/// x ⊕= x ≫ 16` (wrapping).
#[inline(always)]
pub fn hash32(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^ (x >> 16)
}

/// The word of `point` from its draw's Philox words `a`, `b`: `h(a ⊕ h(b + point))`.
#[inline(always)]
pub fn point_word(a: u32, b: u32, point: u32) -> u32 {
    hash32(a ^ hash32(b.wrapping_add(point)))
}

/// The direction cosine from a word's low half: `c = ((w mod 2¹⁶) + ½)·2⁻¹⁵ − 1`, in (−1, 1)
/// on a grid of 2⁻¹⁵ (the same in f32 on the GPU: both operands are exact there).
#[inline(always)]
pub fn cosine(w: u32) -> f64 {
    (f64::from(w & 0xFFFF) + 0.5) * (1.0 / 32768.0) - 1.0
}

/// The discrepancy as the engine draws it: radii (mm) and the run's Philox key.
#[derive(Clone, Debug, PartialEq)]
pub struct DiscrepancyDraws {
    radii: Vec<f64>,
    /// Per draw, one of these factors of every radius (the term's size, [`SIZE_DRAWS`] of them).
    /// (A fixed-size array: the 8-bit index needs no bounds check in the lanes.)
    factors: Box<[f64; SIZE_DRAWS]>,
    /// Per test point, the factor the radius is drawn with (empty: 1 everywhere); with a
    /// [`SecondTerm`], each point's factor in the term it draws.
    scales: Vec<f64>,
    key: [u32; 2],
    /// A second term drawn at some of the points instead of this one ([`Self::with_second`]),
    /// with its factors as a fixed-size array (as `factors`).
    second: Option<Box<(SecondTerm, [f64; SIZE_DRAWS])>>,
}

/// A term a run draws at some test points instead of the first (a model with backlash whose
/// sides are known at some points: there its own term, at the others the term for unknown
/// sides; docs/METHOD.md §19.5). The same words and the same draw's factor word pick its radius
/// and size factor.
#[derive(Clone, Debug, PartialEq)]
pub struct SecondTerm {
    /// Its radii, mm (1 to [`MAX_SAMPLES`]).
    pub radii: Vec<f64>,
    /// Its per-draw factors of the radii ([`SIZE_DRAWS`]).
    pub factors: Vec<f64>,
    /// Per test point, whether the point draws this term.
    pub at: Vec<bool>,
}

impl DiscrepancyDraws {
    /// Draws from `radii` (mm; 1 to [`MAX_SAMPLES`] of them), each draw's times one of the
    /// [`SIZE_DRAWS`] `factors` ([`crate::discrepancy::Discrepancy::draw_factors`]), with the
    /// run's `seed`.
    ///
    /// # Panics
    ///
    /// When `radii` is empty or longer than [`MAX_SAMPLES`] ([`crate::discrepancy::Discrepancy::checked`] keeps
    /// model files inside), or there are not [`SIZE_DRAWS`] finite non-negative factors.
    pub fn new(radii: Vec<f64>, factors: Vec<f64>, seed: u64) -> DiscrepancyDraws {
        assert!(
            !radii.is_empty() && radii.len() <= MAX_SAMPLES,
            "1 to {MAX_SAMPLES} radii"
        );
        assert!(
            factors.len() == SIZE_DRAWS && factors.iter().all(|g| g.is_finite() && *g >= 0.0),
            "{SIZE_DRAWS} finite non-negative factors"
        );
        let factors: Box<[f64; SIZE_DRAWS]> = factors
            .into_boxed_slice()
            .try_into()
            .expect("checked length");
        DiscrepancyDraws {
            radii,
            factors,
            scales: Vec::new(),
            key: Philox::new(seed).key,
            second: None,
        }
    }

    /// The draws with `second` drawn at the points it marks instead of this term (per-point
    /// factors, [`Self::with_scales`], then hold each point's factor in its own term).
    ///
    /// # Panics
    ///
    /// As [`Self::new`] for the second term's radii and factors.
    pub fn with_second(mut self, second: SecondTerm) -> DiscrepancyDraws {
        assert!(
            !second.radii.is_empty() && second.radii.len() <= MAX_SAMPLES,
            "1 to {MAX_SAMPLES} radii"
        );
        assert!(
            second.factors.len() == SIZE_DRAWS
                && second.factors.iter().all(|g| g.is_finite() && *g >= 0.0),
            "{SIZE_DRAWS} finite non-negative factors"
        );
        let factors: [f64; SIZE_DRAWS] = second.factors[..].try_into().expect("checked length");
        self.second = Some(Box::new((second, factors)));
        self
    }

    /// The second term and the points that draw it, when there is one.
    pub fn second(&self) -> Option<&SecondTerm> {
        self.second.as_deref().map(|(t, _)| t)
    }

    /// The radii (mm) and the per-draw factors of the term test point `point` draws (the first
    /// term's, or the second's where it marks the point).
    #[inline(always)]
    pub fn term_of(&self, point: usize) -> (&[f64], &[f64; SIZE_DRAWS]) {
        match self.second.as_deref() {
            Some((t, factors)) if t.at[point] => (&t.radii, factors),
            _ => (&self.radii, &self.factors),
        }
    }

    /// The radii and the factor of draw word `c` of the term point `point` draws.
    #[inline(always)]
    fn term_at(&self, point: usize, c: u32) -> (&[f64], f64) {
        let (radii, factors) = self.term_of(point);
        (radii, factors[(c >> 24) as usize])
    }

    /// The draws with a factor per test point (a compensated model's predictive σ at each point
    /// over its reference, [`crate::discrepancy::Compensation::point_scales`]); empty keeps 1.
    ///
    /// # Panics
    ///
    /// When a factor is not finite and positive.
    pub fn with_scales(mut self, scales: Vec<f64>) -> DiscrepancyDraws {
        assert!(
            scales.iter().all(|s| s.is_finite() && *s > 0.0),
            "finite positive scales"
        );
        self.scales = scales;
        self
    }

    /// The per-point factors (empty: 1 at every point; with a second term, each point's in the
    /// term it draws).
    pub fn scales(&self) -> &[f64] {
        &self.scales
    }

    /// The factor at `point`.
    #[inline(always)]
    fn scale(&self, point: usize) -> f64 {
        if self.scales.is_empty() {
            1.0
        } else {
            self.scales[point]
        }
    }

    /// The radii, mm.
    pub fn radii(&self) -> &[f64] {
        &self.radii
    }

    /// The per-draw factors of the radii ([`SIZE_DRAWS`], ascending).
    pub fn factors(&self) -> &[f64] {
        &self.factors[..]
    }

    /// The factor of a draw whose Philox block has third word `c`: `factors[c ≫ 24]`.
    #[inline(always)]
    pub fn factor(&self, c: u32) -> f64 {
        self.factors[(c >> 24) as usize]
    }

    /// The Philox key.
    pub fn key(&self) -> [u32; 2] {
        self.key
    }

    /// Index into `k` radii from a word's high half: `⌊(w ≫ 16)·K / 2¹⁶⌋`.
    #[inline(always)]
    pub fn index(w: u32, k: usize) -> usize {
        (((w >> 16) * k as u32) >> 16) as usize
    }

    /// The word of `draw` at `point`, and the draw's factor word.
    fn word(&self, draw: u64, point: usize) -> (u32, u32) {
        let [a, b, c, _] = Philox { key: self.key }.block(draw, 0, DISCREPANCY_STREAM);
        (point_word(a, b, point as u32), c)
    }

    /// The error at `point` of `draw` whose kinematic part has length `e`:
    /// `√(e² + r² + 2erc)`.
    pub fn apply(&self, e: f64, draw: u64, point: usize) -> f64 {
        let (r, c) = self.draw_pair(draw, point);
        (e * e + r * r + 2.0 * e * r * c).max(0.0).sqrt()
    }

    /// [`Self::apply`] on squared errors of `L` draws at once (`e2[l]` of draw `draws[l]`);
    /// `words` caches the draws' Philox words (computed at point 0, so the points of a block of
    /// draws come in order from 0).
    #[inline(always)]
    pub fn apply_squared_lanes<const L: usize>(
        &self,
        e2: &mut [f64; L],
        draws: &[u64; L],
        point: usize,
        words: &mut [[u32; L]; 4],
    ) {
        if point == 0 {
            let c: [[u32; L]; 4] = [
                std::array::from_fn(|l| draws[l] as u32),
                std::array::from_fn(|l| (draws[l] >> 32) as u32),
                [0; L],
                [DISCREPANCY_STREAM; L],
            ];
            *words = crate::sampling::philox4x32_10_lanes(c, self.key);
        }
        let w: [u32; L] =
            std::array::from_fn(|l| point_word(words[0][l], words[1][l], point as u32));
        let s = self.scale(point);
        // The point's term, chosen once for all lanes.
        let (radii, factors) = self.term_of(point);
        for l in 0..L {
            let g = factors[(words[2][l] >> 24) as usize];
            let r = radii[Self::index(w[l], radii.len())] * s * g;
            let c = cosine(w[l]);
            let e = e2[l].sqrt();
            let v = e2[l] + r * r + 2.0 * e * r * c;
            e2[l] = if v > 0.0 { v } else { 0.0 };
        }
    }

    /// The radius (mm) and direction cosine of `draw` at `point`.
    pub fn draw_pair(&self, draw: u64, point: usize) -> (f64, f64) {
        let (w, c) = self.word(draw, point);
        let (radii, g) = self.term_at(point, c);
        (
            radii[Self::index(w, radii.len())] * self.scale(point) * g,
            cosine(w),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lanes_give_the_point_form_bits() {
        let d = DiscrepancyDraws::new(
            vec![0.01, 0.02, 0.05, 0.3, 1.0],
            (0..SIZE_DRAWS).map(|k| 0.5 + k as f64 / 128.0).collect(),
            77,
        );
        let draws: [u64; 8] = std::array::from_fn(|l| 1_000_000_007 + 3 * l as u64);
        let mut words = [[0u32; 8]; 4];
        for point in 0..5 {
            let e: [f64; 8] =
                std::array::from_fn(|l| 0.001 * (l as f64 + 1.0) * (point as f64 + 1.0));
            let mut e2 = e.map(|v| v * v);
            d.apply_squared_lanes(&mut e2, &draws, point, &mut words);
            for l in 0..8 {
                let scalar = d.apply(e[l], draws[l], point);
                assert!(
                    (e2[l].sqrt() - scalar).abs() <= 1e-15 * scalar.max(1.0),
                    "point {point} lane {l}: {} vs {scalar}",
                    e2[l].sqrt()
                );
            }
        }
    }

    #[test]
    fn radii_are_drawn_uniformly_and_directions_isotropically() {
        // e = 0: the error is the drawn radius itself, each of the K equally often.
        let radii = vec![1.0, 2.0, 3.0, 4.0];
        let d = DiscrepancyDraws::new(radii.clone(), vec![1.0; SIZE_DRAWS], 5);
        let n = 40_000u64;
        let mut counts = [0usize; 4];
        let mut cross = 0.0;
        for k in 0..n {
            let r = d.apply(0.0, k, (k % 7) as usize);
            counts[radii.iter().position(|&v| (v - r).abs() < 1e-12).unwrap()] += 1;
            // e = 1 mm: E[e'²] = 1 + E[r²] (the cross term has mean 0 for a uniform direction)
            let e1 = d.apply(1.0, k, 3);
            cross += e1 * e1 - 1.0 - d.draw_pair(k, 3).0.powi(2);
        }
        for c in counts {
            // binomial σ = √(n·¼·¾) ≈ 87
            assert!((c as f64 - n as f64 / 4.0).abs() < 5.0 * 87.0, "{counts:?}");
        }
        // 2·E[r·c] = 0 with sd of the mean ≈ 2·√(7.5/3)/√n ≈ 0.016
        assert!((cross / n as f64).abs() < 0.05, "{}", cross / n as f64);
    }

    #[test]
    fn each_draw_takes_one_factor_at_every_point_and_every_factor_equally_often() {
        // Radius 1 and factor k + 1 for quantile k: at e = 0 the error is the factor itself,
        // the same at every point of a draw.
        let d = DiscrepancyDraws::new(
            vec![1.0],
            (0..SIZE_DRAWS).map(|k| k as f64 + 1.0).collect(),
            9,
        );
        let n = 51_200u64;
        let mut counts = vec![0usize; SIZE_DRAWS];
        for k in 0..n {
            let g = d.apply(0.0, k, 0);
            for point in 1..6 {
                assert_eq!(d.apply(0.0, k, point), g, "draw {k} point {point}");
            }
            counts[g as usize - 1] += 1;
        }
        // 200 expected per factor, binomial σ ≈ 14.1: every count within 5σ
        for (k, c) in counts.iter().enumerate() {
            assert!((*c as f64 - 200.0).abs() < 5.0 * 14.1, "factor {k}: {c}");
        }
    }

    #[test]
    fn the_index_rule_covers_every_radius_and_stays_in_range() {
        for k in [1usize, 2, 3, 1000, MAX_SAMPLES] {
            assert_eq!(DiscrepancyDraws::index(0, k), 0);
            assert_eq!(DiscrepancyDraws::index(u32::MAX, k), k - 1);
        }
    }

    #[test]
    fn a_second_term_is_drawn_at_its_points_only() {
        // First term: radius 1, factor 1; second: radii 10 and 20, factor 3 (so 30 or 60) at
        // points 1 and 3. At e = 0 the error is the radius times the factor.
        let d =
            DiscrepancyDraws::new(vec![1.0], vec![1.0; SIZE_DRAWS], 11).with_second(SecondTerm {
                radii: vec![10.0, 20.0],
                factors: vec![3.0; SIZE_DRAWS],
                at: vec![false, true, false, true],
            });
        let mut seen = [0usize; 2];
        for k in 0..2000u64 {
            for point in 0..4 {
                let r = d.apply(0.0, k, point);
                if point % 2 == 0 {
                    assert_eq!(r, 1.0);
                } else {
                    assert!(r == 30.0 || r == 60.0, "{r}");
                    seen[usize::from(r == 60.0)] += 1;
                }
            }
        }
        // both radii, about equally often (4000 draws: binomial σ ≈ 32)
        assert!((seen[0] as f64 - 2000.0).abs() < 5.0 * 32.0, "{seen:?}");
        // The lanes give the point form's bits, the second term included.
        let draws: [u64; 8] = std::array::from_fn(|l| 99 + 7 * l as u64);
        let mut words = [[0u32; 8]; 4];
        for point in 0..4 {
            let e: [f64; 8] = std::array::from_fn(|l| 0.5 + l as f64);
            let mut e2 = e.map(|v| v * v);
            d.apply_squared_lanes(&mut e2, &draws, point, &mut words);
            for l in 0..8 {
                let scalar = d.apply(e[l], draws[l], point);
                assert!(
                    (e2[l].sqrt() - scalar).abs() <= 1e-14 * scalar,
                    "{point} {l}"
                );
            }
        }
    }
}
