//! Parameters the data do not determine (issue 35, item 3): the identifiability analysis holds
//! each at its nominal value ([`crate::identify::identifiability::fix_null_directions`]), and
//! this module keeps their *prior* uncertainty in the covariance the model file carries, so that
//! a model identified from data that never moved the wrist does not claim to know the wrist
//! exactly.
//!
//! With the undetermined inputs `U` held at nominal while the truth is `nominal + δ`, `δ ~ N(0,
//! Σ_U)` (the prior), the fitted free inputs `F` absorb `G δ` with `G = (JᵀWJ + prior)⁻¹_F
//! J_Fᵀ W J_U` (the fit's response to a shift of `U`). The error of the estimate is then `(G δ
//! + ε_F, −δ)` and its covariance
//!
//! ```text
//! [ C_F + G Σ_U Gᵀ   −G Σ_U ]
//! [ −Σ_U Gᵀ            Σ_U  ]
//! ```
//!
//! which is positive definite whenever `C_F` (linearised or Monte Carlo) and `Σ_U` are. Along a
//! direction the data determine exactly, the prior's spread cancels at the measured poses and
//! shows at the others.
//!
//! The prior σ of an input is the nominal model's σ when it has one and it is larger, else a
//! documented default: [`NOMINAL_LENGTH_SIGMA_MM`] and [`NOMINAL_ANGLE_SIGMA_DEG`] for the MDH
//! parameters (the prior of the nominal geometry), [`UNDETERMINED_TOOL_SIGMA_MM`] for the
//! target, [`UNDETERMINED_PLACEMENT_SIGMA_MM`] / [`UNDETERMINED_PLACEMENT_SIGMA_DEG`] for the
//! placement.

use super::covariance::{information, invert_spd};
use crate::identify::chain_fit::{jacobian, ChainState, Observation, Prior};
use crate::identify::pipeline::{NOMINAL_ANGLE_SIGMA_DEG, NOMINAL_LENGTH_SIGMA_MM};
use crate::kinematics::{Block, InputSpace, RobotModel};
use nalgebra::DMatrix;

/// Prior σ of a target coordinate the data do not determine, mm: the largest standard
/// deviation a model file holds ([`crate::kinematics::MAX_SIGMA_MM`]). A target is often given
/// as the flange centre while the reflector sits 50–100 mm off it; nothing smaller is safe.
pub const UNDETERMINED_TOOL_SIGMA_MM: f64 = 100.0;
/// Prior σ of a placement coordinate the data do not determine, mm (the largest a file holds).
pub const UNDETERMINED_PLACEMENT_SIGMA_MM: f64 = 100.0;
/// Prior σ of a placement angle the data do not determine, degrees (the largest a file holds).
pub const UNDETERMINED_PLACEMENT_SIGMA_DEG: f64 = 10.0;

/// The key of the `[provenance]` table that lists the inputs the data did not determine.
pub const NOT_IDENTIFIED_KEY: &str = "not_identified";

/// The prior σ (internal units) of input `i` of `space` held at `nominal`'s value because the
/// data do not determine it.
pub fn prior_sigma(nominal: &RobotModel, space: InputSpace, i: usize) -> f64 {
    let angle = space.is_angle(i);
    match space.locate(i) {
        (Block::Joints, k) => {
            let default = if angle {
                NOMINAL_ANGLE_SIGMA_DEG.to_radians()
            } else {
                NOMINAL_LENGTH_SIGMA_MM
            };
            let own = nominal.param_sigmas().get(k).copied().unwrap_or(0.0);
            default.max(own)
        }
        (Block::Tool, k) => UNDETERMINED_TOOL_SIGMA_MM.max(nominal.tool_sigma[k]),
        (Block::Placement, _) if angle => UNDETERMINED_PLACEMENT_SIGMA_DEG.to_radians(),
        (Block::Placement, _) => UNDETERMINED_PLACEMENT_SIGMA_MM,
    }
}

