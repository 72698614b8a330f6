//! The `gpu-amcs` binary: parse the command line, call the library, print errors.

/// `eprintln!` that never panics: std's panics when stderr cannot be written (`2>/dev/full`,
/// a closed pipe), which turned a usage error into a crash. Defined before the modules, it
/// shadows std's in all of them; a line that cannot be written is dropped (there is nowhere
/// left to say so), and the exit code still tells the outcome.
macro_rules! eprintln {
    () => {
        $crate::to_stderr(format_args!(""))
    };
    ($($arg:tt)*) => {
        $crate::to_stderr(format_args!($($arg)*))
    };
}

mod cli;
mod cmd;

/// Writes one line to stderr, ignoring a failed write (the `eprintln!` above).
fn to_stderr(args: std::fmt::Arguments) {
    use std::io::Write;
    let mut err = std::io::stderr().lock();
    let _ = err.write_fmt(args).and_then(|()| err.write_all(b"\n"));
}

use clap::Parser;

/// The error and its causes on one line, each cause once: a cause whose text the line already
/// holds (an error that embeds its source) is not repeated.
fn one_line(e: &anyhow::Error) -> String {
    let mut line = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        let text = text.split_whitespace().collect::<Vec<_>>().join(" ");
        if text.is_empty() || line.contains(&text) {
            continue;
        }
        if !line.is_empty() {
            line.push_str(": ");
        }
        line.push_str(&text);
    }
    line
}

/// A command-line parsing error on one line: clap's text without the blank lines and the
/// "For more information" hint.
fn usage_line(text: &str) -> String {
    text.lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with("For more information"))
        .collect::<Vec<_>>()
        .join(" ")
}

fn main() {
    // The Vulkan loader prints "XDG_RUNTIME_DIR is invalid or not set" when probing for adapters
    // on headless machines; no display is used, so point it at the temp directory. Done before
    // any thread starts.
    if std::env::var_os("XDG_RUNTIME_DIR").is_none() {
        std::env::set_var("XDG_RUNTIME_DIR", std::env::temp_dir());
    }
    let cli = match cli::Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) if !e.use_stderr() => e.exit(),
        Err(e) => {
            eprintln!("{}", usage_line(&e.to_string()));
            std::process::exit(2);
        }
    };
    // Like other command-line tools, end quietly when the reader of stdout goes away
    // (`gpu-amcs calibrate | head -1`). Other failed writes to stdout (a full disk) are a
    // one-line error (`cmd::stdout`). Reports are written (renamed into place) before anything
    // goes to stdout, so no temporary file is left.
    #[cfg(unix)]
    // SAFETY: restoring the default disposition of SIGPIPE before any thread starts.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    // Under an address-space limit (`ulimit -v`, as Slurm and containers set), glibc's
    // per-thread malloc arenas each reserve 64 MiB of address space when a thread first
    // allocates: the rayon workers and the progress thread would take it from the room the
    // default memory limit was measured in (before they start), and a run sized to that limit
    // could then fail to allocate. One arena keeps the address space what the limit saw.
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    if gpu_amcs::memory::address_space_limit().is_some() {
        // SAFETY: a malloc tuning call before any other thread starts.
        unsafe {
            libc::mallopt(libc::M_ARENA_MAX, 1);
        }
    }
    cmd::outputs::install_signal_cleanup();
    if let Err(e) = cli.run() {
        eprintln!("error: {}", one_line(&e));
        std::process::exit(2);
    }
}

#[cfg(test)]
mod tests {
    use super::one_line;
    use anyhow::Context;

    #[test]
    fn each_cause_printed_once() {
        let io = std::io::Error::from(std::io::ErrorKind::PermissionDenied);
        let inner = anyhow::Error::new(io).context("cannot write x: permission denied");
        let e = Err::<(), _>(inner).context("--json").unwrap_err();
        let line = one_line(&e);
        assert_eq!(line, "--json: cannot write x: permission denied");
        let e = anyhow::anyhow!("two\nlines");
        assert_eq!(one_line(&e), "two lines");
    }
}
