//! Positioning accuracy of a model against measured positions (the paper's accuracy check,
//! docs/METHOD.md §5: mean absolute positioning error before and after calibration).
//!
//! Input CSV header `q1,…,qn,x,y,z` (`q1,q2,q3,q4,q5,q6,x,y,z` for a six-axis arm; 4 to 7 joints,
//! as many as the model has): commanded joint angles (deg) and the measured
//! target position (mm, in the robot base frame, or with [`validate_in`] in the measurement frame
//! of an identified placement). The error at a point is `‖P(model, q) − p_measured‖`;
//! [`validate`] reports its mean, RMS and maximum for a model and optionally for a nominal model,
//! with the improvement in percent ([`Validation::improvement_percent`]).
//!
//! Which nominal model and which frame a validation uses are decided first ([`choose_nominal`],
//! [`choose_frame`]): the model file's own nominal, a given one of the same robot, or a
//! refusal; a stated or recorded frame, or the base frame where the data plausibly are. On
//! measurement-frame data the nominal model gets its own best-fit placement
//! ([`register_nominal`]), so that the improvement is the geometry's alone.

mod baseline;
mod measurements;
mod setup;
mod term;

pub use super::provenance::{
    geometry_sha256, provenance_table, provenance_target, recorded_nominal, RecordedNominal,
};
pub use baseline::{register_nominal, Registration};
pub use measurements::{
    measurement_columns, parse_measurements, read_measurements, write_measurements, Measurement,
};
pub use setup::{
    choose_frame, choose_nominal, choose_target, run_validation, FrameSource, NominalSource,
    TargetChoice, ValidateError, ValidateRequest, OTHER_FRAME_MM, OTHER_ROBOT_MM,
};
pub use term::{held_out_term, HeldOutTerm};

use super::{IdentifyError, Placement};
use crate::kinematics::RobotModel;

/// Positioning error statistics, mm.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct AccuracyStats {
    /// Number of points.
    pub points: usize,
    /// Mean error.
    pub mean_mm: f64,
    /// Root mean square error.
    pub rms_mm: f64,
    /// Largest error.
    pub max_mm: f64,
}

/// Positioning error of `model` at every measurement, mm (measurements in the robot base frame).
pub fn point_errors(model: &RobotModel, m: &[Measurement]) -> Vec<f64> {
    point_errors_in(model, m, Placement::Known)
}

/// Positioning error of `model` at every measurement, mm: with [`Placement::Identify`] the
/// measurements are in the measurement frame and the model's `base` (its identified placement)
/// applies; with [`Placement::Known`] they are in the robot base frame.
///
/// The model's prediction includes its compensation when it has one
/// ([`RobotModel::compensated_position`]); [`point_errors_geometric`] leaves it out.
pub fn point_errors_in(model: &RobotModel, m: &[Measurement], frame: Placement) -> Vec<f64> {
    point_errors_with(model, m, frame, true)
}

/// [`point_errors_in`] of the geometric model alone (no compensation).
pub fn point_errors_geometric(model: &RobotModel, m: &[Measurement], frame: Placement) -> Vec<f64> {
    point_errors_with(model, m, frame, false)
}

fn point_errors_with(
    model: &RobotModel,
    m: &[Measurement],
    frame: Placement,
    compensate: bool,
) -> Vec<f64> {
    // A pose whose sides are not all recorded is predicted as the model predicts without
    // them, when it has a term for that (RobotModel::with_sides_unknown).
    let centre = model.with_sides_unknown();
    m.iter()
        .map(|p| {
            let q = p.q_deg.map(f64::to_radians);
            let model = match &centre {
                Some(c) if !p.sides.is_some_and(|s| model.sides_complete(&s)) => c,
                _ => model,
            };
            let at = p.payload_kg.and_then(|kg| model.knowing_payload(kg));
            let model = at.as_ref().unwrap_or(model);
            let turns = p.sides.and_then(|s| model.side_turns(&s));
            let world = frame == Placement::Identify;
            let x = model.predicted_position(&q, turns.as_ref(), compensate, world);
            (0..3)
                .map(|k| (x[k] - p.position_mm[k]).powi(2))
                .sum::<f64>()
                .sqrt()
        })
        .collect()
}

