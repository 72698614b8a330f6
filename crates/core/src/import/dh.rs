//! DH table reader: standard (distal) and Craig's modified (proximal) Denavit–Hartenberg tables.
//!
//! One row per joint (4 to 7 for the model, [`MIN_JOINTS`] to [`MAX_JOINTS`]: six for a six-axis
//! arm, seven for a seven-axis one; more with joints held at a fixed angle on import,
//! [`super::JointHold`]), each `theta, d, a, alpha, lower, upper` (θ the joint-angle offset at
//! q = 0, lower/upper the joint limits). The file states its convention and units:
//!
//! * `convention`: `standard` — `T_i = Rz(θ_i + q_i)·Tz(d_i)·Tx(a_i)·Rx(α_i)`; or `modified`
//!   (Craig) — `T_i = Rx(α_{i−1})·Tx(a_{i−1})·Rz(θ_i + q_i)·Tz(d_i)`, where row i holds
//!   `α_{i−1}` and `a_{i−1}` (Craig's table layout).
//! * `units`: `mm-deg` (lengths in mm, angles and limits in degrees) or `m-rad`.
//! * optional `name`, and optional `tool` (x, y, z in the last frame, the table's length unit;
//!   default the frame's origin).
//!
//! CSV form (lines starting with `#` are comments):
//! ```text
//! convention,standard
//! units,m-rad
//! name,UR5e
//! theta,d,a,alpha,lower,upper
//! 0,0.1625,0,1.5707963267948966,-6.283185307179586,6.283185307179586
//! ...
//! ```
//! TOML form: top-level `convention`, `units`, optional `name` and `tool`, and one `[[joint]]`
//! table per joint with `theta`, `d`, `a`, `alpha`, `limits = [lower, upper]`.

use super::{ImportError, SourceChain, SourceFormat, SourceJoint, MAX_SOURCE_JOINTS};
use crate::kinematics::{MAX_JOINTS, MIN_JOINTS};
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use serde::Deserialize;

/// Convention of a DH table.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Convention {
    /// Standard (distal) DH.
    Standard,
    /// Craig's modified (proximal) DH.
    Modified,
}

/// One row: `[θ, d, a, α]` in mm and radians, limits in degrees.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DhRow {
    /// `[θ, d, a, α]`, mm and radians (for `Modified`, `a` and `α` are `a_{i−1}`, `α_{i−1}`).
    pub params: [f64; 4],
    /// Joint limits, degrees.
    pub limits_deg: (f64, f64),
}

/// A DH table in internal units.
#[derive(Clone, Debug, PartialEq)]
pub struct DhTable {
    /// Model name.
    pub name: String,
    /// Convention.
    pub convention: Convention,
    /// The rows, base to tip.
    pub rows: Vec<DhRow>,
    /// Tool point in the last frame, mm.
    pub tool: [f64; 3],
}

fn rz(t: f64) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::identity(),
        UnitQuaternion::from_axis_angle(&Vector3::z_axis(), t),
    )
}

fn rx(t: f64) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::identity(),
        UnitQuaternion::from_axis_angle(&Vector3::x_axis(), t),
    )
}

fn tr(x: f64, y: f64, z: f64) -> Isometry3<f64> {
    Isometry3::translation(x, y, z)
}

impl DhTable {
    /// The table as a source chain: each row's transform split at its joint rotation.
    pub fn to_chain(&self) -> SourceChain {
        // Standard: T_i = Rz(q_i)·B_i with B_i = Rz(θ)Tz(d)Tx(a)Rx(α): joint i's origin is
        // B_{i−1}. Modified: T_i = A_i·Rz(q_i)·C_i with A_i = Rx(α)Tx(a)Rz(θ), C_i = Tz(d):
        // joint i's origin is C_{i−1}·A_i.
        let mut joints = Vec::with_capacity(self.rows.len());
        let mut carry = Isometry3::identity();
        for (i, r) in self.rows.iter().enumerate() {
            let [theta, d, a, alpha] = r.params;
            let (origin, after) = match self.convention {
                Convention::Standard => (
                    carry,
                    rz(theta) * tr(0.0, 0.0, d) * tr(a, 0.0, 0.0) * rx(alpha),
                ),
                Convention::Modified => (
                    carry * rx(alpha) * tr(a, 0.0, 0.0) * rz(theta),
                    tr(0.0, 0.0, d),
                ),
            };
            joints.push(SourceJoint {
                name: format!("joint {}", i + 1),
                origin,
                axis: Vector3::z_axis(),
                limits_deg: r.limits_deg,
            });
            carry = after;
        }
        SourceChain {
            name: self.name.clone(),
            format: match self.convention {
                Convention::Standard => SourceFormat::StandardDh,
                Convention::Modified => SourceFormat::ModifiedDh,
            },
            joints,
            tip: carry * tr(self.tool[0], self.tool[1], self.tool[2]),
            what: "the table".into(),
            notes: Vec::new(),
            held: Vec::new(),
            arm_frame: None,
            bodies: None,
        }
    }
}

