//! Geometry shared by every structure: [`Ray`], [`Aabb`], [`Triangle`], [`HitRecord`].
//!
//! All types are `#[repr(C)]` plain data so that flat arrays of them can be uploaded to a GPU
//! unchanged (STYLE.md: "build, then flatten").

use serde::{Deserialize, Serialize};

/// Three-component `f32` vector (glam's scalar `Vec3`, 12 bytes, `#[repr(C)]`).
pub type Vec3 = glam::Vec3;

/// `v.length()`, also where the sum of squares leaves f32's range (a vector of 1e30 or 1e-30):
/// there `v` is first divided by its largest component. Where the squares are in range the
/// result is `v.length()` bit for bit.
pub fn length(v: Vec3) -> f32 {
    let l2 = v.length_squared();
    if l2.is_normal() && l2.is_finite() {
        return l2.sqrt();
    }
    let m = v.abs().max_element();
    if m == 0.0 || !m.is_finite() {
        return if m.is_nan() { f32::NAN } else { m };
    }
    m * (v / m).length()
}

/// `v.normalize_or_zero()`, also where the sum of squares leaves f32's range (the direction
/// between two points at 1e30 or 1e-30 apart): there `v` is first divided by its largest
/// component. Zero for a zero or non-finite `v`. Where the squares are in range the result is
/// `v.normalize_or_zero()` bit for bit (for cameras, aimed rays and normals at extreme
/// scales).
pub fn unit(v: Vec3) -> Vec3 {
    let l2 = v.length_squared();
    if l2.is_normal() && l2.is_finite() {
        return v.normalize_or_zero();
    }
    let m = v.abs().max_element();
    if m == 0.0 || !m.is_finite() {
        return Vec3::ZERO;
    }
    (v / m).normalize_or_zero()
}

/// A ray `origin + t * dir` for `t` in the half-open interval `[tmin, tmax)`.
///
/// `dir` need not be normalised, but every generator in trace-bench normalises it so that `t`
/// is a distance. 32 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Ray {
    /// Start point of the ray.
    pub origin: Vec3,
    /// Start of the accepted interval of `t` (inclusive).
    pub tmin: f32,
    /// Direction (normalised by every generator, so `t` is a distance).
    pub dir: Vec3,
    /// End of the accepted interval of `t` (exclusive).
    pub tmax: f32,
}

impl Ray {
    /// A ray over `[0, +inf)`.
    pub fn new(origin: Vec3, dir: Vec3) -> Self {
        Self {
            origin,
            tmin: 0.0,
            dir,
            tmax: f32::INFINITY,
        }
    }

    /// A ray over `[tmin, tmax)`.
    pub fn segment(origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> Self {
        Self {
            origin,
            tmin,
            dir,
            tmax,
        }
    }

    /// The point at parameter `t`.
    #[inline(always)]
    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + t * self.dir
    }

    /// Component-wise reciprocal of the direction. Zero components give `±inf` with the sign
    /// of the zero, which the slab test in [`Aabb::intersect`] handles.
    #[inline(always)]
    pub fn inv_dir(&self) -> Vec3 {
        Vec3::new(1.0 / self.dir.x, 1.0 / self.dir.y, 1.0 / self.dir.z)
    }
}

/// `gamma(n) = n·u / (1 − n·u)` with `u = 2^-24`: the bound on relative rounding error of `n`
/// floating-point operations (Higham; pbrt-v3 §3.9.1).
pub const fn gamma(n: i32) -> f32 {
    let u = f32::EPSILON * 0.5;
    (n as f32 * u) / (1.0 - n as f32 * u)
}

/// Axis-aligned bounding box. An empty box has `min = +inf`, `max = -inf`. 24 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Aabb {
    /// Lower corner (`+inf` on every axis for the empty box).
    pub min: Vec3,
    /// Upper corner (`-inf` on every axis for the empty box).
    pub max: Vec3,
}

impl Default for Aabb {
    fn default() -> Self {
        Self::EMPTY
    }
}

impl Aabb {
    /// The empty box (identity of [`Aabb::union`]).
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    /// The box with corners `min` and `max` (not checked: `min > max` is empty).
    pub fn new(min: Vec3, max: Vec3) -> Self {
        Self { min, max }
    }

    /// Smallest box holding all `points`.
    pub fn from_points(points: impl IntoIterator<Item = Vec3>) -> Self {
        let mut b = Self::EMPTY;
        for p in points {
            b.grow(p);
        }
        b
    }

    /// Extend the box to hold the point `p`.
    #[inline(always)]
    pub fn grow(&mut self, p: Vec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }

