//! Ray–triangle tests, selectable per experiment (`triangle_test` in a config).
//!
//! Both are behind the [`TriTest`] trait so that traversal kernels are monomorphised for one
//! test: the per-ray set-up ([`TriTest::prepare`]) is done once per ray, not once per triangle.

use crate::geom::{Ray, Triangle, Vec3};
use serde::{Deserialize, Serialize};
use std::hint::select_unpredictable;

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
    /// Both tests, watertight first.
    pub const ALL: [TriTestKind; 2] = [TriTestKind::Watertight, TriTestKind::MollerTrumbore];

    /// The config name (`watertight`, `moller-trumbore`).
    pub fn name(self) -> &'static str {
        match self {
            TriTestKind::Watertight => "watertight",
            TriTestKind::MollerTrumbore => "moller-trumbore",
        }
    }

    /// The test with config name `s`, if any.
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
    /// The same test on the four triangles of `tris` at once (SSE on x86-64, lane by lane
    /// elsewhere), every lane with the scalar test's operations in the scalar test's order, so
    /// that a lane in [`Lanes4::hit`] has bit for bit the `(t, u, v)` [`TriTest::intersect`]
    /// returns for that triangle and `tmax`, and a lane in neither `hit` nor `redo` is a miss
    /// of [`TriTest::intersect`]. Lanes the SIMD code cannot answer exactly are in
    /// [`Lanes4::redo`]: the caller asks [`TriTest::intersect`] about them. Lanes past the
    /// triangles of a partly filled block are answered too (and must be masked off).
    fn intersect4(pre: &Self::Pre, ray: &Ray, tris: &Tri4, tmax: f32) -> Lanes4;
    /// Whether lane `i` of `l`, a hit of `intersect4(pre, ray, tris, tmax0)`, is still a hit of
    /// [`TriTest::intersect`] with a `tmax ≤ tmax0` (the closest hit so far, found meanwhile
    /// in the same block): the test's `tmax` comparisons replayed on the lane's values. With it
    /// a block's lanes resolved in order give exactly the scalar loop's answer.
    fn still_hits(l: &Lanes4, i: usize, tmax: f32) -> bool;
}

/// Four triangles in structure-of-arrays layout for [`TriTest::intersect4`] (as Embree's
/// `triangle4` blocks): `v[k][a][l]` is coordinate `a` of vertex `k` of lane `l`'s triangle.
/// Unused lanes repeat lane 0's triangle: they answer as lane 0 does (and are masked off by the
/// caller), so a block whose triangles all miss ends early in every lane.
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Tri4 {
    /// Coordinates, `v[vertex][axis][lane]`.
    pub v: [[[f32; 4]; 3]; 3],
}

impl Tri4 {
    /// The block of `tris` (at most four; lanes past them repeat the first, or hold zeros
    /// where there is none).
    pub fn new(tris: &[Triangle]) -> Tri4 {
        assert!(tris.len() <= 4, "a Tri4 holds at most 4 triangles");
        let mut b = Tri4::default();
        let pad = tris.first().into_iter().cycle().take(4 - tris.len());
        for (l, t) in tris.iter().chain(pad).enumerate() {
            for (k, v) in [t.v0, t.v1, t.v2].into_iter().enumerate() {
                for a in 0..3 {
                    b.v[k][a][l] = v[a];
                }
            }
        }
        b
    }

    /// Lane `l`'s triangle (bit for bit the one given to [`Tri4::new`]).
    #[inline(always)]
    pub fn lane(&self, l: usize) -> Triangle {
        let v = |k: usize| Vec3::new(self.v[k][0][l], self.v[k][1][l], self.v[k][2][l]);
        Triangle::new(v(0), v(1), v(2))
    }
}

