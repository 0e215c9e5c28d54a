//! Command-line front end of trace-bench (thin: every piece of work lives in `tb-harness`).

#![deny(missing_docs)]

use anyhow::{bail, Context, Result};
use clap::{Parser, Subcommand};
use std::ffi::OsString;
use std::path::{Path, PathBuf};
use tb_harness::experiment::config::{self, Device, Overrides};
use tb_harness::experiment::folder::{self, Policy, RunFolder};
use tb_harness::experiment::runner::{self, Mode, RunOptions};

mod env;
mod papers;
mod run;
pub use env::names as env_names;
use run::*;

#[derive(Parser)]
#[command(
    name = "trace-bench",
    version,
    about = "Measure ray-tracing acceleration structures on the same rays, checked against brute force"
)]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

/// Selecting and editing a config from the command line (run and validate).
#[derive(clap::Args)]
struct Select {
    /// Run only these scenes (labels or sources; repeat or separate by commas).
    #[arg(long = "scene", value_delimiter = ',')]
    scenes: Vec<String>,
    /// Run only these structures, `NAME` or `NAME:traversal` (repeat or separate by commas).
    #[arg(long = "structure", value_delimiter = ',')]
    structures: Vec<String>,
    /// Change the config without editing it: `--set run.repeat=9`,
    /// `--set scene.camera.width=256` (every scene); repeatable. The edited config is the
    /// one results.json records.
    #[arg(long = "set")]
    sets: Vec<String>,
}

impl Select {
    /// The overrides of this selection and scenes root, the rest left at their defaults.
    fn overrides(self, scenes_root: Option<PathBuf>) -> Overrides {
        Overrides {
            scenes_root,
            sets: self.sets,
            scenes: self.scenes,
            structures: self.structures,
            ..Default::default()
        }
    }
}

/// `trace-bench run`'s arguments.
#[derive(clap::Args)]
struct RunArgs {
    /// The experiment config (TOML).
    config: PathBuf,
    /// Output directory (default: results/NAME/TIMESTAMP, or the newest one with --resume).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Thread counts, overriding the config's run.threads (0 = all cores).
    #[arg(long, value_delimiter = ',')]
    threads: Option<Vec<usize>>,
    /// Timed repeats per combination, overriding run.repeat.
    #[arg(long)]
    repeat: Option<usize>,
    /// Devices, overriding run.devices: `cpu`, `gpu` or `cpu,gpu`; naming `gpu` makes a
    /// GPU failure fail the run.
    #[arg(long, value_delimiter = ',', value_parser = parse_device)]
    device: Option<Vec<Device>>,
    /// GPU adapter: a substring of its name (case-insensitive), overriding run.gpu_adapter.
    #[arg(long, value_parser = clap::builder::NonEmptyStringValueParser::new())]
    adapter: Option<String>,
    /// GPU backend, overriding run.gpu_backend: vulkan, gl, metal or dx12.
    #[arg(long, value_parser = parse_backend)]
    backend: Option<tb_gpu::Backend>,
    #[command(flatten)]
    select: Select,
    /// Run one shard of the config's work units (one scene x one build with all its rows),
    /// `K/N` with K in 1..=N, or `slurm` to read the job array task from
    /// SLURM_ARRAY_TASK_ID / _COUNT / _MIN / _MAX. Deterministic for a config and binary;
    /// combine the shards' folders with `trace-bench merge`.
    #[arg(long, value_parser = parse_shard)]
    shard: Option<tb_harness::cluster::shard::Shard>,
    /// Make the run in K processes, one after another (overriding run.processes; default
    /// 1): process I writes OUT/process-I (rows tagged `process = I`; the odd ones run the
    /// structure entries in reverse order), and OUT holds the rows of all of them, merged
    /// after each, so times can be compared between processes (`claims`).
    #[arg(
        long,
        value_name = "K",
        value_parser = clap::value_parser!(u32).range(1..=64),
        conflicts_with = "shard"
    )]
    processes: Option<u32>,
    /// Run as process I of K (`I/K`, 0-based) of a `--processes K` run, which sets it: rows
    /// get `process = I`; odd I run the structure entries in reverse order.
    #[arg(
        long,
        value_name = "I/K",
        value_parser = parse_process,
        conflicts_with_all = ["processes", "shard"]
    )]
    process: Option<tb_harness::experiment::processes::Process>,
    /// Continue an interrupted run: keep its rows, skip finished combinations (with
    /// --processes: reuse the complete processes, resume the others).
    #[arg(long)]
    resume: bool,
    /// Replace the results of an earlier run in `--out` (results.csv, results.json,
    /// convergence.csv, images/).
    #[arg(long, conflicts_with = "resume")]
    force: bool,
    /// Root directory for scene files named in the config.
    #[arg(long, env = "TRACE_BENCH_SCENES")]
    scenes_root: Option<PathBuf>,
    #[command(flatten)]
    cache: CacheArgs,
    /// No progress output.
    #[arg(long, short)]
    quiet: bool,
}

