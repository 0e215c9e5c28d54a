// The uniform grid's `dda` (Amanatides and Woo 1987; with macro regions, Devillers 1989),
// program `uniform-grid/dda` on grid.wgsl: tb_grid's UniformGrid::dda cell for cell.
// Buffers: the lattice (`hdr`, then word 15: 1 when macro regions are built), the cell ranges
// (`start`), the references (`refs`) and the macro regions (6 words per cell: lo, hi; one
// unused word without them). Counters: cells and steps per cell visited, prims per test.

@group(0) @binding(6) var<storage, read> start: array<u32>;
@group(0) @binding(7) var<storage, read> refs: array<u32>;
@group(0) @binding(8) var<storage, read> macros: array<u32>;

fn walk(r: Ray, st: ptr<function, Stats>) -> Hit {
    let l = lattice(0u);
    let w = clip(r, l);
    if !w.ok {
        return miss();
    }
    if far(l, r) {
        return brute_force(r, st);
    }
    let with_macros = hw(15u) != real(0.0);
    let p = prepare(r);
    var best = no_hit(r);
    var v = voxel_at(w, l, w.t0);
    let line = voxel_line(w, l);
    loop {
        (*st).cells += 1u;
        (*st).steps += 1u;
        let i = index(l, v);
        let b = start[i];
        let e = start[i + 1u];
        if test_refs(p, r, b, e, &best, st) {
            break;
        }
        var lo = v;
        var hi = v + vec3<u32>(1u);
        if b == e && with_macros {
            let m = 6u * i;
            lo = vec3<u32>(macros[m], macros[m + 1u], macros[m + 2u]);
            hi = vec3<u32>(macros[m + 3u], macros[m + 4u], macros[m + 5u]);
        }
        let n = next_voxel(w, l, line, best.t, v, lo, hi);
        if !n.ok {
            break;
        }
        v = n.v;
    }
    return record(best);
}