/// Mean, RMS and maximum positioning error of `model` over `m` (all zero for no points).
pub fn accuracy(model: &RobotModel, m: &[Measurement]) -> AccuracyStats {
    stats(&point_errors(model, m))
}

/// [`accuracy`] with the measurements in `frame` ([`point_errors_in`]).
pub fn accuracy_in(model: &RobotModel, m: &[Measurement], frame: Placement) -> AccuracyStats {
    stats(&point_errors_in(model, m, frame))
}

/// Mean, RMS and maximum of a list of errors (all zero for an empty list).
pub fn stats(e: &[f64]) -> AccuracyStats {
    let n = e.len().max(1) as f64;
    AccuracyStats {
        points: e.len(),
        mean_mm: e.iter().sum::<f64>() / n,
        rms_mm: (e.iter().map(|v| v * v).sum::<f64>() / n).sqrt(),
        max_mm: e.iter().fold(0.0, |a: f64, &b| a.max(b)),
    }
}

/// A nominal model whose tool point is further than this from the validated model's (mm) is taken
/// to describe another target (a preset's flange centre against a tracker target): its errors are
/// computed with the model's tool instead. Closer tools are two estimates of the same target (a
/// calibration moves the tool by tenths of a millimetre) and are kept.
pub const SAME_TOOL_MM: f64 = 5.0;

/// A model's accuracy, optionally beside a nominal model's.
#[derive(Clone, Debug, PartialEq)]
pub struct Validation {
    /// Name of the validated model.
    pub model_name: String,
    /// Its errors (with its compensation when it has one).
    pub model: AccuracyStats,
    /// Its errors without the compensation, when it has one.
    pub geometric: Option<AccuracyStats>,
    /// The nominal model's name and errors, if one was given.
    pub nominal: Option<(String, AccuracyStats)>,
    /// The nominal model's own tool point (mm) when it was more than [`SAME_TOOL_MM`] from the
    /// model's and the nominal errors were computed with the model's tool instead (robot base
    /// frame only).
    pub nominal_tool_replaced: Option<[f64; 3]>,
    /// On measurement-frame data: how the nominal model was placed (its own best-fit placement,
    /// [`register_nominal`]).
    pub nominal_registration: Option<Registration>,
}

impl Validation {
    /// Improvement of the model over the nominal in percent, `100 (nominal − model) / nominal`,
    /// for mean, RMS and max; `None` without a nominal model.
    pub fn improvement_percent(&self) -> Option<[f64; 3]> {
        let (_, n) = self.nominal.as_ref()?;
        let pct = |a: f64, b: f64| if a > 0.0 { 100.0 * (a - b) / a } else { 0.0 };
        Some([
            pct(n.mean_mm, self.model.mean_mm),
            pct(n.rms_mm, self.model.rms_mm),
            pct(n.max_mm, self.model.max_mm),
        ])
    }
}

/// A validation with what it compared and how, as every front end prints and writes it
/// ([`ValidationReport::text`], [`ValidationReport::json`]).
#[derive(Clone, Debug, PartialEq)]
pub struct ValidationReport {
    /// The errors.
    pub validation: Validation,
    /// The frame of the measurements.
    pub frame: Placement,
    /// Where the frame came from.
    pub frame_source: FrameSource,
    /// Where the nominal model came from, when there is one.
    pub nominal_source: Option<NominalSource>,
    /// The predictive check, when it was run.
    pub predictive: Option<super::predictive::PredictiveCheck>,
    /// The target compared, when the measurements named targets.
    pub target: Option<setup::TargetChoice>,
    /// The registration of the measurements to the model's frame by base reference reflectors
    /// (rows with `mount` = `base`), when the data and the model file have them.
    pub registration: Option<super::drift::DriftReport>,
    /// Base reference rows left out because the model file records no references.
    pub references_left_out: usize,
    /// The model with its discrepancy term from these errors, when asked for.
    pub term: Option<HeldOutTerm>,
    /// The approach sides the measurements record (`s1..sn`), when they record any.
    pub sides: Option<RecordedSides>,
}

