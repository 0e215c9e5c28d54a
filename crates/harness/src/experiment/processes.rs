//! `trace-bench run --processes K` (or `run.processes = K`): the whole run made `K` times, each
//! in a process of its own, one after another, so that the variation between processes
//! (memory placement, the machine's state; the same rows moved by up to 31 % between processes
//! on the 2-core reference machine, `claims/README.md`, Verdicts) is measured per config and
//! machine instead of assumed.
//!
//! Process `I` is `trace-bench run CONFIG … --process I/K --out OUT/process-I`, a normal run:
//! its rows carry `process = I`, and the odd processes build and time the structure entries in
//! reverse order (with `run.interleave`, each round's rows too), so what running first or last
//! does to a row falls on either side of a comparison alike (the counterbalanced, ABBA, order
//! of repeated-measures designs). After each process, the rows of the processes made so far are
//! merged into `OUT` (`results.csv`, `params.csv`, `results.json`: [`merge`]): an interruption
//! loses at most the process in progress, whose own folder keeps its finished rows, as a
//! shard's does (`run --shard`, [`tb_results::merge`]); `--resume` reuses the complete
//! processes and resumes the others. The claims evaluator compares times between processes
//! (tb-claims: the spread of the per-process values).
//!
//! **Count once.** Counters are deterministic: a later process copies the counters and hit
//! rates of the first process's rows ([`first_rows`]) where that process finished with the
//! same binary and config, instead of counting its whole batches again; it still checks its
//! oracle samples with the timed code and times as before.

use crate::error::HarnessError;
use serde_json::{json, Value};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Instant;
use tb_results::output::{read_csv_resume, Row};

/// The most processes a run is made in (the range of its rows' `process` column).
pub const MAX: usize = tb_results::output::MAX_PROCESSES;

/// One process of a run of `of`: `index` in `0..of`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Process {
    /// This process's index, 0-based.
    pub index: usize,
    /// How many processes the run is made in.
    pub of: usize,
}

impl Process {
    /// Parse `I/K` (`I` from 0 to `K - 1`, `K` at most [`MAX`]).
    pub fn parse(s: &str) -> Result<Process, String> {
        let (i, k) = s
            .split_once('/')
            .ok_or_else(|| format!("`{s}`: expected I/K (e.g. 1/3: the second of three)"))?;
        let num = |v: &str| {
            v.trim()
                .parse::<usize>()
                .map_err(|_| format!("`{s}`: `{v}` is not a whole number"))
        };
        let (index, of) = (num(i)?, num(k)?);
        if of == 0 || of > MAX || index >= of {
            return Err(format!(
                "`{s}`: I must be in 0..K (0-based) and K in 1..={MAX}"
            ));
        }
        Ok(Process { index, of })
    }

    /// Whether this process runs the structure entries in reverse order (the odd ones).
    pub fn reversed(self) -> bool {
        self.index % 2 == 1
    }

    /// The process as results.json's `meta.process` records it.
    pub fn meta(self) -> Value {
        json!({
            "index": self.index,
            "of": self.of,
            "structures": if self.reversed() { "reversed" } else { "as written" },
        })
    }
}

impl std::fmt::Display for Process {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.of)
    }
}

/// The folder of process `i` in the run's folder `out`.
pub fn folder(out: &Path, i: usize) -> PathBuf {
    out.join(format!("process-{i}"))
}

/// What `run --processes` makes.
#[derive(Clone, Debug)]
pub struct Plan {
    /// The trace-bench executable.
    pub exe: PathBuf,
    /// `run CONFIG` and the options every process gets, but `--out`, `--process`, `--resume`,
    /// `--force` and `--quiet`.
    pub args: Vec<String>,
    /// The run's folder: the merged rows, and each process's folder in it.
    pub out: PathBuf,
    /// Processes to make, one after another.
    pub n: usize,
    /// Reuse the complete processes' folders, resume the others.
    pub resume: bool,
    /// Replace the processes' results (`run --force` for each).
    pub force: bool,
    /// No progress lines on stderr (each process gets `--quiet`).
    pub quiet: bool,
}

