//! The GPU programs of the five traversals (`shaders/*.wgsl` on tb-gpu's prelude, contract in
//! `tb_core::gpu`): `stackless` (Feldmann 2015 section 4.1, Listing 1), `ordered` (section
//! 4.2, Listing 2; the paper's CUDA tracer used it for Tables 1 and 2) and `stack` (section
//! 5.2, the CPU-only reference of Table 3), and our variants `stackless-skip-empty` and
//! `ordered-pop-cull` (override constants `SKIP_EMPTY` and `POP_CULL` of the same sources,
//! programs of their own names). Each walks the packed level-order array in the CPU
//! traversal's order, so hits and per-ray counters agree with the CPU ray for ray.
//!
//! Bindings: the leaf-ordered triangles (3), the slot array unchanged, empty slots included
//! (5: `RtreeNode`, 32 bytes) and the primitive ids (6). The paper keeps the first slot of
//! every level, `Δ_L(l)`, and `L` in CUDA constant memory; in the complete layout the entry
//! relation `n_e(n) = (n − Δ_L(l))·M + Δ_L(l−1)` reduces to `M·n + 1` on every level, so the
//! kernels need only `Δ_L(0)` and `L`, which travel in the `meta_` uniform (WGSL's uniform
//! address space, the counterpart of constant memory): `meta = [slots, Δ_L(0), L]`. `M` is an
//! override constant and the stacks are sized for it, so there is one program per `M`
//! (`rtree/ordered-m4`, …): tb-gpu fixes constants and stack size per program name.
//!
//! No step cap: like the CPU walks, the kernels visit every slot at most once per ray and
//! `capped` stays 0. Size: the slot array is bound whole; where it exceeds the adapter's
//! `max_storage_buffer_binding_size` (Conference with `M = 4`: 695 MiB, over the 128 MiB many
//! adapters bind), tb-gpu refuses the upload with one line naming the array and the limit (the
//! row's note in a run). Splitting the array over several bindings would not rescue that case:
//! a program has 4 buffers of its own at most, and 4 × 128 MiB is still under 695 MiB.

use crate::{Rtree, MAX_LAYOUT_BYTES, MAX_LEVELS, MAX_M};
use std::borrow::Cow;
use tb_core::GpuProgram;

/// What the slot array is called in tb-gpu's errors (e.g. over the binding size).
pub const GPU_NODES: &str = "the R-tree's packed level-order slot array";

/// Program names per traversal, indexed by `M − 4`.
macro_rules! names {
    ($t:literal) => {
        names!($t; 4 5 6 7 8 9 10 11 12 13 14 15 16)
    };
    ($t:literal; $($m:literal)*) => {
        [$(concat!("rtree/", $t, "-m", $m)),*]
    };
}

const STACKLESS: [&str; MAX_M - 3] = names!("stackless");
const STACKLESS_SKIP_EMPTY: [&str; MAX_M - 3] = names!("stackless-skip-empty");
const ORDERED: [&str; MAX_M - 3] = names!("ordered");
const ORDERED_POP_CULL: [&str; MAX_M - 3] = names!("ordered-pop-cull");
const STACK: [&str; MAX_M - 3] = names!("stack");

/// The most levels (`L + 1`) of a tree [`Rtree::try_build`] accepts for this `M`: those
/// whose complete layout fits [`MAX_LAYOUT_BYTES`] (and fewer than `2^32` slots).
pub const fn max_levels(big_m: u32) -> u32 {
    let max_slots = MAX_LAYOUT_BYTES / std::mem::size_of::<crate::RtreeNode>() as u64;
    let (mut levels, mut slots, mut per_level) = (0u32, 0u64, 1u64);
    while levels < MAX_LEVELS as u32 {
        let next = slots + per_level;
        if next > max_slots || next >= u32::MAX as u64 {
            break;
        }
        slots = next;
        per_level *= big_m as u64;
        levels += 1;
    }
    levels
}

/// Entries of the `ordered` kernel's stacks: `M` per level above the leaves.
pub const fn ordered_stack(big_m: u32) -> u32 {
    (max_levels(big_m) - 1) * big_m
}

/// Entries of the `stack` kernel's stack: `M − 1` pending per level above the current node
/// and `M` at its own (`(L − 1)(M − 1) + M` for a root at level `L ≥ 1`).
pub const fn stack_stack(big_m: u32) -> u32 {
    (max_levels(big_m) - 2) * (big_m - 1) + big_m
}

