//! The GPU evaluator: the parameter vectors of [`Evaluator`] through a WGSL
//! compute shader (`shaders/philox.wgsl` + `shaders/mdh_max_error.wgsl`) on any Vulkan, Metal or
//! DX12 adapter via wgpu, one invocation per parameter vector (`docs/METHOD.md §3`:
//! `w = max_j e_j`, paper eqs. 12 and 17).
//!
//! The shader's entry point [`ENTRY_POINT`] draws exactly the normals of the CPU sampler
//! (Philox4x32-10 with counter `[draw lo, draw hi, block, 0]`, the Box–Muller layout of
//! [`gpu_amcs_core::sampling::box_muller`], independent `δ_i = σ_i z_i` or correlated `δ = L z` on the
//! free parameters), so draw `k` is the same parameter vector on both backends. The entry point
//! [`OFFSETS_ENTRY_POINT`] reads δ from an uploaded offset matrix instead (rows converted to
//! f32 chunk by chunk), and [`PICK_FREEZE_ENTRY_POINT`] generates the rows of a Sobol
//! pick-freeze design from two counter draws and a per-matrix mask of normals
//! ([`PickFreeze`]; only the masks are uploaded); all call the same WGSL
//! kinematics. The kinematics is the f32
//! deviation form of [`deviation`], whose module docs give the error budget.
//!
//! # One device per process
//!
//! Device, queue, bind-group layout and pipelines live in a [`GpuContext`], opened once per
//! adapter and process and shared (`Arc`) by every evaluator on that adapter
//! ([`GpuContext::shared`]; [`devices_opened`] counts the opens). An evaluator owns only the
//! per-problem buffers (configuration, joint constants, spread, per-point constants) and its
//! chunk slots; [`GpuEvaluator::set_problem`] replaces the per-problem buffers and keeps the
//! rest. Bindings are named ([`binding`]), not positional; `tests/gpu.rs` checks them, the
//! workgroup size and the uniform sizes against the shader.
//!
//! # Batching
//!
//! A request is cut into chunks of at most [`GpuOptions::chunk`] parameter vectors (also
//! bounded by the device's workgroup-count, binding-size and buffer-size limits); two chunk
//! slots alternate so the readback and f32→f64 conversion of chunk h overlaps the computation
//! of chunk h+1. After a request for draws `[k, k+n)` (without per-point output) the evaluator
//! speculatively submits `[k+n, k+n+min(n, chunk))`: draws are a pure function of their index,
//! and the Monte Carlo drivers ask for consecutive batches, so the next batch is already
//! computing while the caller sorts this one ([`GpuOptions::prefetch`]). Memory is per chunk,
//! never per request: an MCS of 10^8 draws needs the caller's output slice and two chunks of GPU
//! buffers; an offset request of n rows uploads `N_UNCERTAIN` f32 per row, one chunk at a time.

mod backend;
mod context;
mod device;

pub use backend::{list_adapters, make_evaluator, WgpuBackends};
pub use context::{devices_opened, GpuContext};

use device::{BindGroup, Buffer, Gpu, Timer};
use gpu_amcs_core::engine::deviation::{self, SpreadPacking};
use gpu_amcs_core::engine::{BackendInfo, EngineError, Evaluator, PickFreeze, Problem};
use gpu_amcs_core::kinematics::N_UNCERTAIN;
use std::collections::VecDeque;
use std::sync::Arc;
use std::time::Instant;

/// WGSL: Philox4x32-10 and the Box–Muller transform.
pub const PHILOX_WGSL: &str = include_str!("../../../shaders/philox.wgsl");
/// WGSL: the per-draw maximum point error kernel (entry points [`ENTRY_POINT`] and
/// [`OFFSETS_ENTRY_POINT`]).
pub const MDH_WGSL: &str = include_str!("../../../shaders/mdh_max_error.wgsl");
/// WGSL: a test kernel exposing Philox blocks and normals (entry point `philox_kat`).
pub const PHILOX_KAT_WGSL: &str = include_str!("../../../shaders/philox_kat.wgsl");

