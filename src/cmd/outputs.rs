//! Every output of a subcommand in one value, checked before any work and written all or none.
//!
//! Before the computation, [`Outputs::file`] and [`Outputs::dir`] check each output location: the
//! nearest existing ancestor is a writable directory, an existing file is not a directory (or a
//! directory output not a file), no two outputs are the same file and no output is a file the
//! run reads (inputs inside an output directory included, by the names it will write). After the
//! computation, the contents are staged (a directory only the names it declared; the same file
//! staged twice with the same contents, as a report directory that is also another output's,
//! is written once), and [`Outputs::commit`] writes every file to a temporary file beside it
//! (`.NAME.tmpPID`), and only when all are written renames them into place. On any error, and
//! on SIGINT, SIGTERM or SIGHUP (see [`install_signal_cleanup`]), the temporary files and the
//! directories the commit created are removed. A signal that arrives once every report is in
//! place does not turn the finished run into a failure: the run prints its summary and exits 0,
//! unless it is still running [`COMMITTED_GRACE`] later (stdout blocked, say).

use anyhow::{anyhow, bail, Result};
use std::path::{Component, Path, PathBuf};
use std::sync::Mutex;

/// Temporary files and created directories of the commit in progress, for the signal handler.
static PENDING: Mutex<Pending> = Mutex::new(Pending {
    files: Vec::new(),
    dirs: Vec::new(),
    committed: false,
});

struct Pending {
    files: Vec<PathBuf>,
    dirs: Vec<PathBuf>,
    /// Every report of the last commit is in place: what is left of the run is its summary.
    committed: bool,
}

/// How long a signal that arrives after the commit waits for the run to end by itself (exit 0)
/// before it ends it with 128 + the signal number.
pub const COMMITTED_GRACE: std::time::Duration = std::time::Duration::from_secs(2);

impl Pending {
    /// Removes the temporary files and (when empty) the created directories, deepest first.
    fn clean(&mut self) {
        for f in self.files.drain(..) {
            let _ = std::fs::remove_file(f);
        }
        for d in self.dirs.drain(..).rev() {
            let _ = std::fs::remove_dir(d);
        }
    }
}

fn pending() -> std::sync::MutexGuard<'static, Pending> {
    PENDING.lock().unwrap_or_else(|e| e.into_inner())
}

/// Starts a thread that, on SIGINT, SIGTERM or SIGHUP, removes the pending temporary files and
/// exits with 128 + the signal number; after a completed commit it first gives the run
/// [`COMMITTED_GRACE`] to finish (a run whose reports are all written is not a failure). SIGXFSZ (file size limit) is caught too, so a write over
/// the limit fails with an error that the commit cleans up after instead of killing the process.
pub fn install_signal_cleanup() {
    use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM, SIGXFSZ};
    let Ok(mut signals) = signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP, SIGXFSZ])
    else {
        return;
    };
    std::thread::spawn(move || {
        for sig in signals.forever() {
            if sig == SIGXFSZ {
                continue;
            }
            // The lock is held until the process ends: a writer that is creating or writing
            // a temporary file finishes it first (and it is then removed), and none can start
            // another between the cleanup and the exit.
            let mut p = pending();
            if p.committed {
                // Every report is in place: let the run print its summary and exit 0 (the
                // process ends this thread), unless it is still running after the grace.
                drop(p);
                std::thread::sleep(COMMITTED_GRACE);
                p = pending();
            }
            p.clean();
            std::process::exit(128 + sig);
        }
    });
}

/// What an output is.
#[derive(Clone, Debug)]
enum Kind {
    /// One file.
    File,
    /// An existing file that is not a regular file (`/dev/null`, a FIFO): written in place, at
    /// the end, never replaced by a rename.
    Special,
    /// A directory of files; the names it may write (any name when empty).
    Dir(Vec<String>),
}

#[derive(Clone, Debug)]
struct Target {
    flag: &'static str,
    path: PathBuf,
    resolved: PathBuf,
    kind: Kind,
}

