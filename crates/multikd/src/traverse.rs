//! The walks of a multi-kd-tree (Torres et al. 2012 §5-6): every tb-kdtree kernel run from the
//! root of each ray's tree, in the rays' order or arranged by tree (the `-sorted` and
//! `-presorted` rows).

use super::*;
use tb_kdtree::traverse::{self as kd_traverse, Tree};

impl MultiKdTree {
    /// The per-ray kernel: `make` applied to the walk input of each header entry.
    pub(crate) fn per_ray<'a, L: Layout, K>(
        &'a self,
        l: L,
        make: impl Fn(Tree<'a, L>) -> K,
    ) -> PerRay<K> {
        let v = self.view();
        PerRay {
            k: [0, 1, 2].map(|i| make(Tree::new(v, l, self.start(i)))),
            pick: self.pick,
        }
    }

    /// The ray arrangement of §6: `rays` in blocks of [`ARRANGE_BLOCK`], each block stably
    /// counting-sorted by tree index (the 2-bit key, [`MultiKdTree::tree_of`]). Entry `p` of
    /// `out` names the ray traced `p`-th: `j | tree << TREE_SHIFT`, the ray being number `j`
    /// of the block holding position `p` (so the entries of a block stay right for any slice
    /// of the rays cut at multiples of [`ARRANGE_BLOCK`], as the runner's chunks are).
    pub fn arrange(&self, rays: &[Ray], out: &mut Vec<u32>) {
        out.clear();
        out.resize(rays.len(), 0);
        let mut keys = [0u8; ARRANGE_BLOCK];
        for (block, dst) in rays
            .chunks(ARRANGE_BLOCK)
            .zip(out.chunks_mut(ARRANGE_BLOCK))
        {
            // start[k + 1] counts key k; then start[k] is where key k's run begins.
            let mut start = [0usize; 4];
            for (k, r) in keys.iter_mut().zip(block) {
                *k = self.tree_of(r.dir.to_array()) as u8;
                start[*k as usize + 1] += 1;
            }
            for k in 1..4 {
                start[k] += start[k - 1];
            }
            for (j, &k) in keys[..block.len()].iter().enumerate() {
                dst[start[k as usize]] = j as u32 | (k as u32) << TREE_SHIFT;
                start[k as usize] += 1;
            }
        }
    }
}

/// Where an [`MultiKdTree::arrange`] entry keeps the tree index: `j | tree << TREE_SHIFT`,
/// `j` (below bit 30) the ray's number within its block.
pub const TREE_SHIFT: u32 = 30;

/// The ray number bits of an arrangement entry.
pub(crate) const RAY_MASK: u32 = (1 << TREE_SHIFT) - 1;

/// Rays sorted together by [`MultiKdTree::arrange`]: one traced chunk of the runner.
pub const ARRANGE_BLOCK: usize = tb_core::par::CHUNK;
const _: () = assert!(ARRANGE_BLOCK <= RAY_MASK as usize + 1);

/// A kd traversal kernel per header entry; each ray runs the one of its tree (§5).
pub(crate) struct PerRay<K> {
    k: [K; 3],
    pick: Heuristic,
}

impl<K: Kernel> Kernel for PerRay<K> {
    #[inline(always)]
    fn closest<T: TriTest, C: Counter>(&self, ray: &Ray, c: &mut C) -> HitRecord {
        self.k[self.pick.pick(ray.dir.to_array())].closest::<T, C>(ray, c)
    }

    #[inline(always)]
    fn any<T: TriTest, C: Counter>(&self, ray: &Ray, c: &mut C) -> HitRecord {
        self.k[self.pick.pick(ray.dir.to_array())].any::<T, C>(ray, c)
    }
}

/// Trace batch `b` into `out` with plain row `row`'s kernel, in the arrangement `order`
/// ([`MultiKdTree::arrange`]) or, with `None`, in the rays' order with the tree picked per ray
/// in the walk: the one call of the plain, `-sorted` and `-presorted` rows.
pub(crate) fn trace_row(
    m: &MultiKdTree,
    row: usize,
    b: Batch<'_>,
    order: Option<&[u32]>,
    out: Answers<'_>,
) {
    match m.params.kd.layout {
        KdLayout::DepthFirst => trace_in(m, DepthFirst, row, (b, order, out)),
        KdLayout::Treelet => {
            let l = Treelet::new(m.params.kd.treelet_height);
            trace_in(m, l, row, (b, order, out))
        }
    }
}

