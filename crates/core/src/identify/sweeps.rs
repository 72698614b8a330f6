//! Sweep data (the tracker measurements of the circle-point method) and its CSV format.
//!
//! Header `joint,q1,…,qn,x,y,z` for an `n`-joint robot (`n` = 4 to 7;
//! `joint,q1,q2,q3,q4,q5,q6,x,y,z` for a six-axis arm), optionally with a `run` column (any
//! position, any label): `joint` is the joint (1–n) swept in that row, `q1..qn` the commanded joint
//! angles in degrees, `x,y,z` the measured target position in mm in the robot base frame. The
//! number of joints is the number of `q` columns; [`crate::identify::identify`] checks that it is
//! the nominal model's. The rows of one joint (within one run) form that joint's sweep; all other
//! joints stay at the sweep's home pose. Reading checks the syntax and that every number is finite,
//! naming the line; the structural checks (enough points, only the swept joint moving, every joint
//! present) are made by [`crate::identify::identify`] so that simulated data passes the same
//! checks. [`write_sweeps`] writes the same format, so real and simulated data go through one
//! reader.

use super::IdentifyError;
use crate::kinematics::{Joints, MAX_JOINTS, MIN_JOINTS};
use std::io::{Read, Write};
use std::path::Path;

/// The joint-angle columns, `q1` to `q7`; a file of an `n`-joint robot has the first `n`.
pub const Q_COLUMNS: [&str; MAX_JOINTS] = ["q1", "q2", "q3", "q4", "q5", "q6", "q7"];

/// The columns a sweep file of an `joints`-joint robot must have (besides the optional `run`):
/// `joint`, `q1` to `q{joints}`, `x`, `y`, `z`.
pub fn sweep_columns(joints: usize) -> Vec<&'static str> {
    let mut c = vec!["joint"];
    c.extend_from_slice(&Q_COLUMNS[..joints.min(MAX_JOINTS)]);
    c.extend_from_slice(&["x", "y", "z"]);
    c
}

/// The number of joints of a data file: the `q` columns of its header, `q1` up to the highest
/// present. All of `q1` to `q{n}` must be there, and `n` is [`MIN_JOINTS`] to [`MAX_JOINTS`];
/// `formats` lists the accepted headers for the error.
pub(crate) fn joint_count(
    header: &csv::StringRecord,
    origin: &str,
    formats: &str,
) -> Result<usize, IdentifyError> {
    let has = |name: &str| header.iter().any(|h| h.trim().eq_ignore_ascii_case(name));
    let n = (1..=MAX_JOINTS)
        .rev()
        .find(|&k| has(Q_COLUMNS[k - 1]))
        .unwrap_or(0);
    let beyond = format!("q{}", MAX_JOINTS + 1);
    if has(&beyond) {
        return Err(IdentifyError::JointCount(format!(
            "{origin}: the header has a column '{beyond}', but a model has at most {MAX_JOINTS} joints"
        )));
    }
    match (0..n.max(MIN_JOINTS)).find(|&k| !has(Q_COLUMNS[k])) {
        Some(k) => Err(IdentifyError::MissingColumn {
            origin: origin.to_string(),
            column: Q_COLUMNS[k],
            expected: formats.to_string(),
        }),
        None => Ok(n),
    }
}

/// One measured point of a sweep.
#[derive(Clone, Debug, PartialEq)]
pub struct SweepPoint {
    /// Commanded joint angles, degrees, one per joint.
    pub q_deg: Joints,
    /// Measured target position in the base frame, mm.
    pub position_mm: [f64; 3],
    /// Line number in the CSV file (for simulated data: the line it has when written).
    pub line: u64,
}

/// The sweep of one joint: its points in measurement order.
#[derive(Clone, Debug, PartialEq)]
pub struct Sweep {
    /// The swept joint, 1-based.
    pub joint: usize,
    /// The points.
    pub points: Vec<SweepPoint>,
}

