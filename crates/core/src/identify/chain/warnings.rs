//! The warnings of a whole-chain fit: directions the data leave free, ill-conditioning,
//! residuals inconsistent with the stated noise or far above tracker noise, parameters far from
//! nominal.

use super::{NoiseReport, ParameterRow, Placement};
use crate::discrepancy::LackOfFit;
use crate::identify::identifiability::{advice, Identifiability, CONDITION_LIMIT};

/// The warnings of a chain fit: directions the data leave free, ill-conditioning, residuals
/// inconsistent with the stated noise, parameters far from nominal.
pub(super) fn chain_warnings(
    a: &Identifiability,
    noise: &NoiseReport,
    lack: &LackOfFit,
    rows: &[ParameterRow],
) -> Vec<String> {
    let mut w = Vec::new();
    if !a.null_directions.is_empty() {
        let fixed: Vec<&str> = a.null_directions.iter().map(|n| n.fixed.as_str()).collect();
        let first = &a.null_directions[0].combination;
        w.push(format!(
            "rank deficient: the data do not determine {} combination(s) of the parameters (first: {first}); held at nominal with their prior uncertainty, so the model is not fully identified: {}; {}",
            a.null_directions.len(),
            fixed.join(", "),
            advice(first, a)
        ));
    }
    if a.condition_number > CONDITION_LIMIT {
        w.push(format!(
            "ill-conditioned: condition number {:.3e} is above {CONDITION_LIMIT}; the data barely determine {}; {}",
            a.condition_number,
            a.weakest,
            advice(&a.weakest, a)
        ));
    }
    if let Some(p) = noise.p_value {
        let ratio = (noise.chi2 / noise.dof.max(1) as f64).sqrt();
        if lack.found == Some(true) {
            w.push(format!(
                "the residuals are {ratio:.2}× the stated noise (χ² = {:.1} for {} degrees of freedom, p = {p:.1e}): the geometric model leaves {:.4} mm RMS unexplained (or the stated σ is too small); {}",
                noise.chi2,
                noise.dof,
                lack.unexplained_rms_mm.unwrap_or(0.0),
                if lack.carried {
                    format!("the covariance is scaled by {:.2} (the residuals' mean square over the noise's) and the model carries a discrepancy term that every analysis draws", lack.covariance_scale)
                } else {
                    format!("the covariance is scaled by {:.2} (the residuals' mean square over the noise's); too few points for a discrepancy term, so reliability figures leave the lack of fit out", lack.covariance_scale)
                }
            ));
        } else if p > 1.0 - 1e-3 {
            w.push(format!(
                "the residuals are only {ratio:.2}× the stated noise (χ² = {:.1} for {} degrees of freedom): the stated σ looks too large, so the covariance is too wide",
                noise.chi2, noise.dof
            ));
        }
    }
    let far: Vec<String> = rows
        .iter()
        .filter(|r| r.status == "identified")
        .filter(|r| {
            !["base_", "tool_", "target"]
                .iter()
                .any(|p| r.name.starts_with(p))
        })
        .filter(|r| {
            let limit = if r.unit == "deg" {
                crate::identify::MAX_ANGLE_CHANGE_DEG
            } else {
                crate::identify::MAX_LENGTH_CHANGE_MM
            };
            (r.value - r.nominal).abs() > limit
        })
        .map(|r| format!("{} {:+.3} {}", r.name, r.value - r.nominal, r.unit))
        .collect();
    if !far.is_empty() {
        w.push(format!(
            "{} parameter(s) moved further from nominal than a calibration corrects ({} mm / {}°): {}; check the nominal model, the data's units and the warnings above",
            far.len(),
            crate::identify::MAX_LENGTH_CHANGE_MM,
            crate::identify::MAX_ANGLE_CHANGE_DEG,
            far.join(", ")
        ));
    }
    w
}

/// The warnings of a fit whose point residuals have RMS `rms` (mm): [`chain_warnings`], led by
/// one when `rms` is far above tracker noise (with what to check for data in `placement`).
pub(super) fn run_warnings(
    a: &Identifiability,
    noise: &NoiseReport,
    lack: &LackOfFit,
    rows: &[ParameterRow],
    rms: f64,
    placement: Placement,
) -> Vec<String> {
    let mut warnings = chain_warnings(a, noise, lack, rows);
    if rms > crate::identify::MAX_RMS_RESIDUAL_MM {
        warnings.insert(
            0,
            format!(
                "the RMS residual {rms:.4} mm is far above tracker noise ({} mm allowed): {}",
                crate::identify::MAX_RMS_RESIDUAL_MM,
                match placement {
                    Placement::Known => "are the data really in the robot base frame, with the nominal model's structure?",
                    Placement::Identify => "check the nominal model's structure, the target and the data",
                }
            ),
        );
    }
    warnings
}
