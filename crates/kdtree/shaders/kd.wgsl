// The kd-tree's shared WGSL (tb_kdtree; Hapala and Havran 2011, "Review: Kd-tree traversal
// algorithms for ray tracing"), included by every program of the kd family (kdtree/…,
// multi-kd/…, sparse-boxes/…) on tb-gpu's prelude (tb_core::gpu): the node array and its
// decoding in both layouts (review §6), the header, the one split decision every kd traversal
// shares (traverse.rs `split_decision`), the leaf test, and the full-stack recursive traversal
// (traverse.rs `RecursiveDirection`).

// tb_kdtree::KdNode, 8 bytes: bits = link << 2 | axis (interior) or count << 2 | 3 (leaf);
// data = split (f32 bits) or the first reference. The node count is meta_.counts.y.
@group(0) @binding(5) var<storage, read> nodes: array<vec2<u32>>;   // GpuProgram::buffers[0]
@group(0) @binding(6) var<storage, read> refs: array<u32>;          // buffers[1]: references
// buffers[2], a uniform buffer (the same for every ray), 12 words (tb_kdtree::gpu_header), four
// to an element (a uniform array's elements are 16-byte aligned), read by `hw`: the start
// nodes (kd-tree: word 0, the walk's start node; multi-kd: roots X, Y, Z); word 3 the multi-kd
// pick rule; word 4 the layout (0 depth-first, else the treelet block's slot mask); words
// 5..10 the start cell min xyz, max xyz (f32 bits); word 11 the step cap of the restart-type
// traversals.
@group(0) @binding(7) var<uniform> header: array<vec4<u32>, 3>;

// Word `k` of the header.
fn hw(k: u32) -> u32 {
    return header[k >> 2u][k & 3u];
}

// tb_kdtree::traverse::SLACK = 1 + 8·2^-23.
const SLACK: f32 = 1.00000095367431640625;

fn is_leaf(n: vec2<u32>) -> bool {
    return (n.x & 3u) == 3u;
}

// The depth-first layout (review §6.1).
fn depth_first() -> bool {
    return hw(4u) == 0u;
}

// Layout::children: depth-first (left next, right at the link) or treelet blocks (§6.2).
fn children(i: u32, n: vec2<u32>) -> vec2<u32> {
    let mask = hw(4u);
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

// The start cell.
fn cell_min() -> vec3<f32> {
    return vec3<f32>(bitcast<f32>(hw(5u)), bitcast<f32>(hw(6u)), bitcast<f32>(hw(7u)));
}
fn cell_max() -> vec3<f32> {
    return vec3<f32>(bitcast<f32>(hw(8u)), bitcast<f32>(hw(9u)), bitcast<f32>(hw(10u)));
}

// traverse::Kind.
const NEAR_ONLY: u32 = 0u;
const FAR_ONLY: u32 = 1u;
const BOTH: u32 = 2u;

// traverse::Decision.
struct Decision { kind: u32, near: u32, far: u32, near_tf: f32, far_tn: f32 }

// traverse::split_decision, operation for operation: `t > tf·SLACK` near only, `t·SLACK < tn`
// far only, else both (a NaN `t`, the ray in the plane, fails both comparisons and is ignored
// by the interval updates).
fn decide(idx: u32, n: vec2<u32>, rb: RayBox, tn: f32, tf: f32) -> Decision {
    let a = n.x & 3u;
    let t = (bitcast<f32>(n.y) - rb.org[a]) * rb.inv[a];
    let c = children(idx, n);
    var near = c.x;
    var far = c.y;
    if rb.neg[a] {
        near = c.y;
        far = c.x;
    }
    var kind = BOTH;
    if t > tf * SLACK {
        kind = NEAR_ONLY;
    } else if t * SLACK < tn {
        kind = FAR_ONLY;
    }
    return Decision(kind, near, far, min_num(tf, t), max_num(tn, t));
}

// An interior node visited: counted as traverse.rs counts it (interior, step, plane), then
// decided.
fn counted_decide(idx: u32, n: vec2<u32>, rb: RayBox, tn: f32, tf: f32, st: ptr<function, Stats>) -> Decision {
    (*st).interior += 1u;
    (*st).steps += 1u;
    (*st).planes += 1u;
    return decide(idx, n, rb, tn, tf);
}

// traverse::leaf: test the leaf's triangles against [r.tmin, best.t), updating `best` (no hit:
// prim MISS_PRIM); with ANY, true at the first hit. Counts the leaf, its step and its tests.
fn leaf(n: vec2<u32>, p: Pre, r: Ray, best: ptr<function, Hit>, st: ptr<function, Stats>) -> bool {
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
        let h = intersect(p, r, id, (*best).t);
        if h.w != 0.0 {
            *best = Hit(h.x, id, h.y, h.z);
            if ANY {
                return true;
            }
        }
    }
    return false;
}

