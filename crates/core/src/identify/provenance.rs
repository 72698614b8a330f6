//! Where an identified model came from, written into its model file as a `[provenance]` table:
//! the data file and its SHA-256, the number of points and runs, the fit's residuals, the rank
//! and condition number, how the noise was obtained, the frame, and the nominal model the fit
//! started from (its name, a SHA-256 of its geometry and the model itself, so that a validation
//! can compare against the model's own nominal). The model reader accepts and ignores the table,
//! so the file stays a plain model file.

use super::chain::Placement;
use super::Identification;
use crate::kinematics::{InputSpace, RobotModel};

/// Provenance of an identified model.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Provenance {
    /// The data file as given.
    pub data_file: String,
    /// SHA-256 of the data file's bytes, hex.
    pub data_sha256: String,
    /// Measured points over all runs.
    pub points: usize,
    /// Runs.
    pub runs: usize,
    /// RMS of the 3-D residuals over all points, mm.
    pub rms_residual_mm: f64,
    /// Largest 3-D residual, mm.
    pub max_residual_mm: f64,
    /// Smallest rank over the runs, and the number of identified quantities.
    pub rank: usize,
    /// Identified quantities.
    pub parameters: usize,
    /// Largest condition number over the runs.
    pub condition_number: f64,
    /// Where σ came from.
    pub noise: String,
    /// The frame of the data and the model.
    pub frame: String,
    /// The nominal model's name.
    pub nominal_name: String,
    /// [`geometry_sha256`] of the nominal model.
    pub nominal_sha256: String,
    /// The nominal model's file text (TOML).
    pub nominal_model: String,
    /// Inputs the data did not determine in some run (held at nominal with their prior σ;
    /// written as `not_identified` only when there are some; files without it read as none).
    pub not_identified: Vec<String>,
    /// The label of the model's target when the data named their targets (`target` column;
    /// written only then): a validation compares that target's rows.
    pub target: Option<String>,
    /// The base reference reflectors' labels and where they stood in the model's frame, mm,
    /// when the data had some (written only then): a validation registers measurements with
    /// the same references to that frame.
    pub references: Vec<(String, [f64; 3])>,
}

/// SHA-256 (hex) of a model's geometry: its number of joints, the `5n` MDH parameters (mm,
/// degrees) and the tool point (mm), each rounded to 1e-6 in file units so that a model and its
/// model file (written and read back) give the same value. Names, limits and uncertainties do
/// not enter: two files of the same robot geometry agree.
pub fn geometry_sha256(model: &RobotModel) -> String {
    let space = InputSpace::parameters(model.joints());
    // Rounded, and −0 folded into +0.
    let fixed = |v: f64| format!("{:.6}", (v * 1e6).round() / 1e6 + 0.0);
    let mut s = format!("joints {}\n", model.joints());
    for (i, v) in model.params.iter().enumerate() {
        s.push_str(&fixed(v / space.to_internal(i)));
        s.push('\n');
    }
    for v in model.tool {
        s.push_str(&fixed(v));
        s.push('\n');
    }
    sha256_hex(s.as_bytes())
}

pub use crate::digest::sha256_hex;

impl Provenance {
    /// The provenance of `ids` (runs through the whole-chain fit; `None` when none did),
    /// identified from `data` read from `data_file` with `nominal` as the nominal model.
    pub fn new(
        ids: &[Identification],
        nominal: &RobotModel,
        data_file: &str,
        data: &[u8],
    ) -> Option<Provenance> {
        let chains: Vec<_> = ids.iter().filter_map(|i| i.report.chain.as_ref()).collect();
        let first = chains.first()?;
        let points: usize = chains.iter().map(|c| c.points).sum();
        let sq: f64 = chains
            .iter()
            .map(|c| c.rms_residual_mm.powi(2) * c.points as f64)
            .sum();
        Some(Provenance {
            data_file: data_file.to_string(),
            data_sha256: sha256_hex(data),
            points,
            runs: ids.len(),
            rms_residual_mm: (sq / points.max(1) as f64).sqrt(),
            max_residual_mm: chains.iter().map(|c| c.max_residual_mm).fold(0.0, f64::max),
            rank: chains
                .iter()
                .map(|c| c.identifiability.rank)
                .min()
                .unwrap_or(0),
            parameters: first.identifiability.parameters,
            condition_number: chains
                .iter()
                .map(|c| c.identifiability.condition_number)
                .fold(0.0, f64::max),
            noise: first.noise.source.clone(),
            frame: match first.frame {
                Placement::Identify => "measurement".into(),
                Placement::Known => "robot base".into(),
            },
            nominal_name: nominal.name.clone(),
            nominal_sha256: geometry_sha256(nominal),
            nominal_model: nominal.to_toml(),
            not_identified: chains.iter().fold(Vec::new(), |mut all, c| {
                for n in &c.identifiability.null_directions {
                    if !all.contains(&n.fixed) {
                        all.push(n.fixed.clone());
                    }
                }
                all
            }),
            target: first.targets.first().cloned(),
            references: first.drift.as_ref().map_or(Vec::new(), |d| {
                d.references
                    .iter()
                    .cloned()
                    .zip(d.home_mm.iter().copied())
                    .collect()
            }),
        })
    }

