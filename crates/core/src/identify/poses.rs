//! Pose data (the target measured at many configurations) and its CSV format, and the reader
//! that tells pose and sweep files apart by their header.
//!
//! Header `q1,…,qn,x,y,z` for an `n`-joint robot (`n` = 4 to 7; `q1,q2,q3,q4,q5,q6,x,y,z` for a
//! six-axis arm), optionally with `run` (any position, any label) and with per-point standard
//! uncertainties `sx,sy,sz` (mm; all three or none). The angles are commanded
//! joint angles in degrees (or radians, declared by naming every joint column `q1_rad`, …;
//! `q1_deg`, … are degrees), `x,y,z` the measured target position in mm in any measurement
//! frame. Rows of a run with the same joint angles (and sides) are repeated measurements of one
//! pose ([`super::repeats`]). Optional columns `s1..sn` give the side each joint arrived from
//! (1 moving positive, −1, 0 not known), which the backlash check then uses instead of the
//! poses' order (docs/METHOD.md §19.5).
//! [`read_tracker_data`] reads either this or a sweep file (a `joint` column); the checks that
//! need the nominal model (joint limits, positions that look like metres, angles that look like
//! radians) are made by
//! [`check_tracker_data`] (which also checks that the data have the model's number of joints).
//! Every error is one line naming the file, the line and the column.

use super::chain_fit::MAX_TARGETS;
use super::pose_units::{angle_unit, check_not_radians, split_unit};
use super::sweeps::{
    column_indices, csv_error, csv_reader, joint_count, open_input, parse_number, parse_sweeps,
    run_label, SweepData, Q_COLUMNS,
};
use super::IdentifyError;
use crate::kinematics::{Joints, RobotModel, MAX_JOINTS, MIN_JOINTS};
use std::collections::HashMap;
use std::io::Read;
use std::path::Path;

/// The columns a pose file of an `joints`-joint robot must have: `q1` to `q{joints}`, `x`, `y`,
/// `z`.
pub fn pose_columns(joints: usize) -> Vec<&'static str> {
    let mut c = Q_COLUMNS[..joints.min(MAX_JOINTS)].to_vec();
    c.extend_from_slice(&["x", "y", "z"]);
    c
}

/// The accepted headers, for the error of a file that has neither.
const FORMATS: &str = "joint,q1,…,qn,x,y,z (sweeps) or q1,…,qn,x,y,z [,sx,sy,sz] [,payload_kg] [,s1,…,sn] (poses), one q column per joint (4 to 7), each optionally with run";
/// The optional per-point standard uncertainty columns.
pub const SIGMA_COLUMNS: [&str; 3] = ["sx", "sy", "sz"];
/// The optional column naming which of several targets on the tool a row measured.
pub const TARGET_COLUMN: &str = "target";
/// The optional column saying where a row's reflector is mounted: `tool` (moves with the arm;
/// the default) or `base` (a reference fixed on the robot's base, to follow drift).
pub const MOUNT_COLUMN: &str = "mount";

/// The optional column of the payload during each measurement, kg (its centre of mass at the
/// measured target): joint compliance bends the robot under it.
pub const PAYLOAD_COLUMN: &str = "payload_kg";
/// The largest payload a pose file may state, kg.
pub const MAX_PAYLOAD_KG: f64 = 1000.0;

/// One measured pose.
#[derive(Clone, Debug, PartialEq)]
pub struct PosePoint {
    /// Commanded joint angles, degrees, one per joint.
    pub q_deg: Joints,
    /// Measured target position, mm, in the data's frame.
    pub position_mm: [f64; 3],
    /// Stated standard uncertainty per coordinate, mm.
    pub sigma_mm: Option<[f64; 3]>,
    /// The payload the robot carried, kg (the `payload_kg` column; 0 without it), its centre of
    /// mass at the measured target.
    pub payload_kg: f64,
    /// Line in the file.
    pub line: u64,
    /// Which target was measured: the index of its `target` label in [`PoseData::targets`]
    /// (0 without the column).
    pub target: u8,
    /// The side each joint arrived from (the optional `s1..sn` columns: 1 moving positive, −1,
    /// 0 not known; docs/METHOD.md §19.5); `None` without them: the backlash check takes the
    /// sides from the poses' order.
    pub sides: Option<Joints>,
}

