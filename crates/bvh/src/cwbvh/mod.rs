//! The compressed wide BVH (CWBVH) of Ylitie, Karras and Laine 2017, "Efficient incoherent ray
//! traversal on GPUs through compressed wide BVHs" (HPG '17): the state of the art GPU BVH row
//! beside the papers' baselines. Structure `cwbvh`, traversal `node-groups`.
//!
//! - **Build** (module `build`, §3): a binary BVH of one triangle per leaf (`builder`: the SBVH
//!   by default, as the authors start from a high-quality binary tree, or the binned builder),
//!   collapsed into 8-wide nodes SAH-optimally by dynamic programming (§3.1; the BVH's
//!   `collapse = "sah"`, module `wide::collapse`) with leaves of at most `max_leaf` = 3
//!   triangles, priced `C_node` (`c_trav`) per node and `C_prim` (`c_isect`) per triangle.
//! - **Child order** (§3.2): each node's children are placed in its eight slots so that slot
//!   `s` holds the child a ray of octant `s` should visit first: the assignment minimising
//!   `Σ dot(c_child − c_node, d_s)`, `c` the box centres and `d_s` the diagonal direction of
//!   octant `s`. The authors solve it with an auction algorithm; here it is solved exactly
//!   (the Hungarian method, [`build::assign`]), which gives the same least total.
//! - **Node** ([`CwNode`], §3.3): 80 bytes. The node's box origin `p` and a power-of-two scale
//!   `2^e` per axis; per slot a `meta` byte (empty, interior child with its slot, or a leaf's
//!   triangle count in unary and its offset from the node's first triangle) and the child's
//!   box quantized to 8 bits per plane, rounded outwards; the interior children stored
//!   consecutively from `child_base` (their order the slots', `imask` marks which slots hold
//!   one), the leaves' triangles consecutively from `tri_base`.
//! - **Traversal** `node-groups` (module `walk`, §4, Algorithm 1): the stack holds *node
//!   groups*, a node's interior children still to visit as a bit mask (8 bits, permuted by the
//!   ray's octant so that the highest bit is the next child in the octant's order) with their
//!   first index and `imask`; a node's leaf hits form a *triangle group* (24 bits, one per
//!   triangle) tested before the next node. There are no distances on the stack: children are
//!   visited in the octant order, not sorted by entry distance.
//!
//! Our deviations, named: child boxes are decoded to `f32` (`p + q·2^e`, exact but for one
//! rounding, checked at build time to contain the child) and tested with tb-core's robust slab
//! test (Ize 2013), not the authors' fused-multiply-add form on the quantized values, so that
//! the walk agrees with the oracle on the stress scenes; the triangle test is the run's; the
//! GPU programs store uncompressed stack entries. The authors' triangle postponing (a lane's
//! triangles wait on its stack while few lanes of the warp test triangles) is the traversal
//! `node-groups-postponing` (run on request, GPU rows only: on the CPU a ray is a subgroup of
//! one, which never postpones); its threshold, 20 %, is the share reimplementations use.
//! The cost constants `C_node = 1`, `C_prim = 0.3` are the commonly reimplemented reading of
//! the authors' SAH (parameters here).
//!
//! Counters: `interior` per node intersected (the root included; it has no box test),
//! `boxes` per used slot of each node intersected, `leaves` per leaf child hit (its triangles
//! join the triangle group), `prims` per triangle test, `steps = interior + leaves`.

mod build;
mod check;
mod gpu;
mod walk;

use crate::{Builder, ObjectSplit};
use tb_core::params::ParamKind;
use tb_core::{
    build_with, dispatch, AccelError, BuildReport, Family, MemoryReport, Structure, Traversal,
    TraversalInfo, Triangle,
};

/// The most triangles a leaf slot holds: its count is written in unary (`0b001`, `0b011`,
/// `0b111`) in the top three bits of its `meta` byte.
pub const MAX_LEAF: u32 = 3;

