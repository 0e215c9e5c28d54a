// A program without a ray key traces the rays of a dispatch in their order.
fn ray_index(i: u32) -> u32 { return i; }
