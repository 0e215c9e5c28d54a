//! Sharded runs: `configs/ci.toml` run whole and as three shards (one of them killed
//! midway and resumed), merged; the merged folder carries the unsharded run's rows, in its
//! order, with identical counters, and `check` passes both ways; no build runs in two shards;
//! shards of another config or binary are refused.
//!
//! Reduced so that the test costs well under a minute of CPU: every structure entry of ci.toml
//! (all its builds and traversals, both triangle tests, every ray kind) on its two cheapest
//! scenes, `cornell` and `teapot-stadium` (the whole ci.toml costs about a minute of CPU per
//! run even with fewer rays, its builds on `sphereflake` and `soup` dominating, and the test
//! runs it twice), with fewer rays (32 x 32 cameras, 1024 random rays). What is tested is the
//! partition and the merge, which depend on neither.

mod common;
use common::*;

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Path, PathBuf};
use tb_results::output::{read_csv, Row};

const REDUCE: [&str; 8] = [
    "--scene",
    "cornell,teapot-stadium",
    "--set",
    "scene.camera.width=32",
    "--set",
    "scene.camera.height=32",
    "--set",
    "scene.random.count=1024",
];

fn ci() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs/ci.toml")
}

fn run_ci(out: &Path, extra: &[&str]) -> i32 {
    let (cfg, out) = (ci(), out.to_str().unwrap().to_string());
    let mut args = vec!["run", cfg.to_str().unwrap(), "--out", &out, "-q"];
    args.extend(REDUCE);
    args.extend(extra);
    run(&args)
}

/// The columns that must not depend on where or how a row ran: counters, hits, validation,
/// the structure's size and build figures (not the build's phase times).
fn deterministic(r: &Row) -> String {
    let mut v: Vec<String> = tb_results::check::counter_columns()
        .iter()
        .map(|c| format!("{c}={:?}", r.counter(c)))
        .collect();
    // Build figures less the phase times.
    let stats: Vec<&str> = r
        .build_stats
        .split(';')
        .filter(|kv| !kv.split('=').next().unwrap_or("").ends_with("_ms"))
        .collect();
    v.push(format!(
        "rays={} hit_rate={:?} validated={:?} mismatches={:?} nodes={:?} prim_refs={:?} memory={:?} sah={:?} stats={} note={}",
        r.rays, r.hit_rate, r.validated_rays, r.mismatches, r.nodes, r.prim_refs,
        r.memory_bytes, r.sah_cost, stats.join(";"), r.note
    ));
    v.join(" ")
}