/// What a validation did with recorded approach sides (docs/METHOD.md §19.5).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct RecordedSides {
    /// Measurements with at least one joint's side recorded (±1).
    pub poses: usize,
    /// Whether the model has a backlash they turn (then it predicts with them, and the
    /// predictive check draws only the sides left at 0); otherwise they change nothing.
    pub used: bool,
    /// For a model with a term for unknown sides ([`RobotModel::with_sides_unknown`]): the
    /// measurements with every side recorded (predicted with them; the others at the centre of
    /// the gaps with that term, nothing drawn). `None` for another model.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub complete: Option<usize>,
}

impl RecordedSides {
    /// The sides of `measurements` as `model` uses them; `None` when none is recorded.
    pub fn of(model: &RobotModel, measurements: &[Measurement]) -> Option<RecordedSides> {
        let poses = (measurements.iter())
            .filter(|m| m.sides.is_some_and(|s| s.iter().any(|&v| v != 0.0)))
            .count();
        let used = (model.joint_errors.as_ref())
            .and_then(|e| e.backlash.as_ref())
            .is_some_and(|b| b.acts());
        let complete = model.sides_unknown_term().map(|_| {
            (measurements.iter())
                .filter(|m| m.sides.is_some_and(|s| model.sides_complete(&s)))
                .count()
        });
        (poses > 0).then_some(RecordedSides {
            poses,
            used,
            complete,
        })
    }

    /// One line for the terminal.
    pub fn sentence(&self) -> String {
        if let (true, Some(k)) = (self.used, self.complete) {
            format!(
                "approach sides recorded at {} poses, every side at {k}: those predicted with them, the others at the centre of the backlash's gaps with the model's term for unknown sides\n",
                self.poses
            )
        } else if self.used {
            format!(
                "approach sides recorded at {} poses: the model's backlash predicted with them (the predictive check draws only the sides not recorded)\n",
                self.poses
            )
        } else {
            format!(
                "approach sides recorded at {} poses: the model has no backlash, so they change nothing (a model identified with the backlash check fits its gaps to them)\n",
                self.poses
            )
        }
    }
}

/// The frame of validated measurements, in words.
pub fn frame_words(frame: Placement) -> &'static str {
    match frame {
        Placement::Identify => "measurement (the model's placement applies)",
        Placement::Known => "robot base",
    }
}

impl ValidationReport {
    /// The method of the nominal baseline in one sentence, when there is a nominal model.
    pub fn nominal_method(&self) -> Option<String> {
        self.validation.nominal.as_ref()?;
        Some(match &self.validation.nominal_registration {
            Some(r) => r.method(),
            None if self.validation.nominal_tool_replaced.is_some() => {
                "nominal geometry in the robot base frame with the model's target offset".into()
            }
            None => "nominal model as it is, in the robot base frame".into(),
        })
    }