    /// The `[provenance]` table (TOML), to append to a model file.
    pub fn to_toml(&self) -> String {
        let q = |s: &str| toml::Value::String(s.to_string()).to_string();
        let num = |v: f64| {
            if v.is_finite() {
                format!("{v:?}")
            } else {
                "inf".to_string()
            }
        };
        let listed = if self.not_identified.is_empty() {
            String::new()
        } else {
            let names: Vec<String> = self.not_identified.iter().map(|n| q(n)).collect();
            format!(
                "# not determined by the data: at nominal with their prior uncertainty\n{} = [{}]\n",
                super::chain::NOT_IDENTIFIED_KEY,
                names.join(", ")
            )
        };
        let references = if self.references.is_empty() {
            String::new()
        } else {
            let labels: Vec<String> = self.references.iter().map(|(l, _)| q(l)).collect();
            let home: Vec<String> = self
                .references
                .iter()
                .map(|(_, p)| format!("[{}, {}, {}]", num(p[0]), num(p[1]), num(p[2])))
                .collect();
            format!(
                "# base reference reflectors and where they stood in the model's frame, mm\nreference_labels = [{}]\nreference_home_mm = [{}]\n",
                labels.join(", "),
                home.join(", ")
            )
        };
        let target = self.target.as_deref().map_or(String::new(), |t| {
            format!(
                "# the data's target this model's tool is (its `target` column)\ntarget = {}\n",
                q(t)
            )
        });
        format!(
            "\n# Where this model came from (read and ignored by the model reader)\n[provenance]\n\
             data_file = {}\ndata_sha256 = {}\npoints = {}\nruns = {}\nrms_residual_mm = {}\n\
             max_residual_mm = {}\nrank = {}\nparameters = {}\ncondition_number = {}\nnoise = {}\n\
             frame = {}\nnominal_name = {}\nnominal_sha256 = {}\n{listed}{target}{references}nominal_model = {}\n",
            q(&self.data_file),
            q(&self.data_sha256),
            self.points,
            self.runs,
            num(self.rms_residual_mm),
            num(self.max_residual_mm),
            self.rank,
            self.parameters,
            num(self.condition_number),
            q(&self.noise),
            q(&self.frame),
            q(&self.nominal_name),
            q(&self.nominal_sha256),
            q(&self.nominal_model)
        )
    }
}

/// The frame a model file's `[provenance]` says its model was identified in, if it has one.
pub fn provenance_frame(model_file_text: &str) -> Option<Placement> {
    let table: toml::Table = model_file_text.parse().ok()?;
    match table.get("provenance")?.get("frame")?.as_str()? {
        "measurement" => Some(Placement::Identify),
        "robot base" => Some(Placement::Known),
        _ => None,
    }
}

/// The target label a model file's `[provenance]` records (`None` when the data named no
/// targets, or the file has no `[provenance]`).
pub fn provenance_target(model_file_text: &str) -> Option<String> {
    let table: toml::Table = model_file_text.parse().ok()?;
    Some(
        table
            .get("provenance")?
            .get("target")?
            .as_str()?
            .to_string(),
    )
}

/// The base reference reflectors a model file's `[provenance]` records: labels and where they
/// stood in the model's frame, mm (`None` when it records none or the record is malformed).
pub fn provenance_references(model_file_text: &str) -> Option<Vec<(String, [f64; 3])>> {
    let table: toml::Table = model_file_text.parse().ok()?;
    let p = table.get("provenance")?;
    let labels = p.get("reference_labels")?.as_array()?;
    let home = p.get("reference_home_mm")?.as_array()?;
    if labels.len() != home.len() || labels.is_empty() {
        return None;
    }
    labels
        .iter()
        .zip(home)
        .map(|(l, h)| {
            let h = h.as_array()?;
            let v: Vec<f64> = h.iter().filter_map(|x| x.as_float()).collect();
            (v.len() == 3 && h.len() == 3 && v.iter().all(|x| x.is_finite()))
                .then(|| (l.as_str().map(str::to_string), [v[0], v[1], v[2]]))
                .and_then(|(l, p)| Some((l?, p)))
        })
        .collect()
}

/// The nominal model a model file's `[provenance]` records.
#[derive(Clone, Debug, PartialEq)]
pub struct RecordedNominal {
    /// Its name.
    pub name: String,
    /// Its [`geometry_sha256`].
    pub sha256: String,
    /// The model itself, or why the recorded text does not give it (unreadable, or its geometry
    /// does not match the recorded SHA-256).
    pub model: Result<RobotModel, String>,
}

