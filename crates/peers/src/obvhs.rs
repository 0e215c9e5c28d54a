//! obvhs: a compressed wide BVH8 (CWBVH; Ylitie, Karras and Laine 2017) built from a PLOC
//! BVH2 (Meister and Bittner 2018), traversed by the crate's CPU traversal; candidates are
//! tested with our triangle test.

use obvhs::cwbvh::CwBvh;
use obvhs::ray::Ray as ORay;
use obvhs::BvhBuildParams;
use obvhs_glam::Vec3A;
use tb_core::params::ParamKind;
use tb_core::{
    build_with, Family, HitRecord, MemoryReport, Query, Ray, Structure, Traversal, TriTest,
    Triangle,
};

/// obvhs in the registry (feature `obvhs`).
pub static FAMILY: Family = Family::new::<ObvhsPeer, ObvhsParams>(
    "peer: obvhs PLOC-built compressed wide BVH8 (feature `obvhs`)",
    |tris, set| build_with(set, |p: &ObvhsParams| Ok(ObvhsPeer::build(tris, p.preset))),
)
.with_method(1, tb_core::FIRST_METHOD);

tb_core::choice! {
    /// obvhs build presets (`BvhBuildParams::*_build`).
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    pub enum Preset {
        /// The fastest build and lowest tree quality (`BvhBuildParams::very_fast_build()`).
        VeryFast = "very-fast",
        /// A faster build than `medium` (`BvhBuildParams::fast_build()`).
        Fast = "fast",
        /// The default trade of build time for quality (`BvhBuildParams::medium_build()`).
        Medium = "medium",
        /// A better tree than `medium`, built slower (`BvhBuildParams::slow_build()`).
        Slow = "slow",
        /// The slowest build and best tree quality (`BvhBuildParams::very_slow_build()`).
        VerySlow = "very-slow",
    }
}

tb_core::params! {
    /// obvhs build settings.
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    pub struct ObvhsParams {
        /// obvhs BvhBuildParams preset
        preset: Preset = Preset::Medium, ParamKind::Choice(Preset::NAMES);
    }
}

/// A CWBVH of the triangles.
pub struct ObvhsPeer {
    bvh: CwBvh,
    tris: Vec<Triangle>,
}

impl ObvhsPeer {
    /// Build with one of the presets.
    pub fn build(tris: &[Triangle], preset: Preset) -> Self {
        let params = match preset {
            Preset::VeryFast => BvhBuildParams::very_fast_build(),
            Preset::Fast => BvhBuildParams::fast_build(),
            Preset::Medium => BvhBuildParams::medium_build(),
            Preset::Slow => BvhBuildParams::slow_build(),
            Preset::VerySlow => BvhBuildParams::very_slow_build(),
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
        ObvhsPeer {
            bvh,
            tris: tris.to_vec(),
        }
    }
}

impl crate::PerRay for ObvhsPeer {
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

impl Structure for ObvhsPeer {
    const NAME: &'static str = "obvhs";
    const TRAVERSALS: &'static [Traversal<Self>] = &[Traversal::cpu(
        crate::NATIVE,
        tb_core::kernel!(|p: &ObvhsPeer, batch, out| crate::trace_each(p, batch, out)),
    )];

    /// The compressed wide nodes, the primitive indices and our copy of the triangles.
    ///
    /// `structure_bytes`: the nodes and 4 bytes a primitive index; not the triangle copy.
    fn own_memory(&self) -> MemoryReport {
        let nodes = self.bvh.nodes.len();
        let node_bytes = std::mem::size_of::<obvhs::cwbvh::node::CwBvhNode>();
        let structure = nodes * node_bytes + self.bvh.primitive_indices.len() * 4;
        MemoryReport {
            bytes: (structure + std::mem::size_of_val(self.tris.as_slice())) as u64,
            structure_bytes: structure as u64,
            nodes: nodes as u64,
            prim_refs: self.bvh.primitive_indices.len() as u64,
            node_bytes: node_bytes as u32,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::test_tris as tris;

    /// `structure_bytes` is the wide nodes and 4 bytes an index; `bytes` adds the triangles.
    #[test]
    fn structure_bytes_are_the_nodes_and_indices() {
        let tris = tris();
        let p = ObvhsPeer::build(&tris, Preset::Medium);
        let m = p.own_memory();
        let nodes = std::mem::size_of_val(p.bvh.nodes.as_slice());
        assert_eq!(m.structure_bytes, (nodes + 4 * m.prim_refs as usize) as u64);
        assert!(m.prim_refs >= tris.len() as u64);
        assert_eq!(
            m.bytes - m.structure_bytes,
            std::mem::size_of_val(&tris[..]) as u64
        );
    }
}
