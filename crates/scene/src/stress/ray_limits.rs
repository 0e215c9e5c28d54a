//! `stress/ray-limits`: origins on surfaces with `tmin = 0`, `tmax` exactly at a hit, huge and
//! empty intervals, denormal, signed-zero and scaled directions.

use super::common::{aim, in_box, in_plane_dir, rng, unit, view_from, Generated};
use super::mesh::{grid_box, icosphere, quad_grid};
use crate::procedural::BuiltinInfo;
use rand::Rng;
use rand_pcg::Pcg64;
use tb_core::{Ray, Vec3};

/// The listing entry of `builtin:stress/ray-limits`.
pub(super) const INFO: BuiltinInfo = BuiltinInfo {
    name: "stress/ray-limits",
    doc: "ray intervals and directions: origins exactly on surfaces with tmin = 0, tmax exactly at the hit distance, tmin = tmax, huge tmin/tmax, denormal, signed-zero and scaled (1e-20..1e20) directions, far origins",
    params: &["seed=1: random seed"],
};

/// Ray intervals and directions on simple exact geometry: the ground grid `z = 0` over
/// `[-4, 4]²`, an icosphere of radius 1 at (0, 0, 2) and a box `[2, 3]² x [0, 1]`.
pub(super) fn generate(seed: u64) -> Generated {
    let mut r = rng(seed, 7);
    let mut m = quad_grid(2, 0.0, (-4.0, -4.0), (4.0, 4.0), 8);
    m.append(&icosphere(2).map(|p| p + Vec3::new(0.0, 0.0, 2.0)));
    m.append(&grid_box(
        Vec3::new(2.0, 2.0, 0.0),
        Vec3::new(3.0, 3.0, 1.0),
        1,
    ));
    let mut rays = Vec::new();
    interval_rays(&mut r, &mut rays);
    direction_rays(&mut r, &mut rays);
    origin_rays(&mut r, &mut rays);
    (m.tris(), rays, view_from(Vec3::new(-0.8, -0.5, 0.7)))
}

/// A dyadic point of the ground in the free quadrant x, y in [-4, -1].
fn ground(r: &mut Pcg64) -> Vec3 {
    Vec3::new(
        -1.0 - r.gen_range(0..=192) as f32 / 64.0,
        -1.0 - r.gen_range(0..=192) as f32 / 64.0,
        0.0,
    )
}

/// Ray intervals on the ground: origins on it with `tmin = 0`, `tmax` exactly at the hit
/// distance, huge and empty intervals.
fn interval_rays(r: &mut Pcg64, rays: &mut Vec<Ray>) {
    // Origins exactly on the ground, tmin = 0: leaving, entering, in the plane, and along ±z.
    for k in 0..120 {
        let o = ground(r);
        let d = match k % 4 {
            0 => unit(r),
            1 => in_plane_dir(r, 2),
            2 => Vec3::new(0.0, 0.0, 1.0),
            _ => Vec3::new(-0.0, 0.0, -1.0),
        };
        rays.push(Ray::new(o, d));
    }
    // tmax exactly at the hit distance: along -z from a power-of-two height h the hit is at
    // t = h exactly. [0, h) misses, [0, next_up(h)) and [h, inf) hit, [next_up(h), inf) and
    // the empty [h, h) miss.
    for k in 0..60 {
        let h = [0.25f32, 0.5, 1.0, 2.0, 4.0, 1024.0][k % 6];
        let o = ground(r) + Vec3::new(0.0, 0.0, h);
        let d = -Vec3::Z;
        let up = f32::from_bits(h.to_bits() + 1);
        for (tmin, tmax) in [
            (0.0, h),
            (0.0, up),
            (h, f32::INFINITY),
            (up, f32::INFINITY),
            (h, h),
        ] {
            rays.push(Ray::segment(o, d, tmin, tmax));
        }
    }
    // Huge intervals: tmax = f32::MAX, tmin = 1e30 (misses), tmin = tmax = f32::MAX.
    for _ in 0..40 {
        let t = ground(r);
        let o = t + unit(r).abs() * 3.0;
        let Some(ray) = aim(o, t) else { continue };
        rays.push(Ray::segment(ray.origin, ray.dir, 0.0, f32::MAX));
        rays.push(Ray::segment(ray.origin, ray.dir, 1e30, f32::INFINITY));
        rays.push(Ray::segment(ray.origin, ray.dir, f32::MAX, f32::MAX));
    }
}