/// The covariance over `free` then `held` (in that order) of a fit at `state` whose inputs
/// `held` are at their nominal values with prior σ `sigma` (internal units): `chosen` is the
/// covariance of `free` alone (any method, scaled as the model keeps it), `prior` the fit's
/// prior on `free` (as in its linearised covariance). See the module docs.
pub fn with_held_inputs(
    obs: &[Observation],
    state: &ChainState,
    free: &[usize],
    held: &[usize],
    sigma: &[f64],
    chosen: &DMatrix<f64>,
    prior: Option<&Prior>,
) -> DMatrix<f64> {
    let (p, u) = (free.len(), held.len());
    let jf = jacobian(obs, state, free);
    let ju = jacobian(obs, state, held);
    let g = if p > 0 {
        invert_spd(&information(&jf, free, prior)) * (jf.transpose() * &ju)
    } else {
        DMatrix::zeros(0, u)
    };
    let s = DMatrix::from_diagonal(&nalgebra::DVector::from_iterator(
        u,
        sigma.iter().map(|v| v * v),
    ));
    let gs = &g * &s;
    let mut out = DMatrix::zeros(p + u, p + u);
    out.view_mut((0, 0), (p, p))
        .copy_from(&(chosen + &gs * g.transpose()));
    out.view_mut((0, p), (p, u)).copy_from(&(-&gs));
    out.view_mut((p, 0), (u, p)).copy_from(&(-gs.transpose()));
    out.view_mut((p, p), (u, u)).copy_from(&s);
    // exact symmetry, as the model file requires
    (&out + out.transpose()) * 0.5
}

/// The inputs a model file's `[provenance]` lists as not identified by its data (empty when it
/// lists none: fully identified, or a file written before the list existed).
pub fn not_identified(model_file_text: &str) -> Vec<String> {
    let Ok(table) = model_file_text.parse::<toml::Table>() else {
        return Vec::new();
    };
    table
        .get("provenance")
        .and_then(|p| p.get(NOT_IDENTIFIED_KEY))
        .and_then(|v| v.as_array())
        .map(|a| {
            a.iter()
                .filter_map(|v| v.as_str().map(str::to_string))
                .collect()
        })
        .unwrap_or_default()
}

/// The note every analysis of a model gives when its data did not determine `names` (`None`
/// when they did).
pub fn not_identified_note(names: &[String]) -> Option<String> {
    (!names.is_empty()).then(|| {
        format!(
            "the model was not fully identified: the data did not determine {} ({}), which stay at their nominal values and keep their prior uncertainty; figures that depend on them rest on that prior, not on measurements",
            if names.len() == 1 {
                "one parameter".to_string()
            } else {
                format!("{} parameters", names.len())
            },
            names.join(", ")
        )
    })
}

/// [`not_identified_note`] of the model file at `path` (`None` when it cannot be read or lists
/// nothing).
pub fn not_identified_note_of_file(path: &std::path::Path) -> Option<String> {
    let text = std::fs::read_to_string(path).ok()?;
    not_identified_note(&not_identified(&text))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_list_reads_back_and_old_files_have_none() {
        let text = "[provenance]\nnot_identified = [\"alpha3\", \"tool_x\"]\n";
        assert_eq!(not_identified(text), vec!["alpha3", "tool_x"]);
        let note = not_identified_note(&not_identified(text)).unwrap();
        assert!(
            note.starts_with("the model was not fully identified"),
            "{note}"
        );
        assert!(note.contains("alpha3, tool_x") && note.contains("keep their prior uncertainty"));
        assert!(not_identified("[provenance]\npoints = 3\n").is_empty());
        assert!(not_identified("not toml [").is_empty());
        assert_eq!(not_identified_note(&[]), None);
    }

    #[test]
    fn prior_sigmas_by_kind() {
        let m = crate::kinematics::tx60();
        let space = m.layout().measured();
        let a2 = space.find("a2").unwrap();
        let alpha3 = space.find("alpha3").unwrap();
        let tool_x = space.find("tool_x").unwrap();
        let yaw = space.find("base_yaw").unwrap();
        assert_eq!(prior_sigma(&m, space, a2), NOMINAL_LENGTH_SIGMA_MM);
        assert!((prior_sigma(&m, space, alpha3) - 0.1f64.to_radians()).abs() < 1e-15);
        assert_eq!(prior_sigma(&m, space, tool_x), UNDETERMINED_TOOL_SIGMA_MM);
        assert!((prior_sigma(&m, space, yaw) - 10f64.to_radians()).abs() < 1e-15);
    }
}
