//! The build report of a [`MultiKdTree`] (`Structure::report`): its cost figure and extra columns.

use crate::MultiKdTree;
use tb_core::BuildReport;

impl MultiKdTree {
    /// `sah_cost`: the mean over the trees of each tree's cost under its own measure; extra:
    /// `trees`, `nodes` and `references` (all trees; the paper's Table 3 `Num.Nodes`,
    /// `Num.Ref.`), `leaves`, `slots` (node-array entries), `paper_bytes` (Table 3: 16 bytes a
    /// node, 4 a reference), `real_bytes` (8-byte nodes, references, header; triangles not
    /// counted, as in the paper), and per tree `nodes_X`, `refs_X`, `cost_X` and its weights
    /// `wX_X`, `wY_X`, `wZ_X` (X, Y or Z the patch).
    pub(crate) fn report_figures(&self) -> BuildReport {
        let nodes: u64 = self.trees.iter().map(|t| t.nodes).sum();
        let refs = self.refs.len() as u64;
        let mut extra = vec![
            ("trees".into(), self.trees.len() as f64),
            ("nodes".into(), nodes as f64),
            ("references".into(), refs as f64),
            (
                "leaves".into(),
                self.trees.iter().map(|t| t.leaves).sum::<u64>() as f64,
            ),
            ("slots".into(), self.nodes.len() as f64),
            ("paper_bytes".into(), (16 * nodes + 4 * refs) as f64),
            (
                "real_bytes".into(),
                (self.nodes.bytes() + 4 * refs as usize + 12) as f64,
            ),
        ];
        for t in &self.trees {
            let a = crate::measure::AXES[t.patch];
            extra.push((format!("nodes_{a}"), t.nodes as f64));
            extra.push((format!("refs_{a}"), t.refs as f64));
            extra.push((format!("cost_{a}"), t.cost));
            for (i, w) in t.weights.iter().enumerate() {
                extra.push((format!("w{}_{a}", crate::measure::AXES[i]), *w));
            }
        }
        if self.budget_leaves > 0 {
            extra.push(("ref_budget_leaves".into(), self.budget_leaves as f64));
        }
        let cost = self.trees.iter().map(|t| t.cost).sum::<f64>() / self.trees.len() as f64;
        BuildReport {
            sah_cost: (!self.nodes.is_empty() && cost.is_finite()).then_some(cost),
            extra,
        }
    }
}
