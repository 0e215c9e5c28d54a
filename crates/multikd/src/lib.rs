//! Multi-kd-trees (Torres et al. 2012, "Improving ray traversal by using several specialized
//! kd-trees", GRAPP 2012, sections 5-6): three kd-trees over one triangle array, each built with
//! the measure of one set of directions ([`crate::measure`]), and every ray traversing the tree
//! of the set holding its direction.
//!
//! - **Build** (§5): `kd-tree_n^(i)` for `i` = X, Y, Z, each with [`tb_kdtree::KdTree::try_build`]
//!   and the [`WeightedArea`] measure of heuristic `measure` for patch `i` (the builder, its
//!   cost constants and termination as for the kd-tree; the paper uses `C_plane = C_tri = 1`,
//!   §7, this structure's defaults).
//! - **Layout** (§6): the trees' nodes in one node array, each tree contiguous (in the treelet
//!   layout each starts on a block boundary), their leaf references in one reference array,
//!   and a *header* of three root indices, one per patch; the triangles are shared.
//! - **Traversal** (§5): every kd-tree traversal of the review ([`tb_kdtree::KdTree`]'s table, same
//!   names) runs unchanged from the root the header gives for the ray's patch
//!   ([`Heuristic::pick`]: cube mapping for the cubic heuristics, the spherical patches
//!   otherwise): the per-ray choice wraps the traversal kernel ([`KdStart`]).
//! - **Ray arrangement** (§6): before traversal the rays are sorted by tree index with a
//!   counting sort on the 2-bit key ([`MultiKdTree::arrange`]), in blocks of
//!   [`ARRANGE_BLOCK`] rays (the runner's [`tb_core::par::CHUNK`], so one block is one traced
//!   chunk), and traced in that order, each with the tree its entry names, the answers written
//!   to the rays' own places. Every traversal comes as
//!   - `NAME` (rays in the order given, the tree picked per ray in the walk),
//!   - `NAME-sorted`: the arrangement computed inside the timed call (the paper's "inc.":
//!     the *Sort* kernel's time added to *TI*'s), and
//!   - `NAME-presorted`: the same arrangement computed per batch by the untimed start-hint
//!     pass ([`tb_core::Accel::batch_hints`], as the paper's rays carry the tree index chosen
//!     when they were generated), the timed call only walking it (the paper's "n.inc.").
//!
//!   Both run the same walk of the same arrangement, so `time(-sorted) - time(-presorted)` is
//!   the time of arranging (computing each ray's key, counting, placing) and nothing else;
//!   the three give the same hits and counters ray for ray.
//! - **GPU** (`recursive-direction` only, `shaders/multikd.wgsl` on the kd-tree's
//!   `shaders/kd.wgsl`): the per-ray choice from the header and the kd-tree's full-stack walk
//!   (the CPU kernel's, in its order) from the chosen root, so hits and counters agree ray
//!   for ray (tb-harness `gpu_oracle`); either layout. `recursive-direction-sorted` and
//!   `-presorted` have GPU programs too: the same walk after tb-gpu's sort pass (a stable
//!   counting sort of each dispatch's rays by the tree index, `ray_key` in `multikd.wgsl`,
//!   as compute passes timed on their own; `tb_core::gpu`), the sort's time added to the
//!   row's trace time for `-sorted` ("inc.") and not for `-presorted` ("n.inc."), the `sort_ms`
//!   column giving it for both; hits and counters are written at the rays' own places, so
//!   they equal the plain row's ray for ray. On the GPU the sorted blocks are the dispatches
//!   (`Gpu::max_rays_per_dispatch` rays), not [`ARRANGE_BLOCK`].
//! - **Controls**: `measure = sah` builds one SAH tree (the three patch measures are the same)
//!   and every header entry names it; `trees = x | y | z` builds only that patch's tree with
//!   the chosen measure and every ray traverses it (is the gain from specialising per
//!   direction or from the measure?). Both still evaluate the per-ray choice, so rows differ
//!   only in the trees.
//!
//! Counters: the kd-tree's (see [`tb_kdtree::KdTree`]); the paper's "traversal step" (§7: a plane
//! or a triangle intersection) is `planes + prims` of the `recursive-direction` traversal,
//! which computes one plane distance per interior node visited, as the paper's stack
//! traversal does. Memory: the real arrays ([`Structure::own_memory`]: 8-byte nodes,
//! 4-byte references, the triangles, the header) and, in the build report, the paper's
//! Table 3 figure (`paper_bytes`: 16 bytes a node, 4 a reference).

