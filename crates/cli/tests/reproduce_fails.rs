//! `trace-bench reproduce` and `claims` when work does not complete or the input is wrong:
//! a failed run exits non-zero in words, what can be checked is checked before the first run,
//! a folder another process writes to is refused, junk results are refused, and a signal to
//! reproduce ends its run.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const EXE: &str = env!("CARGO_BIN_EXE_trace-bench");

fn config(dir: &Path, structure: &str, repeat: u32) -> PathBuf {
    let p = dir.join(format!("{structure}-{repeat}.toml"));
    fs::write(
        &p,
        format!(
            "name = \"tiny\"\n[run]\nthreads = 1\nrepeat = {repeat}\nwarmup = 0\n\n[[scene]]\nsource = \"builtin:sphereflake\"\nrays = [\"primary\"]\n\n[[structure]]\nname = \"{structure}\"\n"
        ),
    )
    .unwrap();
    p
}

/// A config whose scene file exists but is no OBJ: it passes every check before a run and
/// fails when its run loads the scene.
fn corrupt_scene(dir: &Path) -> PathBuf {
    let obj = dir.join("corrupt.obj");
    fs::write(&obj, "v 1 2 x\nf 1 2 9\n").unwrap();
    let p = dir.join("corrupt-scene.toml");
    fs::write(
        &p,
        format!(
            "name = \"tiny\"\n[run]\nthreads = 1\nrepeat = 3\nwarmup = 0\n\n[[scene]]\nsource = \"{}\"\nrays = [\"primary\"]\n\n[[structure]]\nname = \"kdtree\"\n",
            obj.display()
        ),
    )
    .unwrap();
    p
}

/// A claims file with one run of `cfg` and one counter claim.
fn claims(dir: &Path, cfg: &Path, width: u32) -> PathBuf {
    let p = dir.join("tiny-paper.toml");
    fs::write(
        &p,
        format!(
            r#"paper = "A tiny paper"

[[run]]
config = "{}"
set = ["scene.camera.width={width}", "scene.camera.height={width}"]
cost_s = 1

[[claim]]
id = "hits"
where = "Table 1"
text = "rays hit"
paper = "some"
measure = "hit_rate"
rows.a = {{ structure = "kdtree" }}
test = {{ kind = "value", of = "a", min = 0 }}
"#,
            cfg.display()
        ),
    )
    .unwrap();
    p
}

