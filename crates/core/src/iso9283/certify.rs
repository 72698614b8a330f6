//! The certificate from measured cycles ([`certify`]): refused when it could say nothing about
//! the robot (a model without uncertainty) or when the measurements contradict the model it is
//! drawn from (a measured AP beyond every predicted error at its pose: positions in metres, in
//! another frame, or of another robot).

use super::{certificate_with_progress, Certificate, CertificateError, PoseFigures};
use crate::engine::{CpuEvaluator, Evaluator, Problem, Reference};
use crate::identify::Placement;
use crate::kinematics::{Joints, RobotModel};
use crate::progress::ProgressHook;

/// Draws of the consistency check at most (the certificate's own draws when fewer).
pub const CHECK_DRAWS: u64 = 100_000;

/// Standard errors of the barycentre a measured AP may exceed the largest predicted error by
/// before the measurements count as contradicting the model.
pub const CHECK_STANDARD_ERRORS: f64 = 5.0;

/// Draws evaluated at once by the check.
const CHUNK: usize = 4096;

/// Why no certificate is given.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum CertifyError {
    /// The model states no uncertainty: every draw is the model itself, so the certificate would
    /// be 1 (or 0) by construction.
    #[error("the model '{model}' carries no uncertainty (every σ is 0, as in a preset from a published table or an imported description): every draw is the model itself, so the certificate would be 1 by construction; identify the model from measurements first")]
    NoUncertainty {
        /// The model's name.
        model: String,
    },
    /// A pose's measured AP lies beyond every error the model predicts there.
    #[error("pose P{pose} (line {line}): the measured AP {ap_mm:.4} mm is beyond all {draws} of the model's predicted errors there (largest {largest_mm:.4} mm, barycentre uncertain by {standard_error_mm:.4} mm): the model's uncertainty does not describe these cycles{hint}, so no certificate is given")]
    Contradiction {
        /// The pose (P1, P2, …).
        pose: usize,
        /// The line of its first cycle.
        line: u64,
        /// Its measured AP, mm.
        ap_mm: f64,
        /// The largest predicted error at the pose, mm.
        largest_mm: f64,
        /// The standard error of the pose's barycentre, mm.
        standard_error_mm: f64,
        /// The draws of the check.
        draws: u64,
        /// What the measurements look like, when that is clear (" (the positions look like
        /// metres; they must be mm)").
        hint: String,
    },
    /// The certificate's own run failed.
    #[error(transparent)]
    Run(#[from] CertificateError),
}

/// The standard error of a pose's barycentre, mm: `√(Σ l_i² / (n (n − 1)))`, from l̄ and S_l
/// (`Σ l_i² = (n − 1) S_l² + n l̄²`).
pub fn barycentre_standard_error(f: &PoseFigures) -> f64 {
    let n = f.cycles as f64;
    let sum_l2 = (n - 1.0) * f.s_l_mm.powi(2) + n * f.l_mean_mm.powi(2);
    (sum_l2 / (n * (n - 1.0))).sqrt()
}

/// The problem of the certificate: the model's uncertainty at `poses`, against the calibrated
/// model, without the placement in the robot base frame.
pub(super) fn problem(
    model: &RobotModel,
    poses: &[Joints],
    frame: Placement,
    seed: u64,
) -> Result<Problem, CertificateError> {
    let problem = Problem::new(model.clone(), poses, &Reference::Calibrated, seed)
        .map_err(|e| CertificateError(e.to_string()))?;
    Ok(match frame {
        Placement::Known => problem.without_placement(),
        Placement::Identify => problem,
    })
}

/// The largest predicted error at each pose over the first `draws` draws of `seed`, mm.
///
/// # Errors
///
/// [`CertificateError`] when the problem cannot be built or evaluated.
pub fn largest_predicted(
    model: &RobotModel,
    poses: &[Joints],
    frame: Placement,
    draws: u64,
    seed: u64,
) -> Result<Vec<f64>, CertificateError> {
    largest_with_progress(model, poses, frame, draws, seed, &ProgressHook::none())
}

