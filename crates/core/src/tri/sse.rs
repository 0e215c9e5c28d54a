//! The 4-wide tests with SSE: each line is the scalar test's operation on four lanes (no fused
//! multiply-add, IEEE division, ordered comparisons that are false for NaN as Rust's are).

use super::{Lanes4, Tri4, WatertightPre};
use crate::geom::Ray;
use std::arch::x86_64::*;

#[inline(always)]
unsafe fn store(v: __m128) -> [f32; 4] {
    let mut a = [0.0f32; 4];
    // SAFETY: four floats into a four-float array.
    unsafe { _mm_storeu_ps(a.as_mut_ptr(), v) };
    a
}

/// `x != 0 && x` finite: `0 < |x| < inf` (false for NaN).
#[inline(always)]
unsafe fn nonzero_finite(x: __m128) -> __m128 {
    unsafe {
        let abs = _mm_andnot_ps(_mm_set1_ps(-0.0), x);
        _mm_and_ps(
            _mm_cmpgt_ps(abs, _mm_setzero_ps()),
            _mm_cmplt_ps(abs, _mm_set1_ps(f32::INFINITY)),
        )
    }
}

#[inline(always)]
unsafe fn abs(x: __m128) -> __m128 {
    unsafe { _mm_andnot_ps(_mm_set1_ps(-0.0), x) }
}

/// `!(|x| < inf)`: infinite or NaN.
#[inline(always)]
unsafe fn not_finite(x: __m128) -> __m128 {
    unsafe { _mm_cmpnlt_ps(abs(x), _mm_set1_ps(f32::INFINITY)) }
}

/// The triangles' vertices relative to the ray origin, permuted (`kx`, `ky`, `kz`) and sheared
/// into the ray's space: `x` and `y` of vertices a, b, c, and their unscaled `z`.
#[inline(always)]
unsafe fn sheared4(
    p: &WatertightPre,
    ray: &Ray,
    b: &Tri4,
) -> ([__m128; 3], [__m128; 3], [__m128; 3]) {
    // SAFETY: aligned loads of the block's rows; SSE/SSE2 only.
    unsafe {
        let o = ray.origin.to_array();
        let rel =
            |k: usize, a: usize| _mm_sub_ps(_mm_load_ps(b.v[k][a].as_ptr()), _mm_set1_ps(o[a]));
        let (sx, sy) = (_mm_set1_ps(p.sx), _mm_set1_ps(p.sy));
        let (az, bz, cz) = (rel(0, p.kz), rel(1, p.kz), rel(2, p.kz));
        let ax = _mm_sub_ps(rel(0, p.kx), _mm_mul_ps(sx, az));
        let ay = _mm_sub_ps(rel(0, p.ky), _mm_mul_ps(sy, az));
        let bx = _mm_sub_ps(rel(1, p.kx), _mm_mul_ps(sx, bz));
        let by = _mm_sub_ps(rel(1, p.ky), _mm_mul_ps(sy, bz));
        let cx = _mm_sub_ps(rel(2, p.kx), _mm_mul_ps(sx, cz));
        let cy = _mm_sub_ps(rel(2, p.ky), _mm_mul_ps(sy, cz));
        ([ax, bx, cx], [ay, by, cy], [az, bz, cz])
    }
}

/// The masks of the edge functions `u`, `v`, `w`: an exactly zero one (the scalar test
/// recomputes in f64), and signs that disagree (a negative and a positive one).
#[inline(always)]
unsafe fn edge_signs(u: __m128, v: __m128, w: __m128) -> (__m128, __m128) {
    // SAFETY: SSE/SSE2 only (x86-64's baseline).
    unsafe {
        let zero = _mm_setzero_ps();
        let zero_edge = _mm_or_ps(
            _mm_or_ps(_mm_cmpeq_ps(u, zero), _mm_cmpeq_ps(v, zero)),
            _mm_cmpeq_ps(w, zero),
        );
        let neg = _mm_or_ps(
            _mm_or_ps(_mm_cmplt_ps(u, zero), _mm_cmplt_ps(v, zero)),
            _mm_cmplt_ps(w, zero),
        );
        let pos = _mm_or_ps(
            _mm_or_ps(_mm_cmpgt_ps(u, zero), _mm_cmpgt_ps(v, zero)),
            _mm_cmpgt_ps(w, zero),
        );
        (zero_edge, _mm_and_ps(neg, pos))
    }
}

