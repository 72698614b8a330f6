//! Base reference reflectors: reflectors fixed on the robot's base (rows with `mount` = `base`),
//! measured at every pose to follow what moves the whole measurement — the tracker drifting
//! (temperature, a nudged tripod) or the base settling. A geometric model cannot explain such a
//! motion: it enters the residuals as lack of fit and biases the parameters.
//!
//! At pose `e` (rows of a run with the same joint angles, in the order they were measured)
//! each reference `j` is at `b_ej`. The drift is smoothed over the `w` poses around `e` (a
//! centred moving mean, `w` = [`WINDOW`] or fewer at the ends): a drift is slow, and each
//! pose's own references carry the tracker's noise, which the correction would otherwise add
//! to every tool point (multiplied by the lever from the references to the tool). The
//! references' home `b̄_j` is where they stood at the first pose (`b̃_0j`): the corrected data
//! are in the tracker's frame as it stood when the run began. The smoothed positions `b̃_ej`
//! give the pose's correction: the rigid motion that takes them home (Kabsch, with three or
//! more references not on one line), or the mean translation `b̄ − b̃` with one or two. The
//! tool rows of pose `e` are moved by it.
//!
//! The references' noise `s` comes from successive poses (`b_{e+1,j} − b_ej`: noise times √2,
//! plus a drift step that is small for a slow drift); the drift is corrected when its RMS over
//! the poses and references exceeds [`SIGNIFICANT`] times the noise left after smoothing,
//! `s/√w`. Below that the data are left as measured and the report says the references held
//! still.

use super::poses::{PoseData, PoseRun, ReferenceRow};
use super::IdentifyError;
use nalgebra::{Matrix3, Vector3};
use serde::Serialize;
use std::collections::HashMap;

/// Poses in the moving mean of the references (centred; fewer at the ends of a run).
pub const WINDOW: usize = 9;
/// A drift is corrected when its RMS exceeds this many times the smoothed references' noise.
pub const SIGNIFICANT: f64 = 3.0;

/// What the base references showed in one run.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DriftReport {
    /// The references' labels.
    pub references: Vec<String>,
    /// Poses they were measured at.
    pub poses: usize,
    /// The references' noise per coordinate from successive poses, mm.
    pub noise_mm: f64,
    /// RMS over poses and references of the smoothed references' distance from where they
    /// stood at the first pose, mm.
    pub rms_drift_mm: f64,
    /// Largest such distance, mm.
    pub max_drift_mm: f64,
    /// Largest correction applied to a tool point, mm (0 when not corrected).
    pub max_correction_mm: f64,
    /// Whether the tool rows were corrected.
    pub corrected: bool,
    /// Rigid (three or more references) or translation only.
    pub rigid: bool,
    /// Where the references stood in the frame the corrected data are in (one per label),
    /// mm: the identification's first pose, which the model file records so that later
    /// measurements with the same references are registered to it.
    pub home_mm: Vec<[f64; 3]>,
}

impl DriftReport {
    /// One line for the terminal.
    pub fn sentence(&self) -> String {
        let what = if self.corrected {
            format!(
                "corrected to the tracker frame of the first pose ({}; tool points moved by up to {:.4} mm)",
                if self.rigid {
                    "rigid motion"
                } else {
                    "translation"
                },
                self.max_correction_mm
            )
        } else {
            "within their noise: left as measured".to_string()
        };
        format!(
            "base references ({}) at {} poses: drift from the first pose RMS {:.4} mm, max {:.4} mm, against noise {:.4} mm per reading (smoothed over {WINDOW} poses): {what}",
            self.references.join(", "),
            self.poses,
            self.rms_drift_mm,
            self.max_drift_mm,
            self.noise_mm
        )
    }
}