/// Units declared by a table: (length factor to mm, angle factor to radians, limit factor to
/// degrees).
fn units(s: &str) -> Option<(f64, f64, f64)> {
    match s.trim() {
        "mm-deg" => Some((1.0, std::f64::consts::PI / 180.0, 1.0)),
        "m-rad" => Some((1000.0, 1.0, 180.0 / std::f64::consts::PI)),
        _ => None,
    }
}

fn convention(s: &str) -> Option<Convention> {
    match s.trim() {
        "standard" => Some(Convention::Standard),
        "modified" | "craig" => Some(Convention::Modified),
        _ => None,
    }
}

const UNITS_HELP: &str = "must be 'mm-deg' or 'm-rad'";
const CONVENTION_HELP: &str = "must be 'standard' or 'modified' (Craig)";

/// Builds one row from raw file values `[θ, d, a, α, lower, upper]`; `field` names the row.
fn row(
    raw: [f64; 6],
    (len, ang, lim): (f64, f64, f64),
    bad: &dyn Fn(String, String) -> ImportError,
    joint: usize,
) -> Result<DhRow, ImportError> {
    const NAMES: [&str; 6] = ["theta", "d", "a", "alpha", "lower", "upper"];
    for (k, v) in raw.iter().enumerate() {
        if !v.is_finite() {
            return Err(bad(
                format!("joint[{joint}].{}", NAMES[k]),
                format!("must be finite, got {v}"),
            ));
        }
    }
    let (lo, hi) = (raw[4] * lim, raw[5] * lim);
    if lo >= hi {
        return Err(bad(
            format!("joint[{joint}].limits"),
            format!("lower {} must be below upper {}", raw[4], raw[5]),
        ));
    }
    Ok(DhRow {
        params: [raw[0] * ang, raw[1] * len, raw[2] * len, raw[3] * ang],
        limits_deg: (lo, hi),
    })
}

