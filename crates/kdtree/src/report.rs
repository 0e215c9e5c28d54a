//! The build report of a [`KdTree`] (`Structure::report`): its cost figure and extra columns.

use crate::{KdTree, BACKTRACK_AUX, ROPES_AUX};
use tb_core::{BuildReport, Structure};

impl KdTree {
    /// `sah_cost = (C_trav·Σ_interior A(n) + C_isect·Σ_leaves A(l)·|l|) / A(root)` with `A` the
    /// surface area of the cells (`None` for an empty tree or a root of zero area); extra
    /// figures: `nodes`, `slots` (entries of the node array: `nodes` depth-first, more in the
    /// treelet layout, whose unused slots count in the memory), `leaves`, `empty_leaves`,
    /// `references`, `depth_max` (root 0), `leaf_depth_mean`, `refs_per_leaf_mean` (over
    /// non-empty leaves), `leaf_size_max`, and the bytes of the auxiliary arrays, built or not:
    /// `backtrack_aux_bytes` (cell and parent per node, read by `backtrack`) and
    /// `ropes_aux_bytes` (cell and six ropes per leaf and the leaves' rank, read by `ropes`).
    pub(crate) fn report_figures(&self) -> BuildReport {
        let (mut interior, mut leaves, mut empty) = (0u64, 0u64, 0u64);
        let (mut depth_max, mut depth_sum, mut leaf_max) = (0u32, 0u64, 0u32);
        let (mut ia, mut la) = (0f64, 0f64);
        let v = self.view();
        v.walk(v.root(), |i, cell, d| {
            let n = self.nodes[i];
            let a = cell.area() as f64;
            depth_max = depth_max.max(d);
            if n.is_leaf() {
                leaves += 1;
                empty += (n.count() == 0) as u64;
                depth_sum += d as u64;
                leaf_max = leaf_max.max(n.count());
                la += a * n.count() as f64;
            } else {
                interior += 1;
                ia += a;
            }
        });
        let root = self.bounds.area() as f64;
        let sah = (self.params.sah.c_trav as f64 * ia + self.params.sah.c_isect as f64 * la) / root;
        BuildReport {
            sah_cost: (!self.nodes.is_empty() && root > 0.0 && sah.is_finite()).then_some(sah),
            extra: vec![
                ("nodes".into(), (interior + leaves) as f64),
                ("slots".into(), self.nodes.len() as f64),
                ("leaves".into(), leaves as f64),
                ("empty_leaves".into(), empty as f64),
                ("references".into(), self.prim_refs.len() as f64),
                ("depth_max".into(), depth_max as f64),
                (
                    "leaf_depth_mean".into(),
                    depth_sum as f64 / leaves.max(1) as f64,
                ),
                (
                    "refs_per_leaf_mean".into(),
                    self.prim_refs.len() as f64 / (leaves - empty).max(1) as f64,
                ),
                ("leaf_size_max".into(), leaf_max as f64),
                (
                    "backtrack_aux_bytes".into(),
                    self.aux_bytes(BACKTRACK_AUX) as f64,
                ),
                ("ropes_aux_bytes".into(), self.aux_bytes(ROPES_AUX) as f64),
            ]
            .into_iter()
            // Only where the bound acted, so a row says when it did.
            .chain(
                (self.budget_leaves > 0)
                    .then(|| ("ref_budget_leaves".into(), self.budget_leaves as f64)),
            )
            .collect(),
        }
    }
}
