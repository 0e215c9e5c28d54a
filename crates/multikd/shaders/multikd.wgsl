// Multi-kd-tree `recursive-direction` (tb_kdtree::multi; Torres et al. 2012 §5-6 on the kd-tree
// review's Alg. 2), program `multi-kd/recursive-direction`: shaders/kd.wgsl (nodes, references,
// header, `recursive`) then this file, on tb-gpu's prelude (tb_core::gpu):
// each ray picks its tree by the paper's rule (header word 3: 0 SAH, 1 cube mapping, 2 spherical
// patches), starts at that tree's root (header words 0..2), clips itself to the root cell
// (words 5..10) and walks the stack traversal exactly as the CPU kernel (traverse.rs,
// `RecursiveDirection` and `decide`): near/far by the sign of the reciprocal direction, the far
// child pushed with its entry and exit distances when the plane distance lies in the interval
// (SLACK), pending entries skipped when they start beyond the closest hit. Counters as the CPU:
// boxes 1 (the root cell), interior/planes/steps per interior node, leaves/steps per leaf, prims
// per triangle test. One thread per ray. The programs `multi-kd/recursive-direction-sorted`
// (the `-sorted` and `-presorted` rows) are the same walk, the rays of each dispatch first sorted
// by tree index (`ray_key`) by tb-gpu's sort pass.

// measure::Heuristic::pick, operation for operation.
fn pick(d: vec3<f32>) -> u32 {
    let rule = hw(3u);
    let a = abs(d);
    if rule == 0u {
        return 0u;
    }
    if rule == 1u {
        if a.x >= a.y && a.x >= a.z {
            return 0u;
        } else if a.y >= a.z {
            return 1u;
        }
        return 2u;
    }
    let len2 = (d.x * d.x + d.y * d.y) + d.z * d.z;
    if (9.0 * d.z) * d.z >= 4.0 * len2 {
        return 2u;
    } else if a.x >= a.y {
        return 0u;
    }
    return 1u;
}

// The ray key of the `-sorted` / `-presorted` programs (tb_core::gpu, "Ray arrangement by
// key"): the tree index, as MultiKdTree::arrange sorts by (§6's 2-bit key; 3 keys).
fn ray_key(r: Ray) -> u32 {
    return pick(r.dir);
}

fn walk(r: Ray, st: ptr<function, Stats>) -> Hit {
    return recursive(r, hw(pick(r.dir)), st);
}
