// The kd-tree's traversals on the GPU (tb_kdtree; Hapala and Havran 2011, "Review: Kd-tree
// traversal algorithms for ray tracing", CGF 30(1)): shaders/kd.wgsl (nodes, references,
// header, the split decision, the leaf test, `recursive`) then this file, on tb-gpu's prelude
// (tb_core::gpu). One program per traversal (`kdtree/NAME`), the kernel chosen by the override
// constant KERNEL; each repeats its CPU kernel (traverse/, stackless/) decision for
// decision, in the CPU's order, so the counters agree ray for ray. One thread per ray.

// Which traversal (GpuProgram::constants).
const K_RECURSIVE: u32 = 0u;   // recursive-direction, §3.2 Alg. 2, full stack (Novák 2009)
const K_RESTART: u32 = 1u;     // restart, §5.1 (Foley and Sugerman 2005)
const K_PUSH_DOWN: u32 = 2u;   // push-down, §5.2 Alg. 4 (Horn et al. 2007)
const K_SHORT_STACK: u32 = 3u; // short-stack, §5.2 (Horn et al. 2007)
const K_ROPES: u32 = 4u;       // ropes, §3.3 (Havran et al. 1998, Popov et al. 2007)
const K_SEQUENTIAL: u32 = 5u;  // sequential, §3.1 Alg. 1 (Kaplan 1985)
const K_BACKTRACK: u32 = 6u;   // backtrack, §5.1.1 Alg. 3 (Foley and Sugerman 2005)
override KERNEL: u32 = 0u;

// ---- restart, push-down, short-stack, backtrack (stackless/restarts.rs `Restarts`) ----

// buffers[3]: `backtrack`: per node its cell and parent (8 words: min xyz, parent, max xyz, 0;
// the BACKTRACK_AUX array); `ropes`: the leaves' rank (per 64 nodes the bits' low and high
// words and the count of leaves before them), then per leaf, in node order, its cell and six
// ropes (12 words: min xyz, max xyz, ropes; the ROPES_AUX array, view.rs `Ropes::words`); one
// word for the programs that read neither.
@group(0) @binding(8) var<storage, read> aux: array<u32>;

// The short stack on chip (see `Restarts`): SHORT_SLOTS and SHORT_ON_CHIP come from the
// program's source (kdtree/src/gpu.rs), one slot where it is unused.
var<workgroup> short_stack: array<vec4<u32>, SHORT_SLOTS>;

// The short stack in registers (SHORT_IN_REGISTERS, STACK_SIZE <= REG_SLOTS): newest entry
// first, every index a constant (so that a compiler keeps the entries in registers, which
// dynamic indexing would send to memory); a push shifts the entries down, the oldest falling
// off when all STACK_SIZE are taken, as the circular stack overwrites its oldest; a pop takes
// the first and shifts the rest up. The same entries come back in the same order.
const REG_SLOTS: u32 = 8u;

fn reg_push(w: ptr<function, Restarts>, e: vec4<u32>) {
    if STACK_SIZE > 7u { (*w).regs[7] = (*w).regs[6]; }
    if STACK_SIZE > 6u { (*w).regs[6] = (*w).regs[5]; }
    if STACK_SIZE > 5u { (*w).regs[5] = (*w).regs[4]; }
    if STACK_SIZE > 4u { (*w).regs[4] = (*w).regs[3]; }
    if STACK_SIZE > 3u { (*w).regs[3] = (*w).regs[2]; }
    if STACK_SIZE > 2u { (*w).regs[2] = (*w).regs[1]; }
    if STACK_SIZE > 1u { (*w).regs[1] = (*w).regs[0]; }
    (*w).regs[0] = e;
}

fn reg_pop(w: ptr<function, Restarts>) -> vec4<u32> {
    let e = (*w).regs[0];
    if STACK_SIZE > 1u { (*w).regs[0] = (*w).regs[1]; }
    if STACK_SIZE > 2u { (*w).regs[1] = (*w).regs[2]; }
    if STACK_SIZE > 3u { (*w).regs[2] = (*w).regs[3]; }
    if STACK_SIZE > 4u { (*w).regs[3] = (*w).regs[4]; }
    if STACK_SIZE > 5u { (*w).regs[4] = (*w).regs[5]; }
    if STACK_SIZE > 6u { (*w).regs[5] = (*w).regs[6]; }
    if STACK_SIZE > 7u { (*w).regs[6] = (*w).regs[7]; }
    return e;
}

