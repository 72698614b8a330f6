//! The GPU evaluator: the draws of [`crate::engine::Evaluator`] through a WGSL compute shader
//! (`shaders/philox.wgsl` + `shaders/mdh_max_error.wgsl`) on any Vulkan, Metal or DX12 adapter
//! via wgpu, one invocation per draw (METHOD.md §3: `w = max_j e_j`, paper eqs. 12 and 17).
//!
//! The shader draws exactly the normals of the CPU sampler (Philox4x32-10 with counter
//! `[draw lo, draw hi, block, 0]`, the Box–Muller layout of [`crate::sampling::box_muller`],
//! independent `δ_i = σ_i z_i` or correlated `δ = L z` on the free parameters), so draw `k` is
//! the same parameter vector on both backends.
//!
//! # Deviation formulation (why f32 is enough)
//!
//! Positions are ~1000 mm and errors ~0.1 mm: subtracting two f32 positions would lose about
//! 1e-4 mm to cancellation. Instead the shader propagates the *deviation* from the chain of the
//! mean parameters. With `u_i = Rx(α_i)Ry(β_i)p_{i+1} + (a_i, 0, d_i)` and
//! `p_i = Rz(θ_i + q_i) u_i` (tool → base), and `p0`, `u0` the mean-parameter intermediate points
//! of each test point (computed here in f64 once, uploaded as f32):
//!
//! ```text
//! Δ_7  = 0
//! Δu_i = Rx(α')Ry(β') Δ_{i+1} + (Rx(α')Ry(β') − Rx(α)Ry(β)) p0_{i+1} + (δa, 0, δd)
//! Δ_i  = Rz(φ') Δu_i + (Rz(φ') − Rz(φ)) u0_i,          φ = θ + q, φ' = φ + δθ
//! e_j  = |Δ_1 + o_j|,  o_j = P(mean, q_j) − P_ref,j (f64; 0 for the calibrated reference)
//! ```
//!
//! Rotation differences use `cos(x+δ) − cos x = −2 sin(δ/2) sin(x+δ/2)` and
//! `sin(x+δ) − sin x = 2 sin(δ/2) cos(x+δ/2)` with `sin/cos(δ/2)` from a series and
//! `sin/cos(x)` of the mean precomputed (per point for `φ`), so the GPU only handles small
//! quantities. The ~1000 mm constants enter only multiplied by differences of order δ.
//!
//! # Error budget (f32 unit roundoff `u = 2^-24 ≈ 6e-8`)
//!
//! * normals: series truncation < 2e-9; f32 rounding gives `|Δz| ≲ 1e-6·(1+|z|)`, so the
//!   offsets δ have relative error ≲ 1e-6 and `e_j` a relative error of the same order;
//! * constants: `p0`, `u0` rounded to f32 (≤ u·1000 mm ≈ 6e-5 mm) times rotation differences
//!   (≲ 1e-3) → ≲ 6e-8 mm per joint; `cos φ`, `sin φ` rounded (u) times `|Δu|` (≲ 1 mm) →
//!   ≲ 6e-8 mm per joint;
//! * arithmetic: ~25 f32 operations per joint on quantities of size `|Δ|` → ≲ 1e-6·|Δ|;
//! * offsets `o_j` rounded to f32: ≤ u·|o_j| (6e-7 mm for a 10 mm nominal-reference offset).
//!
//! Together `|e_gpu − e_cpu| ≲ 2e-6·e_j + 1e-6 mm + u·|o_j|`, i.e. well under 1e-5 mm for the
//! TX60 at the paper's spreads (e ≈ 0.1–1 mm). Measured on lavapipe (`tests/gpu.rs`, 50 test
//! points, 4–6·10^4 draws): max `|w_gpu − w_cpu|` = 9.6e-8 mm (independent), 6.9e-8 mm
//! (correlated), 2.0e-7 mm (nominal reference, `|o_j|` ≈ 1.3 mm); moments agree to ≤ 2e-8
//! relative; the normals to 1.1e-7·(1+|z|). The tests assert 1e-5 mm per sample.
//!
//! # Batching
//!
//! Device, pipeline and every buffer are created once. A request is cut into chunks of at most
//! [`GpuOptions::chunk`] draws (also bounded by the device's workgroup-count, binding-size and
//! buffer-size limits); two chunk slots alternate so the readback and f32→f64 conversion of
//! chunk h overlaps the computation of chunk h+1. After a request for draws `[k, k+n)` (without
//! per-point output) the evaluator speculatively submits `[k+n, k+n+min(n, chunk))`: draws are a
//! pure function of their index, and the Monte Carlo drivers ask for consecutive batches, so
//! the next batch is already computing while the caller sorts this one
//! ([`GpuOptions::prefetch`]). Memory is per chunk, never per request: an MCS of 10^8 draws
//! needs the caller's output slice and two chunks of GPU buffers.

