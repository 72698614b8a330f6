//! Field → flag, in one place: which flags set each field of every library options struct the
//! command line fills ([`TABLES`]), and through those tables the flag a library setting error is
//! given ([`Driver::error`], [`sensitivity_error`], [`tail_error`], [`map_error`],
//! [`simulate_error`]).
//!
//! The library names its settings with enums (`Setting`, `SensitivitySetting`, `TailSetting`,
//! `MapSetting`, `SimulateSetting`), matched here without a wildcard, so a new setting does not
//! compile until it is given its field (and the flag is `None` only where the table says the
//! field is fixed, and why). The tests below check that every field of every struct in
//! [`TABLES`] has an entry (a field added to or renamed in a struct fails them until its table
//! has it), that every flag in the tables exists in clap's definition of their subcommands, and
//! that every setting an error can name maps to a field of its tables.

use gpu_amcs::map::{MapError, MapSetting};
use gpu_amcs::mc::sensitivity::{SensitivityError, SensitivitySetting};
use gpu_amcs::mc::tail::{TailError, TailSetting};
use gpu_amcs::mc::{McError, Setting};
use gpu_amcs::simulate::{SimulateError, SimulateSetting};
use std::fmt::Display;

/// Where a field's value comes from on the command line. (The nested tables, the reasons, the
/// subcommands and [`TABLES`] are read by the tests, which check them against the library's
/// structs and clap's flags.)
#[derive(Clone, Copy, Debug)]
#[cfg_attr(not(test), allow(dead_code))]
pub enum Source {
    /// The flags that set it.
    Flags(&'static [&'static str]),
    /// The fields of another struct, by its table.
    Nested(&'static Table),
    /// No flag sets it: why.
    Fixed(&'static str),
}

/// The fields of one library options struct as one group of subcommands fills it.
#[derive(Debug)]
#[cfg_attr(not(test), allow(dead_code))]
pub struct Table {
    /// The struct's path in the library.
    pub name: &'static str,
    /// The subcommands whose flags fill it.
    pub commands: &'static [&'static str],
    /// Every field of the struct and where it comes from.
    pub fields: &'static [(&'static str, Source)],
}

use Source::{Fixed, Flags, Nested};

/// `mc::RunSettings` in `amcs` and `mcs`.
pub const RUN_SETTINGS: Table = Table {
    name: "mc::RunSettings",
    commands: &["amcs", "mcs"],
    fields: &[
        ("coverage_probability", Flags(&["--coverage"])),
        ("interval", Flags(&["--interval"])),
        ("thresholds", Flags(&["--thresholds"])),
        ("per_point", Flags(&["--per-point"])),
    ],
};

/// `mc::AmcsOptions` in `amcs`.
pub const AMCS_OPTIONS: Table = Table {
    name: "mc::AmcsOptions",
    commands: &["amcs"],
    fields: &[
        ("tolerance", Flags(&["--delta", "--ndig"])),
        ("batch_size", Flags(&["--batch"])),
        ("max_draws", Flags(&["--max-draws"])),
        ("settings", Nested(&RUN_SETTINGS)),
    ],
};

/// `mc::McsOptions` in `mcs`.
pub const MCS_OPTIONS: Table = Table {
    name: "mc::McsOptions",
    commands: &["mcs"],
    fields: &[
        ("draws", Flags(&["--draws"])),
        (
            "chunk",
            Fixed(
                "10^5 draws per evaluation (fewer for a smaller run): results do not depend on it",
            ),
        ),
        ("settings", Nested(&RUN_SETTINGS)),
    ],
};

/// `mc::RunSettings` in `compare`.
pub const COMPARE_SETTINGS: Table = Table {
    name: "mc::RunSettings",
    commands: &["compare"],
    fields: &[
        ("coverage_probability", Flags(&["--coverage"])),
        (
            "interval",
            Fixed("the default: a comparison is of the moments"),
        ),
        (
            "thresholds",
            Fixed("the default: a comparison is of the moments"),
        ),
        ("per_point", Fixed("off: a comparison is of the moments")),
    ],
};

/// `mc::AmcsOptions` in `compare`.
pub const COMPARE_AMCS: Table = Table {
    name: "mc::AmcsOptions",
    commands: &["compare"],
    fields: &[
        ("tolerance", Flags(&["--deltas"])),
        ("batch_size", Flags(&["--batch"])),
        (
            "max_draws",
            Fixed("10^8: each AMCS run of a comparison is to converge"),
        ),
        ("settings", Nested(&COMPARE_SETTINGS)),
    ],
};