fn aux_min(i: u32) -> vec3<f32> {
    let b = 8u * i;
    return vec3<f32>(bitcast<f32>(aux[b]), bitcast<f32>(aux[b + 1u]), bitcast<f32>(aux[b + 2u]));
}
fn aux_max(i: u32) -> vec3<f32> {
    let b = 8u * i + 4u;
    return vec3<f32>(bitcast<f32>(aux[b]), bitcast<f32>(aux[b + 1u]), bitcast<f32>(aux[b + 2u]));
}
fn aux_parent(i: u32) -> u32 {
    return aux[8u * i + 3u];
}

// stackless/mod.rs `cell_interval`: the interval of the node with cell `lo..hi`, the slab interval
// with the plane distances of `decide`, the start cell's faces counting as `[t0, t1]`.
fn cell_interval(rb: RayBox, lo: vec3<f32>, hi: vec3<f32>, t0: f32, t1: f32) -> vec2<f32> {
    let rlo = cell_min();
    let rhi = cell_max();
    var tn = t0;
    var tf = t1;
    for (var a = 0u; a < 3u; a++) {
        let neg = rb.neg[a];
        let np = select(lo[a], hi[a], neg);
        let fp = select(hi[a], lo[a], neg);
        let rn = select(rlo[a], rhi[a], neg);
        let rf = select(rhi[a], rlo[a], neg);
        if np != rn {
            tn = max_num(tn, (np - rb.org[a]) * rb.inv[a]);
        }
        if fp != rf {
            tf = min_num(tf, (fp - rb.org[a]) * rb.inv[a]);
        }
    }
    return vec2<f32>(tn, tf);
}

// The state of a restart-type walk kept between leaves: the depth of the current node, `both`
// (bit k: the node at depth k on the way sent the ray both ways and the walk went near), `path`
// (bit k: the walk went right at depth k; treelet layout only).
struct Track { depth: u32, both: vec2<u32>, path: vec2<u32> }

// stackless/mod.rs `below`: the track of the far child of the node at depth `at >> 1` (`at & 1`:
// the right child), bits from that depth on cleared.
fn below(t: Track, at: u32) -> Track {
    let pd = at >> 1u;
    var path = keep_below(t.path, pd);
    if (at & 1u) == 1u {
        path = bit_set(path, pd);
    }
    return Track(pd + 1u, keep_below(t.both, pd), path);
}

// The restart-type walks (K_RESTART, K_PUSH_DOWN, K_SHORT_STACK, K_BACKTRACK) of a ray clipped
// to `[t0, t1]` from the start node, with the closest hit `best` and `steps0` steps taken, as
// one walk state (`Restarts`) and its named steps (`restarts_descend`, `_leaf`, `_pop`,
// `_at_start`, `_restart`, `_climb`, `_enter`), the names of stackless/restarts.rs, and one
// function per traversal (`restart_walk`, `short_stack_walk`, `backtrack_walk`) reading as its
// CPU twin; the step cap (header word 11) ends a walk as on the CPU. The short stack is a circular array of
// STACK_SIZE entries (the program's stack size: KdParams::short_stack, as the CPU kernel's),
// kept on chip as Horn et al.'s is (review §5.2: the short stack in fast memory, the full stack
// of `recursive-direction` in the invocation's memory, Novák's contrast): in registers up to
// REG_SLOTS entries (SHORT_IN_REGISTERS: `reg_push`, `reg_pop`), else in workgroup memory,
// STACK_SIZE entries per invocation at `LANE * STACK_SIZE` (SHORT_ON_CHIP, set by the program's
// source for sizes whose slots fit WebGPU's 16 KiB of workgroup memory: up to 16 entries);
// larger short stacks stay in the invocation's memory.
//
// - `restart` (Foley and Sugerman 2005, kd-restart; review §5.1): after each leaf, restart at
//   the start node and descend toward the last leaf down to the deepest node that sent the ray
//   both ways, continuing in the far child of the deepest one whose far side starts before the
//   closest hit (the next subtree the stack traversal would pop);
// - `push-down` (Horn et al. 2007; review §5.2, Alg. 4): restart at the pushed-down node, the
//   deepest node above every subtree still to visit;
// - `short-stack` (Horn et al. 2007; review §5.2): push-down with a circular short stack of far
//   children, the oldest overwritten when full; a restart only when it runs dry;
// - `backtrack` (Foley and Sugerman 2005, kd-backtrack; review §5.1.1, Alg. 3): from a leaf
//   climb the parent links, recomputing each node's interval from its cell (the auxiliary
//   array), up to the first node where the walk went both ways from the near child, then
//   descend into its far child.
// One restart-type walk's state between its steps (stackless/restarts.rs `Restarts`): the
// traversal `k`, the steps taken (against the step cap, header word 11), the current node and
// its interval, its track (`Track`; not kept by `backtrack`), whether the ray lies in a split
// plane it met (its children overlap in `t`), the pushed-down node with its interval and depth
// and whether it may still be pushed down (`push-down`, `short-stack`; the start node for the
// others), the last leaf, and `short-stack`'s circular stack: far child, its interval (f32
// bits), its parent's depth << 1 | whether it is the right child; `count` entries, the newest
// at `top - 1` (mod STACK_SIZE), in `regs` (SHORT_IN_REGISTERS), `short_stack`
// (SHORT_ON_CHIP) or `stack`.
struct Restarts {
    k: u32,
    steps: u32,
    idx: u32,
    tn: f32,
    tf: f32,
    tr: Track,
    in_plane: bool,
    pd: u32,
    pd_tn: f32,
    pd_tf: f32,
    pd_depth: u32,
    push: bool,
    last: u32,
    top: u32,
    count: u32,
    stack: array<vec4<u32>, LOCAL_SLOTS>,
    regs: array<vec4<u32>, REG_SLOTS>,
}

