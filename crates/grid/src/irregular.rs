//! The irregular grid of Pérard-Gayot, Kalojanov and Slusallek 2017, "GPU ray tracing using
//! irregular grids" (Eurographics): build (§4: initial subdivision, SAH cell merging, cell
//! expansion) and the traversal of §5.

use crate::common::{
    bin_uniform, bounded_res, enter, grid_bounds, is_subset, planes_for, resolution, test_refs,
    union_into, union_len, walk_by, Lattice, Planes, Real, Visit, MAX_AXIS_RES,
    MAX_REFS_PER_TRIANGLE,
};
use crate::params::{Initial, IrregularParams, Precision};
use rayon::prelude::*;
use std::sync::Arc;
use std::time::Instant;
use tb_core::{
    AccelError, BuildReport, Counter, HitRecord, MemoryReport, Ray, Structure, Traversal,
    TraversalInfo, TriTest, Triangle,
};

/// One cell, 32 bytes: its box on the virtual base grid (`lo..hi`, exclusive, in base voxels;
/// grown by expansion) and its range of [`IrregularGrid::refs`].
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Cell {
    pub lo: [u32; 3],
    pub begin: u32,
    pub hi: [u32; 3],
    pub end: u32,
}

impl Cell {
    fn range(&self) -> std::ops::Range<usize> {
        self.begin as usize..self.end as usize
    }
}

/// Largest depth the voxel map's 4 bits hold (§4.1: 2^15 = 32768 per axis).
const MAX_DEPTH: u32 = 15;
/// Largest resolution of the virtual base grid per axis (voxel indices stay exact in `f32`
/// and `f64` arithmetic, below 2^24, and within `u32` with room; where a base voxel is
/// smaller than the f32 walk's rounding, the margin, sized in world units, still holds).
const MAX_BASE_RES: u32 = 1 << 22;
const NONE: u32 = u32::MAX;
/// A merge pass's mark of a cell absorbed by the cell in its low bits (cell counts stay
/// below 2^28).
const ABSORBED: u32 = 1 << 31;

/// An irregular grid: cells aligned on a virtual base grid, the two-level voxel map from base
/// voxels to cells, and the flat references (Pérard-Gayot et al. 2017 §3, Figure 1).
///
/// Per-ray counters of `walk`: `cells` (and `steps`): cells visited, N_T; `prims`: triangle
/// tests, N_I (no mailbox: a triangle referenced by several visited cells is tested in each).
pub struct IrregularGrid {
    /// The top-level grid.
    top: Lattice,
    /// The virtual base grid: the top level refined by 2^dmax.
    pub(crate) base: Lattice,
    /// `base` in `f32`, the walk's lattice at [`Precision::F32`].
    pub(crate) base32: Lattice<f32>,
    /// The planes of the walk's lattice (`base32` or `base`, by `precision`; the other is
    /// empty).
    planes32: Planes<f32>,
    planes64: Planes<f64>,
    pub(crate) precision: Precision,
    pub(crate) dmax: u32,
    /// Voxel map (§4.1): one word per top cell, `D << 28 | index` of its second level in this
    /// same array, then the second levels (`2^D` per axis each, x fastest): cell indices.
    pub(crate) map: Vec<u32>,
    pub(crate) cells: Vec<Cell>,
    pub(crate) refs: Vec<u32>,
    pub(crate) tris: Arc<[Triangle]>,
    figures: Vec<(String, f64)>,
}

/// The cells, references and second-level map of a build in progress.
struct Work {
    cells: Vec<Cell>,
    refs: Vec<u32>,
    map: Vec<u32>,
    n_top: usize,
    /// `map` is one level, each base voxel's cell ([`cell_at`]; `dmax = 0` only), until
    /// [`unflatten`] gives it the top words.
    flat: bool,
}

