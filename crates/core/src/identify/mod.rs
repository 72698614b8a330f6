//! Robot identification by the circle-point (axis measurement) method (docs/METHOD.md §2, paper
//! §1.3).
//!
//! Flow: [`read_sweeps`] (CSV → [`SweepData`]) → [`identify`] → one [`Identification`] per run:
//! the identified [`RobotModel`](crate::kinematics::RobotModel) plus an [`IdentifyReport`]
//! ([`render_identify_report`] formats it, [`render_identify_summary`] summarises the runs). Per
//! run and joint: the sweep is checked ([`check_sweep`]), a circle is fitted
//! ([`circle::fit_circle`], by [`CircleFitMethod`]) giving the joint's axis line in the base frame;
//! consecutive axes give the MDH parameters ([`mdh`]) and the last joint's sweep (J6 of a
//! six-axis arm) the tool point. Every step works for the 4 to 7 joints a model may have: the
//! data have one sweep per joint and one `q` column per joint. The
//! conventions for what point measurements cannot separate are documented in [`mdh`]. By default
//! ([`IdentifyOptions::default`]) two further steps use the commanded angles and the design:
//! a prior that keeps poorly determined quantities near the nominal geometry ([`NominalPrior`],
//! [`circle::AxisPrior`]) and a whole-chain least-squares refinement over all sweep points
//! ([`refine`]); both can be switched off to get the plain circle-point result.
//! [`quality_warnings`] flags results that fitted but look implausible (residuals far above
//! tracker noise, parameters far from nominal, a J1 axis away from base z); every report carries
//! them. [`validate()`] compares a model's predictions with measured positions.
//!
//! One algorithm per file: `sweeps` (CSV), `circle` (circle fits), `lm` (the Levenberg–Marquardt
//! solver of the fits and the refinement), `refine`,
//! `pipeline` (one run end to end), `quality` (plausibility), `statistics` (over runs),
//! `validate` (accuracy against measurements), `error`, `report` (the terminal renderings and
//! [`IdentifyReports`], the runs as a [`Report`](crate::report::Report)). The axes → parameters
//! conversion ([`lines`], [`mdh`]) lives in `crate::kinematics`, which the importer shares, and is
//! re-exported here.
//!
//! Held-out RMS error on simulated TX60s (perturbed by 0.3 mm / 0.03°, tool (30, −20, 80) mm,
//! σ = 10 µm, 2° steps; `cargo bench --bench identify_range`, 20 robots; nominal model 0.87 mm):
//!
//! | range | point cloud | commanded angles | default (commanded + prior + refinement) |
//! |-------|-------------|------------------|------------------------------------------|
//! | 10 %  | 5.18 mm     | 2.81 mm          | 0.45 mm                                  |
//! | 25 %  | 0.50 mm     | 0.29 mm          | 0.19 mm                                  |
//! | 50 %  | 0.096 mm    | 0.066 mm         | 0.044 mm                                 |
//! | 75 %  | 0.040 mm    | 0.027 mm         | 0.020 mm                                 |
//! | 100 % | 0.018 mm    | 0.015 mm         | 0.012 mm                                 |
//!
//! Why short arcs are hard whatever the circle model: a rigid tilt of the circle about the arc's
//! tangent moves the points only by the sagitta, so the axis tilt is fixed by `σ/(r(1−cos Δ/2))`
//! and the resulting position error `~ 8σ/(Δ²√N)` does not depend on the radius. The
//! commanded angles pin the radius and the centre along the chord (so they beat the point cloud
//! at every range), but not that tilt; the nominal prior bounds it.
//!
//! The identified model copies the nominal model's name (suffixed), joint limits and structure
//! (`fixed`, except where [`mdh::PARALLEL_THRESHOLD_DEG`] switches a pair to the `β` form). Its
//! uncertainty is independent σ of zero for all `5n` parameters (30 for six joints): one run says
//! nothing about the spread;
//! statistics over repeated runs ([`parameter_statistics`]) or a simulation supply it.
//!
//! ```
//! use gpu_amcs_core::identify::{identify, IdentifyOptions};
//! use gpu_amcs_core::kinematics::tx60;
//! use gpu_amcs_core::simulate::{simulate_sweeps, SweepPlan};
//! let mut truth = tx60();
//! truth.tool = [30.0, -20.0, 80.0];
//! let data = simulate_sweeps(&truth, &SweepPlan::default(), 0.0, 1, 1);
//! let ids = identify(&data, &tx60(), &IdentifyOptions::default()).unwrap();
//! assert!((ids[0].model.tool[0] - 30.0).abs() < 1e-6);
//! println!("{}", gpu_amcs_core::identify::render_identify_report(&ids[0].report));
//! ```

pub mod chain;
pub mod chain_fit;
mod chain_outputs;
mod chain_text;
pub mod circle;
mod columns;
pub mod drift;
mod error;
pub mod identifiability;
mod job;
mod lm;
pub mod measured;
pub mod noise;
mod pipeline;
mod pose_units;
pub mod poses;
pub mod predictive;
mod provenance;
mod quality;
pub mod refine;
pub mod repeats;
mod report;
mod statistics;
pub mod sweeps;
pub mod targets;
pub mod validate;

pub use crate::kinematics::{lines, mdh};
pub use chain::{
    ChainOptions, ChainReport, HeldOut, JointErrorFit, MeasuredPoint, Placement, UncertaintyMethod,
};
pub use chain_text::{frame_label, render_chain_report, render_chain_summary};
pub use circle::{fit_circle, AxisPrior, CircleFit, CircleFitError, CircleFitMethod, MIN_ARC_DEG};
pub use columns::{ColumnMap, ColumnMapError, ColumnMapSetting};
pub use error::IdentifyError;
pub use job::{
    IdentifyJob, IdentifyJobError, IdentifyOutcome, IdentifySetting, MAX_MC_DRAWS, MIN_MC_DRAWS,
};
pub use lines::{common_normal, CommonNormal, Line, LineRelation};
pub use mdh::PARALLEL_THRESHOLD_DEG;
pub use measured::{identify_data, identify_poses, identify_sweeps_chain, placement_from_axes};
pub use noise::NoiseModel;
pub use pipeline::{
    check_sweep, identify, identify_run, Identification, IdentifyOptions, IdentifyReport,
    JointReport, NominalPrior, HOME_TOLERANCE_DEG, NOMINAL_ANGLE_SIGMA_DEG,
    NOMINAL_LENGTH_SIGMA_MM,
};
pub use poses::{
    check_tracker_data, parse_poses, parse_tracker_data, read_poses, read_tracker_data,
    write_poses, PoseData, PosePoint, PoseRun, TrackerData,
};
pub use provenance::{model_file_text, provenance_frame, sha256_hex, Provenance};
pub use quality::{
    grouped_warnings, quality_warnings, IdentifyWarning, QualityLimits, MAX_ANGLE_CHANGE_DEG,
    MAX_LENGTH_CHANGE_MM, MAX_RMS_RESIDUAL_MM,
};
pub use report::{
    render_identify_report, render_identify_summary, render_validation, IdentifyReports,
};
pub use statistics::{
    correlated_statistics, identified_model, parameter_statistics, sample_covariance,
    COVARIANCE_RIDGE,
};
pub use sweeps::{
    open_input as read_data_text, parse_sweeps, read_sweeps, write_sweeps, Sweep, SweepData,
    SweepPoint, SweepRun,
};
pub use validate::{
    accuracy, accuracy_in, parse_measurements, point_errors_in, read_measurements, validate,
    validate_in, write_measurements, AccuracyStats, Measurement, Validation, SAME_TOOL_MM,
};
