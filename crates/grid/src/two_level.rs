//! The two-level grid of Kalojanov, Billeter and Slusallek 2011, "Two-level grids for ray
//! tracing on GPUs" (Eurographics): the baseline of Tables 2 and 4 of Pérard-Gayot et al.
//! 2017.

use crate::common::{enter, test_refs, walk, Visit};
use crate::lattice::{
    bin_uniform, box_refs, resolution, scale_res, within_budget, Lattice, Real,
    MAX_REFS_PER_TRIANGLE,
};
use crate::params::{Precision, TwoLevelParams};
use rayon::prelude::*;
use std::sync::Arc;
use std::time::Instant;
use tb_core::{
    AccelError, BuildReport, Counter, HitRecord, MemoryReport, Ray, Structure, Traversal,
    TraversalInfo, TriTest, Triangle,
};

/// Largest second-level resolution per axis (8 bits per axis in the top cell, Kalojanov et
/// al. 2011).
const MAX_SUB: u32 = 255;

/// One top-level cell, 8 bytes: its first leaf cell and its resolution (8 bits per axis).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct TopCell {
    /// Index of the top cell's first leaf cell; its leaf cells follow in order.
    pub first_leaf: u32,
    /// `rx | ry << 8 | rz << 16`.
    pub res: u32,
}

impl TopCell {
    fn res(&self) -> [u32; 3] {
        [self.res & 0xff, self.res >> 8 & 0xff, self.res >> 16 & 0xff]
    }
}

/// A two-level grid: a uniform top level whose every cell is a uniform grid of its own
/// resolution; leaf cells are ranges of the flat reference array.
///
/// Per-ray counters of `dda`: `cells` (and `steps`): top and leaf cells visited (N_T);
/// `interior`: top cells visited; `leaves`: leaf cells visited; `prims`: triangle tests (N_I).
#[derive(serde::Serialize, serde::Deserialize)]
pub struct TwoLevelGrid {
    pub(crate) top: Lattice,
    /// `top` in `f32`, the walk's top lattice at [`Precision::F32`].
    pub(crate) top32: Lattice<f32>,
    pub(crate) precision: Precision,
    pub(crate) tops: Vec<TopCell>,
    /// `start[l]..start[l+1]` indexes `refs` for leaf cell `l`.
    pub(crate) start: Vec<u32>,
    pub(crate) refs: Vec<u32>,
    /// The scene's triangles: not saved by the build cache, given back by
    /// [`tb_core::Persist::attach`].
    #[serde(skip)]
    pub(crate) tris: Arc<[Triangle]>,
    figures: Vec<(String, f64)>,
}

/// The lattice of top cell `v` at resolution `res` (the same in build and traversal).
fn sub_lattice<F: Real>(top: &Lattice<F>, v: [u32; 3], res: [u32; 3]) -> Lattice<F> {
    let size: [F; 3] = std::array::from_fn(|a| top.size[a] / F::of_u32(res[a]));
    Lattice {
        min: std::array::from_fn(|a| top.plane(a, v[a])),
        size,
        inv_size: size.map(|s| F::ONE / s),
        res,
        ..*top
    }
}

/// The top level (Kalojanov et al. 2011 §3): equation 1's resolution at density λ_1, lowered
/// first by the reference bound (the top level's references are the leaves' least), and the
/// triangles binned to its cells; with the bound's scale of the resolution.
fn top_level(tris: &[Triangle], p: &TwoLevelParams) -> Result<(Binned, f64), AccelError> {
    let (top, top_scale) = crate::lattice::top_level(
        tris,
        p.densities.lambda_1 as f64,
        p.densities.rounding,
        p.max_cells as u64,
        p.walk.precision,
    );
    let (start, refs) = bin_uniform(&top, tris)?;
    Ok((Binned { top, start, refs }, top_scale))
}

