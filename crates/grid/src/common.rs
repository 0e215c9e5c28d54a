//! What every grid kind shares: the resolution rule (equation 1 of Pérard-Gayot et al. 2017,
//! after Cleary et al. 1983), the lattice that maps voxel indices to world coordinates, the
//! exact triangle/box overlap test that assigns references to cells, the flat
//! `cell → reference range` layout, and the robust ray state of the cell walks.
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

use crate::{Precision, Rounding};
use rayon::prelude::*;
use std::fmt::Debug;
use std::hint::select_unpredictable;
use std::ops::{Add, Div, Mul, Sub};
use tb_core::{Aabb, AccelError, Counter, HitRecord, Ray, TriTest, Triangle};

/// The arithmetic of a walk ([`Precision`]): `f32` (the paper's) or `f64`.
pub trait Real:
    Copy
    + PartialOrd
    + Debug
    + Send
    + Sync
    + 'static
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
{
    const ZERO: Self;
    const ONE: Self;
    const INFINITY: Self;
    /// `x` rounded to this type (the lattice's constants).
    fn of(x: f64) -> Self;
    /// `x`, exactly (the ray's components).
    fn of32(x: f32) -> Self;
    fn of_u32(i: u32) -> Self;
    /// `min(⌊self⌋, hi)` for `self ≥ 0` (not NaN) and `hi < 2^24`: clamped in floating point,
    /// then truncated with no saturation code (`as u32` adds its range checks).
    fn floor_to(self, hi: u32) -> u32;
    fn max(self, o: Self) -> Self;
    fn min(self, o: Self) -> Self;
    fn is_nan(self) -> bool;
}

macro_rules! real {
    ($t:ty) => {
        impl Real for $t {
            const ZERO: Self = 0.0;
            const ONE: Self = 1.0;
            const INFINITY: Self = <$t>::INFINITY;
            #[inline(always)]
            fn of(x: f64) -> Self {
                x as $t
            }
            #[inline(always)]
            fn of32(x: f32) -> Self {
                x as $t
            }
            #[inline(always)]
            fn of_u32(i: u32) -> Self {
                i as $t
            }
            #[inline(always)]
            fn floor_to(self, hi: u32) -> u32 {
                debug_assert!(self >= 0.0 && hi < 1 << 24);
                let c = <$t>::min(self, hi as $t);
                // SAFETY: `c` is finite and in `[0, hi]` (`self ≥ 0` is not NaN, `hi` is
                // exact in both types), so it fits an `i32`.
                unsafe { c.to_int_unchecked::<i32>() as u32 }
            }
            #[inline(always)]
            fn max(self, o: Self) -> Self {
                <$t>::max(self, o)
            }
            #[inline(always)]
            fn min(self, o: Self) -> Self {
                <$t>::min(self, o)
            }
            #[inline(always)]
            fn is_nan(self) -> bool {
                <$t>::is_nan(self)
            }
        }
    };
}
real!(f32);
real!(f64);

/// Largest resolution of one axis of any grid (the walks keep voxel indices in `u32` and the
/// voxel map's levels must multiply without overflow).
pub const MAX_AXIS_RES: u32 = 1 << 16;

