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

use super::noise::NoiseSetting;
use super::{
    check_tracker_data, grouped_warnings, identified_model, identify_data, model_file_text,
    parse_tracker_data, ChainOptions, CircleFitMethod, Identification, IdentifyError,
    IdentifyOptions, IdentifyReports, JointErrorFit, NoiseModel, NominalPrior, Placement,
    TrackerData, UncertaintyMethod,
};
use crate::kinematics::RobotModel;
use std::path::PathBuf;

mod setting;
pub use setting::{IdentifyJobError, IdentifySetting};

/// Fewest Monte Carlo re-identifications that give a covariance.
pub const MIN_MC_DRAWS: usize = 10;

/// Most Monte Carlo re-identifications a job makes: each is a whole fit (200 of 60 poses take
/// about 5 s on two cores), and 10⁴ already give each variance to 1.4 %.
pub const MAX_MC_DRAWS: usize = 10_000;

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
    /// When joint compliance and gear harmonics are fitted and kept
    /// ([`crate::identify::JointErrorFit`], [`crate::identify::chain::BeyondGeometry`]).
    pub beyond_geometry: JointErrorFit,
    /// Per joint, the gear harmonics fitted beyond geometry: orders 1 to this (0, 1 or 2), and
    /// no selection of the terms; none (the default): the data choose them
    /// ([`ChainOptions::harmonic_orders`]).
    pub harmonic_orders: Option<Vec<u8>>,
    /// The memory the identification may use, checked against [`Self::memory_estimate`] once
    /// the data are read and before any fit (data from a pipe cannot be sized before); none:
    /// no check.
    pub memory: Option<crate::memory::MemoryBudget>,
    /// Told each step of the identification as it starts.
    pub progress: crate::progress::ProgressHook,
    /// How the data file's columns map to a data file's, with their units and delimiter
    /// ([`super::ColumnMap`]); none: the file is a data file as it stands.
    pub columns: Option<super::ColumnMap>,
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

/// The mean model of several `runs` keeps the prior σ of every input some run's data did not
/// determine: the runs' spread of an input they all held at nominal is 0, which would claim it
/// known exactly. Its variance gets the prior's added (diagonal), which keeps a covariance
/// positive definite.
fn keep_prior_of_held(model: &mut RobotModel, nominal: &RobotModel, runs: &[Identification]) {
    use crate::kinematics::{Block, Covariance, Uncertainty};
    let space = nominal.layout().measured();
    let held: Vec<usize> = runs
        .iter()
        .filter_map(|r| r.report.chain.as_ref())
        .flat_map(|c| c.identifiability.null_directions.iter())
        .filter_map(|n| space.find(&n.fixed))
        .fold(Vec::new(), |mut all, i| {
            if !all.contains(&i) {
                all.push(i);
            }
            all
        });
    let prior = |i: usize| super::chain::prior_sigma(nominal, space, i);
    match &mut model.uncertainty {
        Uncertainty::Independent(sigma) => {
            for &i in &held {
                match space.locate(i) {
                    (Block::Joints, k) => sigma[k] = sigma[k].max(prior(i)),
                    (Block::Tool, k) => model.tool_sigma[k] = model.tool_sigma[k].max(prior(i)),
                    (Block::Placement, _) => {}
                }
            }
        }
        Uncertainty::Covariance(c) => {
            let (cs, n) = (c.space(), c.space().len());
            let mut m = c.matrix().to_vec();
            for &i in &held {
                match (cs.find(&space.name(i)), space.locate(i)) {
                    (Some(k), _) => m[k * n + k] += prior(i).powi(2),
                    // A covariance without the tool block: the tool's own σ.
                    (None, (Block::Tool, k)) => {
                        model.tool_sigma[k] = model.tool_sigma[k].max(prior(i));
                    }
                    (None, _) => {}
                }
            }
            if let Some(c) = Covariance::new(cs, m) {
                model.set_covariance(c);
            }
        }
    }
}

