//! The walks of a multi-kd-tree (Torres et al. 2012 §5-6): every tb-kdtree kernel run from the
//! root of each ray's tree, in the rays' order or arranged by tree (the `-sorted` and
//! `-presorted` rows).

use super::*;
use tb_core::accel::GpuFn;
use tb_kdtree::traverse::Tree;

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

/// A chunk as the generated `trace_row` passes it on: the batch, its arrangement, its
/// answers.
pub(crate) type Chunk<'a, 'o> = (Batch<'a>, Option<&'a [u32]>, Answers<'o>);

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

/// The doc of a `NAME-sorted` row.
pub(crate) const SORTED_DOC: &str =
    "the traversal named without `-sorted`, the rays of each traced \
    chunk first counting-sorted by tree index (2-bit key) and walked in that order (Torres et \
    al. 2012 §6); the sort is timed with the traversal (the paper's \"inc.\")";

/// The doc of a `NAME-presorted` row.
pub(crate) const PRESORTED_DOC: &str = "the traversal named without `-presorted`, walking the \
    `-sorted` rows' arrangement by tree index computed per batch by the untimed hint pass \
    (Torres et al. 2012 §6, the paper's \"n.inc.\"); without hints it sorts as `-sorted`";

/// The hints of the `-presorted` rows: the batch's arrangement ([`MultiKdTree::arrange`]).
pub(crate) fn arrangement(m: &MultiKdTree, _: Query, rays: &[Ray]) -> Vec<u32> {
    let mut order = Vec::new();
    m.arrange(rays, &mut order);
    order
}

/// Whether two names are the same (in a constant).
const fn same(a: &str, b: &str) -> bool {
    let (a, b) = (a.as_bytes(), b.as_bytes());
    if a.len() != b.len() {
        return false;
    }
    let mut i = 0;
    while i < a.len() {
        if a[i] != b[i] {
            return false;
        }
        i += 1;
    }
    true
}

/// The GPU programs of the rows of kd traversal `name`: plain, `-sorted`, `-presorted`
/// (`recursive-direction` only, the one kernel of the paper's GPU column).
pub(crate) const fn gpu_of(name: &str) -> [Option<GpuFn<MultiKdTree>>; 3] {
    if same(name, "recursive-direction") {
        [
            Some(MultiKdTree::gpu_recursive_direction),
            Some(MultiKdTree::gpu_sorted),
            Some(MultiKdTree::gpu_presorted),
        ]
    } else {
        [None, None, None]
    }
}

/// Multi-kd's traversal table and per-ray dispatch from [`tb_kdtree::kd_walks!`]'s list:
/// every kd traversal with the tree picked per ray (the same name, info and kernel), then each
/// as `NAME-sorted`, then each as `NAME-presorted`; `trace_row` traces a batch with the kernel
/// of the traversal named. A kd traversal added to the list is offered here without edits.
macro_rules! multikd_walks {
    ($(
        $name:literal, $paper:literal, $doc:literal, [$($info:tt)*], gpu [$($gpu:path)?],
        |$t:ident, $w:ident| $k:expr;
    )*) => {
        /// Trace batch `b` into `out` with the kernel of kd traversal `name`, in the
        /// arrangement `order` ([`MultiKdTree::arrange`]) or, with `None`, in the rays' order
        /// with the tree picked per ray in the walk.
        pub(crate) fn trace_row(
            m: &MultiKdTree,
            name: &str,
            b: Batch<'_>,
            order: Option<&[u32]>,
            out: Answers<'_>,
        ) {
            match m.params.kd.layout {
                KdLayout::DepthFirst => trace_in(m, DepthFirst, name, (b, order, out)),
                KdLayout::Treelet => {
                    let l = Treelet::new(m.params.kd.treelet_height);
                    trace_in(m, l, name, (b, order, out))
                }
            }
        }

        /// `trace_row` of a `NAME-sorted` row: the batch arranged by tree first.
        fn trace_sorted(m: &MultiKdTree, name: &str, b: Batch<'_>, out: Answers<'_>) {
            let mut order = Vec::new();
            m.arrange(b.rays, &mut order);
            trace_row(m, name, b, Some(&order), out)
        }

        /// `trace_row` in layout `l`: the kd kernel named `name` per header entry.
        fn trace_in<L: Layout>(m: &MultiKdTree, l: L, name: &str, c: $crate::traverse::Chunk<'_, '_>) {
            match name {
                $($name => {
                    #[allow(unused_variables)]
                    let $t = m;
                    $crate::traverse::walk(&m.per_ray(l, |$w| $k), c)
                })*
                _ => unreachable!("multi-kd: no kd traversal {name}"),
            }
        }

        /// The table: plain rows, `-sorted` rows, `-presorted` rows, each in the list's order.
        pub(crate) const TABLE: &[Traversal<MultiKdTree>] = &[
            $(Traversal {
                info: TraversalInfo::new($name, $paper, $doc) $($info)*,
                trace: tb_core::kernel!(|m: &MultiKdTree, batch, out| {
                    trace_row(m, $name, batch, None, out)
                }),
                gpu: $crate::traverse::gpu_of($name)[0],
                hints: None,
            },)*
            $(Traversal {
                info: TraversalInfo {
                    name: concat!($name, "-sorted"),
                    doc: $crate::traverse::SORTED_DOC,
                    ..TraversalInfo::new($name, $paper, $doc) $($info)*
                },
                trace: tb_core::kernel!(|m: &MultiKdTree, batch, out| {
                    trace_sorted(m, $name, batch, out)
                }),
                gpu: $crate::traverse::gpu_of($name)[1],
                hints: None,
            },)*
            $(Traversal {
                info: TraversalInfo {
                    name: concat!($name, "-presorted"),
                    doc: $crate::traverse::PRESORTED_DOC,
                    ..TraversalInfo::new($name, $paper, $doc) $($info)*
                },
                // Traced without hints it sorts, as `-sorted`.
                trace: tb_core::kernel!(|m: &MultiKdTree, batch, out| {
                    match batch.hints {
                        Some(order) => trace_row(m, $name, batch, Some(order), out),
                        None => trace_sorted(m, $name, batch, out),
                    }
                }),
                gpu: $crate::traverse::gpu_of($name)[2],
                hints: Some($crate::traverse::arrangement),
            },)*
        ];
    };
}

/// Plain traversals (the kd-tree's), then their `-sorted` and `-presorted` forms.
#[cfg(test)]
pub(crate) const PLAIN: usize = KdTree::TRAVERSALS.len();

/// The table and dispatch of the kd list.
pub(crate) mod rows {
    use super::*;
    tb_kdtree::kd_walks!(multikd_walks);
}

#[cfg(test)]
pub(crate) use multikd_walks;
