//! Sweep data (the tracker measurements of the circle-point method) and its CSV format.
//!
//! Header `joint,q1,q2,q3,q4,q5,q6,x,y,z`, optionally with a `run` column (any position, any
//! label): `joint` is the joint (1–6) swept in that row, `q1..q6` the commanded joint angles in
//! degrees, `x,y,z` the measured target position in mm in the robot base frame. The rows of one
//! joint (within one run) form that joint's sweep; all other joints stay at the sweep's home
//! pose. Reading checks the syntax and that every number is finite, naming the line; the
//! structural checks (enough points, only the swept joint moving, every joint present) are made
//! by [`crate::identify::identify`] so that simulated data passes the same checks.
//! [`write_sweeps`] writes the same format, so real and simulated data go through one reader.

use super::IdentifyError;
use crate::kinematics::JOINTS;
use std::io::{Read, Write};
use std::path::Path;

/// The columns a sweep file must have (besides the optional `run`).
pub const SWEEP_COLUMNS: [&str; 10] = ["joint", "q1", "q2", "q3", "q4", "q5", "q6", "x", "y", "z"];

/// One measured point of a sweep.
#[derive(Clone, Debug, PartialEq)]
pub struct SweepPoint {
    /// Commanded joint angles, degrees.
    pub q_deg: [f64; JOINTS],
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
pub(crate) fn open_input(path: &Path) -> Result<(String, String), IdentifyError> {
    let origin = path.display().to_string();
    let io = |cause| IdentifyError::Io {
        path: origin.clone(),
        cause,
    };
    if path.is_dir() {
        return Err(io(std::io::Error::other("is a directory, not a CSV file")));
    }
    let text = crate::input::read_csv_text(path)?;
    Ok((text, origin))
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
/// number, a joint outside 1–6), naming its line; [`IdentifyError::MissingColumn`] when the header
/// lacks a required column; [`IdentifyError::Empty`] when there are no data rows.
pub fn parse_sweeps<R: Read>(reader: R, origin: &str) -> Result<SweepData, IdentifyError> {
    let mut rdr = csv_reader(reader);
    let header = rdr.headers().map_err(|e| csv_error(e, origin))?.clone();
    let cols = column_indices(&header, &SWEEP_COLUMNS, origin)?;
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
            Ok(j) if (1..=JOINTS).contains(&j) => j,
            _ => {
                return Err(IdentifyError::Csv {
                    origin: origin.to_string(),
                    line,
                    message: format!("column joint: '{jtext}' is not a joint number 1–{JOINTS}"),
                })
            }
        };
        let run = run_col.map(|c| rec.get(c).unwrap_or("").trim().to_string());
        let context = format!(" (joint {joint} sweep{})", run_label(run.as_deref()));
        let mut vals = [0.0; 9];
        for (k, v) in vals.iter_mut().enumerate() {
            *v = parse_number(
                &rec,
                cols[k + 1],
                SWEEP_COLUMNS[k + 1],
                line,
                origin,
                &context,
            )?;
        }
        let point = SweepPoint {
            q_deg: [vals[0], vals[1], vals[2], vals[3], vals[4], vals[5]],
            position_mm: [vals[6], vals[7], vals[8]],
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
/// run has a label.
///
/// # Errors
///
/// [`IdentifyError::Io`] when writing to `writer` fails.
pub fn write_sweeps<W: Write>(data: &SweepData, writer: W) -> Result<(), IdentifyError> {
    let io = |e: csv::Error| IdentifyError::Io {
        path: "<sweep output>".into(),
        cause: std::io::Error::other(e.to_string()),
    };
    let with_run = data.runs.iter().any(|r| r.run.is_some());
    let mut w = csv::Writer::from_writer(writer);
    let mut header: Vec<&str> = Vec::new();
    if with_run {
        header.push("run");
    }
    header.extend_from_slice(&SWEEP_COLUMNS);
    w.write_record(&header).map_err(io)?;
    for r in &data.runs {
        for s in &r.sweeps {
            for p in &s.points {
                let mut row: Vec<String> = Vec::with_capacity(11);
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
