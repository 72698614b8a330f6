//! The steps of one whole-chain identification as its progress hook hears them.

use crate::progress::ProgressHook;

/// Units a step counts in, so that a long step (the Monte Carlo re-identifications) can report
/// its share done.
pub(super) const UNITS: u64 = 1000;

/// Counts the steps of [`super::identify_chain`] for its hook, in thousandths of a step: each
/// geometric pass is a fit, the identifiability and covariance, the Monte Carlo
/// re-identifications when asked for, the check beyond geometry when it runs, and the lack of
/// fit (with the compensation); a kept check adds a second pass.
pub(super) struct Steps<'a> {
    hook: &'a ProgressHook,
    done: u64,
    total: u64,
}

impl<'a> Steps<'a> {
    /// The steps of one pass, with the check beyond geometry when `checks` may run and the
    /// Monte Carlo re-identifications when `monte_carlo`.
    pub(super) fn new(hook: &'a ProgressHook, checks: bool, monte_carlo: bool) -> Self {
        Steps {
            hook,
            done: 0,
            total: Self::pass(checks, monte_carlo),
        }
    }

    /// Steps of one geometric pass.
    pub(super) fn pass(checks: bool, monte_carlo: bool) -> u64 {
        3 + u64::from(checks) + u64::from(monte_carlo)
    }

    /// Step `label` starts.
    pub(super) fn next(&mut self, label: &str) {
        let total = self.total.max(self.done + 1);
        self.hook.report(label, self.done * UNITS, total * UNITS);
        self.done += 1;
    }

    /// `k` of the `n` parts of the step now running are done (from any thread).
    pub(super) fn within(&self, label: &str, k: u64, n: u64) {
        let start = self.done.saturating_sub(1) * UNITS;
        let total = self.total.max(self.done) * UNITS;
        self.hook
            .report(label, start + k.min(n) * UNITS / n.max(1), total);
    }

    /// The plan changes by `more` steps (negative: a planned step does not run).
    pub(super) fn grow(&mut self, more: i64) {
        self.total = self.total.saturating_add_signed(more).max(self.done);
    }

    /// Every step is done.
    pub(super) fn finish(&mut self) {
        self.total = self.done;
        self.hook
            .report("done", self.done * UNITS, self.total * UNITS);
    }
}
