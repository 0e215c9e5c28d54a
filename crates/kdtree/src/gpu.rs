//! The kd-tree's GPU programs (review §3-5 on the GPU; docs/GPU.md).

use crate::{KdLayout, KdParams, KdTree, MAX_SHORT_STACK, STACK_SIZE};
use tb_core::gpu::words;
use tb_core::{Aabb, GpuProgram};

/// The GPU kernels of `shaders/kdtree.wgsl` (its override constant `KERNEL`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum GpuKernel {
    Recursive = 0,
    Restart = 1,
    PushDown = 2,
    ShortStack = 3,
    Ropes = 4,
    Sequential = 5,
    Backtrack = 6,
}

/// The names of the `short-stack` GPU programs by stack size 1 ..= [`MAX_SHORT_STACK`] (the
/// size is the program's `STACK_SIZE`, so the compiler sizes the stack exactly).
const SHORT_STACK_PROGRAMS: [&str; MAX_SHORT_STACK] = [
    "kdtree/short-stack-1",
    "kdtree/short-stack-2",
    "kdtree/short-stack-3",
    "kdtree/short-stack-4",
    "kdtree/short-stack-5",
    "kdtree/short-stack-6",
    "kdtree/short-stack-7",
    "kdtree/short-stack-8",
    "kdtree/short-stack-9",
    "kdtree/short-stack-10",
    "kdtree/short-stack-11",
    "kdtree/short-stack-12",
    "kdtree/short-stack-13",
    "kdtree/short-stack-14",
    "kdtree/short-stack-15",
    "kdtree/short-stack-16",
    "kdtree/short-stack-17",
    "kdtree/short-stack-18",
    "kdtree/short-stack-19",
    "kdtree/short-stack-20",
    "kdtree/short-stack-21",
    "kdtree/short-stack-22",
    "kdtree/short-stack-23",
    "kdtree/short-stack-24",
    "kdtree/short-stack-25",
    "kdtree/short-stack-26",
    "kdtree/short-stack-27",
    "kdtree/short-stack-28",
    "kdtree/short-stack-29",
    "kdtree/short-stack-30",
    "kdtree/short-stack-31",
    "kdtree/short-stack-32",
];

/// The 12-word header of `shaders/kd.wgsl` (binding 7, a uniform buffer), which the programs
/// built on the kd-tree (multi-kd's, sparse boxes') fill too:
/// `starts` (words 0..=3: the kd-tree's start node; multi-kd's roots X, Y, Z and pick rule),
/// the layout (word 4: 0 depth-first, else the treelet block's slot mask), the start `cell`
/// (words 5..=10, f32 bits) and the restart-type traversals' `step_cap` (word 11).
pub fn gpu_header(params: &KdParams, starts: [u32; 4], cell: Aabb, step_cap: u32) -> [u32; 12] {
    let mask = match params.layout {
        KdLayout::DepthFirst => 0,
        KdLayout::Treelet => (1u32 << params.treelet_height) - 1,
    };
    let (b0, b1) = (cell.min, cell.max);
    let [s0, s1, s2, s3] = starts;
    [
        s0,
        s1,
        s2,
        s3,
        mask,
        b0.x.to_bits(),
        b0.y.to_bits(),
        b0.z.to_bits(),
        b1.x.to_bits(),
        b1.y.to_bits(),
        b1.z.to_bits(),
        step_cap,
    ]
}

/// The kd-tree family's shared WGSL (`shaders/kd.wgsl`): the node array, references and header,
/// the interior decision and leaf loop, the recursive walk. The kd-tree's programs and those
/// of the structures built on it (the multi-kd-tree's, sparse boxes') include it through
/// tb-gpu ([`GpuProgram::include`]).
pub const KD_WGSL: &str = include_str!("../shaders/kd.wgsl");

/// The programs' source after [`KD_WGSL`]: the short stack's placement, `shaders/kdtree.wgsl`.
const SOURCE: &str = concat!(
    "const SHORT_IN_REGISTERS: bool = false;\nconst SHORT_ON_CHIP: bool = false;\nconst SHORT_SLOTS: u32 = 1u;\nconst LOCAL_SLOTS: u32 = STACK_SIZE;\n",
    include_str!("../shaders/kdtree.wgsl")
);

