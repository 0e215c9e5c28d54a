//! `trace-bench claims` and `trace-bench reproduce`: a paper's claims evaluated against results,
//! and its runs made within a budget, then evaluated and written up.

use super::*;

impl ClaimsArgs {
    /// `trace-bench claims`: evaluate a claims file against results and print the verdicts.
    pub(crate) fn run(self) -> Result<i32> {
        let ClaimsArgs {
            claims,
            results,
            format,
            only,
            require_agree,
            width,
            time_floor,
        } = self;
        let (claims, results, format, only) =
            (claims.as_path(), &results[..], format.as_str(), &only[..]);
        use tb_claims as claims;
        if !(time_floor >= 0.0 && time_floor.is_finite()) {
            bail!("--time-floor {time_floor}: must be a fraction >= 0 (0.2 = ±20 %)");
        }
        let file = claims::load(claims)?;
        if let Some(id) = only.iter().find(|id| file.claim(id).is_none()) {
            bail!("{}: no claim `{id}`", claims.display());
        }
        let rows = claims::RowSet::read_results(results)?;
        if rows.replaced > 0 {
            eprintln!(
                "note: {} rows appear in several sources; the later source's row is used",
                rows.replaced
            );
        }
        let opts = claims::Options {
            time_floor,
            methods: tb_harness::registry::Registry::builtin().methods(),
        };
        let mut verdicts = claims::evaluate_with(&file, &rows, &opts);
        if !only.is_empty() {
            verdicts.retain(|v| only.contains(&v.id));
        }
        match format {
            "md" => print!("{}", claims::render::markdown(&verdicts)),
            "json" => {
                let sources: Vec<String> =
                    results.iter().map(|p| p.display().to_string()).collect();
                println!(
                    "{}",
                    serde_json::to_string_pretty(&claims::render::json(
                        &file.paper,
                        &sources,
                        &verdicts
                    ))?
                );
            }
            _ => {
                let w = width
                    .or_else(|| std::env::var("COLUMNS").ok().and_then(|c| c.parse().ok()))
                    .map(|w: u16| w.max(40))
                    .unwrap_or(160);
                println!("{}", file.paper);
                print!("{}", claims::render::text(&verdicts, w));
            }
        }
        let all_agree = verdicts.iter().all(|v| v.verdict == claims::Verdict::Agree);
        if verdicts.is_empty() && require_agree {
            bail!(
                "{}: --require-agree: the file has no claim, so none can agree",
                claims.display()
            );
        }
        Ok(if require_agree && !all_agree { 1 } else { 0 })
    }
}

impl ReproduceArgs {
    /// `trace-bench reproduce`: runs, claims, report.
    pub(crate) fn run(self) -> Result<i32> {
        let ReproduceArgs {
            paper,
            budget,
            device: devices,
            out,
            claims_dir,
            with,
            scenes_root,
            sets,
            adapter,
            heavy,
            deadline,
            write_anywhere,
            cache: _,
            quiet,
        } = self;
        let (paper, budget, claims_dir) = (paper.as_str(), budget.as_str(), claims_dir.as_path());
        use tb_claims::reproduce;
        if let Some(s) = sets.iter().find(|s| !s.contains('=')) {
            bail!("--set {s}: expected KEY=VALUE (e.g. run.validate=64)");
        }
        let budget_s = seconds("--budget", budget)?;
        let deadline_s = deadline
            .as_deref()
            .map(|d| seconds("--deadline", d))
            .transpose()?;
        let papers = claims_files(paper, claims_dir)?;
        if let Some(r) = scenes_root.as_deref().filter(|r| !r.is_dir()) {
            bail!(
                "--scenes-root {} (or TRACE_BENCH_SCENES): not a folder",
                r.display()
            );
        }
        // Further results are read before the first run, not after the last.
        for w in &with {
            tb_claims::RowSet::read_results(std::slice::from_ref(w))
                .with_context(|| format!("--with {}", w.display()))?;
        }
        if let Some(o) = &out {
            folder::check_out(o)?;
        }
        let default_folder = out.is_none();
        let out = out.unwrap_or_else(|| {
            PathBuf::from("results/reproduce").join(
                tb_results::meta::now_rfc3339()
                    .replace(':', "-")
                    .trim_end_matches('Z'),
            )
        });
        if default_folder {
            folder::link_latest(&out);
        }
        let opts = reproduce::Options {
            papers,
            budget_s: budget_s * reproduce::RUNS_SHARE,
            devices,
            out: out.clone(),
            exe: std::env::current_exe().context("cannot find the trace-bench executable")?,
            scenes_root,
            with,
            sets,
            adapter,
            budget_text: budget.to_owned(),
            heavy,
            deadline_s,
            write_anywhere,
            quiet,
            methods: tb_harness::registry::Registry::builtin().methods(),
        };
        let reports = reproduce::reproduce(&opts, &HarnessRuns)?;
        for r in &reports {
            println!("{}", r.paper);
            print!("{}", tb_claims::render::text(&r.claims, 160));
        }
        println!(
            "report: {} (REPORT.md, REPRODUCTION.md, verdicts.json)",
            out.display()
        );
        let failed: Vec<String> = reports
            .iter()
            .flat_map(|r| &r.runs)
            .filter_map(|r| {
                r.failed
                    .as_ref()
                    .map(|f| format!("{} {} ({f})", r.paper, r.label))
            })
            .collect();
        if !failed.is_empty() {
            bail!(
                "{} runs failed: {} (their finished rows are used; see REPORT.md)",
                failed.len(),
                failed.join(", ")
            );
        }
        Ok(0)
    }
}

