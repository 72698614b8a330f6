//! Plausibility checks of an identification: results that fitted but should not be trusted.
//!
//! A sweep can pass every structural check and still be wrong: tracker noise far above the
//! instrument's (a loose target, the wrong file), axes swapped in the header (a mirrored robot),
//! data not in the base frame. [`quality_warnings`] flags, per run:
//!
//! * a joint whose circle-fit RMS residual exceeds [`QualityLimits::max_rms_residual_mm`]
//!   (default [`MAX_RMS_RESIDUAL_MM`] = 0.05 mm: a laser tracker of the AT960 class leaves
//!   ~0.01 mm per coordinate, ~0.02 mm as a 3-D residual, at robot distances);
//! * an identified parameter further from its nominal value than a calibration corrects
//!   ([`MAX_LENGTH_CHANGE_MM`] = 5 mm, [`MAX_ANGLE_CHANGE_DEG`] = 2°; manufacturing errors are
//!   tenths of a millimetre and hundredths of a degree);
//! * a measured J1 axis more than [`MAX_ANGLE_CHANGE_DEG`] from base z or more than
//!   [`MAX_LENGTH_CHANGE_MM`] from it: the data are not in the base frame, or two of the x, y, z
//!   columns are swapped (which mirrors the robot and turns base z sideways).

use super::pipeline::{Identification, IdentifyReport};
use crate::kinematics::ParamKind;
use std::fmt;

/// Default largest plausible circle-fit RMS residual, mm.
pub const MAX_RMS_RESIDUAL_MM: f64 = 0.05;
/// Default largest plausible change of a length (d, a) from its nominal value, mm.
pub const MAX_LENGTH_CHANGE_MM: f64 = 5.0;
/// Default largest plausible change of an angle (θ, α, β) from its nominal value, degrees.
pub const MAX_ANGLE_CHANGE_DEG: f64 = 2.0;

/// The limits of [`quality_warnings`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct QualityLimits {
    /// Largest plausible circle-fit RMS residual, mm.
    pub max_rms_residual_mm: f64,
    /// Largest plausible change of d or a from nominal, mm (also the J1 axis offset).
    pub max_length_change_mm: f64,
    /// Largest plausible change of θ, α or β from nominal, degrees (also the J1 axis tilt).
    pub max_angle_change_deg: f64,
}

impl Default for QualityLimits {
    fn default() -> Self {
        QualityLimits {
            max_rms_residual_mm: MAX_RMS_RESIDUAL_MM,
            max_length_change_mm: MAX_LENGTH_CHANGE_MM,
            max_angle_change_deg: MAX_ANGLE_CHANGE_DEG,
        }
    }
}

/// Something implausible in an identification (see the module docs). `Display` gives one line
/// naming the joint (and run) and the limit.
#[derive(Clone, Debug, PartialEq)]
pub enum IdentifyWarning {
    /// A joint's circle fit left residuals far above tracker noise.
    Residual {
        /// 1-based joint.
        joint: usize,
        /// " (run X)" or "".
        run: String,
        /// The RMS residual, mm.
        rms_mm: f64,
        /// The limit, mm.
        limit_mm: f64,
    },
    /// An identified parameter is far from its nominal value.
    Parameter {
        /// 1-based joint.
        joint: usize,
        /// " (run X)" or "".
        run: String,
        /// Which parameter.
        kind: ParamKind,
        /// Identified value, mm or degrees.
        identified: f64,
        /// Nominal value, mm or degrees.
        nominal: f64,
        /// The limit on the change, mm or degrees.
        limit: f64,
    },
    /// The whole-chain fit found the data unable to identify something, or inconsistent with
    /// the stated noise ([`super::chain::ChainReport::warnings`]).
    Chain {
        /// " (run X)" or "".
        run: String,
        /// The warning, with what to measure instead.
        message: String,
    },
    /// The measured J1 axis is far from base z.
    BaseAxis {
        /// " (run X)" or "".
        run: String,
        /// Tilt from base z, degrees.
        tilt_deg: f64,
        /// Distance from base z, mm.
        offset_mm: f64,
    },
}

impl IdentifyWarning {
    /// The 1-based joint the warning is about.
    pub fn joint(&self) -> usize {
        match self {
            Self::Residual { joint, .. } | Self::Parameter { joint, .. } => *joint,
            Self::BaseAxis { .. } => 1,
            Self::Chain { .. } => 0,
        }
    }
}

