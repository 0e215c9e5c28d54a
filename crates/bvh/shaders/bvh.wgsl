// The BVH `ordered` traversal (tb_bvh, pbrt-v3 §4.3.5), program `bvh/ordered` on tb-gpu's
// prelude (tb_core::gpu): depth-first with a fixed stack (STACK_SIZE = tb_bvh::STACK_SIZE), both
// children's boxes tested at their parent, the nearer child first, the farther pushed with its
// entry distance and skipped on pop when a closer hit was found meanwhile. One thread per ray
// (the reference kernel; Aila and Laine 2009's persistent threads: `while-while`). It visits the
// nodes in exactly the CPU's order, so the counters agree ray for ray: boxes (1 for the root,
// 2 per interior node), interior, leaves, prims, steps = interior + leaves.

// The node, the bindings and `children`: binary.wgsl, included before this source.

// The program's entry, called by the prelude's `trace_ray` once per ray with zeroed counters.
fn walk(r: Ray, st: ptr<function, Stats>) -> Hit {
    if meta_.counts.y == 0u {
        return miss();
    }
    let rb = ray_box(r);
    let tmin = r.tmin;
    var best = no_best(r);
    (*st).boxes += 1u;
    let root = nodes[0];
    let rs = slab(rb, root.bmin, root.bmax, tmin, best.t);
    if !(rs.x <= rs.y) {
        return miss();
    }
    let p = prepare(r);
    // Pending far children: (node index, bits of the entry distance).
    var stack: array<vec2<u32>, STACK_SIZE>;
    var sp = 0u;
    var node = root;
    loop {
        if node.count == 0u {
            let l = node.index;
            let c = children(node, rb, tmin, best.t, st);
            let hit_a = c.sa.x <= c.sa.y;
            let hit_b = c.sb.x <= c.sb.y;
            if hit_a {
                if hit_b {
                    if c.sa.x <= c.sb.x {
                        stack[sp] = vec2<u32>(l + 1u, bitcast<u32>(c.sb.x));
                        node = c.a;
                    } else {
                        stack[sp] = vec2<u32>(l, bitcast<u32>(c.sa.x));
                        node = c.b;
                    }
                    sp += 1u;
                } else {
                    node = c.a;
                }
                continue;
            } else if hit_b {
                node = c.b;
                continue;
            }
        } else {
            (*st).steps += 1u;
            if leaf_range(node.index, node.count, p, r, &best, st) {
                return record(best);
            }
        }
        // Pop the next pending subtree, skipping those entered beyond the closest hit.
        let next = pop_entered(&stack, &sp, best.t);
        if next == NO_ENTRY {
            break;
        }
        node = nodes[next];
    }
    return record(best);
}