/// The answers of [`TriTest::intersect4`], lane `l` in bit `l` of the masks.
#[derive(Clone, Copy, Debug)]
pub struct Lanes4 {
    /// Lanes hit within `[ray.tmin, tmax)`.
    pub hit: u32,
    /// Lanes to be tested again with [`TriTest::intersect`] (watertight: an edge function is
    /// exactly zero, which the scalar test recomputes in double precision).
    pub redo: u32,
    /// Per lane: `t` and the barycentrics `u`, `v` (as [`TriTest::intersect`] returns them).
    pub t: [f32; 4],
    /// Per lane: the barycentric `u` of `v1`.
    pub u: [f32; 4],
    /// Per lane: the barycentric `v` of `v2`.
    pub v: [f32; 4],
    /// Watertight: the sign-normalised scaled distance `tt` and determinant `det` its `tmax`
    /// comparison uses (unused by Möller–Trumbore).
    pub tt: [f32; 4],
    /// Per lane: the sign-normalised determinant (watertight; see `tt`).
    pub det: [f32; 4],
}

impl Lanes4 {
    /// No lane hit, none to redo.
    pub const NONE: Lanes4 = Lanes4 {
        hit: 0,
        redo: 0,
        t: [0.0; 4],
        u: [0.0; 4],
        v: [0.0; 4],
        tt: [0.0; 4],
        det: [0.0; 4],
    };

    /// Lane by lane with the scalar test (the portable fallback): every lane it hits is put in
    /// `redo`, so the caller's scalar re-test gives the answer.
    #[allow(dead_code)]
    fn by_lanes<T: TriTest>(pre: &T::Pre, ray: &Ray, tris: &Tri4, tmax: f32) -> Lanes4 {
        let mut redo = 0;
        for l in 0..4 {
            if T::intersect(pre, ray, &tris.lane(l), tmax).is_some() {
                redo |= 1 << l;
            }
        }
        Lanes4 {
            redo,
            ..Lanes4::NONE
        }
    }
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
        if t >= ray.tmin && t < tmax && t > mt_error_bound(e2, s, e1, inv) {
            Some((t, u, v))
        } else {
            None
        }
    }

    #[inline(always)]
    fn intersect4(_: &(), ray: &Ray, tris: &Tri4, tmax: f32) -> Lanes4 {
        #[cfg(target_arch = "x86_64")]
        {
            // SAFETY: SSE and SSE2 are part of x86-64.
            unsafe { sse::moller_trumbore4(ray, tris, tmax) }
        }
        #[cfg(not(target_arch = "x86_64"))]
        Lanes4::by_lanes::<Self>(&(), ray, tris, tmax)
    }

    #[inline(always)]
    fn still_hits(l: &Lanes4, i: usize, tmax: f32) -> bool {
        l.t[i] < tmax
    }
}

