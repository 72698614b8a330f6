//! The evaluator's GPU buffers: the uniforms the shader reads ([`ConfigUniform`],
//! [`ChunkUniform`]), the per-problem buffers, the alternating chunk slots with their bind
//! groups, and the bookkeeping of a dispatched chunk.

use crate::device::{self, BindGroup, Buffer, Gpu, Timer};
use crate::{binding, GpuContext};
use gpu_amcs_core::engine::deviation::{self, SpreadPacking};
use gpu_amcs_core::engine::{PickFreeze, PlacementSpread, Problem};

/// The run configuration uniform (`cfg` in the shader; `tests/it/gpu.rs` checks that its size
/// equals the WGSL struct's).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ConfigUniform {
    /// Philox key.
    pub key: [u32; 2],
    /// Test points m.
    pub m: u32,
    /// 0: independent spread (σ), 1: correlated (Cholesky factor), 2: correlated with the base
    /// placement.
    pub mode: u32,
    /// Free parameters of a correlated spread.
    pub nfree: u32,
    /// Bit b set: Philox block b feeds some free parameter.
    pub block_mask: u32,
    /// Radii of the model's discrepancy term drawn by counter draws (0: no term).
    pub disc_count: u32,
    /// 1: the term's per-point factors follow its radii in `disc_radii` (a compensated model);
    /// 0: factor 1 everywhere.
    pub disc_scaled: u32,
    /// 1: counter draws and pick-freeze rows draw the model's joint errors (`term`, Method
    /// §19.2); 0: none (the mean deflections are in the point constants either way).
    pub term_on: u32,
    /// Free coefficients of the joint errors.
    pub term_free: u32,
    /// Rows of their shift of the geometric inputs.
    pub term_rows: u32,
    /// Where the per-point words start in `term` (f32 entries; 0: the buffer holds only them).
    pub term_pts: u32,
    /// Where a second discrepancy term starts in `disc_radii` (0: none;
    /// `gpu_amcs_core::engine::SecondTerm`): its radii, its factors, then per point 1.0 where the
    /// point draws it.
    pub disc_second: u32,
    /// Radii of the second term.
    pub disc_second_count: u32,
    /// Padding to the WGSL struct's size.
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
pub(crate) fn words(x: u64) -> [u32; 2] {
    [x as u32, (x >> 32) as u32]
}

/// The buffers of one problem (see [`GpuEvaluator::set_problem`]).
pub(crate) struct ProblemBuffers {
    pub(crate) config: Buffer,
    pub(crate) joint_trig: Buffer,
    pub(crate) spread: Buffer,
    pub(crate) free: Buffer,
    pub(crate) points: Buffer,
    /// The discrepancy term's radii as f32 (one unused entry without a term).
    pub(crate) disc_radii: Buffer,
    /// The joint errors' words, then their per-point words (one unused entry without them).
    pub(crate) term: Buffer,
    pub(crate) m: usize,
    /// The draws include the base placement (counter draws only).
    pub(crate) placed: bool,
    /// The model's input layout (its joint count).
    pub(crate) layout: gpu_amcs_core::kinematics::Layout,
}

