//! The binary and wide BVHs' invariants (checked after every build; SBVH coverage) and the
//! figures of the build report.

use crate::*;

#[derive(Default)]
pub(crate) struct TreeFigures {
    pub(crate) interior: u64,
    pub(crate) leaves: u64,
    pub(crate) depth_max: u32,
    pub(crate) leaf_depth_sum: u64,
    pub(crate) max_leaf: u32,
    pub(crate) interior_area: f64,
    pub(crate) leaf_area_prims: f64,
}

impl Bvh {
    /// Walk the tree: call `f(node_index, depth)` for every node reachable from the root,
    /// depth-first (root depth 0). Assumes a valid tree (see [`Structure::check`]).
    pub(crate) fn walk(&self, mut f: impl FnMut(usize, u32)) {
        let nodes = self.nodes();
        if nodes.is_empty() {
            return;
        }
        let mut stack = vec![(0usize, 0u32)];
        while let Some((i, d)) = stack.pop() {
            f(i, d);
            let n = &nodes[i];
            if !n.is_leaf() {
                let l = n.index as usize;
                stack.push((l + 1, d + 1));
                stack.push((l, d + 1));
            }
        }
    }

    /// Tree figures: (interior count, leaf count, max depth, sum of leaf depths, max leaf size,
    /// Σ interior area, Σ leaf area × leaf price (`leaf_cost`)).
    pub(crate) fn figures(&self) -> TreeFigures {
        let mut t = TreeFigures::default();
        let nodes = self.nodes();
        self.walk(|i, d| {
            let n = &nodes[i];
            let a = n.bounds().area() as f64;
            t.depth_max = t.depth_max.max(d);
            if n.is_leaf() {
                t.leaves += 1;
                t.leaf_depth_sum += d as u64;
                t.max_leaf = t.max_leaf.max(n.count);
                t.leaf_area_prims += a * self.params.leaf_cost.units(n.count as usize) as f64;
            } else {
                t.interior += 1;
                t.interior_area += a;
            }
        });
        t
    }

    /// Check the tree: the triangle permutation, every node reached once, every slot in one
    /// leaf, children inside their parents, then SBVH coverage and the wide nodes.
    pub(crate) fn check_invariants(&self) -> Result<(), String> {
        let nodes = self.nodes();
        let n_tris = self.triangles.len();
        let sbvh = self.params.builder == Builder::Sbvh;
        if sbvh {
            if self.prim_ids.len() != n_tris {
                return Err(format!(
                    "{} prim_ids for {n_tris} slots",
                    self.prim_ids.len()
                ));
            }
        } else {
            tb_core::accel::check_permutation(&self.prim_ids, n_tris).map_err(|e| e.to_string())?;
        }
        if n_tris == 0 {
            return if nodes.is_empty() {
                Ok(())
            } else {
                Err("an empty BVH must have no nodes".into())
            };
        }
        if nodes.is_empty() {
            return Err("no nodes for a non-empty scene".into());
        }
        // Every node is reached exactly once (no cycles, no shared or orphan nodes), every
        // triangle slot is owned by exactly one leaf.
        let mut visited = vec![false; nodes.len()];
        let mut owned = vec![false; n_tris];
        let mut stack = vec![(0usize, 0u32)];
        while let Some((i, depth)) = stack.pop() {
            if std::mem::replace(&mut visited[i], true) {
                return Err(format!("node {i} reached twice (cycle or shared child)"));
            }
            if depth as usize > STACK_SIZE {
                return Err(format!(
                    "node {i} at depth {depth} exceeds the traversal stack ({STACK_SIZE})"
                ));
            }
            let n = &nodes[i];
            let b = n.bounds();
            if n.is_leaf() {
                self.check_leaf(i, &mut owned)?;
            } else {
                let l = n.index as usize;
                if l <= i || l + 1 >= nodes.len() {
                    return Err(format!(
                        "node {i}: children {l}, {} invalid ({} nodes; children follow parents)",
                        l + 1,
                        nodes.len()
                    ));
                }
                for c in [l, l + 1] {
                    if !b.contains_box(&nodes[c].bounds()) {
                        return Err(format!("node {c} not inside its parent {i}"));
                    }
                    stack.push((c, depth + 1));
                }
            }
        }
        if let Some(i) = visited.iter().position(|v| !v) {
            return Err(format!("node {i} is unreachable from the root"));
        }
        if let Some(k) = owned.iter().position(|v| !v) {
            return Err(format!("triangle slot {k} is in no leaf"));
        }
        if sbvh {
            self.check_coverage()?;
        }
        let root = nodes[0].bounds();
        let leaves = (self.blocks.as_slice(), self.block_first.as_slice());
        let ids = self.prim_ids.as_slice();
        match (&self.wide, self.params.width) {
            (WideNodes::None, 2) => Ok(()),
            (WideNodes::W4(w), 4) => wide::check(w, leaves, &self.triangles, ids, &root),
            (WideNodes::W8(w), 8) => wide::check(w, leaves, &self.triangles, ids, &root),
            _ => Err(format!(
                "wide nodes do not match width {}",
                self.params.width
            )),
        }
    }

