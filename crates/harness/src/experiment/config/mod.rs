//! Two-stage config: raw serde structs (`deny_unknown_fields`), then a checked
//! [`Experiment`] with scenes loaded, structures resolved and sweeps expanded, before any work
//! starts. Every error names the file, the line and the key.
//!
//! The schema is documented in README.md ("Config reference"). The image and convergence
//! sections are checked in their own modules ([`images`], [`convergence`]), which the work
//! modules ([`crate::experiment::images`], [`crate::experiment::convergence`]) read from, never the other way round.

pub(crate) mod ctx;
pub mod overrides;
mod run;
mod scenes;
pub(crate) mod spec;
mod structures;
pub mod views;

pub use ctx::line_of;
pub(crate) use ctx::Ctx;
pub use run::RunSettings;
pub use spec::{device_threads, Device, GpuSpec, SceneSpec, StructureSpec, Validate};

use crate::experiment::convergence::config as convergence;
use crate::experiment::dynamic::config as dynamic;
use crate::experiment::images::config as images;

use crate::error::HarnessError;
use crate::registry::Registry;
use serde::Deserialize;
use std::path::{Path, PathBuf};
use tb_scene::PixelOrder;
use toml::Spanned;

/// One value or a list of them (`threads = 1` or `threads = [1, 2]`): read through a
/// `toml::Value`, so a wrong value says what was expected (`invalid value: integer -1,
/// expected u32`) rather than that no variant matched.
enum OneOrMany<T> {
    One(T),
    Many(Vec<T>),
}