#[test]
fn ci_in_three_shards_merges_to_the_unsharded_run() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    let full = t.join("full");
    assert_eq!(run_ci(&full, &[]), 0);

    // Shards 1 and 3 run through; shard 2 is killed after 5 rows, then resumed.
    let shard = |k: usize| t.join(format!("shard-{k}"));
    assert_eq!(run_ci(&shard(1), &["--shard", "1/3"]), 0);
    assert_eq!(run_ci(&shard(3), &["--shard", "3/3"]), 0);
    let status = std::process::Command::new(env!("CARGO_BIN_EXE_trace-bench"))
        .current_dir(t)
        .env("TRACE_BENCH_ABORT_AFTER_ROWS", "5")
        .args([
            "run",
            ci().to_str().unwrap(),
            "--shard",
            "2/3",
            "-q",
            "--out",
        ])
        .arg(shard(2))
        .args(REDUCE)
        .output()
        .unwrap();
    assert!(!status.status.success(), "the shard was not killed");
    let partial = read_csv(&shard(2).join("results.csv")).unwrap();
    assert_eq!(partial.len(), 5, "killed after 5 rows");
    // An incomplete shard makes the merge list what is missing and exit 1.
    let early = t.join("early");
    let dirs: Vec<String> = (1..=3)
        .map(|k| shard(k).to_str().unwrap().to_string())
        .collect();
    let merge = |out: &Path| {
        let mut a = vec!["merge"];
        a.extend(dirs.iter().map(String::as_str));
        a.extend(["--out", out.to_str().unwrap()]);
        run(&a)
    };
    assert_eq!(merge(&early), 1, "missing units must fail the merge");
    let doc: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(early.join("results.json")).unwrap()).unwrap();
    assert_eq!(doc["meta"]["status"], "incomplete");
    assert!(!doc["meta"]["merged"]["missing"]
        .as_array()
        .unwrap()
        .is_empty());
    // Resuming shard 2 with another shard index is refused; with its own it completes.
    assert_eq!(run_ci(&shard(2), &["--shard", "1/3", "--resume"]), 1);
    assert_eq!(run_ci(&shard(2), &["--shard", "2/3", "--resume"]), 0);

    let merged = t.join("merged");
    assert_eq!(merge(&merged), 0);

    let a = read_csv(&full.join("results.csv")).unwrap();
    let b = read_csv(&merged.join("results.csv")).unwrap();
    let keys = |rows: &[Row]| rows.iter().map(Row::key).collect::<Vec<_>>();
    assert_eq!(a.len(), b.len(), "no row lost or duplicated");
    assert_eq!(keys(&a), keys(&b), "same rows in the unsharded order");
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(deterministic(x), deterministic(y), "{:?}", x.key());
        assert_eq!(x.host, y.host);
    }
    let (fa, fb) = (full.join("results.csv"), merged.join("results.csv"));
    let (fa, fb) = (fa.to_str().unwrap(), fb.to_str().unwrap());
    assert_eq!(run(&["check", "--baseline", fa, fb]), 0);
    assert_eq!(run(&["check", "--baseline", fb, fa]), 0);
    // params.csv is rewritten for the merged rows.
    let params = fs::read_to_string(merged.join("params.csv")).unwrap();
    let last_row = params.lines().last().unwrap().split(',').next().unwrap();
    assert_eq!(last_row.parse::<usize>().unwrap(), b.len() - 1);

    // No build in two shards, every build in one, and each shard loaded only its scenes.
    let mut owner: BTreeMap<(String, String, String), usize> = BTreeMap::new();
    for k in 1..=3 {
        let rows = read_csv(&shard(k).join("results.csv")).unwrap();
        let builds: BTreeSet<_> = rows
            .iter()
            .map(|r| (r.scene.clone(), r.structure.clone(), r.params.clone()))
            .collect();
        for u in builds {
            if let Some(j) = owner.insert(u.clone(), k) {
                panic!("{u:?} built in shards {j} and {k}");
            }
        }
        let doc: serde_json::Value =
            serde_json::from_str(&fs::read_to_string(shard(k).join("results.json")).unwrap())
                .unwrap();
        let m = &doc["meta"]["shard"];
        assert_eq!(
            (m["k"].as_u64(), m["n"].as_u64()),
            (Some(k as u64), Some(3))
        );
        assert_eq!(m["rows"].as_u64(), Some(rows.len() as u64));
        assert!(m["cost_est_s"].as_f64().unwrap() > 0.0);
    }
    let all: BTreeSet<_> = a
        .iter()
        .map(|r| (r.scene.clone(), r.structure.clone(), r.params.clone()))
        .collect();
    assert_eq!(all.len(), owner.len());

    // Refusals: a shard of another config, a shard of another commit, a shard given twice.
    let other = t.join("other");
    let cfg = ci();
    let mut args = vec![
        "run",
        cfg.to_str().unwrap(),
        "--out",
        other.to_str().unwrap(),
        "-q",
        "--shard",
        "3/3",
        "--scene",
        "cornell",
    ];
    args.extend(REDUCE);
    assert_eq!(run(&args), 0);
    let refused = |dirs: &[&Path], what: &str| {
        let out = t.join("refused");
        let mut a = vec!["merge".to_string()];
        a.extend(dirs.iter().map(|d| d.to_str().unwrap().to_string()));
        a.extend(["--out".into(), out.to_str().unwrap().into()]);
        let a: Vec<&str> = a.iter().map(String::as_str).collect();
        assert_eq!(run(&a), 1, "{what}");
        assert!(!out.join("results.csv").exists(), "{what}: nothing written");
        let err = tb_results::merge::merge(
            &dirs.iter().map(|d| d.to_path_buf()).collect::<Vec<_>>(),
            &out,
        )
        .unwrap_err()
        .to_string();
        assert!(err.contains(what), "{err}");
        for d in dirs {
            assert!(err.contains(&d.display().to_string()), "{err}");
        }
        assert_eq!(err.lines().count(), 1, "{err}");
    };
    refused(&[&shard(1), &other], "config hash");
    let forged = t.join("forged");
    fs::create_dir_all(&forged).unwrap();
    fs::copy(shard(3).join("results.csv"), forged.join("results.csv")).unwrap();
    let mut doc: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(shard(3).join("results.json")).unwrap()).unwrap();
    doc["meta"]["build"]["commit"] = "0123456789ab".into();
    fs::write(forged.join("results.json"), doc.to_string()).unwrap();
    refused(&[&shard(1), &forged], "commit");
    refused(&[&shard(1), &shard(1)], "both shard 1/3");
}

#[test]
fn shard_flag_errors_are_one_line() {
    let cfg = ci();
    for bad in ["0/3", "4/3", "x/3", "3"] {
        assert_eq!(
            run(&["run", cfg.to_str().unwrap(), "--shard", bad, "-q"]),
            2,
            "{bad}"
        );
    }
}
