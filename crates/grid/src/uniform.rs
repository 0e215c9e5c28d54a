//! The uniform grid (equation 1 with density `lambda`) traversed by 3D-DDA (Amanatides and
//! Woo 1987), optionally with macro regions (Devillers 1989): the baseline of Table 5 of
//! Pérard-Gayot et al. 2017.

use crate::common::{cell_walk, GridView};
use crate::lattice::{bin_uniform, planes_for, Lattice, Planes, Real};
use crate::params::{Precision, UniformParams};
use rayon::prelude::*;
use std::sync::Arc;
use std::time::Instant;
use tb_core::{
    AccelError, BuildReport, Counter, HitRecord, MemoryReport, Ray, Structure, Traversal,
    TraversalInfo, TriTest, Triangle,
};

/// A uniform grid: cells on a regular lattice, each a range of the flat reference array.
///
/// Per-ray counters of `dda`: `cells` (and `steps`): cells visited (N_T; a macro region skipped
/// in one step counts once); `prims`: triangle tests (N_I; a triangle in several visited cells
/// is tested in each, there is no mailbox); the others stay 0.
#[derive(serde::Serialize, serde::Deserialize)]
pub struct UniformGrid {
    pub(crate) lat: Lattice,
    /// `lat` in `f32`, the walk's lattice at [`Precision::F32`].
    pub(crate) lat32: Lattice<f32>,
    /// The planes of the walk's lattice (`lat32` or `lat`, by `precision`; the other is
    /// empty).
    planes32: Planes<f32>,
    planes64: Planes<f64>,
    pub(crate) precision: Precision,
    /// `start[c]..start[c+1]` indexes `refs` for cell `c` (x fastest).
    pub(crate) start: Vec<u32>,
    /// Scene indices of the triangles, sorted by cell then index.
    pub(crate) refs: Vec<u32>,
    /// With macro regions: per cell, the box `[lo, hi)` in voxels that the walk leaves in
    /// one step (the cell itself when it is not empty).
    pub(crate) macros: Vec<[u32; 6]>,
    /// The scene's triangles: not saved by the build cache, given back by
    /// [`tb_core::Persist::attach`].
    #[serde(skip)]
    pub(crate) tris: Arc<[Triangle]>,
    times_ms: [f64; 2],
    /// The factor [`within_budget`] scaled the resolution by (1: the bound did not act).
    budget_scale: f64,
}

impl UniformGrid {
    /// Build the grid over `tris` (parallel with rayon).
    pub fn build(tris: &Arc<[Triangle]>, p: &UniformParams) -> Result<UniformGrid, AccelError> {
        let t = Instant::now();
        let precision = p.walk.precision;
        // Equation 1 at λ over the scene's box, lowered by the reference bound while the
        // boxes cover too many voxels.
        let (lat, budget_scale) = crate::lattice::top_level(
            tris,
            p.lambda as f64,
            p.rounding,
            p.max_cells as u64,
            precision,
        );
        let (start, refs) = bin_uniform(&lat, tris)?;
        let t_bin = t.elapsed().as_secs_f64() * 1e3;
        let t = Instant::now();
        let macros = if p.macro_regions {
            macro_regions(&lat, &start)
        } else {
            Vec::new()
        };
        let (planes32, planes64) = planes_for(&lat, precision);
        Ok(UniformGrid {
            lat,
            lat32: lat.cast(),
            planes32,
            planes64,
            precision,
            start,
            refs,
            macros,
            tris: tris.clone(),
            times_ms: [t_bin, t.elapsed().as_secs_f64() * 1e3],
            budget_scale,
        })
    }

    /// The grid's lattice (box, cell size, resolution).
    pub fn lattice(&self) -> &Lattice {
        &self.lat
    }

    #[inline(always)]
    fn dda<T: TriTest, C: Counter, const ANY: bool>(&self, ray: &Ray, c: &mut C) -> HitRecord {
        match self.precision {
            Precision::F32 => self.dda_in::<T, C, ANY, f32>(&self.lat32, &self.planes32, ray, c),
            Precision::F64 => self.dda_in::<T, C, ANY, f64>(&self.lat, &self.planes64, ray, c),
        }
    }

    /// 3D-DDA over `lat`, the lattice in the walk's arithmetic `F`, with its `planes`.
    #[inline(always)]
    fn dda_in<T: TriTest, C: Counter, const ANY: bool, F: Real>(
        &self,
        lat: &Lattice<F>,
        planes: &Planes<F>,
        ray: &Ray,
        c: &mut C,
    ) -> HitRecord {
        let grid = GridView {
            lat,
            planes,
            tris: &self.tris,
            refs: &self.refs,
        };
        cell_walk::<T, C, ANY, false, F>(ray, &grid, c, |v| {
            let i = lat.index(v);
            let r = self.start[i] as usize..self.start[i + 1] as usize;
            if r.is_empty() && !self.macros.is_empty() {
                let m = self.macros[i];
                (r, [m[0], m[1], m[2]], [m[3], m[4], m[5]])
            } else {
                (r, v, v.map(|x| x + 1))
            }
        })
    }
}

