//! `stress/plane-origins`: a lattice of boxes whose faces are split planes; origins exactly in
//! those planes, on their edges and corners, directions with and without a normal component
//! (review §3.1, §3.2).

use super::common::{axis_dir, in_box, in_plane_dir, rng, unit, view_from, Generated};
use super::mesh::{grid_box, Mesh};
use crate::procedural::BuiltinInfo;
use rand::Rng;
use tb_core::{Ray, Vec3};

/// The listing entry of `builtin:stress/plane-origins`.
pub(super) const INFO: BuiltinInfo = BuiltinInfo {
    name: "stress/plane-origins",
    doc: "a 3x3x3 lattice of unit boxes whose faces become split planes; ray origins exactly in those planes (on faces and in the gaps, on edges and corners) with tmin = 0, directions with a non-zero (also at every binary scale down to the smallest subnormal), a signed-zero and an axis-parallel normal component",
    params: &["seed=1: random seed"],
};

/// Review §3.1 (Hapala and Havran 2011: a ray origin embedded in a splitting plane) and §3.2
/// (the origin-classified traversal fails there, Havran et al. 1997): a 3x3x3 lattice of unit
/// boxes `[2i, 2i + 1]³` (faces in 2x2 quads), so the integer coordinates 0..=5 become split
/// planes, and every ray starts (`tmin = 0`) exactly in one of them: on a box face (a hit at
/// `t = 0`), in the gap between boxes, on a cell edge or corner (two or three planes), with a
/// random direction whose normal component is non-zero (either sign, also tiny), exactly `±0`
/// (the ray lies in the plane: review §3.1's zero-extent case), or axis-parallel along the
/// normal or along the plane (along cell faces and edges). Then, for a direction component
/// below the normal range (`1/d` overflows to `±inf` and `0 · inf` is NaN at the plane),
/// rays from the same kinds of origins whose normal component is `±2^-e` for every `e` from
/// 0 to 149 (the smallest subnormal) and `1e-38` and `1e-40` (the values the fault was found at),
/// the rest of the direction in the plane: unnormalised, so the tiny component is exact.
pub(super) fn generate(seed: u64) -> Generated {
    let mut r = rng(seed, 9);
    let mut m = Mesh::default();
    for k in 0..27u32 {
        let lo = Vec3::new(
            2.0 * (k % 3) as f32,
            2.0 * (k / 3 % 3) as f32,
            2.0 * (k / 9) as f32,
        );
        m.append(&grid_box(lo, lo + Vec3::ONE, 2));
    }
    let tris = m.tris();
    let (lo, hi) = (Vec3::splat(-1.0), Vec3::splat(6.0));
    let mut rays = Vec::new();
    for a in 0..3 {
        for c in 0..=5 {
            for k in 0..48u32 {
                let mut o = in_box(&mut r, lo, hi);
                o[a] = c as f32;
                // In one plane, on a cell edge (two planes) or on a corner (three): the other
                // coordinates snapped onto planes too.
                let (u, v) = ((a + 1) % 3, (a + 2) % 3);
                if k / 16 >= 1 {
                    o[u] = r.gen_range(0..=5) as f32;
                }
                if k / 16 == 2 {
                    o[v] = r.gen_range(0..=5) as f32;
                }
                let s = if k / 8 % 2 == 0 { 1.0 } else { -1.0 };
                let d = match k % 8 {
                    // The normal component non-zero, of either sign.
                    0..=2 => {
                        let mut d = unit(&mut r);
                        d[a] = s * d[a].abs().max(0.05);
                        d
                    }
                    // A tiny normal component: leaves the plane at a grazing angle.
                    3 => {
                        let mut d = in_plane_dir(&mut r, a);
                        d[a] = s * 1e-6;
                        d
                    }
                    // Lying in the plane.
                    4 | 5 => in_plane_dir(&mut r, a),
                    // Axis-parallel along the normal.
                    6 => axis_dir(a, s),
                    // Axis-parallel along the plane: along a cell face (or edge when snapped).
                    _ => axis_dir(if r.gen::<bool>() { u } else { v }, s),
                };
                rays.push(Ray::new(o, d));
            }
        }
    }
    rays.extend(tiny_normal_components(&mut r, lo, hi));
    (tris, rays, view_from(Vec3::new(-0.7, 0.5, 1.0)))
}

/// Origins in a lattice plane (on a face, in a gap, on an edge or a corner) and a
/// direction whose normal component is tiny, at every binary scale down to the smallest
/// subnormal (`2^-149`), of both signs: the ray leaves the plane to the side of its sign, so
/// a traversal must treat the plane's distance as `0`, not as "the ray lies in the plane".
fn tiny_normal_components(r: &mut rand_pcg::Pcg64, lo: Vec3, hi: Vec3) -> Vec<Ray> {
    // 2^-e exactly: a normal number's exponent field, then a subnormal's single bit.
    let pow2 = |e: u32| {
        f32::from_bits(if e <= 126 {
            (127 - e) << 23
        } else {
            1 << (149 - e)
        })
    };
    let mut scales: Vec<f32> = (0..=149).map(pow2).collect();
    scales.extend([1e-38, 1e-40]);
    let mut rays = Vec::new();
    for (i, &m) in scales.iter().enumerate() {
        for s in [1.0f32, -1.0] {
            let a = i % 3;
            let mut o = in_box(r, lo, hi);
            o[a] = r.gen_range(0..=5) as f32;
            let (u, v) = ((a + 1) % 3, (a + 2) % 3);
            // Face or gap (one plane), edge (two), corner (three), by turns.
            if i % 4 >= 2 {
                o[u] = r.gen_range(0..=5) as f32;
            }
            if i % 4 == 3 {
                o[v] = r.gen_range(0..=5) as f32;
            }
            let mut d = in_plane_dir(r, a);
            d[a] = s * m;
            assert!(d[a] != 0.0, "2^-e is representable down to e = 149");
            rays.push(Ray::new(o, d));
        }
    }
    rays
}
