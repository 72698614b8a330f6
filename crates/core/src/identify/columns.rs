//! Data files as trackers and robot logs export them: a column map renames their columns to the
//! ones a data file has (`q1`…`q7`, `x`, `y`, `z`, `sx`, `sy`, `sz`, `run`, `joint`,
//! `payload_kg`), converts their units and reads another delimiter, so that nobody rewrites a
//! file by hand (and nobody slips doing it).
//!
//! A map is a list of `ours=theirs` or `ours=theirs:unit` entries separated by commas:
//! `q1=A1:rad,q2=A2:rad,…,x=X:m,y=Y:m,z=Z:m`. Names match the file's header ignoring case and
//! surrounding blanks; the unit says what the file's column is in (lengths `mm`, `cm`, `m`,
//! `in`, `um`; angles `deg`, `rad`; masses `kg`, `g`, `lb`), and the value is converted to the
//! data file's (mm, degrees, kg). Columns the map does not name keep their names, except one
//! named like a mapped column, which the map replaces. The converted text keeps every line where
//! it was, so errors still name the lines of the user's file.
//!
//! # Examples
//!
//! ```
//! use gpu_amcs_core::identify::ColumnMap;
//!
//! let map = ColumnMap::parse("q1=A1:rad,q2=A2:rad,q3=A3:rad,q4=A4:rad,x=X:m,y=Y:m,z=Z:m")
//!     .unwrap()
//!     .with_delimiter(b';');
//! let file = "A1;A2;A3;A4;X;Y;Z\n0.5;0;0;0;1.2;0.3;0.25\n";
//! let text = map.apply(file, "log.csv").unwrap();
//! assert_eq!(
//!     text,
//!     "q1,q2,q3,q4,x,y,z\n28.64788975654116,0,0,0,1200,300,250\n"
//! );
//! ```

use super::poses::{PAYLOAD_COLUMN, SIGMA_COLUMNS};
use super::sweeps::Q_COLUMNS;

/// Why a column map cannot be used.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ColumnMapError {
    /// An entry is not `ours=theirs[:unit]`, names a column no data file has, a unit that does
    /// not fit the column, or a column twice.
    #[error("{0}")]
    Syntax(String),
    /// The file has no column of a name the map gives.
    #[error("{origin}: line {line}: the column map names '{theirs}' (for {ours}), which the header does not have (it has: {header})")]
    Missing {
        /// The file.
        origin: String,
        /// The header's line.
        line: u64,
        /// The name the map gives.
        theirs: String,
        /// The data file's column it was to fill.
        ours: String,
        /// The header's names.
        header: String,
    },
    /// The file cannot be read as CSV with the map's delimiter.
    #[error("{origin}: line {line}: {message}")]
    Csv {
        /// The file.
        origin: String,
        /// The line.
        line: u64,
        /// What is wrong.
        message: String,
    },
}

/// Which setting of [`ColumnMap::from_settings`] is at fault.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ColumnMapSetting {
    /// The map's text.
    Map,
    /// The delimiter.
    Delimiter,
}

/// One entry: the data file's column, the file's column it comes from and the factor from the
/// file's unit to the data file's.
#[derive(Clone, Debug, PartialEq)]
struct Entry {
    ours: String,
    theirs: String,
    factor: f64,
}

/// A column map: `ours=theirs[:unit]` entries and the file's delimiter (see [`ColumnMap::parse`]
/// and [`ColumnMap::apply`]).
#[derive(Clone, Debug, PartialEq)]
pub struct ColumnMap {
    entries: Vec<Entry>,
    delimiter: u8,
}

/// What a data file's column holds, for its units.
#[derive(Clone, Copy, PartialEq)]
enum Kind {
    Length,
    Angle,
    Mass,
    Label,
}