impl ProblemBuffers {
    pub(crate) fn new(gpu: &Gpu, problem: &Problem) -> Self {
        // A model whose placement is uncertain (checked positive definite when the problem was
        // made) draws it too.
        let packing = match PlacementSpread::of(problem) {
            Ok(Some(sp)) => SpreadPacking::with_placement(&sp),
            _ => SpreadPacking::new(problem),
        };
        let m = problem.n_points();
        // The term's radii (at most 2¹⁶, so the count fits the shader's index rule); a binding
        // cannot be empty, so a problem without one uploads a single unused zero.
        // The size's per-draw factors follow the radii (SIZE_DRAWS of them), then a compensated
        // model's per-point factors (m of them).
        // A second term (drawn at the points it marks) follows: its radii, its factors and a
        // 1.0 per point that draws it (0.0 elsewhere).
        let (disc, disc_count, disc_scaled, disc_second, disc_second_count): (
            Vec<f32>,
            u32,
            u32,
            u32,
            u32,
        ) = match &problem.discrepancy {
            Some(d) => {
                debug_assert_eq!(d.key(), problem.sampler.key(), "one key for both streams");
                let radii = d.radii().iter().map(|&r| r as f32);
                let factors = d.factors().iter().map(|&g| g as f32);
                let scales = d.scales().iter().map(|&s| s as f32);
                let mut words: Vec<f32> = radii.chain(factors).chain(scales).collect();
                let (at, count) = match d.second() {
                    Some(t) => {
                        let at = words.len() as u32;
                        words.extend(t.radii.iter().map(|&r| r as f32));
                        words.extend(t.factors.iter().map(|&g| g as f32));
                        words.extend(t.at.iter().map(|&a| if a { 1.0f32 } else { 0.0 }));
                        (at, t.radii.len() as u32)
                    }
                    None => (0, 0),
                };
                (
                    words,
                    d.radii().len() as u32,
                    u32::from(!d.scales().is_empty()),
                    at,
                    count,
                )
            }
            None => (Vec::new(), 0, 0, 0, 0),
        };
        let disc_radii = if disc.is_empty() { vec![0.0f32] } else { disc };
        let packing_term = problem.joint_errors.as_ref().map(|t| t.packing());
        // Only the per-point quantities, as vec4 (two loads per point and joint, not six): the
        // rest of the packing is written into the kernel's code (term_code).
        let (term, term_pts): (Vec<f32>, u32) = match &packing_term {
            Some(t) => (t.points.iter().flatten().copied().collect(), 0),
            None => (vec![0.0; 4], 0),
        };
        let cfg = ConfigUniform {
            key: problem.sampler.key(),
            m: m as u32,
            mode: deviation::kernel_mode(&packing),
            nfree: packing.n_free() as u32,
            block_mask: packing.block_mask,
            disc_count,
            disc_scaled,
            disc_second,
            disc_second_count,
            pad: [0; 2],
            term_on: u32::from(packing_term.is_some()),
            term_free: packing_term.as_ref().map_or(0, |t| t.free),
            term_rows: packing_term.as_ref().map_or(0, |t| t.rows),
            term_pts,
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
            disc_radii: gpu.storage_init("discrepancy radii", bytemuck::cast_slice(&disc_radii)),
            term: gpu.storage_init("joint errors", bytemuck::cast_slice(&term)),
            m,
            placed: packing.placement,
            layout: problem.model.layout(),
        }
    }
}

/// One of the alternating chunk slots: its uniform, outputs, staging and offset input.
pub(crate) struct Slot {
    pub(crate) chunk: Buffer,
    pub(crate) w: Buffer,
    pub(crate) w_stage: Buffer,
    pub(crate) e: Buffer,
    pub(crate) e_stage: Buffer,
    pub(crate) offsets: Buffer,
    pub(crate) bind: BindGroup,
    pub(crate) timer: Option<Timer>,
}

/// The buffers a slot binds besides the problem's.
pub(crate) struct SlotBuffers<'a> {
    pub(crate) chunk: &'a Buffer,
    pub(crate) w: &'a Buffer,
    pub(crate) e: &'a Buffer,
    pub(crate) offsets: &'a Buffer,
    pub(crate) masks: &'a Buffer,
}

/// The bind group of a slot over `problem`'s buffers, every binding by name.
pub(crate) fn bind_slot(ctx: &GpuContext, problem: &ProblemBuffers, s: SlotBuffers) -> BindGroup {
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
            (binding::DISC_RADII, &problem.disc_radii),
            (binding::TERM, &problem.term),
        ],
    )
}

impl Slot {
    /// A slot of `chunk` outputs; per-point and offset buffers are placeholders until needed.
    pub(crate) fn new(
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
    pub(crate) fn rebind(&mut self, ctx: &GpuContext, problem: &ProblemBuffers, masks: &Buffer) {
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
pub(crate) enum Rows<'a> {
    /// Counter draws from this index on.
    Draws(u64),
    /// An offset matrix of the given width (the evaluator's offset space: the robot's inputs, or
    /// with the placement for a problem that draws it) per row, from its first row on.
    Offsets(&'a [f64], usize),
    /// The rows of a pick-freeze request from this row on (its masks already uploaded).
    PickFreeze(PickFreeze<'a>, usize),
}

impl<'a> Rows<'a> {
    /// The rows from `n` on.
    pub(crate) fn skip(self, n: usize) -> Rows<'a> {
        match self {
            Rows::Draws(k) => Rows::Draws(k.wrapping_add(n as u64)),
            Rows::Offsets(o, width) => Rows::Offsets(&o[(n * width).min(o.len())..], width),
            Rows::PickFreeze(pf, row) => Rows::PickFreeze(pf, row + n),
        }
    }
}

pub(crate) struct InFlight {
    pub(crate) slot: usize,
    pub(crate) start: usize,
    pub(crate) count: usize,
    pub(crate) index: device::SubmissionIndex,
    pub(crate) pending_w: device::PendingMap,
    pub(crate) pending_e: Option<device::PendingMap>,
    pub(crate) pending_t: Option<device::PendingMap>,
}
