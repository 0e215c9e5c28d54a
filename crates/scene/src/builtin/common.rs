//! Helpers shared by the procedural generators.

use super::MAX_TRIANGLES;
use crate::camera::Camera;
use crate::camera::PixelOrder;
use crate::error::SceneError;
use crate::procedural::Params;
use crate::scene::Scene;
use crate::scene::View;
use tb_core::{Triangle, Vec3};

/// Default resolution of the built-in cameras.
pub(super) const RESOLUTION: u32 = 256;

/// AO distance as a fraction of the bounding-box diagonal.
pub(super) const AO_FRACTION: f32 = 0.04;

/// Refuse a triangle count above [`MAX_TRIANGLES`]; `formula` says how it was computed.
pub(super) fn budget(params: &Params, count: u64, formula: &str) -> Result<(), SceneError> {
    params.check(
        count <= MAX_TRIANGLES,
        &format!(
            "{formula} = {count} triangles, more than the limit of {MAX_TRIANGLES} (lower the size parameter)"
        ),
    )
}

/// A pinhole camera at the default resolution, row order.
pub(super) fn camera(eye: Vec3, target: Vec3, up: Vec3, fov: f32) -> Camera {
    Camera {
        eye,
        target,
        up,
        fov,
        width: RESOLUTION,
        height: RESOLUTION,
        order: PixelOrder::Row,
    }
}

/// A scene with its default view (AO distance from the bounds).
pub(super) fn scene(
    name: &str,
    triangles: Vec<Triangle>,
    camera: Camera,
    light: Option<Vec3>,
) -> Scene {
    let mut s = Scene::from_triangles(format!("builtin:{name}"), triangles);
    s.view = Some(View {
        camera,
        light,
        ao_distance: AO_FRACTION * s.bounds.diagonal(),
    });
    s
}

/// Quad `a b c d` (in order around it) as triangles `a b c` and `a c d`.
pub(super) fn quad(out: &mut Vec<Triangle>, a: Vec3, b: Vec3, c: Vec3, d: Vec3) {
    out.push(Triangle::new(a, b, c));
    out.push(Triangle::new(a, c, d));
}

/// Saturating `base^exp` in `u64`, for triangle-count formulas.
pub(super) fn pow(base: u64, exp: u32) -> u64 {
    base.saturating_pow(exp)
}
