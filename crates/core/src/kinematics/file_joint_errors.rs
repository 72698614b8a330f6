//! The `[joint_errors]` section of a model file (docs/METHOD.md §19): read with the rest of the
//! file by serde, converted and checked here, and written back.

use super::file::fnum;
use super::gravity::LinkMasses;
use super::joint_errors::{Backlash, JointErrors, Payload, COEFFICIENTS_PER_JOINT};
use super::{InputSpace, Joints};
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;

/// The section as the file holds it (µrad/(N·m), degrees, kg, mm).
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct JointErrorsFile {
    compliance_urad_per_nm: Vec<f64>,
    harmonics_deg: Vec<Vec<f64>>,
    link_mass_kg: Vec<f64>,
    #[serde(default)]
    link_com_mm: Option<Vec<Vec<f64>>>,
    #[serde(default)]
    calibration_payload_kg: f64,
    #[serde(default)]
    calibration_payload_com_mm: Option<Vec<f64>>,
    #[serde(default)]
    payload_kg: Option<f64>,
    #[serde(default)]
    payload_sigma_kg: f64,
    #[serde(default)]
    payload_com_mm: Option<Vec<f64>>,
    #[serde(default)]
    free: Vec<String>,
    #[serde(default)]
    covariance: Vec<Vec<f64>>,
    #[serde(default)]
    geometry_shift: Vec<Vec<f64>>,
    #[serde(default)]
    backlash_deg: Option<Vec<f64>>,
    #[serde(default)]
    backlash_sigma_deg: Option<Vec<f64>>,
    #[serde(default)]
    backlash_sides_unknown: Option<crate::discrepancy::Discrepancy>,
}

/// The backlash's term for unknown sides, checked as the model's own `[discrepancy]`, its
/// fields named under `joint_errors.backlash_sides_unknown`.
fn checked_term(
    d: crate::discrepancy::Discrepancy,
    joints: usize,
) -> Result<crate::discrepancy::Discrepancy, (String, String)> {
    let rename = |field: &str| {
        let f = field.strip_prefix("discrepancy.").unwrap_or(field);
        format!("joint_errors.backlash_sides_unknown.{f}")
    };
    let d = d.checked().map_err(|e| match e {
        crate::discrepancy::DiscrepancyError::Invalid { field, message } => {
            (rename(&field), message)
        }
    })?;
    if let Some(c) = &d.compensation {
        c.check(joints)
            .map_err(|(field, message)| (rename(&field), message))?;
    }
    Ok(d)
}

fn three(v: &Option<Vec<f64>>, field: &str) -> Result<[f64; 3], (String, String)> {
    match v {
        None => Ok([0.0; 3]),
        Some(v) => v.as_slice().try_into().map_err(|_| {
            (
                format!("joint_errors.{field}"),
                format!(
                    "must be exactly 3 numbers [x, y, z] (mm), found {}",
                    v.len()
                ),
            )
        }),
    }
}

