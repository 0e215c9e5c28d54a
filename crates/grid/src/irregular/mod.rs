//! The irregular grid of Pérard-Gayot, Kalojanov and Slusallek 2017, "GPU ray tracing using
//! irregular grids" (Eurographics): build (§4: initial subdivision, SAH cell merging, cell
//! expansion) and the traversal of §5.

use crate::common::{cell_walk, GridView};
use crate::lattice::{
    bin_uniform, is_subset, planes_for, resolution, union_into, union_len, Lattice, Planes, Real,
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

mod build;
mod merge;

/// One cell, 32 bytes: its box on the virtual base grid (`lo..hi`, exclusive, in base voxels;
/// grown by expansion) and its range of `IrregularGrid::refs`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Cell {
    /// Lower corner of the cell's box on the base grid, in base voxels (inclusive).
    pub lo: [u32; 3],
    /// First index of the cell's range of references.
    pub begin: u32,
    /// Upper corner of the cell's box on the base grid, in base voxels (exclusive).
    pub hi: [u32; 3],
    /// One past the last index of the cell's range of references.
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
#[derive(serde::Serialize, serde::Deserialize)]
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
    /// The scene's triangles: not saved by the build cache, given back by
    /// [`tb_core::Persist::attach`].
    #[serde(skip)]
    pub(crate) tris: Arc<[Triangle]>,
    figures: Vec<(String, f64)>,
}

impl IrregularGrid {
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

    /// Traversal `walk`.
    #[inline(always)]
    fn walk<T: TriTest, C: Counter, const ANY: bool>(&self, ray: &Ray, c: &mut C) -> HitRecord {
        self.walk_with::<T, C, ANY, false>(ray, c)
    }

    /// The §5 walk in the grid's precision; with `TIES` by the authors' step (traversal
    /// `walk-hagrid`, [`crate::common::WalkRay::advance_ties`]).
    #[inline(always)]
    fn walk_with<T: TriTest, C: Counter, const ANY: bool, const TIES: bool>(
        &self,
        ray: &Ray,
        c: &mut C,
    ) -> HitRecord {
        match self.precision {
            Precision::F32 => {
                self.walk_in::<T, C, ANY, TIES, f32>(&self.base32, &self.planes32, ray, c)
            }
            Precision::F64 => {
                self.walk_in::<T, C, ANY, TIES, f64>(&self.base, &self.planes64, ray, c)
            }
        }
    }

    /// The §5 walk over `base`, the base lattice in the walk's arithmetic `F`, with its
    /// `planes`.
    #[inline(always)]
    fn walk_in<T: TriTest, C: Counter, const ANY: bool, const TIES: bool, F: Real>(
        &self,
        base: &Lattice<F>,
        planes: &Planes<F>,
        ray: &Ray,
        c: &mut C,
    ) -> HitRecord {
        let grid = GridView {
            lat: base,
            planes,
            tris: &self.tris,
            refs: &self.refs,
        };
        cell_walk::<T, C, ANY, TIES, F>(ray, &grid, c, |v| {
            let cell = &self.cells[self.lookup(v) as usize];
            (cell.range(), cell.lo, cell.hi)
        })
    }
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

tb_core::kernel_by_query!(walk: [] IrregularGrid);

/// Traversal `walk-hagrid`: the §5 walk with the step of the authors' code (hagrid), a
/// reading of step d the paper leaves open ([`crate::common::WalkRay::advance_ties`]).
struct HagridWalk<'a>(&'a IrregularGrid);

impl HagridWalk<'_> {
    #[inline(always)]
    fn walk<T: TriTest, C: Counter, const ANY: bool>(&self, ray: &Ray, c: &mut C) -> HitRecord {
        self.0.walk_with::<T, C, ANY, true>(ray, c)
    }
}

tb_core::kernel_by_query!(walk: [] HagridWalk<'_>);

impl tb_core::Persist for IrregularGrid {
    fn attach(
        &mut self,
        tris: &Arc<[Triangle]>,
        _params: &tb_core::ParamSet,
    ) -> Result<(), tb_core::ParamError> {
        self.tris = tris.clone();
        Ok(())
    }
}

impl Structure for IrregularGrid {
    const NAME: &'static str = "irregular-grid";
    const TRAVERSALS: &'static [Traversal<Self>] = &[
        Traversal::with_gpu(
            TraversalInfo::new(
                "walk",
                "Pérard-Gayot et al. 2017 §5",
                "3D-DDA on the virtual base grid with the increment recomputed per cell: voxel-map \
                 look-up, exit through the cell box's three far planes, monotone advance",
            ),
            tb_core::kernel!(|g: &IrregularGrid, batch, out| { tb_core::dispatch(g, batch, out) }),
            IrregularGrid::gpu_walk,
        ),
        Traversal::with_gpu(
            TraversalInfo::new(
                "walk-hagrid",
                "Pérard-Gayot et al. 2017 §5 (the authors' code, hagrid)",
                "walk with the authors' step: every axis tied for the exit steps (diagonally \
                 through edges and corners), the other axes take the exit point's voxel unclamped \
                 to the cell's box",
            )
            .on_request(),
            tb_core::kernel!(|g: &IrregularGrid, batch, out| {
                tb_core::dispatch(&HagridWalk(g), batch, out)
            }),
            IrregularGrid::gpu_walk_hagrid,
        ),
    ];

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
    use super::build::*;
    use super::merge::*;
    use super::*;
    use crate::lattice::{grid_bounds, MAX_AXIS_RES};
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
            let binned = Binned { start, refs };
            let depth = vec![0; top.count()];
            let mut made = Subdivision {
                top: &top,
                base: &base,
                dmax: 0,
                depth: &depth,
                tris,
            }
            .initial(&binned);
            merge_pass(&base, 0, &mut made, 0, &p);
            let implicit = merge_first_x(&base, binned, &p);
            merged_somewhere |= implicit.cells.len() < top.count();
            let name = &scene.source;
            assert_eq!(made.cells, implicit.cells, "{name}: cells");
            assert_eq!(made.refs, implicit.refs, "{name}: references");
            assert_eq!(made.map, unflatten(implicit.map), "{name}: voxel map");
        }
        assert!(merged_somewhere, "no scene of the suite merged a cell");
    }

    /// A cap that lowers an octree below equation 1's depth says so in the build
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

    /// §6.1, Figure 5 (the expansion's share of the build): the build reports its
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
