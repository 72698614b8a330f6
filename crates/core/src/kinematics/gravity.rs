//! Gravity torques about a chain's joint axes and the default link masses they are computed
//! with: what joint compliance acts on (issue 33). The simulator's non-geometric robots
//! (`simulate::nongeometric`) and the identification's check beyond geometry
//! (`identify::chain`) share them.
//!
//! Gravity acts along −z of the robot's base frame ([`GRAVITY`] m/s²). Link i (the body joint i
//! turns, with everything fixed to it) has its mass at its centre of mass ([`LinkMasses`]); a
//! payload sits at the tool point. A model imported from a description with `<inertial>` data
//! carries its links' masses and centres of mass (`RobotModel::links`, the `[links]` table of a
//! model file). Without them the masses are a documented default ([`default_link_masses`]): 12,
//! 10, 6, 5, 1.5, 0.5 kg for the six links of a TX60-class arm (further links 0.5 kg), scaled by
//! the square of the robot's size against the TX60's (size: the sum of |a| and |d| over the
//! chain), each at the middle of the origins of frames i − 1 and i (the frames before and after
//! joint i's transform, both of which move with link i). They are plausible, not published.

use super::{joint_transform, Capped, Joints, RobotModel, MAX_JOINTS};

/// The masses and centres of mass of a chain's moving links.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LinkMasses {
    /// Mass of link i (the body joint i turns, with everything fixed to it), kg, one per joint.
    pub mass_kg: Joints,
    /// Centre of mass of link i in MDH frame i (the frame after joint i's transform, which moves
    /// with link i), mm, one per joint; `None`: the middle of the origins of frames i − 1 and i.
    pub com_mm: Option<Capped<[f64; 3], MAX_JOINTS>>,
}

impl LinkMasses {
    /// Masses `mass_kg`, each at the middle of its link's frame origins.
    pub fn at_midpoints(mass_kg: Joints) -> LinkMasses {
        LinkMasses {
            mass_kg,
            com_mm: None,
        }
    }

    /// The links of `model`: its own (`RobotModel::links`) or the default
    /// ([`default_link_masses`] at the midpoints).
    pub fn of(model: &RobotModel) -> LinkMasses {
        model
            .links
            .unwrap_or_else(|| LinkMasses::at_midpoints(default_link_masses(model)))
    }

    /// Number of joints.
    pub fn joints(&self) -> usize {
        self.mass_kg.len()
    }

    /// Every link's centre of mass in its MDH frame (mm) for the chain `params`: the given ones,
    /// or the middle of the link's frame origins (the origin of frame i − 1 lies on joint i's
    /// axis, so it is a point of link i, fixed in frame i).
    pub fn centres_mm(&self, params: &[f64]) -> Capped<[f64; 3], MAX_JOINTS> {
        match &self.com_mm {
            Some(c) => *c,
            None => Capped::from_fn(self.joints(), |j| {
                let p = &params[5 * j..5 * j + 5];
                let m = joint_transform(p[0], p[1], p[2], p[3], p[4], 0.0);
                // −½ Rᵀ t: half of frame i − 1's origin in frame i.
                std::array::from_fn(|k| -0.5 * (0..3).map(|r| m[r][k] * m[r][3]).sum::<f64>())
            }),
        }
    }

    /// Checks the values: one mass (finite, 0 to 10 t) and, when given, one finite centre of
    /// mass (within 100 m) per joint.
    ///
    /// # Errors
    ///
    /// The field at fault (`mass_kg`, `com_mm`) and what is wrong with it.
    pub fn check(&self, joints: usize) -> Result<(), (&'static str, String)> {
        if self.mass_kg.len() != joints {
            return Err((
                "mass_kg",
                format!(
                    "needs one mass per joint ({joints}), found {}",
                    self.mass_kg.len()
                ),
            ));
        }
        if let Some((j, m)) = self
            .mass_kg
            .iter()
            .enumerate()
            .find(|(_, m)| !(m.is_finite() && (0.0..=1e4).contains(*m)))
        {
            return Err((
                "mass_kg",
                format!("link {} has mass {m}: a mass is 0 to 10000 kg", j + 1),
            ));
        }
        if let Some(c) = &self.com_mm {
            if c.len() != joints {
                return Err((
                    "com_mm",
                    format!(
                        "needs one [x, y, z] (mm) per joint ({joints}), found {}",
                        c.len()
                    ),
                ));
            }
            if let Some(j) = c
                .iter()
                .position(|v| v.iter().any(|x| !(x.is_finite() && x.abs() <= 1e5)))
            {
                return Err((
                    "com_mm",
                    format!(
                        "link {}: a centre of mass is finite and within 100 m",
                        j + 1
                    ),
                ));
            }
        }
        Ok(())
    }
}

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

/// The gravity torque about each joint's axis, N·m, of the links beyond it (`links`) and of a
/// payload of `payload_kg` at the tool point, for the chain of MDH parameters `params` (5 per
/// joint) and tool `tool` (mm) at joint angles `q` (rad).
pub fn gravity_torques(
    params: &[f64],
    tool: &[f64; 3],
    links: &LinkMasses,
    payload_kg: f64,
    q: &[f64],
) -> Joints {
    let n = q.len();
    // Origins (m), z axes and rotations of frames 0 … n in the base frame.
    let mut rot = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let mut origin = [0.0; 3];
    let mut origins = [[0.0; 3]; MAX_JOINTS + 1];
    let mut axes = [[0.0, 0.0, 1.0]; MAX_JOINTS + 1];
    let mut rots = [rot; MAX_JOINTS + 1];
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
        rots[j + 1] = rot;
    }
    let tool_at: [f64; 3] =
        std::array::from_fn(|k| origin[k] + (0..3).map(|c| rot[k][c] * tool[c]).sum::<f64>());
    // Weights (N, along −z) at their points (m): links, then the payload.
    let mut loads = [([0.0; 3], 0.0); MAX_JOINTS + 1];
    for (l, load) in loads.iter_mut().enumerate().take(n) {
        let centre = match &links.com_mm {
            None => std::array::from_fn(|k| 0.5 * (origins[l][k] + origins[l + 1][k])),
            Some(c) => std::array::from_fn(|k| {
                origins[l + 1][k] + 1e-3 * (0..3).map(|a| rots[l + 1][k][a] * c[l][a]).sum::<f64>()
            }),
        };
        *load = (centre, links.mass_kg[l] * GRAVITY);
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
