//! The ray–box slab test of the hierarchy traversals, specialised by ray octant.
//!
//! Per ray, [`RayBox::new`] computes `1/dir` and the octant (bit `a` set when `inv[a] < 0`,
//! as [`crate::Aabb::intersect`] decides: a `−0` direction component gives `−inf`). Kernels
//! make the octant a const parameter (`OCT`), so which plane of each slab is near is known at
//! compile time (pbrt-v3 §4.3.5, `dirIsNeg`) and the test needs no min/max of plane pairs.
//!
//! Robustness is that of [`crate::Aabb::intersect`]: the `NaN` of `0 · inf` (origin in a
//! slab's plane, zero direction component) is ignored by the folds ([`max_num`]/[`min_num`]),
//! so a ray lying in a box face enters the box; the exit distance is scaled by
//! [`EXIT_SCALE`] `= 1 + 2·gamma(3)` (Ize 2013) so rounding never culls a box the ray touches.

use crate::geom::{gamma, Ray};

/// `1 + 2·gamma(3)`: the exit-distance scaling of the robust slab test (Ize 2013); also the
/// slack when comparing a stored entry distance with the closest hit.
pub const EXIT_SCALE: f32 = 1.0 + 2.0 * gamma(3);

/// Per-ray data of the octant-specialised slab test.
#[derive(Clone, Copy, Debug)]
pub struct RayBox {
    /// The ray's origin.
    pub org: [f32; 3],
    /// The reciprocal of the ray's direction, per axis (`±inf` for a zero component).
    pub inv: [f32; 3],
}

impl RayBox {
    /// The ray's slab data and its octant.
    #[inline(always)]
    pub fn new(ray: &Ray) -> (Self, u8) {
        let inv = ray.inv_dir().to_array();
        let oct = (inv[0] < 0.0) as u8 | ((inv[1] < 0.0) as u8) << 1 | ((inv[2] < 0.0) as u8) << 2;
        (
            RayBox {
                org: ray.origin.to_array(),
                inv,
            },
            oct,
        )
    }

    /// Entry and exit distance of the box `[min, max]` clipped to `[tmin, tmax]`; the box is
    /// hit when `entry <= exit` (an empty box, `min > max`, never is). `OCT` must be the
    /// octant returned by [`RayBox::new`].
    #[inline(always)]
    pub fn slab<const OCT: u8>(
        &self,
        min: &[f32; 3],
        max: &[f32; 3],
        tmin: f32,
        tmax: f32,
    ) -> (f32, f32) {
        let pick = |a: usize| {
            if OCT & (1 << a) != 0 {
                (max[a], min[a])
            } else {
                (min[a], max[a])
            }
        };
        let (nx, fx) = pick(0);
        let (ny, fy) = pick(1);
        let (nz, fz) = pick(2);
        let tx0 = (nx - self.org[0]) * self.inv[0];
        let ty0 = (ny - self.org[1]) * self.inv[1];
        let tz0 = (nz - self.org[2]) * self.inv[2];
        let tx1 = (fx - self.org[0]) * self.inv[0];
        let ty1 = (fy - self.org[1]) * self.inv[1];
        let tz1 = (fz - self.org[2]) * self.inv[2];
        let tn = max_num(max_num(max_num(tmin, tx0), ty0), tz0);
        let tf = min_num(min_num(min_num(tmax, tx1), ty1), tz1) * EXIT_SCALE;
        (tn, tf)
    }
}

/// `$walker.walk::<T, C, $any, OCT>($ray, &rb, $c)` for the ray's octant `OCT`, with `rb` its
/// [`RayBox`]: the octant made a const parameter of a hierarchy walk (the BVH's and the
/// R-tree's), inside a generic kernel whose type parameters are named `T` and `C`.
#[macro_export]
macro_rules! by_octant {
    ($walker:expr, $ray:expr, $c:expr, $any:expr) => {{
        let ray = $ray;
        let (rb, oct) = $crate::slab::RayBox::new(ray);
        match oct {
            0 => $walker.walk::<T, C, $any, 0>(ray, &rb, $c),
            1 => $walker.walk::<T, C, $any, 1>(ray, &rb, $c),
            2 => $walker.walk::<T, C, $any, 2>(ray, &rb, $c),
            3 => $walker.walk::<T, C, $any, 3>(ray, &rb, $c),
            4 => $walker.walk::<T, C, $any, 4>(ray, &rb, $c),
            5 => $walker.walk::<T, C, $any, 5>(ray, &rb, $c),
            6 => $walker.walk::<T, C, $any, 6>(ray, &rb, $c),
            _ => $walker.walk::<T, C, $any, 7>(ray, &rb, $c),
        }
    }};
}

