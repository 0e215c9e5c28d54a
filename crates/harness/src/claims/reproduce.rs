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
use crate::HarnessError;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

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
    let rows = crate::results::output::read_csv(&folder.join("results.csv")).ok()?;
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
            let med = crate::experiment::timing::median(&mut v);
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
        median: crate::experiment::timing::median(&mut xs),
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
pub fn papers_in(dir: &Path) -> Result<Vec<PathBuf>, HarnessError> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(|e| HarnessError::io(dir, e))?
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
    let dirty = if crate::results::meta::dirty() == Some(true) {
        "+dirty"
    } else {
        ""
    };
    format!("{}{dirty}", crate::results::meta::commit())
}

/// Plan every paper's runs within the budget.
pub fn plan(opts: &Options) -> Result<Vec<(PathBuf, ClaimsFile, Vec<PlannedRun>)>, HarnessError> {
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
/// be known wrong is checked before the first run ([`preflight`]); a signal ends the run in
/// progress and returns an error (the finished rows stay for a rerun to resume).
pub fn reproduce(opts: &Options) -> Result<Vec<PaperReport>, HarnessError> {
    let planned = plan(opts)?;
    preflight(opts, &planned)?;
    let mut devs = planned
        .iter()
        .map(|(path, file, _)| deviations::load(path, file))
        .collect::<Result<Vec<_>, _>>()?
        .into_iter();
    say_plan(opts, &planned);
    // One reproduce per report folder, until this one ends.
    let _lock = crate::results::lock::FolderLock::acquire(&opts.out)?;
    crate::experiment::child::catch_signals();
    let started = Instant::now();
    let start_time = crate::results::meta::now_rfc3339();
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
    for (path, file, mut runs) in planned {
        for r in &mut runs {
            make_run(r, opts)?;
            r.spread = spread(&r.folder);
        }
        let mut sources: Vec<PathBuf> = runs
            .iter()
            .map(|r| r.folder.clone())
            .filter(|f| f.is_dir() && std::fs::read_dir(f).is_ok_and(|mut d| d.next().is_some()))
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
    if let Some(sig) = crate::experiment::child::received() {
        return Err(interrupted(sig, None, opts));
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
    let notice = match plot {
        Some(Err(why)) => Some(why),
        _ => None,
    };
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

/// Before the first run: every `--with` holds trace-bench results, every run's config exists
/// and parses with its edits, and no other process writes into a run's folder.
fn preflight(
    opts: &Options,
    planned: &[(PathBuf, ClaimsFile, Vec<PlannedRun>)],
) -> Result<(), HarnessError> {
    for w in &opts.with {
        RowSet::read_results(std::slice::from_ref(w))
            .map_err(|e| HarnessError::Other(format!("--with {}: {e}", w.display())))?;
    }
    for (path, _, runs) in planned {
        for r in runs.iter().filter(|r| r.args[0] == "run") {
            let cfg = Path::new(&r.args[1]);
            let sets: Vec<String> = r
                .args
                .windows(2)
                .filter(|w| w[0] == "--set")
                .map(|w| w[1].clone())
                .collect();
            let text = std::fs::read_to_string(cfg).map_err(|e| {
                HarnessError::io(cfg, format!("{e} (a [[run]] config of {})", path.display()))
            })?;
            let text = crate::experiment::config::overrides::apply_sets(
                &cfg.display().to_string(),
                &text,
                &sets,
            )?;
            toml::from_str::<toml::Table>(&text).map_err(|e| {
                let line = e
                    .span()
                    .map(|s| crate::experiment::config::line_of(&text, s.start));
                HarnessError::io(
                    cfg,
                    format!(
                        "{}{} (a [[run]] config of {})",
                        line.map(|l| format!("{l}: ")).unwrap_or_default(),
                        e.message().trim().replace('\n', " "),
                        path.display()
                    ),
                )
            })?;
        }
        for r in runs.iter().filter(|r| r.folder.is_dir()) {
            crate::results::lock::FolderLock::acquire(&r.folder)?;
        }
    }
    Ok(())
}

/// Make one planned run (or reuse its folder); a failed run is recorded, a signal is an error.
fn make_run(r: &mut PlannedRun, opts: &Options) -> Result<(), HarnessError> {
    if let Some(sig) = crate::experiment::child::received() {
        return Err(interrupted(sig, None, opts));
    }
    let complete = status(&r.folder).as_deref() == Some("complete");
    if r.left_out.is_some() && !complete {
        return Ok(());
    }
    r.left_out = None;
    if complete || (r.args.first().is_some_and(|a| a != "run") && r.folder.is_dir()) {
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
        return Ok(());
    }
    let mut args = r.args.clone();
    if r.args.first().is_some_and(|a| a == "run") && r.folder.join("results.json").exists() {
        args.push("--resume".into());
    }
    std::fs::create_dir_all(&r.folder).map_err(|e| HarnessError::io(&r.folder, e))?;
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
    let (st, sig) = match crate::experiment::child::run(&mut cmd) {
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
        return Err(interrupted(sig, Some(r), opts));
    }
    if !st.success() {
        r.failed = Some(crate::experiment::child::ended(&st));
    }
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

/// The error of a reproduce ended by signal `sig` (in run `r`, which was ended).
fn interrupted(sig: i32, r: Option<&PlannedRun>, opts: &Options) -> HarnessError {
    let run = r
        .map(|r| {
            format!(
                "ended the run {} {} (its finished rows stay in {}); ",
                r.paper,
                r.label,
                r.folder.display()
            )
        })
        .unwrap_or_default();
    HarnessError::Other(format!(
        "reproduce: interrupted by {}: {run}no report written; rerun with --out {} to resume",
        crate::experiment::child::signal_name(sig),
        opts.out.display()
    ))
}

fn write(path: &Path, text: &str) -> Result<(), HarnessError> {
    let tmp = path.with_extension("tmp");
    std::fs::write(&tmp, text).map_err(|e| HarnessError::io(&tmp, e))?;
    std::fs::rename(&tmp, path).map_err(|e| HarnessError::io(path, e))
}

/// The machine in one line.
fn machine() -> String {
    let h = crate::results::meta::host_info();
    format!(
        "{} ({}, {} logical / {} physical cores, {} GiB, {})",
        h["name"].as_str().unwrap_or("?"),
        h["cpu"].as_str().unwrap_or("?"),
        h["cores"],
        h["physical_cores"],
        h["memory_gib"],
        h["os"].as_str().unwrap_or("?")
    )
}

fn commit_line() -> String {
    let dirty = if crate::results::meta::dirty() == Some(true) {
        " (with uncommitted changes)"
    } else {
        ""
    };
    format!("{}{dirty}", crate::results::meta::commit())
}

fn write_report(
    opts: &Options,
    reports: &[PaperReport],
    start: &str,
    wall: f64,
    figures_notice: Option<&str>,
) -> Result<(), HarnessError> {
    let all: Vec<ClaimResult> = reports.iter().flat_map(|r| r.claims.clone()).collect();
    let mut gpus: Vec<&str> = Vec::new();
    for a in reports.iter().flat_map(|r| &r.adapters) {
        if !gpus.contains(&a.as_str()) {
            gpus.push(a);
        }
    }
    let gpu_line = if gpus.is_empty() {
        String::new()
    } else {
        format!("GPU adapter: {}  \n", gpus.join("; "))
    };
    let sets = if opts.sets.is_empty() {
        String::new()
    } else {
        format!("; every run with --set {}", opts.sets.join(" --set "))
    };
    let head = format!(
        "Machine: {}  \n{gpu_line}Commit: {}  \nStarted: {start}; runs and claims took {:.0} s (budget {}: {:.0} s); devices: {}{sets}\n",
        machine(),
        commit_line(),
        wall,
        opts.budget_text,
        opts.budget_s,
        opts.devices.join(", ")
    );
    // REPORT.md: per paper the runs (what was scaled) and the verdicts beside the paper's.
    let mut md = format!(
        "# trace-bench reproduce\n\n{head}\nVerdicts: {}.\n",
        kinds_line(&Kinds::of(&all))
    );
    let below = all
        .iter()
        .filter(|c| c.effect.as_ref().is_some_and(|e| e.below()))
        .count();
    if below > 0 {
        md.push_str(&format!(
            "\n{below} timed claims ask for an effect below what this run decides: \
             [Effects below what this run decides](#effects-below-what-this-run-decides).\n"
        ));
    }
    let figs: Vec<Figure> = reports.iter().flat_map(|r| r.figures.clone()).collect();
    if figures_notice.is_some() || !figs.is_empty() {
        md.push_str(&figures::markdown(&figs, figures_notice));
    }
    for r in reports {
        md.push_str(&format!("\n## {} (`claims/{}.toml`)\n\n", r.paper, r.key));
        md.push_str(&runs_table(r));
        md.push('\n');
        md.push_str(&spread_table(r));
        md.push_str(&render::markdown(&r.claims));
    }
    md.push_str(&below_markdown(reports));
    write(&opts.out.join("REPORT.md"), &md)?;
    write(
        &opts.out.join("REPRODUCTION.md"),
        &reproduction(reports, &head),
    )?;
    let json = serde_json::json!({
        "machine": crate::results::meta::host_info(),
        "build": crate::results::meta::build_info(),
        "started": start,
        "wall_s": wall,
        "budget_s": opts.budget_s,
        "devices": opts.devices,
        "figures_notice": figures_notice,
        "tally": Tally::of(&all),
        "kinds": Kinds::of(&all),
        "papers": reports,
    });
    write(
        &opts.out.join("verdicts.json"),
        &serde_json::to_string_pretty(&json).unwrap_or_default(),
    )
}

/// REPORT.md's table of a paper's runs: the command, its estimate, what was scaled, the wall
/// time (or reuse) and the exit.
fn runs_table(r: &PaperReport) -> String {
    let mut md = String::new();
    md.push_str("| run | estimate | scaled | wall s | exit |\n|---|---|---|---|---|\n");
    for p in &r.runs {
        md.push_str(&format!(
            "| `trace-bench {}` | {:.0} s | {} | {} | {} |\n",
            p.args.join(" ").replace('|', "\\|"),
            p.cost_s,
            p.left_out
                .clone()
                .or_else(|| p.scaled.clone())
                .unwrap_or_else(|| "as declared".into()),
            if let Some(by) = &p.reused_from {
                format!("reused, made by {by}")
            } else if p.reused {
                "reused".into()
            } else {
                p.wall_s.map(|w| format!("{w:.0}")).unwrap_or_default()
            },
            p.failed
                .clone()
                .or(p.exit.map(|c| c.to_string()))
                .unwrap_or_default()
        ));
    }
    md
}

/// The table of the paper's runs made in several processes: the processes and how far the
/// same rows' median times moved between them (empty when no run has several).
fn spread_table(r: &PaperReport) -> String {
    if r.runs.iter().all(|p| p.processes <= 1) {
        return String::new();
    }
    let mut s = String::from(
        "Between processes (`run --processes`): per row timed in several processes, \
         `(max − min) / median` of its median time over them. A compared time of rows from \
         3 processes or more gets its interval from their spread, else the floor ±20 %.\n\n\
         | run | processes | rows | median spread | largest spread (row) |\n|---|---|---|---|---|\n",
    );
    for p in &r.runs {
        let label = format!(
            "`{}`",
            p.folder
                .file_name()
                .map_or_else(|| p.label.clone(), |f| f.to_string_lossy().into_owned())
        );
        match &p.spread {
            Some(x) => s.push_str(&format!(
                "| {label} | {} | {} | {:.1} % | {:.1} % ({}) |\n",
                x.processes,
                x.rows,
                100.0 * x.median,
                100.0 * x.max,
                x.worst.replace('|', "\\|")
            )),
            None => s.push_str(&format!(
                "| {label} | {} | — | — | {} |\n",
                p.processes,
                if p.processes > 1 {
                    "no rows timed in two processes"
                } else {
                    "one process: the floor"
                }
            )),
        }
    }
    s.push('\n');
    s
}

/// The counts of every kind in one line: the claims' tally, then the others' (not tallied).
pub fn kinds_line(k: &Kinds) -> String {
    let mut s = format!("claims {}", k.claims);
    for (name, t) in [
        ("observations", k.observations),
        ("invariants", k.invariants),
    ] {
        if t.total() > 0 {
            s.push_str(&format!("; {name} (not tallied) {t}"));
        }
    }
    s
}

/// The section of REPORT.md listing the timed claims whose effect (from their test) is below
/// the smallest effect the run decides, with the processes that would decide them.
pub fn below_markdown(reports: &[PaperReport]) -> String {
    use super::effect::ClaimEffect;
    let listed: Vec<(&PaperReport, Vec<(&ClaimResult, &ClaimEffect)>)> = reports
        .iter()
        .map(|r| {
            let cs = r
                .claims
                .iter()
                .filter_map(|c| c.effect.as_ref().filter(|e| e.below()).map(|e| (c, e)))
                .collect::<Vec<_>>();
            (r, cs)
        })
        .filter(|(_, cs)| !cs.is_empty())
        .collect();
    if listed.is_empty() {
        return String::new();
    }
    let mut s = String::from(
        "\n## Effects below what this run decides\n\n\
         A timed comparison is decided when its interval clears the bound, so a run decides \
         only effects larger than its intervals' relative half-width: the *smallest decidable \
         effect* (a claim's widest group; with one process the interval is widened to the \
         floor between runs). The effect a claim asks for comes from its test: a two-sided \
         band's half-width (the interval must fit in it), a one-sided bound's or a margin's \
         distance from no effect (a ratio of 1), nothing for a direction only (the paper's \
         figure is then the effect to resolve). Listed: the timed claims asking for less than \
         the run decides (a verdict given all the same stands: our value lay far from the \
         bound). *Processes* would decide the claim's effect, *at ours* our measured \
         value (its distance from the bound), assuming the interval's log half-width shrinks as \
         1/√processes from this run's (the spread of a mean of independent processes; from \
         one process the floor is an assumed spread, not a measured one, and an interval \
         measured between processes needs three at least); each process repeats the paper's \
         runs, so the budget grows in proportion.\n",
    );
    for (r, cs) in listed {
        s.push_str(&format!(
            "\n### {}\n\n| claim | verdict | asks for | decides | processes | at ours |\n|---|---|---|---|---|---|\n",
            r.paper
        ));
        for (c, e) in cs {
            let asks = match e.paper_from {
                "direction" => format!("a direction (paper: {})", render::short_paper(c)),
                "band" => format!("±{} % (band)", super::effect::pct(e.paper)),
                _ => format!("{} % (bound)", super::effect::pct(e.paper)),
            };
            let n = |x: Option<usize>| x.map_or("—".to_owned(), |n| n.to_string());
            s.push_str(&format!(
                "| `{}` | {} | {} | ±{} % ({} process{}) | {} | {} |\n",
                claim_label(c),
                render::md_verdict(c.verdict),
                asks.replace('|', "\\|"),
                super::effect::pct(e.smallest),
                e.processes,
                if e.processes == 1 { "" } else { "es" },
                n(e.processes_for_paper),
                n(e.processes_for_ours)
            ));
        }
    }
    s
}

/// A claim's id, with the device when not the CPU.
fn claim_label(c: &ClaimResult) -> String {
    if c.device == "cpu" {
        c.id.clone()
    } else {
        format!("{} [{}]", c.id, c.device)
    }
}

/// REPRODUCTION.md: per paper one short table per kind (claim, the paper's figure, ours and
/// the verdict on the CPU and the GPU), the paper's claims first (the tally), then its
/// observations and invariants apart; then the long reasons of every claim (where it stands,
/// the paper's figures in full, the measured why, the note), then every paper's deviations.
pub fn reproduction(reports: &[PaperReport], head: &str) -> String {
    let mut s = format!(
        "# Reproduction\n\nGenerated by `trace-bench reproduce all`: what holds and what does not. \
         Each paper opens with a short table per kind (the claim, the paper's figure, ours, the \
         verdict); the measured reasons are in [Reasons](#reasons) (a claim's id links to its), \
         the figures drawn from the runs in the report folder's `REPORT.md`. Verdicts: `agree`, \
         `disagree`, `inconclusive` (rows missing, a time interval across the bound, noisy or \
         software-GPU timings), `undecidable` (cannot be decided by construction: the reason is \
         given); a GPU cell stays `not measured` until a run on a real GPU (`--device gpu`). \
         Each paper's *claims* are its statements, tallied; its *observations* (a GPU statement \
         tried on the CPU, a question the paper leaves open, our own figures) and *invariants* \
         (properties of our code true by construction) are shown apart and not tallied. Where \
         our implementation differs from the papers: [Deviations](#deviations). Details: \
         `claims/README.md`.\n\n{head}"
    );
    for r in reports {
        s.push_str(&format!("\n## {}\n\n", r.paper));
        s.push_str(&format!("{}.\n\n", kinds_line(&r.kinds)));
        for kind in kinds_present(r) {
            if kind != ClaimKind::Claim {
                let (title, what) = render::section(kind);
                let t = Tally::of_kind(&r.claims, kind);
                s.push_str(&format!("\n### {title}\n\n{what}. {t}.\n\n"));
            }
            s.push_str(&short_table(r, kind));
        }
    }
    s.push_str(
        "\n## Reasons\n\nPer claim: where it stands in the paper, the paper's figures as \
         printed, and why the verdict (measured; for a timed claim, the smallest effect the run \
         decides), with the claim's note. Every figure and interval is also in `verdicts.json`.\n",
    );
    for r in reports {
        s.push_str(&format!("\n### {}\n", r.paper));
        for kind in kinds_present(r) {
            if kind != ClaimKind::Claim {
                s.push_str(&format!("\n#### {}\n", render::section(kind).0));
            }
            s.push('\n');
            s.push_str(&reasons_table(r, kind));
        }
    }
    s.push_str("\n## Deviations\n\nEvery difference between our implementation and the paper that remains \
        (method, measure, scene or view, hardware), why, and the claims it touches \
        (`claims/deviations/PAPER.toml`).\n");
    for r in reports {
        s.push_str(&format!("\n### {}\n\n", r.paper));
        if r.deviations.is_empty() {
            s.push_str("None listed.\n");
        } else {
            s.push_str(&deviations::markdown(&r.deviations));
        }
    }
    s
}

/// The kinds a paper's section shows: claims always, the others where it has some.
fn kinds_present(r: &PaperReport) -> Vec<ClaimKind> {
    ClaimKind::ALL
        .into_iter()
        .filter(|k| *k == ClaimKind::Claim || r.claims.iter().any(|c| c.kind == *k))
        .collect()
}

/// The ids of one kind's results, in file order, each once.
fn ids_of(r: &PaperReport, kind: ClaimKind) -> Vec<&str> {
    let mut ids: Vec<&str> = Vec::new();
    for c in r.claims.iter().filter(|c| c.kind == kind) {
        if !ids.contains(&c.id.as_str()) {
            ids.push(&c.id);
        }
    }
    ids
}

/// The anchor of a claim's reasons (`r-PAPER-ID`).
fn anchor(r: &PaperReport, id: &str) -> String {
    format!("r-{}-{id}", r.key)
}

fn md_escape(x: &str) -> String {
    x.replace('|', "\\|").replace('\n', " ")
}

/// One kind's short table of a paper: claim | paper | CPU: ours | CPU | GPU: ours | GPU.
fn short_table(r: &PaperReport, kind: ClaimKind) -> String {
    let mut s = String::from(
        "| claim | paper | CPU: ours | CPU | GPU: ours | GPU |\n|---|---|---|---|---|---|\n",
    );
    for id in ids_of(r, kind) {
        let on = |d: &str| r.claims.iter().find(|c| c.id == id && c.device == d);
        let first = r.claims.iter().find(|c| c.id == id).expect("listed");
        let cell = |c: Option<&ClaimResult>| match c {
            None => (String::new(), String::new()),
            Some(c) if unmeasured(c) => (String::new(), "not measured".to_owned()),
            Some(c) => (
                render::short_ours(c),
                render::md_verdict(c.verdict).to_owned(),
            ),
        };
        let (co, cv) = cell(on("cpu"));
        let (go, gv) = cell(on("gpu"));
        s.push_str(&format!(
            "| [`{id}`](#{}) | {} | {} | {cv} | {} | {gv} |\n",
            anchor(r, id),
            md_escape(&render::short_paper(first)),
            md_escape(&co),
            md_escape(&go),
        ));
    }
    s
}

/// A GPU result without rows: its cell reads `not measured`.
fn unmeasured(c: &ClaimResult) -> bool {
    c.device == "gpu" && c.verdict == Verdict::Inconclusive && c.ours == "—"
}

/// One kind's reasons of a paper: claim | where | paper (as printed) | why (measured).
fn reasons_table(r: &PaperReport, kind: ClaimKind) -> String {
    let mut s = String::from("| claim | where | paper | why (measured) |\n|---|---|---|---|\n");
    for id in ids_of(r, kind) {
        let all: Vec<&ClaimResult> = r.claims.iter().filter(|c| c.id == id).collect();
        let first = all[0];
        let mut why: Vec<String> = Vec::new();
        for c in &all {
            if c.why.is_empty() || unmeasured(c) {
                continue;
            }
            let full = if c.ours.chars().count() > render::SHORT || all.len() > 1 {
                format!("ours {}: {}", c.ours, c.why)
            } else {
                c.why.clone()
            };
            why.push(if all.len() > 1 {
                format!("{}: {full}", c.device.to_uppercase())
            } else {
                full
            });
        }
        if let Some(n) = &first.note {
            why.push(format!("note: {n}"));
        }
        s.push_str(&format!(
            "| <a id=\"{}\"></a>`{id}` | {} | {} | {} |\n",
            anchor(r, id),
            md_escape(&first.place),
            md_escape(&first.paper),
            md_escape(&why.join(" — "))
        ));
    }
    s
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
        use crate::results::output::{write_all, Row};
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
        assert!(this_build().starts_with(&crate::results::meta::commit()));
    }
}
