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
//! - **Layout** (review §6, module `layout`): 8-byte [`KdNode`]s, leaves pointing into
//!   [`KdTree::prim_refs`] (original triangle indices), in depth-first order with the left
//!   child next to its parent (§6.1, the default) or in treelets: subtrees of a few levels in
//!   aligned blocks, children inside a block addressed implicitly (§6.2, Havran 1999).
//!   Every traversal is compiled per layout ([`Layout`]) and visits the same nodes in both.
//! - **Traversals** ([`TRAVERSALS`]): module `traverse`, the stack-based algorithms of review
//!   §3.2 (`recursive-direction`, `havran` (TA^B_rec), `recursive-origin`); module
//!   `stackless`, the restart-type ones of §3.1, §3.3, §5.1, §5.2 (`restart`, `push-down`,
//!   `short-stack`, `sequential`, `backtrack`, `ropes`). `recursive-origin` (origins in split
//!   planes) is inherently not robust; the others answer every ray of the conformance suite
//!   as brute force does.
//!
//! Robustness: triangle tests are never restricted to a leaf's interval (only to
//! `[tmin, closest hit)`), and traversal stops only when the next node to visit starts beyond
//! the closest hit found, so a hit found in a leaf beyond that leaf's exit never ends the walk
//! early. Clipped triangle boxes are made conservative (see `build`), so every triangle is
//! referenced in every leaf cell it touches.

mod build;
mod layout;
mod stackless;
mod traverse;

use serde::{Deserialize, Serialize};
use tb_core::{
    dispatch, Aabb, Accel, BuildReport, HitRecord, MemoryReport, Query, Ray, TraversalInfo,
    TraversalStats, TriTestKind, Triangle,
};

pub use layout::{DepthFirst, KdLayout, Layout, Nodes, Treelet};
pub use stackless::{MAX_SHORT_STACK, STEP_CAP};
pub use traverse::STACK_SIZE;

/// The traversals every [`KdTree`] offers (index = position, as passed to [`Accel::trace`]).
pub const TRAVERSALS: &[TraversalInfo] = &[
    TraversalInfo {
        name: "recursive-direction",
        doc: "stack-based, near/far child by the sign of the ray direction, entry/exit distances \
              on the stack (Keller 1997, Wald 2004; Hapala & Havran 2011 §3.2, Alg. 2); zero \
              direction components handled by the sign of the zero (no epsilon)",
    },
    TraversalInfo {
        name: "havran",
        doc: "Havran's robust TA^B_rec: entry/exit points on the stack, near/far decided by \
              comparing point coordinates with the split (Havran 2000; Hapala & Havran 2011 \
              §3.2); rays lying in a split plane visit both children",
    },
    TraversalInfo {
        name: "recursive-origin",
        doc: "stack-based, near/far child by the side of the split plane holding the ray origin \
              (Jansen 1986, Arvo 1988; Hapala & Havran 2011 §3.2, Alg. 2): inherently not \
              robust for origins in a split plane (Havran et al. 1997)",
    },
    TraversalInfo {
        name: "restart",
        doc: "stackless kd-restart: after each leaf restart at the root with the entry distance \
              set to the leaf's exit (Foley & Sugerman 2005; Hapala & Havran 2011 §5.1), \
              t-intervals and exact comparisons, no epsilon step",
    },
    TraversalInfo {
        name: "push-down",
        doc: "kd-push-down: restart at the deepest node holding the whole remaining segment \
              (Horn et al. 2007; Hapala & Havran 2011 §5.2, Alg. 4)",
    },
    TraversalInfo {
        name: "short-stack",
        doc: "push-down with a circular short stack of `short_stack` far children, restarting \
              from the pushed-down node when it runs dry (Horn et al. 2007; Hapala & Havran \
              2011 §5.2)",
    },
    TraversalInfo {
        name: "sequential",
        doc: "Kaplan's sequential traversal: locate the leaf holding the ray point at the entry \
              distance from the root, leave it through its cell's exit (Kaplan 1985; Hapala & \
              Havran 2011 §3.1, Alg. 1), no epsilon step: crossed faces' coordinates exact, \
              rays a point cannot decide (edges, corners) handed to `restart`",
    },
    TraversalInfo {
        name: "backtrack",
        doc: "kd-backtrack: parent links and node cells in an auxiliary array; from a leaf climb \
              until a cell extends beyond the leaf's exit, then descend (Foley & Sugerman 2005; \
              Hapala & Havran 2011 §5.1.1, Alg. 3)",
    },
    TraversalInfo {
        name: "ropes",
        doc: "neighbour links: from a leaf follow the pushed-down rope of its exit face (leaf \
              cells and six ropes per node in auxiliary arrays) and locate the next leaf below \
              it (MacDonald & Booth 1990, Havran et al. 1998, Popov et al. 2007; Hapala & \
              Havran 2011 §3.3)",
    },
    TraversalInfo {
        name: "branchless",
        doc: "recursive-direction with a branchless node step: far and near written to the \
              stack, the pointer moved by the two comparisons (Hapala 2009; Hapala & Havran \
              2011 §5.5, Alg. 5)",
    },
    TraversalInfo {
        name: "stack-spilling",
        doc: "short circular stack of `short_stack` entries whose oldest entry is spilled to a \
              full memory stack on overflow and refilled on underflow, never restarting \
              (Novák 2009; Hapala & Havran 2011 §5.2, Fig. 8)",
    },
];

