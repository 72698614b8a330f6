//! The histogram counts of a summary while it is built ([`BinTally`]): a dense window of
//! atomic slots over the bins seen so far, moved into the summary's sparse map at the end.

use super::bin_of;
use crate::mc::summary::BYTES_PER_BIN;
use rayon::prelude::*;
use std::collections::BTreeMap;
use std::sync::atomic::{AtomicU64, Ordering};

/// Draws per piece of the parallel work on one chunk of a summary.
pub(super) const PIECE: usize = 1 << 16;

/// Histogram counts while a summary is built. Counting into the sorted map costs a tree walk per
/// draw (about 140 ns, far more than evaluating a draw on a GPU), so the counts go into a dense
/// window of slots (8 bytes each) over the bins seen so far, counted by all threads at once, and
/// into the map only at the end. The window is kept while it and the map the bins will become
/// fit the bin budget (`2·8·slots + BYTES_PER_BIN·occupied ≤ BYTES_PER_BIN·max_bins`, twice the
/// slots as growing the window copies it); a run whose values spread wider falls back to
/// counting into the map draw by draw, under the same budget.
pub(super) struct BinTally {
    /// Bin of `counts[0]`.
    lo: u64,
    /// Draws per bin of the window `[lo, lo + counts.len())`.
    counts: Vec<AtomicU64>,
    /// Non-zero slots of the window.
    occupied: u64,
    /// The budget in bins ([`BYTES_PER_BIN`] each).
    max_bins: u64,
    /// Whether the window is still in use.
    dense: bool,
}

impl BinTally {
    pub(super) fn new(max_bins: u64) -> Self {
        BinTally {
            lo: 0,
            counts: Vec::new(),
            occupied: 0,
            max_bins,
            dense: true,
        }
    }

    /// Whether a window of `slots` slots with `occupied` bins fits the budget.
    fn fits(&self, slots: u64, occupied: u64) -> bool {
        let bytes = u128::from(slots) * 8 + u128::from(occupied) * u128::from(BYTES_PER_BIN);
        bytes <= u128::from(self.max_bins) * u128::from(BYTES_PER_BIN)
    }

    /// Counts the bins of `w` (finite, non-negative, within `range`): into the window when it
    /// can cover them, else (once and for all) into `bins`.
    pub(super) fn add(&mut self, w: &[f64], range: (f64, f64), bins: &mut BTreeMap<u64, u64>) {
        if w.is_empty() {
            return;
        }
        if self.dense {
            // bin_of is monotone: the extreme values have the extreme bins.
            let (a, b) = (bin_of(range.0), bin_of(range.1));
            let (lo, hi) = if self.counts.is_empty() {
                (a, b + 1)
            } else {
                (
                    a.min(self.lo),
                    (b + 1).max(self.lo + self.counts.len() as u64),
                )
            };
            if self.fits(2 * (hi - lo), self.occupied) {
                if lo != self.lo || hi - lo != self.counts.len() as u64 {
                    let mut grown: Vec<AtomicU64> =
                        (0..hi - lo).map(|_| AtomicU64::new(0)).collect();
                    let at = if self.counts.is_empty() {
                        0
                    } else {
                        (self.lo - lo) as usize
                    };
                    for (g, c) in grown[at..].iter_mut().zip(&mut self.counts) {
                        *g.get_mut() = *c.get_mut();
                    }
                    self.counts = grown;
                    self.lo = lo;
                }
                let (counts, base) = (&self.counts, self.lo);
                let new: u64 = w
                    .par_chunks(PIECE)
                    .map(|piece| {
                        let mut new = 0;
                        for &v in piece {
                            let c = &counts[(bin_of(v) - base) as usize];
                            new += u64::from(c.fetch_add(1, Ordering::Relaxed) == 0);
                        }
                        new
                    })
                    .sum();
                self.occupied += new;
                return;
            }
            self.flush(bins);
            self.dense = false;
        }
        for &v in w {
            *bins.entry(bin_of(v)).or_insert(0) += 1;
        }
    }

    /// Occupied bins so far, window and map together.
    pub(super) fn occupied(&self, bins: &BTreeMap<u64, u64>) -> u64 {
        self.occupied + bins.len() as u64
    }

    /// Moves the window's counts into `bins` and empties it.
    pub(super) fn flush(&mut self, bins: &mut BTreeMap<u64, u64>) {
        for (i, c) in self.counts.iter_mut().enumerate() {
            let c = *c.get_mut();
            if c > 0 {
                *bins.entry(self.lo + i as u64).or_insert(0) += c;
            }
        }
        self.counts = Vec::new();
        self.occupied = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Counts of `w` draw by draw, as the map would hold them.
    fn naive(chunks: &[Vec<f64>]) -> BTreeMap<u64, u64> {
        let mut m = BTreeMap::new();
        for v in chunks.iter().flatten() {
            *m.entry(bin_of(*v)).or_insert(0) += 1;
        }
        m
    }

    fn tallied(chunks: &[Vec<f64>], max_bins: u64) -> (BTreeMap<u64, u64>, bool, u64) {
        let mut t = BinTally::new(max_bins);
        let mut bins = BTreeMap::new();
        let mut most = 0;
        for c in chunks {
            let lo = c.iter().cloned().fold(f64::INFINITY, f64::min);
            let hi = c.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
            t.add(c, (lo, hi), &mut bins);
            most = most.max(t.occupied(&bins));
        }
        let dense = t.dense;
        t.flush(&mut bins);
        (bins, dense, most)
    }

    #[test]
    fn the_window_counts_as_the_map_does_and_falls_back_when_too_wide() {
        // Chunks that grow the window at both ends and revisit bins; one lone far value.
        let chunks = vec![
            vec![0.100_000_4, 0.100_000_6, 0.100_002_1],
            vec![0.099_990_0, 0.100_000_5],
            vec![0.100_050_0, 0.099_990_01, 0.1],
        ];
        let want = naive(&chunks);
        // A budget that holds the ~60-slot window: dense to the end, the same counts.
        let (got, dense, most) = tallied(&chunks, 1000);
        assert!(dense);
        assert_eq!(got, want);
        assert_eq!(most, want.len() as u64);
        // A budget too small for the window: the map from the first chunk on, the same counts.
        let (got, dense, _) = tallied(&chunks, 4);
        assert!(!dense);
        assert_eq!(got, want);
        // A far value after a dense start: the window is moved into the map, nothing lost.
        let mut far = chunks.clone();
        far.push(vec![5.0, 0.100_000_4]);
        let want = naive(&far);
        let (got, dense, most) = tallied(&far, 1000);
        assert!(!dense);
        assert_eq!(got, want);
        assert_eq!(most, want.len() as u64);
    }
}