// The next subtree (restarts.rs `Next`): node, interval (f32 bits) and parent's depth << 1 |
// right-child bit; `only`: the only one pending (`push-down` may push down to it); `found`:
// there is one.
struct Next { e: vec4<u32>, only: bool, found: bool }

// restarts.rs `Restarts::new`: a walk of `k` over `[t0, t1]` from the start node, `steps0`
// steps already taken.
fn restarts_new(w: ptr<function, Restarts>, k: u32, t0: f32, t1: f32, steps0: u32) {
    let root = hw(0u);
    (*w).k = k;
    (*w).steps = steps0;
    (*w).idx = root;
    (*w).tn = t0;
    (*w).tf = t1;
    (*w).pd = root;
    (*w).pd_tn = t0;
    (*w).pd_tf = t1;
    (*w).push = k == K_PUSH_DOWN || k == K_SHORT_STACK;
}

// `short-stack`: keep far child entry `e` on the circular stack, the oldest overwritten when full.
fn restarts_keep(w: ptr<function, Restarts>, e: vec4<u32>) {
    if SHORT_IN_REGISTERS {
        reg_push(w, e);
    } else if SHORT_ON_CHIP {
        short_stack[LANE * STACK_SIZE + (*w).top] = e;
    } else {
        (*w).stack[(*w).top] = e;
    }
    (*w).top = select((*w).top + 1u, 0u, (*w).top + 1u == STACK_SIZE);
    (*w).count = min((*w).count + 1u, STACK_SIZE);
}

// restarts.rs `Restarts::descend`: to the first leaf of the current subtree, near child first;
// `short-stack` keeps the far children, and the pushed-down node follows while the walk visits
// one child only.
fn restarts_descend(w: ptr<function, Restarts>, rb: RayBox, st: ptr<function, Stats>) {
    let track = (*w).k != K_BACKTRACK;
    let df = depth_first();
    loop {
        let idx = (*w).idx;
        let n = nodes[idx];
        if is_leaf(n) {
            break;
        }
        (*w).steps += 1u;
        let d = counted_decide(idx, n, rb, (*w).tn, (*w).tf, st);
        let near_right = rb.neg[n.x & 3u];
        var go_right = near_right;
        if d.kind == NEAR_ONLY {
            (*w).idx = d.near;
        } else if d.kind == FAR_ONLY {
            (*w).idx = d.far;
            go_right = !near_right;
        } else {
            // `far_tn < near_tf` only for `t = NaN` (see `decide`).
            (*w).in_plane = (*w).in_plane || d.far_tn < d.near_tf;
            if (*w).k == K_SHORT_STACK {
                restarts_keep(w, vec4<u32>(d.far, bitcast<u32>(d.far_tn), bitcast<u32>((*w).tf),
                                           ((*w).tr.depth << 1u) | select(1u, 0u, near_right)));
            }
            (*w).push = false;
            (*w).idx = d.near;
            (*w).tf = d.near_tf;
            if track {
                (*w).tr.both = bit_set((*w).tr.both, (*w).tr.depth);
            }
        }
        if track {
            if !df && go_right {
                (*w).tr.path = bit_set((*w).tr.path, (*w).tr.depth);
            }
            (*w).tr.depth += 1u;
        }
        if (*w).push {
            (*w).pd = (*w).idx;
            (*w).pd_tn = (*w).tn;
            (*w).pd_tf = (*w).tf;
            (*w).pd_depth = (*w).tr.depth;
        }
    }
}

