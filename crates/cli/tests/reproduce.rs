//! `trace-bench reproduce` and `claims` end to end: a claims file with two runs (a tiny
//! config, shrunk to its budget, and `weights --csv`), its verdicts and report; a rerun into
//! the same folder reuses the complete runs.

use std::fs;
use std::process::Command;

const CONFIG: &str = r#"
name = "tiny"
[run]
threads = 1
repeat = 3
warmup = 0
validate = 256

[[scene]]
source = "builtin:sphereflake"
rays = ["primary"]

[[structure]]
name = "kdtree"
traversals = ["recursive-direction", "restart"]
"#;

/// A counter claim on [`CONFIG`]'s rows (placed in the claims files by `format!`).
const RESTART_CLAIM: &str = r#"[[claim]]
id = "restart-revisits"
where = "Table 9"
text = "restart visits more nodes than the recursive walk"
paper = "more"
measure = "interior_per_ray"
rows.rec = { traversal = "recursive-direction" }
rows.restart = { traversal = "restart" }
test = { kind = "order", rows = ["rec", "restart"], strict = true }
"#;

#[test]
fn reproduce_runs_scales_and_reports() {
    let t = tempfile::tempdir().unwrap();
    let cfg = t.path().join("tiny.toml");
    fs::write(&cfg, CONFIG).unwrap();
    let claims = t.path().join("tiny-paper.toml");
    fs::write(
        &claims,
        format!(
            r#"
paper = "A tiny paper"

[[run]]
config = "{cfg}"
set = ["scene.camera.width=64", "scene.camera.height=64"]
cost_s = 1000
fixed_s = 0
scalable = true

[[run]]
exec = ["weights", "--csv", "{{out}}/weights.csv"]
cost_s = 0

{RESTART_CLAIM}
[[claim]]
id = "gpu-only"
where = "Table 9"
text = "a GPU figure"
paper = "1"
devices = ["gpu"]
measure = "time"
rows.rec = {{ traversal = "recursive-direction" }}
test = {{ kind = "value", of = "rec", min = 0 }}

[[claim]]
id = "weight"
kind = "observation"
where = "Table 1"
text = "a weight"
paper = "50.00"
measure = "weight_pct"
filter = {{ file = "weights" }}
rows.w = {{ table = 1, heuristic = "cube-obli", patch = "Y", axis = "Y" }}
test = {{ kind = "value", of = "w", min = 49.999, max = 50.01 }}

[[figure]]
name = "nodes"
title = "Table 9 as bars"
script = "plot.py"
args = ["bars", "{{run:tiny}}"]
"#,
            cfg = cfg.display()
        ),
    )
    .unwrap();
    // Its deviations, beside it.
    fs::create_dir(t.path().join("deviations")).unwrap();
    let deviations = t.path().join("deviations/tiny-paper.toml");
    let deviation = |claims: &str| {
        format!("[[deviation]]\nkind = \"hardware\"\nwhat = \"no GPU here\"\nwhy = \"a CPU machine\"\nclaims = {claims}\n")
    };
    fs::write(&deviations, deviation(r#"["gpu-only"]"#)).unwrap();
    let out = t.path().join("report");
    let exe = env!("CARGO_BIN_EXE_trace-bench");
    // The figures' interpreter: one with "matplotlib" (writes its --out), one without.
    fs::create_dir(t.path().join("scripts")).unwrap();
    fs::write(t.path().join("scripts/plot.py"), "").unwrap();
    let python = |name: &str, probe: &str| {
        use std::os::unix::fs::PermissionsExt;
        let p = t.path().join(name);
        fs::write(
            &p,
            format!(
                "#!/bin/sh\nif [ \"$1\" = -c ]; then exit {probe}; fi\n\
                 prev=; for a in \"$@\"; do if [ \"$prev\" = --out ]; then echo png > \"$a\"; fi; prev=$a; done\n"
            ),
        )
        .unwrap();
        fs::set_permissions(&p, fs::Permissions::from_mode(0o755)).unwrap();
        p
    };
    let (with_mpl, without) = (python("python-mpl", "0"), python("python-bare", "1"));
    let python = std::cell::RefCell::new(with_mpl);
    let run_into = |out: &std::path::Path| {
        Command::new(exe)
            .current_dir(t.path())
            .env("TRACE_BENCH_PYTHON", &*python.borrow())
            .args([
                "reproduce",
                claims.to_str().unwrap(),
                "--budget",
                "20s",
                "--out",
            ])
            .arg(out)
            .args(["-q"])
            .output()
            .unwrap()
    };
    let run = || run_into(&out);
    let o = run();
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let report = fs::read_to_string(out.join("REPORT.md")).unwrap();
    // 1000 s declared into 19 s: a 64-pixel image shrinks to the smallest scale (1/64 of the
    // pixels: 8, kept at 32), and the report says so.
    assert!(report.contains("scene.camera.width 64 → 32"), "{report}");
    let v: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(out.join("verdicts.json")).unwrap()).unwrap();
    let claims_out = &v["papers"][0]["claims"];
    let field = |id: &str, key: &str| {
        claims_out
            .as_array()
            .unwrap()
            .iter()
            .find(|c| c["id"] == id)
            .unwrap()[key]
            .clone()
    };
    let verdict = |id: &str| field(id, "verdict");
    assert_eq!(verdict("restart-revisits"), "agree", "{report}");
    assert_eq!(verdict("weight"), "agree", "{report}");
    assert_eq!(verdict("gpu-only"), "inconclusive");
    // The observation is counted apart from the tally, with its kind.
    let kind = |id: &str| field(id, "kind");
    assert_eq!(kind("weight"), "observation");
    assert_eq!(kind("gpu-only"), "claim");
    assert_eq!(v["tally"]["agree"], 1, "{v}");
    assert_eq!(v["kinds"]["observations"]["agree"], 1, "{v}");
    // The figure, drawn from the run's folder and linked.
    assert!(
        report.contains("- Table 9 as bars (tiny-paper): [figures/tiny-paper-nodes.png](figures/tiny-paper-nodes.png)"),
        "{report}"
    );
    assert!(out.join("figures/tiny-paper-nodes.png").is_file());
    let repro = fs::read_to_string(out.join("REPRODUCTION.md")).unwrap();
    assert!(
        repro.contains("| [`gpu-only`](#r-tiny-paper-gpu-only) |")
            && repro.contains("not measured"),
        "{repro}"
    );
    let at = |s: &str| {
        repro
            .find(s)
            .unwrap_or_else(|| panic!("{s} not in {repro}"))
    };
    assert!(repro.contains(
        "claims 1 agree, 0 disagree, 1 inconclusive; observations (not tallied) 1 agree"
    ));
    assert!(
        at("| [`gpu-only`]") < at("### Observations")
            && at("### Observations") < at("| [`weight`]")
            && at("| [`weight`]") < at("## Reasons")
    );
    assert!(at("## Deviations") < at("| hardware | no GPU here | a CPU machine | `gpu-only` |"));
    // The same folder again, without matplotlib: both runs reused, the same verdicts, and one
    // line saying how to get the figures.
    *python.borrow_mut() = without;
    let o = run();
    assert!(o.status.success());
    let report = fs::read_to_string(out.join("REPORT.md")).unwrap();
    assert_eq!(report.matches("| reused |").count(), 2, "{report}");
    assert!(
        report.contains("Not drawn: matplotlib is not installed for")
            && report.contains("pip install -r scripts/requirements.txt"),
        "{report}"
    );
    // `claims` on the runs' folders directly, and the CI form failing on a non-agreeing claim.
    let runs = out.join("runs/tiny-paper");
    let folders: Vec<String> = fs::read_dir(&runs)
        .unwrap()
        .map(|e| e.unwrap().path().display().to_string())
        .collect();
    let o = Command::new(exe)
        .args(["claims", claims.to_str().unwrap(), "--format", "md"])
        .args(&folders)
        .output()
        .unwrap();
    let md = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success() && md.contains("| `restart-revisits` |"),
        "{md}"
    );
    let o = Command::new(exe)
        .args(["claims", claims.to_str().unwrap(), "--require-agree"])
        .args(&folders)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1), "gpu-only is inconclusive");
    // A deviation naming a claim the file does not have stops reproduce before any run.
    fs::write(&deviations, deviation(r#"["gpu-olny"]"#)).unwrap();
    let o = run_into(&t.path().join("report2"));
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("deviation[0].claims") && err.contains("`gpu-olny` names no claim"),
        "{err}"
    );
    assert!(
        !t.path().join("report2/runs").exists(),
        "no run before the check"
    );
}

