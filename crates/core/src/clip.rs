//! Conservative boxes of a triangle clipped to an axis-aligned box: the one clipping routine of
//! the builders that split triangles (kd-trees with perfect splits, Havran 2000 §4 and Wald and
//! Havran 2006 §4; SBVH spatial splits, Stich, Friedrich and Dietrich 2009 §4.2).
//!
//! Clipping is Sutherland–Hodgman against the box's planes. An intersection point gets the
//! clipping plane's coordinate exactly, but its other coordinates are rounded, so the bounds
//! of the clipped polygon are grown by [`tolerance`] (64 ulps of the triangle's coordinate
//! magnitude) and then cut back to the box and to the reference's previous box: sides that lie
//! on an original vertex or on a clipping plane stay exact (axis-aligned triangles stay
//! planar), the others become slightly conservative, so every point of the triangle inside the
//! box is inside the result. Should clipping leave nothing (rounding), the cut-back box is kept.

use crate::geom::{Aabb, Triangle, Vec3};

/// The rounding allowance of clipped boxes of a triangle with bounds `b`, per axis.
pub fn tolerance(b: &Aabb) -> Vec3 {
    let m = b.min.abs().max(b.max.abs());
    m * (64.0 * f32::EPSILON) + Vec3::splat(f32::MIN_POSITIVE)
}

/// The intersection of two boxes (empty, `min > max` on some axis, when they are disjoint).
pub fn intersect(a: &Aabb, b: &Aabb) -> Aabb {
    Aabb {
        min: a.min.max(b.min),
        max: a.max.min(b.max),
    }
}

const MAX_POLY: usize = 16;

/// Clip the convex polygon `inp[..n]` to the half-space `p[a] >= c` (`keep_ge`) or
/// `p[a] <= c`; returns the new vertex count.
fn clip_plane(
    inp: &[Vec3; MAX_POLY],
    n: usize,
    out: &mut [Vec3; MAX_POLY],
    a: usize,
    c: f32,
    keep_ge: bool,
) -> usize {
    let inside = |p: &Vec3| if keep_ge { p[a] >= c } else { p[a] <= c };
    let mut m = 0;
    for i in 0..n {
        let p = inp[i];
        let q = inp[if i + 1 == n { 0 } else { i + 1 }];
        let (pin, qin) = (inside(&p), inside(&q));
        if pin {
            out[m] = p;
            m += 1;
        }
        if pin != qin {
            let t = (c - p[a]) / (q[a] - p[a]);
            let mut x = p + (q - p) * t;
            x[a] = c;
            out[m] = x;
            m += 1;
        }
    }
    m
}

/// A conservative box of `tri ∩ cell`, inside `lim` (a conservative box of the triangle in a
/// box containing `cell`, e.g. the triangle's own bounds); empty when the triangle misses the
/// cell.
pub fn clip_box(tri: &Triangle, lim: &Aabb, cell: &Aabb) -> Aabb {
    let lim = intersect(lim, cell);
    if lim.is_empty() {
        return Aabb::EMPTY;
    }
    let tb = tri.bounds();
    if cell.contains_box(&tb) {
        return intersect(&tb, &lim);
    }
    let mut a = [Vec3::ZERO; MAX_POLY];
    let mut b = [Vec3::ZERO; MAX_POLY];
    a[0] = tri.v0;
    a[1] = tri.v1;
    a[2] = tri.v2;
    let mut n = 3;
    for axis in 0..3 {
        if tb.min[axis] < cell.min[axis] {
            n = clip_plane(&a, n, &mut b, axis, cell.min[axis], true);
            std::mem::swap(&mut a, &mut b);
        }
        if tb.max[axis] > cell.max[axis] {
            n = clip_plane(&a, n, &mut b, axis, cell.max[axis], false);
            std::mem::swap(&mut a, &mut b);
        }
    }
    if n == 0 {
        // The triangle misses the cell (its box only overlaps it).
        return Aabb::EMPTY;
    }
    let mut pb = Aabb::EMPTY;
    for p in &a[..n] {
        pb.grow(*p);
    }
    let tol = tolerance(&tb);
    let grown = Aabb::new(pb.min - tol, pb.max + tol);
    let out = intersect(&grown, &lim);
    if out.is_empty() {
        lim
    } else {
        out
    }
}

