//! The grids' build parameters (their tables: `trace-bench list`): the two densities of a
//! two-level subdivision, declared once ([`Densities`]) and composed by the two-level and the
//! irregular grid, then each kind's own.

#[cfg(doc)]
use crate::{IrregularGrid, TwoLevelGrid, UniformGrid};
use tb_core::{ParamKind, Params};

tb_core::params! {
    /// The two densities of a two-level subdivision (equation 1 at each level; Kalojanov et
    /// al. 2011 §3, Pérard-Gayot et al. 2017 §4.1): one group, declared here once and composed
    /// by the two-level and the irregular grid, whose family offers them to the dynamic
    /// experiment's density choice ([`DENSITIES`]).
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct Densities {
        /// top-level density λ_1 of equation 1 (the irregular grid's §4.1; with its
        /// `initial = "uniform"`, the density of that uniform grid)
        lambda_1: f32 = 0.12, ParamKind::Float { min: 1e-4, max: 1e3 };
        /// second-level density λ_2 of equation 1 over each top cell and its primitives: the
        /// resolution of the cell's uniform grid (two-level grid, at most 255 cells per axis),
        /// or the cell's octree depth D = ⌈log2 max(R_x, R_y, R_z)⌉ (irregular grid, §4.1)
        lambda_2: f32 = 2.4, ParamKind::Float { min: 1e-4, max: 1e3 };
        /// how equation 1's `R_a = d_a ∛(λN/V)` becomes an integer at both levels: the
        /// paper does not say; `truncate` is the authors' code's (hagrid: the conversion to
        /// int), `nearest` our earlier reading
        rounding: Rounding = Rounding::Truncate, ParamKind::Choice(Rounding::NAMES);
    }
}

tb_core::choice! {
    /// Equation 1's resolution as an integer (Pérard-Gayot et al. 2017 §4.1 leave it open:
    /// two readings, each a variant).
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    pub enum Rounding {
        /// toward zero, as the authors' code converts it (the default: the paper's method)
        Truncate = "truncate",
        /// to the nearest integer (our earlier reading)
        Nearest = "nearest",
    }
}

tb_core::choice! {
    /// The arithmetic of the cell walks (the module doc of `tb_grid`'s walks: the reference
    /// margin and the far-origin threshold follow it).
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    pub enum Precision {
        /// positions and plane distances in `f32`, as the paper's walk (hagrid); the GPU
        /// programs run on every adapter
        F32 = "f32",
        /// in `f64` (for comparison; the GPU programs need `SHADER_F64`)
        F64 = "f64",
    }
}

tb_core::params! {
    /// How every grid walks its cells: one group, declared here once and composed by the
    /// three grids.
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct Walk {
        /// arithmetic of the cell walk, `f32` (the paper's) or `f64`; the reference margin
        /// and the far-origin threshold are sized for it, so both are exact against the oracle
        precision: Precision = Precision::F32, ParamKind::Choice(Precision::NAMES);
    }
}

/// The names of [`Densities`]' two entries, as the families offer them
/// ([`tb_core::Family::with_densities`]).
pub const DENSITIES: [&str; 2] = [Densities::SPECS[0].name, Densities::SPECS[1].name];

tb_core::params! {
    /// Build parameters of [`UniformGrid`].
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct UniformParams {
        /// grid density λ of equation 1 (cells per primitive; Pérard-Gayot et al. 2017 §4.1,
        /// Table 5 uses λ = 5)
        lambda: f32 = 5.0, ParamKind::Float { min: 1e-4, max: 1e3 };
        /// equation 1's resolution as an integer, as [`Densities`]' `rounding`
        rounding: Rounding = Rounding::Truncate, ParamKind::Choice(Rounding::NAMES);
        /// store a macro region per empty cell and skip it in one step (Devillers 1989)
        macro_regions: bool = false, ParamKind::Bool;
        /// largest number of cells (the resolution is scaled down to stay under it)
        max_cells: u32 = 1 << 26, ParamKind::Int { min: 1, max: 1 << 30 };
        /// how the cells are walked ([`Walk`]: the arithmetic of the cell walk)
        @flatten
        walk: Walk = Walk::default();
    }
}

tb_core::params! {
    /// Build parameters of [`TwoLevelGrid`] (Kalojanov et al. 2011 §3).
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct TwoLevelParams {
        /// the two densities λ_1, λ_2 and their rounding ([`Densities`])
        @flatten
        densities: Densities = Densities::default();
        /// largest number of top-level cells
        max_cells: u32 = 1 << 24, ParamKind::Int { min: 1, max: 1 << 28 };
        /// how the cells are walked ([`Walk`]: the arithmetic of the cell walk)
        @flatten
        walk: Walk = Walk::default();
    }
}

tb_core::choice! {
    /// The initial subdivision of §4.1.
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    pub enum Initial {
        /// a top-level grid of density λ_1 with an octree of depth D (from λ_2) per top cell
        TwoLevel = "two-level",
        /// a uniform grid of density λ_1 (Table 5: merge and expansion on a uniform grid)
        Uniform = "uniform",
    }
}

tb_core::params! {
    /// Build parameters of [`IrregularGrid`] (Pérard-Gayot et al. 2017 §4).
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct IrregularParams {
        /// the two densities λ_1, λ_2 and their rounding ([`Densities`])
        @flatten
        densities: Densities = Densities::default();
        /// initial subdivision: `two-level` (octree per top cell, §4.1) or `uniform`
        initial: Initial = Initial::TwoLevel, ParamKind::Choice(Initial::NAMES);
        /// SAH cell merging along alternating axes (§4.2)
        merge: bool = true, ParamKind::Bool;
        /// merge termination: stop when a round of x, y, z passes leaves
        /// N_after ≥ α N_before cells (§4.2)
        alpha: f32 = 0.995, ParamKind::Float { min: 0.0, max: 1.0 };
        /// cell expansion passes (§4.3; 3 for static scenes, 1 for dynamic ones)
        expansion: u32 = 3, ParamKind::Int { min: 0, max: 16 };
        /// cost of traversing a cell, C_t (§4.2)
        c_t: f32 = 1.0, ParamKind::Float { min: 0.0, max: 1e6 };
        /// cost of a triangle test, C_i (§4.2)
        c_i: f32 = 1.0, ParamKind::Float { min: 0.0, max: 1e6 };
        /// largest number of voxel-map entries, the finest voxels of every top cell's octree
        /// (octree depths are lowered to stay under it; the initial cells are at most as many)
        max_cells: u32 = 1 << 25, ParamKind::Int { min: 1, max: 1 << 27 };
        /// how the cells are walked ([`Walk`]: the arithmetic of the cell walk)
        @flatten
        walk: Walk = Walk::default();
    }
}
