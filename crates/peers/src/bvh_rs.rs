//! svenstaro's `bvh` crate: its SAH-bucketed BVH, closest hit computed from the candidate
//! iterator (`traverse_iterator`) with our triangle test, as its users do.

use bvh::aabb::{Aabb as BAabb, Bounded};
use bvh::bounding_hierarchy::BHShape;
use bvh::bvh::Bvh;
use nalgebra::{Point3, Vector3};
use tb_core::oracle::NoParams;
use tb_core::{
    build_with, Family, HitRecord, MemoryReport, Query, Ray, Structure, Traversal, TriTest,
    Triangle,
};

/// The `bvh` crate in the registry (feature `bvh-rs`).
pub static FAMILY: Family = Family::new::<BvhRsPeer, NoParams>(
    "peer: the `bvh` crate (svenstaro), closest hit from its candidates (feature `bvh-rs`)",
    |tris, set| build_with(set, |_: &NoParams| Ok(BvhRsPeer::build(tris))),
)
.with_method(1, tb_core::FIRST_METHOD);

/// A triangle as a `bvh` shape.
struct Shape {
    index: u32,
    bounds: BAabb<f32, 3>,
    node: usize,
}

impl Bounded<f32, 3> for Shape {
    fn aabb(&self) -> BAabb<f32, 3> {
        self.bounds
    }
}

impl BHShape<f32, 3> for Shape {
    fn set_bh_node_index(&mut self, i: usize) {
        self.node = i;
    }
    fn bh_node_index(&self) -> usize {
        self.node
    }
}

/// A `bvh::Bvh` over the triangles.
pub struct BvhRsPeer {
    bvh: Bvh<f32, 3>,
    shapes: Vec<Shape>,
    tris: Vec<Triangle>,
}

impl BvhRsPeer {
    /// Build the crate's BVH over `tris` (its SAH-bucketed builder).
    pub fn build(tris: &[Triangle]) -> Self {
        let mut shapes: Vec<Shape> = tris
            .iter()
            .enumerate()
            .map(|(i, t)| {
                let b = t.bounds();
                Shape {
                    index: i as u32,
                    bounds: BAabb::with_bounds(
                        Point3::new(b.min.x, b.min.y, b.min.z),
                        Point3::new(b.max.x, b.max.y, b.max.z),
                    ),
                    node: 0,
                }
            })
            .collect();
        let bvh = Bvh::build(&mut shapes);
        BvhRsPeer {
            bvh,
            shapes,
            tris: tris.to_vec(),
        }
    }
}

impl crate::PerRay for BvhRsPeer {
    fn trace_one<T: TriTest>(&self, query: Query, r: &Ray) -> HitRecord {
        let pre = T::prepare(r);
        let bray = bvh::ray::Ray::new(
            Point3::new(r.origin.x, r.origin.y, r.origin.z),
            Vector3::new(r.dir.x, r.dir.y, r.dir.z),
        );
        let mut best = HitRecord::MISS;
        let mut tmax = r.tmax;
        for s in self.bvh.traverse_iterator(&bray, &self.shapes) {
            if let Some((t, u, v)) = T::intersect(&pre, r, &self.tris[s.index as usize], tmax) {
                // Keep the first index among equal distances, as the oracle does.
                if t < tmax || (t == tmax && s.index < best.prim) {
                    best = HitRecord {
                        t,
                        prim: s.index,
                        u,
                        v,
                    };
                    tmax = t;
                }
                if query == Query::Any {
                    break;
                }
            }
        }
        best
    }
}

impl Structure for BvhRsPeer {
    const NAME: &'static str = "bvh-rs";
    const TRAVERSALS: &'static [Traversal<Self>] = &[Traversal::cpu(
        crate::NATIVE,
        tb_core::kernel!(|p: &BvhRsPeer, batch, out| crate::trace_each(p, batch, out)),
    )];

    /// The library's nodes, its shapes (one per triangle: index, box and node, which its
    /// traversal reads) and our copy of the triangles.
    ///
    /// `structure_bytes`: the nodes and the shapes (the library's reference array); not the
    /// triangle copy.
    fn own_memory(&self) -> MemoryReport {
        let nodes = self.bvh.nodes.len();
        let node_bytes = std::mem::size_of_val(&self.bvh.nodes[0..nodes.min(1)]);
        let structure = std::mem::size_of_val(self.bvh.nodes.as_slice())
            + self.shapes.len() * std::mem::size_of::<Shape>();
        MemoryReport {
            bytes: (structure + std::mem::size_of_val(self.tris.as_slice())) as u64,
            structure_bytes: structure as u64,
            nodes: nodes as u64,
            prim_refs: self.shapes.len() as u64,
            node_bytes: node_bytes as u32,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::test_tris as tris;

    /// `structure_bytes` is the library's nodes and shapes; `bytes` adds the triangle copy.
    #[test]
    fn structure_bytes_are_the_nodes_and_shapes() {
        let tris = tris();
        let p = BvhRsPeer::build(&tris);
        let m = p.own_memory();
        let nodes = std::mem::size_of_val(p.bvh.nodes.as_slice());
        let shapes = tris.len() * std::mem::size_of::<Shape>();
        assert_eq!(m.structure_bytes, (nodes + shapes) as u64);
        assert_eq!(
            m.bytes - m.structure_bytes,
            std::mem::size_of_val(&tris[..]) as u64
        );
    }
}