// restarts.rs `Restarts::leaf`: test the leaf reached (one step); true when the ray is done: an
// any-hit found, a hit before the end of the leaf's interval (Foley and Sugerman's early exit;
// not for a ray lying in a split plane), or the step cap reached.
fn restarts_leaf(w: ptr<function, Restarts>, p: Pre, r: Ray, best: ptr<function, Hit>,
                 st: ptr<function, Stats>) -> bool {
    (*w).steps += 1u;
    if leaf(nodes[(*w).idx], p, r, best, st) {
        return true;
    }
    if (*best).t < (*w).tf && !(*w).in_plane {
        return true;
    }
    if (*w).steps >= hw(11u) {
        (*st).capped = 1u;
        return true;
    }
    (*w).last = (*w).idx;
    return false;
}

// restarts.rs `Restarts::pop`: `short-stack` continues in the newest kept far child that starts
// before the closest hit `best_t` (any-hit queries: the newest); false when the stack runs dry.
fn restarts_pop(w: ptr<function, Restarts>, best_t: f32) -> bool {
    loop {
        if (*w).count == 0u {
            return false;
        }
        (*w).top = select((*w).top - 1u, STACK_SIZE - 1u, (*w).top == 0u);
        (*w).count -= 1u;
        var e = (*w).stack[0];
        if SHORT_IN_REGISTERS {
            e = reg_pop(w);
        } else if SHORT_ON_CHIP {
            e = short_stack[LANE * STACK_SIZE + (*w).top];
        } else {
            e = (*w).stack[(*w).top];
        }
        if ANY || bitcast<f32>(e.y) <= best_t {
            (*w).idx = e.x;
            (*w).tn = bitcast<f32>(e.y);
            (*w).tf = bitcast<f32>(e.z);
            (*w).tr = below((*w).tr, e.w);
            return true;
        }
    }
    return false;
}

// restarts.rs `Restarts::at_start`: the last leaf is the start node (nothing to climb to).
fn restarts_at_start(w: ptr<function, Restarts>) -> bool {
    return (*w).last == hw(0u);
}

// restarts.rs `Restarts::restart`: descend from the pushed-down node toward the last leaf, down
// to the deepest node that sent the ray both ways; the next subtree is the far child of the
// deepest one whose far side starts before the closest hit `best_t`. None below the
// pushed-down node: the ray is done.
fn restarts_restart(w: ptr<function, Restarts>, rb: RayBox, best_t: f32,
                    st: ptr<function, Stats>) -> Next {
    var next = Next(vec4<u32>(0u), false, false);
    let tr = (*w).tr;
    let live = tr.both ^ keep_below(tr.both, (*w).pd_depth);
    if all(live == vec2<u32>(0u)) {
        return next;
    }
    let df = depth_first();
    let last = (*w).last;
    let deepest = highest(live);
    var pending = 0u;
    var x = (*w).pd;
    var xn = (*w).pd_tn;
    var xf = (*w).pd_tf;
    var xd = (*w).pd_depth;
    loop {
        if xd > deepest {
            break;
        }
        let n = nodes[x];
        (*w).steps += 1u;
        let d = counted_decide(x, n, rb, xn, xf, st);
        var toward: u32;
        if df {
            // The left subtree of `x` is `x + 1 .. link`.
            let link = n.x >> 2u;
            toward = select(link, x + 1u, last < link);
        } else {
            let c = children(x, n);
            toward = select(c.x, c.y, bit_get(tr.path, xd));
        }
        if d.kind == BOTH {
            if toward == d.near {
                if ANY || d.far_tn <= best_t {
                    let far_right = !rb.neg[n.x & 3u];
                    next.e = vec4<u32>(d.far, bitcast<u32>(d.far_tn), bitcast<u32>(xf),
                                       (xd << 1u) | select(0u, 1u, far_right));
                    next.found = true;
                    pending += 1u;
                }
                xf = d.near_tf;
            } else {
                xn = d.far_tn;
            }
        }
        x = toward;
        xd += 1u;
    }
    next.only = pending == 1u;
    return next;
}

