//! `map`: a workspace reliability map over a plane slice or a 3-D grid (inverse kinematics per
//! cell, one per-point evaluation of all reached cells).

use super::args::thread_pool;
use super::flags::map_error;
use super::merge::Shard;
use super::outputs::Outputs;
use super::progress::Progress;
use super::reports::{model_source, threads_row, write_reports};
use super::Run;
use crate::cmd::args::{BackendArgs, BoxArgs, MemoryArgs, ModelArgs};
use crate::cmd::reports::ReportFlags;
use anyhow::{bail, Context, Result};
use clap::{Args, ValueEnum};
use gpu_amcs::engine::{BackendInfo, Problem, Reference};
use gpu_amcs::kinematics::RobotModel;
use gpu_amcs::map::shard::MapShard;
use gpu_amcs::map::{
    self, default_reference_deg, tool_down_rpy_deg, CellErrors, CellIk, Evaluation, Grid,
    MapResult, MapSpec, Plane, Timings,
};
use gpu_amcs::mc::summary::Provenance;
use std::path::PathBuf;

/// Plane of a slice.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum PlaneArg {
    /// Horizontal plane at z = --at.
    Xy,
    /// Vertical plane at y = --at.
    Xz,
    /// Vertical plane at x = --at.
    Yz,
}

/// `map` options.
#[derive(Args, Debug, Clone)]
#[command(
    mut_arg("json", |a| a.help("Write every cell as JSON to FILE")),
    mut_arg("csv", |a| a.help("Write map.csv (one row per cell) into DIR")),
    mut_arg("svg", |a| a.help(
        "Write the heat maps (95 % quantile of e_j and R_j at the first threshold, per plane) \
         into DIR"
    )),
    mut_arg("quiet", |a| a.help("No progress bar and no summary on stdout"))
)]
pub struct MapArgs {
    #[command(flatten)]
    pub model: ModelArgs,
    /// Frame of the grid and the targets: `measurement` (the model's description or tracker
    /// frame; a model's uncertain base placement is drawn) or `base` (the robot's own frame: the
    /// model's `base` placement and its uncertainty are left out).
    #[arg(long, value_enum, default_value_t = crate::cmd::args::FrameArg::Measurement)]
    pub frame: crate::cmd::args::FrameArg,
    /// The box the grid spans (the same flags as the generated test points).
    #[command(flatten)]
    pub workspace: BoxArgs,
    /// A plane slice through the box (with --at); without it, a 3-D grid fills the box.
    #[arg(long, value_enum)]
    pub plane: Option<PlaneArg>,
    /// Position of the plane along its normal, mm (z for xy, y for xz, x for yz).
    #[arg(long, value_name = "MM", allow_hyphen_values = true)]
    pub at: Option<f64>,
    /// Cells: NX,NY of a plane (along its two axes) or NX,NY,NZ of a 3-D grid
    /// (default 50,50 or 10,10,10).
    #[arg(long, value_delimiter = ',', value_name = "N,N[,N]")]
    pub cells: Option<Vec<usize>>,
    /// Flange orientation as roll,pitch,yaw in degrees about the fixed x, y, z axes
    /// (default: the tool pointing down, 180,0,0 for most robots; targets and orientation are in the world frame).
    #[arg(
        long,
        value_delimiter = ',',
        value_name = "R,P,Y",
        allow_hyphen_values = true,
        conflicts_with = "free_orientation"
    )]
    pub orientation: Option<Vec<f64>>,
    /// Position only (3-DOF task): any flange orientation.
    #[arg(long)]
    pub free_orientation: bool,
    /// Reference configuration q1..qn (degrees, one per joint of the model): each cell takes the solution nearest it
    /// (default: mid-range, joints 2, 3 and 5 turned 30°).
    #[arg(
        long,
        value_delimiter = ',',
        value_name = "Q1,...,Q6",
        allow_hyphen_values = true
    )]
    pub reference_q: Option<Vec<f64>>,
    /// Inverse kinematics: extra seeds tried where the built-in 64 (spread over the joint
    /// ranges, besides the reference and the solved neighbours) reach nothing.
    #[arg(long, default_value_t = 0, value_name = "N")]
    pub ik_seeds: usize,
    /// Parameter draws (one stream shared by all cells).
    #[arg(long, default_value_t = 10_000, value_name = "N")]
    pub draws: u64,
    /// Thresholds l_c (mm) for the reliabilities.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = super::args::DEFAULT_THRESHOLDS.as_str(),
        value_name = "MM,...",
        allow_hyphen_values = true
    )]
    pub thresholds: Vec<f64>,
    /// Seed of the parameter draws.
    #[arg(long, default_value_t = 2025, value_name = "SEED")]
    pub seed: u64,
    #[command(flatten)]
    pub backend: BackendArgs,
    /// CPU threads (default: all cores). Results do not depend on it.
    #[arg(long, value_name = "N")]
    pub threads: Option<usize>,
    #[command(flatten)]
    pub memory: MemoryArgs,
    #[command(flatten)]
    pub reports: ReportFlags,
    /// Evaluate only shard K of N (K from 0): reached cells [K·r/N, (K+1)·r/N) of the r the
    /// grid reaches, at every draw (each shard solves the whole grid's inverse kinematics).
    /// Without it, with --summary-out, K and N come from SLURM_ARRAY_TASK_ID and
    /// SLURM_ARRAY_TASK_COUNT, or from JOB_COMPLETION_INDEX and --shards, when set.
    #[arg(long, value_name = "K/N", requires = "summary_out")]
    pub shard: Option<String>,
    /// Number of shards N of a Kubernetes Indexed Job (its completions): this shard is
    /// JOB_COMPLETION_INDEX of N.
    #[arg(
        long,
        value_name = "N",
        requires = "summary_out",
        conflicts_with = "shard"
    )]
    pub shards: Option<u64>,
    /// Write the shard's cells (JSON) for `gpu-amcs merge`, which writes the map's reports.
    #[arg(long, value_name = "FILE", conflicts_with_all = ["json", "csv", "svg", "html"])]
    pub summary_out: Option<PathBuf>,
}

