//! The `trace-bench` binary: parse arguments, run, map the outcome to an exit code.

fn main() {
    std::process::exit(trace_bench::run(std::env::args_os()));
}