impl Rtree {
    fn gpu(&self, names: &[&'static str], source: &'static str, stack: u32) -> GpuProgram<'_> {
        let m = self.params.big_m;
        debug_assert!(self.nodes.is_empty() || self.root_level < max_levels(m));
        GpuProgram::new(names[m as usize - 4], source, &self.triangles[..])
            .buffer(GPU_NODES, Cow::Borrowed(bytemuck::cast_slice(&self.nodes)))
            .buffer(
                "the R-tree's primitive-id array",
                Cow::Borrowed(bytemuck::cast_slice(&self.prim_ids)),
            )
            .meta([self.nodes.len() as u32, self.first_leaf, self.root_level])
            .stack(stack)
            .constant("M", m as f64)
            .include(tb_core::gpu::LEAF_RANGES)
    }

    fn stackless_program(&self, skip_empty: bool) -> GpuProgram<'_> {
        const SRC: &str = concat!(
            include_str!("../shaders/tree.wgsl"),
            include_str!("../shaders/stackless.wgsl")
        );
        let names = if skip_empty {
            &STACKLESS_SKIP_EMPTY
        } else {
            &STACKLESS
        };
        self.gpu(names, SRC, 0)
            .constant("SKIP_EMPTY", skip_empty as u8 as f64)
    }

    /// The GPU program of `stackless` (`shaders/stackless.wgsl`, Listing 1, no stack).
    pub(crate) fn gpu_stackless(&self) -> GpuProgram<'_> {
        self.stackless_program(false)
    }

    /// The GPU program of `stackless-skip-empty` (`shaders/stackless.wgsl`, `SKIP_EMPTY`).
    pub(crate) fn gpu_stackless_skip_empty(&self) -> GpuProgram<'_> {
        self.stackless_program(true)
    }

    fn ordered_program(&self, pop_cull: bool) -> GpuProgram<'_> {
        const SRC: &str = concat!(
            include_str!("../shaders/tree.wgsl"),
            include_str!("../shaders/ordered.wgsl")
        );
        let names = if pop_cull {
            &ORDERED_POP_CULL
        } else {
            &ORDERED
        };
        self.gpu(names, SRC, ordered_stack(self.params.big_m))
            .constant("POP_CULL", pop_cull as u8 as f64)
    }

    /// The GPU program of `ordered` (`shaders/ordered.wgsl`, Listing 2, per-level stacks).
    pub(crate) fn gpu_ordered(&self) -> GpuProgram<'_> {
        self.ordered_program(false)
    }

    /// The GPU program of `ordered-pop-cull` (`shaders/ordered.wgsl`, `POP_CULL`).
    pub(crate) fn gpu_ordered_pop_cull(&self) -> GpuProgram<'_> {
        self.ordered_program(true)
    }

    /// The GPU program of `stack` (`shaders/stack.wgsl`, Table 3's stack-based reference).
    pub(crate) fn gpu_stack(&self) -> GpuProgram<'_> {
        const SRC: &str = concat!(
            include_str!("../shaders/tree.wgsl"),
            include_str!("../shaders/stack.wgsl")
        );
        self.gpu(&STACK, SRC, stack_stack(self.params.big_m))
            .include(tb_core::gpu::STACK_POP)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::build;

    #[test]
    fn stacks_cover_every_tree_the_builder_accepts() {
        for m in 4..=MAX_M as u32 {
            let levels = max_levels(m);
            // One level more would be over the layout limit the builder enforces.
            let over =
                build::slot_count(m, levels).is_none_or(|n| n as u64 * 32 > MAX_LAYOUT_BYTES);
            assert!(over, "M = {m}: {levels} levels");
            assert!(build::slot_count(m, levels - 1).is_some());
            assert!(ordered_stack(m) >= (levels - 1) * m);
            assert!(stack_stack(m) >= m);
        }
        assert_eq!(max_levels(4), 14);
        assert_eq!(ordered_stack(4), 52);
        assert_eq!(stack_stack(4), 40);
        assert_eq!(STACKLESS[0], "rtree/stackless-m4");
        assert_eq!(ORDERED[MAX_M - 4], "rtree/ordered-m16");
    }
}