tb_core::kernel_by_query!(dda: [] UniformGrid);

/// Macro regions (Devillers 1989, "The macro-regions: an efficient space subdivision
/// structure for ray tracing"): for every empty cell a large empty box of cells around it, so
/// that the walk leaves it in one step. Devillers partitions empty space into maximal empty
/// boxes; here each empty cell grows its own box greedily (one face at a time, as far as the
/// slab beyond it stays empty, until no face can move), so neighbouring cells' regions may
/// overlap, which the walk does not mind (every cell of a region is empty). Emptiness of a
/// box is one look-up in a 3D prefix count of non-empty cells; each face's growth is found by
/// exponential and binary search.
fn macro_regions(lat: &Lattice, start: &[u32]) -> Vec<[u32; 6]> {
    let [rx, ry, _] = lat.res.map(|r| r as usize);
    let fc = FullCount::new(lat, start);
    let full = |lo, hi| fc.any(lo, hi);
    (0..lat.count())
        .into_par_iter()
        .map(|c| {
            let v = [c % rx, (c / rx) % ry, c / (rx * ry)].map(|x| x as u32);
            let (mut lo, mut hi) = (v, v.map(|x| x + 1));
            if start[c + 1] > start[c] {
                return [lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]];
            }
            loop {
                let mut grew = false;
                for a in 0..3 {
                    // Grow the upper face: the largest k with the slab [hi, hi + k) empty.
                    let room = lat.res[a] - hi[a];
                    let k = largest(room, |k| {
                        let (mut l, mut h) = (lo, hi);
                        l[a] = hi[a];
                        h[a] = hi[a] + k;
                        !full(l, h)
                    });
                    hi[a] += k;
                    let room = lo[a];
                    let k2 = largest(room, |k| {
                        let (mut l, mut h) = (lo, hi);
                        h[a] = lo[a];
                        l[a] = lo[a] - k;
                        !full(l, h)
                    });
                    lo[a] -= k2;
                    grew |= k + k2 > 0;
                }
                if !grew {
                    return [lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]];
                }
            }
        })
        .collect()
}

/// Non-empty cells of any box of cells in O(1): a 3D prefix count over `(r+1)^3` entries.
struct FullCount {
    s: Vec<u32>,
    sx: usize,
    sy: usize,
}

impl FullCount {
    fn new(lat: &Lattice, start: &[u32]) -> Self {
        let [rx, ry, rz] = lat.res.map(|r| r as usize);
        let (sx, sy) = (rx + 1, (rx + 1) * (ry + 1));
        let mut s = vec![0u32; sy * (rz + 1)];
        for z in 0..rz {
            for y in 0..ry {
                for x in 0..rx {
                    let c = x + rx * (y + ry * z);
                    let full = (start[c + 1] > start[c]) as u32;
                    let i = (x + 1) + sx * (y + 1) + sy * (z + 1);
                    s[i] = full + s[i - 1] + s[i - sx] + s[i - sy]
                        - s[i - 1 - sx]
                        - s[i - 1 - sy]
                        - s[i - sx - sy]
                        + s[i - 1 - sx - sy];
                }
            }
        }
        FullCount { s, sx, sy }
    }

    /// Whether any cell of `lo..hi` (exclusive) is non-empty.
    fn any(&self, lo: [u32; 3], hi: [u32; 3]) -> bool {
        let at = |x: u32, y: u32, z: u32| {
            self.s[x as usize + self.sx * y as usize + self.sy * z as usize] as i64
        };
        at(hi[0], hi[1], hi[2])
            - at(lo[0], hi[1], hi[2])
            - at(hi[0], lo[1], hi[2])
            - at(hi[0], hi[1], lo[2])
            + at(lo[0], lo[1], hi[2])
            + at(lo[0], hi[1], lo[2])
            + at(hi[0], lo[1], lo[2])
            - at(lo[0], lo[1], lo[2])
            > 0
    }
}

/// The largest `k` in `0..=room` with `ok(k)`, for a predicate true up to some `k` and false
/// beyond (exponential, then binary search).
fn largest(room: u32, ok: impl Fn(u32) -> bool) -> u32 {
    if room == 0 || !ok(1) {
        return 0;
    }
    // ok(good) holds, ok(bad) does not (bad = room + 1: beyond the grid).
    let (mut good, mut bad) = (1u32, room + 1);
    let mut step = 2u32;
    while step <= room {
        if ok(step) {
            good = step;
            step = step.saturating_mul(2);
        } else {
            bad = step;
            break;
        }
    }
    while bad - good > 1 {
        let mid = good + (bad - good) / 2;
        if ok(mid) {
            good = mid;
        } else {
            bad = mid;
        }
    }
    good
}

impl tb_core::Persist for UniformGrid {
    fn attach(
        &mut self,
        tris: &Arc<[Triangle]>,
        _params: &tb_core::ParamSet,
    ) -> Result<(), tb_core::ParamError> {
        self.tris = tris.clone();
        Ok(())
    }
}

