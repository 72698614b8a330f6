//! `import`: a URDF (or xacro), DH table or UR calibration file to a model file, with the conversion proved.

use super::outputs::Outputs;
use super::Run;
use anyhow::Result;
use clap::Args;
use gpu_amcs::import::{import_file, ImportError, ImportOptions, JointHold};
use std::path::PathBuf;

/// `import` options.
#[derive(Args, Debug, Clone)]
pub struct ImportArgs {
    /// Robot description: .urdf/.xml (URDF), .xacro (expanded here, no ROS needed),
    /// .csv/.toml (standard or modified DH table), .yaml/.yml (UR calibration).
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
    /// xacro: the directory of package NAME for `$(find NAME)` (repeatable; without it a
    /// package is looked for upwards from the including file).
    #[arg(long = "package", value_name = "NAME=DIR", value_parser = package_pair)]
    pub packages: Vec<(String, PathBuf)>,
    /// xacro: set `$(arg NAME)` to VALUE, overriding the file's default (repeatable).
    #[arg(long = "xacro-arg", value_name = "NAME:=VALUE", value_parser = xacro_arg_pair)]
    pub xacro_args: Vec<(String, String)>,
    /// Hold joint JOINT (its name in the description, or its number along the chain) at DEG
    /// degrees: a seven-axis arm with one joint held imports as a six-axis model (repeatable).
    #[arg(long = "hold-joint", value_name = "JOINT=DEG", value_parser = hold_pair)]
    pub hold: Vec<(String, f64)>,
}

/// `JOINT=DEG`.
fn hold_pair(s: &str) -> Result<(String, f64), String> {
    match s.rsplit_once('=') {
        Some((j, d)) if !j.trim().is_empty() => match d.trim().parse::<f64>() {
            Ok(v) if v.is_finite() => Ok((j.trim().to_string(), v)),
            _ => Err(format!("'{d}' is not an angle in degrees")),
        },
        _ => Err(format!("expected JOINT=DEG, got '{s}'")),
    }
}

/// `NAME=DIR`.
fn package_pair(s: &str) -> Result<(String, PathBuf), String> {
    match s.split_once('=') {
        Some((n, d)) if !n.trim().is_empty() && !d.is_empty() => {
            Ok((n.trim().to_string(), PathBuf::from(d)))
        }
        _ => Err(format!("expected NAME=DIR, got '{s}'")),
    }
}

/// `NAME:=VALUE`.
fn xacro_arg_pair(s: &str) -> Result<(String, String), String> {
    match s.split_once(":=") {
        Some((n, v)) if !n.trim().is_empty() => Ok((n.trim().to_string(), v.to_string())),
        _ => Err(format!("expected NAME:=VALUE, got '{s}'")),
    }
}

/// The pairs as a map; a name given twice is an error naming `flag`.
fn unique<V: Clone>(
    pairs: &[(String, V)],
    flag: &str,
) -> Result<std::collections::BTreeMap<String, V>> {
    let mut m = std::collections::BTreeMap::new();
    for (k, v) in pairs {
        if m.insert(k.clone(), v.clone()).is_some() {
            anyhow::bail!("{flag} {k} is given twice");
        }
    }
    Ok(m)
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
            packages: unique(&a.packages, "--package")?,
            xacro_args: unique(&a.xacro_args, "--xacro-arg")?,
            held: a
                .hold
                .iter()
                .map(|(joint, angle_deg)| JointHold {
                    joint: joint.clone(),
                    angle_deg: *angle_deg,
                })
                .collect(),
        };
        let imported = import_file(&a.source, &opts).map_err(|e| match e {
            ImportError::Branching { .. } => anyhow::anyhow!("{e} (--tip LINK)"),
            ImportError::Chain { ref message, .. } if message.contains("hold") => {
                anyhow::anyhow!("{e} (--hold-joint JOINT=DEG)")
            }
            // A geometry the chain without holds does not have: the holds made it (two free
            // joints left turning about one line, say).
            ImportError::NotRepresentable { .. }
                if !opts.held.is_empty()
                    && import_file(
                        &a.source,
                        &ImportOptions {
                            held: Vec::new(),
                            ..opts.clone()
                        },
                    )
                    .is_ok() =>
            {
                let held: Vec<String> = a.hold.iter().map(|(j, d)| format!("{j}={d}")).collect();
                anyhow::anyhow!(
                    "--hold-joint {}: with these joints held, {e}; the chain without them imports, so hold other joints or at other angles",
                    held.join(", ")
                )
            }
            _ => e.into(),
        })?;
        // A xacro's included files are known only now: --out must not be one of them.
        outputs.inputs_read(
            "read by the xacro expansion",
            imported.files.iter().map(PathBuf::as_path),
        )?;
        outputs.stage_file("--out", imported.to_toml())?;
        outputs.commit()?;
        for n in &imported.notes {
            eprintln!("note: {n}");
        }
        // Where joint 1 stands in the description's frame, when it is not at the origin along z.
        if let Some(b) = imported.model.base {
            let f = |v: &[f64; 3], deg: bool| -> String {
                v.iter()
                    .map(|&x| {
                        let x = if deg { x.to_degrees() } else { x };
                        gpu_amcs::number::fmt_plain((x * 1e6).round() / 1e6 + 0.0)
                    })
                    .collect::<Vec<_>>()
                    .join(", ")
            };
            eprintln!(
                "note: joint 1's frame in the description: xyz ({}) mm, rpy ({})° (the model's base)",
                f(&b.xyz, false),
                f(&b.rpy, true)
            );
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