#![deny(missing_docs)]

mod build;
mod gpu;
pub mod measure;
mod params;
mod report;
mod traverse;

pub use params::{MultiKdParams, Trees};
use traverse::*;
pub use traverse::{ARRANGE_BLOCK, TREE_SHIFT};

use measure::{Heuristic, WeightedArea};
use std::sync::Arc;
use tb_core::{
    build_with, dispatch, Aabb, AccelError, Answers, Batch, BuildReport, Counter, Family,
    HitRecord, Kernel, MemoryReport, MollerTrumbore, NoStats, Query, Ray, Structure, Traversal,
    TraversalInfo, TraversalStats, TriTest, TriTestKind, Triangle, Watertight,
};
use tb_kdtree::view;
use tb_kdtree::{
    layout, AuxArrays, BackNode, DepthFirst, KdLayout, KdNode, KdStart, KdTree, KdView, Layout,
    Nodes, Ropes, Treelet,
};

/// The multi-kd-tree in the registry.
pub static FAMILY: Family = Family::new::<MultiKdTree, MultiKdParams>(
    "multi-kd-tree: three kd-trees built with direction-specialised SAH measures (`measure`: \
     sphere, cube, cos, orthogonal or oblique; `sah` is the kd-tree itself), one node array with \
     a header of roots, each ray traversing the tree of its direction's patch; single-tree \
     controls (`trees`) (Torres et al. 2012)",
    |tris, set| {
        build_with(set, |p: &MultiKdParams| {
            MultiKdTree::try_build(tris.clone(), p)
        })
    },
)
.with_summary(
    "multi-kd-tree: three kd-trees of direction-weighted SAH measures, a tree per ray direction \
     (Torres et al. 2012)",
)
.with_rules::<MultiKdParams>()
.with_persist::<MultiKdTree>()
.with_method(1, tb_core::FIRST_METHOD);

impl tb_core::Persist for MultiKdTree {
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

/// One tree of the node array.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TreeEntry {
    /// The patch whose measure built it (0 = X, 1 = Y, 2 = Z; 0 for SAH).
    pub patch: usize,
    /// The normalised weights of its measure.
    pub weights: [f64; 3],
    /// Its root (first node) in the node array, and its node slots.
    pub root: u32,
    /// Entries it takes in the node array (unused treelet slots included).
    pub slots: u32,
    /// Nodes (interior and leaves, unused treelet slots not counted) and references.
    pub nodes: u64,
    /// Its leaf references, contiguous in the shared reference array.
    pub refs: u64,
    /// Its leaves, empty ones included.
    pub leaves: u64,
    /// Its SAH cost under its own measure, relative to the root.
    pub cost: f64,
}

/// A multi-kd-tree (see the module doc).
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct MultiKdTree {
    nodes: Arc<Nodes>,
    refs: Arc<[u32]>,
    /// Not saved by the build cache: the scene's triangles and the parameters (its key) are
    /// given back by [`tb_core::Persist::attach`], the auxiliary arrays built on first use.
    #[serde(skip)]
    tris: Arc<[Triangle]>,
    bounds: Aabb,
    #[serde(skip)]
    params: MultiKdParams,
    /// The rule choosing a ray's patch.
    pick: Heuristic,
    /// Root node per patch (the header array of §6).
    header: [u32; 3],
    trees: Vec<TreeEntry>,
    #[serde(skip)]
    aux: Arc<AuxArrays>,
    /// Leaves the trees' builds made at the reference budget (tb-kdtree's bound).
    budget_leaves: u64,
}

