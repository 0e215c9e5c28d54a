//! R-trees for ray tracing (Feldmann 2015, "Accelerated Ray Tracing using R-Trees").
//!
//! - **Build** ([`Rtree::build`], module `build`): successive insertion of the triangles'
//!   boxes into a dynamic tree (paper section 2.2.1): ChooseSubtree by a [`Strategy`] of the
//!   paper's section 5.1 (Guttman 1984; Beckmann et al. 1990), overflow treatment by forced
//!   reinsertion once per level per insertion and the R*-tree split. The tree is
//!   height-balanced: all leaves lie at level `l = 0`, the root at level `L`; every node but
//!   the root holds `m ≤ n ≤ M` entries.
//! - **Layout** (paper section 4, Figure 4): the tree is packed into one array in level order
//!   *including empty nodes*, a complete `M`-ary tree of `N = (M^(L+1) − 1)/(M − 1)` slots
//!   whose node `i` has its entries at `M·i + 1 … M·i + M` (the paper's
//!   `n_e(n) = (n − Δ_L(l))·M + Δ_L(l−1)`), its parent at `⌊(i − 1)/M⌋` (`n_p`) and its
//!   position in the parent `χ(i) = (i − 1) mod M`. Non-empty entries come first within a
//!   node, in [`ChildOrder`]; empty slots hold the empty box and `count = 0`. Leaves (level 0)
//!   hold their triangles as a run of [`Rtree::triangles`] (copied in leaf order;
//!   [`Rtree::prim_ids`] maps back to scene indices).
//! - **Traversals** (module `traverse`, [`Structure::TRAVERSALS`]): `stackless` (Listing 1), `ordered`
//!   (Listing 2) and `stack` (the conventional stack-based scheme of Table 3), and our variants
//!   `stackless-skip-empty` (no visits to empty sibling slots) and `ordered-pop-cull` (popped
//!   entries beyond the closest hit dropped as well).
//! - **GPU** (module `gpu`, `shaders/`): the same five walks as WGSL kernels over the same
//!   packed array (the paper's CUDA tracer ran `stackless` and `ordered`, Tables 1-3), with
//!   the per-ray counters of the CPU walks.

#![deny(missing_docs)]

mod build;
mod check;
mod gpu;
mod node;
mod params;
mod report;
mod traverse;

pub use node::RtreeNode;
pub use params::{ChildOrder, RtreeParams, Strategy};

pub use gpu::GPU_NODES;

use std::time::Instant;
use tb_core::{
    build_with, dispatch, Aabb, AccelError, BuildReport, Family, MemoryReport, Structure,
    Traversal, TraversalInfo, Triangle,
};

/// The R-tree in the registry.
pub static FAMILY: Family = Family::new::<Rtree, RtreeParams>(
    "R-tree by insertion (min-volume, min-surface, min-overlap, R*, R*-srfc, and our tie and \
     overlap-enlargement variants) or STR bulk loading, \
     R* split, forced reinsertion, packed level-order layout (Feldmann)",
    |tris, set| build_with(set, |p: &RtreeParams| Rtree::try_build(tris, p)),
)
.with_summary(
    "R-tree by insertion (R* and others) or STR, packed level-order layout (Feldmann 2015)",
)
.with_rules::<RtreeParams>()
.with_persist::<Rtree>()
.with_method(1, tb_core::FIRST_METHOD);

impl tb_core::Persist for Rtree {
    fn attach(
        &mut self,
        _tris: &std::sync::Arc<[Triangle]>,
        params: &tb_core::ParamSet,
    ) -> Result<(), tb_core::ParamError> {
        self.params = tb_core::persist::params_from(params)?;
        Ok(())
    }
}

/// Largest `M` supported (node capacity of the builder, size of the per-level stacks).
pub const MAX_M: usize = 16;

/// Most levels a packed tree can have (`L + 1`): with `M ≥ 4` a complete tree of more than
/// 16 levels needs more than `2^32` slots, which [`Rtree::build`] refuses.
pub const MAX_LEVELS: usize = 17;

/// Largest packed layout [`Rtree::try_build`] allocates: 8 GiB of 32-byte slots. The
/// complete `M`-ary layout holds `(M^(L+1) − 1)/(M − 1)` slots however few are used (with
/// `M = 4`, Conference's 331K triangles already take 695 MiB, 99 % empty).
pub const MAX_LAYOUT_BYTES: u64 = 8 << 30;

