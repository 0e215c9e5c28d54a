//! Spatial-split BVH (SBVH; Stich, Friedrich and Dietrich 2009, "Spatial splits in bounding
//! volume hierarchies"), built top-down in parallel (rayon, both children of large nodes at
//! once).
//!
//! A node holds *references*: a triangle and a conservative box of the part of it inside the
//! node (at the root its bounds). Per node (§4):
//! 1. the best **object split** is found by a full SAH sweep (`object_split = "sweep"`, the
//!    original SBVH's: on each axis the references sorted by box centre, every boundary
//!    between two consecutive ones tried, the right-hand boxes accumulated in a backward pass;
//!    the three axes in parallel for large nodes), or by binned SAH over the centres as in the
//!    binned builder (`object_split = "binned"`, `build`);
//! 2. when the children of that split overlap, `A(B_L ∩ B_R) > alpha·A(root)` (§4.4, the
//!    overlap threshold restricting spatial splits to where they pay), the best **spatial
//!    split** is found too: the node box is cut into `bins` equal slabs per axis, each reference
//!    is *chopped* into the slabs it spans (the triangle's part in each slab, the box
//!    [`tb_core::clip::slab_box`] gives, computed by [`chop`] for all slabs at once so that
//!    each plane's edge crossings are found once), and per boundary the SAH
//!    cost uses the union of the chopped boxes and the counts of references entering left of it
//!    and leaving right of it (§4.2);
//! 3. the cheaper split is made, or a leaf when `|n| ≤ min_leaf` or, for `|n| ≤ max_leaf`, when
//!    the leaf cost is no higher. Costs price a side of `k` references at `A·c(k)`, `c` the
//!    leaf price of `leaf_cost` (`k`, or `⌈k/4⌉` for `blocks`). A spatial split sends each straddling reference to both sides
//!    (its triangle clipped to each child's cell by [`tb_core::clip::clip_box`], the routine
//!    the kd-tree builder clips with) unless **reference unsplitting** (§4.3) is
//!    cheaper: putting it wholly into one child, `A(B_L ∪ B)·c(N_L) + A(B_R)·c(N_R − 1)` or
//!    the mirror, against `A(B_L)·c(N_L) + A(B_R)·c(N_R)`.
//!
//! A spatial split that would not make both children smaller than the node falls back to the
//! object split; the fallbacks and depth bound of the binned builder (object median splits
//! where binning cannot separate, only median splits from depth `MEDIAN_DEPTH`) hold here too,
//! so leaves never exceed `max_leaf` unless their reference centres coincide.
//!
//! A triangle may be referenced by several leaves; each reference's slot in the triangle array
//! holds a copy of the triangle, and `validate` checks coverage instead of a permutation.

use crate::build::MEDIAN_DEPTH;
use crate::{BvhNode, BvhParams, ObjectSplit};
use rayon::prelude::*;
use tb_core::clip::{clip_box, tolerance};
use tb_core::{Aabb, Triangle, Vec3};

/// A reference: a conservative box of the part of triangle `id` inside the node.
#[derive(Clone, Copy)]
struct Ref {
    b: Aabb,
    id: u32,
}

impl Ref {
    #[inline(always)]
    fn c2(&self) -> Vec3 {
        self.b.min + self.b.max
    }
}

/// The temporary tree, flattened once built.
enum Node {
    Leaf(Aabb, Vec<u32>),
    Inner(Aabb, Box<(Node, Node)>),
}

/// Nodes with at least this many references build their children in parallel.
const PAR_MIN: usize = 4096;

/// The most references an SBVH may hold per triangle. Spatial splits duplicate references
/// (the paper scenes end at 1.03 to 1.24 per triangle), but where triangles overlap in one
/// plane every node passes the overlap threshold and every spatial split cuts nearly all of
/// them (2,000 such triangles made 10.9M references and 120 s before this bound). Each node
/// gets an allowance, its share of `32·N` in proportion to its references (Embree's split
/// budget is shared out the same way), so that no path multiplies references more than
/// 32-fold; a spatial split over its node's allowance is refused (the object split is made),
/// decided per node and so the same whatever the thread schedule; `build_stats` counts the
/// refusals (`ref_budget_splits`) where there were any. 32 never acts on the paper scenes
/// (8 did, 33 times on Conference, 9 on Sponza: locally a path multiplies more than the
/// 1.06-1.24 of the whole).
pub const MAX_REFS_PER_TRIANGLE: f64 = 32.0;

