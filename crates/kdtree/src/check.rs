//! The invariants of kd-trees over one node array ([`check_trees`], for the kd-tree and the
//! multi-kd-tree) and the cell arithmetic they and the builders share.

use crate::KdParams;
use crate::{build, layout, KdLayout, KdView, STACK_SIZE};
use tb_core::Aabb;

/// The invariants of the trees rooted at `roots` in the node array of `v` (one for a kd-tree,
/// several for a multi-kd-tree): node and reference indices in range, children after their
/// parent and distinct, every node reached once from exactly one root (the treelet layout's
/// unused slots empty), depth within the limit, splits inside their cells, every referenced
/// triangle's box overlapping its leaf cell, every finite triangle referenced in every tree.
pub fn check_trees(v: &KdView, roots: &[u32], params: &KdParams) -> Result<(), String> {
    let nodes = v.nodes;
    let n_tris = v.tris.len();
    if nodes.is_empty() {
        return if v.refs.is_empty() {
            Ok(())
        } else {
            Err("references without nodes".into())
        };
    }
    if let Some(k) = v.refs.iter().position(|&r| r as usize >= n_tris) {
        return Err(format!("prim_refs[{k}] out of range ({n_tris} triangles)"));
    }
    let depth_limit = params.depth_limit(n_tris) as usize;
    let mut visited = vec![false; nodes.len()];
    for &root in roots {
        let mut referenced = vec![false; n_tris];
        let mut stack = vec![(root as usize, v.bounds, 0usize)];
        while let Some((i, cell, depth)) = stack.pop() {
            if i >= nodes.len() {
                return Err(format!("node index {i} out of range ({})", nodes.len()));
            }
            if std::mem::replace(&mut visited[i], true) {
                return Err(format!("node {i} reached twice (cycle or shared child)"));
            }
            if depth > depth_limit || depth > STACK_SIZE {
                return Err(format!("node {i} at depth {depth} exceeds the depth limit"));
            }
            let n = nodes[i];
            if n.is_leaf() {
                let (o, c) = (n.offset(), n.count() as usize);
                if o + c > v.refs.len() {
                    return Err(format!(
                        "leaf {i}: references {o}..{} out of range ({})",
                        o + c,
                        v.refs.len()
                    ));
                }
                for &r in &v.refs[o..o + c] {
                    referenced[r as usize] = true;
                    let tb = v.tris[r as usize].bounds();
                    let tol = build::tolerance(&tb);
                    let grown = Aabb::new(tb.min - tol, tb.max + tol);
                    if intersect(&grown, &cell).is_empty() {
                        return Err(format!(
                            "leaf {i}: triangle {r} does not overlap the leaf cell"
                        ));
                    }
                }
            } else {
                let ((l, r), s) = (v.children(i), n.split());
                let a = n.axis();
                // Children after their parent (so no cycles), distinct, in range.
                if l <= i || r <= l || r >= nodes.len() {
                    return Err(format!("node {i}: children {l}, {r} invalid"));
                }
                if !(s >= cell.min[a] && s <= cell.max[a]) {
                    return Err(format!("node {i}: split {s} outside its cell on axis {a}"));
                }
                let (lc, rc) = split_cell(&cell, a, s);
                stack.push((r, rc, depth + 1));
                stack.push((l, lc, depth + 1));
            }
        }
        for (k, t) in v.tris.iter().enumerate() {
            let finite = t.v0.is_finite() && t.v1.is_finite() && t.v2.is_finite();
            if finite && !referenced[k] {
                return Err(format!(
                    "triangle {k} is referenced by no leaf of the tree at {root}"
                ));
            }
        }
    }
    // Every node is reachable; the treelet layout's unused slots stay empty.
    let unused = |i: usize| v.layout == KdLayout::Treelet && nodes[i] == layout::EMPTY_SLOT;
    if let Some(i) = (0..nodes.len()).find(|&i| !visited[i] && !unused(i)) {
        return Err(format!("node {i} is unreachable from the root"));
    }
    Ok(())
}

/// The two children's cells of `cell` split on `axis` at `s`.
pub fn split_cell(cell: &Aabb, axis: usize, s: f32) -> (Aabb, Aabb) {
    let (mut l, mut r) = (*cell, *cell);
    l.max[axis] = s;
    r.min[axis] = s;
    (l, r)
}

/// Intersection of two boxes (empty when disjoint).
pub fn intersect(a: &Aabb, b: &Aabb) -> Aabb {
    Aabb {
        min: a.min.max(b.min),
        max: a.max.min(b.max),
    }
}
