//! The cell walk every grid kind shares: the robust ray state of a walk over a lattice
//! ([`crate::lattice`]), the walk from cell to cell, and the tests of a cell's references.
//!
//! # Robustness of the walks
//!
//! The walks compute positions and plane distances in the grid's [`Precision`]: `f32` as the
//! paper's walk (hagrid) by default, or `f64` for comparison, from the `f32` ray; the triangle
//! tests are the `f32` tests every structure uses. References are assigned with the
//! separating-axis test (in `f64`) against the cell's box grown by [`Lattice::delta`] on every
//! side, so a triangle the `f32` test may report as hit just outside its exact extent, or at a
//! point the walk places a little outside the cell it is in, is still referenced by that cell.
//! The test is thus conservative (never drops a triangle, may add one touching a cell within
//! `delta`). The margin is sized for the walk's arithmetic:
//!
//! - `f64` walks locate a cell boundary crossing to about `1e-16` of the ray's length; the
//!   margin is a 2048th of a voxel of the uniform or top-level grid plus 8 `f32` ulps of the
//!   scene's coordinates, which covers the triangle test's rounding (2^-21 of `|o| + mag`).
//! - `f32` walks compute every plane position, plane distance and exit point with a few
//!   roundings each: each coordinate of a point the walk places in a cell lies within about
//!   12 roundings (2^-24 each) of `|o| + mag` of that cell's box, whatever the ray's direction
//!   (a distance's error along a nearly parallel axis moves the point along the ray, not off
//!   the plane). The margin is a 2048th of a voxel plus 32 ulps of the coordinates, and rays
//!   are sent to brute force at 2^-19 of `|o| + mag` instead of 2^-21: the triangle test's
//!   rounding plus 24 roundings for the walk, twice the estimate. Origins inside the grid's
//!   box are never far in either precision; the far threshold lies about 256 voxels of the
//!   uniform or top-level grid beyond the box in `f32` (1024 in `f64`). A larger voxel share
//!   would keep 1024, but a 512th of a voxel added up to 53 % triangle tests on
//!   `teapot-stadium` (the teapot's triangles near every cell face), 32 ulps add at most 4.5 %
//!   there and 0.01 % at the median of `configs/ci.toml`'s grid rows.
//!
//! Rays whose origin is so far away that the rounding exceeds `delta` ([`Lattice::far`]) test
//! every triangle instead. Every step of either walk is monotone in voxel indices, so walks
//! end whatever the rounding.

use crate::lattice::{Lattice, Planes, Real};
use std::hint::select_unpredictable;
use std::ops::Range;
use tb_core::{Counter, HitRecord, Ray, TriTest, Triangle};

/// The walk ray's coordinates in voxel units of one lattice as linear functions of `t`:
/// `base + t·slope` per axis, `base = (o − min)·(1/size)` and `slope = d·(1/size)` computed
/// once per walk. [`WalkRay::advance`] places the exit point's voxel with one multiply and
/// one add instead of four operations (`((o + t·d) − min)·(1/size)`), on the walk's chain from
/// one cell to the next. The roundings are as many, of the same magnitudes (`|o|`, the
/// lattice's coordinates and `|t·d|`, all within `|o| + mag` for a point in the grid), so the
/// margin's estimate in the module doc holds. The GPU walk (`grid.wgsl`'s `advance`) computes
/// the same expressions.
#[derive(Clone, Copy, Debug)]
pub struct VoxelLine<F: Real> {
    pub base: [F; 3],
    pub slope: [F; 3],
}

/// The ray of a walk in `F`: origin, direction, and the interval `[t0, t1]` in which it is
/// inside the grid's box (clipped to its own `[tmin, tmax]`).
#[derive(Clone, Copy, Debug)]
pub struct WalkRay<F: Real> {
    pub o: [F; 3],
    pub d: [F; 3],
    /// `1 / d` (`±inf` for a zero component, never used then).
    pub inv: [F; 3],
    pub t0: F,
    pub t1: F,
}

/// Where a walk leaves a cell: the box of voxels `lo..hi` (exclusive) that it leaves at
/// distance `t` (the least of its far planes' distances), from voxel `v` inside the box.
#[derive(Clone, Copy, Debug)]
pub struct Exit<F: Real> {
    pub t: F,
    pub v: [u32; 3],
    pub lo: [u32; 3],
    pub hi: [u32; 3],
}

