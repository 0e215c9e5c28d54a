// R-tree `ordered` (Feldmann 2015 section 4.2, Listing 2), program `rtree/ordered-mM`: one
// stack of at most M entries per level l >= 1, all in one array (level l's at (l - 1) * M,
// STACK_SIZE = M times the most levels tb_rtree builds for this M, less one), with its
// stack pointer sp[l]. At an intermediate node of level l the boxes of its entries are tested
// and those hit are inserted into stack l with their entry distance by insertion sort
// (decreasing from bottom to top: the nearest on top). The walk continues with the top of the
// lowest non-empty stack, climbing a level when a stack runs empty, and ends when the root
// level's stack is empty. Entries are culled against the closest hit only when pushed, as in
// Listing 2; with POP_CULL (program `rtree/ordered-pop-cull-mM`, tb_rtree's
// `ordered-pop-cull`) an entry popped farther than the closest hit found meanwhile also empties
// its whole stack (the rest lies farther still). The same walk as tb_rtree's CPU `Ordered`,
// node for node, so the counters agree ray for ray: boxes (the root's, then one per entry of
// every intermediate node visited), interior, leaves, prims, steps = interior + leaves.

const MAX_LEVELS: u32 = 17u;   // tb_rtree::MAX_LEVELS

override POP_CULL: bool = false;   // `ordered-pop-cull` (GpuProgram::constants)

fn walk(r: Ray, st: ptr<function, Stats>) -> Hit {
    let rb = ray_box(r);
    if !enter_root(r, rb, st) {
        return miss();
    }
    let top = meta_.counts.w;
    var best = no_best(r);
    let p = prepare(r);
    // Entries (slot, bits of the entry distance).
    var stack: array<vec2<u32>, STACK_SIZE>;
    var sp: array<u32, MAX_LEVELS + 1u>;
    var n = 0u;
    var l = top;
    loop {
        let node = nodes[n];
        if l > 0u {
            (*st).interior += 1u;
            let base = (l - 1u) * M;
            let first = n * M + 1u;
            var k = 0u;
            for (var i = 0u; i < node.count; i++) {
                (*st).boxes += 1u;
                let c = nodes[first + i];
                let s = slab(rb, c.bmin, c.bmax, r.tmin, best.t);
                if s.x <= s.y {
                    // Insertion sort: decreasing distance from bottom to top.
                    var j = k;
                    loop {
                        if j == 0u {
                            break;
                        }
                        let below = stack[base + j - 1u];
                        if bitcast<f32>(below.y) >= s.x {
                            break;
                        }
                        stack[base + j] = below;
                        j -= 1u;
                    }
                    stack[base + j] = vec2<u32>(first + i, bitcast<u32>(s.x));
                    k += 1u;
                }
            }
            sp[l] = k;
        } else if leaf_range(node.index, node.count, p, r, &best, st) {
            return record(best);
        }
        // The next node: top of the lowest non-empty stack (Listing 2, lines 27-34).
        var done = false;
        loop {
            while l <= top && sp[l] == 0u {
                l += 1u;
            }
            if l > top {
                done = true;
                break;
            }
            sp[l] -= 1u;
            let e = stack[(l - 1u) * M + sp[l]];
            if !POP_CULL || ANY || bitcast<f32>(e.y) <= best.t * EXIT_SCALE {
                n = e.x;
                l -= 1u;
                (*st).steps += 1u;
                break;
            }
            sp[l] = 0u;
        }
        if done {
            break;
        }
    }
    return record(best);
}