/// A conservative box of the part of `tri` in the slab `lo ≤ p[axis] ≤ hi`, inside `lim`
/// (a conservative box of the triangle in a region containing the slab's part of it); empty
/// when the triangle misses the slab. The part is a convex polygon whose corners are the
/// triangle's vertices inside the slab and the points where its edges cross the two planes, so
/// no general clipping is needed (the cheap chopping of SBVH spatial-split binning, Stich et
/// al. 2009 §4.2); the result is grown by [`tolerance`] and cut back as [`clip_box`]'s.
pub fn slab_box(tri: &Triangle, lim: &Aabb, axis: usize, lo: f32, hi: f32) -> Aabb {
    let mut cell = *lim;
    cell.min[axis] = cell.min[axis].max(lo);
    cell.max[axis] = cell.max[axis].min(hi);
    if cell.is_empty() {
        return Aabb::EMPTY;
    }
    let tb = tri.bounds();
    if tb.min[axis] >= lo && tb.max[axis] <= hi {
        return intersect(&tb, &cell);
    }
    let v = [tri.v0, tri.v1, tri.v2];
    let mut pb = Aabb::EMPTY;
    for i in 0..3 {
        let p = v[i];
        let q = v[(i + 1) % 3];
        if p[axis] >= lo && p[axis] <= hi {
            pb.grow(p);
        }
        for c in [lo, hi] {
            if (p[axis] < c && q[axis] > c) || (p[axis] > c && q[axis] < c) {
                let t = (c - p[axis]) / (q[axis] - p[axis]);
                let mut x = p + (q - p) * t;
                x[axis] = c;
                pb.grow(x);
            }
        }
    }
    if pb.is_empty() {
        return Aabb::EMPTY;
    }
    let tol = tolerance(&tb);
    let grown = Aabb::new(pb.min - tol, pb.max + tol);
    let out = intersect(&grown, &cell);
    if out.is_empty() {
        cell
    } else {
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clipping_is_conservative() {
        let t = Triangle::new(
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(4.0, 0.0, 1.0),
            Vec3::new(0.0, 4.0, 2.0),
        );
        let cell = Aabb::new(Vec3::new(1.0, 1.0, -1.0), Vec3::new(2.0, 2.0, 5.0));
        let b = clip_box(&t, &t.bounds(), &cell);
        // Points of the triangle inside the cell, sampled.
        for i in 0..=40 {
            for j in 0..=40 - i {
                let (u, v) = (i as f32 / 40.0, j as f32 / 40.0);
                let p = t.v0 + (t.v1 - t.v0) * u + (t.v2 - t.v0) * v;
                if cell.contains_box(&Aabb::new(p, p)) {
                    assert!(b.contains_box(&Aabb::new(p, p)), "{p} not in {b:?}");
                }
            }
        }
        assert!(b.max.x <= 2.0 && b.min.x >= 1.0 && b.max.z < 2.0);
        // Axis-aligned triangles stay planar.
        let f = Triangle::new(
            Vec3::ZERO,
            Vec3::new(4.0, 0.0, 0.0),
            Vec3::new(0.0, 4.0, 0.0),
        );
        let b = clip_box(&f, &f.bounds(), &cell);
        assert_eq!((b.min.z, b.max.z), (0.0, 0.0));
        // A triangle missing the cell's box gives the empty box.
        let far = Aabb::new(Vec3::splat(10.0), Vec3::splat(11.0));
        assert!(clip_box(&t, &t.bounds(), &far).is_empty());
    }

    #[test]
    fn slab_boxes_are_conservative_and_no_larger_than_clip_boxes() {
        let t = Triangle::new(
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(4.0, 0.0, 1.0),
            Vec3::new(0.0, 4.0, 2.0),
        );
        let tb = t.bounds();
        for axis in 0..3 {
            for (lo, hi) in [(0.5f32, 1.5f32), (1.0, 3.0), (-1.0, 0.25), (3.5, 9.0)] {
                let b = slab_box(&t, &tb, axis, lo, hi);
                let mut cell = tb;
                cell.min[axis] = lo;
                cell.max[axis] = hi;
                for i in 0..=40 {
                    for j in 0..=40 - i {
                        let (u, v) = (i as f32 / 40.0, j as f32 / 40.0);
                        let p = t.v0 + (t.v1 - t.v0) * u + (t.v2 - t.v0) * v;
                        if p[axis] >= lo && p[axis] <= hi {
                            assert!(b.contains_box(&Aabb::new(p, p)), "{p} not in {b:?}");
                        }
                    }
                }
                let c = clip_box(&t, &tb, &cell);
                let tol = tolerance(&tb) * 2.0;
                assert!(
                    Aabb::new(c.min - tol, c.max + tol).contains_box(&b),
                    "{b:?} vs {c:?}"
                );
            }
        }
        assert!(slab_box(&t, &tb, 0, 5.0, 6.0).is_empty());
    }
}