impl CompareArgs {
    /// `trace-bench compare`: the verdicts of several reports, claim by claim.
    pub(crate) fn run(self) -> Result<i32> {
        let s = tb_claims::stability::compare(&self.reports)?;
        let list = |what: &str, v: &[String]| {
            if !v.is_empty() {
                println!("{what}:");
                for l in v {
                    println!("  {l}");
                }
            }
        };
        list("counter verdicts that moved", &s.counter_moved);
        list("time verdicts between agree and disagree", &s.time_flipped);
        list(
            "time verdicts decided in some reports only",
            &s.time_decided_once,
        );
        list("claims missing from some report", &s.missing);
        println!(
            "{} reports: counter claims {} identical, {} moved; time claims {} identical, {} \
             decided in some only, {} between agree and disagree; {} not in every report",
            self.reports.len(),
            s.counter_same,
            s.counter_moved.len(),
            s.time_same,
            s.time_decided_once.len(),
            s.time_flipped.len(),
            s.missing.len()
        );
        if s.compared() == 0 {
            eprintln!("error: compare: the reports have no claim in common: nothing was compared");
        }
        Ok(if s.holds() { 0 } else { 1 })
    }
}

/// The seconds of duration `text` given to `flag` (`10m`, `90s`, `1h`), more than zero.
fn seconds(flag: &str, text: &str) -> Result<f64> {
    let s = humantime::parse_duration(text)
        .with_context(|| format!("{flag} {text}: expected a duration such as 10m, 90s, 1h"))?
        .as_secs_f64();
    if s <= 0.0 {
        bail!("{flag} {text}: must be more than zero");
    }
    Ok(s)
}

/// The claims files `reproduce PAPER` names: a paper's key under `claims_dir`, a claims file,
/// or `all` (every claims file there with runs); several, comma-separated, in that order.
fn claims_files(paper: &str, claims_dir: &Path) -> Result<Vec<PathBuf>> {
    use tb_claims::reproduce;
    if paper.trim().is_empty() {
        bail!("reproduce: names no paper (give a paper's key, a claims file or all)");
    }
    if paper.contains(',') {
        // Papers in this order (`all` adds the ones not named yet), each once.
        let mut papers: Vec<PathBuf> = Vec::new();
        for part in paper.split(',').map(str::trim).filter(|p| !p.is_empty()) {
            for p in claims_files(part, claims_dir)? {
                if !papers.contains(&p) {
                    papers.push(p);
                }
            }
        }
        if papers.is_empty() {
            bail!("reproduce `{paper}`: names no paper (give a paper's key, a claims file or all)");
        }
        return Ok(papers);
    }
    let papers = if paper == "all" {
        reproduce::papers_in(claims_dir)?
    } else if Path::new(paper).is_file() {
        vec![PathBuf::from(paper)]
    } else {
        let p = claims_dir.join(format!("{paper}.toml"));
        if !p.is_file() {
            let known: Vec<String> = reproduce::papers_in(claims_dir)
                .unwrap_or_default()
                .iter()
                .filter_map(|p| p.file_stem().map(|s| s.to_string_lossy().into_owned()))
                .collect();
            bail!(
                "{}: no such claims file (papers: {}, or all)",
                p.display(),
                known.join(", ")
            );
        }
        vec![p]
    };
    if papers.is_empty() {
        bail!("{}: no claims file with runs", claims_dir.display());
    }
    Ok(papers)
}

/// Reproduce's runs as the runner makes them (tb-claims knows nothing of the runner): config
/// edits as `run --set` applies them, and child processes that end with reproduce.
struct HarnessRuns;

impl tb_claims::reproduce::Runs for HarnessRuns {
    fn apply_sets(
        &self,
        file: &str,
        text: &str,
        sets: &[String],
    ) -> Result<String, tb_claims::Error> {
        tb_harness::experiment::config::overrides::apply_sets(file, text, sets)
            .map_err(|e| tb_claims::Error::Other(e.to_string()))
    }
    fn check_run(&self, args: &[String]) -> Result<Vec<PathBuf>, tb_claims::Error> {
        let err = |m: String| tb_claims::Error::Other(m);
        let argv = std::iter::once("trace-bench".to_owned()).chain(args.iter().cloned());
        let cli = Cli::try_parse_from(argv).map_err(|e| {
            err(format!(
                "trace-bench {}: {}",
                args.join(" "),
                e.to_string().lines().next().unwrap_or_default()
            ))
        })?;
        let Cmd::Run(a) = cli.cmd else {
            return Ok(Vec::new());
        };
        let ov = a.overrides();
        config::check_offline(&a.config, &ov).map_err(|e| err(e.to_string()))
    }
    fn catch_signals(&self) {
        child::catch_signals()
    }
    fn received(&self) -> Option<i32> {
        child::received()
    }
    fn run(
        &self,
        cmd: &mut std::process::Command,
    ) -> std::io::Result<(std::process::ExitStatus, Option<i32>)> {
        child::run(cmd)
    }
    fn run_until(
        &self,
        cmd: &mut std::process::Command,
        deadline: Option<std::time::Instant>,
    ) -> std::io::Result<(std::process::ExitStatus, Option<i32>, bool)> {
        child::run_until(cmd, deadline)
    }
    fn ended(&self, st: &std::process::ExitStatus) -> String {
        child::ended(st)
    }
    fn signal_name(&self, sig: i32) -> String {
        child::signal_name(sig)
    }
}

use tb_harness::experiment::child;
