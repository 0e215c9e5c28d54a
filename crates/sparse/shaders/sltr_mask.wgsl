// `sltr-mask`: our stackless variant of the bottom-up traversal with sparse boxes (Havran and
// Bittner 2007 §5.3), not the paper's Algorithm 3 (no epsilon shift, no point location: it
// visits exactly HTR's leaves; the paper's SLTR, `sltr`, has no GPU kernel). Programs
// `sparse-boxes/sltr-mask` (START: from the start node located per ray) and
// `sparse-boxes/sltr-mask-root` on tb-gpu's prelude (tb_core::gpu). The same walk as the CPU
// kernel (crates/sparse/src/traverse.rs, `Ctx::sltr_mask`), statement for statement, so the
// counters agree ray for ray: down to a leaf by the first intersected child, then to the far
// child of the deepest node that sent the ray both ways (one bit per depth, two words),
// restarting from the last augmented node or climbing parent links to the one above it (each
// link followed counted in `ups` and in `interior`, as traverse.rs's `climb`), and above the
// start node descending from the parent augmented node toward it to learn the bits of those
// levels.

// On the kd-tree family's WGSL (tb_kdtree::KD_WGSL, included through tb-gpu before this file):
// its node array (`nodes`, binding 5), references (`refs`, 6), header (7: depth-first layout,
// the root cell, the step cap in word 11), `is_leaf`, the split decision `decide` (traverse.rs
// `split_decision`) and the leaf test `leaf`.

// tb_sparse::AugNode, 32 bytes: the node's cell, the parent record, the node.
struct Aug { bmin: vec3<f32>, parent: u32, bmax: vec3<f32>, node: u32 }

@group(0) @binding(8) var<storage, read> aug: array<Aug>;        // buffers[3]: record 0 = root
@group(0) @binding(9) var<storage, read> depths: array<u32>;     // buffers[4]: per record, then the rank

// Start at the start node (the deepest augmented node strictly holding the origin).
override START: bool = false;

const NONE: u32 = 0xffffffffu;

// One interior node on the way down toward the last leaf `lf` (the split decision, and
// `toward`: the child holding `lf`), counted as traverse.rs counts it.
struct Toward { d: Decision, toward: u32 }

fn toward_leaf(x: u32, lf: u32, rb: RayBox, xn: f32, xf: f32, st: ptr<function, Stats>) -> Toward {
    let n = nodes[x];
    let d = counted_decide(x, n, rb, xn, xf, st);
    var toward = n.x >> 2u;
    if lf < toward {
        toward = x + 1u;
    }
    return Toward(d, toward);
}

// traverse.rs `AugRank::find`: the record of `node` (records in node order: the number of
// augmented nodes before it), 0 if none. The rank follows the depths in `depths`: per 64
// nodes, the bits' low and high words and the count of the blocks before.
fn find_aug(node: u32) -> u32 {
    let k = meta_.counts.z + 3u * (node / 64u);
    let b = node % 64u;
    let lo = depths[k];
    let hi = depths[k + 1u];
    var n = depths[k + 2u];
    var bit = 0u;
    if b < 32u {
        bit = (lo >> b) & 1u;
        n += countOneBits(lo & ((1u << b) - 1u));
    } else {
        bit = (hi >> (b - 32u)) & 1u;
        n += countOneBits(lo) + countOneBits(hi & ((1u << (b - 32u)) - 1u));
    }
    if bit == 0u {
        return 0u;
    }
    return n;
}