/// The rounding-error bound of Möller–Trumbore's `t = (e2 · (s × e1)) / det`: a `t` at or
/// below it may belong to a plane behind the origin, so it is no hit (as [`t_error_bound`]
/// for the watertight test). Each component of `q = s × e1` is off by at most
/// `γ(3)·(|s_j·e1_k| + |s_k·e1_j|)` (the inputs rounded once, two products, a difference),
/// and the dot product with `e2` (itself rounded once) adds `γ(4)` of `Σ|e2_i·q_i|`: in all
/// at most `γ(8)·Σ|e2_i|·a_i` with `a` the absolute cross product of `|s|` and `|e1|`; `γ(9)`
/// covers the division and the comparison. Unlike the watertight test there is no f64 path:
/// the numerator is a product of three coordinates and leaves f32's range beyond about 1e12,
/// where the test misses (documented in docs/results.md, "Numerical notes").
#[inline(always)]
fn mt_error_bound(e2: Vec3, s: Vec3, e1: Vec3, inv: f32) -> f32 {
    let (s, e1, e2) = (s.abs(), e1.abs(), e2.abs());
    let a = Vec3::new(
        s.y * e1.z + s.z * e1.y,
        s.z * e1.x + s.x * e1.z,
        s.x * e1.y + s.y * e1.x,
    );
    gamma(9.0) * ((e2.x * a.x + e2.y * a.y) + e2.z * a.z) * inv.abs()
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

/// `γ(n) = n·ε / (1 − n·ε)` with `ε = 2⁻²⁴` (f32's unit roundoff): the bound on the relative
/// error of `n` rounded f32 operations (Pharr, Jakob and Humphreys, PBR 4th ed., §6.8.1).
pub const fn gamma(n: f32) -> f32 {
    let e = f32::EPSILON * 0.5;
    n * e / (1.0 - n * e)
}

/// Whether `|det|` lies where the f32 path of [`Watertight`] keeps its precision: the edge
/// functions are products of two sheared coordinates and the distance `tt` of three, so a
/// determinant outside `[2⁻⁶⁴, 2⁶⁴]` (a scene at 1e-20 or 1e20, say) means products near f32's
/// underflow or overflow, and the test is finished otherwise ([`Sheared::finish`]: scaled by a
/// power of two, else in f64).
#[inline(always)]
fn in_f32_range(det: f32) -> bool {
    let a = det.abs();
    (F32_DET_MIN..=F32_DET_MAX).contains(&a)
}
const F32_DET_MIN: f32 = 5.421_011e-20; // 2^-64
const F32_DET_MAX: f32 = 1.844_674_4e19; // 2^64

/// What [`Sheared::solve`] found: the answer, or that f32's products left their range.
enum Solved {
    Done(Option<(f32, f32, f32)>),
    Wide,
}

/// The exponent `e` of `x = f · 2^e` with `f` in `[0.5, 1)`, as WGSL's `frexp` (`x` finite and
/// positive; subnormals included).
fn frexp_exp(x: f32) -> i32 {
    let bits = x.to_bits();
    let biased = ((bits >> 23) & 0xff) as i32;
    if biased == 0 {
        // Subnormal: normalise by 2^64 first.
        return frexp_exp(x * f32::from_bits((127 + 64) << 23)) - 64;
    }
    biased - 126
}

/// `x · 2^k`, as WGSL's `ldexp`: exact wherever the result is a normal f32 (two steps, so that
/// `2^k` itself need not be one).
fn ldexp(x: f32, k: i32) -> f32 {
    let pow2 = |e: i32| f32::from_bits(((127 + e.clamp(-126, 127)) as u32) << 23);
    let h = k / 2;
    x * pow2(h) * pow2(k - h)
}

/// The vertices relative to the ray's origin, permuted (`kz` last) and sheared (Woop et al.
/// 2013, Listing 1): `x`, `y` sheared, `z` not yet scaled by `sz`.
#[derive(Clone, Copy)]
struct Sheared {
    ax: f32,
    ay: f32,
    az: f32,
    bx: f32,
    by: f32,
    bz: f32,
    cx: f32,
    cy: f32,
    cz: f32,
}

impl Sheared {
    #[inline(always)]
    fn new(p: &WatertightPre, ray: &Ray, tri: &Triangle) -> Sheared {
        // The permuted coordinates are loaded by index from the triangle and the origin in
        // place (`AsRef<[f32; 3]>`, not glam's `Index`, a match per access): subtracting first
        // and indexing the difference went through a stack copy (a store and a load per
        // coordinate). The values are the same: `v[k] - o[k]` either way.
        let o: &[f32; 3] = ray.origin.as_ref();
        let rel = |v: &Vec3, k: usize| v.as_ref()[k] - o[k];
        let (az, bz, cz) = (rel(&tri.v0, p.kz), rel(&tri.v1, p.kz), rel(&tri.v2, p.kz));
        Sheared {
            ax: rel(&tri.v0, p.kx) - p.sx * az,
            ay: rel(&tri.v0, p.ky) - p.sy * az,
            az,
            bx: rel(&tri.v1, p.kx) - p.sx * bz,
            by: rel(&tri.v1, p.ky) - p.sy * bz,
            bz,
            cx: rel(&tri.v2, p.kx) - p.sx * cz,
            cy: rel(&tri.v2, p.ky) - p.sy * cz,
            cz,
        }
    }

    /// The test from the sheared vertices on, for the ray's interval `[tmin, tmax)`: the edge
    /// functions (an exactly zero one recomputed in f64, Woop et al. 2013), the signs, the
    /// determinant, the distance and its rounding-error bound; [`Solved::Wide`] where f32's
    /// products leave their range (a determinant outside [`in_f32_range`], a distance or bound
    /// that is not finite).
    #[inline(always)]
    fn solve(&self, sz: f32, tmin: f32, tmax: f32) -> Solved {
        let (ax, ay, bx, by, cx, cy) = (self.ax, self.ay, self.bx, self.by, self.cx, self.cy);
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
            return Solved::Done(None);
        }
        let det = u + v + w;
        if !in_f32_range(det) {
            // Zero (the ray in the triangle's plane, or products under f32's range), or out of
            // the range where f32 holds the products.
            return Solved::Wide;
        }
        let (az, bz, cz) = (sz * self.az, sz * self.bz, sz * self.cz);
        let tt = u * az + v * bz + w * cz;
        if !tt.is_finite() {
            return Solved::Wide;
        }
        // Compare tt/det against [tmin, tmax) without dividing: flip signs so det > 0.
        let (tt_s, det_s) = if det < 0.0 { (-tt, -det) } else { (tt, det) };
        if tt_s < tmin * det_s || tt_s >= tmax * det_s {
            return Solved::Done(None);
        }
        let inv = 1.0 / det;
        let t = tt * inv;
        // Guard the rounding of the final division against the interval.
        if t < tmin || t >= tmax {
            return Solved::Done(None);
        }
        let bound = t_error_bound(self, [az, bz, cz], [u, v, w], inv);
        if !bound.is_finite() {
            return Solved::Wide;
        }
        if t <= bound {
            return Solved::Done(None);
        }
        // u weighs v0 (edge opposite), v weighs v1, w weighs v2 in Woop et al.'s convention.
        Solved::Done(Some((t, v * inv, w * inv)))
    }

    /// Where f32's products leave their range ([`Solved::Wide`]): a scene at 1e-30 or 1e30,
    /// say. The nine sheared coordinates are scaled by the power of two `2^k` that brings the
    /// largest to `[0.5, 1)`; scaling by a power of two is exact, so the edge functions
    /// (`2^2k`), the determinant and the distance (`2^3k`) round as they would for the same
    /// scene at scale 1, and [`Sheared::solve`] runs on them with the interval scaled by
    /// `2^k`, its distance scaled back. Where even that leaves f32's range (a triangle under
    /// `2^-32` of its distance from the origin across), the test finishes in f64
    /// ([`Sheared::in_f64`]). The GPU's prelude does the same operation for operation
    /// (`watertight` in tb-gpu's `shaders/prelude.wgsl`), so that both devices answer alike at
    /// every scale.
    #[cold]
    #[inline(never)]
    fn finish(&self, p: &WatertightPre, ray: &Ray, tmax: f32) -> Option<(f32, f32, f32)> {
        let big = [
            self.ax, self.ay, self.az, self.bx, self.by, self.bz, self.cx, self.cy, self.cz,
        ]
        .iter()
        .fold(0.0f32, |m, x| m.max(x.abs()));
        if big == 0.0 || !big.is_finite() {
            return None;
        }
        let k = -frexp_exp(big);
        let sc = |x: f32| ldexp(x, k);
        let scaled = Sheared {
            ax: sc(self.ax),
            ay: sc(self.ay),
            az: sc(self.az),
            bx: sc(self.bx),
            by: sc(self.by),
            bz: sc(self.bz),
            cx: sc(self.cx),
            cy: sc(self.cy),
            cz: sc(self.cz),
        };
        match scaled.solve(p.sz, sc(ray.tmin), sc(tmax)) {
            Solved::Done(h) => h.map(|(t, u, v)| (ldexp(t, -k), u, v)),
            Solved::Wide => self.in_f64(p, ray, tmax),
        }
    }

    /// The rest of the test in f64 from the f32 sheared vertices: edge functions, determinant,
    /// distance and the error bound of `t` cannot leave f64's range for any f32 input, so a
    /// scene at 1e-30 or 1e30 is hit where the f32 products would underflow to zero or
    /// overflow. The bound keeps f32's `γ` (it bounds the f32 shear's
    /// error, the larger one).
    #[cold]
    #[inline(never)]
    fn in_f64(&self, p: &WatertightPre, ray: &Ray, tmax: f32) -> Option<(f32, f32, f32)> {
        let d = |x: f32| x as f64;
        let (ax, ay, bx, by, cx, cy) = (
            d(self.ax),
            d(self.ay),
            d(self.bx),
            d(self.by),
            d(self.cx),
            d(self.cy),
        );
        let u = cx * by - cy * bx;
        let v = ax * cy - ay * cx;
        let w = bx * ay - by * ax;
        if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + v + w;
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let sz = d(p.sz);
        let (az, bz, cz) = (sz * d(self.az), sz * d(self.bz), sz * d(self.cz));
        let inv = 1.0 / det;
        let t = (u * az + v * bz + w * cz) * inv;
        let (max_x, max_y, max_z) = (
            ax.abs().max(bx.abs()).max(cx.abs()),
            ay.abs().max(by.abs()).max(cy.abs()),
            az.abs().max(bz.abs()).max(cz.abs()),
        );
        let g = |n: f32| gamma(n) as f64;
        let delta_z = g(3.0) * max_z;
        let delta_x = g(5.0) * (max_x + max_z);
        let delta_y = g(5.0) * (max_y + max_z);
        let delta_e = 2.0 * (g(2.0) * max_x * max_y + delta_y * max_x + delta_x * max_y);
        let max_e = u.abs().max(v.abs()).max(w.abs());
        let bound = 3.0 * (g(3.0) * max_e * max_z + delta_e * max_z + delta_z * max_e) * inv.abs();
        let t32 = t as f32;
        if t <= bound || !(t32 >= ray.tmin && t32 < tmax) {
            return None;
        }
        Some((t32, (v * inv) as f32, (w * inv) as f32))
    }
}

