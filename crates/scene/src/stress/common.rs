//! Building blocks of the stress scenes: the seeded generator and its samplers (ranges,
//! unit vectors, points in a box, directions entering a surface, in a plane or along an axis),
//! rays aimed at a target, and the view every scene gets.

use crate::camera::Camera;
use crate::camera::PixelOrder;
use crate::rays::ray_rng;
use crate::scene::View;
use rand::Rng;
use rand_pcg::Pcg64;
use tb_core::geom::unit as unit_vec;
use tb_core::{Aabb, Ray, Triangle, Vec3};

/// What a stress generator returns: triangles, own rays (before [`super::valid_ray`]
/// filtering) and the view, a function of the scene's bounds.
pub(super) type Generated = (Vec<Triangle>, Vec<Ray>, ViewFn);

/// A scene's default view as a function of its bounds.
pub(super) type ViewFn = Box<dyn Fn(&Aabb) -> View>;

/// The view every stress scene gets: given the bounds, a camera looking at the centre from
/// `from` (a direction), a light and an AO distance proportional to the diagonal.
pub(super) fn view_from(from: Vec3) -> ViewFn {
    Box::new(move |b: &Aabb| {
        let c = b.center();
        let d = b.diagonal().max(f32::MIN_POSITIVE);
        let eye = c + from.normalize() * (0.8 * d);
        camera_view(
            eye,
            c,
            c + Vec3::new(0.35, 1.0, 0.6).normalize() * d,
            0.05 * d,
        )
    })
}

/// A 32x32 camera (row order, 50° field of view) from `eye` to `target`, with a point light at
/// `light`; up is `Y` unless the view is within ~18° of vertical, then `Z`.
pub(super) fn camera_view(eye: Vec3, target: Vec3, light: Vec3, ao_distance: f32) -> View {
    let f = unit_vec(target - eye);
    let up = if f.dot(Vec3::Y).abs() > 0.95 {
        Vec3::Z
    } else {
        Vec3::Y
    };
    View {
        camera: Camera {
            eye,
            target,
            up,
            fov: 50.0,
            width: 32,
            height: 32,
            order: PixelOrder::Row,
        },
        light: Some(light),
        ao_distance,
    }
}

/// The generator of one stress scene: the crate's [`ray_rng`] stream for `seed`, told apart
/// per scene by `tag`.
pub(super) fn rng(seed: u64, tag: u64) -> Pcg64 {
    ray_rng(seed, 0x5354_5245_5353 ^ tag, 0)
}

/// Uniform between `lo` and `hi`.
pub(super) fn range(r: &mut Pcg64, lo: f32, hi: f32) -> f32 {
    lo + (hi - lo) * r.gen::<f32>()
}

/// Uniform on the unit sphere.
pub(super) fn unit(r: &mut Pcg64) -> Vec3 {
    let z = 1.0 - 2.0 * r.gen::<f32>();
    let phi = std::f32::consts::TAU * r.gen::<f32>();
    let s = (1.0 - z * z).max(0.0).sqrt();
    Vec3::new(s * phi.cos(), s * phi.sin(), z)
}

/// Uniform in the box.
pub(super) fn in_box(r: &mut Pcg64, lo: Vec3, hi: Vec3) -> Vec3 {
    Vec3::new(
        range(r, lo.x, hi.x),
        range(r, lo.y, hi.y),
        range(r, lo.z, hi.z),
    )
}

/// A ray from `origin` through `target` (normalised direction), or `None` if they coincide.
pub(super) fn aim(origin: Vec3, target: Vec3) -> Option<Ray> {
    let d = unit_vec(target - origin);
    (d != Vec3::ZERO && d.is_finite()).then(|| Ray::new(origin, d))
}

/// A unit direction entering a surface with outward unit normal `n`: `-n` tilted by at most
/// `atan(tilt)`.
pub(super) fn entering(r: &mut Pcg64, n: Vec3, tilt: f32) -> Vec3 {
    let w = unit(r);
    let w = (w - n * w.dot(n)) * (tilt * r.gen::<f32>());
    (-n + w).normalize()
}

/// The unit vector along `axis` with sign `s` (a signed zero on the others when `s < 0` is
/// not wanted: plain zeros).
pub(super) fn axis_dir(axis: usize, s: f32) -> Vec3 {
    let mut d = Vec3::ZERO;
    d[axis] = s;
    d
}

/// A random direction with component `axis` exactly `+0.0` or `-0.0`.
pub(super) fn in_plane_dir(r: &mut Pcg64, axis: usize) -> Vec3 {
    let mut d = unit(r);
    d[axis] = 0.0;
    let mut d = d.normalize_or_zero();
    if d == Vec3::ZERO {
        d = axis_dir((axis + 1) % 3, 1.0);
    }
    if r.gen::<bool>() {
        d[axis] = -0.0;
    }
    d
}