impl Structure for UniformGrid {
    const NAME: &'static str = "uniform-grid";
    const TRAVERSALS: &'static [Traversal<Self>] = &[Traversal::with_gpu(
        TraversalInfo::new(
            "dda",
            "Amanatides & Woo 1987; Devillers 1989",
            "3D-DDA from cell to cell (Amanatides and Woo 1987), skipping an empty cell's \
             macro region in one step where built (Devillers 1989)",
        ),
        tb_core::kernel!(|g: &UniformGrid, batch, out| { tb_core::dispatch(g, batch, out) }),
        UniformGrid::gpu_dda,
    )];

    /// The cells' reference starts, the references, the macro regions (24 bytes each, where
    /// built), the plane-coordinate tables and the triangles: what the walk reads.
    ///
    /// `structure_bytes`, the grid alone as Pérard-Gayot et al.'s Table 5 counts the macro-
    /// region grid's memory: cells, references and macro regions (`cells_bytes + refs_bytes +
    /// macro_bytes`); not the plane tables (the lattice's coordinates, derived from the
    /// scene's bounds and the resolution) nor the scene's triangle array.
    fn own_memory(&self) -> MemoryReport {
        let cells = self.lat.count() as u64;
        let structure = self.start.len() * 4 + self.refs.len() * 4 + self.macros.len() * 24;
        MemoryReport {
            bytes: (structure
                + self.planes32.bytes()
                + self.planes64.bytes()
                + self.tris.len() * std::mem::size_of::<Triangle>()) as u64,
            structure_bytes: structure as u64,
            nodes: cells,
            prim_refs: self.refs.len() as u64,
            node_bytes: 4 + if self.macros.is_empty() { 0 } else { 24 },
        }
    }

    /// Extra figures: resolution, cells, empty cells, references, memory of the cell array,
    /// references, macro regions and plane table, build time of the binning and the macro
    /// regions.
    fn report(&self) -> BuildReport {
        let empty = self.start.windows(2).filter(|w| w[0] == w[1]).count();
        let r = self.lat.res;
        let mut extra = vec![
            ("res_x".into(), r[0] as f64),
            ("res_y".into(), r[1] as f64),
            ("res_z".into(), r[2] as f64),
            ("cells".into(), self.lat.count() as f64),
            ("empty_cells".into(), empty as f64),
            ("refs".into(), self.refs.len() as f64),
            ("cells_bytes".into(), (self.start.len() * 4) as f64),
            ("refs_bytes".into(), (self.refs.len() * 4) as f64),
            ("macro_bytes".into(), (self.macros.len() * 24) as f64),
            (
                "planes_bytes".into(),
                (self.planes32.bytes() + self.planes64.bytes()) as f64,
            ),
            ("build_bin_ms".into(), self.times_ms[0]),
            ("build_macro_ms".into(), self.times_ms[1]),
        ];
        if self.budget_scale < 1.0 {
            // Only where the reference bound acted, so that other rows' figures are unchanged.
            extra.push(("ref_budget_scale".into(), self.budget_scale));
        }
        BuildReport {
            sah_cost: None,
            extra,
        }
    }

    /// Checks: the cell ranges are monotone and cover the references, every reference names
    /// a triangle and overlaps its (grown) cell, every macro region holds its cell and only empty cells, and
    /// non-empty cells have none.
    fn check(&self) -> Result<(), AccelError> {
        let bad = |m: String| Err(AccelError::Invalid(m));
        let n = self.lat.count();
        if self.start.len() != n + 1
            || self.start[0] != 0
            || self.start[n] as usize != self.refs.len()
        {
            return bad("cell ranges do not cover the references".into());
        }
        for c in 0..n {
            let (a, b) = (self.start[c] as usize, self.start[c + 1] as usize);
            if a > b {
                return bad(format!("cell {c}: range {a}..{b} decreasing"));
            }
            let v = self.lat.voxel_of(c);
            self.lat.check_refs(
                &self.refs[a..b],
                &self.tris,
                v,
                v.map(|x| x + 1),
                &format!("cell {c}"),
            )?;
        }
        if !self.macros.is_empty() {
            if self.macros.len() != n {
                return bad("one macro region per cell".into());
            }
            let fc = FullCount::new(&self.lat, &self.start);
            for c in 0..n {
                let m = self.macros[c];
                let v = self.lat.voxel_of(c);
                let (lo, hi) = ([m[0], m[1], m[2]], [m[3], m[4], m[5]]);
                if (0..3).any(|a| lo[a] > v[a] || hi[a] <= v[a] || hi[a] > self.lat.res[a]) {
                    return bad(format!("cell {c}: macro region does not hold it"));
                }
                let own = (lo, hi) == (v, v.map(|x| x + 1));
                if self.start[c] == self.start[c + 1] {
                    if fc.any(lo, hi) {
                        return bad(format!("cell {c}: macro region holds a non-empty cell"));
                    }
                } else if !own {
                    return bad(format!("non-empty cell {c} has a macro region"));
                }
            }
        }
        Ok(())
    }
}

impl UniformGrid {}