/// The build cache's flags (`run`, `reproduce`; `tb_harness::experiment::cache`).
#[derive(clap::Args, Clone, Debug)]
pub(crate) struct CacheArgs {
    /// Build every structure: neither load one from the build cache nor save one to it
    /// (sets TRACE_BENCH_BUILD_CACHE=off for this command and the processes it starts).
    #[arg(long)]
    no_cache: bool,
    /// The build cache's folder (default: target/build-cache beside a binary in a cargo
    /// target folder, else ~/.cache/trace-bench/builds; sets TRACE_BENCH_BUILD_CACHE).
    #[arg(long, value_name = "DIR", conflicts_with = "no_cache")]
    cache_dir: Option<PathBuf>,
}

impl CacheArgs {
    /// Pass the flags on as the environment variable that this process and every process it
    /// starts read (before any thread is started).
    pub(crate) fn apply(&self) -> Result<()> {
        let var = tb_harness::experiment::cache::ENV;
        if self.no_cache {
            std::env::set_var(var, "off");
        } else if let Some(d) = &self.cache_dir {
            if d.as_os_str().is_empty() || d.as_os_str() == "off" {
                bail!("--cache-dir `{}`: not a folder name", d.display());
            }
            if d.exists() && !d.is_dir() {
                bail!("--cache-dir {}: is a file, not a folder", d.display());
            }
            std::env::set_var(var, d);
        }
        Ok(())
    }
}

#[derive(Subcommand)]
enum Cmd {
    /// Run an experiment: build, trace, count, validate; write results.csv and results.json.
    Run(Box<RunArgs>),
    /// Compare every structure and traversal of a config with the brute-force oracle only;
    /// exit 1 on any mismatch.
    Validate(ValidateArgs),
    /// Compare the deterministic counters of RESULTS with a baseline; exit 1 on a regression.
    Check(CheckArgs),
    /// Difference map of one counter of two heat-map EXRs of the same rays (B − A): PNG with
    /// a colour bar (blue: B lower, red: B higher), and the means.
    Diff(DiffArgs),
    /// Merge the results folders of the shards of one run (`run --shard K/N`) into one:
    /// refuses shards of another config or binary, lists the work units no shard completed
    /// (exit 1), keeps each row's host.
    Merge(MergeArgs),
    /// List the structures, their traversals and parameters.
    List(ListArgs),
    /// List the built-in scenes and their parameters.
    Scenes,
    /// Print the normalised weights of the multi-kd-tree heuristics in the layout of Tables 1
    /// and 2 of Torres et al. 2012, computed by numerical integration.
    Weights(WeightsArgs),
    /// Reproduce a paper (or all five): run its claims file's runs scaled to the budget, then
    /// its claims; write REPORT.md, REPRODUCTION.md and verdicts.json to one folder.
    Reproduce(ReproduceArgs),
    /// Evaluate a paper's claims (claims/PAPER.toml) against results folders or CSVs:
    /// claim | paper | ours | verdict (agree, disagree, inconclusive) | why.
    Claims(ClaimsArgs),
    /// Compare the verdicts of reproduce reports made alike (the same command run again):
    /// every counter claim must keep its verdict, and no time claim may agree in one report
    /// and disagree in another (decided in one, inconclusive in another is allowed); exit 1
    /// otherwise.
    Compare(CompareArgs),
    /// Print a scene's triangles, bounds, zero-area count and memory.
    Info(InfoArgs),
}

