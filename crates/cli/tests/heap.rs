//! The measured build heap (`build_heap_peak_bytes`, `build_heap_kept_bytes`): this test
//! binary installs the counting allocator, as the `trace-bench` binary does.

mod common;
use common::*;

use std::fs;
use std::sync::{Mutex, MutexGuard};
use tb_harness::experiment::heap::{self, CountingAlloc};
use tb_results::output::read_csv;

#[global_allocator]
static HEAP: CountingAlloc = CountingAlloc;

/// The counter is global: the tests of this file take turns, so that one's run (rays,
/// batches) is not counted in the other's measurement.
static SERIAL: Mutex<()> = Mutex::new(());

fn serial() -> MutexGuard<'static, ()> {
    SERIAL.lock().unwrap_or_else(|e| e.into_inner())
}

const MIB: u64 = 1 << 20;

#[test]
fn measure_sees_a_freed_scratch_array_in_the_peak_and_not_in_what_is_kept() {
    let _turn = serial();
    assert!(heap::installed());
    let (kept, used) = heap::measure(|| {
        let scratch = std::hint::black_box(vec![1u8; 2 * MIB as usize]);
        let out = std::hint::black_box(vec![2u8; MIB as usize]);
        drop(scratch);
        out
    });
    let used = used.expect("counted");
    // libtest's own threads may allocate or free a few bytes meanwhile (CI saw 24 freed).
    assert!(used.peak.abs_diff(3 * MIB) < MIB / 4, "{used:?}");
    assert!(used.kept.abs_diff(MIB) < MIB / 4, "{used:?}");
    drop(kept);
}

#[test]
fn rows_report_the_build_heap_of_every_structure() {
    let _turn = serial();
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("c.toml");
    fs::write(
        &cfg,
        r#"
[run]
threads = 1
repeat = 2
warmup = 0

[[scene]]
source = "builtin:sphereflake?size=2"
rays = ["random"]
random = { count = 500 }

[[structure]]
name = "bvh"

[[structure]]
name = "kdtree"

[[structure]]
name = "irregular-grid"
"#,
    )
    .unwrap();
    let out = dir.path().join("out");
    assert_eq!(run_quiet(&cfg, &out), 0);
    let rows = read_csv(&out.join("results.csv")).unwrap();
    assert!(rows.len() >= 3);
    for r in &rows {
        let (peak, kept) = (
            r.build_heap_peak_bytes.unwrap(),
            r.build_heap_kept_bytes.unwrap(),
        );
        // The structure's nodes are among what its build kept, and a build holds at least
        // what it keeps.
        if let (Some(n), Some(b)) = (r.nodes, r.node_bytes) {
            let nodes = n * u64::from(b);
            assert!(
                kept >= nodes,
                "{}: kept {kept} < nodes {nodes}",
                r.structure
            );
        }
        assert!(kept > 0, "{}", r.structure);
        assert!(peak >= kept, "{}: peak {peak} < kept {kept}", r.structure);
    }
}

/// Large blocks start on a cache line (`heap::placement`), through every way a block is made:
/// allocated, zeroed, grown past the threshold and shrunk below it, with its bytes kept.
#[test]
fn large_blocks_start_on_a_cache_line_and_keep_their_bytes() {
    let _turn = serial();
    if !heap::placement().align {
        eprintln!("note: TRACE_BENCH_ALIGN=0: large blocks are not aligned, nothing to check");
        return;
    }
    let line = |p: *const u8| (p as usize).is_multiple_of(heap::LINE);
    for n in [heap::ALIGN_MIN, 3 * heap::ALIGN_MIN + 16, 1 << 20] {
        let v = std::hint::black_box(vec![7u8; n]);
        assert!(line(v.as_ptr()), "{n} bytes at {:p}", v.as_ptr());
        let z = std::hint::black_box(vec![0u64; n / 8]);
        assert!(line(z.as_ptr().cast()) && z.iter().all(|x| *x == 0));
    }
    // Grown one element at a time from a few bytes to 64 KiB (reallocated across the
    // threshold), then shrunk below it: the same values throughout.
    let mut v: Vec<u32> = Vec::new();
    for i in 0..16384u32 {
        v.push(i.wrapping_mul(2654435761));
        if v.len() * 4 >= heap::ALIGN_MIN {
            assert!(line(v.as_ptr().cast()), "{} elements", v.len());
        }
    }
    v.truncate(100);
    v.shrink_to_fit();
    assert!((0..100u32).all(|i| v[i as usize] == i.wrapping_mul(2654435761)));
}
