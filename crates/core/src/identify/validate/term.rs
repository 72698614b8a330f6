//! The discrepancy term estimated again from a validation's errors: poses the identification did
//! not see, spread where the model will be used.
//!
//! A fit's term is drawn from its own standardised residuals (docs/METHOD.md §18): honest for a
//! new pose like the fitted ones. Data that do not sample the workspace (circle-point sweeps: one
//! joint at a time over part of its range) leave errors their residuals do not show, at poses
//! elsewhere. The errors a model makes at measured poses it was not fitted to are what a new pose
//! shows, with nothing left out: the term drawn from their norms (a bootstrap, as a fit's) keeps
//! the reliability true at poses like them. The norms hold the parameters' own part of the error
//! too, which the analyses also draw: conservative by that part (on a model whose errors there
//! are mostly what its data could not show, a small one).

use super::{point_errors_in, Measurement};
use crate::discrepancy::{Discrepancy, NoiseSource, MIN_RESIDUALS};
use crate::identify::{IdentifyError, Placement};
use crate::kinematics::RobotModel;

/// A model whose discrepancy term was estimated again from held-out errors.
#[derive(Clone, Debug, PartialEq)]
pub struct HeldOutTerm {
    /// The model with the new term (everything else as it was).
    pub model: RobotModel,
    /// Poses whose errors the term is drawn from.
    pub poses: usize,
    /// RMS of those errors, mm (each over the compensation's predictive σ there, times its
    /// reference, when the model has a compensation).
    pub rms_mm: f64,
    /// RMS of the term's norms the model had, mm (`None`: it had none).
    pub previous_rms_mm: Option<f64>,
}

impl HeldOutTerm {
    /// One line for the terminal.
    pub fn sentence(&self) -> String {
        let was = match self.previous_rms_mm {
            Some(p) => format!("its own residuals' {p:.4} mm"),
            None => "no term".into(),
        };
        format!(
            "discrepancy term from these {} poses' errors: RMS {:.4} mm (the model had {was}); every analysis of the written model draws it\n",
            self.poses, self.rms_mm
        )
    }

    /// The model file of [`Self::model`]: its TOML, then the `[provenance]` of the file it came
    /// from (`model_text`) with the validation data recorded as the term's source (`data_file`,
    /// the SHA-256 of its bytes `data`).
    pub fn file_text(&self, model_text: &str, data_file: &str, data: &[u8]) -> String {
        let mut s = self.model.to_toml();
        let mut table: toml::Table = model_text.parse().unwrap_or_default();
        let mut p = match table.remove("provenance") {
            Some(toml::Value::Table(t)) => t,
            _ => toml::Table::new(),
        };
        p.insert("discrepancy_data_file".into(), data_file.into());
        p.insert(
            "discrepancy_data_sha256".into(),
            crate::digest::sha256_hex(data).into(),
        );
        p.insert("discrepancy_poses".into(), (self.poses as i64).into());
        let mut only = toml::Table::new();
        only.insert("provenance".into(), toml::Value::Table(p));
        s.push_str("\n# Where this model came from (read and ignored by the model reader)\n");
        s.push_str(&toml::to_string(&only).unwrap_or_default());
        s
    }
}

/// `model` with its discrepancy term drawn from its errors at `measurements` (in `frame`): the
/// norms of measured minus predicted (the prediction compensated when the model is), each scaled
/// by the compensation's reference σ over its predictive σ at the pose (as the analyses scale
/// them back), with the noise the model's term states.
///
/// # Errors
///
/// [`IdentifyError::NoData`] with fewer than [`MIN_RESIDUALS`] measurements.
pub fn held_out_term(
    model: &RobotModel,
    measurements: &[Measurement],
    frame: Placement,
) -> Result<HeldOutTerm, IdentifyError> {
    let n = measurements.len();
    if n < MIN_RESIDUALS {
        return Err(IdentifyError::NoData(format!(
            "at least {MIN_RESIDUALS} poses are needed, got {n}"
        )));
    }
    // A model with a term for unknown sides predicts the poses whose sides are not all
    // recorded at the centre (point_errors_in): their errors renew that term, the others the
    // model's own.
    let has_centre = model.sides_unknown_term().is_some();
    let at_centre: Vec<bool> = (measurements.iter())
        .map(|m| has_centre && !m.sides.is_some_and(|s| model.sides_complete(&s)))
        .collect();
    let mut norms = point_errors_in(model, measurements, frame);
    let old = model.discrepancy.as_ref();
    let compensation = old.and_then(|d| d.compensation.clone());
    if let Some(c) = &compensation {
        // The compensation is a function of the commanded angles (as the prediction adds it).
        let q: Vec<Vec<f64>> = measurements.iter().map(|m| m.q_deg.to_vec()).collect();
        for ((r, s), centre) in norms
            .iter_mut()
            .zip(c.predictive_sigmas(&q))
            .zip(&at_centre)
        {
            if !centre {
                *r *= c.loo_sigma_mm / s.max(1e-300);
            }
        }
    }
    if let Some(i) = norms.iter().position(|r| !r.is_finite()) {
        return Err(IdentifyError::NoData(format!(
            "line {}: the model's error there is not a number",
            measurements[i].line
        )));
    }
    let rms = |v: &[f64]| (v.iter().map(|r| r * r).sum::<f64>() / v.len().max(1) as f64).sqrt();
    let (noise, sigma) = old.map_or((NoiseSource::Unknown, None), |d| {
        (d.noise, d.noise_sigma_mm)
    });
    let part = |centre: bool| -> Vec<f64> {
        (norms.iter().zip(&at_centre))
            .filter(|(_, &c)| c == centre)
            .map(|(r, _)| *r)
            .collect()
    };
    let (sided, centred) = (part(false), part(true));
    for (v, which) in [
        (&sided, "with every side recorded"),
        (
            &centred,
            "without every side recorded (predicted at the centre of the backlash's gaps)",
        ),
    ] {
        if !v.is_empty() && v.len() < MIN_RESIDUALS {
            return Err(IdentifyError::NoData(format!(
                "{} poses {which}: at least {MIN_RESIDUALS} are needed for their term",
                v.len()
            )));
        }
    }
    let mut out = model.clone();
    let mut previous = old.map(|d| rms(&d.residual_norms));
    if !sided.is_empty() {
        out.discrepancy = Some(Discrepancy::from_norms(&sided, noise, sigma, compensation));
    }
    let backlash = out.joint_errors.as_mut().and_then(|e| e.backlash.as_mut());
    if let Some(b) = backlash.filter(|_| !centred.is_empty()) {
        let was = b.sides_unknown.as_ref();
        if sided.is_empty() {
            previous = was.map(|d| rms(&d.residual_norms));
        }
        let (noise, sigma) = was.map_or((noise, sigma), |d| (d.noise, d.noise_sigma_mm));
        b.sides_unknown = Some(Discrepancy::from_norms(&centred, noise, sigma, None));
    }
    Ok(HeldOutTerm {
        model: out,
        poses: n,
        rms_mm: rms(&norms),
        previous_rms_mm: previous,
    })
}