impl MultiKdTree {
    /// The view of the whole node array (walks begin at a header entry).
    pub fn view(&self) -> KdView<'_> {
        KdView {
            nodes: &self.nodes,
            refs: &self.refs,
            tris: &self.tris,
            bounds: self.bounds,
            layout: self.params.kd.layout,
            treelet_height: self.params.kd.treelet_height,
            short_stack: self.params.kd.short_stack,
            step_cap: self.params.kd.step_cap,
        }
    }

    /// The header: the root node of the tree each patch's rays traverse (X, Y, Z).
    pub fn header(&self) -> [u32; 3] {
        self.header
    }

    /// The start of the walks of patch `i`'s rays.
    pub fn start(&self, i: usize) -> KdStart {
        KdStart {
            node: if self.nodes.is_empty() {
                0
            } else {
                self.header[i]
            },
            cell: self.bounds,
        }
    }

    /// The tree index (0, 1, 2: the header entry) ray direction `d` selects (§5).
    #[inline(always)]
    pub fn tree_of(&self, d: [f32; 3]) -> usize {
        self.pick.pick(d)
    }

    /// The distinct trees, in node-array order.
    pub fn trees(&self) -> &[TreeEntry] {
        &self.trees
    }

    /// The parameters it was built with.
    pub fn params(&self) -> &MultiKdParams {
        &self.params
    }

    /// The roots of the distinct trees.
    fn roots(&self) -> Vec<u32> {
        if self.nodes.is_empty() {
            return Vec::new();
        }
        self.trees.iter().map(|t| t.root).collect()
    }

    /// [`tb_kdtree::BACKTRACK_AUX`] over every tree, built on first use.
    pub fn back_nodes(&self) -> &[BackNode] {
        self.aux.back_nodes(&self.view(), &self.roots())
    }

    /// [`tb_kdtree::ROPES_AUX`] over every tree, built on first use.
    pub fn ropes(&self) -> &Ropes {
        self.aux.ropes(&self.view(), &self.roots())
    }
}

impl Structure for MultiKdTree {
    const NAME: &'static str = "multi-kd";

    /// The kd-tree's traversals (same names, same kernels) with the per-ray tree choice, then
    /// each as `NAME-sorted`, then each as `NAME-presorted` (see the module doc), generated
    /// from [`tb_kdtree::kd_walks!`]'s list.
    const TRAVERSALS: &'static [Traversal<Self>] = rows::TABLE;

    /// Nodes (8 bytes each, unused treelet slots and block padding included), references,
    /// triangles and the 12-byte header.
    ///
    /// `structure_bytes`, the trees alone as Torres et al.'s Table 3 counts them: the nodes,
    /// the references and the header (the `real_bytes` build figure; the paper's own 16 bytes
    /// a node and 4 a reference are `paper_bytes`), plus the auxiliary arrays the row's
    /// traversal reads; not the scene's triangle array, which the trees share.
    fn own_memory(&self) -> MemoryReport {
        let structure = self.nodes.bytes()
            + std::mem::size_of_val(&*self.refs)
            + std::mem::size_of_val(&self.header);
        MemoryReport {
            bytes: (structure + std::mem::size_of_val(&*self.tris)) as u64,
            structure_bytes: structure as u64,
            nodes: self.nodes.len() as u64,
            prim_refs: self.refs.len() as u64,
            node_bytes: std::mem::size_of::<KdNode>() as u32,
        }
    }

    fn aux_bytes(&self, aux: &str) -> u64 {
        tb_kdtree::aux_bytes(
            aux,
            self.nodes.len(),
            view::leaf_count(&self.view(), &self.roots()),
        )
    }

    fn prepare_aux(&self, aux: &str) {
        self.aux.prepare(aux, &self.view(), &self.roots());
    }

    /// The build report: see `report.rs`.
    fn report(&self) -> BuildReport {
        self.report_figures()
    }