/// The traversals that end a ray after [`KdParams::step_cap`] steps.
const CAPPED: &[&str] = &[
    "restart",
    "push-down",
    "short-stack",
    "sequential",
    "backtrack",
    "ropes",
];

/// Which split-search algorithm the builder uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum KdBuilder {
    /// Exact SAH sweep over events sorted once at the root and passed down, only the events
    /// of re-clipped straddling triangles sorted per node: O(N log N) (Wald and Havran 2006,
    /// §5). The same tree as `sweep-nlog2n`.
    Sweep,
    /// Exact SAH sweep over the sorted events of each node, the events sorted anew at every
    /// node: O(N log² N) (Wald and Havran 2006, §4.2).
    SweepNlog2n,
    /// SAH evaluated only at the `bins − 1` inner boundaries of `bins` equal intervals of the
    /// node cell on each axis, from per-bin counts of box starts and ends (min-max binning,
    /// Shevtsov et al. 2007; Hapala and Havran 2011 §2): O(N) per node.
    Binned,
}

/// Build parameters of [`KdTree::build`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct KdParams {
    /// Split-search algorithm: `sweep` (exact, O(N log N)), `sweep-nlog2n` (exact, the same
    /// tree, O(N log² N)) or `binned`. Default `sweep`.
    pub builder: KdBuilder,
    /// Bins per axis of the `binned` builder (ignored by the others). In `2..=1024`;
    /// default 32.
    pub bins: u32,
    /// SAH cost of a traversal step, `C_trav`. Finite, > 0; default 1.
    pub c_trav: f32,
    /// SAH cost of one ray–triangle test, `C_isect`. Finite, > 0; default 1.5 (Hapala and
    /// Havran's review uses `C_trav ≈ 1`, `C_isect ≈ 1.5`).
    pub c_isect: f32,
    /// Empty-space bonus: the SAH cost of a split with one empty child is multiplied by
    /// `1 − empty_bonus` (Wald and Havran 2006 use 0.8 as the factor, i.e. bonus 0.2).
    /// In `0..1`; default 0.2.
    pub empty_bonus: f32,
    /// Depth limit (root depth 0); 0 means automatic: `round(8 + 1.3·log2 N)` (Havran 2000),
    /// capped at [`STACK_SIZE`]. In `0..=STACK_SIZE`; default 0.
    pub max_depth: u32,
    /// Nodes with at most this many triangles always become leaves. In `0..=1024`; default 1.
    pub min_leaf: u32,
    /// Entries of the circular stack of the `short-stack` traversal (Horn et al. 2007). In
    /// `1..=MAX_SHORT_STACK` (32); default 4.
    pub short_stack: u32,
    /// Per-ray step cap of the restart-type traversals (`restart` … `ropes`): after this many
    /// steps (nodes visited) a ray is ended with its closest hit so far and counted in
    /// `capped_rays` (review §3.1: an epsilon step can loop forever; these walks provably end,
    /// the cap is a guard). At least 1; default [`STEP_CAP`] (100 000).
    pub step_cap: u32,
    /// Node layout (review §6): `depth-first` (left child next to its parent) or `treelet`
    /// (subtrees of `treelet_height` levels in aligned blocks, Havran 1999). Every traversal
    /// runs on either and visits the same nodes. Default `depth-first`.
    pub layout: KdLayout,
    /// Levels per treelet block of the `treelet` layout: blocks of `2^h` 8-byte slots (3: one
    /// 64-byte cache line). In `2..=8`; default 3.
    pub treelet_height: u32,
}

