//! What a validation compares and in which frame, decided before any error is computed, the
//! same way for every front end: the nominal model (the one the model file records, a given one
//! that is the same robot, or a clear refusal) and the frame of the measured positions (stated,
//! recorded in the model file, or the robot base frame when that is plausible — never a silent
//! switch to a frame the data are not in).

use super::{held_out_term, point_errors_geometric, stats, Measurement};
use crate::identify::provenance::{geometry_sha256, RecordedNominal};
use crate::identify::{IdentifyError, Placement};
use crate::kinematics::{position, RobotModel};
use serde::Serialize;

/// RMS distance (mm) between the flange centres of the model and a nominal model at the
/// measured poses above which the nominal is taken to be another robot. Calibration moves a
/// flange by millimetres; another robot's by hundreds.
pub const OTHER_ROBOT_MM: f64 = 25.0;

/// RMS error (mm) in the robot base frame above which measured positions are taken to be in
/// another frame (a tracker's, metres away) when nothing states their frame.
pub const OTHER_FRAME_MM: f64 = 100.0;

/// Why a validation does not start.
#[derive(Debug, thiserror::Error)]
pub enum ValidateError {
    /// A given nominal model is not the one the model file records.
    #[error(
        "the nominal model '{given}' (geometry sha256 {given_sha}) is not the one {origin} was \
         identified against: '{recorded}' (geometry sha256 {recorded_sha}), which its \
         [provenance] holds and a validation uses when no nominal model is given"
    )]
    NotTheRecordedNominal {
        /// The model file.
        origin: String,
        /// The given nominal's name.
        given: String,
        /// Its geometry SHA-256, shortened.
        given_sha: String,
        /// The recorded nominal's name.
        recorded: String,
        /// Its geometry SHA-256, shortened.
        recorded_sha: String,
    },
    /// The model file records its nominal model but the record cannot be used.
    #[error(
        "{origin}: the nominal model '{name}' (geometry sha256 {sha}) its [provenance] records \
         cannot be read back ({reason}); give that nominal model"
    )]
    RecordedNominalUnreadable {
        /// The model file.
        origin: String,
        /// The recorded name.
        name: String,
        /// The recorded geometry SHA-256, shortened.
        sha: String,
        /// Why.
        reason: String,
    },
    /// The model file records no nominal model and no preset matches its geometry.
    #[error(
        "{origin}: no nominal model is recorded (no nominal in a [provenance] table) and no \
         built-in preset is within {OTHER_ROBOT_MM} mm of {model}'s geometry; give the nominal \
         model it was identified against"
    )]
    NoNominal {
        /// The model file.
        origin: String,
        /// The model's name.
        model: String,
    },
    /// The nominal model is another robot (other joint count or geometry).
    #[error(
        "the nominal model '{nominal}' is another robot than {model} ({origin}): {why}; give \
         the nominal model {model} was identified against"
    )]
    OtherRobot {
        /// The model file.
        origin: String,
        /// The nominal's name.
        nominal: String,
        /// The model's name.
        model: String,
        /// What differs.
        why: String,
    },
    /// No frame is stated or recorded and the data are far from the model in the base frame.
    #[error(
        "{measured}: the measured positions are {base_rms_mm:.1} mm RMS from {model} in the \
         robot base frame, as positions in another (tracker) frame would be, and {origin} \
         records no frame (no [provenance] table){placement}; state the frame of the \
         measurements"
    )]
    UnknownFrame {
        /// The measurement file.
        measured: String,
        /// The model file.
        origin: String,
        /// The model's name.
        model: String,
        /// RMS error in the base frame, mm.
        base_rms_mm: f64,
        /// What the model's own placement would give, or that it has none.
        placement: String,
    },
    /// The measurements name several targets and the model records none of them as its own.
    #[error(
        "{measured}: the rows measure {count} targets ({labels}) and {origin} records no target          as its tool (no `target` in its [provenance]: identified from data without a `target`          column); keep only the rows of the target the model was identified with"
    )]
    UnknownTarget {
        /// The measurement file.
        measured: String,
        /// The model file.
        origin: String,
        /// Number of distinct targets.
        count: usize,
        /// Their labels, comma-separated.
        labels: String,
    },
    /// The model's target is not among the measured ones.
    #[error(
        "{measured}: no row measures '{target}', the target {origin} was identified with (its          [provenance] records it); the rows measure {labels}"
    )]
    TargetNotMeasured {
        /// The measurement file.
        measured: String,
        /// The model file.
        origin: String,
        /// The recorded target.
        target: String,
        /// The labels found, comma-separated.
        labels: String,
    },
    /// The measurements or models cannot be validated.
    #[error(transparent)]
    Identify(#[from] IdentifyError),
    /// No discrepancy term can be drawn from the measurements' errors.
    #[error("the discrepancy term from these errors: {0}")]
    Term(IdentifyError),
}

