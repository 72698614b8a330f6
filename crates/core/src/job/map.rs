//! The map job: a model and the grid a user states → the workspace reliability map (inverse
//! kinematics per cell, one per-point evaluation of all reached cells), or one shard's cells
//! for `merge`.

use super::{JobError, MemoryCheck, Shard};
use crate::engine::{BackendChoice, BackendInfo, Backends, Frame, Problem, Reference};
use crate::kinematics::{Joints, RobotModel};
use crate::map::shard::MapShard;
use crate::map::{
    self, default_reference_deg, tool_down_rpy_deg, CellErrors, CellIk, Evaluation, Grid, MapError,
    MapResult, MapSetting, MapSpec, Plane, ReportKinds, Timings,
};
use crate::mc::summary::Provenance;
use crate::memory::MemoryBudget;
use crate::progress::{Notice, ProgressHook};
use crate::spec::{self, ModelSource, SpecError};

/// The grid of a map as a user states it; what is left out comes from the model (the box, the
/// tool pointing down, the reference configuration) or is `gpu-amcs map`'s default (50 × 50
/// cells of a plane, 10 × 10 × 10 of a volume).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MapSettings {
    /// A plane slice through the box (with [`Self::at`]); none: a 3-D grid fills the box.
    pub plane: Option<Plane>,
    /// The plane's position along its normal, mm.
    pub at: Option<f64>,
    /// Cells: two counts for a plane, three for a volume.
    pub cells: Option<Vec<usize>>,
    /// Flange orientation, roll, pitch, yaw in degrees; none: the tool pointing down.
    pub orientation: Option<Vec<f64>>,
    /// Position only: any flange orientation (overrides [`Self::orientation`]).
    pub free_orientation: bool,
    /// The configuration each cell's solution is nearest, degrees (one per joint).
    pub reference_q: Option<Vec<f64>>,
    /// Extra inverse-kinematics seeds.
    pub ik_seeds: usize,
    /// Centre of the box, mm; none: the robot's.
    pub box_center: Option<[f64; 3]>,
    /// Edge lengths of the box, mm; none: the robot's.
    pub box_size: Option<[f64; 3]>,
}

impl MapSettings {
    /// The grid (needs no model).
    ///
    /// # Errors
    ///
    /// [`MapError::Setting`]: a plane without its position ([`MapSetting::PlanePosition`]) or
    /// the other way round ([`MapSetting::Plane`]), cell counts of the wrong number ([`MapSetting::Cells`]).
    pub fn grid(&self) -> Result<Grid, MapError> {
        let counts = |default: Vec<usize>| self.cells.clone().unwrap_or(default);
        let wrong = |what: &str, got: usize| MapError::Setting {
            field: MapSetting::Cells,
            message: format!("needs {what}, got {got}"),
        };
        Ok(match (self.plane, self.at) {
            (Some(plane), Some(at)) => {
                let cells = counts(vec![50, 50]);
                let cells = <[usize; 2]>::try_from(cells.as_slice())
                    .map_err(|_| wrong("two counts NX,NY for a plane", cells.len()))?;
                Grid::Plane { plane, at, cells }
            }
            (Some(_), None) => {
                return Err(MapError::Setting {
                    field: MapSetting::PlanePosition,
                    message: "a plane needs its position along its normal (mm)".into(),
                })
            }
            (None, Some(_)) => {
                return Err(MapError::Setting {
                    field: MapSetting::Plane,
                    message: "a position along a plane's normal needs the plane (xy, xz or yz)"
                        .into(),
                })
            }
            (None, None) => {
                let cells = counts(vec![10, 10, 10]);
                let cells = <[usize; 3]>::try_from(cells.as_slice()).map_err(|_| {
                    wrong(
                        "three counts NX,NY,NZ for a 3-D grid (or a plane)",
                        cells.len(),
                    )
                })?;
                Grid::Volume { cells }
            }
        })
    }