/// Parses the CSV form (see the module docs) and returns its chain.
///
/// # Errors
///
/// [`ImportError::Syntax`] for a line that is not the CSV form (naming it),
/// [`ImportError::Element`] for a missing or unknown convention or unit, or a value that is not a
/// finite number or out of range, and [`ImportError::Chain`] when the table has no rows or more
/// than [`MAX_SOURCE_JOINTS`] (the count of the model, 4 to 7 after any joints held, is checked
/// by [`super::convert`]).
pub fn parse_csv(text: &str, path: &str, default_name: &str) -> Result<SourceChain, ImportError> {
    let mut conv = None;
    let mut unit = None;
    let mut name = default_name.to_string();
    let mut tool_raw = [0.0; 3];
    let mut header_seen = false;
    let mut seen_directives: Vec<String> = Vec::new();
    let mut raws: Vec<([f64; 6], usize)> = Vec::new();
    let syntax = |line: usize, message: String| ImportError::Syntax {
        path: path.into(),
        line,
        message,
    };
    for (k, l) in text.lines().enumerate() {
        let line = k + 1;
        let l = l.trim();
        if l.is_empty() || l.starts_with('#') {
            continue;
        }
        let cells: Vec<&str> = l.split(',').map(str::trim).collect();
        let key = cells[0].to_ascii_lowercase();
        match key.as_str() {
            "convention" | "units" | "name" if cells.len() != 2 => {
                return Err(syntax(line, format!("'{key}' takes one value")))
            }
            "convention" | "units" | "name" | "tool" if seen_directives.contains(&key) => {
                return Err(syntax(
                    line,
                    format!("'{key}' is given twice (a table states its {key} once)"),
                ))
            }
            "convention" => {
                seen_directives.push(key.clone());
                conv = Some(convention(cells[1]).ok_or_else(|| {
                    syntax(line, format!("convention '{}' {CONVENTION_HELP}", cells[1]))
                })?)
            }
            "units" => {
                seen_directives.push(key.clone());
                unit =
                    Some(units(cells[1]).ok_or_else(|| {
                        syntax(line, format!("units '{}' {UNITS_HELP}", cells[1]))
                    })?)
            }
            "name" => {
                seen_directives.push(key.clone());
                name = cells[1].to_string()
            }
            "tool" => {
                seen_directives.push(key.clone());
                if cells.len() != 4 {
                    return Err(syntax(line, "'tool' takes three values x, y, z".into()));
                }
                for c in 0..3 {
                    tool_raw[c] = cells[c + 1].parse().map_err(|_| {
                        syntax(
                            line,
                            format!("tool value '{}' is not a number", cells[c + 1]),
                        )
                    })?;
                }
            }
            "theta" => {
                let want = ["theta", "d", "a", "alpha", "lower", "upper"];
                let got: Vec<String> = cells.iter().map(|c| c.to_ascii_lowercase()).collect();
                if got != want {
                    return Err(syntax(line, format!("header must be '{}'", want.join(","))));
                }
                header_seen = true;
            }
            _ => {
                if !header_seen {
                    return Err(syntax(
                        line,
                        "expected 'convention', 'units', 'name', 'tool' or the header 'theta,d,a,alpha,lower,upper' before the rows".into(),
                    ));
                }
                if cells.len() != 6 {
                    return Err(syntax(
                        line,
                        format!("a row needs 6 values, found {}", cells.len()),
                    ));
                }
                let mut raw = [0.0; 6];
                for c in 0..6 {
                    raw[c] = cells[c]
                        .parse()
                        .map_err(|_| syntax(line, format!("'{}' is not a number", cells[c])))?;
                }
                raws.push((raw, line));
            }
        }
    }
    let conv =
        conv.ok_or_else(|| syntax(1, format!("missing 'convention' line ({CONVENTION_HELP})")))?;
    let unit = unit.ok_or_else(|| syntax(1, format!("missing 'units' line ({UNITS_HELP})")))?;
    if raws.is_empty() || raws.len() > MAX_SOURCE_JOINTS {
        return Err(ImportError::Chain {
            path: path.into(),
            message: format!(
                "expected {MIN_JOINTS} to {MAX_JOINTS} rows (up to {MAX_SOURCE_JOINTS} with joints held), found {}",
                raws.len()
            ),
        });
    }
    let mut rows = Vec::with_capacity(raws.len());
    for (j, (raw, line)) in raws.iter().enumerate() {
        let bad = |element: String, message: String| ImportError::Element {
            path: path.into(),
            line: *line,
            element,
            message,
        };
        rows.push(row(*raw, unit, &bad, j + 1)?);
    }
    finish(name, conv, rows, tool_raw, unit, path)
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct TomlJoint {
    theta: f64,
    d: f64,
    a: f64,
    alpha: f64,
    limits: Vec<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct TomlTable {
    convention: String,
    units: String,
    name: Option<String>,
    tool: Option<Vec<f64>>,
    joint: Vec<TomlJoint>,
}

/// Parses the TOML form (see the module docs) and returns its chain.
///
/// # Errors
///
/// [`ImportError::Syntax`] for malformed TOML or unknown keys (naming the line),
/// [`ImportError::Element`] for an unknown convention or unit or a value that is not a finite
/// number or out of range, and [`ImportError::Element`] when the table has no joints or more
/// than [`MAX_SOURCE_JOINTS`] (the count of the model, 4 to 7 after any joints held, is checked
/// by [`super::convert`]).
pub fn parse_toml(text: &str, path: &str, default_name: &str) -> Result<SourceChain, ImportError> {
    let t: TomlTable = toml::from_str(text).map_err(|e| {
        let line = e.span().map_or(1, |s| {
            text[..s.start.min(text.len())].lines().count().max(1)
        });
        ImportError::Syntax {
            path: path.into(),
            line,
            message: e.message().trim().replace('\n', " "),
        }
    })?;
    let bad = |element: String, message: String| ImportError::Element {
        path: path.into(),
        line: 0,
        element,
        message,
    };
    let conv = convention(&t.convention).ok_or_else(|| {
        bad(
            "convention".into(),
            format!("'{}' {CONVENTION_HELP}", t.convention),
        )
    })?;
    let unit = units(&t.units)
        .ok_or_else(|| bad("units".into(), format!("'{}' {UNITS_HELP}", t.units)))?;
    if t.joint.is_empty() || t.joint.len() > MAX_SOURCE_JOINTS {
        return Err(bad(
            "joint".into(),
            format!(
                "expected {MIN_JOINTS} to {MAX_JOINTS} [[joint]] tables (up to {MAX_SOURCE_JOINTS} with joints held), found {}",
                t.joint.len()
            ),
        ));
    }
    let mut rows = Vec::with_capacity(t.joint.len());
    for (j, jt) in t.joint.iter().enumerate() {
        let [lo, hi] = jt.limits[..] else {
            return Err(bad(
                format!("joint[{}].limits", j + 1),
                format!(
                    "needs exactly 2 values [lower, upper], got {}",
                    jt.limits.len()
                ),
            ));
        };
        let raw = [jt.theta, jt.d, jt.a, jt.alpha, lo, hi];
        rows.push(row(raw, unit, &bad, j + 1)?);
    }
    finish(
        t.name.unwrap_or_else(|| default_name.to_string()),
        conv,
        rows,
        match t.tool.as_deref() {
            None => [0.0; 3],
            Some(&[x, y, z]) => [x, y, z],
            Some(v) => {
                return Err(bad(
                    "tool".into(),
                    format!("needs exactly 3 values [x, y, z], got {}", v.len()),
                ))
            }
        },
        unit,
        path,
    )
}

fn finish(
    name: String,
    convention: Convention,
    rows: Vec<DhRow>,
    tool_raw: [f64; 3],
    (len, _, _): (f64, f64, f64),
    path: &str,
) -> Result<SourceChain, ImportError> {
    if let Some(k) = tool_raw.iter().position(|v| !v.is_finite()) {
        return Err(ImportError::Element {
            path: path.into(),
            line: 0,
            element: format!("tool[{k}]"),
            message: format!("must be finite, got {}", tool_raw[k]),
        });
    }
    let table = DhTable {
        name,
        convention,
        rows,
        tool: tool_raw.map(|v| v * len),
    };
    Ok(table.to_chain())
}