/// The rounding-error bound of the watertight test's `t` (Pharr, Jakob and Humphreys, PBR
/// 4th ed., §6.8.7, "Conservative Ray–Triangle t Values"): a computed `t` at or below it may
/// belong to a plane behind the ray's origin, so it is no hit. Without it, a shadow ray
/// starting one ulp in front of a box face got `t = 3.6e-8` from that face, whose plane is
/// 1.6e-8 behind the origin. `[az, bz, cz]`: the vertices' `z` scaled by `sz`; `[u, v, w]`:
/// the edge functions; `inv = 1 / det`. The products are grouped so that a determinant in
/// [`in_f32_range`] cannot overflow them (`max_e · |inv| ≤ 1`); a non-finite bound sends the
/// test to f64.
#[inline(always)]
fn t_error_bound(s: &Sheared, [az, bz, cz]: [f32; 3], [u, v, w]: [f32; 3], inv: f32) -> f32 {
    let max_x = s.ax.abs().max(s.bx.abs()).max(s.cx.abs());
    let max_y = s.ay.abs().max(s.by.abs()).max(s.cy.abs());
    let max_z = az.abs().max(bz.abs()).max(cz.abs());
    let delta_z = gamma(3.0) * max_z;
    let delta_x = gamma(5.0) * (max_x + max_z);
    let delta_y = gamma(5.0) * (max_y + max_z);
    let ainv = inv.abs();
    let delta_e = 2.0 * (gamma(2.0) * max_x * max_y + delta_y * max_x + delta_x * max_y);
    let e = u.abs().max(v.abs()).max(w.abs()) * ainv;
    3.0 * (gamma(3.0) * max_z * e + (delta_e * ainv) * max_z + delta_z * e)
}

