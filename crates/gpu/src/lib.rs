//! The GPU evaluator: the parameter vectors of [`Evaluator`](gpu_amcs_core::engine::Evaluator) through a WGSL
//! compute shader (`shaders/philox.wgsl` + `shaders/mdh_max_error.wgsl`) on any Vulkan, Metal or
//! DX12 adapter via wgpu, one invocation per parameter vector (`docs/METHOD.md §3`:
//! `w = max_j e_j`, paper eqs. 12 and 17).
//!
//! The shader's entry point [`ENTRY_POINT`] draws exactly the normals of the CPU sampler
//! (Philox4x32-10 with counter `[draw lo, draw hi, block, 0]`, the Box–Muller layout of
//! [`gpu_amcs_core::sampling::box_muller`], independent `δ_i = σ_i z_i` or correlated `δ = L z` on the
//! free parameters), so draw `k` is the same parameter vector on both backends; with the
//! model's discrepancy term ([`Problem::discrepancy`](gpu_amcs_core::engine::Problem::discrepancy))
//! it also draws the CPU's radius and direction cosine at every point (its own Philox stream,
//! [`gpu_amcs_core::discrepancy`]), which the other two entry points leave out. The entry point
//! [`OFFSETS_ENTRY_POINT`] reads δ from an uploaded offset matrix instead (rows converted to
//! f32 chunk by chunk), and [`PICK_FREEZE_ENTRY_POINT`] generates the rows of a Sobol
//! pick-freeze design from two counter draws and a per-matrix mask of normals
//! ([`PickFreeze`](gpu_amcs_core::engine::PickFreeze); only the masks are uploaded); all call the same WGSL
//! kinematics. The kinematics is the f32
//! deviation form of [`deviation`](gpu_amcs_core::engine::deviation), whose module docs give the error budget.
//!
//! # One device per process
//!
//! Device, queue, bind-group layout and pipelines live in a [`GpuContext`], opened once per
//! adapter and process and shared (`Arc`) by every evaluator on that adapter
//! ([`GpuContext::shared`]; [`devices_opened`] counts the opens). An evaluator owns only the
//! per-problem buffers (configuration, joint constants, spread, per-point constants) and its
//! chunk slots; [`GpuEvaluator::set_problem`] replaces the per-problem buffers and keeps the
//! rest. Bindings are named ([`binding`]), not positional; `tests/it/gpu.rs` checks them, the
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
//! buffers; an offset request of n rows uploads one f32 per input of the evaluator's offset space
//! per row (the robot's inputs, and the placement's when the problem draws it), one chunk at a
//! time.
#![warn(clippy::missing_errors_doc)]

mod backend;
mod buffers;
mod context;
mod device;
mod evaluator;
mod kat;
mod term_code;

pub use backend::{list_adapters, make_evaluator, WgpuBackends};
pub use buffers::{ChunkUniform, ConfigUniform};
pub use context::{devices_opened, GpuContext};
pub use evaluator::GpuEvaluator;
pub use kat::{philox_on_gpu, PhiloxBlock};

use gpu_amcs_core::engine::{EngineError, TermPacking};
pub use term_code::term_draw_source;

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
    /// Input of the offset path: one offset per input of the evaluator's offset space per row
    /// (the robot's inputs, then the placement's when drawn; `offsets_in`).
    pub const OFFSETS: u32 = 8;
    /// Input of the pick-freeze path: one mask of normals per matrix, (lo, hi) words (`masks`).
    pub const MASKS: u32 = 9;
    /// The model's discrepancy term: its radii as f32, mm, drawn by the counter-draw entry
    /// point only (`disc_radii`: the radii, the size's 256 per-draw factors, then a compensated
    /// model's m per-point factors; one unused entry without a term).
    pub const DISC_RADII: u32 = 10;
    /// The model's joint errors (Method §19.2): 8 f32 per test point and joint, read as two
    /// vec4 (`term`; one unused vec4 without them; the rest of the joint errors is written into
    /// the kernel's code).
    pub const TERM: u32 = 11;
}

/// The evaluator shader for an `joints`-joint model: [`PHILOX_WGSL`], the input space's
/// constants ([`input_constants`]), `TERM_ON` (whether the model draws joint errors), [`MDH_WGSL`],
/// then the chain written out joint by joint ([`unrolled_chain`]) and the joint errors' per-draw
/// code of the model whose [`TermPacking`] is given ([`term_draw_source`]).
///
/// `TERM_ON` is a constant, not a uniform, so that a model without joint errors gets a kernel
/// without their code: with it merely switched off at run time, the joint errors' dynamically
/// indexed arrays (the shift of the geometric offsets, the per-joint factors) put the draw's
/// offsets into local memory on NVIDIA's compiler for every model.
///
/// # Panics
///
/// When `joints` is not 4 to 7 (a model has been checked before).
pub fn shader_source(joints: usize, joint_errors: Option<&TermPacking>) -> String {
    let code = joint_errors.map(|t| term_draw_source(joints, Some(t)));
    shader_with_term(joints, code.as_deref())
}