/// The outputs of one subcommand.
#[derive(Debug, Default)]
pub struct Outputs {
    inputs: Vec<(&'static str, PathBuf, PathBuf)>,
    targets: Vec<Target>,
    staged: Vec<(&'static str, PathBuf, String)>,
    /// Indices into `staged` of the outputs written in place.
    special: Vec<usize>,
}

/// `p` made absolute, `.`/`..` resolved, and symbolic links resolved as far as it exists.
fn resolve(p: &Path) -> PathBuf {
    let abs = std::env::current_dir().unwrap_or_default().join(p);
    let mut clean = PathBuf::new();
    for c in abs.components() {
        match c {
            Component::ParentDir => {
                clean.pop();
            }
            Component::CurDir => {}
            other => clean.push(other),
        }
    }
    let mut base = clean.as_path();
    let mut rest = Vec::new();
    loop {
        if let Ok(c) = std::fs::canonicalize(base) {
            return rest.iter().rev().fold(c, |acc, n| acc.join(n));
        }
        match (base.parent(), base.file_name()) {
            (Some(parent), Some(name)) => {
                rest.push(name.to_os_string());
                base = parent;
            }
            _ => return clean,
        }
    }
}

/// The nearest existing ancestor of `p` (or `p`) must be a directory we can create files in.
fn check_writable(flag: &str, shown: &Path, dir: &Path) -> Result<()> {
    let mut base = dir;
    while !base.exists() {
        match base.parent() {
            Some(p) => base = p,
            None => break,
        }
    }
    if !base.is_dir() {
        bail!(
            "{flag} {}: {} is not a directory",
            shown.display(),
            base.display()
        );
    }
    let probe = base.join(format!(".gpu-amcs-probe{}", std::process::id()));
    match std::fs::File::create(&probe) {
        Ok(_) => {
            let _ = std::fs::remove_file(&probe);
            Ok(())
        }
        Err(e) => bail!(
            "{flag} {}: cannot write in {}: {e}",
            shown.display(),
            base.display()
        ),
    }
}

impl Outputs {
    /// Outputs of a run that reads `inputs` (`(flag, path)`), which no output may overwrite.
    pub fn new<'a>(inputs: impl IntoIterator<Item = (&'static str, &'a Path)>) -> Self {
        Outputs {
            inputs: inputs
                .into_iter()
                .map(|(f, p)| (f, p.to_path_buf(), resolve(p)))
                .collect(),
            ..Outputs::default()
        }
    }

    /// Adds inputs known only after the work (the files a xacro expansion included, as
    /// `what`): an output declared already that is one of them is an error, before anything
    /// is written.
    pub fn inputs_read<'a>(
        &mut self,
        what: &'static str,
        files: impl IntoIterator<Item = &'a Path>,
    ) -> Result<()> {
        for f in files {
            self.inputs.push((what, f.to_path_buf(), resolve(f)));
        }
        for t in &self.targets {
            for (shown, f) in Self::files_of(t) {
                self.check_not_input(t.flag, &shown, &f)?;
            }
        }
        Ok(())
    }

    /// Adds and checks a file output given by `flag` (nothing when `path` is `None`).
    pub fn file(&mut self, flag: &'static str, path: Option<&Path>) -> Result<()> {
        let Some(path) = path else { return Ok(()) };
        if path.is_dir() {
            bail!("{flag} {}: is a directory", path.display());
        }
        let resolved = resolve(path);
        // Opening a FIFO here would consume its reader; it is opened once, at the commit.
        let special = std::fs::metadata(path).is_ok_and(|m| !m.is_file());
        if !special {
            let parent = resolved.parent().unwrap_or(Path::new("/"));
            check_writable(flag, path, parent)?;
        }
        self.add(Target {
            flag,
            path: path.to_path_buf(),
            resolved,
            kind: if special { Kind::Special } else { Kind::File },
        })
    }

