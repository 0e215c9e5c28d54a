//! Top-down SAH build with perfect splits (Havran 2000 §4; Wald and Havran 2006, "On building
//! fast kd-trees for ray tracing, and on doing that in O(N log N)", §4).
//!
//! Every node keeps one [`Ref`] per triangle overlapping its cell: the triangle's index and a
//! *conservative clipped box*, a box containing the part of the triangle inside the cell.
//! Per node and axis the builder
//! 1. makes the events of the boxes: `start` at `min`, `end` at `max`, `planar` where
//!    `min == max`, sorted by position and then type (end < planar < start);
//! 2. sweeps the events, keeping the counts left, right and in the plane (Wald–Havran Alg. 4),
//!    and evaluates at every event position strictly inside the cell the SAH cost
//!    `λ·(C_trav + C_isect·(P_L·N_L + P_R·N_R))`, `P = measure(child) / measure(node)`,
//!    `λ = 1 − empty_bonus` when a side is empty, the planar triangles put on the side of
//!    lower cost;
//! 3. makes a leaf when the node has at most `min_leaf` triangles, is at the depth limit, has a
//!    cell of measure 0, or when the leaf cost `C_isect·N` is at most the best split's;
//!    otherwise classifies the references (as the sweep counted them: a box ending at the
//!    plane goes left, one starting there right, a planar one in the plane to its chosen side)
//!    and re-clips the triangles straddling the plane to each child cell.
//!
//! Clipping ([`tb_core::clip::clip_box`], shared with the SBVH builder) is Sutherland–Hodgman
//! against the cell's six planes. An intersection point gets the
//! clipping plane's coordinate exactly, but its other coordinates are rounded, so the bounds
//! of the clipped polygon are grown by [`tolerance`] (64 ulps of the triangle's coordinate
//! magnitude) and then cut back to the cell and to the reference's previous box: sides that lie
//! on an original vertex or on a cell plane stay exact (axis-aligned triangles stay planar),
//! the others become slightly conservative, so a triangle is referenced by every leaf cell it
//! touches. Should clipping leave nothing (rounding), the cut-back box is kept.

use crate::{split_cell, BoxMeasure, KdBuilder, KdNode, KdParams};
use std::sync::atomic::{AtomicU64, Ordering};
use tb_core::{Aabb, Triangle};

pub struct Output {
    pub nodes: Vec<KdNode>,
    pub prim_refs: Vec<u32>,
    pub bounds: Aabb,
    /// Leaves made because the reference budget was reached ([`MAX_REFS_PER_TRIANGLE`]).
    pub budget_leaves: u64,
}

/// A triangle reference of a node: its conservative clipped box and its scene index.
#[derive(Clone, Copy)]
struct Ref {
    b: Aabb,
    id: u32,
}

use tb_core::clip::clip_box;
pub use tb_core::clip::tolerance;

/// Sortable key of an event: the position's order-preserving bits, then the type.
#[inline(always)]
fn key(pos: f32, ty: u64) -> u64 {
    let bits = (pos + 0.0).to_bits(); // -0 → +0
    let ord = if bits >> 31 != 0 {
        !bits
    } else {
        bits | 0x8000_0000
    };
    (ord as u64) << 2 | ty
}

#[inline(always)]
fn key_pos(k: u64) -> f32 {
    let ord = (k >> 2) as u32;
    let bits = if ord >> 31 != 0 {
        ord & 0x7fff_ffff
    } else {
        !ord
    };
    f32::from_bits(bits)
}

const END: u64 = 0;
const PLANAR: u64 = 1;
const START: u64 = 2;

#[derive(Clone, Copy)]
struct Split {
    axis: usize,
    pos: f32,
    cost: f32,
    planar_left: bool,
    /// References of the two children together, as the SAH counted them (the straddling
    /// triangles twice): what the split adds is `refs − n` (the reference budget's charge).
    refs: u32,
}

/// Keep the split at `pos` on `axis` of SAH `cost` as the best if it costs less than the best
/// so far (the first of equal costs stays); `refs`: the children's references together.
#[inline(always)]
fn keep_cheaper(
    best: &mut Option<Split>,
    axis: usize,
    pos: f32,
    cost: f32,
    planar_left: bool,
    refs: u32,
) {
    if cost < best.map_or(f32::INFINITY, |b| b.cost) {
        *best = Some(Split {
            axis,
            pos,
            cost,
            planar_left,
            refs,
        });
    }
}