fn reproduce(claims: &Path, out: &Path, extra: &[&str]) -> Output {
    Command::new(EXE)
        .args([
            "reproduce",
            claims.to_str().unwrap(),
            "--budget",
            "60s",
            "-q",
        ])
        .arg("--out")
        .arg(out)
        .args(extra)
        .output()
        .unwrap()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// `reproduce` ended with exit status 1, its last line naming the one failed run of the tiny
/// paper (`e`: its standard error).
fn assert_one_run_failed(o: &Output, e: &str) {
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(
        e.lines()
            .last()
            .unwrap()
            .starts_with("error: 1 runs failed: tiny-paper"),
        "{e}"
    );
}

#[test]
fn a_failed_run_exits_non_zero_in_words() {
    let t = tempfile::tempdir().unwrap();
    // A config that passes the checks before the first run and fails in its run:
    // a scene file that is there but no OBJ.
    let cfg = corrupt_scene(t.path());
    let c = claims(t.path(), &cfg, 32);
    let out = t.path().join("out");
    let o = reproduce(&c, &out, &[]);
    let e = stderr(&o);
    assert_one_run_failed(&o, &e);
    assert!(e.contains("exit status 1") && !e.contains("Some("), "{e}");
    // The report of what did finish is still written.
    assert!(fs::read_to_string(out.join("REPORT.md"))
        .unwrap()
        .contains("exit status 1"));
}

/// A run in several processes that fails before any row leaves its processes' folders but no
/// CSV: the report of the rest is still written and the failure is said (it ended in
/// "no CSV file in this folder" without a report before).
#[test]
fn a_run_of_several_processes_failing_before_a_row_still_gets_its_report() {
    let t = tempfile::tempdir().unwrap();
    let cfg = corrupt_scene(t.path());
    let c = claims(t.path(), &cfg, 32);
    let text = fs::read_to_string(&c).unwrap();
    fs::write(
        &c,
        text.replace("cost_s = 1\n", "cost_s = 1\nprocesses = 3\n"),
    )
    .unwrap();
    let out = t.path().join("out");
    let o = reproduce(&c, &out, &[]);
    let e = stderr(&o);
    assert_one_run_failed(&o, &e);
    assert!(!e.contains("no CSV file"), "{e}");
    let report = fs::read_to_string(out.join("REPORT.md")).unwrap();
    assert!(report.contains("exit status 1"), "{report}");
}

#[test]
fn configs_and_with_are_checked_before_the_first_run() {
    let t = tempfile::tempdir().unwrap();
    let good = config(t.path(), "kdtree", 3);
    let cases: Vec<(PathBuf, Vec<String>, &str)> = vec![
        (
            t.path().join("nope.toml"),
            vec![],
            "nope.toml: No such file or directory",
        ),
        (
            good.clone(),
            vec![
                "--with".into(),
                t.path().join("absent").display().to_string(),
            ],
            "absent: no such file or folder",
        ),
        (
            good.clone(),
            vec!["--with".into(), {
                let p = t.path().join("other.csv");
                fs::write(&p, "a,b\n1,2\n").unwrap();
                p.display().to_string()
            }],
            "holds no trace-bench results",
        ),
    ];
    for (cfg, extra, want) in cases {
        let c = claims(t.path(), &cfg, 32);
        let out = t.path().join("out");
        let extra: Vec<&str> = extra.iter().map(String::as_str).collect();
        let o = reproduce(&c, &out, &extra);
        let e = stderr(&o);
        assert!(!o.status.success(), "{e}");
        assert!(e.contains(want) && e.trim().lines().count() == 1, "{e}");
        assert!(!out.join("runs").exists(), "nothing ran: {e}");
    }
    // A config whose edits break it.
    fs::write(t.path().join("broken.toml"), "name = \n").unwrap();
    let c = claims(t.path(), &t.path().join("broken.toml"), 32);
    let o = reproduce(&c, &t.path().join("out"), &[]);
    let e = stderr(&o);
    assert!(!o.status.success() && e.contains("broken.toml: "), "{e}");
    assert!(
        e.trim().lines().count() == 1 && !t.path().join("out/runs").exists(),
        "{e}"
    );
}

/// A later run's `set` values are checked before the first run spends any
/// of the budget.
#[test]
fn a_later_runs_edits_are_checked_before_the_first_run() {
    let t = tempfile::tempdir().unwrap();
    let good = config(t.path(), "kdtree", 3);
    let c = claims(t.path(), &good, 32);
    let text = fs::read_to_string(&c).unwrap().replacen(
        "[[claim]]",
        &format!(
            "[[run]]\nconfig = \"{}\"\nset = [\"run.repeat=x\"]\ncost_s = 1\n\n[[claim]]",
            good.display()
        ),
        1,
    );
    fs::write(&c, text).unwrap();
    let out = t.path().join("out");
    let o = reproduce(&c, &out, &[]);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(
        e.contains("run.repeat") && e.trim().lines().count() == 1,
        "{e}"
    );
    assert!(!out.join("runs").exists(), "nothing ran: {e}");
}

/// Commands with nothing to do fail in words: `claims --require-agree` of a
/// file without claims, `reproduce ,`, `compare` of reports with no claim in common.
#[test]
fn commands_with_nothing_to_do_fail() {
    let t = tempfile::tempdir().unwrap();
    let empty = t.path().join("empty.toml");
    fs::write(&empty, "paper = \"No claims\"\n").unwrap();
    let base = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs/baselines/ci.csv");
    let o = Command::new(EXE)
        .args(["claims", empty.to_str().unwrap(), base.to_str().unwrap()])
        .arg("--require-agree")
        .output()
        .unwrap();
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(e.contains("the file has no claim"), "{e}");
    let o = Command::new(EXE)
        .args(["reproduce", ",", "-q", "--out"])
        .arg(t.path().join("r"))
        .output()
        .unwrap();
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(e.trim().lines().count() == 1, "{e}");
    assert!(!t.path().join("r/REPORT.md").exists(), "{e}");
    let report = |name: &str, id: &str| {
        let d = t.path().join(name);
        fs::create_dir_all(&d).unwrap();
        fs::write(
            d.join("verdicts.json"),
            format!(
                r#"{{"papers": [{{"key": "p", "claims": [{{"id": "{id}", "device": "cpu", "verdict": "agree", "timed": false}}]}}]}}"#
            ),
        )
        .unwrap();
        d
    };
    let (a, b) = (report("a", "one"), report("b", "two"));
    let o = Command::new(EXE)
        .arg("compare")
        .arg(&a)
        .arg(&b)
        .output()
        .unwrap();
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(e.contains("no claim in common"), "{e}");
}

#[test]
fn a_run_folder_another_process_writes_is_refused() {
    let t = tempfile::tempdir().unwrap();
    let cfg = config(t.path(), "kdtree", 3);
    let c = claims(t.path(), &cfg, 32);
    let out = t.path().join("out");
    let folder = out.join("runs/tiny-paper/0-kdtree-3");
    let _held = tb_results::lock::FolderLock::acquire(&folder).unwrap();
    let o = reproduce(&c, &out, &[]);
    let e = stderr(&o);
    assert!(!o.status.success(), "{e}");
    assert!(e.contains("another trace-bench run is writing"), "{e}");
    assert!(!out.join("REPORT.md").exists(), "no claims on partial rows");
}

#[test]
fn claims_refuses_sources_without_results() {
    let t = tempfile::tempdir().unwrap();
    let cfg = config(t.path(), "kdtree", 3);
    let c = claims(t.path(), &cfg, 32);
    let d = t.path().join("junk");
    fs::create_dir(&d).unwrap();
    fs::write(d.join("prices.csv"), "item,price\napple,3\n").unwrap();
    let o = Command::new(EXE)
        .args(["claims", c.to_str().unwrap(), d.to_str().unwrap()])
        .output()
        .unwrap();
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(e.contains("junk: holds no trace-bench results"), "{e}");
    assert!(o.stdout.is_empty());
}

/// Linux: the child `run` of an interrupted reproduce is ended and waited for, and the
/// reproduce exits non-zero saying how to resume; a rerun into the same folder resumes the run
/// (no lock of an orphan refuses it), and SIGINT does the same.
#[cfg(target_os = "linux")]
#[test]
fn a_signal_to_reproduce_ends_its_run() {
    let t = tempfile::tempdir().unwrap();
    let cfg = config(t.path(), "kdtree", 1000);
    let c = claims(t.path(), &cfg, 512);
    let out = t.path().join("out");
    for (sig, name, resumed) in [("-TERM", "SIGTERM", false), ("-INT", "SIGINT", true)] {
        let mut p = Command::new(EXE)
            .args(["reproduce", c.to_str().unwrap(), "-q", "--out"])
            .arg(&out)
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        let child = wait_for(|| children_of(p.id()).into_iter().next(), 60.0)
            .expect("reproduce started its run");
        let cmdline = fs::read_to_string(format!("/proc/{child}/cmdline")).unwrap_or_default();
        assert_eq!(cmdline.contains("--resume"), resumed, "{cmdline}");
        std::thread::sleep(std::time::Duration::from_millis(300));
        let k = Command::new("kill")
            .args([sig, &p.id().to_string()])
            .status()
            .unwrap();
        assert!(k.success());
        let st = wait_for(|| p.try_wait().unwrap(), 30.0).expect("reproduce ended");
        let mut e = String::new();
        std::io::Read::read_to_string(p.stderr.as_mut().unwrap(), &mut e).unwrap();
        assert!(!st.success(), "{e}");
        assert!(
            e.contains(&format!("interrupted by {name}")) && e.contains("rerun with --out"),
            "{e}"
        );
        assert!(
            !Path::new(&format!("/proc/{child}")).exists(),
            "run {child} orphaned"
        );
        assert!(!out.join("REPORT.md").exists());
    }
}

#[cfg(target_os = "linux")]
fn children_of(pid: u32) -> Vec<u32> {
    let mut v = Vec::new();
    for e in fs::read_dir("/proc").unwrap().flatten() {
        let Ok(stat) = fs::read_to_string(e.path().join("stat")) else {
            continue;
        };
        // `pid (comm) state ppid …`: the fields after the last `)`.
        let rest = &stat[stat.rfind(')').map_or(0, |i| i + 1)..];
        let ppid = rest.split_whitespace().nth(1).and_then(|x| x.parse().ok());
        if ppid == Some(pid) {
            v.extend(e.file_name().to_str().and_then(|s| s.parse::<u32>().ok()));
        }
    }
    v
}

#[cfg(target_os = "linux")]
fn wait_for<T>(mut f: impl FnMut() -> Option<T>, secs: f64) -> Option<T> {
    let t = std::time::Instant::now();
    while t.elapsed().as_secs_f64() < secs {
        if let Some(x) = f() {
            return Some(x);
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    None
}

#[test]
fn a_budget_below_the_runs_is_said() {
    let t = tempfile::tempdir().unwrap();
    let cfg = config(t.path(), "kdtree", 3);
    let c = claims(t.path(), &cfg, 32);
    fs::write(
        &c,
        fs::read_to_string(&c)
            .unwrap()
            .replace("cost_s = 1", "cost_s = 100"),
    )
    .unwrap();
    let o = Command::new(EXE)
        .args(["reproduce", c.to_str().unwrap(), "--budget", "1s", "-q"])
        .arg("--out")
        .arg(t.path().join("out"))
        .output()
        .unwrap();
    let e = stderr(&o);
    assert!(o.status.success(), "{e}");
    assert!(
        e.contains("note: reproduce: --budget 1s is less than the runs take at their smallest images (about 100 s"),
        "{e}"
    );
}

#[test]
fn out_naming_a_file_is_said() {
    let t = tempfile::tempdir().unwrap();
    let cfg = config(t.path(), "kdtree", 3);
    let c = claims(t.path(), &cfg, 32);
    let file = t.path().join("a-file");
    fs::write(&file, "x").unwrap();
    for args in [
        vec!["run", cfg.to_str().unwrap(), "-q"],
        vec!["reproduce", c.to_str().unwrap(), "-q"],
    ] {
        let o = Command::new(EXE)
            .args(&args)
            .arg("--out")
            .arg(&file)
            .output()
            .unwrap();
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{e}");
        assert_eq!(
            e.trim(),
            format!("error: --out {}: is a file, not a folder", file.display())
        );
    }
}

/// `./` and `../` scene paths are relative to the current directory, for `info` and `run`
/// alike; other relative paths stay under the scenes root.
#[test]
fn dot_paths_are_relative_to_the_current_directory() {
    let t = tempfile::tempdir().unwrap();
    fs::write(
        t.path().join("tri.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    )
    .unwrap();
    let root = t.path().join("root");
    fs::create_dir(&root).unwrap();
    let cmd = |args: &[&str]| {
        Command::new(EXE)
            .current_dir(t.path())
            .args(args)
            .arg("--scenes-root")
            .arg(&root)
            .output()
            .unwrap()
    };
    let o = cmd(&["info", "./tri.obj"]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success() && out.contains("triangles   1"),
        "{out}{}",
        stderr(&o)
    );
    let sub = t.path().join("sub");
    fs::create_dir(&sub).unwrap();
    let o = Command::new(EXE)
        .current_dir(&sub)
        .args(["info", "../tri.obj", "--scenes-root"])
        .arg(&root)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let o = cmd(&["info", "tri.obj"]);
    assert!(
        !o.status.success() && stderr(&o).contains("root/tri.obj"),
        "{}",
        stderr(&o)
    );
    fs::write(
        t.path().join("c.toml"),
        "name = \"t\"\n[run]\nthreads = 1\nrepeat = 1\nwarmup = 0\n\n[[scene]]\nsource = \"./tri.obj\"\nrays = [\"primary\"]\ncamera = { width = 32, height = 32, eye = [0.3, 0.3, 2.0], target = [0.3, 0.3, 0.0], fov = 40.0 }\n\n[[structure]]\nname = \"kdtree\"\n",
    )
    .unwrap();
    let o = cmd(&["run", "c.toml", "-q", "--out", "o"]);
    assert!(o.status.success(), "{}", stderr(&o));
}
