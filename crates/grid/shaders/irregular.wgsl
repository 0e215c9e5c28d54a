// The irregular grid's `walk` (Pérard-Gayot et al. 2017 §5), program `irregular-grid/walk` on
// grid.wgsl: tb_grid's IrregularGrid::walk cell for cell: on the virtual base grid, the cell
// of the current voxel from the two-level voxel map, the exit through the far planes of the
// cell's box and the monotone advance, then its references (hagrid's order). Buffers: the
// base lattice (`hdr`, then value 15: the deepest octree level D_max), the voxel map (`vmap`:
// per top cell `D << 28 | index` of its second level, then the second levels), the cells
// (`cells`, 8 words each: lo, begin, hi, end, read as two 16-byte loads) and the references
// (`refs`).
// `TIES` (a constant the program's source declares first): program
// `irregular-grid/walk-hagrid`, the authors' step (grid.wgsl's advance_ties) instead of the
// monotone advance.
// Counters: cells and steps per cell visited, prims per test.

@group(0) @binding(6) var<storage, read> vmap: array<u32>;
@group(0) @binding(7) var<storage, read> cells: array<vec4<u32>>;
@group(0) @binding(8) var<storage, read> refs: array<u32>;

// IrregularGrid::lookup: the cell holding base voxel `v` (two dependent reads, §5 step a).
fn lookup(top_res: vec3<u32>, dmax: u32, v: vec3<u32>) -> u32 {
    let t = v >> vec3<u32>(dmax);
    let e = vmap[t.x + top_res.x * (t.y + top_res.y * t.z)];
    let d = e >> 28u;
    let first = e & 0x0fffffffu;
    let mask = (1u << dmax) - 1u;
    let s = (v & vec3<u32>(mask)) >> vec3<u32>(dmax - d);
    return vmap[first + (s.x | (s.y << d) | (s.z << (2u * d)))];
}

fn walk(r: Ray, st: ptr<function, Stats>) -> Hit {
    let base = lattice(0u);
    let w = clip(r, base);
    if !w.ok {
        return miss();
    }
    if far(base, r) {
        return brute_force(r, st);
    }
    let dmax = u32(hw(15u));
    let top_res = base.res >> vec3<u32>(dmax);
    let p = prepare(r);
    var best = no_hit(r);
    var v = voxel_at(w, base, w.t0);
    let line = voxel_line(w, base);
    loop {
        (*st).cells += 1u;
        (*st).steps += 1u;
        let c = 2u * lookup(top_res, dmax, v);
        let a = cells[c];
        let b = cells[c + 1u];
        let lo = a.xyz;
        let hi = b.xyz;
        // The authors' step order (hagrid's traversal): the exit and the next voxel before
        // the cell's references, which they do not depend on; then the tests of the walk's
        // end, after the references, as the CPU walk makes them (the same cells and counts).
        let x = exit(w, base, lo, hi);
        var n: Next;
        if TIES {
            n = advance_ties(w, base, line, x, v, lo, hi);
        } else {
            n = advance(w, base, line, x.t, x.axis, v, lo, hi);
        }
        if test_refs(p, r, a.w, b.w, &best, st) {
            break;
        }
        if !goes_on(best.t, x, w) || !n.ok {
            break;
        }
        v = n.v;
    }
    return record(best);
}