/// The most references a tree may hold per (finite) triangle. Splits duplicate the references
/// of the triangles they cut; on the paper scenes a tree holds 1.3 to 5.5 per triangle, but
/// overlapping coplanar triangles can make every split cut nearly all of them (2,000 such
/// triangles made 190M references and gigabytes before this bound). Beyond it the builder
/// makes leaves instead of splits, in its fixed depth-first order, so the tree stays
/// deterministic; `build_stats` then counts those leaves (`ref_budget_leaves`). A bound that
/// holds for any input: references ≤ 16·N, and the build's memory with them.
pub const MAX_REFS_PER_TRIANGLE: u64 = 16;

/// The SAH of a cell's candidate planes: the children's shares of the cell's measure and
/// the cost of a split.
struct Pricing<'c, M: BoxMeasure> {
    m: &'c M,
    scale: f32,
    cell: &'c Aabb,
    /// `1 / measure(cell)`.
    inv_area: f32,
    ct: f32,
    ci: f32,
    /// `1 − empty_bonus`: the factor of a split with an empty side.
    lambda: f32,
}

impl<M: BoxMeasure> Pricing<'_, M> {
    /// The children's shares of the cell's measure at plane `pos` on `axis`.
    #[inline(always)]
    fn shares(&self, axis: usize, pos: f32) -> (f32, f32) {
        let (lc, rc) = split_cell(self.cell, axis, pos);
        (
            scaled_measure(self.m, self.scale, &lc) * self.inv_area,
            scaled_measure(self.m, self.scale, &rc) * self.inv_area,
        )
    }

    /// The SAH of `l` and `r` references on the two sides of shares `(pl, pr)` (the empty
    /// bonus where a side is empty).
    #[inline(always)]
    fn sah(&self, (pl, pr): (f32, f32), l: u32, r: u32) -> f32 {
        let c = self.ct + self.ci * (pl * l as f32 + pr * r as f32);
        if l == 0 || r == 0 {
            c * self.lambda
        } else {
            c
        }
    }
}

struct Builder<'a, M: BoxMeasure> {
    tris: &'a [Triangle],
    p: &'a KdParams,
    m: &'a M,
    /// A power of two the cells are scaled by before they are measured (1 but for scenes
    /// whose areas leave f32's range, [`measure_scale`]): the SAH's ratios are unchanged, bit
    /// for bit, and a scene at 1e30 or 1e-30 is split as the same scene at 1.
    scale: f32,
    depth_limit: u32,
    /// References splits may add beyond the triangles' own ([`MAX_REFS_PER_TRIANGLE`]).
    extra_budget: u64,
    /// References splits have added so far.
    extra: u64,
    /// Leaves made because a split would have gone over the budget.
    budget_leaves: u64,
    /// Build the children of large nodes as rayon tasks ([`Builder::children`]).
    parallel: bool,
    /// A parallel build's charges to the budget, shared by its tasks ([`build`]).
    shared: Option<&'a AtomicU64>,
    nodes: Vec<KdNode>,
    refs: Vec<u32>,
    events: Vec<u64>,
    /// Per-bin start and end counts of the binned builder.
    bins: Vec<u32>,
    /// Per-bin least start and greatest end of the binned builder.
    bin_bounds: Vec<f32>,
}

/// The power of two [`scaled_measure`] scales cells by: 1 where the scene's extent lies in
/// `[2⁻³², 2³²]` (every cell's area then stays in f32's range and the scaling would change
/// nothing), else the power of two that brings the largest extent to about 1 (without it,
/// at 1e30 every area overflowed, at 1e-30 every area was 0, and the builds stopped
/// at the root).
fn measure_scale(bounds: &Aabb) -> f32 {
    let e = bounds.extent().max_element();
    if !(e.is_finite() && e > 0.0) || (2f32.powi(-32)..=2f32.powi(32)).contains(&e) {
        return 1.0;
    }
    2f32.powi(-e.log2().round() as i32)
}

/// The measure `m` of `cell` scaled by `scale` (exact: a power of two).
#[inline(always)]
fn scaled_measure<M: BoxMeasure>(m: &M, scale: f32, cell: &Aabb) -> f32 {
    if scale == 1.0 {
        m.measure(cell)
    } else {
        m.measure(&Aabb::new(cell.min * scale, cell.max * scale))
    }
}

