//! The long-lived GPU context: one device, queue, bind-group layout and set of pipelines (one per entry point) per
//! adapter and process, shared by every [`super::GpuEvaluator`] on that adapter (the pattern of
//! wgpu's `repeated_compute` example: device and pipelines once, per-problem buffers replaced).
//!
//! A study of 22 levels × 2 point sets × 2 spreads used to open 88 devices and compile the
//! shader 88 times; now it opens one. Contexts are kept in a process-wide registry keyed by
//! the adapter's identity; one whose device reported an error is marked failed and replaced on
//! the next request. Validation errors are collected per device, so evaluators sharing a device
//! share its error sink (an error surfaces in whichever evaluator waits next).

use super::device::{self, BindGroupLayout, BindingKind, ComputePipeline, Gpu};
use super::{
    binding, gpu_err, shader_with_term, ENTRY_POINT, OFFSETS_ENTRY_POINT, PICK_FREEZE_ENTRY_POINT,
    WORKGROUP,
};
use gpu_amcs_core::engine::EngineError;
use gpu_amcs_core::engine::TermPacking;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};

/// Devices opened by this process so far.
static DEVICES_OPENED: AtomicUsize = AtomicUsize::new(0);
/// The open contexts, one per adapter.
static REGISTRY: Mutex<Vec<Arc<GpuContext>>> = Mutex::new(Vec::new());

/// How many GPU devices this process has opened (each [`GpuContext`] opens one).
pub fn devices_opened() -> usize {
    DEVICES_OPENED.load(Ordering::SeqCst)
}

/// An open device with the evaluator's compiled pipelines (see the module docs).
pub struct GpuContext {
    pub(super) gpu: Gpu,
    pub(super) layout: BindGroupLayout,
    /// The pipelines per joint count and joint-error switch: the six-joint ones without joint
    /// errors compiled when the device opens, any other when a model first asks
    /// ([`GpuContext::kernels`]).
    kernels: Mutex<Vec<(KernelKey, Arc<Kernels>)>>,
    failed: AtomicBool,
}

/// What a kernel is specialised by: the joint count and the model's joint-error code
/// ([`crate::term_draw_source`]; `None`: no joint errors).
type KernelKey = (usize, Option<String>);

/// The evaluator's three pipelines for one joint count and joint-error switch (the shader is
/// specialised by them).
pub struct Kernels {
    /// Entry point [`ENTRY_POINT`]: counter draws.
    pub(super) draws: ComputePipeline,
    /// Entry point [`OFFSETS_ENTRY_POINT`]: explicit offset rows.
    pub(super) offsets: ComputePipeline,
    /// Entry point [`PICK_FREEZE_ENTRY_POINT`]: pick-freeze rows.
    pub(super) pick_freeze: ComputePipeline,
}

/// The evaluator shader's bind group 0, by name.
const LAYOUT: [(u32, BindingKind); 12] = [
    (binding::CONFIG, BindingKind::Uniform),
    (binding::CHUNK, BindingKind::Uniform),
    (binding::JOINT_TRIG, BindingKind::StorageRead),
    (binding::SPREAD, BindingKind::StorageRead),
    (binding::FREE, BindingKind::StorageRead),
    (binding::POINTS, BindingKind::StorageRead),
    (binding::W, BindingKind::StorageReadWrite),
    (binding::E, BindingKind::StorageReadWrite),
    (binding::OFFSETS, BindingKind::StorageRead),
    (binding::MASKS, BindingKind::StorageRead),
    (binding::DISC_RADII, BindingKind::StorageRead),
    (binding::TERM, BindingKind::StorageRead),
];