/// The poses of one run.
#[derive(Clone, Debug, PartialEq)]
pub struct PoseRun {
    /// The `run` label; `None` without such a column.
    pub run: Option<String>,
    /// The poses in file order.
    pub points: Vec<PosePoint>,
}

/// Pose data: runs in the order they first appear.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PoseData {
    /// The runs.
    pub runs: Vec<PoseRun>,
    /// The labels of the `target` column in the order they first appear (empty without the
    /// column): several targets measured at each pose, the first the model's tool.
    pub targets: Vec<String>,
    /// Reflectors fixed on the robot's base (`mount` = `base`), measured at the poses to
    /// follow tracker or base drift ([`super::drift`]), in file order.
    pub references: Vec<ReferenceRow>,
    /// Their labels (the `target` column of those rows), in the order they first appear.
    pub reference_labels: Vec<String>,
}

/// A base reference reflector measured at a pose (a row with `mount` = `base`).
#[derive(Clone, Debug, PartialEq)]
pub struct ReferenceRow {
    /// The run it belongs to.
    pub run: Option<String>,
    /// The pose (commanded joint angles, degrees) it was measured at.
    pub q_deg: Joints,
    /// Measured position, mm, in the data's frame.
    pub position_mm: [f64; 3],
    /// Index into [`PoseData::reference_labels`].
    pub reference: u8,
    /// Line in the file.
    pub line: u64,
}

/// Sweep or pose data, as [`read_tracker_data`] found it.
#[derive(Clone, Debug, PartialEq)]
pub enum TrackerData {
    /// Circle-point sweeps.
    Sweeps(SweepData),
    /// Poses.
    Poses(PoseData),
}

impl TrackerData {
    /// Measured points over all runs.
    pub fn points(&self) -> usize {
        match self {
            TrackerData::Sweeps(d) => d
                .runs
                .iter()
                .flat_map(|r| &r.sweeps)
                .map(|s| s.points.len())
                .sum(),
            TrackerData::Poses(p) => p.runs.iter().map(|r| r.points.len()).sum(),
        }
    }

    /// Whether every point states its own σ.
    pub fn has_sigmas(&self) -> bool {
        matches!(self, TrackerData::Poses(p)
            if p.runs.iter().all(|r| r.points.iter().all(|x| x.sigma_mm.is_some())))
    }

    /// Every measured point with its commanded angles, position and line.
    fn rows(&self) -> Vec<(Joints, [f64; 3], u64)> {
        match self {
            TrackerData::Sweeps(d) => d
                .runs
                .iter()
                .flat_map(|r| &r.sweeps)
                .flat_map(|s| &s.points)
                .map(|p| (p.q_deg, p.position_mm, p.line))
                .collect(),
            TrackerData::Poses(d) => d
                .runs
                .iter()
                .flat_map(|r| &r.points)
                .map(|p| (p.q_deg, p.position_mm, p.line))
                .collect(),
        }
    }
}