impl Default for KdParams {
    fn default() -> Self {
        Self {
            builder: KdBuilder::Sweep,
            bins: 32,
            c_trav: 1.0,
            c_isect: 1.5,
            empty_bonus: 0.2,
            max_depth: 0,
            min_leaf: 1,
            short_stack: 4,
            step_cap: STEP_CAP,
            layout: KdLayout::DepthFirst,
            treelet_height: 3,
        }
    }
}

impl KdParams {
    /// Check the parameters (ranges as documented on the fields).
    pub fn check(&self) -> Result<(), String> {
        if !(self.c_trav > 0.0 && self.c_trav.is_finite()) {
            return Err(format!(
                "c_trav must be positive and finite, got {}",
                self.c_trav
            ));
        }
        if !(self.c_isect > 0.0 && self.c_isect.is_finite()) {
            return Err(format!(
                "c_isect must be positive and finite, got {}",
                self.c_isect
            ));
        }
        if !(0.0..1.0).contains(&self.empty_bonus) {
            return Err(format!(
                "empty_bonus must be in [0, 1), got {}",
                self.empty_bonus
            ));
        }
        if self.max_depth as usize > STACK_SIZE {
            return Err(format!(
                "max_depth must be at most {STACK_SIZE} (0 = automatic), got {}",
                self.max_depth
            ));
        }
        if self.min_leaf > 1024 {
            return Err(format!(
                "min_leaf must be at most 1024, got {}",
                self.min_leaf
            ));
        }
        if !(2..=1024).contains(&self.bins) {
            return Err(format!("bins must be in 2..=1024, got {}", self.bins));
        }
        if !(1..=MAX_SHORT_STACK as u32).contains(&self.short_stack) {
            return Err(format!(
                "short_stack must be in 1..={MAX_SHORT_STACK}, got {}",
                self.short_stack
            ));
        }
        if self.step_cap == 0 {
            return Err("step_cap must be at least 1".into());
        }
        if !(2..=8).contains(&self.treelet_height) {
            return Err(format!(
                "treelet_height must be in 2..=8, got {}",
                self.treelet_height
            ));
        }
        Ok(())
    }

    /// The depth limit for `n` triangles: `max_depth`, or when 0, `round(8 + 1.3·log2 n)`
    /// capped at [`STACK_SIZE`].
    pub fn depth_limit(&self, n: usize) -> u32 {
        if self.max_depth > 0 {
            return self.max_depth;
        }
        let d = 8.0 + 1.3 * (n.max(1) as f64).log2();
        (d.round() as u32).min(STACK_SIZE as u32)
    }
}

/// The measure of a cell used by the SAH: the probability that a ray hitting a node's cell
/// hits a child cell is taken as `measure(child) / measure(node)`.
pub trait BoxMeasure: Sync {
    fn measure(&self, b: &Aabb) -> f32;
}

/// The surface area (half of it; only ratios matter): uniformly distributed rays.
#[derive(Clone, Copy, Debug, Default)]
pub struct SurfaceArea;

impl BoxMeasure for SurfaceArea {
    #[inline(always)]
    fn measure(&self, b: &Aabb) -> f32 {
        b.half_area()
    }
}

/// One node of the flattened tree, 8 bytes (review §6; `#[repr(C)]`, two GPU words).
///
/// | | `bits` | `data` |
/// |---|---|---|
/// | interior | `link << 2 \| axis` (axis 0, 1, 2) | split position (`f32` bits) |
/// | leaf | `count << 2 \| 3` | offset of the first reference in [`KdTree::prim_refs`] |
///
/// The root is node 0. Where the children are depends on the layout ([`Layout`]): in the
/// default depth-first order the left child is the next node and the link is the right
/// child's index; in the treelet layout the link is used only on a block's lowest level.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct KdNode {
    pub bits: u32,
    pub data: u32,
}

const _: () = assert!(std::mem::size_of::<KdNode>() == 8);

impl KdNode {
    /// An interior node splitting `axis` at `split`, with link `link` (see [`Layout`]).
    pub fn interior(axis: usize, split: f32, link: u32) -> KdNode {
        debug_assert!(axis < 3 && link < (1 << 30));
        KdNode {
            bits: link << 2 | axis as u32,
            data: split.to_bits(),
        }
    }

    /// A leaf of `count` references starting at `offset`.
    pub fn leaf(offset: u32, count: u32) -> KdNode {
        debug_assert!(count < (1 << 30));
        KdNode {
            bits: count << 2 | 3,
            data: offset,
        }
    }