/// Stack entries of the `node-groups` walk: one group a level at most (the binary tree's
/// depth bound, which the wide tree does not exceed).
pub const CW_STACK_SIZE: usize = crate::STACK_SIZE;

/// A node of the compressed wide BVH, 80 bytes (Ylitie, Karras and Laine 2017 §3.3, Figure 3).
///
/// Slot `s`'s box is `p[a] + q_lo[a][s]·2^(e[a] − 127)` to `p[a] + q_hi[a][s]·2^(e[a] − 127)`
/// per axis `a` (`e` is the scale's biased `f32` exponent). `meta[s]`:
/// - `0`: empty slot;
/// - interior child: `0b001` in the top three bits and `24 + s` below (`imask` bit `s` set);
///   its node is `child_base` plus the number of interior slots before `s`;
/// - leaf: its triangle count `n` in unary in the top three bits and its first triangle's
///   offset from `tri_base` (below 24) in the low five bits.
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct CwNode {
    /// Origin of the quantisation grid: the low corner of the node's box.
    pub p: [f32; 3],
    /// Per axis, the biased `f32` exponent of the quantisation scale.
    pub e: [u8; 3],
    /// Bit `s` set where slot `s` holds an interior child.
    pub imask: u8,
    /// Node index of the first interior child; the others follow in slot order.
    pub child_base: u32,
    /// Index of the first triangle of the node's leaves; its leaves' triangles follow.
    pub tri_base: u32,
    /// Per slot: empty, interior child or leaf (the encoding above).
    pub meta: [u8; 8],
    /// Per axis and slot: the quantised low plane of the slot's box.
    pub q_lo: [[u8; 8]; 3],
    /// Per axis and slot: the quantised high plane of the slot's box.
    pub q_hi: [[u8; 8]; 3],
}

const _: () = assert!(std::mem::size_of::<CwNode>() == 80);

impl CwNode {
    /// The scale of axis `a`: `2^(e[a] − 127)`.
    #[inline(always)]
    pub fn scale(&self, a: usize) -> f32 {
        f32::from_bits((self.e[a] as u32) << 23)
    }

    /// Slot `s`'s decoded box (min, max), as the walks compute it: `p + q·scale` per plane.
    #[inline(always)]
    pub fn child_box(&self, s: usize) -> ([f32; 3], [f32; 3]) {
        let d = |a: usize, q: u8| self.p[a] + q as f32 * self.scale(a);
        (
            [
                d(0, self.q_lo[0][s]),
                d(1, self.q_lo[1][s]),
                d(2, self.q_lo[2][s]),
            ],
            [
                d(0, self.q_hi[0][s]),
                d(1, self.q_hi[1][s]),
                d(2, self.q_hi[2][s]),
            ],
        )
    }

    /// Whether slot `s` holds an interior child.
    #[inline(always)]
    pub fn is_interior(&self, s: usize) -> bool {
        self.imask & (1 << s) != 0
    }

    /// The node index of interior slot `s`.
    #[inline(always)]
    pub fn child(&self, s: usize) -> u32 {
        self.child_base + (self.imask as u32 & ((1u32 << s) - 1)).count_ones()
    }

    /// Leaf slot `s`: its first triangle's offset from `tri_base` and its triangle count.
    #[inline(always)]
    pub fn leaf(&self, s: usize) -> (u32, u32) {
        let m = self.meta[s] as u32;
        (m & 31, (m >> 5).count_ones())
    }
}