/// Most layout bytes per triangle [`Rtree::try_build`] allocates (512 slots of 32 bytes),
/// beyond a floor of [`MIN_LAYOUT_LIMIT`] and within [`MAX_LAYOUT_BYTES`]: the limit is
/// `min(8 GiB, max(64 MiB, 16 KiB · triangles))` ([`layout_limit`]). The complete layout of
/// section 4 grows as `M^L` while the triangles grow as `f^L` (`f`: mean entries per node, `m ≤
/// f ≤ M`), so its bytes per triangle are bounded by no constant: a tree of poorly filled
/// nodes, or one level more at a level boundary, multiplies them. The paper's configurations
/// need at most 14.9 KB (Conference, `m = 2`, `M = 8`: 4.9 GB; `M = 4`: 2.2 KB), 1M identical
/// triangles 2.9 KB (`f = 2.7`, 14 levels).
pub const MAX_LAYOUT_BYTES_PER_TRIANGLE: u64 = 16 << 10;

/// The floor of the layout limit (small scenes, whose complete layout is small anyway).
pub const MIN_LAYOUT_LIMIT: u64 = 64 << 20;

/// The layout limit [`Rtree::try_build`] applies to `n` triangles:
/// `min(MAX_LAYOUT_BYTES, max(MIN_LAYOUT_LIMIT, MAX_LAYOUT_BYTES_PER_TRIANGLE · n))`.
pub fn layout_limit(n: usize) -> u64 {
    MAX_LAYOUT_BYTES_PER_TRIANGLE
        .saturating_mul(n as u64)
        .clamp(MIN_LAYOUT_LIMIT, MAX_LAYOUT_BYTES)
}

/// An R-tree over triangles in the paper's implicit level-order layout.
///
/// Per-ray counters (`TraversalStats`):
/// - `boxes`: ray–box slab tests; `interior`: intermediate nodes whose entries were examined
///   (entered); `leaves`: leaves whose triangles were tested; `prims`: ray–triangle tests;
/// - `steps`: nodes the walk visits. `stackless` and `stackless-skip-empty`: every slot the
///   walk reaches (an iteration of Listing 1's loop), empty slots included, so `steps ==
///   boxes + empty slots visited` (`stackless-skip-empty` visits none); `ordered`,
///   `ordered-pop-cull`, `stack`: the root when its box is hit and every entry taken from a
///   stack and entered (`ordered` enters every popped entry, as Listing 2; the other two skip
///   those beyond the closest hit), so `steps == interior + leaves`;
/// - `restarts`: the stackless walks only, climbs to a parent (`n_p`) when no next sibling
///   remains;
/// - `planes`: always 0.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct Rtree {
    #[serde(with = "tb_core::persist::sparse_pod")]
    nodes: Vec<RtreeNode>,
    triangles: Vec<Triangle>,
    prim_ids: Vec<u32>,
    /// `L`: the root's level; leaves are at level 0.
    root_level: u32,
    /// `Δ_L(0)`: first leaf slot.
    first_leaf: u32,
    /// Not saved by the build cache (its key): given back by [`tb_core::Persist::attach`].
    #[serde(skip)]
    params: RtreeParams,
    splits: u64,
    reinserts: u64,
    /// Entries ejected by the forced reinsertions (`p` each).
    ejected: u64,
    /// Wall time of the pointer build, ms: successive insertion (STR: the bulk load), the
    /// part Feldmann section 5 calls construction ("constructed on the CPU using pointers").
    insert_ms: f64,
    /// Wall time of packing the pointer tree into the level-order array of section 4 ("packed
    /// ... into a linear memory layout in a subsequent step", section 5), ms: the slots, the
    /// index map and the triangles in leaf order.
    pack_ms: f64,
}

impl Rtree {
    /// Build an R-tree over `tris` by successive insertion (single-threaded). Panics where
    /// [`Rtree::try_build`] returns an error.
    ///
    /// An empty input gives an empty tree (no slots) that misses every ray.
    pub fn build(tris: &[Triangle], params: &RtreeParams) -> Rtree {
        Self::try_build(tris, params).unwrap_or_else(|e| panic!("{e}"))
    }

    /// Build an R-tree over `tris` by successive insertion (single-threaded), or say why not:
    /// `params.check()` fails, there are `u32::MAX` or more triangles, or the complete
    /// level-order layout of section 4 (which grows as `M^(L+1)`, empty slots included) would
    /// need `2^32 − 1` or more slots or more than [`layout_limit`] bytes (16 KiB a triangle,
    /// at least 64 MiB, at most 8 GiB). The insertion build refuses as soon as the tree
    /// grows a level whose layout is over the limit (levels only grow), not after inserting
    /// every triangle.
    pub fn try_build(tris: &[Triangle], params: &RtreeParams) -> Result<Rtree, AccelError> {
        Self::build_within(tris, params, layout_limit(tris.len()))
    }

