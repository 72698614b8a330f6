//! Can the data identify the parameters? The singular value decomposition of the column-scaled
//! identification Jacobian at the solution (docs/METHOD.md §2.5).
//!
//! Each column of the whitened Jacobian is divided by its norm, so the analysis does not depend
//! on units (mm against radians) and a parameter's scale is its own effect on the data. Then
//!
//! * a singular value below [`RANK_TOLERANCE`] × the largest is a direction the data do not
//!   determine at all (rank deficiency): the combination of parameters along it is reported by
//!   name, and the parameter with the largest share in it is fixed at its nominal value
//!   ([`fix_null_directions`]), one direction at a time, until the rest has full rank;
//! * the condition number κ = σ_max / σ_min of what remains says how unevenly the data determine
//!   the rest; above [`CONDITION_LIMIT`] it is a warning naming the weakest combination;
//! * the observability index O1 = (σ_1⋯σ_p)^{1/p} / √n (Borm and Menq; n measured points) and
//!   the smallest singular value O3 summarise the design for comparisons;
//! * every pair of parameters whose correlation (from the covariance) exceeds
//!   [`CORRELATION_LIMIT`] in magnitude is listed.
//!
//! Each warning says what to measure instead, from the joints whose parameters make up the weak
//! combination and the joint ranges the data actually cover.

use super::chain::Placement;
use super::chain_fit::{
    default_free, fit_input_name, input_joint, local_jacobian, ChainState, Observation,
};
use super::IdentifyError;
use crate::kinematics::{Layout, RobotModel, MAX_JOINTS, MIN_JOINTS};
use nalgebra::DMatrix;
use serde::Serialize;

/// Relative singular value below which a direction counts as not identified at all. A
/// central-difference Jacobian is accurate to ~1e-8 relative, so an exact redundancy shows up
/// near 1e-8; anything the data determine at all is far above 1e-6.
pub const RANK_TOLERANCE: f64 = 1e-6;

/// Condition number of the column-scaled Jacobian above which identification is flagged as
/// ill-conditioned. The weakest combination's standard uncertainty is κ times that of the best
/// determined one (in the scaled units), so κ says how much worse than the tracker's own noise the
/// worst direction is known. Schröer's rule for calibration designs is κ < 100 and robotkinecal's
/// field procedure accepts a tracker calibration up to 100–1000. Measured here (σ = 10 µm, target
/// 96 mm off the flange centre, TX60 / UR5e / IRB 2400 / KR 6): random poses within the limits give
/// κ = 16–40 from 30 poses on and 58–514 with 10; the simulator's circle-point sweeps (50 % of the
/// measuring ranges) 210; a target on the last (J6) axis κ ≈ 10⁵ at any pose count, mirrored data
/// (two columns swapped) 10⁵. The warning is at 1000, the upper end of the accepted range, so that
/// it marks data that cannot be trusted; the report calls 100–1000 "weak" ([`WEAK_CONDITION`]).
pub const CONDITION_LIMIT: f64 = 1000.0;

/// Condition number above which the report calls the design weak (Schröer's rule), without a
/// warning.
pub const WEAK_CONDITION: f64 = 100.0;

/// A joint whose commanded angle spans less than this in the data (degrees) counts as not moved.
pub const STILL_JOINT_DEG: f64 = 30.0;

/// Correlation magnitude above which a parameter pair is listed.
pub const CORRELATION_LIMIT: f64 = 0.9;

/// A combination of parameters the data do not determine.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct NullDirection {
    /// The combination, e.g. `d2 − 0.98 d3 + 0.21 a2` (coefficients in column-scaled units).
    pub combination: String,
    /// Relative singular value of the direction.
    pub relative_singular_value: f64,
    /// The parameter fixed at its nominal value because of it.
    pub fixed: String,
}

/// A parameter pair with a strong correlation.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Correlation {
    /// First parameter.
    pub a: String,
    /// Second parameter.
    pub b: String,
    /// Correlation coefficient.
    pub rho: f64,
}

