//! The compressed wide BVH's GPU program: `node-groups` (`shaders/cwbvh.wgsl`), the CPU's walk
//! step for step, traced with persistent threads as the authors' kernel (Ylitie, Karras and
//! Laine 2017 §4 build on Aila and Laine's persistent kernels).

use super::{Cwbvh, CW_STACK_SIZE};
use std::borrow::Cow;
use tb_core::GpuProgram;

impl Cwbvh {
    /// The program of `node-groups`: the triangles in node order, the 80-byte nodes as they
    /// are (five `vec4<u32>` loads a node), the primitive ids, the node count in `meta[0]`.
    pub(crate) fn gpu_node_groups(&self) -> GpuProgram<'_> {
        GpuProgram::new(
            "cwbvh/node-groups",
            include_str!("../../shaders/cwbvh.wgsl"),
            &self.triangles[..],
        )
        .buffer(
            "the compressed node array",
            Cow::Borrowed(bytemuck::cast_slice(&self.nodes)),
        )
        .buffer(
            "the primitive-id array",
            Cow::Borrowed(bytemuck::cast_slice(&self.prim_ids)),
        )
        .meta([self.nodes.len() as u32, 0, 0])
        .stack(CW_STACK_SIZE as u32)
        .include(tb_core::gpu::LEAF_RANGES)
        .persistent()
    }
}