    /// The map's specification for `model`.
    ///
    /// # Errors
    ///
    /// Those of [`Self::grid`]; [`MapError::Setting`] for an orientation that is not three
    /// numbers or a reference configuration that is not one per joint.
    pub fn spec(&self, model: &RobotModel) -> Result<MapSpec, MapError> {
        let orientation_rpy_deg = match (&self.orientation, self.free_orientation) {
            (_, true) => None,
            (Some(o), false) => {
                Some(
                    <[f64; 3]>::try_from(o.as_slice()).map_err(|_| MapError::Setting {
                        field: MapSetting::Orientation,
                        message: format!(
                            "needs 3 numbers (roll, pitch, yaw in degrees), got {}",
                            o.len()
                        ),
                    })?,
                )
            }
            (None, false) => Some(tool_down_rpy_deg(model)),
        };
        let reference_q_deg = match &self.reference_q {
            Some(q) if q.len() == model.joints() => Joints::from_slice(q),
            Some(q) => {
                return Err(MapError::Setting {
                    field: MapSetting::ReferenceConfiguration,
                    message: format!(
                    "needs {n} numbers (q1..q{n} in degrees, one per joint of the model), got {}",
                    q.len(),
                    n = model.joints()
                ),
                })
            }
            None => default_reference_deg(model),
        };
        let workspace = spec::GeneratedPoints {
            box_center: self.box_center,
            box_size: self.box_size,
            ..spec::GeneratedPoints::default()
        }
        .workspace(model);
        Ok(MapSpec {
            grid: self.grid()?,
            workspace,
            orientation_rpy_deg,
            reference_q_deg,
            ik_seeds: self.ik_seeds,
        })
    }
}

/// What a [`MapJob`] gives.
#[derive(Clone, Debug)]
pub struct MapOutcome {
    /// Every cell and its report.
    pub result: MapResult,
    /// What the job chose (the frame, the backend), as it told them.
    pub notes: Vec<String>,
}

/// A workspace reliability map over a plane slice or a 3-D grid.
///
/// # Examples
///
/// ```
/// use gpu_amcs_core::engine::{BackendChoice, CpuOnly};
/// use gpu_amcs_core::job::MapJob;
/// use gpu_amcs_core::map::Plane;
/// use gpu_amcs_core::spec::ModelSource;
///
/// let mut job = MapJob::new(ModelSource::Preset("tx60".into()));
/// job.grid.plane = Some(Plane::Xz);
/// job.grid.at = Some(0.0);
/// job.grid.cells = Some(vec![4, 4]);
/// job.draws = 200;
/// job.backend = BackendChoice::Cpu;
/// assert_eq!(job.layers().unwrap(), 1);
/// let outcome = job.run(&CpuOnly).unwrap();
/// assert_eq!(outcome.result.cells.len(), 16);
/// assert!(outcome.result.reached > 0);
/// ```
#[derive(Clone, Debug)]
pub struct MapJob {
    /// The model.
    pub model: ModelSource,
    /// The frame of the grid and the targets: the base frame leaves the model's placement out.
    pub frame: Frame,
    /// The grid.
    pub grid: MapSettings,
    /// Parameter draws (one stream shared by all cells).
    pub draws: u64,
    /// Thresholds l_c, mm.
    pub thresholds: Vec<f64>,
    /// Seed of the draws.
    pub seed: u64,
    /// Which evaluator.
    pub backend: BackendChoice,
    /// GPU adapter (part of its name).
    pub adapter: Option<String>,
    /// The memory the job may plan to use.
    pub memory: MemoryBudget,
    /// The reports a whole map is kept for while they are written (their memory counts).
    pub reports: ReportKinds,
    /// Told the progress ("map IK" in cells, then "map" or "map shard" in draws) and notices.
    pub progress: ProgressHook,
}

/// What one process computes of a map: the inverse kinematics of the whole grid, then the
/// evaluation of a shard of the reached cells (all of them for [`Shard::WHOLE`]) at every draw.
struct Evaluated {
    /// Every cell's configuration, `None` where unreachable.
    solutions: Vec<Option<CellIk>>,
    /// The evaluated part of the reached cells.
    range: (usize, usize),
    /// Their statistics and w over them.
    errors: CellErrors,
    /// The evaluator.
    backend: BackendInfo,
    /// The two stages' wall-clock seconds.
    timings: Timings,
    /// What the job chose.
    notes: Vec<String>,
}

