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
        // gpu_oracle on lavapipe: the trusted build (no bounds checks) answered differently
        // from the checked one on stress and Bunny rays, which points at an out-of-bounds
        // read the checks turn into zeros (suspected: the climb through `aug[rec].parent`
        // past the root); kept checked until found.
        .checked_only("its trusted build differs from the checked one on lavapipe")
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
