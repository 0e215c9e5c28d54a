//! `trace-bench run --processes K` end to end: K processes into one folder, their
//! rows tagged and merged, an interrupted run resumed; and a process slowed by a busy loop
//! beside it widens the interval of an absolute time between processes while the paired
//! ratio's verdict survives.
//!
//! Small: SPD's tetra at its second level (64 triangles) at 192 x 192 primary rays, the default
//! BVH against brute force (about 1 and 12-28 ms a pass on the 2-core reference machine, a
//! ratio of 10 to 24 that itself moved between processes), fifteen timed rounds: a run of three
//! processes takes about two seconds.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use tb_claims::{self as claims, RowSet, Verdict};
use tb_results::output::read_csv;

const EXE: &str = env!("CARGO_BIN_EXE_trace-bench");

const CONFIG: &str = r#"
name = "processes"
[run]
threads = 1
repeat = 15
warmup = 1
validate = 64
interleave = true

[[scene]]
source = "builtin:tetra?size=2"
rays = ["primary"]
camera = { width = 192, height = 192 }

[[structure]]
name = "bvh"

[[structure]]
name = "brute-force"
"#;

/// The tests of this file one at a time: each makes runs of three processes, and one
/// compares times that another's runs beside it would disturb.
static SERIAL: std::sync::Mutex<()> = std::sync::Mutex::new(());

fn trace_bench(args: &[&str], env: &[(&str, &str)]) -> std::process::Output {
    let mut c = Command::new(EXE);
    c.args(args);
    for (k, v) in env {
        c.env(k, v);
    }
    c.output().expect("trace-bench runs")
}