/// Resolution rule, equation 1 (Pérard-Gayot et al. 2017 §4.1; Cleary et al. 1983):
/// `R_a = d_a · ∛(λ N / V)` for a box of extents `d` holding `n` primitives at density
/// `lambda`. Axes much thinner than the box's largest (flat scenes) get one cell and are left
/// out of `V`, whose root is then taken over the remaining axes; each axis is made an
/// integer by `rounding` (truncated as the authors' code does, or rounded to the nearest;
/// the paper does not say), at least 1, at most `max_axis`, and the product is kept under
/// `max_cells` by scaling all axes down together. Truncation takes the root exactly (`cbrt`,
/// `sqrt`), so that a whole resolution (1000 primitives at density 1 in a unit cube: 10) is
/// not truncated one below by `powf(1/3)`'s rounding.
pub fn resolution(
    extent: [f64; 3],
    n: usize,
    lambda: f64,
    rounding: Rounding,
    max_axis: u32,
    max_cells: u64,
) -> [u32; 3] {
    let dmax = extent.iter().cloned().fold(0.0, f64::max);
    if n == 0 || dmax <= 0.0 || lambda <= 0.0 {
        return [1, 1, 1];
    }
    let active: Vec<usize> = (0..3).filter(|&a| extent[a] > dmax * 1e-4).collect();
    let vol: f64 = active.iter().map(|&a| extent[a]).product();
    let density = lambda * n as f64 / vol;
    let s = match (rounding, active.len()) {
        (Rounding::Nearest, k) => density.powf(1.0 / k as f64),
        (Rounding::Truncate, 3) => density.cbrt(),
        (Rounding::Truncate, 2) => density.sqrt(),
        (Rounding::Truncate, _) => density,
    };
    let whole = |x: f64| match rounding {
        Rounding::Nearest => x.round(),
        Rounding::Truncate => x.trunc(),
    };
    let mut r = [1u32; 3];
    let mut scale = 1.0f64;
    loop {
        for &a in &active {
            r[a] = (whole(extent[a] * s * scale) as u64).clamp(1, max_axis as u64) as u32;
        }
        let cells = r.iter().map(|&x| x as u64).product::<u64>();
        if cells <= max_cells {
            return r;
        }
        scale *= 0.9 * (max_cells as f64 / cells as f64).cbrt();
    }
}

/// References a grid may hold per triangle (counted as the voxels each triangle's box covers,
/// an upper bound of the exact references) before its resolution is lowered: the bound of
/// every grid's memory for any input (issue 30 item 2). The paper scenes hold at most 9
/// exact references per triangle at the papers' densities and never reach it; 2,000
/// overlapping coplanar triangles held 60,000 each in the two-level grid (1.5 GB) before.
pub const MAX_REFS_PER_TRIANGLE: u64 = 64;

/// The voxels of `lat` that the boxes of `tris[ids]` cover (as [`Lattice::range`] finds them,
/// the most references binning them can make).
pub fn box_refs(lat: &Lattice, tris: &[Triangle], ids: &[u32]) -> u64 {
    ids.iter()
        .map(|&i| {
            let (lo, hi) = lat.range(&tris[i as usize].bounds());
            (0..3).map(|a| (hi[a] - lo[a] + 1) as u64).product::<u64>()
        })
        .sum()
}

/// The largest of the factors `1, 0.8, 0.8², …` by which `res` (every axis, at least 1)
/// can be scaled so that `refs(scaled)` is at most `budget`; `1` when `res` is within it, and
/// the factor at which every axis reached 1 otherwise.
pub fn within_budget(res: &[[u32; 3]], budget: u64, refs: impl Fn(&[[u32; 3]]) -> u64) -> f64 {
    let mut f = 1.0f64;
    loop {
        let scaled = scale_res(res, f);
        if refs(&scaled) <= budget || scaled.iter().all(|r| *r == [1, 1, 1]) {
            return f;
        }
        f *= 0.8;
    }
}

/// `res`, the resolution of a lattice over `bounds` holding all of `tris`, lowered by
/// [`within_budget`] to at most [`MAX_REFS_PER_TRIANGLE`] covered voxels per triangle, with
/// the factor (1: unchanged).
pub fn bounded_res(
    bounds: &Aabb,
    res: [u32; 3],
    tris: &[Triangle],
    precision: Precision,
) -> ([u32; 3], f64) {
    let all: Vec<u32> = (0..tris.len() as u32).collect();
    let budget = MAX_REFS_PER_TRIANGLE * tris.len() as u64;
    let f = within_budget(&[res], budget, |r| {
        box_refs(&Lattice::new(bounds, r[0], precision), tris, &all)
    });
    (scale_res(&[res], f)[0], f)
}

