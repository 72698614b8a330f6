//! SHA-256 digests as lower-case hex: the data fingerprint of an identification's provenance and
//! the content checksum of shard files (a module of its own so that both can use it).

use sha2::{Digest, Sha256};
use std::fmt::Write as _;

/// SHA-256 of `bytes` as lower-case hex.
pub fn sha256_hex(bytes: &[u8]) -> String {
    Sha256::digest(bytes)
        .iter()
        .fold(String::with_capacity(64), |mut s, b| {
            let _ = write!(s, "{b:02x}");
            s
        })
}
