//! tb-gpu: the `gpu` device of trace-bench, through wgpu. It knows no structure: a structure
//! hands it a wgpu-free [`GpuProgram`] (`tb_core::gpu`, [`tb_core::Accel::gpu_program`]) —
//! its WGSL, triangles, read-only buffers as bytes, meta words, stack size and override
//! constants — and tb-gpu compiles, uploads, binds and dispatches it.
//!
//! - [`Gpu::new`] picks an adapter ([`AdapterChoice`]: a name substring and a [`Backend`]),
//!   opens a device with the adapter's own limits, and reports it ([`AdapterSummary`]).
//! - [`Gpu::upload`] copies a program's arrays unchanged (STYLE.md, "build, then flatten"):
//!   the triangles (three `vec4<f32>` each, `w` = 0) at binding 3, the `meta_` uniform `(triangles, meta[0],
//!   meta[1], meta[2])` at 4, the program's buffers at 5, 6, … (read-only storage, or uniform
//!   where the program says); it gives a [`GpuStructure`].
//! - [`Gpu::upload_rays`] copies a ray batch and allocates its hit and counter buffers;
//!   [`Gpu::trace`] runs one pass of a program over it (timed with GPU timestamp queries where
//!   the adapter has them, else wall time around submit-and-wait); [`Gpu::read_hits`] and
//!   [`Gpu::read_stats`] copy the results back, timed separately.
//!
//! Programs (one thread per ray, workgroups of [`WORKGROUP`]): the shader module of a program
//! is `const STACK_SIZE` ([`GpuProgram::stack_size`]), `const WORKGROUP_SIZE`, the `Stats`
//! record generated from tb-core's counter list ([`tb_core::stats::wgsl_stats_struct`]), the
//! common prelude (`shaders/prelude.wgsl`: the bindings 0–4, `Ray`, `Hit`, the slab test, both
//! triangle tests, `trace_ray` calling the program's `walk`), the watertight test's edge
//! fallback (`shaders/edge_f64.wgsl` on adapters with `SHADER_F64`, else `edge_f32.wgsl`), the
//! program's source, then the entry point `main` (`shaders/entry.wgsl`, a thread per ray, or
//! for a [`GpuProgram::persistent`] program `shaders/persistent.wgsl`: at most
//! [`PERSISTENT_GROUPS`] workgroups fetching runs of rays from a counter bound after the
//! program's buffers, module `persistent`); the contract is stated in `tb_core::gpu`.
//! Modules are compiled once per program name, bind group layouts made once per number of
//! program buffers, and pipelines once per (program, query, triangle test, counting): WGSL
//! override constants pick the query (`ANY`), the triangle test (`WATERTIGHT`, watertight /
//! Möller–Trumbore) and counting (`COUNT`: the timed pass writes no counters, the counting pass
//! the same per-ray [`TraversalStats`] as the CPU), with the program's own constants added.
//! The prelude repeats tb-core's arithmetic operation for operation, and a structure's kernel
//! visits nodes in its CPU traversal's order, so on an adapter that neither contracts `a*b+c`
//! into FMA nor rounds division differently, hits and counters equal the CPU's bit for bit;
//! see docs/GPU.md for what Vulkan allows and what the tests check
//! (`crates/harness/tests/gpu_oracle.rs` checks every registered program against the CPU).
//!
//! Ray arrangement: a program with a ray key ([`GpuProgram::arrange`], [`GpuArrange`]) gets
//! `shaders/arrange.wgsl` in place of `shaders/unsorted.wgsl` before its source: per dispatch,
//! a stable counting sort of the rays' indices by `ray_key` in three compute passes
//! (per-workgroup histograms, one exclusive scan in key-major order, a scatter by
//! in-workgroup rank) into a permutation (group 1), submitted as its own compute pass before
//! the trace and timed on its own ([`Timing::sort_ms`]); `main` then traces ray `perm[i]` in
//! thread `i`, writing its hit and counters at the ray's own index. [`Gpu::read_order`] reads
//! the permutation back (tests).
//!
//! Limits: a batch is split into dispatches of at most [`Gpu::max_rays_per_dispatch`] rays, so
//! that every bound buffer range respects `max_storage_buffer_binding_size` and the workgroup
//! count respects `max_compute_workgroups_per_dimension`; a program's array that exceeds the
//! binding size cannot be split (every ray may need all of it) and gives
//! [`GpuError::TooLarge`]; a program may have as many storage buffers as
//! `max_storage_buffers_per_shader_stage` leaves beside the 4 common storage buffers, the
//! sort's and a persistent program's counter (4 on every WebGPU adapter without those), and uniform buffers ([`GpuProgram::uniform`]: per-dispatch
//! constants such as a header) within `max_uniform_buffers_per_shader_stage` beside `meta_`
//! and `max_uniform_buffer_binding_size`. A program that computes in `f64` ([`GpuProgram::needs_f64`]) is
//! refused ([`GpuError::Unsupported`], one line) on an adapter without `SHADER_F64`.