/// The top cells (their first leaf and resolution) of the second-level resolutions `sub_res`,
/// and the number of leaf cells; an error past `u32` leaf indices.
fn top_cells(sub_res: &[[u32; 3]]) -> Result<(Vec<TopCell>, u64), AccelError> {
    let mut tops = Vec::with_capacity(sub_res.len());
    let mut n_leaves = 0u64;
    for r in sub_res {
        tops.push(TopCell {
            first_leaf: n_leaves as u32,
            res: r[0] | r[1] << 8 | r[2] << 16,
        });
        n_leaves += r.iter().map(|&x| x as u64).product::<u64>();
        if n_leaves >= u32::MAX as u64 {
            return Err(AccelError::TooLarge {
                what: "two-level grid leaf cells",
                count: n_leaves,
                limit: u32::MAX as u64 - 1,
            });
        }
    }
    Ok((tops, n_leaves))
}

/// The top level and its binned references: `refs[start[c]..start[c + 1]]` are the
/// triangles overlapping top cell `c`.
struct Binned {
    top: Lattice,
    start: Vec<u32>,
    refs: Vec<u32>,
}

impl Binned {
    /// The triangles of top cell `c`.
    fn of(&self, c: usize) -> &[u32] {
        &self.refs[self.start[c] as usize..self.start[c + 1] as usize]
    }

    /// Each top cell's resolution (equation 1 at density λ_2 over the cell and its triangles,
    /// at most `MAX_SUB` per axis), every one lowered by one factor while the triangles' boxes
    /// cover too many leaf cells (the reference bound); with that factor.
    fn sub_resolutions(&self, tris: &[Triangle], p: &TwoLevelParams) -> (Vec<[u32; 3]>, f64) {
        let (top, n_top) = (&self.top, self.top.count());
        let sub_res: Vec<[u32; 3]> = (0..n_top)
            .into_par_iter()
            .map(|c| {
                let n = (self.start[c + 1] - self.start[c]) as usize;
                let d = &p.densities;
                resolution(
                    top.size,
                    n,
                    d.lambda_2 as f64,
                    d.rounding,
                    MAX_SUB,
                    u64::MAX,
                )
            })
            .collect();
        let budget = MAX_REFS_PER_TRIANGLE * tris.len() as u64;
        let budget_scale = within_budget(&sub_res, budget, |r| {
            (0..n_top)
                .into_par_iter()
                .map(|c| box_refs(&sub_lattice(top, top.voxel_of(c), r[c]), tris, self.of(c)))
                .sum()
        });
        (scale_res(&sub_res, budget_scale), budget_scale)
    }

    /// The (leaf, triangle) pairs (`leaf << 32 | triangle`) of every leaf cell a triangle of
    /// its top cell overlaps, sorted (the sort of Kalojanov et al. 2011), per run of top cells:
    /// a run's leaves are consecutive, so the runs in order are the global order, without one
    /// array of every pair beside its sorted copy.
    fn leaf_pairs(
        &self,
        tris: &[Triangle],
        sub_res: &[[u32; 3]],
        tops: &[TopCell],
    ) -> Vec<Vec<u64>> {
        const TOPS: usize = 64;
        let (top, n_top) = (&self.top, self.top.count());
        (0..n_top.div_ceil(TOPS))
            .into_par_iter()
            .map(|run| {
                let mut out = Vec::new();
                for c in run * TOPS..n_top.min((run + 1) * TOPS) {
                    let v = top.voxel_of(c);
                    let sub = sub_lattice(top, v, sub_res[c]);
                    let first = tops[c].first_leaf as u64;
                    for &i in self.of(c) {
                        let tri = &tris[i as usize];
                        let (lo, hi) = sub.range(&tri.bounds());
                        let single = lo == hi;
                        for z in lo[2]..=hi[2] {
                            for y in lo[1]..=hi[1] {
                                for x in lo[0]..=hi[0] {
                                    let w = [x, y, z];
                                    if single || sub.overlaps(tri, w, w.map(|k| k + 1)) {
                                        out.push((first + sub.index(w) as u64) << 32 | i as u64);
                                    }
                                }
                            }
                        }
                    }
                }
                out.sort_unstable();
                out.shrink_to_fit();
                out
            })
            .collect()
    }
}