/// Every resolution of `res` scaled by `f` (rounded, at least 1 on each axis).
pub fn scale_res(res: &[[u32; 3]], f: f64) -> Vec<[u32; 3]> {
    if f == 1.0 {
        return res.to_vec();
    }
    res.iter()
        .map(|r| r.map(|x| ((x as f64 * f).round() as u32).max(1)))
        .collect()
}

/// A regular lattice of `res` voxels over a box: voxel `i` of axis `a` spans
/// `[min[a] + i·size[a], min[a] + (i+1)·size[a]]`, computed in `F` the same way by the build
/// (`f64`) and the walks (`F` of the grid's [`Precision`], [`Lattice::cast`]).
#[derive(Clone, Copy, Debug)]
pub struct Lattice<F: Real = f64> {
    pub min: [F; 3],
    pub size: [F; 3],
    /// `1 / size`.
    pub inv_size: [F; 3],
    pub res: [u32; 3],
    /// Growth of cell boxes for reference assignment, per axis (see the module doc).
    pub delta: [f64; 3],
    /// Largest absolute coordinate of the lattice's box.
    pub mag: f64,
    /// The share of `|o| + mag` that the triangle test's and the walk's rounding may reach
    /// (2^-21 in `f64`, 2^-19 in `f32`; the module doc): [`Lattice::far`]'s factor.
    pub far_scale: f64,
}

impl Lattice {
    /// The lattice of `res` voxels over `bounds` (already padded, see [`grid_bounds`]), with
    /// the reference margin of walks in `precision` (the module doc).
    pub fn new(bounds: &Aabb, res: [u32; 3], precision: Precision) -> Self {
        let lo = bounds.min.to_array().map(f64::from);
        let hi = bounds.max.to_array().map(f64::from);
        let mag = lo
            .iter()
            .chain(hi.iter())
            .fold(0.0f64, |m, x| m.max(x.abs()));
        let ulp = mag * f64::from(f32::EPSILON);
        let size = std::array::from_fn(|a| (hi[a] - lo[a]) / res[a] as f64);
        let (share, ulps, far_scale) = match precision {
            Precision::F64 => (2048.0, 8.0, 1.0 / (1u64 << 21) as f64),
            Precision::F32 => (2048.0, 32.0, 1.0 / (1u64 << 19) as f64),
        };
        Lattice {
            min: lo,
            size,
            inv_size: size.map(|s| 1.0 / s),
            res,
            delta: std::array::from_fn(|a| size[a] / share + ulps * ulp),
            mag,
            far_scale,
        }
    }

    /// The same box at `k` times the resolution on every axis (the virtual base grid).
    pub fn refined(&self, k: u32) -> Self {
        Lattice {
            min: self.min,
            size: self.size.map(|s| s / k as f64),
            inv_size: self.size.map(|s| k as f64 / s),
            res: self.res.map(|r| r * k),
            ..*self
        }
    }

    /// The lattice in a walk's arithmetic: `min`, `size` and `1 / size` rounded to `G`.
    pub fn cast<G: Real>(&self) -> Lattice<G> {
        Lattice {
            min: self.min.map(G::of),
            size: self.size.map(G::of),
            inv_size: self.inv_size.map(G::of),
            res: self.res,
            delta: self.delta,
            mag: self.mag,
            far_scale: self.far_scale,
        }
    }

    /// The check every grid's `validate` makes of a cell's references: sorted, each naming a
    /// triangle of `tris` that overlaps the cell's box, voxels `lo..hi` of this lattice (grown
    /// by the margin, as the build assigns them); `Err` names the cell as `what`.
    pub(crate) fn check_refs(
        &self,
        refs: &[u32],
        tris: &[Triangle],
        lo: [u32; 3],
        hi: [u32; 3],
        what: &str,
    ) -> Result<(), AccelError> {
        let bad = |m: String| Err(AccelError::Invalid(format!("{what}: {m}")));
        if refs.windows(2).any(|w| w[0] >= w[1]) {
            return bad("references not sorted".into());
        }
        for &t in refs {
            let Some(tri) = tris.get(t as usize) else {
                return bad(format!("reference {t} out of range"));
            };
            if !self.overlaps(tri, lo, hi) {
                return bad(format!("triangle {t} does not overlap it"));
            }
        }
        Ok(())
    }

