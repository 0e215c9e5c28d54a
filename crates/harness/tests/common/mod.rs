//! Helpers shared by the harness's integration tests.

use tb_results::output::Row;

/// A row without what timing and the build cache change (times, rates, load, heap, the
/// build's phase times in `build_stats`), as text to compare rows of two runs.
pub fn deterministic(r: &Row) -> String {
    let mut r = r.clone();
    for f in [
        &mut r.build_ms,
        &mut r.trace_ms_min,
        &mut r.trace_ms_median,
        &mut r.trace_ms_max,
        &mut r.mrays_per_s,
        &mut r.trace_ms_ci,
        &mut r.load_avg,
        &mut r.cpu_others,
    ] {
        *f = None;
    }
    r.build_ms_runs.clear();
    r.trace_ms_runs.clear();
    r.noisy = None;
    r.build_cached = None;
    r.build_heap_peak_bytes = None;
    r.build_heap_kept_bytes = None;
    // `insert_ms`, `pack_ms` and the grids' phase times are build times in build_stats.
    r.build_stats = r
        .build_stats
        .split(';')
        .filter(|kv| !kv.contains("_ms="))
        .collect::<Vec<_>>()
        .join(";");
    format!("{r:?}")
}
