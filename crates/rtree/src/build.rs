//! Construction: successive insertion of the triangles' boxes into a dynamic (arena) R-tree
//! (Guttman 1984; R*-tree: Beckmann, Kriegel, Schneider and Seeger 1990), then packing into
//! the complete level-order array of the paper's section 4 ([`pack`]).
//!
//! Measures in 3D follow the paper's section 3.1: Guttman's and Beckmann's *area* becomes the
//! box volume, their *margin* (perimeter) the surface area, *overlap* the volume of the
//! intersection of two boxes. All measures are evaluated in `f64` so that huge scenes
//! (coordinates near `f32::MAX`) neither overflow nor produce `inf − inf`.

use crate::{ChildOrder, RtreeNode, RtreeParams, Strategy, MAX_M};
use tb_core::{Aabb, Triangle, Vec3};

/// One entry of a dynamic node: the box of a child node (`level > 0`) or of a triangle
/// (`level == 0`), and the child's arena index or the triangle's scene index.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Entry {
    pub bb: Aabb,
    pub id: u32,
}

const NO_ENTRY: Entry = Entry {
    bb: Aabb::EMPTY,
    id: u32::MAX,
};

/// A node of the dynamic tree: up to `M + 1` entries (one more than `M` while it overflows).
#[derive(Clone, Copy)]
pub(crate) struct DynNode {
    /// Level `l`: 0 for leaves (entries are triangles), `l > 0` for intermediate nodes whose
    /// entries are nodes of level `l − 1` (paper section 2.2).
    pub level: u32,
    pub len: u32,
    pub e: [Entry; MAX_M + 1],
}

impl DynNode {
    fn new(level: u32) -> Self {
        DynNode {
            level,
            len: 0,
            e: [NO_ENTRY; MAX_M + 1],
        }
    }

    #[inline]
    pub fn entries(&self) -> &[Entry] {
        &self.e[..self.len as usize]
    }

    #[inline]
    fn push(&mut self, e: Entry) {
        self.e[self.len as usize] = e;
        self.len += 1;
    }

    fn bounds(&self) -> Aabb {
        self.entries()
            .iter()
            .fold(Aabb::EMPTY, |b, e| b.union(&e.bb))
    }
}

/// `f64` extent of a box (zero for the empty box).
#[inline]
fn ext(b: &Aabb) -> [f64; 3] {
    if b.is_empty() {
        return [0.0; 3];
    }
    let e = [
        b.max.x as f64 - b.min.x as f64,
        b.max.y as f64 - b.min.y as f64,
        b.max.z as f64 - b.min.z as f64,
    ];
    // A NaN extent (NaN coordinates) counts as zero so that measures stay comparable.
    e.map(|v| if v.is_nan() { 0.0 } else { v })
}

/// Volume (Guttman's "area" in 3D).
#[inline]
pub(crate) fn volume(b: &Aabb) -> f64 {
    let e = ext(b);
    e[0] * e[1] * e[2]
}

/// Surface area (Beckmann's "margin" in 3D, paper section 3.1).
#[inline]
pub(crate) fn surface(b: &Aabb) -> f64 {
    let e = ext(b);
    2.0 * (e[0] * e[1] + e[1] * e[2] + e[2] * e[0])
}

/// Volume of the intersection of two boxes ("overlap", paper section 3.1).
#[inline]
fn overlap(a: &Aabb, b: &Aabb) -> f64 {
    let i = Aabb {
        min: a.min.max(b.min),
        max: a.max.min(b.max),
    };
    volume(&i)
}

/// Lexicographic "less than" of cost keys (NaN never wins).
#[inline]
fn less(a: &[f64; 4], b: &[f64; 4]) -> bool {
    for k in 0..4 {
        if a[k] < b[k] {
            return true;
        }
        if a[k] > b[k] || a[k].is_nan() {
            return false;
        }
    }
    false
}

/// Counts reported by the build.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct BuildCounts {
    pub splits: u64,
    pub reinserts: u64,
    /// Entries ejected by the forced reinsertions, `p` each
    /// ([`RtreeParams::reinsert_count`]).
    pub ejected: u64,
}

/// The dynamic R-tree during construction.
pub(crate) struct Builder<'p> {
    p: &'p RtreeParams,
    m: usize,
    big_m: usize,
    pub nodes: Vec<DynNode>,
    pub root: u32,
    /// `reinserted[l]`: forced reinsertion already done at level `l` during the current
    /// insertion of a triangle (R*-tree OverflowTreatment, once per level per insertion).
    reinserted: Vec<bool>,
    pub counts: BuildCounts,
}