    #[inline(always)]
    pub fn is_leaf(&self) -> bool {
        self.bits & 3 == 3
    }

    /// Split axis of an interior node (3 for a leaf).
    #[inline(always)]
    pub fn axis(&self) -> usize {
        (self.bits & 3) as usize
    }

    /// Split position of an interior node.
    #[inline(always)]
    pub fn split(&self) -> f32 {
        f32::from_bits(self.data)
    }

    /// Link of an interior node: the right child in the depth-first layout (the left child is
    /// the node's index + 1), the first child slot on a treelet block's lowest level.
    #[inline(always)]
    pub fn link(&self) -> usize {
        (self.bits >> 2) as usize
    }

    /// Number of references of a leaf.
    #[inline(always)]
    pub fn count(&self) -> u32 {
        self.bits >> 2
    }

    /// Offset of a leaf's first reference.
    #[inline(always)]
    pub fn offset(&self) -> usize {
        self.data as usize
    }
}

/// A kd-tree over triangles (see the crate doc).
///
/// Per-ray counters (`TraversalStats`) of the stack traversals (the restart-type ones count
/// as documented in module `stackless`: `restarts` and cell-interval `boxes` added):
/// - `interior`: interior nodes visited; `leaves`: leaves visited (empty ones included);
/// - `prims`: ray–triangle tests (a triangle referenced by several leaves may be tested more
///   than once: no mailboxing);
/// - `planes`: ray–split-plane distances computed (`havran`: only where the ray crosses);
/// - `boxes`: 1 (the root cell, tested first);
/// - `steps`: nodes visited (`interior + leaves`);
/// - `restarts`: 0.
#[derive(Clone, Debug)]
pub struct KdTree {
    nodes: Nodes,
    prim_refs: Vec<u32>,
    tris: Vec<Triangle>,
    bounds: Aabb,
    params: KdParams,
    /// Per node: its cell and its parent (the `backtrack` traversal's auxiliary array; cells
    /// also used by `ropes`).
    back: Vec<BackNode>,
    /// Per node: its six ropes (the `ropes` traversal's auxiliary array).
    ropes: Vec<[u32; 6]>,
}

/// The auxiliary record of a node for the `backtrack` traversal (Foley and Sugerman 2005):
/// the node's cell and its parent's index (0 for the root). 32 bytes, `#[repr(C)]`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BackNode {
    pub min: [f32; 3],
    pub parent: u32,
    pub max: [f32; 3],
    pub pad: u32,
}

const _: () = assert!(std::mem::size_of::<BackNode>() == 32);

impl KdTree {
    /// Build a kd-tree over `tris` with `params` and the surface-area measure
    /// (single-threaded). Panics if `params.check()` fails or there are 2^30 or more triangles.
    /// Triangles with non-finite vertices are left out (no ray can hit them).
    pub fn build(tris: &[Triangle], params: &KdParams) -> KdTree {
        Self::build_with(tris, params, &SurfaceArea)
    }

    /// [`KdTree::build`] with another cell measure for the SAH.
    pub fn build_with<M: BoxMeasure>(tris: &[Triangle], params: &KdParams, m: &M) -> KdTree {
        if let Err(e) = params.check() {
            panic!("invalid kd-tree parameters: {e}");
        }
        assert!(
            tris.len() < (1 << 30),
            "a kd-tree holds fewer than 2^30 triangles"
        );
        let out = build::build(tris, params, m);
        let nodes = match params.layout {
            KdLayout::DepthFirst => Nodes::from_slice(&out.nodes),
            KdLayout::Treelet => {
                Nodes::from_slice(&layout::to_treelets(&out.nodes, params.treelet_height))
            }
        };
        let mut kd = KdTree {
            nodes,
            prim_refs: out.prim_refs,
            tris: tris.to_vec(),
            bounds: out.bounds,
            params: *params,
            back: Vec::new(),
            ropes: Vec::new(),
        };
        let mut back = vec![
            BackNode {
                min: [0.0; 3],
                parent: 0,
                max: [0.0; 3],
                pad: 0,
            };
            kd.nodes.len()
        ];
        kd.walk(|i, cell, _| {
            back[i].min = cell.min.to_array();
            back[i].max = cell.max.to_array();
            if !kd.nodes[i].is_leaf() {
                let (l, r) = kd.children(i);
                back[l].parent = i as u32;
                back[r].parent = i as u32;
            }
        });
        kd.back = back;
        kd.ropes = stackless::build_ropes(&kd);
        kd
    }