impl fmt::Display for IdentifyWarning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Chain { run, message } => write!(f, "whole-chain fit{run}: {message}"),
            Self::Residual {
                joint,
                run,
                rms_mm,
                limit_mm,
            } => write!(
                f,
                "joint {joint} sweep{run}: circle-fit RMS residual {rms_mm:.4} mm is above \
                 {limit_mm} mm, far beyond tracker noise: check the target and the sweep's data"
            ),
            Self::Parameter {
                joint,
                run,
                kind,
                identified,
                nominal,
                limit,
            } => {
                let unit = if kind.is_angle() { "deg" } else { "mm" };
                write!(
                    f,
                    "joint {joint}{run}: identified {} = {identified:.4} {unit} is {:.4} {unit} \
                     from nominal {nominal:.4} {unit}, more than a calibration corrects \
                     ({limit} {unit}): check the data's frame and column order",
                    kind.name(),
                    (identified - nominal).abs()
                )
            }
            Self::BaseAxis {
                run,
                tilt_deg,
                offset_mm,
            } => write!(
                f,
                "joint 1{run}: the measured J1 axis is {tilt_deg:.4} deg from base z and \
                 {offset_mm:.4} mm from it: the data are not in the robot base frame, or x, y, z \
                 are swapped (a mirrored robot)"
            ),
        }
    }
}

/// The warnings of several runs, one line per joint, kind of warning and parameter: the first
/// run's message, with the number of runs that share it (`… [3 of 5 runs]`), ordered by joint.
/// This is how the command line and the Python package print an identification's warnings.
pub fn grouped_warnings(ids: &[Identification]) -> Vec<String> {
    type Key = (
        usize,
        std::mem::Discriminant<IdentifyWarning>,
        Option<ParamKind>,
        Option<String>,
    );
    let key = |w: &IdentifyWarning| -> Key {
        let kind = match w {
            IdentifyWarning::Parameter { kind, .. } => Some(*kind),
            _ => None,
        };
        // A chain warning's kind is its first words ("rank deficient", "ill-conditioned", …).
        let what = match w {
            IdentifyWarning::Chain { message, .. } => {
                Some(message.split([':', '(']).next().unwrap_or("").to_string())
            }
            _ => None,
        };
        (w.joint(), std::mem::discriminant(w), kind, what)
    };
    let mut seen: Vec<(Key, String, usize)> = Vec::new();
    for w in ids.iter().flat_map(|i| &i.report.warnings) {
        match seen.iter_mut().find(|(k, _, _)| *k == key(w)) {
            Some((_, _, n)) => *n += 1,
            None => seen.push((key(w), w.to_string(), 1)),
        }
    }
    seen.sort_by_key(|s| s.0 .0);
    seen.into_iter()
        .map(|(_, text, n)| {
            if n > 1 {
                format!("{text} [{n} of {} runs]", ids.len())
            } else {
                text
            }
        })
        .collect()
}

/// `value` is above `limit` or not a number.
fn beyond(value: f64, limit: f64) -> bool {
    value.is_nan() || value > limit
}

/// The warnings of one identification run under `limits` (see the module docs), by joint.
pub fn quality_warnings(report: &IdentifyReport, limits: &QualityLimits) -> Vec<IdentifyWarning> {
    let run = super::sweeps::run_label(report.run.as_deref());
    let mut out = Vec::new();
    if report.j1_tilt_deg > limits.max_angle_change_deg
        || report.j1_offset_mm > limits.max_length_change_mm
    {
        out.push(IdentifyWarning::BaseAxis {
            run: run.clone(),
            tilt_deg: report.j1_tilt_deg,
            offset_mm: report.j1_offset_mm,
        });
    }
    for j in &report.joints {
        if beyond(j.rms_residual_mm, limits.max_rms_residual_mm) {
            out.push(IdentifyWarning::Residual {
                joint: j.joint,
                run: run.clone(),
                rms_mm: j.rms_residual_mm,
                limit_mm: limits.max_rms_residual_mm,
            });
        }
        // The last joint's parameters (J6's of a six-axis arm) are held at nominal (the tool
        // point absorbs the rest); the report has one entry per joint.
        if j.joint == report.joints.len() {
            continue;
        }
        for (k, kind) in ParamKind::ALL.into_iter().enumerate() {
            let limit = if kind.is_angle() {
                limits.max_angle_change_deg
            } else {
                limits.max_length_change_mm
            };
            if beyond((j.identified[k] - j.nominal[k]).abs(), limit) {
                out.push(IdentifyWarning::Parameter {
                    joint: j.joint,
                    run: run.clone(),
                    kind,
                    identified: j.identified[k],
                    nominal: j.nominal[k],
                    limit,
                });
            }
        }
    }
    out.sort_by_key(IdentifyWarning::joint);
    out
}
