//! The terminal text of a whole-chain fit ([`super::chain::ChainReport`]).

use super::chain::{ChainReport, Placement, UncertaintyMethod};
use std::fmt::Write;

/// The frame line: which frame the data and the model are in.
pub fn frame_label(p: Placement) -> &'static str {
    match p {
        Placement::Identify => "measurement frame (placement identified)",
        Placement::Known => "robot base frame (placement known)",
    }
}

/// A few lines: points, residuals, noise, identifiability and the covariance's source.
pub fn render_chain_summary(c: &ChainReport) -> String {
    let mut s = String::new();
    let a = &c.identifiability;
    let _ = writeln!(
        s,
        "Whole-chain fit: {} points in the {}, {} quantities identified",
        c.points,
        frame_label(c.frame),
        a.parameters
    );
    let _ = writeln!(
        s,
        "  residuals: rms {:.4} mm, max {:.4} mm",
        c.rms_residual_mm, c.max_residual_mm
    );
    render_targets(&mut s, c);
    if let Some(d) = &c.drift {
        let _ = writeln!(s, "  {}", d.sentence());
    }
    match (c.noise.sigma_mm, c.noise.p_value) {
        (Some(sig), _) => {
            let _ = writeln!(
                s,
                "  noise: {}: σ = {:.4} mm per coordinate ({} degrees of freedom)",
                c.noise.source, sig, c.noise.dof
            );
        }
        (None, Some(p)) => {
            let verdict = if p < 1e-3 {
                "residuals too large for it"
            } else if p > 1.0 - 1e-3 {
                "residuals too small for it"
            } else {
                "consistent"
            };
            let _ = writeln!(
                s,
                "  noise: {}: χ² = {:.1} for {} degrees of freedom (p = {:.3}): {verdict}",
                c.noise.source, c.noise.chi2, c.noise.dof, p
            );
        }
        (None, None) => {}
    }
    render_lack_of_fit(&mut s, &c.lack_of_fit);
    match &c.beyond_geometry {
        Some(b) => render_beyond_geometry(&mut s, b),
        None if c.joint_error_fit == super::chain::JointErrorFit::Auto => {
            let _ = writeln!(
                s,
                "  beyond geometry: not checked: the geometric fit shows no lack of fit against the stated noise (joint compliance and gear harmonics are fitted when it does, or when asked for)"
            );
        }
        None => {}
    }
    let weak = if a.condition_number > super::identifiability::WEAK_CONDITION
        && a.condition_number <= super::identifiability::CONDITION_LIMIT
    {
        " (weak: above 100)"
    } else {
        ""
    };
    let _ = writeln!(
        s,
        "  identifiability: rank {} of {}, condition number {:.1}{weak}, O1 {:.4}, O3 {:.4}; weakest: {}",
        a.rank, a.parameters, a.condition_number, a.o1, a.o3, a.weakest
    );
    for n in &a.null_directions {
        let _ = writeln!(
            s,
            "  not identifiable: {} (relative singular value {:.1e}) → {} held at nominal with its prior σ{}",
            n.combination,
            n.relative_singular_value,
            n.fixed,
            c.parameters
                .iter()
                .find(|p| p.name == n.fixed)
                .map_or(String::new(), |p| format!(" ({:.4} {})", p.sigma, p.unit))
        );
    }
    if !a.fixed_by_user.is_empty() {
        let _ = writeln!(s, "  fixed by request: {}", a.fixed_by_user.join(", "));
    }
    if !a.correlated.is_empty() {
        let pairs: Vec<String> = a
            .correlated
            .iter()
            .take(8)
            .map(|c| format!("{}/{} {:+.3}", c.a, c.b, c.rho))
            .collect();
        let more = a.correlated.len().saturating_sub(8);
        let _ = writeln!(
            s,
            "  correlated (|ρ| > 0.9): {}{}",
            pairs.join(", "),
            if more > 0 {
                format!(" and {more} more")
            } else {
                String::new()
            }
        );
    }
    if let Some(m) = &c.monte_carlo {
        let _ = writeln!(
            s,
            "  Monte Carlo check ({} re-identifications): σ_MC / σ_linearised min {:.3}, median {:.3}, max {:.3}",
            m.draws, m.ratio_min, m.ratio_median, m.ratio_max
        );
    }
    let _ = writeln!(
        s,
        "  covariance: {}",
        match c.covariance_from {
            UncertaintyMethod::Linearised => "s²(JᵀWJ)⁻¹ at the solution".to_string(),
            UncertaintyMethod::MonteCarlo { draws } =>
                format!("sample covariance of {draws} Monte Carlo re-identifications"),
        }
    );
    s
}