struct Ctx<'a> {
    tris: &'a [Triangle],
    p: &'a BvhParams,
    /// `alpha · A(root)` (half areas).
    min_overlap: f32,
    /// Spatial splits refused by the reference allowance.
    refused: std::sync::atomic::AtomicU64,
}

/// Build an SBVH: the flat node array, per triangle slot the scene index of its triangle, and
/// the spatial splits the reference allowance refused.
pub(crate) fn build(tris: &[Triangle], params: &BvhParams) -> (Vec<BvhNode>, Vec<u32>, u64) {
    if tris.is_empty() {
        return (Vec::new(), Vec::new(), 0);
    }
    let refs: Vec<Ref> = tris
        .iter()
        .enumerate()
        .map(|(i, t)| Ref {
            b: t.bounds(),
            id: i as u32,
        })
        .collect();
    let root = refs.iter().fold(Aabb::EMPTY, |a, r| a.union(&r.b));
    let ctx = Ctx {
        tris,
        p: params,
        min_overlap: params.alpha * root.half_area(),
        refused: Default::default(),
    };
    let allow = MAX_REFS_PER_TRIANGLE * refs.len() as f64;
    let tree = ctx.node(refs, 0, allow);
    let mut nodes = vec![BvhNode::EMPTY];
    let mut order = Vec::new();
    flatten(&tree, 0, &mut nodes, &mut order);
    (nodes, order, ctx.refused.into_inner())
}

fn flatten(n: &Node, at: usize, nodes: &mut Vec<BvhNode>, order: &mut Vec<u32>) {
    match n {
        Node::Leaf(b, ids) => {
            nodes[at] = BvhNode {
                min: b.min.to_array(),
                index: order.len() as u32,
                max: b.max.to_array(),
                count: ids.len() as u32,
            };
            order.extend_from_slice(ids);
        }
        Node::Inner(b, kids) => {
            let l = nodes.len();
            nodes.push(BvhNode::EMPTY);
            nodes.push(BvhNode::EMPTY);
            nodes[at] = BvhNode {
                min: b.min.to_array(),
                index: l as u32,
                max: b.max.to_array(),
                count: 0,
            };
            flatten(&kids.0, l, nodes, order);
            flatten(&kids.1, l + 1, nodes, order);
        }
    }
}

fn bounds_of(refs: &[Ref]) -> (Aabb, Aabb) {
    let mut b = Aabb::EMPTY;
    let mut cb = Aabb::EMPTY;
    for r in refs {
        b = b.union(&r.b);
        cb.grow(r.c2());
    }
    (b, cb)
}

/// The chosen split.
enum Split {
    /// The references flagged `true` (by position) go left: a boundary of the sweep.
    Sorted(Vec<bool>),
    /// References with centre bin `≤ k` on `axis` go left (bins of `map`).
    Object {
        axis: usize,
        k: usize,
        min: f32,
        scale: f32,
    },
    /// Cut at `pos` on `axis`; `lb`, `rb`, `nl`, `nr` the binned child boxes and counts.
    Spatial {
        axis: usize,
        pos: f32,
        lb: Aabb,
        rb: Aabb,
        nl: u32,
        nr: u32,
    },
    /// Object median on `axis` (by index when `axis` is `None`).
    Median(Option<usize>),
}

