// The part shared by the R-tree's GPU programs (tb_rtree, Feldmann 2015 section 4; the
// traversals follow in stackless.wgsl, ordered.wgsl and stack.wgsl), on tb-gpu's prelude
// (tb_core::gpu) and the leaf ranges it includes (tb_core::gpu::LEAF_RANGES).
//
// The packed level-order array of section 4 (Figure 4): a complete M-ary tree of N slots,
// empty slots included, root first; slot n has its entries at M*n + 1 .. M*n + M (the paper's
// n_e), its parent at (n - 1) / M (n_p). The paper keeps the first slot of every level,
// Delta_L(l), and the root level L in CUDA constant memory; in the complete layout
// n_e(n) = (n - Delta_L(l)) * M + Delta_L(l - 1) = M * n + 1 on every level, so only
// Delta_L(0) (is a slot a leaf?) and L remain, and they sit in the meta_ uniform, WGSL's
// counterpart of constant memory (uniform address space):
//   meta_.counts.y = N (slots), .z = Delta_L(0) (first leaf slot), .w = L (root level).
// M is an override constant (one program per M, so that `/ M` is a constant division and the
// stacks get their exact size).

// tb_rtree::RtreeNode, 32 bytes. Intermediate node: `count` entries at M*n + 1 ..; leaf:
// triangles index .. index + count of the leaf-ordered triangle array (the prelude's `tris`);
// empty slot: count == 0 (and the empty box).
struct Node { bmin: vec3<f32>, index: u32, bmax: vec3<f32>, count: u32 }

@group(0) @binding(5) var<storage, read> nodes: array<Node>;     // GpuProgram::buffers[0]
@group(0) @binding(6) var<storage, read> prim_ids: array<u32>;   // GpuProgram::buffers[1]

override M: u32 = 4u;   // RtreeParams::big_m (GpuProgram::constants)

// The root's box test that opens the stack-based walks (ordered.wgsl, stack.wgsl), counted as
// tb_rtree's CPU walks count it: one box, then one step when the root is entered. False for an
// empty tree (nothing counted) or a ray that misses the root's box.
fn enter_root(r: Ray, rb: RayBox, st: ptr<function, Stats>) -> bool {
    if meta_.counts.y == 0u {
        return false;
    }
    (*st).boxes += 1u;
    let root = nodes[0];
    let rs = slab(rb, root.bmin, root.bmax, r.tmin, r.tmax);
    if !(rs.x <= rs.y) {
        return false;
    }
    (*st).steps += 1u;
    return true;
}
