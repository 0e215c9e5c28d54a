//! Brute force: every ray against every triangle. The ground truth of every oracle test.

use crate::accel::{
    build_with, dispatch, Family, Kernel, MemoryReport, Structure, Traversal, TraversalInfo,
};
use crate::geom::{Aabb, HitRecord, Ray, Triangle};
use crate::gpu::GpuProgram;
use crate::stats::Counter;
use crate::tri::TriTest;
use std::sync::Arc;

/// Times the GPU kernel's triangle loop is unrolled (`UNROLL` in `shaders/brute.wgsl`).
const GPU_UNROLL: u32 = 8;

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
    tris: Arc<[Triangle]>,
    boxes: Vec<Aabb>,
}

crate::params! {
    /// Parameters of a structure that takes none.
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct NoParams {}
}

/// Brute force in the registry.
pub static FAMILY: Family = Family::new::<BruteForce, NoParams>(
    "every ray against every triangle: the oracle",
    |tris, set| build_with(set, |_: &NoParams| Ok(BruteForce::shared(tris.clone()))),
);

impl BruteForce {
    /// Brute force over a copy of `tris`.
    pub fn new(tris: &[Triangle]) -> Self {
        Self::shared(tris.into())
    }

    /// Brute force over shared triangles.
    pub fn shared(tris: Arc<[Triangle]>) -> Self {
        let boxes = tris.iter().map(Triangle::bounds).collect();
        Self { tris, boxes }
    }

    /// The triangles, in the scene's order.
    pub fn triangles(&self) -> &[Triangle] {
        &self.tris
    }

    /// The GPU program of `linear` (`shaders/brute.wgsl`): the same loop, boxes computed per
    /// triangle from its vertices (no buffers of its own), the loop unrolled [`GPU_UNROLL`]
    /// times for llvmpipe's limit on loop iterations.
    fn gpu_linear(&self) -> GpuProgram<'_> {
        GpuProgram::new(
            "brute-force/linear",
            include_str!("../shaders/brute.wgsl"),
            &self.tris[..],
        )
        .unrolled_triangle_loop(GPU_UNROLL)
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

impl Structure for BruteForce {
    const NAME: &'static str = "brute-force";
    const TRAVERSALS: &'static [Traversal<Self>] = &[Traversal::with_gpu(
        TraversalInfo::new(
            "linear",
            "ground truth",
            "every triangle in index order (the oracle)",
        ),
        dispatch::<BruteForce>,
        BruteForce::gpu_linear,
    )];

    fn own_memory(&self) -> MemoryReport {
        MemoryReport {
            bytes: (std::mem::size_of_val(&*self.tris)
                + std::mem::size_of_val(self.boxes.as_slice())) as u64,
            nodes: 1,
            prim_refs: self.tris.len() as u64,
            node_bytes: 0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gpu_unroll_is_the_kernels() {
        let brute = BruteForce::new(&[]);
        let p = brute.gpu_linear();
        let decl = format!("const UNROLL: u32 = {GPU_UNROLL}u;");
        assert!(p.source.contains(&decl), "brute.wgsl must declare `{decl}`");
    }
}
