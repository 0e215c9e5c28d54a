//! The invariants of [`SparseBoxes`] (`Structure::check`): one record per augmented node,
//! in node order, each with its node's cell and depth and a parent link to the record above.

use crate::SparseBoxes;

impl SparseBoxes {
    /// Checks: record 0 the root, one depth per record, a record for exactly the root and the
    /// interior nodes at depths that are multiples of the period, each holding its node's
    /// cell and depth, and each parent link naming an earlier record one period up whose cell
    /// holds it.
    pub(crate) fn check_invariants(&self) -> Result<(), String> {
        let v = self.kd.view();
        let nodes = v.nodes();
        if nodes.is_empty() {
            return if self.aug.is_empty() {
                Ok(())
            } else {
                Err("augmented nodes without a tree".into())
            };
        }
        if self.aug.first().map(|a| a.node) != Some(0) {
            return Err("record 0 is not the root".into());
        }
        if self.aug.len() != self.depth.len() {
            return Err("one depth per record".into());
        }
        let period = self.params.period();
        let mut expect = Vec::new();
        v.walk(v.root(), |i, cell, d| {
            let n = nodes[i];
            if i == 0 || (!n.is_leaf() && d % period == 0) {
                expect.push((i as u32, *cell, d));
            }
        });
        if expect.len() != self.aug.len() {
            return Err(format!(
                "{} records for {} augmented nodes",
                self.aug.len(),
                expect.len()
            ));
        }
        for (k, ((node, cell, d), a)) in expect.iter().zip(self.aug.iter()).enumerate() {
            if a.node != *node || a.cell() != *cell || self.depth[k] as u32 != *d {
                return Err(format!("record {k} does not match node {node}"));
            }
            if k > 0 {
                let p = a.parent as usize;
                if p >= k
                    || self.depth[p] as u32 + period != *d
                    || !self.aug[p].cell().contains_box(cell)
                {
                    return Err(format!("record {k}: parent link {p} is not its ancestor"));
                }
            }
        }
        Ok(())
    }
}
