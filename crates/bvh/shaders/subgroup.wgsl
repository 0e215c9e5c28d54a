// A lane's view of its subgroup (32 lanes on NVIDIA, 8 on lavapipe) in the programs with the
// authors' warp votes: `bvh/while-while-speculative` and `cwbvh/node-groups-postponing`.
// tb-gpu opens the device with subgroups where the adapter has them
// (tb_core::GpuProgram::needs_subgroups). Its twin for the CPU walk's order is solo.wgsl.

// `all_lanes` (while_while.wgsl): true when `b` holds on every active lane of the subgroup
// (Aila and Laine 2009's speculative traversal, their `__all` vote).
fn all_lanes(b: bool) -> bool {
    return subgroupAll(b);
}

// `active_lanes` (cwbvh.wgsl): the subgroup's active lanes (Ylitie, Karras and Laine 2017 §4's
// `__popc(__activemask())` for triangle postponing), from a ballot of every active lane.
fn active_lanes() -> u32 {
    let b = subgroupBallot(true);
    return countOneBits(b.x) + countOneBits(b.y) + countOneBits(b.z) + countOneBits(b.w);
}
