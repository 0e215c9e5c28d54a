//! The kd-tree's build parameters (its table: `trace-bench list`), the split search, the cell
//! measure of the SAH, and the rules across parameters checked with a config.

use crate::stackless::{MAX_SHORT_STACK, STEP_CAP};
use crate::traverse::STACK_SIZE;
use crate::KdLayout;
use tb_core::{Aabb, AccelError, ParamKind};

tb_core::choice! {
    /// Which split-search algorithm the builder uses.
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    pub enum KdBuilder {
        /// Exact SAH sweep over events sorted once at the root and passed down, only the events
        /// of re-clipped straddling triangles sorted per node: O(N log N) (Wald and Havran 2006,
        /// §5). The same tree as `sweep-nlog2n`.
        Sweep = "sweep",
        /// Exact SAH sweep over the sorted events of each node, the events sorted anew at every
        /// node: O(N log² N) (Wald and Havran 2006, §4.2).
        SweepNlog2n = "sweep-nlog2n",
        /// SAH evaluated only at the `bins − 1` inner boundaries of `bins` equal intervals of
        /// the node cell on each axis, from per-bin counts of box starts and ends (min-max
        /// binning, Shevtsov et al. 2007; Hapala and Havran 2011 §2), and with `snap` also at
        /// the box bounds nearest each boundary: O(N) per node; nodes of at most `bins`
        /// references are split by the exact sweep, as Shevtsov et al. switch.
        Binned = "binned",
    }
}

tb_core::params! {
    /// The SAH split search of a kd-tree build: one group, declared here once and composed by
    /// every structure built on this crate's builders ([`KdParams`], tb-sparse's and
    /// tb-multikd's parameters, each with `@flatten`); its entries keep their own names in
    /// those tables.
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct SahParams {
        /// Split search: exact SAH event sweep, O(N log N) (`sweep`) or O(N log² N)
        /// (`sweep-nlog2n`, the same tree) (Wald and Havran 2006), or min-max binning
        /// (`binned`, Shevtsov et al. 2007; the exact sweep below `bins` references).
        builder: KdBuilder = KdBuilder::Sweep, ParamKind::Choice(KdBuilder::NAMES);
        /// Bins per axis, `binned` builder only (nodes of at most `bins` references are split
        /// by the exact sweep).
        bins: u32 = 32, ParamKind::Int { min: 2, max: 1024 };
        /// `binned` builder only: also price, at each bin boundary, the greatest box end in
        /// the bin below and the least box start in the bin above with the boundary's counts,
        /// so that splits can lie on triangle bounds as the sweep's do (`false`: the
        /// boundaries only, as Shevtsov et al. 2007).
        snap: bool = true, ParamKind::Bool;
        /// SAH traversal cost C_trav (Hapala and Havran 2011, section 2; `Cost_plane` of
        /// Torres et al. 2012 §3).
        c_trav: f32 = 1.0, ParamKind::Float { min: 1e-6, max: 1e6 };
        /// SAH triangle test cost C_isect (the review uses C_trav ≈ 1, C_isect ≈ 1.5;
        /// `Cost_tri` of Torres et al. 2012 §3, 1 in their §7).
        c_isect: f32 = 1.5, ParamKind::Float { min: 1e-6, max: 1e6 };
        /// A split with an empty side costs (1 - bonus) times the SAH (Wald and Havran 2006
        /// use the factor 0.8, i.e. bonus 0.2).
        empty_bonus: f32 = 0.2, ParamKind::Float { min: 0.0, max: 0.999 };
        /// Depth limit (root depth 0); 0 = round(8 + 1.3 log2 N) (Havran 2000), capped at
        /// the traversal stack (64 entries).
        max_depth: u32 = 0, ParamKind::Int { min: 0, max: STACK_SIZE as i64 };
        /// Nodes with at most this many triangles become leaves.
        min_leaf: u32 = 1, ParamKind::Int { min: 0, max: 1024 };
    }
}

tb_core::params! {
    /// Build parameters of [`KdTree::build`]: the SAH split search ([`SahParams`]), then the
    /// walks' and the layout's; each field's doc, default and range is its entry in the
    /// parameter table ([`Params::SPECS`](tb_core::Params::SPECS)).
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct KdParams {
        /// The SAH split search ([`SahParams`]), its entries first in the table.
        @flatten
        sah: SahParams = SahParams::default();
        /// Entries of the short stack (`short-stack` traversal, Horn et al. 2007;
        /// `stack-spilling`, Novák 2009).
        short_stack: u32 = 4, ParamKind::Int { min: 1, max: MAX_SHORT_STACK as i64 };
        /// Per-ray step cap of the restart-type traversals (`restart` … `ropes`, sparse boxes'
        /// SLTR and SEQ); capped rays are ended with their closest hit so far and counted (a
        /// guard: these walks end).
        step_cap: u32 = STEP_CAP, ParamKind::Int { min: 1, max: 1 << 30 };
        /// Node layout: left child next to its parent (`depth-first`), or subtrees in aligned
        /// blocks (`treelet`) (Havran 1999; Hapala and Havran 2011, section 6); every
        /// traversal visits the same nodes in both.
        layout: KdLayout = KdLayout::DepthFirst, ParamKind::Choice(KdLayout::NAMES);
        /// Levels per treelet block, 2^h 8-byte slots (3 = one 64-byte cache line).
        treelet_height: u32 = 3, ParamKind::Int { min: 2, max: 8 };
    }
}

impl KdParams {
    /// The ranges of the table: what [`crate::KdTree::build`] checks (the kd-tree has no rules
    /// across its parameters beyond them).
    pub fn check(&self) -> Result<(), AccelError> {
        tb_core::ParamRules::check_all(self, "kd-tree")
    }

    /// The depth limit for `n` triangles ([`SahParams::depth_limit`]).
    pub fn depth_limit(&self, n: usize) -> u32 {
        self.sah.depth_limit(n)
    }
}

impl SahParams {
    /// The depth limit for `n` triangles: `max_depth`, or when 0, `round(8 + 1.3·log2 n)`
    /// capped at [`STACK_SIZE`].
    pub fn depth_limit(&self, n: usize) -> u32 {
        if self.max_depth > 0 {
            return self.max_depth;
        }
        let d = 8.0 + 1.3 * (n.max(1) as f64).log2();
        (d.round() as u32).min(STACK_SIZE as u32)
    }
}

/// The measure of a cell used by the SAH: the probability that a ray hitting a node's cell
/// hits a child cell is taken as `measure(child) / measure(node)`.
pub trait BoxMeasure: Sync {
    /// The measure of cell `b` (non-negative; only ratios between cells matter).
    fn measure(&self, b: &Aabb) -> f32;
}

/// The surface area (half of it; only ratios matter): uniformly distributed rays.
#[derive(Clone, Copy, Debug, Default)]
pub struct SurfaceArea;

impl BoxMeasure for SurfaceArea {
    #[inline(always)]
    fn measure(&self, b: &Aabb) -> f32 {
        b.half_area()
    }
}

/// No rules beyond the ranges.
impl tb_core::ParamRules for KdParams {}
