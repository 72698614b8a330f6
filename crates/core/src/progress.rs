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

/// What a hook calls with a [`Notice`].
type NoticeListener = dyn Fn(Notice<'_>) + Send + Sync;

/// What a long call tells besides its progress, as it arises (before the long part runs), for
/// the front end to show its own way; the call's result holds what it keeps of them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Notice<'a> {
    /// What loading the model chose on the user's behalf (the tip link of a robot description).
    Model(&'a str),
    /// What the call chose on the user's behalf: the backend, the frame, a summary instead of
    /// the values.
    Note(&'a str),
    /// The call expects to take about `seconds` (measured on a pilot): `label` names the work,
    /// `what` says of what size.
    Estimate {
        /// The work ("sensitivity").
        label: &'a str,
        /// Expected wall-clock seconds.
        seconds: f64,
        /// Its size, in words.
        what: &'a str,
    },
}

/// A listener of `(label of the step now starting, steps done, steps planned)`; the plan may
/// grow as the call learns what it has to do. Cloning shares the listener. A hook may also
/// listen to [`Notice`]s ([`ProgressHook::with_notices`]). A hook changes no result: two option
/// sets that differ only in it compare equal.
#[derive(Clone, Default)]
pub struct ProgressHook {
    steps: Option<Arc<Listener>>,
    notices: Option<Arc<NoticeListener>>,
}

impl ProgressHook {
    /// A hook calling `f`.
    pub fn new(f: impl Fn(&str, u64, u64) + Send + Sync + 'static) -> Self {
        ProgressHook {
            steps: Some(Arc::new(f)),
            notices: None,
        }
    }

    /// A hook nobody listens to (the default).
    pub fn none() -> Self {
        ProgressHook::default()
    }

    /// This hook, telling its [`Notice`]s to `f` too.
    ///
    /// ```
    /// use gpu_amcs_core::progress::{Notice, ProgressHook};
    /// use std::sync::{Arc, Mutex};
    ///
    /// let seen = Arc::new(Mutex::new(Vec::new()));
    /// let log = seen.clone();
    /// let hook = ProgressHook::none().with_notices(move |n: Notice<'_>| {
    ///     if let Notice::Note(text) = n {
    ///         log.lock().unwrap().push(text.to_string());
    ///     }
    /// });
    /// assert!(hook.hears_notices());
    /// hook.notice(Notice::Note("using the CPU"));
    /// hook.report("steps are not heard", 0, 1);
    /// assert_eq!(*seen.lock().unwrap(), ["using the CPU"]);
    /// ```
    pub fn with_notices(mut self, f: impl Fn(Notice<'_>) + Send + Sync + 'static) -> Self {
        self.notices = Some(Arc::new(f));
        self
    }

    /// Tells the notice listener, if any, `notice`.
    pub fn notice(&self, notice: Notice<'_>) {
        if let Some(f) = &self.notices {
            f(notice);
        }
    }

    /// Whether anyone listens to notices (a call may skip measuring an estimate nobody hears).
    pub fn hears_notices(&self) -> bool {
        self.notices.is_some()
    }

    /// A hook for part `k` (from 0) of `n` equal parts of the work (one run of several): it
    /// tells this hook's listener each label after `prefix`, and the part's steps as a share of
    /// the whole (in thousandths of a part, so the counts only grow from part to part whatever
    /// each part's own plan).
    pub fn part(&self, k: u64, n: u64, prefix: String) -> Self {
        const UNITS: u64 = 1000;
        let notices = self.notices.clone();
        match &self.steps {
            None => ProgressHook {
                steps: None,
                notices,
            },
            Some(f) => {
                let f = f.clone();
                let mut part = ProgressHook::new(move |label: &str, done, total| {
                    let within = done.min(total) * UNITS / total.max(1);
                    f(
                        &format!("{prefix}{label}"),
                        k * UNITS + within,
                        n.max(1) * UNITS,
                    )
                });
                part.notices = notices;
                part
            }
        }
    }

    /// Tells the listener, if any, that step `label` starts after `done` of `total` steps.
    pub fn report(&self, label: &str, done: u64, total: u64) {
        if let Some(f) = &self.steps {
            f(label, done, total);
        }
    }
}

impl fmt::Debug for ProgressHook {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(if self.steps.is_some() || self.notices.is_some() {
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