    /// Every tree's kd-tree invariants from its root, every node in exactly one tree, and
    /// the header naming roots of the node array's trees.
    fn check(&self) -> Result<(), AccelError> {
        let roots = self.roots();
        if !self.nodes.is_empty() {
            if let Some(h) = self.header.iter().find(|h| !roots.contains(h)) {
                return Err(AccelError::Invalid(format!(
                    "header entry {h} is no tree's root"
                )));
            }
        }
        tb_kdtree::check_trees(&self.view(), &roots, &self.params.kd).map_err(AccelError::Invalid)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tb_core::{Accel, Vec3};

    fn grid() -> Vec<Triangle> {
        (0..200)
            .map(|i| {
                let p = Vec3::new((i % 7) as f32, ((i / 7) % 5) as f32, (i / 35) as f32 * 1.3);
                let q = Vec3::new(0.9, 0.2 * (i % 3) as f32, 0.1);
                Triangle::new(p, p + q, p + Vec3::Y * 0.8 + Vec3::Z * 0.3)
            })
            .collect()
    }

    /// The table and dispatch generated from tb-kdtree's list with one more kd traversal
    /// (`recursive-direction`'s kernel under another name), as a traversal added there.
    mod with_dummy {
        use super::*;
        tb_kdtree::kd_walks!(
            multikd_walks;
            "dummy-walk", "a test", "recursive-direction's kernel under another name", [],
            gpu [],
            |t, w| tb_kdtree::traverse::RecursiveDirection(w);
        );
    }

    /// A kd traversal added to tb-kdtree's list ([`tb_kdtree::kd_walks!`]) is offered by
    /// multi-kd, per ray, `-sorted` and `-presorted`, with no edit here, and its rows trace
    /// with its kernel.
    #[test]
    fn a_kd_walk_added_to_the_list_is_offered_without_edits() {
        let t = with_dummy::TABLE;
        assert_eq!(t.len(), 3 * (PLAIN + 1));
        let names: Vec<&str> = t.iter().map(|r| r.info.name).collect();
        let at = |n: &str| names.iter().position(|x| *x == n).expect(n);
        let rows = [
            at("dummy-walk"),
            at("dummy-walk-sorted"),
            at("dummy-walk-presorted"),
        ];
        assert_eq!(rows, [PLAIN, 2 * PLAIN + 1, 3 * PLAIN + 2]);
        assert!(t[rows[2]].hints.is_some() && t[rows[0]].hints.is_none());
        // The other rows are multi-kd's own, in its order.
        let own: Vec<&str> = MultiKdTree::TRAVERSALS
            .iter()
            .map(|r| r.info.name)
            .collect();
        let rest: Vec<&str> = names
            .iter()
            .copied()
            .filter(|n| !n.starts_with("dummy-walk"))
            .collect();
        assert_eq!(rest, own);
        // Each dummy row answers and counts as `recursive-direction`'s row of that form.
        let m = MultiKdTree::build(&grid(), &MultiKdParams::default());
        let rays = random_rays(ARRANGE_BLOCK + 100);
        let trace = |f: tb_core::TraceFn<MultiKdTree>| {
            let n = rays.len();
            let (mut h, mut st) = (vec![HitRecord::MISS; n], vec![TraversalStats::default(); n]);
            let b = tb_core::Batch::new(Query::Closest, TriTestKind::Watertight, &rays);
            f(&m, b, tb_core::Answers::new(&mut h, Some(&mut st)));
            (h, st)
        };
        for (row, kd_row) in rows.into_iter().zip([0, PLAIN, 2 * PLAIN]) {
            let mine = MultiKdTree::TRAVERSALS[kd_row].trace;
            assert!(trace(t[row].trace) == trace(mine), "{}", t[row].info.name);
        }
    }

    #[test]
    fn table_mirrors_the_kd_tree_table() {
        let kd = KdTree::TRAVERSALS;
        let all = MultiKdTree::TRAVERSALS;
        assert_eq!(kd.len(), PLAIN);
        assert_eq!(all.len(), 3 * PLAIN);
        for (i, t) in kd.iter().enumerate() {
            assert_eq!(all[i].info.name, t.info.name);
            for (row, suffix) in [(PLAIN + i, "-sorted"), (2 * PLAIN + i, "-presorted")] {
                assert_eq!(all[row].info.name, format!("{}{suffix}", t.info.name));
                assert_eq!(all[row].info.aux, t.info.aux);
                assert_eq!(all[row].info.counters, t.info.counters);
                // `recursive-direction` alone has GPU programs, in all three forms.
                assert_eq!(all[row].gpu.is_some(), i == 0);
            }
            // Only the `-presorted` rows take hints (the arrangement).
            assert!(all[i].hints.is_none() && all[PLAIN + i].hints.is_none());
            assert!(all[2 * PLAIN + i].hints.is_some());
        }
    }

    /// `structure_bytes` is the trees alone (Table 3): whole 64-byte lines of 8-byte nodes,
    /// 4 bytes a reference and the 12-byte header (the `real_bytes` figure), plus the
    /// auxiliary arrays the traversal reads; `bytes` adds exactly the triangle array.
    #[test]
    fn structure_bytes_are_the_trees_alone() {
        let tris = grid();
        let tri_bytes = std::mem::size_of_val(tris.as_slice()) as u64;
        for layout in [KdLayout::DepthFirst, KdLayout::Treelet] {
            let mut p = MultiKdParams::default();
            p.kd.layout = layout;
            let m = MultiKdTree::build(&tris, &p);
            assert_eq!(m.trees().len(), 3);
            let trees = 64 * m.nodes.len().div_ceil(8) as u64 + 4 * m.refs.len() as u64 + 12;
            let mem = Accel::memory(&m);
            assert_eq!(mem.structure_bytes, trees, "{layout:?}");
            assert_eq!(mem.bytes - mem.structure_bytes, tri_bytes, "{layout:?}");
            let r = Accel::build_report(&m);
            let real = r.extra.iter().find(|(n, _)| n == "real_bytes").unwrap().1;
            assert_eq!(real as u64, trees);
            for (i, t) in MultiKdTree::TRAVERSALS.iter().enumerate() {
                let aux: u64 = t.info.aux.iter().map(|a| m.aux_bytes(a)).sum();
                assert_eq!(
                    aux > 0,
                    ["backtrack", "ropes"]
                        .iter()
                        .any(|n| t.info.name.starts_with(n))
                );
                let mem = m.memory_for(i);
                assert_eq!(mem.structure_bytes, trees + aux, "{}", t.info.name);
                assert_eq!(
                    mem.bytes - mem.structure_bytes,
                    tri_bytes,
                    "{}",
                    t.info.name
                );
            }
        }
    }

    /// Three trees in one array, contiguous, the header naming their roots; each tree the
    /// same as a kd-tree built alone with its patch's measure; the controls hold one tree.
    #[test]
    fn layout_header_and_controls() {
        let tris = grid();
        for layout in [KdLayout::DepthFirst, KdLayout::Treelet] {
            let mut p = MultiKdParams::default();
            p.kd.layout = layout;
            let m = MultiKdTree::build(&tris, &p);
            assert_eq!(Accel::validate(&m), Ok(()));
            assert_eq!(m.trees().len(), 3);
            let h = m.header();
            assert!(h[0] == 0 && h[0] < h[1] && h[1] < h[2], "{h:?}");
            for (i, t) in m.trees().iter().enumerate() {
                let w = Heuristic::SphereOrth.weights(i, 2.0);
                let alone = KdTree::try_build(
                    m.tris.clone(),
                    &p.kd,
                    &WeightedArea([w[0] as f32, w[1] as f32, w[2] as f32]),
                )
                .unwrap();
                assert_eq!(t.slots as usize, alone.nodes().len());
                assert_eq!(t.refs as usize, alone.prim_refs().len());
            }
            let r = Accel::build_report(&m);
            let get = |k: &str| r.extra.iter().find(|(n, _)| n == k).unwrap().1;
            assert_eq!(
                get("paper_bytes"),
                16.0 * get("nodes") + 4.0 * get("references")
            );
        }
        for (trees, patch) in [(Trees::X, 0), (Trees::Z, 2)] {
            let p = MultiKdParams {
                trees,
                ..Default::default()
            };
            let m = MultiKdTree::build(&tris, &p);
            assert_eq!(m.trees().len(), 1);
            assert_eq!(m.trees()[0].patch, patch);
            assert_eq!(m.header(), [0; 3]);
            assert_eq!(Accel::validate(&m), Ok(()));
        }
        let p = MultiKdParams {
            measure: Heuristic::Sah,
            ..Default::default()
        };
        let m = MultiKdTree::build(&tris, &p);
        assert_eq!(m.trees().len(), 1);
        let kd = KdTree::build(&tris, &p.kd);
        assert_eq!(&m.nodes[..], kd.nodes());
        assert_eq!(&m.refs[..], kd.prim_refs());
    }

    /// A broken header or a node shared by two trees is found.
    #[test]
    fn validate_finds_corruption() {
        let m = MultiKdTree::build(&grid(), &MultiKdParams::default());
        let mut b = m.clone();
        b.header[1] = 1;
        assert!(Accel::validate(&b).is_err());
        let mut b = m.clone();
        let root1 = b.header[1] as usize;
        let n = b.nodes[root1];
        assert!(!n.is_leaf());
        // Tree Y's root pointing at a node of tree X.
        Arc::make_mut(&mut b.nodes)[root1] = KdNode::interior(n.axis(), n.split(), 2);
        assert!(Accel::validate(&b).is_err());
    }

    /// Each ray traverses its patch's tree: counters equal those of the kd-tree built alone
    /// with that patch's measure, ray for ray; `-sorted` and `-presorted` rows (with the hint
    /// pass's arrangement, over the whole batch and chunked as the runner does, and without
    /// hints) give the same hits and counters as the plain ones, ray for ray.
    #[test]
    fn rays_traverse_their_patch_tree_and_arranging_changes_nothing() {
        for layout in [KdLayout::DepthFirst, KdLayout::Treelet] {
            let mut p = MultiKdParams {
                measure: Heuristic::CubeObli,
                ..Default::default()
            };
            p.kd.layout = layout;
            per_ray_in(p);
        }
    }

    /// Rays from inside and around [`grid`], in every direction: more than two arrangement
    /// blocks, the last one partial.
    fn random_rays(n: usize) -> Vec<Ray> {
        let mut s = 7u32;
        let mut next = || {
            s = s.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (s >> 8) as f32 / (1 << 24) as f32
        };
        (0..n)
            .map(|_| {
                let o = Vec3::new(next() * 9.0 - 1.0, next() * 7.0 - 1.0, next() * 9.0 - 1.0);
                let d = Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5);
                Ray::new(o, d)
            })
            .collect()
    }

