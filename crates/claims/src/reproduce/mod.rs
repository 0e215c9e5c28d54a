//! `trace-bench reproduce`: a paper's runs, scaled to a time budget, then its claims, into one
//! report folder (`REPORT.md`, `REPRODUCTION.md`, `verdicts.json`, `runs/`).
//!
//! Each `[[run]]` of a claims file is a child `trace-bench` process (a failed or killed run
//! leaves the others and its own finished rows; rerunning with the same `--out` reuses every
//! run whose `results.json` says `complete`, and resumes the others). The budget is shared by
//! the runs' declared costs (`cost_s`, measured on the 2-core reference machine, times the
//! run's `processes`): when they do not fit, the CPU rows are timed on a smaller share of each
//! batch first, then the images of `scalable` runs shrink by one factor (module `plan`), and
//! the report says so. A run of several processes (`run --processes`) is reported with the spread of its
//! rows' times between them ([`Spread`]).

use super::deviations::{self, Resolved};
use super::eval::{evaluate_with, ClaimResult, Verdict};
use super::figures::{self, Figure};
use super::render::{self, Kinds, Tally};
use super::rows::RowSet;
use super::schema::{ClaimKind, RunSpec};
use crate::Error;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

mod plan;
mod preflight;
mod report;
mod stop;
mod writes;

use preflight::preflight;
use stop::{interrupted, past_deadline};

pub use crate::runs::Runs;
pub use plan::{fit, heavy_included, plan, Fit, PaperPlan, MIN_SCALE, MIN_SHARE};
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
    /// Print no progress on stderr (failures are still said).
    pub quiet: bool,
    /// The current method versions the claims read rows against
    /// ([`crate::eval::Options::methods`]; empty: no method check).
    pub methods: std::collections::BTreeMap<String, u32>,
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
    /// The run's index in its claims file's `[[run]]`s.
    #[serde(skip)]
    pub spec: usize,
    /// The paper's key (its claims file's stem).
    pub paper: String,
    /// The run's label (the config's file stem, or the command's first word).
    pub label: String,
    /// The trace-bench arguments the run is made with.
    pub args: Vec<String>,
    /// An `exec` run (a command of the claims file's), not a `run` of a config.
    #[serde(skip)]
    pub exec: bool,
    /// The run's folder, where its rows are written.
    pub folder: PathBuf,
    /// Planned wall seconds on the reference machine, at its scale and timed share.
    pub cost_s: f64,
    /// The image scale applied (1 = as declared).
    pub scale: f64,
    /// The share of each batch the run's CPU rows are timed on (`run.timed_share`; 1 = all).
    pub timed_share: f64,
    /// What was scaled, in words.
    pub scaled: Option<String>,
    /// Measured wall seconds (`None`: not made).
    pub wall_s: Option<f64>,
    /// The run's exit code (`None`: not made, or ended by a signal).
    pub exit: Option<i32>,
    /// How the run failed (`exit status 1`, `killed by signal 9`, `did not start: …`).
    pub failed: Option<String>,
    /// Whether the complete folder of an earlier reproduce was reused instead of a run.
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
    /// The largest of the rows' spreads (fraction).
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
    /// The paper's key (its claims file's stem).
    pub key: String,
    /// The paper, as its claims file names it.
    pub paper: String,
    /// Its runs, as planned and as made.
    pub runs: Vec<PlannedRun>,
    /// Every claim's result, per device.
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

/// Make the planned runs, evaluate the claims, write the report folder. Everything that can
/// be known wrong is checked before the first run (`preflight`); a signal ends the run in
/// progress and returns an error (the finished rows stay for a rerun to resume).
pub fn reproduce(opts: &Options, runner: &dyn Runs) -> Result<Vec<PaperReport>, Error> {
    let mut planned = plan(opts)?;
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
    let plot = plotter(&planned);
    let mut reports = Vec::new();
    let deadline = opts
        .deadline_s
        .map(|s| started + Duration::from_secs_f64(s));
    while !planned.is_empty() {
        refit(&mut planned, opts, started);
        let (path, file, mut runs) = planned.remove(0);
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
        let eval = crate::eval::Options {
            methods: opts.methods.clone(),
            ..Default::default()
        };
        let claims = evaluate_with(&file, &rows, &eval);
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

/// The interpreter for the figures, or why there are none (`None`: no paper has figures).
fn plotter(planned: &[PaperPlan]) -> Option<Result<PathBuf, String>> {
    planned.iter().any(|p| !p.1.figures.is_empty()).then(|| {
        let py = figures::python();
        if !Path::new(SCRIPTS).is_dir() {
            return Err(format!(
                "no {SCRIPTS}/ folder here (reproduce runs from the repository root)"
            ));
        }
        figures::check(&py).map(|()| py)
    })
}

/// Before a paper's runs: the timed share fitted again to the budget left (`plan::refit`),
/// and said where it changed.
fn refit(rest: &mut [PaperPlan], opts: &Options, started: Instant) {
    let left = opts.budget_s - started.elapsed().as_secs_f64();
    if let Some((old, new)) = plan::refit(rest, opts, left) {
        if !opts.quiet {
            eprintln!(
                "reproduce: {:.0} s of the budget left for the runs still to be made: CPU rows \
                 timed on {} % of each batch (was {} %)",
                left.max(0.0),
                (new * 1e4).round() / 1e2,
                (old * 1e4).round() / 1e2
            );
        }
    }
}

/// Before the runs: the heavy runs left out and a budget below the runs' smallest cost, said.
fn say_plan(opts: &Options, planned: &[PaperPlan]) {
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

    pub(super) fn spec(cost: f64, fixed: f64, scalable: bool) -> RunSpec {
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
            trace_s: 0.0,
            processes: 1,
            scalable,
            interleave: true,
            heavy: false,
            note: None,
        }
    }

    /// Options of a quiet reproduce on the CPU into `o`, no paper yet.
    pub(super) fn options() -> Options {
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
            methods: Default::default(),
        }
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