impl<M: BoxMeasure> Builder<'_, M> {
    /// Whether splitting `n` references at `s` stays within the reference budget (charged
    /// with the children's references the SAH counted, so no further pass over them).
    /// A parallel build charges its tasks' splits in whatever order they come, to the counter
    /// they share.
    fn within_budget(&mut self, n: usize, s: &Split) -> bool {
        let added = (s.refs as u64).saturating_sub(n as u64);
        let ok = match self.shared {
            None => self.extra + added <= self.extra_budget,
            Some(total) => total.fetch_add(added, Ordering::Relaxed) + added <= self.extra_budget,
        };
        self.budget_leaves += u64::from(!ok);
        ok
    }

    /// Charge a split of `n` references into children of `children` references in all, the
    /// SAH having counted `counted` ([`Split::refs`]). A parallel build's shared counter takes
    /// the larger of the two, so that it bounds what the serial build checks at every split
    /// ([`build`]).
    fn charge(&mut self, n: u64, counted: u32, children: usize) {
        let added = (children as u64).saturating_sub(n);
        self.extra += added;
        if let Some(total) = self.shared {
            let more = added.saturating_sub((counted as u64).saturating_sub(n));
            total.fetch_add(more, Ordering::Relaxed);
        }
    }

    /// The cheapest split of the cell `cell` holding `refs` by the SAH, if it costs less than
    /// a leaf: min-max binning (Shevtsov et al. 2007) for the binned builder on nodes of more
    /// references than bins, else the exact event sweep (Wald and Havran 2006; the events
    /// `sorted` per axis when given, else sorted here).
    fn find_split(
        &mut self,
        refs: &[Ref],
        cell: &Aabb,
        sorted: Option<&[Events; 3]>,
    ) -> Option<Split> {
        let (m, scale) = (self.m, self.scale);
        let area = scaled_measure(m, scale, cell);
        if !(area > 0.0 && area.is_finite()) {
            return None;
        }
        let ci = self.p.sah.c_isect;
        let price = Pricing {
            m,
            scale,
            cell,
            inv_area: 1.0 / area,
            ct: self.p.sah.c_trav,
            ci,
            lambda: 1.0 - self.p.sah.empty_bonus,
        };
        let n = refs.len() as u32;
        let mut best: Option<Split> = None;
        // Min-max binning for nodes of more references than bins; at most that many, the
        // exact sweep, as Shevtsov et al. 2007 switch (binning there would evaluate more
        // candidates than the sweep's 2n, and worse ones).
        if self.p.sah.builder == KdBuilder::Binned && refs.len() > self.p.sah.bins as usize {
            for axis in 0..3 {
                self.binned_axis(refs, &price, axis, &mut best);
            }
            return best.filter(|b| b.cost < ci * n as f32);
        }
        for axis in 0..3 {
            self.sweep_axis(refs, &price, axis, sorted, &mut best);
        }
        best.filter(|b| b.cost < ci * n as f32)
    }

    /// The binned candidates on `axis` (boundaries and, with `snap`, the extreme bounds in
    /// the bins beside them), each kept in `best` if cheaper.
    #[inline]
    fn binned_axis(
        &mut self,
        refs: &[Ref],
        price: &Pricing<'_, M>,
        axis: usize,
        best: &mut Option<Split>,
    ) {
        let n = refs.len() as u32;
        let (bins, snap) = (self.p.sah.bins as usize, self.p.sah.snap);
        let (lo, hi) = (price.cell.min[axis], price.cell.max[axis]);
        if lo >= hi {
            return;
        }
        let scale = bins as f32 / (hi - lo);
        let bin = |x: f32| (((x - lo) * scale) as usize).min(bins - 1);
        let (starts, ends) = self.bins.split_at_mut(bins);
        starts.fill(0);
        ends.fill(0);
        // Per bin the least start and the greatest end in it (the snapped candidates).
        let (first, last) = self.bin_bounds.split_at_mut(bins);
        first.fill(f32::INFINITY);
        last.fill(f32::NEG_INFINITY);
        for r in refs {
            let (a, z) = (r.b.min[axis], r.b.max[axis]);
            let (ba, bz) = (bin(a), bin(z));
            starts[ba] += 1;
            ends[bz] += 1;
            first[ba] = first[ba].min(a);
            last[bz] = last[bz].max(z);
        }
        // Boundary b: N_L = starts in bins < b, N_R = ends in bins >= b. With `snap`,
        // the same counts also price the greatest end below the boundary (planar
        // triangles there go left) and the least start above it (they go right): both
        // counts hold there or over-count, and a plane on a triangle's bound cuts no
        // triangle that ends there, as the sweep's planes.
        let (mut nl, mut nr) = (0u32, n);
        for b in 1..bins {
            nl += starts[b - 1];
            nr -= ends[b - 1];
            let boundary = lo + (hi - lo) * (b as f32 / bins as f32);
            let candidates = [
                (boundary, true),
                (if snap { last[b - 1] } else { f32::NAN }, true),
                (if snap { first[b] } else { f32::NAN }, false),
            ];
            for (pos, planar_left) in candidates {
                // (Also false for the NaN of a candidate left out or an empty bin's
                // infinity.)
                if !(lo < pos && pos < hi) {
                    continue;
                }
                let cost = price.sah(price.shares(axis, pos), nl, nr);
                keep_cheaper(best, axis, pos, cost, planar_left, nl + nr);
            }
        }
    }

    /// The exact sweep's candidates on `axis` (every distinct event position, planar
    /// triangles priced on either side), each kept in `best` if cheaper.
    #[inline]
    fn sweep_axis(
        &mut self,
        refs: &[Ref],
        price: &Pricing<'_, M>,
        axis: usize,
        sorted: Option<&[Events; 3]>,
        best: &mut Option<Split>,
    ) {
        let n = refs.len() as u32;
        let (lo, hi) = (price.cell.min[axis], price.cell.max[axis]);
        if lo >= hi {
            return;
        }
        let mut own = std::mem::take(&mut self.events);
        let ev: &[u64] = match sorted {
            Some(e) => &e[axis].keys,
            None => {
                own.clear();
                for r in refs {
                    let (a, b) = (r.b.min[axis], r.b.max[axis]);
                    if a == b {
                        own.push(key(a, PLANAR));
                    } else {
                        own.push(key(a, START));
                        own.push(key(b, END));
                    }
                }
                own.sort_unstable();
                &own
            }
        };
        let (mut nl, mut nr) = (0u32, n);
        let mut i = 0;
        while i < ev.len() {
            let k = ev[i] >> 2;
            let (mut pe, mut pp, mut ps) = (0u32, 0u32, 0u32);
            while i < ev.len() && ev[i] >> 2 == k {
                match ev[i] & 3 {
                    END => pe += 1,
                    PLANAR => pp += 1,
                    _ => ps += 1,
                }
                i += 1;
            }
            let pos = key_pos(ev[i - 1]);
            nr -= pp + pe;
            if lo < pos && pos < hi {
                let p = price.shares(axis, pos);
                let (c_left, c_right) = (price.sah(p, nl + pp, nr), price.sah(p, nl, nr + pp));
                let (c, planar_left) = if c_left <= c_right {
                    (c_left, true)
                } else {
                    (c_right, false)
                };
                keep_cheaper(best, axis, pos, c, planar_left, nl + nr + pp);
            }
            nl += ps + pp;
        }
        self.events = own;
    }

    fn node(&mut self, refs: Vec<Ref>, cell: Aabb, depth: u32) {
        let split = if refs.len() as u32 <= self.p.sah.min_leaf || depth >= self.depth_limit {
            None
        } else {
            self.find_split(&refs, &cell, None)
        };
        let split = split.filter(|s| self.within_budget(refs.len(), s));
        let n = refs.len() as u64;
        let Some(s) = split else {
            let offset = self.refs.len() as u32;
            self.refs.extend(refs.iter().map(|r| r.id));
            self.nodes.push(KdNode::leaf(offset, refs.len() as u32));
            return;
        };
        let (lc, rc) = split_cell(&cell, s.axis, s.pos);
        let mut left = Vec::with_capacity(refs.len() / 2 + 1);
        let mut right = Vec::with_capacity(refs.len() / 2 + 1);
        let a = s.axis;
        for r in refs {
            let (lo, hi) = (r.b.min[a], r.b.max[a]);
            if lo == hi && lo == s.pos {
                if s.planar_left {
                    left.push(r);
                } else {
                    right.push(r);
                }
            } else if hi <= s.pos {
                left.push(r);
            } else if lo >= s.pos {
                right.push(r);
            } else {
                let tri = &self.tris[r.id as usize];
                let bl = clip_box(tri, &r.b, &lc);
                if !bl.is_empty() {
                    left.push(Ref { b: bl, id: r.id });
                }
                let br = clip_box(tri, &r.b, &rc);
                if !br.is_empty() {
                    right.push(Ref { b: br, id: r.id });
                }
            }
        }
        self.charge(n, s.refs, left.len() + right.len());
        self.children(
            a,
            s.pos,
            n as usize,
            move |b| b.node(left, lc, depth + 1),
            move |b| b.node(right, rc, depth + 1),
        );
    }

    /// An interior node splitting `axis` at `pos` over `n` references, then its left subtree
    /// (`left`) and its right one (`right`), in depth-first order. With `parallel` and at least
    /// [`PARALLEL_MIN`] references the two subtrees are built as rayon tasks, each into a
    /// builder of its own, and appended in the same order, their links and reference offsets
    /// moved to where they land: the same nodes and references as one builder makes.
    fn children(
        &mut self,
        axis: usize,
        pos: f32,
        n: usize,
        left: impl FnOnce(&mut Self) + Send,
        right: impl FnOnce(&mut Self) + Send,
    ) {
        let idx = self.nodes.len();
        self.nodes.push(KdNode::leaf(0, 0));
        if self.parallel && n >= PARALLEL_MIN {
            let (mut lb, mut rb) = (self.fresh(), self.fresh());
            rayon::join(|| left(&mut lb), || right(&mut rb));
            self.append(lb);
            self.link(idx, axis, pos);
            self.append(rb);
        } else {
            left(self);
            self.link(idx, axis, pos);
            right(self);
        }
    }

    /// Node `idx` becomes the interior node whose right child is the next node made.
    fn link(&mut self, idx: usize, axis: usize, pos: f32) {
        let right_idx = self.nodes.len();
        assert!(right_idx < 1 << 30, "kd-tree: too many nodes");
        self.nodes[idx] = KdNode::interior(axis, pos, right_idx as u32);
    }

    /// A builder of the same scene and parameters with nothing built yet.
    fn fresh(&self) -> Self {
        Builder {
            extra: 0,
            budget_leaves: 0,
            nodes: Vec::new(),
            refs: Vec::new(),
            events: Vec::new(),
            bins: vec![0; self.bins.len()],
            bin_bounds: vec![0.0; self.bin_bounds.len()],
            ..*self
        }
    }

    /// Append the subtree `b` built: its links and leaves' offsets moved by the nodes and
    /// references already here.
    fn append(&mut self, b: Self) {
        let (base, refs) = (self.nodes.len() as u32, self.refs.len() as u32);
        self.nodes.extend(b.nodes.iter().map(|n| {
            if n.is_leaf() {
                KdNode::leaf(n.offset() as u32 + refs, n.count())
            } else {
                KdNode::interior(n.axis(), n.split(), n.link() as u32 + base)
            }
        }));
        self.refs.extend_from_slice(&b.refs);
        self.extra += b.extra;
        self.budget_leaves += b.budget_leaves;
    }
}