/// A test's start: the file's tests one at a time, a folder, the config in it.
fn start() -> (
    std::sync::MutexGuard<'static, ()>,
    tempfile::TempDir,
    PathBuf,
) {
    let one = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let t = tempfile::tempdir().unwrap();
    let cfg = t.path().join("processes.toml");
    std::fs::write(&cfg, CONFIG).unwrap();
    (one, t, cfg)
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn meta(dir: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(dir.join("results.json")).unwrap();
    serde_json::from_str::<serde_json::Value>(&text).unwrap()["meta"].clone()
}

/// Three processes: each folder a run of its own (the odd one with the structures reversed),
/// the run's folder their rows with `process`; killed processes lose only their unfinished
/// rows, and `--resume` completes the run.
#[test]
fn processes_merge_into_one_folder_and_resume() {
    let (_one, t, cfg) = start();
    let out = t.path().join("run");
    // Every process aborts after its first row (as if killed).
    let o = trace_bench(
        &["run", s(&cfg), "--processes", "3", "--out", s(&out), "-q"],
        &[("TRACE_BENCH_ABORT_AFTER_ROWS", "1")],
    );
    assert_eq!(o.status.code(), Some(1), "{o:?}");
    let rows = read_csv(&out.join("results.csv")).unwrap();
    let procs: Vec<Option<u32>> = rows.iter().map(|r| r.process).collect();
    assert_eq!(procs, [Some(0), Some(1), Some(2)], "the finished rows stay");
    assert_eq!(meta(&out)["status"], "incomplete");
    // A fresh run into the folder is refused; --resume completes it.
    let o = trace_bench(&["run", s(&cfg), "--processes", "3", "--out", s(&out)], &[]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("--resume"),
        "{o:?}"
    );
    let o = trace_bench(
        &[
            "run",
            s(&cfg),
            "--processes",
            "3",
            "--out",
            s(&out),
            "--resume",
            "-q",
        ],
        &[],
    );
    assert!(o.status.success(), "{o:?}");
    let rows = read_csv(&out.join("results.csv")).unwrap();
    assert_eq!(rows.len(), 6);
    for p in 0..3 {
        let mine: Vec<&str> = rows
            .iter()
            .filter(|r| r.process == Some(p))
            .map(|r| r.structure.as_str())
            .collect();
        assert_eq!(mine.len(), 2, "process {p}");
        let m = meta(&tb_harness::experiment::processes::folder(&out, p as usize));
        assert_eq!(m["process"]["index"], p);
        let order = if p == 1 { "reversed" } else { "as written" };
        assert_eq!(m["process"]["structures"], order);
    }
    // The odd process built brute force first: its rows come in that order.
    let p1: Vec<&str> = rows
        .iter()
        .filter(|r| r.process == Some(1))
        .map(|r| r.structure.as_str())
        .collect();
    assert_eq!(p1, ["brute-force", "bvh"]);
    let m = meta(&out);
    assert_eq!(m["status"], "complete");
    assert_eq!(m["processes"]["n"], 3);
    // The merged folder's phases and build-cache figures are the processes' sums (each
    // process of the resumed run counts the session that finished it).
    let each: Vec<serde_json::Value> = (0..3)
        .map(|p| meta(&tb_harness::experiment::processes::folder(&out, p)))
        .collect();
    let total: f64 = each
        .iter()
        .map(|e| e["phases"]["total_s"].as_f64().unwrap())
        .sum();
    let merged = m["phases"]["total_s"].as_f64().unwrap();
    assert!((merged - total).abs() < 0.01, "{merged} against {total}");
    let builds = |v: &serde_json::Value| {
        v["build_cache"]["built"].as_u64().unwrap() + v["build_cache"]["loaded"].as_u64().unwrap()
    };
    assert_eq!(builds(&m), each.iter().map(builds).sum::<u64>());
    assert!(builds(&m) >= 3, "{}", m["build_cache"]);
    // Rounds pair within a process, never across: no timing group spans two processes.
    for a in &rows {
        for b in rows.iter().filter(|b| b.process != a.process) {
            assert_ne!(a.timing_group, b.timing_group);
        }
    }
    // A run of several processes is not sharded.
    let o = trace_bench(
        &[
            "run",
            s(&cfg),
            "--processes",
            "2",
            "--shard",
            "1/2",
            "--out",
            s(&t.path().join("x")),
        ],
        &[],
    );
    assert_eq!(o.status.code(), Some(2), "{o:?}");
}

/// Count once: the later processes copy the first one's counters and hit rates (same binary,
/// same config), check their own oracle samples and time as before; a first process made by
/// another binary is not trusted, and they count again.
#[test]
fn later_processes_copy_the_first_ones_counters() {
    let (_one, t, cfg) = start();
    let out = t.path().join("run");
    let o = trace_bench(
        &["run", s(&cfg), "--processes", "3", "--out", s(&out), "-q"],
        &[],
    );
    assert!(o.status.success(), "{o:?}");
    let folder = |p: usize| tb_harness::experiment::processes::folder(&out, p);
    let copied = |p: usize| meta(&folder(p))["build_cache"]["counters_copied"].as_u64();
    assert_eq!(
        (copied(0), copied(1), copied(2)),
        (Some(0), Some(2), Some(2))
    );
    let rows = read_csv(&out.join("results.csv")).unwrap();
    let of = |p: u32| -> Vec<_> {
        let mut v: Vec<_> = rows
            .iter()
            .filter(|r| r.process == Some(p))
            .map(|r| {
                (
                    r.structure.clone(),
                    r.hit_rate,
                    r.steps_per_ray,
                    r.prims_per_ray,
                    r.validated_rays,
                    r.mismatches,
                )
            })
            .collect();
        v.sort_by(|a, b| a.0.cmp(&b.0));
        v
    };
    assert!(
        of(0).iter().all(|r| r.1.is_some() && r.4 == Some(64)),
        "{:?}",
        of(0)
    );
    assert_eq!(of(1), of(0));
    assert_eq!(of(2), of(0));
    assert!(rows.iter().all(|r| r.trace_ms_median.is_some()));
    // The first process's binary digest altered: the later processes count again.
    let json = folder(0).join("results.json");
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    v["meta"]["binary_digest"] = "another binary".into();
    std::fs::write(&json, serde_json::to_string_pretty(&v).unwrap()).unwrap();
    for p in [1, 2] {
        std::fs::remove_dir_all(folder(p)).unwrap();
    }
    let o = trace_bench(
        &[
            "run",
            s(&cfg),
            "--processes",
            "3",
            "--out",
            s(&out),
            "--resume",
            "-q",
        ],
        &[],
    );
    assert!(o.status.success(), "{o:?}");
    assert_eq!((copied(1), copied(2)), (Some(0), Some(0)));
}

/// Spin `threads` threads until the returned flag is set.
fn busy(threads: usize) -> (Arc<AtomicBool>, Vec<std::thread::JoinHandle<u64>>) {
    let stop = Arc::new(AtomicBool::new(false));
    let handles = (0..threads)
        .map(|_| {
            let stop = stop.clone();
            std::thread::spawn(move || {
                let mut x = 0u64;
                while !stop.load(Ordering::Relaxed) {
                    x = std::hint::black_box(x.wrapping_mul(6364136223846793005).wrapping_add(1));
                }
                x
            })
        })
        .collect();
    (stop, handles)
}

const CLAIMS: &str = r#"
paper = "t"

[[claim]]
id = "bvh-time"
where = "T1"
text = "the BVH's time"
paper = "-"
measure = "time"
rows.bvh = { structure = "bvh" }
test = { kind = "value", of = "bvh", min = 0 }

[[claim]]
id = "bvh-faster"
where = "T1"
text = "the BVH traces faster than brute force"
paper = "-"
measure = "time"
rows.bvh = { structure = "bvh" }
rows.brute = { structure = "brute-force" }
test = { kind = "speedup", of = "bvh", base = "brute", min = 1.5 }
"#;

/// The same run twice: three processes as the machine gives them, then with process 1 made
/// again beside a busy loop (four spinning threads per core, so that it gets a fraction of a
/// core whatever else runs). The BVH's time, compared between processes, gets a wider
/// interval; the speedup over brute force, each process's rounds paired, agrees in both.
///
/// A timed pass must outlast the scheduler's time slice (a few ms), or the median of the
/// rounds drops the preempted passes and the slowed process's time barely moves (a 1 ms pass
/// made this test fail in CI at stop 49): here 512 x 512 rays on the tetra of 16 triangles,
/// about 10 ms a pass for the BVH and 35 for brute force on the 2-core machine.
#[test]
fn a_slowed_process_widens_a_times_interval_and_the_paired_verdict_survives() {
    let (_one, t, cfg) = start();
    let longer = CONFIG
        .replace("size=2", "size=1")
        .replace("width = 192, height = 192", "width = 512, height = 512")
        .replace("repeat = 15", "repeat = 9");
    assert_ne!(longer, CONFIG);
    std::fs::write(&cfg, longer).unwrap();
    let quiet = t.path().join("quiet");
    let o = trace_bench(
        &["run", s(&cfg), "--processes", "3", "--out", s(&quiet), "-q"],
        &[],
    );
    assert!(o.status.success(), "{o:?}");
    let slowed = t.path().join("slowed");
    use tb_harness::experiment::processes::folder;
    for p in [0, 2] {
        std::fs::create_dir_all(folder(&slowed, p)).unwrap();
        for f in ["results.csv", "results.json", "params.csv"] {
            std::fs::copy(folder(&quiet, p).join(f), folder(&slowed, p).join(f)).unwrap();
        }
    }
    let cores = std::thread::available_parallelism().map_or(2, |n| n.get());
    let (stop, spinning) = busy(4 * cores);
    let o = trace_bench(
        &[
            "run",
            s(&cfg),
            "--process",
            "1/3",
            "--out",
            s(&folder(&slowed, 1)),
            "-q",
        ],
        &[],
    );
    stop.store(true, Ordering::Relaxed);
    for h in spinning {
        h.join().unwrap();
    }
    assert!(o.status.success(), "{o:?}");
    // The three complete processes merged (none made again).
    let o = trace_bench(
        &[
            "run",
            s(&cfg),
            "--processes",
            "3",
            "--out",
            s(&slowed),
            "--resume",
        ],
        &[],
    );
    assert!(o.status.success(), "{o:?}");
    assert_eq!(
        String::from_utf8_lossy(&o.stdout)
            .matches("complete, reused")
            .count(),
        3,
        "{o:?}"
    );
    let file = claims::parse(Path::new("t.toml"), CLAIMS).unwrap();
    let eval = |dir: &Path| claims::evaluate(&file, &RowSet::read(&[dir.to_path_buf()]).unwrap());
    let (q, w) = (eval(&quiet), eval(&slowed));
    let width = |v: &[claims::ClaimResult]| {
        let d = v[0].groups[0].derived.unwrap();
        d[2] / d[0]
    };
    for v in [&q, &w] {
        assert_eq!(v[0].groups[0].between, Some(3), "{:?}", v[0]);
        assert!(
            v[0].why.contains("interval between 3 processes"),
            "{}",
            v[0].why
        );
    }
    println!(
        "the BVH time's interval between processes, upper / lower: quiet {:.3}, slowed {:.3}",
        width(&q),
        width(&w)
    );
    assert!(
        width(&w) > width(&q),
        "the slowed process widens the BVH time's interval: quiet {}, slowed {} ({} / {})",
        width(&q),
        width(&w),
        q[0].ours,
        w[0].ours
    );
    for v in [&q, &w] {
        let said = format!("{} {}: {}", v[1].verdict.as_str(), v[1].ours, v[1].why);
        assert_eq!(v[1].verdict, Verdict::Agree, "{said}");
        assert!(v[1].why.contains("between 3 processes"), "{said}");
    }
}

/// `reproduce` makes a `[[run]]` of `processes = 3` as `run --processes 3` (planned three times
/// its declared cost), compares its times between the processes, and REPORT.md gives the spread
/// of its rows between them; a rerun into the folder reuses the complete run.
#[test]
fn reproduce_makes_a_run_in_processes_and_reports_their_spread() {
    let (_one, t, cfg) = start();
    let claims = t.path().join("p.toml");
    let runs = format!(
        "paper = \"t\"\n[[run]]\nconfig = \"{}\"\ncost_s = 2\nfixed_s = 1\nprocesses = 3\n",
        cfg.display()
    );
    std::fs::write(&claims, CLAIMS.replacen("paper = \"t\"\n", &runs, 1)).unwrap();
    let out = t.path().join("report");
    let reproduce = || {
        trace_bench(
            &[
                "reproduce",
                s(&claims),
                "--budget",
                "1m",
                "--out",
                s(&out),
                "-q",
            ],
            &[],
        )
    };
    let o = reproduce();
    assert!(o.status.success(), "{o:?}");
    let report = std::fs::read_to_string(out.join("REPORT.md")).unwrap();
    assert!(report.contains("--processes 3"), "{report}");
    assert!(
        report.contains("| 6 s |"),
        "three processes of 2 s: {report}"
    );
    let line = report
        .lines()
        .find(|l| l.starts_with("| `0-processes` | 3 | 2 |"))
        .unwrap_or_else(|| panic!("a spread row for the run's two rows: {report}"));
    assert!(line.contains(" % ("), "{line}");
    // Each run's time split and build cache, from its results.json.
    let run = report
        .lines()
        .find(|l| l.contains("--processes 3"))
        .unwrap();
    assert!(run.contains(" built |") && run.contains(" %"), "{run}");
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("verdicts.json")).unwrap()).unwrap();
    let why = v["papers"][0]["claims"][1]["why"].as_str().unwrap();
    assert!(why.contains("between 3 processes"), "{why}");
    let o = reproduce();
    assert!(o.status.success(), "{o:?}");
    let report = std::fs::read_to_string(out.join("REPORT.md")).unwrap();
    assert!(report.contains("| reused |"), "{report}");
}