/// Entry point of the evaluator kernel for counter draws.
pub const ENTRY_POINT: &str = "max_point_error";
/// Entry point of the evaluator kernel for explicit offset rows.
pub const OFFSETS_ENTRY_POINT: &str = "max_point_error_offsets";
/// Entry point of the evaluator kernel for pick-freeze rows.
pub const PICK_FREEZE_ENTRY_POINT: &str = "max_point_error_pick_freeze";
/// Workgroup size of the kernel (must match `@workgroup_size` in the shader).
pub const WORKGROUP: usize = 64;
/// Default draws per dispatch.
pub const DEFAULT_CHUNK: usize = 1 << 18;

/// Binding numbers of the evaluator shader's bind group 0 (the WGSL variable in brackets).
pub mod binding {
    /// Run configuration, [`super::ConfigUniform`] (`cfg`).
    pub const CONFIG: u32 = 0;
    /// Chunk description, [`super::ChunkUniform`] (`chunk`).
    pub const CHUNK: u32 = 1;
    /// Mean joint trigonometry, `deviation::joint_trig` (`joint_trig`).
    pub const JOINT_TRIG: u32 = 2;
    /// σ or the Cholesky factor (`spread`).
    pub const SPREAD: u32 = 3;
    /// Free-parameter indices (`free_idx`).
    pub const FREE: u32 = 4;
    /// Per-point constants, `deviation::point_constants` (`pts`).
    pub const POINTS: u32 = 5;
    /// Output: w per parameter vector (`w_out`).
    pub const W: u32 = 6;
    /// Output: e_j per parameter vector and point (`e_out`).
    pub const E: u32 = 7;
    /// Input of the offset path: `N_UNCERTAIN` offsets per row (`offsets_in`).
    pub const OFFSETS: u32 = 8;
    /// Input of the pick-freeze path: one mask of normals per matrix, (lo, hi) words (`masks`).
    pub const MASKS: u32 = 9;
}

/// The evaluator shader: [`PHILOX_WGSL`] followed by [`MDH_WGSL`].
pub fn shader_source() -> String {
    format!("{PHILOX_WGSL}\n{MDH_WGSL}")
}

/// The Philox test shader: [`PHILOX_WGSL`] followed by [`PHILOX_KAT_WGSL`].
pub fn philox_test_source() -> String {
    format!("{PHILOX_WGSL}\n{PHILOX_KAT_WGSL}")
}

/// One adapter on the machine.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct AdapterDescription {
    /// Adapter name.
    pub name: String,
    /// Backend (Vulkan, Metal, Dx12).
    pub backend: String,
    /// wgpu device type (DiscreteGpu, IntegratedGpu, Cpu, …).
    pub device_type: String,
    /// Driver name and info.
    pub driver: String,
    /// Whether it is a software (CPU) implementation such as lavapipe.
    pub is_cpu: bool,
}

/// All Vulkan / Metal / DX12 adapters.
pub fn adapters() -> Vec<AdapterDescription> {
    device::adapters()
        .into_iter()
        .map(|a| AdapterDescription {
            name: a.name,
            backend: a.backend,
            device_type: a.device_type,
            driver: a.driver,
            is_cpu: a.is_cpu,
        })
        .collect()
}

/// Whether a hardware (non-CPU) adapter is present.
pub fn hardware_adapter_present() -> bool {
    device::adapters().iter().any(|a| !a.is_cpu)
}

/// Construction options of [`GpuEvaluator`].
#[derive(Clone, Debug)]
pub struct GpuOptions {
    /// Case-insensitive substring of the adapter name; `None`: the most capable adapter.
    pub adapter: Option<String>,
    /// Refuse software (CPU) adapters when `adapter` is `None`.
    pub hardware_only: bool,
    /// Most draws per dispatch (further bounded by the device limits).
    pub chunk: usize,
    /// Time each dispatch with timestamp queries when the adapter supports them.
    pub timestamps: bool,
    /// After each request without per-point output, start computing the next range of the
    /// same length (at most one chunk), so a following consecutive request finds it ready.
    pub prefetch: bool,
}

impl Default for GpuOptions {
    fn default() -> Self {
        GpuOptions {
            adapter: None,
            hardware_only: false,
            chunk: DEFAULT_CHUNK,
            timestamps: false,
            prefetch: true,
        }
    }
}