/// `mc::McsOptions` in `compare`.
pub const COMPARE_MCS: Table = Table {
    name: "mc::McsOptions",
    commands: &["compare"],
    fields: &[
        ("draws", Flags(&["--draws"])),
        ("chunk", Fixed("as in mcs: results do not depend on it")),
        ("settings", Nested(&COMPARE_SETTINGS)),
    ],
};

/// `mc::sensitivity::SensitivityOptions` in `sensitivity`.
pub const SENSITIVITY_OPTIONS: Table = Table {
    name: "mc::sensitivity::SensitivityOptions",
    commands: &["sensitivity"],
    fields: &[
        ("draws", Flags(&["--draws"])),
        ("bootstrap", Flags(&["--bootstrap"])),
        ("bootstrap_seed", Flags(&["--bootstrap-seed"])),
        (
            "chunk",
            Fixed("the library's default: results do not depend on it"),
        ),
        ("thresholds", Flags(&["--thresholds"])),
    ],
};

/// `mc::tail::TailOptions` in `tail`.
pub const TAIL_OPTIONS: Table = Table {
    name: "mc::tail::TailOptions",
    commands: &["tail"],
    fields: &[
        ("method", Flags(&["--method"])),
        ("thresholds", Flags(&["--threshold"])),
        ("target_cov", Flags(&["--cov"])),
        ("max_evaluations", Flags(&["--max-evaluations"])),
        ("samples_per_level", Flags(&["--samples-per-level"])),
        ("p0", Flags(&["--p0"])),
        (
            "proposal",
            Fixed("adaptive conditional sampling, the library's default"),
        ),
        (
            "proposal_spread",
            Fixed("used only by the modified Metropolis proposal"),
        ),
        (
            "batch_size",
            Fixed("the library's default: results do not depend on it"),
        ),
    ],
};

/// `map::MapSpec` in `map`.
pub const MAP_SPEC: Table = Table {
    name: "map::MapSpec",
    commands: &["map"],
    fields: &[
        ("grid", Flags(&["--plane", "--at", "--cells"])),
        ("workspace", Flags(&["--box-center", "--box-size"])),
        (
            "orientation_rpy_deg",
            Flags(&["--orientation", "--free-orientation"]),
        ),
        ("reference_q_deg", Flags(&["--reference-q"])),
        ("ik_seeds", Flags(&["--ik-seeds"])),
    ],
};

/// The arguments of `map::check_run` and `map::evaluate_cells` in `map` (not a struct).
pub const MAP_RUN: Table = Table {
    name: "map::check_run",
    commands: &["map"],
    fields: &[
        ("thresholds", Flags(&["--thresholds"])),
        ("draws", Flags(&["--draws"])),
    ],
};

/// `simulate::Factors` in `simulate` and `calibrate`.
pub const FACTORS: Table = Table {
    name: "simulate::Factors",
    commands: &["simulate", "calibrate"],
    fields: &[
        ("runs", Flags(&["--runs"])),
        ("range_fraction", Flags(&["--range"])),
        ("step_deg", Flags(&["--step"])),
        ("speed_fraction", Flags(&["--speed"])),
        ("direction", Flags(&["--start"])),
    ],
};

/// `simulate::Factors` as the study's baseline.
pub const STUDY_BASELINE: Table = Table {
    name: "simulate::Factors",
    commands: &["study"],
    fields: &[
        ("runs", Flags(&["--runs"])),
        (
            "range_fraction",
            Fixed("the paper's baseline; the factor's levels vary it"),
        ),
        (
            "step_deg",
            Fixed("the paper's baseline; the factor's levels vary it"),
        ),
        (
            "speed_fraction",
            Fixed("the paper's baseline; the factor's levels vary it"),
        ),
        (
            "direction",
            Fixed("the paper's baseline; the factor's levels vary it"),
        ),
    ],
};