tb_core::params! {
    /// Build parameters of [`Cwbvh::build`].
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct CwbvhParams {
        /// the binary tree's builder: `sbvh` (spatial splits, Stich et al. 2009; the authors
        /// start from a high-quality binary BVH) or `binned` (binned SAH, Wald 2007), one
        /// triangle per leaf either way
        builder: Builder = Builder::Sbvh, ParamKind::Choice(Builder::NAMES);
        /// SAH bins per axis of the binned builder (and of `object_split = "binned"`)
        bins: u32 = 16, ParamKind::Int { min: 2, max: 256 };
        /// SBVH overlap threshold (Stich et al. 2009 §4.4)
        alpha: f32 = 1e-5, ParamKind::Float { min: 0.0, max: 1.0 };
        /// SBVH object splits: `sweep` (full SAH sweep) or `binned`
        object_split: ObjectSplit = ObjectSplit::Sweep, ParamKind::Choice(ObjectSplit::NAMES);
        /// SAH cost of a wide node, C_node (of the binary build too)
        c_trav: f32 = 1.0, ParamKind::Float { min: 1e-6, max: 1e6 };
        /// SAH cost of a triangle test, C_prim
        c_isect: f32 = 0.3, ParamKind::Float { min: 1e-6, max: 1e6 };
        /// largest wide leaf, p_max (the node's meta byte holds at most 3 triangles a leaf)
        max_leaf: u32 = 3, ParamKind::Int { min: 1, max: 3 };
        /// build threads: 0 = the current rayon pool, n = a pool of n threads (the tree is
        /// the same for every count)
        build_threads: u32 = 0, ParamKind::Int { min: 0, max: 1024 };
    }
}

impl tb_core::ParamRules for CwbvhParams {}

impl CwbvhParams {
    /// The binary BVH the wide tree is collapsed from: one triangle per leaf.
    fn binary(&self) -> crate::BvhParams {
        crate::BvhParams {
            builder: self.builder,
            bins: self.bins,
            alpha: self.alpha,
            object_split: self.object_split,
            c_trav: self.c_trav,
            c_isect: self.c_isect,
            max_leaf: 1,
            min_leaf: 1,
            width: 2,
            leaf_cost: crate::LeafCost::Linear,
            build_threads: self.build_threads,
            ..crate::BvhParams::binary()
        }
    }
}

/// The compressed wide BVH in the registry.
pub static FAMILY: Family = Family::new::<Cwbvh, CwbvhParams>(
    "compressed 8-wide BVH: a binary SBVH (or binned BVH, `builder`) of one triangle per leaf \
     collapsed SAH-optimally into 8-wide nodes with leaves of at most `max_leaf` = 3 triangles, \
     children ordered per ray octant, child boxes quantized to 8 bits in 80-byte nodes; node- and \
     triangle-group stack traversal (Ylitie, Karras and Laine 2017)",
    |tris, set| build_with(set, |p: &CwbvhParams| Cwbvh::try_build(tris, p)),
)
.with_summary("compressed 8-wide BVH, 80-byte quantized nodes (Ylitie, Karras and Laine 2017)")
.with_rules::<CwbvhParams>()
.with_persist::<Cwbvh>()
.with_method(1, tb_core::FIRST_METHOD);

impl tb_core::Persist for Cwbvh {
    fn attach(
        &mut self,
        _tris: &std::sync::Arc<[Triangle]>,
        params: &tb_core::ParamSet,
    ) -> Result<(), tb_core::ParamError> {
        self.params = tb_core::persist::params_from(params)?;
        Ok(())
    }
}

/// A compressed wide BVH over triangles (see the module doc for the paper).
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct Cwbvh {
    #[serde(with = "tb_core::persist::pod")]
    nodes: Vec<CwNode>,
    /// The triangles in node order (each node's leaves consecutive from its `tri_base`).
    triangles: Vec<Triangle>,
    /// `prim_ids[i]` is the scene index of `triangles[i]`.
    prim_ids: Vec<u32>,
    n_scene: usize,
    /// Not saved by the build cache (its key): given back by [`tb_core::Persist::attach`].
    #[serde(skip)]
    params: CwbvhParams,
    /// The wide tree's SAH cost under the parameters' cost model (the boxes before
    /// quantization).
    sah: Option<f64>,
    /// The binary tree's node count.
    binary_nodes: usize,
}

impl Cwbvh {
    /// Build over `tris` with `params`; panics where [`Cwbvh::try_build`] fails. An empty
    /// input gives an empty tree (no nodes) that misses every ray.
    pub fn build(tris: &[Triangle], params: &CwbvhParams) -> Cwbvh {
        Self::try_build(tris, params).unwrap_or_else(|e| panic!("{e}"))
    }

