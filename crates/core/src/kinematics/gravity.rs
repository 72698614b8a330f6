//! Gravity torques about a chain's joint axes and the default link masses they are computed
//! with: what joint compliance acts on (issue 33). The simulator's non-geometric robots
//! (`simulate::nongeometric`) and the identification's check beyond geometry
//! (`identify::chain`) share them.
//!
//! Gravity acts along −z of the robot's base frame ([`GRAVITY`] m/s²). Link i (the body joint i
//! turns) has its mass at the middle of the origins of frames i − 1 and i (the frames before and
//! after joint i's transform, both of which move with link i); a payload sits at the tool point.
//! The robot model holds no inertial data, so the masses are a documented default
//! ([`default_link_masses`]): 12, 10, 6, 5, 1.5, 0.5 kg for the six links of a TX60-class arm
//! (further links 0.5 kg), scaled by the square of the robot's size against the TX60's (size:
//! the sum of |a| and |d| over the chain). They are plausible, not published.

use super::{joint_transform, Joints, RobotModel, MAX_JOINTS};

/// Gravity, m/s² (along −z of the base frame).
pub const GRAVITY: f64 = 9.81;

/// Link masses of a TX60-class arm, kg, link 1 first (plausible figures, not published).
pub const TX60_LINK_MASS_KG: [f64; 6] = [12.0, 10.0, 6.0, 5.0, 1.5, 0.5];

/// The TX60's size for the mass scaling: the sum of |a| and |d| over its chain, mm.
const TX60_SIZE_MM: f64 = 1065.0;

/// The default link masses of `model` (kg, one per joint): see the module docs.
pub fn default_link_masses(model: &RobotModel) -> Joints {
    let n = model.joints();
    let size: f64 = (0..n)
        .map(|j| model.params[5 * j + 1].abs() + model.params[5 * j + 2].abs())
        .sum();
    let scale = (size / TX60_SIZE_MM).powi(2);
    Joints::from_fn(n, |j| {
        TX60_LINK_MASS_KG.get(j).copied().unwrap_or(0.5) * scale
    })
}

/// The compliance a joint of `model` is assumed to have when the data do not determine it,
/// rad/(N·m), as one standard deviation of a zero-mean prior: 5·10⁻⁶ rad/(N·m), the upper end of
/// a 60 kg-class arm's (the TX60's size), scaled by the cube of the TX60's size over the
/// robot's (the [`default_link_masses`]' size), so that a link bends by the same angle under
/// its own weight (masses ∝ size², lever ∝ size). Plausible, not published.
pub fn compliance_prior(model: &RobotModel) -> f64 {
    let n = model.joints();
    let size: f64 = (0..n)
        .map(|j| model.params[5 * j + 1].abs() + model.params[5 * j + 2].abs())
        .sum();
    5e-6 * (TX60_SIZE_MM / size.max(1.0)).powi(3)
}

/// The gravity torque about each joint's axis, N·m, of the links beyond it (masses
/// `link_mass_kg`, one per joint) and of a payload of `payload_kg` at the tool point, for the
/// chain of MDH parameters `params` (5 per joint) and tool `tool` (mm) at joint angles `q`
/// (rad).
pub fn gravity_torques(
    params: &[f64],
    tool: &[f64; 3],
    link_mass_kg: &[f64],
    payload_kg: f64,
    q: &[f64],
) -> Joints {
    let n = q.len();
    // Origins (m) and z axes of frames 0 … n in the base frame.
    let mut rot = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let mut origin = [0.0; 3];
    let mut origins = [[0.0; 3]; MAX_JOINTS + 1];
    let mut axes = [[0.0, 0.0, 1.0]; MAX_JOINTS + 1];
    for j in 0..n {
        let p = &params[5 * j..5 * j + 5];
        let m = joint_transform(p[0], p[1], p[2], p[3], p[4], q[j]);
        for (k, o) in origin.iter_mut().enumerate() {
            *o += (0..3).map(|c| rot[k][c] * m[c][3]).sum::<f64>();
        }
        let mut next = [[0.0; 3]; 3];
        for (k, row) in next.iter_mut().enumerate() {
            for (c, v) in row.iter_mut().enumerate() {
                *v = (0..3).map(|l| rot[k][l] * m[l][c]).sum();
            }
        }
        rot = next;
        origins[j + 1] = origin.map(|v| v * 1e-3);
        axes[j + 1] = [rot[0][2], rot[1][2], rot[2][2]];
    }
    let tool_at: [f64; 3] =
        std::array::from_fn(|k| origin[k] + (0..3).map(|c| rot[k][c] * tool[c]).sum::<f64>());
    // Weights (N, along −z) at their points (m): links, then the payload.
    let mut loads = [([0.0; 3], 0.0); MAX_JOINTS + 1];
    for (l, load) in loads.iter_mut().enumerate().take(n) {
        let centre = std::array::from_fn(|k| 0.5 * (origins[l][k] + origins[l + 1][k]));
        *load = (centre, link_mass_kg[l] * GRAVITY);
    }
    loads[n] = (tool_at.map(|v| v * 1e-3), payload_kg * GRAVITY);
    Joints::from_fn(n, |i| {
        let (o, z) = (origins[i], axes[i]);
        // (r × F)·z with F = (0, 0, −w): r × F = (−r_y·w, r_x·w, 0).
        loads[i..=n]
            .iter()
            .map(|&(c, w)| {
                let (rx, ry) = (c[0] - o[0], c[1] - o[1]);
                -ry * w * z[0] + rx * w * z[1]
            })
            .sum()
    })
}
