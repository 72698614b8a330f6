//! The evaluation of a map's reached cells: every draw at every cell in one per-point run, the
//! statistics of each cell's error and of the multi-point `w`, and the memory it keeps.

use super::{setting, MapError, MapSetting};
use crate::engine::Evaluator;
use crate::mc::Reliability;
use crate::memory::Estimate;
use serde::{Deserialize, Serialize};

/// Bytes kept per cell besides its errors: target, configuration, statistics.
pub const BYTES_PER_CELL: u64 = 512;

/// Memory a map evaluation keeps: the errors of every evaluated cell and draw (8 bytes each,
/// kept for the exact 95 % quantile), one batch of per-point errors in the driver and as much in
/// the evaluator, the multi-point w of every draw, and the cells of the whole grid. A map split
/// into shards ([`shard`](super::shard)) evaluates only a shard's cells in each, so `evaluated` may be fewer
/// than the grid's `cells`.
pub fn memory_estimate(cells: usize, evaluated: usize, draws: u64, batch: u64) -> Estimate {
    memory_estimate_with_reports(cells, evaluated, draws, batch, 0)
}

/// Which reports a map run writes, for [`report_bytes_per_cell`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ReportKinds {
    /// The JSON report.
    pub json: bool,
    /// The CSV table.
    pub csv: bool,
    /// The SVG maps.
    pub svg: bool,
    /// The HTML report (which holds the JSON, CSV and SVG files too).
    pub html: bool,
}

/// Bytes the reports of a map keep per grid cell while they are built and staged: every
/// report's text, kept until all are written (JSON about 530 + 95·T bytes a cell with T
/// thresholds, CSV 176 + 15·T, SVG maps 150, the HTML report its index, 150, plus its own copies
/// of the other three; measured on 10^4-cell planes), and, while the JSON is built, its
/// document tree, five times its text. Measured peaks (200 × 200 plane, 40³ and 30³ grids, one
/// and eight thresholds, JSON alone, CSV and SVG, and every report) are 52–91 % of it.
pub fn report_bytes_per_cell(thresholds: usize, kinds: ReportKinds) -> u64 {
    let t = thresholds as u64;
    let (json, csv, svg) = (530 + 95 * t, 176 + 15 * t, 150);
    let mut bytes = 0;
    if kinds.json {
        bytes += json;
    }
    if kinds.csv {
        bytes += csv;
    }
    if kinds.svg {
        bytes += svg;
    }
    if kinds.html {
        bytes += 150 + json + csv + svg;
    }
    if kinds.json || kinds.html {
        bytes += 5 * json;
    }
    bytes
}

/// [`memory_estimate`] plus `report_bytes` a grid cell for the reports
/// ([`report_bytes_per_cell`]).
pub fn memory_estimate_with_reports(
    cells: usize,
    evaluated: usize,
    draws: u64,
    batch: u64,
    report_bytes: u64,
) -> Estimate {
    let what = if evaluated < cells {
        format!("a shard of {evaluated} of the {cells} cells of a map with {draws} draws")
    } else {
        format!("a map of {cells} cells with {draws} draws")
    };
    Estimate::new(what, "use fewer cells or draws, or raise the memory limit")
        .plus(&[evaluated as u64, draws, 8])
        .plus(&[batch, evaluated as u64, 2 * 8])
        .plus(&[draws, 8])
        .plus(&[cells as u64, BYTES_PER_CELL])
        .plus(&[cells as u64, report_bytes])
}

/// Draws evaluated at a time for `cells` reached cells: about 4·10^6 errors (32 MB) a batch.
pub fn batch_size(cells: usize, draws: u64) -> u64 {
    (4_000_000 / cells.max(1) as u64).clamp(1, draws.max(1))
}

/// The statistics of one reached cell over the draws.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CellStats {
    /// Mean of the point error e_j, mm.
    pub mean_mm: f64,
    /// 95 % quantile of e_j (the ⌈0.95 N⌉-th smallest value), mm.
    pub q95_mm: f64,
    /// `R_j(l_c)` at each threshold, with the Wilson 95 % interval.
    pub reliability: Vec<Reliability>,
}

