//! Established ray-tracing libraries as peers on the same rays, behind the [`tb_core::Accel`]
//! interface, each behind a cargo feature so the default build needs nothing extra:
//!
//! - `embree`: Intel Embree 3 (single-ray `rtcIntersect1` / `rtcOccluded1`, the like-for-like
//!   peer of our single-ray traversals), build quality and scene flags as parameters;
//! - `obvhs`: the PLOC-built compressed wide BVH8 (CWBVH, Ylitie et al. 2017) and its CPU
//!   traversal;
//! - `bvh`: svenstaro's `bvh` crate, closest hit computed from its candidate iterator as its
//!   users do.
//!
//! Peers expose no traversal counters (their traversal reports [`CounterSet::NONE`]: their rows
//! leave the counter columns empty). obvhs and bvh call our triangle test on their candidates, so they honour the
//! experiment's `triangle_test`; Embree uses its own intersector.

#![deny(missing_docs)]

#[cfg(feature = "bvh")]
pub mod bvh_rs;
#[cfg(feature = "embree")]
pub mod embree;
#[cfg(feature = "obvhs")]
pub mod obvhs;

/// 64 small triangles on a lattice: the scene of the peers' memory tests.
#[cfg(all(test, any(feature = "bvh", feature = "embree", feature = "obvhs")))]
fn test_tris() -> Vec<tb_core::Triangle> {
    (0..64)
        .map(|i| {
            let p = tb_core::Vec3::new((i % 8) as f32, (i / 8) as f32, (i % 3) as f32);
            tb_core::Triangle::new(p, p + tb_core::Vec3::X * 0.9, p + tb_core::Vec3::Y * 0.9)
        })
        .collect()
}

use tb_core::{
    Answers, Batch, CounterSet, HitRecord, MollerTrumbore, Query, Ray, TraversalInfo,
    TraversalStats, TriTest, TriTestKind, Watertight,
};

/// A peer that answers one ray at a time with our triangle test on its candidates.
pub trait PerRay {
    /// The closest (or any) hit of `r` with triangle test `T`.
    fn trace_one<T: TriTest>(&self, query: Query, r: &Ray) -> HitRecord;
}

/// The `native` traversal of a [`PerRay`] peer: each ray with the requested triangle test;
/// counters, which the library does not expose, left at zero (and reported as none).
pub fn trace_each<P: PerRay>(p: &P, b: Batch<'_>, out: Answers<'_>) {
    for (r, h) in b.rays.iter().zip(out.hits.iter_mut()) {
        *h = match b.tri {
            TriTestKind::Watertight => p.trace_one::<Watertight>(b.query, r),
            TriTestKind::MollerTrumbore => p.trace_one::<MollerTrumbore>(b.query, r),
        };
    }
    if let Some(s) = out.stats {
        s.fill(TraversalStats::default());
    }
}

/// The single traversal a peer offers: the library's own, with no counters.
pub const NATIVE: TraversalInfo = TraversalInfo::new(
    "native",
    "the library's documentation",
    "the library's own traversal",
)
.counting(CounterSet::NONE);
