//! Grids for ray tracing: the uniform grid with 3D-DDA and macro regions, and the irregular
//! grid of Pérard-Gayot, Kalojanov and Slusallek 2017, "GPU ray tracing using irregular grids".
//!
//! # Structures
//!
//! One registry structure per grid kind, each with its own parameters (the paper's symbols):
//! - `uniform-grid` ([`UniformGrid`]): equation 1 with density λ, references per cell,
//!   traversal `dda` (Amanatides and Woo 1987); `macro_regions = true` adds a macro region
//!   per empty cell (Devillers 1989), the baseline of the paper's Table 5;
//! - `two-level-grid` ([`TwoLevelGrid`]): Kalojanov et al. 2011, a top grid of density λ_1
//!   whose every cell holds a uniform grid of density λ_2 (at most 255 cells per axis),
//!   traversal `dda` (3D-DDA over the top level, nested 3D-DDA in each non-empty top cell),
//!   the baseline of Tables 2 and 4;
//! - `irregular-grid` ([`IrregularGrid`]): the initial subdivision of §4.1 (`two-level`: a top
//!   grid of density λ_1 with an octree per top cell from λ_2; or `uniform` at density λ_1, for
//!   Table 5), SAH merging (§4.2, `merge`, `alpha`), expansion (§4.3, `expansion` passes) and
//!   the traversal of §5 (`walk`; `walk-hagrid`, on request, with the step of the authors'
//!   code, the other reading of §5 step d). Every phase combination of Tables 1 and 5 is a
//!   parameter set of this one structure.
//!
//! Separate structures rather than one with a `kind` choice: the kinds have different
//! parameters (λ vs λ_1, λ_2, α), different memory layouts and different traversals, so a
//! `kind` would leave most parameters meaningless for most kinds.
//!
//! # Shared pieces (module `common`)
//!
//! The resolution rule (equation 1), the lattice, the exact triangle/box overlap (separating
//! axes, against boxes grown by a small margin: conservative, never drops a triangle), the
//! flat `cell → reference range` layout, and one cell walk for every kind.
//!
//! # Why the walk cannot loop or skip
//!
//! Every walk works on integer voxel coordinates. A step leaves the current cell's box through
//! the far plane nearest along the ray, puts the next voxel one layer past the box on that
//! axis, and on the other axes takes the exit point's voxel clamped so it never moves back
//! against the ray (the paper's `max`/`min` with the previous position, §5). So one
//! coordinate strictly advances and none retreats: a ray crosses at most
//! `res_x + res_y + res_z` cells and no step cap is needed. Plane distances and exit points are
//! computed in the grid's `precision` (`f32`, the paper's, or `f64`) from the `f32` ray, so a
//! crossing is placed within a few roundings of the coordinates (module `common` sizes the
//! margin for each), and a misplaced corner or edge crossing lands in a cell whose grown box
//! (references are assigned with the `delta` margin) still holds every triangle of the cell
//! passed by; the walk stops only when the closest hit lies before the current cell's exit.
//! Rays whose origin is so far from the grid that the `f32` triangle test's own rounding can
//! exceed that margin (origins farther than about the grid's own coordinates away; only the
//! far origins of `stress/ray-limits` among our scenes) test every triangle instead
//! (`Lattice::far`), which the counters show.
//!
//! # GPU (module `gpu`)
//!
//! Each traversal has a WGSL kernel of its own (`shaders/`): `uniform-grid/dda`,
//! `two-level-grid/dda`, `irregular-grid/walk` and `irregular-grid/walk-hagrid`, the CPU walks step for step in the same
//! precision: in `f32` on every adapter (a driver contracting into FMAs may move a crossing by
//! an ulp, which the margin covers), in `f64` as `…-f64` programs on adapters with
//! `SHADER_F64` (refused elsewhere), hits and counters equal to the CPU's ray for ray.
//! Construction stays on the CPU.
//!
//! # The paper's experiments
//!
//! The configs run the paper's tables and figures on these structures: Tables 1 and 5 (the
//! build phases, the uniform initial grid and macro regions) in `configs/irregular-grid.toml`,
//! the static scenes at two views (Table 3) in `configs/irregular-table3.toml`, the
//! λ_1 × λ_2 sweep (Table 2, Figure 6) in `configs/irregular-lambda.toml`, the scene inside
//! itself (§6.2, Figure 8; `inset` of a scene) in `configs/irregular-inset.toml`, and the
//! dynamic scenes rebuilt per frame (§6.3, Table 4; the animated `explode` and `deform`
//! teapots) in `configs/irregular-dynamic.toml`: the static scenes against the paper's SBVH
//! (`bvh` with `builder = "sbvh"`), the dynamic ones against the two-level grid. Procedural
//! built-ins stand in for the paper's Hairball and Crown (`builtin:hairball`,
//! `builtin:crown`).
//!
//! Not done: construction on the GPU (§4 builds on the GPU; here the grids are built on the
//! CPU and their arrays uploaded as they are), and the paper's own scene files that are not
//! ours (San Miguel, Crytek Sponza, the dynamic scenes' fairy, dragon and lion), for which
//! the configs name their stand-ins.

#![deny(missing_docs)]

mod common;
mod gpu;
mod irregular;
mod lattice;
mod params;
mod two_level;
mod uniform;

pub use irregular::{Cell, IrregularGrid};
pub use lattice::{resolution, tri_box_overlap, Lattice};
pub use params::{
    Densities, Initial, IrregularParams, Precision, Rounding, TwoLevelParams, UniformParams, Walk,
    DENSITIES,
};
pub use two_level::{TopCell, TwoLevelGrid};
pub use uniform::UniformGrid;

use tb_core::{build_with, Family};

/// The uniform grid in the registry.
pub static UNIFORM_FAMILY: Family = Family::new::<UniformGrid, UniformParams>(
    "uniform grid of equation 1's density `lambda`, optional macro regions per empty cell \
     (`macro_regions`) (Amanatides and Woo 1987; Devillers 1989)",
    |tris, set| build_with(set, |p: &UniformParams| UniformGrid::build(tris, p)),
)
.with_summary("uniform grid, optional macro regions (Amanatides and Woo 1987; Devillers 1989)")
.with_persist::<UniformGrid>()
.with_method(1, tb_core::FIRST_METHOD);

/// The two-level grid in the registry.
pub static TWO_LEVEL_FAMILY: Family = Family::new::<TwoLevelGrid, TwoLevelParams>(
    "top-level grid of density `lambda_1`, a uniform `lambda_2` grid in each top cell (Kalojanov \
     et al. 2011)",
    |tris, set| build_with(set, |p: &TwoLevelParams| TwoLevelGrid::build(tris, p)),
)
.with_densities(DENSITIES)
.with_persist::<TwoLevelGrid>()
.with_method(1, tb_core::FIRST_METHOD);

/// The irregular grid in the registry.
pub static IRREGULAR_FAMILY: Family = Family::new::<IrregularGrid, IrregularParams>(
    "two-level (octree per top cell) or uniform (`initial`) voxelization, SAH cell merging \
     (`merge`, `alpha`), cell expansion passes (`expansion`), two-level voxel map (Pérard-Gayot \
     et al. 2017)",
    |tris, set| build_with(set, |p: &IrregularParams| IrregularGrid::build(tris, p)),
)
.with_summary(
    "irregular grid: voxelization, SAH cell merging, cell expansion (Pérard-Gayot et al. 2017)",
)
.with_densities(DENSITIES)
.with_persist::<IrregularGrid>()
.with_method(1, tb_core::FIRST_METHOD);