/// `v` as `N` numbers, or an error naming `flag` and `what` they are.
fn exactly<const N: usize>(v: &[f64], flag: &str, what: &str) -> Result<[f64; N]> {
    <[f64; N]>::try_from(v)
        .map_err(|_| anyhow::anyhow!("{flag} needs {N} numbers ({what}), got {}", v.len()))
}

impl MapArgs {
    /// The map's specification from the flags (the model gives the default reference).
    fn spec(&self, model: &gpu_amcs::kinematics::RobotModel) -> Result<MapSpec> {
        let grid = match (self.plane, self.at) {
            (Some(p), Some(at)) => {
                let cells = self.cells.clone().unwrap_or_else(|| vec![50, 50]);
                let [nx, ny] = <[usize; 2]>::try_from(cells.as_slice()).map_err(|_| {
                    anyhow::anyhow!(
                        "--cells needs two counts NX,NY for a plane, got {}",
                        cells.len()
                    )
                })?;
                Grid::Plane {
                    plane: match p {
                        PlaneArg::Xy => Plane::Xy,
                        PlaneArg::Xz => Plane::Xz,
                        PlaneArg::Yz => Plane::Yz,
                    },
                    at,
                    cells: [nx, ny],
                }
            }
            (Some(_), None) => {
                bail!("--plane needs --at MM (the plane's position along its normal)")
            }
            (None, Some(_)) => bail!("--at needs --plane xy|xz|yz"),
            (None, None) => {
                let cells = self.cells.clone().unwrap_or_else(|| vec![10, 10, 10]);
                let c = <[usize; 3]>::try_from(cells.as_slice()).map_err(|_| {
                    anyhow::anyhow!(
                        "--cells needs three counts NX,NY,NZ for a 3-D grid (or give --plane), got {}",
                        cells.len()
                    )
                })?;
                Grid::Volume { cells: c }
            }
        };
        let orientation = match (&self.orientation, self.free_orientation) {
            (_, true) => None,
            (Some(o), false) => Some(exactly::<3>(
                o,
                "--orientation",
                "roll,pitch,yaw in degrees",
            )?),
            (None, false) => Some(tool_down_rpy_deg(model)),
        };
        let reference_q_deg = match &self.reference_q {
            Some(q) if q.len() == model.joints() => gpu_amcs::kinematics::Joints::from_slice(q),
            Some(q) => anyhow::bail!(
                "--reference-q needs {n} numbers (q1..q{n} in degrees, one per joint of the model), got {}",
                q.len(),
                n = model.joints()
            ),
            None => default_reference_deg(model),
        };
        Ok(MapSpec {
            grid,
            workspace: self.workspace.workspace(model)?,
            orientation_rpy_deg: orientation,
            reference_q_deg,
            ik_seeds: self.ik_seeds,
        })
    }
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

impl Run for MapArgs {
    fn run(self) -> Result<()> {
        let a = self;
        map::check_run(&a.thresholds, a.draws).map_err(map_error)?;
        let mut model = a.model.load()?;
        if a.frame == crate::cmd::args::FrameArg::Base {
            model = model.without_base_uncertainty();
            model.base = None;
        } else if model.base_uncertain() && !a.reports.quiet {
            eprintln!(
                "note: frame: measurement frame (base placement drawn: 6 more inputs); the grid is in that frame, --frame base maps the robot's own frame"
            );
        }
        let spec = a.spec(&model)?;
        spec.check(&model).map_err(map_error)?;
        let (_, n, _) = spec.layout();
        let shard = match &a.summary_out {
            Some(_) => Some(Shard::from_flags_or_env(
                a.shard.as_deref(),
                a.shards,
                |v| std::env::var(v).ok(),
            )?),
            None => None,
        };
        let mut outputs = Outputs::new(a.model.model.as_deref().map(|p| ("--model", p)));
        match &a.summary_out {
            Some(out) => outputs.file("--summary-out", Some(out))?,
            None => a
                .reports
                .declare(&mut outputs, &MapResult::planned_layout(n[2]))?,
        }
        // A shard evaluates at most ⌈cells/N⌉ cells (its share of the reached ones).
        let cells = spec.n_cells();
        let evaluated = cells.div_ceil(shard.map_or(1, |s| s.n.min(cells as u64) as usize));
        // A shard's file holds no per-cell reports; a run's reports are kept while written.
        let kinds = map::ReportKinds {
            json: a.reports.json.is_some(),
            csv: a.reports.csv.is_some(),
            svg: a.reports.svg.is_some(),
            html: a.reports.html.is_some(),
        };
        let report_bytes = if a.summary_out.is_some() {
            0
        } else {
            map::report_bytes_per_cell(a.thresholds.len(), kinds)
        };
        let estimate = |evaluated: usize, report_bytes: u64| {
            let batch = map::batch_size(evaluated, a.draws);
            map::memory_estimate_with_reports(cells, evaluated, a.draws, batch, report_bytes)
        };
        let budget = a.memory.budget()?;
        let mut needed = estimate(evaluated, report_bytes);
        if budget.check(&needed).is_err() && shard.is_none() {
            // Shards write their summaries only (the merge writes the reports).
            if let Some(k) = fewest_shards(cells, |e| budget.check(&estimate(e, 0)).is_ok()) {
                needed.advice = format!(
                    "split it into {k} or more shards (--shard K/{k} --summary-out FILE, then \
                     gpu-amcs merge), or {}",
                    needed.advice
                );
            }
        }
        budget.check(&needed).context("--draws, --cells")?;
        a.backend.choice()?;
        let pool = thread_pool(a.threads)?;
        if let (Some(shard), Some(out)) = (shard, &a.summary_out) {
            let s = pool.install(|| run_shard(&a, &model, &spec, shard))?;
            outputs.stage_file("--summary-out", s.to_json())?;
            outputs.commit()?;
            if !a.reports.quiet {
                crate::cmd::stdout::println(&format!(
                    "map shard {}/{}: reached cells [{}, {}) of {} evaluated at {} draws; \
                     written to {}",
                    shard.k,
                    shard.n,
                    s.first,
                    s.end,
                    s.provenance.points,
                    a.draws,
                    out.display()
                ))?;
            }
            return Ok(());
        }
        let result = pool.install(|| -> Result<MapResult> {
            let run = solve_and_evaluate(&a, &model, &spec, Shard::WHOLE)?;
            let eval = Evaluation::new(run.errors.cells, run.errors.w, &a.thresholds);
            Ok(MapResult::new(
                &model.name,
                &spec,
                a.seed,
                run.solutions,
                eval,
                run.backend,
                run.timings,
            )
            .of_model(&model))
        })?;
        let rows = [
            ("model source".to_string(), model_source(&a.model)),
            threads_row(a.threads),
        ];
        write_reports(outputs, &result, &a.reports, &rows)
    }
}

/// What one process computes of a map: the inverse kinematics of the whole grid, then the
/// evaluation of shard `shard` of the reached cells (all of them for [`Shard::WHOLE`]) at every
/// draw.
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
}

