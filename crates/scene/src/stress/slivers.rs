//! `stress/slivers`: aspect-ratio-1e6 slivers and needles, zero-area triangles, a fan of thin
//! triangles.

use super::common::{aim, entering, in_box, range, rng, unit, view_from, Generated};
use super::mesh::quad_grid;
use crate::procedural::BuiltinInfo;
use rand_pcg::Pcg64;
use tb_core::{Ray, Triangle, Vec3};

/// The listing entry of `builtin:stress/slivers`.
pub(super) const INFO: BuiltinInfo = BuiltinInfo {
    name: "stress/slivers",
    doc: "slivers and needles of aspect ratio 1e6, zero-area triangles (collinear, repeated vertices), a fan of 1000 thin triangles, over a ground grid; rays aimed at them",
    params: &["seed=1: random seed"],
};

/// Slivers (aspect ratio 1e6), needles, zero-area triangles and a fan of thin triangles over a
/// ground grid.
pub(super) fn generate(seed: u64) -> Generated {
    let mut r = rng(seed, 3);
    let mut tris = quad_grid(2, -1.0, (-4.0, -4.0), (4.0, 4.0), 12).tris();
    let mut rays = Vec::new();
    let region = (Vec3::new(-3.0, -3.0, 0.0), Vec3::new(3.0, 3.0, 2.0));
    let from = |r: &mut Pcg64, t: Vec3| t + unit(r) * range(r, 2.0, 6.0);
    // Slivers: base L, height L·1e-6, random orientation.
    for k in 0..400 {
        let c = in_box(&mut r, region.0, region.1);
        let a = unit(&mut r);
        let b = (unit(&mut r).cross(a)).normalize();
        let l = range(&mut r, 0.3, 2.0);
        let tri = if k % 2 == 0 {
            // Sliver: apex at the middle of the base.
            Triangle::new(c - a * (0.5 * l), c + a * (0.5 * l), c + b * (l * 1e-6))
        } else {
            // Needle: apex near one end.
            Triangle::new(c, c + a * l, c + a * l + b * (l * 1e-6))
        };
        let target = tri.v0 * 0.4 + tri.v1 * 0.3 + tri.v2 * 0.3;
        tris.push(tri);
        rays.extend(aim(from(&mut r, target), target));
        // A second ray at an edge point of the sliver.
        let e = tri.v0 * 0.5 + tri.v1 * 0.5;
        rays.extend(aim(from(&mut r, e), e));
    }
    // Zero-area triangles: collinear (exactly, on axis-aligned lines), repeated vertices, a
    // single point, and "collinear" in f32 rounding (midpoint of a general segment).
    for k in 0..160 {
        let p = in_box(&mut r, region.0, region.1);
        let q = p + unit(&mut r);
        let tri = match k % 4 {
            0 => {
                let mut q = p;
                q[k / 4 % 3] += 1.0;
                Triangle::new(p, q, p + (q - p) * 2.0)
            }
            1 => Triangle::new(p, p, q),
            2 => Triangle::new(p, p, p),
            _ => Triangle::new(p, q, (p + q) * 0.5),
        };
        let target = (tri.v0 + tri.v1 + tri.v2) * (1.0 / 3.0);
        tris.push(tri);
        rays.extend(aim(from(&mut r, target), target));
    }
    // A fan of 1000 thin triangles (2π/1000 at the apex) sharing edges, in a tilted plane; rays
    // at the shared spokes and the apex.
    let centre = Vec3::new(0.0, 0.0, 3.0);
    let nrm = Vec3::new(0.2, -0.3, 1.0).normalize();
    let (bx, by) = crate::rays::orthonormal_basis(nrm);
    let rim: Vec<Vec3> = (0..1000)
        .map(|i| {
            let phi = std::f32::consts::TAU * i as f32 / 1000.0;
            centre + (bx * phi.cos() + by * phi.sin()) * 1.5
        })
        .collect();
    for i in 0..1000 {
        tris.push(Triangle::new(centre, rim[i], rim[(i + 1) % 1000]));
    }
    for i in (0..1000).step_by(3) {
        let t = centre + (rim[i] - centre) * range(&mut r, 0.05, 0.95);
        let d = entering(&mut r, nrm * if i % 2 == 0 { 1.0 } else { -1.0 }, 0.8);
        rays.push(Ray::new(t - d * 2.0, d));
    }
    for _ in 0..20 {
        let d = entering(&mut r, nrm, 0.8);
        rays.push(Ray::new(centre - d * 2.0, d));
    }
    (tris, rays, view_from(Vec3::new(0.3, -0.7, 0.8)))
}
