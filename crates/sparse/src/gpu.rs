//! The GPU program of `sltr-mask` (our stackless variant of Havran and Bittner 2007 §5.3, not
//! the paper's Algorithm 3, which has no GPU kernel; docs/GPU.md).

use crate::SparseBoxes;
use std::borrow::Cow;
use tb_core::gpu::words;
use tb_core::GpuProgram;
use tb_kdtree::gpu_header;

impl SparseBoxes {
    /// The GPU program of `sltr-mask` (`crates/sparse/shaders/sltr_mask.wgsl`): from the start
    /// node located per ray in the kernel (`start`, program `sparse-boxes/sltr-mask`) or from
    /// the root (`sparse-boxes/sltr-mask-root`), on the kd-tree family's WGSL
    /// ([`tb_kdtree::KD_WGSL`]: its node decoding, split decision and leaf test). Buffers: the
    /// kd-tree's nodes and references; the kd header ([`gpu_header`], a uniform buffer:
    /// depth-first, the root cell, the step cap in word 11); the augmented records; their
    /// depths followed by their rank ([`tb_kdtree::NodeRank`], three words per 64 nodes: the
    /// bits' low and high words, the count before); meta: node count, record count,
    /// `d_min + 1`.
    pub(crate) fn gpu_sltr_mask(&self, start: bool) -> GpuProgram<'_> {
        let v = self.kd.view();
        GpuProgram::new(
            if start {
                "sparse-boxes/sltr-mask"
            } else {
                "sparse-boxes/sltr-mask-root"
            },
            include_str!("../shaders/sltr_mask.wgsl"),
            Cow::Borrowed(v.triangles()),
        )
        // Its timed passes keep wgpu's loop bounding: without it, lavapipe's compiler (LLVM
        // 15, which may take a loop without side effects to end) gave 10-40 % of the stress
        // and paper-scene rays other answers than the checked build and the CPU, with
        // climbs from impossible depths (the timed variant's loops write nothing, its
        // counters being dead); with the bound and no bounds checks every ray agrees
        // (gpu_oracle). Found with a scratch test comparing the builds ray for ray.
        .bounded_loops(
            "lavapipe's compiler took its unbounded loops to end and answered differently",
        )
        .include(tb_kdtree::KD_WGSL)
        // No stack: one entry sizes the array of kd.wgsl's `recursive`, which it never calls.
        .stack(1)
        .buffer(
            "the kd-tree node array",
            words(v.nodes().iter().flat_map(|n| [n.bits, n.data])),
        )
        .buffer(
            "the kd-tree reference array",
            words(v.refs().iter().copied()),
        )
        .uniform(
            "the kd-tree header",
            words(gpu_header(
                self.kd.params(),
                [0; 4],
                self.kd.bounds(),
                self.params.step_cap,
            )),
        )
        .buffer(
            "the augmented nodes",
            words(self.aug.iter().flat_map(|a| {
                [
                    a.min[0].to_bits(),
                    a.min[1].to_bits(),
                    a.min[2].to_bits(),
                    a.parent,
                    a.max[0].to_bits(),
                    a.max[1].to_bits(),
                    a.max[2].to_bits(),
                    a.node,
                ]
            })),
        )
        .buffer(
            "the augmented nodes' depths and their rank",
            words(
                self.depth
                    .iter()
                    .map(|&d| d as u32)
                    .chain(self.rank.words()),
            ),
        )
        .meta([
            v.nodes().len() as u32,
            self.aug.len() as u32,
            self.params.period(),
        ])
        .constant("START", start as u32 as f64)
    }
}
