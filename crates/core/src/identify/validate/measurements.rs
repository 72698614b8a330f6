//! Measured positions for a validation and their CSV format (the columns of a pose file: the
//! commanded angles, the measured target; optionally its payload, target label, mount and the
//! recorded backlash sides).

use crate::identify::poses::pose_columns;
use crate::identify::sweeps::{
    column_indices, csv_error, csv_reader, joint_count, open_input, parse_number,
};
use crate::identify::IdentifyError;
use crate::kinematics::{Joints, MAX_JOINTS};
use std::io::{Read, Write};
use std::path::Path;

/// The columns of a measurement file of an `joints`-joint robot: `q1` to `q{joints}`, `x`, `y`,
/// `z` (the columns of a pose file).
pub fn measurement_columns(joints: usize) -> Vec<&'static str> {
    pose_columns(joints)
}

/// A measured position at commanded joint angles.
#[derive(Clone, Debug, PartialEq)]
pub struct Measurement {
    /// Commanded joint angles, degrees, one per joint.
    pub q_deg: Joints,
    /// Measured target position, mm, base frame.
    pub position_mm: [f64; 3],
    /// The payload during the measurement, kg (the optional `payload_kg` column; `None`
    /// without it: the model's task payload). A model with joint compliance is compared at it.
    pub payload_kg: Option<f64>,
    /// Line in the CSV file (for generated data: the line it has when written).
    pub line: u64,
    /// The `target` column's label, when the file has one (several targets on the tool: a
    /// validation compares the model's own target's rows).
    pub target: Option<String>,
    /// A reflector fixed on the robot's base (`mount` = `base`), not a measured position of the
    /// tool: it registers the measurements with the tracker frame the model was identified in.
    pub on_base: bool,
    /// The side each joint arrived from (the optional `s1..sn` columns: 1, −1, 0 not known): a
    /// model with backlash predicts each joint half its gap on that side
    /// ([`crate::kinematics::RobotModel::side_turns`]).
    pub sides: Option<Joints>,
}

/// Reads a measurement CSV file.
///
/// # Errors
///
/// [`IdentifyError::Io`] when `path` is a directory or cannot be read, [`IdentifyError::Read`] when
/// the file is too large or not UTF-8; otherwise as [`parse_measurements`].
pub fn read_measurements(path: &Path) -> Result<Vec<Measurement>, IdentifyError> {
    let (text, origin) = open_input(path)?;
    parse_measurements(text.as_bytes(), &origin)
}

/// Parses measurement CSV text; `origin` names the source in errors.
///
/// # Errors
///
/// [`IdentifyError::Csv`] for a malformed row (wrong number of fields, a field that is not a finite
/// number), naming its line; [`IdentifyError::MissingColumn`] when the header lacks a required
/// column (fewer than four `q` columns, or a gap in them); [`IdentifyError::Empty`] when there
/// are no data rows.
pub fn parse_measurements<R: Read>(
    reader: R,
    origin: &str,
) -> Result<Vec<Measurement>, IdentifyError> {
    let mut rdr = csv_reader(reader);
    let header = rdr.headers().map_err(|e| csv_error(e, origin))?.clone();
    let n = joint_count(
        &header,
        origin,
        "q1,…,qn,x,y,z (one q column per joint, 4 to 7)",
    )?;
    let columns = measurement_columns(n);
    let cols = column_indices(&header, &columns, origin)?;
    let payload_col = header.iter().position(|h| {
        h.trim()
            .eq_ignore_ascii_case(crate::identify::poses::PAYLOAD_COLUMN)
    });
    let target_col = header.iter().position(|h| {
        h.trim()
            .eq_ignore_ascii_case(crate::identify::poses::TARGET_COLUMN)
    });
    let mount_col = header.iter().position(|h| {
        h.trim()
            .eq_ignore_ascii_case(crate::identify::poses::MOUNT_COLUMN)
    });
    let side_cols = crate::identify::poses::side_columns(&header, n, origin)?;
    let mut out = Vec::new();
    for rec in rdr.records() {
        let rec = rec.map_err(|e| csv_error(e, origin))?;
        let line = rec.position().map(|p| p.line()).unwrap_or(0);
        let mut v = [0.0; MAX_JOINTS + 3];
        let v = &mut v[..n + 3];
        for (k, x) in v.iter_mut().enumerate() {
            *x = parse_number(&rec, cols[k], columns[k], line, origin, "")?;
        }
        let payload_kg = match payload_col {
            None => None,
            Some(c) => {
                let name = crate::identify::poses::PAYLOAD_COLUMN;
                let m = parse_number(&rec, c, name, line, origin, "")?;
                if !(0.0..=crate::identify::poses::MAX_PAYLOAD_KG).contains(&m) {
                    return Err(IdentifyError::Csv {
                        origin: origin.to_string(),
                        line,
                        message: format!(
                            "column {name} = {} is not a payload: it must be within 0 … {} kg",
                            crate::number::fmt_plain(m),
                            crate::identify::poses::MAX_PAYLOAD_KG
                        ),
                    });
                }
                Some(m)
            }
        };
        out.push(Measurement {
            q_deg: Joints::from_slice(&v[..n]),
            position_mm: [v[n], v[n + 1], v[n + 2]],
            payload_kg,
            line,
            target: target_col.map(|c| rec.get(c).unwrap_or("").trim().to_string()),
            on_base: mount_col
                .is_some_and(|c| rec.get(c).unwrap_or("").trim().eq_ignore_ascii_case("base")),
            sides: crate::identify::poses::row_sides(&rec, side_cols.as_deref(), origin, line)?,
        });
    }
    if out.is_empty() {
        return Err(IdentifyError::Empty {
            origin: origin.to_string(),
        });
    }
    Ok(out)
}

/// Writes measurements in the format [`parse_measurements`] reads; the `q` columns are those of
/// the first measurement's joints (six without measurements), then `s1..sn` when any
/// measurement has its sides (0 where one has none).
///
/// # Errors
///
/// [`IdentifyError::Io`] when writing to `writer` fails, or when the measurements do not all have
/// the same number of joint angles.
pub fn write_measurements<W: Write>(m: &[Measurement], writer: W) -> Result<(), IdentifyError> {
    let io = |e: csv::Error| IdentifyError::Io {
        path: "<measurement output>".into(),
        cause: std::io::Error::other(e.to_string()),
    };
    let n = m.first().map_or(6, |p| p.q_deg.len());
    if m.iter().any(|p| p.q_deg.len() != n) {
        return Err(IdentifyError::Io {
            path: "<measurement output>".into(),
            cause: std::io::Error::other(
                "the measurements do not all have the same number of joint angles",
            ),
        });
    }
    let with_sides = m.iter().any(|p| p.sides.is_some());
    let mut w = csv::Writer::from_writer(writer);
    let mut header: Vec<String> = measurement_columns(n)
        .iter()
        .map(|c| c.to_string())
        .collect();
    if with_sides {
        header.extend((1..=n).map(|j| format!("s{j}")));
    }
    w.write_record(&header).map_err(io)?;
    for p in m {
        let mut row: Vec<String> = p
            .q_deg
            .iter()
            .chain(&p.position_mm)
            .map(|v| format!("{v:?}"))
            .collect();
        if with_sides {
            let s = p.sides.unwrap_or_else(|| Joints::filled(n, 0.0));
            row.extend(s.iter().map(|v| format!("{v}")));
        }
        w.write_record(&row).map_err(io)?;
    }
    w.flush().map_err(|cause| IdentifyError::Io {
        path: "<measurement output>".into(),
        cause,
    })
}