/// The poses of `run` in order of first appearance, each with the indices of its rows.
fn poses(run: &PoseRun) -> Vec<(Vec<u64>, Vec<usize>)> {
    let mut at: HashMap<Vec<u64>, usize> = HashMap::new();
    let mut out: Vec<(Vec<u64>, Vec<usize>)> = Vec::new();
    for (i, p) in run.points.iter().enumerate() {
        let key: Vec<u64> = p.q_deg.iter().map(|v| (v + 0.0).to_bits()).collect();
        match at.get(&key) {
            Some(&k) => out[k].1.push(i),
            None => {
                at.insert(key.clone(), out.len());
                out.push((key, vec![i]));
            }
        }
    }
    out
}

/// The rigid motion that best maps `from` onto `to` ([`super::chain_fit::kabsch`]), `None`
/// when the points lie on one line (the rotation about it is free).
fn rigid(from: &[Vector3<f64>], to: &[Vector3<f64>]) -> Option<(Matrix3<f64>, Vector3<f64>)> {
    let n = from.len() as f64;
    let c = from.iter().sum::<Vector3<f64>>() / n;
    let spread: Matrix3<f64> = from.iter().map(|p| (p - c) * (p - c).transpose()).sum();
    let s = spread.symmetric_eigenvalues();
    let big = s.max();
    if big <= 0.0 || s.iter().filter(|&&v| v > 1e-12 * big).count() < 2 {
        return None;
    }
    Some(super::chain_fit::kabsch(from, to))
}

/// Corrects `run` for the drift its base references (`refs`, the rows of that run; labels
/// `labels`) show, and reports it. `origin` names the data file in errors.
///
/// # Errors
///
/// [`IdentifyError::NoData`] when a pose of the run lacks a reference that others have, or a
/// run has fewer than three poses with references.
pub fn correct_run(
    run: &PoseRun,
    refs: &[&ReferenceRow],
    labels: &[String],
) -> Result<(PoseRun, DriftReport), IdentifyError> {
    correct_to(run, refs, labels, None)
}

