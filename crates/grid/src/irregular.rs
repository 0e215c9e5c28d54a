//! The irregular grid of Pérard-Gayot, Kalojanov and Slusallek 2017, "GPU ray tracing using
//! irregular grids" (Eurographics): build (§4: initial subdivision, SAH cell merging, cell
//! expansion) and the traversal of §5.

use crate::common::{
    bin_uniform, bounded_res, enter, grid_bounds, is_subset, resolution, test_refs, union_into,
    union_len, walk, Lattice, Real, Visit, MAX_AXIS_RES, MAX_REFS_PER_TRIANGLE,
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
}

impl IrregularGrid {
    /// Build over `tris` (parallel with rayon): §4.1 initial subdivision, §4.2 merging when
    /// `merge`, §4.3 `expansion` passes.
    pub fn build(tris: &Arc<[Triangle]>, p: &IrregularParams) -> Result<IrregularGrid, AccelError> {
        let mut fig = Vec::new();
        let t = Instant::now();
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
                            1 << MAX_DEPTH,
                            u64::MAX,
                        );
                        let m = r.into_iter().max().unwrap_or(1);
                        32 - (m - 1).leading_zeros()
                    })
                    .collect()
            }
        };
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
        let dmax = depth.iter().copied().max().unwrap_or(0);
        let base = top.refined(1 << dmax);
        let w = initial(&top, &base, dmax, &depth, &tstart, &trefs, tris);
        drop((tstart, trefs));
        fig.push(("build_init_ms".into(), ms(t)));
        fig.push(("cells_initial".into(), w.cells.len() as f64));
        fig.push(("refs_initial".into(), w.refs.len() as f64));
        let mut w = w;
        let t = Instant::now();
        let mut passes = 0u32;
        if p.merge {
            loop {
                let before = w.cells.len();
                for a in 0..3 {
                    w = merge_pass(&base, dmax, w, a, p);
                    passes += 1;
                }
                let after = w.cells.len();
                if after as f64 >= p.alpha as f64 * before as f64 {
                    break;
                }
            }
        }
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
            cells, refs, map, ..
        } = w;
        fig.push(("cells".into(), cells.len() as f64));
        fig.push(("refs".into(), refs.len() as f64));
        fig.push(("voxel_map_bytes".into(), (map.len() * 4) as f64));
        fig.push(("cells_bytes".into(), (cells.len() * 32) as f64));
        fig.push(("refs_bytes".into(), (refs.len() * 4) as f64));
        fig.push(("top_res_x".into(), res[0] as f64));
        fig.push(("top_res_y".into(), res[1] as f64));
        fig.push(("top_res_z".into(), res[2] as f64));
        fig.push(("depth_max".into(), dmax as f64));
        Ok(IrregularGrid {
            top,
            base,
            base32: base.cast(),
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
            Precision::F32 => self.walk_in::<T, C, ANY, f32>(&self.base32, ray, c),
            Precision::F64 => self.walk_in::<T, C, ANY, f64>(&self.base, ray, c),
        }
    }

    /// The §5 walk over `base`, the base lattice in the walk's arithmetic `F`.
    #[inline(always)]
    fn walk_in<T: TriTest, C: Counter, const ANY: bool, F: Real>(
        &self,
        base: &Lattice<F>,
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
        walk(&w, base, |v| {
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
        });
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

/// §4.1: the cells of the two-level subdivision. Each top cell of depth `D` is split as an
/// octree, one level per pass, each reference tested (separating axes) against the 8 children
/// of its octree cell and kept in those it overlaps, down to depth `D`; every leaf of depth `D`
/// becomes a cell (empty ones included), so top cell `t` owns `8^D` cells and its voxel-map
/// entry is `D << 28 | first`. The references of each cell stay sorted by triangle. The
/// paper runs each pass over all references at once on the GPU; here each top cell is one
/// rayon task (the same references and cells).
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
    let per_top: Vec<(Vec<u32>, Vec<u32>)> = (0..n_top)
        .into_par_iter()
        .map(|t| {
            let d = depth[t];
            let tv = top.voxel_of(t);
            let tri_ids = &trefs[tstart[t] as usize..tstart[t + 1] as usize];
            let side = 1u32 << d;
            let n_sub = 1usize << (3 * d);
            if d == 0 {
                return (vec![0, tri_ids.len() as u32], tri_ids.to_vec());
            }
            // (octree cell at the current level, triangle).
            let mut cur: Vec<([u32; 3], u32)> = tri_ids.iter().map(|&i| ([0; 3], i)).collect();
            for k in 0..d {
                let size = 1u32 << (dmax - k - 1);
                let mut next = Vec::with_capacity(cur.len() * 2);
                for &(s, i) in &cur {
                    let tri = &tris[i as usize];
                    let b = tri.bounds();
                    // Which halves the grown bounds reach on each axis: a triangle in one
                    // child only needs no test (it overlaps the parent); the others get the
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
                    for ch in 0..8u32 {
                        let bit = [ch & 1, ch >> 1 & 1, ch >> 2];
                        if (0..3).any(|a| !halves[a][bit[a] as usize]) {
                            continue;
                        }
                        let c: [u32; 3] = std::array::from_fn(|a| s[a] * 2 + bit[a]);
                        let lo: [u32; 3] = std::array::from_fn(|a| (tv[a] << dmax) + c[a] * size);
                        if single || base.overlaps(tri, lo, lo.map(|x| x + size)) {
                            next.push((c, i));
                        }
                    }
                }
                cur = next;
            }
            let mut keys: Vec<u64> = cur
                .into_iter()
                .map(|(s, i)| {
                    let local =
                        s[0] as u64 + side as u64 * (s[1] as u64 + side as u64 * s[2] as u64);
                    local << 32 | i as u64
                })
                .collect();
            keys.sort_unstable();
            crate::common::flatten(keys, n_sub)
        })
        .collect();
    let mut cells = Vec::with_capacity(off[n_top]);
    let mut refs = Vec::new();
    let mut map = vec![0u32; n_top + off[n_top]];
    for (t, (start, r)) in per_top.into_iter().enumerate() {
        let d = depth[t];
        let tv = top.voxel_of(t);
        let side = 1u32 << d;
        let size = 1u32 << (dmax - d);
        map[t] = d << 28 | (n_top + off[t]) as u32;
        let base_ref = refs.len() as u32;
        for local in 0..(1usize << (3 * d)) {
            let l = local as u32;
            let s = [l % side, (l / side) % side, l / (side * side)];
            let lo: [u32; 3] = std::array::from_fn(|a| (tv[a] << dmax) + s[a] * size);
            map[n_top + off[t] + local] = cells.len() as u32;
            cells.push(Cell {
                lo,
                begin: base_ref + start[local],
                hi: lo.map(|x| x + size),
                end: base_ref + start[local + 1],
            });
        }
        refs.extend_from_slice(&r);
    }
    Work {
        cells,
        refs,
        map,
        n_top,
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

/// One merge pass along `axis` (§4.2): (1) every cell whose neighbour across its upper face
/// has the same extent on the other two axes, and whose merge lowers the SAH cost, becomes a
/// merge candidate; (2) along each merge chain, candidates at even positions merge with their
/// successor, those at odd positions are residue (pairwise merges only); (3) merged cells
/// replace their pairs (references united, sorted), the others stay; (4) the voxel map's
/// entries of removed cells point to their new cells. Returns the new state.
fn merge_pass(base: &Lattice, dmax: u32, w: Work, axis: usize, p: &IrregularParams) -> Work {
    let Work {
        cells,
        refs,
        mut map,
        n_top,
    } = w;
    let n = cells.len();
    let top = top_lattice(base, dmax);
    // (1) Candidates: the neighbour across the upper face and the size of the union.
    let target: Vec<(u32, u32)> = cells
        .par_iter()
        .map(|c| {
            if c.hi[axis] >= base.res[axis] {
                return (NONE, 0);
            }
            let mut v = c.lo;
            v[axis] = c.hi[axis];
            let j = lookup(&map, &top, dmax, v);
            let nb = &cells[j as usize];
            let same = (0..3).all(|a| a == axis || (nb.lo[a] == c.lo[a] && nb.hi[a] == c.hi[a]));
            if !same || nb.lo[axis] != c.hi[axis] {
                return (NONE, 0);
            }
            let (ra, rb) = (&refs[c.range()], &refs[nb.range()]);
            let mut hi = c.hi;
            hi[axis] = nb.hi[axis];
            let u = union_len(ra, rb);
            let merged = cost(base, u, c.lo, hi, p);
            let apart = cost(base, ra.len(), c.lo, c.hi, p) + cost(base, rb.len(), nb.lo, nb.hi, p);
            if apart > merged {
                (j, u as u32)
            } else {
                (NONE, 0)
            }
        })
        .collect();
    // (2) Chains, walked from their heads in parallel: a head is a candidate that its lower
    // neighbour does not target. Even positions merge with their successor.
    let heads: Vec<u32> = (0..n as u32)
        .into_par_iter()
        .filter(|&i| {
            let c = &cells[i as usize];
            if target[i as usize].0 == NONE {
                return false;
            }
            if c.lo[axis] == 0 {
                return true;
            }
            let mut v = c.lo;
            v[axis] -= 1;
            target[lookup(&map, &top, dmax, v) as usize].0 != i
        })
        .collect();
    let pairs: Vec<(u32, u32)> = heads
        .par_iter()
        .flat_map_iter(|&h| {
            let mut out = Vec::new();
            let (mut c, mut pos) = (h, 0u32);
            while target[c as usize].0 != NONE {
                let t = target[c as usize].0;
                if pos % 2 == 0 {
                    out.push((c, t));
                }
                c = t;
                pos += 1;
            }
            out
        })
        .collect();
    let mut partner = vec![NONE; n];
    let mut absorbed = vec![false; n];
    for &(c, t) in &pairs {
        partner[c as usize] = t;
        absorbed[t as usize] = true;
    }
    // (3) New cells: kept cells in order, each merged with its partner.
    let mut new_id = vec![NONE; n];
    let mut kept = Vec::with_capacity(n - pairs.len());
    for i in 0..n {
        if !absorbed[i] {
            new_id[i] = kept.len() as u32;
            kept.push(i as u32);
        }
    }
    for &(c, t) in &pairs {
        new_id[t as usize] = new_id[c as usize];
    }
    let mut begin = Vec::with_capacity(kept.len() + 1);
    begin.push(0usize);
    for &i in &kept {
        let i = i as usize;
        let s = match partner[i] {
            NONE => cells[i].range().len(),
            _ => target[i].1 as usize,
        };
        begin.push(begin.last().copied().unwrap_or(0) + s);
    }
    let total = *begin.last().unwrap_or(&0);
    let mut new_refs = vec![0u32; total];
    {
        let mut slices = Vec::with_capacity(kept.len());
        let mut rest: &mut [u32] = &mut new_refs;
        for k in 0..kept.len() {
            let (a, b) = rest.split_at_mut(begin[k + 1] - begin[k]);
            slices.push(a);
            rest = b;
        }
        slices
            .into_par_iter()
            .zip(kept.par_iter())
            .for_each(|(out, &i)| {
                let c = &cells[i as usize];
                match partner[i as usize] {
                    NONE => out.copy_from_slice(&refs[c.range()]),
                    j => union_into(&refs[c.range()], &refs[cells[j as usize].range()], out),
                }
            });
    }
    let new_cells: Vec<Cell> = kept
        .par_iter()
        .enumerate()
        .map(|(k, &i)| {
            let c = cells[i as usize];
            let hi = match partner[i as usize] {
                NONE => c.hi,
                j => cells[j as usize].hi,
            };
            Cell {
                lo: c.lo,
                begin: begin[k] as u32,
                hi,
                end: begin[k + 1] as u32,
            }
        })
        .collect();
    map[n_top..]
        .par_iter_mut()
        .for_each(|e| *e = new_id[*e as usize]);
    Work {
        cells: new_cells,
        refs: new_refs,
        map,
        n_top,
    }
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
                                let nb = &cells[lookup(&w.map, &top, dmax, v) as usize];
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

    fn own_memory(&self) -> MemoryReport {
        MemoryReport {
            bytes: (self.map.len() * 4
                + self.cells.len() * 32
                + self.refs.len() * 4
                + self.tris.len() * std::mem::size_of::<Triangle>()) as u64,
            nodes: self.cells.len() as u64,
            prim_refs: self.refs.len() as u64,
            node_bytes: 32,
        }
    }

    /// Extra figures: time per build phase (`build_init_ms`, `build_merge_ms`,
    /// `build_expand_ms`), cells after each phase, merge passes, memory per part
    /// (`voxel_map_bytes`, `cells_bytes`, `refs_bytes`), top-level resolution, deepest octree.
    /// The peak heap of the build is measured for every structure by the harness
    /// (`build_heap_peak_bytes`).
    fn report(&self) -> BuildReport {
        BuildReport {
            sah_cost: None,
            extra: self.figures.clone(),
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
