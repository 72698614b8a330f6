//! Printing on stdout without panicking: `print!` panics when the write fails (a full disk
//! behind `> file`, `> /dev/full`), so every command prints through [`print`], which turns a
//! failed write into the one-line error `stdout: No space left on device` (exit code 2). A
//! closed pipe (`| head -1`) still ends the run quietly: `main` restores SIGPIPE's default, so
//! the write never returns.

use anyhow::{anyhow, Result};
use std::io::Write;

/// Writes `text` to stdout and flushes it.
///
/// # Errors
/// `stdout: CAUSE` when the write or the flush fails.
pub fn print(text: &str) -> Result<()> {
    let mut out = std::io::stdout().lock();
    out.write_all(text.as_bytes())
        .and_then(|()| out.flush())
        .map_err(|e| anyhow!("stdout: {}", cause(&e)))
}

/// Writes `line` and a newline to stdout (see [`print`]).
///
/// # Errors
/// As [`print`].
pub fn println(line: &str) -> Result<()> {
    print(&format!("{line}\n"))
}

/// The system's text of an I/O error without Rust's " (os error N)" suffix.
fn cause(e: &std::io::Error) -> String {
    let text = e.to_string();
    match text.rfind(" (os error ") {
        Some(i) if text.ends_with(')') => text[..i].to_string(),
        _ => text,
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_os_error_number_is_dropped() {
        let e = std::io::Error::from_raw_os_error(28);
        assert!(e.to_string().contains("(os error 28)"));
        assert!(!super::cause(&e).contains("os error"));
        assert!(!super::cause(&e).is_empty());
    }
}