/// Path from the root to a node: `(node, slot)` pairs, `slot` being the entry followed.
type Path = Vec<(u32, u32)>;

impl<'p> Builder<'p> {
    pub fn new(p: &'p RtreeParams) -> Self {
        Builder {
            p,
            m: p.m as usize,
            big_m: p.big_m as usize,
            nodes: vec![DynNode::new(0)],
            root: 0,
            reinserted: vec![false],
            counts: BuildCounts::default(),
        }
    }

    /// Number of levels (`L + 1`).
    pub fn height(&self) -> u32 {
        self.nodes[self.root as usize].level + 1
    }

    /// InsertData (Beckmann et al. 1990): insert one triangle box at the leaf level.
    pub fn insert_data(&mut self, bb: Aabb, id: u32) {
        self.reinserted.iter_mut().for_each(|r| *r = false);
        self.insert(Entry { bb, id }, 0);
    }

    /// Insert `e` into a node of level `level` chosen by ChooseSubtree.
    fn insert(&mut self, e: Entry, level: u32) {
        let mut path: Path = Vec::with_capacity(32);
        let mut n = self.root;
        while self.nodes[n as usize].level > level {
            let s = self.choose_subtree(n, &e.bb);
            path.push((n, s));
            n = self.nodes[n as usize].e[s as usize].id;
        }
        self.nodes[n as usize].push(e);
        for &(pn, s) in &path {
            let x = &mut self.nodes[pn as usize].e[s as usize].bb;
            *x = x.union(&e.bb);
        }
        if self.nodes[n as usize].len as usize > self.big_m {
            self.overflow(n, &path);
        }
    }

    /// ChooseSubtree: the entry of node `n` that receives a box `bb`, by the strategy (keys
    /// and ties per [`Strategy`] variant; remaining ties go to the first entry).
    pub(crate) fn choose_subtree(&self, n: u32, bb: &Aabb) -> u32 {
        use Strategy as S;
        let node = &self.nodes[n as usize];
        let children_are_leaves = node.level == 1;
        let es = node.entries();
        // Summed overlap volume of `b` with the boxes of the siblings of entry `i`.
        let overlap_with_siblings = |i: usize, b: &Aabb| -> f64 {
            es.iter()
                .enumerate()
                .filter(|&(j, _)| j != i)
                .map(|(_, o)| overlap(b, &o.bb))
                .sum()
        };
        let mut best = 0u32;
        let mut best_key = [f64::INFINITY; 4];
        for (i, en) in es.iter().enumerate() {
            let u = en.bb.union(bb);
            let (v0, v1) = (volume(&en.bb), volume(&u));
            let (s0, s1) = (surface(&en.bb), surface(&u));
            let (dv, ds) = (v1 - v0, s1 - s0);
            // Overlap enlargement (Beckmann et al. 1990).
            let enlargement = || {
                let mut d = 0.0;
                for (j, o) in es.iter().enumerate() {
                    if j != i {
                        d += overlap(&u, &o.bb) - overlap(&en.bb, &o.bb);
                    }
                }
                d
            };
            let key = match self.p.strategy {
                // The paper's minOverlap: least overlap after insertion, ties by least volume
                // enlargement (Feldmann §5.1, §2.2.1).
                S::MinOverlap => [overlap_with_siblings(i, &u), dv, 0.0, 0.0],
                // Section 2.2.1's words for the R*-tree's leaf rule (the paper's minOverlap).
                S::RStarOverlapAfter | S::RStarSrfcOverlapAfter if children_are_leaves => {
                    [overlap_with_siblings(i, &u), dv, 0.0, 0.0]
                }
                S::MinOverlapEnlargement => [enlargement(), dv, v0, ds],
                // R*-tree leaf rule (Beckmann et al. 1990).
                S::RStar | S::RStarSrfc if children_are_leaves => [enlargement(), dv, v0, 0.0],
                S::RStarSurfaceTies if children_are_leaves => [enlargement(), dv, v0, ds],
                // Guttman: least volume enlargement, ties by least volume.
                S::MinVolume | S::RStar | S::RStarOverlapAfter => [dv, v0, 0.0, 0.0],
                S::MinVolumeSurfaceTies | S::RStarSurfaceTies => [dv, v0, ds, s0],
                S::MinSurface | S::RStarSrfc | S::RStarSrfcOverlapAfter | S::Str => {
                    [ds, s0, dv, 0.0]
                }
            };
            if i == 0 || less(&key, &best_key) {
                best = i as u32;
                best_key = key;
            }
        }
        best
    }

