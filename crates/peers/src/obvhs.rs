//! obvhs: a compressed wide BVH8 (CWBVH; Ylitie, Karras and Laine 2017) built from a PLOC
//! BVH2 (Meister and Bittner 2018), traversed by the crate's CPU traversal; candidates are
//! tested with our triangle test.

use obvhs::cwbvh::CwBvh;
use obvhs::ray::Ray as ORay;
use obvhs::BvhBuildParams;
use obvhs_glam::Vec3A;
use tb_core::{
    Accel, HitRecord, MemoryReport, MollerTrumbore, Query, Ray, TraversalInfo, TraversalStats,
    TriTest, TriTestKind, Triangle, Watertight,
};

/// A CWBVH of the triangles.
pub struct ObvhsPeer {
    bvh: CwBvh,
    tris: Vec<Triangle>,
}

/// obvhs build presets (`BvhBuildParams::*_build`).
pub const PRESETS: &[&str] = &["very-fast", "fast", "medium", "slow", "very-slow"];

impl ObvhsPeer {
    /// Build with one of [`PRESETS`].
    pub fn build(tris: &[Triangle], preset: &str) -> Result<Self, String> {
        let params = match preset {
            "very-fast" => BvhBuildParams::very_fast_build(),
            "fast" => BvhBuildParams::fast_build(),
            "medium" => BvhBuildParams::medium_build(),
            "slow" => BvhBuildParams::slow_build(),
            "very-slow" => BvhBuildParams::very_slow_build(),
            other => return Err(format!("unknown obvhs preset `{other}`")),
        };
        let otris: Vec<obvhs::triangle::Triangle> = tris
            .iter()
            .map(|t| obvhs::triangle::Triangle {
                v0: Vec3A::from_array(t.v0.to_array()),
                v1: Vec3A::from_array(t.v1.to_array()),
                v2: Vec3A::from_array(t.v2.to_array()),
            })
            .collect();
        let mut core = std::time::Duration::default();
        let bvh = obvhs::cwbvh::builder::build_cwbvh_from_tris(&otris, params, &mut core);
        Ok(ObvhsPeer {
            bvh,
            tris: tris.to_vec(),
        })
    }

    fn trace_one<T: TriTest>(&self, query: Query, r: &Ray) -> HitRecord {
        let pre = T::prepare(r);
        let oray = ORay::new(
            Vec3A::from_array(r.origin.to_array()),
            Vec3A::from_array(r.dir.to_array()),
            r.tmin,
            r.tmax,
        );
        let mut best = HitRecord::MISS;
        let ids = &self.bvh.primitive_indices;
        match query {
            Query::Closest => {
                let mut hit = obvhs::ray::RayHit::none();
                self.bvh.ray_traverse(oray, &mut hit, |ray, id| {
                    let prim = ids[id];
                    match T::intersect(&pre, r, &self.tris[prim as usize], ray.tmax) {
                        Some((t, u, v)) => {
                            best = HitRecord { t, prim, u, v };
                            t
                        }
                        None => f32::INFINITY,
                    }
                });
                best
            }
            Query::Any => {
                self.bvh.ray_traverse_miss(oray, |ray, id| {
                    let prim = ids[id];
                    match T::intersect(&pre, r, &self.tris[prim as usize], ray.tmax) {
                        Some((t, u, v)) => {
                            best = HitRecord { t, prim, u, v };
                            t
                        }
                        None => f32::INFINITY,
                    }
                });
                best
            }
        }
    }
}

impl Accel for ObvhsPeer {
    fn name(&self) -> &'static str {
        "obvhs"
    }

    fn traversals(&self) -> &'static [TraversalInfo] {
        crate::NATIVE
    }

    fn memory(&self) -> MemoryReport {
        let nodes = self.bvh.nodes.len();
        let node_bytes = std::mem::size_of::<obvhs::cwbvh::node::CwBvhNode>();
        MemoryReport {
            bytes: (nodes * node_bytes
                + self.bvh.primitive_indices.len() * 4
                + std::mem::size_of_val(self.tris.as_slice())) as u64,
            nodes: nodes as u64,
            prim_refs: self.bvh.primitive_indices.len() as u64,
            node_bytes: node_bytes as u32,
        }
    }

    fn has_counters(&self) -> bool {
        false
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
        for (r, h) in rays.iter().zip(hits.iter_mut()) {
            *h = match tri {
                TriTestKind::Watertight => self.trace_one::<Watertight>(query, r),
                TriTestKind::MollerTrumbore => self.trace_one::<MollerTrumbore>(query, r),
            };
        }
        if let Some(s) = stats {
            s.fill(TraversalStats::default());
        }
    }
}
