//! Progress of a long library call, told to whoever runs it: the command line draws a bar, a
//! notebook may print, a test may count. The library only says which step it is on.
//!
//! # Examples
//!
//! ```
//! use gpu_amcs_core::progress::ProgressHook;
//! use std::sync::{Arc, Mutex};
//!
//! let seen = Arc::new(Mutex::new(Vec::new()));
//! let log = seen.clone();
//! let hook = ProgressHook::new(move |label: &str, done, total| {
//!     log.lock().unwrap().push(format!("{label} {done}/{total}"));
//! });
//! hook.report("fitting", 0, 2);
//! hook.report("checking", 1, 2);
//! ProgressHook::none().report("nobody listens", 0, 1);
//! // The second of four runs, half done: 1500 of 4000 thousandths.
//! hook.part(1, 4, "run 2/4: ".into()).report("checking", 1, 2);
//! assert_eq!(
//!     *seen.lock().unwrap(),
//!     ["fitting 0/2", "checking 1/2", "run 2/4: checking 1500/4000"]
//! );
//! ```

use std::fmt;
use std::sync::Arc;

/// What a hook calls: `(label, done, total)`.
type Listener = dyn Fn(&str, u64, u64) + Send + Sync;

/// A listener of `(label of the step now starting, steps done, steps planned)`; the plan may
/// grow as the call learns what it has to do. Cloning shares the listener. A hook changes no
/// result: two option sets that differ only in it compare equal.
#[derive(Clone, Default)]
pub struct ProgressHook(Option<Arc<Listener>>);

impl ProgressHook {
    /// A hook calling `f`.
    pub fn new(f: impl Fn(&str, u64, u64) + Send + Sync + 'static) -> Self {
        ProgressHook(Some(Arc::new(f)))
    }

    /// A hook nobody listens to (the default).
    pub fn none() -> Self {
        ProgressHook(None)
    }

    /// A hook for part `k` (from 0) of `n` equal parts of the work (one run of several): it
    /// tells this hook's listener each label after `prefix`, and the part's steps as a share of
    /// the whole (in thousandths of a part, so the counts only grow from part to part whatever
    /// each part's own plan).
    pub fn part(&self, k: u64, n: u64, prefix: String) -> Self {
        const UNITS: u64 = 1000;
        match &self.0 {
            None => ProgressHook(None),
            Some(f) => {
                let f = f.clone();
                ProgressHook::new(move |label: &str, done, total| {
                    let within = done.min(total) * UNITS / total.max(1);
                    f(
                        &format!("{prefix}{label}"),
                        k * UNITS + within,
                        n.max(1) * UNITS,
                    )
                })
            }
        }
    }

    /// Tells the listener, if any, that step `label` starts after `done` of `total` steps.
    pub fn report(&self, label: &str, done: u64, total: u64) {
        if let Some(f) = &self.0 {
            f(label, done, total);
        }
    }
}

impl fmt::Debug for ProgressHook {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(if self.0.is_some() {
            "ProgressHook(listening)"
        } else {
            "ProgressHook(none)"
        })
    }
}

impl PartialEq for ProgressHook {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}
