//! The `trace-bench` binary: parse arguments, run, map the outcome to an exit code.

/// Counts the heap a build holds at its peak and keeps (`build_heap_*` columns); off, one
/// relaxed load per allocation, outside builds.
#[global_allocator]
static HEAP: tb_harness::experiment::heap::CountingAlloc =
    tb_harness::experiment::heap::CountingAlloc;

fn main() {
    std::process::exit(trace_bench::run(std::env::args_os()));
}
