//! The acceleration-structure interface.
//!
//! Dynamic dispatch happens once per ray batch ([`Accel::trace`]); inside, a structure picks a
//! monomorphised [`Kernel`] variant with [`dispatch`] (one per traversal x query x triangle test
//! x counter), so no virtual call or branch on configuration happens per node
//! (STYLE.md, "dynamic dispatch only at the batch edge").
//!
//! How the interface fits the structures of the five papers:
//! - one build serves several traversals: [`Accel::traversals`] lists them and
//!   [`Accel::trace`] takes the index (kd-tree review: sequential, restart, push-down, …;
//!   R-trees: stackless, ordered, stack);
//! - a kernel sees one ray at a time and may keep any per-ray state (entry/exit intervals,
//!   restarts, short stacks, the tree chosen by direction for multi-kd-trees, a start node for
//!   sparse boxes, the cell walk of irregular grids);
//! - threading is the caller's: the runner splits a batch across threads and calls `trace` on
//!   each chunk, so structures contain no threading code.

use crate::geom::{HitRecord, Ray};
use crate::stats::{Counter, NoStats, TraversalStats};
use crate::tri::{MollerTrumbore, TriTest, TriTestKind, Watertight};
use serde::{Deserialize, Serialize};

/// Which query a batch asks.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Query {
    /// Closest hit in `[tmin, tmax)` (primary, ao-free bounces, random rays).
    Closest,
    /// Any hit in `[tmin, tmax)`, stopping at the first found (shadow and AO rays).
    Any,
}

/// A traversal algorithm a structure offers, as listed by `trace-bench list`.
#[derive(Clone, Copy, Debug)]
pub struct TraversalInfo {
    /// Config name, kebab-case (e.g. `ordered`, `short-stack`).
    pub name: &'static str,
    /// One line: the algorithm and its paper/section.
    pub doc: &'static str,
}

/// Memory used by a built structure, including every auxiliary array a traversal needs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MemoryReport {
    /// Total bytes of all arrays the traversals read (nodes, references, triangles).
    pub bytes: u64,
    /// Number of nodes (interior and leaves, including empty slots of implicit layouts).
    pub nodes: u64,
    /// Number of primitive references stored in leaves.
    pub prim_refs: u64,
    /// Size of one node in bytes.
    pub node_bytes: u32,
}

/// Structure-specific build figures, reported in the `build_stats` column and in JSON.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct BuildReport {
    /// Surface-area-heuristic cost of the built tree, with the structure's own constants.
    pub sah_cost: Option<f64>,
    /// Further named figures (leaves, depth, empty leaves, …).
    pub extra: Vec<(String, f64)>,
}

/// A built acceleration structure, object-safe. Implemented with [`dispatch`].
pub trait Accel: Send + Sync {
    /// Registry name of the structure (e.g. `bvh`).
    fn name(&self) -> &'static str;

    /// The traversal algorithms this build supports; the index into this slice selects one.
    fn traversals(&self) -> &'static [TraversalInfo];

    /// Memory of the built structure: every array any of its traversals reads.
    fn memory(&self) -> MemoryReport;

    /// Memory that traversal number `traversal` reads: [`Accel::memory`] less the auxiliary
    /// arrays only other traversals need (the kd-tree review's Table 3 "additional memory"
    /// shows up as the difference between traversals). Default: all of it.
    fn memory_for(&self, traversal: usize) -> MemoryReport {
        let _ = traversal;
        self.memory()
    }

    /// Build figures (SAH cost and others).
    fn build_report(&self) -> BuildReport {
        BuildReport::default()
    }

    /// Whether the counters of [`Accel::trace`] are meaningful. External libraries (peers
    /// such as Embree) expose none: their rows leave the counter columns empty, not zero.
    fn has_counters(&self) -> bool {
        true
    }

    /// Whether `traversal` ends rays after a per-ray step cap (and counts them with
    /// [`crate::Counter::capped`]); its rows then report `capped_rays`.
    fn has_step_cap(&self, _traversal: usize) -> bool {
        false
    }

    /// The triangle test the structure always uses, when it ignores the requested one
    /// (Embree's own intersector); `None` for structures that honour [`TriTestKind`].
    fn own_triangle_test(&self) -> Option<&'static str> {
        None
    }

    /// Check the structure's invariants; `Err` names the first violation.
    fn validate(&self) -> Result<(), String> {
        Ok(())
    }

    /// The concrete structure, for devices that trace it with their own kernels (the GPU
    /// crate uploads a `tb_bvh::Bvh`'s arrays); `None` where no other device supports it.
    fn as_any(&self) -> Option<&dyn std::any::Any> {
        None
    }

    /// Trace `rays` with traversal number `traversal`, writing one record per ray to `hits`
    /// and, when `stats` is given, one counter record per ray. Single-threaded.
    fn trace(
        &self,
        traversal: usize,
        query: Query,
        tri: TriTestKind,
        rays: &[Ray],
        hits: &mut [HitRecord],
        stats: Option<&mut [TraversalStats]>,
    );
}

