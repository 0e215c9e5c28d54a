// Brute force (tb_core::BruteForce, the oracle), program `brute-force/linear` on tb-gpu's
// prelude (tb_core::gpu): every triangle in index order given to the triangle test, nothing in
// front of it; one thread per ray. No buffers of its own: the triangles are the prelude's
// `tris`, their count `meta_.counts.x`. Counters as on the CPU: closest hit counts 1 leaf and
// `steps = prims = triangles` up front; any hit counts a step and a prim per triangle until
// the first hit.
//
// The loop is unrolled by UNROLL: llvmpipe (lavapipe) ends a shader invocation's loops after
// 65535 iterations in all, so a plain loop would stop early on scenes of more triangles; the
// host refuses it on llvmpipe beyond UNROLL * 65000 triangles (GpuProgram::
// unrolled_triangle_loop, which must equal UNROLL).

const UNROLL: u32 = 8u;

// The walk's state, updated by `visit`.
struct Walk { best: Hit, tmax: f32, st: Stats, done: bool }

fn visit(k: u32, r: Ray, p: Pre, w: ptr<function, Walk>) {
    if (*w).done {
        return;
    }
    if ANY {
        (*w).st.steps += 1u;
        (*w).st.prims += 1u;
    }
    let h = intersect(p, r, k, (*w).tmax);
    if h.w != 0.0 {
        (*w).best = Hit(h.x, k, h.y, h.z);
        if ANY {
            (*w).done = true;
        } else {
            (*w).tmax = h.x;
        }
    }
}

// The program's entry, called by the prelude's `trace_ray` once per ray with zeroed counters.
fn walk(r: Ray, st: ptr<function, Stats>) -> Hit {
    let n = meta_.counts.x;
    let p = prepare(r);
    var w = Walk(miss(), r.tmax, zero_stats(), false);
    w.st.leaves = 1u;
    if !ANY {
        w.st.steps = n;
        w.st.prims = n;
    }
    let whole = n / UNROLL * UNROLL;
    for (var k = 0u; k < whole && !w.done; k += UNROLL) {
        visit(k, r, p, &w);
        visit(k + 1u, r, p, &w);
        visit(k + 2u, r, p, &w);
        visit(k + 3u, r, p, &w);
        visit(k + 4u, r, p, &w);
        visit(k + 5u, r, p, &w);
        visit(k + 6u, r, p, &w);
        visit(k + 7u, r, p, &w);
    }
    for (var k = whole; k < n && !w.done; k++) {
        visit(k, r, p, &w);
    }
    *st = w.st;
    return w.best;
}
