//! The multi-kd-tree's GPU programs (Torres et al. 2012 §6 on the GPU; docs/GPU.md).

use crate::measure::Heuristic;
use crate::MultiKdTree;
use tb_core::gpu::words;
use tb_core::{GpuArrange, GpuProgram};
use tb_kdtree::{gpu_header, STACK_SIZE};

impl MultiKdTree {
    /// The GPU program of `recursive-direction` (`shaders/kd.wgsl`'s `recursive` from the ray's
    /// root, picked in `shaders/multikd.wgsl`: the CPU kernel's walk
    /// in the CPU's order, so the counters agree ray for ray): the triangles in scene order,
    /// the node array, the references and a 12-word header (roots X, Y, Z; the pick rule; the
    /// layout; the root cell), the node count in `meta[0]`.
    pub(crate) fn gpu_recursive_direction(&self) -> GpuProgram<'_> {
        self.gpu_program(None)
    }

    /// The GPU program of `recursive-direction-sorted`: [`Self::gpu_recursive_direction`]'s
    /// walk of the rays of each dispatch stably sorted by tree index (tb-gpu's sort pass on
    /// `shaders/multikd.wgsl`'s `ray_key`, the header's pick rule: 3 keys), the sort timed
    /// with the trace (the paper's "inc.").
    pub(crate) fn gpu_sorted(&self) -> GpuProgram<'_> {
        self.gpu_program(Some(true))
    }

    /// The GPU program of `recursive-direction-presorted`: as [`Self::gpu_sorted`], the sort
    /// run but not counted in the trace time (the paper's "n.inc.").
    pub(crate) fn gpu_presorted(&self) -> GpuProgram<'_> {
        self.gpu_program(Some(false))
    }

    /// The `recursive-direction` program, its rays sorted by tree index first when `sort` is
    /// `Some(timed)`, traced with persistent threads: the paper's kernel TI "is actually the
    /// algorithm persistent while-while by (Aila and Laine, 2009) adapted to kd-trees"
    /// (Torres et al. 2012 §6); which thread traces a ray changes, not the walk.
    pub(crate) fn gpu_program(&self, sort: Option<bool>) -> GpuProgram<'_> {
        let nodes = self.nodes.iter().flat_map(|n| [n.bits, n.data]);
        let rule = match self.pick {
            Heuristic::Sah => 0,
            Heuristic::CubeOrth | Heuristic::CubeObli => 1,
            _ => 2,
        };
        let [x, y, z] = self.header;
        let header = gpu_header(&self.params.kd, [x, y, z, rule], self.bounds, 0);
        GpuProgram::new(
            if sort.is_some() {
                "multi-kd/recursive-direction-sorted"
            } else {
                "multi-kd/recursive-direction"
            },
            include_str!("../shaders/multikd.wgsl"),
            &self.tris[..],
        )
        .include(tb_kdtree::KD_WGSL)
        .buffer("the multi-kd-tree node array", words(nodes))
        .buffer(
            "the multi-kd-tree reference array",
            words(self.refs.iter().copied()),
        )
        .uniform("the multi-kd-tree header", words(header))
        .meta([self.nodes.len() as u32, 0, 0])
        .stack(STACK_SIZE as u32)
        .arranged(sort.map(|timed| GpuArrange {
            keys: self.header.len() as u32,
            timed,
        }))
        .persistent()
    }
}
