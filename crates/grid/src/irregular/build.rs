//! The build of the irregular grid (Pérard-Gayot et al. 2017, §4): §4.1 the initial
//! subdivision (uniform or two-level, adaptive octrees), §4.2 SAH cell merging, §4.3 cell
//! expansion.

use super::merge::*;
use super::*;

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
}

pub(super) fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

/// One leaf of a top cell's octree (§4.1): its lower corner in the top cell's finest voxels
/// (`2^D` per axis), its level (0: the top cell itself; `D`: the finest) and how many
/// references it holds (its own, in order, in the top cell's reference list).
#[derive(Clone, Copy)]
pub(super) struct Leaf {
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
pub(super) fn initial(
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
pub(super) fn octree(
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
/// [`crate::lattice::box_refs`] counts them).
pub(super) fn initial_box_refs(
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