/// Where the time of the last [`Evaluator::evaluate`] or [`Evaluator::evaluate_offsets`] call
/// went.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GpuTimings {
    /// Sum of the compute passes' device time from timestamp queries, s (`None`: not
    /// supported or not asked for).
    pub device_s: Option<f64>,
    /// Host time spent recording and submitting work and waiting for it, s.
    pub submit_wait_s: f64,
    /// Host time spent mapping the results and converting them to f64, s.
    pub readback_s: f64,
    /// Dispatches (including a speculative one for the next range).
    pub chunks: usize,
    /// Whether the start of this request had been computed speculatively by the previous one.
    pub prefetch_hits: usize,
}

/// The run configuration uniform (`cfg` in the shader; `tests/gpu.rs` checks that its size
/// equals the WGSL struct's).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ConfigUniform {
    /// Philox key.
    pub key: [u32; 2],
    /// Test points m.
    pub m: u32,
    /// 0: independent spread (σ), 1: correlated (Cholesky factor).
    pub mode: u32,
    /// Free parameters of a correlated spread.
    pub nfree: u32,
    /// Bit b set: Philox block b feeds some free parameter.
    pub block_mask: u32,
    /// Padding to the WGSL struct size.
    pub pad: [u32; 2],
}

/// The per-chunk uniform (`chunk` in the shader).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ChunkUniform {
    /// First draw of the chunk, (lo, hi) words (unused by the offset path; the draw of row 0
    /// of matrix A on the pick-freeze path).
    pub first: [u32; 2],
    /// Parameter vectors in the chunk.
    pub count: u32,
    /// 1: write per-point errors.
    pub want_e: u32,
    /// Pick-freeze path: the draw of row 0 of matrix B, (lo, hi) words.
    pub b_first: [u32; 2],
    /// Pick-freeze path: rows per matrix.
    pub per_matrix: u32,
    /// Pick-freeze path: the request's row computed by the chunk's invocation 0.
    pub row0: u32,
}

/// The (lo, hi) words of a 64-bit draw index or mask.
fn words(x: u64) -> [u32; 2] {
    [x as u32, (x >> 32) as u32]
}

/// The buffers of one problem (see [`GpuEvaluator::set_problem`]).
struct ProblemBuffers {
    config: Buffer,
    joint_trig: Buffer,
    spread: Buffer,
    free: Buffer,
    points: Buffer,
    m: usize,
}

impl ProblemBuffers {
    fn new(gpu: &Gpu, problem: &Problem) -> Self {
        let packing = SpreadPacking::new(problem);
        let m = problem.n_points();
        let cfg = ConfigUniform {
            key: problem.sampler.key(),
            m: m as u32,
            mode: u32::from(packing.correlated),
            nfree: packing.n_free() as u32,
            block_mask: packing.block_mask,
            pad: [0; 2],
        };
        let config = gpu.uniform("config", std::mem::size_of::<ConfigUniform>() as u64);
        gpu.write(&config, bytemuck::bytes_of(&cfg));
        let trig = deviation::joint_trig(problem);
        let pts = deviation::point_constants(problem);
        ProblemBuffers {
            config,
            joint_trig: gpu.storage_init("joint trig", bytemuck::cast_slice(&trig)),
            spread: gpu.storage_init("spread", bytemuck::cast_slice(&packing.spread)),
            free: gpu.storage_init("free", bytemuck::cast_slice(&packing.free)),
            points: gpu.storage_init("points", bytemuck::cast_slice(&pts)),
            m,
        }
    }
}

/// One of the alternating chunk slots: its uniform, outputs, staging and offset input.
struct Slot {
    chunk: Buffer,
    w: Buffer,
    w_stage: Buffer,
    e: Buffer,
    e_stage: Buffer,
    offsets: Buffer,
    bind: BindGroup,
    timer: Option<Timer>,
}

/// The buffers a slot binds besides the problem's.
struct SlotBuffers<'a> {
    chunk: &'a Buffer,
    w: &'a Buffer,
    e: &'a Buffer,
    offsets: &'a Buffer,
    masks: &'a Buffer,
}

/// The bind group of a slot over `problem`'s buffers, every binding by name.
fn bind_slot(ctx: &GpuContext, problem: &ProblemBuffers, s: SlotBuffers) -> BindGroup {
    ctx.gpu.bind_group(
        &ctx.layout,
        &[
            (binding::CONFIG, &problem.config),
            (binding::CHUNK, s.chunk),
            (binding::JOINT_TRIG, &problem.joint_trig),
            (binding::SPREAD, &problem.spread),
            (binding::FREE, &problem.free),
            (binding::POINTS, &problem.points),
            (binding::W, s.w),
            (binding::E, s.e),
            (binding::OFFSETS, s.offsets),
            (binding::MASKS, s.masks),
        ],
    )
}

