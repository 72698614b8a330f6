//! The progress bar all long subcommands use: hidden with `--quiet`, on stderr otherwise, with
//! the remaining time; a run estimated to take more than [`ANNOUNCE_S`] says so once on stderr,
//! terminal or not.

use indicatif::{ProgressBar, ProgressStyle};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;
use std::time::Instant;

/// Runs estimated to take longer than this many seconds print the estimate.
pub const ANNOUNCE_S: f64 = 10.0;

/// A progress bar over draws or steps.
pub struct Progress {
    bar: ProgressBar,
    unit: &'static str,
    quiet: bool,
    capped: AtomicBool,
    start: Mutex<Instant>,
    announced: AtomicBool,
}

impl Progress {
    /// A bar labelled `label` counting `unit` ("draws", "steps"); hidden when `quiet`.
    pub fn new(quiet: bool, label: &str, unit: &'static str) -> Self {
        let bar = if quiet {
            ProgressBar::hidden()
        } else {
            let bar = ProgressBar::new(0);
            bar.set_style(
                ProgressStyle::with_template(&format!(
                    "{{prefix}} [{{bar:30}}] {{pos}}/{{len}} {unit} ({{elapsed}}, eta {{eta}}) {{msg}}"
                ))
                .unwrap_or_else(|_| ProgressStyle::default_bar())
                .progress_chars("=> "),
            );
            bar
        };
        bar.set_prefix(label.to_string());
        Progress {
            bar,
            unit,
            quiet,
            capped: AtomicBool::new(false),
            start: Mutex::new(Instant::now()),
            announced: AtomicBool::new(false),
        }
    }

    /// The totals are a cap the run may stop short of (AMCS).
    pub fn capped(self) -> Self {
        self.capped.store(true, Ordering::Relaxed);
        self
    }

    /// `done` of `total` (the plan or the cap) so far; announces a long estimate once.
    pub fn update(&self, done: u64, total: u64) {
        self.bar.set_length(total);
        self.bar.set_position(done);
        let elapsed = self
            .start
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .elapsed()
            .as_secs_f64();
        if done == 0 || done >= total || elapsed < 0.2 {
            return;
        }
        let estimate = elapsed * total as f64 / done as f64;
        if estimate > ANNOUNCE_S && !self.quiet && !self.announced.swap(true, Ordering::Relaxed) {
            let line = format!(
                "{}: estimated ~{estimate:.0} s for {total} {}{}",
                self.bar.prefix(),
                self.unit,
                if self.capped.load(Ordering::Relaxed) {
                    " (the cap: it may stop sooner)"
                } else {
                    ""
                }
            );
            // Without a terminal the bar is not drawn; the estimate still goes to stderr.
            if self.bar.is_hidden() {
                eprintln!("{line}");
            } else {
                self.bar.println(line);
            }
        }
    }

    /// Sets the message after the counts.
    pub fn set_message(&self, msg: &str) {
        self.bar.set_message(msg.to_string());
    }

    /// Removes the bar.
    pub fn finish(&self) {
        self.bar.finish_and_clear();
    }
}

/// Where a job's progress under one label is drawn: the bar's label (a fixed one, or the job's
/// label itself), its unit, whether its totals are a cap ([`Progress::capped`]).
pub type Route = for<'a> fn(&'a str) -> (&'a str, &'static str, bool);

/// The bars of a job ([`gpu_amcs::progress::ProgressHook`]): each label the job reports goes to
/// the bar its [`Route`] names (a new one when the bar changes; a label other than the bar's is
/// its message), and its notices go to stderr: what loading the model chose (always, naming
/// `--model`), notes and long estimates (unless quiet).
pub struct Bars {
    quiet: bool,
    route: Route,
    bar: Mutex<Option<(String, Progress)>>,
}

impl Bars {
    /// Bars hidden when `quiet`, routed by `route`.
    pub fn new(quiet: bool, route: Route) -> std::sync::Arc<Bars> {
        std::sync::Arc::new(Bars {
            quiet,
            route,
            bar: Mutex::new(None),
        })
    }

    /// The hook a job reports to; `model` is the `--model` file whose loading notes it tells.
    pub fn hook(
        self: &std::sync::Arc<Bars>,
        model: Option<&std::path::Path>,
    ) -> gpu_amcs::progress::ProgressHook {
        use gpu_amcs::progress::{Notice, ProgressHook};
        let (bars, quiet) = (self.clone(), self.quiet);
        let model = model.map(|p| p.display().to_string());
        ProgressHook::new(move |label: &str, done, total| bars.update(label, done, total))
            .with_notices(move |n: Notice<'_>| match n {
                Notice::Model(text) => {
                    if let Some(m) = &model {
                        eprintln!("note: --model {m}: {text}");
                    }
                }
                Notice::Note(text) if !quiet => eprintln!("note: {text}"),
                Notice::Estimate {
                    label,
                    seconds,
                    what,
                } if !quiet && seconds > ANNOUNCE_S => {
                    eprintln!("{label}: estimated ~{seconds:.0} s for {what}");
                }
                _ => {}
            })
    }

    /// `done` of `total` under `label`.
    fn update(&self, label: &str, done: u64, total: u64) {
        let (name, unit, capped) = (self.route)(label);
        let mut bar = self.bar.lock().unwrap_or_else(|e| e.into_inner());
        if bar.as_ref().map(|(n, _)| n.as_str()) != Some(name) {
            if let Some((_, old)) = bar.take() {
                old.finish();
            }
            let new = Progress::new(self.quiet, name, unit);
            *bar = Some((name.to_string(), if capped { new.capped() } else { new }));
        }
        if let Some((name, b)) = bar.as_ref() {
            b.set_message(if label == name { "" } else { label });
            b.update(done, total);
        }
    }

    /// Removes the bar.
    pub fn finish(&self) {
        if let Some((_, b)) = self.bar.lock().unwrap_or_else(|e| e.into_inner()).take() {
            b.finish();
        }
    }
}
