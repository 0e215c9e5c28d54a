// The two-level grid's `dda` (Kalojanov et al. 2011 §4), program `two-level-grid/dda` on
// grid.wgsl: tb_grid's TwoLevelGrid::dda cell for cell: the walk over the top level, and in
// each top cell that is not a single empty leaf the walk over its own grid, clipped to it.
// Buffers: the top lattice (`hdr`), the top cells (`tops`, 2 words each, one 8-byte load:
// first leaf, resolution `rx | ry << 8 | rz << 16`), the leaf ranges (`start`) and the references
// (`refs`). Counters: cells and steps per top and leaf cell, interior per top cell, leaves per
// leaf cell, prims per test.

@group(0) @binding(6) var<storage, read> tops: array<vec2<u32>>;
@group(0) @binding(7) var<storage, read> start: array<u32>;
@group(0) @binding(8) var<storage, read> refs: array<u32>;

// two_level::sub_lattice: the grid of top cell `v` at resolution `res`.
fn sub_lattice(top: Lat, v: vec3<u32>, res: vec3<u32>) -> Lat {
    var l = top;
    let one = real(1.0);
    for (var a = 0u; a < 3u; a++) {
        l.size[a] = top.size[a] / real(res[a]);
        l.lo[a] = plane(top, a, v[a]);
        l.inv[a] = one / l.size[a];
    }
    l.res = res;
    return l;
}

// The walk over the leaves of one top cell; true when ANY and a hit was found.
fn walk_leaves(w: WalkRay, sub: Lat, first: u32, p: Pre, r: Ray, best: ptr<function, Hit>, st: ptr<function, Stats>) -> bool {
    var u = voxel_at(w, sub, w.t0);
    let line = voxel_line(w, sub);
    loop {
        (*st).cells += 1u;
        (*st).leaves += 1u;
        (*st).steps += 1u;
        let li = first + index(sub, u);
        if test_refs(p, r, start[li], start[li + 1u], best, st) {
            return true;
        }
        let hi = u + vec3<u32>(1u);
        let n = next_voxel(w, sub, line, (*best).t, u, u, hi);
        if !n.ok {
            return false;
        }
        u = n.v;
    }
    return false;
}

fn walk(r: Ray, st: ptr<function, Stats>) -> Hit {
    let top = lattice(0u);
    let w = clip(r, top);
    if !w.ok {
        return miss();
    }
    if far(top, r) {
        return brute_force(r, st);
    }
    let p = prepare(r);
    var best = no_hit(r);
    var v = voxel_at(w, top, w.t0);
    let line = voxel_line(w, top);
    loop {
        (*st).cells += 1u;
        (*st).interior += 1u;
        (*st).steps += 1u;
        let t = tops[index(top, v)];
        let first = t.x;
        let rw = t.y;
        let res = vec3<u32>(rw & 0xffu, (rw >> 8u) & 0xffu, (rw >> 16u) & 0xffu);
        let single_empty = all(res == vec3<u32>(1u)) && start[first] == start[first + 1u];
        if !single_empty {
            let sub = sub_lattice(top, v, res);
            let ws = clip_near(w, sub);
            if ws.ok && walk_leaves(ws, sub, first, p, r, &best, st) {
                break;
            }
        }
        let hi = v + vec3<u32>(1u);
        let n = next_voxel(w, top, line, best.t, v, v, hi);
        if !n.ok {
            break;
        }
        v = n.v;
    }
    return record(best);
}