/// `trace-bench validate`'s arguments.
#[derive(clap::Args)]
pub(crate) struct ValidateArgs {
    config: PathBuf,
    #[arg(long, env = "TRACE_BENCH_SCENES")]
    scenes_root: Option<PathBuf>,
    #[command(flatten)]
    select: Select,

    /// Mismatching rays printed per combination.
    #[arg(long, default_value_t = 5)]
    show: usize,
    #[arg(long, short)]
    quiet: bool,
}

/// `trace-bench check`'s arguments.
#[derive(clap::Args)]
pub(crate) struct CheckArgs {
    /// The baseline results.csv.
    #[arg(long)]
    baseline: PathBuf,
    /// The results.csv to check.
    results: PathBuf,
    /// Relative growth allowed per counter (finite, at least 0).
    #[arg(long, default_value_t = 0.01, value_parser = parse_tolerance, allow_negative_numbers = true)]
    tolerance: f64,
}

/// `trace-bench diff`'s arguments.
#[derive(clap::Args)]
pub(crate) struct DiffArgs {
    /// The first EXR (`images/<scene>/<structure>-p<i>-<traversal>-<test>.exr`).
    a: PathBuf,
    /// The second EXR, of the same rays.
    b: PathBuf,
    /// The channel (counter) to compare.
    #[arg(long, default_value = "steps")]
    channel: String,
    /// Also split the mean difference between the rays where this channel is nonzero in A
    /// or B and the rest (`--split handovers`: how much of it comes from the rays a
    /// traversal handed to its fallback walk).
    #[arg(long)]
    split: Option<String>,
    /// Saturate the colours at ±MAX (default: the 99th percentile of |B − A|).
    #[arg(long)]
    max: Option<f32>,
    /// The PNG to write.
    #[arg(long)]
    out: PathBuf,
}

/// `trace-bench merge`'s arguments.
#[derive(clap::Args)]
pub(crate) struct MergeArgs {
    /// The shards' output folders.
    #[arg(required = true)]
    dirs: Vec<PathBuf>,
    /// The merged folder (must not hold results yet).
    #[arg(long)]
    out: PathBuf,
}

/// `trace-bench list`'s arguments.
#[derive(clap::Args)]
pub(crate) struct ListArgs {
    /// The README's structure table instead: one line per structure, its summary, how
    /// many traversals and GPU programs it has (README.md holds this output between its
    /// `list --markdown` markers; a test checks that they agree).
    #[arg(long)]
    markdown: bool,
    /// With `--markdown`: the reference of docs/structures.md instead, each structure's
    /// doc, traversals with their GPU programs, and parameters (between its markers).
    #[arg(long, requires = "markdown")]
    details: bool,
}

/// `trace-bench weights`'s arguments.
#[derive(clap::Args)]
pub(crate) struct WeightsArgs {
    /// The β values of Table 2 (default: the paper's 1, 2, 3, 4, 5, 10).
    #[arg(long, value_delimiter = ',')]
    beta: Vec<f64>,
    /// Decimals of the percentages (the paper prints 2, truncated).
    #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u8).range(0..=12))]
    decimals: u8,
    /// Also write the tables as rows to this CSV (table, heuristic, beta, patch, axis,
    /// weight_pct), for `trace-bench claims`.
    #[arg(long)]
    csv: Option<PathBuf>,
}

