//! Every value a user gives is checked where it is read, with one line naming it.
//! This walks what a user can give and tries bad values of each:
//!
//! - **The config reference** (README.md's TOML block, "Config reference"): every key it
//!   shows, at every depth, set with `--set` on a small valid config, to a value of the wrong
//!   type, a number that is not finite, and (for the keys whose example is a number at least
//!   0, coordinates aside) a negative one; each must be refused naming the key. A key added to
//!   the reference is walked with no edit here.
//! - **The flags**: every option of every subcommand that takes a value (from clap's
//!   definition of the command line) must have its bad values listed here, and each is refused
//!   with exit 1 or 2 and one `error:` line naming the flag, or the value.
//! - **The environment variables** the binary reads: a bad value of each is refused the same
//!   way.

use std::path::{Path, PathBuf};
use std::process::Command;
use tb_harness::experiment::config::{self, Overrides};

const BIN: &str = env!("CARGO_BIN_EXE_trace-bench");

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// A small valid config every case edits.
const BASE: &str = r#"name = "every"
[run]
repeat = 1
warmup = 0
[[scene]]
source = "builtin:cornell"
rays = ["primary"]
camera = { width = 8, height = 8 }
[[structure]]
name = "bvh"
"#;

/// A valid config of the `[dynamic]` experiment (docs/reports.md), which needs an animated
/// built-in scene and a grid taking densities.
const DYNAMIC_BASE: &str = r#"name = "every-dynamic"
[[scene]]
source = "builtin:explode?tess=2"
[[structure]]
name = "two-level-grid"
[dynamic]
frames = [0]
resolution = [8, 8]
"#;

/// The first TOML block of `file` after `heading` (a config reference), parsed.
fn toml_block(file: &str, heading: &str) -> toml::Table {
    let text = std::fs::read_to_string(repo().join(file)).unwrap();
    let at = text
        .find(heading)
        .unwrap_or_else(|| panic!("{file} has {heading}"));
    let block = &text[at..];
    let start = block.find("```toml\n").expect("its TOML block") + 8;
    let end = block[start..].find("```").unwrap() + start;
    toml::from_str(&block[start..end]).unwrap_or_else(|e| panic!("{file}: {e}"))
}

/// The README's config reference as TOML.
fn reference() -> toml::Table {
    toml_block("README.md", "## Config reference")
}

/// Every key of the reference with its example value (`scene.camera.width`, 256); arrays of
/// tables are entered (their keys under the array's name), inline tables too.
fn keys(prefix: &str, t: &toml::Table, out: &mut Vec<(String, toml::Value)>) {
    for (k, v) in t {
        let key = if prefix.is_empty() {
            k.clone()
        } else {
            format!("{prefix}.{k}")
        };
        match v {
            toml::Value::Table(sub) => keys(&key, sub, out),
            toml::Value::Array(a) if a.iter().all(toml::Value::is_table) && !a.is_empty() => {
                out.push((key.clone(), v.clone()));
                for item in a {
                    if let toml::Value::Table(sub) = item {
                        keys(&key, sub, out);
                    }
                }
            }
            _ => out.push((key, v.clone())),
        }
    }
}

/// Keys whose numbers may be negative (coordinates).
fn signed(key: &str) -> bool {
    ["eye", "target", "up", "light", "at"]
        .iter()
        .any(|k| key.ends_with(&format!(".{k}")))
}

/// The bad values of a key with example value `v`.
fn bad_values(key: &str, v: &toml::Value) -> Vec<String> {
    use toml::Value::*;
    let number = |x: &toml::Value| matches!(x, Integer(_) | Float(_));
    let nonneg = |x: &toml::Value| match x {
        Integer(i) => *i >= 0,
        Float(f) => *f >= 0.0,
        _ => false,
    };
    let mut out = Vec::new();
    match v {
        String(_) => out.push("1".into()),
        Boolean(_) => out.extend(["\"x\"".into(), "2".into()]),
        Integer(_) | Float(_) => {
            out.extend(["\"x\"".into(), "nan".into(), "inf".into()]);
            if nonneg(v) && !signed(key) {
                out.push("-1".into());
            }
        }
        Array(a) if a.iter().all(number) && !a.is_empty() => {
            out.extend(["\"x\"".into(), "[nan, 1, 1]".into(), "[\"x\"]".into()]);
            if a.iter().all(nonneg) && !signed(key) {
                out.push("[-1]".into());
            }
        }
        Array(a) if a.iter().all(toml::Value::is_str) => {
            out.extend(["1".into(), "[1]".into()]);
        }
        Array(_) => out.push("\"x\"".into()),
        Table(_) => out.push("\"x\"".into()),
        Datetime(_) => out.push("1".into()),
    }
    out
}