    type Traced = (Vec<HitRecord>, Vec<TraversalStats>);

    /// Row `t` over `rays` (counting), hinted with `hints` over the whole batch when given.
    fn traced(m: &MultiKdTree, t: usize, q: Query, rays: &[Ray], hints: Option<&[u32]>) -> Traced {
        let n = rays.len();
        let (mut h, mut st) = (vec![HitRecord::MISS; n], vec![TraversalStats::default(); n]);
        let tri = TriTestKind::Watertight;
        m.trace(
            t,
            tb_core::Batch::new(q, tri, rays).with_hints(hints),
            tb_core::Answers::new(&mut h, Some(&mut st)),
        );
        (h, st)
    }

    fn per_ray_in(p: MultiKdParams) {
        let tris = grid();
        let m = MultiKdTree::build(&tris, &p);
        let alone: Vec<KdTree> = (0..3)
            .map(|i| {
                KdTree::try_build(m.tris.clone(), &p.kd, &WeightedArea::of(p.measure, i, 2.0))
                    .unwrap()
            })
            .collect();
        let rays = random_rays(2 * ARRANGE_BLOCK + 300);
        let n = rays.len();
        let tri = TriTestKind::Watertight;
        for t in 0..PLAIN {
            let name = KdTree::TRAVERSALS[t].info.name;
            let (sorted, presorted) = (PLAIN + t, 2 * PLAIN + t);
            for q in [Query::Closest, Query::Any] {
                let plain = traced(&m, t, q, &rays, None);
                let hints = m.batch_hints(presorted, q, &rays).expect("hints");
                assert_eq!(m.batch_hints(sorted, q, &rays), None);
                assert_eq!(traced(&m, sorted, q, &rays, None), plain, "{name}-sorted");
                let pre = traced(&m, presorted, q, &rays, Some(&hints));
                assert_eq!(pre, plain, "{name}-presorted");
                assert_eq!(
                    traced(&m, presorted, q, &rays, None),
                    plain,
                    "{name}-presorted"
                );
                // Chunked as the runner traces (the hints cut with the rays), timed variant.
                let mut h = vec![HitRecord::MISS; n];
                let batch = tb_core::Batch::new(q, tri, &rays).with_hints(Some(&hints));
                tb_core::par::trace_into(&m, presorted, batch, tb_core::Answers::hits(&mut h));
                assert_eq!(h, plain.0, "{name}-presorted in chunks");
                let mut h = vec![HitRecord::MISS; n];
                m.trace(
                    sorted,
                    tb_core::Batch::new(q, tri, &rays),
                    tb_core::Answers::hits(&mut h),
                );
                assert_eq!(h, plain.0, "{name}-sorted uncounted");
                // The walk traces each ray with the tree its entry names: another tree in the
                // hints changes the counters (so the comparisons above can fail).
                let next = |e: u32| e & RAY_MASK | (((e >> TREE_SHIFT) + 1) % 3) << TREE_SHIFT;
                let wrong: Vec<u32> = hints.iter().map(|&e| next(e)).collect();
                let (_, ws) = traced(&m, presorted, q, &rays, Some(&wrong));
                assert_ne!(ws, plain.1, "{name}: hints' trees ignored");
                for (k, r) in rays.iter().enumerate().step_by(3) {
                    let a = &alone[m.tree_of(r.dir.to_array())];
                    let (mut ha, mut sa) = ([HitRecord::MISS], [TraversalStats::default()]);
                    a.trace(
                        t,
                        tb_core::Batch::new(q, tri, std::slice::from_ref(r)),
                        tb_core::Answers::new(&mut ha, Some(&mut sa)),
                    );
                    assert_eq!(ha[0], plain.0[k]);
                    assert_eq!(sa[0], plain.1[k], "{name} ray {k}");
                }
            }
        }
    }