/// Denormal, tiny, signed-zero and scaled (1e-20..1e20) directions.
fn direction_rays(r: &mut Pcg64, rays: &mut Vec<Ray>) {
    // Denormal and tiny direction components.
    let tiny = [1e-40f32, -1e-40, 1e-45, -1e-45, 1e-38, 1e-30];
    for k in 0..120 {
        let o = in_box(r, Vec3::new(-4.0, -4.0, 0.1), Vec3::new(4.0, 4.0, 3.5));
        let mut d = unit(r);
        let a = k % 3;
        d[a] = tiny[k % tiny.len()];
        if k % 5 == 0 {
            // Two tiny components: almost exactly axis-parallel.
            d[(a + 1) % 3] = tiny[(k + 1) % tiny.len()];
        }
        rays.push(Ray::new(o, d));
    }
    // Signed zeros: every axis direction with ±0 on the others, through the sphere and box.
    for k in 0..96 {
        let a = k % 3;
        let s = if (k / 3) % 2 == 0 { 1.0 } else { -1.0 };
        let mut d = Vec3::ZERO;
        d[a] = s;
        for b in 0..3 {
            if b != a && (k / 6) & (1 << b) != 0 {
                d[b] = -0.0;
            }
        }
        let mut o = if k % 2 == 0 {
            in_box(r, Vec3::new(-0.8, -0.8, 1.2), Vec3::new(0.8, 0.8, 2.8))
        } else {
            Vec3::new(
                2.0 + r.gen_range(0..=4) as f32 * 0.25,
                2.0 + r.gen_range(0..=4) as f32 * 0.25,
                r.gen_range(0..=4) as f32 * 0.25,
            )
        };
        o[a] -= 6.0 * s;
        rays.push(Ray::new(o, d));
    }
    // Unnormalised directions scaled by 1e-20 .. 1e20 (t scales inversely).
    for k in 0..100 {
        let t = in_box(r, Vec3::new(-0.5, -0.5, 1.5), Vec3::new(0.5, 0.5, 2.5));
        let o = t + unit(r) * 4.0;
        let Some(ray) = aim(o, t) else { continue };
        let s = [1e-20f32, 1e-10, 1e10, 1e20][k % 4];
        rays.push(Ray::new(ray.origin, ray.dir * s));
    }
}

/// Origins inside the sphere, on its vertices and far away.
fn origin_rays(r: &mut Pcg64, rays: &mut Vec<Ray>) {
    // Origins inside the sphere and on sphere vertices (t = 0 hits).
    let sph = icosphere(2);
    for k in 0..80 {
        let o = if k % 2 == 0 {
            in_box(r, Vec3::splat(-0.5), Vec3::splat(0.5)) + Vec3::new(0.0, 0.0, 2.0)
        } else {
            sph.v[r.gen_range(0..sph.v.len())] + Vec3::new(0.0, 0.0, 2.0)
        };
        rays.push(Ray::new(o, unit(r)));
    }
    // Far origins (1e8 .. 1e20) aimed at the scene: positions lose all precision.
    for k in 0..40 {
        let dist = [1e8f32, 1e12, 1e16, 1e20][k % 4];
        let t = in_box(r, Vec3::new(-1.0, -1.0, 1.0), Vec3::new(1.0, 1.0, 3.0));
        rays.extend(aim(t + unit(r) * dist, t));
    }
}