fn solve_and_evaluate(
    a: &MapArgs,
    model: &RobotModel,
    spec: &MapSpec,
    shard: Shard,
) -> Result<Evaluated> {
    let t0 = std::time::Instant::now();
    let ik_bar = Progress::new(a.reports.quiet, "map IK", "cells");
    let solutions = spec
        .solve_with_progress(model, Some(&|done, total| ik_bar.update(done, total)))
        .map_err(map_error);
    ik_bar.finish();
    let solutions = solutions?;
    let ik_seconds = t0.elapsed().as_secs_f64();
    let points = map::test_points(&solutions);
    let r = points.len() as u64;
    if shard.n > r {
        bail!(
            "--shard: {} shards of the {r} reached cells leave some empty",
            shard.n
        );
    }
    let (first, end) = shard.range(r);
    let (first, end) = (first as usize, end as usize);
    let problem = Problem::new(
        model.clone(),
        &points[first..end],
        &Reference::Calibrated,
        a.seed,
    )
    .context("reached configurations")?;
    let (mut ev, notes) = a.backend.evaluator(problem)?;
    if !a.reports.quiet {
        for n in &notes {
            eprintln!("note: {n}");
        }
    }
    let label = if shard == Shard::WHOLE {
        "map"
    } else {
        "map shard"
    };
    let bar = Progress::new(a.reports.quiet, label, "draws");
    let t1 = std::time::Instant::now();
    let errors = map::evaluate_cells(
        ev.as_mut(),
        a.draws,
        map::batch_size(end - first, a.draws),
        &a.thresholds,
        Some(&|done, total| bar.update(done, total)),
    );
    bar.finish();
    Ok(Evaluated {
        solutions,
        range: (first, end),
        errors: errors.map_err(map_error)?,
        backend: ev.info(),
        timings: Timings {
            ik_seconds,
            eval_seconds: t1.elapsed().as_secs_f64(),
        },
    })
}

/// Shard `shard` of the map, with the provenance of the problem of all its reached cells.
fn run_shard(a: &MapArgs, model: &RobotModel, spec: &MapSpec, shard: Shard) -> Result<MapShard> {
    let e = solve_and_evaluate(a, model, spec, shard)?;
    let points = map::test_points(&e.solutions);
    let reference = Reference::Calibrated;
    let all = Problem::new(model.clone(), &points, &reference, a.seed)
        .context("reached configurations")?;
    let provenance = Provenance::new(&all, &reference.label(model), a.draws, 0, a.draws);
    Ok(MapShard::new(
        provenance,
        [shard.k, shard.n],
        spec,
        &a.thresholds,
        &e.solutions,
        e.range,
        e.errors,
        e.backend,
        e.timings,
    )
    .with_base_origin(model.base_origin_mm()))
}