/// The evaluation of the reached cells.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Evaluation {
    /// Draws.
    pub draws: u64,
    /// Per reached cell, in the order of the evaluator's test points.
    pub cells: Vec<CellStats>,
    /// Multi-point `R(l_c) = Pr[w < l_c]`, `w = max_j e_j` over the reached cells.
    pub multi_point: Vec<Reliability>,
    /// Mean of w, mm.
    pub w_mean_mm: f64,
    /// 95 % quantile of w, mm.
    pub w_q95_mm: f64,
}

/// Checks thresholds and draws.
///
/// # Errors
///
/// [`MapError::Setting`] for no thresholds, a threshold that is not a positive number of mm, or no
/// draws.
pub fn check_run(thresholds: &[f64], draws: u64) -> Result<(), MapError> {
    if thresholds.is_empty() {
        return Err(setting(MapSetting::Thresholds, "at least one is needed"));
    }
    if let Some(t) = thresholds.iter().find(|t| !t.is_finite() || **t <= 0.0) {
        return Err(setting(
            MapSetting::Thresholds,
            format!("each must be a positive number of mm, got {t}"),
        ));
    }
    if draws < MIN_MAP_DRAWS {
        return Err(setting(
            MapSetting::Draws,
            format!(
                "at least {MIN_MAP_DRAWS} are needed, got {draws}: the map reports each cell's \
                 95 % quantile, and with fewer than 1/(1 − 0.95) = 20 draws that is just the \
                 largest draw"
            ),
        ));
    }
    Ok(())
}

/// Fewest draws a map accepts: `1/(1 − 0.95)`, below which the 95 % quantile it reports is the
/// largest draw.
pub const MIN_MAP_DRAWS: u64 = 20;

/// The probability of the per-cell quantile a map reports.
const Q95: f64 = 0.95;

/// The ⌈p·n⌉-th smallest of `v` (reorders `v`).
fn quantile(v: &mut [f64], p: f64) -> f64 {
    let k = ((p * v.len() as f64).ceil() as usize).clamp(1, v.len()) - 1;
    *v.select_nth_unstable_by(k, f64::total_cmp).1
}

/// The statistics of one set of errors over the draws, in draw order: a cell's `e_j` or the
/// multi-point `w` (reorders `v`, which must not be empty).
pub fn statistics(v: &mut [f64], thresholds: &[f64]) -> CellStats {
    let n = v.len() as u64;
    let mean_mm = v.iter().sum::<f64>() / n as f64;
    let reliability = thresholds
        .iter()
        .map(|&l| Reliability::from_count(l, v.iter().filter(|&&e| e < l).count() as u64, n))
        .collect();
    CellStats {
        mean_mm,
        q95_mm: quantile(v, Q95),
        reliability,
    }
}

/// The evaluated cells' statistics and the multi-point `w = max_j e_j` over them of every draw,
/// before its statistics: the part of an evaluation a shard of a map keeps ([`shard`](super::shard)).
#[derive(Clone, Debug, PartialEq)]
pub struct CellErrors {
    /// Per evaluated cell, in the order of the evaluator's test points.
    pub cells: Vec<CellStats>,
    /// `w` of draws `0 … draws − 1`, mm.
    pub w: Vec<f64>,
}