    /// Voxel range `lo..=hi` per axis covering `b` grown by `delta`.
    pub fn range(&self, b: &Aabb) -> ([u32; 3], [u32; 3]) {
        let lo = std::array::from_fn(|a| self.voxel(a, b.min[a] as f64 - self.delta[a]));
        let hi = std::array::from_fn(|a| self.voxel(a, b.max[a] as f64 + self.delta[a]));
        (lo, hi)
    }

    /// Whether triangle `t` overlaps the box of voxels `lo..hi` (exclusive) grown by `delta`.
    pub fn overlaps(&self, t: &Triangle, lo: [u32; 3], hi: [u32; 3]) -> bool {
        let bmin: [f64; 3] = std::array::from_fn(|a| self.plane(a, lo[a]) - self.delta[a]);
        let bmax: [f64; 3] = std::array::from_fn(|a| self.plane(a, hi[a]) + self.delta[a]);
        tri_box_overlap(t, bmin, bmax)
    }
}

impl<F: Real> Lattice<F> {
    /// Whether the `f32` triangle tests of `ray`, with the walk's own rounding, may place a
    /// hit farther from the triangle than the reference margin `delta`: they start from
    /// `v − o`, rounded to the ulp of `|o| + |v|`, and the effective geometry moves by a few
    /// such ulps ([`Lattice::far_scale`] of `|o| + mag` is taken; the margin covers every
    /// origin inside the grid's box). True only for origins far outside the grid compared
    /// with its size (the far origins of `stress/ray-limits`); such rays are answered by
    /// testing every triangle (see [`brute_force`]), which is what the margin could not
    /// guarantee for them.
    #[inline(always)]
    pub fn far(&self, ray: &Ray) -> bool {
        let o = ray.origin.abs().max_element() as f64;
        let e = (o + self.mag) * self.far_scale;
        e > self.delta_min()
    }

    /// The least of the three margins.
    #[inline(always)]
    pub fn delta_min(&self) -> f64 {
        self.delta[0].min(self.delta[1]).min(self.delta[2])
    }

    /// Number of voxels.
    pub fn count(&self) -> usize {
        self.res.iter().map(|&r| r as usize).product()
    }

    /// The voxel of flat index `i` (x fastest; the inverse of [`Lattice::index`]).
    pub fn voxel_of(&self, i: usize) -> [u32; 3] {
        let [rx, ry, _] = self.res.map(|r| r as usize);
        [i % rx, (i / rx) % ry, i / (rx * ry)].map(|x| x as u32)
    }

    /// Position of plane `i` of axis `a`.
    #[inline(always)]
    pub fn plane(&self, a: usize, i: u32) -> F {
        self.min[a] + F::of_u32(i) * self.size[a]
    }

    /// Linear index of voxel `v` (x fastest).
    #[inline(always)]
    pub fn index(&self, v: [u32; 3]) -> usize {
        v[0] as usize
            + self.res[0] as usize * (v[1] as usize + self.res[1] as usize * v[2] as usize)
    }

    /// Voxel index along `a` of coordinate `p`, clamped to the lattice: `⌊(p − min)/size⌋`,
    /// where the truncation of `as u32` is the floor (it is reached only for `f ≥ 0`; below,
    /// and for NaN, voxel 0). No `floor` call: without SSE4.1 (the portable x86-64 target)
    /// it is a libm function, 11 % of the irregular grid's walk instructions (callgrind).
    #[inline(always)]
    pub fn voxel(&self, a: usize, p: F) -> u32 {
        self.voxel_scaled(a, (p - self.min[a]) * self.inv_size[a])
    }

    /// Voxel index along `a` of a coordinate already in voxel units, `f = (p − min)/size`
    /// (clamped as [`Lattice::voxel`]).
    #[inline(always)]
    pub fn voxel_scaled(&self, a: usize, f: F) -> u32 {
        if f >= F::ZERO {
            f.floor_to(self.res[a] - 1)
        } else {
            0
        }
    }
}

