//! The compressed wide BVH's GPU programs (`shaders/cwbvh.wgsl`), traced with persistent threads
//! as the authors' kernel (Ylitie, Karras and Laine 2017 §4 build on Aila and Laine's persistent
//! kernels): `node-groups`, the CPU's walk step for step, and `node-groups-postponing`, with
//! the authors' triangle postponing.

use super::{Cwbvh, CW_STACK_SIZE};
use std::borrow::Cow;
use tb_core::GpuProgram;

impl Cwbvh {
    /// The program of `node-groups` (`shaders/cwbvh.wgsl` with `shaders/solo.wgsl`, the CPU's
    /// walk in the CPU's order): the triangles in node order, the 80-byte nodes as they are
    /// (five `vec4<u32>` loads a node), the primitive ids, the node count in `meta[0]`.
    pub(crate) fn gpu_node_groups(&self) -> GpuProgram<'_> {
        self.program("cwbvh/node-groups", include_str!("../../shaders/solo.wgsl"))
    }

    /// The program of `node-groups-postponing`: [`Cwbvh::gpu_node_groups`]'s with the
    /// subgroup of `shaders/subgroup.wgsl`, whose lanes postpone their triangles while few
    /// lanes test triangles (§4), so its counters depend on the other rays of the subgroup.
    pub(crate) fn gpu_node_groups_postponing(&self) -> GpuProgram<'_> {
        self.program(
            "cwbvh/node-groups-postponing",
            include_str!("../../shaders/subgroup.wgsl"),
        )
        // A step pushes at most one node group and one postponed triangle group, and a
        // popped triangle group postponed again is popped at once: two entries a level.
        .stack(2 * CW_STACK_SIZE as u32 + 1)
        .in_subgroups()
        .own_counts(
            "triangle postponing: a ray's triangles wait on its stack while few rays of its \
             subgroup test triangles, so its node visits depend on the subgroup",
        )
    }

    /// `shaders/cwbvh.wgsl` with the subgroup view `lanes`.
    fn program(&self, name: &'static str, lanes: &'static str) -> GpuProgram<'_> {
        GpuProgram::new(
            name,
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
        .include(lanes)
        .persistent()
    }
}