/// The fewest references of a node whose two subtrees [`Builder::children`] builds as rayon
/// tasks: below it a task costs more than it saves.
const PARALLEL_MIN: usize = 4096;

/// Nodes with at most this many references are built by [`Builder::node`] (sorting their
/// events) even by the O(N log N) sweep: the tree is the same, the lists cost more there.
const SMALL_NODE: usize = 512;

/// The events of one axis, sorted by key: the keys and the indices of their references.
#[derive(Default)]
struct Events {
    keys: Vec<u64>,
    refs: Vec<u32>,
}

impl Events {
    /// The events of the references `which` of `refs` on `axis`, sorted.
    fn of(refs: &[Ref], which: impl Iterator<Item = u32>, axis: usize) -> Events {
        let mut ev: Vec<(u64, u32)> = Vec::new();
        for i in which {
            let b = &refs[i as usize].b;
            let (lo, hi) = (b.min[axis], b.max[axis]);
            if lo == hi {
                ev.push((key(lo, PLANAR), i));
            } else {
                ev.push((key(lo, START), i));
                ev.push((key(hi, END), i));
            }
        }
        ev.sort_unstable_by_key(|e| e.0);
        Events {
            keys: ev.iter().map(|e| e.0).collect(),
            refs: ev.iter().map(|e| e.1).collect(),
        }
    }

