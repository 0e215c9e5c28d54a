// Leaves as ranges of a leaf-ordered triangle array, with the map back to scene indices: the
// part the BVH's (tb_bvh: bvh.wgsl, wide.wgsl) and the R-tree's (tb_rtree) GPU programs share,
// written once (tb_core::gpu::LEAF_RANGES, included with GpuProgram::include after tb-gpu's
// prelude). The including program declares `prim_ids: array<u32>` (leaf slot -> scene
// triangle index).

// The closest hit so far: t, slot in the leaf-ordered triangles (MISS_PRIM: none), u, v.
struct Best { t: f32, slot: u32, u: f32, v: f32 }

fn no_best(r: Ray) -> Best {
    return Best(r.tmax, MISS_PRIM, 0.0, 0.0);
}

fn record(b: Best) -> Hit {
    if b.slot == MISS_PRIM {
        return miss();
    }
    return Hit(b.t, prim_ids[b.slot], b.u, b.v);
}

// The triangles of a leaf, slots first .. first + count, tested as the CPU leaves of tb_bvh
// and tb_rtree test them: the leaf counted once, prims per leaf for the closest hit and per
// test for any hit. Returns true when ANY and a triangle was hit (then `*best` holds that hit).
fn leaf_range(first: u32, count: u32, p: Pre, r: Ray, best: ptr<function, Best>, st: ptr<function, Stats>) -> bool {
    (*st).leaves += 1u;
    if !ANY {
        (*st).prims += count;
    }
    for (var k = 0u; k < count; k++) {
        if ANY {
            (*st).prims += 1u;
        }
        let h = intersect(p, r, first + k, (*best).t);
        if h.w != 0.0 {
            *best = Best(h.x, first + k, h.y, h.z);
            if ANY {
                return true;
            }
        }
    }
    return false;
}