impl TriTest for Watertight {
    type Pre = WatertightPre;

    #[inline(always)]
    fn prepare(ray: &Ray) -> WatertightPre {
        // The axis choice and the swap are selections, and the components are read by array
        // index (not glam's `Index`, a match per access): a ray's direction decides them, so
        // on incoherent rays branches here were mispredicted about once a ray (callgrind,
        // Sibenik random rays). The same values as the branches': `kz` is 0 where
        // `|x| ≥ |y|` and `|x| ≥ |z|`, else 1 where `|y| ≥ |z|`, else 2.
        let a = ray.dir.abs();
        let d: &[f32; 3] = ray.dir.as_ref();
        let kz = select_unpredictable(
            (a.x >= a.y) & (a.x >= a.z),
            0,
            select_unpredictable(a.y >= a.z, 1, 2),
        );
        let k1 = (kz + 1) % 3;
        let k2 = (k1 + 1) % 3;
        let dz = d[kz];
        let (kx, ky) = select_unpredictable(dz < 0.0, (k2, k1), (k1, k2));
        WatertightPre {
            kx,
            ky,
            kz,
            sx: d[kx] / dz,
            sy: d[ky] / dz,
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
        let s = Sheared::new(p, ray, tri);
        match s.solve(p.sz, ray.tmin, tmax) {
            Solved::Done(h) => h,
            Solved::Wide => s.finish(p, ray, tmax),
        }
    }

    #[inline(always)]
    fn intersect4(p: &WatertightPre, ray: &Ray, tris: &Tri4, tmax: f32) -> Lanes4 {
        #[cfg(target_arch = "x86_64")]
        {
            // SAFETY: SSE and SSE2 are part of x86-64.
            unsafe { sse::watertight4(p, ray, tris, tmax) }
        }
        #[cfg(not(target_arch = "x86_64"))]
        Lanes4::by_lanes::<Self>(p, ray, tris, tmax)
    }

    #[inline(always)]
    fn still_hits(l: &Lanes4, i: usize, tmax: f32) -> bool {
        // The scalar test's two `tmax` comparisons (the `tmin` ones do not depend on `tmax`),
        // negated as the scalar test rejects: a NaN passes there too.
        #[allow(clippy::neg_cmp_op_on_partial_ord)]
        let keep = !(l.tt[i] >= tmax * l.det[i]) && !(l.t[i] >= tmax);
        keep
    }
}

/// The 4-wide tests with SSE: each line is the scalar test's operation on four lanes (no fused
/// multiply-add, IEEE division, ordered comparisons that are false for NaN as Rust's are).
#[cfg(target_arch = "x86_64")]
mod sse;

/// The geometric normal of `tri` facing against `dir` (for offsetting secondary rays).
pub fn facing_normal(tri: &Triangle, dir: Vec3) -> Vec3 {
    let n = tri.unit_normal();
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

    /// A deterministic generator (no dependency): xorshift from `seed`, uniform in `[-1, 1)`.
    fn uniform(mut s: u64) -> impl FnMut() -> f32 {
        move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0
        }
    }

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