/// Parses pose CSV text; `origin` names the source in errors.
///
/// # Errors
///
/// [`IdentifyError::MissingColumn`] for a missing required column (fewer than four `q` columns or a
/// gap in them, or one of `sx,sy,sz` while another is present), [`IdentifyError::Csv`] for a
/// malformed row, a value that is not a finite number, a σ outside
/// [`MIN_SIGMA_MM`](super::noise::MIN_SIGMA_MM) … [`MAX_SIGMA_MM`](super::noise::MAX_SIGMA_MM), joint
/// columns that mix units (`q1_rad` beside `q2`), or a row that repeats an earlier one exactly
/// (same run, angles and position) in a file without repeated measurements that differ (a
/// copied row; where poses were measured several times, identical readings are repeats that a
/// coarse resolution made equal), naming its line; [`IdentifyError::Empty`] for no data rows.
pub fn parse_poses<R: Read>(reader: R, origin: &str) -> Result<PoseData, IdentifyError> {
    let mut rdr = csv_reader(reader);
    let declared = rdr.headers().map_err(|e| csv_error(e, origin))?.clone();
    let (header, radians) = angle_unit(&declared, origin)?;
    let n = joint_count(&header, origin, FORMATS)?;
    let columns = pose_columns(n);
    let cols = column_indices(&header, &columns, origin)?;
    let find = |name: &str| {
        header
            .iter()
            .position(|h| h.trim().eq_ignore_ascii_case(name))
    };
    let run_col = find("run");
    let target_col = find(TARGET_COLUMN);
    let mount_col = find(MOUNT_COLUMN);
    if mount_col.is_some() && target_col.is_none() {
        return Err(IdentifyError::MissingColumn {
            origin: origin.to_string(),
            column: TARGET_COLUMN,
            expected: format!(
                "a {TARGET_COLUMN} column naming each reflector beside the {MOUNT_COLUMN} column"
            ),
        });
    }
    let payload_col = find(PAYLOAD_COLUMN);
    let side_cols = side_columns(&header, n, origin)?;
    let present: Vec<bool> = SIGMA_COLUMNS.iter().map(|c| find(c).is_some()).collect();
    let sigma_cols = if present.iter().any(|&p| p) {
        Some(column_indices(&header, &SIGMA_COLUMNS, origin)?)
    } else {
        None
    };
    let mut data = PoseData::default();
    let mut seen: HashMap<(Option<String>, Vec<u64>), u64> = HashMap::new();
    let mut copies: Vec<(u64, u64)> = Vec::new();
    for rec in rdr.records() {
        let rec = rec.map_err(|e| csv_error(e, origin))?;
        let line = rec.position().map(|p| p.line()).unwrap_or(0);
        let run = run_col.map(|c| rec.get(c).unwrap_or("").trim().to_string());
        let context = run_label(run.as_deref());
        let mut v = [0.0; MAX_JOINTS + 3];
        let v = &mut v[..n + 3];
        for (k, x) in v.iter_mut().enumerate() {
            *x = parse_number(&rec, cols[k], columns[k], line, origin, &context)?;
            if radians && k < n {
                *x = x.to_degrees();
            }
        }
        let sigma_mm = match &sigma_cols {
            None => None,
            Some(sc) => {
                let mut s = [0.0; 3];
                for (k, x) in s.iter_mut().enumerate() {
                    *x = parse_number(&rec, sc[k], SIGMA_COLUMNS[k], line, origin, &context)?;
                    if !super::noise::sigma_in_range(*x) {
                        return Err(IdentifyError::Csv {
                            origin: origin.to_string(),
                            line,
                            message: format!(
                                "column {} = {} is not a usable standard uncertainty: it must be within {:e} … {} mm",
                                SIGMA_COLUMNS[k],
                                crate::number::fmt_plain(*x),
                                super::noise::MIN_SIGMA_MM,
                                super::noise::MAX_SIGMA_MM
                            ),
                        });
                    }
                }
                Some(s)
            }
        };
        let payload_kg = match payload_col {
            None => 0.0,
            Some(c) => {
                let m = parse_number(&rec, c, PAYLOAD_COLUMN, line, origin, &context)?;
                if !(0.0..=MAX_PAYLOAD_KG).contains(&m) {
                    return Err(IdentifyError::Csv {
                        origin: origin.to_string(),
                        line,
                        message: format!(
                            "column {PAYLOAD_COLUMN} = {} is not a payload: it must be within 0 … {MAX_PAYLOAD_KG} kg",
                            crate::number::fmt_plain(m)
                        ),
                    });
                }
                m
            }
        };
        let on_base = match mount_col.map(|c| rec.get(c).unwrap_or("").trim().to_ascii_lowercase()) {
            None => false,
            Some(m) if m.is_empty() || m == "tool" => false,
            Some(m) if m == "base" => true,
            Some(m) => {
                return Err(IdentifyError::Csv {
                    origin: origin.to_string(),
                    line,
                    message: format!(
                        "column {MOUNT_COLUMN} = '{m}' is neither 'tool' (a reflector on the tool) nor 'base' (a reference fixed on the robot's base)"
                    ),
                })
            }
        };
        let labels = if on_base {
            &mut data.reference_labels
        } else {
            &mut data.targets
        };
        let target = match target_col {
            None => 0,
            Some(c) => target_index(labels, rec.get(c).unwrap_or(""), line, origin)?,
        };
        let key = (
            run.clone(),
            v.iter()
                .chain(std::iter::once(&f64::from(
                    target + if on_base { 100 } else { 0 },
                )))
                .chain(std::iter::once(&payload_kg))
                .map(|x| x.to_bits())
                .collect(),
        );
        if let Some(first) = seen.insert(key, line) {
            copies.push((line, first));
        }
        if on_base {
            data.references.push(ReferenceRow {
                run,
                q_deg: Joints::from_slice(&v[..n]),
                position_mm: [v[n], v[n + 1], v[n + 2]],
                reference: target,
                line,
            });
            continue;
        }
        let sides = row_sides(&rec, side_cols.as_deref(), origin, line)?;
        let point = PosePoint {
            q_deg: Joints::from_slice(&v[..n]),
            position_mm: [v[n], v[n + 1], v[n + 2]],
            sigma_mm,
            payload_kg,
            line,
            target,
            sides,
        };
        match data.runs.iter_mut().find(|r| r.run == run) {
            Some(r) => r.points.push(point),
            None => data.runs.push(PoseRun {
                run,
                points: vec![point],
            }),
        }
    }
    if data.runs.is_empty() {
        return Err(IdentifyError::Empty {
            origin: origin.to_string(),
        });
    }
    if let Some(&(line, first)) = copies.first() {
        if !has_differing_repeats(&data) {
            return Err(IdentifyError::Csv {
                origin: origin.to_string(),
                line,
                message: format!(
                    "repeats line {first} (same run, joint angles and position): a copied row? (repeated measurements of a pose differ in x, y, z by the tracker's noise)"
                ),
            });
        }
    }
    Ok(data)
}

