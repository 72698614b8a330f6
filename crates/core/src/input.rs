//! Reading input files with a size bound: a model file is kilobytes and a CSV at most some
//! megabytes, so a wrong path (`/dev/zero`, a disk image) gives an error naming the file and the
//! limit instead of filling the memory.
//!
//! Text must be UTF-8 (a leading byte-order mark, as spreadsheet programs write, is dropped); an
//! invalid byte is reported with its line. CSV text has its `\r\n` (and lone `\r`) line ends
//! turned into `\n` before parsing, so the line numbers the CSV reader reports are those an
//! editor shows (the `csv` crate counts a CRLF file's lines one short).

use std::io::Read;
use std::path::Path;

/// Largest model file read: a six-joint model with a full 30 × 30 covariance is 15–30 KiB, a
/// seven-joint one with 35 × 35 about a third more.
pub const MODEL_FILE_LIMIT: u64 = 1 << 20;
/// Largest CSV file read (test points, sweeps, measurements): about two million rows of six or
/// seven angles, far more than any analysis uses.
pub const CSV_FILE_LIMIT: u64 = 128 << 20;
/// Largest robot description read by the importer (URDF, DH table, UR calibration): a URDF with
/// inertials and visual elements is tens of kilobytes.
pub const DESCRIPTION_FILE_LIMIT: u64 = 16 << 20;

/// Errors reading an input file.
#[derive(Debug, thiserror::Error)]
pub enum ReadError {
    /// The file could not be opened or read (the OS error is the source).
    #[error("cannot read {what} {path}")]
    Io {
        /// What the file is, e.g. "model file".
        what: &'static str,
        /// The path given.
        path: String,
        /// The OS error.
        source: std::io::Error,
    },
    /// The file is larger than the limit for its kind.
    #[error("{what} {path} is larger than {}, the limit for a {what}", human_bytes(*.limit))]
    TooLarge {
        /// What the file is.
        what: &'static str,
        /// The path given.
        path: String,
        /// The limit, bytes.
        limit: u64,
    },
    /// The file is not UTF-8 text.
    #[error("{what} {path}: line {line} is not valid UTF-8 text")]
    NotUtf8 {
        /// What the file is.
        what: &'static str,
        /// The path given.
        path: String,
        /// 1-based line of the first invalid byte.
        line: usize,
    },
}

/// `n` bytes in KiB/MiB/GiB when it is a whole number of them.
fn human_bytes(n: u64) -> String {
    for (unit, size) in [("GiB", 1u64 << 30), ("MiB", 1 << 20), ("KiB", 1 << 10)] {
        if n >= size && n.is_multiple_of(size) {
            return format!("{} {unit}", n / size);
        }
    }
    format!("{n} bytes")
}

/// Reads `path` as UTF-8 text of at most `limit` bytes; `what` names the kind of file in errors
/// ("model file").
///
/// # Errors
///
/// [`ReadError::Io`] when the file cannot be opened or read, [`ReadError::TooLarge`] when it has
/// more than `limit` bytes, and [`ReadError::NotUtf8`] (naming the line) when it is not UTF-8.
pub fn read_text(path: &Path, limit: u64, what: &'static str) -> Result<String, ReadError> {
    read_text_and_bytes(path, limit, what, false).map(|(text, _)| text)
}

/// [`read_text`], and with `keep` the bytes as read (empty without): one read, so that a pipe
/// or FIFO, which can be read only once, gives its checksum too.
fn read_text_and_bytes(
    path: &Path,
    limit: u64,
    what: &'static str,
    keep: bool,
) -> Result<(String, Vec<u8>), ReadError> {
    let p = path.display().to_string();
    let io = |source| ReadError::Io {
        what,
        path: p.clone(),
        source,
    };
    let file = std::fs::File::open(path).map_err(io)?;
    let mut buf = Vec::new();
    // One byte past the limit tells a file of exactly `limit` bytes from a longer one.
    file.take(limit.saturating_add(1))
        .read_to_end(&mut buf)
        .map_err(io)?;
    if buf.len() as u64 > limit {
        return Err(ReadError::TooLarge {
            what,
            path: p,
            limit,
        });
    }
    let raw = if keep { buf.clone() } else { Vec::new() };
    if buf.starts_with(b"\xef\xbb\xbf") {
        buf.drain(..3);
    }
    let text = String::from_utf8(buf).map_err(|e| {
        let valid = &e.as_bytes()[..e.utf8_error().valid_up_to()];
        ReadError::NotUtf8 {
            what,
            path: p.clone(),
            line: 1 + valid.iter().filter(|&&b| b == b'\n').count(),
        }
    })?;
    Ok((text, raw))
}

/// Reads a CSV file (at most [`CSV_FILE_LIMIT`]) with `\r\n` and lone `\r` line ends made `\n`.
///
/// # Errors
///
/// As [`read_text`]: the file cannot be read, is larger than [`CSV_FILE_LIMIT`] or is not UTF-8.
pub fn read_csv_text(path: &Path) -> Result<String, ReadError> {
    read_csv_text_and_bytes(path, false).map(|(text, _)| text)
}

/// [`read_csv_text`], and with `keep` the file's bytes as read (for their checksum; empty
/// without).
///
/// # Errors
///
/// As [`read_csv_text`].
pub fn read_csv_text_and_bytes(path: &Path, keep: bool) -> Result<(String, Vec<u8>), ReadError> {
    let (text, raw) = read_text_and_bytes(path, CSV_FILE_LIMIT, "CSV file", keep)?;
    let text = if text.contains('\r') {
        text.replace("\r\n", "\n").replace('\r', "\n")
    } else {
        text
    };
    Ok((text, raw))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp(name: &str, bytes: &[u8]) -> std::path::PathBuf {
        let p = std::env::temp_dir().join(format!("gpu-amcs-input-{}-{name}", std::process::id()));
        std::fs::write(&p, bytes).unwrap();
        p
    }

    #[test]
    fn limit_is_exact_and_named() {
        let p = temp("limit", b"abcd");
        assert_eq!(read_text(&p, 4, "model file").unwrap(), "abcd");
        let e = read_text(&p, 3, "model file").unwrap_err().to_string();
        assert!(
            e.contains("larger than 3 bytes, the limit for a model file"),
            "{e}"
        );
        assert_eq!(human_bytes(MODEL_FILE_LIMIT), "1 MiB");
        assert_eq!(human_bytes(CSV_FILE_LIMIT), "128 MiB");
        let _ = std::fs::remove_file(p);
    }

    #[test]
    fn invalid_utf8_names_the_line() {
        let p = temp("utf8", b"a\nb\n\xffc\n");
        let e = read_text(&p, 100, "CSV file").unwrap_err().to_string();
        assert!(e.ends_with("line 3 is not valid UTF-8 text"), "{e}");
        let _ = std::fs::remove_file(p);
    }

    #[test]
    fn crlf_and_cr_become_lf_and_a_bom_is_dropped() {
        let p = temp("crlf", b"\xef\xbb\xbfq1\r\n1\r\n2\r3\n");
        assert_eq!(read_csv_text(&p).unwrap(), "q1\n1\n2\n3\n");
        let _ = std::fs::remove_file(p);
    }
}
