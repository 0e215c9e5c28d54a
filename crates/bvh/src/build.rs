//! Top-down binned SAH build (Wald 2007; SAH after Goldsmith and Salmon 1987, MacDonald and
//! Booth 1990), writing the flat node array directly.
//!
//! The builder sees one [`PrimRef`] per triangle: its box and (implicitly) the box centre,
//! which is the "centroid" that is binned. Per node it
//! 1. computes the node box and the centroid bounds (one pass);
//! 2. bins the centroids on all three axes at once into `bins` equal intervals of the
//!    centroid bounds, keeping per bin a box and a count (one pass);
//! 3. sweeps the bins of each axis to find the boundary of least SAH cost
//!    `C_trav·A(n) + C_isect·(A(L)·c(|L|) + A(R)·c(|R|))` (costs kept unnormalised by
//!    `A(n)`), the children priced as leaves, `c(k)` the leaf price of `leaf_cost`: `k`
//!    (`linear`) or `⌈k/4⌉` (`blocks`, the wide trees' leaf blocks of four);
//! 4. makes a leaf when `|n| ≤ min_leaf`, or when `|n| ≤ max_leaf` and the leaf cost
//!    `C_isect·A(n)·c(|n|)` is at most the best split's; otherwise partitions the references
//!    in place at the chosen boundary (one pass).
//!
//! Where binning cannot separate the primitives (all centroids coincide, a zero-area node,
//! every centroid in one bin) and `|n| > max_leaf`, the node is split at the object median
//! (along the largest centroid extent, by index when all centroids coincide), so leaves never
//! exceed `max_leaf`. From depth [`MEDIAN_DEPTH`] on only median splits are made, so no leaf
//! is deeper than `MEDIAN_DEPTH + 32 ≤ STACK_SIZE` and the traversal stack cannot overflow.

use crate::traverse::STACK_SIZE;
use crate::{BvhNode, BvhParams};
use tb_core::{Aabb, Triangle, Vec3};

/// Depth from which only object-median splits are made (bounds the tree depth).
pub(crate) const MEDIAN_DEPTH: u32 = 32;

const _: () = assert!(MEDIAN_DEPTH as usize + 32 <= STACK_SIZE);

/// What the builder knows of a primitive: its box and its index in the scene. 32 bytes, so
/// that the in-place partitions move little memory. The centroid is the box centre;
/// [`PrimRef::c2`] gives twice it (the factor cancels everywhere it is used).
#[derive(Clone, Copy)]
#[repr(C)]
struct PrimRef {
    min: Vec3,
    id: u32,
    max: Vec3,
}

impl PrimRef {
    /// Twice the box centre.
    #[inline(always)]
    fn c2(&self) -> Vec3 {
        self.min + self.max
    }
}

#[derive(Clone, Copy)]
struct Bin {
    bounds: Aabb,
    count: u32,
}

impl Bin {
    const EMPTY: Bin = Bin {
        bounds: Aabb::EMPTY,
        count: 0,
    };
}

/// Partition `part` in place by bin: the references whose centroid falls in bins `0..=k` of
/// `axis` first; returns their count.
#[inline]
fn partition_by_bin(part: &mut [PrimRef], map: &BinMap, axis: usize, k: usize) -> usize {
    let (mut i, mut j) = (0, part.len());
    while i < j {
        if map.bin(part[i].c2(), axis) <= k {
            i += 1;
        } else {
            j -= 1;
            part.swap(i, j);
        }
    }
    i
}

/// Maps a centroid coordinate to its bin: `floor((c - min)·scale)` clamped to `bins - 1`.
/// The binning pass and the partition use this one function, so they agree exactly.
#[derive(Clone, Copy)]
struct BinMap {
    min: Vec3,
    scale: Vec3,
    last: usize,
}

impl BinMap {
    #[inline(always)]
    fn bin(&self, c2: Vec3, axis: usize) -> usize {
        // Float-to-int `as` saturates (NaN → 0), so this never goes out of range.
        (((c2[axis] - self.min[axis]) * self.scale[axis]) as usize).min(self.last)
    }
}

struct Builder<'p> {
    params: &'p BvhParams,
    /// Index of the first reference of the slice being built in the whole reference array
    /// (leaves store global triangle slots).
    base: usize,
    nodes: Vec<BvhNode>,
    /// Scratch: `3 × bins` bins, reused at every node.
    bins: Vec<Bin>,
    /// Scratch: per bin boundary, A(R)·|R| and |R| of the bins to its right.
    right_cost: Vec<f32>,
    right_count: Vec<u32>,
}

/// Nodes with at least this many references are split on the current rayon pool, both
/// children at once, when it has more than one thread.
const PAR_MIN: usize = 8192;

