//! `trace-bench reproduce`: a paper's runs, scaled to a time budget, then its claims, into one
//! report folder (`REPORT.md`, `REPRODUCTION.md`, `verdicts.json`, `runs/`).
//!
//! Each `[[run]]` of a claims file is a child `trace-bench` process (a failed or killed run
//! leaves the others and its own finished rows; rerunning with the same `--out` reuses every
//! run whose `results.json` says `complete`, and resumes the others). The budget is shared by
//! the runs' declared costs (`cost_s`, measured on the 2-core reference machine, times the
//! run's `processes`): when they do not fit, the images of `scalable` runs shrink by one factor
//! (the variable part of a run's cost is taken as proportional to its pixels), and the report
//! says so. A run of several processes (`run --processes`) is reported with the spread of its
//! rows' times between them ([`Spread`]).

use super::deviations::{self, Resolved};
use super::eval::{evaluate, ClaimResult, Verdict};
use super::figures::{self, Figure};
use super::render::{self, Kinds, Tally};
use super::rows::RowSet;
use super::schema::{ClaimKind, ClaimsFile, RunSpec};
use crate::Error;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

mod preflight;
mod report;
mod stop;
mod writes;

use preflight::preflight;
use stop::{interrupted, past_deadline};

pub use crate::runs::Runs;
pub use report::*;

/// What to reproduce.
#[derive(Clone, Debug)]
pub struct Options {
    /// Claims files, in order.
    pub papers: Vec<PathBuf>,
    /// Seconds for all the runs.
    pub budget_s: f64,
    /// Devices whose runs are made (`cpu`, `gpu`).
    pub devices: Vec<String>,
    /// The report folder.
    pub out: PathBuf,
    /// The trace-bench executable for the runs.
    pub exe: PathBuf,
    /// `--scenes-root` for the runs.
    pub scenes_root: Option<PathBuf>,
    /// Further results folders or CSVs evaluated with each paper's runs (e.g. a GPU run made
    /// on another machine).
    pub with: Vec<PathBuf>,
    /// `--set` edits for every run, after each run's own (they win).
    pub sets: Vec<String>,
    /// `--adapter` for the runs on the GPU.
    pub adapter: Option<String>,
    /// The budget as the user wrote it (for the report).
    pub budget_text: String,
    /// Make the `heavy` runs whatever the budget (`--heavy`).
    pub heavy: bool,
    /// Seconds after the start at which a run still going is ended (its finished rows kept)
    /// and no further run is started (`--deadline`); the claims and the report are made
    /// either way.
    pub deadline_s: Option<f64>,
    /// Let the runs write outside the report folder (`--write-anywhere`; module `writes`).
    pub write_anywhere: bool,
    pub quiet: bool,
}

/// The folder of the plotting scripts, relative to where reproduce runs (the repository root,
/// as the claims files' configs are).
pub const SCRIPTS: &str = "scripts";

/// The share of the user's `--budget` given to the runs ([`Options::budget_s`]); the rest is
/// kept for loading the claims and writing the report.
pub const RUNS_SHARE: f64 = 0.95;

/// One planned (and then made) run.
#[derive(Clone, Debug, serde::Serialize)]
pub struct PlannedRun {
    pub paper: String,
    pub label: String,
    pub args: Vec<String>,
    /// An `exec` run (a command of the claims file's), not a `run` of a config.
    #[serde(skip)]
    pub exec: bool,
    pub folder: PathBuf,
    pub cost_s: f64,
    /// The image scale applied (1 = as declared).
    pub scale: f64,
    /// What was scaled, in words.
    pub scaled: Option<String>,
    pub wall_s: Option<f64>,
    pub exit: Option<i32>,
    /// How the run failed (`exit status 1`, `killed by signal 9`, `did not start: …`).
    pub failed: Option<String>,
    pub reused: bool,
    /// Where the reused rows were made by another build: `commit` (`+dirty`) of their
    /// results.json, said beside the run in REPORT.md.
    pub reused_from: Option<String>,
    /// Why a `heavy` run is not made (it is reused where an earlier reproduce made it).
    pub left_out: Option<String>,
    /// Processes the run is made in (`run --processes`).
    pub processes: usize,
    /// How its rows' times moved between its processes (with more than one).
    pub spread: Option<Spread>,
}

