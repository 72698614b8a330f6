//! The model's discrepancy term as a run draws it at every test point of every counter draw:
//! the rule of [`crate::discrepancy`] (radius by integer index from one Philox word, direction
//! cosine from the next), in the scalar form and over lanes of draws.

use crate::discrepancy::MAX_SAMPLES;
use crate::sampling::Philox;

/// The Philox stream of the discrepancy's uniforms (the parameter draws use stream 0).
pub const DISCREPANCY_STREAM: u32 = 0xD15C_0000;

/// The discrepancy as the engine draws it: radii (mm) and the run's Philox key.
#[derive(Clone, Debug, PartialEq)]
pub struct DiscrepancyDraws {
    radii: Vec<f64>,
    key: [u32; 2],
}

impl DiscrepancyDraws {
    /// Draws from `radii` (mm; 1 to [`MAX_SAMPLES`] of them) with the run's `seed`.
    ///
    /// # Panics
    ///
    /// When `radii` is empty or longer than [`MAX_SAMPLES`] ([`Discrepancy::checked`] keeps
    /// model files inside).
    pub fn new(radii: Vec<f64>, seed: u64) -> DiscrepancyDraws {
        assert!(
            !radii.is_empty() && radii.len() <= MAX_SAMPLES,
            "1 to {MAX_SAMPLES} radii"
        );
        DiscrepancyDraws {
            radii,
            key: Philox::new(seed).key,
        }
    }

    /// The radii, mm.
    pub fn radii(&self) -> &[f64] {
        &self.radii
    }

    /// The Philox key.
    pub fn key(&self) -> [u32; 2] {
        self.key
    }

    /// Index into the radii from a word: `⌊(w ≫ 16)·K / 2¹⁶⌋`.
    #[inline(always)]
    pub fn index(&self, w: u32) -> usize {
        (((w >> 16) * self.radii.len() as u32) >> 16) as usize
    }

    /// `(r, c)` of `draw` at `point` from the block's words.
    #[inline(always)]
    fn pair(&self, words: [u32; 4], point: usize) -> (f64, f64) {
        let o = 2 * (point % 2);
        let r = self.radii[self.index(words[o])];
        let c = 2.0 * crate::sampling::uniform_open(words[o + 1]) - 1.0;
        (r, c)
    }

    /// The error at `point` of `draw` whose kinematic part has length `e`:
    /// `√(e² + r² + 2erc)`.
    pub fn apply(&self, e: f64, draw: u64, point: usize) -> f64 {
        let words = Philox { key: self.key }.block(draw, (point / 2) as u32, DISCREPANCY_STREAM);
        let (r, c) = self.pair(words, point);
        (e * e + r * r + 2.0 * e * r * c).max(0.0).sqrt()
    }

    /// [`Self::apply`] on squared errors of `L` draws at once (`e2[l]` of draw `draws[l]`);
    /// `words` caches the Philox block of the pair of points (computed at even `point`).
    #[inline(always)]
    pub fn apply_squared_lanes<const L: usize>(
        &self,
        e2: &mut [f64; L],
        draws: &[u64; L],
        point: usize,
        words: &mut [[u32; L]; 4],
    ) {
        if point.is_multiple_of(2) {
            let c: [[u32; L]; 4] = [
                std::array::from_fn(|l| draws[l] as u32),
                std::array::from_fn(|l| (draws[l] >> 32) as u32),
                [(point / 2) as u32; L],
                [DISCREPANCY_STREAM; L],
            ];
            *words = crate::sampling::philox4x32_10_lanes(c, self.key);
        }
        let o = 2 * (point % 2);
        for l in 0..L {
            let r = self.radii[self.index(words[o][l])];
            let c = 2.0 * crate::sampling::uniform_open(words[o + 1][l]) - 1.0;
            let e = e2[l].sqrt();
            let v = e2[l] + r * r + 2.0 * e * r * c;
            e2[l] = if v > 0.0 { v } else { 0.0 };
        }
    }

    /// The per-draw `(r, c)` pairs of `point` for `draws` (tests and the GPU comparison).
    pub fn draw_pair(&self, draw: u64, point: usize) -> (f64, f64) {
        let words = Philox { key: self.key }.block(draw, (point / 2) as u32, DISCREPANCY_STREAM);
        self.pair(words, point)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lanes_give_the_point_form_bits() {
        let d = DiscrepancyDraws::new(vec![0.01, 0.02, 0.05, 0.3, 1.0], 77);
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
        let d = DiscrepancyDraws::new(radii.clone(), 5);
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
    fn the_index_rule_covers_every_radius_and_stays_in_range() {
        for k in [1usize, 2, 3, 1000, MAX_SAMPLES] {
            let d = DiscrepancyDraws::new(vec![0.0; k], 1);
            assert_eq!(d.index(0), 0);
            assert_eq!(d.index(u32::MAX), k - 1);
        }
    }
}