    /// The arrangement: per block, a stable counting sort by tree index, entries naming the
    /// ray within its block and its tree.
    #[test]
    fn arrangement_groups_by_tree_stably_per_block() {
        let m = MultiKdTree::build(&grid(), &MultiKdParams::default());
        let dirs = [
            Vec3::Z,
            Vec3::X,
            -Vec3::Y,
            Vec3::X,
            Vec3::new(0.1, 0.1, -1.0),
            Vec3::Y,
        ];
        let rays: Vec<Ray> = dirs.iter().map(|&d| Ray::new(Vec3::ZERO, d)).collect();
        let mut order = Vec::new();
        m.arrange(&rays, &mut order);
        let t = |i: u32, tree: u32| i | tree << TREE_SHIFT;
        assert_eq!(
            order,
            [t(1, 0), t(3, 0), t(2, 1), t(5, 1), t(0, 2), t(4, 2)]
        );
        // Blocks sort apart, numbering their rays from 0.
        let rays = random_rays(2 * ARRANGE_BLOCK + 5);
        m.arrange(&rays, &mut order);
        for (b, (block, entries)) in rays
            .chunks(ARRANGE_BLOCK)
            .zip(order.chunks(ARRANGE_BLOCK))
            .enumerate()
        {
            let mut seen = vec![false; block.len()];
            let mut last = None;
            for &e in entries {
                let (j, tree) = ((e & RAY_MASK) as usize, e >> TREE_SHIFT);
                assert!(
                    !std::mem::replace(&mut seen[j], true),
                    "block {b}: ray {j} twice"
                );
                assert_eq!(tree as usize, m.tree_of(block[j].dir.to_array()));
                assert!(last < Some((tree, j)), "block {b}: not stable by tree");
                last = Some((tree, j));
            }
            assert!(seen.iter().all(|&s| s));
        }
    }

    #[test]
    fn params_are_checked() {
        let tris: Arc<[Triangle]> = grid().into();
        let mut set = (FAMILY.defaults)();
        assert!((FAMILY.build)(&tris, &set).is_ok());
        set.0[1].1 = tb_core::ParamValue::Float(0.0);
        assert!((FAMILY.build)(&tris, &set).is_err());
        let mut set = (FAMILY.defaults)();
        set.0[0].1 = tb_core::ParamValue::Str("sphere".into());
        assert!((FAMILY.build)(&tris, &set).is_err());
    }
}
