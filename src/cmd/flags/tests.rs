//! The checks of the tables against the library's structs, clap's flags and the error mappers.

use super::*;
use crate::cli::Cli;
use clap::CommandFactory;
use std::collections::BTreeSet;
use Source::{Fixed, Nested};

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
    use gpu_amcs::identify::{ChainOptions, IdentifyOptions};
    use gpu_amcs::import::ImportOptions;
    use gpu_amcs::map::MapSpec;
    use gpu_amcs::mc::sensitivity::SensitivityOptions;
    use gpu_amcs::mc::tail::TailOptions;
    use gpu_amcs::mc::{AmcsOptions, McsOptions, RunSettings};
    use gpu_amcs::simulate::Factors;
    use gpu_amcs::study::{JointErrorStudy, StudySettings};
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
        adapter,
        joint_errors
    });
    same_fields(&STUDY_SETTINGS, &study);
    let joint_error_study = fields!(JointErrorStudy { sizes, poses, mode });
    same_fields(&JOINT_ERROR_STUDY, &joint_error_study);
    let identify = fields!(IdentifyOptions {
        method,
        nominal_prior,
        refine
    });
    same_fields(&IDENTIFY_OPTIONS, &identify);
    let chain = fields!(ChainOptions {
        placement,
        fix,
        noise,
        uncertainty,
        seed,
        compensate,
        beyond_geometry,
        held_out,
        harmonic_orders,
        progress
    });
    same_fields(&CHAIN_OPTIONS, &chain);
    let import = fields!(ImportOptions {
        base,
        tip,
        name,
        packages,
        xacro_args,
        held
    });
    same_fields(&IMPORT_OPTIONS, &import);
    // The serialised forms agree where the structs are serialisable (a field renamed for
    // serde would be named by its serde key in the documentation).
    let keys =
        |v: serde_json::Value| -> Vec<String> { v.as_object().unwrap().keys().cloned().collect() };
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
    // `backend` is not serialised (it is how, not what, the study computes), and
    // `joint_errors` only when set (a study without them writes the study.json it wrote before).
    let mut study_keys = keys(serde_json::to_value(StudySettings::default()).unwrap());
    study_keys.push("backend".into());
    study_keys.push("joint_errors".into());
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
        M::Plane,
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