/// Build the flat node array and the leaf order (scene index of each triangle slot).
///
/// On a rayon pool of more than one thread, large subtrees are built in parallel, each into
/// its own array, and spliced in the order the sequential build writes (a node's child pair,
/// then the left subtree, then the right one), so the result is the same array.
pub(crate) fn build(tris: &[Triangle], params: &BvhParams) -> (Vec<BvhNode>, Vec<u32>) {
    if tris.is_empty() {
        return (Vec::new(), Vec::new());
    }
    let mut refs: Vec<PrimRef> = tris
        .iter()
        .enumerate()
        .map(|(i, t)| {
            let b = t.bounds();
            PrimRef {
                min: b.min,
                id: i as u32,
                max: b.max,
            }
        })
        .collect();
    let nodes = if rayon::current_num_threads() > 1 && refs.len() >= PAR_MIN {
        let (root, desc) = par_node(params, &mut refs, 0, 0);
        let mut nodes = Vec::with_capacity(desc.len() + 1);
        nodes.push(shifted(root, 1));
        nodes.extend(desc.iter().map(|n| shifted(*n, 1)));
        nodes
    } else {
        let mut b = Builder::new(params, 0);
        // A binary tree with leaves of ≥ 1 primitive has at most 2n − 1 nodes.
        b.nodes.reserve(2 * tris.len() - 1);
        b.nodes.push(BvhNode::EMPTY);
        let n = refs.len();
        b.build_node(0, &mut refs, 0, n, 0);
        b.nodes.shrink_to_fit();
        b.nodes
    };
    let order = refs.iter().map(|r| r.id).collect();
    (nodes, order)
}

/// `n` with its child index moved by `by` when it is an interior node.
#[inline]
fn shifted(mut n: BvhNode, by: isize) -> BvhNode {
    if !n.is_leaf() {
        n.index = (n.index as isize + by) as u32;
    }
    n
}

/// Build the subtree of `refs` (global slots from `base`): its root and its descendants in
/// sequential order, child indices relative to the start of the descendants.
fn par_node(
    params: &BvhParams,
    refs: &mut [PrimRef],
    base: usize,
    depth: u32,
) -> (BvhNode, Vec<BvhNode>) {
    let mut b = Builder::new(params, base);
    b.nodes.push(BvhNode::EMPTY);
    let n = refs.len();
    if n < PAR_MIN {
        b.build_node(0, refs, 0, n, depth);
        let root = shifted(b.nodes[0], -1);
        let desc = b.nodes[1..].iter().map(|n| shifted(*n, -1)).collect();
        return (root, desc);
    }
    let (bounds, cb) = node_bounds(refs);
    let mut root = BvhNode {
        min: bounds.min.to_array(),
        index: 0,
        max: bounds.max.to_array(),
        count: 0,
    };
    let Some(mid) = b.split(refs, 0, n, &bounds, &cb, depth) else {
        root.index = base as u32;
        root.count = n as u32;
        return (root, Vec::new());
    };
    let (l, r) = refs.split_at_mut(mid);
    let ((ln, ld), (rn, rd)) = rayon::join(
        || par_node(params, l, base, depth + 1),
        || par_node(params, r, base + mid, depth + 1),
    );
    let lofs = 2isize;
    let rofs = 2 + ld.len() as isize;
    let mut desc = Vec::with_capacity(2 + ld.len() + rd.len());
    desc.push(shifted(ln, lofs));
    desc.push(shifted(rn, rofs));
    desc.extend(ld.iter().map(|n| shifted(*n, lofs)));
    desc.extend(rd.iter().map(|n| shifted(*n, rofs)));
    (root, desc)
}

/// The box of the references and the box of their (doubled) centroids.
fn node_bounds(refs: &[PrimRef]) -> (Aabb, Aabb) {
    let mut bounds = Aabb::EMPTY;
    let mut cb = Aabb::EMPTY;
    for r in refs {
        bounds.min = bounds.min.min(r.min);
        bounds.max = bounds.max.max(r.max);
        cb.grow(r.c2());
    }
    (bounds, cb)
}

impl<'p> Builder<'p> {
    fn new(params: &'p BvhParams, base: usize) -> Self {
        let bins = params.bins as usize;
        Builder {
            params,
            base,
            nodes: Vec::new(),
            bins: vec![Bin::EMPTY; 3 * bins],
            right_cost: vec![0.0; bins],
            right_count: vec![0; bins],
        }
    }
}

