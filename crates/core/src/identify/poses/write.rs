//! Writing pose data in the format [`super::parse_poses`] reads.

use super::{pose_columns, PoseData, PAYLOAD_COLUMN, SIGMA_COLUMNS, TARGET_COLUMN};
use crate::identify::IdentifyError;
use crate::kinematics::Joints;
use std::io::Write;

/// Writes pose data in the format [`super::parse_poses`] reads: a `run` column when any run has a label,
/// `sx,sy,sz` when every point has them, `payload_kg` when any point carried a payload,
/// `s1..sn` when any point has its sides (0 where one has none). The `q` columns are those of
/// the first pose's joints (six without poses).
///
/// # Errors
///
/// [`IdentifyError::Io`] when writing fails, or when the poses do not all have the same number
/// of joint angles.
pub fn write_poses<W: Write>(data: &PoseData, writer: W) -> Result<(), IdentifyError> {
    let io = |e: csv::Error| IdentifyError::Io {
        path: "<pose output>".into(),
        cause: std::io::Error::other(e.to_string()),
    };
    let with_run = data.runs.iter().any(|r| r.run.is_some());
    let with_sigma = data
        .runs
        .iter()
        .all(|r| r.points.iter().all(|p| p.sigma_mm.is_some()));
    let with_payload = data
        .runs
        .iter()
        .any(|r| r.points.iter().any(|p| p.payload_kg != 0.0));
    let with_sides = (data.runs.iter()).any(|r| r.points.iter().any(|p| p.sides.is_some()));
    let mut points = data.runs.iter().flat_map(|r| &r.points);
    let n = points.clone().next().map_or(6, |p| p.q_deg.len());
    if points.any(|p| p.q_deg.len() != n) {
        return Err(IdentifyError::Io {
            path: "<pose output>".into(),
            cause: std::io::Error::other(
                "the poses do not all have the same number of joint angles",
            ),
        });
    }
    let mut w = csv::Writer::from_writer(writer);
    let mut header: Vec<&str> = Vec::new();
    if with_run {
        header.push("run");
    }
    header.extend(pose_columns(n));
    if with_sigma {
        header.extend_from_slice(&SIGMA_COLUMNS);
    }
    if with_payload {
        header.push(PAYLOAD_COLUMN);
    }
    let with_target = !data.targets.is_empty();
    if with_target {
        header.push(TARGET_COLUMN);
    }
    let side_names: Vec<String> = (1..=n).map(|j| format!("s{j}")).collect();
    if with_sides {
        header.extend(side_names.iter().map(String::as_str));
    }
    w.write_record(&header).map_err(io)?;
    for r in &data.runs {
        for p in &r.points {
            let mut row: Vec<String> = Vec::with_capacity(n + 7);
            if with_run {
                row.push(r.run.clone().unwrap_or_default());
            }
            row.extend(p.q_deg.iter().map(|v| format!("{v:?}")));
            row.extend(p.position_mm.iter().map(|v| format!("{v:?}")));
            if let (true, Some(s)) = (with_sigma, p.sigma_mm) {
                row.extend(s.iter().map(|v| format!("{v:?}")));
            }
            if with_payload {
                row.push(format!("{:?}", p.payload_kg));
            }
            if with_target {
                row.push(
                    data.targets
                        .get(p.target as usize)
                        .cloned()
                        .unwrap_or_default(),
                );
            }
            if with_sides {
                let s = p.sides.unwrap_or_else(|| Joints::filled(n, 0.0));
                row.extend(s.iter().map(|v| format!("{v}")));
            }
            w.write_record(&row).map_err(io)?;
        }
    }
    w.flush().map_err(|cause| IdentifyError::Io {
        path: "<pose output>".into(),
        cause,
    })
}