/// The identifiability of a fit.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Identifiability {
    /// Number of measured points.
    pub points: usize,
    /// Scalar equations (3 per point).
    pub equations: usize,
    /// Parameters the fit adjusted (after fixing null directions).
    pub parameters: usize,
    /// Numerical rank of the scaled Jacobian of those parameters.
    pub rank: usize,
    /// κ = σ_max / σ_min of the scaled Jacobian.
    pub condition_number: f64,
    /// Observability index O1 = (σ_1⋯σ_p)^{1/p} / √n.
    pub o1: f64,
    /// Smallest singular value of the scaled Jacobian (O3).
    pub o3: f64,
    /// Singular values of the scaled Jacobian, largest first.
    pub singular_values: Vec<f64>,
    /// The weakest determined combination of the parameters.
    pub weakest: String,
    /// Directions the data did not determine, with the parameter fixed for each.
    pub null_directions: Vec<NullDirection>,
    /// Parameters the user fixed by name.
    pub fixed_by_user: Vec<String>,
    /// Pairs with |ρ| above [`CORRELATION_LIMIT`].
    pub correlated: Vec<Correlation>,
    /// Span of each joint's commanded angle in the data, degrees, one per joint.
    pub joint_spans_deg: Vec<f64>,
    /// Distance of the target from the last joint's axis (J6's of a six-axis arm), mm: near 0
    /// its phase about that axis is invisible.
    pub target_axis_distance_mm: f64,
}

/// The SVD of the column-scaled Jacobian: singular values (largest first) and the right singular
/// vectors as columns in the same order, plus the column norms.
pub struct ScaledSvd {
    /// Singular values, largest first.
    pub values: Vec<f64>,
    /// Right singular vectors (column k belongs to `values[k]`), in scaled coordinates.
    pub vectors: DMatrix<f64>,
    /// Column norms of the unscaled Jacobian.
    pub norms: Vec<f64>,
}

/// Column-scales `j` and decomposes it.
pub fn scaled_svd(j: &DMatrix<f64>) -> ScaledSvd {
    scaled_svd_grouped(j, &[])
}

/// The columns of the placement's translation and, when all three are free, of its rotation
/// ([`crate::identify::chain_fit::rotation_free`]): each triple is scaled by one factor, so
/// that turning the tracker frame (which mixes a triple's columns orthogonally) changes no
/// singular value.
fn placement_groups(state: &ChainState, free: &[usize]) -> Vec<Vec<usize>> {
    let space = state.space();
    let Some(r) = space.range(crate::kinematics::Block::Placement) else {
        return Vec::new();
    };
    let cols = |inputs: std::ops::Range<usize>| -> Vec<usize> {
        inputs
            .filter_map(|i| free.iter().position(|&f| f == i))
            .collect()
    };
    let mut groups = vec![cols(r.start..r.start + 3)];
    if crate::identify::chain_fit::rotation_free(space, free) {
        groups.push(cols(r.start + 3..r.end));
    }
    groups.retain(|g| g.len() == 3);
    groups
}

/// [`scaled_svd`] with the columns of each of `groups` scaled by their RMS norm together.
pub fn scaled_svd_grouped(j: &DMatrix<f64>, groups: &[Vec<usize>]) -> ScaledSvd {
    let norms: Vec<f64> = (0..j.ncols()).map(|c| j.column(c).norm()).collect();
    let mut scale = norms.clone();
    for g in groups {
        let rms = (g.iter().map(|&c| norms[c] * norms[c]).sum::<f64>() / g.len() as f64).sqrt();
        for &c in g {
            scale[c] = rms;
        }
    }
    let mut s = j.clone();
    for (c, &n) in scale.iter().enumerate() {
        if n > 0.0 {
            s.column_mut(c).scale_mut(1.0 / n);
        }
    }
    if s.ncols() == 0 {
        // Nothing free (every parameter fixed): no directions, and nalgebra's eigen-decomposition
        // refuses an empty matrix.
        return ScaledSvd {
            values: Vec::new(),
            vectors: DMatrix::zeros(0, 0),
            norms,
        };
    }
    // Jᵀ J's eigen-decomposition is enough (p ≤ 5n + 9, 44 at most) and avoids an m × p SVD of
    // a tall matrix.
    let eig = (s.transpose() * &s).symmetric_eigen();
    let mut order: Vec<usize> = (0..eig.eigenvalues.len()).collect();
    order.sort_by(|&a, &b| eig.eigenvalues[b].total_cmp(&eig.eigenvalues[a]));
    let values = order
        .iter()
        .map(|&k| eig.eigenvalues[k].max(0.0).sqrt())
        .collect();
    let vectors = DMatrix::from_fn(s.ncols(), order.len(), |r, c| {
        eig.eigenvectors[(r, order[c])]
    });
    ScaledSvd {
        values,
        vectors,
        norms,
    }
}

