//! Ray batches: generated once per scene and kind, with fixed seeds, so that every structure
//! traces exactly the same rays.
//!
//! Kinds ([`RayKind`]):
//! - `primary`: one ray per camera pixel, in [`Camera::pixels`] order ([`primary`]);
//! - `shadow`: one any-hit segment per primary hit towards a point light ([`shadow`]);
//! - `ao`: `samples` cosine-distributed any-hit segments per hit, of length `distance` ([`ao`]);
//! - `path1`, `path2`, …: one diffuse continuation per hit of the previous bounce, implicit
//!   path tracing without light sampling, as in the multi-kd-tree paper ([`bounce`]);
//! - `random`: origin uniform in the scene bounds, direction uniform on the sphere, the
//!   irregular-grid paper's "Random" rays ([`random`]);
//! - `stress`: a stress scene's own rays ([`crate::Scene::own_rays`]).
//!
//! Determinism: every random ray takes its numbers from its own `Pcg64`, seeded from the batch
//! seed, a per-kind tag and the index of the ray (or of the hit it continues) through a
//! SplitMix64 mix ([`ray_rng`]). The output depends on nothing else: not on thread count, not on
//! the order rays are generated in.
//!
//! Secondary origins: the hit point is recomputed from the barycentrics of the hit triangle,
//! `(1−u−v)·v0 + u·v1 + v·v2` (its error is relative to the vertex coordinates, unlike
//! `origin + t·dir` whose error grows with the ray's length), then pushed off the surface
//! along the geometric normal facing the incoming ray with [`offset_origin_scaled`]
//! (Wächter and Binder's integer-ulp offset), so secondary rays use `tmin = 0`.

use crate::camera::Camera;
use rand::Rng;
use rand_pcg::Pcg64;
use std::f32::consts::PI;
use tb_core::tri::facing_normal;
use tb_core::{Aabb, Accel, HitRecord, Query, Ray, TriTestKind, Triangle, Vec3};

/// What a batch of rays is, and what a config's `scene.rays` names (the one ray-kind type of
/// the project: configs, the runner's batches, the conformance suite).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum RayKind {
    /// One ray per pixel from the camera, through the pixel centre.
    Primary,
    /// From the primary hits towards the scene's point light (any hit).
    Shadow,
    /// Ambient-occlusion rays from the primary hits, within the AO distance (any hit).
    Ao,
    /// Path-tracing bounce number (1-based): `Path(1)` continues the primary hits. A config's
    /// `path` is [`RayKind::PATH`], the first bounce; the runner makes the bounces after it
    /// up to the scene's `path.bounces`.
    Path(u32),
    /// Origins uniform in the scene's bounds, directions uniform on the sphere.
    Random,
    /// A stress scene's own rays (named `stress`).
    Stress,
}

impl RayKind {
    /// The path-tracing rays as a config names them (`path`): the first bounce.
    pub const PATH: RayKind = RayKind::Path(1);

