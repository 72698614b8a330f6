//! The Philox known-answer kernel: the shader's Philox words and normals, for tests against the
//! Rust generator.

use crate::{gpu_err, philox_test_source, GpuContext};
use gpu_amcs_core::engine::EngineError;

/// The 4 Philox words of one block and its 4 normals, as the shader computes them.
pub type PhiloxBlock = ([u32; 4], [f32; 4]);

/// Runs the Philox test kernel on the adapter chosen by `adapter` (substring, or the most
/// capable; the process's shared device): for each `(counter, key)` the 4 Philox words and the
/// 4 normals of that block. For tests of the shader against the Rust generator.
///
/// # Errors
///
/// [`EngineError::Gpu`] when the adapter cannot be found or opened, the test shader does not
/// compile, or the dispatch or readback fails.
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