/// `run.interleave`: the same rows and counters as a run timed row by row; the CPU rows of a
/// batch share a timing group (over both builds) and carry their rounds in order.
#[test]
fn interleaved_runs_keep_rows_and_counters() {
    let t = tempfile::tempdir().unwrap();
    let cfg = t.path().join("tiny.toml");
    let text = format!(
        "{CONFIG}\n[[scene]]\nsource = \"builtin:cornell\"\nrays = [\"primary\", \"shadow\"]\ncamera = {{ width = 32, height = 32 }}\n\n[[structure]]\nname = \"bvh\"\n"
    )
    .replace("[run]\n", "[run]\ndevices = [\"cpu\"]\n");
    fs::write(&cfg, &text).unwrap();
    let exe = env!("CARGO_BIN_EXE_trace-bench");
    let run = |out: &str, extra: &[&str]| {
        let o = Command::new(exe)
            .args(["run", cfg.to_str().unwrap(), "--out"])
            .arg(t.path().join(out))
            .arg("-q")
            .args(extra)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let mut rd = csv::Reader::from_path(t.path().join(out).join("results.csv")).unwrap();
        let head = rd.headers().unwrap().clone();
        rd.records()
            .map(|r| {
                let r = r.unwrap();
                head.iter()
                    .zip(r.iter())
                    .map(|(h, v)| (h.to_owned(), v.to_owned()))
                    .collect::<std::collections::BTreeMap<_, _>>()
            })
            .collect::<Vec<_>>()
    };
    let apart = run("apart", &[]);
    let together = run("together", &["--set", "run.interleave=true"]);
    assert_eq!(apart.len(), together.len());
    for (a, b) in apart.iter().zip(&together) {
        for col in [
            "scene",
            "structure",
            "traversal",
            "ray_kind",
            "interior_per_ray",
            "prims_per_ray",
            "mismatches",
        ] {
            assert_eq!(a[col], b[col], "{col}");
        }
        assert!(a["timing_group"].is_empty());
        assert_eq!(b["trace_ms_runs"].split(';').count(), 3);
    }
    // Per view and batch, every row of both builds shares one group.
    let groups: std::collections::BTreeSet<&str> = together
        .iter()
        .filter(|r| r["scene"] == "sphereflake" && r["ray_kind"] == "primary")
        .map(|r| r["timing_group"].as_str())
        .collect();
    assert_eq!(groups.len(), 1, "{groups:?}");
    assert!(!groups.iter().next().unwrap().is_empty());
    let structures: std::collections::BTreeSet<&str> = together
        .iter()
        .filter(|r| r["scene"] == "cornell" && r["ray_kind"] == "shadow")
        .map(|r| r["structure"].as_str())
        .collect();
    assert_eq!(structures.len(), 2);
}