/// How the same rows' times moved between the processes of a run: per row timed in two
/// processes or more, `(max − min) / median` of its `trace_ms_median` over the processes.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Spread {
    /// The processes whose rows are in the folder.
    pub processes: usize,
    /// Rows timed in two processes or more.
    pub rows: usize,
    /// The median and the largest of the rows' spreads (fractions).
    pub median: f64,
    pub max: f64,
    /// The row of the largest (`scene structure traversal ray_kind threads`).
    pub worst: String,
}

/// The spread between processes of the rows in a run folder's `results.csv`; `None` without
/// rows of two processes.
pub fn spread(folder: &Path) -> Option<Spread> {
    use std::collections::BTreeMap;
    let rows = tb_results::output::read_csv(&folder.join("results.csv")).ok()?;
    let mut by: BTreeMap<String, Vec<f64>> = BTreeMap::new();
    let mut procs = std::collections::BTreeSet::new();
    for r in &rows {
        let (Some(p), Some(ms)) = (r.process, r.trace_ms_median) else {
            continue;
        };
        procs.insert(p);
        let params = if r.params.is_empty() {
            String::new()
        } else {
            format!(" [{}]", r.params)
        };
        let key = format!(
            "{} {}{params} {} {} {} {}t",
            r.scene, r.structure, r.traversal, r.triangle_test, r.ray_kind, r.threads
        );
        by.entry(key).or_default().push(ms);
    }
    let mut s: Vec<(f64, String)> = by
        .into_iter()
        .filter(|(_, v)| v.len() > 1)
        .map(|(k, mut v)| {
            let med = tb_results::stats::median(&mut v);
            let (lo, hi) = v
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
                    (a.min(*x), b.max(*x))
                });
            ((hi - lo) / med, k)
        })
        .filter(|(x, _)| x.is_finite())
        .collect();
    if s.is_empty() {
        return None;
    }
    s.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut xs: Vec<f64> = s.iter().map(|x| x.0).collect();
    let (max, worst) = s.pop().expect("not empty");
    Some(Spread {
        processes: procs.len(),
        rows: xs.len(),
        median: tb_results::stats::median(&mut xs),
        max,
        worst,
    })
}

/// One paper's outcome.
#[derive(Clone, Debug, serde::Serialize)]
pub struct PaperReport {
    pub key: String,
    pub paper: String,
    pub runs: Vec<PlannedRun>,
    pub claims: Vec<ClaimResult>,
    /// The paper's claims' verdicts (kind `claim`).
    pub tally: Tally,
    /// Every kind's counts (observations and invariants are not tallied).
    pub kinds: Kinds,
    /// Where our implementation differs from the paper (`claims/deviations/PAPER.toml`).
    pub deviations: Vec<Resolved>,
    /// The GPU adapters of the rows (`name (type)`), for the report's head.
    pub adapters: Vec<String>,
    /// The paper's figures drawn from the runs (the claims file's `[[figure]]`s).
    pub figures: Vec<Figure>,
}

/// The distinct GPU adapters of `rows`, `name (type)`.
fn adapters(rows: &RowSet) -> Vec<String> {
    let mut v: Vec<String> = Vec::new();
    for r in &rows.rows {
        let Some(name) = r.get("adapter").filter(|a| !a.is_empty()) else {
            continue;
        };
        let a = match r.get("adapter_type").filter(|t| !t.is_empty()) {
            Some(t) => format!("{name} ({t})"),
            None => name.to_owned(),
        };
        if !v.contains(&a) {
            v.push(a);
        }
    }
    v
}

/// The papers' keys (file stems) in `dir` that have runs, sorted.
pub fn papers_in(dir: &Path) -> Result<Vec<PathBuf>, Error> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(|e| Error::io(dir, e))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    v.sort();
    let mut out = Vec::new();
    for p in v {
        if !super::load(&p)?.runs.is_empty() {
            out.push(p);
        }
    }
    Ok(out)
}

