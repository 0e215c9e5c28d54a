//! The R-tree's invariants (checked after every build) and the figures of its build report.

use crate::*;

#[derive(Default)]
pub(crate) struct Figures {
    pub(crate) interior: u64,
    pub(crate) leaves: u64,
    pub(crate) empty: u64,
    pub(crate) interior_entries: u64,
    pub(crate) leaf_entries: u64,
    pub(crate) interior_area: f64,
    pub(crate) leaf_area_prims: f64,
}

impl Rtree {
    /// Check the tree: the triangle permutation, the complete `M`-ary slot layout, every
    /// non-empty slot's entry count and minimal box, every triangle slot in one leaf.
    pub(crate) fn check_invariants(&self) -> Result<(), String> {
        let n_tris = self.triangles.len();
        let nodes = &self.nodes;
        let big_m = self.params.big_m;
        let m = self.big_m();
        tb_core::accel::check_permutation(&self.prim_ids, n_tris).map_err(|e| e.to_string())?;
        if n_tris == 0 {
            return if nodes.is_empty() {
                Ok(())
            } else {
                Err("an empty R-tree must have no slots".into())
            };
        }
        let want = build::slot_count(big_m, self.root_level);
        if want != Some(nodes.len() as u32) {
            return Err(format!(
                "{} slots, a complete {big_m}-ary tree of {} levels has {want:?}",
                nodes.len(),
                self.root_level + 1
            ));
        }
        if self.first_leaf != build::first_leaf(big_m, self.root_level) {
            return Err("first leaf slot is not Δ_L(0)".into());
        }
        if nodes[0].is_empty() {
            return Err("the root of a non-empty tree is empty".into());
        }
        let same = |a: f32, b: f32| a == b || (a.is_nan() && b.is_nan());
        let same_box = |a: &Aabb, b: &Aabb| {
            (0..3).all(|k| same(a.min[k], b.min[k]) && same(a.max[k], b.max[k]))
        };
        let mut owned = vec![false; n_tris];
        for (i, n) in nodes.iter().enumerate() {
            let is_leaf = i as u32 >= self.first_leaf;
            let parent_empty = i > 0 && nodes[(i - 1) / m].is_empty();
            if n.is_empty() {
                if *n != RtreeNode::EMPTY {
                    return Err(format!("empty slot {i} is not the empty node"));
                }
                continue;
            }
            if parent_empty {
                return Err(format!("slot {i} is non-empty under an empty parent"));
            }
            if i > 0 {
                // Non-empty entries come first: the previous sibling is non-empty.
                if (i - 1) % m != 0 && nodes[i - 1].is_empty() {
                    return Err(format!("slot {i} follows an empty sibling"));
                }
            }
            let count = n.count as usize;
            let lo = if i == 0 {
                if is_leaf {
                    1
                } else {
                    2
                }
            } else {
                self.params.m as usize
            };
            if count < lo || count > m {
                return Err(format!(
                    "node {i} ({}) has {count} entries, outside {lo}..={m}",
                    if is_leaf { "leaf" } else { "intermediate" }
                ));
            }
            let bb = self.entries_box(i, count, &mut owned)?;
            if !same_box(&bb, &n.bounds()) {
                return Err(format!(
                    "node {i}: box {:?} is not the minimal box {bb:?} of its entries",
                    n.bounds()
                ));
            }
        }
        if let Some(k) = owned.iter().position(|v| !v) {
            return Err(format!("triangle slot {k} is in no leaf"));
        }
        Ok(())
    }

    /// The minimal box of the `count` entries of non-empty slot `i`: of its triangles for a
    /// leaf (each marked in `owned`, which must not have it yet), of its child slots (the first
    /// `count` used, the rest empty) for an intermediate node.
    fn entries_box(&self, i: usize, count: usize, owned: &mut [bool]) -> Result<Aabb, String> {
        let (nodes, n_tris, m) = (&self.nodes, self.triangles.len(), self.big_m());
        let n = &nodes[i];
        if i as u32 >= self.first_leaf {
            let r = n.index as usize..n.index as usize + count;
            if r.end > n_tris {
                return Err(format!("leaf {i}: triangles {r:?} out of range"));
            }
            let mut bb = Aabb::EMPTY;
            for k in r {
                if std::mem::replace(&mut owned[k], true) {
                    return Err(format!("triangle slot {k} in two leaves"));
                }
                bb = bb.union(&self.triangles[k].bounds());
            }
            Ok(bb)
        } else {
            let c = i * m + 1;
            let ch = &nodes[c..c + m];
            if let Some(k) = (0..count).find(|&k| ch[k].is_empty()) {
                return Err(format!("node {i}: entry {k} of {count} is empty"));
            }
            if let Some(k) = (count..m).find(|&k| !ch[k].is_empty()) {
                return Err(format!("node {i}: slot {k} beyond {count} entries is used"));
            }
            Ok(ch[..count]
                .iter()
                .fold(Aabb::EMPTY, |b, c| b.union(&c.bounds())))
        }
    }

    /// Tree figures over non-empty slots.
    pub(crate) fn figures(&self) -> Figures {
        let mut f = Figures::default();
        for (i, n) in self.nodes.iter().enumerate() {
            if n.is_empty() {
                f.empty += 1;
                continue;
            }
            let a = n.bounds().area() as f64;
            if i as u32 >= self.first_leaf {
                f.leaves += 1;
                f.leaf_entries += n.count as u64;
                f.leaf_area_prims += a * n.count as f64;
            } else {
                f.interior += 1;
                f.interior_entries += n.count as u64;
                f.interior_area += a;
            }
        }
        f
    }
}