impl Ctx<'_> {
    /// The subtree of `refs`, which may hold at most `allow` references in all.
    fn node(&self, refs: Vec<Ref>, depth: u32, allow: f64) -> Node {
        let (bounds, cb) = bounds_of(&refs);
        let Some(split) = self.choose(&refs, &bounds, &cb, depth) else {
            return Node::Leaf(bounds, refs.iter().map(|r| r.id).collect());
        };
        let split = match split {
            Split::Spatial { nl, nr, .. } if (nl + nr) as f64 > allow => {
                self.refused
                    .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                match self.object_or_median(&refs, &bounds, &cb, depth) {
                    None => return Node::Leaf(bounds, refs.iter().map(|r| r.id).collect()),
                    Some(s) => s,
                }
            }
            s => s,
        };
        let (l, r) = match self.partition(refs, &bounds, split) {
            Ok(lr) => lr,
            Err(refs) => {
                // A spatial split that did not shrink both sides: object split instead.
                let s = self.object_or_median(&refs, &bounds, &cb, depth);
                match s {
                    None => return Node::Leaf(bounds, refs.iter().map(|r| r.id).collect()),
                    Some(s) => self
                        .partition(refs, &bounds, s)
                        .unwrap_or_else(|_| unreachable!("object splits always shrink")),
                }
            }
        };
        // The children's shares of the allowance, in proportion to their references.
        let al = allow * l.len() as f64 / (l.len() + r.len()).max(1) as f64;
        let ar = allow - al;
        let (a, b) = if l.len() + r.len() >= PAR_MIN {
            rayon::join(
                || self.node(l, depth + 1, al),
                || self.node(r, depth + 1, ar),
            )
        } else {
            (self.node(l, depth + 1, al), self.node(r, depth + 1, ar))
        };
        Node::Inner(bounds, Box::new((a, b)))
    }

    /// Leaf (`None`) or the split to make, as the binned builder decides, with spatial splits.
    fn choose(&self, refs: &[Ref], bounds: &Aabb, cb: &Aabb, depth: u32) -> Option<Split> {
        let n = refs.len();
        let p = self.p;
        if n <= 1 || n <= p.min_leaf as usize {
            return None;
        }
        let max_leaf = p.max_leaf as usize;
        let area = bounds.half_area();
        let area_usable = area > 0.0 && area.is_finite();
        if cb.extent() == Vec3::ZERO {
            return (n > max_leaf).then_some(Split::Median(None));
        }
        if depth >= MEDIAN_DEPTH || !area_usable {
            return (n > max_leaf).then_some(Split::Median(Some(cb.largest_axis())));
        }
        let obj = self.object(refs, cb);
        let overlap = obj.as_ref().map_or(f32::INFINITY, |o| o.2);
        let mut best: Option<(f32, Split)> = obj.map(|(c, s, _)| (c, s));
        if overlap > self.min_overlap {
            if let Some((c, s)) = self.spatial(refs, bounds) {
                if best.as_ref().is_none_or(|b| c < b.0) {
                    best = Some((c, s));
                }
            }
        }
        let Some((cost, split)) = best else {
            return (n > max_leaf).then_some(Split::Median(Some(cb.largest_axis())));
        };
        if n <= max_leaf {
            let split_cost = p.c_trav * area + p.c_isect * cost;
            if p.c_isect * area * p.leaf_cost.units(n) <= split_cost {
                return None;
            }
        }
        Some(split)
    }

    fn object_or_median(
        &self,
        refs: &[Ref],
        bounds: &Aabb,
        cb: &Aabb,
        depth: u32,
    ) -> Option<Split> {
        let n = refs.len();
        let max_leaf = self.p.max_leaf as usize;
        let area = bounds.half_area();
        if cb.extent() == Vec3::ZERO {
            return (n > max_leaf).then_some(Split::Median(None));
        }
        if depth >= MEDIAN_DEPTH || !(area > 0.0 && area.is_finite()) {
            return (n > max_leaf).then_some(Split::Median(Some(cb.largest_axis())));
        }
        match self.object(refs, cb) {
            Some((cost, s, _)) => {
                if n <= max_leaf {
                    let p = self.p;
                    let split_cost = p.c_trav * area + p.c_isect * cost;
                    if p.c_isect * area * p.leaf_cost.units(n) <= split_cost {
                        return None;
                    }
                }
                Some(s)
            }
            None => (n > max_leaf).then_some(Split::Median(Some(cb.largest_axis()))),
        }
    }

    /// Best object split (`object_split`): its cost `A(L)·c(|L|) + A(R)·c(|R|)` (half
    /// areas), the split, and the children's overlap area.
    fn object(&self, refs: &[Ref], cb: &Aabb) -> Option<(f32, Split, f32)> {
        match self.p.object_split {
            ObjectSplit::Sweep => self.sweep(refs, cb),
            ObjectSplit::Binned => self.binned(refs, cb),
        }
    }

    /// Best object split by the full SAH sweep (Stich et al. 2009 §4): per axis with centres
    /// not all equal, the references sorted by centre (ties by position, so the order is
    /// deterministic) and every boundary between two consecutive ones tried; the first axis
    /// of least cost wins. Large nodes sweep the three axes in parallel.
    fn sweep(&self, refs: &[Ref], cb: &Aabb) -> Option<(f32, Split, f32)> {
        let ext = cb.extent();
        let axes: Vec<usize> = (0..3).filter(|&a| ext[a] > 0.0).collect();
        let per_axis: Vec<Option<(f32, usize, Vec<u32>)>> = if refs.len() >= PAR_MIN {
            axes.par_iter().map(|&a| self.sweep_axis(refs, a)).collect()
        } else {
            axes.iter().map(|&a| self.sweep_axis(refs, a)).collect()
        };
        let mut best: Option<(f32, usize, Vec<u32>)> = None;
        for r in per_axis.into_iter().flatten() {
            if best.as_ref().is_none_or(|b| r.0 < b.0) {
                best = Some(r);
            }
        }
        let (cost, k, order) = best?;
        let mut left = vec![false; refs.len()];
        let mut lb = Aabb::EMPTY;
        let mut rb = Aabb::EMPTY;
        for (j, &i) in order.iter().enumerate() {
            let r = &refs[i as usize];
            if j <= k {
                left[i as usize] = true;
                lb = lb.union(&r.b);
            } else {
                rb = rb.union(&r.b);
            }
        }
        let ov = tb_core::clip::intersect(&lb, &rb);
        let overlap = if ov.is_empty() { 0.0 } else { ov.half_area() };
        Some((cost, Split::Sorted(left), overlap))
    }

    /// The sweep on one axis: the least cost, the last position in the sorted order that goes
    /// left, and the order (indices into `refs`).
    fn sweep_axis(&self, refs: &[Ref], axis: usize) -> Option<(f32, usize, Vec<u32>)> {
        let n = refs.len();
        if n < 2 {
            return None;
        }
        let c = self.p.leaf_cost;
        // Sort keys: the centre's bits made monotonic (as `f32::total_cmp` orders), then the
        // position; one integer sort, no indirection into `refs` while sorting.
        let mut keys: Vec<u64> = refs
            .iter()
            .enumerate()
            .map(|(i, r)| {
                let b = r.c2()[axis].to_bits();
                let m = if b >> 31 == 1 { !b } else { b | 1 << 31 };
                (m as u64) << 32 | i as u64
            })
            .collect();
        keys.sort_unstable();
        let order: Vec<u32> = keys.iter().map(|&k| k as u32).collect();
        drop(keys);
        // right[k]: A(box of order[k..])·c(n − k), for k ≥ 1.
        let mut right = vec![0.0f32; n];
        let mut acc = Aabb::EMPTY;
        for k in (1..n).rev() {
            acc = acc.union(&refs[order[k] as usize].b);
            right[k] = acc.half_area() * c.units(n - k);
        }
        let mut left = Aabb::EMPTY;
        let mut best: Option<(f32, usize)> = None;
        for k in 0..n - 1 {
            left = left.union(&refs[order[k] as usize].b);
            let cost = left.half_area() * c.units(k + 1) + right[k + 1];
            if best.is_none_or(|b| cost < b.0) {
                best = Some((cost, k));
            }
        }
        best.map(|(cost, k)| (cost, k, order))
    }

    /// Best binned object split (`bins` bins of the centre bounds per axis, Wald 2007).
    fn binned(&self, refs: &[Ref], cb: &Aabb) -> Option<(f32, Split, f32)> {
        let c = self.p.leaf_cost;
        let nb = self.p.bins as usize;
        let ext = cb.extent();
        let mut best: Option<(f32, Split, f32)> = None;
        let mut bins = vec![(Aabb::EMPTY, 0u32); nb];
        let mut right = vec![(Aabb::EMPTY, 0u32); nb];
        for axis in 0..3 {
            if ext[axis] <= 0.0 {
                continue;
            }
            let scale = nb as f32 / ext[axis];
            let min = cb.min[axis];
            bins.fill((Aabb::EMPTY, 0));
            for r in refs {
                let k = obj_bin(r.c2()[axis], min, scale, nb);
                bins[k].0 = bins[k].0.union(&r.b);
                bins[k].1 += 1;
            }
            let mut acc = (Aabb::EMPTY, 0u32);
            for k in (1..nb).rev() {
                acc = (acc.0.union(&bins[k].0), acc.1 + bins[k].1);
                right[k] = acc;
            }
            let mut left = (Aabb::EMPTY, 0u32);
            for k in 0..nb - 1 {
                left = (left.0.union(&bins[k].0), left.1 + bins[k].1);
                let r = right[k + 1];
                if left.1 == 0 || r.1 == 0 {
                    continue;
                }
                let cost = left.0.half_area() * c.units(left.1 as usize)
                    + r.0.half_area() * c.units(r.1 as usize);
                if best.as_ref().is_none_or(|b| cost < b.0) {
                    let ov = tb_core::clip::intersect(&left.0, &r.0);
                    let overlap = if ov.is_empty() { 0.0 } else { ov.half_area() };
                    best = Some((
                        cost,
                        Split::Object {
                            axis,
                            k,
                            min,
                            scale,
                        },
                        overlap,
                    ));
                }
            }
        }
        best
    }

    /// Best spatial split (§4.2): chopped references binned into equal slabs of the node box.
    fn spatial(&self, refs: &[Ref], bounds: &Aabb) -> Option<(f32, Split)> {
        let c = self.p.leaf_cost;
        let nb = self.p.bins as usize;
        let ext = bounds.extent();
        let mut best: Option<(f32, Split)> = None;
        let mut boxes = vec![Aabb::EMPTY; nb];
        let mut enter = vec![0u32; nb];
        let mut exit = vec![0u32; nb];
        let mut right = vec![(Aabb::EMPTY, 0u32); nb];
        let mut cross = Vec::with_capacity(nb + 1);
        for axis in 0..3 {
            if ext[axis] <= 0.0 {
                continue;
            }
            let w = ext[axis] / nb as f32;
            let lo = bounds.min[axis];
            let plane = |k: usize| {
                if k == nb {
                    bounds.max[axis]
                } else {
                    lo + w * k as f32
                }
            };
            boxes.fill(Aabb::EMPTY);
            enter.fill(0);
            exit.fill(0);
            for r in refs {
                let first = spatial_bin(r.b.min[axis], lo, w, nb);
                let last = spatial_bin(r.b.max[axis], lo, w, nb).max(first);
                enter[first] += 1;
                exit[last] += 1;
                if first == last {
                    boxes[first] = boxes[first].union(&r.b);
                    continue;
                }
                let tri = &self.tris[r.id as usize];
                chop(tri, &r.b, axis, first..=last, &plane, &mut cross, |k, c| {
                    if !c.is_empty() {
                        boxes[k] = boxes[k].union(&c);
                    }
                });
            }
            let mut acc = (Aabb::EMPTY, 0u32);
            for k in (1..nb).rev() {
                acc = (acc.0.union(&boxes[k]), acc.1 + exit[k]);
                right[k] = acc;
            }
            let mut left = (Aabb::EMPTY, 0u32);
            for k in 0..nb - 1 {
                left = (left.0.union(&boxes[k]), left.1 + enter[k]);
                let r = right[k + 1];
                if left.1 == 0 || r.1 == 0 || left.0.is_empty() || r.0.is_empty() {
                    continue;
                }
                let cost = left.0.half_area() * c.units(left.1 as usize)
                    + r.0.half_area() * c.units(r.1 as usize);
                if best.as_ref().is_none_or(|b| cost < b.0) {
                    best = Some((
                        cost,
                        Split::Spatial {
                            axis,
                            pos: plane(k + 1),
                            lb: left.0,
                            rb: r.0,
                            nl: left.1,
                            nr: r.1,
                        },
                    ));
                }
            }
        }
        best
    }

    /// Make the children's references; `Err` gives the references back when a spatial split
    /// would not shrink both sides.
    fn partition(
        &self,
        mut refs: Vec<Ref>,
        bounds: &Aabb,
        split: Split,
    ) -> Result<(Vec<Ref>, Vec<Ref>), Vec<Ref>> {
        match split {
            Split::Sorted(left) => {
                let k = left.iter().filter(|&&g| g).count();
                let mut l = Vec::with_capacity(k);
                let mut r = Vec::with_capacity(refs.len() - k);
                for (x, &go_left) in refs.iter().zip(&left) {
                    if go_left {
                        l.push(*x);
                    } else {
                        r.push(*x);
                    }
                }
                if l.is_empty() || r.is_empty() {
                    // Cannot happen (the sweep keeps both sides non-empty).
                    return Ok(median(refs, None));
                }
                Ok((l, r))
            }
            Split::Object {
                axis,
                k,
                min,
                scale,
            } => {
                let nb = self.p.bins as usize;
                let (l, r): (Vec<Ref>, Vec<Ref>) = refs
                    .iter()
                    .partition(|r| obj_bin(r.c2()[axis], min, scale, nb) <= k);
                if l.is_empty() || r.is_empty() {
                    // Cannot happen (the bins counted both sides); never make an empty child.
                    return Ok(median(refs, Some(axis)));
                }
                Ok((l, r))
            }
            Split::Median(axis) => Ok(median(refs, axis)),
            Split::Spatial {
                axis,
                pos,
                lb,
                rb,
                nl,
                nr,
            } => {
                let n = refs.len();
                let c = |k: u32| self.p.leaf_cost.units(k as usize);
                let (al, ar) = (lb.half_area(), rb.half_area());
                let c_split = al * c(nl) + ar * c(nr);
                let mut lcell = *bounds;
                lcell.max[axis] = pos;
                let mut rcell = *bounds;
                rcell.min[axis] = pos;
                let mut l = Vec::with_capacity(nl as usize);
                let mut r = Vec::with_capacity(nr as usize);
                for x in &refs {
                    if x.b.max[axis] <= pos {
                        l.push(*x);
                    } else if x.b.min[axis] >= pos {
                        r.push(*x);
                    } else {
                        // Reference unsplitting (§4.3).
                        let c1 = lb.union(&x.b).half_area() * c(nl) + ar * c(nr.saturating_sub(1));
                        let c2 = al * c(nl.saturating_sub(1)) + rb.union(&x.b).half_area() * c(nr);
                        if c1 < c_split && c1 <= c2 {
                            l.push(*x);
                        } else if c2 < c_split {
                            r.push(*x);
                        } else {
                            let tri = &self.tris[x.id as usize];
                            let bl = clip_box(tri, &x.b, &lcell);
                            let br = clip_box(tri, &x.b, &rcell);
                            if !bl.is_empty() {
                                l.push(Ref { b: bl, id: x.id });
                            }
                            if !br.is_empty() {
                                r.push(Ref { b: br, id: x.id });
                            }
                            if bl.is_empty() && br.is_empty() {
                                // Rounding only (the reference overlaps the node): keep it whole.
                                l.push(*x);
                            }
                        }
                    }
                }
                if l.is_empty() || r.is_empty() || l.len() >= n || r.len() >= n {
                    refs.shrink_to_fit();
                    return Err(refs);
                }
                Ok((l, r))
            }
        }
    }
}

