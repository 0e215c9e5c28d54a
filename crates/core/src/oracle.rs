//! Brute force: every ray against every triangle. The ground truth of every oracle test.

use crate::accel::{
    build_with, dispatch, Family, Kernel, MemoryReport, Structure, Traversal, TraversalInfo,
};
use crate::geom::{HitRecord, Ray, Triangle};
use crate::gpu::GpuProgram;
use crate::stats::Counter;
use crate::tri::TriTest;
use std::sync::Arc;

/// Times the GPU kernel's triangle loop is unrolled (`UNROLL` in `shaders/brute.wgsl`).
const GPU_UNROLL: u32 = 8;

/// The oracle: tests every triangle in index order, keeping the smallest `t` (the first index
/// wins ties). `steps` and `prims` count one per triangle tested; no box is tested.
///
/// Every triangle is given to the very test the structures call, with nothing in front of it:
/// a box test culling triangles first would hide a false hit of the triangle test from the
/// comparison (it once hid one: a hit 1.6e-8 behind a shadow ray's origin that every kd, grid
/// and R-tree traversal reported and the oracle's box culling rejected). Hits behind the
/// origin are the triangle test's to reject ([`crate::tri::Watertight`]'s conservative `t`).
pub struct BruteForce {
    tris: Arc<[Triangle]>,
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
)
.with_method(1, crate::FIRST_METHOD);

impl BruteForce {
    /// Brute force over a copy of `tris`.
    pub fn new(tris: &[Triangle]) -> Self {
        Self::shared(tris.into())
    }

    /// Brute force over shared triangles.
    pub fn shared(tris: Arc<[Triangle]>) -> Self {
        Self { tris }
    }

    /// The triangles, in the scene's order.
    pub fn triangles(&self) -> &[Triangle] {
        &self.tris
    }

    /// The GPU program of `linear` (`shaders/brute.wgsl`): the same loop (no buffers of its
    /// own), unrolled [`GPU_UNROLL`]
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
        let mut best = HitRecord::MISS;
        let mut tmax = ray.tmax;
        let n = self.tris.len() as u32;
        c.leaf();
        c.steps(n);
        c.prims(n);
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
            c.steps(1);
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
        crate::kernel!(|o: &BruteForce, batch, out| dispatch(o, batch, out)),
        BruteForce::gpu_linear,
    )];

    /// The triangle array alone; no structure (`structure_bytes` 0).
    fn own_memory(&self) -> MemoryReport {
        MemoryReport {
            bytes: std::mem::size_of_val(&*self.tris) as u64,
            structure_bytes: 0,
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