/// `study::StudySettings` in `study`.
pub const STUDY_SETTINGS: Table = Table {
    name: "study::StudySettings",
    commands: &["study"],
    fields: &[
        ("quick", Flags(&["--quick"])),
        ("baseline", Nested(&STUDY_BASELINE)),
        ("factors", Flags(&["--factors"])),
        ("robot_seed", Flags(&["--robot-seed"])),
        ("calibration_seed", Flags(&["--seed"])),
        (
            "mc_seed",
            Fixed("the library's default: the study's draws are fixed"),
        ),
        (
            "points_seed",
            Fixed("the library's default: the study's points are fixed"),
        ),
        ("point_counts", Flags(&["--points"])),
        ("mcs_draws", Flags(&["--mcs-draws"])),
        ("deltas", Flags(&["--deltas"])),
        ("batch", Fixed("the paper's batch size H = 10^4")),
        ("thresholds", Fixed("the paper's thresholds 0.1 to 0.8 mm")),
        (
            "workspace",
            Fixed("the studied robot's default box (from --model/--preset)"),
        ),
        ("accuracy_points", Fixed("the library's default")),
        (
            "sensitivity_draws",
            Fixed("the library's default (2^12, --quick 2^10)"),
        ),
        ("backend", Flags(&["--backend"])),
        ("adapter", Flags(&["--adapter"])),
    ],
};

/// Every table.
#[cfg_attr(not(test), allow(dead_code))]
pub const TABLES: &[&Table] = &[
    &RUN_SETTINGS,
    &AMCS_OPTIONS,
    &MCS_OPTIONS,
    &COMPARE_SETTINGS,
    &COMPARE_AMCS,
    &COMPARE_MCS,
    &SENSITIVITY_OPTIONS,
    &TAIL_OPTIONS,
    &MAP_SPEC,
    &MAP_RUN,
    &FACTORS,
    &STUDY_BASELINE,
    &STUDY_SETTINGS,
];

/// A setting error as one line: the setting, its flag when it has one, and what is wrong.
fn named(field: impl Display, flag: Option<&str>, message: &str) -> anyhow::Error {
    match flag {
        Some(flag) => anyhow::anyhow!("{field} ({flag}): {message}"),
        None => anyhow::anyhow!("{field}: {message}"),
    }
}

/// `flag` when table `t` says it sets `field`; `None` when the field is fixed there or set by
/// other flags (the subcommand has no `flag`).
fn on(t: &Table, field: &str, flag: &'static str) -> Option<&'static str> {
    match t.fields.iter().find(|(f, _)| *f == field) {
        Some((_, Flags(flags))) => flags.contains(&flag).then_some(flag),
        Some(_) => None,
        None => {
            // A field this file misnames: the tests run every setting through here.
            debug_assert!(false, "{}: no field {field}", t.name);
            if cfg!(test) {
                panic!("{}: no field {field}", t.name);
            }
            None
        }
    }
}

/// The subcommands that run the MCS and AMCS drivers, whose settings ([`Setting`]) have
/// different flags.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Driver {
    /// `amcs` (and the default run) and `mcs` (and `merge`, which reports an `mcs` run):
    /// [`AMCS_OPTIONS`], [`MCS_OPTIONS`], [`RUN_SETTINGS`].
    Run,
    /// `compare`: [`COMPARE_AMCS`], [`COMPARE_MCS`], [`COMPARE_SETTINGS`].
    Compare,
}

impl Driver {
    /// The tables of the AMCS options, the MCS options and the run settings.
    fn tables(self) -> [&'static Table; 3] {
        match self {
            Driver::Run => [&AMCS_OPTIONS, &MCS_OPTIONS, &RUN_SETTINGS],
            Driver::Compare => [&COMPARE_AMCS, &COMPARE_MCS, &COMPARE_SETTINGS],
        }
    }

    /// The flag of a driver setting, if the subcommand has one.
    pub fn flag(self, s: Setting) -> Option<&'static str> {
        let [amcs, mcs, settings] = self.tables();
        match s {
            Setting::CoverageProbability => on(settings, "coverage_probability", "--coverage"),
            Setting::Thresholds => on(settings, "thresholds", "--thresholds"),
            Setting::Tolerance => {
                on(amcs, "tolerance", "--delta").or(on(amcs, "tolerance", "--deltas"))
            }
            Setting::SignificantDigits => on(amcs, "tolerance", "--ndig"),
            Setting::BatchSize => on(amcs, "batch_size", "--batch"),
            Setting::MaxDraws => on(amcs, "max_draws", "--max-draws"),
            Setting::Draws => on(mcs, "draws", "--draws"),
            Setting::Chunk => on(mcs, "chunk", "--chunk"),
        }
    }

    /// A driver error with the flag added to a setting's name.
    pub fn error(self, e: McError) -> anyhow::Error {
        match e {
            McError::Setting { field, message } => named(field, self.flag(field), &message),
            other => other.into(),
        }
    }
}