/// The full text: the summary and every input with its value, σ, nominal value and status.
pub fn render_chain_report(c: &ChainReport) -> String {
    let mut s = render_chain_summary(c);
    let _ = writeln!(
        s,
        "\n{:<11} {:>16} {:>12} {:>16} {:>5}  status",
        "parameter", "value", "σ", "nominal", "unit"
    );
    for r in &c.parameters {
        let _ = writeln!(
            s,
            "{:<11} {:>16.6} {:>12.6} {:>16.6} {:>5}  {}",
            r.name, r.value, r.sigma, r.nominal, r.unit, r.status
        );
    }
    s
}

/// The lack-of-fit lines: noise against what the model does not explain, the term, the
/// leave-one-out self-check.
/// Several targets per pose: which is the model's tool and where the others sit.
fn render_targets(s: &mut String, c: &ChainReport) {
    if c.targets.len() < 2 {
        return;
    }
    let _ = writeln!(
        s,
        "  targets: {} measured at each pose, one chain and placement; '{}' is the model's tool (tool_x…z), the others' offsets are not kept in the model:",
        c.targets.len(),
        c.targets[0]
    );
    for (k, label) in c.targets.iter().enumerate().skip(1) {
        let rows: Vec<&super::chain::ParameterRow> = ["x", "y", "z"]
            .iter()
            .filter_map(|a| {
                let name = format!("target{}_{a}", k + 1);
                c.parameters.iter().find(|p| p.name == name)
            })
            .collect();
        let xyz: Vec<String> = rows
            .iter()
            .map(|p| format!("{:.4} ± {:.4}", p.value, p.sigma))
            .collect();
        let _ = writeln!(
            s,
            "    '{label}' (target{}): ({}) mm in the flange frame",
            k + 1,
            xyz.join(", ")
        );
    }
}