/// `trace-bench reproduce`'s arguments.
#[derive(clap::Args)]
pub(crate) struct ReproduceArgs {
    /// A paper's key (`feldmann-rtrees`, … : a file stem under --claims-dir), a claims
    /// file, or `all` (every claims file with runs); several, comma-separated, are made in
    /// that order (`a,b,all`: a, b, then the others).
    paper: String,
    /// Time for all the runs (`10m`, `90s`, `1h`); images shrink to fit.
    #[arg(long, default_value = "10m")]
    budget: String,
    /// Devices whose runs are made: `cpu` (default), `gpu` or `cpu,gpu`.
    #[arg(long, value_delimiter = ',', default_value = "cpu", value_parser = ["cpu", "gpu"])]
    device: Vec<String>,
    /// The report folder (default results/reproduce/TIMESTAMP); an existing one reuses
    /// its complete runs and resumes the others.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Where the claims files are.
    #[arg(long, default_value = "claims")]
    claims_dir: PathBuf,
    /// Further results (folders or CSVs) evaluated with each paper's runs, e.g. a GPU run
    /// made on another machine.
    #[arg(long = "with")]
    with: Vec<PathBuf>,
    #[arg(long, env = "TRACE_BENCH_SCENES")]
    scenes_root: Option<PathBuf>,
    /// A config edit for every run, after the claims file's own (`--set run.validate=64`;
    /// repeatable): a smoke test at tiny sizes, or a change the report then records.
    #[arg(long = "set")]
    sets: Vec<String>,
    /// GPU adapter of the GPU runs: a substring of its name (case-insensitive).
    #[arg(long, value_parser = clap::builder::NonEmptyStringValueParser::new())]
    adapter: Option<String>,
    /// Also make the claims files' `heavy = true` runs (the stand-in scenes of millions
    /// of triangles: minutes of builds) whatever the budget; without it they are made
    /// only when the budget covers every run as declared.
    #[arg(long)]
    heavy: bool,
    /// A hard limit on the runs' wall time (`7m`, `450s`): a run still going then is ended
    /// (its finished rows kept), runs not yet started are left out, and the claims and the
    /// report are made from what is there (the budget plans; this stops).
    #[arg(long)]
    deadline: Option<String>,
    /// Let the claims files' runs write outside the report folder (an `exec` run's `--out` or
    /// `--csv` elsewhere, a config's `[convergence] cache`); refused without it
    /// (claims/README.md, "What a claims file may do").
    #[arg(long)]
    write_anywhere: bool,
    #[command(flatten)]
    cache: CacheArgs,
    #[arg(long, short)]
    quiet: bool,
}

/// `trace-bench claims`'s arguments.
#[derive(clap::Args)]
pub(crate) struct ClaimsArgs {
    /// The claims file.
    claims: PathBuf,
    /// Results folders (every CSV in them but params.csv) or CSV files; later ones win
    /// for rows of the same identity.
    #[arg(required = true)]
    results: Vec<PathBuf>,
    /// text (a table), md (Markdown) or json.
    #[arg(long, default_value = "text", value_parser = ["text", "md", "json"])]
    format: String,
    /// Only these claims (ids; repeat or separate by commas).
    #[arg(long = "claim", value_delimiter = ',')]
    only: Vec<String>,
    /// Exit 1 unless every evaluated claim agrees (CI's guard of the papers' effects).
    #[arg(long)]
    require_agree: bool,
    /// Width of the text table, at least 40 (default: the terminal's, else 160).
    #[arg(long, value_parser = clap::value_parser!(u16).range(40..))]
    width: Option<u16>,
    /// The least relative uncertainty of a compared time (the variation between runs,
    /// which one run's intervals do not see; claims/README.md).
    #[arg(long, default_value_t = tb_claims::TIME_FLOOR)]
    time_floor: f64,
}

/// `trace-bench compare`'s arguments.
#[derive(clap::Args)]
pub(crate) struct CompareArgs {
    /// The reports: reproduce's folders (or their verdicts.json), two or more.
    #[arg(required = true, num_args = 2..)]
    reports: Vec<PathBuf>,
}

/// `trace-bench info`'s arguments.
#[derive(clap::Args)]
pub(crate) struct InfoArgs {
    /// `builtin:NAME?…` or a file path (relative to the scenes root).
    scene: String,
    #[arg(long, env = "TRACE_BENCH_SCENES")]
    scenes_root: Option<PathBuf>,
}

/// The command line's definition (the test of every value walks its flags).
pub fn command() -> clap::Command {
    <Cli as clap::CommandFactory>::command()
}

/// Run the command line `args`; returns the process exit code.
pub fn run(args: impl IntoIterator<Item = OsString>) -> i32 {
    let cli = match Cli::try_parse_from(args) {
        Ok(c) => c,
        Err(e) => {
            let _ = e.print();
            return if e.use_stderr() { 2 } else { 0 };
        }
    };
    match env::check().and_then(|()| dispatch(cli)) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e:#}");
            1
        }
    }
}