    /// [`Rtree::try_build`] with a layout limit of `max_bytes`.
    fn build_within(
        tris: &[Triangle],
        params: &RtreeParams,
        max_bytes: u64,
    ) -> Result<Rtree, AccelError> {
        params.check()?;
        if tris.len() >= u32::MAX as usize {
            return Err(AccelError::TooLarge {
                what: "R-tree triangles",
                count: tris.len() as u64,
                limit: u32::MAX as u64 - 1,
            });
        }
        let fits = |levels: u32| {
            build::slot_count(params.big_m, levels - 1)
                .is_some_and(|n| n as u64 * std::mem::size_of::<RtreeNode>() as u64 <= max_bytes)
        };
        let refuse = |levels: u32, inserted: Option<usize>| {
            let gib = (params.big_m as f64).powi(levels as i32) / (params.big_m as f64 - 1.0)
                * std::mem::size_of::<RtreeNode>() as f64
                / (1u64 << 30) as f64;
            let when = match inserted {
                Some(k) => format!(" (refused after inserting {k} of {} triangles)", tris.len()),
                None => String::new(),
            };
            AccelError::Unsupported(format!(
                "the complete {}-ary level-order layout of {levels} levels needs {gib:.3} GiB \
                 of slots (empty ones included), over the {:.3} GiB limit for {} triangles \
                 (16 KiB a triangle, at least 64 MiB, at most 8 GiB){when}; use a smaller M or \
                 strategy = \"str\"",
                params.big_m,
                max_bytes as f64 / (1u64 << 30) as f64,
                tris.len()
            ))
        };
        let t_insert = Instant::now();
        let b = match params.strategy {
            Strategy::Str => build::bulk_load_str(tris, params),
            _ => build::insert_all(tris, params, &fits)
                .map_err(|(levels, inserted)| refuse(levels, Some(inserted)))?,
        };
        let insert_ms = t_insert.elapsed().as_secs_f64() * 1e3;
        let levels = b.height();
        if !fits(levels) {
            return Err(refuse(levels, None));
        }
        let counts = b.counts;
        let t_pack = Instant::now();
        let packed = build::pack(&b, tris, params.child_order, params.big_m);
        drop(b);
        assert!((packed.root_level as usize) < MAX_LEVELS);
        let triangles = packed.prim_ids.iter().map(|&i| tris[i as usize]).collect();
        let pack_ms = t_pack.elapsed().as_secs_f64() * 1e3;
        Ok(Rtree {
            first_leaf: build::first_leaf(params.big_m, packed.root_level),
            nodes: packed.nodes,
            triangles,
            prim_ids: packed.prim_ids,
            root_level: packed.root_level,
            params: *params,
            splits: counts.splits,
            reinserts: counts.reinserts,
            ejected: counts.ejected,
            insert_ms,
            pack_ms,
        })
    }

    /// The level-order slots, root first, empty slots included.
    #[inline(always)]
    pub fn nodes(&self) -> &[RtreeNode] {
        &self.nodes
    }

    /// The triangles in leaf order.
    pub fn triangles(&self) -> &[Triangle] {
        &self.triangles
    }

    /// `prim_ids()[i]` is the scene index of `triangles()[i]`.
    pub fn prim_ids(&self) -> &[u32] {
        &self.prim_ids
    }

    /// `L`, the level of the root (the tree has `L + 1` levels).
    pub fn root_level(&self) -> u32 {
        self.root_level
    }

    /// `Δ_L(0)`, the slot of the first leaf.
    pub fn first_leaf(&self) -> u32 {
        self.first_leaf
    }

    /// The parameters the tree was built with.
    pub fn params(&self) -> &RtreeParams {
        &self.params
    }

    /// `M` as `usize`.
    #[inline(always)]
    pub(crate) fn big_m(&self) -> usize {
        self.params.big_m as usize
    }
}

