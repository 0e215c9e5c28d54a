//! `trace-bench run`: the config loaded with its overrides, its output folder opened by the
//! harness's policy ([`tb_harness::experiment::folder`]), the run in one process or in several
//! (`--processes K`: child processes, merged), and what it prints.

use super::*;

pub(crate) fn load(config: &Path, ov: &Overrides, quiet: bool) -> Result<config::Experiment> {
    let exp = config::load(config, ov, &mut |src| {
        if !quiet {
            eprintln!("loading {src}");
        }
    })?;
    Ok(exp)
}

pub(crate) fn cmd_run(
    config: &Path,
    out: Option<PathBuf>,
    ov: Overrides,
    resume: bool,
    force: bool,
    quiet: bool,
) -> Result<i32> {
    let exp = load(config, &ov, quiet)?;
    let folder = RunFolder::open(out, &exp, Policy { resume, force })?;
    let out = folder.path.clone();
    let opts = RunOptions {
        out: out.clone(),
        resume,
        quiet,
        mode: Mode::Run,
        max_report: 5,
        cache: tb_harness::experiment::cache::BuildCache::from_env(),
    };
    let summary = runner::run(&exp, &opts)?;
    if !summary.rows.is_empty() {
        println!("{}", runner::table(&summary.rows));
    }
    for n in &summary.notes {
        eprintln!("note: {n}");
    }
    if summary.skipped > 0 {
        println!(
            "resumed: {} rows were already done and kept",
            summary.skipped
        );
    }
    for r in &summary.mismatch_reports {
        println!("mismatch: {r}");
    }
    if exp.dynamic.is_some() {
        // A [dynamic] run measures frames, not rows of results.csv.
        let frames = std::fs::read_to_string(out.join("dynamic.csv"))
            .map(|t| t.lines().count().saturating_sub(1))
            .unwrap_or(0);
        println!(
            "wrote {frames} frame rows to {} (densities tried: {}; the notes above sum them up)",
            out.join("dynamic.csv").display(),
            out.join("dynamic-choice.csv").display()
        );
    } else {
        println!(
            "wrote {} rows to {}",
            summary.written,
            out.join("results.csv").display()
        );
        println!("      and {}", out.join("results.json").display());
    }
    wrong_rows(&summary.wrong_rows);
    if !summary.failures.is_empty() {
        for f in &summary.failures {
            eprintln!("error: {f}");
        }
        return Ok(1);
    }
    Ok(if summary.wrong_rows.is_empty() {
        0
    } else {
        tb_results::EXIT_MISMATCHES
    })
}

/// Name the rows whose oracle mismatches are wrong answers (`runner::must_conform`), after
/// everything else a run prints (their rows are written like every other).
fn wrong_rows(rows: &[String]) {
    if rows.is_empty() {
        return;
    }
    eprintln!(
        "error: {} row{} mismatch the brute-force oracle with the watertight test, where every \
         traversal must answer as it does (exit {}):",
        rows.len(),
        if rows.len() == 1 { "" } else { "s" },
        tb_results::EXIT_MISMATCHES
    );
    for r in rows {
        eprintln!("  {r}");
    }
}

impl RunArgs {
    /// `trace-bench run`: one process, or several (`--processes`, `run.processes`).
    /// The config edits and filters of these arguments.
    pub(crate) fn overrides(&self) -> Overrides {
        let a = self;
        Overrides {
            threads: a.threads.clone(),
            repeat: a.repeat,
            devices: a.device.clone(),
            adapter: a.adapter.clone(),
            backend: a.backend,
            shard: a.shard,
            process: a.process,
            scenes_root: a.scenes_root.clone(),
            sets: a.select.sets.clone(),
            scenes: a.select.scenes.clone(),
            structures: a.select.structures.clone(),
        }
    }

    pub(crate) fn run(self) -> Result<i32> {
        let ov = self.overrides();
        let a = self;
        let (resume, force, quiet) = (a.resume, a.force, a.quiet);
        match several_processes(&a.config, &ov, a.processes)? {
            Some((name, n)) => {
                cmd_processes(&a.config, &name, n, a.out, &ov, (resume, force), quiet)
            }
            None => cmd_run(&a.config, a.out, ov, resume, force, quiet),
        }
    }
}