impl IrregularGrid {
    /// Build over `tris` (parallel with rayon): §4.1 initial subdivision, §4.2 merging when
    /// `merge`, §4.3 `expansion` passes.
    pub fn build(tris: &Arc<[Triangle]>, p: &IrregularParams) -> Result<IrregularGrid, AccelError> {
        let mut fig = Vec::new();
        let total = Instant::now();
        let t = total;
        let bounds = grid_bounds(tris);
        let ext = bounds.extent().to_array().map(f64::from);
        let max_top = match p.initial {
            Initial::TwoLevel => MAX_AXIS_RES,
            Initial::Uniform => MAX_AXIS_RES,
        };
        let res = resolution(
            ext,
            tris.len(),
            p.densities.lambda_1 as f64,
            p.densities.rounding,
            max_top,
            p.max_cells as u64,
        );
        // The reference bound on the top level first (its references are the cells' least).
        let precision = p.walk.precision;
        let (res, top_scale) = bounded_res(&bounds, res, tris, precision);
        if top_scale < 1.0 {
            fig.push(("ref_budget_top_scale".into(), top_scale));
        }
        let top = Lattice::new(&bounds, res, precision);
        let (tstart, trefs) = bin_uniform(&top, tris)?;
        let n_top = top.count();
        // Octree depth per top cell.
        let mut depth: Vec<u32> = match p.initial {
            Initial::Uniform => vec![0; n_top],
            Initial::TwoLevel => {
                let cell_ext = top.size;
                (0..n_top)
                    .map(|c| {
                        let n = (tstart[c + 1] - tstart[c]) as usize;
                        if n == 0 {
                            return 0;
                        }
                        let r = resolution(
                            cell_ext,
                            n,
                            p.densities.lambda_2 as f64,
                            p.densities.rounding,
                            1 << MAX_DEPTH,
                            u64::MAX,
                        );
                        let m = r.into_iter().max().unwrap_or(1);
                        32 - (m - 1).leading_zeros()
                    })
                    .collect()
            }
        };
        // Equation 1's depths, to report the cells a cap lowered.
        let eq1_depth = depth.clone();
        let max_res = res.into_iter().max().unwrap_or(1);
        let mut dcap = MAX_DEPTH.min((MAX_BASE_RES / max_res).max(1).ilog2());
        // The reference bound: lower the depth cap while the triangles' boxes cover too many
        // cells of the initial grid.
        let budget = MAX_REFS_PER_TRIANGLE * tris.len() as u64;
        let mut budget_acted = false;
        loop {
            for d in depth.iter_mut() {
                *d = (*d).min(dcap);
            }
            let cells: u64 = depth.iter().map(|&d| 1u64 << (3 * d)).sum();
            let fits = cells + n_top as u64 <= (p.max_cells as u64).min(1 << 28);
            if dcap == 0 {
                break;
            }
            if fits {
                if initial_box_refs(&top, &depth, &tstart, &trefs, tris) <= budget {
                    break;
                }
                budget_acted = true;
            }
            dcap -= 1;
        }
        if budget_acted {
            // Only where the reference bound acted, so that other rows' figures are unchanged.
            fig.push(("ref_budget_depth".into(), dcap as f64));
        }
        // Any cap (the voxel map's 4 bits, the base resolution, `max_cells`, the reference
        // bound) that lowered an octree below equation 1's depth says so: the cap and the top
        // cells it lowered (only where it acted).
        let capped = eq1_depth.iter().zip(&depth).filter(|(e, d)| e > d).count();
        if capped > 0 {
            fig.push(("depth_cap".into(), dcap as f64));
            fig.push(("depth_capped_cells".into(), capped as f64));
        }
        drop(eq1_depth);
        let dmax = depth.iter().copied().max().unwrap_or(0);
        let base = top.refined(1 << dmax);
        // A grid whose top cells are its voxels (`dmax = 0`) has the binned references as its
        // initial cells; with merging, the first pass starts from them (`merge_first_x`).
        let implicit = dmax == 0 && p.merge;
        let made = (!implicit).then(|| initial(&top, &base, dmax, &depth, &tstart, &trefs, tris));
        drop(depth);
        let (cells_initial, refs_initial) = match &made {
            Some(w) => (w.cells.len(), w.refs.len()),
            None => (n_top, trefs.len()),
        };
        fig.push(("build_init_ms".into(), ms(t)));
        fig.push(("cells_initial".into(), cells_initial as f64));
        fig.push(("refs_initial".into(), refs_initial as f64));
        let t = Instant::now();
        let mut passes = 0u32;
        let mut w = match made {
            Some(w) => {
                drop((tstart, trefs));
                w
            }
            None => {
                passes += 1;
                merge_first_x(&base, tstart, trefs, p)
            }
        };
        if p.merge {
            let (mut before, mut first) = (cells_initial, passes as usize);
            loop {
                for a in first..3 {
                    merge_pass(&base, dmax, &mut w, a, p);
                    passes += 1;
                }
                let after = w.cells.len();
                if after as f64 >= p.alpha as f64 * before as f64 {
                    break;
                }
                (before, first) = (after, 0);
            }
        }
        // The merge passes compact the cells in place; give back the initial capacity.
        w.cells.shrink_to_fit();
        fig.push(("build_merge_ms".into(), ms(t)));
        fig.push(("merge_passes".into(), passes as f64));
        fig.push(("cells_merged".into(), w.cells.len() as f64));
        let t = Instant::now();
        let boxes = expand(&base, dmax, &w, p.expansion);
        for (c, (lo, hi)) in w.cells.iter_mut().zip(boxes) {
            c.lo = lo;
            c.hi = hi;
        }
        fig.push(("build_expand_ms".into(), ms(t)));
        let Work {
            cells,
            refs,
            map,
            flat,
            ..
        } = w;
        let map = if flat { unflatten(map) } else { map };
        fig.push(("cells".into(), cells.len() as f64));
        fig.push(("refs".into(), refs.len() as f64));
        fig.push(("voxel_map_bytes".into(), (map.len() * 4) as f64));
        fig.push(("cells_bytes".into(), (cells.len() * 32) as f64));
        fig.push(("refs_bytes".into(), (refs.len() * 4) as f64));
        fig.push(("top_res_x".into(), res[0] as f64));
        fig.push(("top_res_y".into(), res[1] as f64));
        fig.push(("top_res_z".into(), res[2] as f64));
        fig.push(("depth_max".into(), dmax as f64));
        let (planes32, planes64) = planes_for(&base, precision);
        fig.push((
            "planes_bytes".into(),
            (planes32.bytes() + planes64.bytes()) as f64,
        ));
        // The whole build, phases and the rest (bounds, plane tables, voxel map): the total
        // that Figure 5 divides into its steps, measured in this build as its phases are.
        fig.push(("build_total_ms".into(), ms(total)));
        Ok(IrregularGrid {
            top,
            base,
            base32: base.cast(),
            planes32,
            planes64,
            precision,
            dmax,
            map,
            cells,
            refs,
            tris: tris.clone(),
            figures: fig,
        })
    }

    /// The virtual base grid (every cell boundary lies on one of its planes).
    pub fn base_lattice(&self) -> &Lattice {
        &self.base
    }

    /// The top-level grid.
    pub fn top_lattice(&self) -> &Lattice {
        &self.top
    }

    /// The cells.
    pub fn cells(&self) -> &[Cell] {
        &self.cells
    }

    /// The voxel map (see the field's doc).
    pub fn voxel_map(&self) -> &[u32] {
        &self.map
    }

    /// The cell holding base voxel `v`: two dependent look-ups in the voxel map (§5, step a).
    #[inline(always)]
    pub fn lookup(&self, v: [u32; 3]) -> u32 {
        lookup(&self.map, &self.top, self.dmax, v)
    }

    #[inline(always)]
    fn walk<T: TriTest, C: Counter, const ANY: bool>(&self, ray: &Ray, c: &mut C) -> HitRecord {
        match self.precision {
            Precision::F32 => self.walk_in::<T, C, ANY, f32>(&self.base32, &self.planes32, ray, c),
            Precision::F64 => self.walk_in::<T, C, ANY, f64>(&self.base, &self.planes64, ray, c),
        }
    }