/// The target a validation compared when the measurements named several or the model records
/// one.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TargetChoice {
    /// The label of the rows compared.
    pub label: String,
    /// Rows of other targets left out.
    pub left_out: usize,
}

/// The rows of `measurements` a validation compares: those of the target the model file
/// records (`recorded`), or all of them when the rows name no target or one. `origin` and
/// `measured` name the model and measurement files.
///
/// # Errors
///
/// [`ValidateError::TargetNotMeasured`] when no row is the recorded target's,
/// [`ValidateError::UnknownTarget`] when the rows name several targets and none is recorded.
pub fn choose_target(
    measurements: &[Measurement],
    recorded: Option<&str>,
    origin: &str,
    measured: &str,
) -> Result<(Vec<Measurement>, Option<TargetChoice>), ValidateError> {
    let mut labels: Vec<&str> = Vec::new();
    for m in measurements {
        if let Some(l) = m.target.as_deref() {
            if !labels.contains(&l) {
                labels.push(l);
            }
        }
    }
    let all = || (measurements.to_vec(), None);
    let choice = match (recorded, labels.len()) {
        (_, 0) => return Ok(all()),
        (None, 1) => labels[0],
        (None, count) => {
            return Err(ValidateError::UnknownTarget {
                measured: measured.to_string(),
                origin: origin.to_string(),
                count,
                labels: labels.join(", "),
            })
        }
        (Some(t), _) => {
            if !labels.contains(&t) {
                return Err(ValidateError::TargetNotMeasured {
                    measured: measured.to_string(),
                    origin: origin.to_string(),
                    target: t.to_string(),
                    labels: labels.join(", "),
                });
            }
            t
        }
    };
    let kept: Vec<Measurement> = measurements
        .iter()
        .filter(|m| m.target.as_deref().is_none_or(|l| l == choice))
        .cloned()
        .collect();
    let left_out = measurements.len() - kept.len();
    Ok((
        kept,
        Some(TargetChoice {
            label: choice.to_string(),
            left_out,
        }),
    ))
}

/// Where the nominal model of a validation came from.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(rename_all = "snake_case", tag = "kind", content = "name")]
pub enum NominalSource {
    /// The nominal recorded in the model file's `[provenance]`.
    Recorded,
    /// Given by the user (and, where the model file records one, the same geometry).
    Given,
    /// No nominal recorded or given: the built-in preset (named) whose geometry is the model's.
    PresetByGeometry(String),
}

impl NominalSource {
    /// In words.
    pub fn words(&self) -> String {
        match self {
            NominalSource::Recorded => "the model file's own (recorded in its [provenance])".into(),
            NominalSource::Given => "as given".into(),
            NominalSource::PresetByGeometry(p) => format!(
                "preset {p}, the built-in model of the same geometry (the model file records no \
                 nominal)"
            ),
        }
    }
}

/// The short form of a SHA-256 shown in messages.
fn short(sha: &str) -> String {
    sha.chars().take(12).collect()
}

/// RMS distance (mm) between the flange centres of `a` and `b` (robot base frame, no tool) at
/// the measured poses; `None` when the joint counts differ.
fn flange_gap(a: &RobotModel, b: &RobotModel, m: &[Measurement]) -> Option<f64> {
    if a.joints() != b.joints() {
        return None;
    }
    let sq: f64 = m
        .iter()
        .map(|p| {
            let q = p.q_deg.map(f64::to_radians);
            let (x, y) = (
                position(&a.params, &[0.0; 3], &q),
                position(&b.params, &[0.0; 3], &q),
            );
            (0..3).map(|k| (x[k] - y[k]).powi(2)).sum::<f64>()
        })
        .sum();
    Some((sq / m.len().max(1) as f64).sqrt())
}