/// The box a grid covers: the scene's bounds padded on every side by a little more than the
/// reference growth, so that every triangle lies strictly inside and flat scenes get a
/// non-zero thickness. An empty scene gets the unit box.
pub fn grid_bounds(tris: &[Triangle]) -> Aabb {
    let b = tris.iter().fold(Aabb::EMPTY, |b, t| b.union(&t.bounds()));
    if b.is_empty() || !b.min.is_finite() || !b.max.is_finite() {
        return Aabb::new(tb_core::Vec3::ZERO, tb_core::Vec3::ONE);
    }
    let ext = b.extent().max_element();
    let mag = b.min.abs().max(b.max.abs()).max_element();
    let pad = (ext * 1e-4)
        .max(mag * 64.0 * f32::EPSILON)
        .max(f32::MIN_POSITIVE);
    Aabb::new(b.min - pad, b.max + pad)
}

/// Exact triangle/box overlap by the separating-axis theorem (Akenine-Möller 2001, "Fast
/// 3D triangle-box overlap testing"): the three box normals, the triangle's normal and the
/// nine cross products of box and triangle edges, in `f64`. Degenerate triangles (segments,
/// points) are handled: their zero cross products and normal never separate, and the
/// remaining axes are the separating axes of a segment or a point.
pub fn tri_box_overlap(t: &Triangle, bmin: [f64; 3], bmax: [f64; 3]) -> bool {
    let c: [f64; 3] = std::array::from_fn(|a| 0.5 * (bmin[a] + bmax[a]));
    let h: [f64; 3] = std::array::from_fn(|a| 0.5 * (bmax[a] - bmin[a]));
    let v: [[f64; 3]; 3] = [t.v0, t.v1, t.v2].map(|p| std::array::from_fn(|a| p[a] as f64 - c[a]));
    // Box normals: the triangle's bounds against the box.
    for a in 0..3 {
        let lo = v[0][a].min(v[1][a]).min(v[2][a]);
        let hi = v[0][a].max(v[1][a]).max(v[2][a]);
        if lo > h[a] || hi < -h[a] {
            return false;
        }
    }
    let sub = |p: [f64; 3], q: [f64; 3]| [p[0] - q[0], p[1] - q[1], p[2] - q[2]];
    let cross = |p: [f64; 3], q: [f64; 3]| {
        [
            p[1] * q[2] - p[2] * q[1],
            p[2] * q[0] - p[0] * q[2],
            p[0] * q[1] - p[1] * q[0],
        ]
    };
    let dot = |p: [f64; 3], q: [f64; 3]| p[0] * q[0] + p[1] * q[1] + p[2] * q[2];
    let e = [sub(v[1], v[0]), sub(v[2], v[1]), sub(v[0], v[2])];
    let separates = |ax: [f64; 3]| {
        let p = [dot(v[0], ax), dot(v[1], ax), dot(v[2], ax)];
        let r = h[0] * ax[0].abs() + h[1] * ax[1].abs() + h[2] * ax[2].abs();
        p[0].min(p[1]).min(p[2]) > r || p[0].max(p[1]).max(p[2]) < -r
    };
    // Triangle normal.
    if separates(cross(e[0], e[1])) {
        return false;
    }
    // Edge × box axis.
    for ei in e {
        for a in 0..3 {
            let mut u = [0.0; 3];
            u[a] = 1.0;
            if separates(cross(ei, u)) {
                return false;
            }
        }
    }
    true
}