impl Slot {
    /// A slot of `chunk` outputs; per-point and offset buffers are placeholders until needed.
    fn new(
        ctx: &GpuContext,
        problem: &ProblemBuffers,
        masks: &Buffer,
        chunk: usize,
        timer: bool,
    ) -> Self {
        let gpu = &ctx.gpu;
        let w_bytes = 4 * chunk as u64;
        let chunk = gpu.uniform("chunk", std::mem::size_of::<ChunkUniform>() as u64);
        let w = gpu.storage("w", w_bytes);
        let e = gpu.storage("e (unused)", 4);
        let offsets = gpu.storage("offsets (unused)", 4);
        let bind = bind_slot(
            ctx,
            problem,
            SlotBuffers {
                chunk: &chunk,
                w: &w,
                e: &e,
                offsets: &offsets,
                masks,
            },
        );
        Slot {
            chunk,
            w,
            w_stage: gpu.staging("w staging", w_bytes),
            e,
            e_stage: gpu.staging("e staging (unused)", 4),
            offsets,
            bind,
            timer: if timer { gpu.timer() } else { None },
        }
    }

    /// Rebuilds the bind group after a buffer changed.
    fn rebind(&mut self, ctx: &GpuContext, problem: &ProblemBuffers, masks: &Buffer) {
        self.bind = bind_slot(
            ctx,
            problem,
            SlotBuffers {
                chunk: &self.chunk,
                w: &self.w,
                e: &self.e,
                offsets: &self.offsets,
                masks,
            },
        );
    }
}

/// Where the parameter offsets of a request come from.
#[derive(Clone, Copy)]
enum Rows<'a> {
    /// Counter draws from this index on.
    Draws(u64),
    /// An offset matrix, `N_UNCERTAIN` per row, from its first row on.
    Offsets(&'a [f64]),
    /// The rows of a pick-freeze request from this row on (its masks already uploaded).
    PickFreeze(PickFreeze<'a>, usize),
}

impl<'a> Rows<'a> {
    /// The rows from `n` on.
    fn skip(self, n: usize) -> Rows<'a> {
        match self {
            Rows::Draws(k) => Rows::Draws(k.wrapping_add(n as u64)),
            Rows::Offsets(o) => Rows::Offsets(&o[(n * N_UNCERTAIN).min(o.len())..]),
            Rows::PickFreeze(pf, row) => Rows::PickFreeze(pf, row + n),
        }
    }
}

struct InFlight {
    slot: usize,
    start: usize,
    count: usize,
    index: device::SubmissionIndex,
    pending_w: device::PendingMap,
    pending_e: Option<device::PendingMap>,
    pending_t: Option<device::PendingMap>,
}

/// The wgpu evaluator (see the module docs).
pub struct GpuEvaluator {
    ctx: Arc<GpuContext>,
    problem: ProblemBuffers,
    slots: Vec<Slot>,
    /// Masks of the last pick-freeze request (shared by both slots), and its capacity.
    masks: Buffer,
    masks_capacity: usize,
    chunk: usize,
    chunk_e: usize,
    chunk_o: usize,
    e_ready: bool,
    offsets_ready: bool,
    staging_f32: Vec<f32>,
    timings: GpuTimings,
    broken: Option<String>,
    prefetch_enabled: bool,
    prefetch: Option<(u64, InFlight)>,
}

fn gpu_err(e: impl std::fmt::Display) -> EngineError {
    EngineError::Gpu(e.to_string())
}

impl GpuEvaluator {
    /// An evaluator for `problem` on the adapter chosen by `opts`, sharing the process's device
    /// on that adapter ([`GpuContext::shared`]; opened, and the shader compiled, on first use).
    pub fn new(problem: Problem, opts: &GpuOptions) -> Result<Self, EngineError> {
        let ctx = GpuContext::shared(opts.adapter.as_deref(), opts.hardware_only)?;
        Self::with_context(ctx, &problem, opts)
    }