    /// The `backtrack` traversal's auxiliary array (cell and parent per node), included in
    /// [`Accel::memory`].
    pub fn back_nodes(&self) -> &[BackNode] {
        &self.back
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
        let n = self.nodes[i];
        match self.params.layout {
            KdLayout::DepthFirst => DepthFirst.children(i, n),
            KdLayout::Treelet => Treelet::new(self.params.treelet_height).children(i, n),
        }
    }

    /// Call `f(node_index, cell, depth)` for every node, depth-first from the root.
    fn walk(&self, mut f: impl FnMut(usize, &Aabb, u32)) {
        if self.nodes.is_empty() {
            return;
        }
        let mut stack = vec![(0usize, self.bounds, 0u32)];
        while let Some((i, cell, d)) = stack.pop() {
            f(i, &cell, d);
            let n = self.nodes[i];
            if !n.is_leaf() {
                let (l, r) = split_cell(&cell, n.axis(), n.split());
                let (li, ri) = self.children(i);
                stack.push((ri, r, d + 1));
                stack.push((li, l, d + 1));
            }
        }
    }

    fn check_invariants(&self) -> Result<(), String> {
        let nodes = &self.nodes;
        let n_tris = self.tris.len();
        if nodes.is_empty() {
            return if self.prim_refs.is_empty() {
                Ok(())
            } else {
                Err("references without nodes".into())
            };
        }
        if let Some(k) = self.prim_refs.iter().position(|&r| r as usize >= n_tris) {
            return Err(format!("prim_refs[{k}] out of range ({n_tris} triangles)"));
        }
        let depth_limit = self.params.depth_limit(n_tris) as usize;
        let mut visited = vec![false; nodes.len()];
        let mut referenced = vec![false; n_tris];
        let mut stack = vec![(0usize, self.bounds, 0usize)];
        while let Some((i, cell, depth)) = stack.pop() {
            if i >= nodes.len() {
                return Err(format!("node index {i} out of range ({})", nodes.len()));
            }
            if std::mem::replace(&mut visited[i], true) {
                return Err(format!("node {i} reached twice (cycle or shared child)"));
            }
            if depth > depth_limit || depth > STACK_SIZE {
                return Err(format!("node {i} at depth {depth} exceeds the depth limit"));
            }
            let n = nodes[i];
            if n.is_leaf() {
                let (o, c) = (n.offset(), n.count() as usize);
                if o + c > self.prim_refs.len() {
                    return Err(format!(
                        "leaf {i}: references {o}..{} out of range ({})",
                        o + c,
                        self.prim_refs.len()
                    ));
                }
                for &r in &self.prim_refs[o..o + c] {
                    referenced[r as usize] = true;
                    let tb = self.tris[r as usize].bounds();
                    let tol = build::tolerance(&tb);
                    let grown = Aabb::new(tb.min - tol, tb.max + tol);
                    if intersect(&grown, &cell).is_empty() {
                        return Err(format!(
                            "leaf {i}: triangle {r} does not overlap the leaf cell"
                        ));
                    }
                }
            } else {
                let ((l, r), s) = (self.children(i), n.split());
                let a = n.axis();
                // Children after their parent (so no cycles), distinct, in range.
                if l <= i || r <= l || r >= nodes.len() {
                    return Err(format!("node {i}: children {l}, {r} invalid"));
                }
                if !(s >= cell.min[a] && s <= cell.max[a]) {
                    return Err(format!("node {i}: split {s} outside its cell on axis {a}"));
                }
                let (lc, rc) = split_cell(&cell, a, s);
                stack.push((r, rc, depth + 1));
                stack.push((l, lc, depth + 1));
            }
        }
        // Every node is reachable; the treelet layout's unused slots stay empty.
        let unused =
            |i: usize| self.params.layout == KdLayout::Treelet && nodes[i] == layout::EMPTY_SLOT;
        if let Some(i) = (0..nodes.len()).find(|&i| !visited[i] && !unused(i)) {
            return Err(format!("node {i} is unreachable from the root"));
        }
        for (k, t) in self.tris.iter().enumerate() {
            let finite = t.v0.is_finite() && t.v1.is_finite() && t.v2.is_finite();
            if finite && !referenced[k] {
                return Err(format!("triangle {k} is referenced by no leaf"));
            }
        }
        Ok(())
    }
}

