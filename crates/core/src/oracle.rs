//! Brute force: every ray against every triangle. The ground truth of every oracle test.

use crate::accel::{dispatch, Accel, Kernel, MemoryReport, Query, TraversalInfo};
use crate::geom::{Aabb, HitRecord, Ray, Triangle};
use crate::stats::{Counter, TraversalStats};
use crate::tri::{TriTest, TriTestKind};

/// The oracle: tests every triangle in index order, keeping the smallest `t` (the first index
/// wins ties). `steps` counts one per triangle tested.
///
/// Each triangle test is gated by the robust slab test of the triangle's own bounding box
/// ([`Aabb::intersect`]) over the ray's current interval. The exact hit point of a true hit lies
/// in the triangle and so in its box; a test's rounding, though, can report a hit for a ray
/// passing near an elongated sliver (on Conference: a 2560 x 3.8 unit triangle in the plane
/// y = 205.7, a bounce ray starting 0.004 below that plane and moving down got `t = 0.0049`
/// from the watertight test). Such a hit is a numerical false positive that every structure
/// culling by boxes rejects, so the oracle rejects it too. `boxes` counts one per triangle.
pub struct BruteForce {
    tris: Vec<Triangle>,
    boxes: Vec<Aabb>,
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
            boxes: tris.iter().map(Triangle::bounds).collect(),
        }
    }
}

impl Kernel for BruteForce {
    #[inline]
    fn closest<T: TriTest, C: Counter>(&self, ray: &Ray, c: &mut C) -> HitRecord {
        let pre = T::prepare(ray);
        let inv = ray.inv_dir();
        let mut best = HitRecord::MISS;
        let mut tmax = ray.tmax;
        c.leaf();
        c.boxes(self.tris.len() as u32);
        c.steps(self.tris.len() as u32);
        for (i, (tri, b)) in self.tris.iter().zip(&self.boxes).enumerate() {
            if b.intersect(ray.origin, inv, ray.tmin, tmax).is_none() {
                continue;
            }
            c.prims(1);
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
        let inv = ray.inv_dir();
        c.leaf();
        for (i, (tri, b)) in self.tris.iter().zip(&self.boxes).enumerate() {
            c.boxes(1);
            c.steps(1);
            if b.intersect(ray.origin, inv, ray.tmin, ray.tmax).is_none() {
                continue;
            }
            c.prims(1);
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
            bytes: (std::mem::size_of_val(self.tris.as_slice())
                + std::mem::size_of_val(self.boxes.as_slice())) as u64,
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