    /// The §5 walk over `base`, the base lattice in the walk's arithmetic `F`, with its
    /// `planes`.
    #[inline(always)]
    fn walk_in<T: TriTest, C: Counter, const ANY: bool, F: Real>(
        &self,
        base: &Lattice<F>,
        planes: &Planes<F>,
        ray: &Ray,
        c: &mut C,
    ) -> HitRecord {
        let w = match enter::<T, C, ANY, F>(ray, base, &self.tris, c) {
            Ok(w) => w,
            Err(h) => return h,
        };
        let pre = T::prepare(ray);
        let mut hit = HitRecord::MISS;
        let mut best = ray.tmax;
        walk_by::<F, true>(
            &w,
            base,
            |a, i| planes.get(a, i),
            |v| {
                c.cell();
                c.steps(1);
                let cell = &self.cells[self.lookup(v) as usize];
                if test_refs::<T, C, ANY>(
                    &pre,
                    ray,
                    &self.tris,
                    &self.refs[cell.range()],
                    &mut hit,
                    &mut best,
                    c,
                ) {
                    return Visit::Stop;
                }
                Visit::Continue {
                    lo: cell.lo,
                    hi: cell.hi,
                    best,
                }
            },
        );
        hit
    }
}

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

#[inline(always)]
fn lookup(map: &[u32], top: &Lattice, dmax: u32, v: [u32; 3]) -> u32 {
    let t = v.map(|x| x >> dmax);
    let e = map[top.index(t)];
    let d = e >> 28;
    let first = (e & 0x0FFF_FFFF) as usize;
    let mask = (1u32 << dmax) - 1;
    let s = v.map(|x| ((x & mask) >> (dmax - d)) as usize);
    map[first + (s[0] | s[1] << d | s[2] << (2 * d))]
}

/// One leaf of a top cell's octree (§4.1): its lower corner in the top cell's finest voxels
/// (`2^D` per axis), its level (0: the top cell itself; `D`: the finest) and how many
/// references it holds (its own, in order, in the top cell's reference list).
#[derive(Clone, Copy)]
struct Leaf {
    lo: [u16; 3],
    level: u8,
    n: u32,
}

/// §4.1: the cells of the two-level subdivision. Each top cell of depth `D` is split as an
/// octree, one level per pass: each reference of a node is tested (separating axes) against
/// the node's 8 children and emitted to those it overlaps, down to depth `D`. As in the
/// paper (a reference is split, a node without references is not) and in its authors' code
/// (hagrid), the octree is adaptive: a child that receives no reference is an empty leaf at
/// its level, and only the nodes with references are split on. Every leaf becomes a cell;
/// the voxel map's entries (`8^D` per top cell, word `D << 28 | first`) name the leaf that
/// covers them. The references of each cell stay sorted by triangle. The paper runs each
/// pass over all references at once on the GPU; here each top cell is one rayon task (the
/// same references and cells).
fn initial(
    top: &Lattice,
    base: &Lattice,
    dmax: u32,
    depth: &[u32],
    tstart: &[u32],
    trefs: &[u32],
    tris: &[Triangle],
) -> Work {
    let n_top = top.count();
    let mut off = vec![0usize; n_top + 1];
    for t in 0..n_top {
        off[t + 1] = off[t] + (1usize << (3 * depth[t]));
    }
    // One rayon task per run of top cells (a grid of many small top cells, as the uniform
    // initial grid, would otherwise hold a vector per top cell): their leaves, references, and
    // leaf count per top cell.
    const TOPS: usize = 256;
    let per_run: Vec<(Vec<Leaf>, Vec<u32>, Vec<u32>)> = (0..n_top.div_ceil(TOPS))
        .into_par_iter()
        .map(|run| {
            let (mut leaves, mut refs, mut counts) = (Vec::new(), Vec::new(), Vec::new());
            for t in run * TOPS..n_top.min((run + 1) * TOPS) {
                let tri_ids = &trefs[tstart[t] as usize..tstart[t + 1] as usize];
                let before = leaves.len();
                octree(
                    top.voxel_of(t),
                    depth[t],
                    base,
                    dmax,
                    tri_ids,
                    tris,
                    &mut leaves,
                    &mut refs,
                );
                counts.push((leaves.len() - before) as u32);
            }
            leaves.shrink_to_fit();
            refs.shrink_to_fit();
            (leaves, refs, counts)
        })
        .collect();
    let n_cells: usize = per_run.iter().map(|(l, _, _)| l.len()).sum();
    let n_refs: usize = per_run.iter().map(|(_, r, _)| r.len()).sum();
    let mut cells = Vec::with_capacity(n_cells);
    let mut refs = Vec::with_capacity(n_refs);
    let mut first_cell = Vec::with_capacity(n_top + 1);
    let mut t = 0;
    for (leaves, r, counts) in per_run {
        let mut leaves = leaves.into_iter();
        let mut begin = refs.len() as u32;
        for count in counts {
            first_cell.push(cells.len() as u32);
            let d = depth[t];
            let unit = 1u32 << (dmax - d);
            let origin = top.voxel_of(t).map(|x| x << dmax);
            for l in leaves.by_ref().take(count as usize) {
                let size = unit << (d - l.level as u32);
                let lo: [u32; 3] = std::array::from_fn(|a| origin[a] + l.lo[a] as u32 * unit);
                cells.push(Cell {
                    lo,
                    begin,
                    hi: lo.map(|x| x + size),
                    end: begin + l.n,
                });
                begin += l.n;
            }
            t += 1;
        }
        refs.extend_from_slice(&r);
    }
    first_cell.push(cells.len() as u32);
    // The voxel map: each top cell's word, then its second level filled from its leaves
    // (one rayon task per top cell, each writing its own slice).
    let mut map = vec![0u32; n_top + off[n_top]];
    let (words, second) = map.split_at_mut(n_top);
    for (t, w) in words.iter_mut().enumerate() {
        *w = depth[t] << 28 | (n_top + off[t]) as u32;
    }
    let mut slices: Vec<&mut [u32]> = Vec::with_capacity(n_top);
    let mut rest = second;
    for t in 0..n_top {
        let (a, b) = rest.split_at_mut(off[t + 1] - off[t]);
        slices.push(a);
        rest = b;
    }
    slices.into_par_iter().enumerate().for_each(|(t, out)| {
        let d = depth[t];
        let side = 1usize << d;
        let unit = 1u32 << (dmax - d);
        let origin = top.voxel_of(t).map(|x| x << dmax);
        for ci in first_cell[t]..first_cell[t + 1] {
            let c = &cells[ci as usize];
            let lo =
                std::array::from_fn::<usize, 3, _>(|a| ((c.lo[a] - origin[a]) / unit) as usize);
            let hi =
                std::array::from_fn::<usize, 3, _>(|a| ((c.hi[a] - origin[a]) / unit) as usize);
            for z in lo[2]..hi[2] {
                for y in lo[1]..hi[1] {
                    let row = side * (y + side * z);
                    out[row + lo[0]..row + hi[0]].fill(ci);
                }
            }
        }
    });
    Work {
        cells,
        refs,
        map,
        n_top,
        flat: false,
    }
}

