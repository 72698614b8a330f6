//! Memory estimates before large allocations: how much a run will keep (the draws' values, the
//! per-point buffers, generated points, simulated sweeps) against a budget, so an oversized request
//! is refused up front with a sentence saying what it needs instead of aborting mid-allocation.
//!
//! The budget is the user's limit or, by default, a fraction of the memory the system reports as
//! available (`MemAvailable` in `/proc/meminfo`; where that file does not exist,
//! [`FALLBACK_BYTES`] is assumed). All sizes use checked arithmetic: a size that does not fit in
//! 64 bits is an error, never a wrap-around.

use std::fmt;

/// Share of the available memory a run may plan to use by default.
pub const DEFAULT_FRACTION: f64 = 0.8;

/// Memory assumed available where the system does not say (no `/proc/meminfo`), bytes.
pub const FALLBACK_BYTES: u64 = 4 << 30;

/// The binary suffixes [`parse_size`] accepts and their bytes.
const UNITS: [(char, u64); 4] = [
    ('K', 1 << 10),
    ('M', 1 << 20),
    ('G', 1 << 30),
    ('T', 1 << 40),
];

/// Errors of the estimates.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum MemoryError {
    /// The estimate exceeds the budget.
    #[error("{what} needs {} but the memory limit is {} ({source_of_limit}); {advice}", Bytes(*.needed), Bytes(*.limit))]
    TooLarge {
        /// What is being sized (e.g. "10^9 draws").
        what: String,
        /// Bytes needed.
        needed: u64,
        /// Bytes allowed.
        limit: u64,
        /// Where the limit comes from.
        source_of_limit: LimitSource,
        /// What to do instead.
        advice: String,
    },
    /// The size does not fit in 64 bits.
    #[error("{what} is too large to size (more than 2^64 bytes); {advice}")]
    Overflow {
        /// What is being sized.
        what: String,
        /// What to do instead.
        advice: String,
    },
    /// A size text that is not a size.
    #[error("'{0}' is not a size (a number of bytes with an optional K, M, G or T suffix, e.g. 500M or 2G)")]
    BadSize(String),
}

/// Where a [`MemoryBudget`]'s limit comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LimitSource {
    /// Given by the user.
    User,
    /// A fraction of the available memory the system reports.
    Available,
    /// [`FALLBACK_BYTES`]: the system does not report its available memory.
    Assumed,
}

impl fmt::Display for LimitSource {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            LimitSource::User => "as given",
            LimitSource::Available => "80 % of the available memory",
            LimitSource::Assumed => "assumed: the system does not report its available memory",
        })
    }
}

/// A byte count printed with a binary unit (`1.5 GiB`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Bytes(pub u64);

impl fmt::Display for Bytes {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let b = self.0 as f64;
        for (unit, scale) in [("TiB", 1u64 << 40), ("GiB", 1 << 30), ("MiB", 1 << 20)] {
            if self.0 >= scale {
                return write!(f, "{:.1} {unit}", b / scale as f64);
            }
        }
        if self.0 >= 1 << 10 {
            return write!(f, "{:.1} KiB", b / 1024.0);
        }
        write!(f, "{} B", self.0)
    }
}

/// Parses `500M`, `2G`, `1.5G`, `4096` (bytes; suffixes K, M, G, T are binary, an optional
/// trailing `B` or `iB` is accepted).
///
/// # Errors
///
/// [`MemoryError::BadSize`] when `text` is not a number with an optional K, M, G or T suffix, or
/// the size is below 1 byte or does not fit in 64 bits.
pub fn parse_size(text: &str) -> Result<u64, MemoryError> {
    let bad = || MemoryError::BadSize(text.to_string());
    let t = text.trim();
    let t = t
        .strip_suffix("iB")
        .or_else(|| t.strip_suffix('B'))
        .unwrap_or(t);
    let (num, scale) = match t.chars().last().map(|c| c.to_ascii_uppercase()) {
        Some(c) if c.is_ascii_alphabetic() => {
            let scale = UNITS.iter().find(|(u, _)| *u == c).ok_or_else(bad)?.1;
            (&t[..t.len() - 1], scale)
        }
        _ => (t, 1),
    };
    let v: f64 = num.trim().parse().map_err(|_| bad())?;
    let bytes = v * scale as f64;
    if !(bytes.is_finite() && bytes >= 1.0 && bytes < u64::MAX as f64) {
        return Err(bad());
    }
    Ok(bytes as u64)
}

/// Memory the system reports as available, bytes (`MemAvailable`), if it says.
pub fn available_bytes() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    text.lines()
        .find_map(|l| l.strip_prefix("MemAvailable:"))
        .and_then(|rest| rest.trim().strip_suffix("kB"))
        .and_then(|kb| kb.trim().parse::<u64>().ok())
        .and_then(|kb| kb.checked_mul(1024))
}

