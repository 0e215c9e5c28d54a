//! The project's baseline: a bounding volume hierarchy over triangles. The default build
//! (`name = "bvh"`) is the BVH8 from the binned builder with leaves priced per block of four
//! (`width = 8, leaf_cost = "blocks"`), the best general configuration measured: as fast as
//! the SBVH's BVH8 on every ray kind, built 4-7x faster (docs/PERFORMANCE.md, "The default BVH");
//! [`BvhParams::binary`] is the binary binned BVH, the classic baseline and the secondary-ray
//! generator.
//!
//! - **Build** ([`Bvh::build`], module `build`): top-down, splitting each node where the surface
//!   area heuristic (SAH; Goldsmith and Salmon 1987, MacDonald and Booth 1990) is smallest
//!   among the bin boundaries of the centroid bounds on all three axes (binned SAH, Wald 2007,
//!   "On fast construction of SAH-based bounding volume hierarchies"). The builder sees one box
//!   and its centre per triangle, partitions an array of primitive references in place (no
//!   allocation per node), and falls back to object-median splits where SAH cannot separate
//!   primitives (coincident centroids, zero-area nodes) so leaves never exceed `max_leaf`.
//! - **Layout**: flattened to 32-byte [`BvhNode`]s with the two children of an interior node
//!   adjacent (pbrt-v3 §4.3.4 "Compact BVH for traversal", with sibling pairs instead of
//!   left-child-next); triangles are copied into leaf order, [`Bvh::prim_ids`] maps back to the
//!   scene's indices. The arrays are plain `#[repr(C)]` data, uploadable to a GPU unchanged.
//! - **SBVH** (`builder = "sbvh"`, module `sbvh`): object splits by a full SAH sweep (or
//!   binned, `object_split`) and spatial splits with the overlap
//!   threshold `alpha` and reference unsplitting (Stich, Friedrich and Dietrich 2009), the
//!   triangles clipped by `tb_core::clip` (shared with the kd-tree builder); a triangle may be
//!   referenced by several leaves, so `validate` checks coverage instead of a permutation.
//! - **Parallel builds**: both builders split large nodes on the current rayon pool (or a pool
//!   of `build_threads`), giving the same tree as one thread.
//! - **Wide BVHs** (`width = 4` or `8`, module `wide`): collapsed from the binary tree,
//!   SAH-optimally by dynamic programming (Ylitie, Karras and Laine 2017 §3.1; `collapse`),
//!   child boxes in SoA layout tested at once with SSE or AVX (runtime detection, the AVX walk
//!   compiled for AVX-512 where the CPU has it, scalar fallback), nearest child first, leaves
//!   in SoA blocks of four triangles (their SAH price per block with `leaf_cost = "blocks"`);
//!   GPU program `shaders/wide.wgsl`.
//! - **Traversal** `ordered` (module `traverse`): depth-first with a fixed-size stack, both
//!   children's boxes tested at their parent and the nearer visited first (pbrt-v3 §4.3.5), the
//!   slab test made robust as in Ize 2013, "Robust BVH ray traversal" (see [`Aabb::intersect`]).
//! - **Traversal** `while-while` (module `while_while`, run on request): Aila and Laine's GPU
//!   trace kernel (2009; the 2012 addendum), the baseline of the irregular-grid and multi-kd
//!   papers, on the binary nodes, with persistent threads on the GPU; `while-while-speculative`
//!   adds their speculative traversal (a subgroup vote) on the GPU.
//! - **Compressed wide BVH** (structure `cwbvh`, module `cwbvh`, [`CWBVH_FAMILY`]): Ylitie,
//!   Karras and Laine 2017's 80-byte quantized 8-wide nodes over this crate's binary SBVH and
//!   SAH-optimal collapse, children in octant slots, and their node-group traversal; the
//!   state of the art GPU row beside the papers' baselines.

#![deny(missing_docs)]

mod build;
mod check;
mod cwbvh;
mod gpu;
mod node;
mod params;
mod report;
mod sbvh;
mod traverse;
mod while_while;
mod wide;

use std::sync::Arc;
use tb_core::{
    build_with, dispatch, Aabb, AccelError, BuildReport, Family, MemoryReport, ParamError,
    ParamSet, Structure, Traversal, TraversalInfo, Triangle,
};