    /// Adds and checks a directory output given by `flag` that may write files named `names`
    /// (any names when empty: they are then checked as they are staged).
    pub fn dir(
        &mut self,
        flag: &'static str,
        path: Option<&Path>,
        names: Vec<String>,
    ) -> Result<()> {
        let Some(path) = path else { return Ok(()) };
        if path.exists() && !path.is_dir() {
            bail!("{flag} {}: exists and is not a directory", path.display());
        }
        let resolved = resolve(path);
        check_writable(flag, path, &resolved)?;
        self.add(Target {
            flag,
            path: path.to_path_buf(),
            resolved,
            kind: Kind::Dir(names),
        })
    }

    /// The files `t` may write: as given and resolved.
    fn files_of(t: &Target) -> Vec<(PathBuf, PathBuf)> {
        match &t.kind {
            Kind::File | Kind::Special => vec![(t.path.clone(), t.resolved.clone())],
            Kind::Dir(names) => names
                .iter()
                .map(|n| (t.path.join(n), t.resolved.join(n)))
                .collect(),
        }
    }

    fn add(&mut self, t: Target) -> Result<()> {
        let mine = Self::files_of(&t);
        for o in &self.targets {
            let same_path = o.resolved == t.resolved
                && !(matches!(o.kind, Kind::Dir(_)) && matches!(t.kind, Kind::Dir(_)));
            let theirs = Self::files_of(o);
            if same_path || theirs.iter().any(|(_, f)| mine.iter().any(|(_, m)| m == f)) {
                bail!(
                    "{} {} and {} {} would write the same file: give different paths",
                    o.flag,
                    o.path.display(),
                    t.flag,
                    t.path.display()
                );
            }
        }
        for (shown, f) in &mine {
            self.check_not_input(t.flag, shown, f)?;
        }
        self.targets.push(t);
        Ok(())
    }

    fn check_not_input(&self, flag: &str, shown: &Path, file: &Path) -> Result<()> {
        match self.inputs.iter().find(|(_, _, r)| r == file) {
            Some((in_flag, in_path, _)) => bail!(
                "{flag}: {} is also an input ({in_flag} {}): refusing to overwrite it",
                shown.display(),
                in_path.display()
            ),
            None => Ok(()),
        }
    }

    fn target(&self, flag: &str) -> Result<&Target> {
        self.targets
            .iter()
            .find(|t| t.flag == flag)
            .ok_or_else(|| anyhow!("internal: output {flag} was not declared"))
    }

    /// Whether an output was given for `flag`.
    pub fn has(&self, flag: &str) -> bool {
        self.targets.iter().any(|t| t.flag == flag)
    }

    /// Whether `path` is staged already: `Ok(true)` with the same contents (it is written
    /// once), an error naming both outputs with other contents.
    fn staged_already(&self, flag: &str, path: &Path, contents: &str) -> Result<bool> {
        match self.staged.iter().find(|(_, p, _)| p == path) {
            Some((_, _, c)) if c == contents => Ok(true),
            Some((other, _, _)) => bail!(
                "{flag} and {other} would both write {}: give different paths",
                path.display()
            ),
            None => Ok(false),
        }
    }

    /// Stages the contents of the file output `flag` (nothing when it was not given).
    pub fn stage_file(&mut self, flag: &'static str, contents: String) -> Result<()> {
        if !self.has(flag) {
            return Ok(());
        }
        let t = self.target(flag)?;
        let special = matches!(t.kind, Kind::Special);
        let path = t.resolved.clone();
        if self.staged_already(flag, &path, &contents)? {
            return Ok(());
        }
        self.staged.push((flag, path, contents));
        if special {
            self.special.push(self.staged.len() - 1);
        }
        Ok(())
    }