    /// Check leaf `i`: its triangle slots in range and owned by no other leaf (marked in
    /// `owned`), inside its box (but in the SBVH, whose references are clipped), and no more
    /// than `max_leaf` of them unless their centroids coincide (no SBVH).
    fn check_leaf(&self, i: usize, owned: &mut [bool]) -> Result<(), String> {
        let n_tris = self.triangles.len();
        let sbvh = self.params.builder == Builder::Sbvh;
        let n = &self.nodes()[i];
        let b = n.bounds();
        let r = n.prim_range();
        if r.end > n_tris {
            return Err(format!("leaf {i}: triangles {r:?} out of range ({n_tris})"));
        }
        for k in r.clone() {
            if std::mem::replace(&mut owned[k], true) {
                return Err(format!("triangle slot {k} in two leaves"));
            }
            if !sbvh && !b.contains_box(&self.triangles[k].bounds()) {
                return Err(format!("leaf {i}: triangle slot {k} outside the leaf box"));
            }
        }
        if n.count > self.params.max_leaf && !sbvh {
            let c0 = self.triangles[r.start].bounds().center();
            if r.clone().any(|k| self.triangles[k].bounds().center() != c0) {
                return Err(format!(
                    "leaf {i} holds {} > max_leaf = {} triangles whose centroids differ",
                    n.count, self.params.max_leaf
                ));
            }
        }
        Ok(())
    }

    /// SBVH coverage: every scene triangle is referenced, all its copies are equal, and every
    /// point of a barycentric grid on it (vertices, edges and interior, 8 steps per edge) lies
    /// in the box of a leaf referencing it (leaf boxes lie inside their ancestors', checked
    /// separately, so the point is reachable from the root).
    pub(crate) fn check_coverage(&self) -> Result<(), String> {
        const STEPS: u32 = 8;
        let mut by_id: Vec<(u32, Aabb, usize)> = Vec::with_capacity(self.prim_ids.len());
        for n in self.nodes.iter().filter(|n| n.is_leaf()) {
            for k in n.prim_range() {
                by_id.push((self.prim_ids[k], n.bounds(), k));
            }
        }
        by_id.sort_unstable_by_key(|e| e.0);
        if by_id.len() != self.prim_ids.len() {
            return Err("triangle slots and leaf references differ".into());
        }
        let n_scene = self.n_scene;
        let mut i = 0;
        for id in 0..n_scene as u32 {
            let j = i + by_id[i..].iter().take_while(|e| e.0 == id).count();
            let refs = &by_id[i..j];
            i = j;
            let Some(first) = refs.first() else {
                return Err(format!("triangle {id} is in no leaf"));
            };
            let t = self.triangles[first.2];
            if refs.iter().any(|e| self.triangles[e.2] != t) {
                return Err(format!("copies of triangle {id} differ"));
            }
            for a in 0..=STEPS {
                for b in 0..=STEPS - a {
                    let (u, v) = (a as f32 / STEPS as f32, b as f32 / STEPS as f32);
                    let p = t.v0 * (1.0 - u - v) + t.v1 * u + t.v2 * v;
                    // The sample is clamped to the triangle's box (rounding of the weights).
                    let tb = t.bounds();
                    let p = p.clamp(tb.min, tb.max);
                    if !refs.iter().any(|e| e.1.contains_box(&Aabb::new(p, p))) {
                        return Err(format!(
                            "triangle {id}: point {p} (u = {u}, v = {v}) is in no leaf box \
                             referencing it"
                        ));
                    }
                }
            }
        }
        if i != by_id.len() {
            return Err(format!(
                "leaf references triangle {} of {n_scene}",
                by_id[i].0
            ));
        }
        Ok(())
    }

    /// `wide_nodes`, `wide_fill` and `wide_sah_cost` of a wide build (none for `width = 2`).
    pub(crate) fn wide_figures(&self) -> Vec<(String, f64)> {
        let cm = wide::CostModel::of(&self.params);
        let root = self.nodes.first().map_or(Aabb::EMPTY, |n| n.bounds());
        let figs = |used: usize, n: usize, sah: Option<f64>| {
            let mut v = vec![
                ("wide_nodes".to_string(), n as f64),
                ("wide_fill".to_string(), used as f64 / n.max(1) as f64),
            ];
            v.extend(sah.map(|c| ("wide_sah_cost".to_string(), c)));
            v
        };
        fn used<const N: usize>(w: &[WideNode<N>]) -> usize {
            w.iter().map(|n| n.children()).sum()
        }
        match &self.wide {
            WideNodes::None => Vec::new(),
            WideNodes::W4(w) => figs(used(w), w.len(), wide::sah(w, &root, &cm)),
            WideNodes::W8(w) => figs(used(w), w.len(), wide::sah(w, &root, &cm)),
        }
    }
}
