//! The build report of a [`Rtree`] (`Structure::report`): its cost figure and extra columns.

use crate::Rtree;
use tb_core::BuildReport;

impl Rtree {
    /// `sah_cost = (Σ_intermediate A(n) + Σ_leaves A(l)·|l|) / A(root)` (`C_trav = C_isect =
    /// 1`, as the BVH's); extra figures: `levels` (`L + 1`), `slots` (all, empty included),
    /// `empty_slots`, `empty_share` (empty / all slots), `intermediate`, `leaves`,
    /// `fill_intermediate` and `fill_leaves` (mean entries per node), `splits`, `reinserts`
    /// (forced reinsertions during the build), `reinserted_entries` (the entries they
    /// ejected, `p` = [`RtreeParams::reinsert_count`] each), and the build's two parts in wall time,
    /// `insert_ms` (the pointer build: insertion, or STR's bulk load) and `pack_ms` (the
    /// level-order packing; Feldmann section 5 names them apart: the trees "are constructed
    /// on the CPU using pointers and are packed ... in a subsequent step"). `build_ms` times
    /// both (and is the median of `run.build_repeat` builds; these two are the last build's).
    pub(crate) fn report_figures(&self) -> BuildReport {
        let f = self.figures();
        let root_area = self.nodes.first().map_or(0.0, |n| n.bounds().area() as f64);
        let sah = (root_area > 0.0 && root_area.is_finite())
            .then(|| (f.interior_area + f.leaf_area_prims) / root_area);
        let slots = self.nodes.len() as f64;
        BuildReport {
            sah_cost: sah,
            extra: vec![
                ("levels".into(), (self.root_level + 1) as f64),
                ("slots".into(), slots),
                ("empty_slots".into(), f.empty as f64),
                ("empty_share".into(), f.empty as f64 / slots.max(1.0)),
                ("intermediate".into(), f.interior as f64),
                ("leaves".into(), f.leaves as f64),
                (
                    "fill_intermediate".into(),
                    f.interior_entries as f64 / (f.interior as f64).max(1.0),
                ),
                (
                    "fill_leaves".into(),
                    f.leaf_entries as f64 / (f.leaves as f64).max(1.0),
                ),
                ("splits".into(), self.splits as f64),
                ("reinserts".into(), self.reinserts as f64),
                ("reinserted_entries".into(), self.ejected as f64),
                ("insert_ms".into(), self.insert_ms),
                ("pack_ms".into(), self.pack_ms),
            ],
        }
    }
}