/// Chop a reference (triangle `tri`, box `lim`) into the slabs `bins` on `axis`, slab `k`
/// between `plane(k)` and `plane(k + 1)`: calls `out(k, box)` with, bit for bit,
/// `tb_core::clip::slab_box(tri, lim, axis, plane(k), plane(k + 1))` (Stich et al. 2009 §4.2's
/// chopping), with the same operations in the same order, but the triangle's bounds and
/// tolerance computed once and each plane's edge crossings once for the two slabs it bounds.
/// `cross` is scratch space.
fn chop(
    tri: &Triangle,
    lim: &Aabb,
    axis: usize,
    bins: std::ops::RangeInclusive<usize>,
    plane: &impl Fn(usize) -> f32,
    cross: &mut Vec<([Vec3; 3], u8)>,
    mut out: impl FnMut(usize, Aabb),
) {
    let (first, last) = (*bins.start(), *bins.end());
    let v = [tri.v0, tri.v1, tri.v2];
    // Where edge `i` (v[i] → v[i + 1]) crosses plane `first + j` strictly (bit `i` of the
    // mask set).
    cross.clear();
    for k in first..=last + 1 {
        let c = plane(k);
        let mut x = [Vec3::ZERO; 3];
        let mut m = 0u8;
        for i in 0..3 {
            let (p, q) = (v[i], v[(i + 1) % 3]);
            if (p[axis] < c && q[axis] > c) || (p[axis] > c && q[axis] < c) {
                let t = (c - p[axis]) / (q[axis] - p[axis]);
                x[i] = p + (q - p) * t;
                x[i][axis] = c;
                m |= 1 << i;
            }
        }
        cross.push((x, m));
    }
    let tb = tri.bounds();
    let tol = tolerance(&tb);
    for k in bins {
        let (lo, hi) = (plane(k), plane(k + 1));
        let mut cell = *lim;
        cell.min[axis] = cell.min[axis].max(lo);
        cell.max[axis] = cell.max[axis].min(hi);
        if cell.is_empty() {
            out(k, Aabb::EMPTY);
            continue;
        }
        if tb.min[axis] >= lo && tb.max[axis] <= hi {
            out(k, tb_core::clip::intersect(&tb, &cell));
            continue;
        }
        let (cl, ch) = (&cross[k - first], &cross[k - first + 1]);
        let mut pb = Aabb::EMPTY;
        for i in 0..3 {
            let p = v[i];
            if p[axis] >= lo && p[axis] <= hi {
                pb.grow(p);
            }
            if cl.1 & (1 << i) != 0 {
                pb.grow(cl.0[i]);
            }
            if ch.1 & (1 << i) != 0 {
                pb.grow(ch.0[i]);
            }
        }
        if pb.is_empty() {
            out(k, Aabb::EMPTY);
            continue;
        }
        let grown = Aabb::new(pb.min - tol, pb.max + tol);
        let o = tb_core::clip::intersect(&grown, &cell);
        out(k, if o.is_empty() { cell } else { o });
    }
}