/// [`super::t_error_bound`] on four lanes, operation by operation: the sheared `x` and `y` of
/// the vertices, their scaled `z`, the edge functions `u, v, w` and `1 / det`.
#[inline(always)]
unsafe fn t_error_bound4(
    [ax, bx, cx]: [__m128; 3],
    [ay, by, cy]: [__m128; 3],
    [azs, bzs, czs]: [__m128; 3],
    [u, v, w]: [__m128; 3],
    inv: __m128,
) -> __m128 {
    // SAFETY: SSE/SSE2 only (x86-64's baseline).
    unsafe {
        let max3 = |a: __m128, b: __m128, c: __m128| _mm_max_ps(_mm_max_ps(abs(a), abs(b)), abs(c));
        let (max_x, max_y, max_z) = (max3(ax, bx, cx), max3(ay, by, cy), max3(azs, bzs, czs));
        let g = |n: f32| _mm_set1_ps(super::gamma(n));
        let delta_z = _mm_mul_ps(g(3.0), max_z);
        let delta_x = _mm_mul_ps(g(5.0), _mm_add_ps(max_x, max_z));
        let delta_y = _mm_mul_ps(g(5.0), _mm_add_ps(max_y, max_z));
        let ainv = abs(inv);
        let delta_e = _mm_mul_ps(
            _mm_set1_ps(2.0),
            _mm_add_ps(
                _mm_add_ps(
                    _mm_mul_ps(_mm_mul_ps(g(2.0), max_x), max_y),
                    _mm_mul_ps(delta_y, max_x),
                ),
                _mm_mul_ps(delta_x, max_y),
            ),
        );
        let e = _mm_mul_ps(max3(u, v, w), ainv);
        _mm_mul_ps(
            _mm_set1_ps(3.0),
            _mm_add_ps(
                _mm_add_ps(
                    _mm_mul_ps(_mm_mul_ps(g(3.0), max_z), e),
                    _mm_mul_ps(_mm_mul_ps(delta_e, ainv), max_z),
                ),
                _mm_mul_ps(delta_z, e),
            ),
        )
    }
}