/// One traversal algorithm for one ray, generic over the triangle test and the counter.
pub trait Kernel: Sync {
    /// Closest hit in `[ray.tmin, ray.tmax)`, or [`HitRecord::MISS`].
    fn closest<T: TriTest, C: Counter>(&self, ray: &Ray, c: &mut C) -> HitRecord;
    /// Any hit in `[ray.tmin, ray.tmax)`, or [`HitRecord::MISS`].
    fn any<T: TriTest, C: Counter>(&self, ray: &Ray, c: &mut C) -> HitRecord;
}

/// A `validate()` check shared by structures that store triangles in leaf order with a map
/// back to scene indices: `prim_ids` must be a permutation of `0..n_tris`.
pub fn check_permutation(prim_ids: &[u32], n_tris: usize) -> Result<(), String> {
    if prim_ids.len() != n_tris {
        return Err(format!(
            "{} prim_ids for {n_tris} triangles",
            prim_ids.len()
        ));
    }
    let mut seen = vec![false; n_tris];
    for (i, &id) in prim_ids.iter().enumerate() {
        let id = id as usize;
        if id >= n_tris {
            return Err(format!("prim_ids[{i}] = {id} out of range"));
        }
        if std::mem::replace(&mut seen[id], true) {
            return Err(format!("triangle {id} appears twice in prim_ids"));
        }
    }
    Ok(())
}

/// Implement [`Kernel`] for traversal types whose one method `$walk::<T, C, ANY>(ray, c)`
/// serves both queries (`ANY = false`: closest hit, `true`: any hit). Each type is written
/// `[generics] Type`, e.g. `kernel_by_query!(walk: [] Havran<'_>, [const M: u8] Walk<'_, M>)`.
#[macro_export]
macro_rules! kernel_by_query {
    ($walk:ident: $([$($gen:tt)*] $ty:ty),+ $(,)?) => {$(
        impl<$($gen)*> $crate::Kernel for $ty {
            #[inline]
            fn closest<T: $crate::TriTest, C: $crate::Counter>(
                &self,
                ray: &$crate::Ray,
                c: &mut C,
            ) -> $crate::HitRecord {
                self.$walk::<T, C, false>(ray, c)
            }

            #[inline]
            fn any<T: $crate::TriTest, C: $crate::Counter>(
                &self,
                ray: &$crate::Ray,
                c: &mut C,
            ) -> $crate::HitRecord {
                self.$walk::<T, C, true>(ray, c)
            }
        }
    )+};
}

#[inline(always)]
fn run<K: Kernel, T: TriTest, C: Counter>(k: &K, query: Query, ray: &Ray, c: &mut C) -> HitRecord {
    match query {
        Query::Closest => k.closest::<T, C>(ray, c),
        Query::Any => k.any::<T, C>(ray, c),
    }
}

fn batch<K: Kernel, T: TriTest>(
    k: &K,
    query: Query,
    rays: &[Ray],
    hits: &mut [HitRecord],
    stats: Option<&mut [TraversalStats]>,
) {
    assert_eq!(rays.len(), hits.len(), "one hit record per ray");
    match stats {
        None => {
            for (r, h) in rays.iter().zip(hits.iter_mut()) {
                *h = run::<K, T, NoStats>(k, query, r, &mut NoStats);
            }
        }
        Some(stats) => {
            assert_eq!(rays.len(), stats.len(), "one stats record per ray");
            for ((r, h), s) in rays.iter().zip(hits.iter_mut()).zip(stats.iter_mut()) {
                let mut local = TraversalStats::default();
                *h = run::<K, T, TraversalStats>(k, query, r, &mut local);
                *s = local;
            }
        }
    }
}

/// Run kernel `k` over a batch, choosing the monomorphised variant for the triangle test and
/// for counting (`stats` given) or timing (`None`, counters compiled out).
pub fn dispatch<K: Kernel>(
    k: &K,
    query: Query,
    tri: TriTestKind,
    rays: &[Ray],
    hits: &mut [HitRecord],
    stats: Option<&mut [TraversalStats]>,
) {
    match tri {
        TriTestKind::Watertight => batch::<K, Watertight>(k, query, rays, hits, stats),
        TriTestKind::MollerTrumbore => batch::<K, MollerTrumbore>(k, query, rays, hits, stats),
    }
}
