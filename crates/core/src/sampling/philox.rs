//! Philox4x32-10 counter-based generator (Salmon, Moraes, Dror, Shaw, SC'11; Random123).
//!
//! Ten rounds of `(hi, lo) = mulhilo(M, c)` S-boxes with a Weyl-sequence key schedule. Checked
//! against the Random123 known-answer vectors in the tests below (`docs/METHOD.md §6`).

const M0: u32 = 0xD251_1F53;
const M1: u32 = 0xCD9E_8D57;
const W0: u32 = 0x9E37_79B9;
const W1: u32 = 0xBB67_AE85;

#[inline(always)]
fn mulhilo(a: u32, b: u32) -> (u32, u32) {
    let p = u64::from(a) * u64::from(b);
    ((p >> 32) as u32, p as u32)
}

/// One Philox4x32-10 block: 4 output words for a 4-word counter and a 2-word key.
#[inline]
pub fn philox4x32_10(mut c: [u32; 4], mut k: [u32; 2]) -> [u32; 4] {
    for round in 0..10 {
        if round > 0 {
            k[0] = k[0].wrapping_add(W0);
            k[1] = k[1].wrapping_add(W1);
        }
        let (hi0, lo0) = mulhilo(M0, c[0]);
        let (hi1, lo1) = mulhilo(M1, c[2]);
        c = [hi1 ^ c[1] ^ k[0], lo1, hi0 ^ c[3] ^ k[1], lo0];
    }
    c
}

/// Philox4x32-10 on `L` counters at once (structure of arrays, so the rounds vectorise):
/// `c[w][l]` is word `w` of lane `l`'s counter. Same results as [`philox4x32_10`] per lane.
#[inline(always)]
pub fn philox4x32_10_lanes<const L: usize>(mut c: [[u32; L]; 4], mut k: [u32; 2]) -> [[u32; L]; 4] {
    for round in 0..10 {
        if round > 0 {
            k[0] = k[0].wrapping_add(W0);
            k[1] = k[1].wrapping_add(W1);
        }
        for l in 0..L {
            let (hi0, lo0) = mulhilo(M0, c[0][l]);
            let (hi1, lo1) = mulhilo(M1, c[2][l]);
            let (c1, c3) = (c[1][l], c[3][l]);
            c[0][l] = hi1 ^ c1 ^ k[0];
            c[1][l] = lo1;
            c[2][l] = hi0 ^ c3 ^ k[1];
            c[3][l] = lo0;
        }
    }
    c
}

/// The keyed generator of one run: block `(draw, block, stream)` → 4 words.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Philox {
    /// Key derived from the seed.
    pub key: [u32; 2],
}

impl Philox {
    /// Key = the 64-bit seed split into two words.
    pub fn new(seed: u64) -> Self {
        Philox {
            key: [seed as u32, (seed >> 32) as u32],
        }
    }

    /// Words for draw `draw`, block `block` of that draw, in stream `stream`.
    /// Counter layout: `[draw low, draw high, block, stream]`.
    #[inline]
    pub fn block(&self, draw: u64, block: u32, stream: u32) -> [u32; 4] {
        philox4x32_10([draw as u32, (draw >> 32) as u32, block, stream], self.key)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lanes_match_scalar() {
        let key = [0xa4093822, 0x299f31d0];
        let ctr: [[u32; 3]; 4] = [[1, 2, u32::MAX], [0, 7, 9], [3, 3, 3], [0, 1, 2]];
        let out = philox4x32_10_lanes(ctr, key);
        for l in 0..3 {
            let s = philox4x32_10([ctr[0][l], ctr[1][l], ctr[2][l], ctr[3][l]], key);
            assert_eq!(s, [out[0][l], out[1][l], out[2][l], out[3][l]]);
        }
    }

    #[test]
    fn random123_known_answers() {
        assert_eq!(
            philox4x32_10([0; 4], [0; 2]),
            [0x6627e8d5, 0xe169c58d, 0xbc57ac4c, 0x9b00dbd8]
        );
        assert_eq!(
            philox4x32_10([u32::MAX; 4], [u32::MAX; 2]),
            [0x408f276d, 0x41c83b0e, 0xa20bc7c6, 0x6d5451fd]
        );
        assert_eq!(
            philox4x32_10(
                [0x243f6a88, 0x85a308d3, 0x13198a2e, 0x03707344],
                [0xa4093822, 0x299f31d0]
            ),
            [0xd16cfe09, 0x94fdcceb, 0x5001e420, 0x24126ea1]
        );
    }
}
