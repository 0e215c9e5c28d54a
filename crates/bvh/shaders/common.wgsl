// The part shared by the BVH's GPU programs (bvh.wgsl, wide.wgsl; tb_bvh), on tb-gpu's
// prelude (tb_core::gpu). Each program declares `prim_ids` (the BVH's primitive-id array).

// The closest hit so far: t, slot in the leaf-ordered triangles (MISS_PRIM: none), u, v.
struct Best { t: f32, slot: u32, u: f32, v: f32 }

fn record(b: Best) -> Hit {
    if b.slot == MISS_PRIM {
        return miss();
    }
    return Hit(b.t, prim_ids[b.slot], b.u, b.v);
}

// A leaf of `count` triangles from slot `first`, tested as tb_bvh's CPU leaf does: leaves and
// steps counted once, prims per leaf for the closest hit and per test for any hit. Returns true
// when ANY and a triangle was hit (then `*best` holds that hit).
fn leaf(first: u32, count: u32, p: Pre, r: Ray, best: ptr<function, Best>, st: ptr<function, Stats>) -> bool {
    (*st).leaves += 1u;
    (*st).steps += 1u;
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