    /// Smallest box holding both `self` and `o`.
    #[inline(always)]
    pub fn union(&self, o: &Aabb) -> Aabb {
        Aabb {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    /// True when `min > max` on some axis (the box holds no point).
    #[inline(always)]
    pub fn is_empty(&self) -> bool {
        self.min.x > self.max.x || self.min.y > self.max.y || self.min.z > self.max.z
    }

    /// Size along each axis, `max - min`.
    #[inline(always)]
    pub fn extent(&self) -> Vec3 {
        self.max - self.min
    }

    /// Centre point, halfway between `min` and `max`.
    #[inline(always)]
    pub fn center(&self) -> Vec3 {
        0.5 * (self.min + self.max)
    }

    /// Length of the diagonal (0 for the empty box), without overflow or underflow of the
    /// squares at extreme scales ([`length`]).
    pub fn diagonal(&self) -> f32 {
        if self.is_empty() {
            0.0
        } else {
            length(self.extent())
        }
    }

    /// Surface area; 0 for the empty box. Flat boxes have the area of their two faces.
    #[inline(always)]
    pub fn area(&self) -> f32 {
        if self.is_empty() {
            return 0.0;
        }
        let e = self.extent();
        2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
    }

    /// Half the surface area, the SAH measure most builders use.
    #[inline(always)]
    pub fn half_area(&self) -> f32 {
        if self.is_empty() {
            return 0.0;
        }
        let e = self.extent();
        e.x * e.y + e.y * e.z + e.z * e.x
    }

    /// Volume; 0 for the empty box.
    pub fn volume(&self) -> f32 {
        if self.is_empty() {
            return 0.0;
        }
        let e = self.extent();
        e.x * e.y * e.z
    }

    /// Index (0, 1, 2) of the longest axis.
    pub fn largest_axis(&self) -> usize {
        let e = self.extent();
        if e.x >= e.y && e.x >= e.z {
            0
        } else if e.y >= e.z {
            1
        } else {
            2
        }
    }

    /// Whether `o` lies inside this box (faces included); an empty `o` always does.
    pub fn contains_box(&self, o: &Aabb) -> bool {
        o.is_empty() || (self.min.cmple(o.min).all() && o.max.cmple(self.max).all())
    }

    /// Conservative slab test (Kay and Kajiya 1986) returning the entry/exit interval clipped to
    /// `[tmin, tmax]`, or `None`.
    ///
    /// The near and far plane of each slab are chosen by the sign of `inv_dir` (pbrt-v3's
    /// `dirIsNeg`), so no min/max of the two plane distances is needed. Robustness, checked by
    /// the stress scenes:
    /// - a zero direction component gives `inv_dir = ±inf` (sign of the zero); an origin exactly
    ///   on that slab's plane gives `0 · inf = NaN`, which the folds with `f32::max`/`f32::min`
    ///   ignore, so a ray lying in a face plane counts as inside that slab (the box is closed);
    /// - the exit distance is scaled by `1 + 2·gamma(3)` (Ize 2013, "Robust BVH ray
    ///   traversal"; pbrt-v3 §3.9.2) so rounding never culls a box the ray touches.
    #[inline(always)]
    pub fn intersect(
        &self,
        origin: Vec3,
        inv_dir: Vec3,
        tmin: f32,
        tmax: f32,
    ) -> Option<(f32, f32)> {
        let (nx, fx) = if inv_dir.x < 0.0 {
            (self.max.x, self.min.x)
        } else {
            (self.min.x, self.max.x)
        };
        let (ny, fy) = if inv_dir.y < 0.0 {
            (self.max.y, self.min.y)
        } else {
            (self.min.y, self.max.y)
        };
        let (nz, fz) = if inv_dir.z < 0.0 {
            (self.max.z, self.min.z)
        } else {
            (self.min.z, self.max.z)
        };
        let tn = tmin
            .max((nx - origin.x) * inv_dir.x)
            .max((ny - origin.y) * inv_dir.y)
            .max((nz - origin.z) * inv_dir.z);
        let tf = tmax
            .min((fx - origin.x) * inv_dir.x)
            .min((fy - origin.y) * inv_dir.y)
            .min((fz - origin.z) * inv_dir.z)
            * (1.0 + 2.0 * gamma(3));
        if tn <= tf {
            Some((tn, tf))
        } else {
            None
        }
    }
}

/// A triangle by its three vertices, 36 bytes. Structures may store their own layout, but hits
/// always name the triangle's index in the scene's triangle array.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Triangle {
    /// First vertex (the origin of the barycentrics `u`, `v`).
    pub v0: Vec3,
    /// Second vertex (barycentric `u`).
    pub v1: Vec3,
    /// Third vertex (barycentric `v`).
    pub v2: Vec3,
}

impl Triangle {
    /// The triangle with vertices `v0`, `v1`, `v2`.
    pub fn new(v0: Vec3, v1: Vec3, v2: Vec3) -> Self {
        Self { v0, v1, v2 }
    }

    /// Smallest box holding the three vertices.
    pub fn bounds(&self) -> Aabb {
        Aabb {
            min: self.v0.min(self.v1).min(self.v2),
            max: self.v0.max(self.v1).max(self.v2),
        }
    }