// The answer from the closest hit so far.
fn answer(best: Hit) -> Hit {
    if best.prim == MISS_PRIM {
        return miss();
    }
    return best;
}

// The ray clipped to the start cell (Aabb::intersect: the prelude's slab test, exit scaled by
// EXIT_SCALE as on the CPU): a hit when x <= y.
fn clip(r: Ray, rb: RayBox) -> vec2<f32> {
    return slab(rb, cell_min(), cell_max(), r.tmin, r.tmax);
}

// traverse.rs `start`: the start cell's test (one box), the ray clipped to the cell; an
// interval with x > y when the tree is empty or the ray misses the cell.
fn enter(r: Ray, rb: RayBox, st: ptr<function, Stats>) -> vec2<f32> {
    (*st).boxes += 1u;
    if meta_.counts.y == 0u {
        return vec2<f32>(1.0, 0.0);
    }
    return clip(r, rb);
}

// `recursive-direction` from node `root` (review §3.2, Alg. 2; traverse.rs
// `RecursiveDirection`): the stack-based traversal with near/far by the sign of the direction,
// the far child pushed with its entry and exit distances when the ray crosses the plane,
// pending entries skipped when they start beyond the closest hit. The full stack of STACK_SIZE
// entries lives in the invocation's private memory (Novák 2009: a conventional stack in memory
// is viable on GPUs; review §5.2). Counters as the CPU: boxes 1 (the start cell),
// interior/planes/steps per interior node, leaves/steps per leaf, prims per triangle test.
fn recursive(r: Ray, root: u32, st: ptr<function, Stats>) -> Hit {
    let rb = ray_box(r);
    let s = enter(r, rb, st);
    if !(s.x <= s.y) {
        return miss();
    }
    let p = prepare(r);
    var best = Hit(r.tmax, MISS_PRIM, 0.0, 0.0);
    var stack: array<vec3<u32>, STACK_SIZE>;
    var sp = 0u;
    var idx = root;
    var tn = s.x;
    var tf = s.y;
    loop {
        let n = nodes[idx];
        if !is_leaf(n) {
            let d = counted_decide(idx, n, rb, tn, tf, st);
            if d.kind == NEAR_ONLY {
                idx = d.near;
            } else if d.kind == FAR_ONLY {
                idx = d.far;
            } else {
                stack[sp] = vec3<u32>(d.far, bitcast<u32>(d.far_tn), bitcast<u32>(tf));
                sp += 1u;
                idx = d.near;
                tf = d.near_tf;
            }
            continue;
        }
        if leaf(n, p, r, &best, st) {
            return best;
        }
        // Pop the next pending subtree, skipping those entered beyond the closest hit.
        var popped = false;
        loop {
            if sp == 0u {
                break;
            }
            sp -= 1u;
            let e = stack[sp];
            if ANY || bitcast<f32>(e.y) <= best.t {
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
    return answer(best);
}

// ---- 64-bit masks as vec2<u32> (x: bits 0..31, y: bits 32..63): the depth and path bits of
// the restart-type walks, sparse boxes' SLTR masks ----

fn bit_set(v: vec2<u32>, k: u32) -> vec2<u32> {
    if k < 32u {
        return v | vec2<u32>(1u << k, 0u);
    }
    return v | vec2<u32>(0u, 1u << (k - 32u));
}

fn bit_get(v: vec2<u32>, k: u32) -> bool {
    if k < 32u {
        return ((v.x >> k) & 1u) == 1u;
    }
    return ((v.y >> (k - 32u)) & 1u) == 1u;
}

// The bits below `k` (k <= 64).
fn keep_below(v: vec2<u32>, k: u32) -> vec2<u32> {
    if k >= 64u {
        return v;
    }
    if k >= 32u {
        return vec2<u32>(v.x, v.y & ((1u << (k - 32u)) - 1u));
    }
    return vec2<u32>(v.x & ((1u << k) - 1u), 0u);
}

// Index of the highest set bit of a non-zero mask.
fn highest(v: vec2<u32>) -> u32 {
    if v.y != 0u {
        return 32u + firstLeadingBit(v.y);
    }
    return firstLeadingBit(v.x);
}

// The bits at and above `k`.
fn keep_from(v: vec2<u32>, k: u32) -> vec2<u32> {
    if k >= 64u {
        return vec2<u32>(0u, 0u);
    }
    let below = keep_below(v, k);
    return vec2<u32>(v.x & ~below.x, v.y & ~below.y);
}
