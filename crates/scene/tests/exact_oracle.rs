//! The oracle against an independent one in f64: on the Cornell box's
//! primary, shadow, AO and path rays, brute force with the watertight test reports no hit the
//! f64 computation puts behind the origin or outside the triangle, and where it reports a
//! miss although f64 finds a hit well inside a triangle, that hit is within the conservative
//! `t` bound's reach of the origin (a corner's neighbouring wall): at most
//! [`LOST_T_SHARE`] of the scene's diagonal away, and at most [`LOST_RAYS`] of the rays.

use std::path::Path;
use tb_core::{BruteForce, Ray, TriTestKind, Triangle};
use tb_scene::conformance::batches;

/// The farthest a rejected true hit may be, as a share of the scene's diagonal.
const LOST_T_SHARE: f64 = 1e-5;
/// The share of rays that may lose a true hit that close.
const LOST_RAYS: f64 = 1e-3;

/// Möller–Trumbore in f64 from the f32 vertices: `(t, smallest barycentric)`, or `None` when
/// the ray is parallel to the plane.
fn exact(tri: &Triangle, r: &Ray) -> Option<(f64, f64)> {
    let d = |v: tb_core::Vec3| v.as_dvec3();
    let (v0, v1, v2) = (d(tri.v0), d(tri.v1), d(tri.v2));
    let (o, dir) = (d(r.origin), d(r.dir));
    let (e1, e2) = (v1 - v0, v2 - v0);
    let p = dir.cross(e2);
    let det = e1.dot(p);
    if det == 0.0 {
        return None;
    }
    let s = o - v0;
    let u = s.dot(p) / det;
    let q = s.cross(e1);
    let v = dir.dot(q) / det;
    Some((e2.dot(q) / det, u.min(v).min(1.0 - u - v)))
}

#[test]
fn oracle_agrees_with_f64_on_the_cornell_box() {
    let scene = tb_scene::load("builtin:cornell", Path::new(".")).unwrap();
    let diag = scene.bounds.diagonal() as f64;
    let oracle = BruteForce::new(&scene.triangles);
    let (mut rays, mut lost) = (0usize, 0usize);
    for b in batches(&scene, TriTestKind::Watertight) {
        let hits =
            tb_core::par::trace(&oracle, 0, b.kind.query(), TriTestKind::Watertight, &b.rays);
        for (r, h) in b.rays.iter().zip(&hits) {
            rays += 1;
            if h.is_hit() {
                let (t, m) =
                    exact(&scene.triangles[h.prim as usize], r).expect("hit on a parallel plane");
                assert!(
                    t > 0.0 && m > -1e-5,
                    "{:?}: {r:?} hit {h:?}, f64: t {t}, barycentric {m}",
                    b.kind
                );
                continue;
            }
            // The closest f64 hit well inside a triangle, in the ray's interval.
            let best = scene
                .triangles
                .iter()
                .filter_map(|t| exact(t, r))
                .filter(|&(t, m)| m > 1e-6 && t > 0.0 && t >= r.tmin as f64 && t < r.tmax as f64)
                .map(|(t, _)| t)
                .fold(f64::INFINITY, f64::min);
            if best.is_finite() {
                lost += 1;
                assert!(
                    best <= LOST_T_SHARE * diag,
                    "{:?}: {r:?} misses a hit at t {best}",
                    b.kind
                );
            }
        }
    }
    println!("{rays} rays, {lost} true hits within the t bound rejected");
    assert!(
        rays > 100_000 && (lost as f64) <= LOST_RAYS * rays as f64,
        "{lost} of {rays}"
    );
}