    /// Mean of the three vertices.
    pub fn centroid(&self) -> Vec3 {
        (self.v0 + self.v1 + self.v2) * (1.0 / 3.0)
    }

    /// Unnormalised geometric normal `(v1 − v0) × (v2 − v0)`.
    pub fn normal(&self) -> Vec3 {
        (self.v1 - self.v0).cross(self.v2 - self.v0)
    }

    /// The unit normal (zero for a degenerate triangle), also where [`Triangle::normal`]'s
    /// products leave f32's range (a triangle at 1e30 or 1e-30): there the edges are first
    /// divided by their largest component. Elsewhere `normal().normalize_or_zero()` bit for bit.
    pub fn unit_normal(&self) -> Vec3 {
        let n = self.normal();
        let l2 = n.length_squared();
        if l2.is_normal() && l2.is_finite() {
            return n.normalize_or_zero();
        }
        let (e1, e2) = (self.v1 - self.v0, self.v2 - self.v0);
        let m = e1.abs().max(e2.abs()).max_element();
        if m == 0.0 || !m.is_finite() {
            return Vec3::ZERO;
        }
        unit((e1 / m).cross(e2 / m))
    }

    /// Area (half the length of [`Triangle::normal`]).
    pub fn area(&self) -> f32 {
        0.5 * self.normal().length()
    }

    /// True when the triangle has zero area in `f32` (degenerate: collinear or repeated
    /// vertices). Such triangles are kept: a structure must cope with them, and a triangle test
    /// may still report a ray running exactly through the segment as a hit.
    pub fn is_degenerate(&self) -> bool {
        self.normal() == Vec3::ZERO
    }

    /// The vertex `i` (0..3).
    #[inline(always)]
    pub fn vertex(&self, i: usize) -> Vec3 {
        match i {
            0 => self.v0,
            1 => self.v1,
            _ => self.v2,
        }
    }
}

/// The answer to a closest-hit or any-hit query, 16 bytes, GPU-uploadable.
///
/// A miss has `prim == u32::MAX` ([`HitRecord::MISS`]). `u, v` are barycentric coordinates of
/// `v1` and `v2` (the hit point is `(1−u−v)·v0 + u·v1 + v·v2`). For any-hit queries only
/// `prim` (hit or not) is meaningful.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct HitRecord {
    /// Distance along the ray to the hit (`+inf` on a miss).
    pub t: f32,
    /// Index of the hit triangle in the scene's array (`u32::MAX` on a miss).
    pub prim: u32,
    /// Barycentric coordinate of `v1` at the hit point.
    pub u: f32,
    /// Barycentric coordinate of `v2` at the hit point.
    pub v: f32,
}

impl Default for HitRecord {
    fn default() -> Self {
        Self::MISS
    }
}

impl HitRecord {
    /// The answer of a ray that hits nothing: `t = +inf`, `prim = u32::MAX`.
    pub const MISS: HitRecord = HitRecord {
        t: f32::INFINITY,
        prim: u32::MAX,
        u: 0.0,
        v: 0.0,
    };

    /// Whether this record names a triangle (`prim != u32::MAX`).
    #[inline(always)]
    pub fn is_hit(&self) -> bool {
        self.prim != u32::MAX
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slab_test_handles_rays_in_face_planes() {
        let b = Aabb::new(Vec3::ZERO, Vec3::ONE);
        // Ray travelling along the x axis inside the face plane y = 0.
        let r = Ray::new(Vec3::new(-1.0, 0.0, 0.5), Vec3::X);
        assert!(b.intersect(r.origin, r.inv_dir(), r.tmin, r.tmax).is_some());
        // Just outside the face plane: no hit.
        let r = Ray::new(Vec3::new(-1.0, -1e-6, 0.5), Vec3::X);
        assert!(b.intersect(r.origin, r.inv_dir(), r.tmin, r.tmax).is_none());
        // Flat box (zero thickness in z) hit head-on.
        let f = Aabb::new(Vec3::new(0.0, 0.0, 0.5), Vec3::new(1.0, 1.0, 0.5));
        let r = Ray::new(Vec3::new(0.5, 0.5, -1.0), Vec3::Z);
        let (tn, tf) = f.intersect(r.origin, r.inv_dir(), r.tmin, r.tmax).unwrap();
        assert!(tn <= 1.5 && tf >= 1.5);
    }

    #[test]
    fn box_measures() {
        let b = Aabb::new(Vec3::ZERO, Vec3::new(1.0, 2.0, 3.0));
        assert_eq!(b.area(), 22.0);
        assert_eq!(b.half_area(), 11.0);
        assert_eq!(b.volume(), 6.0);
        assert_eq!(b.largest_axis(), 2);
        assert_eq!(Aabb::EMPTY.area(), 0.0);
        assert!(Aabb::EMPTY.union(&b) == b);
    }
}