impl<F: Real> WalkRay<F> {
    /// The ray clipped to the lattice's box (closed), or `None` when it misses it.
    #[inline(always)]
    pub fn clip(ray: &Ray, lat: &Lattice<F>) -> Option<WalkRay<F>> {
        let d = ray.dir.to_array().map(F::of32);
        WalkRay {
            o: ray.origin.to_array().map(F::of32),
            d,
            inv: d.map(|x| F::ONE / x),
            t0: F::of32(ray.tmin),
            t1: F::of32(ray.tmax),
        }
        .clip_to(lat)
    }

    /// The same ray clipped to another lattice's box inside its current interval.
    #[inline(always)]
    pub fn clip_to(&self, lat: &Lattice<F>) -> Option<WalkRay<F>> {
        self.clip_box(lat.min, std::array::from_fn(|a| lat.plane(a, lat.res[a])))
    }

    /// The same ray clipped to another lattice's box grown by its least reference margin
    /// (the cells at its border hold every triangle within `delta`, and the walk's voxels
    /// are clamped to the lattice): a top cell's grid in the two-level walk, which a ray the
    /// top walk placed in that cell must not miss by a rounding of the cell's planes.
    #[inline(always)]
    pub fn clip_near(&self, lat: &Lattice<F>) -> Option<WalkRay<F>> {
        let g = F::of(lat.delta_min());
        self.clip_box(
            std::array::from_fn(|a| lat.min[a] - g),
            std::array::from_fn(|a| lat.plane(a, lat.res[a]) + g),
        )
    }

    /// The same ray clipped to the box `lo..hi` inside its current interval.
    #[inline(always)]
    fn clip_box(&self, lo: [F; 3], hi: [F; 3]) -> Option<WalkRay<F>> {
        let (mut t0, mut t1) = (self.t0, self.t1);
        for a in 0..3 {
            let (lo, hi) = (lo[a], hi[a]);
            let (o, d) = (self.o[a], self.d[a]);
            if d == F::ZERO {
                if o < lo || o > hi {
                    return None;
                }
            } else {
                let (n, f) = if d > F::ZERO { (lo, hi) } else { (hi, lo) };
                t0 = t0.max((n - o) / d);
                t1 = t1.min((f - o) / d);
                // (Divisions here: entry and exit of the box are exact to F's rounding.)
            }
        }
        // Also false for a NaN interval.
        if t0 > t1 || t0.is_nan() || t1.is_nan() {
            return None;
        }
        Some(WalkRay { t0, t1, ..*self })
    }

    /// The ray in voxel units of `lat` ([`VoxelLine`]).
    #[inline(always)]
    pub fn voxel_line(&self, lat: &Lattice<F>) -> VoxelLine<F> {
        VoxelLine {
            base: std::array::from_fn(|a| (self.o[a] - lat.min[a]) * lat.inv_size[a]),
            slope: std::array::from_fn(|a| self.d[a] * lat.inv_size[a]),
        }
    }

    /// The voxel of the lattice holding the ray's point at `t` (clamped to the lattice).
    #[inline(always)]
    pub fn voxel_at(&self, lat: &Lattice<F>, t: F) -> [u32; 3] {
        std::array::from_fn(|a| {
            if self.d[a] == F::ZERO {
                lat.voxel(a, self.o[a])
            } else {
                lat.voxel(a, self.o[a] + t * self.d[a])
            }
        })
    }

    /// Distance to the far plane of the box of voxels `lo..hi` on each axis (`+inf` where the
    /// ray is parallel to the axis), plane `i` of axis `a` at `plane(a, i)`.
    #[inline(always)]
    pub fn exits(&self, plane: impl Fn(usize, u32) -> F, lo: [u32; 3], hi: [u32; 3]) -> [F; 3] {
        std::array::from_fn(|a| {
            if self.d[a] > F::ZERO {
                (plane(a, hi[a]) - self.o[a]) * self.inv[a]
            } else if self.d[a] < F::ZERO {
                (plane(a, lo[a]) - self.o[a]) * self.inv[a]
            } else {
                F::INFINITY
            }
        })
    }

