// R-tree `stackless` (Feldmann 2015 section 4.1, Listing 1), program `rtree/stackless-mM`:
// depth-first over the packed array by index arithmetic alone. At slot n: when its box is hit
// within [tmin, closest hit], an intermediate node continues with its first entry M*n + 1, a
// leaf tests its triangles; an empty slot (count == 0, Listing 1's isEmptyNode) is passed
// without a box test. Otherwise (or after the leaf) the walk moves to the next sibling n + 1,
// climbing to the parent (n - 1) / M while n is its parent's last entry, and ends on climbing
// back to the root; so it visits the empty slots after a node's last entry, as Listing 1 does.
// With SKIP_EMPTY (program `rtree/stackless-skip-empty-mM`, tb_rtree's `stackless-skip-empty`)
// an empty next sibling ends the node's entries like the last entry does (non-empty entries
// come first). The same walk as tb_rtree's CPU `Stackless`, slot for slot, so the counters
// agree ray for ray: steps (one per slot visited, empty ones included), boxes (one per
// non-empty slot visited), interior, leaves, prims, restarts (climbs). No
// stack (STACK_SIZE = 0) and no step cap: the walk ends after at most every slot once.

override SKIP_EMPTY: bool = false;   // `stackless-skip-empty` (GpuProgram::constants)

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
        (*st).steps += 1u;
        let node = nodes[n];
        if SKIP_EMPTY || node.count != 0u {
            (*st).boxes += 1u;
            let s = slab(rb, node.bmin, node.bmax, r.tmin, best.t);
            if s.x <= s.y {
                if n < first_leaf {
                    (*st).interior += 1u;
                    n = n * M + 1u;
                    continue;
                }
                if leaf_range(node.index, node.count, p, r, &best, st) {
                    return record(best);
                }
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
            if !last && (!SKIP_EMPTY || nodes[n + 1u].count != 0u) {
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
