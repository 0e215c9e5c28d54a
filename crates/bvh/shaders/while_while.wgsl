// The BVH `while-while` traversals (tb_bvh, module while_while; Aila and Laine 2009, the
// while-while trace kernel and speculative traversal; Aila, Laine and Karras 2012), programs
// `bvh/while-while` and `bvh/while-while-speculative` on tb-gpu's prelude (tb_core::gpu), traced
// with persistent threads (tb_core::GpuProgram::persistent, shaders/persistent.wgsl of tb-gpu).
// Per ray an outer loop of two inner loops: interior nodes (both children's boxes tested
// against [tmin, closest t], the nearer child hit first, the other's index pushed, a pop when
// neither is hit), then leaves' triangles. No root box test, node indices only on the stack,
// no cull on pop. `bvh/while-while` visits the nodes in exactly the CPU's order, so the
// counters agree ray for ray: 2 boxes, interior and steps per interior node; leaves and steps
// per leaf; prims. `bvh/while-while-speculative`'s depend on the ray's subgroup.

// The node, the bindings and `children`: binary.wgsl, included before this source.

// `id` when the walk is over; `leaf` when no leaf is postponed.
const DONE: u32 = 0xffffffffu;
const NONE: u32 = 0xffffffffu;

// The next node from the stack (its index; `*node` read), or DONE when the stack is empty.
fn pop(stack: ptr<function, array<u32, STACK_SIZE>>, sp: ptr<function, u32>, node: ptr<function, Node>) -> u32 {
    if *sp == 0u {
        return DONE;
    }
    *sp -= 1u;
    let id = (*stack)[*sp];
    *node = nodes[id];
    return id;
}

// The program's entry, called by tb-gpu's `trace_ray` once per ray with zeroed counters.
//
// Aila and Laine's kernel with its postponed leaf: the first leaf reached is set aside and the
// walk goes on through interior nodes until `all_lanes` says every active lane of the subgroup
// has a leaf set aside (speculative traversal), then the leaves are tested. `all_lanes` is
// the subgroup vote in `bvh/while-while-speculative` (subgroup.wgsl) and the lane's own
// value in `bvh/while-while` (solo.wgsl): a subgroup of one, which visits the nodes in the
// CPU walk's order.
fn walk(r: Ray, st: ptr<function, Stats>) -> Hit {
    if meta_.counts.y == 0u {
        return miss();
    }
    let rb = ray_box(r);
    let tmin = r.tmin;
    var best = no_best(r);
    let p = prepare(r);
    var stack: array<u32, STACK_SIZE>;
    var sp = 0u;
    var id = 0u;
    var node = nodes[0];
    var leaf = NONE;
    if node.count != 0u {
        // A root that is a leaf: tested at once.
        leaf = 0u;
        id = DONE;
    }
    loop {
        // Interior nodes, until every active lane has a leaf set aside.
        while id != DONE && node.count == 0u {
            let l = node.index;
            let c = children(node, rb, tmin, best.t, st);
            let hit_a = c.sa.x <= c.sa.y;
            let hit_b = c.sb.x <= c.sb.y;
            if hit_a && hit_b {
                if c.sb.x < c.sa.x {
                    stack[sp] = l;
                    id = l + 1u;
                    node = c.b;
                } else {
                    stack[sp] = l + 1u;
                    id = l;
                    node = c.a;
                }
                sp += 1u;
            } else if hit_a {
                id = l;
                node = c.a;
            } else if hit_b {
                id = l + 1u;
                node = c.b;
            } else {
                id = pop(&stack, &sp, &node);
            }
            // The first leaf reached is set aside; the walk goes on from the next node.
            if id != DONE && node.count != 0u && leaf == NONE {
                leaf = id;
                id = pop(&stack, &sp, &node);
            }
            if all_lanes(leaf != NONE) {
                break;
            }
        }
        // The leaf set aside, then every leaf the walk stands on.
        while leaf != NONE {
            let n = nodes[leaf];
            (*st).steps += 1u;
            if leaf_range(n.index, n.count, p, r, &best, st) {
                return record(best);
            }
            leaf = NONE;
            if id != DONE && node.count != 0u {
                leaf = id;
                id = pop(&stack, &sp, &node);
            }
        }
        if id == DONE {
            break;
        }
    }
    return record(best);
}
