//! The Cornell box.
//!
//! The classic simplified dimensions (room 0..555 on every axis, Y up, open towards −Z; as in
//! the Cornell Program of Computer Graphics data and Shirley's "Ray Tracing: The Next Week"):
//! floor, ceiling, back, left and right walls (10 triangles), the ceiling light
//! 213..343 x 227..332 one unit below the ceiling (2 triangles), a short block of 165³ rotated
//! by −18° and a tall block of 165x330x165 rotated by 15° about Y, each with its 5 visible faces
//! (20 triangles). 32 triangles in all.

use super::common::{camera, quad, scene};
use crate::error::SceneError;
use crate::procedural::Params;
use crate::scene::Scene;
use tb_core::{Triangle, Vec3};

/// A block standing on the floor: `size`, rotated by `degrees` about Y around its corner at the
/// origin, then moved by `offset`; 5 faces (no bottom).
fn block(out: &mut Vec<Triangle>, size: Vec3, degrees: f32, offset: Vec3) {
    let (s, c) = degrees.to_radians().sin_cos();
    let p = |x: f32, y: f32, z: f32| {
        let (x, y, z) = (x * size.x, y * size.y, z * size.z);
        Vec3::new(c * x + s * z, y, -s * x + c * z) + offset
    };
    let (b0, b1, b2, b3) = (p(0., 0., 0.), p(1., 0., 0.), p(1., 0., 1.), p(0., 0., 1.));
    let (t0, t1, t2, t3) = (p(0., 1., 0.), p(1., 1., 0.), p(1., 1., 1.), p(0., 1., 1.));
    quad(out, t0, t1, t2, t3); // top
    quad(out, b0, b1, t1, t0); // front (z = 0 side)
    quad(out, b1, b2, t2, t1);
    quad(out, b2, b3, t3, t2);
    quad(out, b3, b0, t0, t3);
}

/// `builtin:cornell?scale=S`.
pub(super) fn cornell(params: &Params) -> Result<Scene, SceneError> {
    let scale = params.f32("scale", 1.0)?;
    params.check(
        scale > 0.0 && scale <= 1e6,
        "parameter `scale` must be in (0, 1e6]",
    )?;
    let v = |x: f32, y: f32, z: f32| Vec3::new(x, y, z);
    let mut t = Vec::with_capacity(32);
    let w = 555.0;
    quad(
        &mut t,
        v(0., 0., 0.),
        v(w, 0., 0.),
        v(w, 0., w),
        v(0., 0., w),
    ); // floor
    quad(&mut t, v(0., w, 0.), v(0., w, w), v(w, w, w), v(w, w, 0.)); // ceiling
    quad(&mut t, v(0., 0., w), v(w, 0., w), v(w, w, w), v(0., w, w)); // back wall
    quad(&mut t, v(w, 0., 0.), v(w, w, 0.), v(w, w, w), v(w, 0., w)); // left wall (x = 555)
    quad(
        &mut t,
        v(0., 0., 0.),
        v(0., 0., w),
        v(0., w, w),
        v(0., w, 0.),
    ); // right wall (x = 0)
    let ly = 554.0;
    quad(
        &mut t,
        v(213., ly, 227.),
        v(343., ly, 227.),
        v(343., ly, 332.),
        v(213., ly, 332.),
    ); // area light
    block(&mut t, Vec3::splat(165.0), -18.0, v(130., 0., 65.));
    block(&mut t, v(165., 330., 165.), 15.0, v(265., 0., 295.));

    for tri in &mut t {
        *tri = Triangle::new(tri.v0 * scale, tri.v1 * scale, tri.v2 * scale);
    }
    let cam = camera(
        v(278., 278., -800.) * scale,
        v(278., 278., 0.) * scale,
        Vec3::Y,
        40.0,
    );
    let light = v(278., 553., 279.5) * scale;
    Ok(scene("cornell", t, cam, Some(light)))
}
