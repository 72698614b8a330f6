//! `map`: a workspace reliability map over a plane slice or a 3-D grid (inverse kinematics per
//! cell, one per-point evaluation of all reached cells; the library's `MapJob`), or one shard
//! of the reached cells for `merge`.

use super::args::thread_pool;
use super::flags::job_error;
use super::merge::summary_shard;
use super::outputs::Outputs;
use super::progress::Bars;
use super::reports::{model_source, threads_row, write_reports};
use super::Run;
use crate::cmd::args::{BackendArgs, BoxArgs, MemoryArgs, ModelArgs};
use crate::cmd::reports::ReportFlags;
use anyhow::Result;
use clap::{Args, ValueEnum};
use gpu_amcs::job::{MapJob, MapSettings};
use gpu_amcs::map::{self, MapResult, Plane};
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

impl MapArgs {
    /// The library's job of these flags, telling `bars`.
    fn job(&self, bars: &std::sync::Arc<Bars>) -> Result<MapJob> {
        let box_ = self.workspace.generated(0, 0)?;
        Ok(MapJob {
            model: self.model.source()?,
            frame: self.frame.into(),
            grid: MapSettings {
                plane: self.plane.map(|p| match p {
                    PlaneArg::Xy => Plane::Xy,
                    PlaneArg::Xz => Plane::Xz,
                    PlaneArg::Yz => Plane::Yz,
                }),
                at: self.at,
                cells: self.cells.clone(),
                orientation: self.orientation.clone(),
                free_orientation: self.free_orientation,
                reference_q: self.reference_q.clone(),
                ik_seeds: self.ik_seeds,
                box_center: box_.box_center,
                box_size: box_.box_size,
            },
            draws: self.draws,
            thresholds: self.thresholds.clone(),
            seed: self.seed,
            backend: self.backend.backend.into(),
            adapter: self.backend.adapter.clone(),
            memory: self.memory.budget()?,
            reports: map::ReportKinds {
                json: self.reports.json.is_some(),
                csv: self.reports.csv.is_some(),
                svg: self.reports.svg.is_some(),
                html: self.reports.html.is_some(),
            },
            progress: bars.hook(self.model.model.as_deref()),
        })
    }
}

impl Run for MapArgs {
    fn run(self) -> Result<()> {
        let a = self;
        let shard = summary_shard(a.summary_out.is_some(), a.shard.as_deref(), a.shards)?;
        let bars = Bars::new(a.reports.quiet, |label| match label {
            "map IK" => ("map IK", "cells", false),
            "map shard" => ("map shard", "draws", false),
            _ => ("map", "draws", false),
        });
        let job = a.job(&bars)?;
        let mut outputs = Outputs::new(a.model.model.as_deref().map(|p| ("--model", p)));
        match &a.summary_out {
            Some(out) => outputs.file("--summary-out", Some(out))?,
            // A grid that is no grid declares one layer: the run refuses it before any work,
            // after what loading the model says.
            None => a.reports.declare(
                &mut outputs,
                &MapResult::planned_layout(job.layers().unwrap_or(1)),
            )?,
        }
        let pool = thread_pool(a.threads)?;
        if let (Some(shard), Some(out)) = (shard, &a.summary_out) {
            let s = pool.install(|| job.run_shard(gpu_amcs::backends(), shard));
            bars.finish();
            let s = s.map_err(job_error)?;
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
        let outcome = pool.install(|| job.run(gpu_amcs::backends()));
        bars.finish();
        let outcome = outcome.map_err(job_error)?;
        let rows = [
            ("model source".to_string(), model_source(&a.model)),
            threads_row(a.threads),
        ];
        write_reports(outputs, &outcome.result, &a.reports, &rows)
    }
}
