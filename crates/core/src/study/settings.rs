//! What the factor study varies and how much it computes (paper §3.2–3.4, docs/METHOD.md §5).
//!
//! One factor is varied at a time over the paper's levels, the others stay at the baseline
//! ([`Factors::default`]: 20 runs, 50 % range, 2° step, 25 % speed, negative→positive):
//! repeatability 10, 20, 30, 40, 50 runs; range 10, 25, 50, 75, 100 %; step 1–5°; speed 10, 25,
//! 50, 75, 100 %; start negative→positive and positive→negative. [`StudySettings::quick`] keeps
//! two or three levels per factor, 10 runs per calibration, 10^5 MCS draws and 2^10 base samples
//! for the parameter ranking (2^12 in the full study).

use crate::engine::backend::BackendChoice;
use crate::points::WorkspaceBox;
use crate::simulate::{Factors, SimulateError, SimulateSetting, SweepDirection};

/// One of the paper's five factors.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Factor {
    /// Number of repeated calibration runs.
    Repeatability,
    /// Joint range, % of the measuring range.
    Range,
    /// Joint step, degrees.
    Step,
    /// Joint speed, % of rated.
    Speed,
    /// Start position (sweep direction).
    Start,
}

impl Factor {
    /// All five, in the paper's order.
    pub const ALL: [Factor; 5] = [
        Self::Repeatability,
        Self::Range,
        Self::Step,
        Self::Speed,
        Self::Start,
    ];

    /// File-name friendly name.
    pub fn name(self) -> &'static str {
        match self {
            Self::Repeatability => "repeatability",
            Self::Range => "range",
            Self::Step => "step",
            Self::Speed => "speed",
            Self::Start => "start",
        }
    }

    /// The paper's levels (`quick`: a reduced set) applied to `baseline`, with labels.
    pub fn levels(self, baseline: &Factors, quick: bool) -> Vec<(String, Factors)> {
        let b = *baseline;
        match self {
            Self::Repeatability => {
                let v: &[usize] = if quick {
                    &[5, 10]
                } else {
                    &[10, 20, 30, 40, 50]
                };
                v.iter()
                    .map(|&r| (format!("{r} runs"), Factors { runs: r, ..b }))
                    .collect()
            }
            Self::Range => {
                let v: &[f64] = if quick {
                    &[10.0, 50.0, 100.0]
                } else {
                    &[10.0, 25.0, 50.0, 75.0, 100.0]
                };
                v.iter()
                    .map(|&p| {
                        (
                            format!("{p} %"),
                            Factors {
                                range_fraction: p / 100.0,
                                ..b
                            },
                        )
                    })
                    .collect()
            }
            Self::Step => {
                let v: &[f64] = if quick {
                    &[1.0, 5.0]
                } else {
                    &[1.0, 2.0, 3.0, 4.0, 5.0]
                };
                v.iter()
                    .map(|&s| (format!("{s}°"), Factors { step_deg: s, ..b }))
                    .collect()
            }
            Self::Speed => {
                let v: &[f64] = if quick {
                    &[10.0, 100.0]
                } else {
                    &[10.0, 25.0, 50.0, 75.0, 100.0]
                };
                v.iter()
                    .map(|&p| {
                        (
                            format!("{p} %"),
                            Factors {
                                speed_fraction: p / 100.0,
                                ..b
                            },
                        )
                    })
                    .collect()
            }
            Self::Start => [SweepDirection::NegToPos, SweepDirection::PosToNeg]
                .iter()
                .map(|&d| (d.label().to_string(), Factors { direction: d, ..b }))
                .collect(),
        }
    }
}

