//! The `trace-bench` binary: parse arguments, run, map the outcome to an exit code.

/// Counts the heap a build holds at its peak and keeps (`build_heap_*` columns); off, one
/// relaxed load per allocation, outside builds.
#[global_allocator]
static HEAP: tb_harness::experiment::heap::CountingAlloc =
    tb_harness::experiment::heap::CountingAlloc;

fn main() {
    // The reader of our output went away (`trace-bench list | head -3`): stop quietly with
    // exit 0, as Unix tools do, instead of a panic message and exit 101. Rows already written
    // stay (a run flushes each row; `--resume` continues it).
    let default = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let payload = info.payload();
        let msg = payload
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| payload.downcast_ref::<&str>().copied())
            .unwrap_or("");
        if msg.starts_with("failed printing to std") && msg.contains("Broken pipe") {
            std::process::exit(0);
        }
        default(info)
    }));
    std::process::exit(trace_bench::run(std::env::args_os()));
}