/// Refuses an identified model whose file (`text`) the analyses would refuse to read: the data
/// from `origin` determine it too poorly (a σ beyond what a model file holds, a covariance
/// without a Cholesky factor), most often because `runs` left parameters undetermined and their
/// prior uncertainty spreads into the rest.
///
/// # Errors
///
/// [`IdentifyError::NoData`] naming the data file, the model field, why, and what to measure.
fn check_usable(text: &str, origin: &str, runs: &[Identification]) -> Result<(), IdentifyError> {
    let Err(e) = RobotModel::from_toml(text, "the identified model") else {
        return Ok(());
    };
    let why = match &e {
        crate::kinematics::ModelError::Invalid { field, message, .. } => {
            format!("{field}: {message}")
        }
        other => other.to_string(),
    };
    let undetermined = runs
        .iter()
        .filter_map(|r| r.report.chain.as_ref())
        .map(|c| &c.identifiability)
        .find(|a| !a.null_directions.is_empty());
    Err(IdentifyError::NoData(match undetermined {
        Some(a) => format!(
            "{origin}: the data do not determine {} (first combination: {}); at their prior uncertainty they spread into the rest beyond what a model file holds ({why}); no model written: {}",
            a.null_directions
                .iter()
                .map(|n| n.fixed.as_str())
                .collect::<Vec<_>>()
                .join(", "),
            a.null_directions[0].combination,
            super::identifiability::advice(&a.null_directions[0].combination, a)
        ),
        None => format!(
            "{origin}: the data determine the model too poorly for a usable model file ({why}); no model written: measure more poses spread over every joint's range, or state a smaller tracker σ"
        ),
    }))
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
            beyond_geometry: JointErrorFit::Auto,
            harmonic_orders: None,
            memory: None,
            progress: Default::default(),
            columns: None,
        }
    }

    /// Reads and checks the data, identifies every run and makes the model, its file and the
    /// reports.
    ///
    /// # Errors
    ///
    /// [`IdentifyJobError::Identify`] when the data cannot be read, do not fit the nominal
    /// model or cannot be identified; [`IdentifyJobError::Setting`] for a noise setting that
    /// cannot be used, fewer than [`MIN_MC_DRAWS`] Monte Carlo draws (or not more than the
    /// quantities the fit identifies), or a sweeps-only setting
    /// with pose data; [`IdentifyJobError::Strict`] when strict and a result looks implausible;
    /// [`IdentifyJobError::Identify`] with [`IdentifyError::NoData`] when the identified model
    /// would be a file the analyses refuse (an uncertainty beyond what a model file holds:
    /// the data determine the parameters too poorly), so that no such file is written; as
    /// [`IdentifyJobError::Setting`] of the stated noise when one was given and the data
    /// determined every parameter (the stated σ then sets that spread).
    pub fn run(&self) -> Result<IdentifyOutcome, IdentifyJobError> {
        // Read once: a pipe (`/dev/stdin`) gives its bytes only once, for the data and their
        // checksum both.
        let (text, origin, bytes) = super::sweeps::open_input_keeping(&self.data, true)?;
        // The checksum stays the file's own; the map gives the text the readers take.
        let text = match &self.columns {
            None => text,
            Some(map) => map
                .apply(&text, &origin)
                .map_err(|e| IdentifyJobError::Setting {
                    setting: IdentifySetting::Columns,
                    message: e.to_string(),
                })?,
        };
        self.progress.report("checking the data", 0, 1);
        self.check_memory(&text, &origin)?;
        let data = parse_tracker_data(&text, &origin)?;
        check_tracker_data(&data, &self.nominal, &origin)?;
        let chain = self.chain_options(&data)?;
        let runs = identify_data(&data, &self.nominal, &self.options(), &chain, !self.refine)
            .map_err(|e| match e {
                // What the data cannot give names the data.
                IdentifyError::NoData(m) if !m.starts_with(&origin) => {
                    IdentifyError::NoData(format!("{origin}: {m}"))
                }
                e => e,
            })?;
        let warnings = grouped_warnings(&runs);
        if self.strict && !warnings.is_empty() {
            return Err(IdentifyJobError::Strict { warnings });
        }
        let (mut model, note) = identified_model(&runs, &self.nominal, self.covariance, &origin)?;
        if runs.len() > 1 {
            keep_prior_of_held(&mut model, &self.nominal, &runs);
        }
        let file_text = model_file_text(&model, &self.nominal, &runs, &origin, &bytes);
        check_usable(&file_text, &origin, &runs).map_err(|e| self.blame_stated_noise(e, &runs))?;
        Ok(IdentifyOutcome {
            file_text,
            reports: IdentifyReports::new(&self.nominal.name, &runs),
            runs,
            model,
            note,
            warnings,
            chain,
        })
    }

    /// A refusal of [`check_usable`] as the stated noise's setting when one was given and every
    /// parameter was determined: the stated σ then sets the parameters' spread.
    fn blame_stated_noise(&self, e: IdentifyError, runs: &[Identification]) -> IdentifyJobError {
        let determined = runs
            .iter()
            .filter_map(|r| r.report.chain.as_ref())
            .all(|c| c.identifiability.null_directions.is_empty());
        let setting = if self.tracker_sigma_mm.is_some() {
            Some(IdentifySetting::TrackerSigma)
        } else if self.tracker_mpe.is_some() {
            Some(IdentifySetting::TrackerMpe)
        } else {
            None
        };
        match setting {
            Some(setting) if determined => IdentifyJobError::Setting {
                setting,
                message: e.to_string(),
            },
            _ => e.into(),
        }
    }

    /// The number of inputs the whole-chain fit moves: the default free ones less those fixed
    /// by name (an upper bound: directions the data leave free are held too).
    fn free_count(&self) -> usize {
        if !(crate::kinematics::MIN_JOINTS..=crate::kinematics::MAX_JOINTS)
            .contains(&self.nominal.joints())
        {
            return 0;
        }
        let space = self.nominal.layout().measured();
        let named: Vec<usize> = self
            .fix
            .iter()
            .filter_map(|n| space.find(&n.trim().to_ascii_lowercase()))
            .collect();
        super::chain_fit::default_free(&self.nominal.fixed, self.placement == Placement::Identify)
            .into_iter()
            .filter(|i| !named.contains(i))
            .count()
    }

    /// What identifying `rows` data rows (poses, or sweep points) read from a text of
    /// `text_bytes` keeps at most, added to `e`, with `threads` workers: the text and the parsed
    /// rows, and the largest of the phases that follow one another (each frees its work before
    /// the next): the whole-chain fit (a `3n × p` Jacobian, its column buffers and transpose),
    /// the lack of fit (its Jacobian, the points, the compensation's kernel matrices over at
    /// most [`crate::discrepancy::gp::MAX_TRAINING`] poses and the leave-one-out check's draws
    /// per point), the beyond-geometry fit when asked and, with `monte_carlo`, the Monte Carlo
    /// re-identifications (`min(K, threads)` fits at once and `K` estimates kept).
    pub fn memory_estimate(
        &self,
        rows: u64,
        text_bytes: u64,
        threads: u64,
        monte_carlo: bool,
        e: crate::memory::Estimate,
    ) -> crate::memory::Estimate {
        use crate::memory::Estimate;
        let n = rows;
        let p = self.free_count().max(1) as u64;
        let joints = self.nominal.joints() as u64;
        let threads = threads.max(1);
        let obs = std::mem::size_of::<super::chain_fit::Observation>() as u64;
        let row = std::mem::size_of::<super::poses::PosePoint>() as u64 + obs;
        // The Levenberg-Marquardt fit over `cols` inputs: the columns, the Jacobian and its
        // transpose of 3n + cols rows, and each worker's two residual vectors and column.
        let fit = |cols: u64| {
            let rows = n.saturating_mul(3).saturating_add(cols);
            Estimate::new("", "")
                .plus(&[3, rows, cols, 8])
                .plus(&[threads, 3, rows, 8])
                .bytes
        };
        // The leave-one-out check's draws per point (as `discrepancy::estimate::loo_check`
        // draws them): two values each.
        let draws = (20_000_000 / n.max(1)).clamp(200, 2000);
        let training = n.min(crate::discrepancy::gp::MAX_TRAINING as u64);
        // The points (residual, whitening, leverage, configuration, left-out residuals) and,
        // one after the other, the Jacobian with its column buffers, the Jacobian with the
        // compensation's kernel matrices, the Jacobian with the check's draws.
        let jacobian = Estimate::new("", "").plus(&[3, n, p, 8]).bytes;
        let lack_of_fit = Estimate::new("", "")
            .plus(&[n, 2 * 72 + 24 + 24 + 8 * joints + 8 * 24])
            .plus(&[jacobian.unwrap_or(u64::MAX)])
            .bytes
            .zip(
                [
                    jacobian,
                    Estimate::new("", "")
                        .plus(&[4, training, training, 8])
                        .bytes,
                    Estimate::new("", "").plus(&[2, n, draws, 8]).bytes,
                ]
                .into_iter()
                .try_fold(0u64, |m, b| b.map(|b| m.max(b))),
            )
            .and_then(|(a, b)| a.checked_add(b));
        // Joint compliance and the once- and twice-per-turn harmonics: five more inputs a joint,
        // and the leave-one-out's Jacobian beside the fit's.
        let beyond = if self.beyond_geometry != JointErrorFit::Off {
            fit(p + 5 * joints)
                .zip(
                    Estimate::new("", "")
                        .plus(&[
                            n.saturating_mul(3).saturating_add(p + 5 * joints),
                            p + 5 * joints,
                            8,
                        ])
                        .bytes,
                )
                .and_then(|(a, b)| a.checked_add(b))
        } else {
            Some(0)
        };
        let mc = match self.uncertainty {
            UncertaintyMethod::MonteCarlo { draws: k } if monte_carlo => {
                let k = k as u64;
                fit(p)
                    .and_then(|f| f.checked_add(obs.checked_mul(n)?))
                    .and_then(|one| one.checked_mul(k.min(threads)))
                    .zip(
                        Estimate::new("", "")
                            .plus(&[k, 8 * p + 48])
                            .plus(&[n, 24 + 72])
                            .bytes,
                    )
                    .and_then(|(a, b)| a.checked_add(b))
            }
            _ => Some(0),
        };
        let phases = [fit(p), lack_of_fit, beyond, mc];
        let largest = phases.iter().try_fold(0u64, |m, b| b.map(|b| m.max(b)));
        // Each row's residuals and report lines besides.
        let e = e.plus(&[text_bytes]).plus(&[n, row + 256]);
        match largest {
            Some(b) => e.plus(&[b]),
            None => Estimate { bytes: None, ..e },
        }
    }

    /// Checks the [`Self::memory`] budget against the estimate for `text`'s lines: the fit and
    /// lack of fit, then the Monte Carlo re-identifications when asked for.
    fn check_memory(&self, text: &str, origin: &str) -> Result<(), IdentifyJobError> {
        use crate::memory::Estimate;
        let Some(budget) = &self.memory else {
            return Ok(());
        };
        // Lines, the last counted without its newline too.
        let rows = text.lines().count() as u64;
        let threads = rayon::current_num_threads() as u64;
        let what = format!("identifying the {rows} lines of {origin}");
        let mut checks = vec![(
            IdentifySetting::Memory,
            false,
            Estimate::new(
                what.clone(),
                "identify a subset of the rows, or raise the memory limit",
            ),
        )];
        if let UncertaintyMethod::MonteCarlo { draws } = self.uncertainty {
            checks.push((
                IdentifySetting::McDraws,
                true,
                Estimate::new(
                    format!("{what} with {draws} Monte Carlo re-identifications"),
                    "use fewer re-identifications (or the linearised uncertainty), or raise the memory limit",
                ),
            ));
        }
        for (setting, monte_carlo, e) in checks {
            let e = self.memory_estimate(rows, text.len() as u64, threads, monte_carlo, e);
            budget.check(&e).map_err(|e| IdentifyJobError::Setting {
                setting,
                message: e.to_string(),
            })?;
        }
        Ok(())
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
            // A sample covariance of p quantities from k ≤ p draws is singular: no model file
            // holds it.
            let p = self.free_count();
            let message = if draws < MIN_MC_DRAWS {
                format!("at least {MIN_MC_DRAWS} re-identifications are needed for a covariance")
            } else if draws > MAX_MC_DRAWS {
                format!(
                    "at most {MAX_MC_DRAWS} re-identifications (got {draws}): a variance from K draws is uncertain by √(2/K), 1.4 % at {MAX_MC_DRAWS}, and each draw is a whole fit"
                )
            } else if draws <= p {
                format!(
                    "at least {} re-identifications are needed for a covariance of the {p} quantities the fit identifies (got {draws})",
                    p + 1
                )
            } else {
                String::new()
            };
            if !message.is_empty() {
                return Err(IdentifyJobError::Setting {
                    setting: IdentifySetting::McDraws,
                    message,
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
        if let Some(orders) = &self.harmonic_orders {
            let joints = self.nominal.joints();
            (self.beyond_geometry.check_orders(orders, joints)).map_err(|message| {
                IdentifyJobError::Setting {
                    setting: IdentifySetting::HarmonicOrders,
                    message,
                }
            })?;
        }
        Ok(ChainOptions {
            harmonic_orders: self.harmonic_orders.clone(),
            placement: self.placement,
            fix: self.fix.clone(),
            noise,
            uncertainty: self.uncertainty,
            seed: self.seed,
            compensate: self.compensate,
            beyond_geometry: self.beyond_geometry,
            progress: self.progress.clone(),
            ..ChainOptions::default()
        })
    }
}