impl JointErrorsFile {
    /// The model's joint errors, checked, for a model of `joints` joints whose covariance covers
    /// `space`.
    pub(super) fn into_model(
        self,
        joints: usize,
        space: InputSpace,
    ) -> Result<JointErrors, (String, String)> {
        let bad = |f: &str, m: String| (format!("joint_errors.{f}"), m);
        if self.compliance_urad_per_nm.len() != joints {
            return Err(bad(
                "compliance_urad_per_nm",
                format!(
                    "needs one value per joint ({joints}), found {}",
                    self.compliance_urad_per_nm.len()
                ),
            ));
        }
        if self.harmonics_deg.len() != joints || self.harmonics_deg.iter().any(|r| r.len() != 4) {
            return Err(bad(
                "harmonics_deg",
                format!("needs one row [sin1, cos1, sin2, cos2] (deg) per joint ({joints})"),
            ));
        }
        if self.link_mass_kg.len() != joints {
            return Err(bad(
                "link_mass_kg",
                format!(
                    "needs one mass per joint ({joints}), found {}",
                    self.link_mass_kg.len()
                ),
            ));
        }
        let com_mm = super::file_links::com_rows(self.link_com_mm.as_deref(), joints)
            .map_err(|m| bad("link_com_mm", m))?;
        let mut coefficients = vec![0.0; COEFFICIENTS_PER_JOINT * joints];
        for j in 0..joints {
            let c = &mut coefficients[COEFFICIENTS_PER_JOINT * j..COEFFICIENTS_PER_JOINT * (j + 1)];
            c[0] = self.compliance_urad_per_nm[j] * 1e-6;
            for k in 0..4 {
                c[1 + k] = self.harmonics_deg[j][k].to_radians();
            }
        }
        let free = self
            .free
            .iter()
            .map(|name| {
                (0..coefficients.len())
                    .find(|&i| &JointErrors::coefficient_name(i) == name)
                    .ok_or_else(|| {
                        bad(
                            "free",
                            format!("'{name}' is no coefficient (k1, sin1_1, cos1_1, sin2_1, cos2_1, k2, …)"),
                        )
                    })
            })
            .collect::<Result<Vec<_>, _>>()?;
        let p = free.len();
        if self.covariance.len() != p || self.covariance.iter().any(|r| r.len() != p) {
            return Err(bad(
                "covariance",
                format!("needs {p} rows of {p} numbers, one per name in `free`"),
            ));
        }
        let covariance: Vec<f64> = (0..p * p)
            .map(|e| {
                let (r, c) = (e / p, e % p);
                self.covariance[r][c]
                    * JointErrors::to_internal(free[r])
                    * JointErrors::to_internal(free[c])
            })
            .collect();
        let shift = if self.geometry_shift.is_empty() {
            Vec::new()
        } else {
            if self.geometry_shift.len() != space.len()
                || self.geometry_shift.iter().any(|r| r.len() != p)
            {
                return Err(bad(
                    "geometry_shift",
                    format!(
                        "needs {} rows (the covariance's inputs) of {p} numbers",
                        space.len()
                    ),
                ));
            }
            (0..space.len() * p)
                .map(|e| {
                    let (r, c) = (e / p, e % p);
                    self.geometry_shift[r][c] * space.quantity(r).to_internal()
                        / JointErrors::to_internal(free[c])
                })
                .collect()
        };
        let calibration_payload = Payload {
            mass_kg: self.calibration_payload_kg,
            sigma_kg: 0.0,
            com_mm: three(
                &self.calibration_payload_com_mm,
                "calibration_payload_com_mm",
            )?,
        };
        let payload = match (self.payload_kg, &self.payload_com_mm) {
            (None, None) if self.payload_sigma_kg == 0.0 => calibration_payload,
            (m, com) => Payload {
                mass_kg: m.unwrap_or(calibration_payload.mass_kg),
                sigma_kg: self.payload_sigma_kg,
                com_mm: match com {
                    None => calibration_payload.com_mm,
                    Some(_) => three(com, "payload_com_mm")?,
                },
            },
        };
        let sides_unknown = match self.backlash_sides_unknown {
            None => None,
            Some(_) if self.backlash_deg.is_none() => {
                return Err(bad(
                    "backlash_sides_unknown",
                    "needs backlash_deg: it is the term of a model with backlash whose sides are not known".into(),
                ))
            }
            Some(d) => Some(checked_term(d, joints)?),
        };
        let backlash = match (&self.backlash_deg, &self.backlash_sigma_deg) {
            (None, None) => None,
            (None, Some(_)) => {
                return Err(bad(
                    "backlash_sigma_deg",
                    "needs backlash_deg, the gaps it is the uncertainty of".into(),
                ))
            }
            (Some(g), s) => Some(Backlash {
                gap_rad: g.iter().map(|v| v.to_radians()).collect(),
                sigma_rad: match s {
                    Some(s) => s.iter().map(|v| v.to_radians()).collect(),
                    None => vec![0.0; g.len()],
                },
                sides_unknown,
            }),
        };
        let e = JointErrors {
            backlash,
            coefficients,
            links: LinkMasses {
                mass_kg: Joints::from_fn(joints, |j| self.link_mass_kg[j]),
                com_mm,
            },
            calibration_payload,
            payload,
            free,
            covariance,
            shift_space: space,
            shift,
        };
        e.check(joints)?;
        Ok(e)
    }
}

/// Writes `e` as the `[joint_errors]` section.
pub(super) fn write_joint_errors(s: &mut String, e: &JointErrors) {
    write_keys(s, e);
    if let Some(d) = e.backlash.as_ref().and_then(|b| b.sides_unknown.as_ref()) {
        let _ = writeln!(
            s,
            "\n# The discrepancy term of the prediction that does not know the sides (no half gap turned),\n\
             # from its residuals on the calibration data: used where a test point's sides are not all given."
        );
        super::file_discrepancy::write_discrepancy(s, d, "joint_errors.backlash_sides_unknown");
    }
}

