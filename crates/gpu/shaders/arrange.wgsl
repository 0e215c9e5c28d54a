// The ray arrangement of a program with a ray key (tb_core::gpu, "Ray arrangement by key";
// Torres et al. 2012 §6: rays sorted by tree index with a counting sort before traversal): a
// stable counting sort of one dispatch's ray indices by `ray_key`, in three passes of
// WORKGROUP_SIZE threads, then `main` traces ray `ray_index(i)` in thread `i`.
//
// `arrange_` (group 1) holds, for the dispatch bound, the histogram `count[k * G + w]` (rays of
// key k in workgroup w, G workgroups; key-major, so its exclusive scan gives each
// (key, workgroup) its first place in the sorted order) padded to a multiple of 64 words, then
// the permutation `perm[p]`: the dispatch-local index of the ray traced p-th.
//   tb_histogram (G workgroups): count keys per workgroup;
//   tb_scan (1 workgroup): exclusive scan of the K * G counts in place;
//   tb_scatter (G workgroups): perm[start(key, w) + rank] = i, the rank being the number of
//     rays of the same key before ray i in its workgroup (so equal keys keep their order).
// The host prepends `const KEYS: u32` (GpuArrange::keys, at most WORKGROUP_SIZE) with the
// prelude.

@group(1) @binding(0) var<storage, read_write> arrange_: array<u32>;

var<workgroup> tb_count: array<atomic<u32>, KEYS>;
var<workgroup> tb_keys: array<u32, WORKGROUP_SIZE>;
var<workgroup> tb_sums: array<u32, WORKGROUP_SIZE>;

// Workgroups of the dispatch (rays bound: the dispatch's range).
fn tb_groups() -> u32 {
    return (arrayLength(&rays) + WORKGROUP_SIZE - 1u) / WORKGROUP_SIZE;
}

// Where the permutation starts: after the K * G counts, padded to 64 words (256 bytes).
fn tb_perm_base() -> u32 {
    return (KEYS * tb_groups() + 63u) / 64u * 64u;
}

// Ray i's key, clamped to KEYS - 1.
fn tb_key(i: u32) -> u32 {
    return min(ray_key(rays[i]), KEYS - 1u);
}

fn ray_index(i: u32) -> u32 {
    return arrange_[tb_perm_base() + i];
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn tb_histogram(@builtin(local_invocation_id) lid: vec3<u32>, @builtin(workgroup_id) wid: vec3<u32>) {
    let l = lid.x;
    if l < KEYS {
        atomicStore(&tb_count[l], 0u);
    }
    workgroupBarrier();
    let i = wid.x * WORKGROUP_SIZE + l;
    if i < arrayLength(&rays) {
        atomicAdd(&tb_count[tb_key(i)], 1u);
    }
    workgroupBarrier();
    if l < KEYS {
        arrange_[l * tb_groups() + wid.x] = atomicLoad(&tb_count[l]);
    }
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn tb_scan(@builtin(local_invocation_id) lid: vec3<u32>) {
    let l = lid.x;
    let total = KEYS * tb_groups();
    let per = (total + WORKGROUP_SIZE - 1u) / WORKGROUP_SIZE;
    let lo = min(l * per, total);
    let hi = min(lo + per, total);
    var sum = 0u;
    for (var j = lo; j < hi; j++) {
        sum += arrange_[j];
    }
    tb_sums[l] = sum;
    workgroupBarrier();
    if l == 0u {
        var acc = 0u;
        for (var t = 0u; t < WORKGROUP_SIZE; t++) {
            let s = tb_sums[t];
            tb_sums[t] = acc;
            acc += s;
        }
    }
    workgroupBarrier();
    var acc = tb_sums[l];
    for (var j = lo; j < hi; j++) {
        let c = arrange_[j];
        arrange_[j] = acc;
        acc += c;
    }
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn tb_scatter(@builtin(local_invocation_id) lid: vec3<u32>, @builtin(workgroup_id) wid: vec3<u32>) {
    let l = lid.x;
    let i = wid.x * WORKGROUP_SIZE + l;
    let inside = i < arrayLength(&rays);
    var key = KEYS;
    if inside {
        key = tb_key(i);
    }
    tb_keys[l] = key;
    workgroupBarrier();
    if inside {
        var rank = 0u;
        for (var t = 0u; t < l; t++) {
            rank += select(0u, 1u, tb_keys[t] == key);
        }
        arrange_[tb_perm_base() + arrange_[key * tb_groups() + wid.x] + rank] = i;
    }
}
