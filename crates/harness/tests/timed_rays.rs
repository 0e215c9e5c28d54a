//! `run.timed_rays` and `run.timed_share` (count once at full size, time on as many rays as
//! needed):
//! every family's rows timed on a subset of each batch have the counters, hit rates and
//! validation of the rows timed on the whole batch, `timed_rays` says how many rays were
//! timed, and the timed passes give the counting passes' answers on those rays (sparse boxes'
//! start hints included) — alone and interleaved.

mod common;

use std::path::Path;
use tb_harness::experiment::config::{self, Overrides};
use tb_harness::experiment::runner::{self, RunOptions};
use tb_results::output::Row;

const STRUCTURES: &str = r#"
[[structure]]
name = "bvh"
params = { width = [2, 8] }

[[structure]]
name = "cwbvh"

[[structure]]
name = "rtree"

[[structure]]
name = "kdtree"

[[structure]]
name = "sparse-boxes"
params = { d_min = 2 }

[[structure]]
name = "multi-kd"

[[structure]]
name = "uniform-grid"

[[structure]]
name = "two-level-grid"

[[structure]]
name = "irregular-grid"
"#;

/// The rows of a run and its wrong rows (`recursive-origin`, not robust by its paper, has some
/// on the stress rays: they must be the same however the rows are timed).
fn run(run_keys: &str) -> (Vec<Row>, Vec<String>) {
    let text = format!(
        "name = \"timed\"\n[run]\nthreads = 1\nrepeat = 1\nwarmup = 0\nvalidate = 200\n{run_keys}\n\
         [[scene]]\nsource = \"builtin:cornell\"\nrays = [\"primary\", \"ao\", \"random\"]\n\
         camera = {{ width = 24, height = 20 }}\nrandom = {{ count = 700 }}\n\
         ao = {{ samples = 2 }}\n\n\
         [[scene]]\nsource = \"builtin:stress/near-surfaces\"\nrays = [\"primary\", \"stress\"]\n\
         camera = {{ width = 16, height = 16 }}\n{STRUCTURES}"
    );
    let exp = config::parse(
        Path::new("timed.toml"),
        &text,
        &Overrides::default(),
        &mut |_| {},
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let out = tempfile::tempdir().unwrap();
    let s = runner::run(&exp, &RunOptions::quiet(out.path().join("run"))).unwrap();
    assert!(s.failures.is_empty(), "{:?}", s.failures);
    (s.rows, s.wrong_rows)
}

/// A row without what timing changes, here also how many runs and rays were timed and the
/// interleaved rows' group.
fn counted(r: &Row) -> String {
    let mut r = r.clone();
    r.timing_group.clear();
    r.timed_rays = None;
    r.timed_runs = None;
    common::deterministic(&r)
}

#[test]
fn rows_timed_on_a_subset_count_and_validate_the_whole_batch() {
    let (all, wrong) = run("");
    assert!(all.len() > 100, "{} rows", all.len());
    assert!(
        wrong.iter().all(|w| w.contains("recursive-origin")),
        "{wrong:#?}"
    );
    fn capped(n: u64) -> u64 {
        n.min(150)
    }
    // `run.timed_share` with `run.timed_rays`: the smaller count, the share rounded up.
    fn shared(n: u64) -> u64 {
        n.min(150).min(n.div_ceil(4))
    }
    /// The run's keys, a label, and the rays a row of `n` is timed on.
    type Case = (&'static str, &'static str, fn(u64) -> u64);
    let cases: [Case; 3] = [
        ("timed_rays = 150\n", "alone", capped),
        (
            "timed_rays = 150\ninterleave = true\n",
            "interleaved",
            capped,
        ),
        ("timed_rays = 150\ntimed_share = 0.25\n", "a share", shared),
    ];
    for (keys, label, timed) in cases {
        let (sub, sub_wrong) = run(keys);
        assert_eq!(sub.len(), all.len(), "{label}");
        assert_eq!(sub_wrong, wrong, "{label}");
        let mut subset_rows = 0;
        for (a, s) in all.iter().zip(&sub) {
            assert_eq!(counted(a), counted(s), "{label}");
            if a.timed_runs.is_none() {
                continue;
            }
            assert_eq!(a.timed_rays, Some(a.rays), "{a:?}");
            assert_eq!(s.timed_rays, Some(timed(s.rays)), "{label} {s:?}");
            assert!(s.mrays_per_s.is_some_and(|m| m > 0.0));
            assert_eq!(s.mismatches, a.mismatches, "{label} {s:?}");
            subset_rows += usize::from(timed(s.rays) < s.rays);
        }
        assert!(
            subset_rows > 50,
            "{label}: {subset_rows} rows timed on a subset"
        );
        assert!(
            sub.iter().any(|r| r.structure == "sparse-boxes"
                && r.timed_rays < Some(r.rays)
                && r.timed_runs.is_some()),
            "the start hints' subset is not exercised"
        );
    }
}
