// The wide BVH `ordered` traversal (tb_bvh::wide, Wald, Benthin and Boulos 2008), programs
// `bvh/ordered-w4` and `bvh/ordered-w8` on tb-gpu's prelude (tb_core::gpu) and the leaf ranges
// (tb_core::gpu::LEAF_RANGES): depth-first with a fixed stack (STACK_SIZE =
// tb_bvh::WIDE_STACK_SIZE); at a node every child box is tested
// with the prelude's slab test (the CPU's SIMD lanes compute the same operations), the hit
// children sorted by entry distance (insertion sort, ties in slot order), the nearest visited
// next and the others pushed farthest first; any-hit queries push in slot order without
// sorting. It visits the nodes in exactly the CPU's order, so the counters agree ray for ray:
// boxes (1 for the root, then one per used slot of each interior node visited), interior,
// leaves, prims, steps = interior + leaves. One thread per ray.

// tb_bvh::WideNode<WIDTH>, 8·WIDTH words: min rows x, y, z (WIDTH floats each), max rows,
// child[WIDTH], count[WIDTH] (0: interior child node, > 0: leaf of `count` triangles from
// `child`, EMPTY: unused slot). The node count is `meta_.counts.y` (GpuProgram::meta[0]).
override WIDTH: u32 = 8u;
const EMPTY: u32 = 0xffffffffu;

@group(0) @binding(5) var<storage, read> wnodes: array<u32>;     // GpuProgram::buffers[0]
@group(0) @binding(6) var<storage, read> prim_ids: array<u32>;   // GpuProgram::buffers[1]
// The binary root (tb_bvh::BvhNode, 32 bytes: min, index, max, count), a uniform buffer (the
// same for every ray): its box is tested first, as on the CPU.
@group(0) @binding(7) var<uniform> root_node: array<vec4<f32>, 2>;  // GpuProgram::buffers[2]

fn wf(i: u32) -> f32 {
    return bitcast<f32>(wnodes[i]);
}

fn is_nan(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7fffffffu) > 0x7f800000u;
}

fn walk(r: Ray, st: ptr<function, Stats>) -> Hit {
    if meta_.counts.y == 0u {
        return miss();
    }
    if is_nan(r.origin.x) || is_nan(r.origin.y) || is_nan(r.origin.z) || is_nan(r.dir.x)
        || is_nan(r.dir.y) || is_nan(r.dir.z) {
        return miss();
    }
    let rb = ray_box(r);
    let tmin = r.tmin;
    var best = no_best(r);
    (*st).boxes += 1u;
    let rmin = root_node[0].xyz;
    let rmax = root_node[1].xyz;
    let rs = slab(rb, rmin, rmax, tmin, best.t);
    if !(rs.x <= rs.y) {
        return miss();
    }
    let p = prepare(r);
    // Pending children: (node index or first triangle, triangle count) and entry distance.
    var stack: array<vec2<u32>, STACK_SIZE>;
    var stack_t: array<f32, STACK_SIZE>;
    var sp = 0u;
    var cur = vec2<u32>(0u, 0u);
    var hit_t: array<f32, 8>;
    var hit_i: array<u32, 8>;
    loop {
        if cur.y == 0u {
            (*st).interior += 1u;
            (*st).steps += 1u;
            let base = cur.x * 8u * WIDTH;
            var k = 0u;
            for (var s = 0u; s < WIDTH; s++) {
                let cnt = wnodes[base + 7u * WIDTH + s];
                if cnt == EMPTY {
                    continue;
                }
                (*st).boxes += 1u;
                let bmin = vec3<f32>(wf(base + s), wf(base + WIDTH + s), wf(base + 2u * WIDTH + s));
                let bmax = vec3<f32>(
                    wf(base + 3u * WIDTH + s),
                    wf(base + 4u * WIDTH + s),
                    wf(base + 5u * WIDTH + s)
                );
                let h = slab(rb, bmin, bmax, tmin, best.t);
                if !(h.x <= h.y) {
                    continue;
                }
                if ANY || k == 0u {
                    hit_t[k] = h.x;
                    hit_i[k] = s;
                } else {
                    // Insertion by entry distance, stable for ties (slot order).
                    var j = k;
                    loop {
                        if j == 0u || !(hit_t[j - 1u] > h.x) {
                            break;
                        }
                        hit_t[j] = hit_t[j - 1u];
                        hit_i[j] = hit_i[j - 1u];
                        j -= 1u;
                    }
                    hit_t[j] = h.x;
                    hit_i[j] = s;
                }
                k += 1u;
            }
            if k > 0u {
                if ANY {
                    for (var j = 1u; j < k; j++) {
                        let s = hit_i[j];
                        stack[sp] = vec2<u32>(wnodes[base + 6u * WIDTH + s], wnodes[base + 7u * WIDTH + s]);
                        stack_t[sp] = hit_t[j];
                        sp += 1u;
                    }
                } else {
                    for (var j = k - 1u; j >= 1u; j--) {
                        let s = hit_i[j];
                        stack[sp] = vec2<u32>(wnodes[base + 6u * WIDTH + s], wnodes[base + 7u * WIDTH + s]);
                        stack_t[sp] = hit_t[j];
                        sp += 1u;
                    }
                }
                let s = hit_i[0];
                cur = vec2<u32>(wnodes[base + 6u * WIDTH + s], wnodes[base + 7u * WIDTH + s]);
                continue;
            }
        } else {
            (*st).steps += 1u;
            if leaf_range(cur.x, cur.y, p, r, &best, st) {
                return record(best);
            }
        }
        // Pop the next pending child, skipping those entered beyond the closest hit.
        var popped = false;
        loop {
            if sp == 0u {
                break;
            }
            sp -= 1u;
            if ANY || stack_t[sp] <= best.t * EXIT_SCALE {
                cur = stack[sp];
                popped = true;
                break;
            }
        }
        if !popped {
            break;
        }
    }
    return record(best);
}
