// `all_lanes` of `bvh/while-while` (while_while.wgsl): the lane's own value, a subgroup of one,
// so that a leaf is tested as soon as it is reached (the CPU walk's order).
fn all_lanes(b: bool) -> bool {
    return b;
}