/// All sweeps of one run (one calibration experiment), at most one per joint, in joint order.
#[derive(Clone, Debug, PartialEq)]
pub struct SweepRun {
    /// The run label from the `run` column; `None` when the file has no such column.
    pub run: Option<String>,
    /// The sweeps present, sorted by joint.
    pub sweeps: Vec<Sweep>,
}

impl SweepRun {
    /// The sweep of `joint` (1-based), if present.
    pub fn sweep(&self, joint: usize) -> Option<&Sweep> {
        self.sweeps.iter().find(|s| s.joint == joint)
    }

    /// " (run X)" or "", for messages.
    pub fn label(&self) -> String {
        run_label(self.run.as_deref())
    }
}

pub(crate) fn run_label(run: Option<&str>) -> String {
    match run {
        Some(r) => format!(" (run {r})"),
        None => String::new(),
    }
}

/// A sweep file: one or more runs, in order of first appearance.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SweepData {
    /// The runs.
    pub runs: Vec<SweepRun>,
}

/// Reads a sweep CSV file.
///
/// # Errors
///
/// [`IdentifyError::Io`] when `path` is a directory or cannot be read, [`IdentifyError::Read`] when
/// the file is too large or not UTF-8; otherwise as [`parse_sweeps`].
pub fn read_sweeps(path: &Path) -> Result<SweepData, IdentifyError> {
    let (text, origin) = open_input(path)?;
    parse_sweeps(text.as_bytes(), &origin)
}

/// Reads an input CSV file (bounded in size, line ends normalised so line numbers match an
/// editor's: [`crate::input::read_csv_text`]); a directory or an unreadable path is an error
/// naming it. Returns the text and the file's name for messages.
///
/// # Errors
///
/// An [`IdentifyError`] naming the file when it is a directory, cannot be read, is larger
/// than a CSV may be or is not UTF-8 text.
pub fn open_input(path: &Path) -> Result<(String, String), IdentifyError> {
    open_input_keeping(path, false).map(|(text, origin, _)| (text, origin))
}

/// [`open_input`], and with `keep` the file's bytes as read (one read: a pipe gives them once).
pub(crate) fn open_input_keeping(
    path: &Path,
    keep: bool,
) -> Result<(String, String, Vec<u8>), IdentifyError> {
    let origin = path.display().to_string();
    let io = |cause| IdentifyError::Io {
        path: origin.clone(),
        cause,
    };
    if path.is_dir() {
        return Err(io(std::io::Error::other("is a directory, not a CSV file")));
    }
    let (text, bytes) = crate::input::read_csv_text_and_bytes(path, keep)?;
    Ok((text, origin, bytes))
}

