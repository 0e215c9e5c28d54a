//! The one way a batch is traced on the CPU: split into chunks of [`CHUNK`] rays over the
//! current rayon pool (install a pool to choose the threads), one [`Accel::trace`] call per
//! chunk. The runner, the oracle, the heat maps and the renderer all trace through here.

use crate::accel::{Accel, Query};
use crate::geom::{HitRecord, Ray};
use crate::stats::TraversalStats;
use crate::tri::TriTestKind;
use rayon::prelude::*;

/// Rays per call of [`Accel::trace`] when a batch is split across threads.
pub const CHUNK: usize = 1024;

/// Trace `rays` into `hits` (and, counting, into `stats`) on the current rayon pool.
pub fn trace_into(
    accel: &dyn Accel,
    traversal: usize,
    query: Query,
    tri: TriTestKind,
    rays: &[Ray],
    hits: &mut [HitRecord],
    stats: Option<&mut [TraversalStats]>,
) {
    assert_eq!(rays.len(), hits.len(), "one hit record per ray");
    let chunks = rays.par_chunks(CHUNK).zip(hits.par_chunks_mut(CHUNK));
    match stats {
        None => chunks.for_each(|(r, h)| accel.trace(traversal, query, tri, r, h, None)),
        Some(s) => {
            assert_eq!(rays.len(), s.len(), "one stats record per ray");
            chunks
                .zip(s.par_chunks_mut(CHUNK))
                .for_each(|((r, h), s)| accel.trace(traversal, query, tri, r, h, Some(s)))
        }
    }
}

/// The hits of `rays` (counters compiled out), on the current rayon pool.
pub fn trace(
    accel: &dyn Accel,
    traversal: usize,
    query: Query,
    tri: TriTestKind,
    rays: &[Ray],
) -> Vec<HitRecord> {
    let mut hits = vec![HitRecord::MISS; rays.len()];
    trace_into(accel, traversal, query, tri, rays, &mut hits, None);
    hits
}

/// The hits and per-ray counters of `rays`, on the current rayon pool.
pub fn count(
    accel: &dyn Accel,
    traversal: usize,
    query: Query,
    tri: TriTestKind,
    rays: &[Ray],
) -> (Vec<HitRecord>, Vec<TraversalStats>) {
    let mut hits = vec![HitRecord::MISS; rays.len()];
    let mut stats = vec![TraversalStats::default(); rays.len()];
    trace_into(
        accel,
        traversal,
        query,
        tri,
        rays,
        &mut hits,
        Some(&mut stats),
    );
    (hits, stats)
}
