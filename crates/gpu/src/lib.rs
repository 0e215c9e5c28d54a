//! tb-gpu: the `gpu` device of trace-bench, through wgpu.
//!
//! - [`Gpu::new`] picks an adapter ([`AdapterChoice`]: a name substring and a [`Backend`]),
//!   opens a device with the adapter's own limits, and reports it ([`AdapterSummary`]).
//! - [`Gpu::upload`] copies a structure's flat `#[repr(C)]` arrays unchanged: the scene's
//!   triangles for brute force; for the BVH its 32-byte nodes, leaf-ordered triangles and
//!   primitive ids, exactly as the CPU traverses them (STYLE.md, "build, then flatten").
//! - [`Gpu::upload_rays`] copies a ray batch and allocates its hit and counter buffers;
//!   [`Gpu::trace`] runs one pass of a kernel over it (timed with GPU timestamp queries where
//!   the adapter has them, else wall time around submit-and-wait); [`Gpu::read_hits`] and
//!   [`Gpu::read_stats`] copy the results back, timed separately.
//!
//! Kernels (`shaders/*.wgsl`, one thread per ray, workgroups of [`WORKGROUP`]): brute force and
//! the BVH `ordered` traversal, each specialised at pipeline creation by WGSL override
//! constants for the query (closest / any), the triangle test (watertight / Möller–Trumbore)
//! and counting (timed pass without counters / counting pass writing the same per-ray
//! [`TraversalStats`] as the CPU). They repeat tb-core's arithmetic operation for operation,
//! so on an adapter that neither contracts `a*b+c` into FMA nor rounds division differently,
//! hits and counters equal the CPU's bit for bit; see the README's GPU section for what
//! Vulkan allows and what the tests check.
//!
//! Limits: a batch is split into dispatches of at most [`Gpu::max_rays_per_dispatch`] rays, so
//! that every bound buffer range respects `max_storage_buffer_binding_size` and the workgroup
//! count respects `max_compute_workgroups_per_dimension`; a structure array that exceeds the
//! binding size cannot be split (every ray may need all of it) and gives
//! [`GpuError::TooLarge`].

mod device;
mod kernels;

pub use device::{AdapterChoice, AdapterSummary, Backend, Gpu};
pub use kernels::{GpuRays, GpuStructure, Structure, Timing};

use tb_core::TraversalStats;

/// Threads per workgroup of every kernel (one ray per thread).
pub const WORKGROUP: u32 = 64;

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
    /// The adapter cannot run this kernel on this input correctly.
    #[error("{0}")]
    Unsupported(String),
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

/// Bytes of one [`TraversalStats`] record as the kernels write it.
pub const STATS_BYTES: u64 = std::mem::size_of::<TraversalStats>() as u64;

const _: () = assert!(STATS_BYTES == 32);
