//! The build report of a [`Bvh`] (`Structure::report`): its cost figure and extra columns.

use crate::Bvh;
use tb_core::BuildReport;

impl Bvh {
    /// For `width` 4 or 8 the SAH cost is the binary tree's; extra figures `wide_nodes`,
    /// `wide_fill` (mean used slots per wide node) and `wide_sah_cost` (the wide tree's SAH
    /// cost, `C_trav` per wide node visited, the quantity the `sah` collapse minimises) are
    /// added.
    ///
    /// `sah_cost = (C_trav·Σ_interior A(n) + C_isect·Σ_leaves A(l)·c(|l|)) / A(root)` with `A`
    /// the surface area and `c` the leaf price of `leaf_cost` (`|l|`, or `⌈|l|/4⌉` for
    /// `blocks`) (`None` for an empty tree or a root of zero area); extra figures:
    /// `nodes`, `leaves`, `depth_max` (root depth 0), `leaf_depth_mean`, `prims_per_leaf_mean`,
    /// `leaf_size_max`; for the binary tree also `paper_bytes`, the tree as Aila and Laine's
    /// GPU framework stores it (its compact layout; the SBVH of Pérard-Gayot et al.'s Table 2):
    /// 64 bytes an interior node (both children's boxes and links), 48 bytes a reference (its
    /// Woop-transformed triangle, three `float4`) and 12 of triangle-index slots beside them,
    /// and 20 bytes a leaf (its sentinel `float4` and index slot). Table 2's SBVH figures
    /// (74-76 bytes a triangle) hold triangle data: nodes and 4-byte references alone
    /// (`structure_bytes`) come to about 30 bytes a triangle on the same scenes.
    pub(crate) fn report_figures(&self) -> BuildReport {
        let t = self.figures();
        let root_area = self
            .nodes()
            .first()
            .map_or(0.0, |n| n.bounds().area() as f64);
        let sah = (self.params.c_trav as f64 * t.interior_area
            + self.params.c_isect as f64 * t.leaf_area_prims)
            / root_area;
        let leaves = t.leaves.max(1) as f64;
        BuildReport {
            sah_cost: (root_area > 0.0 && sah.is_finite()).then_some(sah),
            extra: vec![
                ("nodes".into(), (t.interior + t.leaves) as f64),
                ("leaves".into(), t.leaves as f64),
                ("depth_max".into(), t.depth_max as f64),
                ("leaf_depth_mean".into(), t.leaf_depth_sum as f64 / leaves),
                (
                    "prims_per_leaf_mean".into(),
                    self.triangles.len() as f64 / leaves,
                ),
                ("leaf_size_max".into(), t.max_leaf as f64),
            ]
            .into_iter()
            .chain((self.params.width == 2).then(|| {
                let bytes = 64 * t.interior + 60 * self.prim_ids.len() as u64 + 20 * t.leaves;
                ("paper_bytes".into(), bytes as f64)
            }))
            .chain(self.wide_figures())
            // Only where the bound acted, so a row says when it did.
            .chain(
                (self.refused_splits > 0)
                    .then(|| ("ref_budget_splits".into(), self.refused_splits as f64)),
            )
            .collect(),
        }
    }
}