/// A chunk as [`trace_row`] passes it on: the batch, its arrangement, its answers.
type Chunk<'a, 'o> = (Batch<'a>, Option<&'a [u32]>, Answers<'o>);

/// [`trace_row`] in layout `l`: the kd-tree's kernel of row `row` per header entry (the
/// kd-tree's table order; a row added there fails [`PLAIN`]'s check and the table test).
pub(crate) fn trace_in<L: Layout>(m: &MultiKdTree, l: L, row: usize, c: Chunk<'_, '_>) {
    macro_rules! go {
        (|$w:ident| $kernel:expr) => {
            walk(&m.per_ray(l, |$w| $kernel), c)
        };
    }
    let ropes = || Aux {
        back: &[],
        ropes: Some(m.ropes()),
    };
    match row {
        0 => go!(|w| kd_traverse::RecursiveDirection(w)),
        1 => go!(|w| kd_traverse::Havran(w)),
        2 => go!(|w| kd_traverse::RecursiveOrigin(w)),
        3 => go!(|w| Stackless::<_, { stackless::RESTART }>(w, Aux::default())),
        4 => go!(|w| Stackless::<_, { stackless::PUSH_DOWN }>(w, Aux::default())),
        5 => go!(|w| Stackless::<_, { stackless::SHORT_STACK }>(w, Aux::default())),
        6 => go!(|w| Stackless::<_, { stackless::SEQUENTIAL }>(w, Aux::default())),
        7 => go!(|w| Stackless::<_, { stackless::BACKTRACK }>(
            w,
            Aux {
                back: m.back_nodes(),
                ropes: None,
            }
        )),
        8 => go!(|w| Stackless::<_, { stackless::ROPES }>(w, ropes())),
        9 => go!(|w| kd_traverse::Branchless(w)),
        10 => go!(|w| kd_traverse::StackSpilling(w)),
        _ => unreachable!("multi-kd: no plain traversal {row}"),
    }
}

/// Run the per-tree kernels `k` over a chunk: [`dispatch`] of the per-ray choice, or the
/// walk of its arrangement; monomorphised per triangle test and for counting or timing.
pub(crate) fn walk<K: Kernel>(k: &PerRay<K>, (b, order, out): Chunk<'_, '_>) {
    let Some(order) = order else {
        return dispatch(k, b, out);
    };
    let (q, rays) = (b.query, b.rays);
    match b.tri {
        TriTestKind::Watertight => arranged::<K, Watertight>(&k.k, q, rays, order, out),
        TriTestKind::MollerTrumbore => arranged::<K, MollerTrumbore>(&k.k, q, rays, order, out),
    }
}

/// The walk of an arrangement: entry `p` names ray `p - p % ARRANGE_BLOCK + j` and its tree;
/// the ray is traced with that tree's kernel and its answer written to its own place.
pub(crate) fn arranged<K: Kernel, T: TriTest>(
    k: &[K; 3],
    query: Query,
    rays: &[Ray],
    order: &[u32],
    out: Answers<'_>,
) {
    let (hits, stats) = (out.hits, out.stats);
    assert_eq!(rays.len(), hits.len(), "one hit record per ray");
    assert_eq!(rays.len(), order.len(), "one arrangement entry per ray");
    let at = |p: usize, e: u32| {
        (
            p - p % ARRANGE_BLOCK + (e & RAY_MASK) as usize,
            e >> TREE_SHIFT,
        )
    };
    match stats {
        None => {
            for (p, &e) in order.iter().enumerate() {
                let (i, t) = at(p, e);
                hits[i] = one::<K, T, NoStats>(&k[t as usize], query, &rays[i], &mut NoStats);
            }
        }
        Some(stats) => {
            assert_eq!(rays.len(), stats.len(), "one stats record per ray");
            for (p, &e) in order.iter().enumerate() {
                let (i, t) = at(p, e);
                let mut local = TraversalStats::default();
                hits[i] = one::<K, T, _>(&k[t as usize], query, &rays[i], &mut local);
                stats[i] = local;
            }
        }
    }
}

#[inline(always)]
pub(crate) fn one<K: Kernel, T: TriTest, C: Counter>(
    k: &K,
    query: Query,
    ray: &Ray,
    c: &mut C,
) -> HitRecord {
    match query {
        Query::Closest => k.closest::<T, C>(ray, c),
        Query::Any => k.any::<T, C>(ray, c),
    }
}

/// The kd-tree's row `i` (name, paper, doc, counters): the kernels are the same.
pub(crate) const fn kd_info(i: usize) -> TraversalInfo {
    KdTree::TRAVERSALS[i].info
}

/// Row `i` of the kd-tree's table as `NAME-sorted`.
pub(crate) const fn sorted_info(i: usize, name: &'static str) -> TraversalInfo {
    TraversalInfo {
        name,
        doc: "the traversal named without `-sorted`, the rays of each traced chunk first \
              counting-sorted by tree index (2-bit key) and walked in that order (Torres et \
              al. 2012 §6); the sort is timed with the traversal (the paper's \"inc.\")",
        ..KdTree::TRAVERSALS[i].info
    }
}

/// Row `i` of the kd-tree's table as `NAME-presorted`.
pub(crate) const fn presorted_info(i: usize, name: &'static str) -> TraversalInfo {
    TraversalInfo {
        name,
        doc: "the traversal named without `-presorted`, walking the `-sorted` rows' \
              arrangement by tree index computed per batch by the untimed hint pass (Torres \
              et al. 2012 §6, the paper's \"n.inc.\"); without hints it sorts as `-sorted`",
        ..KdTree::TRAVERSALS[i].info
    }
}

/// Plain traversals in the kd-tree's order, then their `-sorted` and `-presorted` forms (the
/// table below lists every kd traversal: a new one there fails this).
pub(crate) const PLAIN: usize = 11;
const _: () = assert!(KdTree::TRAVERSALS.len() == PLAIN);

/// Plain row `I`: the tree picked per ray, rays in the order given.
pub(crate) fn plain<const I: usize>(m: &MultiKdTree, b: Batch<'_>, out: Answers<'_>) {
    trace_row(m, I, b, None, out)
}

/// `-sorted` row: arrange the chunk by tree ([`MultiKdTree::arrange`]) and walk it, both in
/// this (timed) call.
pub(crate) fn sorted<const I: usize>(m: &MultiKdTree, b: Batch<'_>, out: Answers<'_>) {
    let mut order = Vec::new();
    m.arrange(b.rays, &mut order);
    trace_row(m, I, b, Some(&order), out)
}

/// The hints of the `-presorted` rows: the batch's arrangement ([`MultiKdTree::arrange`]).
pub(crate) fn arrangement(m: &MultiKdTree, _: Query, rays: &[Ray]) -> Vec<u32> {
    let mut order = Vec::new();
    m.arrange(rays, &mut order);
    order
}

/// `-presorted` row: walk the arrangement the hint pass found (no hints: arrange here, as
/// `-sorted`).
pub(crate) fn presorted<const I: usize>(m: &MultiKdTree, b: Batch<'_>, out: Answers<'_>) {
    match b.hints {
        Some(order) => trace_row(m, I, b, Some(order), out),
        None => sorted::<I>(m, b, out),
    }
}

/// Row `I`'s kernel `$f::<I>` ([`plain`], [`sorted`], [`presorted`]) as a table's named
/// kernel ([`tb_core::kernel!`]: compiled here, not again in every crate using the tree).
macro_rules! row_kernel {
    ($f:ident, $i:literal) => {
        tb_core::kernel!(|m: &MultiKdTree, batch, out| $f::<$i>(m, batch, out))
    };
}

/// Row `I` as `-presorted`: traced without hints it sorts (as `-sorted`).
macro_rules! presorted_row {
    ($i:literal, $name:literal) => {
        Traversal::cpu(presorted_info($i, $name), row_kernel!(presorted, $i))
            .with_hints(arrangement)
    };
}