    /// Merge two sorted event lists.
    fn merge(a: Events, b: Events) -> Events {
        if b.keys.is_empty() {
            return a;
        }
        let n = a.keys.len() + b.keys.len();
        let mut out = Events {
            keys: Vec::with_capacity(n),
            refs: Vec::with_capacity(n),
        };
        let (mut i, mut j) = (0, 0);
        while i < a.keys.len() || j < b.keys.len() {
            if j == b.keys.len() || (i < a.keys.len() && a.keys[i] <= b.keys[j]) {
                out.keys.push(a.keys[i]);
                out.refs.push(a.refs[i]);
                i += 1;
            } else {
                out.keys.push(b.keys[j]);
                out.refs.push(b.refs[j]);
                j += 1;
            }
        }
        out
    }
}

impl<M: BoxMeasure> Builder<'_, M> {
    /// [`Builder::node`] for the O(N log N) sweep (Wald and Havran 2006, §5): the events of
    /// each axis are sorted once at the root and passed down; a child keeps its share of its
    /// parent's sorted lists (a stable filter) and only the events of the re-clipped
    /// straddling triangles are sorted and merged in. Builds the same tree as `sweep-nlog2n`.
    fn node_sweep(&mut self, refs: Vec<Ref>, ev: [Events; 3], cell: Aabb, depth: u32) {
        if refs.len() <= SMALL_NODE {
            // Sorting a few events per node is cheaper than passing lists down; same tree.
            drop(ev);
            return self.node(refs, cell, depth);
        }
        let split = if refs.len() as u32 <= self.p.sah.min_leaf || depth >= self.depth_limit {
            None
        } else {
            self.find_split(&refs, &cell, Some(&ev))
        };
        let split = split.filter(|s| self.within_budget(refs.len(), s));
        let n = refs.len() as u64;
        let Some(s) = split else {
            let offset = self.refs.len() as u32;
            self.refs.extend(refs.iter().map(|r| r.id));
            self.nodes.push(KdNode::leaf(offset, refs.len() as u32));
            return;
        };
        let (lc, rc) = split_cell(&cell, s.axis, s.pos);
        let mut left = Vec::with_capacity(refs.len() / 2 + 1);
        let mut right = Vec::with_capacity(refs.len() / 2 + 1);
        // New index of each reference in the left and right child (NONE: not there), and
        // which child references are re-clipped straddlers (their events are new).
        const NONE: u32 = u32::MAX;
        let mut map_l = vec![NONE; refs.len()];
        let mut map_r = vec![NONE; refs.len()];
        let (mut new_l, mut new_r) = (Vec::new(), Vec::new());
        let a = s.axis;
        for (k, r) in refs.iter().enumerate() {
            let (lo, hi) = (r.b.min[a], r.b.max[a]);
            let to_left = if lo == hi && lo == s.pos {
                Some(s.planar_left)
            } else if hi <= s.pos {
                Some(true)
            } else if lo >= s.pos {
                Some(false)
            } else {
                None
            };
            match to_left {
                Some(true) => {
                    map_l[k] = left.len() as u32;
                    left.push(*r);
                }
                Some(false) => {
                    map_r[k] = right.len() as u32;
                    right.push(*r);
                }
                None => {
                    let tri = &self.tris[r.id as usize];
                    let bl = clip_box(tri, &r.b, &lc);
                    if !bl.is_empty() {
                        new_l.push(left.len() as u32);
                        left.push(Ref { b: bl, id: r.id });
                    }
                    let br = clip_box(tri, &r.b, &rc);
                    if !br.is_empty() {
                        new_r.push(right.len() as u32);
                        right.push(Ref { b: br, id: r.id });
                    }
                }
            }
        }
        drop(refs);
        let mut ev_l: [Events; 3] = Default::default();
        let mut ev_r: [Events; 3] = Default::default();
        for (axis, e) in ev.into_iter().enumerate() {
            let (mut kl, mut kr) = (Events::default(), Events::default());
            for (&k, &r) in e.keys.iter().zip(&e.refs) {
                let (l, r) = (map_l[r as usize], map_r[r as usize]);
                if l != NONE {
                    kl.keys.push(k);
                    kl.refs.push(l);
                } else if r != NONE {
                    kr.keys.push(k);
                    kr.refs.push(r);
                }
            }
            ev_l[axis] = Events::merge(kl, Events::of(&left, new_l.iter().copied(), axis));
            ev_r[axis] = Events::merge(kr, Events::of(&right, new_r.iter().copied(), axis));
        }
        drop((map_l, map_r));
        self.charge(n, s.refs, left.len() + right.len());
        self.children(
            a,
            s.pos,
            n as usize,
            move |b| b.node_sweep(left, ev_l, lc, depth + 1),
            move |b| b.node_sweep(right, ev_r, rc, depth + 1),
        );
    }
}

