//! Ray–triangle tests, selectable per experiment (`triangle_test` in a config).
//!
//! Both are behind the [`TriTest`] trait so that traversal kernels are monomorphised for one
//! test: the per-ray set-up ([`TriTest::prepare`]) is done once per ray, not once per triangle.

use crate::geom::{Ray, Triangle, Vec3};
use serde::{Deserialize, Serialize};

/// Which triangle test a run uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize, PartialOrd, Ord)]
#[serde(rename_all = "kebab-case")]
pub enum TriTestKind {
    /// Woop, Benthin and Wald 2013: watertight, no gaps or double hits on shared edges.
    Watertight,
    /// Möller and Trumbore 1997: fast, but rays through shared edges and vertices may slip
    /// through (reported, not hidden, by the stress scenes).
    MollerTrumbore,
}

impl TriTestKind {
    pub const ALL: [TriTestKind; 2] = [TriTestKind::Watertight, TriTestKind::MollerTrumbore];

    pub fn name(self) -> &'static str {
        match self {
            TriTestKind::Watertight => "watertight",
            TriTestKind::MollerTrumbore => "moller-trumbore",
        }
    }

    pub fn from_name(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.name() == s)
    }
}

/// A ray–triangle intersection test.
pub trait TriTest: Send + Sync + 'static {
    /// Per-ray precomputed data.
    type Pre: Copy;
    /// Set-up once per ray.
    fn prepare(ray: &Ray) -> Self::Pre;
    /// Intersect the triangle with the ray, accepting `t` in `[ray.tmin, tmax)`. Returns
    /// `(t, u, v)` with `u, v` the barycentrics of `v1`, `v2`.
    fn intersect(pre: &Self::Pre, ray: &Ray, tri: &Triangle, tmax: f32) -> Option<(f32, f32, f32)>;
}

/// Möller–Trumbore 1997, "Fast, minimum storage ray-triangle intersection", two-sided.
pub struct MollerTrumbore;

impl TriTest for MollerTrumbore {
    type Pre = ();

    #[inline(always)]
    fn prepare(_ray: &Ray) -> Self::Pre {}

    #[inline(always)]
    fn intersect(_: &(), ray: &Ray, tri: &Triangle, tmax: f32) -> Option<(f32, f32, f32)> {
        let e1 = tri.v1 - tri.v0;
        let e2 = tri.v2 - tri.v0;
        let p = ray.dir.cross(e2);
        let det = e1.dot(p);
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let inv = 1.0 / det;
        let s = ray.origin - tri.v0;
        let u = s.dot(p) * inv;
        if !(0.0..=1.0).contains(&u) {
            return None;
        }
        let q = s.cross(e1);
        let v = ray.dir.dot(q) * inv;
        if v < 0.0 || u + v > 1.0 {
            return None;
        }
        let t = e2.dot(q) * inv;
        if t >= ray.tmin && t < tmax {
            Some((t, u, v))
        } else {
            None
        }
    }
}

/// Watertight ray–triangle intersection (Woop, Benthin and Wald 2013, JCGT 2(1), Listing 1),
/// two-sided, with the double-precision fallback for edge functions that are exactly zero.
pub struct Watertight;

/// Per-ray data of [`Watertight`]: the permutation making `dir[kz]` the largest component and
/// the shear constants.
#[derive(Clone, Copy, Debug)]
pub struct WatertightPre {
    kx: usize,
    ky: usize,
    kz: usize,
    sx: f32,
    sy: f32,
    sz: f32,
}

impl TriTest for Watertight {
    type Pre = WatertightPre;