fn dispatch(cli: Cli) -> Result<i32> {
    match cli.cmd {
        Cmd::Run(a) => {
            a.cache.apply()?;
            a.run()
        }
        Cmd::Validate(a) => a.run(),
        Cmd::Check(a) => a.run(),
        Cmd::Diff(a) => a.run(),
        Cmd::Merge(a) => a.run(),
        Cmd::List(a) => a.run(),
        Cmd::Reproduce(a) => {
            a.cache.apply()?;
            a.run()
        }
        Cmd::Claims(a) => a.run(),
        Cmd::Compare(a) => a.run(),
        Cmd::Weights(a) => a.run(),
        Cmd::Scenes => cmd_scenes(),
        Cmd::Info(a) => a.run(),
    }
}

impl MergeArgs {
    /// `trace-bench merge`: merge the shards' folders and print what is missing.
    pub(crate) fn run(self) -> Result<i32> {
        let MergeArgs { dirs, out } = self;
        let (dirs, out) = (&dirs[..], out.as_path());
        folder::check_out(out)?;
        let r = tb_results::merge::merge(dirs, out)?;
        for n in &r.notes {
            eprintln!("note: {n}");
        }
        for m in &r.missing {
            println!("missing: {m}");
        }
        println!(
            "merged {} shard folders: {} rows to {}",
            dirs.len(),
            r.rows,
            out.join("results.csv").display()
        );
        if r.missing.is_empty() {
            Ok(0)
        } else {
            println!(
                "incomplete: {} work units have missing rows (rerun their shards with --resume)",
                r.missing.len()
            );
            Ok(1)
        }
    }
}

impl ListArgs {
    /// `trace-bench list`: the registry's structures, as a listing, the README's table or
    /// docs/structures.md's reference.
    pub(crate) fn run(self) -> Result<i32> {
        let ListArgs { markdown, details } = self;
        let registry = tb_harness::registry::Registry::builtin();
        if details {
            print!("{}", registry.reference().map_err(anyhow::Error::msg)?);
        } else if markdown {
            print!("{}", registry.markdown().map_err(anyhow::Error::msg)?);
        } else {
            print!("{}", registry.listing());
        }
        Ok(0)
    }
}

impl WeightsArgs {
    /// `trace-bench weights`: print (and optionally write) the multi-kd-tree weight tables.
    pub(crate) fn run(self) -> Result<i32> {
        let WeightsArgs {
            beta,
            decimals,
            csv,
        } = self;
        let betas = if beta.is_empty() {
            tb_harness::registry::weights::TABLE2_BETAS.to_vec()
        } else {
            beta
        };
        if let Some(b) = betas.iter().find(|b| !(**b > 0.0 && b.is_finite())) {
            bail!("--beta {b}: beta must be a positive number");
        }
        print!(
            "{}",
            tb_harness::registry::weights::weight_tables(&betas, decimals as usize)
        );
        if let Some(path) = csv {
            let cols = tb_harness::registry::weights::CSV_COLUMNS.map(|c| c.0);
            let mut text = format!("{}\n", cols.join(","));
            for (t, h, b, p, a, w) in tb_harness::registry::weights::weight_rows(&betas) {
                text.push_str(&format!("{t},{h},{b},{p},{a},{w}\n"));
            }
            if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
                std::fs::create_dir_all(dir)
                    .with_context(|| format!("{}: cannot create", dir.display()))?;
            }
            std::fs::write(&path, text)
                .with_context(|| format!("{}: cannot write", path.display()))?;
            eprintln!("wrote {}", path.display());
        }
        Ok(0)
    }
}

/// `trace-bench scenes`: list the built-in scenes and their parameters.
fn cmd_scenes() -> Result<i32> {
    for s in tb_scene::builtin::list() {
        println!("builtin:{:<28} {}", s.name, s.doc);
        for p in s.params {
            println!("    {p}");
        }
    }
    Ok(0)
}