    /// An evaluator for `problem` on an open context (its adapter-selection options are
    /// ignored): uploads the problem's constants and allocates the chunk slots.
    pub fn with_context(
        ctx: Arc<GpuContext>,
        problem: &Problem,
        opts: &GpuOptions,
    ) -> Result<Self, EngineError> {
        let gpu = &ctx.gpu;
        let chunk = opts.chunk.max(1).min(ctx.max_chunk()).max(1);
        let by_bytes = ctx.max_binding_words();
        let chunk_o = chunk.min((by_bytes / N_UNCERTAIN).max(1));
        let problem_bufs = ProblemBuffers::new(gpu, problem);
        let timestamps = opts.timestamps && gpu.timestamps;
        let masks = gpu.storage("masks (unused)", 8);
        let slots: Vec<Slot> = (0..2)
            .map(|_| Slot::new(&ctx, &problem_bufs, &masks, chunk, timestamps))
            .collect();
        if let Some(e) = gpu.take_error() {
            return Err(EngineError::Gpu(e));
        }
        let chunk_e = Self::chunk_e_for(&ctx, chunk, problem_bufs.m);
        Ok(GpuEvaluator {
            ctx,
            problem: problem_bufs,
            slots,
            masks,
            masks_capacity: 0,
            chunk,
            chunk_e,
            chunk_o,
            e_ready: false,
            offsets_ready: false,
            staging_f32: Vec::new(),
            timings: GpuTimings::default(),
            broken: None,
            prefetch_enabled: opts.prefetch,
            prefetch: None,
        })
    }

    /// Draws per dispatch with per-point output for `m` points.
    fn chunk_e_for(ctx: &GpuContext, chunk: usize, m: usize) -> usize {
        chunk.min((ctx.max_binding_words() / m.max(1)).max(1))
    }

    /// Replaces the problem (model, points, reference, seed): new per-problem buffers on the
    /// same device, pipelines and chunk slots. A speculative chunk of the old problem is
    /// dropped.
    pub fn set_problem(&mut self, problem: &Problem) -> Result<(), EngineError> {
        self.check_usable()?;
        if let Some((_, f)) = self.prefetch.take() {
            self.guard(|s| s.discard(f))?;
        }
        let m_old = self.problem.m;
        self.problem = ProblemBuffers::new(&self.ctx.gpu, problem);
        if self.problem.m != m_old {
            self.chunk_e = Self::chunk_e_for(&self.ctx, self.chunk, self.problem.m);
            if self.e_ready {
                self.e_ready = false;
                for slot in &mut self.slots {
                    slot.e = self.ctx.gpu.storage("e (unused)", 4);
                    slot.e_stage = self.ctx.gpu.staging("e staging (unused)", 4);
                }
            }
        }
        for slot in &mut self.slots {
            slot.rebind(&self.ctx, &self.problem, &self.masks);
        }
        match self.ctx.gpu.take_error() {
            Some(e) => self.guard(|_| Err(EngineError::Gpu(e))),
            None => Ok(()),
        }
    }

    /// The shared device context.
    pub fn context(&self) -> &Arc<GpuContext> {
        &self.ctx
    }

    /// Parameter vectors per dispatch (counter draws without / with per-point output).
    pub fn chunk_sizes(&self) -> (usize, usize) {
        (self.chunk, self.chunk_e)
    }

    /// Where the time of the last `evaluate` or `evaluate_offsets` call went.
    pub fn last_timings(&self) -> GpuTimings {
        self.timings
    }

    /// Whether device timestamps are being recorded.
    pub fn has_timestamps(&self) -> bool {
        self.slots.iter().any(|s| s.timer.is_some())
    }

    fn ensure_e_buffers(&mut self) {
        if self.e_ready {
            return;
        }
        let bytes = 4 * (self.chunk_e * self.problem.m) as u64;
        for slot in &mut self.slots {
            slot.e = self.ctx.gpu.storage("e", bytes);
            slot.e_stage = self.ctx.gpu.staging("e staging", bytes);
            slot.rebind(&self.ctx, &self.problem, &self.masks);
        }
        self.e_ready = true;
    }

