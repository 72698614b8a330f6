//! The units of a pose file's joint angles: declared by the columns' names (`q1_rad`, `q1_deg`)
//! or, when undeclared, checked not to be radians read as degrees (a ROS `joint_states` log
//! written as is), as the positions are checked not to be metres.

use super::sweeps::Q_COLUMNS;
use super::IdentifyError;
use crate::kinematics::Joints;

/// The suffixes that declare the unit of a joint column (`q1_rad`, `q1_deg`).
const ANGLE_SUFFIXES: [(&str, bool); 2] = [("_rad", true), ("_deg", false)];

/// A joint column name without its unit suffix, and whether the suffix says radians (`None`: no
/// suffix, degrees).
pub(super) fn split_unit(name: &str) -> (String, Option<bool>) {
    let lower = name.trim().to_ascii_lowercase();
    for (suffix, radians) in ANGLE_SUFFIXES {
        if let Some(stem) = lower.strip_suffix(suffix) {
            if Q_COLUMNS.contains(&stem) {
                return (stem.to_string(), Some(radians));
            }
        }
    }
    (lower, None)
}

/// The header with the joint columns' unit suffixes taken off, and whether the angles are in
/// radians.
///
/// # Errors
///
/// [`IdentifyError::Csv`] (line 1) when the joint columns do not all declare the same unit.
pub(super) fn angle_unit(
    header: &csv::StringRecord,
    origin: &str,
) -> Result<(csv::StringRecord, bool), IdentifyError> {
    let mut plain = csv::StringRecord::new();
    let mut units: Vec<(String, bool)> = Vec::new();
    for h in header.iter() {
        let (stem, unit) = split_unit(h);
        if Q_COLUMNS.contains(&stem.as_str()) {
            units.push((h.trim().to_string(), unit == Some(true)));
            plain.push_field(&stem);
        } else {
            plain.push_field(h);
        }
    }
    let radians = units.first().is_some_and(|u| u.1);
    if let Some((name, _)) = units.iter().find(|u| u.1 != radians) {
        return Err(IdentifyError::Csv {
            origin: origin.to_string(),
            line: 1,
            message: format!(
                "the joint columns mix units ({} and {name}): name every joint column q1_rad … or none (degrees)",
                units[0].0
            ),
        });
    }
    Ok((plain, radians))
}

/// The largest joint angle (degrees, as read) of data written in radians: a full turn, 2π,
/// rounded up. A calibration moves joints over tens of degrees, so data whose every angle is
/// within ±6.3 over several rows are radians.
const RADIANS_LIMIT: f64 = 6.3;

/// Refuses rows whose every joint angle is within ±[`RADIANS_LIMIT`] while the angles vary:
/// radians read as degrees (a ROS `joint_states` log).
pub(super) fn check_not_radians(
    rows: &[(Joints, [f64; 3], u64)],
    origin: &str,
) -> Result<(), IdentifyError> {
    let mut largest = (0.0f64, 0usize, 0u64);
    for (q, _, line) in rows {
        for (j, v) in q.iter().enumerate() {
            if v.abs() > largest.0 {
                largest = (v.abs(), j + 1, *line);
            }
        }
    }
    let varies = rows.windows(2).any(|w| w[0].0 != w[1].0);
    if rows.len() > 1 && varies && largest.0 <= RADIANS_LIMIT {
        return Err(IdentifyError::Csv {
            origin: origin.to_string(),
            line: rows[0].2,
            message: format!(
                "joint angles look like radians: every angle is within ±{RADIANS_LIMIT} (largest |q{}| = {} on line {}) while a calibration moves joints over tens of degrees; convert them to degrees or declare the unit by naming the columns q1_rad, q2_rad, …",
                largest.1,
                crate::number::fmt_plain(largest.0),
                largest.2
            ),
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::super::poses::{check_tracker_data, parse_tracker_data, TrackerData};
    use crate::kinematics::tx60;

    /// Radians written as degrees are refused in one line naming the file, the line and the
    /// remedy; declared radians are read and converted; mixed units are refused.
    #[test]
    fn radians_are_detected_or_declared() {
        let rad = "q1,q2,q3,q4,q5,q6,x,y,z\n0.1,-1.2,1.5,0.3,0.8,-2.9,1000,200,300\n-0.4,0.2,1.1,-0.3,1.4,3.1,900,250,310\n";
        let d = parse_tracker_data(rad, "js.csv").unwrap();
        let e = check_tracker_data(&d, &tx60(), "js.csv")
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("js.csv")
                && e.contains("line 2")
                && e.contains("joint angles look like radians")
                && e.contains("|q6| = 3.1 on line 3")
                && e.contains("q1_rad")
                && !e.contains('\n'),
            "{e}"
        );
        let declared = rad.replacen(
            "q1,q2,q3,q4,q5,q6",
            "q1_rad,q2_rad,q3_rad,q4_rad,q5_rad,Q6_RAD",
            1,
        );
        let d = parse_tracker_data(&declared, "js.csv").unwrap();
        check_tracker_data(&d, &tx60(), "js.csv").unwrap();
        let TrackerData::Poses(p) = &d else {
            panic!("not poses")
        };
        assert!((p.runs[0].points[1].q_deg[5] - 3.1f64.to_degrees()).abs() < 1e-12);
        let deg = rad
            .replacen("q1,q2", "q1_deg,q2_deg", 1)
            .replace("-2.9", "-20");
        let d = parse_tracker_data(&deg, "f.csv").unwrap();
        check_tracker_data(&d, &tx60(), "f.csv").unwrap();
        let mixed = rad.replacen("q1,", "q1_rad,", 1);
        let e = parse_tracker_data(&mixed, "m.csv").unwrap_err().to_string();
        assert!(
            e.starts_with("m.csv") && e.contains("line 1") && e.contains("mix units"),
            "{e}"
        );
        // One row, or the same angles throughout, say nothing about the unit.
        let one = "q1,q2,q3,q4,q5,q6,x,y,z\n0.1,-1.2,1.5,0.3,0.8,-2.9,1000,200,300\n";
        let d = parse_tracker_data(one, "f.csv").unwrap();
        check_tracker_data(&d, &tx60(), "f.csv").unwrap();
    }
}