    /// The monotone advance of the section-5 walk (Pérard-Gayot et al. 2017 §5): at `exit`,
    /// leaving the box of voxels `lo..hi` (exclusive) at `t` through the far plane of axis
    /// `axis`, from voxel `v` (inside the box), the next voxel: on `axis` the first layer past the box; on
    /// the other axes the voxel of the exit point (from `line`, this walk's
    /// [`WalkRay::voxel_line`] of `lat`), clamped into the box's range and never
    /// behind `v` along the ray's direction (the paper's `max`/`min` with the previous
    /// position). `None` when the next layer is outside the lattice.
    ///
    /// Every step moves the coordinate of `axis` strictly forward along the ray and no other
    /// coordinate backwards, so `Σ_a sign(d_a)·v_a` strictly increases: a walk ends after at
    /// most `res_x + res_y + res_z` steps, whatever the rounding, with no step cap.
    ///
    /// With `SELECT` the exit axis is not branched on: every axis computes both its candidates
    /// (the first layer past the box, the exit point's clamped voxel) and the axis picks one by
    /// selection, the same voxel. Which of three planes a ray leaves a cell through is
    /// unpredictable for incoherent rays, and each mispredicted branch discarded the next
    /// cell's look-up begun behind it; the branches left then depend on the ray's direction
    /// only ([`walk_by`] says where each pays).
    #[inline(always)]
    pub fn advance<const SELECT: bool>(
        &self,
        lat: &Lattice<F>,
        line: &VoxelLine<F>,
        exit: &Exit<F>,
        axis: usize,
    ) -> Option<[u32; 3]> {
        let mut n = exit.v;
        let mut out = false;
        for a in 0..3 {
            let layer = || self.layer(lat, a, exit.lo, exit.hi);
            // The exit point's voxel on `a`, in the box and not behind `v`.
            let along = || self.along(lat, line, exit, a, exit.lo[a], exit.hi[a] - 1);
            if SELECT {
                let ((l, outside), on_axis) = (layer(), a == axis);
                n[a] = select_unpredictable(on_axis, l, along());
                out |= on_axis & outside;
            } else if a == axis {
                let (l, outside) = layer();
                if outside {
                    return None;
                }
                n[a] = l;
            } else {
                n[a] = along();
            }
        }
        if out {
            None
        } else {
            Some(n)
        }
    }
}

impl<F: Real> WalkRay<F> {
    /// The first layer past the box of voxels `lo..hi` on axis `a` along the ray's direction,
    /// and whether it lies outside the lattice.
    #[inline(always)]
    fn layer(&self, lat: &Lattice<F>, a: usize, lo: [u32; 3], hi: [u32; 3]) -> (u32, bool) {
        if self.d[a] > F::ZERO {
            (hi[a], hi[a] >= lat.res[a])
        } else {
            (lo[a].wrapping_sub(1), lo[a] == 0)
        }
    }

    /// The voxel on axis `a` of the ray's point at the `exit` distance `t` (on this walk's
    /// `line`), clamped to `min..=max` (and the lattice) and never behind the exit's voxel `v`
    /// along the ray; `v[a]` where the ray is parallel to `a`.
    #[inline(always)]
    fn along(
        &self,
        lat: &Lattice<F>,
        line: &VoxelLine<F>,
        exit: &Exit<F>,
        a: usize,
        min: u32,
        max: u32,
    ) -> u32 {
        let (t, v) = (exit.t, exit.v);
        if self.d[a] == F::ZERO {
            return v[a];
        }
        let p = lat
            .voxel_scaled(a, line.base[a] + t * line.slope[a])
            .clamp(min, max);
        if self.d[a] > F::ZERO {
            p.max(v[a])
        } else {
            p.min(v[a])
        }
    }