    /// OverflowTreatment (Beckmann et al. 1990): forced reinsertion once per level per
    /// insertion (not at the root), otherwise split, propagating upwards.
    fn overflow(&mut self, n: u32, path: &[(u32, u32)]) {
        let level = self.nodes[n as usize].level;
        if n != self.root && self.p.reinsert && !self.reinserted[level as usize] {
            self.reinserted[level as usize] = true;
            self.reinsert(n, path);
            return;
        }
        let nn = self.split(n);
        self.counts.splits += 1;
        if n == self.root {
            let mut r = DynNode::new(level + 1);
            r.push(Entry {
                bb: self.nodes[n as usize].bounds(),
                id: n,
            });
            r.push(Entry {
                bb: self.nodes[nn as usize].bounds(),
                id: nn,
            });
            self.nodes.push(r);
            self.root = self.nodes.len() as u32 - 1;
            self.reinserted.push(false);
            return;
        }
        let &(pn, s) = path.last().expect("a non-root node has a parent");
        let bn = self.nodes[n as usize].bounds();
        let bnn = self.nodes[nn as usize].bounds();
        let parent = &mut self.nodes[pn as usize];
        parent.e[s as usize].bb = bn;
        parent.push(Entry { bb: bnn, id: nn });
        // The parent's box is unchanged (n ∪ nn is the old n), so ancestors need no refit.
        if parent.len as usize > self.big_m {
            self.overflow(pn, &path[..path.len() - 1]);
        }
    }

    /// Forced reinsertion: remove the `p` entries whose centres lie farthest from the centre
    /// of the node's box, refit the path, and reinsert them at the same level, closest first
    /// ("close reinsert", Beckmann et al. 1990).
    fn reinsert(&mut self, n: u32, path: &[(u32, u32)]) {
        self.counts.reinserts += 1;
        let level = self.nodes[n as usize].level;
        let mut removed = self.eject(n);
        // Refit the boxes on the path (they can only shrink).
        let mut child = n;
        for &(pn, s) in path.iter().rev() {
            let b = self.nodes[child as usize].bounds();
            self.nodes[pn as usize].e[s as usize].bb = b;
            child = pn;
        }
        removed.reverse(); // closest of the ejected first
        for e in removed {
            self.insert(e, level);
        }
    }

    /// Remove and return the `p` = [`RtreeParams::reinsert_count`] entries of node `n` whose
    /// centres lie farthest from the centre of its box, farthest first (Feldmann section
    /// 2.2.1: "the k entries with greatest ... distance are removed (ejected)"; Beckmann et
    /// al. 1990, p = 30 % of M). The node keeps the others, closest last in distance order.
    pub(crate) fn eject(&mut self, n: u32) -> Vec<Entry> {
        let p = self.p.reinsert_count();
        self.counts.ejected += p as u64;
        let node = &mut self.nodes[n as usize];
        let c = node.bounds().center();
        let len = node.len as usize;
        let dist = |e: &Entry| {
            let d = e.bb.center() - c;
            let d = [d.x as f64, d.y as f64, d.z as f64];
            let v = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
            if v.is_nan() {
                f64::INFINITY
            } else {
                v
            }
        };
        // Sort by decreasing distance; the first `p` are ejected.
        node.e[..len].sort_by(|a, b| dist(b).total_cmp(&dist(a)));
        let removed: Vec<Entry> = node.e[..p].to_vec();
        node.e.copy_within(p..len, 0);
        node.len = (len - p) as u32;
        for k in node.len as usize..len {
            node.e[k] = NO_ENTRY;
        }
        removed
    }