impl InfoArgs {
    /// `trace-bench info`: print a scene's triangles, bounds, zero-area count and memory.
    pub(crate) fn run(self) -> Result<i32> {
        let InfoArgs { scene, scenes_root } = self;
        let scene = scene.as_str();
        let root = scenes_root.unwrap_or_else(|| PathBuf::from("scenes"));
        let s = tb_scene::load(scene, &root)?;
        let b = s.bounds;
        println!("scene       {}", s.source);
        println!("triangles   {}", s.triangles.len());
        println!("zero-area   {}", s.degenerate_count());
        println!(
            "bounds      [{}, {}, {}] .. [{}, {}, {}]",
            b.min.x, b.min.y, b.min.z, b.max.x, b.max.y, b.max.z
        );
        println!("diagonal    {}", s.diagonal());
        println!("memory      {} bytes (triangles)", s.memory_bytes());
        for n in &s.notes {
            eprintln!("note: {n}");
        }
        if let Some(v) = &s.view {
            let c = v.camera;
            let light = match v.light {
                Some(l) => format!("{:?}", l.to_array()),
                None => "none".into(),
            };
            println!(
                "view        eye {:?} target {:?} fov {} {}x{}; light {light}; ao distance {}",
                c.eye.to_array(),
                c.target.to_array(),
                c.fov,
                c.width,
                c.height,
                v.ao_distance
            );
        }
        if !s.own_rays.is_empty() {
            println!("own rays    {}", s.own_rays.len());
        }
        Ok(0)
    }
}

impl ValidateArgs {
    /// `trace-bench validate`: every structure and traversal against the oracle only.
    pub(crate) fn run(self) -> Result<i32> {
        let ValidateArgs {
            config,
            scenes_root,
            select,
            show,
            quiet,
        } = self;
        let (config, ov) = (config.as_path(), select.overrides(scenes_root));
        let exp = load(config, &ov, quiet)?;
        if exp
            .scenes
            .iter()
            .all(|s| s.validate == config::Validate::Off)
        {
            bail!(
                "{}: validate = \"off\" for every scene: nothing to validate",
                config.display()
            );
        }
        let opts = RunOptions {
            out: PathBuf::new(),
            resume: false,
            quiet,
            mode: Mode::Validate,
            max_report: show,
            cache: None,
        };
        let summary = runner::run(&exp, &opts)?;
        println!("{}", runner::table(&summary.rows));
        for n in &summary.notes {
            eprintln!("note: {n}");
        }
        for r in &summary.mismatch_reports {
            println!("mismatch: {r}");
        }
        for f in &summary.failures {
            eprintln!("error: {f}");
        }
        let checked: u64 = summary.rows.iter().filter_map(|r| r.validated_rays).sum();
        println!(
            "{} mismatches in {} validated rays",
            summary.mismatches, checked
        );
        Ok(if summary.mismatches > 0 || !summary.failures.is_empty() {
            1
        } else {
            0
        })
    }
}

impl CheckArgs {
    /// `trace-bench check`: the counters of a results.csv against a baseline.
    pub(crate) fn run(self) -> Result<i32> {
        let CheckArgs {
            baseline,
            results,
            tolerance,
        } = self;
        let (baseline, results) = (baseline.as_path(), results.as_path());
        let base = tb_results::output::read_csv(baseline)?;
        let cur = tb_results::output::read_csv(results)?;
        for (p, rows) in [(baseline, &base), (results, &cur)] {
            if rows.is_empty() {
                bail!("{}: holds no rows: nothing to check", p.display());
            }
        }
        let findings = tb_results::check::compare(&base, &cur, tolerance);
        print!("{}", tb_results::check::report(&findings));
        let failed = findings.iter().filter(|f| f.failed).count();
        if failed > 0 {
            println!(
                "check failed: {failed} regressions against {}",
                baseline.display()
            );
            Ok(1)
        } else {
            println!(
                "check passed: {} baseline rows, {} counters changed within tolerance or improved",
                base.len(),
                findings.len()
            );
            Ok(0)
        }
    }
}