impl TwoLevelGrid {
    /// Build over `tris` (parallel with rayon): the top level, then every top cell's grid.
    pub fn build(tris: &Arc<[Triangle]>, p: &TwoLevelParams) -> Result<TwoLevelGrid, AccelError> {
        let t = Instant::now();
        let (binned, top_scale) = top_level(tris, p)?;
        let t_top = t.elapsed().as_secs_f64() * 1e3;
        let t = Instant::now();
        let (sub_res, budget_scale) = binned.sub_resolutions(tris, p);
        let (tops, n_leaves) = top_cells(&sub_res)?;
        let runs = binned.leaf_pairs(tris, &sub_res, &tops);
        let top = binned.top;
        drop(binned);
        let (start, refs) = crate::lattice::flatten(runs, n_leaves as usize);
        let n_top = top.count();
        let mut figures = vec![
            ("build_top_ms".into(), t_top),
            ("build_leaves_ms".into(), t.elapsed().as_secs_f64() * 1e3),
            ("top_res_x".into(), top.res[0] as f64),
            ("top_res_y".into(), top.res[1] as f64),
            ("top_res_z".into(), top.res[2] as f64),
            ("top_cells".into(), n_top as f64),
            ("leaf_cells".into(), n_leaves as f64),
            ("refs".into(), refs.len() as f64),
            ("top_bytes".into(), (n_top * 8) as f64),
            ("cells_bytes".into(), (start.len() * 4) as f64),
            ("refs_bytes".into(), (refs.len() * 4) as f64),
        ];
        // Only where the reference bound acted, so that other rows' figures are unchanged.
        if top_scale < 1.0 {
            figures.push(("ref_budget_top_scale".into(), top_scale));
        }
        if budget_scale < 1.0 {
            figures.push(("ref_budget_scale".into(), budget_scale));
        }
        Ok(TwoLevelGrid {
            top,
            top32: top.cast(),
            precision: p.walk.precision,
            tops,
            start,
            refs,
            tris: tris.clone(),
            figures,
        })
    }

    /// The top-level grid.
    pub fn lattice(&self) -> &Lattice {
        &self.top
    }

    #[inline(always)]
    fn dda<T: TriTest, C: Counter, const ANY: bool>(&self, ray: &Ray, c: &mut C) -> HitRecord {
        match self.precision {
            Precision::F32 => self.dda_in::<T, C, ANY, f32>(&self.top32, ray, c),
            Precision::F64 => self.dda_in::<T, C, ANY, f64>(&self.top, ray, c),
        }
    }

    /// The two levels' 3D-DDA over `top`, the top lattice in the walk's arithmetic `F` (each
    /// top cell's lattice derived from it in `F`).
    #[inline(always)]
    fn dda_in<T: TriTest, C: Counter, const ANY: bool, F: Real>(
        &self,
        top: &Lattice<F>,
        ray: &Ray,
        c: &mut C,
    ) -> HitRecord {
        let w = match enter::<T, C, ANY, F>(ray, top, &self.tris, c) {
            Ok(w) => w,
            Err(h) => return h,
        };
        let pre = T::prepare(ray);
        let mut hit = HitRecord::MISS;
        let mut best = ray.tmax;
        let mut found = false;
        walk(&w, top, |v| {
            c.cell();
            c.interior();
            c.steps(1);
            let tc = self.tops[top.index(v)];
            let r = tc.res();
            let own = (v, v.map(|x| x + 1));
            let first = tc.first_leaf as usize;
            if r == [1, 1, 1] && self.start[first] == self.start[first + 1] {
                return Visit::Continue {
                    lo: own.0,
                    hi: own.1,
                    best,
                };
            }
            let sub = sub_lattice(top, v, r);
            if let Some(ws) = w.clip_near(&sub) {
                walk(&ws, &sub, |u| {
                    c.cell();
                    c.leaf();
                    c.steps(1);
                    let l = first + sub.index(u);
                    let refs = &self.refs[self.start[l] as usize..self.start[l + 1] as usize];
                    if test_refs::<T, C, ANY>(&pre, ray, &self.tris, refs, &mut hit, &mut best, c) {
                        found = true;
                        return Visit::Stop;
                    }
                    Visit::Continue {
                        lo: u,
                        hi: u.map(|x| x + 1),
                        best,
                    }
                });
            }
            if found {
                return Visit::Stop;
            }
            Visit::Continue {
                lo: own.0,
                hi: own.1,
                best,
            }
        });
        hit
    }
}