    fn ensure_offset_buffers(&mut self) {
        if self.offsets_ready {
            return;
        }
        let bytes = 4 * (self.chunk_o * N_UNCERTAIN) as u64;
        for slot in &mut self.slots {
            slot.offsets = self.ctx.gpu.storage("offsets", bytes);
            slot.rebind(&self.ctx, &self.problem, &self.masks);
        }
        self.offsets_ready = true;
    }

    /// Uploads the masks of a pick-freeze request (growing the buffer, and rebinding the
    /// slots, when it is too small). Every earlier dispatch has finished when a request starts,
    /// so the one buffer can be overwritten.
    fn upload_masks(&mut self, masks: &[u64]) {
        if masks.len() > self.masks_capacity {
            self.masks = self.ctx.gpu.storage("masks", 8 * masks.len() as u64);
            self.masks_capacity = masks.len();
            for slot in &mut self.slots {
                slot.rebind(&self.ctx, &self.problem, &self.masks);
            }
        }
        let w: Vec<u32> = masks.iter().flat_map(|&m| words(m)).collect();
        self.ctx.gpu.write(&self.masks, bytemuck::cast_slice(&w));
    }

    /// Copies `n` mapped f32 results of `stage` into `out` as f64.
    fn read_f32(
        gpu: &Gpu,
        stage: &Buffer,
        pending: device::PendingMap,
        out: &mut [f64],
    ) -> Result<(), EngineError> {
        let n = out.len();
        let mapped = gpu.mapped(stage, 4 * n as u64, pending).map_err(gpu_err)?;
        let vals: &[f32] = bytemuck::try_cast_slice(&mapped.bytes()[..4 * n])
            .map_err(|e| gpu_err(format!("result buffer: {e:?}")))?;
        for (o, v) in out.iter_mut().zip(vals) {
            *o = f64::from(*v);
        }
        Ok(())
    }

    fn finish(
        &mut self,
        f: InFlight,
        w: &mut [f64],
        e: &mut Option<&mut [f64]>,
    ) -> Result<(), EngineError> {
        let gpu = &self.ctx.gpu;
        let m = self.problem.m;
        let t0 = Instant::now();
        gpu.wait(f.index).map_err(gpu_err)?;
        let t1 = Instant::now();
        let slot = &self.slots[f.slot];
        Self::read_f32(
            gpu,
            &slot.w_stage,
            f.pending_w,
            &mut w[f.start..f.start + f.count],
        )?;
        if let (Some(pe), Some(e)) = (f.pending_e, e.as_deref_mut()) {
            let rows = &mut e[f.start * m..(f.start + f.count) * m];
            Self::read_f32(gpu, &slot.e_stage, pe, rows)?;
        }
        if let (Some(t), Some(pt)) = (&slot.timer, f.pending_t) {
            let d = gpu.read_timer(t, pt).map_err(gpu_err)?;
            *self.timings.device_s.get_or_insert(0.0) += d;
        }
        self.timings.submit_wait_s += (t1 - t0).as_secs_f64();
        self.timings.readback_s += t1.elapsed().as_secs_f64();
        Ok(())
    }

    /// Records and submits the first `count` rows of `rows` in slot `slot_i`; results go to
    /// offset `start` of the caller's output.
    fn submit(
        &mut self,
        slot_i: usize,
        rows: Rows,
        start: usize,
        count: usize,
        want_e: bool,
    ) -> InFlight {
        let t0 = Instant::now();
        let gpu = &self.ctx.gpu;
        let slot = &self.slots[slot_i];
        let mut cu = ChunkUniform {
            first: [0, 0],
            count: count as u32,
            want_e: u32::from(want_e),
            b_first: [0, 0],
            per_matrix: 0,
            row0: 0,
        };
        let pipeline = match rows {
            Rows::Draws(k0) => {
                cu.first = words(k0);
                &self.ctx.draws
            }
            Rows::Offsets(o) => {
                self.staging_f32.clear();
                self.staging_f32
                    .extend(o[..count * N_UNCERTAIN].iter().map(|&v| v as f32));
                gpu.write(&slot.offsets, bytemuck::cast_slice(&self.staging_f32));
                &self.ctx.offsets
            }
            Rows::PickFreeze(pf, row) => {
                // `run` checked that rows and the matrix length fit in u32.
                cu.first = words(pf.first);
                cu.b_first = words(pf.b_first);
                cu.per_matrix = pf.count as u32;
                cu.row0 = row as u32;
                &self.ctx.pick_freeze
            }
        };
        gpu.write(&slot.chunk, bytemuck::bytes_of(&cu));
        let w_bytes = 4 * count as u64;
        let e_bytes = if want_e {
            4 * (count * self.problem.m) as u64
        } else {
            0
        };
        let groups = count.div_ceil(WORKGROUP) as u32;
        let index = gpu.dispatch(
            pipeline,
            &slot.bind,
            groups,
            &[
                (&slot.w, &slot.w_stage, w_bytes),
                (&slot.e, &slot.e_stage, e_bytes),
            ],
            slot.timer.as_ref(),
        );
        let pending_w = gpu.map_read(&slot.w_stage, w_bytes);
        let pending_e = want_e.then(|| gpu.map_read(&slot.e_stage, e_bytes));
        let pending_t = slot.timer.as_ref().map(|t| gpu.map_timer(t));
        self.timings.submit_wait_s += t0.elapsed().as_secs_f64();
        self.timings.chunks += 1;
        InFlight {
            slot: slot_i,
            start,
            count,
            index,
            pending_w,
            pending_e,
            pending_t,
        }
    }