/// The nominal model a model file's `[provenance]` records (`None` when the file has no
/// `[provenance]` or it names no nominal model: files written before it did).
pub fn recorded_nominal(model_file_text: &str) -> Option<RecordedNominal> {
    let table: toml::Table = model_file_text.parse().ok()?;
    let p = table.get("provenance")?;
    let text = |k: &str| p.get(k).and_then(|v| v.as_str()).map(str::to_string);
    let (name, sha256) = (text("nominal_name")?, text("nominal_sha256")?);
    let model = match text("nominal_model") {
        None => Err("the field provenance.nominal_model is missing".to_string()),
        Some(t) => RobotModel::from_toml(&t, "provenance.nominal_model")
            .map_err(|e| e.to_string())
            .and_then(|m| {
                if geometry_sha256(&m) == sha256 {
                    Ok(m)
                } else {
                    Err("provenance.nominal_model does not match provenance.nominal_sha256".into())
                }
            }),
    };
    Some(RecordedNominal {
        name,
        sha256,
        model,
    })
}

/// A model file's `[provenance]` table alone, as TOML text (`None` when it has none), to
/// append to the model's [`RobotModel::to_toml`] again.
pub fn provenance_table(model_file_text: &str) -> Option<String> {
    let table: toml::Table = model_file_text.parse().ok()?;
    let p = table.get("provenance")?.clone();
    let mut only = toml::Table::new();
    only.insert("provenance".into(), p);
    let text = toml::to_string(&only).ok()?;
    Some(format!(
        "\n# Where this model came from (read and ignored by the model reader)\n{text}"
    ))
}

/// The identified model's file: the model's TOML, then (for runs through the whole-chain fit)
/// the `[provenance]` table of `ids` identified from `data` (the data file's bytes) with
/// `nominal` as the nominal model.
pub fn model_file_text(
    model: &RobotModel,
    nominal: &RobotModel,
    ids: &[Identification],
    data_file: &str,
    data: &[u8],
) -> String {
    let mut s = model.to_toml();
    if let Some(p) = Provenance::new(ids, nominal, data_file, data) {
        s.push_str(&p.to_toml());
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sha256_of_abc() {
        // FIPS 180-2 test vector
        assert_eq!(
            sha256_hex(b"abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
    }

    /// A model file with the table appended still reads as the same model.
    #[test]
    fn model_file_with_provenance_reads() {
        let m = crate::kinematics::tx60();
        let p = Provenance {
            data_file: "poses \"a\".csv".into(),
            data_sha256: sha256_hex(b"x"),
            points: 60,
            runs: 1,
            rms_residual_mm: 0.0147,
            max_residual_mm: 0.04,
            rank: 27,
            parameters: 27,
            condition_number: 17.3,
            noise: "estimated from the residuals".into(),
            frame: "measurement".into(),
            nominal_name: "UR5e".into(),
            nominal_sha256: geometry_sha256(&crate::presets::preset("ur5e").unwrap()),
            nominal_model: crate::presets::preset("ur5e").unwrap().to_toml(),
            not_identified: vec!["alpha4".into(), "tool_x".into()],
            target: Some("SMR 1".into()),
            references: vec![
                ("B1".into(), [1.5, -2.0, 3.25]),
                ("B2".into(), [4.0, 5.0, 6.0]),
            ],
        };
        let text = m.to_toml() + &p.to_toml();
        assert_eq!(provenance_target(&text).as_deref(), Some("SMR 1"));
        assert_eq!(provenance_target(&m.to_toml()), None);
        assert_eq!(provenance_references(&text), Some(p.references.clone()));
        assert_eq!(provenance_references(&m.to_toml()), None);
        let back = crate::kinematics::RobotModel::from_toml(&text, "t").unwrap();
        assert_eq!(back, m);
        let table: toml::Table = text.parse().unwrap();
        assert_eq!(table["provenance"]["points"].as_integer(), Some(60));
        assert_eq!(
            crate::identify::chain::not_identified(&text),
            vec!["alpha4", "tool_x"]
        );
        // The recorded nominal reads back as the model it was.
        let n = recorded_nominal(&text).unwrap();
        assert_eq!(n.name, "UR5e");
        let ur5e = crate::presets::preset("ur5e").unwrap();
        assert_eq!(
            geometry_sha256(n.model.as_ref().unwrap()),
            geometry_sha256(&ur5e)
        );
        // The table alone, appended to the model again, gives the same provenance.
        let again = m.to_toml() + &provenance_table(&text).unwrap();
        assert_eq!(recorded_nominal(&again), Some(n));
        assert_eq!(provenance_frame(&again), Some(Placement::Identify));
        // A tampered geometry is not taken for the recorded one.
        let bad = text.replace(&p.nominal_sha256, &sha256_hex(b"y"));
        assert!(recorded_nominal(&bad).unwrap().model.is_err());
    }

    /// The geometry's SHA-256 survives a round trip through the model file, and tells robots
    /// apart.
    #[test]
    fn geometry_sha256_is_stable_and_distinguishes() {
        for name in crate::presets::PRESETS {
            let m = crate::presets::preset(name).unwrap();
            let back = RobotModel::from_toml(&m.to_toml(), "t").unwrap();
            assert_eq!(geometry_sha256(&m), geometry_sha256(&back), "{name}");
        }
        let a = geometry_sha256(&crate::presets::preset("ur5e").unwrap());
        let b = geometry_sha256(&crate::presets::preset("ur10e").unwrap());
        assert_ne!(a, b);
    }
}