/// Finds the columns of `names` in a header; `origin` names the source in errors.
pub(crate) fn column_indices(
    header: &csv::StringRecord,
    names: &[&'static str],
    origin: &str,
) -> Result<Vec<usize>, IdentifyError> {
    names
        .iter()
        .map(|name| {
            header
                .iter()
                .position(|h| h.trim().eq_ignore_ascii_case(name))
                .ok_or_else(|| IdentifyError::MissingColumn {
                    origin: origin.to_string(),
                    column: name,
                    expected: names.join(","),
                })
        })
        .collect()
}

/// Parses a finite number from field `col` of a record, naming the line and column on failure;
/// `context` is appended to the message (e.g. which sweep the row belongs to).
pub(crate) fn parse_number(
    rec: &csv::StringRecord,
    idx: usize,
    col: &str,
    line: u64,
    origin: &str,
    context: &str,
) -> Result<f64, IdentifyError> {
    let text = rec.get(idx).unwrap_or("").trim();
    let v: f64 = text.parse().map_err(|_| IdentifyError::Csv {
        origin: origin.to_string(),
        line,
        message: format!("column {col}: '{text}' is not a number{context}"),
    })?;
    if !v.is_finite() {
        return Err(IdentifyError::Csv {
            origin: origin.to_string(),
            line,
            message: format!("column {col} = {text} is not a finite number{context}"),
        });
    }
    if v.abs() > MAX_CSV_MAGNITUDE {
        return Err(IdentifyError::Csv {
            origin: origin.to_string(),
            line,
            message: format!(
                "column {col} = {text} is beyond ±{} (10 km in mm, or that many degrees): not a \
                 measurement{context}",
                crate::number::fmt_plain(MAX_CSV_MAGNITUDE)
            ),
        });
    }
    Ok(v)
}

/// Largest magnitude a number of a measurement or sweep CSV may have (mm or degrees): far
/// beyond any robot cell, and small enough that squares and sums of positions stay finite.
pub const MAX_CSV_MAGNITUDE: f64 = 1e7;

pub(crate) fn csv_reader<R: Read>(reader: R) -> csv::Reader<R> {
    csv::ReaderBuilder::new()
        .has_headers(true)
        .flexible(false)
        .trim(csv::Trim::All)
        .comment(Some(b'#'))
        .from_reader(reader)
}

pub(crate) fn csv_error(e: csv::Error, origin: &str) -> IdentifyError {
    let line = e.position().map(|p| p.line()).unwrap_or(0);
    let message = match e.kind() {
        csv::ErrorKind::UnequalLengths {
            expected_len, len, ..
        } => {
            format!("has {len} fields, the header has {expected_len}")
        }
        _ => e.to_string(),
    };
    match e.into_kind() {
        // A read failure is about the file, not a line of it.
        csv::ErrorKind::Io(cause) => IdentifyError::Io {
            path: origin.to_string(),
            cause,
        },
        _ => IdentifyError::Csv {
            origin: origin.to_string(),
            line,
            message,
        },
    }
}

/// Parses sweep CSV text from a reader; `origin` names the source in errors.
///
/// # Errors
///
/// [`IdentifyError::Csv`] for a malformed row (wrong number of fields, a field that is not a finite
/// number, a joint outside 1–n), naming its line; [`IdentifyError::MissingColumn`] when the header
/// lacks a required column (fewer than four `q` columns, or a gap in them);
/// [`IdentifyError::Empty`] when there are no data rows.
pub fn parse_sweeps<R: Read>(reader: R, origin: &str) -> Result<SweepData, IdentifyError> {
    let mut rdr = csv_reader(reader);
    let header = rdr.headers().map_err(|e| csv_error(e, origin))?.clone();
    let n = joint_count(
        &header,
        origin,
        "joint,q1,…,qn,x,y,z (one q column per joint, 4 to 7)",
    )?;
    let columns = sweep_columns(n);
    let cols = column_indices(&header, &columns, origin)?;
    let run_col = header
        .iter()
        .position(|h| h.trim().eq_ignore_ascii_case("run"));
    let mut data = SweepData::default();
    let mut rows = 0usize;
    for rec in rdr.records() {
        let rec = rec.map_err(|e| csv_error(e, origin))?;
        let line = rec.position().map(|p| p.line()).unwrap_or(0);
        rows += 1;
        let jtext = rec.get(cols[0]).unwrap_or("").trim();
        let joint = match jtext.parse::<usize>() {
            Ok(j) if (1..=n).contains(&j) => j,
            _ => {
                return Err(IdentifyError::Csv {
                    origin: origin.to_string(),
                    line,
                    message: format!("column joint: '{jtext}' is not a joint number 1–{n}"),
                })
            }
        };
        let run = run_col.map(|c| rec.get(c).unwrap_or("").trim().to_string());
        let context = format!(" (joint {joint} sweep{})", run_label(run.as_deref()));
        let mut vals = [0.0; MAX_JOINTS + 3];
        let vals = &mut vals[..n + 3];
        for (k, v) in vals.iter_mut().enumerate() {
            *v = parse_number(&rec, cols[k + 1], columns[k + 1], line, origin, &context)?;
        }
        let point = SweepPoint {
            q_deg: Joints::from_slice(&vals[..n]),
            position_mm: [vals[n], vals[n + 1], vals[n + 2]],
            line,
        };
        let ri = match data.runs.iter().position(|r| r.run == run) {
            Some(i) => i,
            None => {
                data.runs.push(SweepRun {
                    run,
                    sweeps: Vec::new(),
                });
                data.runs.len() - 1
            }
        };
        let sweeps = &mut data.runs[ri].sweeps;
        match sweeps.iter_mut().find(|s| s.joint == joint) {
            Some(s) => s.points.push(point),
            None => sweeps.push(Sweep {
                joint,
                points: vec![point],
            }),
        }
    }
    if rows == 0 {
        return Err(IdentifyError::Empty {
            origin: origin.to_string(),
        });
    }
    for r in &mut data.runs {
        r.sweeps.sort_by_key(|s| s.joint);
    }
    Ok(data)
}

/// Writes sweep data in the format [`parse_sweeps`] reads; the `run` column is written when any
/// run has a label. The `q` columns are those of the first point's joints (six without points).
///
/// # Errors
///
/// [`IdentifyError::Io`] when writing to `writer` fails, or when the points do not all have the
/// same number of joint angles.
pub fn write_sweeps<W: Write>(data: &SweepData, writer: W) -> Result<(), IdentifyError> {
    let io = |e: csv::Error| IdentifyError::Io {
        path: "<sweep output>".into(),
        cause: std::io::Error::other(e.to_string()),
    };
    let with_run = data.runs.iter().any(|r| r.run.is_some());
    let mut points = data
        .runs
        .iter()
        .flat_map(|r| &r.sweeps)
        .flat_map(|s| &s.points);
    let n = points.clone().next().map_or(6, |p| p.q_deg.len());
    if points.any(|p| p.q_deg.len() != n) {
        return Err(IdentifyError::Io {
            path: "<sweep output>".into(),
            cause: std::io::Error::other(
                "the sweep points do not all have the same number of joint angles",
            ),
        });
    }
    let mut w = csv::Writer::from_writer(writer);
    let mut header: Vec<&str> = Vec::new();
    if with_run {
        header.push("run");
    }
    header.extend(sweep_columns(n));
    w.write_record(&header).map_err(io)?;
    for r in &data.runs {
        for s in &r.sweeps {
            for p in &s.points {
                let mut row: Vec<String> = Vec::with_capacity(n + 5);
                if with_run {
                    row.push(r.run.clone().unwrap_or_default());
                }
                row.push(s.joint.to_string());
                row.extend(p.q_deg.iter().map(|v| format!("{v:?}")));
                row.extend(p.position_mm.iter().map(|v| format!("{v:?}")));
                w.write_record(&row).map_err(io)?;
            }
        }
    }
    w.flush().map_err(|cause| IdentifyError::Io {
        path: "<sweep output>".into(),
        cause,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A column for an eighth joint is refused, not silently dropped.
    #[test]
    fn a_column_beyond_seven_joints_is_refused() {
        let text = "joint,q1,q2,q3,q4,q5,q6,q7,q8,x,y,z\n1,0,0,0,0,0,0,0,0,1,2,3\n";
        let e = parse_sweeps(text.as_bytes(), "t.csv")
            .unwrap_err()
            .to_string();
        assert!(e.contains("'q8'") && e.contains("at most 7"), "{e}");
    }

    #[test]
    fn reads_runs_and_joints() {
        let text = "run,joint,q1,q2,q3,q4,q5,q6,x,y,z\n\
                    a,2,0,1,0,0,0,0,1,2,3\n\
                    a,1,0,0,0,0,0,0,1,2,3\n\
                    b,1,0,0,0,0,0,0,1,2,3\n\
                    a,2,0,2,0,0,0,0,1,2,3\n";
        let d = parse_sweeps(text.as_bytes(), "t.csv").unwrap();
        assert_eq!(d.runs.len(), 2);
        assert_eq!(d.runs[0].run.as_deref(), Some("a"));
        assert_eq!(d.runs[0].sweeps[0].joint, 1);
        assert_eq!(d.runs[0].sweeps[1].points.len(), 2);
        assert_eq!(d.runs[0].sweeps[1].points[1].line, 5);
        let mut out = Vec::new();
        write_sweeps(&d, &mut out).unwrap();
        let back = parse_sweeps(out.as_slice(), "o").unwrap();
        assert_eq!(back.runs.len(), 2);
        assert_eq!(
            back.runs[1].sweeps[0].points[0].position_mm,
            [1.0, 2.0, 3.0]
        );
    }

    #[test]
    fn the_q_columns_give_the_joint_count() {
        let text = "joint,q1,q2,q3,q4,q5,q6,q7,x,y,z,run\n\
                    7,0,0,0,0,0,0,5,1,2,3,a\n\
                    7,0,0,0,0,0,0,6,1,2,4,a\n";
        let d = parse_sweeps(text.as_bytes(), "t.csv").unwrap();
        let p = &d.runs[0].sweeps[0].points[1];
        assert_eq!(&*p.q_deg, &[0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 6.0]);
        assert_eq!(p.position_mm, [1.0, 2.0, 4.0]);
        let mut out = Vec::new();
        write_sweeps(&d, &mut out).unwrap();
        assert!(String::from_utf8_lossy(&out).starts_with("run,joint,q1,q2,q3,q4,q5,q6,q7,x,y,z\n"));
        assert_eq!(parse_sweeps(out.as_slice(), "o").unwrap(), d);
        let four =
            parse_sweeps("joint,q1,q2,q3,q4,x,y,z\n4,0,0,0,9,1,2,3\n".as_bytes(), "t").unwrap();
        assert_eq!(four.runs[0].sweeps[0].points[0].q_deg.len(), 4);
        for (header, missing) in [
            ("joint,q1,q2,q3,x,y,z\n", "'q4'"),
            ("joint,q1,q2,q3,q5,x,y,z\n", "'q4'"),
        ] {
            let e = parse_sweeps(header.as_bytes(), "t").unwrap_err();
            assert!(e.to_string().contains(missing), "{e}");
        }
        let e =
            parse_sweeps("joint,q1,q2,q3,q4,x,y,z\n5,0,0,0,9,1,2,3\n".as_bytes(), "t").unwrap_err();
        assert!(e.to_string().contains("1–4"), "{e}");
    }

    #[test]
    fn errors_name_the_line() {
        let e = parse_sweeps("joint,q1,q2,q3,q4,q5,q6,x,y\n".as_bytes(), "t").unwrap_err();
        assert!(e.to_string().contains("'z'"), "{e}");
        let e = parse_sweeps(
            "joint,q1,q2,q3,q4,q5,q6,x,y,z\n1,0,0,0,0,0,0,1,2,3\n1,0,0,0,0,0,0,1,2\n".as_bytes(),
            "t",
        )
        .unwrap_err();
        assert!(e.to_string().contains("line 3"), "{e}");
        let e = parse_sweeps(
            "joint,q1,q2,q3,q4,q5,q6,x,y,z\n7,0,0,0,0,0,0,1,2,3\n".as_bytes(),
            "t",
        )
        .unwrap_err();
        assert!(e.to_string().contains("line 2"), "{e}");
        let e = parse_sweeps(
            "joint,q1,q2,q3,q4,q5,q6,x,y,z\n3,0,0,abc,0,0,0,1,2,3\n".as_bytes(),
            "t",
        )
        .unwrap_err();
        assert!(e.to_string().contains("q3"), "{e}");
    }
}
