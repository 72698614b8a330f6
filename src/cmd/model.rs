//! `model`: print a built-in model as a model file.

use super::outputs::Outputs;
use super::Run;
use anyhow::Result;
use clap::Args;
use gpu_amcs::presets::preset;
use std::path::PathBuf;

/// `model` options.
#[derive(Args, Debug, Clone)]
pub struct ModelCmdArgs {
    /// Built-in model to print.
    #[arg(long, default_value = "tx60", value_name = "NAME")]
    pub preset: String,
    /// Write to FILE instead of stdout.
    #[arg(long, short, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// List the built-in models instead.
    #[arg(long, conflicts_with = "out")]
    pub list: bool,
}

impl Run for ModelCmdArgs {
    fn run(self) -> Result<()> {
        if self.list {
            for name in gpu_amcs::presets::PRESETS {
                crate::cmd::stdout::println(&format!("{name:<10} {}", preset(name)?.name))?;
            }
            return Ok(());
        }
        let mut outputs = Outputs::new([]);
        outputs.file("--out", self.out.as_deref())?;
        outputs.write_or_print("--out", preset(&self.preset)?.to_toml())
    }
}
