//! Brute force: every ray against every triangle. The ground truth of every oracle test.

use crate::accel::{dispatch, Accel, Kernel, MemoryReport, Query, TraversalInfo};
use crate::geom::{HitRecord, Ray, Triangle};
use crate::stats::{Counter, TraversalStats};
use crate::tri::{TriTest, TriTestKind};

/// The oracle: tests every triangle in index order, keeping the smallest `t` (the first index
/// wins ties). `steps` counts one per triangle tested.
pub struct BruteForce {
    tris: Vec<Triangle>,
}

/// The one traversal of brute force.
pub const TRAVERSALS: &[TraversalInfo] = &[TraversalInfo {
    name: "linear",
    doc: "every triangle in index order (the oracle)",
}];

impl BruteForce {
    pub fn new(tris: &[Triangle]) -> Self {
        Self {
            tris: tris.to_vec(),
        }
    }
}

impl Kernel for BruteForce {
    #[inline]
    fn closest<T: TriTest, C: Counter>(&self, ray: &Ray, c: &mut C) -> HitRecord {
        let pre = T::prepare(ray);
        let mut best = HitRecord::MISS;
        let mut tmax = ray.tmax;
        c.leaf();
        c.prims(self.tris.len() as u32);
        c.steps(self.tris.len() as u32);
        for (i, tri) in self.tris.iter().enumerate() {
            if let Some((t, u, v)) = T::intersect(&pre, ray, tri, tmax) {
                tmax = t;
                best = HitRecord {
                    t,
                    prim: i as u32,
                    u,
                    v,
                };
            }
        }
        best
    }

    #[inline]
    fn any<T: TriTest, C: Counter>(&self, ray: &Ray, c: &mut C) -> HitRecord {
        let pre = T::prepare(ray);
        c.leaf();
        for (i, tri) in self.tris.iter().enumerate() {
            c.prims(1);
            c.steps(1);
            if let Some((t, u, v)) = T::intersect(&pre, ray, tri, ray.tmax) {
                return HitRecord {
                    t,
                    prim: i as u32,
                    u,
                    v,
                };
            }
        }
        HitRecord::MISS
    }
}

impl Accel for BruteForce {
    fn name(&self) -> &'static str {
        "brute-force"
    }

    fn traversals(&self) -> &'static [TraversalInfo] {
        TRAVERSALS
    }

    fn memory(&self) -> MemoryReport {
        MemoryReport {
            bytes: std::mem::size_of_val(self.tris.as_slice()) as u64,
            nodes: 1,
            prim_refs: self.tris.len() as u64,
            node_bytes: 0,
        }
    }

    fn trace(
        &self,
        _traversal: usize,
        query: Query,
        tri: TriTestKind,
        rays: &[Ray],
        hits: &mut [HitRecord],
        stats: Option<&mut [TraversalStats]>,
    ) {
        dispatch(self, query, tri, rays, hits, stats)
    }
}