impl Builder<'_> {
    fn build_node(
        &mut self,
        node: usize,
        refs: &mut [PrimRef],
        start: usize,
        end: usize,
        depth: u32,
    ) {
        let (bounds, cb) = node_bounds(&refs[start..end]);
        let out = &mut self.nodes[node];
        out.min = bounds.min.to_array();
        out.max = bounds.max.to_array();
        match self.split(refs, start, end, &bounds, &cb, depth) {
            None => {
                let out = &mut self.nodes[node];
                out.index = (self.base + start) as u32;
                out.count = (end - start) as u32;
            }
            Some(mid) => {
                debug_assert!(start < mid && mid < end);
                let left = self.nodes.len();
                self.nodes.push(BvhNode::EMPTY);
                self.nodes.push(BvhNode::EMPTY);
                let out = &mut self.nodes[node];
                out.index = left as u32;
                out.count = 0;
                self.build_node(left, refs, start, mid, depth + 1);
                self.build_node(left + 1, refs, mid, end, depth + 1);
            }
        }
    }

    /// Decide leaf (`None`) or split; on a split, partition `refs[start..end]` and return the
    /// first index of the right part.
    fn split(
        &mut self,
        refs: &mut [PrimRef],
        start: usize,
        end: usize,
        bounds: &Aabb,
        cb: &Aabb,
        depth: u32,
    ) -> Option<usize> {
        let n = end - start;
        let p = self.params;
        let max_leaf = p.max_leaf as usize;
        if n <= 1 || n <= p.min_leaf as usize {
            return None;
        }
        let ext = cb.extent();
        if ext == Vec3::ZERO {
            // All centroids coincide: nothing to sort by; halve the range.
            return (n > max_leaf).then_some(start + n / 2);
        }
        let area = bounds.half_area();
        // (False for NaN as well.)
        let area_usable = area > 0.0 && area.is_finite();
        if depth >= MEDIAN_DEPTH || !area_usable {
            return (n > max_leaf).then(|| self.median(refs, start, end, cb.largest_axis()));
        }

        // Bin all three axes in one pass.
        let nb = p.bins as usize;
        let map = BinMap {
            min: cb.min,
            scale: Vec3::select(
                ext.cmpgt(Vec3::ZERO),
                Vec3::splat(nb as f32) / ext,
                Vec3::ZERO,
            ),
            last: nb - 1,
        };
        self.bin_centroids(&refs[start..end], &map);
        let (best_cost, best) = self.sweep(ext, nb);

        let Some((axis, k)) = best else {
            // Every centroid fell into one bin on every axis (rounding): median split.
            return (n > max_leaf).then(|| self.median(refs, start, end, cb.largest_axis()));
        };
        if n <= max_leaf {
            let split_cost = p.c_trav * area + p.c_isect * best_cost;
            let leaf_cost = p.c_isect * area * p.leaf_cost.units(n);
            if leaf_cost <= split_cost {
                return None;
            }
        }

        let part = &mut refs[start..end];
        let i = partition_by_bin(part, &map, axis, k);
        if i == 0 || i == part.len() {
            // Cannot happen (the bins counted both sides), but never make an empty child.
            return Some(self.median(refs, start, end, axis));
        }
        Some(start + i)
    }

    /// Bin the centroids of `refs` on all three axes in one pass (the bins' bounds and counts).
    #[inline]
    fn bin_centroids(&mut self, refs: &[PrimRef], map: &BinMap) {
        let nb = self.params.bins as usize;
        self.bins.fill(Bin::EMPTY);
        for r in refs {
            let c = r.c2();
            for axis in 0..3 {
                let bin = &mut self.bins[axis * nb + map.bin(c, axis)];
                bin.bounds.min = bin.bounds.min.min(r.min);
                bin.bounds.max = bin.bounds.max.max(r.max);
                bin.count += 1;
            }
        }
    }

    /// The SAH sweep over the `nb` bins of every axis with a non-zero centroid extent `ext`:
    /// the lowest cost and its boundary `(axis, k)` (bins `0..=k` left, `k+1..` right), `None`
    /// when no boundary has primitives on both sides.
    #[inline]
    fn sweep(&mut self, ext: Vec3, nb: usize) -> (f32, Option<(usize, usize)>) {
        let p = self.params;
        let mut best_cost = f32::INFINITY;
        let mut best: Option<(usize, usize)> = None;
        for axis in 0..3 {
            if ext[axis] <= 0.0 {
                continue;
            }
            let bins = &self.bins[axis * nb..(axis + 1) * nb];
            let mut acc = Aabb::EMPTY;
            let mut cnt = 0u32;
            for k in (1..nb).rev() {
                acc = acc.union(&bins[k].bounds);
                cnt += bins[k].count;
                self.right_cost[k] = acc.half_area() * p.leaf_cost.units(cnt as usize);
                self.right_count[k] = cnt;
            }
            acc = Aabb::EMPTY;
            cnt = 0;
            for k in 0..nb - 1 {
                acc = acc.union(&bins[k].bounds);
                cnt += bins[k].count;
                if cnt == 0 || self.right_count[k + 1] == 0 {
                    continue;
                }
                let cost =
                    acc.half_area() * p.leaf_cost.units(cnt as usize) + self.right_cost[k + 1];
                if cost < best_cost {
                    best_cost = cost;
                    best = Some((axis, k));
                }
            }
        }
        (best_cost, best)
    }

    /// Object-median split along `axis`: the lower half of the centroids goes left.
    fn median(&mut self, refs: &mut [PrimRef], start: usize, end: usize, axis: usize) -> usize {
        let mid = (end - start) / 2;
        refs[start..end].select_nth_unstable_by(mid, |a, b| a.c2()[axis].total_cmp(&b.c2()[axis]));
        start + mid
    }
}
