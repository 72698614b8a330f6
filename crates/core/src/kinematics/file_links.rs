//! The `[links]` section of a model file: the masses and centres of mass of the moving links
//! (from a description's `<inertial>` data on import), which joint compliance's gravity torques
//! use ([`super::gravity::LinkMasses`]); read with the rest of the file by serde, converted and
//! checked here, and written back.

use super::file::fnum;
use super::gravity::LinkMasses;
use super::{Capped, Joints, MAX_JOINTS};
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;

/// The section as the file holds it (kg, mm).
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct LinksFile {
    mass_kg: Vec<f64>,
    #[serde(default)]
    com_mm: Option<Vec<Vec<f64>>>,
}

impl LinksFile {
    /// The model's links, checked, for a model of `joints` joints; the error names the field.
    pub(super) fn into_model(self, joints: usize) -> Result<LinkMasses, (String, String)> {
        let bad = |f: &str, m: String| (format!("links.{f}"), m);
        if self.mass_kg.len() != joints {
            return Err(bad(
                "mass_kg",
                format!(
                    "needs one mass per joint ({joints}), found {}",
                    self.mass_kg.len()
                ),
            ));
        }
        let links = LinkMasses {
            mass_kg: Joints::from_fn(joints, |j| self.mass_kg[j]),
            com_mm: com_rows(self.com_mm.as_deref(), joints).map_err(|m| bad("com_mm", m))?,
        };
        links.check(joints).map_err(|(f, m)| bad(f, m))?;
        Ok(links)
    }
}

/// Rows `[x, y, z]` (mm), one per joint, as centres of mass; `None` stays `None`.
pub(super) fn com_rows(
    rows: Option<&[Vec<f64>]>,
    joints: usize,
) -> Result<Option<Capped<[f64; 3], MAX_JOINTS>>, String> {
    let Some(rows) = rows else {
        return Ok(None);
    };
    if rows.len() != joints || rows.iter().any(|r| r.len() != 3) {
        return Err(format!(
            "needs one row [x, y, z] (mm) per joint ({joints}), found {} rows",
            rows.len()
        ));
    }
    Ok(Some(Capped::from_fn(joints, |j| {
        [rows[j][0], rows[j][1], rows[j][2]]
    })))
}

/// The centres of mass as a TOML array of rows.
pub(super) fn com_text(c: &Capped<[f64; 3], MAX_JOINTS>) -> String {
    let rows: Vec<String> = c
        .iter()
        .map(|r| format!("[{}, {}, {}]", fnum(r[0]), fnum(r[1]), fnum(r[2])))
        .collect();
    format!("[{}]", rows.join(", "))
}

/// Writes `l` as the `[links]` section.
pub(super) fn write_links(s: &mut String, l: &LinkMasses) {
    let _ = writeln!(
        s,
        "\n# Link masses (kg) and centres of mass (mm, each in its MDH frame i, which moves with link\n\
         # i): the gravity torques of joint compliance (docs/METHOD.md §19).\n\
         [links]\nmass_kg = [{}]",
        l.mass_kg.iter().map(|v| fnum(*v)).collect::<Vec<_>>().join(", ")
    );
    if let Some(c) = &l.com_mm {
        let _ = writeln!(s, "com_mm = {}", com_text(c));
    }
}
