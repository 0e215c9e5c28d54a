//! The one way a batch is traced on the CPU: split into chunks of [`CHUNK`] rays over the
//! current rayon pool (install a pool to choose the threads), one [`Accel::trace`] call per
//! chunk. The runner, the oracle, the heat maps and the renderer all trace through here.

use crate::accel::{Accel, Answers, Batch, Query};
use crate::geom::{HitRecord, Ray};
use crate::stats::TraversalStats;
use crate::tri::TriTestKind;
use rayon::prelude::*;

/// Rays per call of [`Accel::trace`] when a batch is split across threads.
pub const CHUNK: usize = 1024;

/// Trace `batch` into `out` (its hits and, counting, its counters) with traversal number
/// `traversal`, on the current rayon pool: chunks of [`CHUNK`] rays, their hints split alike,
/// one [`Accel::trace`] call per chunk.
pub fn trace_into(accel: &dyn Accel, traversal: usize, batch: Batch<'_>, out: Answers<'_>) {
    assert_eq!(batch.rays.len(), out.hits.len(), "one hit record per ray");
    let chunks: Vec<Batch<'_>> = batch.chunks(CHUNK).collect();
    let work = chunks.into_par_iter().zip(out.hits.par_chunks_mut(CHUNK));
    match out.stats {
        None => work.for_each(|(b, h)| accel.trace(traversal, b, Answers::hits(h))),
        Some(s) => {
            assert_eq!(batch.rays.len(), s.len(), "one stats record per ray");
            work.zip(s.par_chunks_mut(CHUNK))
                .for_each(|((b, h), s)| accel.trace(traversal, b, Answers::new(h, Some(s))))
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
    let batch = Batch::new(query, tri, rays).with_hints(hints.as_deref());
    let mut hits = vec![HitRecord::MISS; rays.len()];
    trace_into(accel, traversal, batch, Answers::hits(&mut hits));
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
    let batch = Batch::new(query, tri, rays);
    trace_into(accel, traversal, batch, Answers::hits(&mut hits));
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
    let batch = Batch::new(query, tri, rays);
    trace_into(
        accel,
        traversal,
        batch,
        Answers::new(&mut hits, Some(&mut stats)),
    );
    (hits, stats)
}

thread_local! {
    static UNTIMED_BUILD: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Run `f` as an untimed build (one whose time no claim reads, [`untimed_build_running`] true
/// on this thread meanwhile): a builder whose algorithm allows it may then split its work over
/// the current rayon pool, its output identical to its serial build's. Timed builds run
/// outside it and keep the paper's single-threaded builder.
pub fn as_untimed_build<R>(f: impl FnOnce() -> R) -> R {
    /// Puts the flag back as it was, also when `f` unwinds.
    struct Restore(bool);
    impl Drop for Restore {
        fn drop(&mut self) {
            UNTIMED_BUILD.with(|c| c.set(self.0));
        }
    }
    let _restore = Restore(UNTIMED_BUILD.with(|c| c.replace(true)));
    f()
}

/// Whether this thread is in [`as_untimed_build`].
pub fn untimed_build_running() -> bool {
    UNTIMED_BUILD.with(|c| c.get())
}