impl RayBox {
    /// [`RayBox::slab`] with the octant chosen at run time (for tests and one-off queries;
    /// kernels make `OCT` a const parameter instead).
    pub fn slab_dyn(
        &self,
        oct: u8,
        min: &[f32; 3],
        max: &[f32; 3],
        tmin: f32,
        tmax: f32,
    ) -> (f32, f32) {
        match oct {
            0 => self.slab::<0>(min, max, tmin, tmax),
            1 => self.slab::<1>(min, max, tmin, tmax),
            2 => self.slab::<2>(min, max, tmin, tmax),
            3 => self.slab::<3>(min, max, tmin, tmax),
            4 => self.slab::<4>(min, max, tmin, tmax),
            5 => self.slab::<5>(min, max, tmin, tmax),
            6 => self.slab::<6>(min, max, tmin, tmax),
            _ => self.slab::<7>(min, max, tmin, tmax),
        }
    }
}

/// `max(acc, t)` ignoring a `NaN` `t` (for a non-NaN `acc`); one `maxss`.
#[inline(always)]
pub fn max_num(acc: f32, t: f32) -> f32 {
    if t > acc {
        t
    } else {
        acc
    }
}

/// `min(acc, t)` ignoring a `NaN` `t`; one `minss`.
#[inline(always)]
pub fn min_num(acc: f32, t: f32) -> f32 {
    if t < acc {
        t
    } else {
        acc
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::{Aabb, Vec3};

    /// The octant-specialised test gives exactly `Aabb::intersect`'s answer, entry and exit,
    /// over a lattice of origins and directions: rays with zero direction components (both
    /// signs) lying in face planes, flat and point boxes, and the empty box (the BVH's and the
    /// R-tree's walks use this test as it is).
    #[test]
    fn agrees_with_aabb_intersect_including_face_planes() {
        let vals = [-1.0f32, -0.0, 0.0, 0.5, 1.0, 2.0];
        let dirs = [-1.0f32, -0.0, 0.0, 0.3, 1.0];
        let boxes = [
            Aabb::new(Vec3::ZERO, Vec3::ONE),
            Aabb::new(Vec3::new(0.0, 0.0, 0.5), Vec3::new(1.0, 1.0, 0.5)),
            Aabb::new(Vec3::splat(0.5), Vec3::splat(0.5)),
            Aabb::EMPTY,
        ];
        let mut hits = 0;
        for b in &boxes {
            for o in vals.iter().flat_map(|&x| vals.map(|y| (x, y))) {
                for oz in vals {
                    for d in dirs.iter().flat_map(|&x| dirs.map(|y| (x, y))) {
                        for dz in dirs {
                            let d = Vec3::new(d.0, d.1, dz);
                            if d == Vec3::ZERO {
                                continue;
                            }
                            let r = Ray::segment(Vec3::new(o.0, o.1, oz), d, 0.0, 10.0);
                            let want = b.intersect(r.origin, r.inv_dir(), r.tmin, r.tmax);
                            let (rb, oct) = RayBox::new(&r);
                            let (tn, tf) = rb.slab_dyn(
                                oct,
                                &b.min.to_array(),
                                &b.max.to_array(),
                                r.tmin,
                                r.tmax,
                            );
                            let got = (tn <= tf).then_some((tn, tf));
                            assert_eq!(want, got, "{b:?} {r:?}");
                            hits += got.is_some() as u32;
                        }
                    }
                }
            }
        }
        assert!(hits > 1000, "{hits} hits");
    }
}
