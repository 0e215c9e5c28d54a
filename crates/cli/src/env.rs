//! The environment variables trace-bench reads, each checked before any work (every
//! value a user gives is checked where it is read, with one line naming it). The readers keep
//! their own parsing (the allocator reads its two flags without allocating); this refuses a
//! value none of them would take, instead of its silent default.

use anyhow::{bail, Result};

/// What a variable may hold.
enum Rule {
    /// `0` or `1`.
    Flag,
    /// `0`, `1` or empty (unset in effect).
    FlagOrEmpty,
    /// A whole number of at least 1.
    Count,
    /// A non-empty path or command.
    Path,
}

/// Every variable trace-bench reads (besides `TRACE_BENCH_SCENES`, the `--scenes-root` flag's
/// own, which clap reads), what it may hold, and what it does.
const VARS: &[(&str, Rule, &str)] = &[
    (
        "TRACE_BENCH_ALIGN",
        Rule::Flag,
        "0: large arrays not aligned to cache lines",
    ),
    (
        "TRACE_BENCH_HUGEPAGES",
        Rule::Flag,
        "1: large arrays on transparent huge pages",
    ),
    (
        "TRACE_BENCH_GPU_CHECKED",
        Rule::Flag,
        "1: timed GPU kernels keep wgpu's runtime checks",
    ),
    (
        "TRACE_BENCH_REQUIRE_GPU",
        Rule::FlagOrEmpty,
        "1: GPU tests fail without an adapter",
    ),
    (
        "TRACE_BENCH_MAX_GUNZIP",
        Rule::Count,
        "the most bytes a .gz scene may decompress to",
    ),
    (
        "TRACE_BENCH_ABORT_AFTER_ROWS",
        Rule::Count,
        "tests: abort after this many rows",
    ),
    (
        "TRACE_BENCH_BUILD_CACHE",
        Rule::Path,
        "the build cache's folder, or `off` (run --cache-dir, --no-cache)",
    ),
    (
        "TRACE_BENCH_BUILD_CACHE_MB",
        Rule::Count,
        "the most megabytes the build cache keeps",
    ),
    (
        "TRACE_BENCH_PYTHON",
        Rule::Path,
        "the interpreter reproduce draws figures with",
    ),
    (
        "TRACE_BENCH_NVIDIA_SMI",
        Rule::Path,
        "the nvidia-smi that GPU rows' clocks come from",
    ),
];

/// Check every variable of [`VARS`] that is set; the first bad one is the error.
pub(crate) fn check() -> Result<()> {
    for (name, rule, what) in VARS {
        let Some(v) = std::env::var_os(name) else {
            continue;
        };
        let Some(v) = v.to_str() else {
            bail!("{name}: not valid UTF-8 ({what})");
        };
        let ok = match rule {
            Rule::Flag => v == "0" || v == "1",
            Rule::FlagOrEmpty => v.is_empty() || v == "0" || v == "1",
            Rule::Count => v.trim().parse::<u64>().is_ok_and(|n| n >= 1),
            Rule::Path => !v.trim().is_empty(),
        };
        if !ok {
            let want = match rule {
                Rule::Flag => "0 or 1",
                Rule::FlagOrEmpty => "0, 1 or empty",
                Rule::Count => "a whole number of at least 1",
                Rule::Path => "a path or command",
            };
            bail!("{name}={v}: expected {want} ({what})");
        }
    }
    Ok(())
}

/// The names of [`VARS`] (the test of every value walks them).
pub fn names() -> Vec<&'static str> {
    VARS.iter().map(|v| v.0).collect()
}