/// The flag of a sensitivity setting.
pub fn sensitivity(s: SensitivitySetting) -> Option<&'static str> {
    let t = &SENSITIVITY_OPTIONS;
    match s {
        SensitivitySetting::Draws => on(t, "draws", "--draws"),
        SensitivitySetting::Bootstrap => on(t, "bootstrap", "--bootstrap"),
        SensitivitySetting::Chunk => on(t, "chunk", "--chunk"),
        SensitivitySetting::Thresholds => on(t, "thresholds", "--thresholds"),
    }
}

/// A sensitivity error with the flag added to a setting's name.
pub fn sensitivity_error(e: SensitivityError) -> anyhow::Error {
    match e {
        SensitivityError::Setting { field, message } => named(field, sensitivity(field), &message),
        other => other.into(),
    }
}

/// The flag of a tail setting.
pub fn tail(s: TailSetting) -> Option<&'static str> {
    let t = &TAIL_OPTIONS;
    match s {
        TailSetting::Thresholds => on(t, "thresholds", "--threshold"),
        TailSetting::TargetCov => on(t, "target_cov", "--cov"),
        TailSetting::MaxEvaluations => on(t, "max_evaluations", "--max-evaluations"),
        TailSetting::SamplesPerLevel => on(t, "samples_per_level", "--samples-per-level"),
        TailSetting::P0 => on(t, "p0", "--p0"),
        TailSetting::ProposalSpread => on(t, "proposal_spread", "--proposal-spread"),
        TailSetting::BatchSize => on(t, "batch_size", "--batch-size"),
    }
}

/// A tail error with the flag added to a setting's name.
pub fn tail_error(e: TailError) -> anyhow::Error {
    match e {
        TailError::Setting { field, message } => named(field, tail(field), &message),
        other => other.into(),
    }
}

/// The flag of a map setting (the workspace box has two).
pub fn map(s: MapSetting) -> Option<&'static str> {
    let (spec, run) = (&MAP_SPEC, &MAP_RUN);
    match s {
        MapSetting::Cells => on(spec, "grid", "--cells"),
        MapSetting::PlanePosition => on(spec, "grid", "--at"),
        MapSetting::Workspace => {
            on(spec, "workspace", "--box-center").map(|_| "--box-center/--box-size")
        }
        MapSetting::Orientation => on(spec, "orientation_rpy_deg", "--orientation"),
        MapSetting::ReferenceConfiguration => on(spec, "reference_q_deg", "--reference-q"),
        MapSetting::IkSeeds => on(spec, "ik_seeds", "--ik-seeds"),
        MapSetting::Thresholds => on(run, "thresholds", "--thresholds"),
        MapSetting::Draws => on(run, "draws", "--draws"),
    }
}

/// A map error with the flag added to a setting's name.
pub fn map_error(e: MapError) -> anyhow::Error {
    match e {
        MapError::Setting { field, message } => named(field, map(field), &message),
        other => other.into(),
    }
}

/// The flag of a simulation or study setting.
pub fn simulate(s: SimulateSetting) -> Option<&'static str> {
    let (factors, study) = (&FACTORS, &STUDY_SETTINGS);
    match s {
        SimulateSetting::Runs => on(factors, "runs", "--runs"),
        SimulateSetting::Range => on(factors, "range_fraction", "--range"),
        SimulateSetting::Step => on(factors, "step_deg", "--step"),
        SimulateSetting::Speed => on(factors, "speed_fraction", "--speed"),
        SimulateSetting::PointCounts => on(study, "point_counts", "--points"),
        SimulateSetting::McsDraws => on(study, "mcs_draws", "--mcs-draws"),
        SimulateSetting::Tolerances => on(study, "deltas", "--deltas"),
        SimulateSetting::Factors => on(study, "factors", "--factors"),
    }
}