    /// The step of the authors' code (hagrid's `traverse.cu`, Pérard-Gayot et al.), a reading
    /// of §5 step d, "find the next virtual base grid position based on the exit distance",
    /// which the paper leaves open; [`WalkRay::advance`] is the other. At `exit`, leaving the
    /// box of voxels `lo..hi` at `t`, the least of the far-plane distances `exits`
    /// ([`WalkRay::exits`]), from voxel `v`:
    ///
    /// - every axis whose far plane lies at `t` (`exits[a] == t`, a tie in the walk's
    ///   arithmetic) steps to the first layer past the box: a ray leaving through an edge or a
    ///   corner steps diagonally, past the cells that only touch it there (`advance` steps one
    ///   axis and visits them);
    /// - the other axes take the exit point's voxel, not clamped into the box's range (so a
    ///   rounding past a box's side also steps across it), and never behind `v` (§5's
    ///   `max`/`min` with the previous position);
    /// - `None` when a stepped axis leaves the lattice (hagrid tests all three axes after the
    ///   step).
    ///
    /// One difference from hagrid, for the robustness the oracle tests hold every walk to: the
    /// exit point's voxel is clamped to the lattice ([`Lattice::voxel_scaled`], as in
    /// `advance`), where hagrid's integer conversion of a point rounded just outside a side
    /// face would end the walk there, before cells the ray still crosses. Each stepped axis
    /// moves strictly forward and no axis backwards, so walks end as `advance`'s do. A cell
    /// skipped by a tie or a rounding is crossed by the ray only within the walk's rounding of
    /// the visited cell's box, whose references hold every triangle within the margin
    /// ([`Lattice::delta`]; module doc).
    #[inline(always)]
    pub fn advance_ties(
        &self,
        lat: &Lattice<F>,
        line: &VoxelLine<F>,
        exit: &Exit<F>,
        exits: [F; 3],
    ) -> Option<[u32; 3]> {
        let mut n = exit.v;
        let mut out = false;
        for a in 0..3 {
            let (layer, outside) = self.layer(lat, a, exit.lo, exit.hi);
            // The exit point's voxel on `a`, in the lattice (not only the box) and not
            // behind `v`.
            let along = self.along(lat, line, exit, a, 0, u32::MAX);
            // A parallel axis's distance is +inf, never `t` (the walk ended before an
            // infinite exit).
            let tie = exits[a] == exit.t;
            n[a] = select_unpredictable(tie, layer, along);
            out |= tie & outside;
        }
        if out {
            None
        } else {
            Some(n)
        }
    }
}

/// What visiting a cell tells the walk: the cell's box in voxels (`lo..hi`, exclusive; it
/// holds the visited voxel) and the closest hit distance so far, or `Stop` (an any-hit query
/// found one).
pub enum Visit {
    Continue {
        lo: [u32; 3],
        hi: [u32; 3],
        best: f32,
    },
    Stop,
}

/// The cell walk of every grid kind (Pérard-Gayot et al. 2017 §5; for unit boxes it is the
/// 3D-DDA of Amanatides and Woo 1987 with each `tMax` recomputed as a plane distance instead of
/// accumulated): from the voxel holding the ray's entry point, `visit` the cell there, leave
/// its box through the nearest far plane and [`WalkRay::advance`] to the next voxel. The walk
/// ends when the closest hit so far lies before the cell's exit (no later cell can hold a
/// closer one), when the ray's interval ends inside the cell, or when it leaves the lattice.
/// Terminates by the monotonicity of `advance`.
#[inline(always)]
pub fn walk<F: Real>(w: &WalkRay<F>, lat: &Lattice<F>, visit: impl FnMut([u32; 3]) -> Visit) {
    walk_by::<F, false, false>(w, lat, |a, i| lat.plane(a, i), visit)
}

/// [`walk`] with the planes' positions given by `plane(axis, index)`, equal to
/// [`Lattice::plane`]'s (a [`Planes`] table), and the exit axis chosen by selection when
/// `SELECT` ([`argmin3`], [`WalkRay::advance`]; the same cells either way).
///
/// With `TIES` the step is the authors' code's ([`WalkRay::advance_ties`]: every axis tied
/// for the exit steps, side axes unclamped to the box) instead of [`WalkRay::advance`]; the
/// end tests are the same.
///
/// Selection pays where the exit axis is unpredictable: the irregular and uniform grids'
/// shadow, AO and random rays trace 0-18 % faster with it, their primary rays -2..+2 %
/// (Conference, Sibenik, Sponza, one thread, two interleaved runs; docs/PERFORMANCE.md). The
/// two-level grid's nested walks lost about a fifth with it and keep the branches.
#[inline(always)]
pub fn walk_by<F: Real, const SELECT: bool, const TIES: bool>(
    w: &WalkRay<F>,
    lat: &Lattice<F>,
    plane: impl Fn(usize, u32) -> F,
    mut visit: impl FnMut([u32; 3]) -> Visit,
) {
    let mut v = w.voxel_at(lat, w.t0);
    let line = w.voxel_line(lat);
    loop {
        let Visit::Continue { lo, hi, best } = visit(v) else {
            return;
        };
        let exits = w.exits(&plane, lo, hi);
        let (axis, t_exit) = argmin3::<F, SELECT>(exits);
        if F::of32(best) <= t_exit || t_exit >= w.t1 {
            return;
        }
        let exit = Exit {
            t: t_exit,
            v,
            lo,
            hi,
        };
        let next = if TIES {
            w.advance_ties(lat, &line, &exit, exits)
        } else {
            w.advance::<SELECT>(lat, &line, &exit, axis)
        };
        match next {
            Some(n) => v = n,
            None => return,
        }
    }
}