/// Refuses a nominal model of another robot than `model`: another number of joints, or flange
/// centres more than [`OTHER_ROBOT_MM`] RMS apart at the measured poses.
fn same_robot(
    model: &RobotModel,
    nominal: &RobotModel,
    m: &[Measurement],
    origin: &str,
) -> Result<(), ValidateError> {
    let why = match flange_gap(model, nominal, m) {
        None => format!("{} joints against {}", nominal.joints(), model.joints()),
        Some(gap) if gap.is_nan() || gap > OTHER_ROBOT_MM => format!(
            "their flanges are {gap:.1} mm RMS apart at the measured poses (more than \
             {OTHER_ROBOT_MM} mm)"
        ),
        Some(_) => return Ok(()),
    };
    Err(ValidateError::OtherRobot {
        origin: origin.to_string(),
        nominal: nominal.name.clone(),
        model: model.name.clone(),
        why,
    })
}

/// The nominal model to validate `model` (read from `origin`, whose `[provenance]` records
/// `recorded`) against, with the measurements `m`:
/// - `given` and a recorded nominal: the given one when its geometry is the recorded one
///   ([`geometry_sha256`]), else [`ValidateError::NotTheRecordedNominal`];
/// - only a recorded nominal: that one;
/// - only `given`: it, when it is the same robot;
/// - neither: the built-in preset whose geometry is the model's (the closest within
///   [`OTHER_ROBOT_MM`]), else [`ValidateError::NoNominal`].
///
/// Any nominal of another robot (joint count, or flanges more than [`OTHER_ROBOT_MM`] apart) is
/// refused ([`ValidateError::OtherRobot`]).
///
/// # Errors
///
/// As listed; [`ValidateError::RecordedNominalUnreadable`] when the record cannot be used and
/// no nominal is given; [`IdentifyError::NoData`] without measurements.
pub fn choose_nominal(
    model: &RobotModel,
    origin: &str,
    recorded: Option<&RecordedNominal>,
    given: Option<RobotModel>,
    m: &[Measurement],
) -> Result<(RobotModel, NominalSource), ValidateError> {
    if m.is_empty() {
        return Err(IdentifyError::NoData("no measurements to validate against".into()).into());
    }
    let (nominal, source) = match (recorded, given) {
        (Some(r), Some(g)) => {
            let sha = geometry_sha256(&g);
            if sha != r.sha256 {
                return Err(ValidateError::NotTheRecordedNominal {
                    origin: origin.to_string(),
                    given: g.name.clone(),
                    given_sha: short(&sha),
                    recorded: r.name.clone(),
                    recorded_sha: short(&r.sha256),
                });
            }
            (g, NominalSource::Given)
        }
        (Some(r), None) => match &r.model {
            Ok(n) => (n.clone(), NominalSource::Recorded),
            Err(reason) => {
                return Err(ValidateError::RecordedNominalUnreadable {
                    origin: origin.to_string(),
                    name: r.name.clone(),
                    sha: short(&r.sha256),
                    reason: reason.clone(),
                })
            }
        },
        (None, Some(g)) => (g, NominalSource::Given),
        (None, None) => {
            let closest = crate::presets::PRESETS
                .iter()
                .filter_map(|name| {
                    let p = crate::presets::preset(name).ok()?;
                    let gap = flange_gap(model, &p, m)?;
                    (gap <= OTHER_ROBOT_MM).then_some((gap, name, p))
                })
                .min_by(|a, b| a.0.total_cmp(&b.0));
            match closest {
                Some((_, name, p)) => (p, NominalSource::PresetByGeometry(name.to_string())),
                None => {
                    return Err(ValidateError::NoNominal {
                        origin: origin.to_string(),
                        model: model.name.clone(),
                    })
                }
            }
        }
    };
    same_robot(model, &nominal, m, origin)?;
    Ok((nominal, source))
}