/// [`largest_predicted`], telling `progress` the draws done (label `checking the cycles`).
fn largest_with_progress(
    model: &RobotModel,
    poses: &[Joints],
    frame: Placement,
    draws: u64,
    seed: u64,
    progress: &ProgressHook,
) -> Result<Vec<f64>, CertificateError> {
    let mut ev = CpuEvaluator::new(problem(model, poses, frame, seed)?);
    let m = poses.len();
    let mut largest = vec![0.0_f64; m];
    let (mut w, mut e) = (vec![0.0; CHUNK], vec![0.0; CHUNK * m]);
    let mut first = 0;
    while first < draws {
        progress.report(CHECKING, first, draws);
        let n = (draws - first).min(CHUNK as u64) as usize;
        ev.evaluate(first, &mut w[..n], Some(&mut e[..n * m]))
            .map_err(|e| CertificateError(e.to_string()))?;
        for row in e[..n * m].chunks_exact(m) {
            for (l, v) in largest.iter_mut().zip(row) {
                *l = l.max(*v);
            }
        }
        first += n as u64;
    }
    Ok(largest)
}

/// The certificate `Pr[AP_j ≤ spec]` of `model` at the poses of the measured `figures` (see
/// [`super::certificate`]), given only when the measurements do not contradict the model: every
/// pose's measured AP, less [`CHECK_STANDARD_ERRORS`] standard errors of its barycentre, must
/// lie within the largest of the model's predicted errors there (over `min(draws,`
/// [`CHECK_DRAWS`]`)` draws of `seed`).
///
/// # Errors
///
/// [`CertifyError::NoUncertainty`] for a model whose every σ is 0,
/// [`CertifyError::Contradiction`] naming the first pose whose measured AP lies beyond the
/// model's predicted errors, [`CertifyError::Run`] when a run fails.
pub fn certify(
    model: &RobotModel,
    figures: &[PoseFigures],
    spec_mm: f64,
    frame: Placement,
    draws: u64,
    seed: u64,
) -> Result<Certificate, CertifyError> {
    certify_with_progress(
        model,
        figures,
        spec_mm,
        frame,
        draws,
        seed,
        &ProgressHook::none(),
    )
}

/// [`certify`], telling `progress` the draws done of all it evaluates: the check's
/// `min(draws, `[`CHECK_DRAWS`]`)` (label `checking the cycles`), then the certificate's
/// `draws` (label `certificate`), one count from 0 to their sum.
///
/// # Errors
///
/// As [`certify`].
pub fn certify_with_progress(
    model: &RobotModel,
    figures: &[PoseFigures],
    spec_mm: f64,
    frame: Placement,
    draws: u64,
    seed: u64,
    progress: &ProgressHook,
) -> Result<Certificate, CertifyError> {
    if model.no_uncertainty_note().is_some() {
        return Err(CertifyError::NoUncertainty {
            model: model.name.clone(),
        });
    }
    let poses: Vec<Joints> = figures.iter().map(|f| f.q_deg).collect();
    let check = draws.clamp(1, CHECK_DRAWS);
    let total = check.saturating_add(draws);
    let hook = progress.clone();
    let checking = ProgressHook::new(move |label: &str, done, _| hook.report(label, done, total));
    let largest = largest_with_progress(model, &poses, frame, check, seed, &checking)?;
    for (f, &top) in figures.iter().zip(&largest) {
        let se = barycentre_standard_error(f);
        if f.ap_mm - CHECK_STANDARD_ERRORS * se > top {
            return Err(CertifyError::Contradiction {
                pose: f.pose,
                line: f.first_line,
                ap_mm: f.ap_mm,
                largest_mm: top,
                standard_error_mm: se,
                draws: check,
                hint: units_hint(f),
            });
        }
    }
    let hook = progress.clone();
    let certifying =
        ProgressHook::new(move |label: &str, done, _| hook.report(label, check + done, total));
    let c = certificate_with_progress(model, &poses, spec_mm, frame, draws, seed, &certifying)?;
    progress.report("done", total, total);
    Ok(c)
}

/// The label of the consistency check's progress.
const CHECKING: &str = "checking the cycles";

/// " (the positions look like metres; they must be mm)" when the barycentre in mm, read as
/// metres, lies within 1 % of the command's distance of the command; else empty.
fn units_hint(f: &PoseFigures) -> String {
    let scaled: f64 = (0..3)
        .map(|k| (1000.0 * f.barycentre_mm[k] - f.command_mm[k]).powi(2))
        .sum::<f64>()
        .sqrt();
    let size = f.command_mm.iter().map(|v| v * v).sum::<f64>().sqrt();
    if size > 0.0 && scaled < 0.01 * size {
        " (the positions look like metres; they must be mm)".into()
    } else {
        String::new()
    }
}