/// Everything the study needs.
#[derive(Clone, Debug, serde::Serialize)]
pub struct StudySettings {
    /// Reduced study (fewer levels and runs, MCS 10^5).
    pub quick: bool,
    /// Factors the others are held at.
    pub baseline: Factors,
    /// Factors to vary (default: all five).
    pub factors: Vec<Factor>,
    /// Seed of the simulated true robot.
    pub robot_seed: u64,
    /// Seed of the calibration runs (run r uses `run_seed(seed, r)`; the same for every level,
    /// so levels are compared on common random numbers).
    pub calibration_seed: u64,
    /// Seed of the Monte Carlo draws.
    pub mc_seed: u64,
    /// Seed of the test points.
    pub points_seed: u64,
    /// Numbers of test points (the paper: 10 and 50).
    pub point_counts: Vec<usize>,
    /// MCS draws (the paper: 10^6).
    pub mcs_draws: u64,
    /// AMCS tolerances δ, mm (the paper: 0.01 and 0.02).
    pub deltas: Vec<f64>,
    /// AMCS batch size H.
    pub batch: u64,
    /// Thresholds l_c of Table 1, mm.
    pub thresholds: Vec<f64>,
    /// Workspace box of the test points.
    pub workspace: WorkspaceBox,
    /// Test points of the before/after accuracy check.
    pub accuracy_points: usize,
    /// Base samples N of the Sobol indices of the baseline calibration (the parameter
    /// ranking), a power of 2.
    pub sensitivity_draws: usize,
    /// Evaluation backend.
    #[serde(skip)]
    pub backend: BackendChoice,
    /// GPU adapter name filter.
    pub adapter: Option<String>,
    /// Robots with joint errors calibrated at the baseline beside the factor study; none: the
    /// study of geometric robots alone.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub joint_errors: Option<super::beyond::JointErrorStudy>,
}

impl Default for StudySettings {
    /// The full study of the paper.
    fn default() -> Self {
        StudySettings {
            quick: false,
            baseline: Factors::default(),
            factors: Factor::ALL.to_vec(),
            robot_seed: 2025,
            calibration_seed: 1,
            mc_seed: 2025,
            points_seed: 1,
            point_counts: vec![10, 50],
            mcs_draws: 1_000_000,
            deltas: vec![0.01, 0.02],
            batch: 10_000,
            thresholds: (1..=8).map(|i| i as f64 / 10.0).collect(),
            workspace: WorkspaceBox::default(),
            accuracy_points: 50,
            sensitivity_draws: 1 << 12,
            backend: BackendChoice::Auto,
            adapter: None,
            joint_errors: None,
        }
    }
}

impl StudySettings {
    /// The reduced study: 2–3 levels per factor, 10 runs per calibration, MCS 10^5.
    pub fn quick() -> Self {
        StudySettings {
            quick: true,
            baseline: Factors {
                runs: 10,
                ..Factors::default()
            },
            mcs_draws: 100_000,
            sensitivity_draws: 1 << 10,
            ..Self::default()
        }
    }

    /// The levels of every factor studied.
    pub fn levels(&self) -> Vec<(Factor, String, Factors)> {
        self.factors
            .iter()
            .flat_map(|&f| {
                f.levels(&self.baseline, self.quick)
                    .into_iter()
                    .map(move |(l, x)| (f, l, x))
            })
            .collect()
    }

    /// Checks the settings.
    ///
    /// # Errors
    ///
    /// [`SimulateError::Setting`] naming the first setting out of range (point counts, MCS draws,
    /// tolerances, factors, or a factor of the baseline).
    pub fn check(&self) -> Result<(), SimulateError> {
        self.baseline.check()?;
        let bad = |field, message: String| Err(SimulateError::Setting { field, message });
        if self.point_counts.is_empty() || self.point_counts.contains(&0) {
            return bad(
                SimulateSetting::PointCounts,
                format!(
                    "needs positive numbers of test points, got {:?}",
                    self.point_counts
                ),
            );
        }
        if self.mcs_draws < 2000 {
            return bad(
                SimulateSetting::McsDraws,
                format!("must be at least 2000, got {}", self.mcs_draws),
            );
        }
        if self.deltas.is_empty() || self.deltas.iter().any(|d| !(d.is_finite() && *d > 0.0)) {
            return bad(
                SimulateSetting::Tolerances,
                format!("needs positive tolerances in mm, got {:?}", self.deltas),
            );
        }
        if self.factors.is_empty() {
            return bad(SimulateSetting::Factors, "needs at least one factor".into());
        }
        if let Some(js) = &self.joint_errors {
            js.check()?;
        }
        Ok(())
    }
}