    /// The names a config's `scene.rays` takes, in the order of [`RayKind::parse`]'s kinds.
    pub const NAMES: [&'static str; 6] = ["primary", "shadow", "ao", "path", "random", "stress"];

    /// The kind a config's `scene.rays` entry names ([`RayKind::NAMES`]; `path` is
    /// [`RayKind::PATH`]), or `None`.
    pub fn parse(name: &str) -> Option<RayKind> {
        Some(match name {
            "primary" => RayKind::Primary,
            "shadow" => RayKind::Shadow,
            "ao" => RayKind::Ao,
            "path" => RayKind::PATH,
            "random" => RayKind::Random,
            "stress" => RayKind::Stress,
            _ => return None,
        })
    }

    /// The kind's name in results: `primary`, `shadow`, `ao`, `path1`, `path2`, …, `random`,
    /// `stress`.
    pub fn name(&self) -> String {
        match self {
            RayKind::Primary => "primary".into(),
            RayKind::Shadow => "shadow".into(),
            RayKind::Ao => "ao".into(),
            RayKind::Path(k) => format!("path{k}"),
            RayKind::Random => "random".into(),
            RayKind::Stress => "stress".into(),
        }
    }

    /// The query the kind asks: any-hit for shadow and AO rays, closest-hit otherwise.
    pub fn query(&self) -> Query {
        match self {
            RayKind::Shadow | RayKind::Ao => Query::Any,
            _ => Query::Closest,
        }
    }
}

/// A batch of rays of one kind.
#[derive(Clone, Debug)]
pub struct RayBatch {
    /// What the rays are.
    pub kind: RayKind,
    /// The rays, in generation order.
    pub rays: Vec<Ray>,
}

/// Per-kind tags mixed into the seeds, so that e.g. AO and bounce rays of the same hit with the
/// same batch seed are independent.
const TAG_AO: u64 = 0x414f;
const TAG_BOUNCE: u64 = 0x424f_554e_4345;
const TAG_RANDOM: u64 = 0x5241_4e44_4f4d;

/// SplitMix64 finaliser (Steele, Lea and Flood 2014).
fn splitmix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// The generator of ray (or hit) number `index` of a batch: `Pcg64` whose 128-bit state and
/// stream are SplitMix64 mixes of `(seed, tag, index)`. Deterministic and independent of the
/// order in which indices are visited.
pub fn ray_rng(seed: u64, tag: u64, index: u64) -> Pcg64 {
    let a = splitmix64(seed ^ splitmix64(tag));
    let b = splitmix64(a ^ splitmix64(index.wrapping_add(0x51ed_270b)));
    let c = splitmix64(b ^ 0x2545_f491_4f6c_dd1d);
    let d = splitmix64(c.wrapping_add(index));
    Pcg64::new(
        ((b as u128) << 64) | c as u128,
        ((d as u128) << 64) | a as u128,
    )
}

/// Primary rays: one per pixel, in `camera.pixels()` order, through the pixel centre
/// ([`Camera::ray`]).
pub fn primary(camera: &Camera) -> Vec<Ray> {
    camera
        .pixels()
        .into_iter()
        .map(|(x, y)| camera.ray(x, y))
        .collect()
}

/// The hit point from barycentrics, the geometric normal facing against `ray.dir`, and the
/// robustly offset origin: `(origin, normal)`. `None` for a miss or a hit on a degenerate
/// triangle. Integrators (tb-render) continue paths from it exactly as the batches here do.
pub fn hit_frame(tris: &[Triangle], ray: &Ray, hit: &HitRecord) -> Option<(Vec3, Vec3)> {
    if !hit.is_hit() {
        return None;
    }
    let tri = tris.get(hit.prim as usize)?;
    let n = facing_normal(tri, ray.dir);
    if n == Vec3::ZERO || !n.is_finite() {
        return None;
    }
    let p = hit_point(tri, hit);
    if !p.is_finite() {
        return None;
    }
    Some((offset_origin_scaled(p, n, tri_scale(tri)), n))
}

/// The hit point `(1−u−v)·v0 + u·v1 + v·v2` of `hit` on `tri`.
pub fn hit_point(tri: &Triangle, hit: &HitRecord) -> Vec3 {
    let w = 1.0 - hit.u - hit.v;
    w * tri.v0 + hit.u * tri.v1 + hit.v * tri.v2
}

/// The magnitude of the coordinates a hit on `tri` is computed from: the largest `|v_i[a]|`
/// over all vertices and axes, the same on every axis.
///
/// Not per axis: the error of the next ray's intersection test against the same triangle
/// grows with all of its coordinates (the watertight test shears every vertex by the ray
/// direction), so a huge flat ground triangle at `y ≈ 0` needs a y-offset scaled by its x/z
/// extent. With a per-axis scale such origins started ~1e-7 above a 16,700-unit ground triangle
/// of `builtin:teapot-stadium`, and brute force reported spurious self-hits at `t < 0.01`
/// outside the triangle's bounding box.
pub fn tri_scale(tri: &Triangle) -> Vec3 {
    let m = tri.v0.abs().max(tri.v1.abs()).max(tri.v2.abs());
    Vec3::splat(m.max_element().max(f32::MIN_POSITIVE))
}

/// Shadow rays: one per hit, from the offset hit point towards `light`, `tmin = 0`,
/// `tmax` = distance to the light, direction normalised. Misses are skipped, and so are hits
/// where the light is at distance 0 from the offset origin. Rays are any-hit queries.
pub fn shadow(tris: &[Triangle], rays: &[Ray], hits: &[HitRecord], light: Vec3) -> Vec<Ray> {
    assert_eq!(rays.len(), hits.len(), "one hit record per ray");
    let mut out = Vec::with_capacity(rays.len());
    for (ray, hit) in rays.iter().zip(hits) {
        let Some((o, _)) = hit_frame(tris, ray, hit) else {
            continue;
        };
        let to = light - o;
        let dist = tb_core::geom::length(to);
        if !(dist > 0.0 && dist.is_finite()) {
            continue;
        }
        let dir = to / dist;
        if dir == Vec3::ZERO || !dir.is_finite() {
            continue;
        }
        out.push(Ray::segment(o, dir, 0.0, dist));
    }
    out
}

/// Ambient-occlusion rays: `samples` cosine-distributed directions about the geometric normal
/// facing the incoming ray, per hit (in hit order, samples consecutive), from the offset hit
/// point, over `[0, distance)`. Misses are skipped. Rays are any-hit queries.
pub fn ao(
    tris: &[Triangle],
    rays: &[Ray],
    hits: &[HitRecord],
    samples: u32,
    distance: f32,
    seed: u64,
) -> Vec<Ray> {
    assert_eq!(rays.len(), hits.len(), "one hit record per ray");
    let mut out = Vec::with_capacity(rays.len() * samples as usize);
    for (i, (ray, hit)) in rays.iter().zip(hits).enumerate() {
        let Some((o, n)) = hit_frame(tris, ray, hit) else {
            continue;
        };
        let mut rng = ray_rng(seed, TAG_AO, i as u64);
        for _ in 0..samples {
            out.push(Ray::segment(
                o,
                cosine_direction(n, &mut rng),
                0.0,
                distance,
            ));
        }
    }
    out
}

/// One diffuse bounce per hit: a cosine-distributed direction about the facing geometric
/// normal, from the offset hit point, over `[0, inf)`. Implicit path tracing (no light
/// sampling), as in the multi-kd-tree paper: the caller traces bounce `k` (closest hit) and
/// passes its rays and hits here to make bounce `k + 1`; use a different `seed` per bounce.
/// Misses are skipped.
pub fn bounce(tris: &[Triangle], rays: &[Ray], hits: &[HitRecord], seed: u64) -> Vec<Ray> {
    assert_eq!(rays.len(), hits.len(), "one hit record per ray");
    let mut out = Vec::with_capacity(rays.len());
    for (i, (ray, hit)) in rays.iter().zip(hits).enumerate() {
        let Some((o, n)) = hit_frame(tris, ray, hit) else {
            continue;
        };
        let mut rng = ray_rng(seed, TAG_BOUNCE, i as u64);
        out.push(Ray::new(o, cosine_direction(n, &mut rng)));
    }
    out
}

/// Random rays (the irregular-grid paper's "Random"): origin uniform in `bounds`, direction
/// uniform on the unit sphere, `tmin = 0`, `tmax = inf`. An empty `bounds` puts every origin at
/// the world origin.
pub fn random(bounds: &Aabb, count: usize, seed: u64) -> Vec<Ray> {
    let b = if bounds.is_empty() {
        Aabb::new(Vec3::ZERO, Vec3::ZERO)
    } else {
        *bounds
    };
    let e = b.extent();
    (0..count)
        .map(|i| {
            let mut rng = ray_rng(seed, TAG_RANDOM, i as u64);
            let u = Vec3::new(rng.gen(), rng.gen(), rng.gen());
            // Clamp: `min + e·u` may round past `max`.
            let origin = (b.min + e * u).clamp(b.min, b.max);
            let z = 1.0 - 2.0 * rng.gen::<f32>();
            let phi = 2.0 * PI * rng.gen::<f32>();
            let r = (1.0 - z * z).max(0.0).sqrt();
            let dir = Vec3::new(r * phi.cos(), r * phi.sin(), z).normalize();
            Ray::new(origin, dir)
        })
        .collect()
}

/// Orthonormal basis `(b1, b2)` completing the unit vector `n` (Duff, Burgess, Christensen,
/// Hery, Kensler, Liani and Villemin 2017, "Building an Orthonormal Basis, Revisited", JCGT
/// 6(1), Listing 3).
pub fn orthonormal_basis(n: Vec3) -> (Vec3, Vec3) {
    let sign = 1.0f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (
        Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        Vec3::new(b, sign + n.y * n.y * a, -n.y),
    )
}

/// A cosine-distributed unit direction about the unit normal `n` (Malley's method: a uniform
/// point on the unit disk by Shirley and Chiu's concentric map, lifted to the hemisphere).
pub fn cosine_direction(n: Vec3, rng: &mut Pcg64) -> Vec3 {
    let a = 2.0 * rng.gen::<f32>() - 1.0;
    let b = 2.0 * rng.gen::<f32>() - 1.0;
    let (x, y) = if a == 0.0 && b == 0.0 {
        (0.0, 0.0)
    } else if a.abs() > b.abs() {
        let phi = (PI / 4.0) * (b / a);
        (a * phi.cos(), a * phi.sin())
    } else {
        let phi = PI / 2.0 - (PI / 4.0) * (a / b);
        (b * phi.cos(), b * phi.sin())
    };
    let z = (1.0 - x * x - y * y).max(0.0).sqrt();
    let (b1, b2) = orthonormal_basis(n);
    let d = (x * b1 + y * b2 + z * n).normalize();
    if d.is_finite() && d != Vec3::ZERO {
        d
    } else {
        n
    }
}

/// Wächter and Binder's constants (Ray Tracing Gems, ch. 6, Listing 6-1).
const OFFSET_ORIGIN: f32 = 1.0 / 32.0;
const OFFSET_FLOAT_SCALE: f32 = 1.0 / 65536.0;
const OFFSET_INT_SCALE: f32 = 256.0;

/// Robust secondary-ray origin: Wächter and Binder 2019, "A Fast and Robust Method for Avoiding
/// Self-Intersection" (Ray Tracing Gems, ch. 6), verbatim.
///
/// Each coordinate of the hit point `p` moves along the unit normal `n` by
/// `int_scale · n[a] = 256 · n[a]` units in the last place of `p[a]` (an integer offset on the
/// bit pattern), so the offset is relative to the magnitude of the coordinate: the same
/// 256-ulp step protects a surface at `1e6` as one at `1`, where a fixed epsilon would be far
/// too small at `1e6` (self-intersection) and far too large near `1e-6` (light leaking).
/// Coordinates closer to 0 than `origin = 1/32`, whose ulps are tiny compared with the error of
/// a point computed from larger vertex coordinates, move by the absolute
/// `float_scale · n[a] = n[a] / 65536` instead. Secondary rays then start at `tmin = 0`.
///
/// The fallback makes this version tuned for scenes of size about 1: in a scene of size `1e-6`
/// near the origin every coordinate takes the absolute offset of `1.5e-5`, far off the surface.
/// Generators therefore use [`offset_origin_scaled`] with the hit triangle's magnitude, which
/// equals this function for triangles of size 1 and scales both fallback constants with the
/// geometry.
pub fn offset_origin(p: Vec3, n: Vec3) -> Vec3 {
    offset_origin_scaled(p, n, Vec3::ONE)
}

/// [`offset_origin`] with the fallback threshold and absolute offset scaled per axis by
/// `scale[a]`, the magnitude of the coordinates the point was computed from (for a hit point,
/// [`tri_scale`]: the largest `|v_i[a]|` of the triangle): coordinates with
/// `|p[a]| < scale[a] / 32` move by `scale[a] · n[a] / 65536`, all others by `256 · n[a]` ulps.
/// With `scale = 1` this is Wächter and Binder's method exactly; scaling keeps it
/// scale-independent at `1e-6` (a tiny scene gets a tiny fallback) and at `1e6` (a coordinate
/// near 0 on a huge triangle, whose error is an ulp of `1e6`, gets a large one). `scale[a]`
/// must be positive.
pub fn offset_origin_scaled(p: Vec3, n: Vec3, scale: Vec3) -> Vec3 {
    let mut out = p;
    for a in 0..3 {
        let s = scale[a];
        if p[a].abs() < OFFSET_ORIGIN * s {
            out[a] = p[a] + OFFSET_FLOAT_SCALE * s * n[a];
        } else {
            let of_i = (OFFSET_INT_SCALE * n[a]) as i32;
            let bits = p[a].to_bits() as i32;
            let moved = if p[a] < 0.0 {
                bits.wrapping_sub(of_i)
            } else {
                bits.wrapping_add(of_i)
            };
            out[a] = f32::from_bits(moved as u32);
        }
    }
    out
}

/// Trace `rays` with traversal 0 of `accel` ([`tb_core::par`]) and return the hits.
pub fn trace_all(
    accel: &dyn Accel,
    query: Query,
    tri: TriTestKind,
    rays: &[Ray],
) -> Vec<HitRecord> {
    tb_core::par::trace(accel, 0, query, tri, rays)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::PixelOrder;
    use tb_core::BruteForce;

    fn camera() -> Camera {
        Camera {
            eye: Vec3::new(0.0, 0.0, 5.0),
            target: Vec3::ZERO,
            up: Vec3::Y,
            fov: 60.0,
            width: 7,
            height: 5,
            order: PixelOrder::Morton,
        }
    }

    fn quad(s: f32) -> Vec<Triangle> {
        let (a, b, c, d) = (
            Vec3::new(-s, -s, 0.0),
            Vec3::new(s, -s, 0.0),
            Vec3::new(s, s, 0.0),
            Vec3::new(-s, s, 0.0),
        );
        vec![Triangle::new(a, b, c), Triangle::new(a, c, d)]
    }

    #[test]
    fn primary_count_and_order() {
        let c = camera();
        let r = primary(&c);
        assert_eq!(r.len(), 35);
        let (x, y) = c.pixels()[3];
        assert_eq!(r[3], c.ray(x, y));
    }

    #[test]
    fn random_rays_in_bounds_and_unit() {
        let b = Aabb::new(Vec3::new(-1.0, 2.0, 3.0), Vec3::new(0.0, 2.5, 10.0));
        let r = random(&b, 1000, 7);
        assert_eq!(r.len(), 1000);
        for ray in &r {
            assert!(b.min.cmple(ray.origin).all() && ray.origin.cmple(b.max).all());
            assert!((ray.dir.length() - 1.0).abs() < 1e-5);
            assert_eq!((ray.tmin, ray.tmax), (0.0, f32::INFINITY));
        }
        // Directions cover the sphere: mean close to 0.
        let m = r.iter().map(|r| r.dir).sum::<Vec3>() / r.len() as f32;
        assert!(m.length() < 0.1, "{m}");
        // Flat bounds keep origins in the plane.
        let f = Aabb::new(Vec3::ZERO, Vec3::new(1.0, 1.0, 0.0));
        assert!(random(&f, 100, 1).iter().all(|r| r.origin.z == 0.0));
    }

    #[test]
    fn ao_in_hemisphere_with_cosine_mean() {
        let tris = quad(10.0);
        let bf = BruteForce::new(&tris);
        // Rays hitting the quad from above and from below.
        let rays: Vec<Ray> = (0..50)
            .map(|i| {
                let z = if i % 2 == 0 { 3.0 } else { -3.0 };
                Ray::new(
                    Vec3::new(i as f32 * 0.1 - 2.5, 0.3, z),
                    Vec3::new(0.1, 0.0, -z).normalize(),
                )
            })
            .collect();
        let hits = trace_all(&bf, Query::Closest, TriTestKind::Watertight, &rays);
        assert!(hits.iter().all(|h| h.is_hit()));
        let ao_rays = ao(&tris, &rays, &hits, 64, 0.5, 3);
        assert_eq!(ao_rays.len(), 50 * 64);
        let mut sum = 0.0f64;
        for (k, r) in ao_rays.iter().enumerate() {
            let n = if (k / 64) % 2 == 0 { Vec3::Z } else { -Vec3::Z };
            let c = r.dir.dot(n);
            assert!(c >= 0.0, "ray {k} below the surface");
            assert!((r.dir.length() - 1.0).abs() < 1e-5);
            assert_eq!((r.tmin, r.tmax), (0.0, 0.5));
            assert!(r.origin.dot(n) > 0.0, "origin on the wrong side");
            sum += c as f64;
        }
        let mean = sum / ao_rays.len() as f64;
        assert!((mean - 2.0 / 3.0).abs() < 0.02, "mean cos {mean}");
        // AO rays starting off the surface do not see it again.
        let occl = trace_all(&bf, Query::Any, TriTestKind::Watertight, &ao_rays);
        assert!(occl.iter().all(|h| !h.is_hit()));
        // Bounces likewise.
        let b = bounce(&tris, &rays, &hits, 4);
        assert_eq!(b.len(), 50);
        let bh = trace_all(&bf, Query::Closest, TriTestKind::Watertight, &b);
        assert!(bh.iter().all(|h| !h.is_hit()));
        // Shadow rays towards a light above: the lit side is unoccluded, the other is not.
        let s = shadow(&tris, &rays, &hits, Vec3::new(0.0, 0.0, 4.0));
        assert_eq!(s.len(), 50);
        let sh = trace_all(&bf, Query::Any, TriTestKind::Watertight, &s);
        for (i, h) in sh.iter().enumerate() {
            assert_eq!(h.is_hit(), i % 2 == 1, "shadow ray {i}");
        }
    }

    #[test]
    fn offset_leaves_surface_on_the_right_side_at_all_scales() {
        for &scale in &[1e-6f32, 1.0, 1e6] {
            for &offset in &[0.0f32, 1.0, -3.0] {
                // A tilted triangle at `scale`, translated by `offset · scale`.
                let t0 = Triangle::new(
                    Vec3::new(0.1, -0.7, 0.3),
                    Vec3::new(1.3, 0.2, -0.4),
                    Vec3::new(-0.6, 0.9, 0.8),
                );
                let tri = Triangle::new(
                    (t0.v0 + offset) * scale,
                    (t0.v1 + offset) * scale,
                    (t0.v2 + offset) * scale,
                );
                let tris = [tri];
                let bf = BruteForce::new(&tris);
                let n = tri.normal().normalize();
                let mut rng = ray_rng(9, 9, 9);
                for i in 0..200 {
                    let (u, v): (f32, f32) = (rng.gen(), rng.gen());
                    let (u, v) = if u + v > 1.0 {
                        (1.0 - u, 1.0 - v)
                    } else {
                        (u, v)
                    };
                    let target = (1.0 - u - v) * tri.v0 + u * tri.v1 + v * tri.v2;
                    let side = if i % 2 == 0 { n } else { -n };
                    let dir = (-side + 0.3 * cosine_direction(side, &mut rng)).normalize();
                    let ray = Ray::new(target - dir * 2.0 * scale, dir);
                    let hits = trace_all(&bf, Query::Closest, TriTestKind::Watertight, &[ray]);
                    if !hits[0].is_hit() {
                        continue;
                    }
                    let p = hit_point(&tri, &hits[0]);
                    let fac = facing_normal(&tri, ray.dir);
                    for o in [
                        offset_origin_scaled(p, fac, tri_scale(&tri)),
                        offset_origin(p, fac),
                    ] {
                        // Exact side test in f64.
                        let d = (o.as_dvec3() - tri.v0.as_dvec3())
                            .dot(tri.normal().as_dvec3().normalize());
                        assert!(
                            d * fac.as_dvec3().dot(tri.normal().as_dvec3()) > 0.0,
                            "scale {scale} offset {offset}: origin on the wrong side"
                        );
                    }
                    // Rays leaving into the facing hemisphere do not hit the triangle again,
                    // and the scaled offset stays close to the surface.
                    let o = offset_origin_scaled(p, fac, tri_scale(&tri));
                    assert!((o - p).length() < 1e-3 * scale * 3.0);
                    for k in 0..8 {
                        let r = Ray::new(o, cosine_direction(fac, &mut ray_rng(i, k, 1)));
                        let h = trace_all(&bf, Query::Any, TriTestKind::Watertight, &[r]);
                        assert!(!h[0].is_hit(), "self-intersection at scale {scale}");
                    }
                }
            }
        }
        // Coordinates near zero take the absolute fallback.
        let o = offset_origin(Vec3::ZERO, Vec3::Z);
        assert_eq!(o, Vec3::new(0.0, 0.0, 1.0 / 65536.0));
        let o = offset_origin(Vec3::new(-0.0, 1.0, -1.0), -Vec3::Z);
        assert!(o.z < -1.0 && o.y == 1.0);
    }

    #[test]
    fn generation_is_deterministic() {
        let b = Aabb::new(Vec3::ZERO, Vec3::ONE);
        assert_eq!(random(&b, 300, 5), random(&b, 300, 5));
        assert_ne!(random(&b, 300, 5), random(&b, 300, 6));
        // Generating a prefix gives the same rays.
        assert_eq!(random(&b, 10, 5)[..], random(&b, 300, 5)[..10]);
        let tris = quad(1.0);
        let rays = primary(&camera());
        let hits = trace_all(
            &BruteForce::new(&tris),
            Query::Closest,
            TriTestKind::Watertight,
            &rays,
        );
        assert_eq!(
            ao(&tris, &rays, &hits, 4, 1.0, 11),
            ao(&tris, &rays, &hits, 4, 1.0, 11)
        );
        assert_eq!(
            bounce(&tris, &rays, &hits, 2),
            bounce(&tris, &rays, &hits, 2)
        );
        assert_ne!(
            bounce(&tris, &rays, &hits, 2),
            bounce(&tris, &rays, &hits, 3)
        );
    }

    #[test]
    fn kind_names_and_queries() {
        assert_eq!(RayKind::Path(2).name(), "path2");
        assert_eq!(RayKind::Stress.name(), "stress");
        for name in RayKind::NAMES {
            let k = RayKind::parse(name).expect("a config name parses");
            assert_eq!(k.name(), if name == "path" { "path1" } else { name });
        }
        assert_eq!(RayKind::parse("path2"), None);
        assert_eq!(RayKind::Shadow.query(), Query::Any);
        assert_eq!(RayKind::Ao.query(), Query::Any);
        assert_eq!(RayKind::Random.query(), Query::Closest);
    }
}