impl GpuContext {
    /// The context of the adapter chosen by `adapter` (case-insensitive substring of its
    /// name) or, without one, the most capable adapter (`hardware_only`: refuse a software
    /// one): the process's existing context for that adapter, or a newly opened one.
    ///
    /// # Errors
    ///
    /// [`EngineError::Gpu`] when no adapter matches `adapter` (or only a software one does and
    /// `hardware_only` is set), the device cannot be opened or the shader does not compile.
    pub fn shared(adapter: Option<&str>, hardware_only: bool) -> Result<Arc<Self>, EngineError> {
        let entry = device::pick_adapter(adapter, hardware_only).map_err(gpu_err)?;
        // Held while opening, so two threads asking at once share one device.
        let mut registry = REGISTRY
            .lock()
            .map_err(|_| gpu_err("the GPU context registry was poisoned by a panic"))?;
        registry.retain(|c| !c.failed.load(Ordering::SeqCst));
        let g = |c: &Arc<Self>| {
            entry.same_as(
                &c.gpu.name,
                &c.gpu.backend,
                &c.gpu.device_type,
                &c.gpu.driver,
            )
        };
        if let Some(c) = registry.iter().find(|c| g(c)) {
            return Ok(Arc::clone(c));
        }
        let ctx = Arc::new(Self::open(entry)?);
        registry.push(Arc::clone(&ctx));
        Ok(ctx)
    }

    /// Opens a device on `entry` and compiles the evaluator's six-joint pipelines.
    fn open(entry: device::AdapterEntry) -> Result<Self, EngineError> {
        let gpu = Gpu::open(entry).map_err(gpu_err)?;
        DEVICES_OPENED.fetch_add(1, Ordering::SeqCst);
        let layout = gpu.layout(&LAYOUT);
        let six = Arc::new(compile(&gpu, &layout, 6, None)?);
        Ok(GpuContext {
            gpu,
            layout,
            kernels: Mutex::new(vec![((6, None), six)]),
            failed: AtomicBool::new(false),
        })
    }

    /// The pipelines for models of `joints` joints with the joint errors of `joint_errors`
    /// (`None`: none), compiled on first use.
    ///
    /// # Errors
    ///
    /// [`EngineError::Gpu`] when the specialised shader does not compile.
    pub(super) fn kernels(
        &self,
        joints: usize,
        joint_errors: Option<&TermPacking>,
    ) -> Result<Arc<Kernels>, EngineError> {
        let code = joint_errors.map(|t| crate::term_draw_source(joints, Some(t)));
        let mut list = self
            .kernels
            .lock()
            .map_err(|_| gpu_err("the GPU pipeline cache was poisoned by a panic"))?;
        let key = (joints, code);
        if let Some((_, k)) = list.iter().find(|(n, _)| *n == key) {
            return Ok(Arc::clone(k));
        }
        let k = Arc::new(compile(&self.gpu, &self.layout, joints, key.1.as_deref())?);
        list.push((key, Arc::clone(&k)));
        Ok(k)
    }

    /// Adapter name.
    pub fn adapter_name(&self) -> &str {
        &self.gpu.name
    }

    /// Whether the device can time passes with timestamp queries.
    pub fn supports_timestamps(&self) -> bool {
        self.gpu.timestamps
    }

    /// Most invocations of one dispatch within the device limits (workgroup count and the
    /// f32 output buffer's binding and buffer size).
    pub(super) fn max_chunk(&self) -> usize {
        let by_groups = (self.gpu.max_workgroups as usize).saturating_mul(WORKGROUP);
        by_groups.min(self.max_binding_words()).max(1)
    }

    /// Most f32 words of one storage binding.
    pub(super) fn max_binding_words(&self) -> usize {
        (self.gpu.max_binding.min(self.gpu.max_buffer) / 4) as usize
    }

    /// Marks the device unusable: the next [`GpuContext::shared`] opens a fresh one.
    pub(super) fn mark_failed(&self) {
        self.failed.store(true, Ordering::SeqCst);
    }
}

/// Compiles the evaluator shader specialised for `joints` joints and a model's joint-error code
/// (`None`: none) into its three pipelines.
fn compile(
    gpu: &Gpu,
    layout: &BindGroupLayout,
    joints: usize,
    term_code: Option<&str>,
) -> Result<Kernels, EngineError> {
    let mut p = gpu
        .pipelines(
            &shader_with_term(joints, term_code),
            &[ENTRY_POINT, OFFSETS_ENTRY_POINT, PICK_FREEZE_ENTRY_POINT],
            layout,
        )
        .map_err(gpu_err)?;
    match (p.pop(), p.pop(), p.pop()) {
        (Some(pick_freeze), Some(offsets), Some(draws)) => Ok(Kernels {
            draws,
            offsets,
            pick_freeze,
        }),
        _ => Err(gpu_err("the evaluator shader gave no pipelines")),
    }
}