fn stem(p: &Path) -> String {
    p.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// Whether the run is made on these devices: a run naming `gpu` only when `gpu` is asked
/// for, one naming no device (the CPU) only when `cpu` is.
fn wanted(r: &RunSpec, devices: &[String]) -> bool {
    let gpu = r
        .device
        .as_ref()
        .is_some_and(|d| d.iter().any(|x| x == "gpu"));
    if gpu {
        devices.iter().any(|d| d == "gpu")
    } else {
        devices.iter().any(|d| d == "cpu")
    }
}

/// The image scale that fits `runs` into `budget_s` (1 when they fit as declared), and the
/// estimate at that scale; a run of several processes costs each of them
/// ([`RunSpec::total_s`]).
pub fn fit(runs: &[&RunSpec], budget_s: f64) -> (f64, f64) {
    let total: f64 = runs.iter().map(|r| r.total_s()).sum();
    if total <= budget_s {
        return (1.0, total);
    }
    let fixed: f64 = runs
        .iter()
        .map(|r| {
            if r.scalable {
                r.total_fixed_s()
            } else {
                r.total_s()
            }
        })
        .sum();
    let var: f64 = runs
        .iter()
        .filter(|r| r.scalable)
        .map(|r| r.total_s() - r.total_fixed_s())
        .sum();
    if var <= 0.0 {
        return (1.0, total);
    }
    let f = ((budget_s - fixed) / var).clamp(MIN_SCALE, 1.0);
    (f, fixed + f * var)
}

/// Whether the `heavy` runs among `runs` are made: with `--heavy`, or when every run fits the
/// budget as declared (heavy runs are never shrunk: their cost is their builds).
pub fn heavy_included(runs: &[&RunSpec], budget_s: f64, heavy: bool) -> bool {
    heavy || runs.iter().map(|r| r.total_s()).sum::<f64>() <= budget_s
}

/// The smallest pixel scale reproduce applies (1/64 of the pixels: 1024² → 128²).
pub const MIN_SCALE: f64 = 1.0 / 64.0;

/// The run's `--set` edits with width and height scaled by `sqrt(f)` (multiples of 8, at
/// least 32 pixels), and what was scaled.
fn scaled_sets(r: &RunSpec, f: f64) -> (Vec<String>, Option<String>) {
    if f >= 1.0 || !r.scalable {
        return (r.set.clone(), None);
    }
    let k = f.sqrt();
    let mut changed = Vec::new();
    let sets = r
        .set
        .iter()
        .map(|s| {
            let Some((key, val)) = s.split_once('=') else {
                return s.clone();
            };
            let is_size = key.ends_with(".width") || key.ends_with(".height");
            match (is_size, val.trim().parse::<f64>()) {
                (true, Ok(v)) => {
                    let n = (((v * k) / 8.0).round() * 8.0).max(32.0) as u64;
                    changed.push(format!("{key} {v} → {n}"));
                    format!("{key}={n}")
                }
                _ => s.clone(),
            }
        })
        .collect();
    let note = if changed.is_empty() {
        Some("not scaled: the run sets no width/height".to_owned())
    } else {
        Some(changed.join(", "))
    };
    (sets, note)
}

/// The trace-bench arguments of a run into `folder`.
fn run_args(r: &RunSpec, sets: &[String], folder: &Path, opts: &Options) -> Vec<String> {
    let out = folder.display().to_string();
    if let Some(exec) = &r.exec {
        return exec.iter().map(|a| a.replace("{out}", &out)).collect();
    }
    let mut a = vec![
        "run".to_owned(),
        r.config.clone().unwrap_or_default(),
        "--out".into(),
        out,
        "-q".into(),
    ];
    for s in sets.iter().chain(&opts.sets) {
        a.push("--set".into());
        a.push(s.clone());
    }
    if r.interleave && !sets.iter().any(|s| s.starts_with("run.interleave")) {
        a.push("--set".into());
        a.push("run.interleave=true".into());
    }
    if r.processes > 1 {
        a.push("--processes".into());
        a.push(r.processes.to_string());
    }
    // One-thread rows timed by the thread's CPU time: on a shared machine the time waited
    // for a core is most of what moves a row between processes (docs/variation.md).
    if !sets
        .iter()
        .chain(&opts.sets)
        .any(|s| s.starts_with("run.clock"))
    {
        a.push("--set".into());
        a.push("run.clock=thread".into());
    }
    if !r.structure.is_empty() {
        a.push("--structure".into());
        a.push(r.structure.join(","));
    }
    if !r.scene.is_empty() {
        a.push("--scene".into());
        a.push(r.scene.join(","));
    }
    if let Some(t) = &r.threads {
        a.push("--threads".into());
        a.push(t.iter().map(usize::to_string).collect::<Vec<_>>().join(","));
    }
    if let Some(d) = &r.device {
        a.push("--device".into());
        a.push(d.join(","));
        if let Some(name) = opts
            .adapter
            .as_ref()
            .filter(|_| d.iter().any(|x| x == "gpu"))
        {
            a.push("--adapter".into());
            a.push(name.clone());
        }
    }
    if let Some(root) = opts.scenes_root.as_deref() {
        a.push("--scenes-root".into());
        a.push(root.display().to_string());
    }
    a
}

/// A run folder's status (`complete`, …) from its results.json.
fn status(folder: &Path) -> Option<String> {
    let text = std::fs::read_to_string(folder.join("results.json")).ok()?;
    let v: serde_json::Value = serde_json::from_str(&text).ok()?;
    v["meta"]["status"].as_str().map(str::to_owned)
}

/// The build a run folder's rows were made by (`commit`, `+dirty` when it had uncommitted
/// changes), from its results.json; `None` without one.
fn made_by(folder: &Path) -> Option<String> {
    let text = std::fs::read_to_string(folder.join("results.json")).ok()?;
    let v: serde_json::Value = serde_json::from_str(&text).ok()?;
    let b = &v["meta"]["build"];
    let dirty = if b["dirty"].as_bool() == Some(true) {
        "+dirty"
    } else {
        ""
    };
    Some(format!("{}{dirty}", b["commit"].as_str()?))
}

/// This binary's build as [`made_by`] writes it.
fn this_build() -> String {
    let dirty = if tb_results::meta::dirty() == Some(true) {
        "+dirty"
    } else {
        ""
    };
    format!("{}{dirty}", tb_results::meta::commit())
}

/// Plan every paper's runs within the budget.
pub fn plan(opts: &Options) -> Result<Vec<(PathBuf, ClaimsFile, Vec<PlannedRun>)>, Error> {
    let mut files = Vec::new();
    for p in &opts.papers {
        files.push((p.clone(), super::load(p)?));
    }
    let all: Vec<&RunSpec> = files
        .iter()
        .flat_map(|(_, f)| f.runs.iter())
        .filter(|r| wanted(r, &opts.devices))
        .collect();
    let with_heavy = heavy_included(&all, opts.budget_s, opts.heavy);
    let made: Vec<&RunSpec> = all
        .iter()
        .copied()
        .filter(|r| with_heavy || !r.heavy)
        .collect();
    let (scale, _) = fit(&made, opts.budget_s);
    let all_cost: f64 = all.iter().map(|r| r.total_s()).sum();
    let mut out = Vec::new();
    for (path, file) in files {
        let key = stem(&path);
        let mut runs = Vec::new();
        for (i, r) in file.runs.iter().enumerate() {
            if !wanted(r, &opts.devices) {
                continue;
            }
            let label = match (&r.config, &r.exec) {
                (Some(c), _) => stem(Path::new(c)),
                (None, Some(e)) => e.first().cloned().unwrap_or_default(),
                _ => String::new(),
            };
            let folder = opts
                .out
                .join("runs")
                .join(&key)
                .join(format!("{i}-{label}"));
            let left_out = (r.heavy && !with_heavy).then(|| {
                format!(
                    "left out (heavy, {:.0} s): --heavy or a budget of {:.0} s makes it",
                    r.total_s(),
                    (all_cost / RUNS_SHARE).ceil()
                )
            });
            let scale = if r.heavy { 1.0 } else { scale };
            let (sets, scaled) = scaled_sets(r, scale);
            let cost = if r.scalable && scaled.as_deref().is_some_and(|s| !s.starts_with("not")) {
                r.total_fixed_s() + scale * (r.total_s() - r.total_fixed_s())
            } else {
                r.total_s()
            };
            runs.push(PlannedRun {
                paper: key.clone(),
                label,
                args: run_args(r, &sets, &folder, opts),
                exec: r.exec.is_some(),
                folder,
                cost_s: cost,
                scale: if scaled.is_some() { scale } else { 1.0 },
                scaled,
                wall_s: None,
                exit: None,
                failed: None,
                reused: false,
                reused_from: None,
                left_out,
                processes: r.processes,
                spread: None,
            });
        }
        out.push((path, file, runs));
    }
    Ok(out)
}

/// Make the planned runs, evaluate the claims, write the report folder. Everything that can
/// be known wrong is checked before the first run (`preflight`); a signal ends the run in
/// progress and returns an error (the finished rows stay for a rerun to resume).
pub fn reproduce(opts: &Options, runner: &dyn Runs) -> Result<Vec<PaperReport>, Error> {
    let planned = plan(opts)?;
    preflight(opts, &planned, runner)?;
    let mut devs = planned
        .iter()
        .map(|(path, file, _)| deviations::load(path, file))
        .collect::<Result<Vec<_>, _>>()?
        .into_iter();
    say_plan(opts, &planned);
    // One reproduce per report folder, until this one ends.
    let _lock = tb_results::lock::FolderLock::acquire(&opts.out)?;
    runner.catch_signals();
    let started = Instant::now();
    let start_time = tb_results::meta::now_rfc3339();
    // The interpreter for the figures, or why there are none.
    let plot = planned.iter().any(|p| !p.1.figures.is_empty()).then(|| {
        let py = figures::python();
        if !Path::new(SCRIPTS).is_dir() {
            return Err(format!(
                "no {SCRIPTS}/ folder here (reproduce runs from the repository root)"
            ));
        }
        figures::check(&py).map(|()| py)
    });
    let mut reports = Vec::new();
    let deadline = opts
        .deadline_s
        .map(|s| started + Duration::from_secs_f64(s));
    for (path, file, mut runs) in planned {
        for r in &mut runs {
            make_run(r, opts, runner, deadline)?;
            r.spread = spread(&r.folder);
        }
        // A run that failed before writing a row (its folder may hold its processes' empty
        // folders) adds no rows: its claims' groups read "rows missing", the report says why.
        let mut sources: Vec<PathBuf> = runs
            .iter()
            .map(|r| r.folder.clone())
            .filter(|f| RowSet::holds_rows(f))
            .collect();
        sources.extend(opts.with.iter().cloned());
        let rows = if sources.is_empty() {
            RowSet::default()
        } else {
            RowSet::read(&sources)?
        };
        let claims = evaluate(&file, &rows);
        let figures = match &plot {
            Some(Ok(py)) => {
                let labels: Vec<(String, PathBuf)> = runs
                    .iter()
                    .map(|r| (r.label.clone(), r.folder.clone()))
                    .collect();
                let figs = figures::draw(
                    runner,
                    py,
                    Path::new(SCRIPTS),
                    &stem(&path),
                    &file.figures,
                    &labels,
                    &opts.out,
                );
                for f in &figs {
                    if let figures::Drawn::Failed(why) = &f.drawn {
                        eprintln!("reproduce: figure {}-{} failed: {why}", f.paper, f.name);
                    }
                }
                figs
            }
            _ => Vec::new(),
        };
        reports.push(PaperReport {
            key: stem(&path),
            paper: file.paper.clone(),
            runs,
            tally: Tally::of(&claims),
            kinds: Kinds::of(&claims),
            claims,
            deviations: devs.next().unwrap_or_default(),
            adapters: adapters(&rows),
            figures,
        });
    }
    if let Some(sig) = runner.received() {
        return Err(interrupted(sig, None, opts, runner));
    }
    let wall = started.elapsed().as_secs_f64();
    let budget = opts.budget_s / RUNS_SHARE;
    if wall > budget + 0.5 {
        eprintln!(
            "note: reproduce: took {wall:.0} s, {:.0} s over the budget of {}",
            wall - budget,
            opts.budget_text
        );
    }
    let notice = plot.and_then(Result::err);
    write_report(opts, &reports, &start_time, wall, notice.as_deref())?;
    Ok(reports)
}

/// Before the runs: the heavy runs left out and a budget below the runs' smallest cost, said.
fn say_plan(opts: &Options, planned: &[(PathBuf, ClaimsFile, Vec<PlannedRun>)]) {
    let estimate: f64 = planned
        .iter()
        .flat_map(|p| &p.2)
        .filter(|r| status(&r.folder).as_deref() != Some("complete") && r.left_out.is_none())
        .map(|r| r.cost_s)
        .sum();
    let left: Vec<&PlannedRun> = planned
        .iter()
        .flat_map(|p| &p.2)
        .filter(|r| r.left_out.is_some() && status(&r.folder).as_deref() != Some("complete"))
        .collect();
    if let Some(r) = left.first() {
        eprintln!(
            "note: reproduce: {} heavy runs left out ({}; their claims' groups read \"rows \
             missing\"): {}",
            left.len(),
            left.iter()
                .map(|r| format!("{} {}", r.paper, r.label))
                .collect::<Vec<_>>()
                .join(", "),
            r.left_out.as_deref().unwrap_or_default()
        );
    }
    if estimate > opts.budget_s + 0.5 {
        eprintln!(
            "note: reproduce: --budget {} is less than the runs take at their smallest images \
             (about {estimate:.0} s on the reference machine)",
            opts.budget_text
        );
    }
}

/// Reuse a planned run's complete folder, saying so (and which build made it, where another).
fn reuse(r: &mut PlannedRun, opts: &Options) {
    r.reused = true;
    r.reused_from = made_by(&r.folder).filter(|by| *by != this_build());
    if let Some(by) = &r.reused_from {
        eprintln!(
            "note: reproduce: {} {}: reusing {}, made by {by}; this binary is {} \
             (a fresh --out measures this build)",
            r.paper,
            r.label,
            r.folder.display(),
            this_build()
        );
    }
    if !opts.quiet {
        eprintln!(
            "reproduce: {} {}: reused {}",
            r.paper,
            r.label,
            r.folder.display()
        );
    }
}

/// Make one planned run (or reuse its folder); a failed run is recorded, a signal is an error.
fn make_run(
    r: &mut PlannedRun,
    opts: &Options,
    runner: &dyn Runs,
    deadline: Option<Instant>,
) -> Result<(), Error> {
    if let Some(sig) = runner.received() {
        return Err(interrupted(sig, None, opts, runner));
    }
    let complete = status(&r.folder).as_deref() == Some("complete");
    if r.left_out.is_some() && !complete {
        return Ok(());
    }
    r.left_out = None;
    if complete || (r.args.first().is_some_and(|a| a != "run") && r.folder.is_dir()) {
        reuse(r, opts);
        return Ok(());
    }
    if past_deadline(r, opts, deadline) {
        return Ok(());
    }
    let mut args = r.args.clone();
    if r.args.first().is_some_and(|a| a == "run") && r.folder.join("results.json").exists() {
        args.push("--resume".into());
    }
    std::fs::create_dir_all(&r.folder).map_err(|e| Error::io(&r.folder, e))?;
    if !opts.quiet {
        eprintln!(
            "reproduce: {} {} (about {:.0} s{}) …",
            r.paper,
            r.label,
            r.cost_s,
            r.scaled
                .as_deref()
                .map(|s| format!("; {s}"))
                .unwrap_or_default()
        );
    }
    let t = Instant::now();
    let mut cmd = Command::new(&opts.exe);
    cmd.args(&args).stdout(std::process::Stdio::null());
    let (st, sig, cut) = match runner.run_until(&mut cmd, deadline) {
        Ok(x) => x,
        Err(e) => {
            r.failed = Some(format!("did not start: {e}"));
            eprintln!(
                "reproduce: {} {}: {}: did not start: {e}",
                r.paper,
                r.label,
                opts.exe.display()
            );
            return Ok(());
        }
    };
    r.wall_s = Some(t.elapsed().as_secs_f64());
    r.exit = st.code();
    if let Some(sig) = sig {
        return Err(interrupted(sig, Some(r), opts, runner));
    }
    r.failed = if cut {
        Some(format!(
            "ended at the --deadline of {:.0} s (its finished rows are kept; --out resumes it)",
            opts.deadline_s.unwrap_or(0.0)
        ))
    } else {
        // Rows mismatching the oracle are a finished run's result (named in its report), not
        // a failure of the run.
        (!st.success() && st.code() != Some(tb_results::EXIT_MISMATCHES)).then(|| runner.ended(&st))
    };
    if !opts.quiet || r.failed.is_some() {
        eprintln!(
            "reproduce: {} {} done in {:.0} s{}",
            r.paper,
            r.label,
            r.wall_s.unwrap_or(0.0),
            r.failed
                .as_deref()
                .map(|f| format!(" (failed: {f})"))
                .unwrap_or_default()
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(cost: f64, fixed: f64, scalable: bool) -> RunSpec {
        RunSpec {
            config: Some("configs/x.toml".into()),
            exec: None,
            set: vec![
                "scene.camera.width=256".into(),
                "scene.camera.height=192".into(),
            ],
            structure: vec![],
            scene: vec![],
            threads: None,
            device: None,
            cost_s: cost,
            fixed_s: fixed,
            processes: 1,
            scalable,
            interleave: true,
            heavy: false,
            note: None,
        }
    }

    /// Options of a quiet reproduce on the CPU into `o`, no paper yet.
    fn options() -> Options {
        Options {
            papers: vec![],
            budget_s: 0.0,
            devices: vec!["cpu".into()],
            out: "o".into(),
            exe: "trace-bench".into(),
            scenes_root: None,
            with: vec![],
            sets: vec![],
            adapter: None,
            budget_text: String::new(),
            heavy: false,
            deadline_s: None,
            write_anywhere: false,
            quiet: true,
        }
    }

    /// Heavy runs are made with `--heavy`, or when the budget covers every run as declared.
    #[test]
    fn heavy_runs_need_the_flag_or_the_whole_budget() {
        let light = spec(100.0, 20.0, true);
        let heavy = RunSpec {
            heavy: true,
            ..spec(300.0, 300.0, false)
        };
        let runs = [&light, &heavy];
        assert!(!heavy_included(&runs, 399.0, false));
        assert!(heavy_included(&runs, 400.0, false));
        assert!(heavy_included(&runs, 10.0, true));
    }

    /// A left-out heavy run is planned (and reported) but not made, and the light runs are
    /// fitted without it.
    #[test]
    fn plans_leave_heavy_runs_out_within_small_budgets() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("p.toml");
        std::fs::write(
            &file,
            "paper = \"P\"\n\
             [[run]]\nconfig = \"configs/a.toml\"\nset = [\"scene.camera.width=256\", \"scene.camera.height=256\"]\ncost_s = 100\nfixed_s = 20\nscalable = true\n\
             [[run]]\nconfig = \"configs/b.toml\"\ncost_s = 300\nfixed_s = 300\nheavy = true\n",
        )
        .unwrap();
        let opts = |budget_s: f64, heavy: bool| Options {
            papers: vec![file.clone()],
            budget_s,
            out: dir.path().join("out"),
            heavy,
            ..options()
        };
        let runs = |o: &Options| plan(o).unwrap().remove(0).2;
        let small = runs(&opts(100.0, false));
        assert!(small[0].left_out.is_none() && small[0].scaled.is_none());
        let why = small[1].left_out.as_deref().expect("left out");
        assert!(why.contains("--heavy") && why.contains("300 s"), "{why}");
        // With the flag the heavy run is made and the light one shrinks to make room.
        let flagged = runs(&opts(100.0, true));
        assert!(flagged[1].left_out.is_none());
        assert!(flagged[0].scale < 1.0 && flagged[1].scale == 1.0);
        assert!(runs(&opts(400.0, false))[1].left_out.is_none());
    }

    #[test]
    fn fitting_scales_only_the_variable_part() {
        let (a, b) = (spec(100.0, 20.0, true), spec(50.0, 50.0, false));
        assert_eq!(fit(&[&a, &b], 200.0), (1.0, 150.0));
        // 20 + 50 fixed, 80 variable: 110 s leaves 40 s, half the pixels.
        let (f, est) = fit(&[&a, &b], 110.0);
        assert!((f - 0.5).abs() < 1e-12 && (est - 110.0).abs() < 1e-9);
        // Never below the smallest scale.
        assert_eq!(fit(&[&a, &b], 10.0).0, MIN_SCALE);
    }

    /// A run of three processes costs three times its declared process, fixed part too.
    #[test]
    fn fitting_counts_every_process() {
        let a = RunSpec {
            processes: 3,
            ..spec(100.0, 20.0, true)
        };
        let b = spec(50.0, 50.0, false);
        assert_eq!(fit(&[&a, &b], 350.0), (1.0, 350.0));
        // 60 + 50 fixed, 240 variable: 230 s leaves 120 s, half the pixels.
        let (f, est) = fit(&[&a, &b], 230.0);
        assert!((f - 0.5).abs() < 1e-12 && (est - 230.0).abs() < 1e-9);
        assert!(!heavy_included(&[&a, &b], 349.0, false));
        let opts = options();
        let args = run_args(&a, &a.set, Path::new("o/r"), &opts);
        assert!(
            args.windows(2).any(|w| w == ["--processes", "3"]),
            "{args:?}"
        );
        assert!(!run_args(&b, &b.set, Path::new("o/r"), &opts).contains(&"--processes".into()));
    }

    /// The spread of a run's rows between its processes: per row `(max − min) / median`, the
    /// median and the largest over the rows timed in two processes or more.
    #[test]
    fn spreads_between_processes_per_row() {
        use tb_results::output::{write_all, Row};
        let dir = tempfile::tempdir().unwrap();
        let row = |scene: &str, p: u32, ms: f64| Row {
            scene: scene.into(),
            process: Some(p),
            trace_ms_median: Some(ms),
            ..Default::default()
        };
        let rows = [
            row("a", 0, 10.0),
            row("a", 1, 12.0),
            row("a", 2, 11.0),
            row("b", 0, 20.0),
            row("b", 1, 20.0),
            row("b", 2, 21.0),
            row("c", 0, 5.0),
        ];
        write_all(dir.path(), serde_json::json!({}), &rows).unwrap();
        let s = spread(dir.path()).expect("rows of three processes");
        assert_eq!((s.processes, s.rows), (3, 2));
        assert!(
            (s.max - 2.0 / 11.0).abs() < 1e-12 && s.worst.starts_with("a "),
            "{s:?}"
        );
        // The median of the two spreads, 2/11 and 1/20.
        assert!(
            (s.median - (2.0 / 11.0 + 0.05) / 2.0).abs() < 1e-12,
            "{s:?}"
        );
        write_all(dir.path(), serde_json::json!({}), &rows[6..]).unwrap();
        assert!(spread(dir.path()).is_none());
    }

    #[test]
    fn scaled_sizes_keep_multiples_of_eight() {
        let (sets, note) = scaled_sets(&spec(1.0, 0.0, true), 0.25);
        assert_eq!(sets, ["scene.camera.width=128", "scene.camera.height=96"]);
        assert!(note.unwrap().contains("256 → 128"));
        let (sets, note) = scaled_sets(&spec(1.0, 0.0, false), 0.25);
        assert_eq!(sets[0], "scene.camera.width=256");
        assert!(note.is_none());
    }

    /// A reused folder names the build its rows were made by, so a stale `--out` is said.
    #[test]
    fn reused_rows_name_their_build() {
        let dir = tempfile::tempdir().unwrap();
        assert_eq!(made_by(dir.path()), None);
        let json = |commit: &str, dirty: bool| {
            format!(
                r#"{{"meta": {{"status": "complete", "build": {{"commit": "{commit}", "dirty": {dirty}}}}}, "rows": []}}"#
            )
        };
        std::fs::write(dir.path().join("results.json"), json("db74e0906af1", false)).unwrap();
        assert_eq!(made_by(dir.path()).as_deref(), Some("db74e0906af1"));
        std::fs::write(dir.path().join("results.json"), json("5c35e1b19c11", true)).unwrap();
        assert_eq!(made_by(dir.path()).as_deref(), Some("5c35e1b19c11+dirty"));
        assert!(this_build().starts_with(&tb_results::meta::commit()));
    }
}