/// The references of a uniform lattice: `(cell, triangle)` pairs for every voxel whose grown
/// box the triangle overlaps, sorted by cell and then triangle (the sort of Kalojanov et al.
/// 2011), returned as the flat layout: `start[c]..start[c+1]` indexes `refs`.
pub fn bin_uniform(lat: &Lattice, tris: &[Triangle]) -> Result<(Vec<u32>, Vec<u32>), AccelError> {
    let n_cells = lat.count();
    if n_cells >= u32::MAX as usize {
        return Err(AccelError::TooLarge {
            what: "grid cells",
            count: n_cells as u64,
            limit: u32::MAX as u64 - 1,
        });
    }
    let mut pairs: Vec<u64> = tris
        .par_iter()
        .enumerate()
        .flat_map_iter(|(i, t)| {
            let (lo, hi) = lat.range(&t.bounds());
            let single = lo == hi;
            let mut out = Vec::new();
            for z in lo[2]..=hi[2] {
                for y in lo[1]..=hi[1] {
                    for x in lo[0]..=hi[0] {
                        let v = [x, y, z];
                        if single || lat.overlaps(t, v, v.map(|c| c + 1)) {
                            out.push((lat.index(v) as u64) << 32 | i as u64);
                        }
                    }
                }
            }
            out
        })
        .collect();
    pairs.par_sort_unstable();
    Ok(flatten(vec![pairs], n_cells))
}

/// `(cell << 32 | triangle)` keys, sorted (runs of them, each sorted and after the one
/// before), to the flat `start` / `refs` layout; each run is freed once read.
pub fn flatten(runs: Vec<Vec<u64>>, n_cells: usize) -> (Vec<u32>, Vec<u32>) {
    let mut start = vec![0u32; n_cells + 1];
    let mut refs = Vec::with_capacity(runs.iter().map(Vec::len).sum());
    for run in runs {
        for p in run {
            start[(p >> 32) as usize + 1] += 1;
            refs.push(p as u32);
        }
    }
    for c in 0..n_cells {
        start[c + 1] += start[c];
    }
    (start, refs)
}

/// The planes of a lattice in the walk's arithmetic, `res[a] + 1` per axis, each the value
/// [`Lattice::plane`] computes: the walk reads a cell's exit plane from here instead of
/// converting its index and scaling it, a shorter chain of dependent operations per cell
/// (the walk is latency-bound: each cell's exit decides the next look-up). Equal values, so
/// the same walk and counters.
#[derive(Clone, Debug, Default)]
pub struct Planes<F> {
    values: Vec<F>,
    at: [usize; 3],
}

impl<F: Real> Planes<F> {
    /// The planes of `lat`.
    pub fn of(lat: &Lattice<F>) -> Self {
        let at = [
            0,
            lat.res[0] as usize + 1,
            lat.res[0] as usize + lat.res[1] as usize + 2,
        ];
        let values = (0..3)
            .flat_map(|a| (0..=lat.res[a]).map(move |i| lat.plane(a, i)))
            .collect();
        Planes { values, at }
    }

    /// Plane `i ≤ res[a]` of axis `a`.
    #[inline(always)]
    pub fn get(&self, a: usize, i: u32) -> F {
        self.values[self.at[a] + i as usize]
    }

    /// Bytes of the table.
    pub fn bytes(&self) -> usize {
        std::mem::size_of_val(&self.values[..])
    }
}