/// The two children's cells of `cell` split on `axis` at `s`.
pub(crate) fn split_cell(cell: &Aabb, axis: usize, s: f32) -> (Aabb, Aabb) {
    let (mut l, mut r) = (*cell, *cell);
    l.max[axis] = s;
    r.min[axis] = s;
    (l, r)
}

/// Intersection of two boxes (empty when disjoint).
pub(crate) fn intersect(a: &Aabb, b: &Aabb) -> Aabb {
    Aabb {
        min: a.min.max(b.min),
        max: a.max.min(b.max),
    }
}

impl Accel for KdTree {
    fn name(&self) -> &'static str {
        "kdtree"
    }

    fn traversals(&self) -> &'static [TraversalInfo] {
        TRAVERSALS
    }

    /// The restart-type traversals (`restart`, `push-down`, `short-stack`, `sequential`,
    /// `backtrack`, `ropes`) end a ray after [`KdParams::step_cap`] steps.
    fn has_step_cap(&self, traversal: usize) -> bool {
        TRAVERSALS
            .get(traversal)
            .is_some_and(|t| CAPPED.contains(&t.name))
    }

    /// All arrays any traversal reads: nodes, references, triangles, and the auxiliary arrays
    /// of `backtrack` and `ropes` (32 + 24 bytes per node; their sizes are also in the build
    /// report, to subtract for the other traversals).
    fn memory(&self) -> MemoryReport {
        MemoryReport {
            bytes: (self.nodes.bytes()
                + std::mem::size_of_val(self.prim_refs.as_slice())
                + std::mem::size_of_val(self.tris.as_slice())
                + std::mem::size_of_val(self.back.as_slice())
                + std::mem::size_of_val(self.ropes.as_slice())) as u64,
            nodes: self.nodes.len() as u64,
            prim_refs: self.prim_refs.len() as u64,
            node_bytes: std::mem::size_of::<KdNode>() as u32,
        }
    }

    /// Nodes, references and triangles for every traversal; `backtrack` adds the cell and
    /// parent per node, `ropes` those and the six ropes per node (review Table 3, "additional
    /// memory").
    fn memory_for(&self, traversal: usize) -> MemoryReport {
        let mut m = self.memory();
        let back = std::mem::size_of_val(self.back.as_slice()) as u64;
        let ropes = std::mem::size_of_val(self.ropes.as_slice()) as u64;
        m.bytes -= match TRAVERSALS.get(traversal).map(|t| t.name) {
            Some("ropes") => 0,
            Some("backtrack") => ropes,
            _ => back + ropes,
        };
        m
    }

    /// `sah_cost = (C_trav·Σ_interior A(n) + C_isect·Σ_leaves A(l)·|l|) / A(root)` with `A` the
    /// surface area of the cells (`None` for an empty tree or a root of zero area); extra
    /// figures: `nodes`, `slots` (entries of the node array: `nodes` depth-first, more in the
    /// treelet layout, whose unused slots count in the memory), `leaves`, `empty_leaves`, `references`, `depth_max` (root 0),
    /// `leaf_depth_mean`, `refs_per_leaf_mean` (over non-empty leaves), `leaf_size_max`, and
    /// the bytes of the auxiliary arrays included in [`Accel::memory`]: `backtrack_aux_bytes`
    /// (cell and parent per node, read by `backtrack` and `ropes`) and `ropes_aux_bytes` (six
    /// ropes per node, read by `ropes`).
    fn build_report(&self) -> BuildReport {
        let (mut interior, mut leaves, mut empty) = (0u64, 0u64, 0u64);
        let (mut depth_max, mut depth_sum, mut leaf_max) = (0u32, 0u64, 0u32);
        let (mut ia, mut la) = (0f64, 0f64);
        self.walk(|i, cell, d| {
            let n = self.nodes[i];
            let a = cell.area() as f64;
            depth_max = depth_max.max(d);
            if n.is_leaf() {
                leaves += 1;
                empty += (n.count() == 0) as u64;
                depth_sum += d as u64;
                leaf_max = leaf_max.max(n.count());
                la += a * n.count() as f64;
            } else {
                interior += 1;
                ia += a;
            }
        });
        let root = self.bounds.area() as f64;
        let sah = (self.params.c_trav as f64 * ia + self.params.c_isect as f64 * la) / root;
        BuildReport {
            sah_cost: (!self.nodes.is_empty() && root > 0.0 && sah.is_finite()).then_some(sah),
            extra: vec![
                ("nodes".into(), (interior + leaves) as f64),
                ("slots".into(), self.nodes.len() as f64),
                ("leaves".into(), leaves as f64),
                ("empty_leaves".into(), empty as f64),
                ("references".into(), self.prim_refs.len() as f64),
                ("depth_max".into(), depth_max as f64),
                (
                    "leaf_depth_mean".into(),
                    depth_sum as f64 / leaves.max(1) as f64,
                ),
                (
                    "refs_per_leaf_mean".into(),
                    self.prim_refs.len() as f64 / (leaves - empty).max(1) as f64,
                ),
                ("leaf_size_max".into(), leaf_max as f64),
                (
                    "backtrack_aux_bytes".into(),
                    std::mem::size_of_val(self.back.as_slice()) as f64,
                ),
                (
                    "ropes_aux_bytes".into(),
                    std::mem::size_of_val(self.ropes.as_slice()) as f64,
                ),
            ],
        }
    }

    /// Checks: node and reference indices in range, children after their parent and distinct
    /// (so no cycles), the treelet layout's unused slots empty, every node reachable exactly once, depth within the limit and the
    /// traversal stack, split positions inside their cells, every referenced triangle's box
    /// overlapping its leaf cell (up to the builder's rounding tolerance), every finite
    /// triangle referenced by at least one leaf.
    fn validate(&self) -> Result<(), String> {
        self.check_invariants()
    }

    fn trace(
        &self,
        traversal: usize,
        query: Query,
        tri: TriTestKind,
        rays: &[Ray],
        hits: &mut [HitRecord],
        stats: Option<&mut [TraversalStats]>,
    ) {
        match self.params.layout {
            KdLayout::DepthFirst => {
                self.trace_in(DepthFirst, traversal, query, tri, rays, hits, stats)
            }
            KdLayout::Treelet => self.trace_in(
                Treelet::new(self.params.treelet_height),
                traversal,
                query,
                tri,
                rays,
                hits,
                stats,
            ),
        }
    }
}

