// R-tree `stackless` (Feldmann 2015 section 4.1, Listing 1), program `rtree/stackless-mM`:
// depth-first over the packed array by index arithmetic alone. At slot n: when its box is hit
// within [tmin, closest hit], an intermediate node continues with its first entry M*n + 1, a
// leaf tests its triangles; otherwise (or after the leaf) the walk moves to the next sibling
// n + 1, climbing to the parent (n - 1) / M while n is its parent's last entry or the next
// sibling is empty (non-empty entries come first), and ends on climbing back to the root.
// The same walk as tb_rtree's CPU `Stackless`, slot for slot, so the counters agree ray for
// ray: boxes (one per slot reached), steps (one per node entered: interior + leaves, as in
// the stack walks), interior, leaves, prims, restarts (climbs). No
// stack (STACK_SIZE = 0) and no step cap: the walk ends after at most every slot once.

fn walk(r: Ray, st: ptr<function, Stats>) -> Hit {
    if meta_.counts.y == 0u {
        return miss();
    }
    let first_leaf = meta_.counts.z;
    let rb = ray_box(r);
    let p = prepare(r);
    var best = no_best(r);
    var n = 0u;
    loop {
        (*st).boxes += 1u;
        let node = nodes[n];
        let s = slab(rb, node.bmin, node.bmax, r.tmin, best.t);
        if s.x <= s.y {
            (*st).steps += 1u;
            if n < first_leaf {
                (*st).interior += 1u;
                n = n * M + 1u;
                continue;
            }
            if leaf_range(node.index, node.count, p, r, &best, st) {
                return record(best);
            }
        }
        // Next sibling, climbing past last entries (Listing 1, lines 19-29).
        var done = false;
        loop {
            if n == 0u {
                done = true;
                break;
            }
            let parent = (n - 1u) / M;
            let last = n == parent * M + M;
            if !last && nodes[n + 1u].count != 0u {
                n += 1u;
                break;
            }
            (*st).restarts += 1u;
            n = parent;
        }
        if done {
            break;
        }
    }
    return record(best);
}
