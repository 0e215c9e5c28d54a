// Multi-kd-tree `recursive-direction` (tb_kdtree::multi; Torres et al. 2012 §5-6 on the kd-tree
// review's Alg. 2), program `multi-kd/recursive-direction` on tb-gpu's prelude (tb_core::gpu):
// each ray picks its tree by the paper's rule (header word 3: 0 SAH, 1 cube mapping, 2 spherical
// patches), starts at that tree's root (header words 0..2), clips itself to the root cell
// (words 5..10) and walks the stack traversal exactly as the CPU kernel (traverse.rs,
// `RecursiveDirection` and `decide`): near/far by the sign of the reciprocal direction, the far
// child pushed with its entry and exit distances when the plane distance lies in the interval
// (SLACK), pending entries skipped when they start beyond the closest hit. Counters as the CPU:
// boxes 1 (the root cell), interior/planes/steps per interior node, leaves/steps per leaf, prims
// per triangle test. One thread per ray.

// tb_kdtree::KdNode, 8 bytes: bits = link << 2 | axis (interior) or count << 2 | 3 (leaf);
// data = split (f32 bits) or the first reference. The node count is meta_.counts.y.
@group(0) @binding(5) var<storage, read> nodes: array<vec2<u32>>;   // GpuProgram::buffers[0]
@group(0) @binding(6) var<storage, read> refs: array<u32>;          // buffers[1]: references
// buffers[2]: roots X, Y, Z; the pick rule; the layout (0 depth-first, else the treelet
// block's slot mask); the root cell min xyz, max xyz (f32 bits).
@group(0) @binding(7) var<storage, read> header: array<u32, 12>;

// tb_kdtree::traverse::SLACK = 1 + 8·2^-23.
const SLACK: f32 = 1.00000095367431640625;

// measure::Heuristic::pick, operation for operation.
fn pick(d: vec3<f32>) -> u32 {
    let rule = header[3];
    let a = abs(d);
    if rule == 0u {
        return 0u;
    }
    if rule == 1u {
        if a.x >= a.y && a.x >= a.z {
            return 0u;
        } else if a.y >= a.z {
            return 1u;
        }
        return 2u;
    }
    let len2 = (d.x * d.x + d.y * d.y) + d.z * d.z;
    if (9.0 * d.z) * d.z >= 4.0 * len2 {
        return 2u;
    } else if a.x >= a.y {
        return 0u;
    }
    return 1u;
}

// Layout::children: depth-first (left next, right at the link) or treelet blocks.
fn children(i: u32, n: vec2<u32>) -> vec2<u32> {
    let mask = header[4];
    let link = n.x >> 2u;
    if mask == 0u {
        return vec2<u32>(i + 1u, link);
    }
    let k = i & mask;
    if 2u * k + 2u < mask {
        return vec2<u32>(i + k + 1u, i + k + 2u);
    }
    return vec2<u32>(link, link + mask + 1u);
}

fn walk(r: Ray, st: ptr<function, Stats>) -> Hit {
    (*st).boxes += 1u;
    if meta_.counts.y == 0u {
        return miss();
    }
    let rb = ray_box(r);
    let bmin = vec3<f32>(bitcast<f32>(header[5]), bitcast<f32>(header[6]), bitcast<f32>(header[7]));
    let bmax = vec3<f32>(bitcast<f32>(header[8]), bitcast<f32>(header[9]), bitcast<f32>(header[10]));
    // Aabb::intersect (the prelude's slab test, exit scaled by EXIT_SCALE as on the CPU).
    let s = slab(rb, bmin, bmax, r.tmin, r.tmax);
    if !(s.x <= s.y) {
        return miss();
    }
    let p = prepare(r);
    var best_t = r.tmax;
    var hit_prim = MISS_PRIM;
    var hit_u = 0.0;
    var hit_v = 0.0;
    var stack: array<vec3<u32>, STACK_SIZE>;
    var sp = 0u;
    var idx = header[pick(r.dir)];
    var tn = s.x;
    var tf = s.y;
    loop {
        let n = nodes[idx];
        let axis = n.x & 3u;
        if axis != 3u {
            (*st).interior += 1u;
            (*st).steps += 1u;
            (*st).planes += 1u;
            let t = (bitcast<f32>(n.y) - rb.org[axis]) * rb.inv[axis];
            let c = children(idx, n);
            var near = c.x;
            var far = c.y;
            if rb.neg[axis] {
                near = c.y;
                far = c.x;
            }
            if t > tf * SLACK {
                idx = near;
            } else if t * SLACK < tn {
                idx = far;
            } else {
                stack[sp] = vec3<u32>(far, bitcast<u32>(max_num(tn, t)), bitcast<u32>(tf));
                sp += 1u;
                idx = near;
                tf = min_num(tf, t);
            }
            continue;
        }
        (*st).leaves += 1u;
        (*st).steps += 1u;
        let count = n.x >> 2u;
        if !ANY {
            (*st).prims += count;
        }
        for (var k = 0u; k < count; k++) {
            if ANY {
                (*st).prims += 1u;
            }
            let id = refs[n.y + k];
            let h = intersect(p, r, id, best_t);
            if h.w != 0.0 {
                best_t = h.x;
                hit_prim = id;
                hit_u = h.y;
                hit_v = h.z;
                if ANY {
                    return Hit(best_t, hit_prim, hit_u, hit_v);
                }
            }
        }
        // Pop the next pending subtree, skipping those entered beyond the closest hit.
        var popped = false;
        loop {
            if sp == 0u {
                break;
            }
            sp -= 1u;
            let e = stack[sp];
            if ANY || bitcast<f32>(e.y) <= best_t {
                idx = e.x;
                tn = bitcast<f32>(e.y);
                tf = bitcast<f32>(e.z);
                popped = true;
                break;
            }
        }
        if !popped {
            break;
        }
    }
    if hit_prim == MISS_PRIM {
        return miss();
    }
    return Hit(best_t, hit_prim, hit_u, hit_v);
}