#![deny(missing_docs)]

mod admit;
mod device;
mod kernels;
mod persistent;
mod probe;
mod trace;

pub use device::{AdapterChoice, AdapterSummary, Backend, Gpu};
pub use kernels::checked_only as timed_passes_checked;
pub use persistent::PERSISTENT_GROUPS;
pub use probe::PROBE_MIN_MS;
pub use tb_core::{GpuArrange, GpuBuffer, GpuProgram};
pub use trace::{GpuRays, GpuStructure, Timing, MAX_PASSES, MIN_SAMPLE_MS};

use tb_core::TraversalStats;

/// Threads per workgroup of every kernel (one ray per thread).
pub const WORKGROUP: u32 = 64;

/// The GPU driver's method version: how programs are dispatched (persistent threads, ray
/// order) and timed (timestamp queries, sustained timing), written as `gpu=N` in every GPU
/// row's `method` (the kernels themselves are their families'). 1: method versions begin
/// (2026-12-08).
pub const METHOD: u32 = 1;

/// Environment variable that makes the GPU tests fail, rather than skip, without an adapter.
pub const REQUIRE_GPU_ENV: &str = "TRACE_BENCH_REQUIRE_GPU";

/// Why the GPU device could not do what was asked. Every message is one line.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    /// No adapter matched the backend and name filter.
    #[error("no GPU adapter found ({0})")]
    NoAdapter(String),
    /// The adapter refused to open a device.
    #[error("GPU adapter {adapter}: cannot open a device: {message}")]
    RequestDevice {
        /// The adapter's name.
        adapter: String,
        /// wgpu's reason, on one line.
        message: String,
    },
    /// An array is larger than one storage binding may be on this adapter.
    #[error("{what} needs {bytes} bytes, over the adapter's max_storage_buffer_binding_size of {limit} bytes (max_buffer_size {max_buffer}); the scene cannot be traced on this GPU")]
    TooLarge {
        /// Which array.
        what: &'static str,
        /// Its size.
        bytes: u64,
        /// The adapter's `max_storage_buffer_binding_size`.
        limit: u64,
        /// The adapter's `max_buffer_size`.
        max_buffer: u64,
    },
    /// The adapter cannot run this program on this input correctly.
    #[error("{0}")]
    Unsupported(String),
    /// The structure's program breaks the contract of `tb_core::gpu` (a buffer that is not
    /// whole 4-byte words, a name reused with other code, WGSL that does not compile).
    #[error("{0}")]
    Program(String),
    /// wgpu reported a validation or out-of-memory error.
    #[error("GPU error: {0}")]
    Wgpu(String),
    /// The device was lost or a wait failed (driver reset, timeout).
    #[error("GPU device lost: {0}")]
    Lost(String),
}

/// `true` when `TRACE_BENCH_REQUIRE_GPU` is set to a value other than `0` or empty.
pub fn gpu_required_by_env() -> bool {
    std::env::var(REQUIRE_GPU_ENV).is_ok_and(|v| !v.is_empty() && v != "0")
}

/// The default adapter for a test: `Some` (its label printed), or `None` with a printed
/// notice, so that the test skips on a machine without one; panics instead when
/// [`gpu_required_by_env`].
pub fn open_or_skip() -> Option<Gpu> {
    match Gpu::new(&AdapterChoice::default()) {
        Ok(g) => {
            println!("GPU adapter: {}", g.adapter().label());
            Some(g)
        }
        Err(e) if gpu_required_by_env() => {
            panic!("{e} ({REQUIRE_GPU_ENV} is set, so this fails rather than skips)")
        }
        Err(e) => {
            println!("skipped: {e} (set {REQUIRE_GPU_ENV}=1 to make this a failure)");
            None
        }
    }
}

/// Bytes of one [`TraversalStats`] record as the kernels write it (one `u32` per counter of
/// [`tb_core::COUNTERS`], then `capped`).
pub const STATS_BYTES: u64 = std::mem::size_of::<TraversalStats>() as u64;

/// Collapse a multi-line wgpu message into one line.
pub(crate) fn one_line(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}