/// The adaptive octree of one top cell (voxel `tv` of the top level) of depth `d` over its
/// triangles `tri_ids` (sorted): its leaves and their references appended to `leaves` and
/// `refs`, each leaf's references sorted by triangle.
#[allow(clippy::too_many_arguments)]
fn octree(
    tv: [u32; 3],
    d: u32,
    base: &Lattice,
    dmax: u32,
    tri_ids: &[u32],
    tris: &[Triangle],
    leaves: &mut Vec<Leaf>,
    refs: &mut Vec<u32>,
) {
    if d == 0 || tri_ids.is_empty() {
        leaves.push(Leaf {
            lo: [0; 3],
            level: 0,
            n: tri_ids.len() as u32,
        });
        refs.extend_from_slice(tri_ids);
        return;
    }
    // (node at the current level, in units of that level; triangle), grouped by node, each
    // group's triangles in increasing order.
    let mut cur: Vec<([u16; 3], u32)> = tri_ids.iter().map(|&i| ([0; 3], i)).collect();
    let mut masks: Vec<u8> = Vec::new();
    for k in 0..d {
        let size = 1u32 << (dmax - k - 1);
        let mut next = Vec::with_capacity(cur.len() * 2);
        for group in cur.chunk_by(|a, b| a.0 == b.0) {
            let s = group[0].0.map(u32::from);
            masks.clear();
            for &(_, i) in group {
                let tri = &tris[i as usize];
                let b = tri.bounds();
                // Which halves the grown bounds reach on each axis: a triangle in one child
                // only needs no test (it overlaps the parent); the others get the
                // separating-axis test.
                let mut halves = [[false; 2]; 3];
                for a in 0..3 {
                    let mid = base.plane(a, (tv[a] << dmax) + (2 * s[a] + 1) * size);
                    halves[a] = [
                        b.min[a] as f64 - base.delta[a] <= mid,
                        b.max[a] as f64 + base.delta[a] >= mid,
                    ];
                }
                let single = halves.iter().all(|h| !(h[0] && h[1]));
                let mut m = 0u8;
                for ch in 0..8u32 {
                    let bit = [ch & 1, ch >> 1 & 1, ch >> 2];
                    if (0..3).any(|a| !halves[a][bit[a] as usize]) {
                        continue;
                    }
                    let lo: [u32; 3] =
                        std::array::from_fn(|a| (tv[a] << dmax) + (s[a] * 2 + bit[a]) * size);
                    if single || base.overlaps(tri, lo, lo.map(|x| x + size)) {
                        m |= 1 << ch;
                    }
                }
                masks.push(m);
            }
            for ch in 0..8u32 {
                let c: [u16; 3] = std::array::from_fn(|a| (s[a] * 2 + (ch >> a & 1)) as u16);
                let before = next.len();
                for (&(_, i), &m) in group.iter().zip(&masks) {
                    if m >> ch & 1 != 0 {
                        next.push((c, i));
                    }
                }
                if next.len() == before {
                    // An empty child: a leaf at level k + 1.
                    leaves.push(Leaf {
                        lo: c.map(|x| x << (d - k - 1)),
                        level: (k + 1) as u8,
                        n: 0,
                    });
                }
            }
        }
        cur = next;
    }
    for group in cur.chunk_by(|a, b| a.0 == b.0) {
        leaves.push(Leaf {
            lo: group[0].0,
            level: d as u8,
            n: group.len() as u32,
        });
        refs.extend(group.iter().map(|&(_, i)| i));
    }
}

/// The most references the initial grid can hold at per-top-cell depths `depth`: the cells of
/// each top cell refined by `2^depth` that its triangles' boxes cover (as
/// [`crate::common::box_refs`] counts them).
fn initial_box_refs(
    top: &Lattice,
    depth: &[u32],
    tstart: &[u32],
    trefs: &[u32],
    tris: &[Triangle],
) -> u64 {
    (0..depth.len())
        .into_par_iter()
        .map(|c| {
            let k = 1u32 << depth[c];
            let fine = top.refined(k);
            let v = top.voxel_of(c);
            trefs[tstart[c] as usize..tstart[c + 1] as usize]
                .iter()
                .map(|&i| {
                    let (lo, hi) = fine.range(&tris[i as usize].bounds());
                    (0..3)
                        .map(|a| {
                            let (l, h) = (lo[a].max(v[a] * k), hi[a].min(v[a] * k + k - 1));
                            (h.saturating_sub(l) + 1) as u64
                        })
                        .product::<u64>()
                })
                .sum::<u64>()
        })
        .sum()
}