/// The experiment's name and the processes of a run of several (`--processes`, else
/// `run.processes`), or `None` for a run of one process (or one process of several,
/// `--process`).
pub(crate) fn several_processes(
    config: &Path,
    ov: &Overrides,
    processes: Option<u32>,
) -> Result<Option<(String, usize)>> {
    if ov.process.is_some() {
        return Ok(None);
    }
    let (name, from_config) = config::peek(config, ov)?;
    let n = processes.map_or(from_config, |k| k as usize);
    if n > 1 && ov.shard.is_some() {
        bail!(
            "run.processes = {n}: a run of several processes cannot be sharded (--shard); give \
             --processes 1"
        );
    }
    Ok((n > 1).then_some((name, n)))
}

/// `trace-bench run --processes N` (or `run.processes = N`): the run in `n` processes of this
/// binary, one after another, merged into one folder.
pub(crate) fn cmd_processes(
    config: &Path,
    name: &str,
    n: usize,
    out: Option<PathBuf>,
    ov: &Overrides,
    (resume, force): (bool, bool),
    quiet: bool,
) -> Result<i32> {
    use tb_harness::experiment::processes;
    let folder = RunFolder::open_processes(out, name, n, Policy { resume, force })?;
    let out = folder.path.clone();
    let plan = processes::Plan {
        exe: std::env::current_exe().context("cannot find the trace-bench executable")?,
        args: process_args(config, ov),
        out: out.clone(),
        n,
        resume,
        force,
        quiet,
    };
    let report = processes::run(&plan)?;
    for (i, p) in report.processes.iter().enumerate() {
        let how = match (&p.failed, p.reused, p.wall_s) {
            (Some(f), _, _) => format!("failed ({f})"),
            (None, true, _) => "complete, reused".into(),
            (None, false, w) => format!("done in {:.0} s", w.unwrap_or(0.0)),
        };
        println!("process {i}: {how} ({})", p.folder.display());
    }
    println!(
        "wrote {} rows of {n} processes to {} ({})",
        report.rows,
        out.join("results.csv").display(),
        report.status
    );
    println!("      and {}", out.join("results.json").display());
    Ok(if report.processes.iter().any(|p| p.failed.is_some()) {
        1
    } else if report.processes.iter().any(|p| p.mismatched) {
        eprintln!(
            "error: rows of these processes mismatch the brute-force oracle (each named its \
             rows above): {}",
            report
                .processes
                .iter()
                .filter(|p| p.mismatched)
                .map(|p| p.folder.display().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        );
        tb_results::EXIT_MISMATCHES
    } else {
        0
    })
}

/// `run CONFIG` and the options of `ov` as each process of `run --processes` gets them.
pub(crate) fn process_args(config: &Path, ov: &Overrides) -> Vec<String> {
    let mut a = vec!["run".to_owned(), config.display().to_string()];
    let list = |v: Vec<String>| v.join(",");
    if let Some(t) = &ov.threads {
        a.extend([
            "--threads".into(),
            list(t.iter().map(usize::to_string).collect()),
        ]);
    }
    if let Some(r) = ov.repeat {
        a.extend(["--repeat".into(), r.to_string()]);
    }
    if let Some(d) = &ov.devices {
        a.extend([
            "--device".into(),
            list(d.iter().map(|d| d.name().into()).collect()),
        ]);
    }
    if let Some(x) = &ov.adapter {
        a.extend(["--adapter".into(), x.clone()]);
    }
    if let Some(b) = ov.backend {
        a.extend(["--backend".into(), b.name().into()]);
    }
    if !ov.scenes.is_empty() {
        a.extend(["--scene".into(), list(ov.scenes.clone())]);
    }
    if !ov.structures.is_empty() {
        a.extend(["--structure".into(), list(ov.structures.clone())]);
    }
    for s in &ov.sets {
        a.extend(["--set".into(), s.clone()]);
    }
    if let Some(r) = &ov.scenes_root {
        a.extend(["--scenes-root".into(), r.display().to_string()]);
    }
    a
}
