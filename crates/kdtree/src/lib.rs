//! A kd-tree over triangles built with the surface area heuristic and *perfect splits*, with
//! the traversal algorithms reviewed by Hapala and Havran 2011, "Review: Kd-tree traversal
//! algorithms for ray tracing" (CGF 30(1)).
//!
//! - **Build** ([`KdTree::build`], module `build`; [`KdBuilder`]: exact O(N log N) sweep,
//!   the same with per-node sorting, or binned): top-down SAH (MacDonald and Booth 1990) over
//!   the exact split candidates of the triangles *clipped to the node cell* (Sutherland–Hodgman;
//!   Havran 2000, Wald and Havran 2006 "On building fast kd-trees for ray tracing, and on doing
//!   that in O(N log N)"): start, end and planar events per axis, planar triangles put on the
//!   cheaper side, an empty-space bonus, termination when the leaf is not costlier than the
//!   best split or at the depth limit. The cost measure is pluggable ([`BoxMeasure`]).
//!   Parameters: [`KdParams`], declared with their defaults, ranges and docs; the registry
//!   builds through [`FAMILY`].
//! - **Layout** (review §6, module `layout`): 8-byte [`KdNode`]s, leaves pointing into
//!   [`KdTree::prim_refs`] (original triangle indices), in depth-first order with the left
//!   child next to its parent (§6.1, the default) or in treelets: subtrees of a few levels in
//!   aligned blocks, children inside a block addressed implicitly (§6.2, Havran 1999).
//!   Every traversal is compiled per layout ([`Layout`]) and visits the same nodes in both.
//! - **Traversals** (the table `<KdTree as Structure>::TRAVERSALS`: name, paper and section,
//!   step cap, auxiliary arrays read, kernel): module `traverse`, the stack-based algorithms
//!   of review §3.2 (`recursive-direction`, `havran` (TA^B_rec), `recursive-origin`) and §5
//!   (`branchless`, `stack-spilling`); module `stackless`, the restart-type ones of §3.1, §3.3,
//!   §5.1, §5.2 (`restart`, `push-down`, `short-stack`, `sequential`, `backtrack`, `ropes`).
//!   `recursive-origin` (origins in split planes) is inherently not robust; the others answer
//!   every ray of the conformance suite as brute force does.
//! - **Views and starts** (module `view`): the kernels read a borrowed [`KdView`] (nodes,
//!   references, triangles, root cell, layout, the parameters they need) and begin every walk
//!   at a [`KdStart`] (a node and its cell): the root, or a node below it that then plays the
//!   root's part for every traversal ([`KdTree::subtree`]). Trees may share one triangle array
//!   ([`KdTree::build_shared`]). The auxiliary arrays of `backtrack` ([`BackNode`]: cell and
//!   parent per node) and `ropes` ([`LeafRopes`]: cell and six ropes per leaf, as the review
//!   stores them) are built only when one of those
//!   traversals is traced or prepared; each traversal's memory figure counts the arrays it
//!   reads, built or not (review Table 3, "additional memory").
//!
//! - **GPU** (`shaders/kd.wgsl`, `shaders/kdtree.wgsl`; docs/GPU.md): `recursive-direction`
//!   with its full stack in the invocation's memory (review §3.2; Novák 2009, review §5.2: a
//!   conventional stack in memory is viable on GPUs), `restart` (§5.1), `push-down` (§5.2),
//!   `short-stack` (§5.2), `backtrack` (§5.1.1), `sequential` (§3.1) and `ropes` (§3.3) as
//!   programs `kdtree/NAME`, both layouts, each the CPU kernel's walk decision for decision, so
//!   hits and counters agree ray for ray (tests `gpu.rs`; tb-harness `gpu_oracle`).
//! - **Multi-kd-trees** (Torres et al. 2012) live in their own crate, `tb-multikd`, built
//!   on this one: its trees are this crate's builds (with another cell measure,
//!   [`BoxMeasure`]) and its walks this crate's kernels ([`traverse`], [`stackless`]) from the
//!   root of each ray's tree, its GPU program this crate's `shaders/kd.wgsl` walk.
//!
//! Robustness: triangle tests are never restricted to a leaf's interval (only to
//! `[tmin, closest hit)`), and traversal stops only when the next node to visit starts beyond
//! the closest hit found, so a hit found in a leaf beyond that leaf's exit never ends the walk
//! early. Clipped triangle boxes are made conservative (see `build`), so every triangle is
//! referenced in every leaf cell it touches.