/// SAH cost of a cell with `n` references and box `lo..hi` (§4.2, without the division by the
/// scene's area): `(C_i |T| + C_t) · SA(B)`.
fn cost(base: &Lattice, n: usize, lo: [u32; 3], hi: [u32; 3], p: &IrregularParams) -> f64 {
    let e: [f64; 3] = std::array::from_fn(|a| (hi[a] - lo[a]) as f64 * base.size[a]);
    (p.c_i as f64 * n as f64 + p.c_t as f64) * 2.0 * (e[0] * e[1] + e[1] * e[2] + e[2] * e[0])
}

/// A cell as the merge sees it: its box and its range of references.
type CellView = ([u32; 3], [u32; 3], std::ops::Range<usize>);

/// Steps (1)-(3) of a merge pass along `axis` (§4.2) over `n` cells, cell `i` given by
/// `cell(i)` and the cell holding a base voxel by `at(v)`: (1) every cell whose neighbour
/// across its upper face has the same extent on the other two axes, and whose merge lowers the
/// SAH cost, becomes a merge candidate; (2) along each merge chain, candidates at even
/// positions merge with their successor, those at odd positions are residue (pairwise merges
/// only); (3) the references of the kept cells, in order (merged pairs united, sorted).
/// Returns `link` (per cell: its partner when it absorbs one, `ABSORBED | c` when absorbed by
/// `c`, `NONE` otherwise) and the new references.
fn plan_merge(
    base: &Lattice,
    n: usize,
    axis: usize,
    cell: impl Fn(usize) -> CellView + Sync,
    at: impl Fn([u32; 3]) -> u32 + Sync,
    refs: &[u32],
    p: &IrregularParams,
) -> (Vec<u32>, Vec<u32>) {
    // (1) Candidates: `link[c]` is the neighbour across the upper face or NONE.
    let mut link: Vec<u32> = (0..n)
        .into_par_iter()
        .map(|i| {
            let (lo, hi, r) = cell(i);
            if hi[axis] >= base.res[axis] {
                return NONE;
            }
            let mut v = lo;
            v[axis] = hi[axis];
            let j = at(v);
            let (nlo, nhi, nr) = cell(j as usize);
            let same = (0..3).all(|a| a == axis || (nlo[a] == lo[a] && nhi[a] == hi[a]));
            if !same || nlo[axis] != hi[axis] {
                return NONE;
            }
            let (ra, rb) = (&refs[r], &refs[nr]);
            let mut mhi = hi;
            mhi[axis] = nhi[axis];
            let merged = cost(base, union_len(ra, rb), lo, mhi, p);
            let apart = cost(base, ra.len(), lo, hi, p) + cost(base, rb.len(), nlo, nhi, p);
            if apart > merged {
                j
            } else {
                NONE
            }
        })
        .collect();
    // (2) Chains, walked from their heads (one bit per cell): a head is a candidate that its
    // lower neighbour does not target. Even positions merge with their successor: `link[c]`
    // stays the partner `t`, and `link[t]` becomes `ABSORBED | c`.
    let heads: Vec<u64> = {
        let link = &link;
        let head = |i: usize| {
            if link[i] == NONE {
                return false;
            }
            let (lo, _, _) = cell(i);
            if lo[axis] == 0 {
                return true;
            }
            let mut v = lo;
            v[axis] -= 1;
            link[at(v) as usize] != i as u32
        };
        (0..n.div_ceil(64))
            .into_par_iter()
            .map(|b| (0..64.min(n - 64 * b)).fold(0u64, |m, k| m | (head(64 * b + k) as u64) << k))
            .collect()
    };
    for (b, &bits) in heads.iter().enumerate() {
        let mut bits = bits;
        while bits != 0 {
            let mut c = (64 * b + bits.trailing_zeros() as usize) as u32;
            bits &= bits - 1;
            loop {
                let t = link[c as usize];
                if t == NONE {
                    break;
                }
                let next = link[t as usize];
                link[t as usize] = ABSORBED | c;
                if next == NONE {
                    break;
                }
                c = next;
            }
        }
    }
    // (3) The references of the kept cells in order, written block by block in parallel.
    const BLOCK: usize = 1 << 14;
    let new_refs = {
        let link = &link;
        let size = |i: usize| match partner(link[i]) {
            Some(t) => union_len(&refs[cell(i).2], &refs[cell(t).2]),
            None if link[i] == NONE => cell(i).2.len(),
            None => 0,
        };
        let totals: Vec<usize> = (0..n.div_ceil(BLOCK))
            .into_par_iter()
            .map(|b| (b * BLOCK..n.min((b + 1) * BLOCK)).map(size).sum())
            .collect();
        let mut new_refs = vec![0u32; totals.iter().sum()];
        let mut slices = Vec::with_capacity(totals.len());
        let mut rest: &mut [u32] = &mut new_refs;
        for &s in &totals {
            let (a, b) = rest.split_at_mut(s);
            slices.push(a);
            rest = b;
        }
        slices.into_par_iter().enumerate().for_each(|(b, out)| {
            let mut at = 0;
            for i in b * BLOCK..n.min((b + 1) * BLOCK) {
                let own = &refs[cell(i).2];
                match partner(link[i]) {
                    Some(t) => at += union_into(own, &refs[cell(t).2], &mut out[at..]),
                    None if link[i] == NONE => {
                        out[at..at + own.len()].copy_from_slice(own);
                        at += own.len();
                    }
                    None => {}
                }
            }
        });
        new_refs
    };
    (link, new_refs)
}

/// The partner a merge candidate absorbs (`link` of [`plan_merge`]).
fn partner(l: u32) -> Option<usize> {
    (l != NONE && l & ABSORBED == 0).then_some(l as usize)
}

/// Whether `link` marks a cell absorbed by another.
fn absorbed(l: u32) -> bool {
    l != NONE && l & ABSORBED != 0
}

