//! Persistent threads (`tb_core::GpuProgram::persistent`; Aila and Laine 2009): a dispatch of
//! at most [`Gpu::set_persistent_groups`] workgroups, each fetching runs of rays from a counter
//! until none is left (`shaders/persistent.wgsl` states the counter's arithmetic).

use crate::device::Gpu;
use crate::WORKGROUP;

/// Workgroups a persistent program's dispatch launches at most (fewer for a batch of fewer
/// runs of rays): 4096 of [`WORKGROUP`] threads, 262,144 threads, more than a large GPU keeps
/// resident at once (an H200: 132 SMs of at most 2048 threads), so that the pool fills any
/// GPU; workgroups that start after the rays are all taken end at their first fetch. Aila and
/// Laine launch "just enough" threads, a figure the adapter does not report here.
pub const PERSISTENT_GROUPS: u32 = 4096;

/// The fetch counters of one pass of a persistent program: one per dispatch chunk, each at
/// its own aligned offset, zeroed (wgpu zeroes a new buffer).
pub(crate) struct Pool {
    buffer: wgpu::Buffer,
    stride: u64,
    groups: u32,
}

impl Pool {
    /// Counters for `chunks` dispatches.
    pub(crate) fn new(gpu: &Gpu, chunks: usize) -> Pool {
        let stride = gpu.limits.min_storage_buffer_offset_alignment.max(4) as u64;
        let buffer = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("persistent threads' fetch counters"),
            size: stride * chunks.max(1) as u64,
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        Pool {
            buffer,
            stride,
            groups: gpu.persistent_groups,
        }
    }

    /// The counter of chunk `c`: its buffer and offset (bound as 4 bytes).
    pub(crate) fn counter(&self, c: usize) -> (&wgpu::Buffer, u64) {
        (&self.buffer, c as u64 * self.stride)
    }

    /// Workgroups of the dispatch of `len` rays.
    pub(crate) fn workgroups(&self, len: u64) -> u32 {
        len.div_ceil(WORKGROUP as u64).min(self.groups as u64) as u32
    }

    /// `passes`, or fewer, so that a pass's fetches (a run of rays each, one more per
    /// workgroup) times the passes stay within the u32 counter.
    pub(crate) fn most_passes(&self, passes: u32, chunks: &[(u64, u64)]) -> u32 {
        let most = chunks
            .iter()
            .map(|&(_, len)| len.div_ceil(WORKGROUP as u64) + self.workgroups(len) as u64)
            .max()
            .unwrap_or(1);
        passes.min((u32::MAX as u64 / most.max(1)) as u32).max(1)
    }
}

impl Gpu {
    /// Workgroups a persistent program's dispatch launches at most ([`PERSISTENT_GROUPS`] by
    /// default): tests make each workgroup fetch many runs of rays.
    pub fn set_persistent_groups(&mut self, groups: u32) {
        self.persistent_groups = groups.max(1);
    }
}
