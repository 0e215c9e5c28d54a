//! Whether this adapter can run a structure's program as given ([`Gpu::admit`]), before
//! anything is uploaded or compiled.

use crate::device::Gpu;
use crate::GpuError;
use tb_core::{GpuArrange, GpuProgram};

/// Storage buffers among [`crate::kernels::COMMON_BINDINGS`] (all but the `meta_` uniform).
const COMMON_STORAGE: u32 = 4;
/// Iterations llvmpipe allows the loops of one shader invocation (65535), with a margin:
/// a program with an unrolled triangle loop handles at most `unroll` times this many there.
const LLVMPIPE_LOOP_MAX: u64 = 65_000;
/// Bytes of a triangle as bound (three `vec4<f32>`).
const TRIANGLE_BYTES: u64 = 48;

impl Gpu {
    /// `Ok` when the adapter can run `p`: `f64` where it computes in it, subgroups where it
    /// uses them, llvmpipe's loop
    /// limit, the adapter's storage and uniform buffer counts and binding sizes, the ray
    /// keys, buffers of whole 4-byte words; else the error [`Gpu::upload`] gives.
    pub(crate) fn admit(&self, p: &GpuProgram<'_>) -> Result<(), GpuError> {
        if p.needs_f64 && !self.summary.f64 {
            return Err(GpuError::Unsupported(format!(
                "{} computes in f64, and adapter {} lacks SHADER_F64",
                p.name, self.summary.name
            )));
        }
        if p.needs_subgroups && self.summary.subgroups.is_none() {
            return Err(GpuError::Unsupported(format!(
                "{} uses subgroup operations, and adapter {} lacks SUBGROUP",
                p.name, self.summary.name
            )));
        }
        let n_tris = p.triangles.len() as u64;
        if let Some(unroll) = p.unrolled_triangle_loop {
            let most = unroll as u64 * LLVMPIPE_LOOP_MAX;
            if self.summary.driver.contains("llvmpipe") && n_tris > most {
                return Err(GpuError::Unsupported(format!(
                    "{} over {n_tris} triangles on llvmpipe: it ends a shader's loops after 65535 iterations, so at most {most} triangles",
                    p.name
                )));
            }
        }
        let bindable = self.limits.max_storage_buffers_per_shader_stage;
        let sorting = p.arrange.is_some() as u64;
        let uniforms = p.uniform_mask().count_ones() as u64;
        let storage = p.buffers.len() as u64 - uniforms;
        let pool = p.persistent as u64;
        if COMMON_STORAGE as u64 + storage + sorting + pool > bindable as u64 {
            return Err(GpuError::Unsupported(format!(
                "{}: {storage} storage buffers of its own, {COMMON_STORAGE} common ones, {sorting} for sorting its rays and {pool} for persistent threads, over the adapter's max_storage_buffers_per_shader_stage of {bindable}",
                p.name,
            )));
        }
        let bindable = self.limits.max_uniform_buffers_per_shader_stage;
        if 1 + uniforms > bindable as u64 {
            return Err(GpuError::Unsupported(format!(
                "{}: {uniforms} uniform buffers of its own and the meta uniform, over the adapter's max_uniform_buffers_per_shader_stage of {bindable}",
                p.name,
            )));
        }
        if let Some(a) = p.arrange {
            if !(1..=GpuArrange::MAX_KEYS).contains(&a.keys) {
                return Err(GpuError::Program(format!(
                    "GPU program `{}`: {} ray keys, not 1 to {}",
                    p.name,
                    a.keys,
                    GpuArrange::MAX_KEYS
                )));
            }
        }
        if n_tris > u32::MAX as u64 {
            return Err(GpuError::Program(format!(
                "GPU program `{}`: {n_tris} triangles, more than a u32 counts",
                p.name
            )));
        }
        self.fits("the triangle array", n_tris * TRIANGLE_BYTES, true)?;
        for b in &p.buffers {
            if b.bytes.len() % 4 != 0 {
                return Err(GpuError::Program(format!(
                    "GPU program `{}`: {} has {} bytes, not a whole number of 4-byte words",
                    p.name,
                    b.what,
                    b.bytes.len()
                )));
            }
            if b.uniform {
                let most = self.limits.max_uniform_buffer_binding_size;
                if b.bytes.len() as u64 > most {
                    return Err(GpuError::Unsupported(format!(
                        "{}: {} has {} bytes, over the adapter's max_uniform_buffer_binding_size of {most}",
                        p.name,
                        b.what,
                        b.bytes.len()
                    )));
                }
            } else {
                self.fits(b.what, b.bytes.len() as u64, true)?;
            }
        }
        Ok(())
    }
}