/// How one process went.
#[derive(Clone, Debug)]
pub struct Outcome {
    /// The process's folder (`OUT/process-I`).
    pub folder: PathBuf,
    /// Complete from an earlier session (`--resume`): not run again.
    pub reused: bool,
    /// Its wall seconds (`None`: not run in this session).
    pub wall_s: Option<f64>,
    /// How it failed (`exit status 1`, `did not start: …`).
    pub failed: Option<String>,
    /// It completed with rows that mismatch the oracle ([`tb_results::EXIT_MISMATCHES`]).
    pub mismatched: bool,
}

/// What `run --processes` did.
#[derive(Clone, Debug, Default)]
pub struct Report {
    /// How each process went, in order.
    pub processes: Vec<Outcome>,
    /// Rows in the merged `results.csv`.
    pub rows: usize,
    /// The merged folder's status (`complete`, `complete-with-failures`, `incomplete`).
    pub status: String,
}

/// A run folder's `meta.status`, if it has a readable results.json.
fn status(dir: &Path) -> Option<String> {
    meta_of(dir).and_then(|m| m["status"].as_str().map(str::to_owned))
}

fn meta_of(dir: &Path) -> Option<Value> {
    let text = std::fs::read_to_string(dir.join("results.json")).ok()?;
    let v: Value = serde_json::from_str(&text).ok()?;
    Some(v["meta"].clone())
}

/// Whether a process folder's run went to its end (with or without failed builds).
fn finished(dir: &Path) -> bool {
    matches!(
        status(dir).as_deref(),
        Some("complete" | "complete-with-failures")
    )
}

/// The rows of the first process of the run whose process `process` is, into `out`
/// (`OUT/process-I`, I ≥ 1), where that first process finished with this binary and this
/// config (`config_hash`): the later processes copy its
/// counters (count once, [`crate::experiment::device::cpu::CpuDevice::count_once`]). `None`
/// for the first process, a run of one process, or a first process that cannot be trusted.
pub fn first_rows(process: Option<Process>, config_hash: &str, out: &Path) -> Option<Vec<Row>> {
    let p = process.filter(|p| p.index > 0)?;
    let parent = out.parent()?;
    if out != folder(parent, p.index) {
        return None;
    }
    let first = folder(parent, 0);
    let meta = meta_of(&first)?;
    let same = finished(&first)
        && meta["config_hash"].as_str() == Some(config_hash)
        && meta["binary_digest"].as_str() == Some(crate::experiment::cache::exe_digest());
    if !same {
        return None;
    }
    read_csv_resume(&first.join("results.csv"))
        .ok()
        .map(|(rows, _)| rows)
}

/// Make the plan's processes one after another, merging after each; a signal ends the process
/// in progress and returns an error (the finished processes' rows are merged, its own stay in
/// its folder for `--resume`).
pub fn run(plan: &Plan) -> Result<Report, HarnessError> {
    crate::experiment::child::catch_signals();
    let mut report = Report::default();
    for i in 0..plan.n {
        let dir = folder(&plan.out, i);
        if plan.resume && !plan.force && finished(&dir) {
            report.processes.push(Outcome {
                folder: dir,
                reused: true,
                wall_s: None,
                failed: None,
                mismatched: false,
            });
            continue;
        }
        let mut args = plan.args.clone();
        args.extend([
            "--out".into(),
            dir.display().to_string(),
            "--process".into(),
            Process {
                index: i,
                of: plan.n,
            }
            .to_string(),
        ]);
        if plan.quiet {
            args.push("--quiet".into());
        }
        if plan.force {
            args.push("--force".into());
        } else if plan.resume && dir.join("results.json").is_file() {
            args.push("--resume".into());
        }
        if !plan.quiet {
            eprintln!("process {i} of {} (0-based) into {}", plan.n, dir.display());
        }
        let t = Instant::now();
        let mut cmd = Command::new(&plan.exe);
        cmd.args(&args).stdout(Stdio::null());
        let ran = crate::experiment::child::run(&mut cmd);
        let mut outcome = Outcome {
            folder: dir.clone(),
            reused: false,
            wall_s: Some(t.elapsed().as_secs_f64()),
            failed: None,
            mismatched: false,
        };
        let sig = match ran {
            Ok((st, sig)) => {
                if st.code() == Some(tb_results::EXIT_MISMATCHES) {
                    outcome.mismatched = true;
                } else if !st.success() {
                    outcome.failed = Some(crate::experiment::child::ended(&st));
                }
                sig
            }
            Err(e) => {
                outcome.failed = Some(format!("did not start: {e}"));
                None
            }
        };
        let began = dir.join("results.json").is_file();
        report.processes.push(outcome);
        let merged = merge(&plan.out, plan.n)?;
        report.rows = merged.0;
        report.status = merged.1;
        if let Some(sig) = sig {
            return Err(HarnessError::other(format!(
                "run: interrupted by {} in process {i} of {} (its finished rows stay in {}; the \
                 finished processes' are merged in {}): rerun with --resume to go on",
                crate::experiment::child::signal_name(sig),
                plan.n,
                dir.display(),
                plan.out.display()
            )));
        }
        if !began {
            // A process that wrote nothing failed before its first row (a config or scene
            // error): the next would fail alike.
            return Err(HarnessError::other(format!(
                "run: process {i} of {} failed before writing a row ({}); see its error above",
                plan.n,
                report.processes[i]
                    .failed
                    .as_deref()
                    .unwrap_or("no results")
            )));
        }
    }
    if report.processes.iter().all(|p| p.reused) {
        let merged = merge(&plan.out, plan.n)?;
        report.rows = merged.0;
        report.status = merged.1;
    }
    Ok(report)
}

