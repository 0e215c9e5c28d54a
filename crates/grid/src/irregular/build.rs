//! The build of the irregular grid (Pérard-Gayot et al. 2017, §4): §4.1 the initial
//! subdivision (uniform or two-level, adaptive octrees), §4.2 SAH cell merging, §4.3 cell
//! expansion.

use super::merge::*;
use super::*;

/// One build of the irregular grid in progress: its inputs and the figures its phases
/// report, in the order they report them.
struct Builder<'a> {
    tris: &'a [Triangle],
    p: &'a IrregularParams,
    fig: Vec<(String, f64)>,
}

/// The lattices of a build once its octree depths are known: the top level and the virtual
/// base grid, the top level refined by `2^dmax` (`dmax` the deepest octree).
struct Levels {
    top: Lattice,
    base: Lattice,
    dmax: u32,
}

impl IrregularGrid {
    /// Build over `tris` (parallel with rayon): §4.1 initial subdivision, §4.2 merging when
    /// `merge`, §4.3 `expansion` passes.
    pub fn build(tris: &Arc<[Triangle]>, p: &IrregularParams) -> Result<IrregularGrid, AccelError> {
        let total = Instant::now();
        let mut b = Builder {
            tris,
            p,
            fig: Vec::new(),
        };
        let (top, binned) = b.top_level()?;
        let mut depth = b.octree_depths(&top, &binned.start);
        b.cap_depths(&top, &binned, &mut depth);
        let dmax = depth.iter().copied().max().unwrap_or(0);
        let lv = Levels {
            top,
            base: top.refined(1 << dmax),
            dmax,
        };
        let (made, cells_initial) = b.subdivide(&lv, depth, &binned, total);
        let mut w = b.merge(&lv, made, binned, cells_initial);
        b.expand(&lv, &mut w);
        Ok(b.finish(lv, w, tris, total))
    }
}