#![deny(missing_docs)]

mod build;
mod check;
mod gpu;
pub mod layout;
mod node;
mod params;
mod report;
pub mod stackless;
pub mod traverse;
pub mod view;
mod walks;

#[cfg(test)]
mod start_tests;

use std::sync::Arc;
use tb_core::{
    build_with, dispatch, Aabb, AccelError, BuildReport, Family, MemoryReport, Structure,
    Traversal, TraversalInfo, Triangle,
};
use traverse::Tree;

pub use check::{check_trees, intersect, split_cell};
pub use gpu::{gpu_header, KD_WGSL};
pub use layout::{DepthFirst, KdLayout, Layout, Nodes, Treelet};
pub use node::KdNode;
pub use params::{BoxMeasure, KdBuilder, KdParams, SahParams, SurfaceArea};
pub use stackless::{Located, MAX_SHORT_STACK, STEP_CAP};
pub use traverse::{split_decision, Best, Decision, Kind, SLACK, STACK_SIZE};
pub use view::{AuxArrays, BackNode, KdStart, KdView, LeafRopes, NodeRank, Ropes};

/// Bytes of auxiliary array `aux` over `nodes` (the node array, unused treelet slots
/// included) of which `leaves` are leaves ([`BACKTRACK_AUX`]: cell and parent per node;
/// [`ROPES_AUX`]: cell and six ropes per leaf and the leaves' rank), built or not, for every
/// structure over kd nodes.
pub fn aux_bytes(aux: &str, nodes: usize, leaves: usize) -> u64 {
    match aux {
        BACKTRACK_AUX => (std::mem::size_of::<BackNode>() * nodes) as u64,
        ROPES_AUX => Ropes::bytes_for(leaves, nodes),
        _ => 0,
    }
}

/// The auxiliary array of cells and parents ([`KdTree::back_nodes`]), read by `backtrack`.
pub const BACKTRACK_AUX: &str = "backtrack";
/// The auxiliary array of the leaves' cells and six ropes ([`KdTree::ropes`]), read by `ropes`.
pub const ROPES_AUX: &str = "ropes";

/// The kd-tree in the registry.
pub static FAMILY: Family = Family::new::<KdTree, KdParams>(
    "SAH kd-tree with perfect splits (exact sweep O(N log N) / O(N log² N), min-max binning, \
     its candidates also at the box bounds beside each boundary unless `snap = false`), \
     8-byte nodes in depth-first or treelet layout (`layout`, `treelet_height`; Hapala and Havran \
     2011 §6); `step_cap` ends restart-type walks (counted in `capped_rays`)",
    |tris, set| {
        build_with(set, |p: &KdParams| {
            KdTree::try_build(tris.clone(), p, &SurfaceArea)
        })
    },
)
.with_summary(
    "SAH kd-tree with perfect splits and the kd-tree review's traversals (Hapala and Havran 2011)",
)
.with_rules::<KdParams>()
.with_persist::<KdTree>()
.with_method(1, tb_core::FIRST_METHOD);

impl tb_core::Persist for KdTree {
    fn attach(
        &mut self,
        tris: &Arc<[Triangle]>,
        params: &tb_core::ParamSet,
    ) -> Result<(), tb_core::ParamError> {
        self.tris = tris.clone();
        self.params = tb_core::persist::params_from(params)?;
        Ok(())
    }
}

