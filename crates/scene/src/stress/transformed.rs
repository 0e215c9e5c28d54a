//! `stress/translated`: a small mesh translated by `offset` (1e6); `stress/scaled-tiny`,
//! `stress/scaled-huge`: the same mesh scaled by `scale` (1e-6, 1e6).

use super::common::{aim, in_box, range, rng, unit, view_from, Generated};
use super::mesh::{grid_box, icosphere, quad_grid, Mesh};
use crate::error::SceneError;
use crate::procedural::{BuiltinInfo, Params};
use rand::Rng;
use rand_pcg::Pcg64;
use tb_core::Vec3;

/// The listing entry of `builtin:stress/translated`.
pub(super) const TRANSLATED: BuiltinInfo = BuiltinInfo {
    name: "stress/translated",
    doc:
        "a small mesh (icosphere, boxes, ground) translated by `offset` on all axes, with its rays",
    params: &[
        "seed=1: random seed",
        "offset=1000000: translation on x, y and z",
    ],
};

/// The listing entry of `builtin:stress/scaled-tiny`.
pub(super) const SCALED_TINY: BuiltinInfo = BuiltinInfo {
    name: "stress/scaled-tiny",
    doc: "the mesh of stress/translated scaled by `scale` about the origin",
    params: &["seed=1: random seed", "scale=0.000001: scale factor"],
};

/// The listing entry of `builtin:stress/scaled-huge`.
pub(super) const SCALED_HUGE: BuiltinInfo = BuiltinInfo {
    name: "stress/scaled-huge",
    doc: "the mesh of stress/translated scaled by `scale` about the origin",
    params: &["seed=1: random seed", "scale=1000000: scale factor"],
};

/// `stress/translated`: read `offset` (|offset| at most 1e30) and generate.
pub(super) fn translated(seed: u64, params: &Params) -> Result<Generated, SceneError> {
    let offset = params.f32("offset", 1e6)?;
    params.check(offset.abs() <= 1e30, "offset must be at most 1e30")?;
    Ok(generate(seed, 1.0, Vec3::splat(offset)))
}

/// `stress/scaled-tiny` and `stress/scaled-huge`: read `scale` (in `[1e-30, 1e30]`, `default`
/// when absent) and generate.
pub(super) fn scaled(seed: u64, params: &Params, default: f32) -> Result<Generated, SceneError> {
    let scale = params.f32("scale", default)?;
    params.check(
        scale > 0.0 && (1e-30..=1e30).contains(&scale),
        "scale must be in [1e-30, 1e30]",
    )?;
    Ok(generate(seed, scale, Vec3::ZERO))
}

/// The mesh of `translated`/`scaled-*` in its own frame: an icosphere, three boxes and a
/// ground grid, about 600 triangles in `[-2, 2]³`.
pub(super) fn small_mesh() -> Mesh {
    let mut m = icosphere(2).map(|p| p * 0.8 + Vec3::new(0.3, 0.0, -0.2));
    m.append(&grid_box(
        Vec3::new(-1.8, -1.0, -1.5),
        Vec3::new(-0.9, 0.5, -0.4),
        2,
    ));
    m.append(&grid_box(
        Vec3::new(1.2, -1.0, 0.6),
        Vec3::new(1.9, 1.7, 1.3),
        1,
    ));
    m.append(&grid_box(
        Vec3::new(-1.5, -1.0, 0.9),
        Vec3::new(-0.2, -0.6, 1.8),
        1,
    ));
    m.append(&quad_grid(1, -1.0, (-2.0, -2.0), (2.0, 2.0), 8));
    m
}

/// Rays for `small_mesh` in its frame: (origin, target) pairs at vertices and random surface
/// points, and random rays from inside the bounds.
fn small_mesh_rays(r: &mut Pcg64, m: &Mesh) -> Vec<(Vec3, Vec3)> {
    let mut out = Vec::new();
    for i in (0..m.v.len()).step_by(2) {
        let t = m.v[i];
        out.push((t + unit(r) * range(r, 1.0, 5.0), t));
    }
    for _ in 0..400 {
        let f = m.f[r.gen_range(0..m.f.len())];
        let (mut u, mut v) = (r.gen::<f32>(), r.gen::<f32>());
        if u + v > 1.0 {
            (u, v) = (1.0 - u, 1.0 - v);
        }
        let t =
            m.v[f[0] as usize] * (1.0 - u - v) + m.v[f[1] as usize] * u + m.v[f[2] as usize] * v;
        out.push((t + unit(r) * range(r, 1.0, 5.0), t));
    }
    for _ in 0..200 {
        let o = in_box(r, Vec3::splat(-2.0), Vec3::splat(2.0));
        out.push((o, o + unit(r)));
    }
    out
}

/// `small_mesh` mapped by `p·scale + offset`; rays aimed at the mapped targets.
pub(super) fn generate(seed: u64, scale: f32, offset: Vec3) -> Generated {
    let mut r = rng(seed, 5);
    let base = small_mesh();
    let pairs = small_mesh_rays(&mut r, &base);
    let f = |p: Vec3| p * scale + offset;
    let m = base.map(f);
    let rays = pairs
        .into_iter()
        .filter_map(|(o, t)| aim(f(o), f(t)))
        .collect();
    (m.tris(), rays, view_from(Vec3::new(0.5, 0.6, 1.0)))
}
