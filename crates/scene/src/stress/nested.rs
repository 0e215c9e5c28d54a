//! `stress/nested`: a cluster nested inside copies of itself scaled by 1000 and 1e6 ("San
//! Miguel inside San Miguel").

use super::common::{aim, camera_view, in_box, range, rng, unit, Generated, ViewFn};
use super::mesh::{grid_box, icosphere, quad_grid, Mesh};
use crate::error::SceneError;
use crate::procedural::{BuiltinInfo, Params};
use rand::Rng;
use tb_core::{Aabb, Ray, Vec3};

/// The listing entry of `builtin:stress/nested`.
pub(super) const INFO: BuiltinInfo = BuiltinInfo {
    name: "stress/nested",
    doc: "a cluster nested in copies of itself scaled by `ratio` (San Miguel inside San Miguel); rays from inside the smallest copy, between copies and from outside",
    params: &[
        "seed=1: random seed",
        "levels=3: number of copies (1..=4)",
        "ratio=1000: scale between copies (ratio^(levels-1) <= 1e12)",
    ],
};

/// Read `levels` (1..=4) and `ratio` (at least 4, `ratio^(levels-1)` at most 1e12) and generate.
pub(super) fn load(seed: u64, params: &Params) -> Result<Generated, SceneError> {
    let levels = params.u32("levels", 3)?;
    let ratio = params.f32("ratio", 1000.0)?;
    params.check((1..=4).contains(&levels), "levels must be in 1..=4")?;
    params.check(
        ratio >= 4.0 && (ratio as f64).powi(levels as i32 - 1) <= 1e12,
        "ratio must be at least 4 and ratio^(levels-1) at most 1e12",
    )?;
    Ok(generate(seed, levels, ratio))
}

/// A cluster with an empty centre (radius 0.3), nested in copies scaled by `ratio^k`.
pub(super) fn generate(seed: u64, levels: u32, ratio: f32) -> Generated {
    let mut r = rng(seed, 6);
    let mut cluster = icosphere(2).map(|p| p * 0.25 + Vec3::new(0.5, 0.1, -0.2));
    cluster.append(&grid_box(
        Vec3::new(-0.8, -0.2, 0.1),
        Vec3::new(-0.4, 0.3, 0.5),
        2,
    ));
    cluster.append(&grid_box(
        Vec3::new(-0.6, -0.9, -0.6),
        Vec3::new(0.6, -0.85, 0.6),
        1,
    ));
    cluster.append(&quad_grid(2, -0.7, (-0.7, -0.7), (0.7, 0.7), 4));
    let scales: Vec<f32> = (0..levels).map(|k| ratio.powi(k as i32)).collect();
    let mut m = Mesh::default();
    for &s in &scales {
        m.append(&cluster.map(|p| p * s));
    }
    let mut rays = Vec::new();
    // From inside the smallest copy's empty centre, and from each gap between copies.
    for _ in 0..300 {
        let o = in_box(&mut r, Vec3::splat(-0.2), Vec3::splat(0.2));
        rays.push(Ray::new(o, unit(&mut r)));
    }
    for w in scales.windows(2) {
        for _ in 0..200 {
            let o = unit(&mut r) * range(&mut r, 1.5 * w[0], 0.25 * w[1]);
            rays.push(Ray::new(o, unit(&mut r)));
        }
    }
    // From outside the largest copy, and from each gap, aimed at vertices of every copy.
    let smax = *scales.last().unwrap();
    for k in 0..500 {
        let level = k % scales.len();
        let t = cluster.v[r.gen_range(0..cluster.v.len())] * scales[level];
        let from = if k % 2 == 0 {
            3.0 * smax
        } else {
            range(&mut r, 1.5, 4.0) * scales[level]
        };
        rays.extend(aim(t + unit(&mut r) * from, t));
    }
    // The camera sits in the gap around the middle copy.
    let mid = scales[scales.len() / 2];
    let view: ViewFn = Box::new(move |_b: &Aabb| {
        camera_view(
            Vec3::new(0.35, 0.2, 1.2) * mid,
            Vec3::ZERO,
            Vec3::new(0.2, 1.5, 0.4) * mid,
            0.1 * mid,
        )
    });
    (m.tris(), rays, view)
}
