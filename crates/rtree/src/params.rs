//! The R-tree's build parameters (its table: `trace-bench list`), their choices and the rule across them.

#[cfg(doc)]
use crate::Rtree;
use tb_core::params::ParamKind;
use tb_core::AccelError;

tb_core::choice! {
    /// ChooseSubtree criterion of the insertion build (paper section 5.1). In 3D, Guttman's
    /// "area" is the box volume and the "margin" its surface (section 3.1); *overlap* of an
    /// entry is the summed intersection volume of its box with its siblings' boxes, *overlap
    /// enlargement* the growth of that sum when the entry takes the new box (Beckmann et al.
    /// 1990). Keys are compared in the order listed; remaining ties go to the first entry in
    /// the node. The paper's five strategies (`min-volume`, `min-surface`, `min-overlap`,
    /// `r-star`, `r-star-srfc`) split overflowing nodes by Beckmann's rule with his ties
    /// (section 5.1: "we thus relied on the original approach"): least overlap, then least
    /// volume sum, then the first distribution. The `…-surface-ties` and
    /// `min-overlap-enlargement` variants are ours (the rules used earlier): they also
    /// break the split's remaining ties by least surface sum.
    #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
    pub enum Strategy {
        /// `min-volume`: the paper's minVolume, "minimize the volume enlargement of nodes,
        /// regardless of their level. This is the same strategy employed by the original
        /// R-tree (Guttman, 1984)" (section 5.1): least volume enlargement, ties by least
        /// volume ("Ties are resolved by selecting the node of least area", section 2.2.1),
        /// then the first entry. Surface never decides, not even between flat (zero-volume)
        /// boxes, the case where section 5.1 says minVolume fails.
        MinVolume = "min-volume",
        /// `min-volume-surface-ties`: ours, not the paper's: `min-volume` whose remaining ties
        /// (flat boxes: all volumes zero) go to least surface enlargement, then least surface;
        /// split ties by surface too.
        MinVolumeSurfaceTies = "min-volume-surface-ties",
        /// `min-surface`: least surface enlargement at every level (the SAH's measure), ties
        /// by least surface, then least volume enlargement.
        MinSurface = "min-surface",
        /// `min-overlap`: the paper's minOverlap, "minimize the mutual overlap of nodes,
        /// resolve ties by selecting the node that needs least volume enlargement" (section
        /// 5.1), read as section 2.2.1 words the overlap rule: the entry "whose box will
        /// overlap least with those of its siblings afterwards", i.e. least summed overlap
        /// volume of the entry's box *after* including the new box with its siblings' boxes,
        /// ties by least volume enlargement, then the first entry; at every level. It
        /// "assigns entries to nodes regardless of dead space" (section 5.1). The paper's
        /// configs (`configs/rtree*.toml`, `claims/feldmann-rtrees.toml`) use this reading.
        MinOverlap = "min-overlap",
        /// `min-overlap-enlargement`: the other reading of "minimize the mutual overlap", and
        /// our earlier rule: least overlap *enlargement* at every level (Beckmann et
        /// al. 1990's leaf rule applied everywhere), ties by least volume enlargement, least
        /// volume, least surface enlargement; split ties by surface too.
        MinOverlapEnlargement = "min-overlap-enlargement",
        /// `r-star`: R*-tree (Beckmann et al. 1990; paper sections 2.2.1 and 5.1): least volume
        /// enlargement at intermediate levels, ties by least volume; least overlap enlargement
        /// where the entries are leaves, ties by least volume enlargement, then least volume;
        /// then the first entry. Surface never decides.
        RStar = "r-star",
        /// `r-star-surface-ties`: ours, not the paper's: `r-star` whose remaining ties (flat
        /// boxes) go to least surface enlargement, then least surface; split ties by surface
        /// too (our earlier `r-star`).
        RStarSurfaceTies = "r-star-surface-ties",
        /// `r-star-srfc`: the paper's R*-treeSrfc: least surface enlargement at intermediate
        /// levels (ties by least surface, then least volume enlargement), the R*-tree's rule
        /// where the entries are leaves (best in Table 1).
        RStarSrfc = "r-star-srfc",
        /// `r-star-overlap-after`: the other reading of the R*-tree's leaf rule in the paper's
        /// words: "data are assigned to the node whose box will overlap least with those of
        /// its siblings afterwards; ties are resolved by using the node that requires least
        /// area enlargement" (section 2.2.1), and "composed of minOverlap and minVolume"
        /// (section 5.1): where the entries are leaves, `min-overlap`'s key (least summed
        /// overlap after insertion, ties by least volume enlargement); elsewhere `r-star`'s.
        /// `r-star` keeps Beckmann et al. 1990's overlap *enlargement*, the rule of the R*-tree
        /// the paper cites; the paper's configs use `r-star`.
        RStarOverlapAfter = "r-star-overlap-after",
        /// `r-star-srfc-overlap-after`: `r-star-srfc` with the leaf rule of
        /// `r-star-overlap-after` (the same reading of section 2.2.1); the paper's configs use
        /// `r-star-srfc`.
        RStarSrfcOverlapAfter = "r-star-srfc-overlap-after",
        /// `str`: no insertion; Sort-Tile-Recursive bulk loading (Leutenegger, Lopez and
        /// Edgington 1997), the bulk loading the paper's conclusion suggests (section 6).
        /// Nodes are full (`M` entries) but for the last of each level; `reinsert` is ignored.
        Str = "str",
    }
}

impl Strategy {
    /// Whether the R* split breaks its remaining ties by least surface sum (our variants)
    /// rather than taking the first distribution (Beckmann et al. 1990, the paper's).
    pub fn split_surface_ties(self) -> bool {
        matches!(
            self,
            Strategy::MinVolumeSurfaceTies
                | Strategy::MinOverlapEnlargement
                | Strategy::RStarSurfaceTies
        )
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
        /// share p/M of the entries a forced reinsertion ejects, p = clamp(round(share M), 1,
        /// M + 1 - m) of the M + 1 (Beckmann et al. 1990: 30 %, their best; Feldmann section
        /// 2.2.1 leaves k open, "depending on choice"); at M = 4, m = 2: 0.3 ejects 1, 0.5
        /// ejects 2, 0.75 ejects 3, the most that leaves m (configs/rtree-reinsert.toml)
        reinsert_share: f32 = 0.3, ParamKind::Float { min: 0.01, max: 0.75 };
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