    /// Waits for a speculative chunk nobody asked for and releases its mappings.
    fn discard(&mut self, f: InFlight) -> Result<(), EngineError> {
        let gpu = &self.ctx.gpu;
        gpu.wait(f.index).map_err(gpu_err)?;
        let slot = &self.slots[f.slot];
        drop(
            gpu.mapped(&slot.w_stage, 4 * f.count as u64, f.pending_w)
                .map_err(gpu_err)?,
        );
        if let (Some(t), Some(pt)) = (&slot.timer, f.pending_t) {
            gpu.read_timer(t, pt).map_err(gpu_err)?;
        }
        Ok(())
    }

    fn run(
        &mut self,
        rows: Rows,
        w: &mut [f64],
        mut e: Option<&mut [f64]>,
    ) -> Result<(), EngineError> {
        let want_e = e.is_some();
        if want_e {
            self.ensure_e_buffers();
        }
        let mut c = if want_e { self.chunk_e } else { self.chunk };
        match rows {
            Rows::Offsets(_) => {
                self.ensure_offset_buffers();
                c = c.min(self.chunk_o);
            }
            Rows::PickFreeze(pf, _) => {
                if u32::try_from(pf.rows()).is_err() {
                    return Err(EngineError::PickFreezeRequest(format!(
                        "{} rows in one request; the GPU path takes at most 2^32 − 1",
                        pf.rows()
                    )));
                }
                self.upload_masks(pf.masks);
            }
            Rows::Draws(_) => {}
        }
        let n = w.len();
        let nslots = self.slots.len();
        let mut inflight: VecDeque<InFlight> = VecDeque::with_capacity(nslots);
        let mut start = 0usize;
        let mut h = 0usize;
        // A speculative chunk from the previous call: used if it is the start of this request.
        if let Some((k, f)) = self.prefetch.take() {
            if matches!(rows, Rows::Draws(first) if first == k) && !want_e && f.count <= n {
                start = f.count;
                h = f.slot + 1;
                self.timings.prefetch_hits += 1;
                inflight.push_back(f);
            } else {
                self.discard(f)?;
            }
        }
        while start < n {
            if inflight.len() == nslots {
                if let Some(f) = inflight.pop_front() {
                    self.finish(f, w, &mut e)?;
                }
            }
            let count = c.min(n - start);
            let f = self.submit(h % nslots, rows.skip(start), start, count, want_e);
            inflight.push_back(f);
            start += count;
            h += 1;
        }
        while let Some(f) = inflight.pop_front() {
            self.finish(f, w, &mut e)?;
        }
        // Draws are a pure function of their index: compute the likely next range (the Monte
        // Carlo drivers ask for consecutive batches) while the caller works on this one.
        if let Rows::Draws(first) = rows {
            if self.prefetch_enabled && !want_e && n > 0 {
                let next = first.wrapping_add(n as u64);
                let count = n.min(self.chunk);
                let f = self.submit(h % nslots, Rows::Draws(next), 0, count, false);
                self.prefetch = Some((next, f));
            }
        }
        Ok(())
    }

