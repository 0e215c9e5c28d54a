//! The GPU program of `sltr-mask` (our stackless variant of Havran and Bittner 2007 §5.3, not
//! the paper's Algorithm 3, which has no GPU kernel; docs/GPU.md).

use crate::SparseBoxes;
use std::borrow::Cow;
use tb_core::GpuProgram;

/// Little-endian-as-native bytes of `words` (GPU buffers).
fn bytes(words: impl Iterator<Item = u32>) -> Cow<'static, [u8]> {
    Cow::Owned(words.flat_map(|w| w.to_ne_bytes()).collect())
}

impl SparseBoxes {
    /// The GPU program of `sltr-mask` (`crates/sparse/shaders/sltr_mask.wgsl`): from the start
    /// node located per ray in the kernel (`start`, program `sparse-boxes/sltr-mask`) or from
    /// the root (`sparse-boxes/sltr-mask-root`). Buffers: the kd-tree's nodes and references, the augmented
    /// records, their depths followed by the step cap and the records' rank
    /// ([`tb_kdtree::NodeRank`], three words per 64 nodes: the bits' low and high words,
    /// the count before); meta: node count, record count, `d_min + 1`.
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
        .buffer(
            "the kd-tree node array",
            bytes(v.nodes().iter().flat_map(|n| [n.bits, n.data])),
        )
        .buffer(
            "the kd-tree reference array",
            bytes(v.refs().iter().copied()),
        )
        .buffer(
            "the augmented nodes",
            bytes(self.aug.iter().flat_map(|a| {
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
            "the augmented nodes' depths, the step cap and the rank",
            bytes(
                self.depth
                    .iter()
                    .map(|&d| d as u32)
                    .chain([self.params.step_cap])
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