    /// R*-tree split of an overflowing node (`M + 1` entries): ChooseSplitAxis by the least
    /// sum of surfaces ("margins") over all `2(M − 2m + 2)` distributions of both sorts (by
    /// lower, then upper box bound) of the axis; ChooseSplitIndex on that axis by the least
    /// overlap volume, ties by least volume sum (Beckmann et al. 1990), then the first
    /// distribution (our [`Strategy::split_surface_ties`] variants: least surface sum, then the
    /// first). Distributions are taken in order: the sort by lower bounds before the one by
    /// upper bounds, `k = m … M + 1 − m` entries in the first group. The node keeps the first
    /// group; the returned new node (same level) holds the second.
    pub(crate) fn split(&mut self, n: u32) -> u32 {
        let (m, big_m) = (self.m, self.big_m);
        let node = self.nodes[n as usize];
        let es = node.entries();
        debug_assert_eq!(es.len(), big_m + 1);
        let mut sorted: [[Vec<Entry>; 2]; 3] = Default::default();
        let mut best_axis = 0;
        let mut best_margin = f64::INFINITY;
        let mut pre = vec![Aabb::EMPTY; big_m + 1];
        let mut suf = vec![Aabb::EMPTY; big_m + 2];
        let fill = |v: &[Entry], pre: &mut [Aabb], suf: &mut [Aabb]| {
            let mut b = Aabb::EMPTY;
            for (k, e) in v.iter().enumerate() {
                b = b.union(&e.bb);
                pre[k] = b; // box of entries 0..=k
            }
            let mut b = Aabb::EMPTY;
            suf[v.len()] = b;
            for k in (0..v.len()).rev() {
                b = b.union(&v[k].bb);
                suf[k] = b; // box of entries k..
            }
        };
        for axis in 0..3 {
            let mut margin = 0.0;
            for (s, out) in sorted[axis].iter_mut().enumerate() {
                let mut v = es.to_vec();
                if s == 0 {
                    v.sort_by(|a, b| {
                        a.bb.min[axis]
                            .total_cmp(&b.bb.min[axis])
                            .then(a.bb.max[axis].total_cmp(&b.bb.max[axis]))
                    });
                } else {
                    v.sort_by(|a, b| {
                        a.bb.max[axis]
                            .total_cmp(&b.bb.max[axis])
                            .then(a.bb.min[axis].total_cmp(&b.bb.min[axis]))
                    });
                }
                fill(&v, &mut pre, &mut suf);
                for k in m..=big_m + 1 - m {
                    margin += surface(&pre[k - 1]) + surface(&suf[k]);
                }
                *out = v;
            }
            if axis == 0 || margin < best_margin {
                best_margin = margin;
                best_axis = axis;
            }
        }
        let surface_ties = self.p.strategy.split_surface_ties();
        let mut best: Option<(usize, usize)> = None;
        let mut best_key = [f64::INFINITY; 4];
        for (s, v) in sorted[best_axis].iter().enumerate() {
            fill(v, &mut pre, &mut suf);
            for k in m..=big_m + 1 - m {
                let (a, b) = (&pre[k - 1], &suf[k]);
                let srfc = if surface_ties {
                    surface(a) + surface(b)
                } else {
                    0.0
                };
                let key = [overlap(a, b), volume(a) + volume(b), srfc, 0.0];
                if best.is_none() || less(&key, &best_key) {
                    best = Some((s, k));
                    best_key = key;
                }
            }
        }
        let (s, k) = best.expect("at least one distribution");
        let v = &sorted[best_axis][s];
        let level = node.level;
        let mut a = DynNode::new(level);
        let mut b = DynNode::new(level);
        v[..k].iter().for_each(|e| a.push(*e));
        v[k..].iter().for_each(|e| b.push(*e));
        self.nodes[n as usize] = a;
        self.nodes.push(b);
        self.nodes.len() as u32 - 1
    }
}

