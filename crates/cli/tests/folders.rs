//! One results folder, one writer: a second `run` on a folder another run holds is refused in
//! one line whatever its mode (fresh, `--resume`, `--force`) and leaves the folder as it was;
//! `--force` replaces every file a run writes (the reports' too); `--resume` of a folder with
//! nothing to resume is an error; a resumed run keeps the time of a killed session.

mod common;

use common::run;
use std::fs;
use std::path::Path;
use tb_results::lock::FolderLock;

const CONFIG: &str = r#"
[run]
threads = 1
repeat = 1
warmup = 0

[[scene]]
source = "builtin:stress/flat"
rays = ["primary"]

[[structure]]
name = "bvh"
"#;

fn run_in(cfg: &Path, out: &Path, extra: &[&str]) -> i32 {
    let mut args = vec![
        "run",
        cfg.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "-q",
    ];
    args.extend_from_slice(extra);
    run(&args)
}

/// Every file under `dir` (but the lock) with its bytes.
fn snapshot(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut v: Vec<(String, Vec<u8>)> = fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_type().unwrap().is_file() && e.file_name() != ".lock")
        .map(|e| {
            (
                e.file_name().to_string_lossy().into_owned(),
                fs::read(e.path()).unwrap(),
            )
        })
        .collect();
    v.sort();
    v
}

#[test]
fn a_held_folder_refuses_a_second_run_in_every_mode_and_stays_as_it_was() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("c.toml");
    fs::write(&cfg, CONFIG).unwrap();
    let out = dir.path().join("out");
    assert_eq!(run_in(&cfg, &out, &[]), 0);
    let before = snapshot(&out);
    assert!(before.iter().any(|(n, _)| n == "results.csv"));
    // Another run holds the folder (the lock a running `run` takes).
    let held = FolderLock::acquire(&out).unwrap();
    for mode in [&[][..], &["--resume"], &["--force"]] {
        assert_eq!(run_in(&cfg, &out, mode), 1, "{mode:?}");
        assert_eq!(snapshot(&out), before, "{mode:?} left the folder changed");
    }
    // A fresh folder beside it is not held.
    assert_eq!(run_in(&cfg, &dir.path().join("other"), &[]), 0);
    drop(held);
    assert_eq!(run_in(&cfg, &out, &["--force"]), 0);
}

#[test]
fn force_replaces_every_file_a_run_writes_and_keeps_the_others() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("c.toml");
    fs::write(&cfg, CONFIG).unwrap();
    let out = dir.path().join("out");
    assert_eq!(run_in(&cfg, &out, &[]), 0);
    // Files of an earlier run of another kind (a dynamic or convergence experiment).
    for f in [
        "dynamic.csv",
        "dynamic-choice.csv",
        "convergence.csv",
        "convergence-budget.csv",
    ] {
        fs::write(out.join(f), "stale\n").unwrap();
    }
    fs::create_dir_all(out.join("images")).unwrap();
    fs::write(out.join("notes.txt"), "mine\n").unwrap();
    assert_eq!(run_in(&cfg, &out, &["--force"]), 0);
    for f in [
        "dynamic.csv",
        "dynamic-choice.csv",
        "convergence.csv",
        "convergence-budget.csv",
        "images",
    ] {
        assert!(!out.join(f).exists(), "{f} is stale after --force");
    }
    assert!(out.join("results.csv").is_file() && out.join("notes.txt").is_file());
}

#[test]
fn resume_needs_something_to_resume() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("c.toml");
    fs::write(&cfg, CONFIG).unwrap();
    let out = dir.path().join("never-ran");
    assert_eq!(run_in(&cfg, &out, &["--resume"]), 1);
    assert!(!out.join("results.csv").exists());
}

#[test]
fn a_resumed_run_keeps_the_time_of_a_killed_session() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("c.toml");
    fs::write(&cfg, CONFIG).unwrap();
    let out = dir.path().join("out");
    assert_eq!(run_in(&cfg, &out, &[]), 0);
    // A killed session: its rows and its results.json as written after its last row, with
    // 100 s of work, no status.
    let path = out.join("results.json");
    let mut doc: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(&path).unwrap()).unwrap();
    doc["meta"]["duration_s"] = serde_json::json!(100.0);
    doc["meta"]["status"] = serde_json::Value::Null;
    fs::write(&path, serde_json::to_string(&doc).unwrap()).unwrap();
    let text = fs::read_to_string(out.join("results.csv")).unwrap();
    let first: Vec<&str> = text.lines().take(2).collect();
    fs::write(out.join("results.csv"), first.join("\n") + "\n").unwrap();
    assert_eq!(run_in(&cfg, &out, &["--resume"]), 0);
    let doc: serde_json::Value = serde_json::from_str(&fs::read_to_string(&path).unwrap()).unwrap();
    let d = doc["meta"]["duration_s"].as_f64().unwrap();
    assert!((100.0..200.0).contains(&d), "duration_s {d}");
}

/// Output into a pipe nobody reads (`trace-bench list | head -1` after head has exited):
/// exit 0 and no panic message, rather than exit 101.
#[test]
fn a_closed_output_pipe_ends_quietly() {
    let (reader, writer) = std::io::pipe().unwrap();
    drop(reader);
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_trace-bench"))
        .arg("list")
        .stdout(writer)
        .stderr(std::process::Stdio::piped())
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
}

/// Rays aimed at the scene that all miss (a camera looking away) get a note: their 0
/// mismatches prove nothing.
#[test]
fn rows_whose_aimed_rays_all_miss_say_so() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("c.toml");
    fs::write(
        &cfg,
        r#"
[run]
threads = 1
repeat = 1
warmup = 0

[[scene]]
source = "builtin:cornell"
rays = ["primary"]
camera = { eye = [278, 273, -800], target = [278, 273, -2000], fov = 40, width = 8, height = 8 }

[[structure]]
name = "bvh"
"#,
    )
    .unwrap();
    let out = dir.path().join("out");
    assert_eq!(run_in(&cfg, &out, &[]), 0);
    let rows = tb_results::output::read_csv(&out.join("results.csv")).unwrap();
    assert!(!rows.is_empty());
    for r in &rows {
        assert_eq!(r.hit_rate, Some(0.0));
        assert!(r.note.contains("no ray hit anything"), "{}", r.note);
    }
}
