//! Where an identified model came from, written into its model file as a `[provenance]` table:
//! the data file and its SHA-256, the number of points and runs, the fit's residuals, the rank
//! and condition number, how the noise was obtained and the frame. The model reader accepts and
//! ignores the table, so the file stays a plain model file.

use super::chain::Placement;
use super::Identification;

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
}

pub use crate::digest::sha256_hex;

impl Provenance {
    /// The provenance of `ids` (runs through the whole-chain fit; `None` when none did),
    /// identified from `data` read from `data_file`.
    pub fn new(ids: &[Identification], data_file: &str, data: &[u8]) -> Option<Provenance> {
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
        format!(
            "\n# Where this model came from (read and ignored by the model reader)\n[provenance]\n\
             data_file = {}\ndata_sha256 = {}\npoints = {}\nruns = {}\nrms_residual_mm = {}\n\
             max_residual_mm = {}\nrank = {}\nparameters = {}\ncondition_number = {}\nnoise = {}\n\
             frame = {}\n",
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
            q(&self.frame)
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

/// The identified model's file: the model's TOML, then (for runs through the whole-chain fit)
/// the `[provenance]` table of `ids` identified from `data` (the data file's bytes).
pub fn model_file_text(
    model: &crate::kinematics::RobotModel,
    ids: &[Identification],
    data_file: &str,
    data: &[u8],
) -> String {
    let mut s = model.to_toml();
    if let Some(p) = Provenance::new(ids, data_file, data) {
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
        };
        let text = m.to_toml() + &p.to_toml();
        let back = crate::kinematics::RobotModel::from_toml(&text, "t").unwrap();
        assert_eq!(back, m);
        let table: toml::Table = text.parse().unwrap();
        assert_eq!(table["provenance"]["points"].as_integer(), Some(60));
    }
}
