// The pop of a depth-first walk's stack of (index, bits of the entry distance) entries, shared
// by the programs that keep one (tb_bvh's bvh.wgsl, tb_rtree's stack.wgsl), written once
// (tb_core::gpu::STACK_POP, included with GpuProgram::include; needs STACK_SIZE > 0).

// No pending entry left (pop_entered).
const NO_ENTRY: u32 = 0xffffffffu;

// Pop the next pending entry (index, bits of its entry distance) of a depth-first walk,
// skipping those entered beyond the closest hit `t` (scaled by EXIT_SCALE, as tb_core::slab's
// exit distances are; every entry when ANY, which ends at the first hit anyway): its index,
// or NO_ENTRY when the stack is empty.
fn pop_entered(stack: ptr<function, array<vec2<u32>, STACK_SIZE>>, sp: ptr<function, u32>, t: f32) -> u32 {
    while *sp > 0u {
        *sp -= 1u;
        let e = (*stack)[*sp];
        if ANY || bitcast<f32>(e.y) <= t * EXIT_SCALE {
            return e.x;
        }
    }
    return NO_ENTRY;
}
