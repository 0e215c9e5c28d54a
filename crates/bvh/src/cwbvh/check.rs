//! The compressed wide BVH's invariants (`validate`) and build figures.

use super::{Cwbvh, CW_STACK_SIZE, MAX_LEAF};
use crate::Builder;
use tb_core::{Aabb, BuildReport, Vec3};

/// Figures of one walk over the tree.
#[derive(Default)]
struct Figures {
    nodes: u64,
    used_slots: u64,
    leaves: u64,
    depth_max: u32,
}

impl Cwbvh {
    /// Check the tree (see `Structure::check` of [`Cwbvh`]).
    pub(crate) fn check_invariants(&self) -> Result<(), String> {
        if self.nodes.is_empty() {
            return if self.triangles.is_empty() && self.n_scene == 0 {
                Ok(())
            } else {
                Err(format!("no nodes for {} triangles", self.n_scene))
            };
        }
        if self.prim_ids.len() != self.triangles.len() {
            return Err(format!(
                "{} primitive ids for {} triangle slots",
                self.prim_ids.len(),
                self.triangles.len()
            ));
        }
        let mut seen = vec![false; self.nodes.len()];
        let mut covered = vec![false; self.triangles.len()];
        seen[0] = true;
        self.subtree(0, 1, &mut seen, &mut covered)?;
        if let Some(i) = seen.iter().position(|s| !s) {
            return Err(format!("node {i} unreachable"));
        }
        if let Some(i) = covered.iter().position(|s| !s) {
            return Err(format!("triangle slot {i} in no leaf"));
        }
        let mut referenced = vec![false; self.n_scene];
        for (i, &id) in self.prim_ids.iter().enumerate() {
            match referenced.get_mut(id as usize) {
                Some(r) => *r = true,
                None => return Err(format!("prim_ids[{i}] = {id} out of range")),
            }
        }
        if let Some(i) = referenced.iter().position(|r| !r) {
            return Err(format!("scene triangle {i} in no leaf"));
        }
        Ok(())
    }

    /// Check node `i` at depth `depth` (root 1) and its subtree; returns the union of its
    /// triangles' boxes.
    fn subtree(
        &self,
        i: usize,
        depth: usize,
        seen: &mut [bool],
        covered: &mut [bool],
    ) -> Result<Aabb, String> {
        if depth > CW_STACK_SIZE {
            return Err(format!("node {i} deeper than the stack ({CW_STACK_SIZE})"));
        }
        let n = &self.nodes[i];
        let mut all = Aabb::EMPTY;
        for s in 0..8 {
            let m = n.meta[s];
            let (lo, hi) = n.child_box(s);
            let decoded = Aabb::new(Vec3::from_array(lo), Vec3::from_array(hi));
            let inside = if m == 0 {
                if n.is_interior(s) {
                    return Err(format!("node {i}: empty slot {s} marked interior"));
                }
                continue;
            } else if n.is_interior(s) {
                if m as usize != (1 << 5) | (24 + s) {
                    return Err(format!("node {i}: interior slot {s} with meta {m:#010b}"));
                }
                let c = n.child(s) as usize;
                if c <= i || c >= self.nodes.len() {
                    return Err(format!("node {i}: child {c} out of order or range"));
                }
                if std::mem::replace(&mut seen[c], true) {
                    return Err(format!("node {c} reached twice"));
                }
                self.subtree(c, depth + 1, seen, covered)?
            } else {
                let (offset, count) = n.leaf(s);
                // `count` is the number of ones in the top three bits: they must be unary.
                if !(1..=MAX_LEAF).contains(&count)
                    || (m as u32 >> 5) != (1 << count) - 1
                    || offset + count > 24
                {
                    return Err(format!("node {i}: leaf slot {s} with meta {m:#010b}"));
                }
                let first = (n.tri_base + offset) as usize;
                let Some(slots) = covered.get_mut(first..first + count as usize) else {
                    return Err(format!("node {i}: leaf slot {s} past the triangles"));
                };
                let mut b = Aabb::EMPTY;
                for (k, c) in slots.iter_mut().enumerate() {
                    if std::mem::replace(c, true) {
                        return Err(format!("triangle slot {} in two leaves", first + k));
                    }
                    b = b.union(&self.triangles[first + k].bounds());
                }
                b
            };
            // The SBVH's leaf boxes hold the parts of their triangles clipped to them: a
            // triangle must then touch its box (the quantization itself is checked at build
            // time, each decoded box against the builder's).
            let clipped = self.params.builder == Builder::Sbvh;
            let ok = if clipped {
                inside.is_empty()
                    || (decoded.min.cmple(inside.max).all() && inside.min.cmple(decoded.max).all())
            } else {
                decoded.contains_box(&inside)
            };
            if !ok {
                return Err(format!(
                    "node {i}: slot {s}'s decoded box {decoded:?} does not contain its \
                     triangles {inside:?}"
                ));
            }
            all = all.union(&inside);
        }
        Ok(all)
    }

    fn figures(&self) -> Figures {
        let mut f = Figures::default();
        let mut stack = vec![(0usize, 1u32)];
        if self.nodes.is_empty() {
            return f;
        }
        while let Some((i, d)) = stack.pop() {
            let n = &self.nodes[i];
            f.nodes += 1;
            f.depth_max = f.depth_max.max(d);
            for s in 0..8 {
                if n.meta[s] == 0 {
                    continue;
                }
                f.used_slots += 1;
                if n.is_interior(s) {
                    stack.push((n.child(s) as usize, d + 1));
                } else {
                    f.leaves += 1;
                }
            }
        }
        f
    }

    /// `sah_cost`: the wide tree's SAH cost under the build's cost model (`C_node` per node,
    /// `C_prim` per triangle, the boxes before quantization; what the collapse minimises);
    /// extra figures `nodes` (wide nodes), `leaves` (leaf slots), `wide_fill` (mean used
    /// slots a node), `depth_max` (root 1), `prims_per_leaf_mean`, `binary_nodes` (the tree
    /// collapsed from), `bytes_per_triangle` (nodes and references a scene triangle).
    pub(crate) fn report_figures(&self) -> BuildReport {
        let f = self.figures();
        let structure = tb_core::Structure::own_memory(self).structure_bytes;
        BuildReport {
            sah_cost: self.sah,
            extra: vec![
                ("nodes".into(), f.nodes as f64),
                ("leaves".into(), f.leaves as f64),
                (
                    "wide_fill".into(),
                    f.used_slots as f64 / f.nodes.max(1) as f64,
                ),
                ("depth_max".into(), f.depth_max as f64),
                (
                    "prims_per_leaf_mean".into(),
                    self.triangles.len() as f64 / f.leaves.max(1) as f64,
                ),
                ("binary_nodes".into(), self.binary_nodes as f64),
                (
                    "bytes_per_triangle".into(),
                    structure as f64 / self.n_scene.max(1) as f64,
                ),
            ],
        }
    }
}