/// Build the flat tree over the finite triangles of `tris`.
pub fn build<M: BoxMeasure>(tris: &[Triangle], p: &KdParams, m: &M) -> Output {
    let refs: Vec<Ref> = tris
        .iter()
        .enumerate()
        .filter(|(_, t)| t.v0.is_finite() && t.v1.is_finite() && t.v2.is_finite())
        .map(|(i, t)| Ref {
            b: t.bounds(),
            id: i as u32,
        })
        .collect();
    let bounds = refs.iter().fold(Aabb::EMPTY, |b, r| b.union(&r.b));
    let budget = (MAX_REFS_PER_TRIANGLE - 1) * refs.len() as u64;
    // An untimed build may use the pool ([`tb_core::par::as_untimed_build`]). The serial build
    // checks each split against the budget with the references added before it in depth-first
    // order; the parallel one's tasks cannot know that order, so they charge every split
    // (the larger of what the SAH counted and what the split made) to one shared counter. Where
    // no split was refused and the whole charge stays within the budget, every check of the
    // serial build passes too, and its tree is this one; else the serial build runs (soon: a
    // task stops splitting once the counter passes the budget).
    let parallel = tb_core::par::untimed_build_running() && rayon::current_num_threads() > 1;
    if parallel {
        let total = AtomicU64::new(0);
        let b = run(tris, p, m, refs.clone(), bounds, budget, Some(&total));
        if b.budget_leaves == 0 && total.load(Ordering::Relaxed) <= budget {
            return output(b, bounds);
        }
    }
    output(run(tris, p, m, refs, bounds, budget, None), bounds)
}