/// A direction (scaled coordinates over `free`, fit inputs of a chain of layout `lay`) written as
/// a named combination: the terms of at least a tenth of the largest, largest first, with the
/// largest's coefficient 1.
pub fn combination(lay: Layout, v: &[f64], free: &[usize]) -> String {
    let max = v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    if max == 0.0 {
        return String::new();
    }
    let mut terms: Vec<(usize, f64)> = v
        .iter()
        .enumerate()
        .filter(|(_, x)| x.abs() >= 0.1 * max)
        .map(|(k, &x)| (k, x))
        .collect();
    terms.sort_by(|a, b| b.1.abs().total_cmp(&a.1.abs()));
    let sign = terms[0].1.signum();
    let mut s = String::new();
    for (n, (k, x)) in terms.iter().enumerate() {
        let c = sign * x / max;
        let name = fit_input_name(lay.measured(), free[*k]);
        if n == 0 {
            s.push_str(&name);
        } else {
            let op = if c < 0.0 { '−' } else { '+' };
            if (c.abs() - 1.0).abs() < 0.005 {
                s.push_str(&format!(" {op} {name}"));
            } else {
                s.push_str(&format!(" {op} {:.2} {name}", c.abs()));
            }
        }
    }
    s
}

/// Refuses a request (`fix`, by name, as [`super::ChainOptions::fix`]) that holds every input
/// the whole-chain fit of `nominal` would move (with the placement when `placement` is
/// [`Placement::Identify`]): nothing would be identified, and the "identified" model would be
/// the nominal one with no uncertainty. Names that are not inputs are left to the fit to refuse.
///
/// # Errors
///
/// [`IdentifyError::NoData`] when every free input is named.
pub fn check_something_free(
    nominal: &RobotModel,
    placement: Placement,
    fix: &[String],
) -> Result<(), IdentifyError> {
    if fix.is_empty() || !(MIN_JOINTS..=MAX_JOINTS).contains(&nominal.joints()) {
        return Ok(());
    }
    let space = nominal.layout().measured();
    let named: Vec<usize> = fix
        .iter()
        .filter_map(|n| space.find(&n.trim().to_ascii_lowercase()))
        .collect();
    let free = default_free(&nominal.fixed, placement == Placement::Identify);
    if free.iter().all(|i| named.contains(i)) {
        return Err(IdentifyError::NoData(format!(
            "every one of the {} parameters the fit would identify is fixed by request: nothing is left to identify; leave at least one free",
            free.len()
        )));
    }
    Ok(())
}

/// Fixes, one at a time, the parameter with the largest share in each direction the data leave
/// free (relative singular value below [`RANK_TOLERANCE`]): removes it from `free`, sets it to
/// `nominal`'s value in `state`, and returns the directions found. Also removes parameters
/// whose column is zero (the data do not depend on them at all).
pub fn fix_null_directions(
    obs: &[Observation],
    state: &mut ChainState,
    nominal: &ChainState,
    free: &mut Vec<usize>,
) -> Vec<NullDirection> {
    let lay = state.layout();
    let mut found = Vec::new();
    while !free.is_empty() {
        let j = local_jacobian(obs, state, free);
        let svd = scaled_svd_grouped(&j, &placement_groups(state, free));
        if let Some(c) = svd.norms.iter().position(|&n| n == 0.0) {
            found.push(NullDirection {
                combination: fit_input_name(lay.measured(), free[c]),
                relative_singular_value: 0.0,
                fixed: fit_input_name(lay.measured(), free[c]),
            });
            state.set(free[c], nominal.get(free[c]));
            free.remove(c);
            continue;
        }
        let n = svd.values.len();
        let rel = svd.values[n - 1] / svd.values[0];
        // More unknowns than equations: the smallest values are exact zeros of Jᵀ J.
        if rel >= RANK_TOLERANCE && free.len() <= j.nrows() {
            break;
        }
        let v: Vec<f64> = svd.vectors.column(n - 1).iter().copied().collect();
        let (k, _) = v
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
            .unwrap_or((0, &0.0));
        found.push(NullDirection {
            combination: combination(lay, &v, free),
            relative_singular_value: rel,
            fixed: fit_input_name(lay.measured(), free[k]),
        });
        state.set(free[k], nominal.get(free[k]));
        free.remove(k);
    }
    found
}