/// The cell holding base voxel `v`: through the two-level map, or, for a `flat` map (a grid
/// whose top cells are its voxels, `dmax = 0`, while it is built), its one level.
#[inline(always)]
fn cell_at(map: &[u32], flat: bool, top: &Lattice, dmax: u32, v: [u32; 3]) -> u32 {
    if flat {
        map[top.index(v)]
    } else {
        lookup(map, top, dmax, v)
    }
}

/// One merge pass along `axis` (§4.2, [`plan_merge`]), in place: (3) merged cells replace
/// their pairs, the others stay, in order; (4) the voxel map's entries point to the new
/// cells. The scratch is one word per cell and per kept cell (the paper's merge is not in
/// place, §6.1; the cells here are compacted in place so that the build's peak stays near the
/// final size).
fn merge_pass(base: &Lattice, dmax: u32, w: &mut Work, axis: usize, p: &IrregularParams) {
    let n = w.cells.len();
    let top = top_lattice(base, dmax);
    let (mut link, new_refs) = {
        let (cells, map, flat) = (&w.cells, &w.map, w.flat);
        plan_merge(
            base,
            n,
            axis,
            |i| (cells[i].lo, cells[i].hi, cells[i].range()),
            |v| cell_at(map, flat, &top, dmax, v),
            &w.refs,
            p,
        )
    };
    // Merged boxes and reference counts first (a partner may lie before its cell and be
    // overwritten by the compaction; partners are never written here), then the kept cells
    // moved down in order; `link` becomes the new index of every old cell.
    for i in 0..n {
        if let Some(t) = partner(link[i]) {
            let u = union_len(&w.refs[w.cells[i].range()], &w.refs[w.cells[t].range()]);
            let hi = w.cells[t].hi[axis];
            let c = &mut w.cells[i];
            c.hi[axis] = hi;
            c.end = c.begin + u as u32;
        }
    }
    let mut k = 0usize;
    let mut begin = 0u32;
    for i in 0..n {
        if absorbed(link[i]) {
            continue;
        }
        let len = w.cells[i].range().len() as u32;
        let mut c = w.cells[i];
        c.begin = begin;
        c.end = begin + len;
        begin += len;
        w.cells[k] = c;
        link[i] = k as u32;
        k += 1;
    }
    for i in 0..n {
        if absorbed(link[i]) {
            let c = (link[i] & !ABSORBED) as usize;
            link[i] = link[c];
        }
    }
    w.cells.truncate(k);
    w.refs = new_refs;
    let first = if w.flat { 0 } else { w.n_top };
    w.map[first..]
        .par_iter_mut()
        .for_each(|e| *e = link[*e as usize]);
}

/// The first merge pass along x of a grid whose initial cells are its voxels (`dmax = 0`: a
/// uniform initial grid, Table 5), made from the binned references `start` / `refs` without
/// those cells: the kept cells, their references and a flat voxel map (the pass's `link`,
/// each voxel's new cell; [`unflatten`] adds the top words at the end). The same cells,
/// references and map as [`initial`] followed by [`merge_pass`] along x, without the 32-byte
/// cell per voxel, and the binned references freed before the kept cells are made: the build's
/// peak on Conference at λ = 5 went from 8.3x the final structure to 2.7x (the second pass's,
/// now the largest).
fn merge_first_x(base: &Lattice, start: Vec<u32>, refs: Vec<u32>, p: &IrregularParams) -> Work {
    let n = base.count();
    // The kept cells' reference counts (merged pairs united), so that the binned references
    // are freed before the cells are made.
    let (mut link, new_refs, lens) = {
        let range = |i: usize| start[i] as usize..start[i + 1] as usize;
        let unit = |i: usize| {
            let lo = base.voxel_of(i);
            (lo, lo.map(|x| x + 1), range(i))
        };
        let (link, new_refs) = plan_merge(base, n, 0, unit, |v| base.index(v) as u32, &refs, p);
        let mut lens = Vec::with_capacity(link.iter().filter(|&&l| !absorbed(l)).count());
        for (i, &l) in link.iter().enumerate() {
            match partner(l) {
                Some(t) => lens.push(union_len(&refs[range(i)], &refs[range(t)]) as u32),
                None if l == NONE => lens.push(range(i).len() as u32),
                None => {}
            }
        }
        (link, new_refs, lens)
    };
    drop((start, refs));
    let mut cells = Vec::with_capacity(lens.len());
    let mut begin = 0u32;
    for i in 0..n {
        if absorbed(link[i]) {
            continue;
        }
        let lo = base.voxel_of(i);
        let mut hi = lo.map(|x| x + 1);
        if partner(link[i]).is_some() {
            hi[0] += 1;
        }
        let len = lens[cells.len()];
        cells.push(Cell {
            lo,
            begin,
            hi,
            end: begin + len,
        });
        begin += len;
        link[i] = (cells.len() - 1) as u32;
    }
    for i in 0..n {
        if absorbed(link[i]) {
            let c = (link[i] & !ABSORBED) as usize;
            link[i] = link[c];
        }
    }
    Work {
        cells,
        refs: new_refs,
        map: link,
        n_top: n,
        flat: true,
    }
}

/// The two-level voxel map of a `flat` build map (`dmax = 0`): a top word per voxel (depth 0,
/// its entry in the second level), then the flat map as the second level.
fn unflatten(flat: Vec<u32>) -> Vec<u32> {
    let n = flat.len();
    let mut map = Vec::with_capacity(2 * n);
    map.extend((0..n).map(|t| (n + t) as u32));
    map.extend_from_slice(&flat);
    map
}

fn top_lattice(base: &Lattice, dmax: u32) -> Lattice {
    Lattice {
        min: base.min,
        size: base.size.map(|s| s * (1u64 << dmax) as f64),
        inv_size: base.inv_size.map(|s| s / (1u64 << dmax) as f64),
        res: base.res.map(|r| r >> dmax),
        ..*base
    }
}