/// The fewest shards `n ≥ 2` of `cells` cells that each fit (`fits` of at most ⌈cells/n⌉
/// evaluated cells), if any does.
fn fewest_shards(cells: usize, fits: impl Fn(usize) -> bool) -> Option<usize> {
    if cells < 2 || !fits(1) {
        return None;
    }
    let (mut lo, mut hi) = (2, cells);
    while lo < hi {
        let mid = lo + (hi - lo) / 2;
        if fits(cells.div_ceil(mid)) {
            hi = mid;
        } else {
            lo = mid + 1;
        }
    }
    Some(lo)
}

impl MapJob {
    /// The map of `model` with `gpu-amcs map`'s defaults: 10⁴ draws, the default thresholds,
    /// seed 2025, the auto backend, the default budget, the measurement frame.
    pub fn new(model: ModelSource) -> MapJob {
        MapJob {
            model,
            frame: Frame::Measurement,
            grid: MapSettings::default(),
            draws: 10_000,
            thresholds: crate::mc::DEFAULT_THRESHOLDS_MM.to_vec(),
            seed: 2025,
            backend: BackendChoice::Auto,
            adapter: None,
            memory: MemoryBudget::new(None),
            reports: ReportKinds::default(),
            progress: ProgressHook::none(),
        }
    }

    /// The number of layers along z (one heat map each), known before the model is read.
    ///
    /// # Errors
    ///
    /// Those of [`MapSettings::grid`].
    pub fn layers(&self) -> Result<usize, MapError> {
        Ok(match self.grid.grid()? {
            Grid::Plane { .. } => 1,
            Grid::Volume { cells } => cells[2],
        })
    }

    /// The model in the job's frame (telling what loading it chose, and the frame of a model
    /// with an uncertain placement), its map specification, checked, within the memory of the
    /// `shard`'s share of the cells.
    fn prepare(&self, shard: Option<Shard>) -> Result<(RobotModel, MapSpec), JobError> {
        map::check_run(&self.thresholds, self.draws)?;
        let (mut model, notes) = self
            .model
            .load_noted()
            .map_err(|e| SpecError::new(self.model.field(), e))?;
        for n in &notes {
            self.progress.notice(Notice::Model(n));
        }
        if self.frame == Frame::Base {
            model = model.without_base_uncertainty();
            model.base = None;
        } else if model.base_uncertain() {
            self.progress.notice(Notice::Note(FRAME_NOTE));
        }
        let spec = self.grid.spec(&model)?;
        spec.check(&model)?;
        // A shard evaluates at most ⌈cells/N⌉ cells (its share of the reached ones); its file
        // holds no per-cell reports.
        let cells = spec.n_cells();
        let evaluated = cells.div_ceil(shard.map_or(1, |s| s.n.min(cells as u64) as usize));
        let report_bytes = match shard {
            Some(_) => 0,
            None => map::report_bytes_per_cell(self.thresholds.len(), self.reports),
        };
        let estimate = |evaluated: usize, report_bytes: u64| {
            let batch = map::batch_size(evaluated, self.draws);
            map::memory_estimate_with_reports(cells, evaluated, self.draws, batch, report_bytes)
        };
        if let Err(error) = self.memory.check(&estimate(evaluated, report_bytes)) {
            // Shards write their summaries only (the merge writes the reports).
            let shards = match shard {
                None => fewest_shards(cells, |e| self.memory.check(&estimate(e, 0)).is_ok()),
                Some(_) => None,
            };
            return Err(JobError::Memory {
                check: MemoryCheck::Map { shards },
                error,
            });
        }
        spec::backend_choice(self.backend, self.adapter.as_deref())?;
        Ok((model, spec))
    }

