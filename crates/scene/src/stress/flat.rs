//! `stress/flat`: a scene of zero thickness (all triangles in `z = 0`); head-on, grazing and
//! in-plane rays.

use super::common::{aim, in_box, in_plane_dir, range, rng, unit, view_from, Generated};
use super::mesh::quad_grid;
use crate::error::SceneError;
use crate::procedural::{BuiltinInfo, Params};
use rand_pcg::Pcg64;
use tb_core::{Ray, Triangle, Vec3};

/// The listing entry of `builtin:stress/flat`.
pub(super) const INFO: BuiltinInfo = BuiltinInfo {
    name: "stress/flat",
    doc: "zero thickness on one axis: random triangles and a grid mesh all in z = 0; head-on, grazing (dir.z down to 1e-8) and in-plane rays",
    params: &[
        "seed=1: random seed",
        "count=1500: number of random triangles",
    ],
};

/// Read `count` (at most 100000) and generate.
pub(super) fn load(seed: u64, params: &Params) -> Result<Generated, SceneError> {
    let count = params.u32("count", 1500)?;
    params.check(count <= 100_000, "count must be at most 100000")?;
    Ok(generate(seed, count as usize))
}

/// Zero thickness in z: `count` random triangles in `[0, 10]²` and a 10x10 grid mesh in
/// `[-5, 0] x [0, 5]`, all in `z = 0` (a few vertices with `z = -0.0`).
pub(super) fn generate(seed: u64, count: usize) -> Generated {
    let mut r = rng(seed, 2);
    let mut tris = quad_grid(2, 0.0, (-5.0, 0.0), (0.0, 5.0), 10).tris();
    for i in 0..count {
        let c = Vec3::new(range(&mut r, 0.0, 10.0), range(&mut r, 0.0, 10.0), 0.0);
        let size = range(&mut r, 0.05, 0.6);
        let mut v = [0; 3]
            .map(|_| c + Vec3::new(range(&mut r, -size, size), range(&mut r, -size, size), 0.0));
        if i % 17 == 0 {
            v[0].z = -0.0;
        }
        tris.push(Triangle::new(v[0], v[1], v[2]));
    }
    let lo = Vec3::new(-5.0, 0.0, 0.0);
    let hi = Vec3::new(10.0, 10.0, 0.0);
    let mut rays = Vec::new();
    let on_plane = |r: &mut Pcg64| in_box(r, lo, hi);
    // Head-on, exactly along ±z and tilted.
    for k in 0..400 {
        let t = on_plane(&mut r);
        let s = if k % 2 == 0 { 1.0 } else { -1.0 };
        if k < 250 {
            rays.push(Ray::new(
                t + Vec3::new(0.0, 0.0, 3.0 * s),
                Vec3::new(0.0, 0.0, -s),
            ));
        } else {
            rays.extend(aim(
                t + Vec3::new(range(&mut r, -1.0, 1.0), range(&mut r, -1.0, 1.0), 3.0 * s),
                t,
            ));
        }
    }
    // Grazing: dir.z from 1e-2 down to 1e-8, arriving at a point of the plane.
    for k in 0..400 {
        let t = on_plane(&mut r);
        let g = [1e-2f32, 1e-4, 1e-6, 1e-8][k % 4];
        let s = if k % 8 < 4 { 1.0 } else { -1.0 };
        let h = in_plane_dir(&mut r, 2);
        let d = Vec3::new(h.x, h.y, -s * g).normalize();
        let len = range(&mut r, 0.5, 8.0);
        rays.push(Ray::new(t - d * len, d));
    }
    // In the plane: origin z = ±0, direction z = ±0 (parallel: never hit).
    for k in 0..200 {
        let mut o = on_plane(&mut r);
        if k % 2 == 0 {
            o.z = -0.0;
        }
        rays.push(Ray::new(o, in_plane_dir(&mut r, 2)));
    }
    // Starting on the plane with tmin = 0, leaving it (hit at t = 0 where inside a triangle).
    for k in 0..150 {
        let o = on_plane(&mut r);
        let mut d = unit(&mut r);
        if k % 3 == 0 {
            d = Vec3::new(0.0, 0.0, if k % 2 == 0 { 1.0 } else { -1.0 });
        }
        rays.push(Ray::new(o, d));
    }
    // Just above the plane, parallel to it (denormal and tiny heights).
    for k in 0..100 {
        let mut o = on_plane(&mut r);
        o.z = [1e-30f32, 1e-40, -1e-40, 1e-7][k % 4];
        rays.push(Ray::new(o, in_plane_dir(&mut r, 2)));
    }
    (tris, rays, view_from(Vec3::new(0.25, -0.6, 1.0)))
}