/// [`SOURCE`] with the short stack on chip: `STACK_SIZE` entries per invocation in workgroup
/// memory (Horn et al. 2007's short stack in fast memory; review §5.2).
const SOURCE_ON_CHIP: &str = concat!(
    "const SHORT_IN_REGISTERS: bool = false;\nconst SHORT_ON_CHIP: bool = true;\nconst SHORT_SLOTS: u32 = WORKGROUP_SIZE * STACK_SIZE;\nconst LOCAL_SLOTS: u32 = 1u;\n",
    include_str!("../shaders/kdtree.wgsl")
);

/// The largest short stack kept on chip: 16 entries of 16 bytes for each of a workgroup's 64
/// invocations fill the 16 KiB of workgroup memory WebGPU guarantees.
pub(crate) const MAX_ON_CHIP_SHORT_STACK: usize = 16;

/// The largest short stack kept in registers (`shaders/kdtree.wgsl` `REG_SLOTS`: 8 entries of
/// 16 bytes, 32 registers, shifted on push and pop with constant indices).
pub(crate) const MAX_REGISTER_SHORT_STACK: usize = 8;

/// [`SOURCE`] with the short stack in registers: `shaders/kdtree.wgsl`'s `reg_push` and
/// `reg_pop`.
const SOURCE_IN_REGISTERS: &str = concat!(
    "const SHORT_IN_REGISTERS: bool = true;\nconst SHORT_ON_CHIP: bool = false;\nconst SHORT_SLOTS: u32 = 1u;\nconst LOCAL_SLOTS: u32 = 1u;\n",
    include_str!("../shaders/kdtree.wgsl")
);

/// The GPU programs (`shaders/kd.wgsl` then `shaders/kdtree.wgsl`, on tb-gpu's prelude; README
/// "GPU"): one per traversal, each the CPU kernel's walk in the CPU's order with the same
/// decisions (so the counters agree ray for ray), in either layout, from the tree's start.
impl KdTree {
    /// The program `name` running `kernel`: the triangles in scene order; buffers: the node
    /// array (two words per [`KdNode`]), the references, a 12-word header (the start node; the
    /// layout: 0 depth-first, else the treelet block's slot mask; the start cell; the step cap)
    /// and the auxiliary arrays (`backtrack`: [`KdTree::back_nodes`]; `ropes`: [`Ropes::words`],
    /// the leaves' rank then their records, [`KdTree::ropes`]; else one unused word); meta
    /// word: the node count. The stack holds
    /// [`STACK_SIZE`] entries for `recursive-direction`, [`KdParams::short_stack`] for
    /// `short-stack` (the circular stack; one program per size, [`SHORT_STACK_PROGRAMS`], since
    /// a program's stack size is fixed by its name), none for the others.
    pub(crate) fn gpu(&self, name: &'static str, kernel: GpuKernel) -> GpuProgram<'_> {
        let header = gpu_header(
            &self.params,
            [self.start.node, 0, 0, 0],
            self.start.cell,
            self.params.step_cap,
        );
        let back = || {
            self.back_nodes().iter().flat_map(|b| {
                let (lo, hi) = (b.min.map(f32::to_bits), b.max.map(f32::to_bits));
                [lo[0], lo[1], lo[2], b.parent, hi[0], hi[1], hi[2], 0]
            })
        };
        let aux = match kernel {
            GpuKernel::Ropes => words(self.ropes().words()),
            GpuKernel::Backtrack => words(back()),
            _ => words([0]),
        };
        let stack_size = match kernel {
            GpuKernel::Recursive => STACK_SIZE,
            GpuKernel::ShortStack => self.params.short_stack as usize,
            _ => 1,
        };
        let source = match kernel {
            GpuKernel::ShortStack if stack_size <= MAX_REGISTER_SHORT_STACK => SOURCE_IN_REGISTERS,
            GpuKernel::ShortStack if stack_size <= MAX_ON_CHIP_SHORT_STACK => SOURCE_ON_CHIP,
            _ => SOURCE,
        };
        GpuProgram::new(name, source, &self.tris[..])
            .include(KD_WGSL)
            .buffer(
                "the kd-tree node array",
                words(self.nodes.iter().flat_map(|n| [n.bits, n.data])),
            )
            .buffer(
                "the kd-tree reference array",
                words(self.prim_refs.iter().copied()),
            )
            .uniform("the kd-tree header", words(header))
            .buffer("the kd-tree cell, parent and rope arrays", aux)
            .meta([self.nodes.len() as u32, 0, 0])
            .stack(stack_size as u32)
            .constant("KERNEL", kernel as u32 as f64)
    }

    /// `recursive-direction` with its full stack in the invocation's memory (review §3.2,
    /// Alg. 2; Novák 2009's finding, review §5.2: a conventional stack in memory is viable on
    /// GPUs).
    pub(crate) fn gpu_recursive(&self) -> GpuProgram<'_> {
        self.gpu("kdtree/recursive-direction", GpuKernel::Recursive)
    }

