// The entry point of a persistent program (tb_core::GpuProgram::persistent; Aila and Laine
// 2009, "persistent threads"), appended by tb-gpu after the program's source with
// POOL_BINDING replaced by the binding after the program's buffers. tb-gpu launches at most
// `Gpu::persistent_groups` workgroups, enough to fill a large GPU, and each fetches the next run
// of WORKGROUP_SIZE rays from the counter `tb_pool` until the dispatch's rays are all taken:
// the authors fetch per warp, here per workgroup (64 threads: two warps on NVIDIA).
//
// The counter is never reset between the dispatches of one compute pass (a sustained sample
// repeats the dispatch back to back); it counts fetches, and every dispatch makes the same
// number of them: one per run of rays, `ceil(n / WORKGROUP_SIZE)`, and one more per workgroup,
// the fetch that finds nothing left. Dispatches of one pass run one after another (they write
// the same hit buffer), so the fetches of the k-th all return values in [k·F, (k+1)·F), F
// that number, and `value % F` is the run. tb-gpu binds each dispatch chunk its own counter,
// zeroed per pass, and keeps passes × F within a u32.

@group(0) @binding(POOL_BINDING) var<storage, read_write> tb_pool: atomic<u32>;

// The run the workgroup traces next, fetched by its first thread.
var<workgroup> tb_run: u32;

@compute @workgroup_size(WORKGROUP_SIZE)
fn main(@builtin(local_invocation_index) lane: u32,
        @builtin(num_workgroups) groups: vec3<u32>) {
    LANE = lane;
    let n = arrayLength(&rays);
    let runs = (n + WORKGROUP_SIZE - 1u) / WORKGROUP_SIZE;
    let fetches = runs + groups.x;
    loop {
        if lane == 0u {
            tb_run = atomicAdd(&tb_pool, 1u) % fetches;
        }
        let run = workgroupUniformLoad(&tb_run);
        if run >= runs {
            break;
        }
        let i = run * WORKGROUP_SIZE + lane;
        if i < n {
            trace_ray(i);
        }
        // Every thread has read `tb_run` before the first one fetches the next run.
        workgroupBarrier();
    }
}