/// Where the frame of a validation came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum FrameSource {
    /// Stated by the user.
    Stated,
    /// Recorded in the model file's `[provenance]`.
    Recorded,
    /// Neither: the robot base frame, where the data are plausibly.
    Default,
}

/// The frame of the measurements `m` (from `measured`) for validating `model` (from `origin`):
/// the `stated` one, else the one its `[provenance]` records (`recorded`), else the robot base
/// frame — refused ([`ValidateError::UnknownFrame`]) when the model's errors there exceed
/// [`OTHER_FRAME_MM`] RMS, as data in a tracker frame give.
///
/// # Errors
///
/// As described; [`IdentifyError::NoData`] without measurements.
pub fn choose_frame(
    model: &RobotModel,
    origin: &str,
    recorded: Option<Placement>,
    stated: Option<Placement>,
    m: &[Measurement],
    measured: &str,
) -> Result<(Placement, FrameSource), ValidateError> {
    if m.is_empty() {
        return Err(IdentifyError::NoData("no measurements to validate against".into()).into());
    }
    if let Some(f) = stated {
        return Ok((f, FrameSource::Stated));
    }
    if let Some(f) = recorded {
        return Ok((f, FrameSource::Recorded));
    }
    // Angles with another joint count or outside the limits are refused by the validation
    // itself, naming the line.
    if m.iter()
        .any(|p| p.q_deg.len() != model.joints() || model.check_limits(&p.q_deg).is_err())
    {
        return Ok((Placement::Known, FrameSource::Default));
    }
    let base = stats(&point_errors_geometric(model, m, Placement::Known)).rms_mm;
    if base.is_finite() && base <= OTHER_FRAME_MM {
        return Ok((Placement::Known, FrameSource::Default));
    }
    let placement = if model.base.is_some() {
        let with = stats(&point_errors_geometric(model, m, Placement::Identify)).rms_mm;
        format!("; with the model's placement they are {with:.3} mm RMS")
    } else {
        "; the model has no placement".into()
    };
    Err(ValidateError::UnknownFrame {
        measured: measured.to_string(),
        origin: origin.to_string(),
        model: model.name.clone(),
        base_rms_mm: base,
        placement,
    })
}

/// What a validation is asked to compare, as a front end gathers it.
#[derive(Clone, Debug)]
pub struct ValidateRequest<'a> {
    /// The model to validate.
    pub model: &'a RobotModel,
    /// Its model file's text (its `[provenance]` records the frame and the nominal model).
    pub model_text: &'a str,
    /// The model file, as messages name it.
    pub origin: &'a str,
    /// The measured positions.
    pub measurements: &'a [Measurement],
    /// The measurement file, as messages name it.
    pub measured: &'a str,
    /// The stated frame of the measurements, if any.
    pub frame: Option<Placement>,
    /// No nominal comparison (`None`), the model's own nominal (`Some(None)`) or a given one.
    pub nominal: Option<Option<RobotModel>>,
    /// Draws per pose of the predictive check; 0 leaves it out.
    pub check_draws: usize,
    /// Seed of the predictive check.
    pub seed: u64,
    /// Also the model with its discrepancy term drawn from these errors ([`held_out_term`]).
    pub term: bool,
}