/// [`super::Watertight::intersect`] on four lanes.
#[inline(always)]
pub(super) unsafe fn watertight4(p: &WatertightPre, ray: &Ray, b: &Tri4, tmax: f32) -> Lanes4 {
    // SAFETY: aligned loads of the block's rows; SSE/SSE2 only.
    unsafe {
        let ([ax, bx, cx], [ay, by, cy], [az, bz, cz]) = sheared4(p, ray, b);
        let sz = _mm_set1_ps(p.sz);
        let u = _mm_sub_ps(_mm_mul_ps(cx, by), _mm_mul_ps(cy, bx));
        let v = _mm_sub_ps(_mm_mul_ps(ax, cy), _mm_mul_ps(ay, cx));
        let w = _mm_sub_ps(_mm_mul_ps(bx, ay), _mm_mul_ps(by, ax));
        let zero = _mm_setzero_ps();
        // Lanes whose edge functions disagree in sign miss (the scalar test's first
        // rejection); most triangles a ray reaches are such misses, so a block without any
        // other lane ends here (as Embree's tests end when no lane is left).
        let (zero_edge, mixed) = edge_signs(u, v, w);
        let miss = _mm_andnot_ps(zero_edge, mixed);
        if _mm_movemask_ps(miss) == 0b1111 {
            return Lanes4::NONE;
        }
        let det = _mm_add_ps(_mm_add_ps(u, v), w);
        let (azs, bzs, czs) = (_mm_mul_ps(sz, az), _mm_mul_ps(sz, bz), _mm_mul_ps(sz, cz));
        let tt = _mm_add_ps(
            _mm_add_ps(_mm_mul_ps(u, azs), _mm_mul_ps(v, bzs)),
            _mm_mul_ps(w, czs),
        );
        // `det < 0`: flip both signs (exact); lanes with det = 0 or NaN are rejected anyway.
        let flip = _mm_and_ps(_mm_cmplt_ps(det, zero), _mm_set1_ps(-0.0));
        let (tt_s, det_s) = (_mm_xor_ps(tt, flip), _mm_xor_ps(det, flip));
        let (tmin_v, tmax_v) = (_mm_set1_ps(ray.tmin), _mm_set1_ps(tmax));
        let out1 = _mm_or_ps(
            _mm_cmplt_ps(tt_s, _mm_mul_ps(tmin_v, det_s)),
            _mm_cmpge_ps(tt_s, _mm_mul_ps(tmax_v, det_s)),
        );
        // The scalar test's second rejection: a determinant in range, a finite distance
        // outside `[tmin, tmax)` (farther than the closest hit so far, mostly). When every
        // lane is out by one rejection or the other, the division and the bound are spared.
        let abs_det = abs(det);
        let in_range = _mm_and_ps(
            _mm_cmpge_ps(abs_det, _mm_set1_ps(super::F32_DET_MIN)),
            _mm_cmple_ps(abs_det, _mm_set1_ps(super::F32_DET_MAX)),
        );
        let far = _mm_andnot_ps(
            zero_edge,
            _mm_and_ps(_mm_andnot_ps(not_finite(tt), in_range), out1),
        );
        if _mm_movemask_ps(_mm_or_ps(miss, far)) == 0b1111 {
            return Lanes4::NONE;
        }
        let inv = _mm_div_ps(_mm_set1_ps(1.0), det);
        let t = _mm_mul_ps(tt, inv);
        let out2 = _mm_or_ps(_mm_cmplt_ps(t, tmin_v), _mm_cmpge_ps(t, tmax_v));
        // The error bound of `t` (`super::t_error_bound`, operation by operation).
        let bound = t_error_bound4([ax, bx, cx], [ay, by, cy], [azs, bzs, czs], [u, v, w], inv);
        let behind = _mm_cmple_ps(t, bound);
        // Lanes the scalar test finishes in f64 (`Sheared::in_f64`): a determinant out of
        // the f32 range, a non-finite distance or bound (among lanes with consistent signs).
        let unfinished = _mm_or_ps(
            _mm_andnot_ps(in_range, _mm_set1_ps(f32::from_bits(!0))),
            _mm_or_ps(not_finite(tt), not_finite(bound)),
        );
        let redo = _mm_or_ps(zero_edge, _mm_andnot_ps(mixed, unfinished));
        let reject = _mm_or_ps(
            _mm_or_ps(redo, mixed),
            _mm_or_ps(_mm_or_ps(out1, out2), behind),
        );
        let hit = _mm_andnot_ps(reject, _mm_set1_ps(f32::from_bits(!0)));
        Lanes4 {
            hit: _mm_movemask_ps(hit) as u32,
            redo: _mm_movemask_ps(redo) as u32,
            t: store(t),
            u: store(_mm_mul_ps(v, inv)),
            v: store(_mm_mul_ps(w, inv)),
            tt: store(tt_s),
            det: store(det_s),
        }
    }
}