pub use cwbvh::{
    CwNode, Cwbvh, CwbvhParams, CW_STACK_SIZE, FAMILY as CWBVH_FAMILY, MAX_LEAF as CW_MAX_LEAF,
};
pub use node::BvhNode;
pub use params::{Builder, BvhParams, Collapse, LeafCost, ObjectSplit, Simd};
pub use traverse::STACK_SIZE;
pub use wide::{LeafBlock, WideNode, EMPTY_SLOT, WIDE_STACK_SIZE};

/// The BVH in the registry.
pub static FAMILY: Family = Family::new::<Bvh, BvhParams>(
    "binned SAH BVH or SBVH (`builder`; the SBVH's object splits by a full SAH sweep or binned, \
     `object_split`), binary with 32-byte nodes or 4/8-wide with SIMD child-box tests (`width`), \
     the wide trees collapsed SAH-optimally by dynamic programming or greedily (`collapse`), a \
     leaf of n triangles priced at n or at ⌈n/4⌉ SoA blocks of four in the SAH (`leaf_cost = \
     \"linear\"` or `\"blocks\"`, both builders and the collapse); default: BVH8 from the binned \
     builder, leaves priced per block (the binary binned BVH: `builder = \"binned\", width = 2, leaf_cost \
     = \"linear\"`) (MacDonald and Booth 1990; Wald 2007; Stich et al. 2009; Wald et al. 2008; \
     Ylitie, Karras and Laine 2017)",
    |tris, set| {
        build_with(set, |p: &BvhParams| {
            p.check()?;
            Bvh::try_build(tris, p)
        })
    },
)
.with_summary(
    "binned SAH BVH or SBVH, binary or 4/8-wide (MacDonald and Booth 1990; Stich et al. 2009; \
     Ylitie et al. 2017)",
)
.with_rules::<BvhParams>()
.with_persist::<Bvh>()
.with_method(1, tb_core::FIRST_METHOD);

/// A binned SAH BVH over triangles (see the crate doc for the papers).
///
/// Per-ray counters (`TraversalStats`) of the `ordered` traversal:
/// - `boxes`: ray–box slab tests (1 for the root, then 2 per interior node visited);
/// - `interior`: interior nodes visited; `leaves`: leaves visited;
/// - `prims`: ray–triangle tests;
/// - `steps`: nodes visited, interior or leaf (`steps == interior + leaves`); a stack entry
///   discarded on pop because a closer hit was found meanwhile is not a step;
/// - `planes`, `restarts`: always 0.
///
/// `while-while` counts the same way, without the root's box test (`boxes` is 2 per interior
/// node visited) and with no entry discarded on pop (module `while_while`).
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct Bvh {
    #[serde(with = "tb_core::persist::pod")]
    nodes: Vec<BvhNode>,
    wide: WideNodes,
    /// Wide builds: the leaves' triangles in blocks of four (see [`LeafBlock`]).
    blocks: Vec<LeafBlock>,
    /// The triangle slot of each block's lane 0.
    block_first: Vec<u32>,
    triangles: Vec<Triangle>,
    prim_ids: Vec<u32>,
    /// Triangles in the scene (`prim_ids` holds each once, or at least once for the SBVH).
    n_scene: usize,
    /// Not saved by the build cache (its key): given back by [`Persist::attach`].
    #[serde(skip)]
    params: BvhParams,
    /// SBVH spatial splits refused by the reference allowance
    /// ([`sbvh::MAX_REFS_PER_TRIANGLE`]; 0 on every paper scene).
    refused_splits: u64,
}