    /// The text for the terminal: the error table, the nominal model's source and method, the
    /// frame and the predictive check.
    pub fn text(&self) -> String {
        let mut s = super::render_validation(&self.validation);
        if let (Some(source), Some(method)) = (&self.nominal_source, self.nominal_method()) {
            s.push_str(&format!("nominal: {}\n", source.words()));
            s.push_str(&format!("nominal baseline: {method}\n"));
            if let Some(r) = &self.validation.nominal_registration {
                let (x, a, t) = (r.base_xyz_mm, r.base_rpy_deg, r.tool_mm);
                s.push_str(&format!(
                    "  its placement: xyz ({:.3}, {:.3}, {:.3}) mm, rpy ({:.4}, {:.4}, {:.4}) \
                     deg; target ({:.3}, {:.3}, {:.3}) mm\n",
                    x[0], x[1], x[2], a[0], a[1], a[2], t[0], t[1], t[2]
                ));
            }
        }
        let source = match self.frame_source {
            FrameSource::Stated => "as stated",
            FrameSource::Recorded => "recorded in the model file",
            FrameSource::Default => "the model file records none",
        };
        s.push_str(&format!("frame: {} — {source}\n", frame_words(self.frame)));
        if let Some(d) = &self.registration {
            s.push_str(&format!(
                "registered to the model's frame by its base references ({}) at {} poses: tool points moved by up to {:.4} mm\n",
                d.references.join(", "),
                d.poses,
                d.max_correction_mm
            ));
        }
        if self.references_left_out > 0 {
            s.push_str(&format!(
                "{} base reference rows left out: the model file records no references to register them with\n",
                self.references_left_out
            ));
        }
        if let Some(t) = &self.target {
            s.push_str(&format!(
                "target: '{}' (the model's own; {} rows of other targets left out)\n",
                t.label, t.left_out
            ));
        }
        if let Some(r) = &self.sides {
            s.push_str(&r.sentence());
        }
        if let Some(p) = &self.predictive {
            s.push_str(&p.render());
        }
        if let Some(t) = &self.term {
            s.push_str(&t.sentence());
        }
        s
    }

    /// The JSON document (pretty-printed).
    pub fn json(&self) -> String {
        let v = &self.validation;
        let nominal = v.nominal.as_ref().map(|(name, stats)| {
            serde_json::json!({
                "name": name,
                "source": self.nominal_source,
                "method": self.nominal_method(),
                "errors_mm": stats,
                "registration": v.nominal_registration,
                "tool_replaced_mm": v.nominal_tool_replaced,
            })
        });
        let doc = serde_json::json!({
            "model": { "name": v.model_name, "errors_mm": v.model, "geometric_errors_mm": v.geometric },
            "nominal": nominal,
            "improvement_percent": v.improvement_percent().map(|[m, r, x]| {
                serde_json::json!({ "mean": m, "rms": r, "max": x })
            }),
            "frame": match self.frame {
                Placement::Identify => "measurement",
                Placement::Known => "robot base",
            },
            "frame_source": self.frame_source,
            "target": self.target,
            "registration": self.registration,
            "references_left_out": self.references_left_out,
            "predictive_check": self.predictive,
            "recorded_sides": self.sides,
        });
        let mut doc = doc;
        if let Some(t) = &self.term {
            doc["discrepancy_term"] = serde_json::json!({
                "poses": t.poses, "rms_mm": t.rms_mm, "previous_rms_mm": t.previous_rms_mm,
            });
        }
        let mut s = serde_json::to_string_pretty(&doc).unwrap_or_default();
        s.push('\n');
        s
    }
}

/// Validates `model` (and optionally `nominal`) against measurements. The nominal model is
/// evaluated with the model's tool when its own is another target (see [`SAME_TOOL_MM`] and
/// [`Validation::nominal_tool_replaced`]).
///
/// # Errors
///
/// [`IdentifyError::NoData`] when there are no measurements, [`IdentifyError::JointCount`] when a
/// measurement does not have one angle per joint of the model or the nominal model has another
/// number of joints, [`IdentifyError::OutsideLimits`] when a measurement's angles are outside the
/// model's joint limits (naming its line and joint).
pub fn validate(
    model: &RobotModel,
    measurements: &[Measurement],
    nominal: Option<&RobotModel>,
) -> Result<Validation, IdentifyError> {
    validate_in(model, measurements, nominal, Placement::Known)
}