// restarts.rs `Restarts::climb`: `backtrack` climbs the parent links from the last leaf,
// recomputing each node's interval from its cell (one node, plane, box and step each), up to the
// first node where the walk went both ways from the near child and whose far side starts before
// the closest hit `best_t`: its far child is next. None above the start node.
fn restarts_climb(w: ptr<function, Restarts>, rb: RayBox, t0: f32, t1: f32, best_t: f32,
                  st: ptr<function, Stats>) -> Next {
    let root = hw(0u);
    var child = (*w).last;
    var x = aux_parent(child);
    loop {
        (*st).interior += 1u;
        (*st).steps += 1u;
        (*st).planes += 1u;
        (*st).boxes += 1u;
        (*w).steps += 1u;
        let xi = cell_interval(rb, aux_min(x), aux_max(x), t0, t1);
        let d = decide(x, nodes[x], rb, xi.x, xi.y);
        if d.kind == BOTH && child == d.near && (ANY || d.far_tn <= best_t) {
            return Next(vec4<u32>(d.far, bitcast<u32>(d.far_tn), bitcast<u32>(xi.y), 0u), false,
                        true);
        }
        if x == root {
            return Next(vec4<u32>(0u), false, false);
        }
        child = x;
        x = aux_parent(x);
    }
    return Next(vec4<u32>(0u), false, false);
}

// restarts.rs `Restarts::enter`: continue in `next`, its track from its parent's, and the
// pushed-down node there where it is the only subtree pending (`push-down`, `short-stack`).
fn restarts_enter(w: ptr<function, Restarts>, next: Next) {
    (*w).idx = next.e.x;
    (*w).tn = bitcast<f32>(next.e.y);
    (*w).tf = bitcast<f32>(next.e.z);
    if (*w).k == K_BACKTRACK {
        return;
    }
    (*w).tr = below((*w).tr, next.e.w);
    (*w).push = next.only && ((*w).k == K_PUSH_DOWN || (*w).k == K_SHORT_STACK);
    if (*w).push {
        (*w).pd = (*w).idx;
        (*w).pd_tn = (*w).tn;
        (*w).pd_tf = (*w).tf;
        (*w).pd_depth = (*w).tr.depth;
    }
}

// `restart` and `push-down` (stackless/restart.rs, push_down.rs): after each leaf, restart
// from the pushed-down node (the start node for `restart`).
fn restart_walk(k: u32, r: Ray, rb: RayBox, p: Pre, t0: f32, t1: f32, best0: Hit, steps0: u32,
                st: ptr<function, Stats>) -> Hit {
    var best = best0;
    var w: Restarts;
    restarts_new(&w, k, t0, t1, steps0);
    loop {
        restarts_descend(&w, rb, st);
        if restarts_leaf(&w, p, r, &best, st) {
            return answer(best);
        }
        (*st).restarts += 1u;
        let next = restarts_restart(&w, rb, best.t, st);
        if !next.found {
            return answer(best);
        }
        restarts_enter(&w, next);
    }
    return answer(best);
}

// `short-stack` (stackless/short_stack.rs): the newest kept far child after each leaf, a
// restart from the pushed-down node only when the stack runs dry.
fn short_stack_walk(r: Ray, rb: RayBox, p: Pre, t0: f32, t1: f32, best0: Hit,
                    st: ptr<function, Stats>) -> Hit {
    var best = best0;
    var w: Restarts;
    restarts_new(&w, K_SHORT_STACK, t0, t1, 0u);
    loop {
        restarts_descend(&w, rb, st);
        if restarts_leaf(&w, p, r, &best, st) {
            return answer(best);
        }
        if restarts_pop(&w, best.t) {
            continue;
        }
        (*st).restarts += 1u;
        let next = restarts_restart(&w, rb, best.t, st);
        if !next.found {
            return answer(best);
        }
        restarts_enter(&w, next);
    }
    return answer(best);
}

// `backtrack` (stackless/backtrack.rs): after each leaf, climb the parent links.
fn backtrack_walk(r: Ray, rb: RayBox, p: Pre, t0: f32, t1: f32, best0: Hit,
                  st: ptr<function, Stats>) -> Hit {
    var best = best0;
    var w: Restarts;
    restarts_new(&w, K_BACKTRACK, t0, t1, 0u);
    loop {
        restarts_descend(&w, rb, st);
        if restarts_leaf(&w, p, r, &best, st) || restarts_at_start(&w) {
            return answer(best);
        }
        (*st).restarts += 1u;
        let next = restarts_climb(&w, rb, t0, t1, best.t, st);
        if !next.found {
            return answer(best);
        }
        restarts_enter(&w, next);
    }
    return answer(best);
}

