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

#[cfg(feature = "bvh")]
pub mod bvh_rs;
#[cfg(feature = "embree")]
pub mod embree;
#[cfg(feature = "obvhs")]
pub mod obvhs;

use tb_core::{CounterSet, TraversalInfo};

/// The single traversal a peer offers: the library's own, with no counters.
pub const NATIVE: TraversalInfo = TraversalInfo::new(
    "native",
    "the library's documentation",
    "the library's own traversal",
)
.counting(CounterSet::NONE);
