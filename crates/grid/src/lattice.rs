//! The lattice every grid kind shares: the arithmetic of a walk ([`Real`]), the resolution
//! rule (equation 1 of Pérard-Gayot et al. 2017, after Cleary et al. 1983), the lattice that
//! maps voxel indices to world coordinates, its planes, the exact triangle/box overlap test
//! that assigns references to cells (conservative by [`Lattice::delta`]: `common`'s module
//! doc gives the margin), the flat `cell → reference range` layout, and the sorted reference
//! lists' union and subset tests of the merges.

use crate::{Precision, Rounding};
use rayon::prelude::*;
use std::fmt::Debug;
use std::ops::{Add, Div, Mul, Sub};
use tb_core::{Aabb, AccelError, Ray, Triangle};

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
/// every grid's memory for any input. The paper scenes hold at most 9
/// exact references per triangle at the papers' densities and never reach it; 2,000
/// overlapping coplanar triangles held 60,000 each in the two-level grid (1.5 GB) without it.
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

/// A grid over the scene's box at density `lambda` (the uniform grid's, or λ_1 for the top
/// level of a two-level subdivision: Kalojanov et al. 2011 §3; Pérard-Gayot et al. 2017
/// §4.1): equation 1's resolution rounded by `rounding` (at most `max_cells` cells), lowered
/// by the reference bound ([`bounded_res`]); the lattice and the bound's factor (1:
/// unchanged).
pub fn top_level(
    tris: &[Triangle],
    lambda: f64,
    rounding: Rounding,
    max_cells: u64,
    precision: Precision,
) -> (Lattice, f64) {
    let bounds = grid_bounds(tris);
    let ext = bounds.extent().to_array().map(f64::from);
    let res = resolution(ext, tris.len(), lambda, rounding, MAX_AXIS_RES, max_cells);
    let (res, scale) = bounded_res(&bounds, res, tris, precision);
    (Lattice::new(&bounds, res, precision), scale)
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
#[derive(Clone, Copy, Debug, serde::Serialize, serde::Deserialize)]
pub struct Lattice<F: Real = f64> {
    /// Lower corner of the lattice's box.
    pub min: [F; 3],
    /// Edge length of one voxel, per axis.
    pub size: [F; 3],
    /// `1 / size`.
    pub inv_size: [F; 3],
    /// Number of voxels per axis.
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
    /// The lattice of `res` voxels over `bounds` (already padded, see `grid_bounds`), with
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
    /// testing every triangle (see `common::brute_force`), which is what the margin could not
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
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
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