/// The section's own keys (the sub-table of the backlash's term follows them).
fn write_keys(s: &mut String, e: &JointErrors) {
    let n = e.joints();
    let join = |v: &mut dyn Iterator<Item = f64>| v.map(fnum).collect::<Vec<_>>().join(", ");
    let _ = writeln!(
        s,
        "\n# Joint errors beyond geometry (docs/METHOD.md §19): commanded to q, joint i stands at\n\
         # q_i + k_i * tau_i(q, payload) + sin1_i sin q_i + cos1_i cos q_i + sin2_i sin 2q_i + cos2_i cos 2q_i,\n\
         # tau_i the gravity torque about joint i of the links (link_mass_kg at link_com_mm, MDH frame i;\n\
         # without it the middle of the link's frame origins) and the payload.\n\
         # payload_*: the payload at the task (analyses draw its mass with payload_sigma_kg);\n\
         # calibration_payload_*: the one during the measurements.\n\
         [joint_errors]"
    );
    let _ = writeln!(
        s,
        "compliance_urad_per_nm = [{}]",
        join(&mut (0..n).map(|j| e.coefficients[COEFFICIENTS_PER_JOINT * j] * 1e6))
    );
    let _ = writeln!(s, "harmonics_deg = [");
    for j in 0..n {
        let _ = writeln!(
            s,
            "  [{}],",
            join(&mut (1..5).map(|k| e.coefficients[COEFFICIENTS_PER_JOINT * j + k].to_degrees()))
        );
    }
    let _ = writeln!(s, "]");
    let _ = writeln!(
        s,
        "link_mass_kg = [{}]",
        join(&mut e.links.mass_kg.iter().copied())
    );
    if let Some(c) = &e.links.com_mm {
        let _ = writeln!(s, "link_com_mm = {}", super::file_links::com_text(c));
    }
    let c = &e.calibration_payload;
    let _ = writeln!(
        s,
        "calibration_payload_kg = {}\ncalibration_payload_com_mm = [{}]",
        fnum(c.mass_kg),
        join(&mut c.com_mm.iter().copied())
    );
    let t = &e.payload;
    let _ = writeln!(
        s,
        "payload_kg = {}\npayload_sigma_kg = {}\npayload_com_mm = [{}]",
        fnum(t.mass_kg),
        fnum(t.sigma_kg),
        join(&mut t.com_mm.iter().copied())
    );
    if let Some(b) = &e.backlash {
        let _ = writeln!(
            s,
            "# Backlash: per joint the gap (deg) and its uncertainty; a joint stands half its gap from the\n\
             # commanded angle on the side it arrived from, which the analyses draw at every point.\n\
             backlash_deg = [{}]\nbacklash_sigma_deg = [{}]",
            join(&mut b.gap_rad.iter().map(|v| v.to_degrees())),
            join(&mut b.sigma_rad.iter().map(|v| v.to_degrees()))
        );
    }
    if e.free.is_empty() {
        return;
    }
    let p = e.free.len();
    let names: Vec<String> = e
        .free
        .iter()
        .map(|&i| format!("\"{}\"", JointErrors::coefficient_name(i)))
        .collect();
    let _ = writeln!(
        s,
        "# The coefficients with spread, their covariance (µrad/(N·m), deg) and the mean shift of\n\
         # each input of [covariance] per unit of each (file units), the geometry's correlation with them.\n\
         free = [{}]\ncovariance = [",
        names.join(", ")
    );
    let u = |k: usize| 1.0 / JointErrors::to_internal(e.free[k]);
    for r in 0..p {
        let _ = writeln!(
            s,
            "  [{}],",
            join(&mut (0..p).map(|c| e.covariance[r * p + c] * u(r) * u(c)))
        );
    }
    let _ = writeln!(s, "]");
    if e.shift.is_empty() {
        return;
    }
    let _ = writeln!(s, "geometry_shift = [");
    let sp = e.shift_space;
    for r in 0..sp.len() {
        let f = sp.quantity(r).from_internal();
        let _ = writeln!(
            s,
            "  [{}],",
            join(&mut (0..p).map(|c| e.shift[r * p + c] * f / u(c)))
        );
    }
    let _ = writeln!(s, "]");
}