mod device;

use super::{check_buffers, BackendInfo, EngineError, Evaluator, Problem};
use crate::kinematics::{JOINTS, N_PARAMS};
use device::{BindGroup, BindGroupLayout, Buffer, ComputePipeline, Gpu, Timer};
use std::collections::VecDeque;
use std::time::Instant;

/// WGSL: Philox4x32-10 and the Box–Muller transform.
pub const PHILOX_WGSL: &str = include_str!("../../shaders/philox.wgsl");
/// WGSL: the per-draw maximum point error kernel (entry point `max_point_error`).
pub const MDH_WGSL: &str = include_str!("../../shaders/mdh_max_error.wgsl");
/// WGSL: a test kernel exposing Philox blocks and normals (entry point `philox_kat`).
pub const PHILOX_KAT_WGSL: &str = include_str!("../../shaders/philox_kat.wgsl");

/// Entry point of the evaluator kernel.
pub const ENTRY_POINT: &str = "max_point_error";
/// Workgroup size of the kernel (must match `@workgroup_size` in the shader).
pub const WORKGROUP: usize = 64;
/// Default draws per dispatch.
pub const DEFAULT_CHUNK: usize = 1 << 18;
/// Vec4 words per test point in the point buffer.
const WORDS_PER_POINT: usize = 13;

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

