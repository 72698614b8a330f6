//! The backlash's sides (docs/METHOD.md §19.5, the module docs of [`super`]): the words of a
//! draw, their lanes, the sides known at the test points, and the turn a side gives.

use super::{JointErrorDraws, BACKLASH_STREAM};
use crate::kinematics::Joints;
use crate::sampling::philox4x32_10_lanes;

impl JointErrorDraws {
    /// Fixes the sides of the joints whose approach direction at each test point is known:
    /// `sides[j][i]` is `+1` (joint `i` arrives at point `j` moving positive, so it stands
    /// `+h_i` from the rest of the model), `−1`, or `0` (not known: drawn).
    ///
    /// # Errors
    ///
    /// A message when `sides` does not have one entry per test point and joint, an entry is not
    /// −1, 0 or +1, or the model has no backlash to turn.
    pub fn set_known_sides(&mut self, sides: &[Joints]) -> Result<(), String> {
        if !self.backlash {
            return Err("the model has no backlash: approach sides change nothing".into());
        }
        if sides.len() != self.terms.len() {
            return Err(format!(
                "{} rows of sides for {} test points",
                sides.len(),
                self.terms.len()
            ));
        }
        let mut known = Vec::with_capacity(sides.len());
        for (j, s) in sides.iter().enumerate() {
            if s.len() != self.joints {
                return Err(format!(
                    "point {}: {} sides for {} joints",
                    j + 1,
                    s.len(),
                    self.joints
                ));
            }
            let (mut mask, mut bits) = (0u32, 0u32);
            for (i, &v) in s.iter().enumerate() {
                if v == 1.0 {
                    mask |= 1 << i;
                    bits |= 1 << i;
                } else if v == -1.0 {
                    mask |= 1 << i;
                } else if v != 0.0 {
                    return Err(format!(
                        "point {}, joint {}: side {v} is not −1, 0 or +1",
                        j + 1,
                        i + 1
                    ));
                }
            }
            known.push([mask, bits]);
        }
        self.known = if known.iter().any(|k| k[0] != 0) {
            known
        } else {
            Vec::new()
        };
        Ok(())
    }

    /// Puts the test points that `centre` marks at the centre of every gap: no side is drawn
    /// or known there, the joints stand where the model without its backlash puts them (a
    /// model with a term for unknown sides predicts so where a point's sides are not all
    /// known, docs/METHOD.md §19.5). An empty `centre` or one that marks no point clears it.
    ///
    /// # Errors
    ///
    /// A message when `centre` is neither empty nor one entry per test point, or the model has
    /// no backlash.
    pub fn set_centre(&mut self, centre: Vec<bool>) -> Result<(), String> {
        if !self.backlash {
            return Err("the model has no backlash: no joint has a gap to stand in".into());
        }
        if !centre.is_empty() && centre.len() != self.terms.len() {
            return Err(format!(
                "{} centre marks for {} test points",
                centre.len(),
                self.terms.len()
            ));
        }
        self.centre = if centre.iter().any(|&c| c) {
            centre
        } else {
            Vec::new()
        };
        Ok(())
    }

    /// Whether test point `point` stands at the centre of the gaps ([`Self::set_centre`]).
    #[inline(always)]
    pub fn at_centre(&self, point: usize) -> bool {
        self.centre.get(point).copied().unwrap_or(false)
    }

    /// How many of the (test point, joint with a gap) pairs have a known side, of how many:
    /// `(0, total)` when every side is drawn.
    pub fn sides_known(&self) -> (usize, usize) {
        self.sides_known_where(|_| true)
    }

    /// [`Self::sides_known`] over the test points `at` accepts only.
    pub fn sides_known_where(&self, at: impl Fn(usize) -> bool) -> (usize, usize) {
        let acting = (0..self.joints).filter(|&i| self.half_gap[i] > 0.0).count();
        let points = (0..self.terms.len()).filter(|&j| at(j)).count();
        let known = (self.known.iter().enumerate())
            .filter(|&(j, _)| at(j))
            .map(|(_, [mask, _])| {
                (0..self.joints)
                    .filter(|&i| self.half_gap[i] > 0.0 && (mask >> i) & 1 == 1)
                    .count()
            })
            .sum();
        (known, acting * points)
    }

    /// A point's side word `w` with the sides known at test point `point` put in.
    #[inline(always)]
    pub fn with_known(&self, w: u32, point: usize) -> u32 {
        match self.known.get(point) {
            Some(&[mask, bits]) => (w & !mask) | (bits & mask),
            None => w,
        }
    }

    /// Normals a state of the tail analysis gives the term: [`Self::normals`], then two for the
    /// backlash's words when the model has backlash.
    pub fn state_normals(&self) -> usize {
        self.normals() + if self.backlash { 2 } else { 0 }
    }

    /// The backlash's words `(a, b)` of draw `k` (module docs).
    pub fn side_words(&self, k: u64) -> [u32; 2] {
        let [a, b, _, _] = self.gen.block(k, 0, BACKLASH_STREAM);
        [a, b]
    }

    /// The backlash's words `(a, b)` ([`Self::side_words`]) of `L` lanes of draws `draws`.
    #[inline(always)]
    pub fn side_lanes<const L: usize>(&self, draws: &[u64; L]) -> [[u32; L]; 2] {
        let lo: [u32; L] = std::array::from_fn(|l| draws[l] as u32);
        let hi: [u32; L] = std::array::from_fn(|l| (draws[l] >> 32) as u32);
        let w = philox4x32_10_lanes([lo, hi, [0; L], [BACKLASH_STREAM; L]], self.gen.key);
        [w[0], w[1]]
    }
}

/// The backlash's turn of joint `i` from a point's word `w`: `+h` where bit `i` is set, else
/// `−h`.
#[inline(always)]
pub fn side(w: u32, i: usize, h: f64) -> f64 {
    if (w >> i) & 1 != 0 {
        h
    } else {
        -h
    }
}
