// The entry point of a program traced one thread per ray (tb-gpu appends it after the
// program's source): thread `i` of the dispatch traces its ray `i` (prelude.wgsl `trace_ray`).
@compute @workgroup_size(WORKGROUP_SIZE)
fn main(@builtin(global_invocation_id) gid: vec3<u32>,
        @builtin(local_invocation_index) lane: u32) {
    LANE = lane;
    if gid.x < arrayLength(&rays) {
        trace_ray(gid.x);
    }
}