// traverse.rs `locate`, then `Ctx::start`: the start record of `r`.
fn start_record(r: Ray) -> u32 {
    if r.tmin != 0.0 {
        return 0u;
    }
    let o = r.origin;
    let root = aug[0];
    for (var a = 0u; a < 3u; a++) {
        if !(o[a] >= root.bmin[a] && o[a] <= root.bmax[a]) {
            return 0u;
        }
    }
    let period = meta_.counts.w;
    var idx = 0u;
    var d = 0u;
    var last = 0u;
    loop {
        let n = nodes[idx];
        if is_leaf(n) {
            break;
        }
        if d % period == 0u {
            last = idx;
        }
        let a = n.x & 3u;
        let s = bitcast<f32>(n.y);
        if o[a] < s {
            idx = idx + 1u;
        } else if o[a] > s {
            idx = n.x >> 2u;
        } else {
            break;
        }
        d += 1u;
    }
    let h = find_aug(last);
    if h == 0u {
        return 0u;
    }
    let b = aug[h];
    for (var a = 0u; a < 3u; a++) {
        let lo = o[a] > b.bmin[a] || (b.bmin[a] == root.bmin[a] && o[a] >= b.bmin[a]);
        let hi = o[a] < b.bmax[a] || (b.bmax[a] == root.bmax[a] && o[a] <= b.bmax[a]);
        if !(lo && hi) {
            return 0u;
        }
    }
    return h;
}

// traverse.rs `Ctx::interval`: the slab interval of record `k`'s cell, root faces standing for
// the root interval [r0, r1].
fn interval(rb: RayBox, r0: f32, r1: f32, k: u32) -> vec2<f32> {
    let b = aug[k];
    let root = aug[0];
    var tn = r0;
    var tf = r1;
    for (var a = 0u; a < 3u; a++) {
        var np = b.bmin[a];
        var fp = b.bmax[a];
        var rn = root.bmin[a];
        var rf = root.bmax[a];
        if rb.neg[a] {
            np = b.bmax[a];
            fp = b.bmin[a];
            rn = root.bmax[a];
            rf = root.bmin[a];
        }
        if np != rn {
            tn = max_num(tn, (np - rb.org[a]) * rb.inv[a]);
        }
        if fp != rf {
            tf = min_num(tf, (fp - rb.org[a]) * rb.inv[a]);
        }
    }
    return vec2<f32>(tn, tf);
}