impl DiffArgs {
    /// `trace-bench diff`: the difference map of one counter of two heat-map EXRs.
    pub(crate) fn run(self) -> Result<i32> {
        let DiffArgs {
            a,
            b,
            channel,
            split,
            max,
            out,
        } = self;
        let (a, b, channel, split, out) = (
            a.as_path(),
            b.as_path(),
            channel.as_str(),
            split.as_deref(),
            out.as_path(),
        );
        if max.is_some_and(|m| !(m > 0.0 && m.is_finite())) {
            bail!(
                "--max {}: must be a positive number",
                max.unwrap_or_default()
            );
        }
        if out.is_dir() {
            bail!(
                "--out {}: is a folder; give the PNG file to write",
                out.display()
            );
        }
        let ia = tb_render::Channels::read_exr(a)?;
        let ib = tb_render::Channels::read_exr(b)?;
        if (ia.width, ia.height) != (ib.width, ib.height) {
            bail!(
                "{}: {}x{} pixels, but {} has {}x{}: not the same rays",
                b.display(),
                ib.width,
                ib.height,
                a.display(),
                ia.width,
                ia.height
            );
        }
        let get_channel =
            |img: &tb_render::Channels, p: &Path, channel: &str| -> Result<Vec<f32>> {
                match img.get(channel) {
                    Some(v) => Ok(v.to_vec()),
                    None => bail!(
                        "{}: no channel `{channel}` (has: {})",
                        p.display(),
                        img.names().join(", ")
                    ),
                }
            };
        let get = |img: &tb_render::Channels, p: &Path| get_channel(img, p, channel);
        let (va, vb) = (get(&ia, a)?, get(&ib, b)?);
        let stem = |p: &Path| {
            p.file_stem()
                .map_or_else(|| p.display().to_string(), |s| s.to_string_lossy().into())
        };
        let title = format!("{channel}: B - A\nA = {}\nB = {}", stem(a), stem(b));
        let (png, scale) = tb_render::heatmap::diff_map(&va, &vb, ia.width, ia.height, max, &title);
        png.write_png(out)?;
        let mean = |v: &[f32]| v.iter().map(|&x| x as f64).sum::<f64>() / v.len().max(1) as f64;
        let (ma, mb) = (mean(&va), mean(&vb));
        println!(
            "{channel}: mean A {ma:.3}, mean B {mb:.3}, B - A {:+.3} ({:+.1}%)",
            mb - ma,
            100.0 * (mb - ma) / ma.max(1e-12)
        );
        if let Some(sc) = split {
            let (sa, sb) = (get_channel(&ia, a, sc)?, get_channel(&ib, b, sc)?);
            let mask: Vec<bool> = sa
                .iter()
                .zip(&sb)
                .map(|(x, y)| *x != 0.0 || *y != 0.0)
                .collect();
            let d = tb_render::heatmap::split_diff(&va, &vb, &mask);
            println!(
            "{channel}: B - A {:+.4} a ray = {:+.4} from the {} rays ({:.3}%) with `{sc}` nonzero in A or B + {:+.4} from the other {}",
            d.all,
            d.in_mask,
            d.masked,
            100.0 * d.masked as f64 / d.pixels.max(1) as f64,
            d.rest,
            d.pixels - d.masked
        );
        }
        println!("wrote {} (colour scale ±{scale})", out.display());
        Ok(0)
    }
}

fn parse_shard(s: &str) -> std::result::Result<tb_harness::cluster::shard::Shard, String> {
    tb_harness::cluster::shard::Shard::parse(s)
}

fn parse_process(
    s: &str,
) -> std::result::Result<tb_harness::experiment::processes::Process, String> {
    tb_harness::experiment::processes::Process::parse(s)
}

fn parse_device(s: &str) -> std::result::Result<Device, String> {
    Device::from_name(s).ok_or_else(|| format!("unknown device `{s}` (known: cpu, gpu)"))
}

fn parse_backend(s: &str) -> std::result::Result<tb_gpu::Backend, String> {
    tb_gpu::Backend::from_name(s)
        .ok_or_else(|| format!("unknown backend `{s}` (known: vulkan, gl, metal, dx12)"))
}

fn parse_tolerance(s: &str) -> std::result::Result<f64, String> {
    let t: f64 = s.parse().map_err(|_| format!("`{s}` is not a number"))?;
    match tb_results::check::bad_tolerance(t) {
        Some(why) => Err(format!("{t} {why}")),
        None => Ok(t),
    }
}
