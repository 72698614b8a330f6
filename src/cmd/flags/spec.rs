//! The flag of each field of the library's problem spec ([`gpu_amcs::spec::ProblemSpec`]), and
//! spec errors shown with the flag the user typed.

use gpu_amcs::spec::{SpecError, SpecField};

/// The flag that sets each field of a [`gpu_amcs::spec::ProblemSpec`] (`ProblemArgs`). Given
/// configurations have no flag of their own: the command line gives them as a points file.
pub fn spec_flag(field: SpecField) -> &'static str {
    match field {
        SpecField::Model => "--model",
        SpecField::Preset => "--preset",
        SpecField::Points => "--points",
        SpecField::PointsSeed => "--points-seed",
        SpecField::BoxCenter => "--box-center",
        SpecField::BoxSize => "--box-size",
        SpecField::PointsFile => "--points-file",
        SpecField::Configurations => "--points-file",
        SpecField::Reference => "--reference",
        SpecField::Nominal => "--nominal",
        SpecField::Seed => "--seed",
        SpecField::Backend => "--backend",
        SpecField::Adapter => "--adapter",
        SpecField::Discrepancy => "--no-discrepancy",
        SpecField::Payload => "--payload-kg",
        // The command line gives sides as a points file's s1..sn columns.
        SpecField::Sides => "--points-file",
    }
}

/// A spec error as the command line shows it: the flag, then the cause.
pub fn spec_error(e: SpecError) -> anyhow::Error {
    use gpu_amcs::import::ImportError;
    use gpu_amcs::spec::SpecErrorKind;
    // A branching URDF whose tip could not be chosen: say how to name one.
    if let SpecErrorKind::Import(ImportError::Branching { .. }) = &e.kind {
        return anyhow::anyhow!(
            "{}: {}: name the tip link with --tip LINK",
            spec_flag(e.field),
            e.kind
        );
    }
    if let SpecErrorKind::NoNominal { model } = &e.kind {
        return anyhow::anyhow!(
            "--reference nominal: the model '{model}' is not a preset and has no nominal model: \
             give --nominal FILE"
        );
    }
    anyhow::Error::new(e.kind).context(spec_flag(e.field))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cli::Cli;
    use clap::CommandFactory;
    use gpu_amcs::kinematics::tx60;
    use gpu_amcs::spec::{
        GeneratedPoints, ModelSource, PointsSource, ProblemSpec, ReferenceSource,
    };
    use std::collections::BTreeSet;

    /// Dotted paths of the leaves of a JSON value (object keys joined by dots).
    fn leaves(v: &serde_json::Value, at: &str, out: &mut BTreeSet<String>) {
        match v {
            serde_json::Value::Object(m) if !m.is_empty() => {
                for (k, v) in m {
                    let p = if at.is_empty() {
                        k.clone()
                    } else {
                        format!("{at}.{k}")
                    };
                    leaves(v, &p, out);
                }
            }
            _ => {
                out.insert(at.to_string());
            }
        }
    }

    /// Every key of a serialized spec, over every variant of every source.
    fn spec_keys() -> BTreeSet<String> {
        let base = ProblemSpec::default();
        let specs = [
            base.clone(),
            ProblemSpec {
                points: PointsSource::Generate(GeneratedPoints {
                    box_center: Some([1.0, 2.0, 3.0]),
                    box_size: Some([4.0, 5.0, 6.0]),
                    ..Default::default()
                }),
                reference: ReferenceSource::Nominal(None),
                adapter: Some("x".into()),
                ..base.clone()
            },
            ProblemSpec {
                model: ModelSource::File("m.toml".into()),
                points: PointsSource::File("p.csv".into()),
                reference: ReferenceSource::Nominal(Some(ModelSource::Preset("tx60".into()))),
                ..base.clone()
            },
            ProblemSpec {
                model: ModelSource::Model(Box::new(tx60())),
                points: PointsSource::Given(vec![[0.0; 6].into()]),
                reference: ReferenceSource::Nominal(Some(ModelSource::File("n.toml".into()))),
                ..base
            },
        ];
        let mut keys = BTreeSet::new();
        for s in &specs {
            leaves(&serde_json::to_value(s).unwrap(), "", &mut keys);
        }
        keys
    }

    /// The long flags (with `--`) of the subcommand `name` (the top level for `None`).
    fn flags_of(name: Option<&str>) -> BTreeSet<String> {
        let cli = Cli::command();
        let cmd = match name {
            Some(n) => cli.find_subcommand(n).unwrap().clone(),
            None => cli,
        };
        cmd.get_arguments()
            .filter_map(|a| a.get_long())
            .map(|l| format!("--{l}"))
            .collect()
    }

    /// Fails when a field of `ProblemSpec` has no flag: every key of a serialized spec belongs
    /// to a `SpecField`, and every field's flag is a flag of each subcommand that takes the
    /// problem flags.
    #[test]
    fn every_problem_spec_field_has_a_flag() {
        let keys = spec_keys();
        let mut fields = BTreeSet::new();
        for k in &keys {
            let f = SpecField::at_path(k).unwrap_or_else(|| {
                panic!("ProblemSpec key '{k}' belongs to no SpecField: add one and its flag")
            });
            fields.insert(f.name());
        }
        let all: BTreeSet<_> = SpecField::ALL.iter().map(|f| f.name()).collect();
        assert_eq!(fields, all, "SpecFields not found in a serialized spec");
        for cmd in [
            None,
            Some("amcs"),
            Some("mcs"),
            Some("compare"),
            Some("sensitivity"),
            Some("tail"),
        ] {
            let flags = flags_of(cmd);
            for f in SpecField::ALL {
                let flag = spec_flag(f);
                assert!(
                    flags.contains(flag),
                    "{cmd:?}: {flag} (for {f}) is not a flag; it has {flags:?}"
                );
            }
        }
    }

    #[test]
    fn spec_errors_lead_with_the_flag() {
        let e = ProblemSpec {
            model: ModelSource::Preset("tx90".into()),
            ..Default::default()
        }
        .build_problem()
        .unwrap_err();
        let e = spec_error(e);
        assert_eq!(
            format!("{e:#}"),
            "--preset: unknown preset 'tx90' (known: tx60, ur5e, ur10e, irb2400, kr6r700sixx, iiwa14, panda)"
        );
    }
}