/// [`validate`] with the measurements in `frame`: in the measurement frame
/// ([`Placement::Identify`]) the model's placement applies, and a nominal model gets its own
/// best-fit placement and target offset ([`register_nominal`]; the model's placement, fitted
/// with the model's geometry, would leave the nominal geometry worse off than it is), so that
/// it is compared on the geometry alone.
///
/// # Errors
///
/// As [`validate`].
pub fn validate_in(
    model: &RobotModel,
    measurements: &[Measurement],
    nominal: Option<&RobotModel>,
    frame: Placement,
) -> Result<Validation, IdentifyError> {
    if measurements.is_empty() {
        return Err(IdentifyError::NoData(
            "no measurements to validate against".into(),
        ));
    }
    if let Some(n) = nominal.filter(|n| n.joints() != model.joints()) {
        return Err(IdentifyError::JointCount(format!(
            "the nominal model {} has {} joints, the model {} has {}",
            n.name,
            n.joints(),
            model.name,
            model.joints()
        )));
    }
    for m in measurements {
        if m.q_deg.len() != model.joints() {
            return Err(IdentifyError::JointCount(format!(
                "line {}: {} joint angles, the model {} has {} joints",
                m.line,
                m.q_deg.len(),
                model.name,
                model.joints()
            )));
        }
        model
            .check_limits(&m.q_deg)
            .map_err(|message| IdentifyError::OutsideLimits {
                line: m.line,
                message,
            })?;
    }
    let mut nominal_tool_replaced = None;
    let mut nominal_registration = None;
    let nominal = nominal.map(|n| {
        if frame == Placement::Identify {
            let (placed, reg) = register_nominal(n, measurements, model.tool);
            nominal_registration = Some(reg);
            return (
                n.name.clone(),
                stats(&point_errors_geometric(&placed, measurements, frame)),
            );
        }
        let mut n = n.clone();
        let gap = (0..3)
            .map(|k| (n.tool[k] - model.tool[k]).powi(2))
            .sum::<f64>()
            .sqrt();
        if gap.is_nan() || gap > SAME_TOOL_MM {
            nominal_tool_replaced = Some(n.tool);
            n.tool = model.tool;
        }
        (n.name.clone(), accuracy_in(&n, measurements, frame))
    });
    Ok(Validation {
        model_name: model.name.clone(),
        model: accuracy_in(model, measurements, frame),
        geometric: model
            .compensated()
            .then(|| stats(&point_errors_geometric(model, measurements, frame))),
        nominal,
        nominal_tool_replaced,
        nominal_registration,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identify::render_validation;
    use crate::kinematics::{position, tx60, Joints};

    #[test]
    fn round_trip_and_stats() {
        let m = tx60();
        let q = Joints::from([10.0, 20.0, 30.0, 40.0, 50.0, 60.0]);
        let p = position(&m.params, &m.tool, &q.map(f64::to_radians));
        let meas = vec![
            Measurement {
                payload_kg: None,
                q_deg: q,
                position_mm: p,
                line: 2,
                target: None,
                on_base: false,
                sides: None,
            },
            Measurement {
                payload_kg: None,
                q_deg: q,
                position_mm: [p[0] + 3.0, p[1] + 4.0, p[2]],
                line: 3,
                target: None,
                on_base: false,
                sides: None,
            },
        ];
        let mut buf = Vec::new();
        write_measurements(&meas, &mut buf).unwrap();
        let back = parse_measurements(buf.as_slice(), "m").unwrap();
        assert_eq!(back.len(), 2);
        let v = validate(&m, &back, Some(&m)).unwrap();
        assert!((v.model.mean_mm - 2.5).abs() < 1e-9);
        assert!((v.model.max_mm - 5.0).abs() < 1e-9);
        assert!((v.model.rms_mm - 12.5f64.sqrt()).abs() < 1e-9);
        assert_eq!(v.improvement_percent(), Some([0.0, 0.0, 0.0]));
        assert!(render_validation(&v).contains("improvement"));
    }

    #[test]
    fn bad_row_names_line() {
        let e = parse_measurements(
            "q1,q2,q3,q4,q5,q6,x,y,z\n0,0,0,0,0,0,1,2,3\n0,0,0,0,0,NaN,1,2,3\n".as_bytes(),
            "m",
        )
        .unwrap_err();
        assert!(
            e.to_string().contains("line 3") && e.to_string().contains("q6"),
            "{e}"
        );
    }
}
