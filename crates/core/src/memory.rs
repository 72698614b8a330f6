//! Memory estimates before large allocations: how much a run will keep (the draws' values, the
//! per-point buffers, generated points, simulated sweeps) against a budget, so an oversized request
//! is refused up front with a sentence saying what it needs instead of aborting mid-allocation.
//!
//! The budget is the user's limit or, by default, a fraction of the smallest of three rooms: the
//! memory the system reports as available (`MemAvailable` in `/proc/meminfo`), the address space
//! left under the process's limit (`RLIMIT_AS`, which `ulimit -v`, Slurm and containers set, less
//! what the process has already mapped), and what the control group's `memory.max` leaves beside
//! its `memory.current` (cgroup v2, the tightest of the process's group and its parents). Where
//! none of them can be read, [`FALLBACK_BYTES`] is assumed. All sizes use checked arithmetic: a
//! size that does not fit in 64 bits is an error, never a wrap-around.

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

impl MemoryError {
    /// The error with `advice` in place of the estimate's: a front end words what to change
    /// with its own names for the settings (a flag, a keyword).
    pub fn with_advice(self, advice: impl Into<String>) -> MemoryError {
        match self {
            MemoryError::TooLarge {
                what,
                needed,
                limit,
                source_of_limit,
                ..
            } => MemoryError::TooLarge {
                what,
                needed,
                limit,
                source_of_limit,
                advice: advice.into(),
            },
            MemoryError::Overflow { what, .. } => MemoryError::Overflow {
                what,
                advice: advice.into(),
            },
            e @ MemoryError::BadSize(_) => e,
        }
    }

    /// The estimate's advice (none for a size that is not one).
    pub fn advice(&self) -> &str {
        match self {
            MemoryError::TooLarge { advice, .. } | MemoryError::Overflow { advice, .. } => advice,
            MemoryError::BadSize(_) => "",
        }
    }
}

/// Where a [`MemoryBudget`]'s limit comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LimitSource {
    /// Given by the user.
    User,
    /// A fraction of the available memory the system reports.
    Available,
    /// A fraction of the address space left under the process's `RLIMIT_AS`.
    AddressSpace,
    /// A fraction of what the control group's `memory.max` leaves.
    Cgroup,
    /// [`FALLBACK_BYTES`]: the system does not report its available memory.
    Assumed,
}

impl fmt::Display for LimitSource {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            LimitSource::User => "as given",
            LimitSource::Available => "80 % of the available memory",
            LimitSource::AddressSpace => {
                "80 % of the address space left under the process's limit, RLIMIT_AS (ulimit -v), which also caps a larger limit given"
            }
            LimitSource::Cgroup => {
                "80 % of what the control group's memory.max leaves, which also caps a larger limit given"
            }
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
    // Any case: 1gb, 1GB, 1GiB and 1gib are the same size.
    let lower = t.to_ascii_lowercase();
    let t = if lower.ends_with("ib") {
        &t[..t.len() - 2]
    } else if lower.ends_with('b') {
        &t[..t.len() - 1]
    } else {
        t
    };
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
    kb_field(
        &std::fs::read_to_string("/proc/meminfo").ok()?,
        "MemAvailable:",
    )
}

/// Reads `key:  N kB` from a `/proc` status-like text, bytes.
fn kb_field(text: &str, key: &str) -> Option<u64> {
    text.lines()
        .find_map(|l| l.strip_prefix(key))
        .and_then(|rest| rest.trim().strip_suffix("kB"))
        .and_then(|kb| kb.trim().parse::<u64>().ok())
        .and_then(|kb| kb.checked_mul(1024))
}

/// The soft address-space limit from a `/proc/PID/limits` text, bytes; `None` when unlimited.
fn address_space_limit_in(limits: &str) -> Option<u64> {
    let line = limits
        .lines()
        .find(|l| l.starts_with("Max address space"))?;
    let soft = line["Max address space".len()..]
        .split_whitespace()
        .next()?;
    soft.parse().ok()
}

/// The process's soft address-space limit (`RLIMIT_AS`), bytes; `None` when unlimited or the
/// system does not say.
pub fn address_space_limit() -> Option<u64> {
    address_space_limit_in(&std::fs::read_to_string("/proc/self/limits").ok()?)
}

/// Address space the process may still map under `RLIMIT_AS`, bytes (the limit less `VmSize`);
/// `None` when unlimited or the system does not say.
pub fn address_space_left() -> Option<u64> {
    let limit = address_space_limit()?;
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let mapped = kb_field(&status, "VmSize:").unwrap_or(0);
    Some(limit.saturating_sub(mapped))
}

/// What the cgroup v2 limits leave beside their current use, bytes: the smallest of
/// `memory.max − memory.current` over the group named in `cgroup` (a `/proc/self/cgroup` text)
/// and its parents, read through `read(relative path)`; `None` when no group sets a limit.
fn cgroup_room_in(cgroup: &str, read: &dyn Fn(&str) -> Option<String>) -> Option<u64> {
    let path = cgroup.lines().find_map(|l| l.strip_prefix("0::"))?.trim();
    let mut room: Option<u64> = None;
    let mut dir = path.trim_end_matches('/').to_string();
    loop {
        let max = read(&format!("{dir}/memory.max"));
        if let Some(max) = max.and_then(|m| m.trim().parse::<u64>().ok()) {
            let current = read(&format!("{dir}/memory.current"))
                .and_then(|c| c.trim().parse::<u64>().ok())
                .unwrap_or(0);
            let left = max.saturating_sub(current);
            room = Some(room.map_or(left, |r| r.min(left)));
        }
        match dir.rfind('/') {
            Some(i) => dir.truncate(i),
            None => break,
        }
    }
    room
}