/// §4.3: `passes` expansion passes. In each, every cell tries to grow its box across each face
/// in turn (x, y, z; lower and upper side): it may when every cell beyond that face, over the
/// face's extent, holds a subset of its references, and it grows by the smallest distance
/// those cells reach beyond the face. Neighbours are found in the voxel map, whose cells keep
/// their merged (unexpanded) boxes, so cells grow independently (one rayon task each), and a
/// later pass reaches farther neighbours. Returns the grown boxes.
fn expand(base: &Lattice, dmax: u32, w: &Work, passes: u32) -> Vec<([u32; 3], [u32; 3])> {
    let top = top_lattice(base, dmax);
    let cells = &w.cells;
    let refs = &w.refs;
    cells
        .par_iter()
        .map(|c| {
            let own = &refs[c.range()];
            let (mut lo, mut hi) = (c.lo, c.hi);
            for _ in 0..passes {
                for a in 0..3 {
                    let (b, cc) = ((a + 1) % 3, (a + 2) % 3);
                    for upper in [false, true] {
                        let x = if upper {
                            if hi[a] >= base.res[a] {
                                continue;
                            }
                            hi[a]
                        } else {
                            if lo[a] == 0 {
                                continue;
                            }
                            lo[a] - 1
                        };
                        let mut amount = u32::MAX;
                        let mut ok = true;
                        let mut vb = lo[b];
                        'face: while vb < hi[b] {
                            let mut next_b = hi[b];
                            let mut vc = lo[cc];
                            while vc < hi[cc] {
                                let mut v = [0; 3];
                                v[a] = x;
                                v[b] = vb;
                                v[cc] = vc;
                                let nb = &cells[cell_at(&w.map, w.flat, &top, dmax, v) as usize];
                                if !is_subset(&refs[nb.range()], own) {
                                    ok = false;
                                    break 'face;
                                }
                                amount = amount.min(if upper {
                                    nb.hi[a] - x
                                } else {
                                    x + 1 - nb.lo[a]
                                });
                                next_b = next_b.min(nb.hi[b]);
                                vc = nb.hi[cc];
                            }
                            vb = next_b;
                        }
                        if ok && amount != u32::MAX {
                            if upper {
                                hi[a] += amount;
                            } else {
                                lo[a] -= amount;
                            }
                        }
                    }
                }
            }
            (lo, hi)
        })
        .collect()
}

tb_core::kernel_by_query!(walk: [] Walk<'_>);

/// The `walk` traversal of an [`IrregularGrid`] (§5).
pub(crate) struct Walk<'a>(pub &'a IrregularGrid);

impl Walk<'_> {
    #[inline(always)]
    fn walk<T: TriTest, C: Counter, const ANY: bool>(&self, ray: &Ray, c: &mut C) -> HitRecord {
        self.0.walk::<T, C, ANY>(ray, c)
    }
}

