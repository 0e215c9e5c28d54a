//! The BVH's build parameters (its table: `trace-bench list`), their choices and the rules across them.

#[cfg(doc)]
use crate::{Bvh, LeafBlock};
use tb_core::params::ParamKind;
use tb_core::AccelError;

tb_core::params! {
    /// Build parameters of [`Bvh::build`].
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct BvhParams {
        /// SAH bins per axis over a node's centroid bounds (Wald 2007, binned SAH)
        bins: u32 = 16, ParamKind::Int { min: 2, max: 256 };
        /// largest leaf; larger nodes are always split (by the best SAH bin, or at the object
        /// median where no bin separates them)
        max_leaf: u32 = 4, ParamKind::Int { min: 1, max: 255 };
        /// nodes this small always become leaves
        min_leaf: u32 = 1, ParamKind::Int { min: 1, max: 255 };
        /// SAH cost of a traversal step, C_trav (MacDonald and Booth 1990)
        c_trav: f32 = 1.0, ParamKind::Float { min: 1e-6, max: 1e6 };
        /// SAH cost of a triangle test, C_isect
        c_isect: f32 = 1.0, ParamKind::Float { min: 1e-6, max: 1e6 };
        /// the builder: `binned` (binned SAH, object splits only) or `sbvh` (object and
        /// spatial splits, Stich et al. 2009); the defaults (`binned`, `width = 8`,
        /// `leaf_cost = "blocks"`) trace as fast as the SBVH's BVH8 and build 4-7x faster
        /// (docs/PERFORMANCE.md, "The default BVH")
        builder: Builder = Builder::Binned, ParamKind::Choice(Builder::NAMES);
        /// SBVH overlap threshold: spatial splits are tried where the object split's children
        /// overlap by more than `alpha` times the root's surface area (Stich et al. 2009 §4.4)
        alpha: f32 = 1e-5, ParamKind::Float { min: 0.0, max: 1.0 };
        /// children per node: 2 (binary), or 4 or 8 (collapsed from the binary tree, child
        /// boxes tested with SIMD; Wald, Benthin and Boulos 2008)
        width: u32 = 8, ParamKind::Int { min: 2, max: 8 };
        /// child-box test of wide nodes: `auto` (SSE for 4, AVX for 8 where the CPU has it,
        /// the same walk compiled for AVX-512 where it has that), or `scalar` (a lane loop)
        simd: Simd = Simd::Auto, ParamKind::Choice(Simd::NAMES);
        /// build threads: 0 = the current rayon pool (all threads in the harness), n = a pool
        /// of n threads (1: sequential); the tree is the same for every count
        build_threads: u32 = 0, ParamKind::Int { min: 0, max: 1024 };
        /// SAH price of a leaf of `n` triangles: `linear`, `C_isect·n` (MacDonald and Booth
        /// 1990), or `blocks`, `C_isect·⌈n/4⌉` (the wide trees test a leaf's triangles four at
        /// once in SoA blocks, `LeafBlock`, so a leaf of 3 costs what a leaf of 1 costs);
        /// used by both builders (leaf or split, the reported SAH cost) and the collapse
        leaf_cost: LeafCost = LeafCost::Blocks, ParamKind::Choice(LeafCost::NAMES);
        /// how a wide tree (`width` 4 or 8) is collapsed from the binary one: `sah`, the
        /// SAH-optimal collapse by dynamic programming (Ylitie, Karras and Laine 2017 §3.1),
        /// or `greedy`, opening the child of largest area until the node is full (Wald et
        /// al. 2008 §3)
        collapse: Collapse = Collapse::Sah, ParamKind::Choice(Collapse::NAMES);
        /// SBVH object splits: `sweep`, the full SAH sweep over the references sorted by
        /// centre on each axis (Stich et al. 2009 §4, as the original SBVH), or `binned`
        /// (`bins` bins of the centre bounds, as the binned builder)
        object_split: ObjectSplit = ObjectSplit::Sweep, ParamKind::Choice(ObjectSplit::NAMES);
    }
}