/// Sort-Tile-Recursive bulk loading (Leutenegger, Lopez and Edgington 1997, "STR: a simple
/// and efficient algorithm for R-tree packing"), in 3D: at each level the `n` entries are
/// sorted by box-centre x and cut into `S = ⌈P^(1/3)⌉` slabs of `S²·M` entries
/// (`P = ⌈n/M⌉` nodes), each slab sorted by y and cut into slices of `S·M` entries, each
/// slice sorted by z; the resulting sequence is cut into nodes of `M` entries. Slab and slice
/// sizes are multiples of `M`, so only the last node can be short; when it would hold fewer
/// than `m` entries, it takes entries from its predecessor (`M ≥ 2m` keeps both legal). Levels
/// are built bottom-up until one node, the root, remains.
pub(crate) fn bulk_load_str<'p>(tris: &[Triangle], p: &'p RtreeParams) -> Builder<'p> {
    let mut b = Builder::new(p);
    if tris.is_empty() {
        return b;
    }
    b.nodes.clear();
    let big_m = p.big_m as usize;
    let m = p.m as usize;
    let mut level_entries: Vec<Entry> = tris
        .iter()
        .enumerate()
        .map(|(i, t)| Entry {
            bb: t.bounds(),
            id: i as u32,
        })
        .collect();
    let mut level = 0u32;
    loop {
        str_order(&mut level_entries, big_m);
        let n = level_entries.len();
        let mut sizes = vec![big_m; n / big_m];
        let rest = n % big_m;
        if rest > 0 {
            sizes.push(rest);
        }
        let k = sizes.len();
        if k >= 2 && sizes[k - 1] < m {
            let moved = m - sizes[k - 1];
            sizes[k - 2] -= moved;
            sizes[k - 1] = m;
        }
        let mut next = Vec::with_capacity(k);
        let mut at = 0;
        for s in sizes {
            let mut node = DynNode::new(level);
            level_entries[at..at + s].iter().for_each(|e| node.push(*e));
            at += s;
            let bb = node.bounds();
            b.nodes.push(node);
            next.push(Entry {
                bb,
                id: b.nodes.len() as u32 - 1,
            });
        }
        if next.len() == 1 {
            b.root = next[0].id;
            break;
        }
        level_entries = next;
        level += 1;
    }
    b
}

/// Reorder `es` into STR's sort-tile order (see [`bulk_load_str`]).
fn str_order(es: &mut [Entry], big_m: usize) {
    let key = |e: &Entry, a: usize| {
        let c = e.bb.center()[a];
        if c.is_nan() {
            f32::INFINITY
        } else {
            c
        }
    };
    let n = es.len();
    let pages = n.div_ceil(big_m);
    let mut s = (pages as f64).cbrt().ceil() as usize;
    while s > 1 && (s - 1).pow(3) >= pages {
        s -= 1;
    }
    let s = s.max(1);
    es.sort_by(|a, b| key(a, 0).total_cmp(&key(b, 0)));
    for slab in es.chunks_mut(s * s * big_m) {
        slab.sort_by(|a, b| key(a, 1).total_cmp(&key(b, 1)));
        for slice in slab.chunks_mut(s * big_m) {
            slice.sort_by(|a, b| key(a, 2).total_cmp(&key(b, 2)));
        }
    }
}

/// Build the dynamic tree by successive insertion of every triangle's box, in scene order,
/// while `fits(levels)` holds for its height; otherwise stop and return the height reached
/// and the triangles inserted (the height never shrinks, so the layout would not fit).
pub(crate) fn insert_all<'p>(
    tris: &[Triangle],
    p: &'p RtreeParams,
    fits: &dyn Fn(u32) -> bool,
) -> Result<Builder<'p>, (u32, usize)> {
    let mut b = Builder::new(p);
    let mut levels = b.height();
    for (i, t) in tris.iter().enumerate() {
        b.insert_data(t.bounds(), i as u32);
        if b.height() != levels {
            levels = b.height();
            if !fits(levels) {
                return Err((levels, i + 1));
            }
        }
    }
    Ok(b)
}

/// The packed tree: complete level-order array with empty slots, triangles in leaf order.
pub(crate) struct Packed {
    pub nodes: Vec<RtreeNode>,
    pub prim_ids: Vec<u32>,
    /// `L`: level of the root (leaves are at level 0); the tree has `L + 1` levels.
    pub root_level: u32,
}

/// `N = (M^(L+1) − 1) / (M − 1)` slots of a complete `M`-ary tree with `L + 1` levels, or
/// `None` when it does not fit a `u32` index.
pub(crate) fn slot_count(big_m: u32, root_level: u32) -> Option<u32> {
    let mut n: u64 = 0;
    let mut per_level: u64 = 1;
    for _ in 0..=root_level {
        n = n.checked_add(per_level)?;
        per_level = per_level.checked_mul(big_m as u64)?;
    }
    (n < u32::MAX as u64).then_some(n as u32)
}

/// The sort key of an entry for [`ChildOrder`].
fn order_entries(es: &mut [Entry], order: ChildOrder) {
    let axis = match order {
        ChildOrder::Insertion => return,
        ChildOrder::SortedX => 0,
        ChildOrder::SortedY => 1,
        ChildOrder::SortedZ => 2,
    };
    es.sort_by(|a, b| {
        let ca: Vec3 = a.bb.center();
        let cb: Vec3 = b.bb.center();
        ca[axis].total_cmp(&cb[axis])
    });
}