// ---- sequential and ropes (stackless/locate.rs `PointWalk`: locate, leaf, leave) ----

const NO_ROPE: u32 = 0xffffffffu;
// SLACK − 1 = 8·2^-23.
const SLACK_EPS: f32 = 0.00000095367431640625;

fn is_nan(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7fffffffu) > 0x7f800000u;
}

// The state of one pass of a `sequential` or `ropes` walk (stackless/locate.rs `PointWalk`).
struct PointWalk {
    // Per axis, the coordinate of the last exit face crossed on that axis (initially the start
    // cell's entry face).
    floor: vec3<f32>,
    // The axis of the exit face just crossed (3 before the first).
    exact: u32,
    // For rays lying in a split plane: the side to take per axis, and the axes met.
    mask: u32,
    seen: u32,
    steps: u32,
    // A plane distance within rounding of the located point was met.
    ambiguous: bool,
}

// A located leaf and its cell (locate.rs `Cell`).
struct Loc { idx: u32, lo: vec3<f32>, hi: vec3<f32> }

// Where a walk goes from a leaf's cell (locate.rs `Exit`): EXIT_DONE (it leaves the start cell,
// or the closest hit lies before the exit), EXIT_AMBIGUOUS (two exit faces tied within
// rounding), EXIT_FACE (through `face` at distance `t`).
const EXIT_DONE: u32 = 0u;
const EXIT_AMBIGUOUS: u32 = 1u;
const EXIT_FACE: u32 = 2u;
struct Exit { kind: u32, face: u32, t: f32 }

// What one pass ends with (locate.rs `point_walk`'s `crawl`): the ray is done with no stop,
// stopped (an any-hit found or the step cap reached), or ambiguous (handed to restart).
const PASS_DONE: u32 = 0u;
const PASS_STOP: u32 = 1u;
const PASS_AMBIGUOUS: u32 = 2u;

// view.rs `Ropes::leaf`: the first word of leaf `node`'s record (the leaves before it, by the
// rank at the start of `aux`).
fn leaf_record(node: u32, n_nodes: u32) -> u32 {
    let k = 3u * (node / 64u);
    let b = node % 64u;
    let lo = aux[k];
    let hi = aux[k + 1u];
    var n = aux[k + 2u];
    if b < 32u {
        n += countOneBits(lo & ((1u << b) - 1u));
    } else {
        n += countOneBits(lo) + countOneBits(hi & ((1u << (b - 32u)) - 1u));
    }
    return 3u * ((n_nodes + 63u) / 64u) + 12u * n;
}

fn rec_vec(k: u32) -> vec3<f32> {
    return vec3<f32>(bitcast<f32>(aux[k]), bitcast<f32>(aux[k + 1u]), bitcast<f32>(aux[k + 2u]));
}

// Kaplan's point location (review §3.1; `PointWalk::locate`) below node `idx0` with cell
// `lo0..hi0` of the ray point at distance `tn`, exact on the axes of crossed exit faces.
fn point_locate(w: ptr<function, PointWalk>, rb: RayBox, idx0: u32, lo0: vec3<f32>,
                hi0: vec3<f32>, tn: f32, st: ptr<function, Stats>) -> Loc {
    var idx = idx0;
    var lo = lo0;
    var hi = hi0;
    let origin = tn == 0.0;
    let below_t = tn - SLACK_EPS * abs(tn);
    let above_t = tn + SLACK_EPS * abs(tn);
    loop {
        let n = nodes[idx];
        if is_leaf(n) {
            return Loc(idx, lo, hi);
        }
        (*st).interior += 1u;
        (*st).steps += 1u;
        (*st).planes += 1u;
        (*w).steps += 1u;
        let a = n.x & 3u;
        let sp = bitcast<f32>(n.y);
        let t = (sp - rb.org[a]) * rb.inv[a];
        let neg = rb.neg[a];
        var left: bool;
        if is_nan(t) {
            // The ray lies in the plane: the side chosen by the pass.
            (*w).seen |= 1u << a;
            left = (((*w).mask >> a) & 1u) == 0u;
        } else {
            let fl = (*w).floor[a];
            var behind = select(sp <= fl, sp >= fl, neg);
            if origin {
                let lower = sp < rb.org[a];
                let upper = sp > rb.org[a];
                behind = behind || select(lower, upper, neg);
            } else if a != (*w).exact {
                if !behind && t >= below_t && t <= above_t {
                    (*w).ambiguous = true;
                }
                behind = behind || t < below_t;
            }
            left = behind == neg;
        }
        let c = children(idx, n);
        if left {
            hi[a] = sp;
            idx = c.x;
        } else {
            lo[a] = sp;
            idx = c.y;
        }
    }
    return Loc(idx, lo, hi);
}

