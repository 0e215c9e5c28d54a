// `all_lanes` of `bvh/while-while-speculative` (while_while.wgsl): true when `b` holds on every
// active lane of the subgroup (Aila and Laine 2009's speculative traversal, their `__all`
// vote, on a WGSL subgroup: 32 lanes on NVIDIA, 8 on lavapipe). tb-gpu opens the device with
// subgroups where the adapter has them (tb_core::GpuProgram::needs_subgroups).
fn all_lanes(b: bool) -> bool {
    return subgroupAll(b);
}