/// Runs a validation as every front end does: [`choose_frame`], [`choose_nominal`],
/// [`super::validate_in`] and the predictive check (with at least 2 measurements and
/// `check_draws > 0`).
///
/// # Errors
///
/// Those of the steps.
pub fn run_validation(r: ValidateRequest<'_>) -> Result<super::ValidationReport, ValidateError> {
    let (base, tool): (Vec<Measurement>, Vec<Measurement>) =
        r.measurements.iter().cloned().partition(|m| m.on_base);
    let recorded_target = crate::identify::provenance::provenance_target(r.model_text);
    let (kept, target) = choose_target(&tool, recorded_target.as_deref(), r.origin, r.measured)?;
    let recorded = crate::identify::provenance::provenance_references(r.model_text);
    let (kept, registration, references_left_out) = match (base.is_empty(), recorded) {
        (true, _) => (kept, None, 0),
        (false, None) => (kept, None, base.len()),
        (false, Some(home)) => {
            let (m, d) = register(&kept, &base, &home, r.measured)?;
            (m, Some(d), 0)
        }
    };
    let r = ValidateRequest {
        measurements: &kept,
        ..r
    };
    let recorded_frame = crate::identify::provenance_frame(r.model_text);
    let (frame, frame_source) = choose_frame(
        r.model,
        r.origin,
        recorded_frame,
        r.frame,
        r.measurements,
        r.measured,
    )?;
    let nominal = match r.nominal {
        None => None,
        Some(given) => {
            let recorded = crate::identify::provenance::recorded_nominal(r.model_text);
            Some(choose_nominal(
                r.model,
                r.origin,
                recorded.as_ref(),
                given,
                r.measurements,
            )?)
        }
    };
    let validation = super::validate_in(
        r.model,
        r.measurements,
        nominal.as_ref().map(|(n, _)| n),
        frame,
    )?;
    let predictive = if r.check_draws > 0 && r.measurements.len() >= 2 {
        Some(crate::identify::predictive::predictive_check(
            r.model,
            r.measurements,
            frame,
            r.check_draws,
            r.seed,
        )?)
    } else {
        None
    };
    let term = r
        .term
        .then(|| held_out_term(r.model, r.measurements, frame))
        .transpose()
        .map_err(ValidateError::Term)?;
    let sides = super::RecordedSides::of(r.model, r.measurements);
    Ok(super::ValidationReport {
        sides,
        term,
        validation,
        frame,
        frame_source,
        nominal_source: nominal.map(|(_, s)| s),
        predictive,
        target,
        registration,
        references_left_out,
    })
}

/// Moves the tool rows `tool` by the rigid motion that takes the base references `base` (rows
/// with `mount` = `base`) of each pose to where the model file records them (`home`):
/// measurements of another session, or another tracker station, in the model's frame.
///
/// # Errors
///
/// [`ValidateError::Identify`] for a reference the model file does not record, and the errors
/// of [`crate::identify::drift::correct_to`] (a pose without a reading of each reference).
fn register(
    tool: &[Measurement],
    base: &[Measurement],
    home: &[(String, [f64; 3])],
    measured: &str,
) -> Result<(Vec<Measurement>, crate::identify::drift::DriftReport), ValidateError> {
    use crate::identify::poses::{PosePoint, PoseRun, ReferenceRow};
    let mut labels: Vec<String> = Vec::new();
    let mut at: Vec<[f64; 3]> = Vec::new();
    let mut refs: Vec<ReferenceRow> = Vec::with_capacity(base.len());
    for b in base {
        let label = b.target.clone().unwrap_or_default();
        let Some((_, h)) = home.iter().find(|(l, _)| *l == label) else {
            return Err(ValidateError::Identify(IdentifyError::NoData(format!(
                "{measured}: line {}: base reference '{label}' is not one the model file records ({})",
                b.line,
                home.iter().map(|(l, _)| l.as_str()).collect::<Vec<_>>().join(", ")
            ))));
        };
        let k = match labels.iter().position(|l| *l == label) {
            Some(k) => k,
            None => {
                labels.push(label);
                at.push(*h);
                labels.len() - 1
            }
        };
        refs.push(ReferenceRow {
            run: None,
            q_deg: b.q_deg,
            position_mm: b.position_mm,
            reference: k as u8,
            line: b.line,
        });
    }
    let run = PoseRun {
        run: None,
        points: tool
            .iter()
            .map(|m| PosePoint {
                q_deg: m.q_deg,
                position_mm: m.position_mm,
                sigma_mm: None,
                payload_kg: m.payload_kg.unwrap_or(0.0),
                line: m.line,
                target: 0,
                sides: m.sides,
            })
            .collect(),
    };
    let refs: Vec<&ReferenceRow> = refs.iter().collect();
    let (moved, report) = crate::identify::drift::correct_to(&run, &refs, &labels, Some(&at))?;
    let out = tool
        .iter()
        .zip(&moved.points)
        .map(|(m, p)| Measurement {
            position_mm: p.position_mm,
            ..m.clone()
        })
        .collect();
    Ok((out, report))
}