    /// Refuses work after a device error.
    fn check_usable(&self) -> Result<(), EngineError> {
        match &self.broken {
            Some(b) => Err(EngineError::Gpu(format!(
                "device unusable after an earlier error: {b}"
            ))),
            None => Ok(()),
        }
    }

    /// Runs `f`; a GPU error marks this evaluator unusable and its context failed (so the next
    /// evaluator on the adapter opens a fresh device).
    fn guard(
        &mut self,
        f: impl FnOnce(&mut Self) -> Result<(), EngineError>,
    ) -> Result<(), EngineError> {
        let r = f(self);
        if let Err(EngineError::Gpu(msg)) = &r {
            self.broken = Some(msg.clone());
            self.ctx.mark_failed();
        }
        r
    }

    /// A request of either kind: refuses a broken evaluator, resets the timings, runs.
    fn request(
        &mut self,
        rows: Rows,
        w: &mut [f64],
        per_point: Option<&mut [f64]>,
    ) -> Result<(), EngineError> {
        self.check_usable()?;
        self.timings = GpuTimings::default();
        self.guard(|s| s.run(rows, w, per_point))
    }
}

impl Evaluator for GpuEvaluator {
    fn info(&self) -> BackendInfo {
        BackendInfo {
            backend: "gpu".into(),
            adapter: self.ctx.gpu.name.clone(),
            driver: self.ctx.gpu.driver.clone(),
        }
    }

    fn n_points(&self) -> usize {
        self.problem.m
    }

    fn eval_draws(
        &mut self,
        first: u64,
        w: &mut [f64],
        per_point: Option<&mut [f64]>,
    ) -> Result<(), EngineError> {
        self.request(Rows::Draws(first), w, per_point)
    }

    fn eval_offsets(
        &mut self,
        offsets: &[f64],
        w: &mut [f64],
        per_point: Option<&mut [f64]>,
    ) -> Result<(), EngineError> {
        self.request(Rows::Offsets(offsets), w, per_point)
    }

    fn eval_pick_freeze(&mut self, request: &PickFreeze, w: &mut [f64]) -> Result<(), EngineError> {
        self.request(Rows::PickFreeze(*request, 0), w, None)
    }
}

/// The 4 Philox words of one block and its 4 normals, as the shader computes them.
pub type PhiloxBlock = ([u32; 4], [f32; 4]);

/// Runs the Philox test kernel on the adapter chosen by `adapter` (substring, or the most
/// capable; the process's shared device): for each `(counter, key)` the 4 Philox words and the
/// 4 normals of that block. For tests of the shader against the Rust generator.
pub fn philox_on_gpu(
    adapter: Option<&str>,
    cases: &[([u32; 4], [u32; 2])],
) -> Result<Vec<PhiloxBlock>, EngineError> {
    let ctx = GpuContext::shared(adapter, false)?;
    let gpu = &ctx.gpu;
    let (pipeline, layout) = gpu
        .pipeline(&philox_test_source(), "philox_kat")
        .map_err(gpu_err)?;
    let input: Vec<u32> = cases
        .iter()
        .flat_map(|(c, k)| [c[0], c[1], c[2], c[3], k[0], k[1]])
        .collect();
    let in_buf = gpu.storage_init("kat in", bytemuck::cast_slice(&input));
    let bytes = 32 * cases.len() as u64;
    let out_buf = gpu.storage("kat out", bytes);
    let stage = gpu.staging("kat staging", bytes);
    let bind = gpu.bind_group(&layout, &[(0, &in_buf), (1, &out_buf)]);
    let index = gpu.dispatch(
        &pipeline,
        &bind,
        cases.len() as u32,
        &[(&out_buf, &stage, bytes)],
        None,
    );
    let pending = gpu.map_read(&stage, bytes);
    gpu.wait(index).map_err(gpu_err)?;
    let mapped = gpu.mapped(&stage, bytes, pending).map_err(gpu_err)?;
    let words: &[u32] = bytemuck::try_cast_slice(mapped.bytes())
        .map_err(|e| gpu_err(format!("result buffer: {e:?}")))?;
    Ok(words
        .chunks_exact(8)
        .map(|c| {
            (
                [c[0], c[1], c[2], c[3]],
                [4, 5, 6, 7].map(|i| f32::from_bits(c[i])),
            )
        })
        .collect())
}