impl KdTree {
    /// [`Accel::trace`] with the kernels compiled for layout `l`.
    fn trace_in<L: Layout>(
        &self,
        l: L,
        traversal: usize,
        query: Query,
        tri: TriTestKind,
        rays: &[Ray],
        hits: &mut [HitRecord],
        stats: Option<&mut [TraversalStats]>,
    ) {
        match traversal {
            0 => dispatch(
                &traverse::RecursiveDirection(self, l),
                query,
                tri,
                rays,
                hits,
                stats,
            ),
            1 => dispatch(&traverse::Havran(self, l), query, tri, rays, hits, stats),
            2 => dispatch(
                &traverse::RecursiveOrigin(self, l),
                query,
                tri,
                rays,
                hits,
                stats,
            ),
            3 => dispatch(
                &stackless::Stackless::<_, { stackless::RESTART }>(self, l),
                query,
                tri,
                rays,
                hits,
                stats,
            ),
            4 => dispatch(
                &stackless::Stackless::<_, { stackless::PUSH_DOWN }>(self, l),
                query,
                tri,
                rays,
                hits,
                stats,
            ),
            5 => dispatch(
                &stackless::Stackless::<_, { stackless::SHORT_STACK }>(self, l),
                query,
                tri,
                rays,
                hits,
                stats,
            ),
            6 => dispatch(
                &stackless::Stackless::<_, { stackless::SEQUENTIAL }>(self, l),
                query,
                tri,
                rays,
                hits,
                stats,
            ),
            7 => dispatch(
                &stackless::Stackless::<_, { stackless::BACKTRACK }>(self, l),
                query,
                tri,
                rays,
                hits,
                stats,
            ),
            8 => dispatch(
                &stackless::Stackless::<_, { stackless::ROPES }>(self, l),
                query,
                tri,
                rays,
                hits,
                stats,
            ),
            9 => dispatch(
                &traverse::Branchless(self, l),
                query,
                tri,
                rays,
                hits,
                stats,
            ),
            10 => dispatch(
                &traverse::StackSpilling(self, l),
                query,
                tri,
                rays,
                hits,
                stats,
            ),
            _ => panic!(
                "kdtree: unknown traversal {traversal} ({} available)",
                TRAVERSALS.len()
            ),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tb_core::Vec3;

    fn grid() -> Vec<Triangle> {
        (0..64)
            .map(|i| {
                let p = Vec3::new((i % 8) as f32, (i / 8) as f32, (i % 3) as f32);
                Triangle::new(p, p + Vec3::X * 0.9, p + Vec3::Y * 0.9)
            })
            .collect()
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
        let bad = [
            KdParams {
                c_trav: 0.0,
                ..Default::default()
            },
            KdParams {
                c_isect: f32::NAN,
                ..Default::default()
            },
            KdParams {
                empty_bonus: 1.0,
                ..Default::default()
            },
            KdParams {
                max_depth: STACK_SIZE as u32 + 1,
                ..Default::default()
            },
            KdParams {
                bins: 1,
                ..Default::default()
            },
            KdParams {
                short_stack: 0,
                ..Default::default()
            },
        ];
        for p in bad {
            assert!(p.check().is_err(), "{p:?}");
        }
        assert_eq!(KdParams::default().depth_limit(1 << 20), 34);
    }

    #[test]
    fn validate_finds_corruption() {
        let good = KdTree::build(&grid(), &KdParams::default());
        assert_eq!(good.validate(), Ok(()));
        assert!(good.nodes().len() > 1);
        let leaf = good
            .nodes()
            .iter()
            .position(|n| n.is_leaf() && n.count() > 0);
        let leaf = leaf.unwrap();

        let mut b = good.clone();
        b.nodes[0] = KdNode::interior(b.nodes[0].axis(), b.nodes[0].split(), 0);
        assert!(b.validate().unwrap_err().contains("children"));

        let mut b = good.clone();
        b.prim_refs[0] = 1000;
        assert!(b.validate().unwrap_err().contains("out of range"));

        let mut b = good.clone();
        let n = b.nodes[leaf];
        b.nodes[leaf] = KdNode::leaf(n.offset() as u32, 10_000);
        assert!(b.validate().is_err());

        let mut b = good.clone();
        let mut v = b.nodes().to_vec();
        v.push(KdNode::leaf(0, 1));
        b.nodes = Nodes::from_slice(&v);
        assert!(b.validate().unwrap_err().contains("unreachable"));

        // A reference far from its leaf's cell.
        let mut b = good.clone();
        b.tris.push(Triangle::new(
            Vec3::splat(100.0),
            Vec3::splat(101.0),
            Vec3::new(100.0, 101.0, 100.0),
        ));
        let o = b.nodes[leaf].offset();
        b.prim_refs[o] = 64;
        assert!(b.validate().is_err());
    }

    #[test]
    fn validate_checks_the_treelet_layout() {
        let p = KdParams {
            layout: KdLayout::Treelet,
            ..Default::default()
        };
        let good = KdTree::build(&grid(), &p);
        assert_eq!(good.validate(), Ok(()));
        // An unused slot that is not empty.
        let free = good
            .nodes()
            .iter()
            .position(|n| *n == layout::EMPTY_SLOT)
            .unwrap();
        let mut b = good.clone();
        b.nodes[free] = KdNode::leaf(0, 1);
        assert!(b.validate().unwrap_err().contains("unreachable"));
        // A lowest-level link pointing back into the tree.
        let low = (0..good.nodes().len())
            .find(|&i| !good.nodes()[i].is_leaf() && i % 8 >= 3)
            .unwrap();
        let mut b = good.clone();
        let n = b.nodes[low];
        b.nodes[low] = KdNode::interior(n.axis(), n.split(), 0);
        assert!(b.validate().unwrap_err().contains("children"));
        // The same tree in fewer bytes depth-first.
        let dfs = KdTree::build(&grid(), &KdParams::default());
        assert!(good.memory().bytes > dfs.memory().bytes);
    }

    #[test]
    fn build_report_and_memory() {
        let kd = KdTree::build(&grid(), &KdParams::default());
        let r = kd.build_report();
        assert!(r.sah_cost.unwrap() > 0.0);
        let get = |k: &str| r.extra.iter().find(|(n, _)| n == k).unwrap().1;
        assert_eq!(get("nodes") as usize, kd.nodes().len());
        assert_eq!(get("references") as usize, kd.prim_refs().len());
        let m = kd.memory();
        assert_eq!(m.node_bytes, 8);
        assert!(m.bytes as usize > kd.nodes().len() * (8 + 32 + 24));
        // Empty scenes build and miss.
        let e = KdTree::build(&[], &KdParams::default());
        assert_eq!(e.validate(), Ok(()));
        let rays = [Ray::new(Vec3::ZERO, Vec3::X)];
        let mut hits = [HitRecord::MISS; 1];
        for t in 0..TRAVERSALS.len() {
            e.trace(
                t,
                Query::Closest,
                TriTestKind::Watertight,
                &rays,
                &mut hits,
                None,
            );
            assert!(!hits[0].is_hit());
        }
    }
}
