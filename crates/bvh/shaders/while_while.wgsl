// The BVH `while-while` traversal (tb_bvh, module while_while; Aila and Laine 2009, the
// while-while trace kernel; Aila, Laine and Karras 2012), program `bvh/while-while` on tb-gpu's
// prelude (tb_core::gpu), traced with persistent threads (tb_core::GpuProgram::persistent,
// shaders/persistent.wgsl of tb-gpu). Per ray an outer loop of two inner loops: interior nodes
// (both children's boxes tested against [tmin, closest t], the nearer child hit first, the
// other's index pushed, a pop when neither is hit) until a leaf, then the leaf's triangles.
// No root box test, node indices only on the stack, no cull on pop. It visits the nodes in
// exactly the CPU's order, so the counters agree ray for ray: 2 boxes, interior and steps per
// interior node; leaves and steps per leaf; prims.

// tb_bvh::BvhNode, 32 bytes, read as two 16-byte loads: interior (count == 0): index = left
// child, right = index + 1 (the sibling pair is the authors' 64-byte node of two child boxes);
// leaf: triangles index .. index + count of the leaf-ordered triangle array (the prelude's
// `tris`). The node count is `meta_.counts.y` (GpuProgram::meta[0]).
struct Node { bmin: vec3<f32>, index: u32, bmax: vec3<f32>, count: u32 }

@group(0) @binding(5) var<storage, read> nodes: array<Node>;     // GpuProgram::buffers[0]
@group(0) @binding(6) var<storage, read> prim_ids: array<u32>;   // GpuProgram::buffers[1]

// Stack entry meaning "empty": no node has this index.
const EMPTY: u32 = 0xffffffffu;

// The program's entry, called by tb-gpu's `trace_ray` once per ray with zeroed counters.
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
    loop {
        // Interior nodes until a leaf (or the end of the walk: id == EMPTY).
        while node.count == 0u {
            (*st).interior += 1u;
            (*st).steps += 1u;
            (*st).boxes += 2u;
            let l = node.index;
            let a = nodes[l];
            let b = nodes[l + 1u];
            let sa = slab(rb, a.bmin, a.bmax, tmin, best.t);
            let sb = slab(rb, b.bmin, b.bmax, tmin, best.t);
            let hit_a = sa.x <= sa.y;
            let hit_b = sb.x <= sb.y;
            if hit_a && hit_b {
                if sb.x < sa.x {
                    stack[sp] = l;
                    node = b;
                } else {
                    stack[sp] = l + 1u;
                    node = a;
                }
                sp += 1u;
            } else if hit_a {
                node = a;
            } else if hit_b {
                node = b;
            } else {
                if sp == 0u {
                    id = EMPTY;
                    break;
                }
                sp -= 1u;
                node = nodes[stack[sp]];
            }
        }
        if id == EMPTY {
            break;
        }
        // The leaf's triangles.
        (*st).steps += 1u;
        if leaf_range(node.index, node.count, p, r, &best, st) {
            return record(best);
        }
        if sp == 0u {
            break;
        }
        sp -= 1u;
        node = nodes[stack[sp]];
    }
    return record(best);
}