/// `run.clock = "thread"`: one-thread rows timed by the thread's CPU time, the same rows and
/// counters, timed both apart and interleaved; an unknown clock is refused, naming the key.
#[test]
fn the_thread_clock_times_the_same_rows() {
    let t = tempfile::tempdir().unwrap();
    let cfg = t.path().join("tiny.toml");
    fs::write(&cfg, CONFIG).unwrap();
    let exe = env!("CARGO_BIN_EXE_trace-bench");
    let run = |out: &str, extra: &[&str]| {
        Command::new(exe)
            .args(["run", cfg.to_str().unwrap(), "--out"])
            .arg(t.path().join(out))
            .arg("-q")
            .args(extra)
            .output()
            .unwrap()
    };
    let rows =
        |out: &str| tb_results::output::read_csv(&t.path().join(out).join("results.csv")).unwrap();
    for (out, extra) in [
        ("wall", &[][..]),
        ("thread", &["--set", "run.clock=thread"][..]),
        (
            "both",
            &["--set", "run.clock=thread", "--set", "run.interleave=true"][..],
        ),
    ] {
        let o = run(out, extra);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    let (wall, thread, both) = (rows("wall"), rows("thread"), rows("both"));
    assert_eq!(wall.len(), thread.len());
    for ((a, b), c) in wall.iter().zip(&thread).zip(&both) {
        assert_eq!(
            (&a.traversal, a.interior_per_ray),
            (&b.traversal, b.interior_per_ray)
        );
        assert_eq!(
            (&a.traversal, a.interior_per_ray),
            (&c.traversal, c.interior_per_ray)
        );
        for r in [b, c] {
            assert!(r.trace_ms_median.is_some_and(|m| m > 0.0), "{r:?}");
        }
    }
    let o = run("bad", &["--set", "run.clock=cpu"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("run.clock") && err.contains("known: wall, thread"),
        "{err}"
    );
}

/// `--deadline`: a run still going at the deadline is ended with its finished rows kept, the
/// runs after it are left out, and the claims and the report are made from what is there
/// (the GPU reference's guard against its device's time limit).
#[test]
fn a_deadline_ends_the_runs_and_still_reports() {
    let t = tempfile::tempdir().unwrap();
    // Many rows of a few hundred ms each on two cores: far longer than the deadline.
    let slow = CONFIG.replace("repeat = 3", "repeat = 40").replace(
        "rays = [\"primary\"]",
        "rays = [\"primary\"]\ncamera = { width = 512, height = 512 }",
    );
    let cfg = t.path().join("slow.toml");
    fs::write(&cfg, slow).unwrap();
    let claims = t.path().join("slow-paper.toml");
    fs::write(
        &claims,
        format!(
            r#"
paper = "A slow paper"

[[run]]
config = "{cfg}"
cost_s = 5

[[run]]
exec = ["weights", "--csv", "{{out}}/weights.csv"]
cost_s = 0

{RESTART_CLAIM}"#,
            cfg = cfg.display()
        ),
    )
    .unwrap();
    let out = t.path().join("report");
    let started = std::time::Instant::now();
    let o = Command::new(env!("CARGO_BIN_EXE_trace-bench"))
        .current_dir(t.path())
        .args([
            "reproduce",
            claims.to_str().unwrap(),
            "--deadline",
            "3s",
            "-q",
            "--out",
        ])
        .arg(&out)
        .output()
        .unwrap();
    let took = started.elapsed().as_secs_f64();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(took < 20.0, "took {took:.1} s\n{stderr}");
    // A run ended at the deadline is a failed run: exit 1, and the report is written.
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    let report = fs::read_to_string(out.join("REPORT.md")).unwrap();
    assert!(
        report.contains("ended at the --deadline of 3 s"),
        "{report}"
    );
    assert!(
        report.contains("not made: the --deadline of 3 s had passed"),
        "{report}"
    );
    assert!(!out.join("weights.csv").exists());
    // The verdicts are written, from the rows the ended run finished (or none).
    let v: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(out.join("verdicts.json")).unwrap()).unwrap();
    assert_eq!(v["papers"][0]["claims"][0]["id"], "restart-revisits", "{v}");
    // A deadline that is no duration, or none, is refused in one line before any run.
    for (bad, why) in [
        ("soon", "expected a duration"),
        ("0s", "must be more than zero"),
    ] {
        let o = Command::new(env!("CARGO_BIN_EXE_trace-bench"))
            .current_dir(t.path())
            .args(["reproduce", claims.to_str().unwrap(), "--deadline", bad])
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{err}");
        assert!(err.contains(&format!("--deadline {bad}: {why}")), "{err}");
        assert_eq!(err.lines().count(), 1, "{err}");
    }
}
