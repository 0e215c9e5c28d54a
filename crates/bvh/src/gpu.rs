//! The BVH's GPU programs: `ordered` on the binary nodes (`shaders/bvh.wgsl`) and on the wide
//! ones (`shaders/wide.wgsl`), and `while-while` on the binary nodes with persistent threads
//! (`shaders/while_while.wgsl`), the CPU's walks in the CPU's order (docs/GPU.md); and
//! `while-while-speculative`, the same walk with Aila and Laine's subgroup vote.

use crate::{wide, Bvh, WideNode, WideNodes, STACK_SIZE, WIDE_STACK_SIZE};
use std::borrow::Cow;
use tb_core::GpuProgram;

impl Bvh {
    /// The wide program of [`Bvh::gpu_ordered`].
    pub(crate) fn gpu_wide(
        &self,
        name: &'static str,
        bytes: Vec<u8>,
        n: usize,
        width: u32,
    ) -> GpuProgram<'_> {
        GpuProgram::new(
            name,
            include_str!("../shaders/wide.wgsl"),
            &self.triangles[..],
        )
        .buffer("the wide BVH node array", Cow::Owned(bytes))
        .buffer(
            "the primitive-id array",
            Cow::Borrowed(bytemuck::cast_slice(&self.prim_ids)),
        )
        .uniform(
            "the binary root node",
            Cow::Borrowed(bytemuck::cast_slice(&self.nodes[..1])),
        )
        .meta([n as u32, 0, 0])
        .stack(WIDE_STACK_SIZE as u32)
        .constant("WIDTH", width as f64)
        .include(tb_core::gpu::LEAF_RANGES)
    }

    /// The GPU program of `ordered` (`shaders/bvh.wgsl`, the same walk in the same order):
    /// the leaf-ordered triangles, the nodes and primitive ids as they are, the node count in
    /// `meta[0]`.
    ///
    /// Wide builds get `shaders/wide.wgsl` (programs `bvh/ordered-w4`, `bvh/ordered-w8`, the
    /// wide walk in the CPU's order): the wide nodes (leaves naming their first triangle in
    /// the leaf-ordered triangles, not their first block), the primitive ids and the binary
    /// root node (a uniform buffer; its box is tested first), the wide node count in `meta[0]`.
    pub(crate) fn gpu_ordered(&self) -> GpuProgram<'_> {
        fn bytes<const N: usize>(w: &[WideNode<N>], first: &[u32]) -> Vec<u8> {
            bytemuck::cast_slice(&wide::unpack_leaves(w, first)).to_vec()
        }
        let first = &self.block_first;
        match &self.wide {
            WideNodes::W4(w) if !w.is_empty() => {
                return self.gpu_wide("bvh/ordered-w4", bytes(w, first), w.len(), 4)
            }
            WideNodes::W8(w) if !w.is_empty() => {
                return self.gpu_wide("bvh/ordered-w8", bytes(w, first), w.len(), 8)
            }
            _ => {}
        }
        self.binary("bvh/ordered", include_str!("../shaders/bvh.wgsl"))
            .include(tb_core::gpu::STACK_POP)
    }

    /// The GPU program of `while-while` (`shaders/while_while.wgsl` with `shaders/solo.wgsl`,
    /// Aila and Laine's kernel, the CPU's walk in the CPU's order), traced with persistent
    /// threads: the leaf-ordered triangles, the binary nodes (a wide build's binary tree) and
    /// the primitive ids, the node count in `meta[0]`.
    pub(crate) fn gpu_while_while(&self) -> GpuProgram<'_> {
        self.while_while("bvh/while-while", include_str!("../shaders/solo.wgsl"))
    }

    /// The GPU program of `while-while-speculative`: [`Bvh::gpu_while_while`]'s with the
    /// subgroup vote of `shaders/subgroup.wgsl` (Aila and Laine 2009's speculative
    /// traversal), so its counters depend on the other rays of the subgroup.
    pub(crate) fn gpu_while_while_speculative(&self) -> GpuProgram<'_> {
        self.while_while(
            "bvh/while-while-speculative",
            include_str!("../shaders/subgroup.wgsl"),
        )
        .in_subgroups()
        .own_counts(
            "speculative traversal: a ray's walk goes on past a leaf until every ray of its \
             subgroup has one, so its steps depend on the adapter's subgroup size and the other rays",
        )
    }

    /// `shaders/while_while.wgsl` with the vote `all_lanes` of `vote`.
    fn while_while(&self, name: &'static str, vote: &'static str) -> GpuProgram<'_> {
        self.binary(name, include_str!("../shaders/while_while.wgsl"))
            .include(vote)
            .persistent()
    }

    /// A program `name` of `source` over the binary nodes (`shaders/binary.wgsl` included
    /// before it): the leaf-ordered triangles, the nodes and primitive ids as they are, the
    /// node count in `meta[0]`, the binary walks' stack, the shared leaf loop.
    fn binary(&self, name: &'static str, source: &'static str) -> GpuProgram<'_> {
        GpuProgram::new(name, source, &self.triangles[..])
            .buffer(
                "the BVH node array",
                Cow::Borrowed(bytemuck::cast_slice(&self.nodes)),
            )
            .buffer(
                "the primitive-id array",
                Cow::Borrowed(bytemuck::cast_slice(&self.prim_ids)),
            )
            .meta([self.nodes.len() as u32, 0, 0])
            .stack(STACK_SIZE as u32)
            .include(include_str!("../shaders/binary.wgsl"))
            .include(tb_core::gpu::LEAF_RANGES)
    }
}