/// [`super::MollerTrumbore::intersect`] on four lanes (glam's `dot` and `cross` spelt out
/// in their order of operations).
#[inline(always)]
pub(super) unsafe fn moller_trumbore4(ray: &Ray, b: &Tri4, tmax: f32) -> Lanes4 {
    // SAFETY: aligned loads of the block's rows; SSE/SSE2 only.
    unsafe {
        let row = |k: usize, a: usize| _mm_load_ps(b.v[k][a].as_ptr());
        let v0 = [row(0, 0), row(0, 1), row(0, 2)];
        let e1 = [0, 1, 2].map(|a| _mm_sub_ps(row(1, a), v0[a]));
        let e2 = [0, 1, 2].map(|a| _mm_sub_ps(row(2, a), v0[a]));
        let d = ray.dir.to_array().map(|x| _mm_set1_ps(x));
        let o = ray.origin.to_array().map(|x| _mm_set1_ps(x));
        // glam: cross(a, b) = (a.y·b.z − b.y·a.z, a.z·b.x − b.z·a.x, a.x·b.y − b.x·a.y),
        // dot(a, b) = (a.x·b.x + a.y·b.y) + a.z·b.z.
        let cross = |a: &[__m128; 3], b: &[__m128; 3]| {
            [
                _mm_sub_ps(_mm_mul_ps(a[1], b[2]), _mm_mul_ps(b[1], a[2])),
                _mm_sub_ps(_mm_mul_ps(a[2], b[0]), _mm_mul_ps(b[2], a[0])),
                _mm_sub_ps(_mm_mul_ps(a[0], b[1]), _mm_mul_ps(b[0], a[1])),
            ]
        };
        let dot = |a: &[__m128; 3], b: &[__m128; 3]| {
            _mm_add_ps(
                _mm_add_ps(_mm_mul_ps(a[0], b[0]), _mm_mul_ps(a[1], b[1])),
                _mm_mul_ps(a[2], b[2]),
            )
        };
        let p = cross(&d, &e2);
        let det = dot(&e1, &p);
        let inv = _mm_div_ps(_mm_set1_ps(1.0), det);
        let s = [0, 1, 2].map(|a| _mm_sub_ps(o[a], v0[a]));
        let u = _mm_mul_ps(dot(&s, &p), inv);
        let (zero, one) = (_mm_setzero_ps(), _mm_set1_ps(1.0));
        let u_in = _mm_and_ps(_mm_cmpge_ps(u, zero), _mm_cmple_ps(u, one));
        let q = cross(&s, &e1);
        let v = _mm_mul_ps(dot(&d, &q), inv);
        let v_out = _mm_or_ps(_mm_cmplt_ps(v, zero), _mm_cmpgt_ps(_mm_add_ps(u, v), one));
        let t = _mm_mul_ps(dot(&e2, &q), inv);
        // `super::mt_error_bound`, operation by operation.
        let (sa, e1a, e2a) = (s.map(|x| abs(x)), e1.map(|x| abs(x)), e2.map(|x| abs(x)));
        let acr = [
            _mm_add_ps(_mm_mul_ps(sa[1], e1a[2]), _mm_mul_ps(sa[2], e1a[1])),
            _mm_add_ps(_mm_mul_ps(sa[2], e1a[0]), _mm_mul_ps(sa[0], e1a[2])),
            _mm_add_ps(_mm_mul_ps(sa[0], e1a[1]), _mm_mul_ps(sa[1], e1a[0])),
        ];
        let bound = _mm_mul_ps(
            _mm_mul_ps(_mm_set1_ps(super::gamma(9.0)), dot(&e2a, &acr)),
            abs(inv),
        );
        let t_in = _mm_and_ps(
            _mm_and_ps(
                _mm_cmpge_ps(t, _mm_set1_ps(ray.tmin)),
                _mm_cmplt_ps(t, _mm_set1_ps(tmax)),
            ),
            _mm_cmpgt_ps(t, bound),
        );
        let hit = _mm_andnot_ps(
            v_out,
            _mm_and_ps(_mm_and_ps(nonzero_finite(det), u_in), t_in),
        );
        Lanes4 {
            hit: _mm_movemask_ps(hit) as u32,
            redo: 0,
            t: store(t),
            u: store(u),
            v: store(v),
            tt: [0.0; 4],
            det: [0.0; 4],
        }
    }
}
