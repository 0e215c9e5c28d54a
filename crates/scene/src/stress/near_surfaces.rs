//! `stress/near-surfaces`: rays that start on, a few ulps beside and inside the mesh's
//! triangles, on its boxes' faces and in the axis planes through its vertices (where kd-trees
//! and grids put their split planes and cell walls), in every direction, at scale `scale`
//! (1e-30 to 1e30). The property test on them: every structure x traversal, with both
//! triangle tests, answers these as the oracle does, and no answer is a hit behind the origin
//! (the triangle tests' conservative `t`).

use super::common::{in_box, rng, unit, view_from, Generated};
use super::transformed::small_mesh;
use crate::error::SceneError;
use crate::procedural::{BuiltinInfo, Params};
use rand::Rng;
use rand_pcg::Pcg64;
use tb_core::{Ray, Vec3};

/// The listing entry of `builtin:stress/near-surfaces`.
pub(super) const INFO: BuiltinInfo = BuiltinInfo {
    name: "stress/near-surfaces",
    doc: "the mesh of stress/translated scaled by `scale`; rays starting on, a few ulps off and inside its triangles, on box faces and in the axis planes through its vertices, in all directions",
    params: &["seed=1: random seed", "scale=1: scale factor (1e-30 to 1e30)"],
};

/// Rays per kind of start.
const RAYS_PER_KIND: usize = 600;

/// Read `scale` (in `[1e-30, 1e30]`) and generate.
pub(super) fn load(seed: u64, params: &Params) -> Result<Generated, SceneError> {
    let scale = params.f32("scale", 1.0)?;
    params.check(
        scale > 0.0 && (1e-30..=1e30).contains(&scale),
        "scale must be in [1e-30, 1e30]",
    )?;
    Ok(generate(seed, scale))
}

/// `x` moved by `ulps` units in the last place (towards +inf for positive `ulps` where `x > 0`).
fn nudge(x: f32, ulps: i32) -> f32 {
    if ulps == 0 || !x.is_finite() {
        return x;
    }
    let mut y = x;
    for _ in 0..ulps.unsigned_abs() {
        y = if ulps > 0 { y.next_up() } else { y.next_down() };
    }
    y
}

/// `p` with each coordinate moved by -4 to 4 ulps.
fn jitter(r: &mut Pcg64, p: Vec3) -> Vec3 {
    Vec3::new(
        nudge(p.x, r.gen_range(-4..=4)),
        nudge(p.y, r.gen_range(-4..=4)),
        nudge(p.z, r.gen_range(-4..=4)),
    )
}

fn generate(seed: u64, scale: f32) -> Generated {
    let mut r = rng(seed, 0x4e53);
    let m = small_mesh().map(|p| p * scale);
    let tris = m.tris();
    let lo =
        m.v.iter()
            .fold(Vec3::splat(f32::INFINITY), |a, &b| a.min(b));
    let hi =
        m.v.iter()
            .fold(Vec3::splat(f32::NEG_INFINITY), |a, &b| a.max(b));
    let mut rays = Vec::new();
    let mut push = |o: Vec3, d: Vec3| {
        if d != Vec3::ZERO && d.is_finite() && o.is_finite() {
            rays.push(Ray::new(o, d));
        }
    };
    // On (rounded), beside (a few ulps) and inside (barycentric interior) triangles.
    for k in 0..RAYS_PER_KIND {
        let t = tris[r.gen_range(0..tris.len())];
        let (mut u, mut v) = (r.gen::<f32>(), r.gen::<f32>());
        if u + v > 1.0 {
            (u, v) = (1.0 - u, 1.0 - v);
        }
        let p = t.v0 * (1.0 - u - v) + t.v1 * u + t.v2 * v;
        let o = if k % 3 == 0 { p } else { jitter(&mut r, p) };
        push(o, unit(&mut r));
    }
    // On vertices and edges (shared by neighbours), a few ulps off.
    for _ in 0..RAYS_PER_KIND / 2 {
        let t = tris[r.gen_range(0..tris.len())];
        let p = if r.gen::<bool>() {
            t.v0
        } else {
            (t.v1 + t.v2) * 0.5
        };
        push(jitter(&mut r, p), unit(&mut r));
    }
    // In the axis planes through vertices (split planes, box faces, cell walls): one
    // coordinate a vertex's (exactly or a few ulps off), the others anywhere in the bounds.
    for k in 0..RAYS_PER_KIND {
        let a = k % 3;
        let c = m.v[r.gen_range(0..m.v.len())][a];
        let mut o = in_box(&mut r, lo, hi);
        o[a] = if k % 2 == 0 {
            c
        } else {
            nudge(c, r.gen_range(-4..=4))
        };
        let mut d = unit(&mut r);
        if k % 5 == 0 {
            // Lying in the plane.
            d[a] = 0.0;
        }
        push(o, d);
    }
    (tris, rays, view_from(Vec3::new(0.5, 0.6, 1.0)))
}
