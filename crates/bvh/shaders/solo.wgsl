// A lane's view of its subgroup in the programs that run in the CPU walk's order
// (`bvh/while-while`, `cwbvh/node-groups`): a subgroup of one, the lane itself. Its twin with a
// real subgroup is subgroup.wgsl.

// `all_lanes` (while_while.wgsl): the lane's own value, so that a leaf is tested as soon as it
// is reached.
fn all_lanes(b: bool) -> bool {
    return b;
}

// `active_lanes` (cwbvh.wgsl): one, so no lane's triangles are ever postponed.
fn active_lanes() -> u32 {
    return 1u;
}