/// Pack the dynamic tree into the level-order array of paper section 4: node `i`'s entries
/// lie at `M·i + 1 … M·i + M` (the paper's `n_e(n) = (n − Δ_L(l))·M + Δ_L(l−1)`), non-empty
/// entries first in [`ChildOrder`], the rest empty slots. Leaves point at runs of the
/// triangle array, which is in leaf (level) order.
pub(crate) fn pack(b: &Builder, tris: &[Triangle], order: ChildOrder, big_m: u32) -> Packed {
    let root_level = b.height() - 1;
    let n = slot_count(big_m, root_level).unwrap_or_else(|| {
        panic!(
            "R-tree with M = {big_m} and {} levels needs more than 2^32 - 1 slots",
            root_level + 1
        )
    });
    let mut nodes = vec![RtreeNode::EMPTY; n as usize];
    let mut prim_ids = Vec::with_capacity(tris.len());
    if tris.is_empty() {
        return Packed {
            nodes: Vec::new(),
            prim_ids,
            root_level: 0,
        };
    }
    // Level by level (breadth first), so leaves and their triangles come in slot order.
    let mut cur: Vec<(u32, u32)> = vec![(0, b.root)]; // (slot, arena node)
    let m = big_m as usize;
    while !cur.is_empty() {
        let mut next = Vec::with_capacity(cur.len() * m);
        for &(slot, id) in &cur {
            let dn = &b.nodes[id as usize];
            let mut es: Vec<Entry> = dn.entries().to_vec();
            order_entries(&mut es, order);
            let node = &mut nodes[slot as usize];
            node.count = es.len() as u32;
            if dn.level == 0 {
                node.index = prim_ids.len() as u32;
                prim_ids.extend(es.iter().map(|e| e.id));
            } else {
                node.index = 0;
                for (k, e) in es.iter().enumerate() {
                    next.push((slot * big_m + 1 + k as u32, e.id));
                }
            }
        }
        cur = next;
    }
    // Minimal boxes bottom-up (children have larger slot indices than their parents).
    for i in (0..n as usize).rev() {
        let node = nodes[i];
        if node.count == 0 {
            continue;
        }
        let bb = if (i as u64) >= first_leaf(big_m, root_level) as u64 {
            let r = node.index as usize..(node.index + node.count) as usize;
            prim_ids[r]
                .iter()
                .fold(Aabb::EMPTY, |b, &t| b.union(&tris[t as usize].bounds()))
        } else {
            let c = i * m + 1;
            nodes[c..c + node.count as usize]
                .iter()
                .fold(Aabb::EMPTY, |b, c| b.union(&c.bounds()))
        };
        nodes[i].min = bb.min.to_array();
        nodes[i].max = bb.max.to_array();
    }
    Packed {
        nodes,
        prim_ids,
        root_level,
    }
}

