// Brute force (tb_core::BruteForce, the oracle): every triangle in index order, each gated by
// the robust slab test of its own bounding box; one thread per ray. Counters as on the CPU:
// closest hit counts 1 leaf and `boxes = steps = triangles` up front, `prims` per box passed;
// any hit counts box, step and (box passed) prim per triangle until the first hit.

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if i >= arrayLength(&rays) {
        return;
    }
    let r = rays[i];
    let n = meta_.counts.x;
    let p = prepare(r);
    let rb = ray_box(r);
    var st = zero_stats();
    var best = miss();
    var tmax = r.tmax;
    st.leaves = 1u;
    if !ANY {
        st.boxes = n;
        st.steps = n;
    }
    for (var k = 0u; k < n; k++) {
        let v0 = vertex(k, 0u);
        let v1 = vertex(k, 1u);
        let v2 = vertex(k, 2u);
        if ANY {
            st.boxes += 1u;
            st.steps += 1u;
        }
        let s = slab(rb, min(min(v0, v1), v2), max(max(v0, v1), v2), r.tmin, tmax);
        if !(s.x <= s.y) {
            continue;
        }
        st.prims += 1u;
        let h = intersect(p, r, k, tmax);
        if h.w != 0.0 {
            best = Hit(h.x, k, h.y, h.z);
            if ANY {
                break;
            }
            tmax = h.x;
        }
    }
    hits[i] = best;
    if COUNT {
        stats[i] = st;
    }
}