// `PointWalk::locate_start`: point location from the start node.
fn point_locate_start(w: ptr<function, PointWalk>, rb: RayBox, tn: f32,
                      st: ptr<function, Stats>) -> Loc {
    return point_locate(w, rb, hw(0u), cell_min(), cell_max(), tn, st);
}

// `PointWalk::leaf`: test leaf `idx` (one step); true when the ray is done (an any-hit found, or
// the step cap reached).
fn point_leaf(w: ptr<function, PointWalk>, idx: u32, p: Pre, r: Ray, best: ptr<function, Hit>,
              st: ptr<function, Stats>) -> bool {
    (*w).steps += 1u;
    if leaf(nodes[idx], p, r, best, st) {
        return true;
    }
    if (*w).steps >= hw(11u) {
        (*st).capped = 1u;
        return true;
    }
    return false;
}

// `PointWalk::leave`: leave the cell `lo..hi` (one box) through the nearest far plane that is
// not a start-cell face, which becomes the floor of its axis and the exact axis of the next
// point; another far plane within rounding of it (a ray through a cell edge or corner) is an
// ambiguity.
fn point_leave(w: ptr<function, PointWalk>, rb: RayBox, lo: vec3<f32>, hi: vec3<f32>,
               best_t: f32, t1: f32, st: ptr<function, Stats>) -> Exit {
    let lo_c = cell_min();
    let hi_c = cell_max();
    (*st).boxes += 1u;
    var ts = vec3<f32>(bitcast<f32>(0x7f800000u));
    var tf = bitcast<f32>(0x7f800000u);
    var face = 3u;
    for (var a = 0u; a < 3u; a++) {
        let far = select(hi[a], lo[a], rb.neg[a]);
        let rootf = select(hi_c[a], lo_c[a], rb.neg[a]);
        if far != rootf {
            let t = (far - rb.org[a]) * rb.inv[a];
            ts[a] = t;
            if t < tf {
                tf = t;
                face = a;
            }
        }
    }
    if face == 3u || best_t <= tf || tf > t1 * SLACK {
        return Exit(EXIT_DONE, 3u, tf);
    }
    let reach = tf + SLACK_EPS * abs(tf);
    for (var a = 0u; a < 3u; a++) {
        if a != face && ts[a] <= reach {
            return Exit(EXIT_AMBIGUOUS, 3u, tf);
        }
    }
    (*w).floor[face] = select(hi[face], lo[face], rb.neg[face]);
    (*w).exact = face;
    return Exit(EXIT_FACE, face, tf);
}

// One pass of `sequential` (stackless/sequential.rs `crawl`): locate the entry leaf, then leave
// each leaf through its exit face and locate the next leaf from the start node (a restart).
fn sequential_pass(w: ptr<function, PointWalk>, r: Ray, rb: RayBox, p: Pre, t0: f32, t1: f32,
                   best: ptr<function, Hit>, st: ptr<function, Stats>) -> u32 {
    var tn = t0;
    var loc = point_locate_start(w, rb, tn, st);
    loop {
        if (*w).ambiguous {
            return PASS_AMBIGUOUS;
        }
        if point_leaf(w, loc.idx, p, r, best, st) {
            return PASS_STOP;
        }
        let x = point_leave(w, rb, loc.lo, loc.hi, (*best).t, t1, st);
        if x.kind == EXIT_DONE {
            return PASS_DONE;
        }
        if x.kind == EXIT_AMBIGUOUS {
            return PASS_AMBIGUOUS;
        }
        tn = max_num(tn, x.t);
        (*st).restarts += 1u;
        loc = point_locate_start(w, rb, tn, st);
    }
    return PASS_DONE;
}