/// The arrays a one-level grid's walk reads, borrowed ([`cell_walk`]): the grid's lattice in
/// the walk's arithmetic `F`, that lattice's plane table, the scene's triangles and the
/// grid's references.
#[derive(Clone, Copy)]
pub struct GridView<'a, F: Real> {
    pub lat: &'a Lattice<F>,
    pub planes: &'a Planes<F>,
    pub tris: &'a [Triangle],
    pub refs: &'a [u32],
}

/// The walk of the one-level grids (the uniform grid's `dda`, the irregular grid's `walk`)
/// over the `grid`'s arrays: the ray entered into `lat` ([`enter`]), then [`walk_by`] over
/// its `planes`, each visited voxel `v` counted (a cell and a step) and resolved by `cell` to
/// its references (a range of `refs`) and its box in voxels `lo..hi`, which are tested
/// ([`test_refs`]) before the walk leaves the box through its far planes; with `TIES`, by the
/// authors' step ([`walk_by`]).
#[inline(always)]
pub fn cell_walk<T: TriTest, C: Counter, const ANY: bool, const TIES: bool, F: Real>(
    ray: &Ray,
    grid: &GridView<F>,
    c: &mut C,
    cell: impl Fn([u32; 3]) -> (Range<usize>, [u32; 3], [u32; 3]),
) -> HitRecord {
    let GridView {
        lat,
        planes,
        tris,
        refs,
    } = *grid;
    let w = match enter::<T, C, ANY, F>(ray, lat, tris, c) {
        Ok(w) => w,
        Err(h) => return h,
    };
    let pre = T::prepare(ray);
    let mut hit = HitRecord::MISS;
    let mut best = ray.tmax;
    walk_by::<F, true, TIES>(
        &w,
        lat,
        |a, i| planes.get(a, i),
        |v| {
            c.cell();
            c.steps(1);
            let (r, lo, hi) = cell(v);
            if test_refs::<T, C, ANY>(&pre, ray, tris, &refs[r], &mut hit, &mut best, c) {
                return Visit::Stop;
            }
            Visit::Continue { lo, hi, best }
        },
    );
    hit
}

/// Test the triangles `refs` (scene indices) against the ray, keeping the closest hit in
/// `hit` (`best` is its distance, or the ray's `tmax`); `true` when `ANY` and one was found.
#[inline(always)]
pub fn test_refs<T: TriTest, C: Counter, const ANY: bool>(
    pre: &T::Pre,
    ray: &Ray,
    tris: &[Triangle],
    refs: &[u32],
    hit: &mut HitRecord,
    best: &mut f32,
    c: &mut C,
) -> bool {
    for &r in refs {
        c.prims(1);
        if let Some((t, u, v)) = T::intersect(pre, ray, &tris[r as usize], *best) {
            *hit = HitRecord { t, prim: r, u, v };
            *best = t;
            if ANY {
                return true;
            }
        }
    }
    false
}

/// The start every grid walk shares: the ray clipped to `lat` (`Err(MISS)` when it misses the
/// grid), or, for an origin so far away that the triangle test's own rounding can exceed the
/// reference margin ([`Lattice::far`]), `Err` with brute force's answer.
#[inline(always)]
pub(crate) fn enter<T: TriTest, C: Counter, const ANY: bool, F: Real>(
    ray: &Ray,
    lat: &Lattice<F>,
    tris: &[Triangle],
    c: &mut C,
) -> Result<WalkRay<F>, HitRecord> {
    let Some(w) = WalkRay::clip(ray, lat) else {
        return Err(HitRecord::MISS);
    };
    if lat.far(ray) {
        return Err(brute_force::<T, C, ANY>(ray, tris, c));
    }
    Ok(w)
}

