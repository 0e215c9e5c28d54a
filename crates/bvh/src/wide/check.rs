//! The wide tree checked against the binary one it was collapsed from (`validate`).

use super::*;

/// Check the wide tree against the binary one it was collapsed from: every node reachable
/// once, children after parents, child boxes inside the parent's slot box, used slots first,
/// each triangle slot in exactly one leaf (a leaf is a range of slots), each leaf's
/// blocks its triangles and primitive ids in order (each block in exactly one leaf), the
/// depth within the stack.
pub(crate) fn check<const N: usize>(
    nodes: &[WideNode<N>],
    leaves: (&[LeafBlock], &[u32]),
    tris: &[Triangle],
    prim_ids: &[u32],
    root: &Aabb,
) -> Result<(), String> {
    let (blocks, block_first) = leaves;
    let n_tris = tris.len();
    if blocks.len() != block_first.len() {
        return Err("leaf blocks and their first slots differ in number".into());
    }
    let mut block_used = vec![false; blocks.len()];
    if nodes.is_empty() {
        return if n_tris == 0 {
            Ok(())
        } else {
            Err("no wide nodes for a non-empty scene".into())
        };
    }
    let mut visited = vec![false; nodes.len()];
    let mut owned = vec![false; n_tris];
    let mut stack = vec![(0usize, *root, 0usize)];
    while let Some((i, b, depth)) = stack.pop() {
        if std::mem::replace(&mut visited[i], true) {
            return Err(format!("wide node {i} reached twice"));
        }
        if depth * (N - 1) + 1 > WIDE_STACK_SIZE {
            return Err(format!("wide node {i} at depth {depth} exceeds the stack"));
        }
        let n = &nodes[i];
        let used = n.children();
        if used == 0 || n.count[used..].iter().any(|&c| c != EMPTY_SLOT) {
            return Err(format!("wide node {i}: used slots must come first (≥ 1)"));
        }
        for s in 0..used {
            let cb = n.child_bounds(s);
            if !b.contains_box(&cb) {
                return Err(format!("wide node {i} slot {s} outside its parent box"));
            }
            let (child, count) = (n.child[s] as usize, n.count[s] as usize);
            if count == 0 {
                if child <= i || child >= nodes.len() {
                    return Err(format!("wide node {i} slot {s}: child {child} invalid"));
                }
                stack.push((child, cb, depth + 1));
            } else {
                let nb = count.div_ceil(4);
                if child + nb > blocks.len() {
                    return Err(format!("wide node {i} slot {s}: leaf blocks out of range"));
                }
                let first = block_first[child] as usize;
                if first + count > n_tris {
                    return Err(format!("wide node {i} slot {s}: leaf out of range"));
                }
                for j in 0..nb {
                    if std::mem::replace(&mut block_used[child + j], true) {
                        return Err(format!("leaf block {} in two wide leaves", child + j));
                    }
                    let (k, e) = (first + 4 * j, (first + 4 * j + 4).min(first + count));
                    let b = &blocks[child + j];
                    let prims_ok = b.prim[..e - k] == prim_ids[k..e]
                        && b.prim[e - k..].iter().all(|&p| p == u32::MAX);
                    if block_first[child + j] as usize != k
                        || b.tris != Tri4::new(&tris[k..e])
                        || !prims_ok
                    {
                        return Err(format!(
                            "wide node {i} slot {s}: leaf block {} differs from triangle slots \
                             {k}..{e}",
                            child + j
                        ));
                    }
                }
                let child = first;
                for k in child..child + count {
                    if std::mem::replace(&mut owned[k], true) {
                        return Err(format!("triangle slot {k} in two wide leaves"));
                    }
                }
            }
        }
    }
    if let Some(i) = visited.iter().position(|v| !v) {
        return Err(format!("wide node {i} is unreachable"));
    }
    if let Some(k) = owned.iter().position(|v| !v) {
        return Err(format!("triangle slot {k} is in no wide leaf"));
    }
    if let Some(b) = block_used.iter().position(|v| !v) {
        return Err(format!("leaf block {b} is in no wide leaf"));
    }
    Ok(())
}