impl Builder<'_> {
    /// §4.1, the top level: equation 1's resolution at density λ_1, lowered first by the
    /// reference bound (the top level's references are the cells' least), and the triangles
    /// binned to its cells.
    fn top_level(&mut self) -> Result<(Lattice, Binned), AccelError> {
        let (tris, p) = (self.tris, self.p);
        let (top, top_scale) = crate::lattice::top_level(
            tris,
            p.densities.lambda_1 as f64,
            p.densities.rounding,
            p.max_cells as u64,
            p.walk.precision,
        );
        if top_scale < 1.0 {
            self.fig.push(("ref_budget_top_scale".into(), top_scale));
        }
        let (start, refs) = bin_uniform(&top, tris)?;
        Ok((top, Binned { start, refs }))
    }

    /// §4.1, the octree depth of each top cell: equation 1 at density λ_2 over the cell and
    /// its triangles (`start`, the binned references' ranges), rounded up to a power of two,
    /// `D = ⌈log2 max(R_x, R_y, R_z)⌉`; 0 for an empty cell and for the uniform initial grid.
    fn octree_depths(&self, top: &Lattice, start: &[u32]) -> Vec<u32> {
        let p = self.p;
        match p.initial {
            Initial::Uniform => vec![0; top.count()],
            Initial::TwoLevel => (0..top.count())
                .map(|c| {
                    let n = (start[c + 1] - start[c]) as usize;
                    if n == 0 {
                        return 0;
                    }
                    let r = resolution(
                        top.size,
                        n,
                        p.densities.lambda_2 as f64,
                        p.densities.rounding,
                        1 << MAX_DEPTH,
                        u64::MAX,
                    );
                    let m = r.into_iter().max().unwrap_or(1);
                    32 - (m - 1).leading_zeros()
                })
                .collect(),
        }
    }

    /// The caps on the octree depths, applied to `depth`: the voxel map's 4 bits, the base
    /// resolution, `max_cells`, and the reference bound (the cap lowered while the triangles'
    /// boxes cover too many cells of the initial grid). Any cap that lowered an octree below
    /// equation 1's depth says so in the figures: the cap and the top cells it lowered (only
    /// where it acted, so that other rows' figures are unchanged).
    fn cap_depths(&mut self, top: &Lattice, binned: &Binned, depth: &mut [u32]) {
        let n_top = top.count();
        let eq1_depth = depth.to_vec();
        let max_res = top.res.into_iter().max().unwrap_or(1);
        let mut dcap = MAX_DEPTH.min((MAX_BASE_RES / max_res).max(1).ilog2());
        let budget = MAX_REFS_PER_TRIANGLE * self.tris.len() as u64;
        let mut budget_acted = false;
        loop {
            for d in depth.iter_mut() {
                *d = (*d).min(dcap);
            }
            let cells: u64 = depth.iter().map(|&d| 1u64 << (3 * d)).sum();
            let fits = cells + n_top as u64 <= (self.p.max_cells as u64).min(1 << 28);
            if dcap == 0 {
                break;
            }
            if fits {
                if initial_box_refs(top, depth, binned, self.tris) <= budget {
                    break;
                }
                budget_acted = true;
            }
            dcap -= 1;
        }
        if budget_acted {
            self.fig.push(("ref_budget_depth".into(), dcap as f64));
        }
        let capped = eq1_depth
            .iter()
            .zip(depth.iter())
            .filter(|(e, d)| e > d)
            .count();
        if capped > 0 {
            self.fig.push(("depth_cap".into(), dcap as f64));
            self.fig.push(("depth_capped_cells".into(), capped as f64));
        }
    }

    /// §4.1, the initial cells ([`Subdivision::initial`]), with their count; `None` for a
    /// merged grid whose top cells are its voxels (`dmax = 0`), whose first merge pass starts
    /// from the binned references instead ([`merge_first_x`]). Reports the time since `start`
    /// (the build's) and the initial cells and references.
    fn subdivide(
        &mut self,
        lv: &Levels,
        depth: Vec<u32>,
        binned: &Binned,
        start: Instant,
    ) -> (Option<Work>, usize) {
        let implicit = lv.dmax == 0 && self.p.merge;
        let made = (!implicit).then(|| {
            Subdivision {
                top: &lv.top,
                base: &lv.base,
                dmax: lv.dmax,
                depth: &depth,
                tris: self.tris,
            }
            .initial(binned)
        });
        drop(depth);
        let (cells_initial, refs_initial) = match &made {
            Some(w) => (w.cells.len(), w.refs.len()),
            None => (lv.top.count(), binned.refs.len()),
        };
        self.fig.push(("build_init_ms".into(), ms(start)));
        self.fig
            .push(("cells_initial".into(), cells_initial as f64));
        self.fig.push(("refs_initial".into(), refs_initial as f64));
        (made, cells_initial)
    }

    /// §4.2, when `merge`: rounds of merge passes along x, y and z ([`merge_pass`]; the first
    /// along x from the binned references where the initial cells were not `made`), until a
    /// round leaves at least `alpha` times the cells it started with. The binned references
    /// are freed before the passes.
    fn merge(
        &mut self,
        lv: &Levels,
        made: Option<Work>,
        binned: Binned,
        cells_initial: usize,
    ) -> Work {
        let p = self.p;
        let t = Instant::now();
        let mut passes = 0u32;
        let mut w = match made {
            Some(w) => {
                drop(binned);
                w
            }
            None => {
                passes += 1;
                merge_first_x(&lv.base, binned, p)
            }
        };
        if p.merge {
            let (mut before, mut first) = (cells_initial, passes as usize);
            loop {
                for a in first..3 {
                    merge_pass(&lv.base, lv.dmax, &mut w, a, p);
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
        self.fig.push(("build_merge_ms".into(), ms(t)));
        self.fig.push(("merge_passes".into(), passes as f64));
        self.fig.push(("cells_merged".into(), w.cells.len() as f64));
        w
    }

    /// §4.3: the cells' boxes grown by `expansion` passes ([`expand`]).
    fn expand(&mut self, lv: &Levels, w: &mut Work) {
        let t = Instant::now();
        let boxes = expand(&lv.base, lv.dmax, w, self.p.expansion);
        for (c, (lo, hi)) in w.cells.iter_mut().zip(boxes) {
            c.lo = lo;
            c.hi = hi;
        }
        self.fig.push(("build_expand_ms".into(), ms(t)));
    }

    /// The grid from the built cells: the voxel map with its top words, the walk's plane
    /// tables, and the figures of its parts and of the whole build since `total`.
    fn finish(
        mut self,
        lv: Levels,
        w: Work,
        tris: &Arc<[Triangle]>,
        total: Instant,
    ) -> IrregularGrid {
        let Work {
            cells,
            refs,
            map,
            flat,
            ..
        } = w;
        let map = if flat { unflatten(map) } else { map };
        let Levels { top, base, dmax } = lv;
        let precision = self.p.walk.precision;
        let fig = &mut self.fig;
        fig.push(("cells".into(), cells.len() as f64));
        fig.push(("refs".into(), refs.len() as f64));
        fig.push(("voxel_map_bytes".into(), (map.len() * 4) as f64));
        fig.push(("cells_bytes".into(), (cells.len() * 32) as f64));
        fig.push(("refs_bytes".into(), (refs.len() * 4) as f64));
        fig.push(("top_res_x".into(), top.res[0] as f64));
        fig.push(("top_res_y".into(), top.res[1] as f64));
        fig.push(("top_res_z".into(), top.res[2] as f64));
        fig.push(("depth_max".into(), dmax as f64));
        let (planes32, planes64) = planes_for(&base, precision);
        fig.push((
            "planes_bytes".into(),
            (planes32.bytes() + planes64.bytes()) as f64,
        ));
        // The whole build, phases and the rest (bounds, plane tables, voxel map): the total
        // that Figure 5 divides into its steps, measured in this build as its phases are.
        fig.push(("build_total_ms".into(), ms(total)));
        IrregularGrid {
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
            figures: self.fig,
        }
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

/// The leaves and references of a run of top cells' octrees, in order, and the number of
/// leaves of each top cell of the run.
struct OctreeRun {
    leaves: Vec<Leaf>,
    refs: Vec<u32>,
    counts: Vec<u32>,
}

/// What the octrees of the initial subdivision share (§4.1): the top level, the virtual base
/// grid (the top level refined by `2^dmax`), each top cell's octree depth and the scene's
/// triangles.
pub(super) struct Subdivision<'a> {
    pub(super) top: &'a Lattice,
    pub(super) base: &'a Lattice,
    pub(super) dmax: u32,
    pub(super) depth: &'a [u32],
    pub(super) tris: &'a [Triangle],
}

impl Subdivision<'_> {
    /// §4.1: the cells of the two-level subdivision over the `binned` references of the top
    /// level. Each top cell of depth `D` is split as an octree, one level per pass: each
    /// reference of a node is tested (separating axes) against the node's 8 children and
    /// emitted to those it overlaps, down to depth `D`. As in the paper (a reference is split,
    /// a node without references is not) and in its authors' code (hagrid), the octree is
    /// adaptive: a child that receives no reference is an empty leaf at its level, and only
    /// the nodes with references are split on. Every leaf becomes a cell; the voxel map's
    /// entries (`8^D` per top cell, word `D << 28 | first`) name the leaf that covers them.
    /// The references of each cell stay sorted by triangle. The paper runs each pass over all
    /// references at once on the GPU; here each top cell is one rayon task (the same
    /// references and cells).
    pub(super) fn initial(&self, binned: &Binned) -> Work {
        let n_top = self.top.count();
        let mut off = vec![0usize; n_top + 1];
        for t in 0..n_top {
            off[t + 1] = off[t] + (1usize << (3 * self.depth[t]));
        }
        let runs = self.octrees(binned);
        let (cells, refs, first_cell) = self.cells_of(runs);
        let map = self.voxel_map(&cells, &first_cell, &off);
        Work {
            cells,
            refs,
            map,
            n_top,
            flat: false,
        }
    }

    /// Every top cell's octree ([`Subdivision::octree`]), one rayon task per run of top cells
    /// (a grid of many small top cells, as the uniform initial grid, would otherwise hold a
    /// vector per top cell).
    fn octrees(&self, binned: &Binned) -> Vec<OctreeRun> {
        const TOPS: usize = 256;
        let n_top = self.top.count();
        (0..n_top.div_ceil(TOPS))
            .into_par_iter()
            .map(|run| {
                let (mut leaves, mut refs, mut counts) = (Vec::new(), Vec::new(), Vec::new());
                for t in run * TOPS..n_top.min((run + 1) * TOPS) {
                    let tri_ids =
                        &binned.refs[binned.start[t] as usize..binned.start[t + 1] as usize];
                    let before = leaves.len();
                    self.octree(t, tri_ids, &mut leaves, &mut refs);
                    counts.push((leaves.len() - before) as u32);
                }
                leaves.shrink_to_fit();
                refs.shrink_to_fit();
                OctreeRun {
                    leaves,
                    refs,
                    counts,
                }
            })
            .collect()
    }

    /// The cells of the octrees' leaves, in order, their references, and the first cell of
    /// each top cell (with the count after the last).
    fn cells_of(&self, runs: Vec<OctreeRun>) -> (Vec<Cell>, Vec<u32>, Vec<u32>) {
        let n_cells: usize = runs.iter().map(|r| r.leaves.len()).sum();
        let n_refs: usize = runs.iter().map(|r| r.refs.len()).sum();
        let mut cells = Vec::with_capacity(n_cells);
        let mut refs = Vec::with_capacity(n_refs);
        let mut first_cell = Vec::with_capacity(self.top.count() + 1);
        let mut t = 0;
        for run in runs {
            let mut leaves = run.leaves.into_iter();
            let mut begin = refs.len() as u32;
            for count in run.counts {
                first_cell.push(cells.len() as u32);
                let d = self.depth[t];
                let unit = 1u32 << (self.dmax - d);
                let origin = self.top.voxel_of(t).map(|x| x << self.dmax);
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
            refs.extend_from_slice(&run.refs);
        }
        first_cell.push(cells.len() as u32);
        (cells, refs, first_cell)
    }

    /// The voxel map: each top cell's word (its depth and the offset `off` of its second
    /// level), then its second level filled from its cells (those from `first_cell`; one
    /// rayon task per top cell, each writing its own slice).
    fn voxel_map(&self, cells: &[Cell], first_cell: &[u32], off: &[usize]) -> Vec<u32> {
        let (top, depth, dmax) = (self.top, self.depth, self.dmax);
        let n_top = top.count();
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
        map
    }

    /// The adaptive octree of top cell `t` (of depth `d`) over its triangles `tri_ids`
    /// (sorted): its leaves and their references appended to `leaves` and `refs`, each leaf's
    /// references sorted by triangle.
    fn octree(&self, t: usize, tri_ids: &[u32], leaves: &mut Vec<Leaf>, refs: &mut Vec<u32>) {
        let d = self.depth[t];
        // The top cell's lower corner in base voxels.
        let origin = self.top.voxel_of(t).map(|x| x << self.dmax);
        let (dmax, tris) = (self.dmax, self.tris);
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
                    masks.push(self.child_mask(origin, s, size, &tris[i as usize]));
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

    /// The children that triangle `tri` overlaps (bit `x | y << 1 | z << 2`) of the octree
    /// node `s` (in units of its level, whose children are `size` base voxels per axis) of the
    /// top cell whose lower corner is base voxel `origin`.
    #[inline]
    fn child_mask(&self, origin: [u32; 3], s: [u32; 3], size: u32, tri: &Triangle) -> u8 {
        let base = self.base;
        let b = tri.bounds();
        // Which halves the grown bounds reach on each axis: a triangle in one child only needs
        // no test (it overlaps the parent); the others get the separating-axis test.
        let mut halves = [[false; 2]; 3];
        for a in 0..3 {
            let mid = base.plane(a, origin[a] + (2 * s[a] + 1) * size);
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
            let lo: [u32; 3] = std::array::from_fn(|a| origin[a] + (s[a] * 2 + bit[a]) * size);
            if single || base.overlaps(tri, lo, lo.map(|x| x + size)) {
                m |= 1 << ch;
            }
        }
        m
    }
}

/// The most references the initial grid can hold at per-top-cell depths `depth`: the cells of
/// each top cell refined by `2^depth` that the boxes of its triangles (its `binned`
/// references) cover (as [`crate::lattice::box_refs`] counts them).
pub(super) fn initial_box_refs(
    top: &Lattice,
    depth: &[u32],
    binned: &Binned,
    tris: &[Triangle],
) -> u64 {
    (0..depth.len())
        .into_par_iter()
        .map(|c| {
            let k = 1u32 << depth[c];
            let fine = top.refined(k);
            let v = top.voxel_of(c);
            binned.refs[binned.start[c] as usize..binned.start[c + 1] as usize]
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
