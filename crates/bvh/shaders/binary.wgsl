// The binary BVH programs' shared part (bvh.wgsl's `ordered`, while_while.wgsl's two), included
// before their source: the node, the bindings, and an interior node's sibling pair tested and
// counted as the CPU walks do (tb_bvh traverse.rs `children`).

// tb_bvh::BvhNode, 32 bytes, read as two 16-byte loads: interior (count == 0): index = left
// child, right = index + 1 (a sibling pair, 64 bytes: the two child boxes Aila and Laine's node
// holds); leaf: triangles index .. index + count of the leaf-ordered triangle array (the
// prelude's `tris`). The node count is `meta_.counts.y` (GpuProgram::meta[0]).
struct Node { bmin: vec3<f32>, index: u32, bmax: vec3<f32>, count: u32 }

@group(0) @binding(5) var<storage, read> nodes: array<Node>;     // GpuProgram::buffers[0]
@group(0) @binding(6) var<storage, read> prim_ids: array<u32>;   // GpuProgram::buffers[1]

// An interior node's children and their slabs against [tmin, tmax] (x: entry, y: exit; hit
// when x <= y).
struct Pair { a: Node, b: Node, sa: vec2<f32>, sb: vec2<f32> }

// The children of interior node `node`, counted: one interior node, one step, two boxes.
fn children(node: Node, rb: RayBox, tmin: f32, tmax: f32, st: ptr<function, Stats>) -> Pair {
    (*st).interior += 1u;
    (*st).steps += 1u;
    (*st).boxes += 2u;
    let a = nodes[node.index];
    let b = nodes[node.index + 1u];
    return Pair(a, b, slab(rb, a.bmin, a.bmax, tmin, tmax), slab(rb, b.bmin, b.bmax, tmin, tmax));
}
