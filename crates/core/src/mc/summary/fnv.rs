//! A hand-written 64-bit FNV-1a hash: the fingerprints of a provenance (the model's TOML text,
//! the test points), stable across platforms and Rust versions, unlike `std`'s hashers.

/// 64-bit FNV-1a: the fingerprints of a provenance.
pub(crate) struct Fnv(u64);

impl Fnv {
    pub(crate) fn new() -> Self {
        Fnv(0xcbf2_9ce4_8422_2325)
    }
    pub(crate) fn write(&mut self, bytes: &[u8]) {
        for b in bytes {
            self.0 = (self.0 ^ u64::from(*b)).wrapping_mul(0x0100_0000_01b3);
        }
    }
    /// The hash as 16 hex digits.
    pub(crate) fn hex(&self) -> String {
        format!("{:016x}", self.0)
    }
}