    /// [`Cwbvh::build`] with an error instead of a panic: parameters out of their ranges, or
    /// too many triangles.
    pub fn try_build(tris: &[Triangle], params: &CwbvhParams) -> Result<Cwbvh, AccelError> {
        tb_core::ParamRules::check_all(params, "cwbvh")?;
        build::build(tris, params)
    }

    /// The nodes, root first (empty for an empty scene).
    pub fn nodes(&self) -> &[CwNode] {
        &self.nodes
    }

    /// The triangles in node order.
    pub fn triangles(&self) -> &[Triangle] {
        &self.triangles
    }

    /// `prim_ids()[i]` is the scene index of `triangles()[i]`.
    pub fn prim_ids(&self) -> &[u32] {
        &self.prim_ids
    }

    /// The parameters it was built with.
    pub fn params(&self) -> &CwbvhParams {
        &self.params
    }
}

impl Structure for Cwbvh {
    const NAME: &'static str = "cwbvh";
    const TRAVERSALS: &'static [Traversal<Self>] = &[
        Traversal::with_gpu(
        TraversalInfo::new(
            "node-groups",
            "Ylitie, Karras and Laine 2017 §4",
            "stack of node groups (a node's interior children still to visit, an 8-bit mask in \
             the ray octant's order) and triangle groups (a node's leaf hits, tested before the \
             next node), children in octant order without distance sorting, no cull on pop \
             (Ylitie, Karras and Laine 2017 §4, Algorithm 1)",
        ),
        tb_core::kernel!(|b: &Cwbvh, batch, out| dispatch(&walk::NodeGroups(b), batch, out)),
        Cwbvh::gpu_node_groups,
    ),
    Traversal::with_gpu(
        TraversalInfo::new(
            "node-groups-postponing",
            "Ylitie, Karras and Laine 2017 §4",
            "`node-groups` with the authors' triangle postponing on the GPU: a ray's triangle \
             group waits on its stack while fewer than a fifth of its subgroup's lanes test \
             triangles (a subgroup ballot; needs the adapter's subgroups); the GPU rows' counters \
             are the GPU's own. On the CPU, a subgroup of one ray: `node-groups` itself, so runs \
             make no CPU rows of it (Ylitie, Karras and Laine 2017 §4)",
        )
        .on_request()
        .cpu_as("node-groups"),
        tb_core::kernel!(|b: &Cwbvh, batch, out| dispatch(&walk::NodeGroups(b), batch, out)),
        Cwbvh::gpu_node_groups_postponing,
    )];

    /// The nodes (80 bytes each), the triangles in node order and their primitive ids;
    /// `structure_bytes` the nodes and 4 bytes a reference (as the BVH's).
    fn own_memory(&self) -> MemoryReport {
        let structure = std::mem::size_of_val(self.nodes.as_slice()) + 4 * self.prim_ids.len();
        MemoryReport {
            bytes: (structure + std::mem::size_of_val(self.triangles.as_slice())) as u64,
            structure_bytes: structure as u64,
            nodes: self.nodes.len() as u64,
            prim_refs: self.prim_ids.len() as u64,
            node_bytes: std::mem::size_of::<CwNode>() as u32,
        }
    }

    fn report(&self) -> BuildReport {
        self.report_figures()
    }

    /// Checks: child indices in range, after their parent and each node reached once; leaf
    /// slots of 1 to 3 triangles inside the triangle array, each triangle slot in exactly one
    /// leaf; `meta` and `imask` consistent; every decoded child box containing its subtree's
    /// triangles (the binned builder; the SBVH's boxes hold the triangles' parts clipped to
    /// them, so there each triangle must touch its leaf's box, and the build checks each
    /// decoded box against the builder's); every scene triangle referenced; the depth within
    /// the stack.
    fn check(&self) -> Result<(), AccelError> {
        self.check_invariants().map_err(AccelError::Invalid)
    }
}