impl Structure for IrregularGrid {
    const NAME: &'static str = "irregular-grid";
    const TRAVERSALS: &'static [Traversal<Self>] = &[Traversal::with_gpu(
        TraversalInfo::new(
            "walk",
            "Pérard-Gayot et al. 2017 §5",
            "3D-DDA on the virtual base grid with the increment recomputed per cell: voxel-map \
             look-up, exit through the cell box's three far planes, monotone advance",
        ),
        |g, query, tri, rays, hits, stats| {
            tb_core::dispatch(&Walk(g), query, tri, rays, hits, stats)
        },
        IrregularGrid::gpu_walk,
    )];

    /// The voxel map, the cells (32 bytes: box and reference range), the references, the
    /// base grid's plane-coordinate tables and the triangles: what the walk reads.
    ///
    /// `structure_bytes`, the structure as Pérard-Gayot et al.'s Tables 2 and 5 and Figure 8
    /// count its storage: the voxel map, the cells and the references (`voxel_map_bytes +
    /// cells_bytes + refs_bytes`); not the plane tables (the lattice's coordinates, derived
    /// from the scene's bounds and the resolution) nor the scene's triangle array.
    fn own_memory(&self) -> MemoryReport {
        let structure = self.map.len() * 4 + self.cells.len() * 32 + self.refs.len() * 4;
        MemoryReport {
            bytes: (structure
                + self.planes32.bytes()
                + self.planes64.bytes()
                + self.tris.len() * std::mem::size_of::<Triangle>()) as u64,
            structure_bytes: structure as u64,
            nodes: self.cells.len() as u64,
            prim_refs: self.refs.len() as u64,
            node_bytes: 32,
        }
    }

    /// Extra figures: time per build phase (`build_init_ms`, `build_merge_ms`,
    /// `build_expand_ms`) and of the whole build (`build_total_ms`, the same build's: the
    /// phases' shares of §6.1 and Figure 5), cells after each phase, merge passes, memory per part
    /// (`voxel_map_bytes`, `cells_bytes`, `refs_bytes`, `planes_bytes`), top-level resolution,
    /// deepest octree; `paper_bytes`, the grid as the authors' code stores it and Table 2
    /// counts it (the same figure as `structure_bytes`), under the key the SBVH's Aila–Laine
    /// layout is reported by, so one claim compares the two (`t2-memory-vs-sbvh`).
    /// The peak heap of the build is measured for every structure by the harness
    /// (`build_heap_peak_bytes`).
    fn report(&self) -> BuildReport {
        let paper = self.own_memory().structure_bytes as f64;
        BuildReport {
            sah_cost: None,
            extra: self
                .figures
                .iter()
                .cloned()
                .chain(std::iter::once(("paper_bytes".into(), paper)))
                .collect(),
        }
    }

    /// Checks: every top-level word of the voxel map has a depth ≤ the deepest and a second
    /// level inside the map; every second-level entry names a cell whose box holds that
    /// entry's voxels; cell boxes lie in the base grid; every cell's references are sorted,
    /// name triangles and overlap the cell's box.
    fn check(&self) -> Result<(), AccelError> {
        let bad = |m: String| Err(AccelError::Invalid(m));
        let n_top = self.top.count();
        if self.map.len() < n_top {
            return bad("voxel map shorter than the top level".into());
        }
        for t in 0..n_top {
            let e = self.map[t];
            let d = e >> 28;
            let first = (e & 0x0FFF_FFFF) as usize;
            if d > self.dmax || first < n_top || first + (1usize << (3 * d)) > self.map.len() {
                return bad(format!("top cell {t}: bad voxel-map word {e:#x}"));
            }
            let tv = self.top.voxel_of(t);
            let side = 1u32 << d;
            let size = 1u32 << (self.dmax - d);
            for l in 0..(1u32 << (3 * d)) {
                let s = [l % side, (l / side) % side, l / (side * side)];
                let lo: [u32; 3] = std::array::from_fn(|a| (tv[a] << self.dmax) + s[a] * size);
                let ci = self.map[first + l as usize] as usize;
                let Some(c) = self.cells.get(ci) else {
                    return bad(format!("voxel map names cell {ci} of {}", self.cells.len()));
                };
                if (0..3).any(|a| c.lo[a] > lo[a] || c.hi[a] < lo[a] + size) {
                    return bad(format!(
                        "cell {ci} does not hold voxel {lo:?} that maps to it"
                    ));
                }
            }
        }
        for (i, c) in self.cells.iter().enumerate() {
            if (0..3).any(|a| c.lo[a] >= c.hi[a] || c.hi[a] > self.base.res[a]) {
                return bad(format!(
                    "cell {i}: box {:?}..{:?} outside the grid",
                    c.lo, c.hi
                ));
            }
            if c.begin > c.end || c.end as usize > self.refs.len() {
                return bad(format!("cell {i}: reference range out of bounds"));
            }
            self.base.check_refs(
                &self.refs[c.range()],
                &self.tris,
                c.lo,
                c.hi,
                &format!("cell {i}"),
            )?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::Densities;

    /// On every scene of the shared suite (stress and procedural scenes), the uniform initial
    /// grid at λ = 5 merged once along x: the implicit first pass gives the same cells,
    /// references and voxel map as the initial cells made and merged.
    #[test]
    fn first_merge_from_binned_references_equals_merging_the_initial_cells() {
        let p = IrregularParams {
            initial: Initial::Uniform,
            densities: Densities {
                lambda_1: 5.0,
                ..Default::default()
            },
            ..Default::default()
        };
        let mut merged_somewhere = false;
        for scene in tb_scene::conformance::suite_scenes() {
            let tris = &scene.triangles;
            let bounds = grid_bounds(tris);
            let ext = bounds.extent().to_array().map(f64::from);
            let res = resolution(
                ext,
                tris.len(),
                5.0,
                p.densities.rounding,
                MAX_AXIS_RES,
                p.max_cells as u64,
            );
            let top = Lattice::new(&bounds, res, Precision::F32);
            let base = top.refined(1);
            let (start, refs) = bin_uniform(&top, tris).unwrap();
            let depth = vec![0; top.count()];
            let mut made = initial(&top, &base, 0, &depth, &start, &refs, tris);
            merge_pass(&base, 0, &mut made, 0, &p);
            let implicit = merge_first_x(&base, start, refs, &p);
            merged_somewhere |= implicit.cells.len() < top.count();
            let name = &scene.source;
            assert_eq!(made.cells, implicit.cells, "{name}: cells");
            assert_eq!(made.refs, implicit.refs, "{name}: references");
            assert_eq!(made.map, unflatten(implicit.map), "{name}: voxel map");
        }
        assert!(merged_somewhere, "no scene of the suite merged a cell");
    }

    /// Issue 42: a cap that lowers an octree below equation 1's depth says so in the build
    /// figures (`depth_cap`, `depth_capped_cells`); a build it does not touch has neither.
    #[test]
    fn depth_caps_are_reported_where_they_act() {
        let scene = tb_scene::source::load("builtin:soup?count=2000", std::path::Path::new("."))
            .expect("the soup loads");
        let tris: Arc<[Triangle]> = scene.triangles.into();
        let figure = |p: &IrregularParams, key: &str| {
            let g = IrregularGrid::build(&tris, p).expect("builds");
            g.figures.iter().find(|(k, _)| k == key).map(|&(_, v)| v)
        };
        let free = IrregularParams {
            merge: false,
            expansion: 0,
            ..Default::default()
        };
        assert_eq!(figure(&free, "depth_cap"), None);
        // Voxel-map entries for about one level below the top: deeper octrees are capped.
        let capped = IrregularParams {
            densities: Densities {
                lambda_2: 64.0,
                ..Default::default()
            },
            max_cells: 4096,
            ..free
        };
        let cap = figure(&capped, "depth_cap").expect("the cap acted");
        assert!(cap < MAX_DEPTH as f64);
        assert!(figure(&capped, "depth_capped_cells").is_some_and(|n| n >= 1.0));
    }

    /// Issue 42 (§6.1, Figure 5: the expansion's share of the build): the build reports its
    /// whole time beside its phases', measured in the same build, the phases within it.
    #[test]
    fn build_total_holds_the_phases() {
        let scene = tb_scene::source::load("builtin:soup?count=2000", std::path::Path::new("."))
            .expect("the soup loads");
        let tris: Arc<[Triangle]> = scene.triangles.into();
        let g = IrregularGrid::build(&tris, &IrregularParams::default()).expect("builds");
        let f = |key: &str| {
            g.figures
                .iter()
                .find(|(k, _)| k == key)
                .map(|&(_, v)| v)
                .unwrap_or_else(|| panic!("no {key}"))
        };
        let phases = f("build_init_ms") + f("build_merge_ms") + f("build_expand_ms");
        let total = f("build_total_ms");
        assert!(
            phases > 0.0 && total >= phases,
            "total {total} ms, phases {phases} ms"
        );
    }
}
