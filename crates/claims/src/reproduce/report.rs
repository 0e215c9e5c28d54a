//! What `reproduce` writes: REPORT.md (the machine, each paper's runs and their spread between
//! processes, the claims beside the paper's figures) and REPRODUCTION.md (the short tables per
//! kind, the reasons, the deviations), and the lines they share.

use super::*;

pub(super) fn write(path: &Path, text: &str) -> Result<(), Error> {
    let tmp = path.with_extension("tmp");
    std::fs::write(&tmp, text).map_err(|e| Error::io(&tmp, e))?;
    std::fs::rename(&tmp, path).map_err(|e| Error::io(path, e))
}

/// The machine in one line.
pub(super) fn machine() -> String {
    let h = tb_results::meta::host_info();
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

pub(super) fn commit_line() -> String {
    let dirty = if tb_results::meta::dirty() == Some(true) {
        " (with uncommitted changes)"
    } else {
        ""
    };
    format!("{}{dirty}", tb_results::meta::commit())
}

pub(super) fn write_report(
    opts: &Options,
    reports: &[PaperReport],
    start: &str,
    wall: f64,
    figures_notice: Option<&str>,
) -> Result<(), Error> {
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
        "# trace-bench reproduce\n\n{head}{}\nVerdicts: {}.\n",
        overall_split(reports),
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
        "machine": tb_results::meta::host_info(),
        "build": tb_results::meta::build_info(),
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

/// The phases of `meta.phases` in REPORT.md's order, with their words.
const PHASES: [(&str, &str); 9] = [
    ("load_s", "load"),
    ("rays_s", "rays"),
    ("build_s", "build"),
    ("oracle_s", "oracle"),
    ("count_s", "count"),
    ("validate_s", "validate"),
    ("trace_s", "timed trace"),
    ("gpu_s", "gpu"),
    ("other_s", "other"),
];

/// A run folder's time split and build-cache figures, from its results.json (`meta.phases`,
/// `meta.build_cache`: `tb_harness::experiment::phases`), in words for REPORT.md: each phase's
/// share of the run's time (those of at least 0.5 %), and the structures loaded from the cache
/// and built. Empty where the folder has none (an `exec` run, rows of an older binary).
pub(super) fn time_split(folder: &Path) -> (String, String) {
    let meta = run_meta(folder);
    (
        split_words(&meta["phases"]),
        cache_words(&meta["build_cache"]),
    )
}

/// A run folder's `meta` (results.json); null where there is none.
fn run_meta(folder: &Path) -> serde_json::Value {
    std::fs::read_to_string(folder.join("results.json"))
        .ok()
        .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
        .map(|v| v["meta"].clone())
        .unwrap_or_default()
}

/// `meta.phases` in words: each phase's share of `total_s` (those of at least 0.5 %).
fn split_words(p: &serde_json::Value) -> String {
    let total = p["total_s"].as_f64().unwrap_or(0.0);
    if total <= 0.0 {
        return String::new();
    }
    PHASES
        .iter()
        .filter_map(|(k, w)| {
            let share = p[*k].as_f64()? / total;
            (share >= 0.005).then(|| format!("{w} {:.0} %", share * 100.0))
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// Where the time of the runs made by this reproduce went (not those reused): their
/// `meta.phases` and build-cache counts summed, in one line for REPORT.md's head; empty
/// where no run made here wrote them.
pub(super) fn overall_split(reports: &[PaperReport]) -> String {
    let made = reports
        .iter()
        .flat_map(|r| &r.runs)
        .filter(|p| !p.reused && p.wall_s.is_some())
        .map(|p| run_meta(&p.folder));
    split_of(made)
}

/// [`overall_split`] over the runs' `meta`s (null ones, runs without results.json, skipped).
fn split_of(metas: impl Iterator<Item = serde_json::Value>) -> String {
    const CACHE: [&str; 4] = ["loaded", "built", "stages_loaded", "counters_copied"];
    let mut sum = serde_json::Map::new();
    let mut runs = 0;
    let mut cache = [0u64; 4];
    for meta in metas {
        let Some(phases) = meta["phases"].as_object() else {
            continue;
        };
        runs += 1;
        for (k, v) in phases {
            let add = v.as_f64().unwrap_or(0.0);
            let e = sum.entry(k.clone()).or_insert(0.0.into());
            *e = (e.as_f64().unwrap_or(0.0) + add).into();
        }
        for (n, k) in cache.iter_mut().zip(CACHE) {
            *n += meta["build_cache"][k].as_u64().unwrap_or(0);
        }
    }
    if runs == 0 {
        return String::new();
    }
    let [loaded, built, stages, copied] = cache;
    let mut extra = String::new();
    if stages > 0 {
        extra += &format!(" ({stages} of them over a kd-tree loaded from it)");
    }
    if copied > 0 {
        extra += &format!("; {copied} rows' counters copied from their run's first process");
    }
    let sum = serde_json::Value::Object(sum);
    format!(
        "\nWhere the time of the {runs} runs made here went ({:.0} s in their processes): {}; \
         structures {loaded} loaded from the build cache, {built} built{extra}.\n",
        sum["total_s"].as_f64().unwrap_or(0.0),
        split_words(&sum)
    )
}

/// `meta.build_cache` in words: loaded, built (and refused) structures, or the cache off.
fn cache_words(c: &serde_json::Value) -> String {
    match (
        c["used"].as_bool(),
        c["loaded"].as_u64(),
        c["built"].as_u64(),
    ) {
        (Some(false), _, Some(b)) => format!("off, {b} built"),
        (_, Some(l), Some(b)) => {
            let refused = c["refused"].as_u64().unwrap_or(0);
            let refused = if refused > 0 {
                format!(", {refused} refused")
            } else {
                String::new()
            };
            format!("{l} loaded, {b} built{refused}")
        }
        _ => String::new(),
    }
}

/// REPORT.md's table of a paper's runs: the command, its estimate, what was scaled, the wall
/// time (or reuse), where that time went, the build cache's hits and misses, and the exit.
pub(super) fn runs_table(r: &PaperReport) -> String {
    let mut md = String::new();
    md.push_str(
        "| run | estimate | scaled | wall s | time split | build cache | exit |\n\
         |---|---|---|---|---|---|---|\n",
    );
    for p in &r.runs {
        let (split, cache) = time_split(&p.folder);
        md.push_str(&format!(
            "| `trace-bench {}` | {:.0} s | {} | {} | {split} | {cache} | {} |\n",
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
                .or(p.exit.map(|c| match c {
                    tb_results::EXIT_MISMATCHES => format!(
                        "{c}: complete, with rows that mismatch the oracle (their `mismatches` column)"
                    ),
                    c => c.to_string(),
                }))
                .unwrap_or_default()
        ));
    }
    md
}

/// The table of the paper's runs made in several processes: the processes and how far the
/// same rows' median times moved between them (empty when no run has several).
pub(super) fn spread_table(r: &PaperReport) -> String {
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
    use crate::effect::ClaimEffect;
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
                "band" => format!("±{} % (band)", crate::effect::pct(e.paper)),
                _ => format!("{} % (bound)", crate::effect::pct(e.paper)),
            };
            let n = |x: Option<usize>| x.map_or("—".to_owned(), |n| n.to_string());
            s.push_str(&format!(
                "| `{}` | {} | {} | ±{} % ({} process{}) | {} | {} |\n",
                claim_label(c),
                render::md_verdict(c.verdict),
                asks.replace('|', "\\|"),
                crate::effect::pct(e.smallest),
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
pub(super) fn claim_label(c: &ClaimResult) -> String {
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
pub(super) fn kinds_present(r: &PaperReport) -> Vec<ClaimKind> {
    ClaimKind::ALL
        .into_iter()
        .filter(|k| *k == ClaimKind::Claim || r.claims.iter().any(|c| c.kind == *k))
        .collect()
}

/// The ids of one kind's results, in file order, each once.
pub(super) fn ids_of(r: &PaperReport, kind: ClaimKind) -> Vec<&str> {
    let mut ids: Vec<&str> = Vec::new();
    for c in r.claims.iter().filter(|c| c.kind == kind) {
        if !ids.contains(&c.id.as_str()) {
            ids.push(&c.id);
        }
    }
    ids
}

/// The anchor of a claim's reasons (`r-PAPER-ID`).
pub(super) fn anchor(r: &PaperReport, id: &str) -> String {
    format!("r-{}-{id}", r.key)
}

pub(super) fn md_escape(x: &str) -> String {
    x.replace('|', "\\|").replace('\n', " ")
}

/// One kind's short table of a paper: claim | paper | CPU: ours | CPU | GPU: ours | GPU.
pub(super) fn short_table(r: &PaperReport, kind: ClaimKind) -> String {
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
pub(super) fn unmeasured(c: &ClaimResult) -> bool {
    c.device == "gpu" && c.verdict == Verdict::Inconclusive && c.ours == "—"
}

/// One kind's reasons of a paper: claim | where | paper (as printed) | why (measured).
pub(super) fn reasons_table(r: &PaperReport, kind: ClaimKind) -> String {
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

    /// REPORT.md's head sums the runs' phases and cache figures; a run without results.json
    /// is left out, and nothing is said without any run.
    #[test]
    fn the_overall_split_sums_the_runs_made() {
        let meta = |build: f64, trace: f64, cache: serde_json::Value| {
            serde_json::json!({
                "phases": {"build_s": build, "trace_s": trace, "total_s": build + trace},
                "build_cache": cache,
            })
        };
        let copied = serde_json::json!({
            "loaded": 0, "built": 5, "stages_loaded": 4, "counters_copied": 7
        });
        let metas = vec![
            meta(1.0, 3.0, serde_json::json!({"loaded": 2, "built": 1})),
            serde_json::Value::Null,
            meta(3.0, 1.0, copied),
        ];
        let line = split_of(metas.into_iter());
        assert_eq!(
            line,
            "\nWhere the time of the 2 runs made here went (8 s in their processes): build 50 %, \
             timed trace 50 %; structures 2 loaded from the build cache, 6 built (4 of them over \
             a kd-tree loaded from it); 7 rows' counters copied from their run's first process.\n"
        );
        assert_eq!(split_of(std::iter::empty()), "");
    }
}