/// Object-median split (by index when `axis` is `None`): the lower half of the centres left.
fn median(mut refs: Vec<Ref>, axis: Option<usize>) -> (Vec<Ref>, Vec<Ref>) {
    let mid = refs.len() / 2;
    if let Some(a) = axis {
        refs.select_nth_unstable_by(mid, |x, y| x.c2()[a].total_cmp(&y.c2()[a]));
    }
    let r = refs.split_off(mid);
    (refs, r)
}

#[inline(always)]
fn obj_bin(c: f32, min: f32, scale: f32, nb: usize) -> usize {
    (((c - min) * scale) as usize).min(nb - 1)
}

#[inline(always)]
fn spatial_bin(x: f32, lo: f32, w: f32, nb: usize) -> usize {
    (((x - lo) / w) as usize).min(nb - 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `chop` gives `slab_box`'s boxes bit for bit (so the SBVH is the one built with it).
    #[test]
    fn chop_equals_slab_box() {
        let mut s = 0x2545f4914f6cdd1du64;
        let mut rnd = move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 40) as f32 / (1u64 << 24) as f32
        };
        let mut cross = Vec::new();
        let mut n = 0;
        for k in 0..3000 {
            let mut v = || Vec3::new(rnd(), rnd(), rnd()) * 10.0 - 5.0;
            let mut tri = Triangle::new(v(), v(), v());
            if k % 5 == 0 {
                // A vertex on a slab plane.
                tri.v1.x = -5.0 + 10.0 / 8.0 * 3.0;
            }
            let tb = tri.bounds();
            // Sometimes a reference box already cut down.
            let lim = if k % 2 == 0 {
                tb
            } else {
                let mut l = tb;
                l.min.y = l.min.y.max(tb.min.y + (tb.max.y - tb.min.y) * rnd());
                l
            };
            let nb = 8;
            let (lo, hi) = (-5.0f32, 5.0f32);
            let w = (hi - lo) / nb as f32;
            let plane = |k: usize| if k == nb { hi } else { lo + w * k as f32 };
            for axis in 0..3 {
                let first = spatial_bin(lim.min[axis], lo, w, nb);
                let last = spatial_bin(lim.max[axis], lo, w, nb).max(first);
                chop(
                    &tri,
                    &lim,
                    axis,
                    first..=last,
                    &plane,
                    &mut cross,
                    |b, c| {
                        let want =
                            tb_core::clip::slab_box(&tri, &lim, axis, plane(b), plane(b + 1));
                        let bits = |a: &Aabb| {
                            (
                                a.min.to_array().map(f32::to_bits),
                                a.max.to_array().map(f32::to_bits),
                            )
                        };
                        assert_eq!(bits(&c), bits(&want), "{tri:?} axis {axis} bin {b}");
                        n += 1;
                    },
                );
            }
        }
        assert!(n > 10_000);
    }
}