    /// Solves the whole grid, then evaluates `shard` of the reached cells at every draw.
    fn solve_and_evaluate(
        &self,
        backends: &dyn Backends,
        model: &RobotModel,
        spec: &MapSpec,
        shard: Shard,
    ) -> Result<Evaluated, JobError> {
        let t0 = std::time::Instant::now();
        let ik = super::counted(&self.progress, "map IK");
        let solutions = spec.solve_with_progress(model, Some(&ik))?;
        let ik_seconds = t0.elapsed().as_secs_f64();
        let points = map::test_points(&solutions);
        let r = points.len() as u64;
        shard.check(r, &format!("the {r} reached cells"))?;
        let (first, end) = shard.range(r);
        let (first, end) = (first as usize, end as usize);
        let problem = Problem::new(
            model.clone(),
            &points[first..end],
            &Reference::Calibrated,
            self.seed,
        )
        .map_err(JobError::Reached)?;
        let (mut ev, notes) =
            spec::make_evaluator(backends, problem, self.backend, self.adapter.as_deref())?;
        for n in &notes {
            self.progress.notice(Notice::Note(n));
        }
        let label = if shard == Shard::WHOLE {
            "map"
        } else {
            "map shard"
        };
        let draws = super::counted(&self.progress, label);
        let t1 = std::time::Instant::now();
        let errors = map::evaluate_cells(
            ev.as_mut(),
            self.draws,
            map::batch_size(end - first, self.draws),
            &self.thresholds,
            Some(&draws),
        )?;
        Ok(Evaluated {
            solutions,
            range: (first, end),
            errors,
            backend: ev.info(),
            timings: Timings {
                ik_seconds,
                eval_seconds: t1.elapsed().as_secs_f64(),
            },
            notes,
        })
    }

    /// Maps the whole grid.
    ///
    /// # Errors
    ///
    /// [`JobError::Map`] naming a setting (or no cell reachable), [`JobError::Spec`] for the
    /// model or the backend, [`JobError::Memory`] ([`MemoryCheck::Map`], with the fewest shards
    /// that would each fit), [`JobError::Reached`].
    pub fn run(&self, backends: &dyn Backends) -> Result<MapOutcome, JobError> {
        let (model, spec) = self.prepare(None)?;
        let run = self.solve_and_evaluate(backends, &model, &spec, Shard::WHOLE)?;
        let eval = Evaluation::new(run.errors.cells, run.errors.w, &self.thresholds);
        let notes = self.frame_notes(&model, run.notes);
        Ok(MapOutcome {
            result: MapResult::new(
                &model.name,
                &spec,
                self.seed,
                run.solutions,
                eval,
                run.backend,
                run.timings,
            )
            .of_model(&model),
            notes,
        })
    }

    /// Shard `shard` of the reached cells for `merge`, with the provenance of the problem of
    /// all of them.
    ///
    /// # Errors
    ///
    /// Those of [`Self::run`], and [`JobError::Setting`] ([`super::JobSetting::Shard`]) for
    /// more shards than reached cells.
    pub fn run_shard(&self, backends: &dyn Backends, shard: Shard) -> Result<MapShard, JobError> {
        let (model, spec) = self.prepare(Some(shard))?;
        let e = self.solve_and_evaluate(backends, &model, &spec, shard)?;
        let points = map::test_points(&e.solutions);
        let reference = Reference::Calibrated;
        let all = Problem::new(model.clone(), &points, &reference, self.seed)
            .map_err(JobError::Reached)?;
        let provenance = Provenance::new(&all, &reference.label(&model), self.draws, 0, self.draws);
        Ok(MapShard::new(
            provenance,
            [shard.k, shard.n],
            &spec,
            &self.thresholds,
            &e.solutions,
            e.range,
            e.errors,
            e.backend,
            e.timings,
        )
        .with_base_origin(model.base_origin_mm()))
    }

    /// The frame's note (for a model drawn with its placement) before the evaluator's.
    fn frame_notes(&self, model: &RobotModel, notes: Vec<String>) -> Vec<String> {
        match self.frame == Frame::Measurement && model.base_uncertain() {
            true => [vec![FRAME_NOTE.to_string()], notes].concat(),
            false => notes,
        }
    }
}

/// The note of a map in the measurement frame of a model with an uncertain placement.
const FRAME_NOTE: &str = "frame: measurement frame (base placement drawn: 6 more inputs); the \
                          grid is in that frame, the base frame maps the robot's own";

#[cfg(test)]
mod tests {
    use super::fewest_shards;

    #[test]
    fn the_fewest_shards_are_the_first_count_that_fits() {
        // Each shard of 100 cells fits with at most 30 cells.
        assert_eq!(fewest_shards(100, |e| e <= 30), Some(4));
        assert_eq!(fewest_shards(100, |e| e <= 50), Some(2));
        // Not even one cell fits: no shard count helps.
        assert_eq!(fewest_shards(100, |_| false), None);
        assert_eq!(fewest_shards(1, |_| true), None);
    }
}
