//! The tables: for every library options struct the command line fills, which flags set each
//! field, or why none does.

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
        ("joint_errors", Nested(&JOINT_ERROR_STUDY)),
    ],
};

/// `study::JointErrorStudy` in `study`.
pub const JOINT_ERROR_STUDY: Table = Table {
    name: "study::JointErrorStudy",
    commands: &["study"],
    fields: &[
        ("sizes", Flags(&["--joint-errors"])),
        ("poses", Flags(&["--joint-error-poses"])),
        ("mode", Fixed("identify's default (auto)")),
    ],
};

/// `identify::IdentifyOptions` in `identify`.
pub const IDENTIFY_OPTIONS: Table = Table {
    name: "identify::IdentifyOptions",
    commands: &["identify"],
    fields: &[
        ("method", Flags(&["--fit"])),
        ("nominal_prior", Flags(&["--no-prior"])),
        ("refine", Flags(&["--no-refine"])),
    ],
};

/// `identify::ChainOptions` in `identify`.
pub const CHAIN_OPTIONS: Table = Table {
    name: "identify::ChainOptions",
    commands: &["identify"],
    fields: &[
        ("placement", Flags(&["--base-known"])),
        ("fix", Flags(&["--fix"])),
        (
            "noise",
            Flags(&["--tracker-sigma", "--tracker-mpe", "--tracker-at"]),
        ),
        ("uncertainty", Flags(&["--uncertainty", "--mc-draws"])),
        ("seed", Flags(&["--seed"])),
        ("compensate", Flags(&["--no-compensation"])),
        ("beyond_geometry", Flags(&["--beyond-geometry"])),
        (
            "held_out",
            Fixed("from the data: arcs of each sweep for sweeps, each point for poses"),
        ),
        ("harmonic_orders", Flags(&["--harmonic-orders"])),
        ("progress", Flags(&["--quiet"])),
    ],
};

/// `import::ImportOptions` in `import`.
pub const IMPORT_OPTIONS: Table = Table {
    name: "import::ImportOptions",
    commands: &["import"],
    fields: &[
        ("base", Flags(&["--base"])),
        ("tip", Flags(&["--tip"])),
        ("name", Flags(&["--name"])),
        ("packages", Flags(&["--package"])),
        ("xacro_args", Flags(&["--xacro-arg"])),
        ("held", Flags(&["--hold-joint"])),
    ],
};

/// Every table.
#[cfg_attr(not(test), allow(dead_code))]
pub const TABLES: &[&Table] = &[
    &IMPORT_OPTIONS,
    &IDENTIFY_OPTIONS,
    &CHAIN_OPTIONS,
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
    &JOINT_ERROR_STUDY,
];
