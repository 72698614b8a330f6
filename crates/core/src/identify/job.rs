//! One identification job, as every front end runs it: a tracker data file and a nominal model
//! with the settings a user gives → the identified model, its model file, the reports, the
//! warnings. The command line (`gpu-amcs identify`) and Python (`gpu_amcs.identify`) each make
//! one [`IdentifyJob`] and call [`IdentifyJob::run`]; neither orchestrates the steps itself, so
//! both read, check, fit and write the same way. Errors name the setting at fault
//! ([`IdentifySetting`]), which each front end spells its own way (a flag, a keyword).
//!
//! # Examples
//!
//! ```
//! use gpu_amcs_core::identify::{write_poses, IdentifyJob};
//! use gpu_amcs_core::kinematics::{tx60, BaseTransform};
//! use gpu_amcs_core::simulate::{random_poses, simulate_poses, TrackerNoise};
//!
//! let mut truth = tx60();
//! truth.tool = [30.0, -20.0, 80.0];
//! let placement = BaseTransform { xyz: [2000.0, 300.0, -100.0], rpy: [0.0, 0.0, 1.0] };
//! let data = simulate_poses(&truth, &random_poses(&truth, 40, 1), &placement,
//!     &TrackerNoise::Isotropic(0.01), 2);
//! let path = std::env::temp_dir().join(format!("job-doctest-{}.csv", std::process::id()));
//! let mut csv = Vec::new();
//! write_poses(&data, &mut csv).unwrap();
//! std::fs::write(&path, csv).unwrap();
//!
//! let outcome = IdentifyJob::new(path.clone(), tx60()).run().unwrap();
//! std::fs::remove_file(&path).unwrap();
//! // The model file names the blocks its covariance covers, the placement among them.
//! assert!(outcome.file_text.contains("blocks = [\"joints\", \"tool\", \"placement\"]"));
//! assert!((outcome.model.tool[2] - 80.0).abs() < 0.1);
//! ```

use std::path::PathBuf;

use super::noise::NoiseSetting;
use super::{
    check_tracker_data, grouped_warnings, identified_model, identify_data, model_file_text,
    parse_tracker_data, ChainOptions, CircleFitMethod, Identification, IdentifyError,
    IdentifyOptions, IdentifyReports, NoiseModel, NominalPrior, Placement, TrackerData,
    UncertaintyMethod,
};
use crate::kinematics::RobotModel;

/// Fewest Monte Carlo re-identifications that give a covariance.
pub const MIN_MC_DRAWS: usize = 10;

/// The settings of an [`IdentifyJob`] its errors name; a front end maps each to its own name.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum IdentifySetting {
    /// [`IdentifyJob::tracker_sigma_mm`].
    TrackerSigma,
    /// [`IdentifyJob::tracker_mpe`].
    TrackerMpe,
    /// [`IdentifyJob::tracker_at_mm`].
    TrackerAt,
    /// The draws of [`UncertaintyMethod::MonteCarlo`].
    McDraws,
    /// [`IdentifyJob::method`] (sweeps only).
    Fit,
    /// [`IdentifyJob::refine`] (sweeps only).
    Refine,
}

/// Why an identification job gave no model.
#[derive(Debug, thiserror::Error)]
pub enum IdentifyJobError {
    /// A setting cannot be used; the message says why (without naming the setting, which the
    /// front end does).
    #[error("{message}")]
    Setting {
        /// The setting at fault.
        setting: IdentifySetting,
        /// What is wrong.
        message: String,
    },
    /// The job is strict and the results look implausible; no model.
    #[error("{} implausible result(s): {}", warnings.len(), warnings.join("; "))]
    Strict {
        /// The warnings, one line per joint and kind of problem.
        warnings: Vec<String>,
    },
    /// Reading, checking or fitting the data failed.
    #[error(transparent)]
    Identify(#[from] IdentifyError),
}

/// An identification from one tracker data file (sweeps or poses, any frame).
#[derive(Clone, Debug)]
pub struct IdentifyJob {
    /// The tracker data CSV.
    pub data: PathBuf,
    /// The nominal model giving the structure and conventions.
    pub nominal: RobotModel,
    /// Whether the placement is identified (data in a measurement frame) or known.
    pub placement: Placement,
    /// Inputs held at their nominal values, by name (`theta1`, `tool_x`, `base_yaw`, …).
    pub fix: Vec<String>,
    /// Tracker noise σ per coordinate, mm (else the MPE, the data's sx,sy,sz or the residuals).
    pub tracker_sigma_mm: Option<f64>,
    /// Tracker noise from its MPE: A, B[, R] (µm, µm/m, µm).
    pub tracker_mpe: Option<Vec<f64>>,
    /// Tracker position in the data's frame, mm (with the MPE).
    pub tracker_at_mm: Option<Vec<f64>>,
    /// How the covariance is obtained.
    pub uncertainty: UncertaintyMethod,
    /// Seed of the Monte Carlo re-identification.
    pub seed: u64,
    /// Circle model (sweeps only).
    pub method: CircleFitMethod,
    /// Prior towards the nominal geometry.
    pub prior: bool,
    /// Whole-chain refinement of sweeps (sweeps only; off gives the plain circle-point result).
    pub refine: bool,
    /// With several runs, the full sample covariance instead of independent σ.
    pub covariance: bool,
    /// Refuse to give a model when a result looks implausible ([`IdentifyJobError::Strict`]).
    pub strict: bool,
    /// Fit a compensation to a single run's residuals (docs/METHOD.md §18.1).
    pub compensate: bool,
}

/// What an [`IdentifyJob`] gives.
#[derive(Clone, Debug)]
pub struct IdentifyOutcome {
    /// Every run's identification.
    pub runs: Vec<Identification>,
    /// The identified model: one run's, or the statistics of several.
    pub model: RobotModel,
    /// The line on the model's uncertainty (single-run note or the statistics of the runs).
    pub note: String,
    /// The model file: the model, then its `[provenance]`.
    pub file_text: String,
    /// The runs as a report (text, JSON, CSV, SVG, HTML).
    pub reports: IdentifyReports,
    /// The warnings, one line per joint and kind of problem.
    pub warnings: Vec<String>,
    /// The whole-chain options the job used (frame, noise, uncertainty).
    pub chain: ChainOptions,
}

impl IdentifyJob {
    /// The job with the defaults of `gpu-amcs identify`: placement identified, noise from the
    /// data, linearised covariance, seed 1, commanded-angle circles, prior and refinement on.
    pub fn new(data: PathBuf, nominal: RobotModel) -> IdentifyJob {
        IdentifyJob {
            data,
            nominal,
            placement: Placement::Identify,
            fix: Vec::new(),
            tracker_sigma_mm: None,
            tracker_mpe: None,
            tracker_at_mm: None,
            uncertainty: UncertaintyMethod::Linearised,
            seed: 1,
            method: CircleFitMethod::CommandedAngles,
            prior: true,
            refine: true,
            covariance: false,
            strict: false,
            compensate: true,
        }
    }