    /// `intersect4` resolved as the wide BVH resolves it (lanes in order, `still_hits` against
    /// the closest so far, `redo` lanes by the scalar test) against the scalar loop.
    fn four_equals_scalar<T: TriTest>(tris: &[Triangle], ray: &Ray) -> usize {
        let pre = T::prepare(ray);
        let mut hits = 0;
        for chunk in tris.chunks(4) {
            let block = Tri4::new(chunk);
            for (l, t) in chunk.iter().enumerate() {
                assert_eq!(block.lane(l), *t);
            }
            // Scalar loop, closest hit.
            let mut best = (ray.tmax, None);
            for (l, t) in chunk.iter().enumerate() {
                if let Some(h) = T::intersect(&pre, ray, t, best.0) {
                    best = (h.0, Some((l, h)));
                }
            }
            let l4 = T::intersect4(&pre, ray, &block, ray.tmax);
            let mut four = (ray.tmax, None);
            let mut cand = (l4.hit | l4.redo) & ((1 << chunk.len()) - 1);
            while cand != 0 {
                let i = cand.trailing_zeros() as usize;
                cand &= cand - 1;
                let h = if l4.redo & (1 << i) != 0 {
                    T::intersect(&pre, ray, &chunk[i], four.0)
                } else {
                    T::still_hits(&l4, i, four.0).then_some((l4.t[i], l4.u[i], l4.v[i]))
                };
                if let Some(h) = h {
                    four = (h.0, Some((i, h)));
                }
            }
            let bits = |x: Option<(usize, (f32, f32, f32))>| {
                x.map(|(i, h)| (i, h.0.to_bits(), h.1.to_bits(), h.2.to_bits()))
            };
            assert_eq!(bits(four.1), bits(best.1), "{ray:?} {chunk:?}");
            // Every lane on its own: hit lanes carry the scalar answer, other lanes miss; also
            // with `tmax` at the closest hit and below it (the lanes beyond it are rejected
            // before the division, and a block of such lanes ends early).
            for tmax in [ray.tmax, best.0, best.0 * 0.5] {
                let l4 = T::intersect4(&pre, ray, &block, tmax);
                for (l, t) in chunk.iter().enumerate() {
                    let s = T::intersect(&pre, ray, t, tmax);
                    if l4.redo & (1 << l) == 0 {
                        let got = (l4.hit & (1 << l) != 0).then_some((l4.t[l], l4.u[l], l4.v[l]));
                        assert_eq!(bits(got.map(|h| (l, h))), bits(s.map(|h| (l, h))), "{tmax}");
                    }
                    hits += (tmax == ray.tmax && s.is_some()) as usize;
                }
            }
        }
        hits
    }