/// Evaluates draws `0 … draws − 1` at every test point of `ev` (the reached cells, or a shard's
/// part of them) in batches of `batch`, keeping each cell's errors for its statistics;
/// `progress` gets (done, total).
///
/// # Errors
///
/// [`MapError::Setting`] for bad thresholds or draws ([`check_run`]), and [`MapError::Engine`] when
/// the evaluator fails.
pub fn evaluate_cells(
    ev: &mut dyn Evaluator,
    draws: u64,
    batch: u64,
    thresholds: &[f64],
    progress: Option<&(dyn Fn(u64, u64) + Sync)>,
) -> Result<CellErrors, MapError> {
    check_run(thresholds, draws)?;
    let m = ev.n_points();
    let n = draws as usize;
    let batch = batch.clamp(1, draws) as usize;
    // Cell-major: errors of cell j are values[j·n .. (j+1)·n], in draw order.
    let mut values = vec![0.0f64; m * n];
    let mut w = vec![0.0f64; n];
    let mut buf = vec![0.0f64; batch * m];
    let mut first = 0usize;
    while first < n {
        let len = batch.min(n - first);
        let e = &mut buf[..len * m];
        ev.evaluate(first as u64, &mut w[first..first + len], Some(e))?;
        for (i, row) in e.chunks(m).enumerate() {
            for (j, v) in row.iter().enumerate() {
                values[j * n + first + i] = *v;
            }
        }
        first += len;
        if let Some(p) = progress {
            p(first as u64, draws);
        }
    }
    let cells = values
        .chunks_mut(n)
        .map(|v| statistics(v, thresholds))
        .collect();
    Ok(CellErrors { cells, w })
}

impl Evaluation {
    /// The evaluation of the reached cells from their statistics and `w` of every draw (one
    /// run's, or the elementwise maximum of its shards'): the multi-point statistics are those
    /// of `w` ([`statistics`]).
    pub fn new(cells: Vec<CellStats>, mut w: Vec<f64>, thresholds: &[f64]) -> Evaluation {
        let multi = statistics(&mut w, thresholds);
        Evaluation {
            draws: w.len() as u64,
            cells,
            multi_point: multi.reliability,
            w_mean_mm: multi.mean_mm,
            w_q95_mm: multi.q95_mm,
        }
    }
}

/// Evaluates draws `0 … draws − 1` at every test point of `ev` (the reached cells) in batches of
/// `batch` ([`evaluate_cells`]) and adds the multi-point statistics.
///
/// # Errors
///
/// As [`evaluate_cells`]: [`MapError::Setting`] for bad thresholds or draws, [`MapError::Engine`]
/// when the evaluator fails.
///
/// # Examples
///
/// A whole map, as the `map` command makes it: a 3 × 2 slice of the TX60's workspace in the
/// plane y = 0, its inverse kinematics, 2000 draws at the reached cells on the CPU evaluator,
/// and the finished map:
///
/// ```
/// use gpu_amcs_core::engine::{CpuEvaluator, Evaluator, Problem, Reference};
/// use gpu_amcs_core::map::{self, Grid, MapResult, MapSpec, Plane, Timings};
///
/// let model = gpu_amcs_core::kinematics::tx60();
/// let spec = MapSpec {
///     grid: Grid::Plane { plane: Plane::Xz, at: 0.0, cells: [3, 2] },
///     workspace: Default::default(),
///     orientation_rpy_deg: None,
///     reference_q_deg: map::default_reference_deg(&model),
///     ik_seeds: 8,
/// };
/// let solutions = spec.solve(&model)?;
/// let points = map::test_points(&solutions);
/// let problem = Problem::new(model.clone(), &points, &Reference::Calibrated, 7)?;
/// let mut ev = CpuEvaluator::new(problem);
/// let draws = 2000;
/// let batch = map::batch_size(points.len(), draws);
/// let eval = map::evaluate(&mut ev, draws, batch, &[0.1, 0.2], None)?;
/// let (info, timings) = (ev.info(), Timings::default());
/// let result = MapResult::new(&model.name, &spec, 7, solutions, eval, info, timings);
/// assert_eq!(result.cells.len(), 6);
/// assert!(result.reached > 0 && result.reached == points.len());
/// for cell in result.cells.iter().filter(|c| c.ik.is_some()) {
///     assert!(map::round_trip_error(&model, cell).unwrap() < 1e-6);
/// }
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn evaluate(
    ev: &mut dyn Evaluator,
    draws: u64,
    batch: u64,
    thresholds: &[f64],
    progress: Option<&(dyn Fn(u64, u64) + Sync)>,
) -> Result<Evaluation, MapError> {
    let e = evaluate_cells(ev, draws, batch, thresholds, progress)?;
    Ok(Evaluation::new(e.cells, e.w, thresholds))
}