impl<'de, T: serde::de::DeserializeOwned> Deserialize<'de> for OneOrMany<T> {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        use serde::de::Error;
        let one = |v: toml::Value| {
            v.try_into::<T>()
                .map_err(|e| D::Error::custom(e.message().trim().to_owned()))
        };
        match toml::Value::deserialize(d)? {
            toml::Value::Array(items) => items
                .into_iter()
                .map(one)
                .collect::<Result<Vec<T>, _>>()
                .map(OneOrMany::Many),
            v => one(v).map(OneOrMany::One),
        }
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawConfig {
    name: Option<String>,
    scenes_root: Option<String>,
    views_file: Option<Spanned<String>>,
    #[serde(default)]
    run: RawRun,
    #[serde(default, rename = "scene")]
    scenes: Vec<RawScene>,
    #[serde(default, rename = "structure")]
    structures: Vec<RawStructure>,
    convergence: Option<Spanned<convergence::RawConvergence>>,
    dynamic: Option<Spanned<dynamic::RawDynamic>>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct RawRun {
    threads: Option<Spanned<OneOrMany<u32>>>,
    repeat: Option<Spanned<u32>>,
    max_repeat: Option<u32>,
    target_ci: Option<Spanned<f64>>,
    max_row_seconds: Option<Spanned<f64>>,
    timed_rays: Option<Spanned<u64>>,
    timed_share: Option<Spanned<f64>>,
    interleave: Option<bool>,
    processes: Option<Spanned<u32>>,
    clock: Option<Spanned<String>>,
    warmup: Option<u32>,
    build_repeat: Option<Spanned<u32>>,
    time_builds: Option<bool>,
    triangle_test: Option<Spanned<OneOrMany<String>>>,
    devices: Option<Spanned<OneOrMany<String>>>,
    gpu_adapter: Option<String>,
    gpu_backend: Option<Spanned<String>>,
    gpu_required: Option<bool>,
    validate: Option<Spanned<toml::Value>>,
    seed: Option<u64>,
    images: Option<bool>,
    heatmap_max: Option<Spanned<toml::Value>>,
    heatmap_colormap: Option<Spanned<String>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawScene {
    source: Spanned<String>,
    name: Option<String>,
    view: Option<Spanned<String>>,
    rays: Option<Spanned<Vec<String>>>,
    camera: Option<Spanned<RawCamera>>,
    light: Option<[f32; 3]>,
    ao: Option<RawAo>,
    path: Option<RawPath>,
    random: Option<RawRandom>,
    validate: Option<Spanned<toml::Value>>,
    optional: Option<bool>,
    enclose: Option<bool>,
    inset: Option<Spanned<RawInset>>,
    views: Option<Spanned<Vec<RawView>>>,
}

/// One entry of `views = [...]`: a viewpoint of the scene table (eye, target, up, fov over
/// the table's camera, and its light), traced on the same load and build as the others.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawView {
    name: Option<String>,
    view: Option<String>,
    eye: Option<[f32; 3]>,
    target: Option<[f32; 3]>,
    up: Option<[f32; 3]>,
    fov: Option<f32>,
    light: Option<[f32; 3]>,
}

/// `inset = { scale = 0.01, at = [x, y, z] }`: the scene inside itself (Figure 8 of
/// Pérard-Gayot et al. 2017), see [`tb_scene::Scene::inset`].
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawInset {
    scale: f32,
    at: Option<[f32; 3]>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct RawCamera {
    eye: Option<[f32; 3]>,
    target: Option<[f32; 3]>,
    up: Option<[f32; 3]>,
    fov: Option<f32>,
    width: Option<u32>,
    height: Option<u32>,
    order: Option<PixelOrder>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawAo {
    samples: Option<u32>,
    distance: Option<f32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPath {
    bounces: u32,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawRandom {
    count: u32,
}

#[derive(Deserialize, Clone)]
#[serde(deny_unknown_fields)]
struct RawStructure {
    name: Spanned<String>,
    traversals: Option<Spanned<Vec<String>>>,
    params: Option<Spanned<toml::Table>>,
    time_builds: Option<bool>,
}

/// A checked experiment: everything needed to run, nothing left to fail on the config.
pub struct Experiment {
    /// The experiment's name: the config's `name`, else the file's stem.
    pub name: String,
    /// The config file.
    pub file: PathBuf,
    /// The config text as read (stored in results.json).
    pub text: String,
    /// Where file scenes are looked up (`scenes_root`, or `--scenes-root`).
    pub scenes_root: PathBuf,
    /// The checked `[run]` table with the command-line overrides.
    pub run: RunSettings,
    /// The checked scene entries, one per table or per view.
    pub scenes: Vec<SceneSpec>,
    /// The checked `[[structure]]` entries, in config order.
    pub structures: Vec<StructureSpec>,
    /// Why scenes marked `optional = true` were left out (file not under the scenes root).
    /// (Also the loaders' notes on what they left out of a file, and the shard's part.)
    pub skipped_scenes: Vec<String>,
    /// `[run] images = true`: heat maps of primary rays ([`crate::experiment::images`]).
    pub images: Option<images::ImageSpec>,
    /// `[convergence]`: error against run time ([`crate::experiment::convergence`]).
    pub convergence: Option<convergence::ConvergenceSpec>,
    /// `--shard K/N`: the partition of the run's work units and this shard's part
    /// ([`crate::cluster::shard`]); only the scenes of this shard's units are loaded.
    pub shard: Option<crate::cluster::shard::ShardPlan>,
    /// SHA-256 of the effective config (the text after `--set`) and the command-line options
    /// that change the rows (threads, repeat, devices, adapter, backend, `--scene`,
    /// `--structure`); shards of one run share it (`trace-bench merge` checks).
    pub config_hash: String,
    /// `[dynamic]`: per-frame rebuilds within frame budgets ([`crate::experiment::dynamic`]).
    pub dynamic: Option<dynamic::DynamicSpec>,
    /// `--process I/K`: this run is process `I` of a `run --processes K`
    /// ([`crate::experiment::processes`]): its rows carry `process = I`, and for odd `I` the
    /// structure entries run in reverse order.
    pub process: Option<crate::experiment::processes::Process>,
    /// The views file the config's named views come from (`views_file`).
    pub views: Option<views::ViewsFile>,
    /// Seconds spent loading and checking the scenes and the sections that read them
    /// (`meta.phases.load_s`).
    pub load_s: f64,
}

/// Overrides from the command line.
#[derive(Clone, Debug, Default)]
pub struct Overrides {
    /// `--scenes-root` (or `TRACE_BENCH_SCENES`): replaces the config's `scenes_root`.
    pub scenes_root: Option<PathBuf>,
    /// `--threads`: replaces run.threads.
    pub threads: Option<Vec<usize>>,
    /// `--repeat`: replaces run.repeat.
    pub repeat: Option<usize>,
    /// `--device`: replaces run.devices; listing `gpu` makes the GPU required.
    pub devices: Option<Vec<Device>>,
    /// `--adapter`: replaces run.gpu_adapter.
    pub adapter: Option<String>,
    /// `--backend`: replaces run.gpu_backend.
    pub backend: Option<tb_gpu::Backend>,
    /// `--set key=value`: edits of the config before it is checked ([`overrides::apply_sets`]).
    pub sets: Vec<String>,
    /// `--scene NAME`: run only these scenes (labels or sources).
    pub scenes: Vec<String>,
    /// `--structure NAME[:traversal]`: run only these structures (and traversals).
    pub structures: Vec<String>,
    /// `--shard K/N`: run only this shard's work units ([`crate::cluster::shard`]).
    pub shard: Option<crate::cluster::shard::Shard>,
    /// `--process I/K`: run as process `I` of `K` ([`crate::experiment::processes`]).
    pub process: Option<crate::experiment::processes::Process>,
}

impl Overrides {
    /// The options that change which rows a run writes or how they are measured, as text
    /// for [`Experiment::config_hash`] (not the scenes root, which differs between machines,
    /// nor the shard, which shards of one run differ in).
    fn hashed(&self) -> String {
        format!(
            "threads={:?}\nrepeat={:?}\ndevices={:?}\nadapter={:?}\nbackend={:?}\nscenes={:?}\nstructures={:?}\n",
            self.threads,
            self.repeat,
            self.devices.as_ref().map(|d| d.iter().map(|d| d.name()).collect::<Vec<_>>()),
            self.adapter,
            self.backend.map(|b| format!("{b:?}")),
            self.scenes,
            self.structures
        )
    }
}

/// SHA-256 of the effective config text, the views file's text and the hashed overrides, hex.
fn config_hash(text: &str, views: Option<&views::ViewsFile>, ov: &Overrides) -> String {
    use sha2::Digest;
    let mut h = sha2::Sha256::new();
    h.update(text.as_bytes());
    h.update([0u8]);
    if let Some(v) = views {
        h.update(v.text.as_bytes());
        h.update([0u8]);
    }
    h.update(ov.hashed().as_bytes());
    h.finalize().iter().map(|b| format!("{b:02x}")).collect()
}

/// A config as every reader of it starts: the effective text (after `--set`, recorded in
/// results.json), the name its errors give the file ("with --set" where edited: their lines
/// are the edited text's), its tables with the named views filled in, and the views file.
struct Source {
    text: String,
    shown: PathBuf,
    raw: RawConfig,
    views: Option<views::ViewsFile>,
}

impl Source {
    /// Apply `ov`'s `--set` edits to `text` (read from `file`), parse it, check that no float
    /// is NaN or infinite (whatever key reads it), and fill in the named views.
    fn read(file: &Path, text: &str, ov: &Overrides) -> Result<Source, HarnessError> {
        let (text, shown) = if ov.sets.is_empty() {
            (text.to_owned(), file.to_path_buf())
        } else {
            (
                overrides::apply_sets(&file.display().to_string(), text, &ov.sets)?,
                PathBuf::from(format!("{} (with --set)", file.display())),
            )
        };
        let mut raw: RawConfig =
            toml::from_str(&text).map_err(|e| syntax_error(&shown, &text, &e))?;
        tb_results::finite::check_toml(&shown, &text)?;
        let cx = Ctx {
            file: &shown,
            text: &text,
        };
        let views = views::resolve(&cx, &mut raw, file)?;
        Ok(Source {
            text,
            shown,
            raw,
            views,
        })
    }
}

/// Parse and check `file` against the built-in registry; loads every scene. `progress` is
/// told each scene as it loads.
pub fn load(
    file: &Path,
    ov: &Overrides,
    progress: &mut dyn FnMut(&str),
) -> Result<Experiment, HarnessError> {
    let text = std::fs::read_to_string(file).map_err(|e| HarnessError::io(file, e))?;
    parse(file, &text, ov, progress)
}

/// Parse and check config `text` (read from `file`, named in errors) against the built-in
/// registry.
pub fn parse(
    file: &Path,
    text: &str,
    ov: &Overrides,
    progress: &mut dyn FnMut(&str),
) -> Result<Experiment, HarnessError> {
    parse_with(file, text, ov, &Registry::builtin(), progress)
}

/// [`parse`], resolving structures against `registry` (tests add their own structures).
pub fn parse_with(
    file: &Path,
    text: &str,
    ov: &Overrides,
    registry: &Registry,
    progress: &mut dyn FnMut(&str),
) -> Result<Experiment, HarnessError> {
    let Source {
        text,
        shown,
        mut raw,
        views,
    } = Source::read(file, text, ov)?;
    let (text, file_arg, file) = (text.as_str(), file, shown.as_path());
    let cx = Ctx { file, text };
    overrides::filter(&cx, &mut raw, &ov.scenes, &ov.structures)?;
    if let Some(p) = ov.process {
        check_process(&cx, &raw, ov, p)?;
        if p.reversed() {
            raw.structures.reverse();
        }
    }
    let name = experiment_name(&cx, &raw, file_arg)?;
    let scenes_root = scenes_root_of(ov, &raw);

    let run = &raw.run;
    let run_settings = run::check_run(&cx, run, ov)?;
    let validate = run_settings.validate;

    let structures = check_structures(&cx, &raw, registry)?;

    if raw.scenes.is_empty() {
        return Err(cx.err(0..0, "scene", "the config names no [[scene]]"));
    }
    if ov.shard.is_some() && raw.dynamic.is_some() {
        return Err(cx.err(
            0..0,
            "dynamic",
            "a [dynamic] run measures frames of one scene and cannot be sharded: drop --shard",
        ));
    }
    let shard = ov
        .shard
        .map(|sel| plan_shard(sel, &raw, &structures, &run_settings, &scenes_root));
    let loading = std::time::Instant::now();
    let (scenes, mut skipped_scenes) =
        check_scenes(&cx, &raw, shard.as_ref(), &scenes_root, validate, progress)?;
    if let Some(p) = &shard {
        skipped_scenes.push(shard_note(p));
    }
    if scenes.is_empty() && shard.is_none() {
        return Err(HarnessError::File(tb_results::Error::ConfigSyntax {
            file: file.into(),
            message: format!("no scene to run: {}", skipped_scenes.join("; ")),
        }));
    }
    let images = images::check(
        &cx,
        run.images,
        run.heatmap_max.as_ref(),
        run.heatmap_colormap.as_ref(),
    )?;
    let convergence = match &raw.convergence {
        None => None,
        Some(c) => Some(convergence::check(&cx, c, &scenes)?),
    };
    let dynamic = match &raw.dynamic {
        None => None,
        Some(d) => Some(dynamic::check(&cx, d, &scenes, &structures)?),
    };

    Ok(Experiment {
        name,
        file: file_arg.to_path_buf(),
        text: text.to_string(),
        scenes_root,
        run: run_settings,
        scenes,
        structures,
        skipped_scenes,
        images,
        convergence,
        shard,
        config_hash: config_hash(text, views.as_ref(), ov),
        views,
        dynamic,
        process: ov.process,
        load_s: loading.elapsed().as_secs_f64(),
    })
}

/// Everything [`load`] checks that needs no scene loaded (so that `reproduce` checks each
/// run's config with its edits before the first run starts, not when that run starts): the
/// syntax, finite numbers, the `--scene`/`--structure` filters, `[run]`, the structures and
/// their parameters, the images settings, and per scene table its ray kinds, that its file
/// exists, the AO, path and random settings, and the camera's size and field of view. `Ok`:
/// the folders the run writes besides its output folder (the `[convergence]` cache).
pub fn check_offline(file: &Path, ov: &Overrides) -> Result<Vec<PathBuf>, HarnessError> {
    let text = std::fs::read_to_string(file).map_err(|e| HarnessError::io(file, e))?;
    let Source {
        text,
        shown,
        mut raw,
        ..
    } = Source::read(file, &text, ov)?;
    let cx = Ctx {
        file: &shown,
        text: &text,
    };
    overrides::filter(&cx, &mut raw, &ov.scenes, &ov.structures)?;
    experiment_name(&cx, &raw, file)?;
    run::check_run(&cx, &raw.run, ov)?;
    check_structures(&cx, &raw, &Registry::builtin())?;
    images::check(
        &cx,
        raw.run.images,
        raw.run.heatmap_max.as_ref(),
        raw.run.heatmap_colormap.as_ref(),
    )?;
    if raw.scenes.is_empty() {
        return Err(cx.err(0..0, "scene", "the config names no [[scene]]"));
    }
    let root = scenes_root_of(ov, &raw);
    for sc in &raw.scenes {
        scenes::check_offline(&cx, sc, &root)?;
    }
    Ok(raw
        .convergence
        .as_ref()
        .map(|c| c.get_ref().cache_dir())
        .into_iter()
        .collect())
}

/// `--process I/K` is refused beside `--shard` (a process runs the whole config) and with
/// `[dynamic]` (its frames are written to dynamic.csv, not as rows a process tags).
fn check_process(
    cx: &Ctx,
    raw: &RawConfig,
    ov: &Overrides,
    p: crate::experiment::processes::Process,
) -> Result<(), HarnessError> {
    if ov.shard.is_some() {
        return Err(cx.err(
            0..0,
            "run.processes",
            format!("process {p} of a run cannot be sharded: drop --shard or --processes"),
        ));
    }
    if raw.dynamic.is_some() {
        return Err(cx.err(
            0..0,
            "run.processes",
            "a [dynamic] run writes frames (dynamic.csv), not rows a process tags: run it as \
             one process",
        ));
    }
    Ok(())
}

/// What `run --processes` reads before it starts its processes, without loading a scene:
/// the experiment's name (the default output folder) and `run.processes` (1 when absent), from
/// `file` with the `--set` edits of `ov`. The syntax and the keys are checked as [`load`]
/// checks them; everything else is checked by each process.
pub fn peek(file: &Path, ov: &Overrides) -> Result<(String, usize), HarnessError> {
    let text = std::fs::read_to_string(file).map_err(|e| HarnessError::io(file, e))?;
    let Source {
        text, shown, raw, ..
    } = Source::read(file, &text, ov)?;
    let cx = Ctx {
        file: &shown,
        text: &text,
    };
    let name = experiment_name(&cx, &raw, file)?;
    let processes = run::check_processes(&cx, &raw.run)?;
    if processes > 1 && raw.dynamic.is_some() {
        return Err(cx.err(
            0..0,
            "run.processes",
            "a [dynamic] run writes frames (dynamic.csv), not rows a process tags: run it as \
             one process",
        ));
    }
    Ok((name, processes))
}

/// The experiment's name: the config's `name`, else the file's stem; a plain file name.
fn experiment_name(cx: &Ctx, raw: &RawConfig, file_arg: &Path) -> Result<String, HarnessError> {
    let name = raw.name.clone().unwrap_or_else(|| {
        file_arg
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "experiment".into())
    });
    if name.is_empty() || name.contains(['/', '\\']) || name.starts_with('.') {
        return Err(cx.err(0..0, "name", "must be a plain, non-empty file name"));
    }
    Ok(name)
}

/// Check the structure tables against `registry` (at least one).
fn check_structures(
    cx: &Ctx,
    raw: &RawConfig,
    registry: &Registry,
) -> Result<Vec<StructureSpec>, HarnessError> {
    if raw.structures.is_empty() {
        return Err(cx.err(0..0, "structure", "the config names no [[structure]]"));
    }
    raw.structures
        .iter()
        .map(|s| structures::check_structure(cx, s, registry))
        .collect()
}

/// A TOML syntax error of `file` (its `text`), with its line where known.
fn syntax_error(file: &Path, text: &str, e: &toml::de::Error) -> HarnessError {
    let line = e.span().map(|s| line_of(text, s.start));
    let msg = match e.message().trim().replace('\n', " ") {
        m if m.is_empty() => "invalid TOML (a value is missing or malformed here)".into(),
        m => m,
    };
    // The key of the value at fault, when the error points at a `key = value` line.
    let key = e
        .span()
        .and_then(|s| key_at(text, s.start).or_else(|| tb_results::finite::key_at(text, s.start)));
    if let (Some(l), Some(key)) = (line, key) {
        return HarnessError::File(tb_results::Error::Config {
            file: file.into(),
            line: l,
            key,
            message: msg,
        });
    }
    match line {
        Some(l) => HarnessError::File(tb_results::Error::ConfigSyntax {
            file: file.into(),
            message: format!("line {l}: {msg}"),
        }),
        None => HarnessError::File(tb_results::Error::ConfigSyntax {
            file: file.into(),
            message: msg,
        }),
    }
}

/// The dotted key of the `key = value` line holding byte `pos` of `text`, prefixed by the table
/// above it (`run.threads`, `scene.camera`), or `None` off such a line.
fn key_at(text: &str, pos: usize) -> Option<String> {
    let start = text[..pos.min(text.len())].rfind('\n').map_or(0, |i| i + 1);
    let line = text[start..].lines().next()?;
    let (key, _) = line.split_once('=')?;
    let key = key.trim();
    if key.is_empty() || key.starts_with('#') || key.starts_with('[') {
        return None;
    }
    let table = text[..start]
        .lines()
        .rev()
        .map(str::trim)
        .find(|l| l.starts_with('['))
        .map(|l| l.trim_matches(|c| c == '[' || c == ']').trim().to_owned());
    Some(match table {
        Some(t) if !t.is_empty() => format!("{t}.{key}"),
        _ => key.to_owned(),
    })
}

/// The scenes root: `--scenes-root`, else TRACE_BENCH_SCENES, else the config's, else
/// `scenes`.
fn scenes_root_of(ov: &Overrides, raw: &RawConfig) -> PathBuf {
    ov.scenes_root
        .clone()
        .or_else(|| std::env::var_os("TRACE_BENCH_SCENES").map(PathBuf::from))
        .or_else(|| raw.scenes_root.as_ref().map(PathBuf::from))
        .unwrap_or_else(|| PathBuf::from("scenes"))
}

/// Check and load the scene tables (but those the shard leaves out): the scene specs, and
/// the notes on the scenes (optional ones skipped, what a loader left out of a file).
fn check_scenes(
    cx: &Ctx,
    raw: &RawConfig,
    shard: Option<&crate::cluster::shard::ShardPlan>,
    scenes_root: &Path,
    validate: Validate,
    progress: &mut dyn FnMut(&str),
) -> Result<(Vec<SceneSpec>, Vec<String>), HarnessError> {
    let mut scenes: Vec<SceneSpec> = Vec::new();
    let mut skipped_scenes = Vec::new();
    for s in &raw.scenes {
        if shard.is_some_and(|p| {
            let label = scenes::label_of(s);
            // Scenes the plan does not know (absent files) go on to the check, which
            // reports them.
            p.scene_cost.contains_key(&label) && !p.needs_scene(&label)
        }) {
            continue;
        }
        match scenes::check_scene(cx, s, scenes_root, validate, progress)? {
            Ok(specs) => {
                if let Some(first) = specs.first() {
                    for n in &first.scene.notes {
                        skipped_scenes.push(format!("{}: {n}", first.table));
                    }
                }
                for spec in specs {
                    if scenes.iter().any(|o| o.label == spec.label) {
                        return Err(cx.err(
                            s.source.span(),
                            "scene.name",
                            format!(
                                "two scenes are labelled `{}`; give one a `name`",
                                spec.label
                            ),
                        ));
                    }
                    scenes.push(spec)
                }
            }
            Err(note) => skipped_scenes.push(note),
        }
    }
    Ok((scenes, skipped_scenes))
}

/// The note of a shard: its work units, rows, estimated time and the scenes left out.
fn shard_note(p: &crate::cluster::shard::ShardPlan) -> String {
    let out = p.left_out();
    format!(
        "shard {}: {} of {} work units (scene x build), {} rows, estimated {:.1} s; {}",
        p.shard,
        p.units.iter().filter(|u| u.shard == p.shard.k).count(),
        p.units.len(),
        p.rows(),
        p.cost_of(p.shard.k) as f64 / 1e9,
        if out.is_empty() {
            "no scene left out".to_string()
        } else {
            format!("left out, not loaded: {}", out.join(", "))
        }
    )
}

/// The partition of the run for `--shard` ([`crate::cluster::shard::plan`]), from the scene tables
/// (not loaded) and the checked structures.
fn plan_shard(
    sel: crate::cluster::shard::Shard,
    raw: &RawConfig,
    structures: &[StructureSpec],
    run: &RunSettings,
    scenes_root: &Path,
) -> crate::cluster::shard::ShardPlan {
    let scenes: Vec<crate::cluster::shard::SceneEstimate> = raw
        .scenes
        .iter()
        .filter_map(|s| scenes::estimate(s, scenes_root, run.validate))
        .collect();
    let mut builds = Vec::new();
    for (si, st) in structures.iter().enumerate() {
        for (pi, p) in st.param_sets.iter().enumerate() {
            builds.push(crate::cluster::shard::BuildEstimate {
                structure: si,
                param_set: pi,
                name: st.family.name,
                params: p.to_string(),
                variants: st.traversals.len() * run.triangle_tests.len(),
            });
        }
    }
    let device_rows = device_threads(&run.devices, &run.threads)
        .into_iter()
        .flat_map(|(_, t)| t)
        .collect();
    let est = crate::cluster::shard::RunEstimate {
        device_rows,
        passes: (run.timing.warmup + run.timing.repeat + 1) as u64,
        build_repeat: run.build_repeat as u64,
    };
    crate::cluster::shard::plan(sel, &scenes, &builds, &est)
}

/// A `validate` value: `"all"` or `true`, `"off"` or `false`, or a positive ray count (`None`
/// for anything else). The one reading of the key, for the config check and the shard plan.
pub(crate) fn validate_of(v: &toml::Value) -> Option<Validate> {
    Some(match v {
        toml::Value::String(s) if s == "all" => Validate::All,
        toml::Value::String(s) if s == "off" => Validate::Off,
        toml::Value::Boolean(true) => Validate::All,
        toml::Value::Boolean(false) => Validate::Off,
        toml::Value::Integer(n) if *n > 0 => Validate::Sample(*n as usize),
        _ => return None,
    })
}

fn parse_validate(cx: &Ctx, v: &Spanned<toml::Value>, key: &str) -> Result<Validate, HarnessError> {
    validate_of(v.get_ref()).ok_or_else(|| {
        cx.err(
            v.span(),
            key,
            format!(
                "expected \"all\", \"off\" or a positive ray count, found {}",
                v.get_ref()
            ),
        )
    })
}

/// A short label for a scene source: `builtin:stress/flat?x=1` → `stress/flat?x=1`,
/// `sibenik/sibenik.obj.gz` → `sibenik`.
pub fn scene_label(src: &str) -> String {
    if let Some(b) = src.strip_prefix("builtin:") {
        return b.to_string();
    }
    let file = Path::new(src)
        .file_name()
        .map(|f| f.to_string_lossy().into_owned())
        .unwrap_or_default();
    let stem = file.split('.').next().unwrap_or("").to_string();
    if stem.is_empty() {
        src.to_string()
    } else {
        stem
    }
}
