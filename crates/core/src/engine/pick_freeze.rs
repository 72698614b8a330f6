//! The rows of a pick-freeze design as the evaluators take them (Sobol indices,
//! `docs/METHOD.md §9`): which draw each standard normal of a row comes from, and the draw of
//! its discrepancy term.

use super::EngineError;
use crate::sampling::{ALL_NORMALS, MAX_NORMALS};

/// The bit of a pick-freeze mask that takes a row's discrepancy term (when the problem draws
/// one) from draw `b` instead of `a`: the term is one more input of a Sobol design, beside the
/// standard normals (bits `0 … MAX_NORMALS − 1`).
pub const DISCREPANCY_MASK: u64 = 1 << 63;

/// The rows of the matrices of a pick-freeze design (Sobol indices, `docs/METHOD.md §9`):
/// matrix `s` has `count` rows, and its row `r` is the parameter vector whose standard normal
/// `i` is normal `i` of draw `b_first + r` if bit `i` of `masks[s]` is set, and of draw
/// `first + r` otherwise. Matrix A is mask 0 (draw `first + r` itself), B is [`ALL_NORMALS`]
/// (draw `b_first + r`), and `A_B^(S)` has the bits of the inputs in `S`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PickFreeze<'a> {
    /// Draw of row 0 of A (the base sample index).
    pub first: u64,
    /// Draw of row 0 of B.
    pub b_first: u64,
    /// Rows per matrix.
    pub count: usize,
    /// One mask of standard normals per matrix (bits `0 … MAX_NORMALS − 1`).
    pub masks: &'a [u64],
}

impl PickFreeze<'_> {
    /// Rows of the request: `count · masks.len()`.
    pub fn rows(&self) -> usize {
        self.count * self.masks.len()
    }

    /// The draw whose discrepancy term row `row` takes: `b` when its mask has
    /// [`DISCREPANCY_MASK`], else `a`.
    #[inline]
    pub fn discrepancy_draw(&self, row: usize) -> u64 {
        let (a, b, mask) = self.row(row);
        if mask & DISCREPANCY_MASK != 0 {
            b
        } else {
            a
        }
    }

    /// The draws row `row` takes its joint errors' normals from, per [`super::TermGroup`], and
    /// (last) its backlash's sides: `b` where its mask has the group's bit
    /// ([`super::TermGroup::mask`], [`super::BACKLASH_MASK`]), else `a`.
    #[inline]
    pub fn joint_error_draws(&self, row: usize) -> [u64; 4] {
        let (a, b, mask) = self.row(row);
        super::TermGroup::ALL.map(|g| if mask & g.mask() != 0 { b } else { a })
    }

    /// Row `row` of the request (matrix-major): draws `(a, b)` and the mask.
    #[inline]
    pub fn row(&self, row: usize) -> (u64, u64, u64) {
        let (s, r) = (row / self.count, (row % self.count) as u64);
        (self.first + r, self.b_first + r, self.masks[s])
    }

    /// Checks masks and draw ranges.
    ///
    /// # Errors
    ///
    /// [`EngineError::PickFreezeRequest`] when a mask has bits beyond the [`MAX_NORMALS`] normals
    /// of a draw, the rows overflow `usize`, or the rows of A or B pass the last draw index 2⁶⁴ −
    /// 1.
    pub fn check(&self) -> Result<(), EngineError> {
        let bad = |m: String| Err(EngineError::PickFreezeRequest(m));
        if let Some((s, m)) =
            self.masks.iter().enumerate().find(|(_, &m)| {
                m & !(ALL_NORMALS | DISCREPANCY_MASK | super::JOINT_ERRORS_MASK) != 0
            })
        {
            return bad(format!(
                "mask of matrix {s} is {m:#x}: a draw has {MAX_NORMALS} normals (bits 59–62 for the joint errors' groups, 63 for the discrepancy term)"
            ));
        }
        if self.count.checked_mul(self.masks.len()).is_none() {
            return bad(format!(
                "{} matrices of {} rows are too many",
                self.masks.len(),
                self.count
            ));
        }
        for (name, d) in [("A", self.first), ("B", self.b_first)] {
            if d.checked_add(self.count as u64).is_none() {
                return bad(format!(
                    "rows of {name} from draw {d} on pass the last draw index 2^64 − 1"
                ));
            }
        }
        Ok(())
    }
}