/// The plane tables of `lat` for a walk in `precision`: the `f32` one or the `f64` one, the
/// other empty.
pub fn planes_for(lat: &Lattice, precision: Precision) -> (Planes<f32>, Planes<f64>) {
    match precision {
        Precision::F32 => (Planes::of(&lat.cast()), Planes::default()),
        Precision::F64 => (Planes::default(), Planes::of(lat)),
    }
}

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

    /// The monotone advance of the section-5 walk (Pérard-Gayot et al. 2017 §5): leaving the
    /// box of voxels `lo..hi` (exclusive) at `t` through the far plane of axis `axis`, from
    /// voxel `v` (inside the box), the next voxel: on `axis` the first layer past the box; on
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
    #[allow(clippy::too_many_arguments)]
    pub fn advance<const SELECT: bool>(
        &self,
        lat: &Lattice<F>,
        line: &VoxelLine<F>,
        t: F,
        axis: usize,
        v: [u32; 3],
        lo: [u32; 3],
        hi: [u32; 3],
    ) -> Option<[u32; 3]> {
        let mut n = v;
        let mut out = false;
        for a in 0..3 {
            let forward = self.d[a] > F::ZERO;
            // The first layer past the box on `a`, and whether it lies outside the lattice.
            let layer = || {
                if forward {
                    (hi[a], hi[a] >= lat.res[a])
                } else {
                    (lo[a].wrapping_sub(1), lo[a] == 0)
                }
            };
            // The exit point's voxel on `a`, in the box and not behind `v`.
            let along = || {
                if self.d[a] == F::ZERO {
                    return v[a];
                }
                let p = lat
                    .voxel_scaled(a, line.base[a] + t * line.slope[a])
                    .clamp(lo[a], hi[a] - 1);
                if forward {
                    p.max(v[a])
                } else {
                    p.min(v[a])
                }
            };
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
    walk_by::<F, false>(w, lat, |a, i| lat.plane(a, i), visit)
}

/// [`walk`] with the planes' positions given by `plane(axis, index)`, equal to
/// [`Lattice::plane`]'s (a [`Planes`] table), and the exit axis chosen by selection when
/// `SELECT` ([`argmin3`], [`WalkRay::advance`]; the same cells either way).
///
/// Selection pays where the exit axis is unpredictable: the irregular and uniform grids'
/// shadow, AO and random rays trace 0-18 % faster with it, their primary rays -2..+2 %
/// (Conference, Sibenik, Sponza, one thread, two interleaved runs; docs/PERFORMANCE.md). The
/// two-level grid's nested walks lost about a fifth with it and keep the branches.
#[inline(always)]
pub fn walk_by<F: Real, const SELECT: bool>(
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
        let (axis, t_exit) = argmin3::<F, SELECT>(w.exits(&plane, lo, hi));
        if F::of32(best) <= t_exit || t_exit >= w.t1 {
            return;
        }
        match w.advance::<SELECT>(lat, &line, t_exit, axis, v, lo, hi) {
            Some(n) => v = n,
            None => return,
        }
    }
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

/// Size of the references of one cell with those of another, counting each triangle once
/// (both sorted): the `|T_1 ∪ T_2|` of the merge cost, one linear pass as in merge sort.
pub fn union_len(a: &[u32], b: &[u32]) -> usize {
    let (mut i, mut j, mut n) = (0, 0, 0);
    while i < a.len() && j < b.len() {
        match a[i].cmp(&b[j]) {
            std::cmp::Ordering::Less => i += 1,
            std::cmp::Ordering::Greater => j += 1,
            std::cmp::Ordering::Equal => {
                i += 1;
                j += 1;
            }
        }
        n += 1;
    }
    n + (a.len() - i) + (b.len() - j)
}

/// The sorted union of two sorted reference lists into the start of `out` (at least
/// [`union_len`] long); returns its length.
pub fn union_into(a: &[u32], b: &[u32], out: &mut [u32]) -> usize {
    let (mut i, mut j, mut k) = (0, 0, 0);
    while i < a.len() && j < b.len() {
        let x = match a[i].cmp(&b[j]) {
            std::cmp::Ordering::Less => {
                i += 1;
                a[i - 1]
            }
            std::cmp::Ordering::Greater => {
                j += 1;
                b[j - 1]
            }
            std::cmp::Ordering::Equal => {
                i += 1;
                j += 1;
                a[i - 1]
            }
        };
        out[k] = x;
        k += 1;
    }
    let (ra, rb) = (&a[i..], &b[j..]);
    out[k..k + ra.len()].copy_from_slice(ra);
    k += ra.len();
    out[k..k + rb.len()].copy_from_slice(rb);
    k + rb.len()
}

/// Whether sorted `sub` is a subset of sorted `sup`.
pub fn is_subset(sub: &[u32], sup: &[u32]) -> bool {
    let mut j = 0;
    for &x in sub {
        while j < sup.len() && sup[j] < x {
            j += 1;
        }
        if j == sup.len() || sup[j] != x {
            return false;
        }
        j += 1;
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;
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