tb_core::kernel_by_query!(dda: [] TwoLevelGrid);

impl tb_core::Persist for TwoLevelGrid {
    fn attach(
        &mut self,
        tris: &Arc<[Triangle]>,
        _params: &tb_core::ParamSet,
    ) -> Result<(), tb_core::ParamError> {
        self.tris = tris.clone();
        Ok(())
    }
}

impl Structure for TwoLevelGrid {
    const NAME: &'static str = "two-level-grid";
    const TRAVERSALS: &'static [Traversal<Self>] = &[Traversal::with_gpu(
        TraversalInfo::new(
            "dda",
            "Kalojanov et al. 2011 §4",
            "3D-DDA over the top level, and in each non-empty top cell 3D-DDA over its own grid",
        ),
        tb_core::kernel!(|g: &TwoLevelGrid, batch, out| { tb_core::dispatch(g, batch, out) }),
        TwoLevelGrid::gpu_dda,
    )];

    /// The top cells (8 bytes: first cell and resolution), the second-level cells' reference
    /// starts, the references and the triangles: what the walk reads.
    ///
    /// `structure_bytes`, the grid alone as Pérard-Gayot et al.'s Table 2 counts the two-level
    /// grid's memory: top cells, cells and references (`top_bytes + cells_bytes +
    /// refs_bytes`); not the scene's triangle array.
    fn own_memory(&self) -> MemoryReport {
        let structure = self.tops.len() * 8 + self.start.len() * 4 + self.refs.len() * 4;
        MemoryReport {
            bytes: (structure + self.tris.len() * std::mem::size_of::<Triangle>()) as u64,
            structure_bytes: structure as u64,
            nodes: (self.tops.len() + self.start.len() - 1) as u64,
            prim_refs: self.refs.len() as u64,
            node_bytes: 4,
        }
    }

    /// Extra figures: build time of each level, resolutions, cell counts, memory per part.
    fn report(&self) -> BuildReport {
        BuildReport {
            sah_cost: None,
            extra: self.figures.clone(),
        }
    }

    /// Checks: leaf ranges are consecutive per top cell and monotone, references sorted per
    /// leaf, in range, and each overlaps its leaf cell (grown by the margin).
    fn check(&self) -> Result<(), AccelError> {
        let bad = |m: String| Err(AccelError::Invalid(m));
        let mut next = 0u32;
        for (c, tc) in self.tops.iter().enumerate() {
            let r = tc.res();
            if r.iter().any(|&x| x == 0 || x > MAX_SUB) || tc.first_leaf != next {
                return bad(format!(
                    "top cell {c}: resolution {r:?} or first leaf {} wrong",
                    tc.first_leaf
                ));
            }
            let sub = sub_lattice(&self.top, self.top.voxel_of(c), r);
            for l in 0..sub.count() {
                let li = tc.first_leaf as usize + l;
                let (a, b) = (self.start[li] as usize, self.start[li + 1] as usize);
                if a > b || b > self.refs.len() {
                    return bad(format!("leaf {li}: range {a}..{b} invalid"));
                }
                let u = sub.voxel_of(l);
                sub.check_refs(
                    &self.refs[a..b],
                    &self.tris,
                    u,
                    u.map(|x| x + 1),
                    &format!("leaf {li}"),
                )?;
            }
            next += sub.count() as u32;
        }
        if next as usize + 1 != self.start.len() {
            return bad("leaf ranges do not match the top cells".into());
        }
        Ok(())
    }
}