/// A simulation or study error with the flag added to a setting's name.
pub fn simulate_error(e: SimulateError) -> anyhow::Error {
    match e {
        SimulateError::Setting { field, message } => named(field, simulate(field), &message),
        other => other.into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cli::Cli;
    use clap::CommandFactory;
    use std::collections::BTreeSet;

    /// The names of the fields of struct `$ty`. The pattern names every field and has no `..`,
    /// so a field added to (or renamed in) the struct fails to compile here until it is listed,
    /// and then [`same_fields`] fails until its table has an entry for it.
    macro_rules! fields {
        ($ty:ident { $($f:ident),* $(,)? }) => {{
            #[allow(dead_code)]
            fn every_field_is_listed(x: &$ty) {
                let $ty { $($f: _),* } = x;
            }
            vec![$(stringify!($f)),*]
        }};
    }

    /// The long flags of subcommand `command`.
    fn clap_flags(command: &str) -> BTreeSet<String> {
        let cli = Cli::command();
        let sub = cli
            .find_subcommand(command)
            .unwrap_or_else(|| panic!("no subcommand {command}"));
        sub.get_arguments()
            .filter_map(|a| a.get_long().map(|l| format!("--{l}")))
            .collect()
    }

    /// The flags a table names itself (not those of its nested tables).
    fn own_flags(t: &Table) -> BTreeSet<&'static str> {
        t.fields
            .iter()
            .filter_map(|(_, from)| match from {
                Flags(f) => Some(f.iter().copied()),
                _ => None,
            })
            .flatten()
            .collect()
    }

    /// The flags of a table and of its nested tables.
    fn all_flags(t: &Table) -> BTreeSet<&'static str> {
        let mut out = own_flags(t);
        for (_, from) in t.fields {
            if let Nested(n) = from {
                out.extend(all_flags(n));
            }
        }
        out
    }

    /// `fields` (of the library struct) are exactly the fields of table `t`.
    fn same_fields(t: &Table, fields: &[&str]) {
        let mine: BTreeSet<&str> = t.fields.iter().map(|(f, _)| *f).collect();
        let theirs: BTreeSet<&str> = fields.iter().copied().collect();
        assert_eq!(mine.len(), t.fields.len(), "{}: a field twice", t.name);
        if let Some(f) = theirs.difference(&mine).next() {
            panic!("{}: field {f} has no entry in cmd/flags.rs", t.name);
        }
        if let Some(f) = mine.difference(&theirs).next() {
            panic!("{}: cmd/flags.rs names {f}, which it does not have", t.name);
        }
    }

    #[test]
    fn every_field_of_every_options_struct_has_an_entry() {
        use gpu_amcs::map::MapSpec;
        use gpu_amcs::mc::sensitivity::SensitivityOptions;
        use gpu_amcs::mc::tail::TailOptions;
        use gpu_amcs::mc::{AmcsOptions, McsOptions, RunSettings};
        use gpu_amcs::simulate::Factors;
        use gpu_amcs::study::StudySettings;
        let run = fields!(RunSettings {
            coverage_probability,
            interval,
            thresholds,
            per_point
        });
        same_fields(&RUN_SETTINGS, &run);
        same_fields(&COMPARE_SETTINGS, &run);
        let amcs = fields!(AmcsOptions {
            tolerance,
            batch_size,
            max_draws,
            settings
        });
        same_fields(&AMCS_OPTIONS, &amcs);
        same_fields(&COMPARE_AMCS, &amcs);
        let mcs = fields!(McsOptions {
            draws,
            chunk,
            settings
        });
        same_fields(&MCS_OPTIONS, &mcs);
        same_fields(&COMPARE_MCS, &mcs);
        let sensitivity = fields!(SensitivityOptions {
            draws,
            bootstrap,
            bootstrap_seed,
            chunk,
            thresholds
        });
        same_fields(&SENSITIVITY_OPTIONS, &sensitivity);
        let tail = fields!(TailOptions {
            method,
            thresholds,
            target_cov,
            max_evaluations,
            samples_per_level,
            p0,
            proposal,
            proposal_spread,
            batch_size
        });
        same_fields(&TAIL_OPTIONS, &tail);
        let map = fields!(MapSpec {
            grid,
            workspace,
            orientation_rpy_deg,
            reference_q_deg,
            ik_seeds
        });
        same_fields(&MAP_SPEC, &map);
        let factors = fields!(Factors {
            runs,
            range_fraction,
            step_deg,
            speed_fraction,
            direction
        });
        same_fields(&FACTORS, &factors);
        same_fields(&STUDY_BASELINE, &factors);
        let study = fields!(StudySettings {
            quick,
            baseline,
            factors,
            robot_seed,
            calibration_seed,
            mc_seed,
            points_seed,
            point_counts,
            mcs_draws,
            deltas,
            batch,
            thresholds,
            workspace,
            accuracy_points,
            sensitivity_draws,
            backend,
            adapter
        });
        same_fields(&STUDY_SETTINGS, &study);
        // The serialised forms agree where the structs are serialisable (a field renamed for
        // serde would be named by its serde key in the documentation).
        let keys = |v: serde_json::Value| -> Vec<String> {
            v.as_object().unwrap().keys().cloned().collect()
        };
        let run_keys = keys(serde_json::to_value(RunSettings::default()).unwrap());
        same_fields(
            &RUN_SETTINGS,
            &run_keys.iter().map(String::as_str).collect::<Vec<_>>(),
        );
        let s = serde_json::to_value(SensitivityOptions::default()).unwrap();
        same_fields(
            &SENSITIVITY_OPTIONS,
            &keys(s).iter().map(String::as_str).collect::<Vec<_>>(),
        );
        let f = serde_json::to_value(Factors::default()).unwrap();
        same_fields(
            &FACTORS,
            &keys(f).iter().map(String::as_str).collect::<Vec<_>>(),
        );
        // `backend` is not serialised (it is how, not what, the study computes).
        let mut study_keys = keys(serde_json::to_value(StudySettings::default()).unwrap());
        study_keys.push("backend".into());
        same_fields(
            &STUDY_SETTINGS,
            &study_keys.iter().map(String::as_str).collect::<Vec<_>>(),
        );
    }

    #[test]
    fn every_flag_in_the_tables_exists_in_its_subcommands() {
        for t in TABLES {
            for c in t.commands {
                let have = clap_flags(c);
                for f in own_flags(t) {
                    assert!(have.contains(f), "{}: {c} has no flag {f}", t.name);
                }
            }
            for (field, from) in t.fields {
                if let Fixed(why) = from {
                    assert!(
                        !why.is_empty(),
                        "{}.{field}: say why no flag sets it",
                        t.name
                    );
                }
            }
        }
    }

    /// Every flag `flag` gives the settings `all` is one of `tables` and exists in their
    /// subcommands; `None` only for a setting the tables say no flag sets.
    fn agrees<S: Copy + std::fmt::Debug>(
        all: &[S],
        flag: impl Fn(S) -> Option<&'static str>,
        tables: &[&Table],
    ) {
        let named: BTreeSet<&str> = tables.iter().flat_map(|t| all_flags(t)).collect();
        let have: BTreeSet<String> = tables
            .iter()
            .flat_map(|t| t.commands.iter().flat_map(|c| clap_flags(c)))
            .collect();
        let fixed = tables
            .iter()
            .flat_map(|t| t.fields.iter())
            .any(|(_, from)| matches!(from, Fixed(_)));
        for &s in all {
            match flag(s) {
                Some(f) => {
                    for one in f.split('/') {
                        assert!(named.contains(one), "{s:?}: {one} is in no table");
                        assert!(have.contains(one), "{s:?}: no subcommand has {one}");
                    }
                }
                None => assert!(fixed, "{s:?} has no flag, but its tables fix nothing"),
            }
        }
    }

    #[test]
    fn the_flags_of_setting_errors_exist_and_agree_with_the_tables() {
        agrees(
            &Setting::ALL,
            |s| Driver::Run.flag(s),
            &[&AMCS_OPTIONS, &MCS_OPTIONS],
        );
        agrees(
            &Setting::ALL,
            |s| Driver::Compare.flag(s),
            &[&COMPARE_AMCS, &COMPARE_MCS],
        );
        agrees(
            &SensitivitySetting::ALL,
            sensitivity,
            &[&SENSITIVITY_OPTIONS],
        );
        use TailSetting as T;
        let tail_all = [
            T::Thresholds,
            T::TargetCov,
            T::MaxEvaluations,
            T::SamplesPerLevel,
            T::P0,
            T::ProposalSpread,
            T::BatchSize,
        ];
        agrees(&tail_all, tail, &[&TAIL_OPTIONS]);
        use MapSetting as M;
        let map_all = [
            M::Cells,
            M::PlanePosition,
            M::Workspace,
            M::Orientation,
            M::ReferenceConfiguration,
            M::IkSeeds,
            M::Thresholds,
            M::Draws,
        ];
        agrees(&map_all, map, &[&MAP_SPEC, &MAP_RUN]);
        agrees(
            &SimulateSetting::ALL,
            simulate,
            &[&FACTORS, &STUDY_SETTINGS],
        );
    }

    #[test]
    fn a_setting_error_names_the_setting_and_its_flag() {
        let e = Driver::Compare.error(McError::Setting {
            field: Setting::Tolerance,
            message: "must be positive".into(),
        });
        assert_eq!(
            e.to_string(),
            "numerical tolerance (--deltas): must be positive"
        );
        let e = sensitivity_error(SensitivityError::Setting {
            field: SensitivitySetting::Chunk,
            message: "is 0".into(),
        });
        assert_eq!(e.to_string(), "chunk: is 0");
    }
}