/// Where a pose or measurement file's side columns `s1..sn` are
/// ([`crate::points::side_columns`]), `None` without them.
///
/// # Errors
///
/// [`IdentifyError::Csv`] (line 1) for a column `s{n+1}`.
pub(crate) fn side_columns(
    header: &csv::StringRecord,
    joints: usize,
    origin: &str,
) -> Result<Option<Vec<Option<usize>>>, IdentifyError> {
    crate::points::side_columns(header, joints).map_err(|message| IdentifyError::Csv {
        origin: origin.to_string(),
        line: 1,
        message,
    })
}

/// The sides of a row in the columns `cols` of [`side_columns`] (`None` without them).
///
/// # Errors
///
/// [`IdentifyError::Csv`] naming the line and column of a value that is not −1, 0 or 1.
pub(crate) fn row_sides(
    rec: &csv::StringRecord,
    cols: Option<&[Option<usize>]>,
    origin: &str,
    line: u64,
) -> Result<Option<Joints>, IdentifyError> {
    cols.map(|c| crate::points::row_sides(rec, c))
        .transpose()
        .map_err(|message| IdentifyError::Csv {
            origin: origin.to_string(),
            line,
            message,
        })
}

/// The index of target `label` in `targets` (appended when new).
///
/// # Errors
///
/// [`IdentifyError::Csv`] for an empty label or more than [`MAX_TARGETS`] targets.
fn target_index(
    targets: &mut Vec<String>,
    label: &str,
    line: u64,
    origin: &str,
) -> Result<u8, IdentifyError> {
    let label = label.trim();
    if label.is_empty() {
        return Err(IdentifyError::Csv {
            origin: origin.to_string(),
            line,
            message: format!(
                "column {TARGET_COLUMN} is empty: name the target each row measured (e.g. SMR1)"
            ),
        });
    }
    if let Some(k) = targets.iter().position(|t| t == label) {
        return Ok(k as u8);
    }
    if targets.len() == MAX_TARGETS {
        return Err(IdentifyError::Csv {
            origin: origin.to_string(),
            line,
            message: format!(
                "column {TARGET_COLUMN} = '{label}' is a {}th target: a fit takes at most {MAX_TARGETS} targets per pose ({})",
                MAX_TARGETS + 1,
                targets.join(", ")
            ),
        });
    }
    targets.push(label.to_string());
    Ok((targets.len() - 1) as u8)
}

/// Whether some pose of `data` was measured more than once with positions that differ.
fn has_differing_repeats(data: &PoseData) -> bool {
    data.runs.iter().any(|r| {
        super::repeats::pose_groups(r).iter().any(|g| {
            g.iter()
                .any(|&i| r.points[i].position_mm != r.points[g[0]].position_mm)
        })
    })
}