// One pass of `ropes` (stackless/ropes.rs `crawl`): as `sequential_pass`, but each leaf's cell
// and ropes come from its record, and the next leaf is located below the exit face's rope.
fn ropes_pass(w: ptr<function, PointWalk>, r: Ray, rb: RayBox, p: Pre, t0: f32, t1: f32,
              best: ptr<function, Hit>, st: ptr<function, Stats>) -> u32 {
    let n_nodes = meta_.counts.y;
    var tn = t0;
    var loc = point_locate_start(w, rb, tn, st);
    loop {
        if (*w).ambiguous {
            return PASS_AMBIGUOUS;
        }
        let rec = leaf_record(loc.idx, n_nodes);
        loc.lo = rec_vec(rec);
        loc.hi = rec_vec(rec + 3u);
        if point_leaf(w, loc.idx, p, r, best, st) {
            return PASS_STOP;
        }
        let x = point_leave(w, rb, loc.lo, loc.hi, (*best).t, t1, st);
        if x.kind == EXIT_DONE {
            return PASS_DONE;
        }
        if x.kind == EXIT_AMBIGUOUS {
            return PASS_AMBIGUOUS;
        }
        tn = max_num(tn, x.t);
        let rope = aux[rec + 6u + 2u * x.face + select(1u, 0u, rb.neg[x.face])];
        if rope == NO_ROPE {
            return PASS_DONE;
        }
        // The cell tracked below the rope is not needed: the next leaf's record has it.
        loc = point_locate(w, rb, rope, loc.lo, loc.hi, tn, st);
    }
    return PASS_DONE;
}

// `sequential` (Kaplan 1985; review §3.1, Alg. 1) and `ropes` (MacDonald and Booth 1990,
// Havran et al. 1998, Popov et al. 2007; review §3.3) as locate.rs `point_walk` runs them: a walk per
// combination of sides on the zero-direction axes where the ray lay in a split plane (`passes`),
// and a ray whose point location was ambiguous within rounding handed to `restart` with its
// closest hit and steps (one restart counted).
fn crawl_passes(rope_walk: bool, r: Ray, rb: RayBox, p: Pre, t0: f32, t1: f32, best0: Hit,
                st: ptr<function, Stats>) -> Hit {
    var best = best0;
    let floor0 = select(cell_min(), cell_max(), rb.neg);
    // Zero-direction axes: 1/d infinite (a zero or a subnormal component; locate.rs `passes`).
    let zero = select(0u, 1u, not_finite(rb.inv.x)) | select(0u, 2u, not_finite(rb.inv.y))
        | select(0u, 4u, not_finite(rb.inv.z));
    var steps = 0u;
    var ambiguous = false;
    for (var m = 0u; m < 8u; m++) {
        if m != 0u && (m & ~zero) != 0u {
            continue;
        }
        var w = PointWalk(floor0, 3u, m, 0u, steps, false);
        var res: u32;
        if rope_walk {
            res = ropes_pass(&w, r, rb, p, t0, t1, &best, st);
        } else {
            res = sequential_pass(&w, r, rb, p, t0, t1, &best, st);
        }
        steps = w.steps;
        ambiguous = res == PASS_AMBIGUOUS;
        let stop = res != PASS_DONE;
        if stop || (m == 0u && w.seen == 0u) {
            break;
        }
    }
    if !ambiguous {
        return answer(best);
    }
    (*st).restarts += 1u;
    (*st).handovers += 1u;
    return restart_walk(K_RESTART, r, rb, p, t0, t1, best, steps, st);
}

fn walk(r: Ray, st: ptr<function, Stats>) -> Hit {
    if KERNEL == K_RECURSIVE {
        return recursive(r, hw(0u), st);
    }
    let rb = ray_box(r);
    let s = enter(r, rb, st);
    if !(s.x <= s.y) {
        return miss();
    }
    let p = prepare(r);
    let best = Hit(r.tmax, MISS_PRIM, 0.0, 0.0);
    if KERNEL == K_SEQUENTIAL || KERNEL == K_ROPES {
        return crawl_passes(KERNEL == K_ROPES, r, rb, p, s.x, s.y, best, st);
    }
    if KERNEL == K_SHORT_STACK {
        return short_stack_walk(r, rb, p, s.x, s.y, best, st);
    }
    if KERNEL == K_BACKTRACK {
        return backtrack_walk(r, rb, p, s.x, s.y, best, st);
    }
    return restart_walk(KERNEL, r, rb, p, s.x, s.y, best, 0u, st);
}
