//! `stress/axis-planes`: axis-aligned walls and boxes; rays lying in their planes and in future
//! split planes, axis-parallel rays through box edges and corners.

use super::common::{axis_dir, in_box, in_plane_dir, rng, view_from, Generated};
use super::mesh::{grid_box, quad_grid, Mesh};
use crate::procedural::BuiltinInfo;
use rand::Rng;
use rand_pcg::Pcg64;
use tb_core::{Aabb, Ray, Triangle, Vec3};

/// The listing entry of `builtin:stress/axis-planes`.
pub(super) const INFO: BuiltinInfo = BuiltinInfo {
    name: "stress/axis-planes",
    doc: "axis-aligned walls and boxes; rays lying exactly in their planes and in future split planes (vertex coordinates, box faces, bin boundaries), axis-parallel rays through box edges and corners, signed-zero directions",
    params: &["seed=1: random seed"],
};

/// Axis-aligned walls (9 planes, 8x8 grids of half-unit quads) and 8 unit boxes in `[0, 8]³`.
pub(super) fn generate(seed: u64) -> Generated {
    let mut r = rng(seed, 1);
    let mut m = Mesh::default();
    let mut walls = Vec::new();
    for a in 0..3 {
        for c in [2.0f32, 4.0, 6.0] {
            m.append(&quad_grid(a, c, (c - 2.0, c - 2.0), (c + 2.0, c + 2.0), 8));
            walls.push((a, c));
        }
    }
    let mut boxes = Vec::new();
    for k in 0..8u32 {
        let lo = Vec3::new(
            0.5 + 4.0 * (k & 1) as f32,
            0.5 + 4.0 * ((k >> 1) & 1) as f32,
            0.5 + 4.0 * ((k >> 2) & 1) as f32,
        );
        let hi = lo + Vec3::splat(if k == 7 { 1.25 } else { 1.0 });
        m.append(&grid_box(lo, hi, 1));
        boxes.push((lo, hi));
    }
    let tris = m.tris();
    let (lo, hi) = (Vec3::splat(-1.0), Vec3::splat(9.0));
    let mut rays = Vec::new();
    wall_rays(&mut r, &walls, (lo, hi), &mut rays);
    split_plane_rays(&mut r, &tris, (lo, hi), &mut rays);
    box_rays(&boxes, &mut rays);
    (tris, rays, view_from(Vec3::new(-0.6, 0.45, 1.0)))
}

/// Rays lying exactly in the wall planes (origin on the plane, that component of the
/// direction ±0), and exact axis-parallel rays through the walls' grid vertices; origins in
/// the box `lo..hi`.
fn wall_rays(r: &mut Pcg64, walls: &[(usize, f32)], (lo, hi): (Vec3, Vec3), rays: &mut Vec<Ray>) {
    for &(a, c) in walls {
        for k in 0..24 {
            let mut o = in_box(r, lo, hi);
            o[a] = c;
            let d = if k < 4 {
                axis_dir((a + 1 + k % 2) % 3, if k < 2 { 1.0 } else { -1.0 })
            } else {
                in_plane_dir(r, a)
            };
            rays.push(Ray::new(o, d));
        }
        for _ in 0..16 {
            let (u, v) = ((a + 1) % 3, (a + 2) % 3);
            let mut o = Vec3::ZERO;
            o[u] = c - 2.0 + 0.5 * r.gen_range(0..=8) as f32;
            o[v] = c - 2.0 + 0.5 * r.gen_range(0..=8) as f32;
            let s = if r.gen::<bool>() { 1.0 } else { -1.0 };
            o[a] = c - 3.0 * s;
            rays.push(Ray::new(o, axis_dir(a, s)));
        }
    }
}

/// Future split planes: every distinct vertex coordinate (where SAH builders split), the
/// centre (spatial median) and bin boundaries of 8, 16 and 32 bins (binned builders); rays
/// lying in them from origins in the box `lo..hi`.
fn split_plane_rays(r: &mut Pcg64, tris: &[Triangle], (lo, hi): (Vec3, Vec3), rays: &mut Vec<Ray>) {
    let bounds = tris.iter().fold(Aabb::EMPTY, |b, t| b.union(&t.bounds()));
    for a in 0..3 {
        let mut planes: Vec<f32> = tris
            .iter()
            .flat_map(|t| [t.v0[a], t.v1[a], t.v2[a]])
            .collect();
        planes.push(bounds.center()[a]);
        for bins in [8u32, 16, 32] {
            let w = bounds.extent()[a] / bins as f32;
            planes.extend((1..bins).map(|k| bounds.min[a] + w * k as f32));
        }
        planes.sort_by(f32::total_cmp);
        planes.dedup();
        for c in planes {
            for _ in 0..3 {
                let mut o = in_box(r, lo, hi);
                o[a] = c;
                rays.push(Ray::new(o, in_plane_dir(r, a)));
            }
        }
    }
}

/// Axis-parallel rays through box edges and corners.
fn box_rays(boxes: &[(Vec3, Vec3)], rays: &mut Vec<Ray>) {
    for &(blo, bhi) in boxes {
        let corner = |bits: u32| {
            Vec3::new(
                if bits & 1 == 0 { blo.x } else { bhi.x },
                if bits & 2 == 0 { blo.y } else { bhi.y },
                if bits & 4 == 0 { blo.z } else { bhi.z },
            )
        };
        for bits in 0..8u32 {
            let p = corner(bits);
            // Outward signs at this corner.
            let s = Vec3::new(
                if bits & 1 == 0 { -1.0 } else { 1.0 },
                if bits & 2 == 0 { -1.0 } else { 1.0 },
                if bits & 4 == 0 { -1.0 } else { 1.0 },
            );
            // Along each edge line through the corner, from outside: lies in two face planes,
            // meets the third face exactly at the corner.
            for a in 0..3 {
                let d = axis_dir(a, -s[a]);
                let mut o = p;
                o[a] += 2.0 * s[a];
                rays.push(Ray::new(o, d));
                // Perpendicular to the edge along axis `a`, through its midpoint: lies in one
                // face plane, meets the other face exactly on the edge.
                for b in [(a + 1) % 3, (a + 2) % 3] {
                    let mut o = p;
                    o[a] = 0.5 * (blo[a] + bhi[a]);
                    o[b] += 2.0 * s[b];
                    rays.push(Ray::new(o, axis_dir(b, -s[b])));
                }
            }
            // Diagonal, exact (unnormalised) direction into the corner.
            rays.push(Ray::new(p + 2.0 * s, -s));
        }
    }
}