/// The answer for a [`Lattice::far`] ray: every triangle tested (counted in `prims`).
#[inline(never)]
pub fn brute_force<T: TriTest, C: Counter, const ANY: bool>(
    ray: &Ray,
    tris: &[Triangle],
    c: &mut C,
) -> HitRecord {
    let pre = T::prepare(ray);
    let mut hit = HitRecord::MISS;
    let mut best = ray.tmax;
    for (i, t) in tris.iter().enumerate() {
        c.prims(1);
        if let Some((t, u, v)) = T::intersect(&pre, ray, t, best) {
            hit = HitRecord {
                t,
                prim: i as u32,
                u,
                v,
            };
            best = t;
            if ANY {
                break;
            }
        }
    }
    hit
}

/// Index and value of the smallest of three distances (the exit axis; ties go to the lower
/// axis); with `SELECT` by selections (conditional moves) instead of branches, the same index
/// and value.
#[inline(always)]
pub fn argmin3<F: Real, const SELECT: bool>(t: [F; 3]) -> (usize, F) {
    // The index and the value are carried together, in registers: reading `t[k]` back by
    // index went through memory on the walk's critical path.
    let (mut k, mut m) = (0, t[0]);
    for (a, &x) in t.iter().enumerate().skip(1) {
        let less = x < m;
        if SELECT {
            k = select_unpredictable(less, a, k);
            m = select_unpredictable(less, x, m);
        } else if less {
            (k, m) = (a, x);
        }
    }
    (k, m)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lattice::*;
    use crate::Rounding;
    use tb_core::Vec3;

    #[test]
    fn sat_agrees_with_simple_cases() {
        let t = Triangle::new(
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        );
        assert!(tri_box_overlap(&t, [0.1, 0.1, -0.1], [0.2, 0.2, 0.1]));
        // Box above the hypotenuse, inside the triangle's bounds: separated by an edge axis.
        assert!(!tri_box_overlap(&t, [0.8, 0.8, -0.1], [0.9, 0.9, 0.1]));
        // Box off the plane.
        assert!(!tri_box_overlap(&t, [0.1, 0.1, 0.1], [0.2, 0.2, 0.2]));
        // Touching the plane counts (closed boxes).
        assert!(tri_box_overlap(&t, [0.1, 0.1, 0.0], [0.2, 0.2, 0.2]));
        // A degenerate triangle (a segment along the diagonal).
        let s = Triangle::new(Vec3::ZERO, Vec3::ONE, Vec3::ONE);
        assert!(tri_box_overlap(&s, [0.4, 0.4, 0.4], [0.6, 0.6, 0.6]));
        assert!(!tri_box_overlap(&s, [0.6, 0.0, 0.0], [0.9, 0.3, 0.3]));
    }

    #[test]
    fn resolution_follows_equation_1() {
        for k in [Rounding::Truncate, Rounding::Nearest] {
            // 1000 primitives in a unit cube at density 1: 10 per axis.
            assert_eq!(
                resolution([1.0; 3], 1000, 1.0, k, 1024, 1 << 30),
                [10, 10, 10]
            );
            // Flat along z: the root is taken over x and y.
            assert_eq!(
                resolution([1.0, 1.0, 0.0], 100, 1.0, k, 1024, 1 << 30),
                [10, 10, 1]
            );
            // The cell cap scales every axis down.
            let r = resolution([1.0; 3], 1_000_000, 8.0, k, 1024, 1000);
            assert!(r.iter().map(|&x| x as u64).product::<u64>() <= 1000);
        }
    }

    /// The two readings of equation 1 differ where `d_a ∛(λN/V)` has a fraction of at least
    /// one half: 2 x 1 x 1 box, 100 primitives, λ = 1: `∛50 = 3.68`, so x is 7.37 and y, z
    /// 3.68: truncated 7 x 3 x 3 (the authors' code), rounded 7 x 4 x 4.
    #[test]
    fn equation_1_truncates_as_the_authors_code() {
        let ext = [2.0, 1.0, 1.0];
        let t = resolution(ext, 100, 1.0, Rounding::Truncate, 1024, 1 << 30);
        let n = resolution(ext, 100, 1.0, Rounding::Nearest, 1024, 1 << 30);
        assert_eq!(t, [7, 3, 3]);
        assert_eq!(n, [7, 4, 4]);
        // Below one cell an axis keeps one.
        assert_eq!(
            resolution([1.0; 3], 1, 0.1, Rounding::Truncate, 1024, 1 << 30),
            [1, 1, 1]
        );
    }

    /// The two readings of §5 step d on a 4³ unit lattice, from voxel 0 whose cell is that
    /// voxel: at a corner (every far plane at the exit distance) `advance` steps the first
    /// axis only and `advance_ties` every axis; past a side face by a rounding (the exit
    /// point's y just beyond the cell) `advance` clamps y into the cell, `advance_ties` does
    /// not; both stop where a stepped axis leaves the lattice.
    #[test]
    fn the_authors_step_takes_ties_and_unclamped_sides() {
        let lat = Lattice::new(
            &tb_core::Aabb::new(Vec3::ZERO, Vec3::splat(4.0)),
            [4; 3],
            crate::Precision::F64,
        );
        let ray = Ray::new(Vec3::ZERO, Vec3::ONE);
        let w = WalkRay::<f64>::clip(&ray, &lat).expect("inside");
        let line = w.voxel_line(&lat);
        let (v, lo, hi) = ([0; 3], [0; 3], [1; 3]);
        let exits = w.exits(|a, i| lat.plane(a, i), lo, hi);
        assert_eq!(exits, [1.0; 3]);
        let (axis, t) = argmin3::<f64, false>(exits);
        assert_eq!(
            w.advance::<false>(&lat, &line, &Exit { t, v, lo, hi }, axis),
            Some([1, 0, 0])
        );
        assert_eq!(
            w.advance_ties(&lat, &line, &Exit { t, v, lo, hi }, exits),
            Some([1, 1, 1])
        );
        // A ray leaving through x whose y at the exit lies a rounding past the cell's face:
        // its y plane's distance, rounded up, came out behind x's.
        let ray = Ray::new(Vec3::new(0.0, 0.5, 0.5), Vec3::new(1.0, 0.5 + 1e-6, 0.1));
        let w = WalkRay::<f64>::clip(&ray, &lat).expect("inside");
        let line = w.voxel_line(&lat);
        let mut exits = w.exits(|a, i| lat.plane(a, i), lo, hi);
        exits[1] = 1.0 + 1e-9;
        let (axis, t) = argmin3::<f64, false>(exits);
        assert_eq!((axis, t), (0, 1.0));
        assert_eq!(
            w.advance::<false>(&lat, &line, &Exit { t, v, lo, hi }, axis),
            Some([1, 0, 0])
        );
        assert_eq!(
            w.advance_ties(&lat, &line, &Exit { t, v, lo, hi }, exits),
            Some([1, 1, 0])
        );
        // Leaving the lattice through a corner: both end.
        let ray = Ray::new(Vec3::splat(3.5), Vec3::ONE);
        let w = WalkRay::<f64>::clip(&ray, &lat).expect("inside");
        let line = w.voxel_line(&lat);
        let (v, lo, hi) = ([3; 3], [3; 3], [4; 3]);
        let exits = w.exits(|a, i| lat.plane(a, i), lo, hi);
        let (axis, t) = argmin3::<f64, false>(exits);
        assert_eq!(
            w.advance::<false>(&lat, &line, &Exit { t, v, lo, hi }, axis),
            None
        );
        assert_eq!(
            w.advance_ties(&lat, &line, &Exit { t, v, lo, hi }, exits),
            None
        );
    }

    #[test]
    fn set_helpers() {
        assert_eq!(union_len(&[1, 3, 5], &[2, 3, 6]), 5);
        let mut v = [0; 5];
        assert_eq!(union_into(&[1, 3, 5], &[2, 3, 6], &mut v), 5);
        assert_eq!(v, [1, 2, 3, 5, 6]);
        assert!(is_subset(&[3, 5], &[1, 3, 5]));
        assert!(!is_subset(&[2], &[1, 3]));
        assert!(is_subset(&[], &[]));
    }
}