    /// `restart` (Foley and Sugerman 2005; review §5.1).
    pub(crate) fn gpu_restart(&self) -> GpuProgram<'_> {
        self.gpu("kdtree/restart", GpuKernel::Restart)
    }

    /// `push-down` (Horn et al. 2007; review §5.2, Alg. 4).
    pub(crate) fn gpu_push_down(&self) -> GpuProgram<'_> {
        self.gpu("kdtree/push-down", GpuKernel::PushDown)
    }

    /// `short-stack` (Horn et al. 2007; review §5.2): program `kdtree/short-stack-N` with a
    /// circular stack of `N = short_stack` entries, in registers for `N` up to
    /// [`MAX_REGISTER_SHORT_STACK`], on chip (workgroup memory) up to
    /// [`MAX_ON_CHIP_SHORT_STACK`], in the invocation's memory above.
    pub(crate) fn gpu_short_stack(&self) -> GpuProgram<'_> {
        let name = SHORT_STACK_PROGRAMS[self.params.short_stack as usize - 1];
        self.gpu(name, GpuKernel::ShortStack)
    }

    /// `sequential` (Kaplan 1985; review §3.1, Alg. 1).
    pub(crate) fn gpu_sequential(&self) -> GpuProgram<'_> {
        self.gpu("kdtree/sequential", GpuKernel::Sequential)
    }

    /// `backtrack` (Foley and Sugerman 2005; review §5.1.1, Alg. 3): reads the cells and
    /// parents.
    pub(crate) fn gpu_backtrack(&self) -> GpuProgram<'_> {
        self.gpu("kdtree/backtrack", GpuKernel::Backtrack)
    }

    /// `ropes` (Havran et al. 1998, Popov et al. 2007; review §3.3): reads the leaves' cells and
    /// ropes.
    pub(crate) fn gpu_ropes(&self) -> GpuProgram<'_> {
        self.gpu("kdtree/ropes", GpuKernel::Ropes)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::KdParams;
    use tb_core::{Accel, Triangle, Vec3};

    /// The short stack is in registers up to [`MAX_REGISTER_SHORT_STACK`] entries, on chip
    /// (workgroup memory) up to [`MAX_ON_CHIP_SHORT_STACK`] and in the invocation's memory
    /// above; no other program places one in either.
    #[test]
    fn short_stacks_in_registers_then_on_chip() {
        let tris: Vec<Triangle> = (0..32)
            .map(|i| {
                let p = Vec3::new(i as f32, (i % 5) as f32, (i % 3) as f32);
                Triangle::new(p, p + Vec3::X, p + Vec3::Y)
            })
            .collect();
        let on_chip = |short_stack: u32, traversal: &str| {
            let kd = KdTree::build(
                &tris,
                &KdParams {
                    short_stack,
                    ..Default::default()
                },
            );
            let i = Accel::traversals(&kd)
                .iter()
                .position(|t| t.name == traversal)
                .unwrap();
            let p = kd.gpu_program(i).expect("a GPU program");
            let registers = p.source.contains("const SHORT_IN_REGISTERS: bool = true;");
            let chip = p.source.contains("const SHORT_ON_CHIP: bool = true;");
            (registers, chip)
        };
        for n in [1, 4, 8] {
            assert_eq!(on_chip(n, "short-stack"), (true, false), "{n}");
        }
        for n in [9, 16] {
            assert_eq!(on_chip(n, "short-stack"), (false, true), "{n}");
        }
        for n in [17, 32] {
            assert_eq!(on_chip(n, "short-stack"), (false, false), "{n}");
        }
        assert_eq!(on_chip(4, "recursive-direction"), (false, false));
        assert_eq!(on_chip(4, "push-down"), (false, false));
    }
}