/// Keys whose strings may be numbers too (`validate = "all" | "off" | N`): their bad string
/// is a made-up word, their bad numbers below 1 or not finite.
fn string_or_number(key: &str) -> bool {
    key == "run.validate"
}

/// Keys whose strings are names from a fixed list: a made-up one must be refused too.
fn enumerated(key: &str) -> bool {
    [
        "run.clock",
        "run.triangle_test",
        "run.devices",
        "run.gpu_backend",
        "run.validate",
        "run.heatmap_colormap",
        "scene.rays",
        "scene.camera.order",
        "scene.source",
        "structure.name",
        "structure.traversals",
        "convergence.integrators",
        "convergence.schedule",
    ]
    .contains(&key)
}

fn refused(base: &str, sets: &[String]) -> Result<String, ()> {
    let ov = Overrides {
        sets: sets.to_vec(),
        ..Default::default()
    };
    match config::parse(Path::new("every.toml"), base, &ov, &mut |_| {}) {
        Ok(_) => Err(()),
        Err(e) => Ok(e.to_string()),
    }
}

#[test]
fn every_key_of_the_config_reference_refuses_bad_values() {
    let mut all = Vec::new();
    keys("", &reference(), &mut all);
    assert!(all.len() > 50, "the reference shows {} keys", all.len());
    walk(BASE, &all);
}

#[test]
fn every_key_of_the_dynamic_section_refuses_bad_values() {
    for base in [BASE, DYNAMIC_BASE] {
        // The base configs themselves are valid.
        assert!(refused(base, &[]).is_err(), "{base}");
    }
    let mut all = Vec::new();
    keys("", &toml_block("docs/reports.md", "[dynamic]"), &mut all);
    assert_eq!(all.len(), 5, "{all:?}");
    walk(DYNAMIC_BASE, &all);
}