/// Picks an adapter: by case-insensitive substring of its name if `filter` is given, else the
/// most capable (discrete, integrated, virtual, other, then CPU); `hardware_only` rejects
/// software (CPU) adapters when no filter is given.
fn pick_adapter(filter: Option<&str>, hardware_only: bool) -> Result<device::AdapterEntry, String> {
    let mut list = device::adapters();
    if list.is_empty() {
        return Err(
            "no Vulkan, Metal or DX12 adapter found (install a GPU driver, or Mesa's \
                    lavapipe for a software Vulkan device)"
                .into(),
        );
    }
    if let Some(f) = filter {
        let names: Vec<String> = list.iter().map(|a| a.name.clone()).collect();
        let needle = f.to_lowercase();
        return match list
            .into_iter()
            .find(|a| a.name.to_lowercase().contains(&needle))
        {
            Some(a) => Ok(a),
            None => Err(format!(
                "no adapter name contains '{f}'; available: {}",
                names.join(", ")
            )),
        };
    }
    list.sort_by_key(|a| a.rank);
    let best = list.remove(0);
    if hardware_only && best.is_cpu {
        return Err(format!(
            "only a software adapter is present ({})",
            best.name
        ));
    }
    Ok(best)
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

/// Where the time of the last [`Evaluator::evaluate`] call went.
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

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct ConfigU {
    key: [u32; 2],
    m: u32,
    mode: u32,
    nfree: u32,
    block_mask: u32,
    pad: [u32; 2],
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct ChunkU {
    first: [u32; 2],
    count: u32,
    want_e: u32,
}

struct Slot {
    chunk: Buffer,
    w: Buffer,
    w_stage: Buffer,
    e: Buffer,
    e_stage: Buffer,
    bind: BindGroup,
    timer: Option<Timer>,
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
    gpu: Gpu,
    pipeline: ComputePipeline,
    layout: BindGroupLayout,
    statics: [Buffer; 5],
    slots: Vec<Slot>,
    m: usize,
    chunk: usize,
    chunk_e: usize,
    e_ready: bool,
    timings: GpuTimings,
    broken: Option<String>,
    prefetch_enabled: bool,
    prefetch: Option<(u64, InFlight)>,
}

/// Per-point constants of the mean-parameter chain (f64, then f32): see the module docs.
fn point_constants(problem: &Problem) -> Vec<[f32; 4]> {
    let mean = &problem.sampler.mean;
    let mut out = Vec::with_capacity(problem.points.len() * WORDS_PER_POINT);
    for (q, r) in problem.points.iter().zip(&problem.reference) {
        let mut words = [[0f32; 4]; WORDS_PER_POINT];
        let mut p = problem.model.tool;
        for i in (0..JOINTS).rev() {
            let [th, d, a, al, be] = [
                mean[5 * i],
                mean[5 * i + 1],
                mean[5 * i + 2],
                mean[5 * i + 3],
                mean[5 * i + 4],
            ];
            let (sb, cb) = be.sin_cos();
            let (sa, ca) = al.sin_cos();
            let x1 = cb * p[0] + sb * p[2];
            let z1 = -sb * p[0] + cb * p[2];
            let u0 = [x1 + a, ca * p[1] - sa * z1, sa * p[1] + ca * z1 + d];
            let (sp, cp) = (th + q[i]).sin_cos();
            words[2 * i] = [u0[0] as f32, u0[1] as f32, u0[2] as f32, cp as f32];
            words[2 * i + 1] = [p[0] as f32, p[1] as f32, p[2] as f32, sp as f32];
            p = [cp * u0[0] - sp * u0[1], sp * u0[0] + cp * u0[1], u0[2]];
        }
        words[12] = [
            (p[0] - r[0]) as f32,
            (p[1] - r[1]) as f32,
            (p[2] - r[2]) as f32,
            0.0,
        ];
        out.extend_from_slice(&words);
    }
    out
}

fn gpu_err(e: impl std::fmt::Display) -> EngineError {
    EngineError::Gpu(e.to_string())
}

impl GpuEvaluator {
    /// Opens the adapter chosen by `opts`, compiles the shader and uploads the problem's
    /// constants.
    pub fn new(problem: Problem, opts: &GpuOptions) -> Result<Self, EngineError> {
        let entry = pick_adapter(opts.adapter.as_deref(), opts.hardware_only).map_err(gpu_err)?;
        let gpu = Gpu::open(entry, opts.timestamps).map_err(gpu_err)?;
        let (pipeline, layout) = gpu
            .pipeline(&shader_source(), ENTRY_POINT)
            .map_err(gpu_err)?;
        let m = problem.n_points();

        // Chunk sizes within the device limits.
        let by_groups = (gpu.max_workgroups as usize).saturating_mul(WORKGROUP);
        let by_bytes = (gpu.max_binding.min(gpu.max_buffer) / 4) as usize;
        let chunk = opts.chunk.max(1).min(by_groups).min(by_bytes).max(1);
        let chunk_e = chunk.min((by_bytes / m.max(1)).max(1));

        // Static buffers.
        let sampler = &problem.sampler;
        let mut block_mask = 0u32;
        let (mode, nfree, spread, free): (u32, u32, Vec<f32>, Vec<u32>) =
            match (sampler.sigmas(), sampler.cholesky()) {
                (Some(s), _) => {
                    for (i, v) in s.iter().enumerate() {
                        if *v != 0.0 {
                            block_mask |= 1 << (i / 4);
                        }
                    }
                    (0, 0, s.iter().map(|v| *v as f32).collect(), vec![0])
                }
                (None, Some((free, l))) => {
                    for &i in free {
                        block_mask |= 1 << (i / 4);
                    }
                    (
                        1,
                        free.len() as u32,
                        l.iter().map(|v| *v as f32).collect(),
                        free.iter().map(|&i| i as u32).collect(),
                    )
                }
                (None, None) => (0, 0, vec![0.0; N_PARAMS], vec![0]),
            };
        let cfg = ConfigU {
            key: sampler.key(),
            m: m as u32,
            mode,
            nfree,
            block_mask,
            pad: [0; 2],
        };
        let mean = &sampler.mean;
        let trig: Vec<f32> = (0..JOINTS)
            .flat_map(|j| {
                let (sa, ca) = mean[5 * j + 3].sin_cos();
                let (sb, cb) = mean[5 * j + 4].sin_cos();
                [ca as f32, sa as f32, cb as f32, sb as f32]
            })
            .collect();
        let cfg_buf = gpu.uniform("config", std::mem::size_of::<ConfigU>() as u64);
        gpu.write(&cfg_buf, bytemuck::bytes_of(&cfg));
        let trig_buf = gpu.storage_init("joint trig", bytemuck::cast_slice(&trig));
        let spread_buf = gpu.storage_init("spread", bytemuck::cast_slice(&spread));
        let free_buf = gpu.storage_init("free", bytemuck::cast_slice(&free));
        let pts = point_constants(&problem);
        let pts_buf = gpu.storage_init("points", bytemuck::cast_slice(&pts));
        let statics = [cfg_buf, trig_buf, spread_buf, free_buf, pts_buf];

        let mut slots = Vec::with_capacity(2);
        for _ in 0..2 {
            let w_bytes = 4 * chunk as u64;
            let chunk_buf = gpu.uniform("chunk", std::mem::size_of::<ChunkU>() as u64);
            let w = gpu.storage("w", w_bytes);
            let w_stage = gpu.staging("w staging", w_bytes);
            let e = gpu.storage("e (unused)", 4);
            let e_stage = gpu.staging("e staging (unused)", 4);
            let bind = Self::bind(&gpu, &layout, &statics, &chunk_buf, &w, &e);
            slots.push(Slot {
                chunk: chunk_buf,
                w,
                w_stage,
                e,
                e_stage,
                bind,
                timer: gpu.timer(),
            });
        }
        if let Some(e) = gpu.take_error() {
            return Err(EngineError::Gpu(e));
        }
        Ok(GpuEvaluator {
            gpu,
            pipeline,
            layout,
            statics,
            slots,
            m,
            chunk,
            chunk_e,
            e_ready: false,
            timings: GpuTimings::default(),
            broken: None,
            prefetch_enabled: opts.prefetch,
            prefetch: None,
        })
    }

    fn bind(
        gpu: &Gpu,
        layout: &BindGroupLayout,
        s: &[Buffer; 5],
        chunk: &Buffer,
        w: &Buffer,
        e: &Buffer,
    ) -> BindGroup {
        gpu.bind_group(layout, &[&s[0], chunk, &s[1], &s[2], &s[3], &s[4], w, e])
    }

    /// Draws per dispatch (without / with per-point output).
    pub fn chunk_sizes(&self) -> (usize, usize) {
        (self.chunk, self.chunk_e)
    }

    /// Where the time of the last `evaluate` call went.
    pub fn last_timings(&self) -> GpuTimings {
        self.timings
    }

    /// Whether device timestamps are being recorded.
    pub fn has_timestamps(&self) -> bool {
        self.gpu.timestamps
    }

    fn ensure_e_buffers(&mut self) {
        if self.e_ready {
            return;
        }
        let bytes = 4 * (self.chunk_e * self.m) as u64;
        for slot in &mut self.slots {
            slot.e = self.gpu.storage("e", bytes);
            slot.e_stage = self.gpu.staging("e staging", bytes);
            slot.bind = Self::bind(
                &self.gpu,
                &self.layout,
                &self.statics,
                &slot.chunk,
                &slot.w,
                &slot.e,
            );
        }
        self.e_ready = true;
    }

    fn finish(
        &mut self,
        f: InFlight,
        w: &mut [f64],
        e: &mut Option<&mut [f64]>,
    ) -> Result<(), EngineError> {
        let t0 = Instant::now();
        self.gpu.wait(f.index).map_err(gpu_err)?;
        let t1 = Instant::now();
        let slot = &self.slots[f.slot];
        {
            let mapped = self
                .gpu
                .mapped(&slot.w_stage, 4 * f.count as u64, f.pending_w)
                .map_err(gpu_err)?;
            let vals: &[f32] = bytemuck::try_cast_slice(&mapped.bytes()[..4 * f.count])
                .map_err(|e| gpu_err(format!("result buffer: {e:?}")))?;
            for (o, v) in w[f.start..f.start + f.count].iter_mut().zip(vals) {
                *o = f64::from(*v);
            }
        }
        if let (Some(pe), Some(e)) = (f.pending_e, e.as_deref_mut()) {
            let n = f.count * self.m;
            let mapped = self
                .gpu
                .mapped(&slot.e_stage, 4 * n as u64, pe)
                .map_err(gpu_err)?;
            let vals: &[f32] = bytemuck::try_cast_slice(&mapped.bytes()[..4 * n])
                .map_err(|e| gpu_err(format!("result buffer: {e:?}")))?;
            let off = f.start * self.m;
            for (o, v) in e[off..off + n].iter_mut().zip(vals) {
                *o = f64::from(*v);
            }
        }
        if let (Some(t), Some(pt)) = (&slot.timer, f.pending_t) {
            let d = self.gpu.read_timer(t, pt).map_err(gpu_err)?;
            *self.timings.device_s.get_or_insert(0.0) += d;
        }
        self.timings.submit_wait_s += (t1 - t0).as_secs_f64();
        self.timings.readback_s += t1.elapsed().as_secs_f64();
        Ok(())
    }

    /// Records and submits draws `[k0, k0 + count)` in slot `slot_i`; results go to offset
    /// `start` of the caller's output.
    fn submit(
        &mut self,
        slot_i: usize,
        k0: u64,
        start: usize,
        count: usize,
        want_e: bool,
    ) -> InFlight {
        let t0 = Instant::now();
        let cu = ChunkU {
            first: [k0 as u32, (k0 >> 32) as u32],
            count: count as u32,
            want_e: u32::from(want_e),
        };
        let slot = &self.slots[slot_i];
        self.gpu.write(&slot.chunk, bytemuck::bytes_of(&cu));
        let w_bytes = 4 * count as u64;
        let e_bytes = if want_e {
            4 * (count * self.m) as u64
        } else {
            0
        };
        let groups = count.div_ceil(WORKGROUP) as u32;
        let index = self.gpu.dispatch(
            &self.pipeline,
            &slot.bind,
            groups,
            &[
                (&slot.w, &slot.w_stage, w_bytes),
                (&slot.e, &slot.e_stage, e_bytes),
            ],
            slot.timer.as_ref(),
        );
        let pending_w = self.gpu.map_read(&slot.w_stage, w_bytes);
        let pending_e = want_e.then(|| self.gpu.map_read(&slot.e_stage, e_bytes));
        let pending_t = slot.timer.as_ref().map(|t| self.gpu.map_timer(t));
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
        self.gpu.wait(f.index).map_err(gpu_err)?;
        let slot = &self.slots[f.slot];
        drop(
            self.gpu
                .mapped(&slot.w_stage, 4 * f.count as u64, f.pending_w)
                .map_err(gpu_err)?,
        );
        if let (Some(t), Some(pt)) = (&slot.timer, f.pending_t) {
            self.gpu.read_timer(t, pt).map_err(gpu_err)?;
        }
        Ok(())
    }

    fn run(
        &mut self,
        first: u64,
        w: &mut [f64],
        mut e: Option<&mut [f64]>,
    ) -> Result<(), EngineError> {
        let want_e = e.is_some();
        if want_e {
            self.ensure_e_buffers();
        }
        let c = if want_e { self.chunk_e } else { self.chunk };
        let n = w.len();
        let nslots = self.slots.len();
        let mut inflight: VecDeque<InFlight> = VecDeque::with_capacity(nslots);
        let mut start = 0usize;
        let mut h = 0usize;
        // A speculative chunk from the previous call: used if it is the start of this request.
        if let Some((k, f)) = self.prefetch.take() {
            if k == first && !want_e && f.count <= n {
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
            let k0 = first.wrapping_add(start as u64);
            let f = self.submit(h % nslots, k0, start, count, want_e);
            inflight.push_back(f);
            start += count;
            h += 1;
        }
        while let Some(f) = inflight.pop_front() {
            self.finish(f, w, &mut e)?;
        }
        // Draws are a pure function of their index: compute the likely next range (the Monte
        // Carlo drivers ask for consecutive batches) while the caller works on this one.
        if self.prefetch_enabled && !want_e && n > 0 {
            let next = first.wrapping_add(n as u64);
            let count = n.min(self.chunk);
            let f = self.submit(h % nslots, next, 0, count, false);
            self.prefetch = Some((next, f));
        }
        Ok(())
    }
}

impl Evaluator for GpuEvaluator {
    fn info(&self) -> BackendInfo {
        BackendInfo {
            backend: "gpu".into(),
            adapter: self.gpu.name.clone(),
            driver: self.gpu.driver.clone(),
        }
    }

    fn n_points(&self) -> usize {
        self.m
    }

    fn evaluate(
        &mut self,
        first: u64,
        w: &mut [f64],
        per_point: Option<&mut [f64]>,
    ) -> Result<(), EngineError> {
        check_buffers(self.m, w, per_point.as_ref())?;
        if let Some(b) = &self.broken {
            return Err(EngineError::Gpu(format!(
                "device unusable after an earlier error: {b}"
            )));
        }
        self.timings = GpuTimings::default();
        let r = self.run(first, w, per_point);
        if let Err(EngineError::Gpu(msg)) = &r {
            self.broken = Some(msg.clone());
        }
        r
    }
}

/// The 4 Philox words of one block and its 4 normals, as the shader computes them.
pub type PhiloxBlock = ([u32; 4], [f32; 4]);

/// Runs the Philox test kernel on the adapter chosen by `adapter` (substring, or the most
/// capable): for each `(counter, key)` the 4 Philox words and the 4 normals of that block.
/// For tests of the shader against the Rust generator.
pub fn philox_on_gpu(
    adapter: Option<&str>,
    cases: &[([u32; 4], [u32; 2])],
) -> Result<Vec<PhiloxBlock>, EngineError> {
    let entry = pick_adapter(adapter, false).map_err(gpu_err)?;
    let gpu = Gpu::open(entry, false).map_err(gpu_err)?;
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
    let bind = gpu.bind_group(&layout, &[&in_buf, &out_buf]);
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