    /// Stages the files of the directory output `flag` (nothing when it was not given).
    pub fn stage_dir(&mut self, flag: &'static str, files: Vec<(String, String)>) -> Result<()> {
        if !self.has(flag) {
            return Ok(());
        }
        let t = self.target(flag)?.clone();
        for (name, contents) in files {
            if Path::new(&name).components().count() != 1 {
                bail!("internal: output file name {name} is not a plain name");
            }
            if let Kind::Dir(names) = &t.kind {
                if !names.is_empty() && !names.contains(&name) {
                    bail!("internal: {flag} writes {name}, which it did not declare");
                }
            }
            let path = t.resolved.join(&name);
            self.check_not_input(t.flag, &t.path.join(&name), &path)?;
            if self.staged_already(flag, &path, &contents)? {
                continue;
            }
            self.staged.push((flag, path, contents));
        }
        Ok(())
    }

    /// Writes `text` to the file output `flag` when it was given (with every other staged file),
    /// else prints it on stdout.
    pub fn write_or_print(mut self, flag: &'static str, text: String) -> Result<()> {
        if self.has(flag) {
            self.stage_file(flag, text)?;
            self.commit()?;
        } else {
            crate::cmd::stdout::print(&text)?;
        }
        Ok(())
    }

    /// Writes every staged file through a temporary file, then renames them all; on error
    /// removes what it wrote. Returns the files written.
    pub fn commit(self) -> Result<Vec<PathBuf>> {
        let result = Self::write_all(&self.staged, &self.special);
        pending().clean();
        result
    }

