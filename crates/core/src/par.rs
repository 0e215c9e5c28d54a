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
    trace_hinted_into(accel, traversal, query, tri, rays, None, hits, stats)
}

/// [`trace_into`] with the per-ray start hints of [`Accel::batch_hints`] (`None`: none),
/// split into chunks with the rays ([`Accel::trace_hinted`]).
// Over clippy's seven: the trace signature, as `Accel::trace_hinted`'s.
#[allow(clippy::too_many_arguments)]
pub fn trace_hinted_into(
    accel: &dyn Accel,
    traversal: usize,
    query: Query,
    tri: TriTestKind,
    rays: &[Ray],
    hints: Option<&[u32]>,
    hits: &mut [HitRecord],
    stats: Option<&mut [TraversalStats]>,
) {
    assert_eq!(rays.len(), hits.len(), "one hit record per ray");
    if let Some(h) = hints {
        assert_eq!(rays.len(), h.len(), "one hint per ray");
    }
    // The hints chunked as the rays (an empty chunk per ray chunk when there are none).
    let hint_chunks: Vec<Option<&[u32]>> = match hints {
        Some(h) => h.chunks(CHUNK).map(Some).collect(),
        None => vec![None; rays.len().div_ceil(CHUNK)],
    };
    let chunks = rays
        .par_chunks(CHUNK)
        .zip(hint_chunks.into_par_iter())
        .zip(hits.par_chunks_mut(CHUNK));
    match stats {
        None => {
            chunks.for_each(|((r, k), h)| accel.trace_hinted(traversal, query, tri, r, k, h, None))
        }
        Some(s) => {
            assert_eq!(rays.len(), s.len(), "one stats record per ray");
            chunks
                .zip(s.par_chunks_mut(CHUNK))
                .for_each(|(((r, k), h), s)| {
                    accel.trace_hinted(traversal, query, tri, r, k, h, Some(s))
                })
        }
    }
}

/// The hits of `rays` with the start hints of [`Accel::batch_hints`] computed first
/// (traversals taking none: as [`trace`]), on the current rayon pool.
pub fn trace_with_hints(
    accel: &dyn Accel,
    traversal: usize,
    query: Query,
    tri: TriTestKind,
    rays: &[Ray],
) -> Vec<HitRecord> {
    let hints = accel.batch_hints(traversal, query, rays);
    let mut hits = vec![HitRecord::MISS; rays.len()];
    trace_hinted_into(
        accel,
        traversal,
        query,
        tri,
        rays,
        hints.as_deref(),
        &mut hits,
        None,
    );
    hits
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
