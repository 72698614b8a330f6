//! Importing a file: the reader its extension names, the xacro expansion before the URDF
//! reader, and the conversion and proof of the chain it reads.

use super::{convert, dh, ur, urdf, xacro, ImportError, Imported, JointHold};

/// Which reader a file needs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FileKind {
    /// `.urdf`, `.xml`.
    Urdf,
    /// `.xacro`: expanded ([`xacro::expand_file`]) to URDF.
    Xacro,
    /// `.csv`, `.toml`: a DH table (standard or modified, as the file states).
    DhTable,
    /// `.yaml`, `.yml`: a UR calibration file.
    UrCalibration,
}

/// Options of [`import_file`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ImportOptions {
    /// URDF: the base link (default: the root link).
    pub base: Option<String>,
    /// URDF: the tip link (default: the single leaf below the base, else tool0, flange or the
    /// deepest leaf of the longest revolute chain, with a note).
    pub tip: Option<String>,
    /// Model name (default: the file's robot name, else the file stem).
    pub name: Option<String>,
    /// xacro: package name → its directory, for `$(find NAME)` (before the search upwards
    /// from the including file).
    pub packages: std::collections::BTreeMap<String, std::path::PathBuf>,
    /// xacro: `$(arg NAME)` values that override the file's `<xacro:arg>` defaults.
    pub xacro_args: std::collections::BTreeMap<String, String>,
    /// Joints held at a fixed angle ([`SourceChain::hold`](super::SourceChain::hold)).
    pub held: Vec<JointHold>,
}

/// The reader for `path` by its extension.
///
/// # Errors
///
/// [`ImportError::Chain`] for an unknown extension.
pub fn kind_of(path: &std::path::Path) -> Result<FileKind, ImportError> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    match ext.as_str() {
        "urdf" | "xml" => Ok(FileKind::Urdf),
        "csv" | "toml" => Ok(FileKind::DhTable),
        "yaml" | "yml" => Ok(FileKind::UrCalibration),
        "xacro" => Ok(FileKind::Xacro),
        _ => Err(ImportError::Chain {
            path: path.display().to_string(),
            message: "unknown file type: expected .urdf/.xml (URDF), .xacro (xacro), .csv/.toml (DH table) or .yaml/.yml (UR calibration)".into(),
        }),
    }
}

/// Reads a robot description of any supported format (chosen by [`kind_of`]), converts and
/// proves it.
///
/// # Errors
///
/// The errors of [`kind_of`] for the file's type; [`ImportError::Read`] when the file cannot be
/// read, is too large or is not UTF-8; the reader's errors ([`urdf::parse`], [`dh::parse_csv`],
/// [`dh::parse_toml`], [`ur::parse`]) for its contents; and those of [`convert`].
pub fn import_file(path: &std::path::Path, opts: &ImportOptions) -> Result<Imported, ImportError> {
    let kind = kind_of(path)?;
    let p = path.display().to_string();
    if kind == FileKind::Xacro {
        let e = xacro::expand_file(path, &opts.packages, &opts.xacro_args)?;
        let mut chain = urdf::parse(&e.text, &p, opts.base.as_deref(), opts.tip.as_deref())
            .map_err(|err| relocate(err, &e))?;
        if let Some(n) = &opts.name {
            chain.name = n.clone();
        }
        chain.hold(&opts.held, &p)?;
        let mut imported = convert(&chain, &p)?;
        imported.files = e.files;
        return Ok(imported);
    }
    let text = crate::input::read_text(
        path,
        crate::input::DESCRIPTION_FILE_LIMIT,
        "robot description",
    )?;
    let stem = path
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("robot")
        .to_string();
    let mut chain = match kind {
        FileKind::Urdf => urdf::parse(&text, &p, opts.base.as_deref(), opts.tip.as_deref())?,
        FileKind::DhTable => {
            let is_toml = path
                .extension()
                .is_some_and(|e| e.eq_ignore_ascii_case("toml"));
            if is_toml {
                dh::parse_toml(&text, &p, &stem)?
            } else {
                dh::parse_csv(&text, &p, &stem)?
            }
        }
        FileKind::UrCalibration => ur::parse(&text, &p, &stem)?,
        FileKind::Xacro => unreachable!("expanded above"),
    };
    if let Some(n) = &opts.name {
        chain.name = n.clone();
    }
    chain.hold(&opts.held, &p)?;
    let mut imported = convert(&chain, &p)?;
    imported.files = std::fs::canonicalize(path).into_iter().collect();
    Ok(imported)
}

/// A URDF reader's error on expanded xacro text, naming the source file and line the offending
/// output line came from instead of the expansion's line.
fn relocate(err: ImportError, e: &xacro::Expanded) -> ImportError {
    let at = |line: usize| e.origins.get(line.wrapping_sub(1)).cloned();
    match err {
        ImportError::Element {
            path,
            line,
            element,
            message,
        } => {
            let (path, line) = at(line).unwrap_or((path, line));
            ImportError::Element {
                path,
                line,
                element,
                message,
            }
        }
        ImportError::Syntax {
            path,
            line,
            message,
        } => {
            let (path, line) = at(line).unwrap_or((path, line));
            ImportError::Syntax {
                path,
                line,
                message,
            }
        }
        ImportError::Xacro { path, line, what } => {
            let (path, line) = at(line).unwrap_or((path, line));
            ImportError::Xacro { path, line, what }
        }
        other => other,
    }
}