fn walk(base: &str, all: &[(String, toml::Value)]) {
    let mut failures = Vec::new();
    let mut tried = 0;
    for (key, example) in all {
        let mut values = bad_values(key, example);
        if string_or_number(key) {
            values = vec!["0".into(), "-1".into(), "nan".into()];
        }
        if enumerated(key) {
            values.push("\"bogus\"".into());
        }
        // The key is named, or (where the base config has no such table: `inset`, `views`)
        // the table the value would go in.
        let mut parts: Vec<&str> = key.split('.').collect();
        let last = parts.pop().unwrap();
        let parent = parts.pop().unwrap_or(last);
        for v in values {
            tried += 1;
            let set = format!("{key}={v}");
            match refused(base, std::slice::from_ref(&set)) {
                Err(()) => failures.push(format!("--set {set}: accepted")),
                Ok(e) if !(e.contains(last) || e.contains(parent)) || e.contains('\n') => failures
                    .push(format!(
                        "--set {set}: the error does not name `{last}` in one line: {e}"
                    )),
                Ok(_) => {}
            }
        }
    }
    println!("{tried} bad values of {} keys tried", all.len());
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

// ---------------------------------------------------------------------------------------------
// Flags

/// The files the flags' cases name (written once per test).
struct Files {
    _dir: tempfile::TempDir,
    /// A valid config of built-in scenes.
    config: String,
    /// A valid config of one file scene (`--scenes-root` matters to it).
    file_config: String,
    /// A results.csv, a folder of one, a claims file.
    results: String,
    folder: String,
    claims: String,
    /// A plain file (not a folder) and a path that does not exist.
    file: String,
    missing: String,
    /// A path for outputs (its folder exists, it does not).
    out: String,
    /// A claims file with one quick run of `config`.
    paper: String,
    /// Two heat-map EXRs of the same size (channels `steps`, `handovers`).
    exr_a: String,
    exr_b: String,
    /// A reproduce report folder (its verdicts.json).
    report: String,
}

fn files() -> Files {
    let dir = tempfile::tempdir().unwrap();
    let p = |n: &str| dir.path().join(n).display().to_string();
    std::fs::write(p("c.toml"), BASE).unwrap();
    std::fs::write(
        p("f.toml"),
        "[[scene]]\nsource = \"cornell-box/CornellBox-Original.obj\"\n[[structure]]\nname = \"bvh\"\n",
    )
    .unwrap();
    let baseline = repo().join("configs/baselines/ci.csv");
    std::fs::create_dir_all(p("folder")).unwrap();
    std::fs::copy(&baseline, p("folder/results.csv")).unwrap();
    std::fs::write(p("plain.txt"), "x").unwrap();
    std::fs::create_dir_all(p("out")).unwrap();
    std::fs::write(
        p("paper.toml"),
        format!(
            "paper = \"A tiny paper\"\n[[run]]\nconfig = \"{}\"\ncost_s = 1\n[[claim]]\n\
             id = \"hits\"\nwhere = \"Table 1\"\ntext = \"rays hit\"\npaper = \"some\"\n\
             measure = \"hit_rate\"\nrows.a = {{ structure = \"bvh\" }}\n\
             test = {{ kind = \"value\", of = \"a\", min = 0 }}\n",
            p("c.toml")
        ),
    )
    .unwrap();
    for name in ["a.exr", "b.exr"] {
        let mut img = tb_render::Channels::new(4, 4);
        img.push("steps", vec![1.0; 16]).unwrap();
        img.push("handovers", vec![0.0; 16]).unwrap();
        img.write_exr(&dir.path().join(name)).unwrap();
    }
    std::fs::create_dir_all(p("report")).unwrap();
    std::fs::write(
        p("report/verdicts.json"),
        r#"{"papers": [{"key": "p", "claims": [{"id": "c", "device": "cpu", "verdict": "agree", "timed": false}]}]}"#,
    )
    .unwrap();
    Files {
        config: p("c.toml"),
        file_config: p("f.toml"),
        results: baseline.display().to_string(),
        folder: p("folder"),
        claims: repo().join("claims/ci.toml").display().to_string(),
        file: p("plain.txt"),
        missing: p("missing/nothing"),
        out: p("out/o"),
        paper: p("paper.toml"),
        exr_a: p("a.exr"),
        exr_b: p("b.exr"),
        report: p("report"),
        _dir: dir,
    }
}

/// One flag's bad values: the subcommand, the argument's id (clap's: the long name with `_`,
/// or the positional's name), the command line before it and its bad values.
struct Case {
    sub: &'static str,
    id: &'static str,
    base: Vec<String>,
    bad: Vec<String>,
}

fn v(a: &[&str]) -> Vec<String> {
    a.iter().map(|s| s.to_string()).collect()
}

fn cases(f: &Files) -> Vec<Case> {
    let run = || v(&["run", &f.config, "--out", &f.out, "-q"]);
    let validate = || v(&["validate", &f.config, "-q"]);
    let check = || v(&["check", "--baseline", &f.results, &f.results]);
    let claims = || v(&["claims", &f.claims, &f.folder]);
    let weights = || v(&["weights"]);
    let reproduce = || v(&["reproduce", &f.paper, "--out", &f.out, "-q"]);
    let diff = || v(&["diff", &f.exr_a, &f.exr_b, "--out", &f.out]);
    let c = |sub, id, base: Vec<String>, bad: &[&str]| Case {
        sub,
        id,
        base,
        bad: v(bad),
    };
    vec![
        // run
        c("run", "config", v(&["run"]), &[&f.missing, &f.folder]),
        c("run", "out", run(), &[&f.file]),
        c("run", "cache_dir", run(), &[&f.file, "", "off"]),
        c("run", "threads", run(), &["x", "-1", "99999", "1,x"]),
        c("run", "repeat", run(), &["x", "-1", "0"]),
        c("run", "device", run(), &["tpu", "cpu,tpu"]),
        c(
            "run",
            "adapter",
            v(&["run", &f.config, "--out", &f.out, "-q", "--device", "gpu"]),
            &["no-such-adapter-x"],
        ),
        c("run", "backend", run(), &["bogus"]),
        c("run", "scenes", run(), &["no-such-scene"]),
        c("run", "structures", run(), &["bogus", "bvh:bogus"]),
        c(
            "run",
            "sets",
            run(),
            &["noequals", "run.repeat=x", "bogus.key=1", "run.repeat=nan"],
        ),
        c("run", "shard", run(), &["0/3", "4/3", "x", "1/0"]),
        c("run", "processes", run(), &["0", "65", "x"]),
        c("run", "process", run(), &["3/2", "x", "-1/2"]),
        c(
            "run",
            "scenes_root",
            v(&["run", &f.file_config, "--out", &f.out, "-q"]),
            &[&f.missing],
        ),
        // validate
        c("validate", "config", v(&["validate"]), &[&f.missing]),
        c(
            "validate",
            "scenes_root",
            v(&["validate", &f.file_config, "-q"]),
            &[&f.missing],
        ),
        c("validate", "scenes", validate(), &["no-such-scene"]),
        c("validate", "structures", validate(), &["bogus"]),
        c(
            "validate",
            "sets",
            validate(),
            &["noequals", "run.threads=[-1]"],
        ),
        c("validate", "show", validate(), &["x", "-1"]),
        // check
        c(
            "check",
            "baseline",
            v(&["check", &f.results, "--baseline"]),
            &[&f.missing, &f.file],
        ),
        c(
            "check",
            "results",
            v(&["check", "--baseline", &f.results]),
            &[&f.missing, &f.file],
        ),
        c("check", "tolerance", check(), &["x", "nan", "inf", "-1"]),
        // diff
        c(
            "diff",
            "a",
            v(&["diff", "--out", &f.out, &f.exr_b]),
            &[&f.missing, &f.file],
        ),
        c(
            "diff",
            "b",
            v(&["diff", "--out", &f.out, &f.file]),
            &[&f.missing],
        ),
        c("diff", "channel", diff(), &["bogus"]),
        c("diff", "split", diff(), &["bogus"]),
        c("diff", "max", diff(), &["x", "nan", "-1", "0"]),
        c(
            "diff",
            "out",
            v(&["diff", &f.exr_a, &f.exr_b]),
            &[&f.folder],
        ),
        // merge
        c(
            "merge",
            "dirs",
            v(&["merge", "--out", &f.out]),
            &[&f.missing, &f.file],
        ),
        c("merge", "out", v(&["merge", &f.folder]), &[&f.file]),
        // weights
        c(
            "weights",
            "beta",
            weights(),
            &["x", "nan", "-1", "0", "inf"],
        ),
        c("weights", "decimals", weights(), &["x", "-1", "99"]),
        // (a missing folder of `--csv` is made, as `run --out`'s is)
        c("weights", "csv", weights(), &[&f.folder]),
        // reproduce
        c(
            "reproduce",
            "paper",
            v(&["reproduce", "--out", &f.out, "-q"]),
            &["bogus", ",", ""],
        ),
        c("reproduce", "budget", reproduce(), &["x", "0", "-1m"]),
        c("reproduce", "device", reproduce(), &["tpu"]),
        c(
            "reproduce",
            "out",
            v(&["reproduce", &f.paper, "-q"]),
            &[&f.file],
        ),
        c(
            "reproduce",
            "claims_dir",
            v(&["reproduce", "all", "--out", &f.out, "-q"]),
            &[&f.missing],
        ),
        c("reproduce", "with", reproduce(), &[&f.missing, &f.file]),
        c("reproduce", "scenes_root", reproduce(), &[&f.file]),
        c("reproduce", "cache_dir", reproduce(), &[&f.file, "", "off"]),
        c(
            "reproduce",
            "sets",
            reproduce(),
            &["noequals", "run.repeat=x"],
        ),
        c(
            "reproduce",
            "adapter",
            v(&[
                "reproduce",
                &f.paper,
                "--out",
                &f.out,
                "-q",
                "--device",
                "gpu",
            ]),
            &[""],
        ),
        c("reproduce", "deadline", reproduce(), &["x", "0"]),
        // claims
        c(
            "claims",
            "claims",
            v(&["claims", &f.folder, "--claims"]),
            &[],
        ),
        c(
            "claims",
            "results",
            v(&["claims", &f.claims]),
            &[&f.missing, &f.file],
        ),
        c("claims", "format", claims(), &["bogus"]),
        c("claims", "only", claims(), &["bogus"]),
        c("claims", "width", claims(), &["x", "-1", "0", "39"]),
        c("claims", "time_floor", claims(), &["x", "nan", "-1"]),
        // compare
        c(
            "compare",
            "reports",
            v(&["compare", &f.report]),
            &[&f.missing, &f.file, &f.folder],
        ),
        // info
        c(
            "info",
            "scene",
            v(&["info"]),
            &["builtin:bogus", &f.missing],
        ),
        c(
            "info",
            "scenes_root",
            v(&["info", "cornell-box/CornellBox-Original.obj"]),
            &[&f.missing],
        ),
    ]
}

/// Run the binary; (exit code, stderr).
fn trace_bench(args: &[String]) -> (i32, String) {
    let o = Command::new(BIN)
        .args(args)
        .env_remove("TRACE_BENCH_SCENES")
        .output()
        .unwrap();
    (
        o.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

/// The argument line for a bad `value` of `case`: a positional replaces the base's last
/// (or is appended), an option is appended as `--flag=value` (so `-1` is its value).
fn line(case: &Case, long: Option<&str>, value: &str) -> Vec<String> {
    let mut a = case.base.clone();
    match long {
        Some(l) => a.push(format!("--{l}={value}")),
        None => a.push(value.to_owned()),
    }
    a
}

#[test]
fn every_flag_refuses_bad_values() {
    let f = files();
    let listed = cases(&f);
    let index = |sub: &str, id: &str| listed.iter().position(|c| c.sub == sub && c.id == id);
    let cmd = trace_bench::command();
    let mut failures = Vec::new();
    let mut tried = 0;
    for sub in cmd.get_subcommands() {
        for arg in sub.get_arguments() {
            let id = arg.get_id().as_str();
            if id == "help" || !arg.get_action().takes_values() {
                continue;
            }
            let Some(at) = index(sub.get_name(), id) else {
                failures.push(format!(
                    "`{} {id}` takes a value and has no bad values listed here",
                    sub.get_name()
                ));
                continue;
            };
            let long = arg.get_long();
            let case = &listed[at];
            // `claims CLAIMS`: any file that is no claims file, tried below.
            let bad = if sub.get_name() == "claims" && id == "claims" {
                vec![f.missing.clone(), f.folder.clone(), f.results.clone()]
            } else {
                case.bad.clone()
            };
            for value in &bad {
                tried += 1;
                // Each value on fresh files: a case accepting its bad value must not leave
                // files that another case then finds (the same paths, new folder).
                let fresh = files();
                let (value, case) = (
                    value.replace(
                        &f._dir.path().display().to_string(),
                        &fresh._dir.path().display().to_string(),
                    ),
                    &cases(&fresh)[at],
                );
                let value = &value;
                let args = if sub.get_name() == "claims" && id == "claims" {
                    v(&["claims", value, &fresh.folder])
                } else {
                    line(case, long, value)
                };
                let (code, err) = trace_bench(&args);
                // Mesa's Vulkan driver says `error: XDG_RUNTIME_DIR is invalid or not set` on
                // its own where that variable is unset (CI): not a line of ours.
                let errors: Vec<&str> = err
                    .lines()
                    .filter(|l| l.starts_with("error:") && !l.contains("XDG_RUNTIME_DIR"))
                    .collect();
                let named = long.is_some_and(|l| err.contains(&format!("--{l}")))
                    || (!value.is_empty() && err.contains(value.as_str()))
                    || value
                        .rsplit([':', '=', ','])
                        .next()
                        .is_some_and(|last| !last.is_empty() && err.contains(last))
                    || err.contains(&id.replace('_', "-"))
                    || err.to_uppercase().contains(&id.to_uppercase());
                if code == 0
                    || code == 101
                    || errors.len() != 1
                    || !named
                    || err.contains("panicked")
                {
                    failures.push(format!(
                        "trace-bench {}: exit {code}, stderr: {}",
                        args.join(" "),
                        err.trim().replace('\n', " | ")
                    ));
                }
            }
        }
    }
    println!("{tried} bad flag values tried");
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn every_environment_variable_refuses_bad_values() {
    let names = trace_bench::env_names();
    assert!(names.len() >= 8, "{names:?}");
    for name in names {
        let o = Command::new(BIN)
            .arg("list")
            .env(name, "  ")
            .env_remove("TRACE_BENCH_SCENES")
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{name}: {err}");
        assert!(
            err.starts_with(&format!("error: {name}=")) && err.lines().count() == 1,
            "{name}: {err}"
        );
    }
}
