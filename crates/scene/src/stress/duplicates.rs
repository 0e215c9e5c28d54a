//! `stress/duplicates`: identical, permuted, coplanar-overlapping and co-centred triangles
//! (ties, unsplittable clusters).

use super::common::{aim, entering, in_plane_dir, range, rng, unit, view_from, Generated};
use super::mesh::quad_grid;
use crate::procedural::BuiltinInfo;
use rand::Rng;
use tb_core::{Ray, Triangle, Vec3};

/// The listing entry of `builtin:stress/duplicates`.
pub(super) const INFO: BuiltinInfo = BuiltinInfo {
    name: "stress/duplicates",
    doc: "64 identical copies of a quad, permuted-vertex copies, 200 overlapping coplanar triangles, 400 triangles sharing one centroid: ties and unsplittable clusters",
    params: &["seed=1: random seed"],
};

/// Ties and unsplittable clusters.
pub(super) fn generate(seed: u64) -> Generated {
    let mut r = rng(seed, 8);
    let mut tris = Vec::new();
    let mut rays = Vec::new();
    // 64 identical copies of a unit quad in z = 0, then 16 copies with permuted vertices.
    let q = quad_grid(2, 0.0, (0.0, 0.0), (1.0, 1.0), 1).tris();
    for _ in 0..64 {
        tris.extend_from_slice(&q);
    }
    for k in 0..16 {
        for t in &q {
            tris.push(match k % 3 {
                0 => Triangle::new(t.v1, t.v2, t.v0),
                1 => Triangle::new(t.v2, t.v0, t.v1),
                _ => Triangle::new(t.v0, t.v2, t.v1),
            });
        }
    }
    for k in 0..300 {
        let mut t = Vec3::new(r.gen(), r.gen(), 0.0);
        if k % 3 == 0 {
            // On the shared diagonal.
            t.y = t.x;
        }
        let d = entering(&mut r, if k % 2 == 0 { Vec3::Z } else { -Vec3::Z }, 1.0);
        rays.push(Ray::new(t - d * 2.0, d));
    }
    // 200 overlapping coplanar triangles in the plane y = 3.
    for _ in 0..200 {
        let v = [0; 3].map(|_| Vec3::new(range(&mut r, 0.0, 2.0), 3.0, range(&mut r, 0.0, 2.0)));
        tris.push(Triangle::new(v[0], v[1], v[2]));
    }
    for k in 0..300 {
        let t = Vec3::new(range(&mut r, 0.0, 2.0), 3.0, range(&mut r, 0.0, 2.0));
        let d = if k % 4 == 0 {
            // Grazing.
            let h = in_plane_dir(&mut r, 1);
            Vec3::new(h.x, 1e-3, h.z).normalize()
        } else {
            entering(&mut r, Vec3::Y, 1.0)
        };
        rays.push(Ray::new(t - d * 2.0, d));
    }
    // 400 triangles with the same centroid (every bounding box contains it).
    let c = Vec3::new(4.0, 1.0, 1.0);
    for _ in 0..400 {
        let a = unit(&mut r) * range(&mut r, 0.1, 0.8);
        let b = unit(&mut r) * range(&mut r, 0.1, 0.8);
        tris.push(Triangle::new(c + a, c + b, c - a - b));
    }
    for _ in 0..300 {
        let t = c + unit(&mut r) * range(&mut r, 0.0, 0.3);
        rays.extend(aim(t + unit(&mut r) * 3.0, t));
    }
    (tris, rays, view_from(Vec3::new(0.3, 0.8, 1.0)))
}