/// [`shader_source`] with the joint errors' function already written ([`term_draw_source`];
/// `None`: a model without joint errors).
pub(crate) fn shader_with_term(joints: usize, term_code: Option<&str>) -> String {
    let code = match term_code {
        Some(c) => c.to_string(),
        None => term_draw_source(joints, None),
    };
    format!(
        "{PHILOX_WGSL}\n{}const TERM_ON: bool = {};\n{MDH_WGSL}\n{}{code}",
        input_constants(joints),
        term_code.is_some(),
        unrolled_chain(joints)
    )
}

/// The per-draw joint offsets and the propagation of a point's deviation from the tool to the
/// base, written out for `joints` joints with constant indices: `struct Chain` (each joint's
/// offsets and mean trigonometry), `fn chain_offsets(d)` and `fn chain_step(dv, base, c)`.
/// Written as loops over arrays, the same code ran 3.1× slower on an NVIDIA H100 (device time of
/// 10^6 draws × 50 points 3.7 ms against 1.2 ms): its compiler kept the arrays in local memory
/// instead of unrolling the loops into registers.
///
/// # Panics
///
/// When `joints` is not 4 to 7.
pub fn unrolled_chain(joints: usize) -> String {
    use std::fmt::Write as _;
    assert!(
        (4..=7).contains(&joints),
        "{joints} joints: a model has 4 to 7"
    );
    let mut s = String::from(
        "// Generated by the host for N_JOINTS joints (gpu-amcs-gpu unrolled_chain).\nstruct Chain {\n",
    );
    for k in 0..joints {
        let _ = writeln!(
            s,
            "    o{k}: JointOffsets,\n    t{k}: vec4<f32>,\n    h{k}: f32,"
        );
    }
    s.push_str("}\n\nfn chain_offsets(d: array<f32, N_PLACED>) -> Chain {\n    return Chain(\n");
    for k in 0..joints {
        let o = 5 * k;
        let _ = writeln!(
            s,
            "        joint_offsets({k}u, d[{o}], d[{}], d[{}], d[{}], d[{}]),\n        joint_trig[{k}],\n        d[{o}],",
            o + 1,
            o + 2,
            o + 3,
            o + 4
        );
    }
    s.push_str("    );\n}\n");
    // The plain chain, and the one whose joints the draw's joint errors turn further.
    for (head, offsets) in [
        ("chain_step(dv0: vec3<f32>, base: u32, c: Chain)", "c.o{j}"),
        (
            "chain_step_turned(dv0: vec3<f32>, base: u32, c: Chain, f: array<vec4<f32>, 2u * N_JOINTS>, pj: u32, wb: u32)",
            "turned(c.o{j}, c.h{j}, term_offset(f, pj, {j}u, wb))",
        ),
    ] {
        let _ = write!(s, "\nfn {head} -> vec3<f32> {{\n    var dv = dv0;\n");
        for j in (0..joints).rev() {
            let _ = writeln!(
                s,
                "    dv = joint_step(dv, pts[base + {}u], pts[base + {}u], c.t{j}, {});",
                2 * j,
                2 * j + 1,
                offsets.replace("{j}", &j.to_string())
            );
        }
        s.push_str("    return dv;\n}\n");
    }
    s
}

/// The WGSL constants that say where each block of a draw's inputs lies, read from the
/// [`InputSpace`](gpu_amcs_core::kinematics::InputSpace) of an `joints`-joint model: the joint
/// count, then for each block its first position in an offset row (`*_AT`) and the widths of the
/// robot's row (`N_INPUTS`) and of a row with the placement (`N_PLACED`). The shader declares
/// none of them itself, so its layout cannot drift from the host's.
///
/// # Panics
///
/// When `joints` is not 4 to 7.
pub fn input_constants(joints: usize) -> String {
    use gpu_amcs_core::kinematics::{Block, InputSpace};
    let (robot, measured) = (InputSpace::robot(joints), InputSpace::measured(joints));
    let at = |b: Block| measured.range(b).map_or(0, |r| r.start);
    // Rows without the placement are the measured rows' first inputs: the same positions.
    debug_assert!(robot.blocks().all(|b| robot.range(b) == measured.range(b)));
    format!(
        "const N_JOINTS: u32 = {joints}u;\n\
         const N_PARAMS: u32 = {}u;\n\
         const TOOL_AT: u32 = {}u;\n\
         const N_INPUTS: u32 = {}u;\n\
         const PLACEMENT_AT: u32 = {}u;\n\
         const N_PLACED: u32 = {}u;\n",
        Block::Joints.len(joints),
        at(Block::Tool),
        robot.len(),
        at(Block::Placement),
        measured.len(),
    )
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
///
/// [`Evaluator::evaluate`]: gpu_amcs_core::engine::Evaluator::evaluate
/// [`Evaluator::evaluate_offsets`]: gpu_amcs_core::engine::Evaluator::evaluate_offsets
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

fn gpu_err(e: impl std::fmt::Display) -> EngineError {
    EngineError::Gpu(e.to_string())
}