    #[test]
    fn four_wide_tests_equal_the_scalar_ones() {
        // A deterministic generator (no dependency): triangles around the origin, some sharing
        // edges and vertices, some degenerate; rays from outside, some through vertices and
        // edges, axis-parallel, and finite segments.
        let mut rnd = uniform(0x9e3779b97f4a7c15);
        let mut tris = Vec::new();
        for i in 0..400 {
            let c = Vec3::new(rnd(), rnd(), rnd());
            let a = c + Vec3::new(rnd(), rnd(), rnd()) * 0.5;
            let b = c + Vec3::new(rnd(), rnd(), rnd()) * 0.5;
            let t = match i % 7 {
                // Shares the edge c–a of the previous triangle.
                0 if !tris.is_empty() => {
                    let p: &Triangle = tris.last().unwrap();
                    Triangle::new(p.v0, p.v1, b)
                }
                // Degenerate.
                1 => Triangle::new(c, a, a),
                _ => Triangle::new(c, a, b),
            };
            tris.push(t);
        }
        let mut hits = 0;
        for k in 0..3000 {
            let o = Vec3::new(rnd(), rnd(), rnd()) * 3.0;
            let tri = tris[k % tris.len()];
            let target = match k % 4 {
                0 => tri.v0,
                1 => (tri.v0 + tri.v1) * 0.5,
                _ => Vec3::new(rnd(), rnd(), rnd()),
            };
            let mut d = (target - o).normalize_or_zero();
            if k % 9 == 0 {
                d = [Vec3::X, -Vec3::Y, Vec3::Z][k % 3];
            }
            if d == Vec3::ZERO {
                continue;
            }
            let ray = if k % 5 == 0 {
                Ray::segment(o, d, 0.5, 3.0 + rnd())
            } else {
                Ray::new(o, d)
            };
            hits += four_equals_scalar::<Watertight>(&tris, &ray);
            hits += four_equals_scalar::<MollerTrumbore>(&tris, &ray);
        }
        assert!(hits > 1000, "too few hits ({hits}) to mean anything");
    }

    /// Where f32's products leave their range only because the whole scene is
    /// scaled (by `2^±100`, about 1e±30), the watertight test's finish ([`Sheared::finish`])
    /// answers bit for bit as the test does at scale 1, the distance scaled alike; the GPU's
    /// prelude does the same, so both devices agree at every scale.
    #[test]
    fn power_of_two_scenes_answer_as_at_scale_one() {
        let mut rnd = uniform(0x9e3779b97f4a7c15);
        let (mut hits, mut checked) = (0, 0);
        for e in [-100, -70, 70, 100] {
            let s = ldexp(1.0, e);
            for k in 0..3000 {
                let c = Vec3::new(rnd(), rnd(), rnd());
                let tri = Triangle::new(
                    c,
                    c + Vec3::new(rnd(), rnd(), rnd()) * 0.3,
                    c + Vec3::new(rnd(), rnd(), rnd()) * 0.3,
                );
                let o = Vec3::new(rnd(), rnd(), rnd()) * 2.0;
                let d = (tri.v0 * 0.4 + tri.v1 * 0.3 + tri.v2 * 0.3 - o).normalize_or_zero()
                    + Vec3::new(rnd(), rnd(), rnd()) * 0.01;
                if d == Vec3::ZERO {
                    continue;
                }
                let ray = if k % 4 == 0 {
                    Ray::segment(o, d, 0.01, 1.5)
                } else {
                    Ray::new(o, d)
                };
                let big = Triangle::new(tri.v0 * s, tri.v1 * s, tri.v2 * s);
                let mut sray = Ray::new(ray.origin * s, ray.dir);
                sray.tmin = ray.tmin * s;
                sray.tmax = ray.tmax * s;
                let want = Watertight::intersect(&Watertight::prepare(&ray), &ray, &tri, ray.tmax);
                let got =
                    Watertight::intersect(&Watertight::prepare(&sray), &sray, &big, sray.tmax);
                let scaled = want.map(|(t, u, v)| ((t * s).to_bits(), u.to_bits(), v.to_bits()));
                let got_bits = got.map(|(t, u, v)| (t.to_bits(), u.to_bits(), v.to_bits()));
                assert_eq!(scaled, got_bits, "2^{e}: {ray:?} {tri:?}");
                hits += want.is_some() as usize;
                checked += 1;
            }
        }
        assert!(
            hits > checked / 4,
            "too few hits ({hits} of {checked}) to mean anything"
        );
    }