/// Measures the identifiability of `free` at `state`, the placement's rotation as small
/// rotations about the measurement frame's axes when all three are free
/// ([`local_jacobian`]: the same figures however the tracker frame is turned); `covariance`
/// (over `free` in those coordinates, any units) gives the correlations.
pub fn analyse(
    obs: &[Observation],
    state: &ChainState,
    free: &[usize],
    covariance: &DMatrix<f64>,
    null_directions: Vec<NullDirection>,
    fixed_by_user: Vec<String>,
) -> Identifiability {
    let lay = state.layout();
    let j = local_jacobian(obs, state, free);
    let svd = scaled_svd_grouped(&j, &placement_groups(state, free));
    let p = svd.values.len();
    let max = svd.values.first().copied().unwrap_or(0.0);
    let min = svd.values.last().copied().unwrap_or(0.0);
    let rank = svd
        .values
        .iter()
        .filter(|&&s| s > RANK_TOLERANCE * max)
        .count();
    let o1 = if p > 0 && min > 0.0 {
        (svd.values.iter().map(|s| s.ln()).sum::<f64>() / p as f64).exp()
            / (obs.len() as f64).sqrt()
    } else {
        0.0
    };
    let weakest = if p > 0 {
        let v: Vec<f64> = svd.vectors.column(p - 1).iter().copied().collect();
        combination(lay, &v, free)
    } else {
        String::new()
    };
    let mut correlated = Vec::new();
    for a in 0..free.len() {
        for b in a + 1..free.len() {
            let d = (covariance[(a, a)] * covariance[(b, b)]).sqrt();
            if d > 0.0 {
                let rho = covariance[(a, b)] / d;
                if rho.abs() > CORRELATION_LIMIT {
                    correlated.push(Correlation {
                        a: fit_input_name(lay.measured(), free[a]),
                        b: fit_input_name(lay.measured(), free[b]),
                        rho,
                    });
                }
            }
        }
    }
    correlated.sort_by(|x, y| y.rho.abs().total_cmp(&x.rho.abs()));
    let mut spans = vec![0.0; lay.joints()];
    for (j, span) in spans.iter_mut().enumerate() {
        let (lo, hi) = obs
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), o| {
                (l.min(o.q[j]), h.max(o.q[j]))
            });
        *span = if obs.is_empty() {
            0.0
        } else {
            (hi - lo).to_degrees()
        };
    }
    Identifiability {
        points: obs.len(),
        equations: 3 * obs.len(),
        parameters: p,
        rank,
        condition_number: if min > 0.0 { max / min } else { f64::INFINITY },
        o1,
        o3: min,
        singular_values: svd.values,
        weakest,
        null_directions,
        fixed_by_user,
        correlated,
        joint_spans_deg: spans,
        target_axis_distance_mm: target_axis_distance(state),
    }
}

/// Distance of the target from the last joint's axis (frame n − 1's z axis; J6's, frame 5's, of a
/// six-axis arm), mm.
pub fn target_axis_distance(state: &ChainState) -> f64 {
    let n = state.layout().joints();
    let p = &state.params[5 * (n - 1)..5 * n];
    // The last joint's own transform applied to the target, in frame n − 1: q_n and θ_n only
    // turn it about z.
    let t = crate::kinematics::joint_transform(0.0, p[1], p[2], p[3], p[4], 0.0);
    let v: [f64; 3] =
        std::array::from_fn(|r| (0..3).map(|c| t[r][c] * state.tool[c]).sum::<f64>() + t[r][3]);
    (v[0] * v[0] + v[1] * v[1]).sqrt()
}

/// Joints (1-based) whose parameters appear in a named combination of the fit inputs of a chain
/// of layout `lay`, and whether the placement does.
fn joints_in(lay: Layout, combination: &str) -> (Vec<usize>, bool) {
    let mut joints = Vec::new();
    let mut base = false;
    for term in combination.split([' ', '+', '−']).filter(|t| !t.is_empty()) {
        let space = lay.measured();
        if let Some(i) = space.find(&term.trim().to_ascii_lowercase()) {
            match input_joint(space, i) {
                Some(j) => {
                    if !joints.contains(&j) {
                        joints.push(j);
                    }
                }
                None => base = true,
            }
        }
    }
    joints.sort_unstable();
    (joints, base)
}