/// A kd-tree over triangles (see the crate doc): its nodes, references and triangles (shared:
/// several trees may index one triangle array), the root cell, its parameters, the start of
/// every traversal's walks (the root, or a node of [`KdTree::subtree`]) and the auxiliary
/// arrays of `backtrack` and `ropes`, built on first use ([`KdTree::back_nodes`],
/// [`KdTree::ropes`]) and shared by clones.
///
/// Per-ray counters (`TraversalStats`) of the stack traversals (the restart-type ones count
/// as documented in module `stackless`: `restarts` and cell-interval `boxes` added):
/// - `interior`: interior nodes visited; `leaves`: leaves visited (empty ones included);
/// - `prims`: ray–triangle tests (a triangle referenced by several leaves may be tested more
///   than once: no mailboxing);
/// - `planes`: ray–split-plane distances computed (`havran`: only where the ray crosses);
/// - `boxes`: 1 (the start cell, tested first);
/// - `steps`: nodes visited (`interior + leaves`);
/// - `restarts`: 0.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct KdTree {
    nodes: Arc<Nodes>,
    prim_refs: Arc<[u32]>,
    /// The build cache saves neither the scene's triangles nor the parameters (its key) nor
    /// the auxiliary arrays: [`tb_core::Persist::attach`] gives the first two back, and the
    /// arrays are built on first use, as after a build.
    #[serde(skip)]
    tris: Arc<[Triangle]>,
    bounds: Aabb,
    #[serde(skip)]
    params: KdParams,
    /// Where every traversal's walks begin.
    start: KdStart,
    #[serde(skip)]
    aux: Arc<AuxArrays>,
    /// Leaves the builder made because the reference budget was reached
    /// ([`build::MAX_REFS_PER_TRIANGLE`]; 0 on every paper scene).
    budget_leaves: u64,
}

impl KdTree {
    /// Build a kd-tree over a copy of `tris` with `params` and the surface-area measure
    /// (single-threaded). Panics if `params.check()` fails or there are 2^30 or more triangles
    /// ([`KdTree::try_build`] returns those as errors). Triangles with non-finite vertices are
    /// left out (no ray can hit them).
    pub fn build(tris: &[Triangle], params: &KdParams) -> KdTree {
        Self::build_shared(tris.into(), params)
    }

    /// [`KdTree::build`] over shared triangles (no copy; several trees may index one array).
    pub fn build_shared(tris: Arc<[Triangle]>, params: &KdParams) -> KdTree {
        Self::try_build(tris, params, &SurfaceArea).unwrap_or_else(|e| panic!("kd-tree: {e}"))
    }

    /// Build over shared triangles with the cell measure `m` for the SAH; `Err` for parameters
    /// out of range or 2^30 or more triangles (the registry's path).
    pub fn try_build<M: BoxMeasure>(
        tris: Arc<[Triangle]>,
        params: &KdParams,
        m: &M,
    ) -> Result<KdTree, AccelError> {
        params.check()?;
        const LIMIT: u64 = (1 << 30) - 1;
        if tris.len() as u64 > LIMIT {
            return Err(AccelError::TooLarge {
                what: "kd-tree triangles",
                count: tris.len() as u64,
                limit: LIMIT,
            });
        }
        let out = build::build(&tris, params, m);
        let nodes = match params.layout {
            KdLayout::DepthFirst => Nodes::from_slice(&out.nodes),
            KdLayout::Treelet => {
                Nodes::from_slice(&layout::to_treelets(&out.nodes, params.treelet_height))
            }
        };
        Ok(KdTree {
            nodes: Arc::new(nodes),
            prim_refs: out.prim_refs.into(),
            tris,
            bounds: out.bounds,
            params: *params,
            start: KdStart {
                node: 0,
                cell: out.bounds,
            },
            aux: Arc::default(),
            budget_leaves: out.budget_leaves,
        })
    }