fn render_beyond_geometry(s: &mut String, b: &super::chain::BeyondGeometry) {
    let _ = writeln!(s, "  {}", b.sentence());
    let joints: Vec<String> = (0..b.harmonic_amplitudes_deg.len())
        .map(|j| {
            let [h1, h2] = b.harmonic_amplitudes_deg[j];
            let k = b.compliance_urad_per_nm[j].map_or(String::new(), |[k, sk]| {
                format!(", compliance {k:.2} ± {sk:.2} µrad/(N·m)")
            });
            format!(
                "J{}: harmonics {h1:.4}°/{h2:.4}°{k}, deflection RMS {:.4}°",
                j + 1,
                b.deflection_rms_deg[j]
            )
        })
        .collect();
    let _ = writeln!(s, "    {}", joints.join("; "));
    let _ = writeln!(s, "    {}", b.selection.sentence());
    if b.calibration_payloads_kg.iter().any(|&m| m != 0.0) {
        let _ = writeln!(
            s,
            "    payloads during the measurements: {} kg",
            b.calibration_payloads_kg
                .iter()
                .map(|m| crate::number::fmt_plain(*m))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    if let Some(k) = &b.backlash {
        let gaps: Vec<String> = k
            .gap_deg
            .iter()
            .enumerate()
            .map(|(j, [g, s])| format!("J{} {g:.4}° ± {s:.4}°", j + 1))
            .collect();
        let _ = writeln!(
            s,
            "    backlash (each joint's approach direction from {}): leave-one-out RMS {:.4} mm against {:.4} mm ({:+.0} %){}; gaps {}",
            if k.sides_given {
                "the data's s1..sn columns"
            } else {
                "the poses' order"
            },
            k.loo_rms_mm,
            b.loo_rms_extended_mm,
            100.0 * (k.loo_rms_mm / b.loo_rms_extended_mm - 1.0),
            match (k.predicts_better, b.kept) {
                (true, true) => ": the robot shows it, and the model carries the gaps (the geometry fitted to the angles corrected by each pose's side) and a second discrepancy term, of the prediction that does not know the sides (each joint at the centre of its gap): an analysis whose points give every side (s1..sn) turns each joint by its side, one that does not uses that term, which holds the hysteresis".to_string() + &match k.residual_rms_mm {
                    Some(r) => format!(" (residual RMS {:.4} mm at the centre against {:.4} mm with the sides)", r.centre, r.sided),
                    None => String::new(),
                },
                (true, false) => ": the robot shows it, but the model carries no joint errors (the discrepancy term holds it)".to_string(),
                _ => ": no gain worth the coefficients".to_string(),
            },
            gaps.join(", ")
        );
    }
    if b.sides_unchecked {
        let _ = writeln!(
            s,
            "    backlash: the data record the side each joint arrived from (s1..sn); the explicit check beyond geometry fits the gaps to them"
        );
    }
    if !b.undetermined.is_empty() {
        let _ = writeln!(
            s,
            "    not determined by these data: {}",
            b.undetermined.join("; ")
        );
    }
}

fn render_lack_of_fit(s: &mut String, l: &crate::discrepancy::LackOfFit) {
    let split = match (l.noise_sigma_mm, l.unexplained_rms_mm) {
        (Some(sig), Some(u)) => format!(
            "measurement noise σ {sig:.4} mm per coordinate ({:.4} mm 3-D), unexplained by the model {u:.4} mm{} ({:.0} % of the residual{})",
            sig * 3f64.sqrt(),
            l.unexplained_upper_mm
                .map_or(String::new(), |v| format!(", up to {v:.4} mm at 95 %")),
            100.0 * l.robot_share,
            if l.found == Some(true) { "" } else { ": no lack of fit found" }
        ),
        _ => "measurement noise unknown: noise and lack of fit cannot be told apart (state the tracker σ to split them)".to_string(),
    };
    let _ = writeln!(
        s,
        "  lack of fit: standardised residual RMS {:.4} mm; {split}",
        l.residual_rms_mm
    );
    let _ = writeln!(
        s,
        "  discrepancy term: {}",
        match &l.term {
            Some(t) if t.drawn() => t.describe() + "; every analysis draws it at each test point",
            Some(_) => "none drawn: the residuals agree with the stated noise (the model file keeps them for checks against measurements, which include the noise)".to_string(),
            None if l.points < crate::discrepancy::MIN_RESIDUALS => format!(
                "none: too few points ({} < {}) to estimate one",
                l.points,
                crate::discrepancy::MIN_RESIDUALS
            ),
            None => "none: the residuals agree with the stated noise".to_string(),
        }
    );
    if let Some(c) = &l.loo {
        let _ = writeln!(
            s,
            "  self-check (leave-one-out): the predicted 95 % error bound covers {:.1} % of left-out measurements ({:.1} % with the parameters' uncertainty alone); PIT of the maximum over {} random sets of 20 points: mean {:.2} (ideal 0.50), {:.0} % at or above 0.99",
            100.0 * c.coverage_95,
            100.0 * c.coverage_95_parameters_only,
            c.subsets,
            c.pit_max_mean,
            100.0 * c.pit_max_at_least_099
        );
    }
}