/// Reads a pose file.
///
/// # Errors
///
/// As [`parse_poses`], and [`IdentifyError::Io`] / [`IdentifyError::Read`] when the file cannot
/// be read, is too large or is not UTF-8.
pub fn read_poses(path: &Path) -> Result<PoseData, IdentifyError> {
    let (text, origin) = open_input(path)?;
    parse_poses(text.as_bytes(), &origin)
}

/// Reads sweep or pose data, told apart by the header: a `joint` column means sweeps, otherwise
/// the pose columns are required (`q1` to `qn` for 4 to 7 joints, `x`, `y`, `z`).
///
/// # Errors
///
/// [`IdentifyError::MissingColumn`] naming both accepted headers when the file is neither; the
/// errors of [`parse_sweeps`] and [`parse_poses`].
pub fn read_tracker_data(path: &Path) -> Result<TrackerData, IdentifyError> {
    let (text, origin) = open_input(path)?;
    parse_tracker_data(&text, &origin)
}

/// [`read_tracker_data`] on text.
///
/// # Errors
///
/// As [`read_tracker_data`].
pub fn parse_tracker_data(text: &str, origin: &str) -> Result<TrackerData, IdentifyError> {
    let header_line = text
        .lines()
        .find(|l| !l.trim().is_empty() && !l.trim_start().starts_with('#'))
        .unwrap_or("");
    let names: Vec<String> = header_line
        .split(',')
        .map(|h| split_unit(h.trim().trim_matches('"')).0)
        .collect();
    if names.iter().any(|n| n == "joint") {
        return Ok(TrackerData::Sweeps(parse_sweeps(text.as_bytes(), origin)?));
    }
    let required = pose_columns(MIN_JOINTS);
    if let Some(missing) = required
        .iter()
        .copied()
        .find(|c| !names.iter().any(|n| n == c))
    {
        return Err(IdentifyError::MissingColumn {
            origin: origin.to_string(),
            column: missing,
            expected: FORMATS.into(),
        });
    }
    Ok(TrackerData::Poses(parse_poses(text.as_bytes(), origin)?))
}

/// The largest plausible coordinate (mm) of data written in metres: a robot cell is a few metres,
/// so all coordinates within ±10 with a spread under 10 are metres, not millimetres.
const METRES_LIMIT: f64 = 10.0;

/// Checks data against the nominal model: every row with one angle per joint of the model, within
/// the joint limits, angles that are not radians and positions that are not in metres.
///
/// # Errors
///
/// [`IdentifyError::Csv`] naming the first row with another number of joint angles than the
/// model has joints or outside the limits (joint, value, limits), or the first row of data that
/// look like radians or metres.
pub fn check_tracker_data(
    data: &TrackerData,
    nominal: &RobotModel,
    origin: &str,
) -> Result<(), IdentifyError> {
    let rows = data.rows();
    check_not_radians(&rows, origin)?;
    for (q, _, line) in &rows {
        if q.len() != nominal.joints() {
            return Err(IdentifyError::Csv {
                origin: origin.to_string(),
                line: *line,
                message: format!(
                    "has {} joint angles (q1–q{}), the nominal model {} has {} joints",
                    q.len(),
                    q.len(),
                    nominal.name,
                    nominal.joints()
                ),
            });
        }
        nominal
            .check_limits(q)
            .map_err(|message| IdentifyError::Csv {
                origin: origin.to_string(),
                line: *line,
                message: format!("{message} of the nominal model {}", nominal.name),
            })?;
    }
    let largest = rows
        .iter()
        .flat_map(|(_, p, _)| p.iter())
        .fold(0.0f64, |m, v| m.max(v.abs()));
    let spread = (0..3)
        .map(|k| {
            let (lo, hi) = rows
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), r| {
                    (l.min(r.1[k]), h.max(r.1[k]))
                });
            hi - lo
        })
        .fold(0.0f64, f64::max);
    if rows.len() > 1 && largest <= METRES_LIMIT && spread < METRES_LIMIT && spread > 0.0 {
        return Err(IdentifyError::Csv {
            origin: origin.to_string(),
            line: rows[0].2,
            message: format!(
                "the positions look like metres (largest coordinate {largest}, spread {spread:.3}); x, y, z must be in mm"
            ),
        });
    }
    Ok(())
}

mod write;
pub use write::write_poses;

#[cfg(test)]
mod tests;
