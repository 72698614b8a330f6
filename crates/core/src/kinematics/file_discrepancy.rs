//! The `[discrepancy]` section a model file is written with (read by serde with the rest of the
//! file, checked in `file.rs`).

use super::file::fnum;
use std::fmt::Write as _;

/// The `[discrepancy]` section of a model file, or the same term as the table `section`.
pub(super) fn write_discrepancy(
    s: &mut String,
    d: &crate::discrepancy::Discrepancy,
    section: &str,
) {
    let _ = writeln!(
        s,
        "\n# What the geometric model does not explain (docs/METHOD.md §18): every analysis draws,\n\
         # at every test point, a deviation whose length is one of these standardised residual\n\
         # norms (mm) times sqrt(robot_share), in a uniformly random direction; each draw takes\n\
         # that share from its posterior given these norms (§18.3), the same at all its points.\n\
         # robot_share: the part of the residuals' mean square that is the robot's, not tracker noise."
    );
    let _ = writeln!(
        s,
        "[{section}]\nrobot_share = {}\nnoise = \"{}\"",
        fnum(d.robot_share),
        d.noise.as_str()
    );
    if let Some(sg) = d.noise_sigma_mm {
        let _ = writeln!(s, "noise_sigma_mm = {}", fnum(sg));
    }
    let _ = writeln!(s, "residual_norms = [");
    for chunk in d.residual_norms.chunks(8) {
        let row: Vec<String> = chunk.iter().map(|v| fnum(*v)).collect();
        let _ = writeln!(s, "  {},", row.join(", "));
    }
    let _ = writeln!(s, "]");
    if let Some(c) = &d.compensation {
        write_compensation(s, c, section);
    }
}

/// The `[discrepancy.compensation]` table: a Gaussian process's mean, added to every predicted
/// position.
fn write_compensation(s: &mut String, c: &crate::discrepancy::Compensation, section: &str) {
    let join = |v: &[f64]| v.iter().map(|x| fnum(*x)).collect::<Vec<_>>().join(", ");
    let _ = writeln!(
        s,
        "\n# Compensation (docs/METHOD.md §18.1): the predicted position gets, in the base frame,\n\
         # sum_i k(q, q_i) * weights_i with k = signal_sigma_mm^2 * exp(-0.5 * sum_d ((q_d - q_id) / length_scales_deg_d)^2)\n\
         # over the configurations below (degrees). residual_norms above are what it leaves, at the\n\
         # predictive sigma loo_sigma_mm; at a task configuration they are drawn times its own\n\
         # predictive sigma (white_sigma_mm included) over loo_sigma_mm."
    );
    let _ = writeln!(
        s,
        "[{section}.compensation]\nlength_scales_deg = [{}]\nsignal_sigma_mm = {}\nwhite_sigma_mm = {}\nloo_rms_geometric_mm = {}\nloo_rms_compensated_mm = {}\nloo_sigma_mm = {}",
        join(&c.length_scales_deg),
        fnum(c.signal_sigma_mm),
        fnum(c.white_sigma_mm),
        fnum(c.loo_rms_geometric_mm),
        fnum(c.loo_rms_compensated_mm),
        fnum(c.loo_sigma_mm)
    );
    let _ = writeln!(s, "configurations_deg = [");
    for row in &c.configurations_deg {
        let _ = writeln!(s, "  [{}],", join(row));
    }
    let _ = writeln!(s, "]\nweights = [");
    for w in &c.weights {
        let _ = writeln!(s, "  [{}],", join(w));
    }
    let _ = writeln!(s, "]");
}