/// The kind of the data file's column `ours`; `None` for a name no data file has.
fn kind(ours: &str) -> Option<Kind> {
    if Q_COLUMNS.contains(&ours) {
        Some(Kind::Angle)
    } else if ["x", "y", "z"].contains(&ours) || SIGMA_COLUMNS.contains(&ours) {
        Some(Kind::Length)
    } else if ours == PAYLOAD_COLUMN {
        Some(Kind::Mass)
    } else if [
        "run",
        "joint",
        super::poses::TARGET_COLUMN,
        super::poses::MOUNT_COLUMN,
    ]
    .contains(&ours)
    {
        Some(Kind::Label)
    } else {
        None
    }
}

/// The factor from `unit` to the data file's unit of a `kind` column; `None` when it does not
/// fit.
fn factor(kind: Kind, unit: &str) -> Option<f64> {
    let table: &[(&str, f64)] = match kind {
        Kind::Length => &[
            ("mm", 1.0),
            ("cm", 10.0),
            ("m", 1000.0),
            ("in", 25.4),
            ("um", 1e-3),
            ("µm", 1e-3),
        ],
        Kind::Angle => &[("deg", 1.0), ("rad", 180.0 / std::f64::consts::PI)],
        Kind::Mass => &[("kg", 1.0), ("g", 1e-3), ("lb", 0.453_592_37)],
        Kind::Label => &[],
    };
    table
        .iter()
        .find(|(u, _)| u.eq_ignore_ascii_case(unit))
        .map(|&(_, f)| f)
}

impl ColumnMap {
    /// Reads a map `ours=theirs[:unit],…` (comma-delimited file).
    ///
    /// # Errors
    ///
    /// [`ColumnMapError::Syntax`] for an entry that is not `ours=theirs[:unit]`, a data-file
    /// column no data file has, a unit that does not fit the column, or a column named twice on
    /// either side.
    pub fn parse(text: &str) -> Result<ColumnMap, ColumnMapError> {
        let err = |m: String| Err(ColumnMapError::Syntax(m));
        let mut entries: Vec<Entry> = Vec::new();
        for item in text.split(',').map(str::trim).filter(|s| !s.is_empty()) {
            let Some((ours, rest)) = item.split_once('=') else {
                return err(format!(
                    "'{item}' is not ours=theirs[:unit] (e.g. q1=A1:rad or x=X:m)"
                ));
            };
            let ours = ours.trim().to_ascii_lowercase();
            let Some(k) = kind(&ours) else {
                return err(format!(
                    "'{ours}' is not a data file's column (q1…q7, x, y, z, sx, sy, sz, run, joint, target, mount, {PAYLOAD_COLUMN})"
                ));
            };
            // A unit after the last ':' when it is one; else the whole is the name.
            let (theirs, factor) = match rest.rsplit_once(':') {
                Some((name, unit)) if k != Kind::Label && !unit.trim().is_empty() => {
                    match factor(k, unit.trim()) {
                        Some(f) => (name.trim(), f),
                        None => {
                            let units = match k {
                                Kind::Length => "mm, cm, m, in, um",
                                Kind::Angle => "deg, rad",
                                _ => "kg, g, lb",
                            };
                            return err(format!(
                                "'{item}': '{}' is not a unit of {ours} ({units})",
                                unit.trim()
                            ));
                        }
                    }
                }
                _ => (rest.trim(), 1.0),
            };
            if theirs.is_empty() {
                return err(format!("'{item}' names no column of the file"));
            }
            if entries.iter().any(|e| e.ours == ours) {
                return err(format!("{ours} is mapped twice"));
            }
            if entries
                .iter()
                .any(|e| e.theirs.eq_ignore_ascii_case(theirs))
            {
                return err(format!("the file's column '{theirs}' is mapped twice"));
            }
            entries.push(Entry {
                ours,
                theirs: theirs.to_string(),
                factor,
            });
        }
        if entries.is_empty() {
            return err("the map is empty: give ours=theirs[:unit] entries".into());
        }
        Ok(ColumnMap {
            entries,
            delimiter: b',',
        })
    }