    /// What the kernels read: nodes, references, triangles, root cell, layout and the
    /// parameters of the walks.
    pub fn view(&self) -> KdView<'_> {
        KdView {
            nodes: &self.nodes,
            refs: &self.prim_refs,
            tris: &self.tris,
            bounds: self.bounds,
            layout: self.params.layout,
            treelet_height: self.params.treelet_height,
            short_stack: self.params.short_stack,
            step_cap: self.params.step_cap,
        }
    }

    /// Where every traversal's walks begin: the root, or the node of [`KdTree::subtree`].
    pub fn start(&self) -> KdStart {
        self.start
    }

    /// Leaves the builder made because the reference budget was reached
    /// (`build::MAX_REFS_PER_TRIANGLE`; 0 where it never acted).
    pub fn budget_leaves(&self) -> u64 {
        self.budget_leaves
    }

    /// This tree (its arrays shared, not copied) traced from node `node`: every traversal
    /// clips rays to the node's cell and treats the node as the root (see [`KdStart`]).
    /// Figures, memory and `validate` stay the whole tree's. `None` when `node` is no node
    /// of the tree.
    pub fn subtree(&self, node: usize) -> Option<KdTree> {
        let start = self.view().start_at(node)?;
        Some(KdTree {
            start,
            ..self.clone()
        })
    }

    /// The walk input of the kernels compiled for layout `l`, from this tree's start.
    fn tree<L: Layout>(&self, l: L) -> Tree<'_, L> {
        Tree::new(self.view(), l, self.start)
    }

    /// The [`BACKTRACK_AUX`] array (cell and parent per node, read by `backtrack`), built on
    /// first use.
    pub fn back_nodes(&self) -> &[BackNode] {
        self.aux.back_nodes(&self.view(), &[0])
    }

    /// The [`ROPES_AUX`] array (cell and six ropes per leaf, read by `ropes`; `u32::MAX`: the
    /// face is on the root cell), built on first use.
    pub fn ropes(&self) -> &Ropes {
        self.aux.ropes(&self.view(), &[0])
    }

    /// The tree's leaves.
    fn leaf_count(&self) -> usize {
        view::leaf_count(&self.view(), &[0])
    }

    /// Whether auxiliary array `aux` ([`BACKTRACK_AUX`], [`ROPES_AUX`]) has been built.
    pub fn aux_built(&self, aux: &str) -> bool {
        self.aux.built(aux)
    }

    /// The flattened nodes, root first (see [`KdNode`]). Empty when no triangle is finite.
    #[inline(always)]
    pub fn nodes(&self) -> &[KdNode] {
        &self.nodes
    }

    /// Leaf references: a leaf owns `prim_refs()[offset .. offset + count]`, scene indices.
    #[inline(always)]
    pub fn prim_refs(&self) -> &[u32] {
        &self.prim_refs
    }

    /// The triangles, in the scene's order.
    pub fn triangles(&self) -> &[Triangle] {
        &self.tris
    }

    /// The triangles, shared (to build further trees over the same array).
    pub fn shared_triangles(&self) -> &Arc<[Triangle]> {
        &self.tris
    }

    /// The root cell (bounds of the finite triangles).
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// The parameters it was built with.
    pub fn params(&self) -> &KdParams {
        &self.params
    }

    /// The children `(left, right)` of interior node `i` in this tree's layout (for code off
    /// the traversals' hot paths; the kernels are compiled per [`Layout`]).
    pub fn children(&self, i: usize) -> (usize, usize) {
        self.view().children(i)
    }

    fn check_invariants(&self) -> Result<(), String> {
        check_trees(&self.view(), &[0], &self.params)
    }
}

/// A traversal table row's trace fn: the kernel `$kernel` (an expression of the tree `$kd` and
/// the kernels' input `$w`, a [`Tree`] from the tree's start) compiled for each layout; the
/// layout is picked once per batch, then [`tb_core::dispatch`] picks the variant for the
/// triangle test and the counter.
macro_rules! per_layout {
    (|$kd:ident, $w:ident| $kernel:expr) => {
        tb_core::kernel!(|$kd: &KdTree, batch, out| match $kd.params.layout {
            KdLayout::DepthFirst => {
                let $w = $kd.tree(DepthFirst);
                dispatch(&$kernel, batch, out)
            }
            KdLayout::Treelet => {
                let $w = $kd.tree(Treelet::new($kd.params.treelet_height));
                dispatch(&$kernel, batch, out)
            }
        })
    };
}