    /// Reads and checks the data, identifies every run and makes the model, its file and the
    /// reports.
    ///
    /// # Errors
    ///
    /// [`IdentifyJobError::Identify`] when the data cannot be read, do not fit the nominal
    /// model or cannot be identified; [`IdentifyJobError::Setting`] for a noise setting that
    /// cannot be used, fewer than [`MIN_MC_DRAWS`] Monte Carlo draws, or a sweeps-only setting
    /// with pose data; [`IdentifyJobError::Strict`] when strict and a result looks implausible.
    pub fn run(&self) -> Result<IdentifyOutcome, IdentifyJobError> {
        // Read once: a pipe (`/dev/stdin`) gives its bytes only once, for the data and their
        // checksum both.
        let (text, origin, bytes) = super::sweeps::open_input_keeping(&self.data, true)?;
        let data = parse_tracker_data(&text, &origin)?;
        check_tracker_data(&data, &self.nominal, &origin)?;
        let chain = self.chain_options(&data)?;
        let runs = identify_data(&data, &self.nominal, &self.options(), &chain, !self.refine)?;
        let warnings = grouped_warnings(&runs);
        if self.strict && !warnings.is_empty() {
            return Err(IdentifyJobError::Strict { warnings });
        }
        let (model, note) = identified_model(&runs, &self.nominal, self.covariance, &origin)?;
        Ok(IdentifyOutcome {
            file_text: model_file_text(&model, &self.nominal, &runs, &origin, &bytes),
            reports: IdentifyReports::new(&self.nominal.name, &runs),
            runs,
            model,
            note,
            warnings,
            chain,
        })
    }

    /// The options of the circle-point steps.
    fn options(&self) -> IdentifyOptions {
        IdentifyOptions {
            method: self.method,
            nominal_prior: self.prior.then(NominalPrior::default),
            refine: self.refine,
        }
    }

    /// The whole-chain options; the noise defaults to the data's sx,sy,sz columns when every
    /// point has them, else to the residuals.
    fn chain_options(&self, data: &TrackerData) -> Result<ChainOptions, IdentifyJobError> {
        let noise = NoiseModel::from_settings(
            self.tracker_sigma_mm,
            self.tracker_mpe.as_deref(),
            self.tracker_at_mm.as_deref(),
            data,
        )
        .map_err(|e| IdentifyJobError::Setting {
            setting: match e.setting() {
                NoiseSetting::Sigma => IdentifySetting::TrackerSigma,
                NoiseSetting::Mpe => IdentifySetting::TrackerMpe,
                NoiseSetting::Position => IdentifySetting::TrackerAt,
            },
            message: e.to_string(),
        })?;
        if let UncertaintyMethod::MonteCarlo { draws } = self.uncertainty {
            if draws < MIN_MC_DRAWS {
                return Err(IdentifyJobError::Setting {
                    setting: IdentifySetting::McDraws,
                    message: format!(
                        "at least {MIN_MC_DRAWS} re-identifications are needed for a covariance"
                    ),
                });
            }
        }
        if matches!(data, TrackerData::Poses(_)) {
            let sweeps_only = if !self.refine {
                Some(IdentifySetting::Refine)
            } else if self.method != CircleFitMethod::CommandedAngles {
                Some(IdentifySetting::Fit)
            } else {
                None
            };
            if let Some(setting) = sweeps_only {
                return Err(IdentifyJobError::Setting {
                    setting,
                    message: format!(
                        "applies to sweeps only; {} holds poses",
                        self.data.display()
                    ),
                });
            }
        }
        Ok(ChainOptions {
            placement: self.placement,
            fix: self.fix.clone(),
            noise,
            uncertainty: self.uncertainty,
            seed: self.seed,
            compensate: self.compensate,
        })
    }
}