    fn write_all(
        staged: &[(&'static str, PathBuf, String)],
        special: &[usize],
    ) -> Result<Vec<PathBuf>> {
        pending().committed = false;
        let mut temps = Vec::new();
        for (i, (flag, path, contents)) in staged.iter().enumerate() {
            if special.contains(&i) {
                continue;
            }
            let dir = path.parent().unwrap_or(Path::new("/"));
            create_dirs(flag, dir)?;
            let name = path
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default();
            let tmp = dir.join(format!(".{name}.tmp{}", std::process::id()));
            {
                // Registered and written under the lock, so that a signal's cleanup never runs
                // while the file is being created (it would remove it before it exists, and the
                // write would then leave it behind).
                let mut p = pending();
                p.files.push(tmp.clone());
                std::fs::write(&tmp, contents)
                    .map_err(|e| anyhow!("{flag}: cannot write {}: {e}", path.display()))?;
            }
            temps.push((flag, tmp, path.clone()));
        }
        {
            // Held through the renames: a signal now waits for them to finish, so the reports
            // are all in place before the process exits.
            let mut p = pending();
            for (flag, tmp, path) in &temps {
                std::fs::rename(tmp, path)
                    .map_err(|e| anyhow!("{flag}: cannot write {}: {e}", path.display()))?;
            }
            p.files.clear();
            p.dirs.clear();
            p.committed = special.is_empty();
        }
        let mut written: Vec<PathBuf> = temps.into_iter().map(|(_, _, p)| p).collect();
        for &i in special {
            let (flag, path, contents) = &staged[i];
            std::fs::write(path, contents)
                .map_err(|e| anyhow!("{flag}: cannot write {}: {e}", path.display()))?;
            written.push(path.clone());
        }
        pending().committed = true;
        Ok(written)
    }
}

/// Creates `dir` and its missing parents, recording each one created for the cleanup.
fn create_dirs(flag: &str, dir: &Path) -> Result<()> {
    let mut missing = Vec::new();
    let mut d = dir;
    while !d.exists() {
        missing.push(d.to_path_buf());
        match d.parent() {
            Some(p) => d = p,
            None => break,
        }
    }
    for m in missing.into_iter().rev() {
        // Created and registered under the lock: no window in which a signal's cleanup could
        // miss it.
        let mut p = pending();
        std::fs::create_dir(&m)
            .map_err(|e| anyhow!("{flag}: cannot create {}: {e}", m.display()))?;
        p.dirs.push(m);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmp(name: &str) -> PathBuf {
        let d =
            std::env::temp_dir().join(format!("gpu-amcs-outputs-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    fn names(v: &[&str]) -> Vec<String> {
        v.iter().map(|s| s.to_string()).collect()
    }

    const CSV_NAMES: &[&str] = &["cdf.csv", "pdf.csv"];
    const SVG_NAMES: &[&str] = &["pdf.svg"];

    #[test]
    fn same_file_twice_and_inputs_are_refused() {
        let d = tmp("same");
        let input = d.join("p").join("cdf.csv");
        std::fs::create_dir_all(input.parent().unwrap()).unwrap();
        std::fs::write(&input, "q1\n").unwrap();
        let mut o = Outputs::new([("--points-file", input.as_path())]);
        let e = o
            .dir("--csv", Some(&d.join("p")), names(CSV_NAMES))
            .unwrap_err();
        assert!(e.to_string().contains("--points-file"), "{e}");
        let mut o = Outputs::new([]);
        o.file("--json", Some(&d.join("x"))).unwrap();
        let e = o
            .dir("--csv", Some(&d.join("./x")), names(CSV_NAMES))
            .unwrap_err();
        assert!(e.to_string().contains("same file"), "{e}");
        o.dir("--svg", Some(&d.join("s")), names(SVG_NAMES))
            .unwrap();
        o.dir("--csv", Some(&d.join("s")), names(CSV_NAMES))
            .unwrap();
    }

    #[test]
    fn a_file_staged_twice_is_written_once_unless_it_differs() {
        let d = tmp("twice");
        let mut o = Outputs::new([]);
        o.dir("--out", Some(&d.join("s")), Vec::new()).unwrap();
        o.dir(
            "--html",
            Some(&d.join("s")),
            names(&["a.csv", "index.html"]),
        )
        .unwrap();
        o.stage_dir("--out", vec![("a.csv".into(), "x".into())])
            .unwrap();
        let page = vec![
            ("a.csv".into(), "x".into()),
            ("index.html".into(), "p".into()),
        ];
        o.stage_dir("--html", page).unwrap();
        // A name the directory did not declare is a bug of the caller.
        let e = o
            .stage_dir("--html", vec![("b.csv".into(), "y".into())])
            .unwrap_err();
        assert!(e.to_string().contains("did not declare"), "{e}");
        assert_eq!(o.commit().unwrap().len(), 2);
        let mut o = Outputs::new([]);
        o.dir("--out", Some(&d.join("t")), Vec::new()).unwrap();
        o.dir("--html", Some(&d.join("t")), Vec::new()).unwrap();
        o.stage_dir("--out", vec![("a.csv".into(), "x".into())])
            .unwrap();
        let e = o
            .stage_dir("--html", vec![("a.csv".into(), "other".into())])
            .unwrap_err();
        assert!(e.to_string().contains("would both write"), "{e}");
    }

    #[test]
    fn commit_writes_all_and_a_failure_leaves_nothing() {
        let d = tmp("commit");
        let mut o = Outputs::new([]);
        o.file("--json", Some(&d.join("a.json"))).unwrap();
        o.dir("--csv", Some(&d.join("new/csv")), names(CSV_NAMES))
            .unwrap();
        o.stage_file("--json", "{}".into()).unwrap();
        o.stage_dir("--csv", vec![("cdf.csv".into(), "x".into())])
            .unwrap();
        let written = o.commit().unwrap();
        assert_eq!(written.len(), 2);
        assert_eq!(
            std::fs::read_to_string(d.join("new/csv/cdf.csv")).unwrap(),
            "x"
        );

        // The second file's directory is taken by a file after the check: nothing is left.
        let mut o = Outputs::new([]);
        o.file("--json", Some(&d.join("b.json"))).unwrap();
        o.dir("--csv", Some(&d.join("late/csv")), names(CSV_NAMES))
            .unwrap();
        std::fs::write(d.join("late"), "in the way").unwrap();
        o.stage_file("--json", "{}".into()).unwrap();
        o.stage_dir("--csv", vec![("cdf.csv".into(), "x".into())])
            .unwrap();
        assert!(o.commit().is_err());
        let left: Vec<_> = std::fs::read_dir(&d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        assert!(
            !left.iter().any(|n| n.starts_with(".") || n == "b.json"),
            "{left:?}"
        );
    }
}