/// The kd table from [`kd_walks!`]'s entries: each one's [`TraversalInfo`], its kernel
/// compiled per layout ([`per_layout!`]) and its GPU program where it has one.
macro_rules! kd_table {
    ($(
        $name:literal, $paper:literal, $doc:literal, [$($info:tt)*], gpu [$($gpu:path)?],
        |$t:ident, $w:ident| $k:expr;
    )*) => {
        &[$(
            kd_row!(
                TraversalInfo::new($name, $paper, $doc) $($info)*,
                per_layout!(|$t, $w| $k)
                $(, $gpu)?
            )
        ),*]
    };
}

/// One row of [`kd_table!`]: CPU only, or with its GPU program.
macro_rules! kd_row {
    ($info:expr, $trace:expr) => {
        Traversal::cpu($info, $trace)
    };
    ($info:expr, $trace:expr, $gpu:path) => {
        Traversal::with_gpu($info, $trace, $gpu)
    };
}

impl Structure for KdTree {
    const NAME: &'static str = "kdtree";

    /// The traversals every [`KdTree`] offers, from [`kd_walks!`]'s list; the restart-type
    /// ones end a ray after [`KdParams::step_cap`] steps, `backtrack` and `ropes` read
    /// auxiliary arrays.
    const TRAVERSALS: &'static [Traversal<Self>] = crate::kd_walks!(kd_table);

    /// Nodes, references and triangles: what every traversal reads. `backtrack` adds the
    /// [`BACKTRACK_AUX`] array, `ropes` the [`ROPES_AUX`] array
    /// ([`Structure::aux_bytes`]; review Table 3, "additional memory").
    ///
    /// `structure_bytes`, the tree alone as the review's Table 3 counts it: the nodes (8
    /// bytes each, in whole 64-byte lines: unused treelet slots count) and the references (4
    /// bytes each), plus the auxiliary arrays the row's traversal reads; not the scene's
    /// triangle array, which the tree shares.
    fn own_memory(&self) -> MemoryReport {
        let structure = self.nodes.bytes() + std::mem::size_of_val(&*self.prim_refs);
        MemoryReport {
            bytes: (structure + std::mem::size_of_val(&*self.tris)) as u64,
            structure_bytes: structure as u64,
            nodes: self.nodes.len() as u64,
            prim_refs: self.prim_refs.len() as u64,
            node_bytes: std::mem::size_of::<KdNode>() as u32,
        }
    }

    /// [`BACKTRACK_AUX`]: 32 bytes per node (cell and parent); [`ROPES_AUX`]: 48 bytes per
    /// leaf (cell and six ropes) and 12 per 64 nodes (the leaves' rank); built or not.
    fn aux_bytes(&self, aux: &str) -> u64 {
        aux_bytes(aux, self.nodes.len(), self.leaf_count())
    }

    fn prepare_aux(&self, aux: &str) {
        self.aux.prepare(aux, &self.view(), &[0]);
    }

    /// The build report: see `report.rs`.
    fn report(&self) -> BuildReport {
        self.report_figures()
    }

