// R-tree `stack` (Feldmann 2015 section 5.2, Table 3's third column; the reference the paper
// ran on the CPU only), program `rtree/stack-mM`: conventional depth-first with one stack. At
// an intermediate node the boxes of its entries are tested and those hit pushed with their
// entry distance in reverse memory order (so they are visited in memory order, as by
// `stackless`); an entry popped after a hit closer than its entry distance was found is
// skipped. STACK_SIZE: at most M - 1 pending entries per level above the current node and M
// at its own, for the most levels tb_rtree builds for this M. The same walk as tb_rtree's CPU
// `Stack`, node for node, so the counters agree ray for ray: boxes, interior, leaves, prims,
// steps = interior + leaves.

fn walk(r: Ray, st: ptr<function, Stats>) -> Hit {
    let rb = ray_box(r);
    if !enter_root(r, rb, st) {
        return miss();
    }
    let first_leaf = meta_.counts.z;
    var best = no_best(r);
    let p = prepare(r);
    // Pending entries: (slot, bits of the entry distance).
    var stack: array<vec2<u32>, STACK_SIZE>;
    var sp = 0u;
    var n = 0u;
    loop {
        let node = nodes[n];
        if n < first_leaf {
            (*st).interior += 1u;
            let first = n * M + 1u;
            for (var i = node.count; i > 0u; i--) {
                let e = first + i - 1u;
                (*st).boxes += 1u;
                let c = nodes[e];
                let s = slab(rb, c.bmin, c.bmax, r.tmin, best.t);
                if s.x <= s.y {
                    stack[sp] = vec2<u32>(e, bitcast<u32>(s.x));
                    sp += 1u;
                }
            }
        } else if leaf_range(node.index, node.count, p, r, &best, st) {
            return record(best);
        }
        let next = pop_entered(&stack, &sp, best.t);
        if next == NO_ENTRY {
            break;
        }
        n = next;
        (*st).steps += 1u;
    }
    return record(best);
}