/// The wide nodes of a build with `width` 4 or 8 (collapsed from [`Bvh::nodes`]).
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub enum WideNodes {
    /// `width = 2`: the binary nodes are traversed.
    None,
    /// `width = 4`: nodes of four child slots.
    W4(#[serde(with = "tb_core::persist::pod")] Vec<WideNode<4>>),
    /// `width = 8`: nodes of eight child slots.
    W8(#[serde(with = "tb_core::persist::pod")] Vec<WideNode<8>>),
}

impl Bvh {
    /// The wide walk over `nodes` (width `N`, this build's), with the leaf blocks and the
    /// binary root, on the instruction set the CPU and [`BvhParams::simd`] allow.
    fn wide_walk<'a, const N: usize>(&'a self, nodes: &'a [WideNode<N>]) -> wide::Wide<'a, N> {
        wide::Wide {
            nodes,
            blocks: &self.blocks,
            isa: wide::Isa::detect(N, self.params.simd == Simd::Scalar),
            root: self.nodes.first(),
        }
    }

    /// Build a BVH over `tris` with `params` (on the current rayon pool, or on a pool of
    /// `params.build_threads`; the same tree either way). Panics if `params.check()`
    /// fails or there are `u32::MAX` or more triangles.
    ///
    /// An empty input gives an empty BVH (no nodes) that misses every ray.
    pub fn build(tris: &[Triangle], params: &BvhParams) -> Bvh {
        if let Err(e) = params.check() {
            panic!("invalid BVH parameters: {e}");
        }
        Self::try_build(tris, params).unwrap_or_else(|e| panic!("{e}"))
    }

    /// [`Bvh::build`] with an error instead of a panic for too many triangles (parameters
    /// must pass [`BvhParams::check`]).
    pub fn try_build(tris: &[Triangle], params: &BvhParams) -> Result<Bvh, AccelError> {
        if params.build_threads > 0 {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(params.build_threads as usize)
                .build()
                .map_err(|e| AccelError::Unsupported(format!("BVH build pool: {e}")))?;
            return pool.install(|| Self::build_here(tris, params));
        }
        Self::build_here(tris, params)
    }

    /// [`Bvh::try_build`] on the current rayon pool.
    fn build_here(tris: &[Triangle], params: &BvhParams) -> Result<Bvh, AccelError> {
        if tris.len() >= u32::MAX as usize {
            return Err(AccelError::TooLarge {
                what: "BVH triangles",
                count: tris.len() as u64,
                limit: u32::MAX as u64 - 1,
            });
        }
        let (nodes, order, refused) = match params.builder {
            Builder::Binned => {
                let (n, o) = build::build(tris, params);
                (n, o, 0)
            }
            Builder::Sbvh => sbvh::build(tris, params),
        };
        if order.len() >= u32::MAX as usize {
            return Err(AccelError::TooLarge {
                what: "SBVH triangle references",
                count: order.len() as u64,
                limit: u32::MAX as u64 - 1,
            });
        }
        let triangles: Vec<Triangle> = order.iter().map(|&i| tris[i as usize]).collect();
        let cost = wide::CostModel::of(params);
        let (wide, (blocks, block_first)) = match params.width {
            4 => {
                let mut w = wide::collapse::<4>(&nodes, params.collapse, &cost);
                let b = wide::pack_leaves(&mut w, &triangles, &order);
                (WideNodes::W4(w), b)
            }
            8 => {
                let mut w = wide::collapse::<8>(&nodes, params.collapse, &cost);
                let b = wide::pack_leaves(&mut w, &triangles, &order);
                (WideNodes::W8(w), b)
            }
            _ => (WideNodes::None, (Vec::new(), Vec::new())),
        };
        Ok(Bvh {
            nodes,
            wide,
            blocks,
            block_first,
            triangles,
            prim_ids: order,
            n_scene: tris.len(),
            params: *params,
            refused_splits: refused,
        })
    }

    /// The flattened nodes, root first (see [`BvhNode`]). Empty for an empty scene (which
    /// every ray misses).
    #[inline(always)]
    pub fn nodes(&self) -> &[BvhNode] {
        &self.nodes
    }

    /// The wide nodes (root first) of a build with `width` 4 or 8.
    pub fn wide_nodes(&self) -> &WideNodes {
        &self.wide
    }

    /// Wide builds: the leaves' triangles in blocks of four, which the wide nodes' leaf slots
    /// name (empty for `width = 2`).
    pub fn leaf_blocks(&self) -> &[LeafBlock] {
        &self.blocks
    }

    /// The triangles in leaf order (leaf `l` owns `triangles()[l.prim_range()]`).
    pub fn triangles(&self) -> &[Triangle] {
        &self.triangles
    }

    /// `prim_ids()[i]` is the scene index of `triangles()[i]`.
    pub fn prim_ids(&self) -> &[u32] {
        &self.prim_ids
    }

    /// The parameters it was built with.
    pub fn params(&self) -> &BvhParams {
        &self.params
    }
}

impl tb_core::Persist for Bvh {
    fn attach(&mut self, _tris: &Arc<[Triangle]>, params: &ParamSet) -> Result<(), ParamError> {
        self.params = tb_core::persist::params_from(params)?;
        Ok(())
    }
}

impl Structure for Bvh {
    const NAME: &'static str = "bvh";
    const TRAVERSALS: &'static [Traversal<Self>] = &[
        Traversal::with_gpu(
            TraversalInfo::new(
                "ordered",
                "pbrt-v3 §4.3.5; Ize 2013",
                "ordered depth-first with a stack, nearer child first (both child boxes tested at \
             the parent; pbrt-v3 §4.3.5; robust slab test, Ize 2013)",
            ),
            tb_core::kernel!(|b: &Bvh, batch, out| match &b.wide {
                WideNodes::None => dispatch(&traverse::Ordered(b), batch, out),
                WideNodes::W4(nodes) => dispatch(&b.wide_walk(nodes), batch, out),
                WideNodes::W8(nodes) => dispatch(&b.wide_walk(nodes), batch, out),
            }),
            Bvh::gpu_ordered,
        ),
        Traversal::with_gpu(
            TraversalInfo::new(
                "while-while",
                "Aila and Laine 2009; Aila, Laine and Karras 2012",
                "Aila and Laine's while-while GPU kernel, the papers' SBVH baseline (Pérard-Gayot \
             et al. 2017 §6.2; Torres et al. 2012 §6): an inner loop over interior nodes (both \
             child boxes tested, nearer first, node indices on the stack, no cull on pop, no \
             root box test), then the leaf's triangles; binary nodes (a wide build's binary \
             tree); the GPU program traces with persistent threads (Aila and Laine 2009; \
             Aila, Laine and Karras 2012)",
            )
            .on_request(),
            tb_core::kernel!(|b: &Bvh, batch, out| dispatch(
                &while_while::WhileWhile(b),
                batch,
                out
            )),
            Bvh::gpu_while_while,
        ),
        Traversal::with_gpu(
            TraversalInfo::new(
                "while-while-speculative",
                "Aila and Laine 2009",
                "`while-while` with Aila and Laine's speculative traversal on the GPU: the first \
                 leaf reached is set aside and interior nodes are visited until every ray of the \
                 subgroup has one (a subgroup vote; needs the adapter's subgroups); the GPU rows' \
                 counters are the GPU's own (they depend on the subgroup). On the CPU, a subgroup \
                 of one ray: `while-while` itself, so runs make no CPU rows of it (Aila and \
                 Laine 2009)",
            )
            .on_request()
            .cpu_as("while-while"),
            tb_core::kernel!(|b: &Bvh, batch, out| dispatch(
                &while_while::WhileWhile(b),
                batch,
                out
            )),
            Bvh::gpu_while_while_speculative,
        ),
    ];

    /// The arrays the CPU traversal reads: the binary nodes, the triangles and the primitive
    /// ids (`width = 2`), or the wide nodes and the leaf blocks (triangles and primitive ids
    /// in blocks of four) and the triangles and primitive ids (kept for the GPU program).
    ///
    /// `structure_bytes`, the tree alone (as Pérard-Gayot et al.'s Table 2 compares the
    /// SBVH's memory with a grid's cells and references): the traversed nodes (binary or
    /// wide) and 4 bytes a reference (`prim_ids`, one per leaf entry, SBVH duplicates
    /// included); not the triangles copied in leaf order nor the leaf blocks (those copies
    /// in SoA form, with the references' ids beside them).
    fn own_memory(&self) -> MemoryReport {
        let (node_bytes, nodes, node_size) = match &self.wide {
            WideNodes::None => (
                std::mem::size_of_val(self.nodes()),
                self.nodes().len(),
                std::mem::size_of::<BvhNode>(),
            ),
            WideNodes::W4(w) => (
                std::mem::size_of_val(w.as_slice()),
                w.len(),
                std::mem::size_of::<WideNode<4>>(),
            ),
            WideNodes::W8(w) => (
                std::mem::size_of_val(w.as_slice()),
                w.len(),
                std::mem::size_of::<WideNode<8>>(),
            ),
        };
        let structure = node_bytes + std::mem::size_of_val(self.prim_ids.as_slice());
        MemoryReport {
            bytes: (structure
                + std::mem::size_of_val(self.blocks.as_slice())
                + std::mem::size_of_val(self.triangles.as_slice())) as u64,
            structure_bytes: structure as u64,
            nodes: nodes as u64,
            prim_refs: self.prim_ids.len() as u64,
            node_bytes: node_size as u32,
        }
    }

    /// The build report: see `report.rs`.
    fn report(&self) -> BuildReport {
        self.report_figures()
    }

    /// Checks: node indices in range with children after their parent (so no cycles), every
    /// node reachable exactly once, depth within the traversal stack, every child box inside
    /// its parent's, every triangle's box inside its leaf's, every triangle slot in exactly
    /// one leaf, `prim_ids` a permutation of the scene's indices, leaves of at most
    /// `max_leaf` triangles unless all their centroids coincide.
    fn check(&self) -> Result<(), AccelError> {
        self.check_invariants().map_err(AccelError::Invalid)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tb_core::Accel;
    use tb_core::Vec3;

    fn grid() -> Vec<Triangle> {
        (0..64)
            .map(|i| {
                let p = Vec3::new((i % 8) as f32, (i / 8) as f32, (i % 3) as f32);
                Triangle::new(p, p + Vec3::X * 0.9, p + Vec3::Y * 0.9)
            })
            .collect()
    }

    /// `structure_bytes` is the traversed nodes and 4 bytes a reference; `bytes` adds
    /// exactly the triangles in leaf order and the leaf blocks, for every width and builder.
    #[test]
    fn structure_bytes_are_the_tree_alone() {
        let tris = grid();
        for builder in [Builder::Binned, Builder::Sbvh] {
            for width in [2, 4, 8] {
                let p = BvhParams {
                    builder,
                    width,
                    ..BvhParams::default()
                };
                let b = Bvh::build(&tris, &p);
                let m = b.memory();
                let refs = b.prim_ids.len() as u64;
                let nodes = m.nodes * m.node_bytes as u64;
                assert_eq!(m.structure_bytes, nodes + 4 * refs, "{builder:?} {width}");
                let copies = std::mem::size_of_val(b.triangles.as_slice())
                    + std::mem::size_of_val(b.blocks.as_slice());
                assert_eq!(
                    m.bytes - m.structure_bytes,
                    copies as u64,
                    "{builder:?} {width}"
                );
                assert_eq!(b.triangles.len() as u64, refs);
                assert_eq!(b.blocks.is_empty(), width == 2);
                assert_eq!(b.memory_for(0), m);
            }
        }
    }

    /// `paper_bytes` is Aila and Laine's compact layout of the binary tree: 64 bytes an
    /// interior node, 60 a reference (Woop triangle and index slots), 20 a leaf (sentinel);
    /// a wide tree has none (the layout is binary).
    #[test]
    fn paper_bytes_are_aila_laines_layout() {
        let tris = grid();
        for builder in [Builder::Binned, Builder::Sbvh] {
            let p = BvhParams {
                builder,
                width: 2,
                ..BvhParams::default()
            };
            let b = Bvh::build(&tris, &p);
            let r = Accel::build_report(&b);
            let get = |k: &str| r.extra.iter().find(|(n, _)| n == k).map(|e| e.1);
            let (nodes, leaves) = (get("nodes").unwrap(), get("leaves").unwrap());
            let refs = b.prim_ids.len() as f64;
            assert!(leaves > 1.0 && refs >= 64.0, "{builder:?}");
            assert_eq!(
                get("paper_bytes"),
                Some(64.0 * (nodes - leaves) + 60.0 * refs + 20.0 * leaves),
                "{builder:?}"
            );
            let wide = Bvh::build(&tris, &BvhParams { width: 4, ..p });
            assert_eq!(
                Accel::build_report(&wide)
                    .extra
                    .iter()
                    .find(|(n, _)| n == "paper_bytes"),
                None
            );
        }
    }

    #[test]
    fn validate_finds_corruption() {
        let good = Bvh::build(&grid(), &BvhParams::binary());
        assert_eq!(good.validate(), Ok(()));
        let err = |b: &Bvh| b.validate().unwrap_err().to_string();
        let first_leaf = good.nodes().iter().position(|n| n.is_leaf()).unwrap();
        let interior = good.nodes().iter().rposition(|n| !n.is_leaf()).unwrap();

        let mut b = good.clone();
        let left = b.nodes[0].index as usize;
        b.nodes[left].max[0] += 100.0;
        assert!(err(&b).contains("not inside its parent"));

        let mut b = good.clone();
        b.nodes[first_leaf].min[1] += 0.5;
        assert!(b.validate().is_err());

        let mut b = good.clone();
        b.prim_ids[1] = b.prim_ids[0];
        assert!(err(&b).contains("twice"));

        let mut b = good.clone();
        b.nodes[interior].index = 0;
        assert!(err(&b).contains("children"));

        let mut b = good.clone();
        b.nodes[first_leaf].count = 60;
        assert!(b.validate().is_err());

        let mut b = good.clone();
        b.nodes.push(BvhNode::EMPTY);
        assert!(err(&b).contains("unreachable"));
    }
}