    /// Checks: node and reference indices in range, children after their parent and distinct
    /// (so no cycles), the treelet layout's unused slots empty, every node reachable exactly
    /// once, depth within the limit and the traversal stack, split positions inside their
    /// cells, every referenced triangle's box overlapping its leaf cell (up to the builder's
    /// rounding tolerance), every finite triangle referenced by at least one leaf.
    fn check(&self) -> Result<(), AccelError> {
        self.check_invariants().map_err(AccelError::Invalid)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tb_core::{Accel, HitRecord, ParamValue, Params, Query, Ray, TriTestKind, Vec3};

    fn grid() -> Vec<Triangle> {
        (0..64)
            .map(|i| {
                let p = Vec3::new((i % 8) as f32, (i / 8) as f32, (i % 3) as f32);
                Triangle::new(p, p + Vec3::X * 0.9, p + Vec3::Y * 0.9)
            })
            .collect()
    }

    /// A copy of `a` edited by `f` (the tree's arrays are shared).
    fn edited<T: Clone>(a: &[T], f: impl FnOnce(&mut Vec<T>)) -> Arc<[T]> {
        let mut v = a.to_vec();
        f(&mut v);
        v.into()
    }

    fn index(name: &str) -> usize {
        KdTree::TRAVERSALS
            .iter()
            .position(|t| t.info.name == name)
            .unwrap()
    }

    #[test]
    fn node_layout() {
        let n = KdNode::interior(2, 1.5, 7);
        assert!(!n.is_leaf());
        assert_eq!((n.axis(), n.split(), n.link()), (2, 1.5, 7));
        let l = KdNode::leaf(40, 3);
        assert!(l.is_leaf());
        assert_eq!((l.offset(), l.count()), (40, 3));
    }

    #[test]
    fn params_are_checked() {
        assert_eq!(KdParams::default().check(), Ok(()));
        let with = |f: fn(&mut KdParams)| {
            let mut p = KdParams::default();
            f(&mut p);
            p
        };
        let bad = [
            with(|p| p.sah.c_trav = 0.0),
            with(|p| p.sah.c_isect = f32::NAN),
            with(|p| p.sah.empty_bonus = 1.0),
            with(|p| p.sah.max_depth = STACK_SIZE as u32 + 1),
            with(|p| p.sah.bins = 1),
            with(|p| p.short_stack = 0),
            with(|p| p.short_stack = MAX_SHORT_STACK as u32 + 1),
            with(|p| p.step_cap = 0),
            with(|p| p.treelet_height = 9),
        ];
        for p in bad {
            assert!(
                matches!(p.check(), Err(AccelError::Params(_))),
                "{p:?}: {:?}",
                p.check()
            );
        }
        assert_eq!(KdParams::default().depth_limit(1 << 20), 34);
    }

    /// The parameter table lists the fields in order with their defaults, converts back
    /// without loss, and the registry's build refuses parameters out of range.
    #[test]
    fn parameter_table_and_family() {
        let names: Vec<&str> = KdParams::SPECS.iter().map(|s| s.name).collect();
        assert_eq!(
            names,
            [
                "builder",
                "bins",
                "snap",
                "c_trav",
                "c_isect",
                "empty_bonus",
                "max_depth",
                "min_leaf",
                "short_stack",
                "step_cap",
                "layout",
                "treelet_height"
            ]
        );
        let defaults = (FAMILY.defaults)();
        assert_eq!(
            defaults.to_string(),
            "builder=sweep;bins=32;snap=true;c_trav=1;c_isect=1.5;empty_bonus=0.2;max_depth=0;\
             min_leaf=1;short_stack=4;step_cap=100000;layout=depth-first;treelet_height=3"
        );
        assert_eq!(KdParams::from_set(&defaults), Ok(KdParams::default()));
        for (spec, (_, v)) in KdParams::SPECS.iter().zip(&defaults.0) {
            assert_eq!(spec.check(v), Ok(()), "{}", spec.name);
        }
        assert_eq!(FAMILY.name, "kdtree");
        assert_eq!((FAMILY.traversals)().len(), KdTree::TRAVERSALS.len());

        let tris: Arc<[Triangle]> = grid().into();
        let mut set = defaults.clone();
        set.0[10].1 = ParamValue::Str("treelet".into());
        let kd = (FAMILY.build)(&tris, &set).unwrap();
        assert_eq!(kd.validate(), Ok(()));
        set.0[1].1 = ParamValue::Int(1);
        let err = (FAMILY.build)(&tris, &set).err().unwrap();
        assert!(matches!(err, AccelError::Params(_)), "{err}");
        assert!(err.to_string().contains("bins"), "{err}");
        let mut set = defaults;
        set.0[0].1 = ParamValue::Str("median".into());
        assert!(matches!(
            (FAMILY.build)(&tris, &set).err(),
            Some(AccelError::Param(_))
        ));
    }

    #[test]
    fn validate_finds_corruption() {
        let good = KdTree::build(&grid(), &KdParams::default());
        assert_eq!(Accel::validate(&good), Ok(()));
        assert!(good.nodes().len() > 1);
        let leaf = good
            .nodes()
            .iter()
            .position(|n| n.is_leaf() && n.count() > 0);
        let leaf = leaf.unwrap();
        let msg = |b: &KdTree| Accel::validate(b).unwrap_err().to_string();

        let mut b = good.clone();
        let n0 = b.nodes[0];
        Arc::make_mut(&mut b.nodes)[0] = KdNode::interior(n0.axis(), n0.split(), 0);
        assert!(msg(&b).contains("children"));

        let mut b = good.clone();
        b.prim_refs = edited(&b.prim_refs, |v| v[0] = 1000);
        assert!(msg(&b).contains("out of range"));

        let mut b = good.clone();
        let n = b.nodes[leaf];
        Arc::make_mut(&mut b.nodes)[leaf] = KdNode::leaf(n.offset() as u32, 10_000);
        assert!(matches!(Accel::validate(&b), Err(AccelError::Invalid(_))));

        let mut b = good.clone();
        let mut v = b.nodes().to_vec();
        v.push(KdNode::leaf(0, 1));
        b.nodes = Arc::new(Nodes::from_slice(&v));
        assert!(msg(&b).contains("unreachable"));

        // A reference far from its leaf's cell.
        let mut b = good.clone();
        b.tris = edited(&b.tris, |v| {
            v.push(Triangle::new(
                Vec3::splat(100.0),
                Vec3::splat(101.0),
                Vec3::new(100.0, 101.0, 100.0),
            ))
        });
        let o = b.nodes[leaf].offset();
        b.prim_refs = edited(&b.prim_refs, |v| v[o] = 64);
        assert!(Accel::validate(&b).is_err());
        // The corrupted copies shared nothing they changed.
        assert_eq!(Accel::validate(&good), Ok(()));
    }

    #[test]
    fn validate_checks_the_treelet_layout() {
        let p = KdParams {
            layout: KdLayout::Treelet,
            ..Default::default()
        };
        let good = KdTree::build(&grid(), &p);
        assert_eq!(Accel::validate(&good), Ok(()));
        let msg = |b: &KdTree| Accel::validate(b).unwrap_err().to_string();
        // An unused slot that is not empty.
        let free = good
            .nodes()
            .iter()
            .position(|n| *n == layout::EMPTY_SLOT)
            .unwrap();
        let mut b = good.clone();
        Arc::make_mut(&mut b.nodes)[free] = KdNode::leaf(0, 1);
        assert!(msg(&b).contains("unreachable"));
        // A lowest-level link pointing back into the tree.
        let low = (0..good.nodes().len())
            .find(|&i| !good.nodes()[i].is_leaf() && i % 8 >= 3)
            .unwrap();
        let mut b = good.clone();
        let n = b.nodes[low];
        Arc::make_mut(&mut b.nodes)[low] = KdNode::interior(n.axis(), n.split(), 0);
        assert!(msg(&b).contains("children"));
        // The same tree in fewer bytes depth-first.
        let dfs = KdTree::build(&grid(), &KdParams::default());
        assert!(Accel::memory(&good).bytes > Accel::memory(&dfs).bytes);
    }

    #[test]
    fn build_report_and_memory() {
        let kd = KdTree::build(&grid(), &KdParams::default());
        let r = Accel::build_report(&kd);
        assert!(r.sah_cost.unwrap() > 0.0);
        let get = |k: &str| r.extra.iter().find(|(n, _)| n == k).unwrap().1;
        assert_eq!(get("nodes") as usize, kd.nodes().len());
        assert_eq!(get("references") as usize, kd.prim_refs().len());
        let m = Accel::memory(&kd);
        assert_eq!(m.node_bytes, 8);
        assert!(m.bytes as usize > kd.nodes().len() * 8);
        let leaves = kd.nodes().iter().filter(|n| n.is_leaf()).count();
        assert!(kd.memory_for(index("ropes")).bytes as usize > kd.nodes().len() * 8 + leaves * 48);
        // Empty scenes build and miss.
        let e = KdTree::build(&[], &KdParams::default());
        assert_eq!(Accel::validate(&e), Ok(()));
        let rays = [Ray::new(Vec3::ZERO, Vec3::X)];
        let mut hits = [HitRecord::MISS; 1];
        for t in 0..KdTree::TRAVERSALS.len() {
            e.trace(
                t,
                tb_core::Batch::new(Query::Closest, TriTestKind::Watertight, &rays),
                tb_core::Answers::hits(&mut hits),
            );
            assert!(!hits[0].is_hit());
        }
        // A root that is a leaf (one triangle): every traversal hits it and misses beside it.
        let one = KdTree::build(&grid()[..1], &KdParams::default());
        assert!(one.nodes()[0].is_leaf());
        let rays = [
            Ray::new(Vec3::new(0.2, 0.2, -1.0), Vec3::Z),
            Ray::new(Vec3::new(0.8, 0.8, -1.0), Vec3::Z),
        ];
        for t in 0..KdTree::TRAVERSALS.len() {
            let mut hits = [HitRecord::MISS; 2];
            let tri = TriTestKind::Watertight;
            one.trace(
                t,
                tb_core::Batch::new(Query::Closest, tri, &rays),
                tb_core::Answers::hits(&mut hits),
            );
            assert_eq!((hits[0].prim, hits[1].prim), (0, u32::MAX));
        }
    }

    /// The auxiliary arrays are built when a traversal reading them is traced or prepared,
    /// not before, and shared by clones and subtrees; the memory figures do not depend on it.
    #[test]
    fn aux_arrays_are_built_on_demand() {
        let kd = KdTree::build(&grid(), &KdParams::default());
        let figures = |kd: &KdTree| -> Vec<u64> {
            (0..KdTree::TRAVERSALS.len())
                .map(|t| kd.memory_for(t).bytes)
                .collect()
        };
        let before = figures(&kd);
        let built = |kd: &KdTree| (kd.aux_built(BACKTRACK_AUX), kd.aux_built(ROPES_AUX));
        assert_eq!(built(&kd), (false, false));
        let rays = [Ray::new(Vec3::new(-1.0, 0.5, 0.5), Vec3::X)];
        let mut hits = [HitRecord::MISS; 1];
        let trace = |kd: &KdTree, t: usize, hits: &mut [HitRecord]| {
            kd.trace(
                t,
                tb_core::Batch::new(Query::Closest, TriTestKind::Watertight, &rays),
                tb_core::Answers::hits(hits),
            )
        };
        for t in 0..KdTree::TRAVERSALS.len() {
            if KdTree::TRAVERSALS[t].info.aux.is_empty() {
                trace(&kd, t, &mut hits);
            }
        }
        assert_eq!(built(&kd), (false, false));
        let sub = kd.subtree(kd.children(0).0).unwrap();
        trace(&sub, index("backtrack"), &mut hits);
        assert_eq!(built(&kd), (true, false));
        kd.prepare(index("ropes"));
        assert_eq!(built(&sub), (true, true));
        assert_eq!(figures(&kd), before);
        assert_eq!(kd.back_nodes().len(), kd.nodes().len());
        let leaves = kd.nodes().iter().filter(|n| n.is_leaf()).count();
        assert_eq!(kd.ropes().leaves.len(), leaves);
    }
}