/// The processes' `meta[key]` objects summed field by field (numbers added, the first
/// process's other values kept): the phases and build-cache figures of the whole run.
fn sum_of(list: &[Value], key: &str) -> Value {
    let mut out = serde_json::Map::new();
    for p in list {
        let Some(m) = p[key].as_object() else {
            continue;
        };
        for (k, v) in m {
            match (out.get(k).and_then(Value::as_f64), v.as_f64()) {
                (Some(a), Some(b)) if v.is_u64() => {
                    out.insert(k.clone(), json!(a as u64 + b as u64))
                }
                (Some(a), Some(b)) => out.insert(k.clone(), json!(((a + b) * 1e3).round() / 1e3)),
                (None, _) => out.insert(k.clone(), v.clone()),
                _ => None,
            };
        }
    }
    Value::Object(out)
}

/// Merge the folders of the processes `0..n` of the run in `out` that have begun into `out`:
/// their rows in process order (each keeps its `process`), `params.csv`, and results.json with
/// process 0's metadata less `process`, plus `processes` (each process's folder, start,
/// duration, status, rows and structure order); its status is `complete` only when all `n`
/// are. `convergence.csv`, `convergence-budget.csv` and `images/` are process 0's (renders and
/// heat maps do not depend on the process). Refuses folders of another config. The rows and
/// the status.
pub fn merge(out: &Path, n: usize) -> Result<(usize, String), HarnessError> {
    let mut rows: Vec<Row> = Vec::new();
    let mut first: Option<(PathBuf, Value)> = None;
    let mut list = Vec::new();
    let mut statuses = Vec::new();
    for i in 0..n {
        let dir = folder(out, i);
        let Some(meta) = meta_of(&dir) else {
            statuses.push("missing".to_owned());
            continue;
        };
        if let Some((d0, m0)) = &first {
            if m0["config_hash"] != meta["config_hash"] {
                return Err(HarnessError::other(format!(
                    "refusing to merge processes: {} has config hash {}, {} has {}",
                    d0.display(),
                    m0["config_hash"],
                    dir.display(),
                    meta["config_hash"]
                )));
            }
        }
        let csv = dir.join("results.csv");
        let (mut own, _torn) = if csv.is_file() {
            read_csv_resume(&csv)?
        } else {
            (Vec::new(), 0)
        };
        for r in &mut own {
            r.process = Some(i as u32);
        }
        let status = meta["status"].as_str().unwrap_or("running").to_owned();
        list.push(json!({
            "index": i,
            "dir": dir.display().to_string(),
            "start": meta["start"],
            "end": meta["end"],
            "duration_s": meta["duration_s"],
            "status": status,
            "resumed": meta["resumed"],
            "structures": meta["process"]["structures"],
            "rows": own.len(),
            "phases": meta["phases"],
            "build_cache": meta["build_cache"],
        }));
        statuses.push(status);
        rows.extend(own);
        if first.is_none() {
            first = Some((dir, meta));
        }
    }
    let Some((_, mut meta)) = first else {
        return Ok((0, "incomplete".into()));
    };
    let status = if statuses.iter().all(|s| s == "complete") {
        "complete"
    } else if statuses
        .iter()
        .all(|s| s == "complete" || s == "complete-with-failures")
    {
        "complete-with-failures"
    } else {
        "incomplete"
    };
    let field = |k: &'static str| list.iter().filter_map(move |p| p[k].as_str());
    let (start, end) = (field("start").min(), field("end").max());
    let duration: f64 = list.iter().filter_map(|p| p["duration_s"].as_f64()).sum();
    if let Some(m) = meta.as_object_mut() {
        m.remove("process");
        m.remove("resumed");
        m.insert("start".into(), json!(start));
        m.insert("end".into(), json!(end));
        m.insert("duration_s".into(), json!((duration * 1e3).round() / 1e3));
        m.insert("status".into(), json!(status));
        m.insert("phases".into(), sum_of(&list, "phases"));
        m.insert("build_cache".into(), sum_of(&list, "build_cache"));
        m.insert("processes".into(), json!({ "n": n, "processes": list }));
    }
    tb_results::output::write_all(out, meta, &rows)?;
    let p0 = folder(out, 0);
    for f in ["convergence.csv", "convergence-budget.csv"] {
        if p0.join(f).is_file() {
            std::fs::copy(p0.join(f), out.join(f)).map_err(|e| HarnessError::io(out.join(f), e))?;
        }
    }
    tb_results::merge::copy_images(&p0.join("images"), &out.join("images"))?;
    Ok((rows.len(), status.into()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn processes_parse_zero_based_and_the_odd_ones_reverse() {
        assert_eq!(Process::parse("0/3"), Ok(Process { index: 0, of: 3 }));
        assert!(!Process::parse("0/3").unwrap().reversed());
        assert!(Process::parse("1/3").unwrap().reversed());
        for bad in ["3/3", "1/0", "a/3", "3", "0/65"] {
            assert!(Process::parse(bad).is_err(), "{bad}");
        }
        assert_eq!(Process { index: 2, of: 5 }.to_string(), "2/5");
    }

    /// The merged folder holds the begun processes' rows, each tagged, and says `complete`
    /// only when every process is.
    #[test]
    fn merges_the_begun_processes_and_says_what_is_missing() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path();
        let write = |i: usize, status: &str, rows: usize| {
            let meta = json!({ "config_hash": "h", "status": status, "duration_s": 1.5,
                "start": format!("2026-01-0{}T00:00:00Z", i + 1) });
            let rs: Vec<Row> = (0..rows)
                .map(|k| Row {
                    scene: format!("s{k}"),
                    process: Some(i as u32),
                    ..Default::default()
                })
                .collect();
            tb_results::output::write_all(&folder(out, i), meta, &rs).unwrap();
        };
        write(0, "complete", 2);
        write(2, "running", 1);
        assert_eq!(merge(out, 3).unwrap(), (3, "incomplete".into()));
        let rows = tb_results::output::read_csv(&out.join("results.csv")).unwrap();
        let procs: Vec<Option<u32>> = rows.iter().map(|r| r.process).collect();
        assert_eq!(procs, [Some(0), Some(0), Some(2)]);
        let meta: Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap())
                .unwrap();
        assert_eq!(meta["meta"]["processes"]["processes"][1]["index"], 2);
        assert_eq!(meta["meta"]["duration_s"], 3.0);
        write(1, "complete", 2);
        write(2, "complete", 2);
        assert_eq!(merge(out, 3).unwrap(), (6, "complete".into()));
        // Another config's process is refused.
        let meta = json!({ "config_hash": "other", "status": "complete" });
        tb_results::output::write_all(&folder(out, 1), meta, &[]).unwrap();
        assert!(merge(out, 3)
            .unwrap_err()
            .to_string()
            .contains("config hash"));
    }
}