    #[inline(always)]
    fn prepare(ray: &Ray) -> WatertightPre {
        let a = ray.dir.abs();
        let kz = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        if ray.dir[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        let dz = ray.dir[kz];
        WatertightPre {
            kx,
            ky,
            kz,
            sx: ray.dir[kx] / dz,
            sy: ray.dir[ky] / dz,
            sz: 1.0 / dz,
        }
    }

    #[inline(always)]
    fn intersect(
        p: &WatertightPre,
        ray: &Ray,
        tri: &Triangle,
        tmax: f32,
    ) -> Option<(f32, f32, f32)> {
        // Arrays, not glam's `Index` (a match per access), so the permutation is a plain load.
        let a = (tri.v0 - ray.origin).to_array();
        let b = (tri.v1 - ray.origin).to_array();
        let c = (tri.v2 - ray.origin).to_array();
        let (az, bz, cz) = (a[p.kz], b[p.kz], c[p.kz]);
        let ax = a[p.kx] - p.sx * az;
        let ay = a[p.ky] - p.sy * az;
        let bx = b[p.kx] - p.sx * bz;
        let by = b[p.ky] - p.sy * bz;
        let cx = c[p.kx] - p.sx * cz;
        let cy = c[p.ky] - p.sy * cz;
        let mut u = cx * by - cy * bx;
        let mut v = ax * cy - ay * cx;
        let mut w = bx * ay - by * ax;
        if u == 0.0 || v == 0.0 || w == 0.0 {
            let (cxd, cyd, bxd, byd, axd, ayd) = (
                cx as f64, cy as f64, bx as f64, by as f64, ax as f64, ay as f64,
            );
            u = (cxd * byd - cyd * bxd) as f32;
            v = (axd * cyd - ayd * cxd) as f32;
            w = (bxd * ayd - byd * axd) as f32;
        }
        if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + v + w;
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let (az, bz, cz) = (p.sz * az, p.sz * bz, p.sz * cz);
        let tt = u * az + v * bz + w * cz;
        // Compare tt/det against [tmin, tmax) without dividing: flip signs so det > 0.
        let (tt_s, det_s) = if det < 0.0 { (-tt, -det) } else { (tt, det) };
        if tt_s < ray.tmin * det_s || tt_s >= tmax * det_s {
            return None;
        }
        let inv = 1.0 / det;
        let t = tt * inv;
        // Guard the rounding of the final division against the interval.
        if t < ray.tmin || t >= tmax {
            return None;
        }
        // u weighs v0 (edge opposite), v weighs v1, w weighs v2 in Woop et al.'s convention.
        Some((t, v * inv, w * inv))
    }
}

/// The geometric normal of `tri` facing against `dir` (for offsetting secondary rays).
pub fn facing_normal(tri: &Triangle, dir: Vec3) -> Vec3 {
    let n = tri.normal().normalize_or_zero();
    if n.dot(dir) > 0.0 {
        -n
    } else {
        n
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tri() -> Triangle {
        Triangle::new(
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        )
    }

    type Tuv = Option<(f32, f32, f32)>;

    fn both(ray: &Ray, t: &Triangle) -> (Tuv, Tuv) {
        (
            Watertight::intersect(&Watertight::prepare(ray), ray, t, ray.tmax),
            MollerTrumbore::intersect(&(), ray, t, ray.tmax),
        )
    }

    #[test]
    fn tests_agree_on_a_plain_hit() {
        let r = Ray::new(Vec3::new(0.25, 0.25, 1.0), -Vec3::Z);
        let (w, m) = both(&r, &tri());
        let (w, m) = (w.unwrap(), m.unwrap());
        assert!((w.0 - 1.0).abs() < 1e-6 && (m.0 - 1.0).abs() < 1e-6);
        assert!(
            (w.1 - 0.25).abs() < 1e-6 && (w.2 - 0.25).abs() < 1e-6,
            "{w:?}"
        );
        assert!((m.1 - 0.25).abs() < 1e-6 && (m.2 - 0.25).abs() < 1e-6);
        // From behind (two-sided).
        let r = Ray::new(Vec3::new(0.25, 0.25, -1.0), Vec3::Z);
        assert!(both(&r, &tri()).0.is_some() && both(&r, &tri()).1.is_some());
    }

    #[test]
    fn interval_is_half_open() {
        let r = Ray::segment(Vec3::new(0.25, 0.25, 1.0), -Vec3::Z, 0.0, 1.0);
        assert_eq!(both(&r, &tri()), (None, None));
        let r = Ray::segment(Vec3::new(0.25, 0.25, 1.0), -Vec3::Z, 1.0, 2.0);
        assert!(both(&r, &tri()).0.is_some());
    }

    #[test]
    fn watertight_on_shared_edge() {
        // Two triangles sharing the diagonal edge of a unit square; rays exactly on the edge
        // must hit at least one of them.
        let a = Triangle::new(Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0));
        let b = Triangle::new(Vec3::ZERO, Vec3::new(1.0, 1.0, 0.0), Vec3::Y);
        for i in 1..100 {
            let s = i as f32 / 100.0;
            let dir = Vec3::new(0.1, 0.3, -1.0).normalize();
            let origin = Vec3::new(s, s, 0.0) - dir * 3.0;
            let r = Ray::new(origin, dir);
            let pre = Watertight::prepare(&r);
            let ha = Watertight::intersect(&pre, &r, &a, r.tmax);
            let hb = Watertight::intersect(&pre, &r, &b, r.tmax);
            assert!(
                ha.is_some() || hb.is_some(),
                "ray {i} slipped through the shared edge"
            );
        }
    }

    #[test]
    fn degenerate_and_parallel_never_hit() {
        let d = Triangle::new(Vec3::ZERO, Vec3::X, Vec3::X * 2.0);
        let r = Ray::new(Vec3::new(0.5, 0.0, 1.0), -Vec3::Z);
        assert_eq!(both(&r, &d), (None, None));
        // Ray in the triangle's plane.
        let r = Ray::new(Vec3::new(-1.0, 0.25, 0.0), Vec3::X);
        assert_eq!(both(&r, &tri()), (None, None));
    }
}
