//! Where a spec's model comes from: a preset, a model file, a robot description or a model
//! given directly ([`ModelSource`]).

use super::{SpecErrorKind, SpecField};
use crate::import::{self, ImportOptions};
use crate::kinematics::RobotModel;
use crate::presets::preset;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Where the model comes from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ModelSource {
    /// A built-in model by name ([`crate::presets::PRESETS`]).
    Preset(String),
    /// A model file (TOML, mm and degrees), or a robot description imported on the fly by its
    /// extension (URDF `.urdf`/`.xml`/`.xacro`, DH table `.csv`, UR calibration `.yaml`/`.yml`),
    /// with the same proof as [`import::import_file`]. A `.toml` is always a model file.
    File(PathBuf),
    /// A robot description imported with its tip link named (a URDF whose tree branches).
    Description {
        /// The description file.
        path: PathBuf,
        /// The tip link.
        tip: String,
    },
    /// A model in memory; serialized as its model-file text ([`RobotModel::to_toml`]).
    #[serde(rename = "toml", with = "model_toml")]
    Model(Box<RobotModel>),
}

/// (De)serializes an in-memory model as its model-file text.
mod model_toml {
    use crate::kinematics::RobotModel;
    use serde::{Deserialize, Deserializer, Serializer};

    pub fn serialize<S: Serializer>(m: &RobotModel, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&m.to_toml())
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Box<RobotModel>, D::Error> {
        let text = String::deserialize(d)?;
        RobotModel::from_toml(&text, "the spec's model text")
            .map(Box::new)
            .map_err(serde::de::Error::custom)
    }
}

/// Whether `path` names a robot description to import rather than a model file (by its
/// extension: `.urdf`, `.xml`, `.xacro`, `.csv`, `.yaml`, `.yml`).
pub fn is_description(path: &Path) -> bool {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    matches!(
        ext.as_deref(),
        Some("urdf" | "xml" | "yaml" | "yml" | "csv" | "xacro")
    )
}

impl ModelSource {
    /// The file `file` when given, else the preset `name` (the command line's `--model` and
    /// `--preset`).
    pub fn file_or_preset(file: Option<&Path>, name: &str) -> ModelSource {
        match file {
            Some(p) => ModelSource::File(p.to_path_buf()),
            None => ModelSource::Preset(name.to_string()),
        }
    }

    /// Reads, imports or copies the model.
    ///
    /// # Errors
    /// [`SpecErrorKind::Model`] for an unknown preset or a model file that cannot be read or is
    /// invalid, [`SpecErrorKind::Import`] for a robot description that cannot be imported.
    pub fn load(&self) -> Result<RobotModel, SpecErrorKind> {
        self.load_noted().map(|(m, _)| m)
    }

    /// [`Self::load`], with what an import chose on the user's behalf (the tip link of a URDF
    /// given without one), and for an identified model file whose data did not determine some
    /// parameters, that it was not fully identified; one line each.
    ///
    /// # Errors
    /// As [`Self::load`].
    pub fn load_noted(&self) -> Result<(RobotModel, Vec<String>), SpecErrorKind> {
        let imported = |p: &Path, opts: &ImportOptions| -> Result<_, SpecErrorKind> {
            let i = import::import_file(p, opts)?;
            Ok((i.model, i.notes))
        };
        Ok(match self {
            ModelSource::Preset(name) => (preset(name)?, Vec::new()),
            ModelSource::File(p) if is_description(p) => imported(p, &ImportOptions::default())?,
            ModelSource::File(p) => (
                RobotModel::from_file(p)?,
                // an identified model whose data left parameters at their prior says so
                crate::identify::chain::not_identified_note_of_file(p)
                    .into_iter()
                    .collect(),
            ),
            ModelSource::Description { path, tip } => imported(
                path,
                &ImportOptions {
                    tip: Some(tip.clone()),
                    ..ImportOptions::default()
                },
            )?,
            ModelSource::Model(m) => ((**m).clone(), Vec::new()),
        })
    }

    /// How errors about the model as a whole name this source: the file's path, `preset NAME`,
    /// or `model 'NAME'` for a model given in memory.
    pub fn describe(&self) -> String {
        match self {
            ModelSource::Preset(name) => format!("preset {name}"),
            ModelSource::File(p) | ModelSource::Description { path: p, .. } => {
                p.display().to_string()
            }
            ModelSource::Model(m) => format!("model '{}'", m.name),
        }
    }

    /// The field that names this source when it is the analysed model: [`SpecField::Preset`]
    /// for a preset, [`SpecField::Model`] otherwise.
    pub fn field(&self) -> SpecField {
        match self {
            ModelSource::Preset(_) => SpecField::Preset,
            _ => SpecField::Model,
        }
    }
}