    /// The map that renames nothing (with [`Self::with_delimiter`]: a data file whose fields
    /// are delimited otherwise).
    pub fn none() -> ColumnMap {
        ColumnMap {
            entries: Vec::new(),
            delimiter: b',',
        }
    }

    /// The map of a front end's two settings: the map's text and the delimiter's (one ASCII
    /// character, or `tab` or `\t`); `None` when neither is given (a delimiter alone maps
    /// nothing).
    ///
    /// # Errors
    ///
    /// [`ColumnMapSetting::Map`] with [`ColumnMap::parse`]'s error, or
    /// [`ColumnMapSetting::Delimiter`] for a delimiter that is not one character.
    pub fn from_settings(
        map: Option<&str>,
        delimiter: Option<&str>,
    ) -> Result<Option<ColumnMap>, (ColumnMapSetting, String)> {
        let delimiter = match delimiter {
            None => None,
            Some("\\t" | "tab" | "\t") => Some(b'\t'),
            Some(d) if d.len() == 1 && d != "\"" && d != "\n" => Some(d.as_bytes()[0]),
            Some(d) => {
                return Err((
                    ColumnMapSetting::Delimiter,
                    format!("'{d}' is not one ASCII character (e.g. ';' or tab)"),
                ))
            }
        };
        let parsed = match map {
            Some(m) => ColumnMap::parse(m).map_err(|e| (ColumnMapSetting::Map, e.to_string()))?,
            None if delimiter.is_some() => ColumnMap::none(),
            None => return Ok(None),
        };
        Ok(Some(match delimiter {
            Some(d) => parsed.with_delimiter(d),
            None => parsed,
        }))
    }

    /// The same map for a file whose fields are delimited by `delimiter` (`;`, a tab, …).
    pub fn with_delimiter(mut self, delimiter: u8) -> Self {
        self.delimiter = delimiter;
        self
    }

    /// `text` (a data file read from `origin`) with the map's columns renamed and converted,
    /// comma-delimited, every record on the line it had (comment and blank lines stay blank).
    /// Values that are not numbers are passed on as they are, for the data file's reader to
    /// name.
    ///
    /// # Errors
    ///
    /// [`ColumnMapError::Missing`] when the header lacks a mapped column,
    /// [`ColumnMapError::Csv`] when the text is not CSV with the map's delimiter.
    pub fn apply(&self, text: &str, origin: &str) -> Result<String, ColumnMapError> {
        // Line by line, so that each record stays on its line (a reader's line count does not
        // see comment lines); a data file has no field spanning lines.
        let mut lines: Vec<String> = Vec::new();
        // Per output column: the file's column and the factor (None: passed on unchanged).
        let mut plan: Vec<(usize, Option<f64>)> = Vec::new();
        let mut width = 0;
        for (k, raw) in text.lines().enumerate() {
            let line = k as u64 + 1;
            if raw.trim().is_empty() || raw.trim_start().starts_with('#') {
                lines.push(String::new());
                continue;
            }
            let rec = csv::ReaderBuilder::new()
                .has_headers(false)
                .trim(csv::Trim::All)
                .delimiter(self.delimiter)
                .from_reader(raw.as_bytes())
                .records()
                .next()
                .unwrap_or_else(|| Ok(csv::StringRecord::new()))
                .map_err(|e| ColumnMapError::Csv {
                    origin: origin.to_string(),
                    line,
                    message: e.to_string(),
                })?;
            let out = if plan.is_empty() {
                let (names, p) = self.header(&rec, origin, line)?;
                plan = p;
                width = rec.len();
                names
            } else if rec.len() != width {
                return Err(ColumnMapError::Csv {
                    origin: origin.to_string(),
                    line,
                    message: format!("has {} fields, the header has {width}", rec.len()),
                });
            } else {
                plan.iter()
                    .map(|&(c, f)| {
                        let v = rec.get(c).unwrap_or("");
                        match (f, v.parse::<f64>()) {
                            (Some(f), Ok(x)) if f != 1.0 => format!("{}", x * f),
                            _ => v.to_string(),
                        }
                    })
                    .collect()
            };
            lines.push(out.iter().map(|f| quoted(f)).collect::<Vec<_>>().join(","));
        }
        let mut text = lines.join("\n");
        text.push('\n');
        Ok(text)
    }

