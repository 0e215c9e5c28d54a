//! [`Tracer`]: "something that traces a batch of rays". Integrators and image writers only see
//! this trait, so they run on every structure ([`AccelTracer`] over any `&dyn Accel`) and on any
//! device: a GPU device implements `Tracer` (or passes a closure) and needs nothing else.

use tb_core::{Accel, Answers, Batch, HitRecord, Query, Ray, TriTestKind};

/// Traces a batch of rays: one hit record per ray (closest or any hit, as `query` asks).
pub trait Tracer: Sync {
    /// Trace `rays` into `hits` (same length).
    fn trace(&self, query: Query, rays: &[Ray], hits: &mut [HitRecord]);
}

impl<F> Tracer for F
where
    F: Fn(Query, &[Ray], &mut [HitRecord]) + Sync,
{
    fn trace(&self, query: Query, rays: &[Ray], hits: &mut [HitRecord]) {
        self(query, rays, hits)
    }
}

/// A CPU tracer: traversal `traversal` of `accel` with triangle test `tri`, the batch traced by
/// [`tb_core::par`] over the current rayon pool (install a pool to pick the threads).
pub struct AccelTracer<'a> {
    /// The structure traced.
    pub accel: &'a dyn Accel,
    /// Index of the traversal in the structure's traversal table.
    pub traversal: usize,
    /// The ray-triangle test used.
    pub tri: TriTestKind,
}

impl Tracer for AccelTracer<'_> {
    fn trace(&self, query: Query, rays: &[Ray], hits: &mut [HitRecord]) {
        let batch = Batch::new(query, self.tri, rays);
        tb_core::par::trace_into(self.accel, self.traversal, batch, Answers::hits(hits));
    }
}