tb_core::choice! {
    /// The SAH price of a leaf's triangles (parameter `leaf_cost`).
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    pub enum LeafCost {
        /// One triangle test per triangle: `C_isect·n`.
        Linear = "linear",
        /// One test of a block of four per started block: `C_isect·⌈n/4⌉` (the wide trees'
        /// [`LeafBlock`]s, `TriTest::intersect4`).
        Blocks = "blocks",
    }
}

impl LeafCost {
    /// The number of triangle tests (or blocks of four) a leaf of `n` triangles is priced at;
    /// the SAH leaf cost is `C_isect` times this times the leaf's area.
    #[inline(always)]
    pub fn units(self, n: usize) -> f32 {
        match self {
            LeafCost::Linear => n as f32,
            LeafCost::Blocks => n.div_ceil(4) as f32,
        }
    }
}

tb_core::choice! {
    /// How the wide trees are collapsed from the binary one (parameter `collapse`).
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    pub enum Collapse {
        /// SAH-optimal by dynamic programming over the binary tree (Ylitie, Karras and Laine
        /// 2017, "Efficient incoherent ray traversal on GPUs through compressed wide BVHs",
        /// §3.1).
        Sah = "sah",
        /// Greedy: open the interior child of largest surface area until the node is full
        /// (Wald, Benthin and Boulos 2008 §3).
        Greedy = "greedy",
    }
}

tb_core::choice! {
    /// How the SBVH finds its object splits (parameter `object_split`).
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    pub enum ObjectSplit {
        /// Full SAH sweep over the references sorted by box centre on each axis (Stich,
        /// Friedrich and Dietrich 2009 §4, after Wald 2007's sweep): every split position.
        Sweep = "sweep",
        /// Binned SAH over the centre bounds (`bins` bins; Wald 2007).
        Binned = "binned",
    }
}

tb_core::choice! {
    /// Which builder makes the binary tree.
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    pub enum Builder {
        /// Binned SAH over triangle centroids, object splits (Wald 2007); parallel (rayon).
        Binned = "binned",
        /// Spatial-split BVH: object splits (full SAH sweep, or binned: `object_split`) and
        /// binned spatial splits with reference unsplitting (Stich, Friedrich and Dietrich
        /// 2009); triangles may be referenced by several leaves; parallel (rayon).
        Sbvh = "sbvh",
    }
}

tb_core::choice! {
    /// How a wide node's child boxes are tested.
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    pub enum Simd {
        /// The widest instruction set the CPU has for the width (runtime detection).
        Auto = "auto",
        /// One lane after the other (the portable fallback).
        Scalar = "scalar",
    }
}

impl BvhParams {
    /// The binary binned BVH with leaves priced per triangle (`builder = "binned", width = 2,
    /// leaf_cost = "linear"`, the rest at the defaults): the classic baseline, the secondary-ray
    /// generator's tree, and the defaults before the binned BVH8 became the default.
    pub fn binary() -> Self {
        BvhParams {
            builder: Builder::Binned,
            width: 2,
            leaf_cost: LeafCost::Linear,
            ..Default::default()
        }
    }

    /// Check the parameters: the ranges of the table, then the rules
    /// ([`tb_core::ParamRules`]).
    pub fn check(&self) -> Result<(), AccelError> {
        tb_core::ParamRules::check_all(self, "bvh")
    }
}

/// The rules across the BVH's parameters: `min_leaf ≤ max_leaf`; `width` 2, 4 or 8.
impl tb_core::ParamRules for BvhParams {
    fn rules(&self) -> Result<(), String> {
        if self.min_leaf > self.max_leaf {
            return Err(format!(
                "min_leaf ({}) must not exceed max_leaf ({})",
                self.min_leaf, self.max_leaf
            ));
        }
        if ![2, 4, 8].contains(&self.width) {
            return Err(format!("width must be 2, 4 or 8, got {}", self.width));
        }
        Ok(())
    }
}