    /// The output header for the file's `header` (on `line`), and per output column where its
    /// values come from and their factor.
    #[allow(clippy::type_complexity)]
    fn header(
        &self,
        header: &csv::StringRecord,
        origin: &str,
        line: u64,
    ) -> Result<(Vec<String>, Vec<(usize, Option<f64>)>), ColumnMapError> {
        let find = |name: &str| {
            header
                .iter()
                .position(|h| h.trim().eq_ignore_ascii_case(name))
        };
        let mut names = Vec::new();
        let mut plan = Vec::new();
        for e in &self.entries {
            let Some(c) = find(&e.theirs) else {
                return Err(ColumnMapError::Missing {
                    origin: origin.to_string(),
                    line,
                    theirs: e.theirs.clone(),
                    ours: e.ours.clone(),
                    header: header.iter().collect::<Vec<_>>().join(", "),
                });
            };
            names.push(e.ours.clone());
            plan.push((c, Some(e.factor)));
        }
        let mapped = |c: usize| self.entries.iter().any(|e| find(&e.theirs) == Some(c));
        for (c, h) in header.iter().enumerate() {
            // A column the map replaces (named like a mapped one, with or without a unit
            // suffix such as q1_rad) is left out.
            let stem = super::pose_units::split_unit(h).0;
            let replaced = self.entries.iter().any(|e| e.ours == stem);
            if !mapped(c) && !replaced {
                names.push(h.to_string());
                plan.push((c, None));
            }
        }
        Ok((names, plan))
    }
}

/// A field as CSV writes it: quoted when it holds a comma, a quote or a line break.
fn quoted(f: &str) -> String {
    if f.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", f.replace('"', "\"\""))
    } else {
        f.to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn maps_names_units_and_delimiters_keeping_lines() {
        let map = ColumnMap::parse(
            "q1=J1:rad, q2=J2:rad, q3=J3:rad, q4=J4:rad, x=Px:m, y=Py:cm, z=Pz, run=Set",
        )
        .unwrap()
        .with_delimiter(b';');
        let file = "# exported\nSet;J1;J2;J3;J4;Px;Py;Pz;q1;note\n\nA;3.141592653589793;0;0;0;1.5;20;300;9;ok\n";
        let text = map.apply(file, "f.csv").unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines.len(), 4);
        assert_eq!(lines[0], "");
        assert_eq!(lines[1], "q1,q2,q3,q4,x,y,z,run,note");
        assert_eq!(lines[2], "");
        assert_eq!(lines[3], "180,0,0,0,1500,200,300,A,ok");
    }

    #[test]
    fn bad_maps_and_missing_columns_are_named() {
        for (map, want) in [
            ("q1", "not ours=theirs"),
            ("w=A", "'w' is not a data file's column"),
            ("x=X:furlong", "'furlong' is not a unit of x"),
            ("q1=A:m", "'m' is not a unit of q1"),
            ("x=A,x=B", "x is mapped twice"),
            ("x=A,y=a", "'a' is mapped twice"),
            ("x=", "names no column"),
            (" , ", "the map is empty"),
        ] {
            let e = ColumnMap::parse(map).unwrap_err().to_string();
            assert!(e.contains(want), "{map}: {e}");
        }
        let e = ColumnMap::parse("x=X")
            .unwrap()
            .apply("a,b\n1,2\n", "f.csv")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("f.csv: line 1") && e.contains("'X'") && e.contains("it has: a, b"),
            "{e}"
        );
        let e = ColumnMap::parse("x=a")
            .unwrap()
            .apply("a,b\n1,2\n3,4,5\n", "f.csv")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("f.csv: line 3: has 3 fields, the header has 2"),
            "{e}"
        );
    }
}