/// [`correct_run`] towards a given `home` (one position per label, mm; the one a model file
/// records): the tool rows are always moved, registering them with the frame the references
/// stood at home in (a later session's tracker frame onto the identification's).
///
/// # Errors
///
/// Those of [`correct_run`].
pub fn correct_to(
    run: &PoseRun,
    refs: &[&ReferenceRow],
    labels: &[String],
    home: Option<&[[f64; 3]]>,
) -> Result<(PoseRun, DriftReport), IdentifyError> {
    let label = super::sweeps::run_label(run.run.as_deref());
    let groups = poses(run);
    let j_count = labels.len();
    // Each pose's references (mean of repeated readings), in pose order.
    let mut at: Vec<Vec<Vector3<f64>>> = Vec::with_capacity(groups.len());
    for (key, rows) in &groups {
        let mut sum = vec![(Vector3::zeros(), 0usize); j_count];
        for r in refs.iter().filter(|r| {
            r.q_deg
                .iter()
                .map(|v| (v + 0.0).to_bits())
                .eq(key.iter().copied())
        }) {
            let s = &mut sum[r.reference as usize];
            s.0 += Vector3::from(r.position_mm);
            s.1 += 1;
        }
        if let Some(j) = sum.iter().position(|s| s.1 == 0) {
            return Err(IdentifyError::NoData(format!(
                "the pose at line {}{label} has no reading of base reference '{}': every pose needs a reading of each (rows with mount = base and the pose's joint angles)",
                run.points[rows[0]].line, labels[j]
            )));
        }
        at.push(sum.iter().map(|s| s.0 / s.1 as f64).collect());
    }
    let e_count = at.len();
    if e_count < 3 {
        return Err(IdentifyError::NoData(format!(
            "base references at {e_count} poses{label}: at least 3 are needed to tell drift from noise"
        )));
    }
    let steps: f64 = at
        .windows(2)
        .map(|w| {
            (0..j_count)
                .map(|j| (w[1][j] - w[0][j]).norm_squared())
                .sum::<f64>()
        })
        .sum();
    let noise = (steps / (2.0 * 3.0 * (e_count - 1) as f64 * j_count as f64)).sqrt();
    let half = WINDOW / 2;
    let smoothed: Vec<Vec<Vector3<f64>>> = (0..e_count)
        .map(|e| {
            let (lo, hi) = (e.saturating_sub(half), (e + half + 1).min(e_count));
            (0..j_count)
                .map(|j| at[lo..hi].iter().map(|b| b[j]).sum::<Vector3<f64>>() / (hi - lo) as f64)
                .collect()
        })
        .collect();
    let given = home.map(|h| h.iter().map(|&p| Vector3::from(p)).collect::<Vec<_>>());
    let home = given.clone().unwrap_or_else(|| smoothed[0].clone());
    let dist: Vec<f64> = smoothed
        .iter()
        .flat_map(|b| b.iter().zip(&home).map(|(x, h)| (x - h).norm()))
        .collect();
    let rms = (dist.iter().map(|d| d * d).sum::<f64>() / dist.len() as f64).sqrt();
    let max = dist.iter().copied().fold(0.0, f64::max);
    // 3-D noise of a smoothed reference: √3·s/√w
    let corrected = given.is_some()
        || rms > SIGNIFICANT * 3f64.sqrt() * noise / (WINDOW.min(e_count) as f64).sqrt();
    let rigid_ok = j_count >= 3 && rigid(&home, &home).is_some();
    let mut out = run.clone();
    let mut max_correction: f64 = 0.0;
    if corrected {
        for ((_, rows), b) in groups.iter().zip(&smoothed) {
            let (r, t) = if rigid_ok {
                rigid(b, &home).unwrap_or((Matrix3::identity(), Vector3::zeros()))
            } else {
                let t =
                    home.iter().zip(b).map(|(h, x)| h - x).sum::<Vector3<f64>>() / j_count as f64;
                (Matrix3::identity(), t)
            };
            for &i in rows {
                let p = Vector3::from(out.points[i].position_mm);
                let q = r * p + t;
                max_correction = max_correction.max((q - p).norm());
                out.points[i].position_mm = [q.x, q.y, q.z];
            }
        }
    }
    Ok((
        out,
        DriftReport {
            references: labels.to_vec(),
            poses: e_count,
            noise_mm: noise,
            rms_drift_mm: rms,
            max_drift_mm: max,
            max_correction_mm: max_correction,
            corrected,
            rigid: rigid_ok,
            home_mm: home.iter().map(|h| [h.x, h.y, h.z]).collect(),
        },
    ))
}

/// The runs of `data` corrected for drift by their base references, one report per run
/// (`None` for every run when the data have no references).
///
/// # Errors
///
/// Those of [`correct_run`]; [`IdentifyError::NoData`] for references in a run without tool
/// rows.
pub fn correct(data: &PoseData) -> Result<(Vec<PoseRun>, Vec<Option<DriftReport>>), IdentifyError> {
    if data.references.is_empty() {
        return Ok((data.runs.clone(), vec![None; data.runs.len()]));
    }
    if let Some(r) = data
        .references
        .iter()
        .find(|r| !data.runs.iter().any(|run| run.run == r.run))
    {
        return Err(IdentifyError::NoData(format!(
            "line {}: a base reference in a run with no tool rows{}",
            r.line,
            super::sweeps::run_label(r.run.as_deref())
        )));
    }
    let mut runs = Vec::with_capacity(data.runs.len());
    let mut reports = Vec::with_capacity(data.runs.len());
    for run in &data.runs {
        let refs: Vec<&ReferenceRow> = data
            .references
            .iter()
            .filter(|r| r.run == run.run)
            .collect();
        let (corrected, report) = correct_run(run, &refs, &data.reference_labels)?;
        runs.push(corrected);
        reports.push(Some(report));
    }
    Ok((runs, reports))
}