fn walk(r: Ray, st: ptr<function, Stats>) -> Hit {
    if meta_.counts.y == 0u {
        return miss();
    }
    let p = meta_.counts.w;
    let cap = hw(11u);
    let rb = ray_box(r);
    (*st).boxes += 1u;
    let root = aug[0];
    let rs = slab(rb, root.bmin, root.bmax, r.tmin, r.tmax);
    if !(rs.x <= rs.y) {
        return miss();
    }
    let r0 = rs.x;
    let r1 = rs.y;
    let pre = prepare(r);
    var best = Hit(r.tmax, MISS_PRIM, 0.0, 0.0);
    var stt = 0u;
    if START {
        stt = start_record(r);
    }
    var top = stt;
    var dtop = depths[stt];
    var sn = r0;
    var sf = r1;
    if stt != 0u {
        (*st).boxes += 1u;
        let iv = interval(rb, r0, r1, stt);
        sn = iv.x;
        sf = iv.y;
    }
    // The last augmented node passed: node, record (NONE: not looked up), depth, interval.
    var l_node = aug[stt].node;
    var l_rec = stt;
    var l_depth = dtop;
    var l_tn = sn;
    var l_tf = sf;
    var idx = aug[stt].node;
    var tn = sn;
    var tf = sf;
    var depth = dtop;
    var both = vec2<u32>(0u, 0u);
    var in_plane = false;
    var steps = 0u;
    loop {
        // TraverseDown to a leaf.
        loop {
            let n = nodes[idx];
            if is_leaf(n) {
                break;
            }
            if depth % p == 0u && idx != l_node {
                l_node = idx;
                l_rec = NONE;
                l_depth = depth;
                l_tn = tn;
                l_tf = tf;
            }
            steps += 1u;
            let d = counted_decide(idx, n, rb, tn, tf, st);
            if d.kind == NEAR_ONLY {
                idx = d.near;
            } else if d.kind == FAR_ONLY {
                idx = d.far;
            } else {
                in_plane = in_plane || d.far_tn < d.near_tf;
                both = bit_set(both, depth);
                idx = d.near;
                tf = d.near_tf;
            }
            depth += 1u;
        }
        steps += 1u;
        // The leaf.
        if leaf(nodes[idx], pre, r, &best, st) {
            return best;
        }
        if best.t < tf && !in_plane {
            break;
        }
        if steps >= cap {
            (*st).capped = 1u;
            break;
        }
        let lf = idx;
        (*st).restarts += 1u;
        // RestartTraversal.
        var done = false;
        var next = vec3<f32>(0.0);
        var next_idx = 0u;
        var at = 0u;
        loop {
            let live = keep_from(both, dtop);
            if live.x != 0u || live.y != 0u {
                let k = highest(live);
                both = keep_below(both, k);
                let dr = k / p * p;
                if dr != l_depth {
                    var rec = l_rec;
                    if rec == NONE {
                        rec = find_aug(l_node);
                    }
                    var dd = l_depth;
                    while dd > dr {
                        rec = aug[rec].parent;
                        dd -= p;
                        (*st).ups += 1u;
                        (*st).interior += 1u;
                    }
                    (*st).boxes += 1u;
                    let iv = interval(rb, r0, r1, rec);
                    l_node = aug[rec].node;
                    l_rec = rec;
                    l_depth = dr;
                    l_tn = iv.x;
                    l_tf = iv.y;
                }
                // Down toward the last leaf to depth k.
                var x = l_node;
                var xn = l_tn;
                var xf = l_tf;
                var xd = l_depth;
                var found = false;
                var f = vec3<f32>(0.0);
                var f_idx = 0u;
                loop {
                    let w = toward_leaf(x, lf, rb, xn, xf, st);
                    let d = w.d;
                    let toward = w.toward;
                    steps += 1u;
                    if xd == k {
                        found = d.kind == BOTH && toward == d.near;
                        f_idx = d.far;
                        f = vec3<f32>(d.far_tn, xf, 0.0);
                        break;
                    }
                    if d.kind == BOTH {
                        if toward == d.near {
                            xf = d.near_tf;
                        } else {
                            xn = d.far_tn;
                        }
                    }
                    x = toward;
                    xd += 1u;
                }
                if found && (ANY || f.x <= best.t) {
                    next_idx = f_idx;
                    next = f;
                    at = k + 1u;
                    break;
                }
                continue;
            }
            if top == 0u {
                done = true;
                break;
            }
            // TraverseUp above the known part.
            let pr = aug[top].parent;
            (*st).ups += 1u;
            (*st).interior += 1u;
            (*st).boxes += 1u;
            let dp = dtop - p;
            let piv = interval(rb, r0, r1, pr);
            var x = aug[pr].node;
            var xn = piv.x;
            var xf = piv.y;
            var xd = dp;
            var has = false;
            var c_idx = 0u;
            var c = vec3<f32>(0.0);
            var ck = 0u;
            while xd < dtop {
                let w = toward_leaf(x, lf, rb, xn, xf, st);
                let d = w.d;
                let toward = w.toward;
                steps += 1u;
                if d.kind == BOTH {
                    in_plane = in_plane || d.far_tn < d.near_tf;
                    if toward == d.near {
                        both = bit_set(both, xd);
                        has = true;
                        c_idx = d.far;
                        c = vec3<f32>(d.far_tn, xf, 0.0);
                        ck = xd;
                        xf = d.near_tf;
                    } else {
                        xn = d.far_tn;
                    }
                }
                x = toward;
                xd += 1u;
            }
            top = pr;
            dtop = dp;
            l_node = aug[pr].node;
            l_rec = pr;
            l_depth = dp;
            l_tn = piv.x;
            l_tf = piv.y;
            if has && (ANY || c.x <= best.t) {
                both = keep_below(both, ck);
                next_idx = c_idx;
                next = c;
                at = ck + 1u;
                break;
            }
        }
        if done {
            break;
        }
        idx = next_idx;
        tn = next.x;
        tf = next.y;
        depth = at;
    }
    return answer(best);
}
