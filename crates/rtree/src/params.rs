//! The R-tree's build parameters (its table: `trace-bench list`), their choices and the rule across them.

#[cfg(doc)]
use crate::Rtree;
use tb_core::params::ParamKind;
use tb_core::AccelError;

tb_core::choice! {
    /// ChooseSubtree criterion of the insertion build (paper section 5.1). In 3D, Guttman's
    /// "area" is the box volume and the "margin" its surface (section 3.1); *overlap
    /// enlargement* of an entry is the growth of the summed overlap volume with its siblings
    /// (Beckmann et al. 1990). Remaining ties fall to further keys listed per variant.
    #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
    pub enum Strategy {
        /// `min-volume`: least volume enlargement at every level, ties by least volume
        /// (Guttman 1984), then least surface enlargement.
        MinVolume = "min-volume",
        /// `min-surface`: least surface enlargement at every level (the SAH's measure), ties
        /// by least surface, then least volume enlargement.
        MinSurface = "min-surface",
        /// `min-overlap`: least overlap enlargement at every level, ties by least volume
        /// enlargement, least volume, least surface enlargement.
        MinOverlap = "min-overlap",
        /// `r-star`: R*-tree (Beckmann et al. 1990): least volume enlargement at intermediate
        /// levels, least overlap enlargement where the entries are leaves.
        RStar = "r-star",
        /// `r-star-srfc`: the paper's R*-treeSrfc: least surface enlargement at intermediate
        /// levels, least overlap enlargement where the entries are leaves (best in Table 1).
        RStarSrfc = "r-star-srfc",
        /// `str`: no insertion; Sort-Tile-Recursive bulk loading (Leutenegger, Lopez and
        /// Edgington 1997), the bulk loading the paper's conclusion suggests (section 6).
        /// Nodes are full (`M` entries) but for the last of each level; `reinsert` is ignored.
        Str = "str",
    }
}

tb_core::choice! {
    /// Order of the entries within a packed node (paper section 3.1, Figure 3: the order in
    /// which children are visited by the `stackless` and `stack` traversals).
    #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
    pub enum ChildOrder {
        /// `insertion`: as the build left them.
        Insertion = "insertion",
        /// `sorted-x`: by increasing box centre x.
        SortedX = "sorted-x",
        /// `sorted-y`: by increasing box centre y.
        SortedY = "sorted-y",
        /// `sorted-z`: by increasing box centre z.
        SortedZ = "sorted-z",
    }
}

impl ChildOrder {
    /// Sorted along `axis` (0, 1, 2).
    pub fn sorted(axis: usize) -> Self {
        match axis {
            0 => ChildOrder::SortedX,
            1 => ChildOrder::SortedY,
            _ => ChildOrder::SortedZ,
        }
    }
}

tb_core::params! {
    /// Build parameters of [`Rtree::build`].
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct RtreeParams {
        /// least entries per node, m (Feldmann section 2.2; 2 <= m <= M/2; default 2 as in
        /// section 5)
        m: u32 = 2, ParamKind::Int { min: 2, max: 8 };
        /// most entries per node, M (Feldmann section 2.2; default 4 as in section 5)
        big_m: u32 = 4, ParamKind::Int { min: 4, max: 16 };
        /// ChooseSubtree strategy (section 5.1, Table 1), or Sort-Tile-Recursive bulk loading
        strategy: Strategy = Strategy::RStarSrfc, ParamKind::Choice(Strategy::NAMES);
        /// forced reinsertion on overflow, once per level per insertion (R*-tree; section
        /// 2.2.1, Table 2)
        reinsert: bool = true, ParamKind::Bool;
        /// share p/M of the entries a forced reinsertion ejects (Beckmann et al. 1990: 30%;
        /// p = clamp(round(share M), 1, M + 1 - m))
        reinsert_share: f32 = 0.3, ParamKind::Float { min: 0.01, max: 0.5 };
        /// order of the entries within a packed node (section 3.1, Figure 3)
        child_order: ChildOrder = ChildOrder::Insertion, ParamKind::Choice(ChildOrder::NAMES);
    }
}

impl RtreeParams {
    /// Check the parameters: the ranges of the table (`4 ≤ M ≤ 16`, …), then the rule
    /// `m ≤ M/2` ([`tb_core::ParamRules`]).
    pub fn check(&self) -> Result<(), AccelError> {
        tb_core::ParamRules::check_all(self, "r-tree")
    }

    /// `p`, the number of entries a forced reinsertion ejects.
    pub fn reinsert_count(&self) -> usize {
        let p = (self.reinsert_share as f64 * self.big_m as f64).round() as usize;
        p.clamp(1, (self.big_m + 1 - self.m) as usize)
    }
}

/// The rule across the R-tree's parameters: `m ≤ M/2` (Feldmann §2.2).
impl tb_core::ParamRules for RtreeParams {
    fn rules(&self) -> Result<(), String> {
        if self.m > self.big_m / 2 {
            return Err(format!(
                "m must be in 2..=M/2 = {}, got {}",
                self.big_m / 2,
                self.m
            ));
        }
        Ok(())
    }
}