/// Build over `refs` in `bounds` with `extra_budget` ([`MAX_REFS_PER_TRIANGLE`]): with a
/// `shared` counter the subtrees of large nodes as rayon tasks charging it.
fn run<'a, M: BoxMeasure>(
    tris: &'a [Triangle],
    p: &'a KdParams,
    m: &'a M,
    refs: Vec<Ref>,
    bounds: Aabb,
    extra_budget: u64,
    shared: Option<&'a AtomicU64>,
) -> Builder<'a, M> {
    let mut b = Builder {
        tris,
        p,
        m,
        scale: measure_scale(&bounds),
        depth_limit: p.depth_limit(tris.len()),
        extra_budget,
        extra: 0,
        budget_leaves: 0,
        parallel: shared.is_some(),
        shared,
        nodes: Vec::new(),
        refs: Vec::new(),
        events: Vec::new(),
        bins: vec![0; 2 * p.sah.bins as usize],
        bin_bounds: vec![0.0; 2 * p.sah.bins as usize],
    };
    if !refs.is_empty() {
        if p.sah.builder == KdBuilder::Sweep {
            let ev = std::array::from_fn(|a| Events::of(&refs, 0..refs.len() as u32, a));
            b.node_sweep(refs, ev, bounds, 0);
        } else {
            b.node(refs, bounds, 0);
        }
    }
    b
}