/// How much memory a run may plan to use.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MemoryBudget {
    /// Bytes allowed.
    pub limit: u64,
    /// Where the limit comes from.
    pub source: LimitSource,
}

impl MemoryBudget {
    /// The user's limit when given, else [`DEFAULT_FRACTION`] of the available memory.
    pub fn new(user_limit: Option<u64>) -> Self {
        match (user_limit, available_bytes()) {
            (Some(limit), _) => MemoryBudget {
                limit,
                source: LimitSource::User,
            },
            (None, Some(avail)) => MemoryBudget {
                limit: (avail as f64 * DEFAULT_FRACTION) as u64,
                source: LimitSource::Available,
            },
            (None, None) => MemoryBudget {
                limit: FALLBACK_BYTES,
                source: LimitSource::Assumed,
            },
        }
    }

    /// Bytes the limit leaves beside `estimate` (0 when it does not fit or overflowed).
    pub fn room_left(&self, estimate: &Estimate) -> u64 {
        estimate
            .bytes
            .map_or(0, |needed| self.limit.saturating_sub(needed))
    }

    /// Checks an [`Estimate`] against the limit.
    ///
    /// # Errors
    ///
    /// [`MemoryError::TooLarge`] when the estimate exceeds the limit, [`MemoryError::Overflow`]
    /// when it overflowed 64 bits; both carry the estimate's advice.
    pub fn check(&self, estimate: &Estimate) -> Result<(), MemoryError> {
        match estimate.bytes {
            None => Err(MemoryError::Overflow {
                what: estimate.what.clone(),
                advice: estimate.advice.clone(),
            }),
            Some(needed) if needed > self.limit => Err(MemoryError::TooLarge {
                what: estimate.what.clone(),
                needed,
                limit: self.limit,
                source_of_limit: self.source,
                advice: estimate.advice.clone(),
            }),
            Some(_) => Ok(()),
        }
    }
}

/// A memory estimate built from checked products and sums; `None` bytes once anything overflowed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Estimate {
    /// What is being sized, for the message.
    pub what: String,
    /// What to do when it does not fit.
    pub advice: String,
    /// Total bytes, `None` after an overflow.
    pub bytes: Option<u64>,
}

impl Estimate {
    /// An empty estimate of `what`; `advice` says what to do when it does not fit.
    pub fn new(what: impl Into<String>, advice: impl Into<String>) -> Self {
        Estimate {
            what: what.into(),
            advice: advice.into(),
            bytes: Some(0),
        }
    }

    /// Adds the product of `factors` bytes (e.g. draws × 8).
    pub fn plus(mut self, factors: &[u64]) -> Self {
        let term = factors.iter().try_fold(1u64, |acc, &f| acc.checked_mul(f));
        self.bytes = self.bytes.zip(term).and_then(|(b, t)| b.checked_add(t));
        self
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse() {
        assert_eq!(parse_size("500M").unwrap(), 500 << 20);
        assert_eq!(parse_size("2g").unwrap(), 2 << 30);
        assert_eq!(parse_size("1.5GiB").unwrap(), 3 << 29);
        assert_eq!(parse_size("4096").unwrap(), 4096);
        for bad in ["", "x", "-1G", "2Q", "nan", "0", "1e30T"] {
            assert!(parse_size(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn overflow_and_limit() {
        let b = MemoryBudget {
            limit: 1000,
            source: LimitSource::User,
        };
        assert!(b.check(&Estimate::new("a", "b").plus(&[10, 100])).is_ok());
        let e = b
            .check(&Estimate::new("a", "b").plus(&[10, 101]))
            .unwrap_err();
        assert!(
            matches!(e, MemoryError::TooLarge { needed: 1010, .. }),
            "{e}"
        );
        let e = Estimate::new("a", "b").plus(&[u64::MAX, 8]);
        assert_eq!(e.bytes, None);
        assert!(matches!(b.check(&e), Err(MemoryError::Overflow { .. })));
        let e = Estimate::new("a", "b").plus(&[u64::MAX]).plus(&[1]);
        assert_eq!(e.bytes, None);
        assert_eq!(b.room_left(&e), 0);
        assert_eq!(b.room_left(&Estimate::new("a", "b").plus(&[300])), 700);
        assert_eq!(b.room_left(&Estimate::new("a", "b").plus(&[3000])), 0);
    }

    #[test]
    fn bytes_print_with_units() {
        assert_eq!(Bytes(512).to_string(), "512 B");
        assert_eq!(Bytes(3 << 29).to_string(), "1.5 GiB");
    }
}