/// What to measure instead when `combination` is poorly determined.
pub fn advice(combination: &str, a: &Identifiability) -> String {
    if a.equations < a.parameters + null_count(a) {
        return format!(
            "measure more poses: {} points give {} equations for {} quantities; 30–60 poses spread over the joint ranges are usual",
            a.points,
            a.equations,
            a.parameters + null_count(a)
        );
    }
    // One span per joint of the chain.
    let n = a.joint_spans_deg.len();
    let lay = Layout::new(n.clamp(MIN_JOINTS, MAX_JOINTS));
    // A joint that barely moved explains most weak directions by itself.
    let still: Vec<String> = (0..n)
        .filter(|&j| a.joint_spans_deg[j] < STILL_JOINT_DEG)
        .map(|j| format!("J{} {:.1}°", j + 1, a.joint_spans_deg[j]))
        .collect();
    if !still.is_empty() {
        return format!(
            "move every joint over a wide range: some barely moved (ranges in the data: {})",
            still.join(", ")
        );
    }
    let (joints, base) = joints_in(lay, combination);
    let tool_fixed = a
        .null_directions
        .iter()
        .map(|n| n.fixed.as_str())
        .chain(a.fixed_by_user.iter().map(String::as_str))
        .any(|n| n.starts_with("tool_"));
    if !tool_fixed && joints.iter().any(|&j| j + 1 >= n) && a.target_axis_distance_mm < 10.0 {
        return format!(
            "mount the target away from the J{n} axis (it is {:.1} mm from it; at 50 mm or more J{n}'s rotation shows in the data)",
            a.target_axis_distance_mm
        );
    }
    let narrow: Vec<String> = joints
        .iter()
        .filter(|&&j| a.joint_spans_deg[j - 1] < 90.0)
        .map(|&j| format!("J{j} {:.1}°", a.joint_spans_deg[j - 1]))
        .collect();
    let mut s = String::new();
    if !joints.is_empty() {
        let list = joints
            .iter()
            .map(|j| j.to_string())
            .collect::<Vec<_>>()
            .join(", ");
        s.push_str(&format!("move joint(s) {list} more widely"));
        if !narrow.is_empty() {
            s.push_str(&format!(" (ranges in the data: {})", narrow.join(", ")));
        }
    }
    if base {
        if !s.is_empty() {
            s.push_str("; ");
        }
        s.push_str("spread the poses over more of the workspace, in all three directions");
    }
    if s.is_empty() {
        s.push_str("measure more poses spread over the joint ranges");
    }
    s
}

fn null_count(a: &Identifiability) -> usize {
    a.null_directions.len()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn combination_names_terms() {
        // free = d2 (index 6), d3 (11), a2 (7)
        let six = Layout::SIX;
        let s = combination(six, &[0.7, -0.7, 0.1], &[6, 11, 7]);
        assert_eq!(s, "d2 − d3 + 0.14 a2");
        let s = combination(six, &[-0.5, 0.01, 0.0], &[6, 11, 7]);
        assert_eq!(s, "d2");
    }

    /// With nothing free the decomposition is empty (nalgebra's panics on an empty matrix).
    #[test]
    fn scaled_svd_of_no_columns_is_empty() {
        let svd = scaled_svd(&DMatrix::zeros(12, 0));
        assert!(svd.values.is_empty() && svd.norms.is_empty());
        assert_eq!(svd.vectors.shape(), (0, 0));
    }

    /// Fixing every input the fit would move is refused; with one left free (or the placement
    /// free when it is identified) the fit goes ahead.
    #[test]
    fn fixing_everything_is_refused() {
        let m = crate::kinematics::tx60();
        let space = m.layout().measured();
        let names = |placement: bool| -> Vec<String> {
            default_free(&m.fixed, placement)
                .into_iter()
                .map(|i| space.name(i).to_uppercase())
                .collect()
        };
        for (placement, p) in [(true, Placement::Identify), (false, Placement::Known)] {
            let all = names(placement);
            let e = check_something_free(&m, p, &all).unwrap_err().to_string();
            assert!(e.contains("nothing is left to identify"), "{e}");
            assert!(check_something_free(&m, p, &all[1..]).is_ok());
        }
        assert!(check_something_free(&m, Placement::Identify, &[]).is_ok());
        assert!(check_something_free(&m, Placement::Identify, &names(false)).is_ok());
    }

    #[test]
    fn joints_of_a_combination() {
        let six = Layout::SIX;
        assert_eq!(
            joints_in(six, "d2 − d3 + 0.14 tool_x"),
            (vec![2, 3, 6], false)
        );
        assert_eq!(joints_in(six, "base_z + 0.3 a1"), (vec![1], true));
        let seven = Layout::new(7);
        assert_eq!(
            joints_in(seven, "d7 − d3 + 0.14 tool_x"),
            (vec![3, 7], false)
        );
    }
}
