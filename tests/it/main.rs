//! The integration tests: one test binary (one link of the workspace's crates instead of one per
//! file), one module per area. Modules that drive the wgpu evaluator directly need the `gpu`
//! feature (on by default).
#![allow(clippy::needless_range_loop)]

mod column_map;
mod common;

mod amcs_vs_mcs;
mod backlash;
mod backlash_gaps;
mod backlash_sides;
mod backlash_unknown;
mod base_references;
mod beyond_geometry;
mod blocks;
mod calibrate_beyond;
mod cli;
mod docs;
mod export_tracker;
mod flag_properties;
mod frame_invariance;
mod fuzz;
#[cfg(feature = "gpu")]
mod gpu;
mod hardening;
mod hardening_round3;
mod harmonic_orders;
mod honesty;
mod html;
mod identify;
mod identify_friction;
mod identify_limits;
mod identify_undetermined;
mod import;
mod inputs;
mod joint_counts;
mod joint_errors;
mod map;
mod map_shards;
mod mc_known_answers;
mod memory_limits;
mod module_cycles;
mod multi_target;
mod payload_data;
mod placement_analyses;
mod plan;
mod plan_runnable;
mod pose_repeats;
mod real_data;
mod reports;
mod sensitivity;
mod simulate_nongeometric;
mod study;
mod summary;
mod tail;
mod tail_joint_errors;
mod tracker_cli;
mod tracker_data;
mod validate_nominal;
mod validate_term;
