//! Random triangle soup.

use super::common::{budget, camera, scene};
use super::MAX_TRIANGLES;
use crate::error::SceneError;
use crate::procedural::Params;
use crate::scene::Scene;
use rand::{Rng, SeedableRng};
use tb_core::{Triangle, Vec3};

/// `builtin:soup?count=N&size=S&seed=X`: `count` triangles; each has its three vertices
/// uniform in a cube of edge `size` around a centre uniform in `[size/2, 1 − size/2]³`, so the
/// whole soup lies in the unit cube.
pub(super) fn soup(params: &Params) -> Result<Scene, SceneError> {
    let count = params.u64("count", 10_000)?;
    let size = params.f32("size", 0.05)?;
    let seed = params.u64("seed", 1)?;
    params.check(count >= 1, "parameter `count` must be at least 1")?;
    budget(params, count, &format!("count={count}"))?;
    debug_assert!(count <= MAX_TRIANGLES);
    params.check(
        size > 0.0 && size <= 1.0,
        "parameter `size` must be in (0, 1]",
    )?;

    let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
    let half = 0.5 * size;
    let mut tris = Vec::with_capacity(count as usize);
    for _ in 0..count {
        let c = Vec3::new(
            half + rng.gen::<f32>() * (1.0 - size),
            half + rng.gen::<f32>() * (1.0 - size),
            half + rng.gen::<f32>() * (1.0 - size),
        );
        let mut vertex = || {
            let o = Vec3::new(rng.gen::<f32>(), rng.gen::<f32>(), rng.gen::<f32>()) - 0.5;
            (c + o * size).clamp(Vec3::ZERO, Vec3::ONE)
        };
        let (a, b, d) = (vertex(), vertex(), vertex());
        tris.push(Triangle::new(a, b, d));
    }
    let cam = camera(Vec3::new(2.0, 1.6, 2.4), Vec3::splat(0.5), Vec3::Y, 40.0);
    Ok(scene("soup", tris, cam, Some(Vec3::new(1.5, 3.0, 2.0))))
}