fn output<M: BoxMeasure>(b: Builder<'_, M>, bounds: Aabb) -> Output {
    Output {
        nodes: b.nodes,
        prim_refs: b.refs,
        bounds,
        budget_leaves: b.budget_leaves,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::SurfaceArea;
    use tb_core::Vec3;

    /// The same triangles at 1e-30 and 1e30 are split as at 1 (every area
    /// once overflowed or vanished and the build stopped at the root), and at 1 the scaling
    /// does not act.
    #[test]
    fn extreme_scales_split_as_at_one() {
        let mut tris = Vec::new();
        for i in 0..200 {
            let c = Vec3::new(
                (i % 7) as f32,
                (i % 11) as f32 * 0.5,
                (i % 13) as f32 * 0.25,
            );
            tris.push(Triangle::new(c, c + Vec3::X * 0.3, c + Vec3::Y * 0.2));
        }
        let nodes = |s: f32| {
            let t: Vec<Triangle> = tris
                .iter()
                .map(|t| Triangle::new(t.v0 * s, t.v1 * s, t.v2 * s))
                .collect();
            build(&t, &KdParams::default(), &SurfaceArea).nodes.len()
        };
        let one = nodes(1.0);
        assert!(one > 50, "{one}");
        assert_eq!(measure_scale(&Aabb::new(Vec3::ZERO, Vec3::ONE)), 1.0);
        for s in [1e-30f32, 1e30] {
            let n = nodes(s);
            assert!(
                n * 10 >= one * 9 && n * 10 <= one * 11,
                "scale {s}: {n} nodes, {one} at 1"
            );
        }
    }

    /// Min-max binning splits only nodes of more references than bins; smaller ones get the
    /// exact sweep (Shevtsov et al. 2007), so a scene of at most `bins` triangles is built
    /// exactly as by the sweep, and a larger one is not.
    #[test]
    fn binning_leaves_small_nodes_to_the_sweep() {
        let tris: Vec<Triangle> = (0..60)
            .map(|i| {
                let c = Vec3::new((i * 7 % 13) as f32, (i * 5 % 11) as f32, (i % 3) as f32);
                Triangle::new(
                    c,
                    c + Vec3::new(0.7, 0.1, 0.0),
                    c + Vec3::new(0.2, 0.9, 0.3),
                )
            })
            .collect();
        let with = |builder, bins, n: usize| {
            let mut p = KdParams::default();
            p.sah.builder = builder;
            p.sah.bins = bins;
            let o = build(&tris[..n], &p, &SurfaceArea);
            (o.nodes, o.prim_refs)
        };
        let sweep = |n| with(KdBuilder::Sweep, 32, n);
        for n in [5, 20, 32] {
            assert!(with(KdBuilder::Binned, 32, n) == sweep(n), "{n} triangles");
        }
        assert!(with(KdBuilder::Binned, 4, 60) != sweep(60));
    }

    /// Snapped binning: 100 triangles in a row along x, each spanning 0.9 of its unit with a
    /// gap of 0.1 to the next; 8 bins over a cell of 99.9 put no boundary in a gap, so the
    /// boundaries alone cut triangles and duplicate their references. The snapped candidates
    /// (the bounds next to each boundary) lie in gaps, and the exact sweep's planes all do
    /// (no triangle cut). The snapped candidates are priced with the boundary's counts (the
    /// triangle across the boundary on both sides), so they win only where their areas are
    /// better: fewer cuts, not none.
    #[test]
    fn snapped_binning_splits_on_triangle_bounds() {
        let tris: Vec<Triangle> = (0..100)
            .map(|i| {
                let x = i as f32;
                Triangle::new(
                    Vec3::new(x, 0.0, 0.0),
                    Vec3::new(x + 0.9, 0.0, 0.0),
                    Vec3::new(x + 0.45, 1.0, 0.3),
                )
            })
            .collect();
        let refs = |builder, snap: bool| {
            let mut p = KdParams::default();
            p.sah.builder = builder;
            p.sah.bins = 8;
            p.sah.snap = snap;
            build(&tris, &p, &SurfaceArea).prim_refs.len()
        };
        assert_eq!(refs(KdBuilder::Sweep, true), tris.len());
        let (snapped, boundaries) = (
            refs(KdBuilder::Binned, true),
            refs(KdBuilder::Binned, false),
        );
        assert!(snapped < boundaries, "{snapped} {boundaries}");
    }

    #[test]
    fn keys_sort_as_floats() {
        let v = [-3.5f32, -0.0, 0.0, 1e-30, 2.0, f32::MAX, -f32::MAX];
        for &a in &v {
            assert_eq!(key_pos(key(a, START)), a + 0.0);
            for &b in &v {
                if a < b {
                    assert!(key(a, START) < key(b, END));
                }
            }
        }
        assert!(key(1.0, END) < key(1.0, PLANAR) && key(1.0, PLANAR) < key(1.0, START));
    }
}
