//! `import`: a URDF, DH table or UR calibration file to a model file, with the conversion proved.

use super::outputs::Outputs;
use super::Run;
use anyhow::Result;
use clap::Args;
use gpu_amcs::import::{import_file, ImportError, ImportOptions};
use std::path::PathBuf;

/// `import` options.
#[derive(Args, Debug, Clone)]
pub struct ImportArgs {
    /// Robot description: .urdf/.xml (URDF), .csv/.toml (standard or modified DH table),
    /// .yaml/.yml (UR calibration).
    #[arg(value_name = "FILE")]
    pub source: PathBuf,
    /// Model file to write (TOML).
    #[arg(long, short, value_name = "FILE")]
    pub out: PathBuf,
    /// URDF: base link of the chain (default: the root link).
    #[arg(long, value_name = "LINK")]
    pub base: Option<String>,
    /// URDF: tip link of the chain; its origin becomes the tool point (default: the single leaf).
    #[arg(long, value_name = "LINK")]
    pub tip: Option<String>,
    /// Model name (default: the robot's name in the file, else the file name).
    #[arg(long, value_name = "NAME")]
    pub name: Option<String>,
}

impl Run for ImportArgs {
    fn run(self) -> Result<()> {
        let a = self;
        let mut outputs = Outputs::new([("the robot description", a.source.as_path())]);
        outputs.file("--out", Some(&a.out))?;
        let opts = ImportOptions {
            base: a.base.clone(),
            tip: a.tip.clone(),
            name: a.name.clone(),
        };
        let imported = import_file(&a.source, &opts).map_err(|e| match e {
            ImportError::Branching { .. } => anyhow::anyhow!("{e} (--tip LINK)"),
            _ => e.into(),
        })?;
        outputs.stage_file("--out", imported.to_toml())?;
        outputs.commit()?;
        for n in &imported.notes {
            eprintln!("note: {n}");
        }
        for w in &imported.warnings {
            eprintln!("warning: {w}");
        }
        crate::cmd::stdout::println(&format!(
            "imported {} ({}) -> {}: max deviation source vs model {:e} mm over {} configurations",
            a.source.display(),
            imported.format.name(),
            a.out.display(),
            imported.max_deviation_mm,
            imported.configurations
        ))?;
        Ok(())
    }
}
