//! The steps of one whole-chain identification as its progress hook hears them.

use crate::progress::ProgressHook;

/// Counts the steps of [`super::identify_chain`] for its hook: each geometric pass is a fit, the
/// identifiability and covariance, the check beyond geometry when it runs, and the lack of fit
/// (with the compensation); a kept check adds a second pass.
pub(super) struct Steps<'a> {
    hook: &'a ProgressHook,
    done: u64,
    total: u64,
}

impl<'a> Steps<'a> {
    /// The steps of one pass, with the check beyond geometry when `checks` may run.
    pub(super) fn new(hook: &'a ProgressHook, checks: bool) -> Self {
        Steps {
            hook,
            done: 0,
            total: Self::pass(checks),
        }
    }

    /// Steps of one geometric pass.
    pub(super) fn pass(checks: bool) -> u64 {
        if checks {
            4
        } else {
            3
        }
    }

    /// Step `label` starts.
    pub(super) fn next(&mut self, label: &str) {
        self.hook
            .report(label, self.done, self.total.max(self.done + 1));
        self.done += 1;
    }

    /// The plan changes by `more` steps (negative: a planned step does not run).
    pub(super) fn grow(&mut self, more: i64) {
        self.total = self.total.saturating_add_signed(more).max(self.done);
    }

    /// Every step is done.
    pub(super) fn finish(&mut self) {
        self.total = self.done;
        self.hook.report("done", self.done, self.total);
    }
}