/// `Δ_L(0)`: the slot of the first leaf (paper section 4), i.e. the number of slots above
/// the leaf level.
pub(crate) fn first_leaf(big_m: u32, root_level: u32) -> u32 {
    if root_level == 0 {
        0
    } else {
        slot_count(big_m, root_level - 1).expect("fits, as the whole tree does")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A box `[x0, x1] × [y0, y1] × [z0, z1]`.
    fn bx(x: [f32; 2], y: [f32; 2], z: [f32; 2]) -> Aabb {
        Aabb::new(Vec3::new(x[0], y[0], z[0]), Vec3::new(x[1], y[1], z[1]))
    }

    /// A builder whose root is one node of `level` holding `boxes` (ids 0, 1, …).
    fn node_of<'p>(p: &'p RtreeParams, level: u32, boxes: &[Aabb]) -> Builder<'p> {
        let mut b = Builder::new(p);
        let mut n = DynNode::new(level);
        for (i, bb) in boxes.iter().enumerate() {
            n.push(Entry {
                bb: *bb,
                id: i as u32,
            });
        }
        b.nodes = vec![n];
        b.root = 0;
        b
    }

    fn choose(s: Strategy, level: u32, boxes: &[Aabb], e: &Aabb) -> u32 {
        let p = RtreeParams {
            strategy: s,
            ..Default::default()
        };
        node_of(&p, level, boxes).choose_subtree(0, e)
    }

    /// The paper's minOverlap (section 5.1, read as section 2.2.1's "overlap least with those
    /// of its siblings afterwards") takes the entry whose box has the least summed overlap
    /// with its siblings after including the new box; Beckmann's overlap enlargement
    /// (`min-overlap-enlargement`) takes another. Entry A (index 0) contains the new box but
    /// overlaps S by 3; B (index 1), enlarged, overlaps only A, by 2; S (index 2), enlarged,
    /// overlaps A by 9. Overlap after: A 3, B 2, S 9; enlargement: A 0, B 2, S 6.
    #[test]
    fn min_overlap_takes_least_overlap_after_insertion() {
        let z = [0.0, 1.0];
        let a = bx([4.0, 7.0], [0.0, 3.0], z);
        let b = bx([6.5, 8.0], [-3.0, -1.0], z);
        let s = bx([0.0, 10.0], [2.0, 10.0], z);
        let e = bx([5.0, 6.0], [0.0, 1.0], z);
        let boxes = [a, b, s];
        let after: Vec<f64> = (0..3)
            .map(|i| {
                let u = boxes[i].union(&e);
                (0..3)
                    .filter(|&j| j != i)
                    .map(|j| overlap(&u, &boxes[j]))
                    .sum()
            })
            .collect();
        assert_eq!(after, [3.0, 2.0, 9.0]);
        // The R*-tree's leaf rule (entries are leaves: level 1) in both readings.
        assert_eq!(choose(Strategy::RStar, 1, &boxes, &e), 0);
        assert_eq!(choose(Strategy::RStarSrfc, 1, &boxes, &e), 0);
        assert_eq!(choose(Strategy::RStarOverlapAfter, 1, &boxes, &e), 1);
        assert_eq!(choose(Strategy::RStarSrfcOverlapAfter, 1, &boxes, &e), 1);
        // Above the leaves both readings use the R*-tree's (or R*-treeSrfc's) volume (surface)
        // keys: A contains the new box, so needs no enlargement.
        for s in [Strategy::RStarOverlapAfter, Strategy::RStarSrfcOverlapAfter] {
            assert_eq!(choose(s, 2, &boxes, &e), 0, "{s:?}");
        }
        for level in [1, 2] {
            assert_eq!(choose(Strategy::MinOverlap, level, &boxes, &e), 1);
            assert_eq!(
                choose(Strategy::MinOverlapEnlargement, level, &boxes, &e),
                0
            );
        }
        // Ties on overlap after insertion go to the least volume enlargement, not to the
        // first entry: two disjoint boxes, the second nearer the new box.
        let boxes = [bx([0.0, 1.0], [0.0, 1.0], z), bx([5.0, 6.0], [0.0, 1.0], z)];
        let e = bx([7.0, 8.0], [0.0, 1.0], z);
        assert_eq!(choose(Strategy::MinOverlap, 1, &boxes, &e), 1);
    }

    /// On flat (zero-volume) boxes every volume key ties: the paper's minVolume and R*-tree
    /// (Guttman's and Beckmann's ties by volume) take the first entry, never the one of least
    /// surface enlargement; the `…-surface-ties` variants take that one.
    #[test]
    fn volume_strategies_never_use_surface_on_flat_boxes() {
        let z = [0.0, 0.0];
        // A far from the new box (large surface enlargement), B containing it.
        let boxes = [
            bx([0.0, 1.0], [0.0, 1.0], z),
            bx([9.0, 12.0], [0.0, 3.0], z),
        ];
        let e = bx([10.0, 11.0], [1.0, 2.0], z);
        for (s, level, want) in [
            (Strategy::MinVolume, 1, 0),
            (Strategy::MinVolume, 2, 0),
            (Strategy::RStar, 1, 0), // leaf rule: overlap enlargement, volume keys
            (Strategy::RStar, 2, 0), // intermediate rule: volume keys
            (Strategy::MinVolumeSurfaceTies, 1, 1),
            (Strategy::MinVolumeSurfaceTies, 2, 1),
            (Strategy::RStarSurfaceTies, 1, 1),
            (Strategy::RStarSurfaceTies, 2, 1),
            (Strategy::MinSurface, 2, 1),
        ] {
            assert_eq!(choose(s, level, &boxes, &e), want, "{s:?} at level {level}");
        }
        // Volume still decides where it differs: boxes with thickness.
        let t = [0.0, 1.0];
        let boxes = [
            bx([0.0, 1.0], [0.0, 1.0], t),
            bx([9.0, 12.0], [0.0, 3.0], t),
        ];
        let e = bx([10.0, 11.0], [1.0, 2.0], t);
        assert_eq!(choose(Strategy::MinVolume, 2, &boxes, &e), 1);
        assert_eq!(choose(Strategy::RStar, 2, &boxes, &e), 1);
    }

    /// Beckmann's split ties: on flat boxes every distribution of the chosen axis has zero
    /// overlap and zero volume, so the paper's strategies take the first (`k = m` entries in
    /// the first group); the surface-ties variants take the least surface sum (`k = 3`).
    #[test]
    fn split_ties_by_volume_then_first_on_flat_boxes() {
        let z = [0.0, 0.0];
        let boxes: Vec<Aabb> = (0..5)
            .map(|i| {
                let x0 = 1.1 * i as f32;
                let y1 = if i == 4 { 3.0 } else { 1.0 };
                let x1 = if i == 4 { x0 + 3.0 } else { x0 + 1.0 };
                bx([x0, x1], [0.0, y1], z)
            })
            .collect();
        let split = |s: Strategy| {
            let p = RtreeParams {
                strategy: s,
                ..Default::default()
            };
            let mut b = node_of(&p, 0, &boxes);
            let nn = b.split(0);
            let ids = |n: u32| -> Vec<u32> {
                b.nodes[n as usize].entries().iter().map(|e| e.id).collect()
            };
            (ids(0), ids(nn))
        };
        for s in [
            Strategy::MinVolume,
            Strategy::MinSurface,
            Strategy::MinOverlap,
            Strategy::RStar,
            Strategy::RStarSrfc,
        ] {
            assert_eq!(split(s), (vec![0, 1], vec![2, 3, 4]), "{s:?}");
        }
        for s in [
            Strategy::MinVolumeSurfaceTies,
            Strategy::MinOverlapEnlargement,
            Strategy::RStarSurfaceTies,
        ] {
            assert_eq!(split(s), (vec![0, 1, 2], vec![3, 4]), "{s:?}");
        }
    }

    /// The reinsert share decides how many entries a forced reinsertion ejects, and which:
    /// the `p = round(share M)` (clamped to `1..=M + 1 − m`) farthest from the node's centre
    /// (Feldmann section 2.2.1; Beckmann et al. 1990). Five boxes on x, the node's box
    /// `[0, 12]` with centre 6; entry centres 1.5, 3.5, 4.5, 5.5, 11.5 lie 4.5, 2.5, 1.5, 0.5,
    /// 5.5 from it, so the order of ejection is 4, 0, 1, 2, 3.
    #[test]
    fn reinsert_share_ejects_the_farthest_p() {
        let y = [0.0, 1.0];
        let boxes = [
            bx([0.0, 3.0], y, y),
            bx([3.0, 4.0], y, y),
            bx([4.0, 5.0], y, y),
            bx([5.0, 6.0], y, y),
            bx([11.0, 12.0], y, y),
        ];
        for (share, ejected) in [
            (0.01, &[4][..]),
            (0.3, &[4]),
            (0.4, &[4, 0]),
            (0.5, &[4, 0]),
            (0.7, &[4, 0, 1]),
            (0.75, &[4, 0, 1]),
        ] {
            let p = RtreeParams {
                reinsert_share: share,
                ..Default::default()
            };
            let mut b = node_of(&p, 0, &boxes);
            let out: Vec<u32> = b.eject(0).iter().map(|e| e.id).collect();
            assert_eq!(out, ejected, "share {share}");
            assert_eq!(b.counts.ejected, ejected.len() as u64);
            let kept = &b.nodes[0];
            assert_eq!(
                kept.len as usize,
                boxes.len() - ejected.len(),
                "share {share}"
            );
            for e in kept.entries() {
                assert!(!ejected.contains(&e.id), "share {share}: {} kept", e.id);
            }
        }
        // At M = 8, m = 4 the clamp keeps m: 0.75 M = 6 > M + 1 − m = 5.
        let p = RtreeParams {
            big_m: 8,
            m: 4,
            reinsert_share: 0.75,
            ..Default::default()
        };
        assert_eq!(p.reinsert_count(), 5);
    }
}
