//! Stiff and extreme scenes for numerical checks, `builtin:stress/NAME`, each with its own rays.
//!
//! Every scene is small (at most a few thousand triangles) so that brute force over all its
//! rays is fast in tests, comes with a default [`View`](crate::View) (a 32x32 camera, a point
//! light and an AO distance, so that the ordinary ray kinds can be generated for it too) and
//! with its own closest-hit rays ([`Scene::own_rays`], traced as kind `stress`), built to
//! provoke the case the scene is about. Own rays always have finite origins, a finite non-zero
//! direction and `0 <= tmin <= tmax`; most directions are normalised, but some are deliberately
//! not (exact axis-aligned and diagonal directions, scaled directions, denormal components).
//!
//! All generation is deterministic: parameter `seed` (default 1) seeds a `Pcg64`.
//!
//! | name | case |
//! |------|------|
//! | `axis-planes` | axis-aligned walls and boxes; rays lying in their planes and in future split planes, axis-parallel rays through box edges and corners |
//! | `flat` | a scene of zero thickness (all triangles in `z = 0`); head-on, grazing and in-plane rays |
//! | `slivers` | aspect-ratio-1e6 slivers and needles, zero-area triangles, a fan of thin triangles |
//! | `watertight` | closed meshes; rays aimed exactly at shared vertices and edges (all must hit with the watertight test) |
//! | `translated` | a small mesh translated by `offset` (1e6) |
//! | `scaled-tiny`, `scaled-huge` | the same mesh scaled by `scale` (1e-6, 1e6) |
//! | `nested` | a cluster nested inside copies of itself scaled by 1000 and 1e6 |
//! | `ray-limits` | origins on surfaces with `tmin = 0`, `tmax` exactly at a hit, huge and empty intervals, denormal, signed-zero and scaled directions |
//! | `duplicates` | identical, permuted, coplanar-overlapping and co-centred triangles (ties, unsplittable clusters) |
//! | `plane-origins` | a lattice of boxes whose faces are split planes; origins exactly in those planes, on their edges and corners, directions with and without a normal component, the normal component at every binary scale down to the smallest subnormal (both signs) |
//! | `near-surfaces` | rays starting on, a few ulps off and inside triangles, on box faces and in the axis planes through vertices, in all directions, at `scale` 1e-30 to 1e30 (the property test) |
//! | `thin-layers` | coplanar layers one ulp apart at coordinates ~1e6; rays crossing many one-ulp cells, grazing them and lying in them |
//!
//! Each scene has its own file (its [`BuiltinInfo`], parameter checks and generator); what they
//! share is in `common` (seeded sampling, aimed rays, the view) and `mesh` (indexed meshes with
//! shared vertices: icosphere, closed box, grid of quads).

mod axis_planes;
mod common;
mod duplicates;
mod flat;
mod mesh;
mod near_surfaces;
mod nested;
mod plane_origins;
mod ray_limits;
mod slivers;
mod thin_layers;
mod transformed;
mod watertight;

use crate::error::SceneError;
use crate::procedural::{BuiltinInfo, Params};
use crate::scene::Scene;
use tb_core::{Ray, Vec3};

/// The stress scenes.
pub const LIST: &[BuiltinInfo] = &[
    axis_planes::INFO,
    flat::INFO,
    slivers::INFO,
    watertight::INFO,
    transformed::TRANSLATED,
    transformed::SCALED_TINY,
    transformed::SCALED_HUGE,
    nested::INFO,
    ray_limits::INFO,
    duplicates::INFO,
    plane_origins::INFO,
    thin_layers::INFO,
    near_surfaces::INFO,
];

/// Load stress scene `name` (the part after `stress/`).
pub fn load(name: &str, params: &Params) -> Result<Scene, SceneError> {
    let seed = params.u64("seed", 1)?;
    let (tris, mut rays, view) = match name {
        "axis-planes" => axis_planes::generate(seed),
        "flat" => flat::load(seed, params)?,
        "slivers" => slivers::generate(seed),
        "watertight" => watertight::generate(seed),
        "translated" => transformed::translated(seed, params)?,
        "scaled-tiny" => transformed::scaled(seed, params, 1e-6)?,
        "scaled-huge" => transformed::scaled(seed, params, 1e6)?,
        "nested" => nested::load(seed, params)?,
        "ray-limits" => ray_limits::generate(seed),
        "duplicates" => duplicates::generate(seed),
        "plane-origins" => plane_origins::generate(seed),
        "thin-layers" => thin_layers::load(seed, params)?,
        "near-surfaces" => near_surfaces::load(seed, params)?,
        _ => {
            return Err(SceneError::Builtin {
                spec: format!("stress/{name}"),
                message: format!(
                    "unknown stress scene `{name}` (run `trace-bench scenes` for the list)"
                ),
            })
        }
    };
    rays.retain(valid_ray);
    let mut scene = Scene::from_triangles(format!("builtin:stress/{name}"), tris);
    scene.own_rays = rays;
    scene.view = Some(view(&scene.bounds));
    Ok(scene)
}

/// Finite origin and direction, non-zero direction, `0 <= tmin <= tmax` (tmax may be inf).
pub fn valid_ray(r: &Ray) -> bool {
    r.origin.is_finite()
        && r.dir.is_finite()
        && r.dir != Vec3::ZERO
        && r.tmin.is_finite()
        && r.tmin >= 0.0
        && !r.tmax.is_nan()
        && r.tmin <= r.tmax
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unknown_scene_is_an_error() {
        let (_, p) = Params::parse("stress/nope").unwrap();
        assert!(load("nope", &p).is_err());
    }
}