impl Structure for Rtree {
    const NAME: &'static str = "rtree";
    const TRAVERSALS: &'static [Traversal<Self>] = &[
        Traversal::with_gpu(
            TraversalInfo::new(
                "stackless",
                "Feldmann 2015 §4.1, Listing 1",
                "stackless depth-first by implicit index arithmetic, next sibling or parent, \
                 visiting empty sibling slots as Listing 1 does (Feldmann 2015 §4.1, Listing 1)",
            ),
            tb_core::kernel!(|t: &Rtree, batch, out| {
                dispatch(&traverse::Stackless::<false>(t), batch, out)
            }),
            Rtree::gpu_stackless,
        ),
        Traversal::with_gpu(
            TraversalInfo::new(
                "ordered",
                "Feldmann 2015 §4.2, Listing 2",
                "per-level stacks of at most M entries sorted by entry distance with insertion \
                 sort, nearest first, culled against the closest hit when pushed only \
                 (Feldmann 2015 §4.2, Listing 2)",
            ),
            tb_core::kernel!(|t: &Rtree, batch, out| {
                dispatch(&traverse::Ordered::<false>(t), batch, out)
            }),
            Rtree::gpu_ordered,
        ),
        Traversal::with_gpu(
            TraversalInfo::new(
                "stack",
                "Feldmann 2015 §5.2, Table 3",
                "conventional depth-first with one stack, skipping boxes entered beyond the \
                 closest hit (Feldmann 2015 §5.2, Table 3)",
            ),
            tb_core::kernel!(|t: &Rtree, batch, out| { dispatch(&traverse::Stack(t), batch, out) }),
            Rtree::gpu_stack,
        ),
        Traversal::with_gpu(
            TraversalInfo::new(
                "stackless-skip-empty",
                "ours, after Feldmann 2015 §4.1, Listing 1",
                "stackless (Listing 1) that ends a node's entries at its first empty slot \
                 instead of visiting the empty slots (ours: the same result, fewer slots)",
            ),
            tb_core::kernel!(|t: &Rtree, batch, out| {
                dispatch(&traverse::Stackless::<true>(t), batch, out)
            }),
            Rtree::gpu_stackless_skip_empty,
        ),
        Traversal::with_gpu(
            TraversalInfo::new(
                "ordered-pop-cull",
                "ours, after Feldmann 2015 §4.2, Listing 2",
                "ordered (Listing 2) that also drops a popped entry beyond the closest hit, \
                 and the rest of its stack (ours: the same result, fewer nodes)",
            ),
            tb_core::kernel!(|t: &Rtree, batch, out| {
                dispatch(&traverse::Ordered::<true>(t), batch, out)
            }),
            Rtree::gpu_ordered_pop_cull,
        ),
    ];

    /// Bytes of the slot array *including empty slots* (paper section 4), the triangles in
    /// leaf order and the index map; `nodes` counts every slot.
    ///
    /// `structure_bytes`, the tree alone: the slot array (empty slots included, as the
    /// paper's implicit layout allocates them) and the index map (4 bytes a leaf entry); not
    /// the triangles, a copy of the scene's in leaf order.
    fn own_memory(&self) -> MemoryReport {
        let structure = std::mem::size_of_val(self.nodes.as_slice())
            + std::mem::size_of_val(self.prim_ids.as_slice());
        MemoryReport {
            bytes: (structure + std::mem::size_of_val(self.triangles.as_slice())) as u64,
            structure_bytes: structure as u64,
            nodes: self.nodes.len() as u64,
            prim_refs: self.prim_ids.len() as u64,
            node_bytes: std::mem::size_of::<RtreeNode>() as u32,
        }
    }

    /// The build report: see `report.rs`.
    fn report(&self) -> BuildReport {
        self.report_figures()
    }

    /// Checks: the slot array is the complete `M`-ary layout of `L + 1` levels; every
    /// non-empty slot lies under a non-empty parent and after non-empty siblings (so every
    /// leaf is at level 0: height balance); every node but the root has `m..=M` entries (the
    /// root 2..=M, or 1..=M when it is a leaf); every box is exactly the minimal box of its
    /// entries; every triangle is in exactly one leaf and `prim_ids` is a permutation.
    fn check(&self) -> Result<(), AccelError> {
        self.check_invariants().map_err(AccelError::Invalid)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tb_core::{Accel, HitRecord, Query, Ray, TraversalStats, TriTestKind, Vec3};

    const TRAVERSALS: &[Traversal<Rtree>] = Rtree::TRAVERSALS;

    fn grid(n: usize) -> Vec<Triangle> {
        (0..n)
            .map(|i| {
                let p = Vec3::new((i % 8) as f32, ((i / 8) % 8) as f32, (i / 64) as f32);
                Triangle::new(p, p + Vec3::X * 0.9, p + Vec3::Y * 0.9)
            })
            .collect()
    }

    #[test]
    fn builds_valid_trees_for_every_strategy_and_size() {
        for &s in Strategy::ALL {
            for reinsert in [false, true] {
                for (m, big_m) in [(2, 4), (2, 5), (3, 8), (8, 16)] {
                    for n in [0, 1, 3, 4, 5, 17, 64, 300] {
                        let p = RtreeParams {
                            m,
                            big_m,
                            strategy: s,
                            reinsert,
                            ..Default::default()
                        };
                        let t = Rtree::build(&grid(n), &p);
                        t.validate()
                            .unwrap_or_else(|e| panic!("{p:?}, {n} triangles: {e}"));
                        assert_eq!(t.prim_ids().len(), n);
                    }
                }
            }
        }
    }

    #[test]
    fn refuses_a_layout_over_the_limit_and_says_why() {
        let p = RtreeParams::default();
        let t = Rtree::build_within(&grid(300), &p, u64::MAX).unwrap();
        let need = t.nodes().len() as u64 * 32;
        assert!(Rtree::build_within(&grid(300), &p, need).is_ok());
        let e = Rtree::build_within(&grid(300), &p, need - 1)
            .unwrap_err()
            .to_string();
        assert!(e.contains("4-ary level-order layout"), "{e}");
        let e = Rtree::try_build(&grid(3), &RtreeParams { m: 3, ..p })
            .unwrap_err()
            .to_string();
        assert!(e.contains("m must be in 2..=M/2"), "{e}");
    }

    /// Identical triangles build a tree of poorly filled nodes (every key
    /// ties, every split takes the first distribution), whose complete layout grows a level
    /// early. Under a lowered limit the insertion build refuses as soon as the tree grows a
    /// level over it, long before the last triangle, and says why; the default limit is
    /// 16 KiB a triangle between 64 MiB and 8 GiB.
    #[test]
    fn identical_triangles_are_refused_early_over_the_limit() {
        let n = 5000;
        let same = vec![Triangle::new(Vec3::ZERO, Vec3::X, Vec3::Y); n];
        let p = RtreeParams::default();
        let t = Rtree::try_build(&same, &p).unwrap();
        t.validate().unwrap();
        let levels = t.root_level() + 1;
        assert!(levels >= 8, "{levels} levels");
        // A limit that admits two levels fewer than the tree reaches.
        let limit = build::slot_count(4, levels - 3).unwrap() as u64 * 32;
        let e = Rtree::build_within(&same, &p, limit)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains(&format!("layout of {} levels", levels - 1)),
            "{e}"
        );
        let k: usize = e
            .split("refused after inserting ")
            .nth(1)
            .and_then(|r| r.split(' ').next())
            .and_then(|k| k.parse().ok())
            .unwrap_or_else(|| panic!("{e}"));
        assert!(k < n / 2, "refused after {k} of {n}: {e}");
        // STR has no insertion to stop; it is refused on its height.
        let str_p = RtreeParams {
            strategy: Strategy::Str,
            ..p
        };
        let e = Rtree::build_within(&same, &str_p, 32)
            .unwrap_err()
            .to_string();
        assert!(e.contains("level-order layout"), "{e}");
        assert_eq!(layout_limit(0), MIN_LAYOUT_LIMIT);
        assert_eq!(layout_limit(10_000), 10_000 * 16 * 1024);
        assert_eq!(layout_limit(1_000_000), MAX_LAYOUT_BYTES);
        assert_eq!(layout_limit(usize::MAX), MAX_LAYOUT_BYTES);
    }

    /// `reinserted_entries` is `p` per forced reinsertion, `p` from the share (1, 2, 3 of
    /// the 5 entries at M = 4), and every share still builds a valid tree.
    #[test]
    fn reinsert_share_sets_the_entries_ejected() {
        let get = |t: &Rtree, k: &str| {
            let r = t.build_report();
            r.extra.iter().find(|e| e.0 == k).unwrap().1
        };
        let mut trees = Vec::new();
        for (share, p) in [(0.3, 1.0), (0.5, 2.0), (0.75, 3.0)] {
            let t = Rtree::build(
                &grid(500),
                &RtreeParams {
                    reinsert_share: share,
                    ..Default::default()
                },
            );
            assert_eq!(t.validate(), Ok(()));
            let n = get(&t, "reinserts");
            assert!(n > 0.0, "share {share}");
            assert_eq!(get(&t, "reinserted_entries"), p * n, "share {share}");
            trees.push(t.nodes().to_vec());
        }
        assert!(trees[0] != trees[1] && trees[1] != trees[2]);
    }

    /// `insert_ms` and `pack_ms` are the two parts of one build: both measured, their sum
    /// within the build's wall time seen from outside.
    #[test]
    fn build_time_parts() {
        let tris = grid(3000);
        for strategy in [Strategy::RStarSrfc, Strategy::Str] {
            let p = RtreeParams {
                strategy,
                ..Default::default()
            };
            let t0 = Instant::now();
            let t = Rtree::build(&tris, &p);
            let whole = t0.elapsed().as_secs_f64() * 1e3;
            let r = t.build_report();
            let get = |k: &str| r.extra.iter().find(|e| e.0 == k).unwrap().1;
            let (insert, pack) = (get("insert_ms"), get("pack_ms"));
            assert!(insert > 0.0 && pack > 0.0, "{strategy:?}: {insert} {pack}");
            assert!(
                insert + pack <= whole,
                "{strategy:?}: {insert} + {pack} > {whole}"
            );
        }
    }

    #[test]
    fn forced_reinsertion_switches() {
        let get = |t: &Rtree, k: &str| {
            let r = t.build_report();
            r.extra.iter().find(|e| e.0 == k).unwrap().1
        };
        let on = Rtree::build(&grid(500), &RtreeParams::default());
        let off = Rtree::build(
            &grid(500),
            &RtreeParams {
                reinsert: false,
                ..Default::default()
            },
        );
        assert!(get(&on, "reinserts") > 0.0);
        assert_eq!(get(&off, "reinserts"), 0.0);
        assert!(get(&off, "splits") > 0.0);
        let bulk = Rtree::build(
            &grid(500),
            &RtreeParams {
                strategy: Strategy::Str,
                ..Default::default()
            },
        );
        assert_eq!(get(&bulk, "splits") + get(&bulk, "reinserts"), 0.0);
        // STR fills nodes: 500 triangles in ceil(500/4) = 125 leaves.
        assert_eq!(get(&bulk, "leaves"), 125.0);
        for t in [&on, &off, &bulk] {
            t.validate().unwrap();
        }
    }

    /// The paper's `Δ_L(l)`, `n_e`, `n_p` and `χ` (section 4) are the heap arithmetic the
    /// traversals use: entries of `i` at `M·i + 1 …`, parent `⌊(i − 1)/M⌋`.
    #[test]
    fn implicit_index_relations_match_the_paper() {
        for big_m in [4usize, 5, 16] {
            let top = 4usize; // L
            let delta = |l: usize| -> usize {
                if l == top {
                    0
                } else {
                    (0..top - l).map(|i| big_m.pow(i as u32)).sum()
                }
            };
            for l in 1..=top {
                for n in delta(l)..delta(l - 1) {
                    let ne = (n - delta(l)) * big_m + delta(l - 1);
                    assert_eq!(ne, big_m * n + 1);
                    for k in 0..big_m {
                        let c = ne + k;
                        let np = (c - delta(l - 1)) / big_m + delta(l);
                        assert_eq!(np, (c - 1) / big_m);
                        assert_eq!((c - delta(l - 1)) % big_m, (c - 1) % big_m);
                        assert_eq!((c - 1) % big_m, k);
                    }
                }
            }
            let p = RtreeParams {
                big_m: big_m as u32,
                ..Default::default()
            };
            assert_eq!(
                build::first_leaf(p.big_m, top as u32) as usize,
                delta(0),
                "Δ_L(0)"
            );
        }
    }

    /// Counter identities documented on [`Rtree`], and the five traversals agree.
    #[test]
    fn counters_are_consistent() {
        let tris = grid(400);
        let t = Rtree::build(&tris, &RtreeParams::default());
        let rays: Vec<Ray> = (0..256)
            .map(|i| {
                let f = i as f32;
                let o = Vec3::new(-2.0 + (f * 0.37) % 12.0, -2.0 + (f * 0.71) % 12.0, 10.0);
                let d = Vec3::new((f * 0.13).sin(), (f * 0.29).cos(), -3.0).normalize();
                Ray::new(o, d)
            })
            .collect();
        let mut answers = Vec::new();
        let mut stats = Vec::new();
        for ti in 0..TRAVERSALS.len() {
            for q in [Query::Closest, Query::Any] {
                let mut hits = vec![HitRecord::MISS; rays.len()];
                let mut st = vec![TraversalStats::default(); rays.len()];
                t.trace(
                    ti,
                    tb_core::Batch::new(q, TriTestKind::Watertight, &rays),
                    tb_core::Answers::new(&mut hits, Some(&mut st)),
                );
                for s in &st {
                    let name = TRAVERSALS[ti].info.name;
                    assert_eq!(s.planes, 0);
                    if name.starts_with("stackless") {
                        // A box per non-empty slot visited; `skip-empty` visits no empty one.
                        assert!(s.steps >= s.boxes, "{name}");
                        if name == "stackless-skip-empty" {
                            assert_eq!(s.steps, s.boxes, "{name}");
                        }
                        assert!(s.boxes >= s.interior + s.leaves, "{name}");
                    } else {
                        assert_eq!(s.steps, s.interior + s.leaves, "{name}");
                        assert_eq!(s.restarts, 0);
                    }
                }
                if q == Query::Closest {
                    answers.push(hits.iter().map(|h| h.t).collect::<Vec<_>>());
                    stats.push(st);
                }
            }
        }
        assert!(answers[0].iter().any(|t| t.is_finite()));
        for a in &answers[1..] {
            assert_eq!(&answers[0], a);
        }
        let by_name = |n: &str| &stats[TRAVERSALS.iter().position(|t| t.info.name == n).unwrap()];
        // The variants walk the same nodes but for what they leave out.
        for (a, b) in by_name("stackless")
            .iter()
            .zip(by_name("stackless-skip-empty"))
        {
            assert!(a.steps >= b.steps);
            let same = |s: &TraversalStats| (s.boxes, s.interior, s.leaves, s.prims, s.restarts);
            assert_eq!(same(a), same(b));
        }
        for (a, b) in by_name("ordered").iter().zip(by_name("ordered-pop-cull")) {
            assert!(a.steps >= b.steps && a.prims >= b.prims && a.boxes >= b.boxes);
        }
    }

    /// Two clusters of 4 triangles stacked along the ray (`z ∈ [−0.3, 0]` and `[−10.3, −10]`):
    /// a root at level 1 whose entries are leaves, with `M − count` empty slots after them.
    fn two_clusters() -> (Rtree, Ray) {
        let tris: Vec<Triangle> = [0.0f32, -0.1, -0.2, -0.3, -10.0, -10.1, -10.2, -10.3]
            .iter()
            .map(|&z| {
                let p = Vec3::new(0.0, 0.0, z);
                Triangle::new(p, p + Vec3::X, p + Vec3::Y)
            })
            .collect();
        let t = Rtree::build(&tris, &RtreeParams::default());
        assert_eq!(t.root_level(), 1);
        (t, Ray::new(Vec3::new(0.2, 0.2, 5.0), -Vec3::Z))
    }

    fn trace_one(t: &Rtree, name: &str, ray: Ray) -> (HitRecord, TraversalStats) {
        let ti = TRAVERSALS.iter().position(|x| x.info.name == name).unwrap();
        let mut hits = [HitRecord::MISS];
        let mut st = [TraversalStats::default()];
        t.trace(
            ti,
            tb_core::Batch::new(Query::Closest, TriTestKind::Watertight, &[ray]),
            tb_core::Answers::new(&mut hits, Some(&mut st)),
        );
        (hits[0], st[0])
    }

    /// Listing 2 culls against `t_min` only when pushing: `ordered` enters the far leaf
    /// popped after the near leaf's hit (t = 5) although its entry distance (15) lies beyond;
    /// `ordered-pop-cull` drops it.
    #[test]
    fn ordered_culls_at_push_time_only() {
        let (t, ray) = two_clusters();
        let (h, paper) = trace_one(&t, "ordered", ray);
        let (h2, ours) = trace_one(&t, "ordered-pop-cull", ray);
        assert!((h.t - 5.0).abs() < 1e-5, "{h:?}");
        assert_eq!(h, h2);
        assert_eq!(ours.leaves, 1, "{ours:?}");
        assert_eq!(ours.prims, 4);
        assert!(paper.leaves >= 2, "{paper:?}");
        assert_eq!(paper.prims, 8);
        assert_eq!(paper.steps, ours.steps + paper.leaves - 1);
        assert_eq!(paper.boxes, ours.boxes);
    }

    /// Listing 1 visits every slot of a node, the empty ones after its entries included
    /// (`isEmptyNode`, no box test): `stackless` visits the root and all `M` slots of its
    /// entries, `stackless-skip-empty` the root and its non-empty entries only.
    #[test]
    fn stackless_visits_empty_sibling_slots() {
        let (t, ray) = two_clusters();
        let m = t.params().big_m;
        let count = t.nodes()[0].count;
        assert!(count < m, "the root has empty slots");
        let (h, paper) = trace_one(&t, "stackless", ray);
        let (h2, ours) = trace_one(&t, "stackless-skip-empty", ray);
        assert!((h.t - 5.0).abs() < 1e-5, "{h:?}");
        assert_eq!(h, h2);
        assert_eq!(paper.steps, 1 + m, "{paper:?}");
        assert_eq!(ours.steps, 1 + count, "{ours:?}");
        assert_eq!(paper.boxes, 1 + count);
        assert_eq!(ours.boxes, 1 + count);
        assert_eq!(paper.restarts, ours.restarts);
    }

    #[test]
    fn names_round_trip() {
        for &s in Strategy::ALL {
            assert_eq!(Strategy::from_name(s.name()), Some(s));
        }
        for &o in ChildOrder::ALL {
            assert_eq!(ChildOrder::from_name(o.name()), Some(o));
        }
    }

    #[test]
    fn params_check() {
        assert!(RtreeParams::default().check().is_ok());
        for (m, big_m) in [(1, 4), (3, 4), (2, 3), (2, 17), (9, 16)] {
            let p = RtreeParams {
                m,
                big_m,
                ..Default::default()
            };
            assert!(p.check().is_err(), "{m} {big_m}");
        }
        let p = RtreeParams {
            reinsert_share: 0.0,
            ..Default::default()
        };
        assert!(p.check().is_err());
        for (share, ok) in [(0.75, true), (0.76, false)] {
            let p = RtreeParams {
                reinsert_share: share,
                ..Default::default()
            };
            assert_eq!(p.check().is_ok(), ok, "{share}");
        }
        assert_eq!(RtreeParams::default().reinsert_count(), 1);
        let p = RtreeParams {
            big_m: 16,
            m: 8,
            ..Default::default()
        };
        assert_eq!(p.reinsert_count(), 5);
    }

    #[test]
    fn layout_is_complete_with_empty_slots() {
        let t = Rtree::build(&grid(300), &RtreeParams::default());
        let m = 4u64;
        let l = t.root_level();
        assert_eq!(t.nodes().len() as u64, (m.pow(l + 1) - 1) / (m - 1));
        let r = t.build_report();
        let get = |k: &str| r.extra.iter().find(|e| e.0 == k).unwrap().1;
        assert!(get("empty_share") > 0.0 && get("empty_share") < 1.0);
        assert_eq!(t.memory().nodes, t.nodes().len() as u64);
    }

    /// `structure_bytes` is the slots (empty ones included) and 4 bytes an index; `bytes`
    /// adds exactly the triangles in leaf order (one per scene triangle).
    #[test]
    fn structure_bytes_are_the_tree_alone() {
        let tris = grid(300);
        let t = Rtree::build(&tris, &RtreeParams::default());
        let m = t.memory();
        let slots = t.nodes().len() as u64 * m.node_bytes as u64;
        assert_eq!(m.structure_bytes, slots + 4 * tris.len() as u64);
        assert_eq!(
            m.bytes - m.structure_bytes,
            std::mem::size_of_val(tris.as_slice()) as u64
        );
        for i in 0..Rtree::TRAVERSALS.len() {
            assert_eq!(t.memory_for(i), m);
        }
    }

    #[test]
    fn validate_finds_corruption() {
        let good = Rtree::build(&grid(300), &RtreeParams::default());
        assert_eq!(good.validate(), Ok(()));
        let err = |b: &Rtree| b.validate().unwrap_err().to_string();
        let mut b = good.clone();
        b.nodes[1].max[0] += 1.0;
        assert!(err(&b).contains("minimal"));
        let mut b = good.clone();
        b.prim_ids[1] = b.prim_ids[0];
        assert!(err(&b).contains("twice"));
        let mut b = good.clone();
        let leaf = b.first_leaf as usize;
        let leaf = leaf + b.nodes[leaf..].iter().position(|n| !n.is_empty()).unwrap();
        b.nodes[leaf].count = 0;
        assert!(b.validate().is_err());
        let mut b = good.clone();
        b.nodes.push(RtreeNode::EMPTY);
        assert!(b.validate().is_err());
    }
}