/// What the process's cgroup v2 `memory.max` (the tightest over the group and its parents)
/// leaves beside `memory.current`, bytes; `None` when no limit is set or the system does not say.
pub fn cgroup_room() -> Option<u64> {
    let cgroup = std::fs::read_to_string("/proc/self/cgroup").ok()?;
    cgroup_room_in(&cgroup, &|rel| {
        std::fs::read_to_string(format!("/sys/fs/cgroup{rel}")).ok()
    })
}

/// [`DEFAULT_FRACTION`] of the smaller of the rooms the kernel enforces: the address space
/// left under `RLIMIT_AS` and the cgroup's `memory.max`; `None` when neither is set.
pub fn hard_room() -> Option<MemoryBudget> {
    let b = default_budget(None, address_space_left(), cgroup_room());
    (b.source != LimitSource::Assumed).then_some(b)
}

/// The default budget from the three rooms (any may be unknown): [`DEFAULT_FRACTION`] of the
/// smallest, or [`FALLBACK_BYTES`] when none is known.
fn default_budget(
    available: Option<u64>,
    address: Option<u64>,
    cgroup: Option<u64>,
) -> MemoryBudget {
    [
        (available, LimitSource::Available),
        (address, LimitSource::AddressSpace),
        (cgroup, LimitSource::Cgroup),
    ]
    .into_iter()
    .filter_map(|(room, source)| room.map(|r| (r, source)))
    .min_by_key(|&(r, _)| r)
    .map_or(
        MemoryBudget {
            limit: FALLBACK_BYTES,
            source: LimitSource::Assumed,
        },
        |(room, source)| MemoryBudget {
            limit: (room as f64 * DEFAULT_FRACTION) as u64,
            source,
        },
    )
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
    /// The user's limit when given (capped by the hard limits, [`hard_room`]), else
    /// [`DEFAULT_FRACTION`] of the smallest of the available memory, the address space left
    /// under `RLIMIT_AS` and the cgroup's room (see the module documentation).
    pub fn new(user_limit: Option<u64>) -> Self {
        match user_limit {
            Some(limit) => MemoryBudget::given(limit, hard_room()),
            None => default_budget(available_bytes(), address_space_left(), cgroup_room()),
        }
    }

    /// A limit the user gave, or the `hard` room ([`hard_room`]) where that is smaller: the
    /// kernel aborts an allocation past `RLIMIT_AS` and kills a group past its `memory.max`
    /// whatever limit was given. (The available memory does not cap it: the user may count on
    /// swap or on memory being freed.)
    pub fn given(limit: u64, hard: Option<MemoryBudget>) -> Self {
        match hard {
            Some(h) if h.limit < limit => h,
            _ => MemoryBudget {
                limit,
                source: LimitSource::User,
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
    fn a_given_limit_is_capped_by_the_hard_room() {
        let hard = MemoryBudget {
            limit: 400 << 20,
            source: LimitSource::AddressSpace,
        };
        assert_eq!(MemoryBudget::given(4 << 30, Some(hard)), hard);
        let small = MemoryBudget::given(100 << 20, Some(hard));
        assert_eq!((small.limit, small.source), (100 << 20, LimitSource::User));
        let free = MemoryBudget::given(4 << 30, None);
        assert_eq!((free.limit, free.source), (4 << 30, LimitSource::User));
    }

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
    fn sizes_in_any_case() {
        for t in ["1gb", "1GB", "1GiB", "1gib", "1G", "1g"] {
            assert_eq!(parse_size(t).unwrap(), 1 << 30, "{t}");
        }
        assert_eq!(parse_size("512b").unwrap(), 512);
    }

    #[test]
    fn address_space_limit_parses_proc_limits() {
        let text = "Limit                     Soft Limit           Hard Limit           Units     \n\
                    Max stack size            8388608              unlimited            bytes     \n\
                    Max address space         204800000            unlimited            bytes     \n";
        assert_eq!(address_space_limit_in(text), Some(204_800_000));
        let unlimited =
            "Max address space         unlimited            unlimited            bytes\n";
        assert_eq!(address_space_limit_in(unlimited), None);
    }

    #[test]
    fn cgroup_room_is_the_tightest_over_the_parents() {
        let files = |rel: &str| -> Option<String> {
            match rel {
                "/a/b/memory.max" => Some("max\n".into()),
                "/a/b/memory.current" => Some("100\n".into()),
                "/a/memory.max" => Some("1000\n".into()),
                "/a/memory.current" => Some("300\n".into()),
                "/memory.max" => None,
                _ => None,
            }
        };
        assert_eq!(cgroup_room_in("0::/a/b\n", &files), Some(700));
        assert_eq!(cgroup_room_in("0::/x\n", &files), None);
        assert_eq!(cgroup_room_in("1:memory:/a\n", &files), None);
    }

    #[test]
    fn the_default_is_the_smallest_room() {
        let b = default_budget(Some(1000), Some(500), None);
        assert_eq!(b.source, LimitSource::AddressSpace);
        assert_eq!(b.limit, 400);
        let b = default_budget(Some(1000), None, Some(2000));
        assert_eq!(b.source, LimitSource::Available);
        let b = default_budget(Some(1000), Some(5000), Some(100));
        assert_eq!((b.source, b.limit), (LimitSource::Cgroup, 80));
        assert_eq!(
            default_budget(None, None, None).source,
            LimitSource::Assumed
        );
        // The live budget under this test process's own limits is positive.
        assert!(MemoryBudget::new(None).limit > 0);
    }

    #[test]
    fn bytes_print_with_units() {
        assert_eq!(Bytes(512).to_string(), "512 B");
        assert_eq!(Bytes(3 << 29).to_string(), "1.5 GiB");
    }
}