    /// The plane distance of `r`'s origin to `tri` along `r.dir` in f64 (exact enough to tell
    /// the sign of an f32 test's `t`).
    fn plane_t(tri: &Triangle, r: &Ray) -> f64 {
        let d = |v: Vec3| v.as_dvec3();
        let n = (d(tri.v1) - d(tri.v0)).cross(d(tri.v2) - d(tri.v0));
        n.dot(d(tri.v0) - d(r.origin)) / n.dot(d(r.dir))
    }

    /// Hits behind the origin and extreme scales at the triangle test: rays starting on a
    /// triangle's plane, a few ulps in front of or behind it, in every direction, at scales
    /// 1e-30 to 1e30. The watertight test reports no hit whose plane lies behind the origin
    /// (conservative `t`; Möller–Trumbore neither, with its own bound), hits at every scale
    /// (scaled by a power of two, else in f64, where f32's products would leave their range),
    /// and its four-wide form equals the scalar one bit for bit.
    #[test]
    fn no_hit_behind_the_origin_at_any_scale() {
        let mut rnd = uniform(0x2545f4914f6cdd1d);
        for scale in [1e-30f32, 1e-12, 1.0, 1e12, 1e30] {
            let mut tris = Vec::new();
            for _ in 0..64 {
                let c = Vec3::new(rnd(), rnd(), rnd());
                let e = |r: &mut dyn FnMut() -> f32| Vec3::new(r(), r(), r()) * 0.5;
                let (a, b) = (c + e(&mut rnd), c + e(&mut rnd));
                tris.push(Triangle::new(c * scale, a * scale, b * scale));
            }
            let (mut hits, mut from_outside) = (0, 0);
            for k in 0..2000 {
                let tri = tris[k % tris.len()];
                let (u, v) = (rnd().abs() * 0.5, rnd().abs() * 0.5);
                let on = tri.v0 + (tri.v1 - tri.v0) * u + (tri.v2 - tri.v0) * v;
                let d = Vec3::new(rnd(), rnd(), rnd()).normalize_or_zero();
                if d == Vec3::ZERO {
                    continue;
                }
                // On the plane (rounded), a few ulps off it along an axis, or from outside.
                let mut o = on;
                let axis = k % 3;
                let ulps = (k / 3 % 9) as i32 - 4;
                o[axis] = f32::from_bits((o[axis].to_bits() as i32 + ulps) as u32);
                let outside = k % 10 == 0;
                let ray = if outside {
                    Ray::new(on - d * (2.0 * scale), d)
                } else {
                    Ray::new(o, d)
                };
                let pre = Watertight::prepare(&ray);
                for t in &tris {
                    if let Some(h) = Watertight::intersect(&pre, &ray, t, ray.tmax) {
                        let exact = plane_t(t, &ray);
                        assert!(
                            exact > 0.0,
                            "scale {scale}: hit at t {} whose plane is at {exact}: {ray:?} {t:?}",
                            h.0
                        );
                        hits += 1;
                        from_outside += outside as usize;
                    }
                    if let Some(h) = MollerTrumbore::intersect(&(), &ray, t, ray.tmax) {
                        let exact = plane_t(t, &ray);
                        assert!(
                            exact > 0.0,
                            "scale {scale}: Möller–Trumbore hit at t {} whose plane is at \
                             {exact}: {ray:?} {t:?}",
                            h.0
                        );
                    }
                }
                four_equals_scalar::<Watertight>(&tris, &ray);
                four_equals_scalar::<MollerTrumbore>(&tris, &ray);
            }
            assert!(
                from_outside > 50,
                "scale {scale}: {from_outside} hits from outside"
            );
            assert!(hits > 200, "scale {scale}: {hits} hits");
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
