// The compressed wide BVH's traversals (tb_bvh::cwbvh, module walk; Ylitie, Karras and Laine
// 2017 §4, Algorithm 1), programs `cwbvh/node-groups` and `cwbvh/node-groups-postponing` on
// tb-gpu's prelude (tb_core::gpu) and the leaf ranges (tb_core::gpu::LEAF_RANGES), traced with
// persistent threads (tb_core::GpuProgram::persistent). A stack of node groups (child base,
// child bits in 24..32 permuted by the ray's octant | imask in 0..8), a triangle group per node
// (its leaf hits, one bit per triangle from tri_base) tested lowest bit first before the next
// node. With solo.wgsl (`node-groups`) it visits the nodes in exactly the CPU's order, so the
// counters agree ray for ray: interior and steps per node intersected, boxes per used slot,
// leaves and steps per leaf slot hit, prims per triangle test. With subgroup.wgsl
// (`node-groups-postponing`) a lane postpones its triangle group (pushes it on the stack) while
// few lanes of its subgroup test triangles, so its counters depend on the subgroup.

// tb_bvh::CwNode, 80 bytes, five vec4<u32>:
//   0: p.x, p.y, p.z (f32), e.x | e.y << 8 | e.z << 16 | imask << 24
//   1: child_base, tri_base, meta[0..4], meta[4..8]
//   2: q_lo.x[0..4], q_lo.x[4..8], q_lo.y[0..4], q_lo.y[4..8]
//   3: q_lo.z[0..4], q_lo.z[4..8], q_hi.x[0..4], q_hi.x[4..8]
//   4: q_hi.y[0..4], q_hi.y[4..8], q_hi.z[0..4], q_hi.z[4..8]
// The node count is `meta_.counts.y` (GpuProgram::meta[0]).
@group(0) @binding(5) var<storage, read> cw: array<vec4<u32>>;   // GpuProgram::buffers[0]
@group(0) @binding(6) var<storage, read> prim_ids: array<u32>;    // GpuProgram::buffers[1]

const CHILD_BITS: u32 = 0xff000000u;
// Triangles are postponed while fewer than 1/POSTPONE_DIVISOR of the lanes active at a step's
// start test them: 20 %, the share reimplementations of the paper use (a constant here).
const POSTPONE_DIVISOR: u32 = 5u;

// Byte `k` (0..4) of word pair (a, b) for slot s: a for slots 0..4, b for 4..8.
fn slot_byte(a: u32, b: u32, s: u32) -> u32 {
    return (select(a, b, s >= 4u) >> (8u * (s & 3u))) & 0xffu;
}

fn scale_of(e: u32) -> f32 {
    return bitcast<f32>((e & 0xffu) << 23u);
}

fn walk(r: Ray, st: ptr<function, Stats>) -> Hit {
    if meta_.counts.y == 0u {
        return miss();
    }
    let rb = ray_box(r);
    let tmin = r.tmin;
    var best = no_best(r);
    let p = prepare(r);
    let oct = select(0u, 1u, rb.neg.x) | select(0u, 2u, rb.neg.y) | select(0u, 4u, rb.neg.z);
    let oct_inv = 7u ^ oct;
    var stack: array<vec2<u32>, STACK_SIZE>;
    var sp = 0u;
    // The root alone (imask 0). A group with child bits (24..32) is a node group; one without
    // is a triangle group set aside by postponing (tri_base, triangle bits in 0..24).
    var group = vec2<u32>(0u, 0x80000000u);
    loop {
        // The subgroup's active lanes as this step starts (one with solo.wgsl).
        let at_start = active_lanes();
        var tris = vec2<u32>(0u, 0u);
        if (group.y & CHILD_BITS) != 0u {
            let hits = group.y;
            let b = firstLeadingBit(hits & CHILD_BITS);
            let rest = hits & ~(1u << b);
            if (rest & CHILD_BITS) != 0u {
                stack[sp] = vec2<u32>(group.x, rest);
                sp += 1u;
            }
            let s0 = (b - 24u) ^ oct_inv;
            let index = group.x + countOneBits(hits & 0xffu & ((1u << s0) - 1u));
            let n0 = cw[5u * index];
            let n1 = cw[5u * index + 1u];
            let n2 = cw[5u * index + 2u];
            let n3 = cw[5u * index + 3u];
            let n4 = cw[5u * index + 4u];
            (*st).interior += 1u;
            (*st).steps += 1u;
            let origin = bitcast<vec3<f32>>(n0.xyz);
            let scale = vec3<f32>(scale_of(n0.w), scale_of(n0.w >> 8u), scale_of(n0.w >> 16u));
            let imask = n0.w >> 24u;
            var child_hits = 0u;
            var tri_hits = 0u;
            for (var s = 0u; s < 8u; s++) {
                let m = slot_byte(n1.z, n1.w, s);
                if m == 0u {
                    continue;
                }
                (*st).boxes += 1u;
                let qlo = vec3<u32>(slot_byte(n2.x, n2.y, s), slot_byte(n2.z, n2.w, s), slot_byte(n3.x, n3.y, s));
                let qhi = vec3<u32>(slot_byte(n3.z, n3.w, s), slot_byte(n4.x, n4.y, s), slot_byte(n4.z, n4.w, s));
                // p + q·scale: the product is exact, one rounding, as on the CPU.
                let lo = origin + vec3<f32>(qlo) * scale;
                let hi = origin + vec3<f32>(qhi) * scale;
                let h = slab(rb, lo, hi, tmin, best.t);
                if h.x <= h.y {
                    if (imask & (1u << s)) != 0u {
                        child_hits |= 1u << ((m & 31u) ^ oct_inv);
                    } else {
                        (*st).leaves += 1u;
                        (*st).steps += 1u;
                        tri_hits |= (m >> 5u) << (m & 31u);
                    }
                }
            }
            tris = vec2<u32>(n1.y, tri_hits);
            group = select(vec2<u32>(0u, 0u), vec2<u32>(n1.x, child_hits | imask), child_hits != 0u);
        } else {
            tris = group;
            group = vec2<u32>(0u, 0u);
        }
        while tris.y != 0u {
            // Triangle postponing (§4): while fewer than a fifth of the lanes active at the
            // step's start test triangles, this lane sets its triangle group aside on the stack
            // and walks on (never with solo.wgsl: one lane of one).
            if active_lanes() * POSTPONE_DIVISOR < at_start {
                stack[sp] = tris;
                sp += 1u;
                break;
            }
            let k = firstTrailingBit(tris.y);
            tris.y &= tris.y - 1u;
            let slot = tris.x + k;
            (*st).prims += 1u;
            let h = intersect(p, r, slot, best.t);
            if h.w != 0.0 {
                best = Best(h.x, slot, h.y, h.z);
                if ANY {
                    return record(best);
                }
            }
        }
        if (group.y & CHILD_BITS) == 0u {
            if sp == 0u {
                break;
            }
            sp -= 1u;
            group = stack[sp];
        }
    }
    return record(best);
}
