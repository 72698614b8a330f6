//! The wgpu evaluator ([`GpuEvaluator`]): requests cut into chunks, two slots alternating so the
//! readback of one chunk overlaps the computation of the next, and the speculative next chunk
//! (see the crate docs, "Batching").

use crate::buffers::{words, ChunkUniform, InFlight, ProblemBuffers, Rows, Slot};
use crate::context::Kernels;
use crate::device::{self, Buffer, Gpu};
use crate::{gpu_err, GpuContext, GpuOptions, GpuTimings, WORKGROUP};
use gpu_amcs_core::engine::{BackendInfo, EngineError, Evaluator, PickFreeze, Problem};
use std::collections::VecDeque;
use std::sync::Arc;
use std::time::Instant;

/// The wgpu evaluator (see the module docs).
pub struct GpuEvaluator {
    ctx: Arc<GpuContext>,
    /// The pipelines for the problem's joint count.
    kernels: Arc<Kernels>,
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

impl GpuEvaluator {
    /// An evaluator for `problem` on the adapter chosen by `opts`, sharing the process's device
    /// on that adapter ([`GpuContext::shared`]; opened, and the shader compiled, on first use).
    ///
    /// # Errors
    ///
    /// [`EngineError::Gpu`] when the adapter cannot be found or opened ([`GpuContext::shared`]) or
    /// the buffers cannot be created.
    pub fn new(problem: Problem, opts: &GpuOptions) -> Result<Self, EngineError> {
        let ctx = GpuContext::shared(opts.adapter.as_deref(), opts.hardware_only)?;
        Self::with_context(ctx, &problem, opts)
    }

    /// An evaluator for `problem` on an open context (its adapter-selection options are
    /// ignored): uploads the problem's constants and allocates the chunk slots.
    ///
    /// # Errors
    ///
    /// [`EngineError::Gpu`] when the device reports an error creating the buffers.
    pub fn with_context(
        ctx: Arc<GpuContext>,
        problem: &Problem,
        opts: &GpuOptions,
    ) -> Result<Self, EngineError> {
        let gpu = &ctx.gpu;
        let chunk = opts.chunk.max(1).min(ctx.max_chunk()).max(1);
        let by_bytes = ctx.max_binding_words();
        // Rows of any model fit: the widest row has MAX_WITH_BASE entries.
        let chunk_o = chunk.min((by_bytes / gpu_amcs_core::kinematics::MAX_INPUTS).max(1));
        let packing = problem.joint_errors.as_ref().map(|t| t.packing());
        let kernels = ctx.kernels(problem.model.joints(), packing.as_ref())?;
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
            kernels,
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
    ///
    /// # Errors
    ///
    /// [`EngineError::Gpu`] when the evaluator is unusable after an earlier device error, or the
    /// device reports an error (which marks it unusable).
    pub fn set_problem(&mut self, problem: &Problem) -> Result<(), EngineError> {
        self.check_usable()?;
        if let Some((_, f)) = self.prefetch.take() {
            self.guard(|s| s.discard(f))?;
        }
        let m_old = self.problem.m;
        let packing = problem.joint_errors.as_ref().map(|t| t.packing());
        let kernels = self.ctx.kernels(problem.model.joints(), packing.as_ref())?;
        self.problem = ProblemBuffers::new(&self.ctx.gpu, problem);
        self.kernels = kernels;
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
        let bytes = 4 * (self.chunk_o * self.offset_width()) as u64;
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
                &self.kernels.draws
            }
            Rows::Offsets(o, width) => {
                self.staging_f32.clear();
                self.staging_f32
                    .extend(o[..count * width].iter().map(|&v| v as f32));
                gpu.write(&slot.offsets, bytemuck::cast_slice(&self.staging_f32));
                &self.kernels.offsets
            }
            Rows::PickFreeze(pf, row) => {
                // `run` checked that rows and the matrix length fit in u32.
                cu.first = words(pf.first);
                cu.b_first = words(pf.b_first);
                cu.per_matrix = pf.count as u32;
                cu.row0 = row as u32;
                &self.kernels.pick_freeze
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
            Rows::Offsets(..) => {
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

    fn layout(&self) -> gpu_amcs_core::kinematics::Layout {
        self.problem.layout
    }

    fn offset_space(&self) -> gpu_amcs_core::kinematics::InputSpace {
        if self.problem.placed {
            self.problem.layout.measured()
        } else {
            self.problem.layout.robot()
        }
    }

    fn eval_offsets(
        &mut self,
        offsets: &[f64],
        w: &mut [f64],
        per_point: Option<&mut [f64]>,
    ) -> Result<(), EngineError> {
        let width = self.offset_width();
        self.request(Rows::Offsets(offsets, width), w, per_point)
    }

    fn eval_pick_freeze(&mut self, request: &PickFreeze, w: &mut [f64]) -> Result<(), EngineError> {
        self.request(Rows::PickFreeze(*request, 0), w, None)
    }
}
